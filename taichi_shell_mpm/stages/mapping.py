"""The double mapping (stages S2 and S4; paper eq 1-3, 8-9, 15; method.md 2.1-2.2).

Element -> corner is done once (frozen CPDI2 weights give the corner masses, see
:func:`taichi_shell_mpm.assembly.cpdi2_weights`); here the corners map to the grid with
trilinear functions and back.  Transfer (compile-time): ``apic`` (affine corner
velocity C_c, conserves angular momentum; default), ``pic``, or ``flip`` blended with
PIC by ``flip_blend``.
"""

import taichi as ti

from ..state import STATUS_LEFT_GRID, State
from .accumulate import Accumulator
from .constraints import NodeUpdate


@ti.data_oriented
class Mapping:
    def __init__(self, state: State, cfg, nodes: NodeUpdate, mass_floor: float):
        self.s = state
        self.cfg = cfg
        self.nodes = nodes
        self.acc = Accumulator(cfg.serial)
        self.mass_floor = mass_floor
        g = cfg.grid
        self.h = g.h
        self.lo = g.lo
        self.dims = g.dims

    @ti.func
    def stencil(self, x):
        """Base grid index (local), fractional position and validity for trilinear weights."""
        r = x / self.h
        base_abs = ti.floor(r, ti.i32)
        frac = r - base_abs
        base = base_abs - ti.Vector(self.lo, dt=ti.i32)
        inside = True
        for d in ti.static(range(3)):
            if base[d] < 0 or base[d] > self.dims[d] - 2:
                inside = False
        return base, frac, inside

    @ti.func
    def flat(self, idx):
        return (idx[0] * self.dims[1] + idx[1]) * self.dims[2] + idx[2]

    @ti.func
    def weight(self, frac, off):
        """N_I = prod_d N^(r_d) and its gradient for the cell-corner offset `off` in {0,1}^3."""
        o = ti.cast(off, ti.f64)
        w = o * frac + (1.0 - o) * (1.0 - frac)
        dw = (2.0 * o - 1.0) / self.h
        n = w[0] * w[1] * w[2]
        grad = ti.Vector([dw[0] * w[1] * w[2], w[0] * dw[1] * w[2], w[0] * w[1] * dw[2]])
        return n, grad

    @ti.func
    def touch(self, g):
        """Record grid node g in the touched list the first time it receives mass."""
        if ti.static(self.cfg.serial):
            if self.s.grid_touched[g] == 0:
                self.s.grid_touched[g] = 1
                self.s.touched_list[self.s.n_touched[None]] = g
                self.s.n_touched[None] += 1
        else:
            if ti.atomic_add(self.s.grid_touched[g], 1) == 0:
                self.s.touched_list[ti.atomic_add(self.s.n_touched[None], 1)] = g

    @ti.func
    def particles_to_grid(self):
        """S2: m_I = sum N m_c, p_I = sum N m_c (v_c + C_c (X_I - x_c)), f_I = sum N (f_ext - f_int)_c."""
        for c in range(self.s.n_nodes):
            if not self.nodes.is_prescribed(c):
                base, frac, inside = self.stencil(self.s.position[c])
                if not inside:
                    self.s.status[None] = STATUS_LEFT_GRID
                    self.s.status_index[None] = c
                else:
                    mass = self.s.corner_mass[c]
                    keep = self.s.velocity_keep[None]
                    force = self.nodes.residual_force(c)
                    vel = keep * self.s.velocity[c]
                    if ti.static(self.cfg.fire):
                        vel += (self.s.fire_mix[None] / mass) * force    # FIRE mixing (solvers/stepper.py)
                    for off in ti.grouped(ti.ndrange(2, 2, 2)):
                        n, _ = self.weight(frac, off)
                        g = self.flat(base + off)
                        p = vel
                        if ti.static(self.cfg.transfer == "apic"):
                            p += keep * (self.s.affine[c] @ ((ti.cast(off, ti.f64) - frac) * self.h))
                        self.touch(g)
                        self.acc.add(self.s.grid_mass, g, n * mass)
                        self.acc.add(self.s.grid_momentum, g, n * mass * p)
                        self.acc.add(self.s.grid_force, g, n * force)

    @ti.func
    def grid_to_particles(self):
        """S4: v~_c = sum N v+_I (moves the node); carried v_c by the transfer rule; then the
        node-level BCs, position and rotation update (:meth:`NodeUpdate.finish`)."""
        for c in range(self.s.n_nodes):
            v_grid = ti.Vector([0.0, 0.0, 0.0])
            if not self.nodes.is_prescribed(c):
                base, frac, inside = self.stencil(self.s.position[c])
                if inside:
                    v_delta = ti.Vector([0.0, 0.0, 0.0])
                    affine = ti.Matrix.zero(ti.f64, 3, 3)
                    massive_grad = ti.Vector([0.0, 0.0, 0.0])
                    for off in ti.grouped(ti.ndrange(2, 2, 2)):
                        n, grad = self.weight(frac, off)
                        g = self.flat(base + off)
                        v_grid += n * self.s.grid_v_plus[g]
                        if ti.static(self.cfg.transfer == "flip"):
                            v_delta += n * (self.s.grid_v_plus[g] - self.s.grid_v_minus[g])
                        if ti.static(self.cfg.transfer == "apic"):
                            affine += self.s.grid_v_plus[g].outer_product(grad)
                            if self.s.grid_mass[g] > self.mass_floor:
                                massive_grad += grad
                    if ti.static(self.cfg.transfer == "apic"):
                        # C = sum over nodes with mass of (v+_I - v~_c) grad N_I^T [choice]: a
                        # massless node (weight 0, gradient not 0: a corner sitting on a grid
                        # plane) carries no velocity, so it must not pull C towards -v/h.
                        # Identical to sum v+_I grad N_I^T when all 8 nodes have mass.
                        affine -= v_grid.outer_product(massive_grad)
                    carried = v_grid
                    if ti.static(self.cfg.transfer == "flip"):
                        a = self.cfg.flip_blend
                        carried = a * (self.s.velocity_keep[None] * self.s.velocity[c] + v_delta) + (1.0 - a) * v_grid
                    if ti.static(self.cfg.transfer == "apic"):
                        self.s.affine[c] = affine
                    self.s.velocity[c] = carried
            self.nodes.finish(c, v_grid)
