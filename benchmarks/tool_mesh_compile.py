"""Does a new mesh-tool file recompile the step? (issue 28 item 13)

    python benchmarks/tool_mesh_compile.py 3     # a sphere of 20 * 4^3 = 1280 triangles
    python benchmarks/tool_mesh_compile.py 5     # 20 * 4^5 = 20480 triangles

Runs the plate-and-tools scene of tests/test_tools.py three times, each in a fresh process,
with a cube (12 triangles), an icosphere of 20 * 4^level triangles, and the cube again as the
punch, all on one kernel cache (a new folder, /tmp/tool_mesh_compile/cache, kept between calls):
prints each run's wall seconds and how many files it added to the cache.  Measured
2026-12-03 on 2 cores: cube 232 s (cold), level 3 13.1 s and no new file, cube again 12.1 s;
level 5 (20480 triangles, above the 16384 entries of the smallest size class,
state.CAPACITY_MIN) 224 s and 28 new files.  So a tool mesh recompiles only when its triangle
or bucket count crosses a size class (powers of 4), as a shell mesh does.
"""
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import meshio  # noqa: E402

from benchmarks.compile_once import run  # noqa: E402
from tests.test_tools import _icosphere, cube_surface, plate_mesh, scene_text  # noqa: E402

WORK = Path("/tmp/tool_mesh_compile")


def main(level: int) -> None:
    d = WORK / "scene"
    d.mkdir(parents=True, exist_ok=True)
    plate_mesh(d)
    cube_surface(d)
    meshio.write(d / "ball.stl", meshio.Mesh(*_icosphere(level)))
    cache = WORK / "cache"
    env = dict(os.environ, TAICHI_SHELL_MPM_CACHE=str(cache))

    def files() -> int:
        return sum(1 for f in cache.rglob("*") if f.is_file()) if cache.exists() else 0

    for name, mesh in (("cube", "cube.obj"), (f"sphere level {level}", "ball.stl"), ("cube again", "cube.obj")):
        (d / "s.toml").write_text(scene_text({"punch": f'kind = "mesh"\nfile = "{mesh}"\ncenter = [0, 0, 0.3]'},
                                             end_time=1e-5))
        before, t0 = files(), time.time()
        summary = run(ROOT, str(d / "s.toml"), [], d / "out", env)
        print(f"{name}: {time.time() - t0:.1f} s wall, {summary['compile_seconds']:.1f} s compiling, "
              f"{files() - before} new cache files", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
