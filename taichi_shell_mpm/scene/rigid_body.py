"""[[rigid_body]]: nodes moving as one rigid body (or a body of its own mass without nodes, which
walls and tools move with)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..keys import (
    Vec3,
    boolean,
    dof_list,
    identifier,
    inertia,
    key,
    keys_of,
    node_set,
    non_negative,
    nonzero_vec3,
    vec3,
)
from .reader import Reader

MAX_BODIES = 256         # [[rigid_body]] entries of a scene (state.bodies tables; a deck may hold many
#                          *CONSTRAINED_NODAL_RIGID_BODY cards)


@dataclass(frozen=True)
class RigidBody:
    """Nodes moving as one rigid body (stages/bodies.py): six DOFs, or translating along
    `direction` only (the tube's 500 kg ram, method.md 2.5c), carrying an added `mass` and
    `inertia` (about the centre, global axes at t = 0: 3 diagonal entries or xx yy zz xy yz zx)."""
    name: str = key(identifier, "body name (force.csv columns, summary.json)")
    nodes: str | None = key(node_set, default=None, default_text="none (a body without nodes)",
        allowed="a defined node set; no node in two bodies or with a fixed translation; without it `mass` > 0 and "
                "`center` are required",
        doc="slave nodes; a body without nodes is its `mass` and `inertia` alone, moved by the walls and tools "
            "that move with it (LS-DYNA's *RIGIDWALL_PLANAR_MOVING)")
    mass: float = key(non_negative, default=0.0, unit="mass", allowed=">= 0 (> 0 with `mass_from_nodes = false`)",
        doc="added mass (at the centre)")
    direction: Vec3 | None = key(nonzero_vec3, default=None, default_text="none (6 DOFs)",
        doc="translation along this direction only, rotations held (the ram)")
    inertia: tuple[float, ...] = key(
        inertia, default=(), unit="mass·length²", allowed="symmetric positive semi-definite; not with `direction`", default_text="none (0)",
        doc="added inertia tensor about the centre, global axes at t = 0: `[Ixx, Iyy, Izz]` or `[Ixx, Iyy, Izz, "
            "Ixy, Iyz, Izx]` (tensor entries: Ixy = −Σ m x y)")
    center: Vec3 | None = key(
        vec3, default=None, unit="length", allowed="not off the mass centre on a rotating body with some but not all translations fixed", default_text="the slaves' mass centre (their centroid if massless)",
        doc="the point `mass` sits at and `inertia` is about; the centre X_c the body turns about when it is its "
            "mass centre or a pivot (else the mass centre, see above)")
    mass_from_nodes: bool = key(boolean, default=True,
        doc="`false`: the slaves' nodal masses and inertias do not count; `mass` and `inertia` are the body's")
    velocity: Vec3 | None = key(
        vec3, default=None, unit="length/time", default_text="the mean `[[initial]]` velocity of its nodes",
        doc="initial velocity of the centre (projected on the free translations)")
    spin: Vec3 | None = key(
        vec3, default=None, unit="rad/time", allowed="not with `direction`", default_text="`[0, 0, 0]`",
        doc="initial angular velocity (global axes; projected on the free rotations)")
    fixed: tuple[str, ...] = key(
        dof_list(allow_all=False), default=(), allowed="some of `ux uy uz rx ry rz`; not with `direction`",
        doc="held DOFs of the body (global axes): those velocity components stay 0")


def read_rigid_body(r: Reader, path: str, data: Any) -> RigidBody | None:
    mark = len(r.messages)
    v = r.read(path, data, keys_of(RigidBody), RigidBody)
    if v is None:
        return None
    if v.get("direction") is not None:
        for key in ("fixed", "spin", "inertia"):
            if key in data:
                r.error(f"{path}.{key}", "a body with a direction translates along it only (its rotations "
                                         "are held): leave out direction for a 6-DOF body")
    if v.get("mass_from_nodes") is False and "mass" in v and not v["mass"] > 0.0:
        r.error(f"{path}.mass", "must be > 0 with mass_from_nodes = false (it is the body's whole mass)")
    if isinstance(data, dict) and "nodes" not in data:
        if not v.get("mass", 0.0) > 0.0:
            r.error(f"{path}.mass", "a body without nodes needs mass > 0 (it is the body's whole mass)")
        if v.get("center") is None:
            r.error(f"{path}.center", "a body without nodes needs its center")
    return r.build(mark, RigidBody, v)
