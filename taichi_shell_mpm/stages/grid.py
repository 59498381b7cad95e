"""Grid update (stage S3; paper eq 5-7; method.md 2.4): v- = p/m and v+ = v- + dt f/m of a
grid node, with the symmetry grid planes (normal parts of p and f removed), and clearing.

The update is evaluated where G2P reads a node (:meth:`GridUpdate.velocities`) rather
than in a loop of its own over a list of touched nodes [choice, measured in the note of
issue 4]: it costs a division per read instead of a list, and lets P2G run in parallel
without atomics.  Only the nodes around shell nodes are ever written, read or cleared,
so the empty grid costs nothing.

Without FLIP and outside statics (StepConfig.grid_force false) only v+ is read, so P2G
scatters the momentum and the force impulse into one field, p~_I = sum N (m (v + C dx) +
dt f), and v+ = p~/m [choice, measured in the note of issue 4]: 4 doubles per grid node
instead of 7, the same v+ up to rounding; P2G + G2P + clear of the tube at 10.75 ms cost
754-802 us per step instead of 883-1027 (two pairs of runs, benchmarks/stage_times.py).
"""

import taichi as ti

from ..state import State
from .timestep import impulse_time


@ti.data_oriented
class GridUpdate:
    """The grid's geometry (h, lo, dims, strides, symmetry planes) and mass floor are run-time
    data (state.grid, state.step.mass_floor)."""

    def __init__(self, state: State, cfg):
        self.s = state
        self.cfg = cfg

    @ti.func
    def velocities(self, g, idx):
        """(v-, v+, f, 1/m or 0 when massless) of grid node g at local index idx (method.md 2.4).
        Without a grid force field (see the module docstring) v- is v+ and f is zero."""
        m = self.s.grid.mass[g]
        p = self.s.grid.momentum[g]
        f = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.grid_force):
            f = self.s.grid.force[g]
        if ti.static(self.cfg.grid_planes):
            lo = self.s.grid.lo[None]
            for q in range(self.s.grid.planes[None]):
                for axis in ti.static(range(3)):
                    if self.s.grid.plane_axis[q] == axis and idx[axis] + lo[axis] == self.s.grid.plane_index[q]:
                        p[axis] = 0.0
                        f[axis] = 0.0
        v_minus = ti.Vector([0.0, 0.0, 0.0])
        v_plus = ti.Vector([0.0, 0.0, 0.0])
        inv_mass = 0.0
        if m > self.s.step.mass_floor[None]:
            inv_mass = 1.0 / m
            v_minus = inv_mass * p
            v_plus = v_minus
            if ti.static(self.cfg.grid_force):
                v_plus += (impulse_time(self.s.step) * inv_mass) * f
        return v_minus, v_plus, f, inv_mass

    @ti.func
    def corner_node(self, cell, strides, i: ti.template(), j: ti.template(), k: ti.template()):
        """Flat index of the cell corner (i, j, k) in {0,1}^3 of the stencil whose base node
        has flat index `cell` (GridGeometry.strides)."""
        return cell + i * strides[0] + j * strides[1] + k * strides[2]

    @ti.func
    def clear(self, cell, strides):
        """Zero the 8 grid nodes of the stencil whose base node has flat index `cell`."""
        for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
            g = self.corner_node(cell, strides, i, j, k)
            self.s.grid.mass[g] = 0.0
            self.s.grid.momentum[g] = ti.Vector([0.0, 0.0, 0.0])
            if ti.static(self.cfg.grid_force):
                self.s.grid.force[g] = ti.Vector([0.0, 0.0, 0.0])
