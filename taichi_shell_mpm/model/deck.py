"""An LS-DYNA deck's materials and sections as scene materials and sections, each value
checked as strictly as the same scene key (numpy; the deck itself is read by dyna/reader.py)."""
from __future__ import annotations

import numpy as np

from ..scene import Scene, SceneError


def deck_specs(deck, source: str):
    """Scene materials and sections for an LS-DYNA deck's parts (dyna.Deck): *MAT_001 elastic;
    *MAT_020 (rigid) elastic too, its E and PR held to the same checks (the part's shells give
    its rigid body its mass and inertia, dyna/scene.py);
    *MAT_003 and *MAT_024 J2: a *MAT_024 stress-strain curve (LCSS or EPS/ES) is the tabulated
    hardening law, extrapolated beyond its last point as LS-DYNA does, else linear hardening
    H = E E_t / (E - E_t) from the tangent modulus; their Cowper-Symonds C and P (*MAT_003 SRC,
    SRP) the cowper_symonds rate law on the total strain rate (VP = 0, -1) or the plastic strain
    rate (VP = 1); FAIL (*MAT_003 FS) > 0 the failure strain (one point, LS-DYNA's NUMFIP
    default), *MAT_024 TDEL the failure step of erosion; *MAT_037 Hill 1948 (hill48) with
    r0 = r45 = r90 = |R| and linear hardening of its ETAN (the plastic hardening modulus, used
    as given) or its HLCID curve; *SECTION_SHELL thickness T1, NIP
    Gauss points (QR = 0; NIP = 0 means 2), QR = 1 (trapezoidal) as Lobatto with a note, SHRF.

    A deck's value is checked as strictly as the same scene key (scene.value_problem, the
    scene's own validator): the third result maps a scene name (mat_<mid>, sec_<secid>) to the
    problems of its card, each naming the deck file, line, keyword and field; the caller
    reports those of the cards its parts use (a card the scene replaces is not used)."""
    from ..scene import Material, Section, value_problem
    materials, sections, notes, problems = {}, {}, [], {}

    def check(name: str, where: str, fields: tuple) -> None:
        """Each (deck field, scene table, scene key, value) against the scene's validator."""
        for deck_key, table, key, value in fields:
            problem = value_problem(table, key, value)
            if problem is not None:
                problems.setdefault(name, []).append(f"{where}: {deck_key} (the scene's {key}): {problem}")
    for mid, card in deck.materials.items():
        v = card.values
        E, nu, rho = v.get("e", 0.0), v.get("pr", 0.0), v.get("ro", 0.0)
        label = f"{card.where or source} (mid {mid})"
        check(f"mat_{mid}", label, (("RO", "material", "density", rho), ("E", "material", "E", E),
                                    ("PR", "material", "nu", nu)))
        if card.kind not in ("elastic", "rigid") and not card.curve:
            etan = v.get("etan", 0.0)
            check(f"mat_{mid}", label, (("SIGY", "material", "yield_stress", v.get("sigy", 0.0)),))
            if card.kind == "transversely_anisotropic":
                check(f"mat_{mid}", label, (("ETAN", "material", "hardening", etan),))
            elif not 0.0 <= etan < E and E > 0.0:
                problems.setdefault(f"mat_{mid}", []).append(
                    f"{label}: ETAN = {etan:g}: expected 0 <= ETAN < E = {E:g} (the tangent modulus of the "
                    "plastic range; ETAN >= E has no hardening modulus H = E ETAN/(E - ETAN) >= 0)")
        if card.kind in ("elastic", "rigid"):     # a rigid part's shells carry its mass (dyna/scene.py: its body)
            materials[f"mat_{mid}"] = Material(E=E, nu=nu, density=rho)
            continue
        keyword = {"piecewise_linear": "*MAT_024", "plastic_kinematic": "*MAT_003",
                   "transversely_anisotropic": "*MAT_037"}[card.kind]
        where = f"{source}: {keyword} {mid}"
        law = {"yield_stress": v.get("sigy", 0.0), "hardening": 0.0}
        if card.curve:
            law = {"hardening_law": "tabulated", "curve": deck_curve(card.curve, where, notes),
                   "beyond_curve": "extrapolate" if len(card.curve) > 1 else "flat"}
        elif card.kind == "transversely_anisotropic":       # its ETAN is the plastic hardening modulus
            law["hardening"] = v.get("etan", 0.0)
        else:
            etan = v.get("etan", 0.0)
            law["hardening"] = E * etan / (E - etan) if 0.0 < etan < E else 0.0
        if card.kind == "transversely_anisotropic":          # Hill 1948 with normal anisotropy |R|
            r = abs(v.get("r", 0.0))
            check(f"mat_{mid}", label, (("R", "material", "r0", r),))
            if v.get("r", 0.0) < 0.0:
                notes.append(f"{where}: R = {v['r']:g} (LS-DYNA's stabilised algorithm) is read as r = {r:g}")
            materials[f"mat_{mid}"] = Material(E=E, nu=nu, density=rho, model="hill48", **law,
                                               model_parameters=(("r0", r), ("r45", r), ("r90", r)))
            continue
        C, P = (v.get("src", 0.0), v.get("srp", 0.0)) if card.kind == "plastic_kinematic" else \
            (v.get("c", 0.0), v.get("p", 0.0))
        if C > 0.0 and P > 0.0:
            vp = int(v.get("vp", 0.0))
            law.update(rate_law="cowper_symonds", C=C, p=P, rate_measure="plastic" if vp == 1 else "total")
            if vp not in (0, -1, 1):
                notes.append(f"{where}: VP = {vp} is read as VP = 0 (Cowper-Symonds on the total strain rate)")
        if card.kind == "piecewise_linear" and int(v.get("lcsr", 0)) > 0:
            notes.append(f"{where}: the strain-rate scaling curve LCSR {int(v['lcsr'])} is not read")
        fail = v.get("fs", 0.0) if card.kind == "plastic_kinematic" else v.get("fail", 0.0)
        if 0.0 < fail < 1e20:                 # LS-DYNA's default 1e21 (and 0): no failure
            law["failure_strain"] = fail
        elif fail < 0.0:
            notes.append(f"{where}: FAIL/FS = {fail:g} (a user failure subroutine) is not read")
        if card.kind == "piecewise_linear" and v.get("tdel", 0.0) > 0.0:
            law["failure_min_dt"] = v["tdel"]
        materials[f"mat_{mid}"] = Material(E=E, nu=nu, density=rho, model="j2", **law)
    for secid, card in deck.sections.items():
        label = f"{card.where or source} (secid {secid})"
        check(f"sec_{secid}", label, (("T1", "section", "thickness", card.thickness),
                                      ("NIP", "section", "points", int(card.nip)),
                                      ("SHRF", "section", "shear_factor", card.shear_factor)))
        points = int(card.nip) if card.nip > 0 else 2             # NIP = 0: LS-DYNA's default, 2
        rule = "gauss"
        if card.quadrature == 1 and points > 1:
            rule = "lobatto"
            notes.append(f"{source}: *SECTION_SHELL {secid}: QR = 1 (trapezoidal) is integrated with the "
                         f"{points}-point Lobatto rule (both have points on the two surfaces)")
        elif card.quadrature != 0:
            notes.append(f"{source}: *SECTION_SHELL {secid}: QR = {card.quadrature} (a user rule) is not read: "
                         f"{points}-point Gauss rule")
        sections[f"sec_{secid}"] = Section(thickness=card.thickness, points=points, rule=rule,
                                           shear_factor=card.shear_factor)
    return materials, sections, notes, problems


def deck_curve(curve, where: str, notes: list) -> tuple[tuple[float, float], ...]:
    """A *MAT_024 stress-strain curve as a tabulated hardening curve (keys.curve_points):
    starting at plastic strain 0 (its first stress there if it starts later), points that do
    not advance in plastic strain dropped, a falling stress held at the highest before it
    (softening is not supported), each change in a note."""
    points = []
    for eps, sig in curve:
        if sig <= 0.0:
            raise SceneError(f"{where}: the stress-strain curve has a yield stress <= 0 ({sig:g} at plastic "
                             f"strain {eps:g})")
        if points and eps <= points[-1][0]:
            notes.append(f"{where}: curve point ({eps:g}, {sig:g}) does not advance in plastic strain: dropped")
            continue
        if points and sig < points[-1][1]:
            notes.append(f"{where}: the curve falls at plastic strain {eps:g} ({points[-1][1]:g} -> {sig:g}): "
                         f"held at {points[-1][1]:g} (softening is not supported)")
            sig = points[-1][1]
        points.append((float(eps), float(sig)))
    if points[0][0] > 0.0:
        notes.append(f"{where}: the curve starts at plastic strain {points[0][0]:g}: its first stress is taken "
                     "from plastic strain 0")
        points.insert(0, (0.0, points[0][1]))
    elif points[0][0] < 0.0:
        raise SceneError(f"{where}: the stress-strain curve starts at a negative plastic strain {points[0][0]:g}")
    return tuple(points)


def deck_element_thickness(deck, scene: Scene, notes: list) -> np.ndarray | None:
    """(m,) thickness of each element from *ELEMENT_SHELL_THICKNESS (the mean of its corner
    values; NaN: the section's), as LS-DYNA takes it over the section's T1 -- except in parts
    whose section the scene redefines ([sections.sec_<id>]: the scene's value wins; part_data)."""
    corner = deck.element_thickness
    if corner is None:
        return None
    given = np.where(corner > 0.0, corner, np.nan)
    count = np.sum(np.isfinite(given), axis=1)
    mean = np.where(count > 0, np.nansum(given, axis=1) / np.maximum(count, 1), np.nan)
    varying = int(np.sum(np.nanmax(given, axis=1, initial=0.0) - np.nanmin(given, axis=1, initial=np.inf) > 1e-12
                         * np.nanmax(given, axis=1, initial=1.0)))
    if varying:
        notes.append(f"{scene.source.name}: {varying} elements of *ELEMENT_SHELL_THICKNESS have corner "
                     "thicknesses that differ: each uses their mean (a constant thickness per element)")
    return mean if np.isfinite(mean).any() else None
