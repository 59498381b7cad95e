"""A run of one scene: build (mesh -> model -> fields -> kernels), drive, record, write.

:class:`Simulation` owns one Taichi runtime's worth of state (runtime.py starts it).  Drivers:
:func:`taichi_shell_mpm.solvers.static.run_static`,
:func:`taichi_shell_mpm.solvers.dynamic.run_dynamic` and
:func:`taichi_shell_mpm.solvers.newton.run_newton`, each in a run_control.RunLoop.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import taichi as ti

from .model.assembly import Model, assemble, element_length
from .config import Features
from .model.materials import COL
from .mesh import Mesh, build_mesh
from .crush import crush_summary
from .output import FrameWriter, OutputError, write_csv, write_json
from .progress import Progress
from .reference import reference_summary
from .scene import Scene
from .solvers.stepper import Stepper
from .stages.timestep import DT_UNSET, initial_dt
from .state import (CANDIDATES_PER_NODE, MAX_FIELDS, STATUS_CONTACT_FULL, STATUS_DT_COLLAPSE, STATUS_ENERGY,
                    STATUS_BODY_ROTATION, STATUS_INVERTED, STATUS_LEFT_GRID, STATUS_MASS_ADDED, STATUS_NONFINITE, STATUS_RETURN_FAILED,
                    STATUS_SMS_SOLVE,
                    State)
from . import energy
from .runtime import choose_launch
from . import program
from .energy import (ENERGY_COLUMNS, PART_COLUMNS, added_kinetic, added_mass, deformation_mass, eroded_elements,
                     part_energies, part_names)


class SimulationError(Exception):
    """A run-time failure (instability, non-convergence); message is one line."""


# in-kernel failure statuses (state.py): what happened, and its likely cause
FAILURES = {
    STATUS_INVERTED: ("element {index} turned inside out",
                      "time step too large ([solve].dt_safety), too little hourglass control "
                      "([element].hourglass), or an excessive load"),
    STATUS_LEFT_GRID: ("node {index} left the background grid",
                       "it left the [method].grid_min/grid_max box (leave them out: the grid follows the "
                       "shell), or flew 2^20 cells from the origin (a missing support, an excessive load "
                       "or initial velocity)"),
    STATUS_NONFINITE: ("node {index} got a non-finite or runaway velocity",
                       "numerical instability: time step too large ([solve].dt_safety), an excessive "
                       "load or initial velocity, or a missing support"),
    STATUS_DT_COLLAPSE: ("the time step collapsed below 1e-3 of the first one at element {index}",
                         "that element is crushed or badly distorted: an excessive load, too little "
                         "hourglass control or too coarse a mesh"),
    STATUS_CONTACT_FULL: ("the contact candidate lists overflowed ({index} entries, room for "
                          f"{CANDIDATES_PER_NODE} per node)",
                          "a contact thickness ([contact].thickness or the shell's) far above the element "
                          "size, or the mesh collapsing into a heap (see the frames); if the packing is real, "
                          "raise state.CANDIDATES_PER_NODE"),
    STATUS_RETURN_FAILED: ("the plastic return map did not converge at element {index}",
                           "a strain increment far beyond yield in one step (an excessive load or velocity, "
                           "or a time step too large: [solve].dt_safety) or a material table that is not "
                           "physical"),
    STATUS_BODY_ROTATION: ("the rotation of rigid body {index} did not converge (the Simo-Wong fixed point, "
                           "stages/bodies.py)",
                           "a body whose inertia is far from isotropic turning fast: give its physical inertia "
                           "([[rigid_body]].inertia) or lower [solve].dt_safety"),
    STATUS_MASS_ADDED: ("conventional mass scaling added {added} of the shell's mass, above [solve].added_mass_limit",
                        "the elements are distorted far below [solve].target_dt: lower target_dt, raise "
                        "added_mass_limit, or refine the mesh where they collapse"),
    STATUS_SMS_SOLVE: ("the selective-mass-scaling solve did not converge in {index} conjugate-gradient iterations",
                       "a target_dt far above the elements' own steps (the solve's iterations grow with "
                       "target/dt_e): lower [solve].target_dt, or raise sms_max_iterations or sms_tolerance"),
    STATUS_ENERGY: ("the energy balance error reached {ratio} of the energy absorbed (energy was created)",
                    "an instability that creates energy (time step too large: [solve].dt_safety; contact "
                    "too stiff: [contact].stiffness) or a constraint that works on the shell; --energy-limit "
                    "sets this limit"),
}
HOURGLASS_WARN, HOURGLASS_STOP = 0.10, 0.20     # (E_hg + E_drill) / E_int
HOURGLASS_ACTIVE = 1e-6     # ratio checked once max(E_int, E_hg) > this x max(W_ext, KE0)


def prepare(scene: Scene, model: Model, launch: str, keep: bool = False) -> tuple[Features, State, Stepper]:
    """The feature set, the state loaded from the model and the step's stages, before any
    kernel is compiled (:class:`Simulation`; tests that use one stage alone).  `keep`: reuse
    the live program's state and stepper when they fit, and keep these for the next run
    (program.py)."""
    cfg = Features.from_scene(scene, model, launch)
    live = program.reuse(cfg, model) if keep else None
    if live is not None:
        state, stepper = live
    else:
        if keep:
            program.release()
        state = State(model, cfg)
        state.load(model)
        stepper = Stepper(state, cfg, model)
        if keep:
            program.keep(cfg, state, stepper)
    program.generation += 1
    return cfg, state, stepper


@dataclass
class History:
    """Rows recorded at each output point (load step or output time)."""
    probe_header: list[str]
    probe_rows: list[list[float]] = field(default_factory=list)
    energy_rows: list[list[float]] = field(default_factory=list)
    force_rows: list[list[float]] = field(default_factory=list)
    part_rows: list[list[float]] = field(default_factory=list)
    """[key, then energy.part_energies flattened row by row] (parts.csv)"""


class Simulation:
    def __init__(self, scene: Scene, out_dir: Path | None = None, arch: str = "cpu", quiet: bool = False,
                 mesh: Mesh | None = None, model: Model | None = None, keep: bool = False):
        self.scene = scene
        self.arch = arch
        self.arch_requested: str | None = None      # set when Taichi fell back from this arch to `arch`
        self.quiet = quiet
        self.out_dir = Path(out_dir) if out_dir is not None else Path("outputs") / scene.info.name
        self.mesh: Mesh = mesh if mesh is not None else build_mesh(scene.mesh)
        self.model: Model = model if model is not None else assemble(scene, self.mesh)
        launch = choose_launch(arch, len(self.model.elements), scene.solve.kind == "static")
        self.cfg, self.state, self.stepper = prepare(scene, self.model, launch, keep)
        self.driver_data: dict = {}          # driver counters (and the last rotations read) kept in checkpoints
        self.driver_arrays: dict[str, np.ndarray] = {}   # the driver's arrays kept in checkpoints
        self._initial_geometry()
        t0, cpu0 = time.perf_counter(), time.process_time()
        self._compile()
        self.initial_kinetic = self.kinetic_energy()
        self.energy_limit = energy.BALANCE_STOP
        self._compile_readers()
        self.compile_seconds = time.perf_counter() - t0
        # CPU seconds of the process (all threads): what the build costs whatever else the
        # machine runs, the figure to compare across sittings (benchmarks/compile_once.py)
        self.compile_cpu_seconds = time.process_time() - cpu0
        key = "load_factor" if scene.solve.kind == "static" else "time"
        header = [key] + [f"{p.name}.{c}" for p in self.model.probes for c in p.components]
        self.history = History(probe_header=header)
        self.frames: FrameWriter | None = None
        self.total_steps = 0
        self.run_seconds = 0.0
        self.run_cpu_seconds = 0.0          # the process's CPU time over the run (all threads)
        self.reporter = Progress(quiet, scene.solve.progress_every)
        self.warnings: list[str] = []
        self.hourglass_warned = False
        self.overflow_warned = False               # the multi-field grid ran out of fields (check_fields)
        self.hourglass_limit = HOURGLASS_STOP      # stop above this (E_hg + E_drill)/E_int (0: never), warn above half
        self.balance_warned = False
        self._last_geometry_check = 0.0

    # ------------------------------------------------------------------ set-up helpers
    def _initial_geometry(self) -> None:
        """State before the first step: for the drilling projection (method.md 2.3) and the
        multi-field grid the nodal normals (sum A e3); for the projection the initial omega
        without its drilling part; the first stable dt."""
        pts, elements = self.model.points, self.model.elements
        w = self.model.omega0
        if self.cfg.nodal_normals:
            # a triangle's corner 4 read as its corner 1: (x3 - x1) x (x1 - x2) = (x2 - x1) x (x3 - x1)
            x = pts[np.where(elements >= 0, elements, elements[:, :1])]
            element_normal = 0.5 * np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])     # A e3
            normal = np.zeros_like(pts)
            area = np.zeros(len(pts))
            corner = elements >= 0
            np.add.at(normal, elements[corner], np.repeat(element_normal[:, None, :], 4, axis=1)[corner])
            np.add.at(area, elements[corner], np.repeat(np.linalg.norm(element_normal, axis=1)[:, None], 4, axis=1)[corner])
            self.state.put("nodes.normal_sum", normal)
            self.state.put("nodes.area_sum", area)
        if not self.cfg.drilling_spring:
            unit = normal / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
            w = w - np.sum(w * unit, axis=1)[:, None] * unit
        self.state.put("nodes.omega", w)
        dt = initial_dt(self.model, self.model.velocity0, self.cfg)
        st = self.state.step
        for f in (st.dt, st.dt_stable, st.dt_first, st.dt_last):
            f[None] = dt
        st.dt_next[None] = DT_UNSET

    # ------------------------------------------------------------------ measurements
    @property
    def initial_kinetic(self) -> float:
        """KE_0 of the energy balance (a field: the in-kernel guard reads it)."""
        return float(self.state.step.kinetic_initial[None])

    @initial_kinetic.setter
    def initial_kinetic(self, value: float) -> None:
        self.state.step.kinetic_initial[None] = value

    @property
    def energy_limit(self) -> float:
        """Balance guard: stop when |E_err| exceeds this x the absorbed energy (0: never;
        energy.py); warn at energy.WARN_FRACTION of it."""
        return float(self.state.step.energy_limit[None])

    @energy_limit.setter
    def energy_limit(self, value: float) -> None:
        self.state.step.energy_limit[None] = value

    def kinetic_energy(self) -> float:
        return energy.kinetic_energy(self.state, self.model)

    def energies(self) -> dict[str, float]:
        """energy.totals now (once per State.reads_cached scope: the run loop's checks, record
        and progress line ask for them on one state)."""
        return dict(self.state.derived("energies", lambda: energy.totals(self.state, self.model, self.initial_kinetic)))

    def displacements(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodal displacement (n,3) and accumulated rotation vector (n,3).

        The orientation quaternion q = (cos phi/2, a sin phi/2) is composed continuously by
        both static solvers and the dynamic step (each increment's quaternion times q, never
        sign-normalised; a rigid body's nodes take its quaternion, composed the same way), so
        it holds the angle phi about the axis a modulo 4 pi.  Its principal vector (phi in
        [0, 2 pi]) jumps from 2 pi a to 2 pi (-a) as a node passes a full turn: a strip
        rolled up by M_max read ry = -6.282 by relaxation (just short of the turn) and +6.283
        by Newton (just past it).  The rotation reported [choice: the angle turned, as a
        rotation probe of a roll-up wants] is the vector (phi + 4 pi k) a nearest the one
        reported last: any number of turns, provided a node turns by less than half a turn
        between two reads (each record, frame and history row reads; the roll-up turns its
        tip by a quarter turn per level).  The last vectors of the nodes turned by more than
        pi are kept in ``driver_data["rotations"]`` (checkpointed); any other node's is
        taken as zero.  (A body's own rotation in force.csv is still the principal one.)"""
        u = self.state.fetch("nodes.position") - self.model.points
        q = self.state.fetch("nodes.rotation")
        s = np.linalg.norm(q[:, 1:], axis=1)
        angle = 2.0 * np.arctan2(s, q[:, 0])
        axis = q[:, 1:] / np.maximum(s, 1e-300)[:, None]
        last = np.zeros_like(axis)
        for row in self.driver_data.get("rotations", []):
            last[int(row[0])] = row[1:]
        turns = np.round((np.einsum("ij,ij->i", last, axis) - angle) / (4.0 * math.pi))
        rot = axis * (angle + 4.0 * math.pi * turns)[:, None]
        turned = np.flatnonzero(np.linalg.norm(rot, axis=1) > math.pi)
        self.driver_data["rotations"] = [[int(c), *map(float, rot[c])] for c in turned]
        return u, rot

    def probe_values(self) -> list[float]:
        u, rot = self.displacements()
        dof = np.concatenate([u, rot], axis=1)
        out = []
        for p in self.model.probes:
            mean = dof[p.nodes].mean(axis=0)
            out += [float(mean[["ux", "uy", "uz", "rx", "ry", "rz"].index(c)]) for c in p.components]
        return out

    def element_results(self) -> dict[str, np.ndarray]:
        """Membrane forces N, bending moments M = int z sigma dz (per unit length), the
        mid-surface von Mises stress of each element (local frame), its thickness and part."""
        data, sections = self.model.element, self.model.sections
        t = data.thickness
        zeta, w = sections.zeta[data.section], sections.weight[data.section]     # (m, nk)
        sig = self.state.fetch("points.stress")                                   # (m, nk, 5)
        n_res = 0.5 * t[:, None] * np.einsum("mk,mkc->mc", w, sig[:, :, :3])
        m_res = 0.25 * (t * t)[:, None] * np.einsum("mk,mkc->mc", w * zeta, sig[:, :, :3])
        s = n_res / t[:, None]
        vm = np.sqrt(np.maximum(s[:, 0] ** 2 - s[:, 0] * s[:, 1] + s[:, 1] ** 2 + 3 * s[:, 2] ** 2, 0.0))
        out = {"membrane_force": n_res, "bending_moment": m_res, "von_mises_mid": vm,
               "thickness": t.copy(), "part": data.part.astype(np.int32)}
        if self.cfg.plastic:
            ep = self.state.fetch("points.plastic_strain")
            used = np.arange(sections.points)[None, :] < sections.point_count[data.section][:, None]
            out["plastic_strain_max"] = np.where(used, ep, -np.inf).max(axis=1)
            out["plastic_strain_mean"] = np.sum(ep * w, axis=1) / w.sum(axis=1)
        if self.cfg.erosion:
            out["eroded"] = eroded_elements(self.state).astype(np.int32)
        if self.cfg.selective_mass:
            out["deformation_mass"] = deformation_mass(self.state, self.model)
        elif self.cfg.mass_scaling:
            out["added_mass"] = added_mass(self.state, self.model)
        return out

    # ------------------------------------------------------------------ recording
    def record(self, key: float, frame: bool) -> None:
        with self.state.reads_cached():
            self._record(key, frame)

    def _record(self, key: float, frame: bool) -> None:
        self.history.probe_rows.append([key] + self.probe_values())
        e = self.energies()
        self.history.energy_rows.append([key] + [e[k] for k in ENERGY_COLUMNS])
        self.history.part_rows.append([key] + self.part_values().ravel().tolist())
        st = self.state.step
        self.history.force_rows.append([key] + st.reaction[None].to_numpy().tolist()
                                       + st.reaction_impulse[None].to_numpy().tolist()
                                       + self.body_values() + self.motion_values() + self.tool_values()
                                       + self.interface_values() + self.joint_values())
        if frame:
            self.write_frame(key)

    def body_state(self) -> list[dict]:
        """Each rigid body's pose, velocities, loads and kinetic energy now (stages/bodies.py)."""
        nb = len(self.model.rigid_bodies)
        if not nb:
            return []
        bd = self.state.bodies
        read = {name: self.state.read(getattr(bd, name), nb) for name in (
            "displacement", "rotation", "velocity", "omega", "angular_momentum", "force", "moment", "kinetic_rotation")}
        out = []
        for i, b in enumerate(self.model.rigid_bodies):
            q = read["rotation"][i]
            half = math.atan2(float(np.linalg.norm(q[1:])), abs(float(q[0])))
            axis = q[1:] / np.linalg.norm(q[1:]) if half > 0.0 else np.zeros(3)
            v = read["velocity"][i]
            out.append({k: read[k][i] for k in read} | {
                "rotation_vector": 2.0 * half * np.sign(q[0] or 1.0) * axis,
                "kinetic": 0.5 * b.total_mass * float(v @ v) + (float(read["kinetic_rotation"][i]) if b.rotates else 0.0)})
        return out

    def body_values(self) -> list[float]:
        """force.csv's body columns (:meth:`body_columns`): a ram along a direction, its
        displacement and force along it (as before 6-DOF bodies); a 6-DOF body, its
        displacement, rotation vector, force, moment about its centre, kinetic energy and
        angular momentum."""
        first, second = [], []
        for b, x in zip(self.model.rigid_bodies, self.body_state()):
            if b.direction is not None:
                d = np.asarray(b.direction)
                first.append(float(x["displacement"] @ d))
                second.append(float(x["force"] @ d))
            else:
                first += [*map(float, x["displacement"]), *map(float, x["rotation_vector"])]
                second += [*map(float, x["force"]), *map(float, x["moment"]), x["kinetic"],
                           *map(float, x["angular_momentum"])]
        return first + second

    def body_columns(self) -> list[str]:
        first, second = [], []
        for b in self.model.rigid_bodies:
            if b.direction is not None:
                first.append(f"{b.name}.displacement")
                second.append(f"{b.name}.force")
            else:
                first += [f"{b.name}.{c}" for c in ("ux", "uy", "uz", "rx", "ry", "rz")]
                second += [f"{b.name}.{c}" for c in ("force_x", "force_y", "force_z", "moment_x", "moment_y",
                                                     "moment_z", "kinetic", "angular_momentum_x",
                                                     "angular_momentum_y", "angular_momentum_z")]
        return first + second

    def body_summary(self) -> list[dict]:
        """summary.json's rigid_bodies block."""
        out = []
        for b, x in zip(self.model.rigid_bodies, self.body_state()):
            out.append({"name": b.name, "mass": b.total_mass, "added_mass": b.added_mass,
                        "center": (b.center + x["displacement"]).tolist(), "inertia": b.inertia.tolist(),
                        "direction": list(b.direction) if b.direction is not None else None,
                        "displacement": x["displacement"].tolist(), "rotation": x["rotation"].tolist(),
                        "rotation_vector": x["rotation_vector"].tolist(), "velocity": x["velocity"].tolist(),
                        "angular_velocity": x["omega"].tolist(), "angular_momentum": x["angular_momentum"].tolist(),
                        "force": x["force"].tolist(), "moment": x["moment"].tolist() if b.rotates else None,
                        "kinetic_energy": x["kinetic"]})
        return out

    def motion_values(self) -> list[float]:
        """force.csv's motion columns (:meth:`motion_columns`): each motion's reaction on each
        of its DOFs (this step's, summed over its nodes) and its work so far."""
        motions = self.model.loading.motions
        if not motions:
            return []
        reaction = self.state.fetch("nodes.motion_reaction")
        work = self.state.fetch("nodes.motion_work")
        nb = len(self.model.rigid_bodies)
        if any(m.body >= 0 for m in motions):       # a body's motions (stages/bodies.py)
            body_reaction = self.state.read(self.state.bodies.motion_reaction, nb)
            body_work = self.state.read(self.state.bodies.motion_work, nb)
        from .scene import DOFS
        out = []
        for m in motions:
            dofs = [DOFS.index(d) for d in m.dofs]
            if m.body >= 0:
                out += [float(body_reaction[m.body, d]) for d in dofs] + [float(body_work[m.body, dofs].sum())]
            else:
                out += [float(reaction[m.nodes, d].sum()) for d in dofs] + [float(work[m.nodes][:, dofs].sum())]
        return out

    def tool_values(self) -> list[float]:
        """force.csv's tool columns (:meth:`tool_columns`): each tool's force on the shell (this
        step's), its contact energy and the part of it booked at the tool's motion."""
        tt = self.model.tools
        if tt is None:
            return []
        k = len(tt.names)
        force = self.state.read(self.state.tools.force, k)
        energy_ = self.state.read(self.state.tools.energy, k)
        work = self.state.read(self.state.tools.work, k)
        return [float(x) for i in range(k) for x in (*force[i], energy_[i], work[i])]

    def interface_values(self) -> list[float]:
        """force.csv's [[contact_pair]] columns (:meth:`interface_columns`): the contact force on
        each interface's slave side, this step's (the step that ends at the row's time), as
        LS-DYNA's RCFORC."""
        laws = self.model.contact
        if laws is None or not laws.pairs:
            return []
        force = self.state.read(self.state.contact.interface_force, len(laws.names))
        return [float(x) for row in force for x in row]

    def interface_columns(self) -> list[str]:
        laws = self.model.contact
        return [] if laws is None else [f"{name}.{c}" for name in laws.names for c in ("force_x", "force_y", "force_z")]

    def tool_columns(self) -> list[str]:
        tt = self.model.tools
        return [] if tt is None else [f"{name}.{c}" for name in tt.names
                                      for c in ("force_x", "force_y", "force_z", "energy", "work")]

    def joint_state(self) -> dict[str, np.ndarray]:
        """The joints' run-time fields now (stages/joints.py)."""
        jt, g = self.model.joints, self.state.joints
        return {name: self.state.read(getattr(g, name), len(jt)) for name in (
            "active", "failure_time", "force_normal", "force_shear", "peak_normal", "peak_shear")}

    def joint_values(self) -> list[float]:
        """force.csv's weld columns (:meth:`joint_columns`): per [[spotweld]] group the largest
        normal (tension > 0) and shear force of this step over its welds intact at its end (0
        when none), and how many have failed."""
        jt = self.model.joints
        if jt is None:
            return []
        from .model.joints import WELD
        x = self.joint_state()
        out = []
        for g in jt.groups:
            if g.kind != WELD:
                continue
            rows = slice(g.first, g.first + g.count)
            intact = x["active"][rows] == 1
            normal = x["force_normal"][rows][intact]
            shear = x["force_shear"][rows][intact]
            out += [float(normal.max()) if len(normal) else 0.0, float(shear.max()) if len(shear) else 0.0,
                    float(np.count_nonzero(x["failure_time"][rows] >= 0.0))]
        return out

    def joint_columns(self) -> list[str]:
        from .model.joints import WELD
        jt = self.model.joints
        return [] if jt is None else [f"{g.name}.{c}" for g in jt.groups if g.kind == WELD
                                      for c in ("force_normal", "force_shear", "failed")]

    def joint_summary(self) -> dict:
        """summary.json's `ties` and `spotwelds` blocks."""
        from .model.joints import TIE
        jt = self.model.joints
        x = self.joint_state()
        ties, welds = [], []
        for g in jt.groups:
            rows = np.arange(g.first, g.first + g.count)
            if g.kind == TIE:
                ties.append({"name": g.name, "slaves": int(g.count), "unfound": len(g.unfound),
                             "unfound_nodes": list(g.unfound[:100]),
                             "released": int(np.count_nonzero(x["active"][rows] == 0))})
                continue
            failed = rows[x["failure_time"][rows] >= 0.0]
            welds.append({
                "name": g.name, "welds": int(g.count), "failed": int(len(failed)),
                "peak_normal": float(x["peak_normal"][rows].max()), "peak_shear": float(x["peak_shear"][rows].max()),
                "failures": [{"pair": [int(jt.masters[j, 0]), int(jt.slave[j])],
                              "time": float(x["failure_time"][j]), "force_normal": float(x["force_normal"][j]),
                              "force_shear": float(x["force_shear"][j])} for j in failed]})
        return {**({"ties": ties} if ties else {}), **({"spotwelds": welds} if welds else {})}

    def motion_columns(self) -> list[str]:
        return [f"{m.name}.{c}" for m in self.model.loading.motions for c in
                [f"reaction_{d}" for d in m.dofs] + ["work"]]

    def write_frame(self, key: float) -> None:
        if self.frames is None:
            self.frames = FrameWriter(self.out_dir, self.model.elements)
        u, rot = self.displacements()
        self.frames.write(key, self.state.fetch("nodes.position"),
                          {"displacement": u, "velocity": self.state.fetch("nodes.grid_velocity"), "rotation": rot},
                          self.element_results())

    def _compile(self) -> None:
        """Compile (or load from the offline cache) the step kernels before the clock of the
        run starts (Stepper.compile).  Newton statics (issue 19) never step: their own
        kernels are compiled by solvers/newton.ShellEquations.compiled instead."""
        if self.scene.solve.kind == "static" and self.scene.solve.solver == "newton":
            return
        self.stepper.compile()
        ti.sync()

    def _compile_readers(self) -> None:
        """The readers of histories, frames and guards are small kernels too: compile them
        before the run clock (reads only), not inside the first history record."""
        self.probe_values()
        self.energies()
        part_energies(self.state, self.model)
        self.displacements()
        self.element_results()
        self.state.step.reaction[None].to_numpy()
        self.state.step.reaction_impulse[None].to_numpy()
        self.state.fetch("nodes.grid_velocity")
        self.body_values()
        self.motion_values()
        self.tool_values()
        self.interface_values()
        self.joint_values()
        self.where()
        ti.sync()

    def where(self) -> str:
        s = self.state.step
        level = f"load factor {s.load_factor[None]:.4g}, " if self.scene.solve.kind == "static" else ""
        return f"{level}t={s.time[None]:.6g}, step {s.step[None]}"

    def element_distortion(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per element of the configuration `positions`: inside out (two or more corner angles
        >= 180 deg about the diagonals' normal: a bow-tie, stages/shell.tangled) and the
        element length L_e of the step rule (assembly.element_length).  A triangle's corners
        cannot fold in its own frame: one configuration shows it inside out only when it has
        collapsed to zero area (the element stage flags one whose normal reversed within a
        step, stages/triangle.py)."""
        elements = self.model.elements
        x = positions[np.where(elements >= 0, elements, elements[:, :1])]     # a triangle's 4th = its 1st
        normal = np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])                 # triangle: (x2-x1) x (x3-x1)
        corner = np.cross(np.roll(x, -1, axis=1) - x, np.roll(x, 1, axis=1) - x)
        inside_out = (np.einsum("mai,mi->ma", corner, normal) <= 0.0).sum(axis=1) >= 2
        area = 0.5 * np.linalg.norm(normal, axis=1)
        triangle = elements[:, 3] < 0
        if triangle.any():
            inside_out = np.where(triangle, area <= 0.0, inside_out)
            return inside_out, element_length(positions, elements, area)
        longest = np.maximum(np.linalg.norm(x[:, 2] - x[:, 0], axis=1), np.linalg.norm(x[:, 3] - x[:, 1], axis=1))
        return inside_out, area / np.maximum(longest, 1e-300)

    def check_status(self) -> None:
        """Raise SimulationError for a failure flagged in-kernel or found here between batches
        (non-finite nodes, elements inside out), then check the hourglass energy.  The kernel's
        flag is refined here: a later stage of the failing step may have overwritten it."""
        code = self.state.step.status[None]
        index = self.state.step.status_index[None]
        now = time.perf_counter()
        if code in FAILURES or self.stepper.batched or now - self._last_geometry_check >= 1.0:
            self._last_geometry_check = now
            x = self.state.fetch("nodes.position")
            speed = np.linalg.norm(self.state.fetch("nodes.grid_velocity"), axis=1)
            bad = ~(np.isfinite(x).all(axis=1) & (speed <= self.state.step.runaway_speed[None]))
            if bad.any():
                code, index = STATUS_NONFINITE, int(np.argmax(bad))
            elif code != STATUS_NONFINITE:
                inside_out, length = self.element_distortion(x)
                if self.cfg.erosion:              # an eroded element may be anything (stages/masses.py)
                    gone = eroded_elements(self.state)
                    inside_out &= ~gone
                    length = np.where(gone, np.inf, length)
                if inside_out.any():
                    code, index = STATUS_INVERTED, int(np.argmax(inside_out))
                elif code == STATUS_DT_COLLAPSE:
                    index = int(np.argmin(length))
        if code == STATUS_BODY_ROTATION:
            index = repr(self.model.rigid_bodies[index].name)
        if code == STATUS_DT_COLLAPSE:
            self.check_body_step()
        if code in FAILURES:
            what, cause = FAILURES[code]
            ratio = energy.balance_ratio(self.energies())
            added = f"{100 * self.added_mass_fraction():.3g}%"
            raise SimulationError(f"{what.format(index=index, ratio=f'{100 * ratio:.3g}%', added=added)} at "
                                  f"{self.where()}: {cause}")
        self.check_hourglass()
        self.check_balance()
        self.check_fields()

    def check_body_step(self) -> None:
        """A collapsed step that a rigid body's turn limit set (stages/bodies.step_limit) names
        the body, not an element."""
        from .stages.timestep import MAX_TURN
        nb = len(self.model.rigid_bodies)
        if not nb or not self.cfg.body_rotation:
            return
        omega = self.state.read(self.state.bodies.omega, nb)
        momentum = self.state.read(self.state.bodies.angular_momentum, nb)
        for i, b in enumerate(self.model.rigid_bodies):
            rate = float(np.linalg.norm(omega[i]))
            if b.turns_freely:
                rate = max(rate, float(np.linalg.norm(momentum[i])) / b.inertia_min)
            if rate > 0.0 and MAX_TURN / rate <= 1.000001 * self.state.step.dt_stable[None]:
                raise SimulationError(f"the time step collapsed below 1e-3 of the first one at rigid body {b.name!r} "
                                      f"at {self.where()}: it turns at {rate:.3g} rad/s (|L| / I_min), and a step "
                                      f"turns it by at most {MAX_TURN} rad: an excessive moment or too small an "
                                      "inertia ([[rigid_body]].inertia)")

    def check_balance(self) -> None:
        """Warn once when |E_err| exceeds energy.WARN_FRACTION x the limit of the absorbed
        energy (the stop itself is in-kernel, energy.EnergyLedger.guard); dynamic runs only."""
        if self.scene.solve.kind != "dynamic":
            return
        limit = self.energy_limit if self.energy_limit > 0.0 else energy.BALANCE_STOP
        ratio = energy.balance_ratio(self.energies())
        if ratio > energy.WARN_FRACTION * limit and not self.balance_warned:
            self.balance_warned = True
            stops = f"the run stops above {100 * self.energy_limit:.3g}%" if self.energy_limit > 0.0 else "no limit set"
            self.warn(f"the energy balance error is {100 * ratio:.2g}% of the energy absorbed at {self.where()} "
                      f"({stops})")

    def check_fields(self) -> None:
        """Warn once when grid nodes of the multi-field grid ran out of velocity fields (more
        layers met there than it keeps; stages/grid.py): the extra layers moved with an
        unrelated one there.  Names the first step it happened in and how many grid nodes."""
        g = self.state.grid
        if not self.cfg.multi_field or self.overflow_warned or g.first_overflow_step[None] < 0:
            return
        self.overflow_warned = True
        nodes = int(g.first_overflow_nodes[None])
        self.warn(f"{nodes} grid node{'s' if nodes != 1 else ''} ran out of velocity fields at "
                  f"t={g.first_overflow_time[None]:.6g}, step {g.first_overflow_step[None]}: more than {MAX_FIELDS} "
                  f"layers met there and the extra ones share the last field with an unrelated layer (they move "
                  f"together there); a smaller [method].cell_size separates them (summary.json grid.field_overflow "
                  "counts the joins)")

    def check_hourglass(self) -> None:
        """Warn once when the zero-energy-mode controls hold more than 10% of E_int (hourglass
        and drilling-spring energy: both are artificial stiffness), stop when > 20%, once the
        energies are meaningful."""
        s = self.state.step
        e_int, e_hg = s.internal_energy[None], s.hourglass_energy[None] + s.drilling_energy[None]
        scale = max(abs(s.external_work[None]), self.initial_kinetic)
        if not (scale > 0.0 and max(e_int, e_hg) > HOURGLASS_ACTIVE * scale):
            return
        ratio = e_hg / e_int if e_int > 0.0 else math.inf
        text = "internal energy" if math.isfinite(ratio) else "internal energy (which is zero)"
        share = f"{100 * ratio:.0f}%" if math.isfinite(ratio) else "all"
        limit = self.hourglass_limit
        if limit > 0.0 and ratio > limit:
            raise SimulationError(
                f"hourglass and drilling energy is {share} of the {text} at {self.where()}: the elements deform in "
                "zero-energy modes; raise [element].hourglass, refine the mesh or spread point loads "
                "(--hourglass-limit sets this limit)")
        warn = limit * HOURGLASS_WARN / HOURGLASS_STOP if limit > 0.0 else HOURGLASS_WARN
        if ratio > warn and not self.hourglass_warned:
            self.hourglass_warned = True
            stops = f"the run stops above {100 * limit:.0f}%" if limit > 0.0 else "no limit set"
            self.warn(f"hourglass and drilling energy is {share} of the internal energy at {self.where()} ({stops})")

    def warn(self, text: str) -> None:
        self.warnings.append(text)
        self.reporter.warn(text)

    def progress(self, text: str) -> None:
        self.reporter.line(text)

    def state_is_finite(self) -> bool:
        return all(np.all(np.isfinite(self.state.fetch(path))) for path in (
            "nodes.position", "nodes.grid_velocity", "nodes.omega", "nodes.rotation", "points.stress"))

    def final_frame(self) -> bool:
        """After an interrupt: write the current state as the last frame if it is finite (never
        a frame with NaN) and not already the last one.  Returns True if written.  Not after a
        failure: the failing state is no result (cli._finish)."""
        key = self.state.step.load_factor[None] if self.scene.solve.kind == "static" else self.state.step.time[None]
        if self.frames is not None and self.frames.entries and self.frames.entries[-1][0] == float(key):
            return False
        if not self.state_is_finite():
            return False
        self.write_frame(key)
        return True

    # ------------------------------------------------------------------ finishing
    def write_tables(self) -> None:
        """probes.csv, energy.csv, force.csv: each is tried even when an earlier one could not
        be written; then the first OutputError is raised."""
        out = self.out_dir
        key = self.history.probe_header[0]
        tables = [("probes.csv", self.history.probe_header, self.history.probe_rows),
                  ("energy.csv", [key, *ENERGY_COLUMNS], self.history.energy_rows),
                  ("force.csv", self.force_header(), self.history.force_rows),
                  ("parts.csv", [key, "part", *PART_COLUMNS, "added_mass"], self.part_table())]
        failed = None
        for name, header, rows in tables:
            try:
                write_csv(out / name, header, rows)
            except OutputError as exc:
                failed = failed or exc
        if failed is not None:
            raise failed

    def force_header(self) -> list[str]:
        return ([self.history.probe_header[0], "support_x", "support_y", "support_z", "support_impulse_x",
                 "support_impulse_y", "support_impulse_z"] + self.body_columns() + self.motion_columns()
                + self.tool_columns() + self.interface_columns() + self.joint_columns())

    def part_added_mass(self) -> np.ndarray:
        """The mass selective mass scaling has added to each part so far (0 for rigid bodies and point masses)."""
        out = np.zeros(len(self.model.parts) + len(self.model.rigid_bodies) + len(self.model.point_masses))
        out[:len(self.model.parts)] = np.bincount(self.model.element.part, weights=added_mass(self.state, self.model),
                                                  minlength=len(self.model.parts))
        return out

    def part_values(self) -> np.ndarray:
        """(parts + bodies + point masses, PART_COLUMNS + added mass): one output point's rows of parts.csv."""
        return np.concatenate([part_energies(self.state, self.model), self.part_added_mass()[:, None]], axis=1)

    def added_mass_fraction(self) -> float:
        """The added mass of selective mass scaling over the shell's physical mass."""
        return float(added_mass(self.state, self.model).sum() / self.model.corner_mass.sum())

    def mass_scaling_summary(self) -> dict:
        """summary.json's mass_scaling block: the kind, target step, elements scaled and mass
        added (none under selective scaling, which reports the mass its deformation modes got,
        the added mass's kinetic energy now and its solve's iterations)."""
        scaled = deformation_mass(self.state, self.model)
        out = {"kind": self.scene.solve.mass_scaling, "target_dt": self.model.parameters.target_dt,
               "target_dt_auto": self.scene.solve.target_dt == "auto",
               "added_mass": float(added_mass(self.state, self.model).sum()),
               "added_mass_percent": 100.0 * self.added_mass_fraction(), "scaled_elements": int((scaled > 0.0).sum())}
        if not self.cfg.selective_mass:
            return {**out, "added_mass_limit_percent": self.scene.solve.added_mass_limit}
        st = self.state.step
        solves = int(st.sms_solves[None])
        return {**out, "deformation_mass_percent": 100.0 * float(scaled.sum() / self.model.corner_mass.sum()),
                "added_kinetic_energy": float(added_kinetic(self.state, self.model).sum()),
                "solve": {"form": self.scene.solve.sms_solve, "solves": solves,
                          "iterations_mean": float(st.sms_iterations[None]) / solves if solves else 0.0,
                          "iterations_max": int(st.sms_iterations_max[None]),
                          "tolerance": self.scene.solve.sms_tolerance,
                          "max_iterations": self.scene.solve.sms_max_iterations}}

    def part_table(self) -> list[list]:
        """parts.csv rows (long format: one row per part and output point), from the history."""
        names = part_names(self.model)
        width = len(PART_COLUMNS) + 1
        return [[row[0], name, *row[1 + i * width:1 + (i + 1) * width]]
                for row in self.history.part_rows for i, name in enumerate(names)]

    def part_summary(self) -> list[dict]:
        """The per-part block of summary.json: each part's material, section, element count,
        thickness range, mass and final energies (energy.part_energies)."""
        energies = part_energies(self.state, self.model)
        element = self.model.element
        density = self.model.materials.rows[self.model.sections.point_material[element.section, 0], COL["density"]]
        mass = density * element.thickness * self.model.area0          # physical (not the statics' scaled) mass
        added = self.part_added_mass()
        gone = eroded_elements(self.state)
        out = []
        for i, p in enumerate(self.model.parts):
            t = element.thickness[p.elements]
            out.append({"name": p.name, "material": p.material, "section": p.section, "elements": int(len(p.elements)),
                        "thickness": [float(t.min()), float(t.max())], "mass": float(mass[p.elements].sum()),
                        **({"eroded_elements": int(gone[p.elements].sum())} if self.cfg.erosion else {}),
                        **({"added_mass": float(added[i])} if self.cfg.mass_scaling else {}),
                        "energies": {k: float(energies[i, j]) for j, k in enumerate(PART_COLUMNS)}})
        for i, b in enumerate(self.model.rigid_bodies):
            out.append({"name": f"rigid_body:{b.name}", "mass": b.added_mass,
                        "energies": {k: float(energies[len(self.model.parts) + i, j]) for j, k in enumerate(PART_COLUMNS)}})
        first = len(self.model.parts) + len(self.model.rigid_bodies)
        for i, p in enumerate(self.model.point_masses):
            out.append({"name": f"point_mass:{p.name}", "mass": p.mass * len(p.nodes), "nodes": int(len(p.nodes)),
                        "energies": {k: float(energies[first + i, j]) for j, k in enumerate(PART_COLUMNS)}})
        return out

    def grid_summary(self) -> dict:
        """The grid's memory (stages/grid.py): slots taken now and in the pool, grid-node
        bytes, collections so far; with the multi-field grid, joins of a full grid node."""
        g = self.state.grid
        per_node = (8 * (4 + 3 * self.cfg.grid_force + 6 * self.cfg.grid_contact)
                    * (MAX_FIELDS if self.cfg.multi_field else 1))
        out = {"slots_used": int(g.slot_count[None]), "slots": int(self.state.grid_slots),
               "bytes": int(self.state.grid_slots * (per_node + 12 * 4 + 4 * (MAX_FIELDS + 1) * self.cfg.multi_field)),
               "collections": int(g.collections[None])}
        if self.cfg.multi_field:
            out["fields"] = MAX_FIELDS
            out["field_overflow"] = int(g.field_overflow[None])
        return out

    def write_results(self, extra: dict | None = None) -> dict:
        """Tables and summary.json (both attempted even if one cannot be written; then the
        first OutputError is raised); returns the summary."""
        out = self.out_dir
        failed = None
        try:
            self.write_tables()
        except OutputError as exc:
            failed = exc
        e = {k: (v if math.isfinite(v) else None) for k, v in self.energies().items()}
        summary = {
            "scene": self.scene.info.name, "source": str(self.scene.source), "method": self.cfg.method,
            "transfer": self.cfg.transfer if self.cfg.method == "mpm" else None,
            "cell_size": self.model.grid.h if self.model.grid else None,
            "elements": len(self.model.elements), "nodes": len(self.model.points), "arch": self.arch,
            **({"arch_requested": self.arch_requested} if self.arch_requested else {}),
            "launch": self.cfg.launch,
            "steps": self.total_steps, "compile_seconds": self.compile_seconds,
            "compile_cpu_seconds": self.compile_cpu_seconds, "run_seconds": self.run_seconds,
            "us_per_element_step": 1e6 * self.run_seconds / max(1, self.total_steps * len(self.model.elements)),
            "run_cpu_seconds": self.run_cpu_seconds,
            "cpu_us_per_element_step": 1e6 * self.run_cpu_seconds / max(1, self.total_steps * len(self.model.elements)),
            "energies": e, "parts": self.part_summary(),
            "mesh_warnings": list(self.mesh.warnings), "warnings": list(self.warnings),
        }
        if extra:
            summary.update(extra)
        if self.state.grid is not None:
            summary["grid"] = self.grid_summary()
        if self.model.loading.motions:
            values = self.motion_values()
            columns = self.motion_columns()
            summary["motions"] = [
                {"name": m.name, "kind": self.scene.motions[k].kind, "dofs": list(m.dofs), "nodes": int(len(m.nodes)),
                 **({"body": self.model.rigid_bodies[m.body].name} if m.body >= 0 else {}),
                 "reaction": {d: values[columns.index(f"{m.name}.reaction_{d}")] for d in m.dofs},
                 "work": values[columns.index(f"{m.name}.work")]} for k, m in enumerate(self.model.loading.motions)]
        if self.model.rigid_bodies:
            summary["rigid_bodies"] = self.body_summary()
        if self.model.tools is not None:
            values, tt = self.tool_values(), self.model.tools
            contacts = self.state.read(self.state.tools.contacts, len(tt.names))
            moves = {0: "fixed", 1: "body", 2: "velocity", 3: "displacement"}
            summary["tools"] = [
                {"name": name, "kind": tt.kinds[i], "motion": moves[int(tt.motion[i])],
                 "force": values[5 * i:5 * i + 3], "energy": values[5 * i + 3], "work": values[5 * i + 4],
                 "nodes_in_contact": int(contacts[i])} for i, name in enumerate(tt.names)]
        if self.cfg.erosion:
            summary["erosion"] = {"eroded_elements": int(eroded_elements(self.state).sum())}
        if self.model.joints is not None:
            summary.update(self.joint_summary())
        if self.cfg.mass_scaling:
            summary["mass_scaling"] = self.mass_scaling_summary()
        if self.state.contact is not None:
            summary["contact"] = {"max_penetration_over_thickness": float(self.state.contact.max_penetration[None]),
                                  "pairs_last_step": int(self.state.contact.pairs[None])}
            laws = self.model.contact
            if laws.pairs:
                force = self.interface_values()
                summary["contact_pairs"] = [
                    {"name": name, "slave": p.slave if p.slave_nodes is None else p.slave_nodes, "master": p.master,
                     "symmetric": p.symmetric, "slave_elements": laws.slave_elements[k],
                     "slave_nodes": laws.slave_nodes[k], "master_elements": laws.master_elements[k],
                     "force": force[3 * k:3 * k + 3]}
                    for k, (name, p) in enumerate(zip(laws.names, self.scene.contact_pairs))]
        stopped = bool(extra and extra.get("error"))
        try:
            if self.scene.crush is not None and self.history.force_rows:
                summary.update(crush_summary(self))
            reference, note = reference_summary(self.scene, self.history.probe_header, self.history.probe_rows)
            if reference is not None:
                summary["reference"] = reference
            if note is not None and note not in self.warnings:
                self.warn(note)
                summary["warnings"].append(note)
        except Exception as exc:   # post-processing of a run cut short must not hide its results
            if not stopped:
                raise
            summary["postprocessing_error"] = f"{type(exc).__name__}: {exc}"
        try:
            write_json(out / "summary.json", summary)
        except OutputError as exc:
            failed = failed or exc
        if failed is not None:
            raise failed
        return summary
