"""Failure at a small stable step (LS-DYNA TDEL): an element fails once its stable step (after
mass scaling) falls below its first point's material's ``failure_min_dt``."""
from __future__ import annotations

from ...keys import Key, keys, positive

NAME = "min_step"
KEYS = keys(Key("failure_min_dt", positive, "erosion (any model, dynamic solves; LS-DYNA TDEL): an element also "
                                            "fails once its stable time step (after mass scaling) falls below this",
                default=0.0, unit="time", default_text="none"))
BLOCK = ("failure_min_dt",)


def active(spec) -> bool:
    return getattr(spec, "failure_min_dt", 0.0) > 0.0


def kernel(state, cfg, columns: dict):
    import taichi as ti
    MIN_DT = columns["failure_min_dt"]
    s = state

    @ti.data_oriented
    class MinStepFailure:
        @ti.func
        def fails(self, e, section, limit):
            return limit < s.sections.failure[s.sections.point_material[section, 0]][MIN_DT]

    return MinStepFailure()
