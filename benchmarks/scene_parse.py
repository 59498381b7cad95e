"""Time to parse a scene (load_scene: TOML -> validated frozen dataclasses) in two checkouts,
alternated in one sitting (issue 30: the scene schema must keep the parser's speed):

    python benchmarks/scene_parse.py --tree ../before --tree . --repeats 5

Cases: scenes/square_tube.toml, and a scene whose mesh is a generated LS-DYNA deck of
316 x 316 = 99 856 shells (its parse checks the file; reading the deck is mesh assembly,
timed apart as "deck read" for scale).  Each case is parsed `--number` times per run; each
run is a fresh process; prints the median and the minimum per parse over the runs and B/A.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
N_SIDE = 316

TIMER = r"""
import json, sys, time
from pathlib import Path
from taichi_shell_mpm.scene import load_scene
out = {}
for name, path, number in json.loads(sys.argv[1]):
    load_scene(path)
    start = time.perf_counter()
    for _ in range(number):
        load_scene(path)
    out[name] = (time.perf_counter() - start) / number
deck = json.loads(sys.argv[2])
from taichi_shell_mpm.dyna import read_deck
start = time.perf_counter()
read_deck(Path(deck))
out["deck read"] = time.perf_counter() - start
print(json.dumps(out))
"""


def write_deck(folder: Path) -> tuple[Path, Path]:
    """A flat N_SIDE x N_SIDE deck (one part, elastic) and the scene that names it."""
    n = N_SIDE + 1
    lines = ["*KEYWORD", "*NODE"]
    lines += [f"{j * n + i + 1:8d}{i * 1.0:16.6f}{j * 1.0:16.6f}{0.0:16.6f}" for j in range(n) for i in range(n)]
    lines.append("*ELEMENT_SHELL")
    for j in range(N_SIDE):
        for i in range(N_SIDE):
            a = j * n + i + 1
            lines.append(f"{j * N_SIDE + i + 1:8d}{1:8d}{a:8d}{a + 1:8d}{a + n + 1:8d}{a + n:8d}")
    lines += ["*PART", "plate", f"{1:10d}{1:10d}{1:10d}", "*SECTION_SHELL", f"{1:10d}{2:10d}",
              f"{0.01:10.4f}{0.01:10.4f}{0.01:10.4f}{0.01:10.4f}", "*MAT_ELASTIC",
              f"{1:10d}{7.85e-6:10.3e}{200.0:10.1f}{0.3:10.2f}", "*END"]
    deck = folder / "plate.k"
    deck.write_text("\n".join(lines) + "\n")
    scene = folder / "deck.toml"
    scene.write_text('[scene]\nname = "deck"\nunits = "kN-mm-ms-kg"\n[mesh]\nkind = "file"\npath = "plate.k"\n'
                     '[solve]\nkind = "dynamic"\nend_time = 1.0\n')
    return deck, scene


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tree", type=Path, action="append", default=[])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--number", type=int, default=200, help="parses per case and run")
    args = p.parse_args()
    trees = (args.tree + [ROOT, ROOT])[:2] if args.tree else [ROOT, ROOT]
    with tempfile.TemporaryDirectory() as tmp:
        deck, deck_scene = write_deck(Path(tmp))
        cases = [("tube", str(ROOT / "scenes" / "square_tube.toml"), args.number),
                 ("deck scene", str(deck_scene), args.number)]
        times: dict[int, dict[str, list[float]]] = {0: {}, 1: {}}
        for r in range(args.repeats):
            for k, tree in enumerate(trees):
                env = dict(os.environ, PYTHONPATH=str(tree.resolve()))
                proc = subprocess.run([sys.executable, "-c", TIMER, json.dumps(cases), json.dumps(str(deck))],
                                      env=env, capture_output=True, text=True, cwd=tmp)
                if proc.returncode:
                    raise SystemExit(proc.stderr[-2000:])
                for name, t in json.loads(proc.stdout).items():
                    times[k].setdefault(name, []).append(t)
                print(f"run {r + 1} {'AB'[k]}: " + ", ".join(f"{n} {t * 1e3:.3f} ms" for n, t in
                                                            json.loads(proc.stdout).items()), flush=True)
    print(f"\n{'case':12s} {'A median ms':>12s} {'B median ms':>12s} {'B/A median':>10s} {'B/A min':>8s}")
    for name in times[0]:
        a, b = times[0][name], times[1][name]
        print(f"{name:12s} {statistics.median(a) * 1e3:12.3f} {statistics.median(b) * 1e3:12.3f} "
              f"{statistics.median(b) / statistics.median(a):10.3f} {min(b) / min(a):8.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
