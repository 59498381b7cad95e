"""The machine the cases run on: CPU, cores, memory, Taichi, Python and OS for the report's
header, and the short tag of the ``machine`` column of results.csv."""
from __future__ import annotations

import os
import platform
from pathlib import Path


def machine_info() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        import importlib.metadata as md
        taichi_version = md.version("taichi")
    except Exception:
        taichi_version = "unknown"
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count() or 0
    try:
        mem_gb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError, AttributeError):
        mem_gb = float("nan")
    return {"cpu": cpu, "cores": cores, "memory_GB": mem_gb, "taichi": taichi_version,
            "python": platform.python_version(), "os": f"{platform.system()} {platform.release()}"}


def machine_tag(info: dict, arch: str, workers: int | None = None) -> str:
    """The machine column; with ``--workers N`` (N cases at a time) it says so."""
    tag = f"{info['cpu']}, {info['cores']} cores, taichi {info['taichi']}, {arch}"
    return tag + (f", {workers} cases at a time" if workers and workers > 1 else "")
