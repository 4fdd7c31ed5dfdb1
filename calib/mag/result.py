"""Magnetometer result: ``m_out = A @ h + B``, sensor frame; section ``magnetometer`` of the calibration file.

``h`` (3,) the true magnetic field in the sensor frame, uT; ``A`` (3, 3) dimensionless (scale factors,
non-orthogonality, soft iron and installation error together); ``B`` (3,) the hard-iron offset, uT.
In the simulator's convention (``drivers.sensors.sim.error_model.MagErrorModel``) ``A = soft_iron`` and
``B = hard_iron_ut``.
"""

from __future__ import annotations

from typing import ClassVar, Optional

import numpy as np
from pydantic import ConfigDict, model_validator, with_config
from typing_extensions import TypedDict

from calib.file.fields import Matrix3, Vector3, field_problem, integer, number, unit
from calib.file.section import choice, WithUncertainty
from calib.frames import SENSOR_AXES

METHODS = ("positions", "ellipsoid")


def sigma_names() -> list[str]:
    """Names of the 12 magnetometer parameters: ``hard_iron_x..z`` (uT), ``a_xx..a_zz`` (-)."""
    return [f"hard_iron_{a}" for a in SENSOR_AXES] + [f"a_{r}{c}" for r in SENSOR_AXES for c in SENSOR_AXES]


#: 1-sigma of ``hard_iron_x..z`` (uT) and ``a_xx..a_zz`` (-)
MagSigma = with_config(ConfigDict(extra="forbid"))(
    TypedDict("MagSigma", {n: number(nonneg=True) for n in sigma_names()}))


class MagCalibration(WithUncertainty):
    """Result of :func:`calib.mag.solve_mag_positions` or :func:`calib.mag.solve_mag_ellipsoid`; ``m = A h + B``.

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

    CAL_TYPE: ClassVar[str] = "magnetometer"
    #: the unit :meth:`apply` takes and the unit it gives: the chip's output already in uT (raw counts are
    #: divided by the recording's counts per uT first: ``calib.file.apply``)
    INPUT_UNIT: ClassVar[str] = "uT"
    OUTPUT_UNIT: ClassVar[str] = "uT"
    FILE_REQUIRED: ClassVar[tuple[str, ...]] = ("fit_quality",)

    method: choice(*METHODS) = unit("-", "positions or ellipsoid")
    matrix: Matrix3 = unit("-", "A (ellipsoid: up to a rotation)")
    hard_iron_ut: Vector3 = unit("uT", "B")
    sigma: MagSigma = unit("-", "1-sigma: hard_iron_* uT, a_* dimensionless")
    residual_rms_ut: number(allow_nan=True) = unit("uT", "RMS of the residuals")
    chi2_per_dof: number(allow_nan=True) = unit("-", "weighted misfit per dof")
    field_ut: number(positive=True, optional=True) = unit("uT", "field magnitude of the ellipsoid fit, or null")
    n_steps: integer() = unit("-", "steps (static intervals) used")
    fit_quality: number(allow_nan=True, optional=True) = unit("uT", "ellipsoid: RMS of |A^-1(m - B)| - field",
                                                             default=None)
    uncertainty: Optional[dict] = unit("-", "positions method: expanded uncertainty U = k u_c in sigma's keys, k, "
                                       "combined_standard and the budget of Type A and B contributions "
                                       "(docs/uncertainty.md, \"The magnetometer\"); absent: none was made",
                                       default=None)

    @model_validator(mode="after")
    def _invertible(self) -> "MagCalibration":
        if abs(np.linalg.det(self.matrix)) < 1e-12:
            raise field_problem("matrix", "an invertible 3x3 matrix")
        return self

    def apply(self, m_ut: np.ndarray) -> np.ndarray:
        """Corrected field ``A^-1 (m - B)`` (N, 3), uT, sensor frame, from raw outputs ``m_ut`` (N, 3), uT.

        For an "ellipsoid" calibration the result is the true field up to one fixed rotation.
        """
        m = np.atleast_2d(np.asarray(m_ut, float))
        return np.linalg.solve(self.matrix, (m - self.hard_iron_ut).T).T

    def predict_ut(self, h_ut: np.ndarray) -> np.ndarray:
        """Model output ``A h + B`` (N, 3), uT, for true fields ``h_ut`` (N, 3) in the sensor frame."""
        h = np.atleast_2d(np.asarray(h_ut, float))
        return h @ self.matrix.T + self.hard_iron_ut
