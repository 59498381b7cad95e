"""A run of one scene: build (mesh -> model -> fields -> kernels), drive, record, write.

:class:`Simulation` owns one Taichi runtime's worth of state.  Drivers:
:func:`taichi_shell_mpm.solvers.static.run_static` and
:func:`taichi_shell_mpm.solvers.dynamic.run_dynamic`.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import taichi as ti

from .assembly import Model, assemble
from .config import StepConfig
from .mesh import Mesh, build_mesh
from .crush import crush_summary
from .output import FrameWriter, write_csv, write_json
from .reference import compare_with_reference
from .scene import Scene
from .solvers.stepper import Stepper
from .stages.timestep import DT_UNSET, initial_dt
from .stages.material import make_material
from .state import STATUS_TEXT, State

ARCHS = {"cpu": "cpu", "cuda": "cuda", "vulkan": "vulkan"}
BATCHED_MAX_ELEMENTS = 4000     # serial multi-step launches pay off below this on CPU


ENERGY_COLUMNS = ("kinetic", "internal", "hourglass", "external_work", "damped", "wall", "contact",
                  "plastic_work", "balance_error")


class SimulationError(Exception):
    """A run-time failure (instability, non-convergence); message is one line."""


def init_taichi(arch: str = "cpu") -> None:
    ti.init(arch=getattr(ti, ARCHS[arch]), default_fp=ti.f64, default_ip=ti.i32, offline_cache=True,
            log_level=ti.WARN)


@dataclass
class History:
    """Rows recorded at each output point (load step or output time)."""
    probe_header: list[str]
    probe_rows: list[list[float]] = field(default_factory=list)
    energy_rows: list[list[float]] = field(default_factory=list)
    force_rows: list[list[float]] = field(default_factory=list)


class Simulation:
    def __init__(self, scene: Scene, out_dir: Path | None = None, arch: str = "cpu", quiet: bool = False):
        self.scene = scene
        self.arch = arch
        self.quiet = quiet
        self.out_dir = Path(out_dir) if out_dir is not None else Path("outputs") / scene.info.name
        self.mesh: Mesh = build_mesh(scene.mesh)
        self.model: Model = assemble(scene, self.mesh)
        batched = arch == "cpu" and len(self.model.quads) <= BATCHED_MAX_ELEMENTS
        self.cfg = replace(StepConfig.from_scene(scene, self.model), serial=batched)
        material = make_material(scene.material)
        self.state = State(self.model, self.cfg.transfer, material.plastic, scene.contact is not None)
        self.stepper = Stepper(self.state, self.cfg, material, self.model, batched)
        self._initial_geometry()
        t0 = time.perf_counter()
        self.stepper.advance(0)
        ti.sync()
        self.compile_seconds = time.perf_counter() - t0
        self.initial_kinetic = self.kinetic_energy()
        key = "load_factor" if scene.solve.kind == "static" else "time"
        header = [key] + [f"{p.name}.{c}" for p in self.model.probes for c in p.components]
        self.history = History(probe_header=header)
        self.frames: FrameWriter | None = None
        self.total_steps = 0
        self.run_seconds = 0.0

    # ------------------------------------------------------------------ set-up helpers
    def _initial_geometry(self) -> None:
        """State before the first step: nodal normals (sum A e3 for the drilling projection,
        method.md 2.3), initial omega without its drilling part, and the first stable dt."""
        pts, quads = self.model.points, self.model.quads
        x = pts[quads]
        element_normal = 0.5 * np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])     # A e3
        normal = np.zeros_like(pts)
        area = np.zeros(len(pts))
        np.add.at(normal, quads, np.repeat(element_normal[:, None, :], 4, axis=1))
        np.add.at(area, quads, np.repeat(np.linalg.norm(element_normal, axis=1)[:, None], 4, axis=1))
        self.state.normal_sum.from_numpy(normal)
        self.state.area_sum.from_numpy(area)
        unit = normal / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
        w = self.model.omega0
        self.state.omega.from_numpy(w - np.sum(w * unit, axis=1)[:, None] * unit)
        dt = initial_dt(pts, quads, self.model.velocity0, self.cfg)
        for f in (self.state.dt, self.state.dt_stable, self.state.dt_first):
            f[None] = dt
        self.state.dt_next[None] = DT_UNSET

    # ------------------------------------------------------------------ measurements
    def kinetic_energy(self) -> float:
        m, J = self.model.node_mass, self.model.node_inertia
        v = self.state.grid_velocity.to_numpy()
        w = self.state.omega.to_numpy()
        bodies = sum(0.5 * b.added_mass * self.state.body_velocity[i] ** 2
                     for i, b in enumerate(self.model.rigid_bodies))
        return float(0.5 * np.sum(m * np.sum(v * v, axis=1)) + 0.5 * np.sum(J * np.sum(w * w, axis=1)) + bodies)

    def energies(self) -> dict[str, float]:
        s = self.state
        e = {"kinetic": self.kinetic_energy(), "internal": s.internal_energy[None],
             "hourglass": s.hourglass_energy[None], "external_work": s.external_work[None],
             "damped": s.damped_energy[None], "plastic_work": s.plastic_work[None],
             "wall": s.wall_energy[None], "contact": s.contact_energy[None] if s.contact else 0.0}
        e["balance_error"] = (e["kinetic"] + e["internal"] + e["hourglass"] + e["damped"] + e["wall"]
                              + e["contact"] - self.initial_kinetic - e["external_work"])
        return e

    def displacements(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodal displacement (n,3) and rotation vector (n,3) from the orientation quaternion."""
        u = self.state.position.to_numpy() - self.model.points
        q = self.state.rotation.to_numpy()
        s = np.linalg.norm(q[:, 1:], axis=1)
        angle = 2.0 * np.arctan2(s, q[:, 0])
        rot = q[:, 1:] * (angle / np.maximum(s, 1e-300))[:, None]
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
        """Membrane forces N, bending moments M = int z sigma dz (per unit length) and the
        mid-surface von Mises stress of each element (local frame)."""
        t = self.cfg.thickness
        zeta, w = np.array(self.cfg.zeta), np.array(self.cfg.zeta_weight)
        sig = self.state.stress.to_numpy()                       # (m, nk, 5)
        n_res = 0.5 * t * np.einsum("k,mkc->mc", w, sig[:, :, :3])
        m_res = 0.25 * t * t * np.einsum("k,mkc->mc", w * zeta, sig[:, :, :3])
        s = n_res / t
        vm = np.sqrt(np.maximum(s[:, 0] ** 2 - s[:, 0] * s[:, 1] + s[:, 1] ** 2 + 3 * s[:, 2] ** 2, 0.0))
        out = {"membrane_force": n_res, "bending_moment": m_res, "von_mises_mid": vm,
               "thickness": np.full(len(sig), t)}
        if self.state.plastic_strain is not None:
            ep = self.state.plastic_strain.to_numpy()
            out["plastic_strain_max"] = ep.max(axis=1)
            out["plastic_strain_mean"] = ep @ (w / w.sum())
        return out

    # ------------------------------------------------------------------ recording
    def record(self, key: float, frame: bool) -> None:
        self.history.probe_rows.append([key] + self.probe_values())
        e = self.energies()
        self.history.energy_rows.append([key] + [e[k] for k in ENERGY_COLUMNS])
        s = self.state
        self.history.force_rows.append([key] + s.reaction[None].to_numpy().tolist()
                                       + [s.body_displacement[i] for i in range(len(self.model.rigid_bodies))]
                                       + [s.body_force[i] for i in range(len(self.model.rigid_bodies))])
        if frame:
            self.write_frame(key)

    def write_frame(self, key: float) -> None:
        if self.frames is None:
            self.frames = FrameWriter(self.out_dir, self.model.quads)
        u, rot = self.displacements()
        self.frames.write(key, self.state.position.to_numpy(),
                          {"displacement": u, "velocity": self.state.grid_velocity.to_numpy(), "rotation": rot},
                          self.element_results())

    def check_status(self) -> None:
        code = self.state.status[None]
        if code in STATUS_TEXT:
            where = f"t={self.state.time[None]:.6g}, step {self.state.step[None]}"
            raise SimulationError(f"{where}: " + STATUS_TEXT[code].format(index=self.state.status_index[None]))

    def progress(self, text: str) -> None:
        if not self.quiet:
            print(text, flush=True)

    # ------------------------------------------------------------------ finishing
    def write_results(self, extra: dict | None = None) -> dict:
        out = self.out_dir
        out.mkdir(parents=True, exist_ok=True)
        write_csv(out / "probes.csv", self.history.probe_header, self.history.probe_rows)
        key = self.history.probe_header[0]
        write_csv(out / "energy.csv", [key, *ENERGY_COLUMNS], self.history.energy_rows)
        names = [b.name for b in self.model.rigid_bodies]
        write_csv(out / "force.csv", [key, "support_x", "support_y", "support_z"]
                  + [f"{b}.displacement" for b in names] + [f"{b}.force" for b in names], self.history.force_rows)
        e = self.energies()
        summary = {
            "scene": self.scene.info.name, "source": str(self.scene.source), "method": self.cfg.method,
            "transfer": self.cfg.transfer if self.cfg.method == "mpm" else None,
            "cell_size": self.model.grid.h if self.model.grid else None,
            "elements": len(self.model.quads), "nodes": len(self.model.points), "arch": self.arch,
            "launch": "batched" if self.stepper.batched else "parallel",
            "steps": self.total_steps, "compile_seconds": self.compile_seconds, "run_seconds": self.run_seconds,
            "us_per_element_step": 1e6 * self.run_seconds / max(1, self.total_steps * len(self.model.quads)),
            "energies": e, "mesh_warnings": list(self.mesh.warnings),
        }
        if extra:
            summary.update(extra)
        if self.model.rigid_bodies and self.scene.solve.kind == "dynamic":
            summary.update(crush_summary(self))
        if self.scene.reference is not None:
            summary["reference"] = compare_with_reference(self.scene.reference, self.history.probe_header,
                                                          self.history.probe_rows)
        write_json(out / "summary.json", summary)
        return summary
