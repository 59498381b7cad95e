"""Stable time step (stage S0; paper eq 38-40; method.md section 5).

The element rule (BT: alpha L_e / c_e with L_e = area / longest diagonal) is evaluated
inside the element pass (:mod:`.shell`) into ``dt_next``; here it is combined with the
paper's grid rule alpha h / (c_dil + max|v_d|) when ``dt_rule = "both"``, clipped to the
next output time, and checked for collapse.
"""

import numpy as np
import taichi as ti

from ..state import STATUS_DT_COLLAPSE, STATUS_OK, State

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
        if dt < 1e-3 * self.s.dt_first[None] and self.s.status[None] == STATUS_OK:   # the first problem wins
            self.s.status[None] = STATUS_DT_COLLAPSE
            self.s.status_index[None] = -1   # the limiting element is found on the host (Simulation.check_status)
        self.s.dt_stable[None] = dt
        remaining = self.s.time_limit[None] - self.s.time[None]
        if remaining < dt:                   # land exactly on the next output time ...
            dt = remaining if remaining > 1e-9 * dt else 0.0
        elif remaining < 2.0 * dt:           # ... in two equal steps rather than a sliver
            dt = 0.5 * remaining
        self.s.dt[None] = dt
        self.s.dt_next[None] = DT_UNSET


def initial_dt(points: np.ndarray, quads: np.ndarray, velocity: np.ndarray, cfg) -> float:
    """The same rules evaluated on the initial configuration (numpy, before the first step)."""
    x = points[quads]
    d13, d24 = x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]
    area = 0.5 * np.linalg.norm(np.cross(d13, d24), axis=1)
    longest = np.maximum(np.linalg.norm(d13, axis=1), np.linalg.norm(d24, axis=1))
    dt = cfg.dt_safety * float(np.min(area / longest)) / cfg.wave_speed
    if cfg.grid_rule:
        dt = min(dt, cfg.dt_safety * cfg.grid.h / (cfg.dilatational_speed + float(np.max(np.abs(velocity)))))
    return dt
