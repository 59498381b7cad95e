"""[scene]: the scene's name, units and description."""
from __future__ import annotations

from dataclasses import dataclass

from ..keys import file_name, key, nonempty, text


@dataclass(frozen=True)
class SceneInfo:
    name: str = key(file_name, "name of the output directory and the summary")
    units: str = key(nonempty, "the consistent unit system, free text")
    description: str = key(text, "free text (display only: a checkpoint may be continued with another)", default="")
