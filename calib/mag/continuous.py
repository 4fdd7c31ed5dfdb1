"""The field ellipsoid fitted on the samples of a magnetometer that turns (no rests).

A magnetometer is usually calibrated by turning it by hand through many orientations. Block means of a
turning sensor are chords of the ellipsoid, inside it (a 2 s block of a sensor turning at 90 deg/s averages
over a 180 deg arc: its mean is nearly the ellipsoid's centre), so a fit on block means is wrong by as much as
the blocks are long. Fitted on the samples themselves, each reading is a point on the ellipsoid with the
chip's own noise.

That noise is measured from the recording: the second difference of the samples,
``d2_k = m_(k+1) - 2 m_k + m_(k-1)``, has variance ``6 sigma^2`` for white noise, and the motion adds
only the field's curvature along the path (``|h| w^2 dt^2``: 0.01 uT at 90 deg/s and 100 Hz, where the
noise of an AK8975 is about 0.4 uT); the few second differences beyond five times their RMS (a knock, a
jump of the hand) are left out of that estimate. Each sample is then weighed by this sigma
(:func:`calib.numerics.magnitude.fit_magnitude`); a misfit beyond the noise (offset wander over the
recording, a field that is not uniform, soft iron that moves) scales the covariance by the Birge ratio.

The squared-distance bias of a noisy point (``|m + n| - |m| ~ sigma^2 / (2 |h|)``: 0.002 uT at 0.4 uT of
noise in 50 uT) is below the sigmas of a recording of a few thousand samples and is not corrected.
"""

from __future__ import annotations

import numpy as np

from calib.errors import CalibError, ObservabilityError
from calib.mag.result import SENSOR_AXES, MagCalibration, sigma_names
from calib.numerics.magnitude import fit_magnitude

#: second differences beyond this many times their RMS are left out of the noise estimate
CLIP = 5.0
#: the noise estimate never goes below this, uT (a quantised, nearly constant axis)
NOISE_FLOOR_UT = 1e-3
#: fewest samples a fit on samples takes (far more than the 9 parameters: a turn, not a few readings)
MIN_SAMPLES = 100


def sample_noise_ut(samples_ut) -> np.ndarray:
    """The white noise of each axis of consecutive samples (N, 3), uT: from their second differences,
    ``sqrt(mean(d2^2) / 6)`` after leaving out those beyond :data:`CLIP` times the RMS; at least
    :data:`NOISE_FLOOR_UT`."""
    m = np.asarray(samples_ut, float)
    d2 = m[2:] - 2 * m[1:-1] + m[:-2]
    out = np.empty(3)
    for axis in range(3):
        x = d2[:, axis]
        rms = float(np.sqrt(np.mean(x * x))) if len(x) else 0.0
        keep = x[np.abs(x) <= CLIP * rms] if rms > 0 else x
        out[axis] = np.sqrt(np.mean(keep * keep) / 6.0) if len(keep) else 0.0
    return np.maximum(out, NOISE_FLOOR_UT)


def solve_mag_ellipsoid_samples(samples_ut, field_ut: float, n_steps: int = 1) -> MagCalibration:
    """Ellipsoid fit ``|A^-1 (m - B)| = field_ut`` on the samples ``samples_ut`` (N, 3), uT, of a magnetometer
    turning through many orientations, in recording order (the noise is estimated from consecutive samples:
    :func:`sample_noise_ut`); ``n_steps``: the continuous steps they come from. A, B and the sigmas as
    :func:`calib.mag.solve.solve_mag_ellipsoid` (A up to a rotation); ``n_steps`` is the steps, not the
    samples."""
    m = np.asarray(samples_ut, float)
    if m.ndim != 2 or m.shape[1] != 3:
        raise CalibError(f"solve_mag_ellipsoid_samples: samples_ut must be (N, 3) uT, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise CalibError("solve_mag_ellipsoid_samples: samples_ut must be finite")
    if len(m) < MIN_SAMPLES:
        raise CalibError(f"a fit on the samples of a turning magnetometer needs at least {MIN_SAMPLES} samples, "
                         f"got {len(m)}")
    try:
        f = float(field_ut)
    except (TypeError, ValueError):
        raise CalibError(f"solve_mag_ellipsoid_samples: field_ut must be a number > 0 (uT), got {field_ut!r}") from None
    if not (np.isfinite(f) and f > 0):
        raise CalibError(f"solve_mag_ellipsoid_samples: field_ut must be a finite number > 0 (uT), got {field_ut!r}")
    spread = np.linalg.svd(m - m.mean(axis=0), compute_uv=False)
    if spread[-1] < 1e-3 * spread[0]:
        raise ObservabilityError("the samples lie in a plane (the sensor turned about one axis only): turn it "
                                 "through all three axes")
    noise = sample_noise_ut(m)
    fit = fit_magnitude(m, np.broadcast_to(noise, m.shape), radius=f)
    sig = {f"hard_iron_{SENSOR_AXES[i]}": float(fit.sigma_bias[i]) for i in range(3)}
    sig.update({f"a_{SENSOR_AXES[i]}{SENSOR_AXES[j]}": float(fit.sigma_matrix[i, j]) for i in range(3) for j in range(3)})
    return MagCalibration(method="ellipsoid", matrix=np.asarray(fit.matrix, float),
                          hard_iron_ut=np.asarray(fit.bias, float), sigma={n: sig[n] for n in sigma_names()},
                          residual_rms_ut=float(fit.residual_rms), chi2_per_dof=float(fit.chi2_per_dof),
                          field_ut=f, n_steps=int(n_steps), fit_quality=float(fit.residual_rms))
