"""A characterisation: every axis of every sensor recorded, its Allan deviation and its fitted noise terms.

:func:`characterize` takes each sensor's samples in its unit (accelerometer g, gyroscope deg/s,
magnetometer uT), refuses a record with gaps, a moving sensor or one too short for the terms asked
(:mod:`calib.noise.checks`, :func:`calib.noise.terms.check_duration`: each one line), and fits each
axis (:func:`calib.noise.fit.fit_terms`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.frames import SENSOR_AXES
from calib.noise.allan import allan_curve
from calib.noise.checks import check_gaps, check_static
from calib.noise.fit import FIT_TAU_MIN_S, fit_terms
from calib.noise.terms import DEFAULT_TERMS, UNITS, NoiseFigures, check_duration

__all__ = ["UNITS", "Characterisation", "characterize"]


@dataclass(frozen=True)
class Characterisation:
    """The fits of every axis: ``fits[sensor][axis]`` (:class:`NoiseFit`), ``duration_s``, ``rate_hz``, ``terms``."""

    fits: dict
    duration_s: float
    rate_hz: float
    terms: tuple

    def figures(self, sensor: str) -> list[NoiseFigures]:
        return [self.fits[sensor][a].figures for a in SENSOR_AXES]


def characterize(t_s, series: dict, rate_hz: float, terms=DEFAULT_TERMS, expected: dict | None = None,
                 tau_min_s: float = FIT_TAU_MIN_S, where: str = "the recording") -> Characterisation:
    """Fit ``terms`` to every axis of ``series`` (sensor -> (N, 3) samples in :data:`UNITS`, "accel" required),
    sampled at ``t_s`` (N,) s at ``rate_hz``. ``expected`` (sensor -> :class:`NoiseFigures`, e.g. the chip
    family's) sets how long the record must be; CalibError (one line) for gaps, motion or a short record."""
    t = np.asarray(t_s, float)
    check_gaps(t, rate_hz, where)
    duration = len(t) / float(rate_hz)
    for sensor in series:
        check_duration(duration, terms, (expected or {}).get(sensor), f"{where} ({sensor})")
    check_static(series["accel"], rate_hz, series.get("gyro"), float(t[0]) if len(t) else 0.0, where)
    fits = {sensor: {axis: fit_terms(allan_curve(np.asarray(x, float)[:, j], rate_hz), terms, tau_min_s=tau_min_s)
                     for j, axis in enumerate(SENSOR_AXES)}
            for sensor, x in series.items()}
    return Characterisation(fits, duration, float(rate_hz), tuple(terms))
