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


@dataclass
class StaticPhysics:
    """A constant physical state (a sensor lying still)."""

    specific_force_g: tuple = (0.0, 0.0, 1.0)
    angular_rate_dps: tuple = (0.0, 0.0, 0.0)
    magnetic_field_ut: tuple = (20.0, 0.0, -45.0)
    temp_c: float = 25.0

    def __call__(self, t_s) -> PhysicsBatch:
        n = len(np.atleast_1d(t_s))
        return PhysicsBatch(np.tile(np.asarray(self.specific_force_g, float), (n, 1)),
                            np.tile(np.asarray(self.angular_rate_dps, float), (n, 1)),
                            np.tile(np.asarray(self.magnetic_field_ut, float), (n, 1)),
                            np.full(n, float(self.temp_c)))
