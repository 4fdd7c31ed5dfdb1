"""Accelerometer result: the model ``a = M f + b(T) + effects`` (counts) and its inverse.

``a`` raw counts, ``f`` specific force in g in the sensor frame, ``T`` the sensor's temperature in C.
Section ``accelerometer`` of the calibration file (docs/calibration-file.md).
"""

from __future__ import annotations

from typing import Any, ClassVar, Optional

import numpy as np
from pydantic import ConfigDict, Field, field_validator, model_validator
from typing_extensions import NotRequired, TypedDict

from calib.discovery.effects import LIBRARY, TIME_EFFECTS, effect_counts, validate_effect
from calib.errors import CalibError
from calib.numerics.design import MISFIT_LEVEL, misfit
from calib.file.fields import Matrix3, Vector3, array, field_problem, integer, number, unit
from calib.file.section import CalibrationSection, choice, WithUncertainty

MODELS = ("triangular", "full", "diagonal")
MISALIGNMENT_NAMES = ("alpha_yz", "alpha_zy", "alpha_zx")

Angle = number()



def triangular_matrix(scale_counts_per_g, angles) -> np.ndarray:
    """``diag(k) T^-1`` (counts/g) of the seed's triangular model from scales and angles (rad)."""
    a_yz, a_zy, a_zx = (float(angles[n]) for n in MISALIGNMENT_NAMES)
    t = np.array([[1.0, -a_yz, a_zy], [0.0, 1.0, -a_zx], [0.0, 0.0, 1.0]])
    return np.diag(np.asarray(scale_counts_per_g, float)) @ np.linalg.inv(t)

class Misalignment(TypedDict):
    """The triangular model's angles, radians: ``T = [[1, -alpha_yz, alpha_zy], [0, 1, -alpha_zx], [0, 0, 1]]``."""

    __pydantic_config__ = ConfigDict(extra="forbid")  # type: ignore[misc]
    alpha_yz: Angle
    alpha_zy: Angle
    alpha_zx: Angle


class AccelSigma(TypedDict):
    """1-sigma of the calibration's quantities (same units and shapes); further keys are kept as they are."""

    __pydantic_config__ = ConfigDict(extra="allow")  # type: ignore[misc]
    bias_counts: array(3, nonneg=True, as_list=True)
    scale_counts_per_g: array(3, nonneg=True, as_list=True)
    matrix_counts_per_g: array(3, 3, nonneg=True, as_list=True)
    misalignment: NotRequired[Optional[dict]]
    temperature: NotRequired[Optional[dict]]


class ThermalModel(CalibrationSection):
    """Bias polynomial in temperature: ``b_j(T) = b_j + sum_s coefficients[j][s-1] (T - t0)^s``.

    Attributes
    ----------
    t0_c : reference temperature, C.
    order : polynomial order S (1..3).
    coefficients : (3, S) counts per C^s (file key ``bias_coefficients``).
    """

    model_config = ConfigDict(frozen=True)
    t0_c: number() = unit("C", "reference temperature t0")
    order: integer(minimum=1, maximum=3) = unit("-", "polynomial order S")
    coefficients: array(3, None) = unit("counts/C^s", "(3, S) bias coefficients", alias="bias_coefficients")

    @model_validator(mode="after")
    def _order_matches(self) -> "ThermalModel":
        if self.coefficients.shape != (3, self.order):
            raise field_problem("bias_coefficients", f"shape [3, {self.order}] (order {self.order}), "
                                f"got {list(self.coefficients.shape)}")
        return self

    def bias_offset_counts(self, temp_c: np.ndarray) -> np.ndarray:
        """Bias change (N, 3), counts, at temperatures ``temp_c`` (N,), C."""
        dt = np.asarray(temp_c, float) - self.t0_c
        powers = np.stack([dt ** (s + 1) for s in range(self.order)], axis=-1)  # (N, S)
        return powers @ np.asarray(self.coefficients, float).T  # (N, 3)


class FitSummary(CalibrationSection):
    """How the solve went: steps, samples, residual RMS (g), chi2/dof (NaN when dof = 0; null in the file)."""

    model_config = ConfigDict(frozen=True)
    steps: integer(minimum=1) = unit("-", "static steps used")
    samples: integer(minimum=1) = unit("-", "samples in those steps")
    residual_rms_g: number(nonneg=True) = unit("g", "RMS of the fit residuals")
    chi2_per_dof: number(nonneg=True, null_is_nan=True) = unit("-", "weighted misfit per degree of freedom")
    method: str = Field("", description="solver method (pinv, flip, combinations, magnitude)")


class AccelCalibration(WithUncertainty):
    """A solved accelerometer calibration (raw counts <-> specific force in g, sensor frame).

    Attributes
    ----------
    model : triangular | full | diagonal (flip method).
    lsb_per_g : nominal sensitivity at the recorded range, counts/g.
    bias_counts : (3,) bias at t0 (or without thermal model), counts.
    scale_counts_per_g : (3,) diagonal of the matrix, counts/g.
    misalignment : {alpha_yz, alpha_zy, alpha_zx} in radians (triangular model) or None.
    misalignment_unit : always "rad".
    matrix_counts_per_g : (3, 3) M in a = M f + b, counts/g.
    temperature : ThermalModel or None.
    effects : added effect terms (discrepancy workflow), each a dict (docs/discrepancy.md).
    sigma : 1-sigma of each quantity above, same keys and shapes.
    fit : FitSummary.
    """

    CAL_TYPE: ClassVar[str] = "accelerometer"
    #: the unit :meth:`apply` takes and the unit it gives (``calib.file.apply`` checks the recording's)
    INPUT_UNIT: ClassVar[str] = "counts"
    OUTPUT_UNIT: ClassVar[str] = "g"
    model_config = ConfigDict(frozen=True, extra="forbid")  # a misspelt key is refused (docs/calibration-file.md)

    model: choice(*MODELS) = unit("-", "triangular (seed), full (12 parameters), diagonal (flip method)")
    lsb_per_g: number(positive=True) = unit("counts/g", "nominal sensitivity of the recorded range")
    bias_counts: Vector3 = unit("counts", "b at t0 (or without thermal model)")
    scale_counts_per_g: array(3, positive=True) = unit("counts/g", "diagonal of M")
    misalignment: Optional[Misalignment] = unit("rad", "triangular model's angles, null otherwise", default=None)
    misalignment_unit: choice("rad") = unit("-", "unit of misalignment", default="rad")
    matrix_counts_per_g: Matrix3 = unit("counts/g", "M")
    temperature: Optional[ThermalModel] = unit("-", "thermal bias model or null", default=None)
    effects: list[dict] = unit("-", "terms added by rig discover -o", default_factory=list)
    sigma: AccelSigma = unit("-", "1-sigma of each quantity, its units")
    fit: FitSummary = unit("-", "fit summary")
    uncertainty: Optional[dict] = unit("-", "expanded uncertainty U = k u_c in sigma's keys, k, combined_standard and "
                                       "the budget of Type A and B contributions (docs/uncertainty.md); absent: "
                                       "none was made", default=None)

    @field_validator("effects", mode="before")
    @classmethod
    def _valid_effects(cls, effects: Any) -> Any:
        if not isinstance(effects, list) or not all(isinstance(e, dict) and "name" in e for e in effects):
            raise ValueError("expected a list of effects, each a mapping with a name")
        for i, e in enumerate(effects):
            problem = validate_effect(e)
            if problem:
                raise field_problem(f"[{i}]", problem)
        return [dict(e) for e in effects]

    @model_validator(mode="after")
    def _consistent(self) -> "AccelCalibration":
        m = self.matrix_counts_per_g
        if not np.allclose(np.diag(m), self.scale_counts_per_g, rtol=1e-9, atol=1e-9):
            raise field_problem("scale_counts_per_g", "must equal the diagonal of matrix_counts_per_g")
        if abs(np.linalg.det(m)) < 1e-12 * np.prod(np.abs(np.diag(m))):
            raise field_problem("matrix_counts_per_g", "matrix is singular")
        if self.model == "triangular":
            if self.misalignment is None:
                raise field_problem("misalignment", "expected {alpha_yz, alpha_zy, alpha_zx} in radians for the "
                                                    "triangular model")
            if np.any(np.abs(np.tril(m, -1)) > 0):
                raise field_problem("matrix_counts_per_g", "the triangular model has zeros below the diagonal")
            implied = triangular_matrix(self.scale_counts_per_g, self.misalignment)
            if not np.allclose(implied, m, rtol=0, atol=1e-6 * float(np.max(np.abs(np.diag(m))))):
                raise field_problem("misalignment", "the angles contradict matrix_counts_per_g (with "
                                                    "T = [[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]], M = diag(k) T^-1)")
        elif self.misalignment is not None:
            raise field_problem("misalignment", f"expected null for the {self.model} model")
        return self

    def n_parameters(self) -> int:
        """How many quantities the solve estimated: the bias (3), the free entries of the matrix (those
        with a sigma: 3 diagonal, 6 triangular, 9 full), the thermal coefficients (3 per order) and each
        added effect's estimates."""
        m_sigma = np.asarray((self.sigma or {}).get("matrix_counts_per_g") or np.eye(3), float)
        n = 3 + int(np.count_nonzero(np.nan_to_num(m_sigma, nan=1.0)))
        if self.temperature is not None:
            n += 3 * int(self.temperature.order)
        for effect in self.effects or ():
            n += int(np.size(np.asarray(effect.get("estimate", []), dtype=object)))
        return n

    def degrees_of_freedom(self) -> int:
        """Residuals less estimated quantities: one residual per axis and step (one per step for the magnitude
        method, which fits |f|) less :meth:`n_parameters`. 0 or less: an exactly determined fit (the flip
        method on six faces), whose residual says nothing about the noise."""
        per_step = 1 if self.fit.method == "magnitude" else 3
        return per_step * int(self.fit.steps) - self.n_parameters()

    def misfit(self, level: float = MISFIT_LEVEL) -> tuple[bool, float]:
        """Whether the fit is worse than its noise explains, by the one rule
        (:func:`calib.numerics.design.misfit`: chi-square beyond its upper ``level`` quantile), and the
        upper-tail probability. The solver rescaled the sigmas by the Birge ratio on the same rule, so a
        True here means "the sigmas carry the misfit". The degrees of freedom: one residual per axis and
        step (one per step for the magnitude method, which fits |f|) less :meth:`n_parameters`."""
        fit = self.fit
        chi2_per_dof = float(fit.chi2_per_dof) if fit.chi2_per_dof is not None else float("nan")
        dof = self.degrees_of_freedom()
        if dof <= 0 or not np.isfinite(chi2_per_dof):
            return False, 1.0
        return misfit(chi2_per_dof * dof, dof, level)

    def bias_at(self, temp_c=None, n: int = 1) -> np.ndarray:
        """Bias (N, 3) in counts at temperatures ``temp_c`` (N,), C."""
        b = np.broadcast_to(np.asarray(self.bias_counts, float), (n, 3)).copy()
        if self.temperature is not None:
            if temp_c is None:
                raise CalibError("this calibration has temperature terms: apply() needs temp_c")
            t = np.broadcast_to(np.asarray(temp_c, float), (n,))
            if not np.all(np.isfinite(t)):
                raise CalibError("apply(): temp_c has NaN values but the calibration has temperature terms")
            b = b + self.temperature.bias_offset_counts(t)
        return b

    def predict_counts(self, f_g, temp_c=None, t_s=None) -> np.ndarray:
        """Forward model: counts (N, 3) for specific force ``f_g`` (N, 3), g, sensor frame.

        ``temp_c`` (N,) C and ``t_s`` (N,) s from session start when the terms need them.
        """
        f = np.atleast_2d(np.asarray(f_g, float))
        out = f @ np.asarray(self.matrix_counts_per_g, float).T + self.bias_at(temp_c, len(f))
        if self.effects:
            out = out + effect_counts(self.effects, f, temp_c, t_s, self.lsb_per_g, self.matrix_counts_per_g)
        return out

    def apply_needs(self) -> tuple[str, ...]:
        """What :meth:`apply` needs besides the counts: ``"temp_c"`` (a thermal model or a temperature
        effect), ``"t_s"`` (a time effect: bias_drift, bias_jump, thermal_gradient)."""
        on_sensor = [LIBRARY[e["name"]] for e in self.effects if LIBRARY[e["name"]].on_sensor]
        temp = self.temperature is not None or any("temp" in lib.needs for lib in on_sensor)
        time = any(lib.name in TIME_EFFECTS for lib in on_sensor)
        return ("temp_c",) * temp + ("t_s",) * time

    def apply(self, counts, temp_c=None, t_s=None) -> np.ndarray:
        """Specific force (N, 3) in g, sensor frame, from raw counts (N, 3).

        Inverts a = M f + b(T) (+ effects, by fixed-point iteration when they are nonlinear).
        """
        a = np.atleast_2d(np.asarray(counts, float))
        if a.shape[1] != 3:
            raise CalibError(f"apply(): counts must have 3 columns, got shape {a.shape}")
        m = np.asarray(self.matrix_counts_per_g, float)
        y = a - self.bias_at(temp_c, len(a))
        f = np.linalg.solve(m, y.T).T
        if self.effects:
            for _ in range(50):
                extra = effect_counts(self.effects, f, temp_c, t_s, self.lsb_per_g, self.matrix_counts_per_g)
                f_new = np.linalg.solve(m, (y - extra).T).T
                if np.max(np.abs(f_new - f)) < 1e-12:
                    f = f_new
                    break
                f = f_new
        return f
