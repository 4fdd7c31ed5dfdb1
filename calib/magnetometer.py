"""Magnetometer calibration: known turntable positions, or an ellipsoid fit without poses.

Model, sensor frame::

    m_out = A @ h + B

with ``h`` (3,) the true magnetic field in the sensor frame, microtesla, ``A``
(3, 3) dimensionless (scale factors, non-orthogonality, soft iron and
installation error together) and ``B`` (3,) the hard-iron offset, microtesla.
In the simulator's convention (:class:`drivers.sensors.sim.error_model.MagErrorModel`)
``A = soft_iron`` and ``B = hard_iron_ut``.

Two solvers:

* :func:`solve_mag_positions` -- the seed's eight-position method (Liang, Xu,
  Cao 2017) generalised: with the local field known (vertical and north
  components from a reference model) and each turntable position known, the
  field in the sensor frame ``h_k`` is known and the 12 parameters of A and B
  follow by linear least squares (8 positions or more).
* :func:`solve_mag_ellipsoid` -- the field-ellipsoid fit the seed recommends in
  the place of use: no poses needed, only the field magnitude. It determines
  A only up to a rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.errors import CalibError, ObservabilityError
from calib.gyro import DictValidator, check_array, fit_affine, input_coverage
from calib.magnitude import fit_magnitude

AXES = "xyz"
METHODS = ("positions", "ellipsoid")


def sigma_names() -> list[str]:
    """Names of the 12 magnetometer parameters: ``hard_iron_x..z`` (uT), ``a_xx..a_zz`` (-)."""
    return [f"hard_iron_{a}" for a in AXES] + [f"a_{r}{c}" for r in AXES for c in AXES]


@dataclass(frozen=True)
class MagStepMeans:
    """One row per static step of a magnetometer calibration.

    Attributes
    ----------
    names : (K,) step names.
    field_nominal_ut : (K, 3) true field in the sensor frame, uT, or None when the poses are unknown.
    mean_ut : (K, 3) mean magnetometer output, uT.
    sem_ut : (K, 3) standard error of each mean (sample std / sqrt(n)), uT, > 0.
    n_samples : (K,) samples per step.
    """

    names: tuple
    field_nominal_ut: np.ndarray | None
    mean_ut: np.ndarray
    sem_ut: np.ndarray
    n_samples: np.ndarray

    def __post_init__(self) -> None:
        k = len(self.names)
        owner = "MagStepMeans"
        if self.field_nominal_ut is not None:
            object.__setattr__(self, "field_nominal_ut",
                               check_array(owner, "field_nominal_ut", self.field_nominal_ut, (k, 3)))
        for name, shape in (("mean_ut", (k, 3)), ("sem_ut", (k, 3)), ("n_samples", (k,))):
            object.__setattr__(self, name, check_array(owner, name, getattr(self, name), shape,
                                                       positive=name in ("sem_ut", "n_samples")))

    def __len__(self) -> int:
        return len(self.names)


@dataclass
class MagCalibration:
    """Result of :func:`solve_mag_positions` or :func:`solve_mag_ellipsoid`; model ``m = A h + B``.

    Attributes
    ----------
    method : "positions" or "ellipsoid".
    matrix : (3, 3) A, dimensionless. For "ellipsoid" it is the upper-triangular
        representative of the family ``A R`` (R any rotation) that fits equally well.
    hard_iron_ut : (3,) B, uT.
    sigma : 1-sigma of ``hard_iron_x..z`` (uT) and ``a_xx..a_zz`` (-).
    residual_rms_ut : "positions": RMS over steps and axes of ``m - (A h + B)``, uT;
        "ellipsoid": RMS of ``|A^-1 (m - B)| - field_ut``, uT.
    chi2_per_dof : weighted misfit per degree of freedom (nan when dof = 0).
    field_ut : the field magnitude given to the ellipsoid fit, uT; None for "positions".
    n_steps : number of steps (static intervals) used.
    fit_quality : "ellipsoid" only: RMS of ``|A^-1 (m - B)| - field_ut``, uT (None for "positions").
    """

    method: str
    matrix: np.ndarray
    hard_iron_ut: np.ndarray
    sigma: dict
    residual_rms_ut: float
    chi2_per_dof: float
    field_ut: float | None
    n_steps: int
    fit_quality: float | None = None

    def apply(self, m_ut: np.ndarray) -> np.ndarray:
        """Corrected field ``A^-1 (m - B)`` (N, 3), uT, from raw outputs ``m_ut`` (N, 3), uT.

        For an "ellipsoid" calibration the result is the true field up to one fixed rotation.
        """
        m = np.atleast_2d(np.asarray(m_ut, float))
        return np.linalg.solve(self.matrix, (m - self.hard_iron_ut).T).T

    def predict_ut(self, h_ut: np.ndarray) -> np.ndarray:
        """Model output ``A h + B`` (N, 3), uT, for true fields ``h_ut`` (N, 3) in the sensor frame."""
        h = np.atleast_2d(np.asarray(h_ut, float))
        return h @ self.matrix.T + self.hard_iron_ut

    def to_dict(self) -> dict:
        """Plain floats, lists and dicts (YAML-friendly); :meth:`from_dict` inverts it exactly."""
        return {
            "method": str(self.method),
            "matrix": np.asarray(self.matrix, float).tolist(),
            "hard_iron_ut": [float(v) for v in self.hard_iron_ut],
            "sigma": {str(k): float(v) for k, v in self.sigma.items()},
            "residual_rms_ut": float(self.residual_rms_ut),
            "chi2_per_dof": float(self.chi2_per_dof),
            "field_ut": None if self.field_ut is None else float(self.field_ut),
            "n_steps": int(self.n_steps),
            "fit_quality": None if self.fit_quality is None else float(self.fit_quality),
        }

    @classmethod
    def from_dict(cls, d: dict, path: str | None = None) -> "MagCalibration":
        """Validate and rebuild from :meth:`to_dict` output.

        Raises
        ------
        CalibrationFileError naming ``path`` (the file, if any), the field path and what was expected.
        """
        v = DictValidator(path, "magnetometer")
        v.keys(d, "", set(_MAG_KEYS))
        if d["method"] not in METHODS:
            v.fail("method", f"one of {', '.join(METHODS)}, got {d['method']!r}")
        matrix = v.array(d, "matrix", (3, 3))
        if abs(np.linalg.det(matrix)) < 1e-12:
            v.fail("matrix", "an invertible 3x3 matrix")
        return cls(
            method=d["method"], matrix=matrix, hard_iron_ut=v.array(d, "hard_iron_ut", (3,)),
            sigma=v.named(d, "sigma", sigma_names(), nonneg=True),
            residual_rms_ut=v.number(d, "residual_rms_ut", allow_nan=True),
            chi2_per_dof=v.number(d, "chi2_per_dof", allow_nan=True),
            field_ut=None if d["field_ut"] is None else v.number(d, "field_ut", positive=True),
            n_steps=v.integer(d, "n_steps"),
            fit_quality=None if d["fit_quality"] is None else v.number(d, "fit_quality", allow_nan=True),
        )


_MAG_KEYS = ("method", "matrix", "hard_iron_ut", "sigma", "residual_rms_ut", "chi2_per_dof", "field_ut",
             "n_steps", "fit_quality")


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

    Weighted least squares per output axis with columns ``[h_x, h_y, h_z, 1]`` and
    weights 1/sem (:func:`calib.design.solve_wls`: covariance scaled by chi2/dof when
    the misfit is significant). The seed's eight-position method is the special case
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
    names = [[f"a_{AXES[i]}{c}" for c in AXES] + [f"hard_iron_{AXES[i]}"] for i in range(3)]
    fit = fit_affine(h, steps.mean_ut, steps.sem_ut, names)
    sig = {}
    for i in range(3):
        s = np.sqrt(np.diag(fit.axis_fits[i].cov))
        sig[f"hard_iron_{AXES[i]}"] = float(s[3])
        for j in range(3):
            sig[f"a_{AXES[i]}{AXES[j]}"] = float(s[j])
    return MagCalibration(method="positions", matrix=fit.matrix, hard_iron_ut=fit.offset,
                          sigma={n: sig[n] for n in sigma_names()},
                          residual_rms_ut=float(np.sqrt(np.mean(fit.residuals**2))),
                          chi2_per_dof=fit.chi2_per_dof, field_ut=None, n_steps=len(steps))


def solve_mag_ellipsoid(steps: MagStepMeans, field_ut: float) -> MagCalibration:
    """Ellipsoid (magnitude-constraint) fit ``|A^-1 (m - B)| = field_ut`` without known poses.

    Uses :func:`calib.magnitude.fit_magnitude` with ``radius = field_ut`` on the step
    means (weights from ``sem_ut``). ``field_nominal_ut`` is ignored.

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
    fit = fit_magnitude(steps.mean_ut, steps.sem_ut, radius=f)
    sig = {f"hard_iron_{AXES[i]}": float(fit.sigma_bias[i]) for i in range(3)}
    sig.update({f"a_{AXES[i]}{AXES[j]}": float(fit.sigma_matrix[i, j]) for i in range(3) for j in range(3)})
    return MagCalibration(method="ellipsoid", matrix=np.asarray(fit.matrix, float),
                          hard_iron_ut=np.asarray(fit.bias, float), sigma={n: sig[n] for n in sigma_names()},
                          residual_rms_ut=float(fit.residual_rms), chi2_per_dof=float(fit.chi2_per_dof),
                          field_ut=f, n_steps=int(fit.n_intervals), fit_quality=float(fit.residual_rms))
