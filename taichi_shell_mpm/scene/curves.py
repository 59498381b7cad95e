"""[curves.NAME]: time functions of loads and motions."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from ..keys import (
    Invalid,
    Key,
    choice,
    increasing,
    keys,
    number,
    scene_file,
    time_curve_points,
)
from .reader import Reader

CURVE_SHAPES = ("constant", "ramp", "smooth_step")


@dataclass(frozen=True)
class Curve:
    """A time function f (curves.py): of the time in a dynamic run, of the load factor in a
    static one."""
    name: str
    kind: Literal["points", "constant", "ramp", "smooth_step"]
    points: tuple[tuple[float, float], ...] = ()
    """points (also read from `file`): (t, f), t strictly increasing; linear between them, flat
    beyond the ends."""
    file: Path | None = None
    start: float = 0.0
    end: float = 1.0
    """ramp: 0 up to start, linear to 1 at end, then 1; smooth_step: the same with the quintic
    10 s^3 - 15 s^4 + 6 s^5 (zero slope and curvature at both ends)."""
    scale: float = 1.0
    """Every value times this."""


MAX_CURVES = 64          # [curves.NAME] tables of a scene (state.loads tables)
CURVE_KEYS = keys(
    Key("points", time_curve_points, "a table: linear between the points, flat beyond the first and the last",
        default_text="", allowed="finite numbers, t strictly increasing", example=[[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]]),
    Key("file", scene_file, "the same table from two columns t, f (a first row that is not two numbers is a header; "
                            "empty rows and rows starting with `#` are skipped)", default_text="",
        allowed="an existing CSV file, relative to the scene file"),
    Key("shape", choice(*CURVE_SHAPES), "`constant`: f = 1; `ramp`: 0 up to `start`, linear to 1 at `end`, then 1; "
                                        "`smooth_step`: the same with the quintic 10x³ − 15x⁴ + 6x⁵ (x = (t − start)/"
                                        "(end − start)), zero slope and curvature at both ends", default_text=""),
    Key("start", number(), "where the shape starts rising", default=0.0,
        allowed="with `ramp` / `smooth_step`; < `end`"),
    Key("end", number(), "where it reaches 1", default=1.0, allowed="> `start`",
        default_text="required with `ramp` / `smooth_step`"),
    Key("scale", number(), "every value times this", default=1.0, allowed="finite"))
"""[curves.NAME]: exactly one of points, file, shape (they build a Curve)."""


def read_curve(r: Reader, path: str, data: Any) -> Curve | None:
    mark = len(r.messages)
    v = r.read(path, data, CURVE_KEYS)
    if v is None:
        return None
    given = [key for key in ("points", "file", "shape") if key in data]
    if len(given) != 1:
        r.error(path, f"expected exactly one of points, file, shape, got {', '.join(given) or 'none'}")
        return None
    shape = v.get("shape")
    for key in ("start", "end"):
        if key in data and data.get("shape") not in ("ramp", "smooth_step"):
            r.error(f"{path}.{key}", 'allowed only with shape = "ramp" or "smooth_step"')
    if shape in ("ramp", "smooth_step"):
        if "end" not in data:
            r.error(f"{path}.end", f'missing required key for shape = "{shape}"')
        elif "start" in v and "end" in v and v["start"] >= v["end"]:
            r.error(path, f"expected start < end, got start = {v['start']:g}, end = {v['end']:g}")
    values = {"name": path[len("[curves."):-1], "kind": shape or "points",
              **{k: v[k] for k in ("start", "end", "scale") if k in v}}
    if "file" in v:
        from ..curves import CurveFileError, read_table
        try:
            values["points"] = increasing(read_table(v["file"]))
            values["file"] = v["file"]
        except (CurveFileError, Invalid) as exc:
            r.error(f"{path}.file", str(exc))
    elif "points" in v:
        values["points"] = v["points"]
    return r.build(mark, Curve, values)
