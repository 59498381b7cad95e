"""Compile-time configuration of the time step, derived once from the Scene and Model.

Every field is a Python constant baked into the kernels (``ti.static``): a scene without
a feature never compiles its code.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .assembly import GridGeometry, Model
from .scene import Scene


@dataclass(frozen=True)
class StepConfig:
    method: str                 # "mpm" | "fem"
    transfer: str               # "apic" | "pic" | "flip"
    flip_blend: float
    static: bool                # dynamic relaxation (method.md 6)
    fire: bool                  # static: FIRE velocity mixing instead of plain kinetic damping
    E: float
    nu: float
    shear_modulus: float
    thickness: float
    shear_factor: float
    zeta: tuple[float, ...]
    zeta_weight: tuple[float, ...]
    hourglass: float
    kirchhoff_w_hourglass: bool  # stages/hourglass.py: w-mode rate less the Kirchhoff field's
    drilling_stiffness: float   # > 0: drilling spring (stages/shell.py); 0: projection (method.md 2.3)
    warping_correction: bool    # BWC curvature of warped quads (stages/warping.py, method.md 3.8)
    wave_speed: float           # plane-stress c_e = sqrt(E / (rho (1 - nu^2)))
    dilatational_speed: float   # c_dil = sqrt((K + 4G/3) / rho), paper eq 38-40
    rotational_frequency: float  # physical rotary inertia: sqrt(12 kappa G / rho) / t, else 0 (timestep.element_limit)
    dt_safety: float
    grid_rule: bool             # include the paper's grid rule in dt (dt_rule = "both")
    length_ref: float           # L_ref for the rotational residual (mean edge)
    grid: GridGeometry | None
    launch: str = "batched"     # "batched" | "threads" | "gpu" (solvers/stepper.py)
    bodies: tuple = ()          # (total mass, added mass, unit direction, first slave, slave count)
    walls: tuple = ()           # (point, unit normal, rigid body index or -1)
    contact: object = None      # scene.Contact or None (no contact kernels compiled)
    contact_thickness: float = 0.0

    @property
    def serial(self) -> bool:
        """One serial kernel for many steps: every scatter is a plain add."""
        return self.launch == "batched"

    @property
    def atomic_scatter(self) -> bool:
        """GPU: scatters to nodes and grid are atomic adds.  On the CPU they are arranged so
        that no two threads write the same place (element loads gathered at the nodes, P2G
        in grid slabs of alternating parity), because an f64 atomic add costs ~13 ns there
        against ~1 ns for a plain one (measured: 36 000 scattered vector adds)."""
        return self.launch == "gpu"

    @property
    def grid_force(self) -> bool:
        """Whether the grid keeps the nodal force apart from the momentum (stages/grid.py):
        FLIP needs v- and v+ separately, statics the grid residual; APIC and PIC dynamics
        scatter p + dt f in one field."""
        return self.transfer == "flip" or self.static

    @property
    def drilling_spring(self) -> bool:
        """Drilling rotation kept and tied to the element spin, instead of projected out."""
        return self.drilling_stiffness > 0.0

    @property
    def has_contact(self) -> bool:
        return self.contact is not None

    @staticmethod
    def from_scene(scene: Scene, model: Model) -> "StepConfig":
        mat, sec = scene.material, scene.section
        G = mat.E / (2.0 * (1.0 + mat.nu))
        K = mat.E / (3.0 * (1.0 - 2.0 * mat.nu))
        return StepConfig(
            method=scene.method.kind, transfer=scene.method.transfer, flip_blend=scene.method.flip_blend,
            static=scene.solve.kind == "static",
            fire=scene.solve.kind == "static" and scene.solve.relaxation == "fire", E=mat.E, nu=mat.nu, shear_modulus=G,
            thickness=sec.thickness, shear_factor=sec.shear_factor,
            zeta=tuple(float(z) for z in model.zeta), zeta_weight=tuple(float(w) for w in model.zeta_weight),
            hourglass=scene.element.hourglass, kirchhoff_w_hourglass=scene.element.w_hourglass == "kirchhoff",
            drilling_stiffness=scene.element.drilling_stiffness if scene.element.drilling == "penalty" else 0.0,
            warping_correction=scene.element.warping == "bwc",
            wave_speed=math.sqrt(mat.E / (mat.density * (1.0 - mat.nu ** 2))),
            dilatational_speed=math.sqrt((K + 4.0 * G / 3.0) / mat.density),
            rotational_frequency=(math.sqrt(12.0 * sec.shear_factor * G / mat.density) / sec.thickness
                                  if scene.solve.rotary_inertia == "physical" else 0.0),
            dt_safety=scene.solve.dt_safety,
            grid_rule=scene.solve.dt_rule == "both" and scene.method.kind == "mpm",
            length_ref=model.mean_edge, grid=model.grid,
            bodies=tuple(_bodies(model)), walls=tuple((w.point, w.normal, w.body) for w in model.walls),
            contact=scene.contact,
            contact_thickness=(scene.contact.thickness or sec.thickness) if scene.contact else 0.0)


def _bodies(model: Model):
    start = 0
    for b in model.rigid_bodies:
        yield (b.total_mass, b.added_mass, b.direction, start, len(b.nodes))
        start += len(b.nodes)
