"""Named poses: the six orthogonal poses and the 26 cube directions."""

from __future__ import annotations

import itertools

import numpy as np

from rig.planning.kinematics import angles_for_direction

_AXES = "XYZ"


def _name(d: tuple[int, int, int]) -> str:
    parts = [f"{'+' if v > 0 else '-'}{_AXES[i]}" for i, v in enumerate(d) if v != 0]
    return "".join(parts) + " up"


def cube_directions() -> dict[str, np.ndarray]:
    """The 26 directions of a cube (6 faces, 12 edges, 8 corners), unit vectors, by name.

    Names list the sensor axes that point up: "+X up", "+X-Y up", "+X+Y+Z up".
    """
    out = {}
    dirs = [d for d in itertools.product((-1, 0, 1), repeat=3) if any(d)]
    dirs.sort(key=lambda d: (sum(abs(v) for v in d), [-v for v in d]))
    for d in dirs:
        v = np.asarray(d, float)
        out[_name(d)] = v / np.linalg.norm(v)
    return out


CUBE = cube_directions()
SIX = {k: v for k, v in CUBE.items() if np.count_nonzero(v) == 1}
POSE_NAMES = tuple(CUBE)


def pose_angles_deg(name: str, a1_deg: float = 0.0) -> np.ndarray:
    """Stage angles (a1, a2, a3), deg, of a named pose (KeyError if unknown)."""
    return angles_for_direction(CUBE[name], a1_deg)
