"""The plan of the study: the cases (:class:`Case`), their scene files and ``--set``
overrides, and the choice among them (``--quick``, ``--cases PATTERN``).

Element size ``l`` of a case (for the ratios and the convergence slopes): the cantilever's
``10 / nx`` (meshes nx x max(1, nx/10)); for the quarter hemisphere the nominal ``8 / n``
(n x n quarter mesh), chosen so that the scene's default cell, 0.25 at 16 x 16 (shorter than
every edge), is ``l/2`` as the cantilever's default 0.5 is at 10 x 1; the tube's 5 mm or
2.5 mm.
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]     # the checkout: scenes/ and the runs' working directory
SCENES = ROOT / "scenes"
SCENE_FILES = {"cantilever": "cantilever.toml", "hemisphere": "hemisphere.toml", "tube": "square_tube.toml",
               "scaling": "square_tube.toml", "empty_grid": "square_tube.toml",
               "relaxation_cantilever": "cantilever.toml", "relaxation_hemisphere": "hemisphere.toml",
               "hemisphere_tri": "hemisphere.toml"}
TRIANGLE_ELEMENTS = {"c0": (), "opt": ("element.triangle=opt",), "ns": ("element.triangle=ns",)}
"""The 3-node shells of the triangle series (issue 33): each name, its ``--set`` overrides."""
STATIC_SCENES = {"cantilever": "Cantilever strip under end shear (Sze), 20 load steps",
                 "hemisphere": "Quarter hemisphere with an 18° hole (Sze)",
                 "hemisphere_tri": "Quarter hemisphere with an 18° hole (Sze), each quad cut into two triangles "
                                   "(checkerboard diagonals; series per triangle element, `kratos`: its thin "
                                   "DKT-type triangle ShellThinElementCorotational3D3N)"}
"""The refinement studies against Sze's tables: their tables, plots and observed orders."""
CANTILEVER_NX = (5, 10, 20, 40)
HEMISPHERE_N = (8, 16, 32)
RATIOS = (1.0, 0.5)                 # grid cell / element size in mpm mode
QUICK_LOAD_STEPS = 10               # hemisphere in --quick: every other Sze row
SCALING_FLAT = (5, 10, 20, 40, 60)  # tube elements across a flat: 720 ... 103 680 elements
SCALING_END_TIME = 0.1              # ms: the impact, yielding and the contact search, no folds yet
# the scene's grid box (100 x 100 x 320 mm about (0, 0, 150)) 100x larger along each axis (issue 20):
# 10 x 10 x 32 m, 10^6 times the volume, 2.0e11 grid nodes at h = 2.5 mm (a dense grid of them would be
# 6.6 TB); the hashed grid only checks that nodes stay inside it
WIDE_GRID = ("method.grid_min=[-5000,-5000,-15850]", "method.grid_max=[5000,5000,16150]")
EMPTY_GRID_PAIRS = 3                # scene grid / wide grid, interleaved: the noise of one pair is ~10 %
EMPTY_GRID_END_TIME = 0.5           # ms: a run of ~1.4 s, long against the per-run fixed costs


@dataclass(frozen=True)
class Case:
    name: str
    scene: str                      # key of SCENE_FILES
    mesh: str                       # label, e.g. "10x1", "16x16q", "10/2/60"
    mode: str                       # mpm | fem | newton | kratos
    ratio: float | None             # grid cell / element size (mpm), else None
    element_size: float
    overrides: tuple[str, ...]

    @property
    def scene_file(self) -> Path:
        return SCENES / SCENE_FILES[self.scene]

    @property
    def series(self) -> str:
        """Mode label of a refinement series (mesh left out)."""
        return f"mpm h={self.ratio:g}l" if self.mode == "mpm" else self.mode


def _ratio_tag(r: float) -> str:
    return f"r{r:g}"


def _mode_cases(scene: str, prefix: str, mesh: str, ell: float, base: tuple[str, ...], ratios, fem: bool,
                peers: bool, tag: str = "", newton: bool = True) -> list[Case]:
    """One mesh of a static refinement series: mpm at each grid ratio, fem (dynamic relaxation
    and, issue 19, Newton: mode ``newton``, steps = Newton iterations), and the peer."""
    out = [Case(f"{prefix}_mpm_{_ratio_tag(r)}{tag}", scene, mesh, "mpm", r, ell,
                base + ("method.kind=mpm", f"method.cell_size={r * ell:g}")) for r in ratios]
    if fem:
        out.append(Case(f"{prefix}_fem{tag}", scene, mesh, "fem", None, ell, base + ("method.kind=fem",)))
        if newton:
            out.append(Case(f"{prefix}_newton{tag}", scene, mesh, "newton", None, ell,
                            base + ("method.kind=fem", "solve.solver=newton")))
    if peers:
        out.append(Case(f"{prefix}_kratos{tag}", scene, mesh, "kratos", None, ell, base))
    return out


def cantilever_cases(nxs=CANTILEVER_NX, ratios=RATIOS, fem=True, peers=False, newton=True) -> list[Case]:
    out = []
    for nx in nxs:
        ny = max(1, nx // 10)
        ell = 10.0 / nx
        mesh = f"{nx}x{ny}"
        base = (f"mesh.nx={nx}", f"mesh.ny={ny}",
                f"solve.max_steps_per_load_step={int(400_000 * max(1.0, nx / 10))}")
        out += _mode_cases("cantilever", f"cantilever_{mesh}", mesh, ell, base, ratios, fem, peers, newton=newton)
    return out


def hemisphere_cases(ns=HEMISPHERE_N, ratios=RATIOS, fem=True, peers=False, load_steps=None,
                     newton=True) -> list[Case]:
    out = []
    for n in ns:
        ell = 8.0 / n                 # nominal: the default cell 0.25 at 16x16 is l/2
        mesh = f"{n}x{n}q"
        base = (f"mesh.n_around={n}", f"mesh.n_meridian={n}",
                f"solve.max_steps_per_load_step={int(400_000 * max(1.0, n / 16))}")
        tag = ""
        if load_steps:
            base += (f"solve.load_steps={load_steps}",)
            tag = f"_ls{load_steps}"
        out += _mode_cases("hemisphere", f"hemisphere_{n}x{n}", mesh, ell, base, ratios, fem, peers, tag, newton)
    return out


def hemisphere_triangle_cases(ns=HEMISPHERE_N, elements=tuple(TRIANGLE_ELEMENTS), peers=False) -> list[Case]:
    """The quarter hemisphere in triangles (`mesh.triangles = "all"`), each triangle element in
    fem (relaxation), Newton and mpm (h = l/2), and the peer's triangle once per mesh: the
    triangle's error against run time beside the quad's (issue 33)."""
    out = []
    for n in ns:
        ell = 8.0 / n
        mesh = f"{n}x{n}t"
        base = (f"mesh.n_around={n}", f"mesh.n_meridian={n}", "mesh.triangles=all",
                f"solve.max_steps_per_load_step={int(400_000 * max(1.0, n / 16))}")
        for name in elements:
            out += _mode_cases("hemisphere_tri", f"hemisphere_tri_{name}_{n}x{n}", mesh, ell,
                               base + TRIANGLE_ELEMENTS[name], (0.5,), True, False)
        if peers:
            out.append(Case(f"hemisphere_tri_{n}x{n}_kratos", "hemisphere_tri", mesh, "kratos", None, ell, base))
    return out


def triangle_element(case: str) -> str | None:
    """The triangle element of a hemisphere_triangle_cases name (None: another case, or the
    peer's row)."""
    parts = case.split("_")
    return parts[2] if case.startswith("hemisphere_tri_") and parts[2] in TRIANGLE_ELEMENTS else None


def tube_cases(end_time: float | None = None) -> list[Case]:
    end = () if end_time is None else (f"solve.end_time={end_time:g}",)
    tag = "" if end_time is None else f"_t{end_time:g}"
    return [Case(f"tube_5mm_mpm{tag}", "tube", "10/2/60", "mpm", 0.5, 5.0, ("method.kind=mpm",) + end),
            Case(f"tube_5mm_fem{tag}", "tube", "10/2/60", "fem", None, 5.0, ("method.kind=fem",) + end),
            # selective mass scaling (issue 29, docs/mass_scaling.md) at 10x and 20x the tube's
            # step (2.47e-4 ms): the speed-against-error trade beside the unscaled fem row
            Case(f"tube_5mm_fem_sms10{tag}", "tube", "10/2/60", "fem", None, 5.0,
                 ("method.kind=fem", "solve.mass_scaling=selective", "solve.target_dt=2.5e-3") + end),
            Case(f"tube_5mm_fem_sms20{tag}", "tube", "10/2/60", "fem", None, 5.0,
                 ("method.kind=fem", "solve.mass_scaling=selective", "solve.target_dt=5e-3") + end),
            # its reciprocal mass matrix: no solve, the step capped at the zigzag's
            Case(f"tube_5mm_fem_sms_reciprocal{tag}", "tube", "10/2/60", "fem", None, 5.0,
                 ("method.kind=fem", "solve.mass_scaling=selective", "solve.sms_solve=reciprocal",
                  "solve.target_dt=auto") + end),
            Case(f"tube_2.5mm_mpm{tag}", "tube", "20/4/120", "mpm", 0.5, 2.5,
                 ("method.kind=mpm", "mesh.n_flat=20", "mesh.n_corner=4", "mesh.n_length=120",
                  "method.cell_size=1.25") + end),
            # one cell per element (issue 20, docs/grid.md): on one field with APIC the folds glue
            # and the impact's wave is filtered; multi fields with PolyPIC keep both
            Case(f"tube_5mm_mpm_h5{tag}", "tube", "10/2/60", "mpm", 1.0, 5.0,
                 ("method.kind=mpm", "method.cell_size=5") + end),
            Case(f"tube_5mm_mpm_h5_multi_polypic{tag}", "tube", "10/2/60", "mpm", 1.0, 5.0,
                 ("method.kind=mpm", "method.cell_size=5", "method.fields=multi", "method.transfer=polypic") + end)]


def scaling_cases(flats=SCALING_FLAT) -> list[Case]:
    """Time per step against the number of elements: the tube (mpm, J2, contact) at n_flat
    elements across a flat, n_flat / 5 around each fillet, 6 n_flat along, grid h = l/2, to
    SCALING_END_TIME."""
    out = []
    for n in flats:
        ell = 50.0 / n
        mesh = f"{n}/{max(1, round(n / 5))}/{6 * n}"
        base = (f"mesh.n_flat={n}", f"mesh.n_corner={max(1, round(n / 5))}", f"mesh.n_length={6 * n}",
                f"method.cell_size={ell / 2:g}", f"solve.end_time={SCALING_END_TIME:g}", "output.times=[]")
        out.append(Case(f"scaling_{n}", "scaling", mesh, "mpm", 0.5, ell, base))
    return out


def empty_grid_cases(pairs=EMPTY_GRID_PAIRS) -> list[Case]:
    """Empty space must cost nothing: the paper's tube (2 880 elements, mpm) to
    EMPTY_GRID_END_TIME in its scene grid box and in a box 100x larger along each axis
    (WIDE_GRID), as `pairs` interleaved pairs, so that a drift of the machine falls on both
    sides; the report gives each pair's run-time ratio and their median."""
    base = ("method.kind=mpm", f"solve.end_time={EMPTY_GRID_END_TIME:g}", "output.times=[]")
    out = []
    for k in range(1, pairs + 1):
        out.append(Case(f"empty_grid_scene_{k}", "empty_grid", "10/2/60", "mpm", 0.5, 5.0, base))
        out.append(Case(f"empty_grid_wide_{k}", "empty_grid", "10/2/60 box x100", "mpm", 0.5, 5.0,
                        base + WIDE_GRID))
    return out


# Static relaxation variants (case = default case + "_" + variant) against the default rows
# (FIRE, uniform_dt mass scaling): plain kinetic damping, the physical masses, and both.
# Their own scene keys keep them out of the refinement tables, slopes and plots.  (The
# cantilever's uniform mesh has one element size: mass scaling changes nothing there.
# Kinetic damping with uniform_dt stalls on the hemisphere: load step 10 ends 400 000 steps
# at a residual of 1.01e-4 of the load, so that pair is not planned.)
RELAXATION_VARIANTS = {"kinetic": ("solve.relaxation=kinetic",), "unscaled": ("solve.mass_scaling=none",),
                       "kinetic_unscaled": ("solve.relaxation=kinetic", "solve.mass_scaling=none")}
RELAXATION = (("cantilever_10x1_mpm_r0.5", "kinetic"), ("cantilever_10x1_fem", "kinetic"),
              ("hemisphere_16x16_mpm_r0.5", "unscaled"), ("hemisphere_16x16_mpm_r0.5", "kinetic_unscaled"))


def relaxation_default(case: str) -> str:
    """The default case of a relaxation variant's name."""
    return next((d for d, v in RELAXATION if case == f"{d}_{v}"), case.rsplit("_", 1)[0])


def relaxation_cases() -> list[Case]:
    """RELAXATION: each variant with the overrides of its default case plus its own."""
    defaults = {c.name: c for c in cantilever_cases((10,), ratios=(0.5,)) + hemisphere_cases((16,), ratios=(0.5,))}
    out = []
    for name, variant in RELAXATION:
        base = defaults[name]
        out.append(Case(f"{name}_{variant}", f"relaxation_{base.scene}", base.mesh, base.mode, base.ratio,
                        base.element_size, base.overrides + RELAXATION_VARIANTS[variant]))
    return out


def peers_available() -> bool:
    try:
        from ..peers import kratos
    except ImportError:              # the peer module is optional
        return False
    try:
        return bool(kratos.available())
    except Exception:
        return False


def plan(quick: bool, peers: bool) -> list[Case]:
    if quick:     # each case compiles its own kernels (~20 s on a cold cache): five cases fit in 3 minutes
        return (cantilever_cases((5,), ratios=(0.5,), fem=False, peers=peers)
                + cantilever_cases((10,), ratios=(0.5,), peers=peers, newton=False)
                + hemisphere_cases((8,), ratios=(0.5,), peers=peers, load_steps=QUICK_LOAD_STEPS, newton=False))
    return (cantilever_cases(peers=peers) + hemisphere_cases(peers=peers) + hemisphere_triangle_cases(peers=peers)
            + relaxation_cases() + tube_cases() + scaling_cases() + empty_grid_cases())


def select(planned: list[Case], patterns: list[str]) -> list[Case]:
    """The planned cases whose name matches one of the shell patterns of ``--cases`` (all
    of them without a pattern)."""
    return [c for c in planned if not patterns or any(fnmatch.fnmatchcase(c.name, pat) for pat in patterns)]
