"""What the sensor physically experiences, as a function of time (the simulators' input)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class PhysicsBatch:
    """Physical inputs at N instants (sensor frame).

    specific_force_g (N,3) g; angular_rate_dps (N,3) deg/s; magnetic_field_ut (N,3) uT; temp_c (N,) C.
    """

    specific_force_g: np.ndarray
    angular_rate_dps: np.ndarray
    magnetic_field_ut: np.ndarray
    temp_c: np.ndarray


PhysicsSource = Callable[[np.ndarray], PhysicsBatch]


def temperature_at(physics: PhysicsSource, t_s) -> np.ndarray:
    """The sensor temperature (N,), C, at times ``t_s``: the source's ``temp_c_at`` where it has one (the
    temperature alone, without the attitude a full batch computes), else the ``temp_c`` of its batch."""
    temp_c_at = getattr(physics, "temp_c_at", None)
    if temp_c_at is not None:
        return np.asarray(temp_c_at(t_s), float)
    return np.asarray(physics(t_s).temp_c, float)


def advance(physics: PhysicsSource, t_s) -> np.ndarray:
    """Take ``physics`` through times ``t_s`` whose samples nobody sees (a chip only counts them) and return the
    sensor temperature there (N,), C: the source's ``advance`` where it has one (a stateful source moves its state
    through those times without computing what is not seen), else its full batch."""
    step = getattr(physics, "advance", None)
    if step is not None:
        return np.asarray(step(t_s), float)
    return np.asarray(physics(t_s).temp_c, float)


@dataclass
class StaticPhysics:
    """A constant physical state (a sensor lying still)."""

    specific_force_g: tuple = (0.0, 0.0, 1.0)
    angular_rate_dps: tuple = (0.0, 0.0, 0.0)
    magnetic_field_ut: tuple = (20.0, 0.0, -45.0)
    temp_c: float = 25.0

    def temp_c_at(self, t_s) -> np.ndarray:
        return np.full(len(np.atleast_1d(t_s)), float(self.temp_c))

    def __call__(self, t_s) -> PhysicsBatch:
        n = len(np.atleast_1d(t_s))
        return PhysicsBatch(np.tile(np.asarray(self.specific_force_g, float), (n, 1)),
                            np.tile(np.asarray(self.angular_rate_dps, float), (n, 1)),
                            np.tile(np.asarray(self.magnetic_field_ut, float), (n, 1)),
                            np.full(n, float(self.temp_c)))


class SeenThrough:
    """Base of a physics source that shows another (``self.physics``) in another frame: the temperature is the
    wrapped source's, and samples nobody sees advance it (:func:`temperature_at`, :func:`advance`); a subclass
    gives ``__call__``."""

    physics: object

    def temp_c_at(self, t_s) -> np.ndarray:
        return temperature_at(self.physics, t_s)

    def advance(self, t_s) -> np.ndarray:
        return advance(self.physics, t_s)
