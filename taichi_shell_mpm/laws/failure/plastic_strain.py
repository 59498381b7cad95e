"""Failure at an equivalent plastic strain (LS-DYNA FAIL, NUMFIP > 0): an element fails in the
step in which ``failure_points`` of its through-thickness points reach their material's
``failure_strain``."""
from __future__ import annotations

from ...keys import Key, integer, keys, positive

NAME = "plastic_strain"
KEYS = keys(
    Key("failure_strain", positive, "erosion (a plastic model, dynamic solves; LS-DYNA FAIL): an element fails in the "
                                    "step in which `failure_points` of its through-thickness points reach this "
                                    "equivalent plastic strain", default=0.0, default_text="none (no failure)"),
    Key("failure_points", integer(1, 10), "how many through-thickness points must reach `failure_strain` (LS-DYNA "
                                          "NUMFIP)", default=1,
        allowed="1 .. the points of every section the material is used with; only with `failure_strain`"))
BLOCK = ("failure_strain", "failure_points")


def rules(r, path: str, data: dict, values: dict) -> None:
    """Only for a plastic model; failure_points only with failure_strain."""
    if "failure_strain" in data and values.get("model") == "elastic":
        r.error(f"{path}.failure_strain", "only for model = \"j2\" (the equivalent plastic strain); "
                                          "failure_min_dt erodes elements of any model")
    if "failure_points" in data and "failure_strain" not in data:
        r.error(f"{path}.failure_points", "only with failure_strain")


def active(spec) -> bool:
    return getattr(spec, "failure_strain", 0.0) > 0.0


def kernel(state, cfg, columns: dict):
    import taichi as ti
    STRAIN, POINTS = columns["failure_strain"], columns["failure_points"]
    s = state

    @ti.data_oriented
    class PlasticStrainFailure:
        @ti.func
        def fails(self, e, section, limit):
            """failure_points of the element's points have reached their material's failure
            strain (a run-time loop: a layered section's points each with their ply's
            material); failure_points is its first point's material's."""
            failed = 0
            if ti.static(cfg.plastic):
                for k in range(s.sections.point_count[section]):
                    strain = s.sections.failure[s.sections.point_material[section, k]][STRAIN]
                    if strain > 0.0 and s.points.plastic_strain[e, k] >= strain:
                        failed += 1
            first = s.sections.failure[s.sections.point_material[section, 0]]
            return failed > 0 and failed >= ti.cast(first[POINTS], ti.i32)

    return PlasticStrainFailure()
