"""[element]: the shell element's options."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ..keys import choice, key, positive, unit_interval


@dataclass(frozen=True)
class ElementOptions:
    hourglass: float = key(unit_interval, default=0.05,
        doc="Belytschko–Tsay hourglass coefficient r (= r_m = r_w = r_θ); 0.01–0.1 is the usual range")
    w_hourglass: Literal["bt", "kirchhoff"] = key(
        choice("kirchhoff", "bt"), default="kirchhoff", allowed="`bt`, `kirchhoff`",
        doc="rate of the transverse hourglass mode: `bt` = Σγ_a w_a (the paper's), which on a non-rectangular "
            "quad also resists the bilinear part of smooth bending and twist; `kirchhoff` subtracts the part "
            "implied by the element's own curvature rate, so only the spurious w-mode is resisted "
            "(`stages/hourglass.py`)")
    drilling: Literal["projection", "penalty"] = key(
        choice("projection", "penalty"), default="penalty", allowed="`penalty`, `projection`",
        doc="rotation about the shell normal: `penalty` keeps it and ties it to each element's in-plane spin with"
            " a drilling spring (`stages/drilling.py`); `projection` removes it at every node (the paper's, "
            "method.md 2.3), which makes a rigid rotation about an axis off the surface bend a curved mesh (the "
            "hemisphere 2-3 % too stiff at every refinement)")
    drilling_stiffness: float = key(positive, default=0.1,
        doc="α of the drilling spring k = α D A β / 4 (α = 1: the bending stiffness one corner rotation meets; "
            "never sets the time step; its energy is reported as `drilling`, apart from the hourglass energy, and"
            " the two together are guarded against the internal energy)")
    triangle: Literal["c0", "opt", "ns"] = key(
        choice("c0", "opt", "ns"), default="c0", allowed="`c0`, `opt`, `ns`",
        doc="the 3-node shell: `c0` is the one-point C0 triangle of Belytschko, Stolarski & Carpenter "
            "(constant-strain membrane; `stages/triangle.py`); `opt` gives it Felippa's optimal ANDES membrane "
            "with corner drilling rotations, which bends in its plane as a flat facet on a curved shell must, and "
            "Lyly–Stenberg stabilised transverse shear (`stages/opt_membrane.py`): Sze's hemisphere in triangles "
            "4.4 / 6.9 % mean error at 16×16 (`c0` 8.7 / 13.7 %), 0.39 / 1.08 % at 32×32 (`c0` 1.66 / 3.17 %) "
            "([element.md](element.md), \"The OPT triangle\"); needs `drilling = \"penalty\"` and the scaled "
            "rotary inertia; selective mass scaling scales its drilling rotations as well ([mass_scaling.md]"
            "(mass_scaling.md), \"OPT triangles\"); its drilling modes shorten the triangles' step by 1/√(1 + g/2); `ns` is the `c0` "
            "triangle with its membrane strain smoothed over the triangles around each node (node-based smoothed "
            "FEM, `stages/ns_membrane.py`), which removes the flat facets' membrane locking: Sze's hemisphere "
            "1.24 / 0.18 % mean error at 16×16 in fem ([element.md](element.md), \"The node-smoothed "
            "triangle\"); the `c0` step; Newton's tangent by coloured copies of the mesh ([newton.md](newton.md)); "
            "with erosion and selective mass scaling as `c0`")
    ns_blend: float = key(unit_interval, default=0.0,
        doc="α of the `ns` triangle's membrane strain: (1 − α) the node-smoothed strain + α the triangle's own "
            "(α-FEM); 0 (pure node smoothing, the count rule of [element.md](element.md), \"The node-smoothed "
            "triangle\") removes the membrane locking on curved shells but is soft in in-plane bending with two "
            "triangles across a strip; 1 is the `c0` triangle.  How the hemisphere and the twisted beam move "
            "with it: [element.md](element.md), \"Blend\"; only with `triangle = \"ns\"`")
    warping: Literal["none", "bwc"] = key(choice("none", "bwc"), default="none",
        doc="warped quads: `none` is the flat-facet BT element (the paper's); `bwc` adds the "
            "Belytschko–Wong–Chiang (1992) curvature rate that in-plane motion gives a warped quad (element spin "
            "removed) and its conjugate in-plane forces (`stages/warping.py`, method.md 3.8). Measured "
            "([element.md](element.md)): the MacNeal–Harder twisted beam moves by < 0.1 % (12×2: +3.3 / +6.2 % "
            "error either way), the hemisphere by < 2·10⁻⁵, the 5 mm tube's mean crush force by −0.5 % with the "
            "same folds; the element stage costs 1–4 % more. Compiled in only when on")
