"""Shared helpers: build scenes from TOML text and simulations in-process."""
from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from taichi_shell_mpm.scene import load_scene
from taichi_shell_mpm.simulation import Simulation, init_taichi

ROOT = Path(__file__).resolve().parents[1]

PLATE = """
[scene]
name = "plate"
units = "consistent"
[mesh]
kind = "plate"
lx = {lx}
ly = {ly}
nx = {nx}
ny = {ny}
[material]
E = {E}
nu = {nu}
density = 1.0
[section]
thickness = {t}
[method]
kind = "{method}"
transfer = "{transfer}"
{method_extra}
[solve]
kind = "{solve}"
end_time = 1.0
dt_rule = "shell"
{extra}
"""


def write_scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def plate_scene(tmp_path: Path, *, lx=1.0, ly=1.0, nx=4, ny=4, E=1e4, nu=0.3, t=0.01, method="mpm",
                transfer="apic", method_extra="", solve="dynamic", extra="", overrides=()):
    text = PLATE.format(lx=lx, ly=ly, nx=nx, ny=ny, E=E, nu=nu, t=t, method=method, transfer=transfer,
                        method_extra=method_extra, solve=solve, extra=extra)
    return load_scene(write_scene(tmp_path, text), overrides)


def simulation(scene, tmp_path: Path) -> Simulation:
    init_taichi("cpu")
    return Simulation(scene, tmp_path / "out", quiet=True)


@pytest.fixture
def make_simulation(tmp_path):
    def make(scene):
        return simulation(scene, tmp_path)
    return make
