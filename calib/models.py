"""Calibration results: the accelerometer model ``a = M f + b(T) + effects`` and its inverse."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from calib.errors import CalibError

MODELS = ("triangular", "full", "diagonal")


@dataclass(frozen=True)
class ThermalModel:
    """Bias polynomial in temperature: b_j(T) = b_j + sum_s coefficients[j][s-1] (T - t0)^s.

    Attributes
    ----------
    t0_c : reference temperature, C.
    order : polynomial order S.
    coefficients : (3, S) counts per C^s.
    """

    t0_c: float
    order: int
    coefficients: np.ndarray

    def bias_offset_counts(self, temp_c: np.ndarray) -> np.ndarray:
        dt = np.asarray(temp_c, float) - self.t0_c
        powers = np.stack([dt ** (s + 1) for s in range(self.order)], axis=-1)  # (N, S)
        return powers @ np.asarray(self.coefficients, float).T  # (N, 3)


@dataclass(frozen=True)
class FitSummary:
    steps: int
    samples: int
    residual_rms_g: float
    chi2_per_dof: float
    method: str


@dataclass(frozen=True)
class AccelCalibration:
    """A solved accelerometer calibration (raw counts <-> specific force in g).

    Attributes
    ----------
    model : triangular | full | diagonal (flip method).
    lsb_per_g : nominal sensitivity at the recorded range, counts/g.
    bias_counts : (3,) bias at t0 (or without thermal model), counts.
    scale_counts_per_g : (3,) diagonal of the matrix, counts/g.
    misalignment : {alpha_yz, alpha_zy, alpha_zx} in radians (triangular model) or None.
    matrix_counts_per_g : (3, 3) M in a = M f + b, counts/g.
    temperature : ThermalModel or None.
    effects : added effect terms (discrepancy workflow), each a dict.
    sigma : 1-sigma of each quantity above, same keys and shapes.
    fit : FitSummary.
    """

    model: str
    lsb_per_g: float
    bias_counts: np.ndarray
    scale_counts_per_g: np.ndarray
    misalignment: dict | None
    matrix_counts_per_g: np.ndarray
    temperature: ThermalModel | None
    sigma: dict
    fit: FitSummary
    effects: list = field(default_factory=list)

    def bias_at(self, temp_c=None, n: int = 1) -> np.ndarray:
        """Bias (N, 3) in counts at temperatures ``temp_c`` (C)."""
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
        """Forward model: counts (N, 3) for specific force f_g (N, 3) in g."""
        f = np.atleast_2d(np.asarray(f_g, float))
        out = f @ np.asarray(self.matrix_counts_per_g, float).T + self.bias_at(temp_c, len(f))
        if self.effects:
            from calib.effects import effect_counts
            out = out + effect_counts(self.effects, f, temp_c, t_s, self.lsb_per_g, self.matrix_counts_per_g)
        return out

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
            from calib.effects import effect_counts
            for _ in range(50):
                extra = effect_counts(self.effects, f, temp_c, t_s, self.lsb_per_g, self.matrix_counts_per_g)
                f_new = np.linalg.solve(m, (y - extra).T).T
                if np.max(np.abs(f_new - f)) < 1e-12:
                    f = f_new
                    break
                f = f_new
        return f
