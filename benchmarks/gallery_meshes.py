"""Meshes of the gallery scenes (docs/gallery.md) that no generator of [mesh] makes:
scenes/data/sphere_drop.k, a clamped 200 x 200 mm plate (part 1, 20 x 20 shells) and a 20 mm
square patch 30.5 mm above its centre (part 2, *MAT_RIGID: the 6-DOF body that carries the
sphere; four 0.25 kg *ELEMENT_MASS at its corners).  Units mm, ms, kg, kN, GPa.

    python benchmarks/gallery_meshes.py
"""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def sphere_drop(path: Path) -> None:
    n, size = 20, 10.0
    lines = ["*KEYWORD", "*TITLE", "plate and the ram of a dropped sphere (benchmarks/gallery_meshes.py)",
             "$ units: mm, ms, kg, kN, GPa", "*NODE"]
    ids = {}
    nid = 0
    for j in range(n + 1):
        for i in range(n + 1):
            nid += 1
            ids[i, j] = nid
            lines.append(f"{nid},{-100.0 + i * size},{-100.0 + j * size},0.0")
    ram = []
    for x, y in ((-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)):
        nid += 1
        ram.append(nid)
        lines.append(f"{nid},{x},{y},30.5")
    lines.append("*ELEMENT_SHELL")
    eid = 0
    for j in range(n):
        for i in range(n):
            eid += 1
            lines.append(f"{eid},1,{ids[i, j]},{ids[i + 1, j]},{ids[i + 1, j + 1]},{ids[i, j + 1]}")
    lines.append(f"{eid + 1},2,{ram[0]},{ram[1]},{ram[2]},{ram[3]}")
    edge = sorted(ids[i, j] for (i, j) in ids if i in (0, n) or j in (0, n))
    lines += ["*PART", "plate", "1,1,1", "*PART", "ram", "2,1,2",
              "*SECTION_SHELL", "1,2,0.833,5", "1.0,1.0,1.0,1.0",
              "*MAT_PIECEWISE_LINEAR_PLASTICITY_TITLE", "aluminium", "1,2.7e-6,70.0,0.33,0.15,0.5", "", "", "",
              "*MAT_RIGID", "2,2.7e-6,70.0,0.33", "0.0", "",
              "*ELEMENT_MASS"] + [f"{900 + k},{r},0.25" for k, r in enumerate(ram)]
    lines += ["*SET_NODE_LIST_TITLE", "clamped edges", "1"]
    lines += [",".join(str(e) for e in edge[k:k + 8]) for k in range(0, len(edge), 8)]
    lines += ["*BOUNDARY_SPC_SET", "1,0,1,1,1,1,1,1",
              "*INITIAL_VELOCITY_GENERATION", "2,2,0.0,1.5,0.0,-8.0", "0.0,0.0,30.5,0.0,0.0,1.0",
              "*CONTROL_TERMINATION", "6.0", "*DATABASE_BINARY_D3PLOT", "1.0", "*DATABASE_GLSTAT", "0.05", "*END"]
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    sphere_drop(ROOT / "scenes" / "data" / "sphere_drop.k")
