"""The MPM grid as Taichi sparse SNodes against the project's hashed grid (issue 20 item 1):
µs per node-step of one P2G / grid update / G2P / clear cycle, memory, compile time:

    python benchmarks/sparse_grid.py                  # the paper's tube, ~1 min on an idle 2-core machine
    python benchmarks/sparse_grid.py --refine 2       # 2x finer mesh and cell (4x the nodes)
    python benchmarks/sparse_grid.py --cache-probe    # does the tree's shape enter the cache key?

The nodes are those of the paper's tube (scenes/square_tube.toml, built by the package's
mesh generator; --refine r: r x the elements along each direction, cell size 2.5 / r mm),
each of unit mass with a velocity that varies over the tube, all translated every step by
a crush: the clamped end (z = 0) held, the rear end (z = 300 mm) moved by h / --cross along
-z per step (and 0.3, 0.2 of that along x, y), the nodes between in proportion to z: the
rear crosses a cell plane every --cross steps (the tube's nodes cross a cell every ~280
steps at 15 m/s, stages/grid.py; the default 20 is 14x more crossings: the hash's lookups
are the part of its cost that grows with them).  The nodes stay inside the scene's box.

Each variant runs in a process of its own (ti.cpu, f64, offline cache off: the first step's
extra time is the compile):

* ``hash``: the project's grid (stages/grid.py, reimplemented compactly): a hash table
  (open addressing, linear probing) maps a grid node's key to a slot of dense storage of
  16 slots per node (GRID_SLOTS_PER_NODE, power-of-4 size class); each node keeps its base
  cell and 8 slots, found again only when its base cell changes (in parallel: which moved;
  serially: slot_of); a collection empties the table when the pool runs dry.  Step: locate,
  P2G (atomic adds), G2P with v = p/m evaluated at the read, clear of the 8 slots of each
  node; one kernel.  It has no box: the box only bounds where nodes may go.
* ``pointer_bitmasked_B`` / ``pointer_dense_B`` (B = 4, 8 cells per block edge): Taichi's
  own sparse MPM layout (taichi_elements: pointer over 128^3-cell top blocks -> pointer over
  B^3-cell blocks -> bitmasked or dense cells), offset to the box's lowest cell.  Step:
  P2G (atomic adds; writing activates the blocks), grid update v = p/m over the active
  cells (struct-for), G2P, in one kernel, then ``deactivate_all()`` of the tree (Python:
  one kernel per sparse level), as Taichi's examples do.  The tree needs a virtual box: the
  scene's grid box (100 x 100 x 320 mm) and the same box 100x larger along each axis
  (--scale), so the box's size enters the tree (and so the kernels' offline cache key).

Per variant: wall µs per node-step (minimum and median over chunks of --chunk steps: the
machine is shared, the minimum is the least disturbed chunk), the process's CPU µs per
node-step (all threads; on a loaded machine it counts the work, not the waiting for a
core), first-step seconds minus
one step (compile), the grid's bytes (hash: table + slots + per-node indices; SNodes: the
root's static pointer array plus every block container allocated, read from Taichi's
allocator counts after the run) and the process's peak RSS.  ``--cache-probe``: the first
call of one kernel on a pointer tree of 3 top blocks, again (loaded from the offline cache),
then of 200 top blocks, again, each in a fresh process on one new cache folder.  The checksum of the gathered
velocities must agree between variants (the same sums up to the order of atomic adds).
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SCENE_LO, SCENE_HI = (-50.0, -50.0, -10.0), (50.0, 50.0, 310.0)   # scenes/square_tube.toml's grid box
TOP = 128                    # cells per top block edge (taichi_elements' grid_block_size)
SLOTS_PER_NODE = 16          # state.GRID_SLOTS_PER_NODE
CAPACITY_MIN = 1 << 16       # state.GRID_CAPACITY_MIN
HASH_PRIMES = (73856093, 19349663, 83492791)
KEY_BITS = 21


def tube_points(refine: int) -> tuple:
    from taichi_shell_mpm.mesh import build_mesh
    from taichi_shell_mpm.scene import load_scene
    scene = load_scene(ROOT / "scenes/square_tube.toml",
                       [f"mesh.n_flat={10 * refine}", f"mesh.n_corner={2 * refine}", f"mesh.n_length={60 * refine}"])
    return build_mesh(scene.mesh).points, 2.5 / refine


def box(scale: float, h: float):
    """The virtual box in cells (lowest cell, cells per axis) of the scene's grid box scaled
    about its centre, one cell of margin for the stencils."""
    lo, n = [], []
    for a, b in zip(SCENE_LO, SCENE_HI):
        c, half = 0.5 * (a + b), 0.5 * (b - a) * scale
        i0, i1 = math.floor((c - half) / h) - 1, math.ceil((c + half) / h) + 2
        lo.append(i0)
        n.append(-(-(i1 - i0) // TOP))
    return lo, n


def rss_peak_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def worker(variant: str, scale: float, refine: int, steps: int, chunk: int, cross: float) -> dict:
    import numpy as np
    import taichi as ti

    points, h = tube_points(refine)
    n = len(points)
    ti.init(arch=ti.cpu, default_fp=ti.f64, offline_cache=False, log_level=ti.WARN)
    x = ti.Vector.field(3, ti.f64, n)
    v = ti.Vector.field(3, ti.f64, n)
    out = ti.Vector.field(3, ti.f64, n)
    x.from_numpy(points)
    v.from_numpy(np.stack([np.sin(points[:, 0]), np.cos(points[:, 1]), 1e-2 * points[:, 2]], axis=1))
    shift = ti.Vector.field(3, ti.f64, n)            # a crush: the rear end crosses a cell every `cross` steps
    shift.from_numpy(np.outer(points[:, 2] / points[:, 2].max(), np.array([0.3, 0.2, -1.0]) * (h / cross)))
    inv_h = 1.0 / h

    @ti.func
    def stencil(c):
        r = x[c] * inv_h
        base = ti.floor(r, ti.i32)
        frac = r - base
        return base, ti.Matrix.rows([1.0 - frac, frac])

    mem = {}
    if variant == "hash":
        cap = CAPACITY_MIN
        while cap < SLOTS_PER_NODE * n:
            cap *= 4
        table_bits = int(math.log2(2 * cap))
        table_key = ti.field(ti.i64, 2 * cap)
        table_slot = ti.field(ti.i32, 2 * cap)
        mass = ti.field(ti.f64)
        mom = ti.Vector.field(3, ti.f64)
        ti.root.dense(ti.i, cap).place(mass, mom)
        node_base = ti.Vector.field(3, ti.i32, n)
        node_slots = ti.field(ti.i32, (n, 8))
        moved = ti.field(ti.i32, n)
        counters = ti.field(ti.i32, 3)           # moved count, slots handed out, collections
        node_base.fill(-(1 << 30))
        mem["grid_bytes"] = 2 * cap * (8 + 4) + cap * 32 + n * (12 + 32 + 4)

        @ti.func
        def slot_of(idx):
            off = 1 << (KEY_BITS - 1)
            k = (((ti.cast(idx[0] + off, ti.i64) << (2 * KEY_BITS)) | (ti.cast(idx[1] + off, ti.i64) << KEY_BITS)
                  | ti.cast(idx[2] + off, ti.i64)) + 1)
            hh = ((ti.cast(idx[0] + off, ti.i64) * HASH_PRIMES[0]) ^ (ti.cast(idx[1] + off, ti.i64) * HASH_PRIMES[1])
                  ^ (ti.cast(idx[2] + off, ti.i64) * HASH_PRIMES[2]))
            mask = (1 << table_bits) - 1
            e = ti.cast(hh & mask, ti.i32)
            slot = -2
            while slot == -2:
                stored = table_key[e]
                if stored == k:
                    slot = table_slot[e]
                elif stored == 0:
                    slot = -1
                    if counters[1] < cap:
                        slot = counters[1]
                        counters[1] = slot + 1
                        table_key[e] = k
                        table_slot[e] = slot
                else:
                    e = (e + 1) & mask
            return slot

        @ti.func
        def look_up(c):
            ok = True
            for q in range(8):
                s = slot_of(node_base[c] + ti.Vector([q >> 2, (q >> 1) & 1, q & 1]))
                node_slots[c, q] = s
                if s < 0:
                    ok = False
            return ok

        @ti.kernel
        def step():
            counters[0] = 0
            for c in range(n):                                   # locate (parallel)
                base = ti.floor(x[c] * inv_h, ti.i32)
                if (base != node_base[c]).any():
                    node_base[c] = base
                    moved[ti.atomic_add(counters[0], 1)] = c
            dry = 0
            ti.loop_config(serialize=True)
            for i in range(counters[0]):                         # slots of the moved nodes (serial)
                if dry == 0:                                     # noqa: SIM102 (a kernel's `and` evaluates both)
                    if not look_up(moved[i]):
                        dry = 1
            if dry == 1:                                         # collection
                counters[2] += 1
                for e in range(2 * cap):
                    table_key[e] = 0
                counters[1] = 0
                ti.loop_config(serialize=True)
                for c in range(n):
                    look_up(c)
            for c in range(n):                                   # P2G
                _b, w = stencil(c)
                for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
                    g = node_slots[c, 4 * i + 2 * j + k]
                    wt = w[i, 0] * w[j, 1] * w[k, 2]
                    mass[g] += wt
                    mom[g] += wt * v[c]
            for c in range(n):                                   # grid update at the read, G2P
                _b, w = stencil(c)
                vg = ti.Vector([0.0, 0.0, 0.0])
                for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
                    g = node_slots[c, 4 * i + 2 * j + k]
                    if mass[g] > 1e-12:
                        vg += (w[i, 0] * w[j, 1] * w[k, 2] / mass[g]) * mom[g]
                out[c] = vg
            for c in range(n):                                   # clear the 8 slots, move
                for q in range(8):
                    g = node_slots[c, q]
                    mass[g] = 0.0
                    mom[g] = ti.Vector([0.0, 0.0, 0.0])
                x[c] += shift[c]

        def run_step():
            step()

        def finish():
            mem["collections"] = int(counters[2])
    else:
        layout, block = variant.rsplit("_", 1)
        block = int(block)
        lo, n_top = box(scale, h)
        mass = ti.field(ti.f64)
        mom = ti.Vector.field(3, ti.f64)
        top = ti.root.pointer(ti.ijk, n_top)
        mid = top.pointer(ti.ijk, TOP // block)
        leaf = mid.bitmasked(ti.ijk, block) if layout == "pointer_bitmasked" else mid.dense(ti.ijk, block)
        leaf.place(mass, mom, offset=tuple(lo))

        @ti.kernel
        def step():
            for c in range(n):                                   # P2G (activates)
                base, w = stencil(c)
                for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
                    wt = w[i, 0] * w[j, 1] * w[k, 2]
                    mass[base + ti.Vector([i, j, k])] += wt
                    mom[base + ti.Vector([i, j, k])] += wt * v[c]
            for I in ti.grouped(mass):                           # grid update over active cells
                if mass[I] > 1e-12:
                    mom[I] /= mass[I]
            for c in range(n):                                   # G2P, move
                base, w = stencil(c)
                vg = ti.Vector([0.0, 0.0, 0.0])
                for i, j, k in ti.static(ti.ndrange(2, 2, 2)):
                    I = base + ti.Vector([i, j, k])
                    if mass[I] > 1e-12:
                        vg += w[i, 0] * w[j, 1] * w[k, 2] * mom[I]
                out[c] = vg
                x[c] += shift[c]

        def run_step():
            step()
            top.deactivate_all()

        def finish():
            # bytes held: the root's cell (the top pointer array) plus every allocated cell of
            # each pointer level (the allocator recycles deactivated cells: the count is the peak)
            held = top.parent().root._cell_size_bytes                # the top pointer array (static)
            held += top._num_dynamically_allocated * top._cell_size_bytes
            held += mid._num_dynamically_allocated * mid._cell_size_bytes
            mem["grid_bytes"] = held
            mem["blocks_allocated"] = mid._num_dynamically_allocated
            mem["top_allocated"] = top._num_dynamically_allocated

    t0 = time.perf_counter()
    run_step()
    ti.sync()
    first = time.perf_counter() - t0
    per, cpu = [], []
    for _ in range(max(1, steps // chunk)):
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(chunk):
            run_step()
        ti.sync()
        per.append((time.perf_counter() - t0) / chunk)
        cpu.append((time.process_time() - c0) / chunk)
    finish()
    return {"variant": variant, "scale": scale, "nodes": n, "h": h,
            "us_min": 1e6 * min(per) / n, "us_median": 1e6 * statistics.median(per) / n,
            "cpu_us_median": 1e6 * statistics.median(cpu) / n,
            "compile_s": first - min(per), "checksum": float(out.to_numpy().sum()),
            "rss_peak_MB": rss_peak_mb(), **mem}


def cache_probe_worker(n_top: int, cache: str) -> float:
    """First call of one P2G-like kernel on a pointer tree of n_top top blocks along z, with
    the offline cache in `cache`: whether the tree's shape is part of the cache key."""
    import taichi as ti
    ti.init(arch=ti.cpu, default_fp=ti.f64, offline_cache=True, offline_cache_file_path=cache, log_level=ti.WARN)
    m = ti.field(ti.f64)
    ti.root.pointer(ti.ijk, (1, 1, n_top)).pointer(ti.ijk, 16).dense(ti.ijk, 8).place(m)
    x = ti.Vector.field(3, ti.f64, 1000)

    @ti.kernel
    def scatter():
        for c in range(1000):
            for i, j, k in ti.static(ti.ndrange(4, 4, 4)):
                m[ti.floor(x[c] + ti.Vector([i, j, k]), ti.i32)] += 1.0 + ti.sin(x[c][0] * i) * ti.cos(x[c][1] * j)

    t0 = time.perf_counter()
    scatter()
    ti.sync()
    return time.perf_counter() - t0


def cache_probe() -> None:
    """Each in a fresh process on one new cache folder: 3 top blocks, again, 200, again."""
    import tempfile
    with tempfile.TemporaryDirectory() as cache:
        for n_top in (3, 3, 200, 200):
            proc = subprocess.run([sys.executable, __file__, "--probe-worker", str(n_top), cache],
                                  capture_output=True, text=True, check=True)
            print(f"pointer tree of {n_top:3d} top blocks: first call {float(proc.stdout.split()[-1]):.2f} s")


VARIANTS = ("hash", "pointer_bitmasked_4", "pointer_bitmasked_8", "pointer_dense_4", "pointer_dense_8")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--refine", type=int, default=1, help="mesh and cell refinement of the paper's tube")
    p.add_argument("--steps", type=int, default=300, help="timed steps per variant")
    p.add_argument("--chunk", type=int, default=25, help="steps per timed chunk")
    p.add_argument("--cross", type=float, default=20.0, help="steps per cell crossing along z")
    p.add_argument("--scale", type=float, default=100.0, help="the large box: the scene's box times this per axis")
    p.add_argument("--rounds", type=int, default=2, help="every variant once per round (interleaved)")
    p.add_argument("--variant", action="append", choices=VARIANTS, default=[])
    p.add_argument("--cache-probe", action="store_true",
                   help="instead: whether the SNode tree's shape enters the offline cache key")
    p.add_argument("--worker", nargs=2, metavar=("VARIANT", "SCALE"), help=argparse.SUPPRESS)
    p.add_argument("--probe-worker", nargs=2, metavar=("N_TOP", "CACHE"), help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.probe_worker:
        print(cache_probe_worker(int(a.probe_worker[0]), a.probe_worker[1]))
        return 0
    if a.cache_probe:
        cache_probe()
        return 0
    if a.worker:
        print(json.dumps(worker(a.worker[0], float(a.worker[1]), a.refine, a.steps, a.chunk, a.cross)))
        return 0
    runs, failed = [], 0
    plan = [(v, scale) for v in a.variant or VARIANTS for scale in ((1.0,) if v == "hash" else (1.0, a.scale))]
    for _round in range(a.rounds):
        for variant, scale in plan:
            cmd = [sys.executable, __file__, "--worker", variant, str(scale), "--refine", str(a.refine),
                   "--steps", str(a.steps), "--chunk", str(a.chunk), "--cross", str(a.cross)]
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                print(f"{variant} x{scale:g} failed:\n{proc.stderr[-3000:]}", file=sys.stderr)
                failed += 1
                continue
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            runs.append(r)
            print(f"{_label(r):28s} {r['us_min']:7.3f} µs/node-step (median {r['us_median']:.3f})  "
                  f"compile {r['compile_s']:5.2f} s  checksum {r['checksum']:.12g}", flush=True)
    if not runs:
        return 1
    print(f"\n{runs[0]['nodes']} nodes, h = {runs[0]['h']:g} mm, the rear crosses a cell plane every {a.cross:g} "
          f"steps; {a.rounds} rounds of {a.steps} steps; minimum over rounds of each run's least-disturbed "
          f"chunk, median over rounds of the runs' median chunks\n")
    print("| grid | µs / node-step (min) | (median) | CPU µs / node-step (median) | compile s (median) | grid MB "
          "| peak RSS MB |")
    print("|---|---|---|---|---|---|---|")
    for variant, scale in plan:
        rs = [r for r in runs if r["variant"] == variant and r["scale"] == scale]
        if rs:
            print(f"| {_label(rs[0])} | {min(r['us_min'] for r in rs):.3f} "
                  f"| {statistics.median(r['us_median'] for r in rs):.3f} "
                  f"| {statistics.median(r['cpu_us_median'] for r in rs):.3f} "
                  f"| {statistics.median(r['compile_s'] for r in rs):.2f} "
                  f"| {max(r['grid_bytes'] for r in rs) / 2**20:.2f} | {max(r['rss_peak_MB'] for r in rs):.0f} |")
    ref = runs[0]["checksum"]
    bad = [r for r in runs if abs(r["checksum"] - ref) > 1e-9 * max(1.0, abs(ref))]
    if bad:
        print("checksums differ: " + ", ".join(_label(r) for r in bad))
    return 1 if bad or failed else 0


def _label(r: dict) -> str:
    return "hash (no box)" if r["variant"] == "hash" else f"{r['variant']}, box x{r['scale']:g}"

if __name__ == "__main__":
    sys.exit(main())
