"""Rigid tools ([[tool]], docs/scenes.md): the host side.  The scene's tools as the step's
tables (stages/tools.py reads them): kind, pose, size, penalty and friction coefficients,
how each moves; the surface meshes' triangles and bucket grids.  numpy only.

Pose.  Every tool has an origin (its ``center``) and a frame, the rows e1, e2, e3 of an
orthonormal matrix, and three numbers of size, each kind's own (tool_kinds/<kind>.py: a
plane's and a rectangle's e3 is the normal, a cylinder's its axis; a sphere's and a mesh's
frame is the identity).  The step works in the tool's frame (q = F (x - c)), so a tool that
turns with a rigid body only changes F (stages/tools.RigidTools.pose).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..tool_kinds import KINDS

TOOL_KINDS = tuple(KINDS)
FIXED, BODY, VELOCITY, DISPLACEMENT = range(4)      # how a tool moves (state.tools.motion)
MAX_TOOLS = 8


@dataclass(frozen=True)
class ToolTable:
    """The tools of a scene as the step's tables (state.tools)."""
    names: tuple[str, ...]
    kinds: tuple[str, ...]          # TOOL_KINDS entries, one per tool
    kind: np.ndarray                # (k,) index into TOOL_KINDS
    motion: np.ndarray              # (k,) FIXED | BODY | VELOCITY | DISPLACEMENT
    body: np.ndarray                # (k,) rigid body index (BODY), else -1
    curve: np.ndarray               # (k,) curve index of VELOCITY / DISPLACEMENT, -1: constant 1
    origin: np.ndarray              # (k, 3) centre at t = 0
    frame: np.ndarray               # (k, 3, 3) rows e1, e2, e3
    size: np.ndarray                # (k, 3) rectangle: half sides; cylinder: R, half length; sphere: R
    value: np.ndarray               # (k, 3) the velocity or displacement times the curve
    coefficients: np.ndarray        # (k, 3) stiffness alpha, damping fraction, friction mu
    # surface meshes, all tools' one after the other (tool frame)
    tri_first: np.ndarray           # (k,) first triangle
    triangles: np.ndarray           # (t, 3, 3) vertices of each triangle
    tri_normal: np.ndarray          # (t, 3) unit facet normals (corner order, right hand)
    grid_lo: np.ndarray             # (k, 3)
    grid_h: np.ndarray              # (k,)
    grid_dims: np.ndarray           # (k, 3)
    bucket_first: np.ndarray        # (k,) first bucket of the tool in bucket_start
    bucket_start: np.ndarray        # (b + 1,) CSR bucket -> bucket_items
    bucket_items: np.ndarray        # global triangle indices
    reach: float                    # capture distance of the mesh search
    speed0: np.ndarray              # (k,) a bound of the speed of the tool's points at t = 0 (first_step_limit)
    bound: np.ndarray               # (k,) radius of a ball about the centre holding the tool (plane: inf)

    @property
    def prescribed(self) -> bool:
        """Some tool moves by a velocity or displacement curve (config.Features.loads)."""
        return bool(np.any((self.motion == VELOCITY) | (self.motion == DISPLACEMENT)))


def build_tools(tools, bodies, curves: dict, reach: float, cell: float | None = None) -> ToolTable:
    """The ToolTable of the scene's [[tool]] entries (scene.Tool); `bodies`: the
    assembly.RigidBodySpec list, `curves`: the scene's curves by name; `reach`: how far behind
    a mesh's surface a node is still caught (the thickest shell's thickness)."""
    from ..curves import evaluate
    body_names, curve_names = [b.name for b in bodies], list(curves)
    k = len(tools)
    kind_index = np.array([TOOL_KINDS.index(t.kind) for t in tools], np.int32)
    motion = np.full(k, FIXED, np.int32)
    body = np.full(k, -1, np.int32)
    curve = np.full(k, -1, np.int32)
    origin, frame = np.zeros((k, 3)), np.tile(np.eye(3), (k, 1, 1))
    size, value, coefficients = np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3))
    tri_first = np.zeros(k, np.int32)
    speed0, bound = np.zeros(k), np.full(k, np.inf)
    grid_lo, grid_h, grid_dims = np.zeros((k, 3)), np.ones(k), np.ones((k, 3), np.int32)
    bucket_first = np.zeros(k, np.int32)
    triangles, normals, starts, items = [np.zeros((0, 3, 3))], [np.zeros((0, 3))], [], []
    n_tri = n_buckets = 0
    for i, t in enumerate(tools):
        origin[i] = t.center
        coefficients[i] = (t.stiffness, t.damping, t.friction)
        if t.moves_with is not None:
            motion[i], body[i] = BODY, body_names.index(t.moves_with)
        elif t.velocity is not None:
            motion[i], value[i] = VELOCITY, t.velocity
            speed0[i] = np.linalg.norm(t.velocity) * abs(evaluate(curves[t.curve], 0.0) if t.curve else 1.0)
        elif t.displacement is not None:
            motion[i], value[i] = DISPLACEMENT, t.displacement
        if t.curve is not None:
            curve[i] = curve_names.index(t.curve)
        kind = KINDS[t.kind]
        if hasattr(kind, "surface"):           # a triangulated surface: its triangles and buckets
            x, unit_normals, (lo, h, dims, start, listed), bound[i] = kind.surface(t, reach, cell)
            tri_first[i], grid_lo[i], grid_h[i], grid_dims[i] = n_tri, lo, h, dims
            bucket_first[i] = n_buckets
            triangles.append(x)
            normals.append(unit_normals)
            starts.append(start[:-1] + (len(np.concatenate(items)) if items else 0))
            items.append(listed + n_tri)
            n_tri += len(x)
            n_buckets += len(start) - 1
        else:
            frame[i], size[i], bound[i] = kind.shape(t)
        if motion[i] == BODY:        # V + |omega| (the centre's arm + the tool's size; a plane's: its centre's)
            b = bodies[body[i]]
            arm = np.linalg.norm(np.asarray(t.center) - b.center) + (bound[i] if np.isfinite(bound[i]) else 0.0)
            speed0[i] = np.linalg.norm(b.velocity0) + np.linalg.norm(b.spin0) * arm
    total = sum(len(a) for a in items)
    bucket_start = np.concatenate(starts + [np.array([total])]).astype(np.int32) if starts else np.zeros(1, np.int32)
    return ToolTable(
        names=tuple(t.name for t in tools), kinds=tuple(t.kind for t in tools), kind=kind_index, motion=motion,
        body=body, curve=curve, origin=origin, frame=frame, size=size, value=value, coefficients=coefficients,
        tri_first=tri_first, triangles=np.concatenate(triangles), tri_normal=np.concatenate(normals),
        grid_lo=grid_lo, grid_h=grid_h, grid_dims=grid_dims, bucket_first=bucket_first, bucket_start=bucket_start,
        bucket_items=np.concatenate(items).astype(np.int32) if items else np.zeros(0, np.int32), reach=reach, speed0=speed0, bound=bound)


def first_step_limit(table: ToolTable, points: np.ndarray, thickness: np.ndarray, velocity: np.ndarray,
                     node_body: np.ndarray, step: np.ndarray) -> float:
    """The tools' step limit (stages/tools.py, Step limit) at t = 0, before the kernel has
    measured a closing speed: dt <= (step_k h + max(D - h/2, 0)) / (speed0_k + |v|) over nodes
    and tools (step_k: timestep.contact_step of the tool's stiffness), with D a lower bound of
    the distance (a plane's |d|, else the distance to the ball of radius `bound`) and the
    relative speed for the closing one, so a tool that starts near the shell and fast does not
    jump past it in the first step.  A displacement-driven tool counts as at rest (its curve
    starts at 0)."""
    limit = np.inf
    for k in range(len(table.names)):
        own = node_body == table.body[k] if table.motion[k] == BODY else np.zeros(len(points), bool)
        r = points[~own] - table.origin[k]
        if np.isfinite(table.bound[k]):
            distance = np.maximum(np.linalg.norm(r, axis=1) - table.bound[k], 0.0)
        else:
            distance = np.abs(r @ table.frame[k][2])
        h = thickness[~own]
        speed = table.speed0[k] + np.linalg.norm(velocity[~own], axis=1)
        moving = speed > 0.0
        if np.any(moving):
            room = step[k] * h + np.maximum(distance - 0.5 * h, 0.0)
            limit = min(limit, float(np.min(room[moving] / speed[moving])))
    return limit
