"""What a characterisation refuses, each in one line (CalibError): a record with gaps, a moving sensor.

An Allan deviation is defined for an unbroken, evenly sampled record of a sensor at rest: a gap joins
two records as if they were one, and a motion is a signal, not noise.
"""

from __future__ import annotations

import numpy as np

from calib.errors import CalibError

#: a sample interval longer than this many nominal intervals is a gap
GAP_INTERVALS = 1.5
#: gravity's direction may wander this far (deg) over the record's 1-second means before the sensor counts as moved
MAX_TILT_DEG = 0.5
#: a gyroscope's 1-second means may stand this far (deg/s) off their median before the sensor counts as turning
MAX_RATE_DPS = 0.5


def check_gaps(t_s, rate_hz: float, where: str = "the recording") -> None:
    """CalibError naming the first gap (or a time that does not increase) of sample times ``t_s`` (s)."""
    t = np.asarray(t_s, float)
    dt = np.diff(t)
    bad = np.flatnonzero((dt > GAP_INTERVALS / rate_hz) | (dt <= 0))
    if len(bad):
        i = int(bad[0])
        raise CalibError(f"{where}: {'a gap of ' + format(dt[i], '.3f') + ' s' if dt[i] > 0 else 'time goes back'} "
                         f"after t = {t[i]:.3f} s (sample {i}; {len(bad)} such places, samples every "
                         f"{1 / rate_hz:g} s expected): an Allan deviation needs one unbroken record")


def _second_means(x: np.ndarray, rate_hz: float) -> np.ndarray:
    k = max(1, int(round(rate_hz)))
    n = len(x) // k
    return x[:n * k].reshape(n, k, -1).mean(axis=1) if n else x.mean(axis=0, keepdims=True)


def check_static(accel_g, rate_hz: float, gyro_dps=None, t0_s: float = 0.0, where: str = "the recording") -> None:
    """CalibError when the sensor moved: gravity's direction in the 1-second means of ``accel_g`` (N, 3)
    turns more than :data:`MAX_TILT_DEG` from its median, or a gyroscope's 1-second means ``gyro_dps``
    (N, 3) stand more than :data:`MAX_RATE_DPS` off their median."""
    a = _second_means(np.asarray(accel_g, float), rate_hz)
    ref = np.median(a, axis=0)
    cos = a @ ref / (np.linalg.norm(a, axis=1) * np.linalg.norm(ref) + 1e-300)
    tilt = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    if tilt.max() > MAX_TILT_DEG:
        i = int(np.argmax(tilt))
        raise CalibError(f"{where}: the sensor moved: gravity's direction turns {tilt[i]:.2f} deg (more than "
                         f"{MAX_TILT_DEG} deg) by t = {t0_s + i:.0f} s; an Allan deviation needs the sensor at rest")
    if gyro_dps is not None:
        w = _second_means(np.asarray(gyro_dps, float), rate_hz)
        off = np.abs(w - np.median(w, axis=0)).max(axis=1)
        if off.max() > MAX_RATE_DPS:
            i = int(np.argmax(off))
            raise CalibError(f"{where}: the sensor turned: the gyroscope reads {off[i]:.2f} deg/s off its median "
                             f"(more than {MAX_RATE_DPS} deg/s) at t = {t0_s + i:.0f} s; an Allan deviation needs "
                             "the sensor at rest")

