"""Frames of the tool kinds (numpy)."""
from __future__ import annotations

import numpy as np


def frame_from(e3, e1=None) -> np.ndarray:
    """Rows e1, e2, e3 of a right-handed orthonormal frame with e3 along `e3` and e1 along
    `e1` projected on the plane normal to it (None, or along e3: the axis least aligned with e3)."""
    e3 = np.asarray(e3, float) / np.linalg.norm(e3)
    guess = None if e1 is None else np.asarray(e1, float) - np.dot(e1, e3) * e3
    if guess is None or np.linalg.norm(guess) < 1e-9 * np.linalg.norm(e1):
        guess = np.eye(3)[int(np.argmin(np.abs(e3)))]
        guess = guess - np.dot(guess, e3) * e3
    u = guess / np.linalg.norm(guess)
    return np.stack([u, np.cross(e3, u), e3])
