"""Gyroscope result: ``counts = M w + b (+ G f)``, sensor frame; section ``gyroscope`` of the calibration file.

``w`` (3,) true angular rate in the sensor frame, deg/s; ``M`` (3, 3) counts per deg/s (diagonal = scale
factors ``k_x, k_y, k_z``, off-diagonal = non-orthogonality / cross-axis couplings); ``b`` (3,) zero-rate
output, counts; ``G`` (3, 3) g-sensitivity, counts per g, ``f`` specific force in g, sensor frame.

Parameter names: ``b_x`` (counts), ``k_x`` (= M_xx, counts per deg/s) and ``m_xy`` (= M_xy / M_xx,
dimensionless: how much of the rate about input axis y appears on output axis x, relative to the x scale).
"""

from __future__ import annotations

from typing import Any, ClassVar, Optional

import numpy as np
from pydantic import ConfigDict, field_validator, model_validator, with_config
from typing_extensions import TypedDict

from calib.file.fields import Matrix3, Vector3, array, field_problem, integer, number, unit
from calib.file.section import CalibrationSection, WithUncertainty
from calib.frames import SENSOR_AXES

OFF_DIAGONAL = tuple((i, j) for i in range(3) for j in range(3) if i != j)
NONORTHOGONALITY_NAMES = tuple(f"m_{SENSOR_AXES[i]}{SENSOR_AXES[j]}" for i, j in OFF_DIAGONAL)


def param_names() -> list[str]:
    """Names of the 12 gyro parameters, in the order b, k, m."""
    return [f"b_{a}" for a in SENSOR_AXES] + [f"k_{a}" for a in SENSOR_AXES] + list(NONORTHOGONALITY_NAMES)


#: ``m_ij = M_ij / M_ii`` for the six i != j, dimensionless
Nonorthogonality = with_config(ConfigDict(extra="forbid"))(
    TypedDict("Nonorthogonality", {n: number() for n in NONORTHOGONALITY_NAMES}))
#: 1-sigma of every parameter: ``b_x`` (counts), ``k_x`` (counts per deg/s), ``m_xy`` (-)
GyroSigma = with_config(ConfigDict(extra="forbid"))(
    TypedDict("GyroSigma", {n: number(nonneg=True) for n in param_names()}))


@with_config(ConfigDict(extra="forbid"))
class GSensitivity(TypedDict):
    """Columns of G the rate steps determined: ``inputs`` (axes), ``matrix_counts_per_g`` and its 1-sigma (3, 3)."""

    inputs: list[str]
    matrix_counts_per_g: Matrix3
    sigma_counts_per_g: array(3, 3, nonneg=True)


class BiasPair(CalibrationSection):
    """Zero-rate output from one + / - pair of rate steps: ``(a_plus + a_minus) / 2``.

    Attributes
    ----------
    axis_spun : "x", "y" or "z" (largest component of the rate), or "xyz" for an oblique rate.
    rate_dps : magnitude of the pair's rate, deg/s.
    bias_counts : (3,) zero-rate output, counts.
    sigma_counts : (3,) 1-sigma of ``bias_counts`` from the two steps' standard errors, counts.
    """

    axis_spun: str = unit("-", "x, y, z or xyz")
    rate_dps: number() = unit("deg/s", "magnitude of the pair's rate")
    bias_counts: Vector3 = unit("counts", "zero-rate output of the pair")
    sigma_counts: array(3, nonneg=True) = unit("counts", "1-sigma of bias_counts")


class GyroCalibration(WithUncertainty):
    """Result of :func:`calib.gyro.solve_gyro`; model ``counts = M @ w + b`` (sensor frame).

    Attributes
    ----------
    lsb_per_dps : nominal sensitivity of the recording, counts per deg/s.
    matrix_counts_per_dps : (3, 3) M, counts per deg/s.
    bias_counts : (3,) b (zero-rate output from the least squares), counts.
    scale_counts_per_dps : (3,) diag(M), counts per deg/s.
    nonorthogonality : ``m_ij = M_ij / M_ii`` for the six i != j, dimensionless.
    sigma : 1-sigma of every parameter: ``b_x`` (counts), ``k_x`` (counts per deg/s), ``m_xy`` (-).
    bias_pairs : zero-rate outputs of the + / - pairs (:class:`BiasPair`).
    residual_rms_dps : RMS over steps and axes of the fit residuals mapped through M^-1, deg/s.
    chi2_per_dof : weighted misfit per degree of freedom (about 1 when the model fits; nan if dof = 0).
    n_steps : number of rate steps used.
    g_sensitivity : None, or {inputs, matrix_counts_per_g (3, 3), sigma_counts_per_g (3, 3)}, counts per g.
    """

    CAL_TYPE: ClassVar[str] = "gyroscope"
    #: the unit :meth:`apply` takes and the unit it gives (``calib.file.apply`` checks the recording's)
    INPUT_UNIT: ClassVar[str] = "counts"
    OUTPUT_UNIT: ClassVar[str] = "deg/s"
    LABEL: ClassVar[str] = "gyro"
    FILE_REQUIRED: ClassVar[tuple[str, ...]] = ("bias_pairs", "residual_rms_dps", "chi2_per_dof", "n_steps")

    lsb_per_dps: number(positive=True) = unit("counts/(deg/s)", "nominal sensitivity of the recording")
    matrix_counts_per_dps: Matrix3 = unit("counts/(deg/s)", "M")
    bias_counts: Vector3 = unit("counts", "b, zero-rate output from the least squares")
    scale_counts_per_dps: Vector3 = unit("counts/(deg/s)", "diag(M)")
    nonorthogonality: Nonorthogonality = unit("-", "m_ij = M_ij / M_ii")
    sigma: GyroSigma = unit("-", "1-sigma: b_* counts, k_* counts/(deg/s), m_* dimensionless")
    bias_pairs: list[BiasPair] = unit("-", "zero rate from each +/- pair", default_factory=list)
    residual_rms_dps: number(allow_nan=True) = unit("deg/s", "RMS of the residuals", default=float("nan"))
    chi2_per_dof: number(allow_nan=True) = unit("-", "weighted misfit per dof", default=float("nan"))
    n_steps: integer() = unit("-", "rate steps used", default=0)
    g_sensitivity: Optional[GSensitivity] = unit("counts/g", "G's determined columns, or null", default=None)
    uncertainty: Optional[dict] = unit("-", "expanded uncertainty U = k u_c in sigma's keys, k, combined_standard and "
                                       "the budget of Type A and B contributions (docs/uncertainty.md, \"The "
                                       "gyroscope\"); absent: none was made", default=None)

    @field_validator("g_sensitivity")
    @classmethod
    def _axes(cls, gs: Any) -> Any:
        if gs is not None and not all(x in SENSOR_AXES for x in gs["inputs"]):
            raise field_problem("inputs", "a list of input axes (x, y, z)")
        return gs

    @model_validator(mode="after")
    def _consistent(self) -> "GyroCalibration":
        if not np.all(np.diag(self.matrix_counts_per_dps) != 0):
            raise field_problem("matrix_counts_per_dps", "a 3x3 matrix with a non-zero diagonal")
        if not np.allclose(self.scale_counts_per_dps, np.diag(self.matrix_counts_per_dps), rtol=1e-12, atol=0):
            raise field_problem("scale_counts_per_dps", "the diagonal of matrix_counts_per_dps")
        return self

    def g_matrix(self) -> np.ndarray:
        """(3, 3) g-sensitivity G (counts per g; zero columns for inputs not determined)."""
        if not self.g_sensitivity:
            return np.zeros((3, 3))
        return np.asarray(self.g_sensitivity["matrix_counts_per_g"], float)

    def predict_counts(self, w_dps: np.ndarray) -> np.ndarray:
        """Model output ``M w + b`` (N, 3) counts for true rates ``w_dps`` (N, 3), sensor frame, deg/s."""
        w = np.atleast_2d(np.asarray(w_dps, float))
        return w @ self.matrix_counts_per_dps.T + self.bias_counts

    def apply(self, counts: np.ndarray, f_g: np.ndarray | None = None) -> np.ndarray:
        """Calibrated rate ``M^-1 (counts - b - G f)`` (N, 3), sensor frame, deg/s, from raw counts (N, 3).

        ``f_g`` (N, 3) the specific force in g, sensor frame, needed only to remove the g-sensitivity.
        """
        c = np.atleast_2d(np.asarray(counts, float)) - self.bias_counts
        if f_g is not None and self.g_sensitivity:
            c = c - np.atleast_2d(np.asarray(f_g, float)) @ self.g_matrix().T
        return np.linalg.solve(self.matrix_counts_per_dps, c.T).T
