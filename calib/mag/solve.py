"""Magnetometer solvers: known turntable positions (linear least squares) or an ellipsoid fit without poses.

* :func:`solve_mag_positions` -- the seed's eight-position method (Liang, Xu, Cao 2017) generalised:
  with the local field known and each turntable position known, the field in the sensor frame
  ``h_k`` is known and the 12 parameters of A and B follow by linear least squares (4 positions or more).
* :func:`solve_mag_ellipsoid` -- the field-ellipsoid fit the seed recommends in the place of use:
  no poses needed, only the field magnitude. It determines A only up to a rotation.

Both weigh the steps by their standard errors and, when the magnetometer's bias stability and the
steps' times are known (:meth:`calib.mag.inputs.MagStepMeans.wander_ut2`), by the covariance of the
offset's wander between them (generalised least squares, :mod:`calib.mag.ellipsoid` for the
ellipsoid; docs/methods.md, "Per-step standard errors"). A step's readings last a fraction of a second and
the steps are seconds to minutes apart: the wander between them is several times a step's standard
error, and a fit that ignored it reported chi2/dof near 9 on a clean simulated session.
"""

from __future__ import annotations

import numpy as np

from calib.numerics.affine import fit_affine, input_coverage
from calib.errors import CalibError, ObservabilityError
from calib.mag.inputs import MagStepMeans
from calib.mag.result import SENSOR_AXES, MagCalibration, sigma_names
from calib.mag.ellipsoid import fit_ellipsoid


def _check_positions(h: np.ndarray) -> None:
    _, full = input_coverage(h)
    rank = int(np.linalg.matrix_rank(h / max(float(np.max(np.abs(h))), 1e-300), tol=1e-9)) if len(h) else 0
    if rank < 3:
        raise ObservabilityError(f"the nominal field directions of the {len(h)} positions span only {rank} "
                                 "dimension(s), not 3D: columns of A undetermined; add positions that turn "
                                 "the field through all three sensor axes")
    if not full:
        raise ObservabilityError(f"the {len(h)} positions do not give 4 independent fields (they lie in one "
                                 "plane), so the hard iron cannot be separated from A; use at least 4 positions "
                                 "not in one plane (the seed uses 8)")


def solve_mag_positions(steps: MagStepMeans) -> MagCalibration:
    """Solve ``m = A h + B`` (12 parameters) from positions with known field in the sensor frame.

    Least squares per output axis with columns ``[h_x, h_y, h_z, 1]``: generalised with the offset
    wander between the steps when known (:func:`calib.numerics.affine.fit_affine`), else weights 1/sem;
    covariance rescaled by chi2/dof only on a significant misfit of the session. The seed's
    eight-position method is the special case
    K = 8; any K >= 4 positions whose fields are not in one plane determine the model,
    more than 4 give a misfit check.

    Parameters
    ----------
    steps : :class:`MagStepMeans` with ``field_nominal_ut`` (K, 3), uT, sensor frame.

    Raises
    ------
    CalibError when ``field_nominal_ut`` is None; ObservabilityError when the fields do
    not span 3D or fewer than 4 independent positions are given.
    """
    if steps.field_nominal_ut is None:
        raise CalibError("solve_mag_positions: MagStepMeans.field_nominal_ut is None; the positions method "
                         "needs the true field per position (use solve_mag_ellipsoid without poses)")
    h = steps.field_nominal_ut
    _check_positions(h)
    names = [[f"a_{SENSOR_AXES[i]}{c}" for c in SENSOR_AXES] + [f"hard_iron_{SENSOR_AXES[i]}"] for i in range(3)]
    fit = fit_affine(h, steps.mean_ut, steps.sem_ut, names, steps.wander_ut2())
    sig = {}
    for i in range(3):
        s = np.sqrt(np.diag(fit.axis_fits[i].cov))
        sig[f"hard_iron_{SENSOR_AXES[i]}"] = float(s[3])
        for j in range(3):
            sig[f"a_{SENSOR_AXES[i]}{SENSOR_AXES[j]}"] = float(s[j])
    return MagCalibration(method="positions", matrix=fit.matrix, hard_iron_ut=fit.offset,
                          sigma={n: sig[n] for n in sigma_names()},
                          residual_rms_ut=float(np.sqrt(np.mean(fit.residuals**2))),
                          chi2_per_dof=fit.chi2_per_dof, field_ut=None, n_steps=len(steps))


def solve_mag_ellipsoid(steps: MagStepMeans, field_ut: float) -> MagCalibration:
    """Ellipsoid (magnitude-constraint) fit ``|A^-1 (m - B)| = field_ut`` without known poses.

    Uses :func:`calib.mag.ellipsoid.fit_ellipsoid` with ``field_ut`` on the step means (weights
    from ``sem_ut`` and, when known, the offset wander between the steps). ``field_nominal_ut``
    is ignored.

    Notes
    -----
    The magnitude constraint is invariant under ``A -> A R`` for any rotation R, so A
    is determined only up to a rotation: the returned matrix is the upper-triangular
    representative, and ``apply`` gives the true field up to one fixed rotation (the
    hard iron B, the field magnitude and the angles between fields are determined).
    The installation rotation needs known poses (:func:`solve_mag_positions`) or an
    alignment against another sensor. Use at least 20 well-spread orientations
    (fit_magnitude refuses fewer than 10, or orientations in a plane).

    Parameters
    ----------
    steps : :class:`MagStepMeans`; only ``mean_ut`` and ``sem_ut`` are used.
    field_ut : local field magnitude, uT (from a reference model, e.g. WMM/IGRF), > 0.

    Returns
    -------
    :class:`MagCalibration` with method "ellipsoid", ``fit_quality`` = ``residual_rms_ut``
    = RMS of ``|A^-1 (m - B)| - field_ut`` (uT), ``chi2_per_dof`` and ``n_steps`` = the
    number of intervals.
    """
    try:
        f = float(field_ut)
    except (TypeError, ValueError):
        raise CalibError(f"solve_mag_ellipsoid: field_ut must be a number > 0 (uT), got {field_ut!r}") from None
    if not (np.isfinite(f) and f > 0):
        raise CalibError(f"solve_mag_ellipsoid: field_ut must be a finite number > 0 (uT), got {field_ut!r}")
    fit = fit_ellipsoid(steps.mean_ut, steps.sem_ut, f, steps.wander_ut2())
    sig = {f"hard_iron_{SENSOR_AXES[i]}": float(fit.sigma_bias[i]) for i in range(3)}
    sig.update({f"a_{SENSOR_AXES[i]}{SENSOR_AXES[j]}": float(fit.sigma_matrix[i, j]) for i in range(3) for j in range(3)})
    return MagCalibration(method="ellipsoid", matrix=np.asarray(fit.matrix, float),
                          hard_iron_ut=np.asarray(fit.bias, float), sigma={n: sig[n] for n in sigma_names()},
                          residual_rms_ut=float(fit.residual_rms), chi2_per_dof=float(fit.chi2_per_dof),
                          field_ut=f, n_steps=int(fit.n_intervals), fit_quality=float(fit.residual_rms))
