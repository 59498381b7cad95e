"""[output]: frames and histories."""
from __future__ import annotations

from dataclasses import dataclass

from ..keys import boolean, integer, key, non_negative, times


@dataclass(frozen=True)
class Output:
    every_steps: int = key(integer(0), "write a frame every this many steps (0: never)", default=0)
    times: tuple[float, ...] = key(times, default=(), unit="time",
        doc="also write frames at these times (a time after a dynamic run's `end_time` is a warning: no frame is "
            "written there)")
    load_steps: bool = key(boolean, "static: write a frame at the end of each load step", default=True)
    frame_interval: float = key(non_negative, default=0.0, unit="time",
        doc="dynamic: also write a frame every this much time (LS-DYNA's *DATABASE_BINARY_D3PLOT DT); 0: none")
    history_interval: float = key(non_negative, default=0.0, unit="time",
        doc="dynamic: also record probes, energies and forces (no frame) every this much time; 0 = only at frames")
