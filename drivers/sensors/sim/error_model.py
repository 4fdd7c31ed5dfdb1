"""Sensor error models: how a true physical input becomes a sensor output (before quantisation).

Accelerometer, output in g (multiplied by the configured sensitivity and
rounded to counts by the chip model)::

    a = (1 + scale_tempco * dT) * (matrix @ f)
        + bias_g + bias_tempco * dT + bias_tempco2 * dT^2 + bias_drift * t
        + scale_nonlinearity * f^2 + cross_axis_nonlinearity @ (fx fy, fy fz, fz fx)
        + hysteresis (+h/2 after heating, -h/2 after cooling) + white noise
        + bias_tempco3 * dT^3 + thermal_gradient * dT/dt + bias_jump * [t >= bias_jump_t_s]

(the last three are off by default and then leave the output bit-identical)

with dT = T - t_ref_c. ``matrix`` is dimensionless (diagonal = scale factor,
off-diagonal = cross-axis / misalignment). Datasheet-class magnitudes
(docs/sensors.md) come from :meth:`AccelErrorModel.draw`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from drivers.sensors.chips import CHIPS


def matrix_from_triangular(scale, alpha_yz: float, alpha_zy: float, alpha_zx: float) -> np.ndarray:
    """diag(k) @ T^-1 with T = [[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]] (the seed paper's model)."""
    t = np.array([[1.0, -alpha_yz, alpha_zy], [0.0, 1.0, -alpha_zx], [0.0, 0.0, 1.0]])
    return np.diag(np.asarray(scale, float)) @ np.linalg.inv(t)


def _v(x=0.0):
    return field(default_factory=lambda: [float(x)] * 3)


@dataclass
class AccelErrorModel:
    """Accelerometer errors (units in the names; see the module docstring for the equation)."""

    matrix: list = field(default_factory=lambda: np.eye(3).tolist())
    bias_g: list = _v()
    bias_tempco_g_per_c: list = _v()
    bias_tempco2_g_per_c2: list = _v()
    scale_tempco_per_c: list = _v()
    scale_nonlinearity: list = _v()  # g per g^2 along the same axis
    cross_axis_nonlinearity: list = field(default_factory=lambda: np.zeros((3, 3)).tolist())  # g per g^2
    bias_drift_g_per_s: list = _v()
    thermal_hysteresis_g: list = _v()
    bias_tempco3_g_per_c3: list = _v()
    thermal_gradient_g_per_c_per_s: list = _v()  # g per (C/s) of temperature rate
    bias_jump_g: list = _v()
    bias_jump_t_s: float = 0.0  # sampler (clock) time of the bias jump, s
    noise_density_g_per_rthz: list = _v(400e-6)
    t_ref_c: float = 25.0
    hysteresis_band_c: float = 0.5

    @classmethod
    def draw(cls, rng: np.random.Generator, chip: str = "MPU-9150") -> "AccelErrorModel":
        """Datasheet-class random errors for ``chip`` (MPU-9150 or ADXL345); effects beyond the
        seed's model (quadratic tempco, scale tempco, nonlinearity, drift, hysteresis) are 0."""
        if chip == "ADXL345":
            bias = rng.normal(0, [0.02, 0.02, 0.03])
            scale = 1 + rng.normal(0, 0.02, 3)
            tempco = rng.normal(0, [0.4e-3, 0.4e-3, 0.6e-3])
        else:
            bias = np.clip(rng.normal(0, [0.025, 0.025, 0.04]), [-0.05, -0.05, -0.08], [0.05, 0.05, 0.08])
            scale = 1 + np.clip(rng.normal(0, 0.01, 3), -0.03, 0.03)
            tempco = rng.normal(0, [0.3e-3, 0.3e-3, 0.5e-3])
        angles = rng.normal(0, 0.005, 3)  # rad, 0.5 % cross-axis class
        m = matrix_from_triangular(scale, *angles)
        density = CHIPS[chip if chip in CHIPS else "MPU-9150"].accel_noise_density_g_rthz  # the datasheet's
        return cls(matrix=m.tolist(), bias_g=bias.tolist(), bias_tempco_g_per_c=tempco.tolist(),
                   noise_density_g_per_rthz=list(density))

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        return {k: (np.asarray(v, float).tolist() if isinstance(v, (list, np.ndarray)) else v) for k, v in d.items()}

    @classmethod
    def from_dict(cls, d: dict) -> "AccelErrorModel":
        allowed = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - allowed
        if unknown:
            raise ValueError(f"unknown accelerometer error-model fields: {', '.join(sorted(unknown))}")
        out = cls(**{k: (np.asarray(v, float).tolist() if isinstance(v, (list, tuple, np.ndarray)) else v)
                     for k, v in d.items()})
        if np.asarray(out.matrix).shape != (3, 3) or np.asarray(out.cross_axis_nonlinearity).shape != (3, 3):
            raise ValueError("matrix and cross_axis_nonlinearity must be 3x3")
        return out

    def _term(self, name: str) -> tuple[np.ndarray, bool]:
        """A field's values as an array and whether any is non-zero, made once per value the field holds (the
        sampler asks at every block of samples; a field given a new value is read anew)."""
        cache = self.__dict__.setdefault("_terms", {})
        value = getattr(self, name)
        hit = cache.get(name)
        if hit is None or hit[0] is not value:
            arr = np.asarray(value, float)
            hit = cache[name] = (value, arr, bool(np.any(arr)))
        return hit[1], hit[2]

    def output_g(self, f_g: np.ndarray, temp_c: np.ndarray, t_s: np.ndarray, heating: np.ndarray,
                 temp_rate: np.ndarray | None = None) -> np.ndarray:
        """Noise-free output (N, 3), g. ``heating`` (N,) is +1 after heating, -1 after cooling, 0 unknown;
        ``temp_rate`` (N,) the true dT/dt, C/s (needed only with ``thermal_gradient_g_per_c_per_s``).

        A term whose coefficients are all 0 is left out (adding its 0 leaves every finite output as it was, bit
        for bit)."""
        f = np.asarray(f_g, float)
        dt = (np.asarray(temp_c, float) - self.t_ref_c)[:, None]
        out = f @ self._term("matrix")[0].T
        scale_tc, on = self._term("scale_tempco_per_c")
        if on:
            out = out * (1 + scale_tc * dt)
        out = out + self._term("bias_g")[0]
        for name, x in (("bias_tempco_g_per_c", dt), ("bias_tempco2_g_per_c2", dt**2)):
            coeff, on = self._term(name)
            if on:
                out = out + coeff * x
        drift, on = self._term("bias_drift_g_per_s")
        if on:
            out = out + drift * np.asarray(t_s)[:, None]
        nonlin, on = self._term("scale_nonlinearity")
        if on:
            out = out + nonlin * f**2
        cross, on = self._term("cross_axis_nonlinearity")
        if on:
            prods = np.stack([f[:, 0] * f[:, 1], f[:, 1] * f[:, 2], f[:, 2] * f[:, 0]], axis=1)
            out = out + prods @ cross.T
        hyst, on = self._term("thermal_hysteresis_g")
        if on:
            out = out + 0.5 * hyst * np.asarray(heating, float)[:, None]
        return self._extra_g(out, dt, t_s, temp_rate)

    def _extra_g(self, out, dt, t_s, temp_rate):
        """The cubic tempco, thermal-gradient and bias-jump terms (only those switched on)."""
        cubic, on = self._term("bias_tempco3_g_per_c3")
        if on:
            out = out + cubic * dt**3
        gradient, on = self._term("thermal_gradient_g_per_c_per_s")
        if on:
            if temp_rate is None:
                raise ValueError("thermal_gradient_g_per_c_per_s needs the temperature rate")
            out = out + gradient * np.asarray(temp_rate, float)[:, None]
        jump, on = self._term("bias_jump_g")
        if on:
            out = out + jump * (np.asarray(t_s, float) >= self.bias_jump_t_s)[:, None]
        return out

    def needs_rate(self) -> bool:
        return self._term("thermal_gradient_g_per_c_per_s")[1]


class HysteresisState:
    """Tracks whether the sensor was last heated (+1) or cooled (-1), with a dead band."""

    def __init__(self, band_c: float = 0.5) -> None:
        self.band_c = band_c
        self.state = 0
        self.ref: float | None = None

    def update(self, temp_c: np.ndarray) -> np.ndarray:
        out = np.empty(len(temp_c))
        for i, t in enumerate(np.asarray(temp_c, float)):
            if self.ref is None:
                self.ref = t
            if self.state >= 0 and t < self.ref - self.band_c:
                self.state, self.ref = -1, t  # started cooling
            elif self.state <= 0 and t > self.ref + self.band_c:
                self.state, self.ref = 1, t  # started heating
            elif (self.state > 0 and t > self.ref) or (self.state < 0 and t < self.ref):
                self.ref = t  # follow the extreme of the current leg
            out[i] = self.state
        return out


@dataclass
class GyroErrorModel:
    """Gyroscope errors: w_out = matrix @ w + bias_dps + g_sensitivity_dps_per_g @ f + noise."""

    matrix: list = field(default_factory=lambda: np.eye(3).tolist())
    bias_dps: list = _v()
    g_sensitivity_dps_per_g: list = field(default_factory=lambda: np.zeros((3, 3)).tolist())
    noise_density_dps_per_rthz: list = _v(0.005)

    @classmethod
    def draw(cls, rng: np.random.Generator, chip: str = "MPU-9150") -> "GyroErrorModel":
        m = np.diag(1 + np.clip(rng.normal(0, 0.01, 3), -0.03, 0.03)) + np.where(
            np.eye(3) > 0, 0.0, rng.normal(0, 0.007, (3, 3)))
        return cls(matrix=m.tolist(), bias_dps=np.clip(rng.normal(0, 8, 3), -20, 20).tolist(),
                   g_sensitivity_dps_per_g=(rng.normal(0, 0.05, (3, 3))).tolist())

    def output_dps(self, w_dps: np.ndarray, f_g: np.ndarray) -> np.ndarray:
        return w_dps @ np.asarray(self.matrix).T + np.asarray(self.bias_dps) + f_g @ np.asarray(
            self.g_sensitivity_dps_per_g).T

    def to_dict(self) -> dict:
        return {k: np.asarray(v, float).tolist() for k, v in dataclasses.asdict(self).items()}


@dataclass
class MagErrorModel:
    """Magnetometer errors: m_out = soft_iron @ m + hard_iron_ut + noise."""

    soft_iron: list = field(default_factory=lambda: np.eye(3).tolist())
    hard_iron_ut: list = _v()
    noise_ut: float = 0.3

    @classmethod
    def draw(cls, rng: np.random.Generator, chip: str = "MPU-9150") -> "MagErrorModel":
        s = np.eye(3) + rng.normal(0, 0.03, (3, 3))
        s = 0.5 * (s + s.T)
        return cls(soft_iron=s.tolist(), hard_iron_ut=rng.normal(0, 20, 3).tolist())

    def output_ut(self, m_ut: np.ndarray) -> np.ndarray:
        return m_ut @ np.asarray(self.soft_iron).T + np.asarray(self.hard_iron_ut)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        return {k: (np.asarray(v, float).tolist() if isinstance(v, list) else v) for k, v in d.items()}
