"""Stable time step (stage S0; paper eq 38-40; method.md section 5).

The element rule (BT: alpha L_e / c_e with L_e = area / longest diagonal) is evaluated
inside the element pass (:mod:`.shell`) into ``dt_next``; here it is combined with the
paper's grid rule alpha h / (c_dil + max|v_d|) when ``dt_rule = "both"``, clipped to the
next output time, and checked for collapse.
"""

import taichi as ti

from ..state import STATUS_DT_COLLAPSE, State

DT_UNSET = 1.0e300


@ti.data_oriented
class TimeStep:
    def __init__(self, state: State, cfg):
        self.s = state
        self.cfg = cfg
        self.h = cfg.grid.h if cfg.grid is not None else 0.0

    @ti.func
    def grid_limit(self):
        return self.cfg.dt_safety * self.h / (self.cfg.dilatational_speed + self.s.max_speed[None])

    @ti.func
    def next_step(self):
        """Set dt for the next step from this step's element and grid limits."""
        dt = self.s.dt_next[None]
        if ti.static(self.cfg.grid_rule):
            dt = ti.min(dt, self.grid_limit())
        if self.s.dt_first[None] == 0.0:
            self.s.dt_first[None] = dt
        if dt < 1e-3 * self.s.dt_first[None]:
            self.s.status[None] = STATUS_DT_COLLAPSE
        self.s.dt_stable[None] = dt
        remaining = self.s.time_limit[None] - self.s.time[None]
        if remaining < dt:
            dt = remaining if remaining > 1e-9 * dt else 0.0
        self.s.dt[None] = dt
        self.s.dt_next[None] = DT_UNSET
