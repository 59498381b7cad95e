"""Grid update (stage S3; paper eq 5-7; method.md 2.4): v- = p/m, v+ = v- + dt f/m on the
touched nodes only, symmetry grid planes (normal parts of p and f removed), the grid
residual used by the static convergence test (method.md 6.4), and clearing.
"""

import taichi as ti

from ..state import State
from .accumulate import Accumulator


@ti.data_oriented
class GridUpdate:
    def __init__(self, state: State, cfg, mass_floor: float):
        self.s = state
        self.cfg = cfg
        self.dims = cfg.grid.dims
        self.lo = cfg.grid.lo
        self.planes = cfg.grid.planes
        self.mass_floor = mass_floor
        self.flip = cfg.transfer == "flip"
        self.acc = Accumulator(cfg.serial)

    @ti.func
    def update(self):
        for i in range(self.s.n_touched[None]):
            g = self.s.touched_list[i]
            m = self.s.grid_mass[g]
            p = self.s.grid_momentum[g]
            f = self.s.grid_force[g]
            if ti.static(len(self.planes) > 0):
                idx = ti.Vector([g // (self.dims[1] * self.dims[2]), (g // self.dims[2]) % self.dims[1],
                                 g % self.dims[2]])
                for axis, plane in ti.static(self.planes):
                    if idx[axis] + self.lo[axis] == plane:
                        p[axis] = 0.0
                        f[axis] = 0.0
            v_minus = ti.Vector([0.0, 0.0, 0.0])
            v_plus = ti.Vector([0.0, 0.0, 0.0])
            if m > self.mass_floor:
                v_minus = p / m
                v_plus = v_minus + (self.s.restart_factor[None] * self.s.dt[None] / m) * f
            self.acc.total(self.s.residual_sq, f.norm_sqr())
            if ti.static(self.flip):
                self.s.grid_v_minus[g] = v_minus
            self.s.grid_v_plus[g] = v_plus

    @ti.func
    def clear(self):
        for i in range(self.s.n_touched[None]):
            g = self.s.touched_list[i]
            self.s.grid_mass[g] = 0.0
            self.s.grid_momentum[g] = ti.Vector([0.0, 0.0, 0.0])
            self.s.grid_force[g] = ti.Vector([0.0, 0.0, 0.0])
            self.s.grid_touched[g] = 0
