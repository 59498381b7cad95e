"""Sequences the stages of one explicit step (method.md 2, "update stress last") and
compiles them into kernels.

Three launches (``StepConfig.launch``, chosen by :func:`taichi_shell_mpm.runtime.choose_launch`)
share the same stage code:

* ``batched`` (CPU: statics and small meshes): one kernel runs many steps in a serial
  loop, so the ~90-140 us Python launch cost is paid once per batch; every scatter is a
  plain add.
* ``threads`` (CPU, dynamics from runtime.THREADS_MIN_ELEMENTS elements on): one kernel
  per step whose stage loops run on all cores.  Nothing in it is an f64 atomic add (13 ns
  here against 1 ns for a plain one): element loads are gathered at the nodes
  (stages/accumulate.py), P2G runs in grid slabs of alternating parity
  (stages/mapping.py), contact and wall impulses are scattered in node order, so the
  trajectory does not depend on the number of threads; only the energy sums (reductions)
  vary in their last bits.  Each parallel loop costs a thread-pool dispatch (~20-75 us by
  the machine), so the contact rebuild is a kernel of its own, launched only when due, the
  loops over rigid bodies are serial, and a small mesh runs its light node loops serially
  too (runtime.serial_node_loops).
* ``gpu``: as ``threads`` (element loads gathered), with atomic adds for the P2G, contact
  and wall-impulse scatters, which a serial loop would stall there.

The dynamic-relaxation decisions (kinetic damping or FIRE, method.md 6.2) are made
in-kernel at the end of each step, so a batch stops exactly at convergence.
"""

import taichi as ti

from .. import frontend
from ..energy import EnergyLedger
from ..state import STATUS_CONVERGED, STATUS_OK, State
from ..stages.accumulate import Accumulator
from ..stages.bodies import RigidBodies
from ..stages.constraints import NodeUpdate, drop_fixed
from ..stages.contact import SelfContact
from ..stages.grid import GridUpdate
from ..stages.joints import Joints
from ..stages.loads import ExternalLoads
from ..stages.mapping import Mapping
from ..stages.motion import PrescribedMotion
from ..stages.selective_mass import SelectiveMass
from ..stages.shell import ShellElement
from ..stages.timestep import TimeStep

KINETIC_CONVERGED = 1e-8     # KE <= 1e-8 W_ext (method.md 6.4)
# FIRE (Bitzek et al., PRL 97, 170201, 2006), their standard parameters; the time step is not
# adapted (ours already sits at the stability limit)
FIRE_ALPHA_START = 0.1
FIRE_ALPHA_SHRINK = 0.99
FIRE_DELAY = 5


@ti.data_oriented
class Stepper:
    def __init__(self, state: State, cfg, model):
        self.s = state
        self.cfg = cfg                  # config.Features
        self.batched = cfg.serial
        self.energy = EnergyLedger(state, cfg, cfg.plastic)
        self.loads = ExternalLoads(state, cfg)
        self.motion = PrescribedMotion(state, cfg, self.loads, self.energy)
        self.bodies = RigidBodies(state, cfg, self.energy, self.loads)     # the rigid system, tools included
        self.joints = Joints(state, cfg, self.loads) if cfg.joints else None      # [[tie]], [[spotweld]]
        self.nodes = NodeUpdate(state, cfg, self.bodies, self.energy, self.loads, self.motion, self.joints)
        if self.joints is not None:
            self.joints.nodes = self.nodes
        self.contact = SelfContact(state, cfg, model) if cfg.contact else None
        self.shell = ShellElement(state, cfg, self.energy)
        self.timestep = TimeStep(state, cfg)
        self.selective = SelectiveMass(state, cfg, self.shell.masses, self.nodes, self.bodies) if cfg.selective_mass else None
        self.acc = Accumulator(cfg.serial)
        self.mpm = cfg.method == "mpm"
        if self.mpm:
            self.grid = GridUpdate(state, cfg)
            self.mapping = Mapping(state, cfg, self.nodes, self.grid)

    # ------------------------------------------------------------------ one step
    @ti.func
    def begin(self):
        self.s.step.kinetic[None] = 0.0
        self.s.step.stagger_energy[None] = 0.0
        self.s.step.residual_sq[None] = 0.0
        self.s.step.max_speed[None] = 0.0
        self.s.step.reaction[None] = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(self.cfg.loads):
            self.loads.begin()              # curves, gravity, pressure at x^n
            self.s.step.constraint_sq[None] = 0.0
            self.motion.begin()
        if ti.static(self.cfg.contact):
            self.s.contact.pairs[None] = 0
            self.s.contact.velocity_high[None] = ti.Vector([-1e300, -1e300, -1e300])
            self.s.contact.velocity_low[None] = ti.Vector([1e300, 1e300, 1e300])
            self.contact.forces()
        if ti.static(self.cfg.tools):
            self.bodies.begin()

    @ti.func
    def velocity_update(self):
        """S2-S6: new nodal velocities, positions and rotations (grid or direct FE); a joint's
        slaves lumped on their masters before, placed after (stages/joints.py)."""
        if ti.static(self.cfg.joints):
            self.joints.distribute()
        if ti.static(self.cfg.bodies):
            if ti.static(self.cfg.selective_mass):      # the bodies' DOFs are in its solve (stages/selective_mass.py)
                self.selective.prepare()
            self.bodies.update()
        if ti.static(self.mpm):
            self.mapping.particles_to_grid()
            self.mapping.grid_to_particles()
            self.mapping.clear_grid()
        else:
            if ti.static(self.cfg.selective_mass and self.cfg.bodies):
                self.selective.advance()
            elif ti.static(self.cfg.selective_mass):
                self.selective.explicit_fe()
            else:
                self.nodes.explicit_fe()
        if ti.static(self.cfg.joints):
            self.joints.follow()

    @ti.func
    def end(self):
        """S8: time, dynamic-relaxation reset and convergence (static), next dt, and whether
        the contact candidate lists are due for a rebuild."""
        if ti.static(self.cfg.contact):
            self.contact.check_skin()
        shell_kinetic = self.s.step.kinetic[None]     # the nodes' (the bodies' is added below)
        if ti.static(self.cfg.bodies or self.cfg.tools):
            self.bodies.end()
        self.energy.guard(shell_kinetic)         # before a relaxation reset books the KE as damped
        self.shell.masses.guard()
        self.s.step.reaction_impulse[None] += self.s.step.dt[None] * self.s.step.reaction[None]
        self.s.step.time[None] += self.s.step.dt[None]
        self.s.step.step[None] += 1
        self.s.step.velocity_keep[None] = 1.0
        self.s.step.restart_factor[None] = 1.0
        if ti.static(self.cfg.static):
            target, work = self.s.step.residual_target_sq[None], self.s.step.external_work[None]
            ramped = True
            if ti.static(self.cfg.loads):       # displacement control: the prescribed DOFs' forces set the scale
                target += self.s.step.tolerance_sq[None] * self.s.step.constraint_sq[None]
                work += self.s.step.motion_work[None]
                ramped = self.s.step.curve_argument[None] == self.s.step.load_factor[None]
            if self.s.step.status[None] == STATUS_OK and self.s.step.residual_sq[None] <= target \
                    and self.s.step.kinetic[None] <= KINETIC_CONVERGED * work and ramped:
                self.s.step.status[None] = STATUS_CONVERGED
            if not ramped:
                self.s.step.kinetic_prev[None] = self.s.step.kinetic[None]
            elif ti.static(self.cfg.fire):
                self.fire()
            elif self.s.step.kinetic[None] < self.s.step.kinetic_prev[None]:
                self.restart_from_rest()         # kinetic damping: a KE peak has passed
            else:
                self.s.step.kinetic_prev[None] = self.s.step.kinetic[None]
        self.timestep.next_step()

    @ti.func
    def restart_from_rest(self):
        """Dynamic relaxation reset (method.md 6.2): drop the velocities and restart from rest
        with the central-difference half step; the kinetic energy goes to damped_energy."""
        self.s.step.damped_energy[None] += self.s.step.kinetic[None]
        self.s.step.kinetic_prev[None] = 0.0
        self.s.step.velocity_keep[None] = 0.0
        self.s.step.restart_factor[None] = 0.5

    @ti.func
    def fire(self):
        """FIRE relaxation [choice, replaces plain kinetic damping in statics; measured in the
        note of issue 4]: with the power P = F.v of the out-of-balance forces at the new
        configuration, P <= 0 restarts from rest (as kinetic damping does at a KE peak);
        otherwise the next step mixes the velocity towards the force,
        v <- (1 - alpha) v + alpha |v|_M / |F|_M^-1 M^-1 F (mass-weighted norms, rotations
        with their inertia), and after FIRE_DELAY uphill steps alpha shrinks by
        FIRE_ALPHA_SHRINK per step."""
        self.s.step.fire_power[None] = 0.0
        self.s.step.fire_speed_sq[None] = 0.0
        self.s.step.fire_force_sq[None] = 0.0
        for c in range(self.s.nodes.count[None]):
            if not self.nodes.is_prescribed(c):
                force, torque = self.nodes.residual_force(c), self.nodes.residual_torque(c)
                v, w = self.s.nodes.grid_velocity[c], self.s.nodes.omega[c]
                if ti.static(self.cfg.loads):      # a prescribed DOF's velocity is no relaxation
                    held = self.s.nodes.motion_mask[c]
                    v, w = drop_fixed(v, held, 0), drop_fixed(w, held, 3)
                m, inertia = self.nodes.mass_of(c), self.nodes.inertia_of(c)
                self.acc.total(self.s.step.fire_power, force.dot(v) + torque.dot(w))
                self.acc.total(self.s.step.fire_speed_sq, m * v.norm_sqr() + inertia * w.norm_sqr())
                self.acc.total(self.s.step.fire_force_sq, force.norm_sqr() / m + torque.norm_sqr() / inertia)
        if self.s.step.fire_power[None] > 0.0:
            self.s.step.fire_uphill[None] += 1
            if self.s.step.fire_uphill[None] > FIRE_DELAY:
                self.s.step.fire_alpha[None] *= FIRE_ALPHA_SHRINK
            alpha = self.s.step.fire_alpha[None]
            self.s.step.velocity_keep[None] = 1.0 - alpha
            self.s.step.fire_mix[None] = alpha * ti.sqrt(self.s.step.fire_speed_sq[None] / ti.max(self.s.step.fire_force_sq[None], 1e-300))
        else:
            self.restart_from_rest()
            self.s.step.fire_uphill[None] = 0
            self.s.step.fire_alpha[None] = FIRE_ALPHA_START
            self.s.step.fire_mix[None] = 0.0

    @ti.func
    def one_step(self):
        self.begin()
        self.velocity_update()
        self.shell.element_pass()
        if ti.static(self.cfg.mass_update):     # erosion, mass scaling: the new nodal masses
            self.shell.masses.node_masses()
        self.end()

    # ------------------------------------------------------------------ kernels
    @ti.kernel
    def advance_batch(self, max_steps: ti.i32) -> ti.i32:
        """Up to max_steps steps in one launch; stops early on a status or the time limit."""
        done = 0
        while done < max_steps and self.s.step.status[None] == STATUS_OK and self.s.step.dt[None] > 0.0:
            self.one_step()
            done += 1
        return done

    @ti.kernel
    def advance_one(self) -> ti.i32:
        """One step; returns 0 when no other may follow (a status, or no time left), else
        1, plus 1 when the contact candidate lists are due for a rebuild."""
        self.one_step()
        go = 0
        if self.s.step.status[None] == STATUS_OK and self.s.step.dt[None] > 0.0:
            go = 1
            if ti.static(self.cfg.contact):
                go += self.s.contact.rebuild[None]
        return go

    @ti.kernel
    def rebuild_contact(self):
        """Parallel launches: the candidate-list rebuild, launched only when it is due."""
        self.contact.build_candidates()

    def compile(self) -> None:
        """Compile the step's kernels, or load them from the offline cache, before the run.
        The batched kernel does so on a zero-step launch.  The parallel ones have no launch
        that leaves the state as it was, so they are compiled without one
        (:func:`load_kernel`) [choice, issue 17]: taking one step and putting every field back
        cost ~300 more kernels (a reader and a writer per field), 3.9 of the 6.2 CPU seconds
        of the tube's cached compile."""
        if self.batched:
            self.advance_batch(0)
            return
        load_kernel(self.advance_one)
        if self.contact is not None:
            load_kernel(self.rebuild_contact)

    def advance(self, max_steps: int) -> int:
        """Advance up to max_steps; returns the number of steps taken."""
        if self.batched:
            return int(self.advance_batch(max_steps))
        done = 0
        if max_steps > 0 and self.s.step.status[None] == STATUS_OK and self.s.step.dt[None] > 0.0:
            rebuild = self.contact is not None and self.s.contact.rebuild[None] == 1
            while done < max_steps:
                if rebuild:
                    self.rebuild_contact()
                go = self.advance_one()
                done += 1
                if go == 0:
                    break
                rebuild = go == 2
        return done


def load_kernel(method) -> bool:
    """Build a kernel method of a ``ti.data_oriented`` object (no other arguments) and compile
    it, or load it from the offline cache, without launching it.  Taichi 1.7 has no public
    call for this: it is what ``Kernel.__call__`` does before its launch (``ensure_compiled``,
    then ``Program.compile_kernel``, which keeps the result for the launch).  Left for the
    first launch: the backend's loading of the compiled code (LLVM JIT on the CPU, ~0.2 s
    for the tube's step kernel).  Those private names are used only where
    frontend.private_api allows them and all are there; otherwise nothing is done here and
    the kernel is compiled by Taichi's own path, at its first launch (returns False)."""
    if not frontend.private_api():
        return False
    try:
        from taichi.lang import impl
        kernel, owner = method._primal, method._kernel_owner
        ensure_compiled, compiled = kernel.ensure_compiled, kernel.compiled_kernels
        prog = impl.get_runtime().prog
        compile_kernel = prog.compile_kernel
    except (ImportError, AttributeError):
        return False
    key = ensure_compiled(owner)
    compile_kernel(prog.config(), prog.get_device_caps(), compiled[key])
    return True
