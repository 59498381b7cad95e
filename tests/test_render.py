"""`render`: pictures and plots of a run's output directory (render.py, cli.py).

One small cantilever run (4x1 elements, 2 load steps) through the public CLI, rendered
through the public CLI; the PNGs are read back with VTK and must be real pictures.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from taichi_shell_mpm.cli import main
from taichi_shell_mpm.render import Run, choose_frames, choose_sheet, nearest_frames, sheet_times

from .conftest import ROOT

MIN_PNG_BYTES = 5000


def cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "taichi_shell_mpm", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


def read_png(path: Path) -> np.ndarray:
    """(height, width, channels) pixels of a PNG, read with VTK."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader
    reader = vtkPNGReader()
    assert reader.CanReadFile(str(path)), path
    reader.SetFileName(str(path))
    reader.Update()
    image = reader.GetOutput()
    w, h, _ = image.GetDimensions()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars())
    return pixels.reshape(h, w, -1)


def assert_picture(path: Path, min_size=(400, 300)) -> np.ndarray:
    assert path.is_file(), path
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > MIN_PNG_BYTES, (path, path.stat().st_size)
    img = read_png(path)
    assert img.shape[1] >= min_size[0] and img.shape[0] >= min_size[1], img.shape
    rgb = img[..., :3].reshape(-1, 3).astype(np.int64)
    # white background plus a good share of drawn (non-white) pixels in several colours
    assert (rgb == 255).all(axis=1).mean() > 0.3
    assert (rgb < 200).any(axis=1).mean() > 0.005
    assert len(np.unique(rgb @ [65536, 256, 1])) > 20
    return img


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("render") / "cantilever"
    proc = cli("run", str(ROOT / "scenes" / "cantilever.toml"), "--out", str(out), "--quiet",
               "--set", "mesh.nx=4", "--set", "solve.load_steps=2")
    assert proc.returncode == 0, proc.stderr[-2000:]
    return out


@pytest.fixture(scope="module")
def rendered(run_dir) -> tuple[Path, subprocess.CompletedProcess]:
    return run_dir, cli("render", str(run_dir))


def test_render_writes_pictures(rendered):
    run_dir, proc = rendered
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    pictures = run_dir / "pictures"
    names = {"frame_00000.png", "frame_00001.png", "sheet.png", "energy.png",
             "load_displacement.png"}
    assert {p.name for p in pictures.glob("*.png")} == names
    for name in sorted(names):
        assert f"wrote {pictures / name}" in proc.stdout
        assert_picture(pictures / name)
    # frames at load factors 0.5 and 1.0 share the camera: the clamped end (which does
    # not move) is drawn at the same pixels, so the two pictures differ only partly
    a, b = (read_png(pictures / f"frame_0000{i}.png")[..., :3] for i in (0, 1))
    assert a.shape == b.shape
    differ = (a != b).any(axis=2).mean()
    assert 0.0 < differ < 0.5
    # the sheet holds the 2 distinct frames nearest to 1/3, 2/3, 1 plus a scalar-bar column
    sheet = read_png(pictures / "sheet.png")
    assert sheet.shape[1] > 2 * sheet.shape[0] * 0.8


def test_render_selected_frames_and_field(run_dir, capsys):
    assert main(["render", str(run_dir), "--frames", "last", "--field", "rotation:z",
                 "--sheet", "none"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.rsplit("/", 1)[-1] for ln in lines] == ["frame_00001.png", "energy.png",
                                                        "load_displacement.png"]


def test_render_missing_directory(tmp_path, capsys):
    assert main(["render", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert err == f"error: {tmp_path / 'nope'}: no such output directory\n"
    assert main(["render", str(tmp_path)]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_render_missing_directory_cli(tmp_path):
    proc = cli("render", str(tmp_path / "nope"), timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("error: ")
    assert proc.stdout == ""


@pytest.mark.parametrize("option, value, message", [
    ("--frames", "abc", "--frames 'abc': expected"),
    ("--sheet", "1,x", "--sheet '1,x': expected"),
    ("--field", "nope", "--field 'nope': no such array in the frames; have bending_moment"),
    ("--field", "displacement:7", "component must be 0..2 or x, y, z"),
])
def test_render_bad_options(run_dir, capsys, option, value, message):
    assert main(["render", str(run_dir), option, value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def fake_run(keys, key="time") -> Run:
    return Run(out_dir=Path("."), name="x", key=key, keys=np.asarray(keys, dtype=float),
               files=[Path(f"frame_{i:05d}.vtu") for i in range(len(keys))])


def test_frame_choice():
    dyn = fake_run(np.arange(0.0, 15.01, 0.5))
    assert sheet_times(dyn) == [5.0, 10.0, 15.0]
    assert choose_sheet(dyn, None) == [10, 20, 30]
    assert choose_frames(dyn, "all") == list(range(31))
    assert choose_frames(dyn, "LAST") == [30]
    assert choose_frames(dyn, "none") == []
    assert choose_frames(dyn, "7.4, 0.1,7.6") == [0, 15]
    assert choose_sheet(dyn, "none") == []
    short = fake_run([0.0, 1.0, 2.0, 3.0])
    assert sheet_times(short) == [1.0, 2.0, 3.0]
    static = fake_run(np.linspace(0.05, 1.0, 20), key="load_factor")
    np.testing.assert_allclose(sheet_times(static), [1 / 3, 2 / 3, 1.0])
    assert choose_sheet(static, None) == [6, 12, 19]
    # a static run to load factor 15 still gets thirds, not 5/10/15
    assert choose_sheet(fake_run([5.0, 10.0, 15.0], key="load_factor"), None) == [0, 1, 2]
    assert nearest_frames(np.array([0.0, 1.0]), [0.9, 1.0, 0.2]) == [1, 0]


DYNAMIC_PLATE = """
[scene]
name = "flap"
units = "consistent"
[mesh]
kind = "plate"
lx = 1.0
ly = 1.0
nx = 2
ny = 2
[material]
E = 1e4
nu = 0.3
density = 1.0
model = "j2"
yield_stress = 50.0
[section]
thickness = 0.05
[method]
kind = "fem"
[nodesets.edge]
plane = {point = [0, 0, 0], normal = [1, 0, 0]}
[[boundary]]
nodes = "edge"
fix = "all"
[[initial]]
velocity = [0, 0, 0.1]
[solve]
kind = "dynamic"
end_time = 0.3
[output]
times = [0.1, 0.2]
"""


def test_render_a_dynamic_run(tmp_path):
    """Every kind of scene renders: a dynamic run (times, plastic strain) without a reference
    gets frames, the sheet and the energy plot, and no load-displacement plot."""
    scene = tmp_path / "flap.toml"
    scene.write_text(DYNAMIC_PLATE)
    out = tmp_path / "flap"
    proc = cli("run", str(scene), "--out", str(out), "--quiet")
    assert proc.returncode == 0, proc.stderr[-2000:]
    proc = cli("render", str(out))
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    names = {p.name for p in (out / "pictures").glob("*.png")}
    assert names == {"frame_00000.png", "frame_00001.png", "frame_00002.png", "frame_00003.png", "sheet.png",
                     "energy.png"}, names
    for name in names:
        assert_picture(out / "pictures" / name)
    assert not list((out / "pictures").glob(".*")), "temporary files left"


def test_render_a_truncated_frame(run_dir, tmp_path, capsys):
    """Issue 16.12: a truncated .vtu made render exit 1 with meshio's own message (its
    SystemExit was not caught).  The frame is skipped with a warning; the rest is drawn."""
    copy = tmp_path / "copy"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("pictures"))
    frame = copy / "frames" / "frame_00001.vtu"
    frame.write_bytes(frame.read_bytes()[:1000])
    assert main(["render", str(copy), "--sheet", "none"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and "Traceback" not in captured.out
    assert f"warning: {frame}: not drawn: cannot read it (" in captured.out
    assert (copy / "pictures" / "frame_00000.png").is_file()
    assert not (copy / "pictures" / "frame_00001.png").exists()


def test_render_nothing_drawable_exits_3(run_dir, tmp_path, capsys):
    """Issue 16.10: frames holding nothing drawable (non-finite coordinates, truncated files)
    or no frame at all (a run stopped before its first one): exit 3, one line, no picture."""
    import meshio
    copy = tmp_path / "copy"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("pictures"))
    for i, frame in enumerate(sorted((copy / "frames").glob("frame_*.vtu"))):
        if i == 0:
            mesh = meshio.read(frame)
            mesh.points[:] = np.nan
            meshio.write(frame, mesh)
        else:
            frame.write_bytes(frame.read_bytes()[:500])
    assert main(["render", str(copy)]) == 3
    err = capsys.readouterr().err
    print(err)
    assert err.count("\n") == 1 and err.startswith(f"error: {copy}: nothing to draw: no frame can be drawn (2 of 2")
    assert not (copy / "pictures").exists()
    (copy / "frames.pvd").unlink()
    assert main(["render", str(copy)]) == 3
    assert capsys.readouterr().err == f"error: {copy}: nothing to draw: the run wrote no frame (see its summary.json)\n"


def test_render_skips_a_runaway_frame(tmp_path):
    """A frame whose shell is 1e24 in size (a runaway state written by an older run) is not
    drawn: it would shrink every other frame to a dot."""
    import meshio

    from taichi_shell_mpm.render import Run, choose_field, frame_mesh, sequence_stats
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    files = []
    for i, scale in enumerate((1.0, 1.1, 1e24)):          # (the runaway frame of a dynamic run is its last)
        files.append(tmp_path / f"frame_{i:05d}.vtu")
        meshio.write(files[-1], meshio.Mesh(points * scale, [("quad", np.array([[0, 1, 2, 3]]))],
                                            point_data={"displacement": points * (scale - 1.0)}))
    run = Run(out_dir=tmp_path, name="x", key="time", keys=np.array([0.0, 1.0, 2.0]), files=files)
    fld = choose_field(frame_mesh(run, 0), None)
    stats = sequence_stats(run, [0, 1, 2], fld)
    assert list(run.undrawable) == [2] and "runaway state (1e+24 times the size of the first frame)" in run.warnings[0]
    assert stats.bounds[1] == pytest.approx(1.1)
    two = Run(out_dir=tmp_path, name="x", key="time", keys=np.array([0.0, 2.0]), files=[files[0], files[2]])
    sequence_stats(two, [0, 1], fld)
    assert list(two.undrawable) == [1]


def test_render_skips_eroded_elements(tmp_path):
    """Issue 28.10: an eroded element (cell array ``eroded`` = 1) whose free node flew away was
    drawn as a line across the picture and set the camera's bounds.  Its cell and the nodes
    only it uses are left out; every element eroded is a frame with nothing to draw."""
    import meshio

    from taichi_shell_mpm.render import Run, frame_mesh
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [1e6, 1e6, 0]], dtype=float)
    quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    files = []
    for i, eroded in enumerate(([0, 1], [1, 1])):
        files.append(tmp_path / f"frame_{i:05d}.vtu")
        meshio.write(files[-1], meshio.Mesh(points, [("quad", quads)], point_data={"displacement": points},
                                            cell_data={"eroded": [np.array(eroded, dtype=np.int32)],
                                                       "thickness": [np.array([0.1, 0.2])]}))
    run = Run(out_dir=tmp_path, name="x", key="time", keys=np.array([0.0, 1.0]), files=files)
    mesh = frame_mesh(run, 0)
    assert mesh.n_cells == 1 and mesh.n_points == 4
    np.testing.assert_array_equal(np.ptp(np.asarray(mesh.points), axis=0), [1, 1, 0])
    assert mesh.cell_data["thickness"].tolist() == [0.1]
    assert frame_mesh(run, 1) is None and run.undrawable[1] == "every element has eroded"
