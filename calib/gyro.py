"""Gyroscope calibration from turntable rate steps (12-parameter model).

Model, sensor frame, per rate step ``k``::

    counts_k = M @ w_k + b

with ``w_k`` (3,) the true angular rate of the step in the sensor frame, deg/s,
``M`` (3, 3) counts per deg/s (diagonal = scale factors ``k_x, k_y, k_z``,
off-diagonal = non-orthogonality / cross-axis couplings) and ``b`` (3,) the
zero-rate output, counts. In the simulator's convention
(:class:`drivers.sensors.sim.error_model.GyroErrorModel`)
``M = lsb_per_dps * matrix`` and ``b = lsb_per_dps * (bias_dps + G f)`` where
``G f`` is the g-sensitivity for the (constant) specific force of the step.

The seed method (Liang, Xu, Cao 2017): each axis spun at +-25, +-40 and +-63
deg/s (18 modes), 100 s at 10 Hz per mode; the zero rate is the mean of each
+ / - pair, the scale factors and non-orthogonality come from least squares.
:func:`solve_gyro` reports the pair biases and solves all 12 parameters by
weighted least squares over every step.

Parameter names: ``b_x`` (counts), ``k_x`` (= M_xx, counts per deg/s) and
``m_xy`` (= M_xy / M_xx, dimensionless: how much of the rate about input
axis y appears on output axis x, relative to the x scale).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from calib.design import solve_wls
from calib.errors import CalibError, CalibrationFileError, ObservabilityError

AXES = "xyz"
OFF_DIAGONAL = tuple((i, j) for i in range(3) for j in range(3) if i != j)


# ----------------------------------------------------------------------------------------------
# shared helpers (also used by calib.magnetometer for its A h + B model)
# ----------------------------------------------------------------------------------------------

def check_array(owner: str, name: str, value: Any, shape: tuple, positive: bool = False) -> np.ndarray:
    """Return ``value`` as a float array of ``shape``; raise :class:`CalibError` otherwise.

    ``owner`` and ``name`` go into the one-line message (``Owner.name: expected ...``).
    """
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise CalibError(f"{owner}.{name}: expected a numeric array of shape {shape}") from None
    if v.shape != shape:
        raise CalibError(f"{owner}.{name}: expected shape {shape}, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise CalibError(f"{owner}.{name}: contains NaN or infinity")
    if positive and not np.all(v > 0):
        raise CalibError(f"{owner}.{name}: every value must be > 0")
    return v


@dataclass(frozen=True)
class AffineFit:
    """Weighted least-squares fit of ``y_k = P @ x_k + c`` (3 outputs, 3 inputs).

    Attributes
    ----------
    matrix : (3, 3) P, units of y per unit of x.
    offset : (3,) c, units of y.
    axis_fits : one :class:`calib.design.AxisFit` per output axis, parameters ``[P_i0, P_i1, P_i2, c_i]``.
    residuals : (K, 3) y - P x - c, units of y.
    chi2_per_dof : total chi-square over total degrees of freedom (nan when dof = 0).
    """

    matrix: np.ndarray
    offset: np.ndarray
    axis_fits: tuple
    residuals: np.ndarray
    chi2_per_dof: float


def affine_design(x: np.ndarray) -> np.ndarray:
    """(K, 4) design ``[x_x, x_y, x_z, 1]`` shared by every output axis."""
    return np.column_stack([np.asarray(x, float), np.ones(len(x))])


def input_coverage(x: np.ndarray, rel_tol: float = 1e-9) -> tuple[list[int], bool]:
    """Which input axes the rows leave undetermined, and whether ``[x, 1]`` has full rank.

    Returns
    -------
    missing : input-axis indices never excited (every |x_j| tiny compared with max |x|).
    full_rank : True when the (K, 4) design ``[x, 1]`` determines all 4 parameters.
    """
    x = np.asarray(x, float)
    scale = float(np.max(np.abs(x))) if x.size else 0.0
    missing = [j for j in range(3) if x.size == 0 or np.max(np.abs(x[:, j])) <= rel_tol * max(scale, 1e-300)]
    g = affine_design(x)
    if g.shape[0] < 4:
        return missing, False
    norm = np.linalg.norm(g, axis=0)
    norm[norm == 0] = 1.0
    sv = np.linalg.svd(g / norm, compute_uv=False)
    return missing, bool(sv[-1] > 1e-10 * sv[0])


def fit_affine(x: np.ndarray, y: np.ndarray, sem: np.ndarray, param_names: list[list[str]]) -> AffineFit:
    """Fit ``y = P x + c`` per output axis with :func:`calib.design.solve_wls` (weights 1/sem).

    The caller checks observability first (:func:`input_coverage`).
    """
    g = affine_design(x)
    fits = [solve_wls(g, y[:, i], sem[:, i], param_names[i]) for i in range(3)]
    p = np.array([f.params[:3] for f in fits])
    c = np.array([f.params[3] for f in fits])
    chi2 = sum(f.chi2 for f in fits)
    dof = sum(f.dof for f in fits)
    res = np.column_stack([f.residuals for f in fits])
    return AffineFit(p, c, tuple(fits), res, chi2 / dof if dof > 0 else float("nan"))


# ----------------------------------------------------------------------------------------------
# inputs
# ----------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RateStepMeans:
    """One row per constant-rate step of a gyroscope calibration.

    Attributes
    ----------
    names : (K,) step names.
    rate_nominal_dps : (K, 3) true angular rate of the step in the sensor frame, deg/s.
    mean_counts : (K, 3) mean raw gyroscope output, counts.
    sem_counts : (K, 3) standard error of each mean (sample std / sqrt(n)), counts, > 0.
    n_samples : (K,) samples per step.
    lsb_per_dps : nominal sensitivity at the recorded range, counts per deg/s, > 0.
    """

    names: tuple
    rate_nominal_dps: np.ndarray
    mean_counts: np.ndarray
    sem_counts: np.ndarray
    n_samples: np.ndarray
    lsb_per_dps: float
    f_mean_g: np.ndarray | None = None  # (K, 3) mean specific force during each step, sensor frame, g

    def __post_init__(self) -> None:
        k = len(self.names)
        owner = "RateStepMeans"
        if self.f_mean_g is not None:
            object.__setattr__(self, "f_mean_g", check_array(owner, "f_mean_g", self.f_mean_g, (k, 3)))
        for name, shape in (("rate_nominal_dps", (k, 3)), ("mean_counts", (k, 3)), ("sem_counts", (k, 3)),
                            ("n_samples", (k,))):
            object.__setattr__(self, name, check_array(owner, name, getattr(self, name), shape,
                                                       positive=name in ("sem_counts", "n_samples")))
        try:
            lsb = float(self.lsb_per_dps)
        except (TypeError, ValueError):
            raise CalibError(f"{owner}.lsb_per_dps: expected a number > 0, got {self.lsb_per_dps!r}") from None
        if not (np.isfinite(lsb) and lsb > 0):
            raise CalibError(f"{owner}.lsb_per_dps: expected a finite number > 0, got {self.lsb_per_dps!r}")
        object.__setattr__(self, "lsb_per_dps", lsb)

    def __len__(self) -> int:
        return len(self.names)


# ----------------------------------------------------------------------------------------------
# result
# ----------------------------------------------------------------------------------------------

@dataclass
class BiasPair:
    """Zero-rate output from one + / - pair of rate steps: ``(a_plus + a_minus) / 2``.

    Attributes
    ----------
    axis_spun : "x", "y" or "z" (largest component of the rate), or "xyz" for an oblique rate.
    rate_dps : magnitude of the pair's rate, deg/s.
    bias_counts : (3,) zero-rate output, counts.
    sigma_counts : (3,) 1-sigma of ``bias_counts`` from the two steps' standard errors.
    """

    axis_spun: str
    rate_dps: float
    bias_counts: np.ndarray
    sigma_counts: np.ndarray

    def to_dict(self) -> dict:
        return {"axis_spun": str(self.axis_spun), "rate_dps": float(self.rate_dps),
                "bias_counts": [float(v) for v in self.bias_counts],
                "sigma_counts": [float(v) for v in self.sigma_counts]}


def param_names() -> list[str]:
    """Names of the 12 gyro parameters, in the order b, k, m."""
    return ([f"b_{a}" for a in AXES] + [f"k_{a}" for a in AXES]
            + [f"m_{AXES[i]}{AXES[j]}" for i, j in OFF_DIAGONAL])


@dataclass
class GyroCalibration:
    """Result of :func:`solve_gyro`; model ``counts = M @ w + b`` (sensor frame).

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
    """

    lsb_per_dps: float
    matrix_counts_per_dps: np.ndarray
    bias_counts: np.ndarray
    scale_counts_per_dps: np.ndarray
    nonorthogonality: dict
    sigma: dict
    bias_pairs: list = field(default_factory=list)
    residual_rms_dps: float = float("nan")
    chi2_per_dof: float = float("nan")
    n_steps: int = 0
    g_sensitivity: dict | None = None  # {inputs, matrix_counts_per_g (3,3), sigma_counts_per_g (3,3)}

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
        """Calibrated rate ``M^-1 (counts - b - G f)`` (N, 3), sensor frame, deg/s, from raw counts (N, 3);
        ``f_g`` (N, 3) the specific force in g, needed only to remove the g-sensitivity."""
        c = np.atleast_2d(np.asarray(counts, float)) - self.bias_counts
        if f_g is not None and self.g_sensitivity:
            c = c - np.atleast_2d(np.asarray(f_g, float)) @ self.g_matrix().T
        return np.linalg.solve(self.matrix_counts_per_dps, c.T).T

    def to_dict(self) -> dict:
        """Plain floats, lists and dicts (YAML-friendly); :meth:`from_dict` inverts it exactly."""
        return {
            "lsb_per_dps": float(self.lsb_per_dps),
            "matrix_counts_per_dps": np.asarray(self.matrix_counts_per_dps, float).tolist(),
            "bias_counts": [float(v) for v in self.bias_counts],
            "scale_counts_per_dps": [float(v) for v in self.scale_counts_per_dps],
            "nonorthogonality": {str(k): float(v) for k, v in self.nonorthogonality.items()},
            "sigma": {str(k): float(v) for k, v in self.sigma.items()},
            "bias_pairs": [p.to_dict() for p in self.bias_pairs],
            "residual_rms_dps": float(self.residual_rms_dps),
            "chi2_per_dof": float(self.chi2_per_dof),
            "n_steps": int(self.n_steps),
            "g_sensitivity": None if not self.g_sensitivity else {
                "inputs": list(self.g_sensitivity["inputs"]),
                "matrix_counts_per_g": np.asarray(self.g_sensitivity["matrix_counts_per_g"], float).tolist(),
                "sigma_counts_per_g": np.asarray(self.g_sensitivity["sigma_counts_per_g"], float).tolist()},
        }

    @classmethod
    def from_dict(cls, d: dict, path: str | None = None) -> "GyroCalibration":
        """Validate and rebuild from :meth:`to_dict` output.

        Raises
        ------
        CalibrationFileError naming ``path`` (the file, if any), the field path and what was expected.
        """
        v = DictValidator(path, "gyro")
        v.keys(d, "", set(_GYRO_KEYS), optional={"g_sensitivity"})
        gs = d.get("g_sensitivity")
        if gs is not None:
            v.keys(gs, "g_sensitivity", {"inputs", "matrix_counts_per_g", "sigma_counts_per_g"})
            if not (isinstance(gs["inputs"], list) and all(x in AXES for x in gs["inputs"])):
                v.fail("g_sensitivity.inputs", "a list of input axes (x, y, z)")
            gs = {"inputs": list(gs["inputs"]),
                  "matrix_counts_per_g": v.array(gs, "matrix_counts_per_g", (3, 3), "g_sensitivity"),
                  "sigma_counts_per_g": v.array(gs, "sigma_counts_per_g", (3, 3), "g_sensitivity", nonneg=True)}
        matrix = v.array(d, "matrix_counts_per_dps", (3, 3))
        scale = v.array(d, "scale_counts_per_dps", (3,))
        if not np.all(np.diag(matrix) != 0):
            v.fail("matrix_counts_per_dps", "a 3x3 matrix with a non-zero diagonal")
        if not np.allclose(scale, np.diag(matrix), rtol=1e-12, atol=0):
            v.fail("scale_counts_per_dps", "the diagonal of matrix_counts_per_dps")
        pairs_raw = d["bias_pairs"]
        if not isinstance(pairs_raw, list):
            v.fail("bias_pairs", "a list of {axis_spun, rate_dps, bias_counts, sigma_counts}")
        pairs = []
        for n, p in enumerate(pairs_raw):
            where = f"bias_pairs[{n}]"
            v.keys(p, where, {"axis_spun", "rate_dps", "bias_counts", "sigma_counts"})
            if not isinstance(p["axis_spun"], str):
                v.fail(f"{where}.axis_spun", "a string (x, y, z or xyz)")
            pairs.append(BiasPair(p["axis_spun"], v.number(p, "rate_dps", where),
                                  v.array(p, "bias_counts", (3,), where),
                                  v.array(p, "sigma_counts", (3,), where, nonneg=True)))
        return cls(
            lsb_per_dps=v.number(d, "lsb_per_dps", positive=True),
            matrix_counts_per_dps=matrix,
            bias_counts=v.array(d, "bias_counts", (3,)),
            scale_counts_per_dps=scale,
            nonorthogonality=v.named(d, "nonorthogonality", [f"m_{AXES[i]}{AXES[j]}" for i, j in OFF_DIAGONAL]),
            sigma=v.named(d, "sigma", param_names(), nonneg=True),
            bias_pairs=pairs,
            residual_rms_dps=v.number(d, "residual_rms_dps", allow_nan=True),
            chi2_per_dof=v.number(d, "chi2_per_dof", allow_nan=True),
            n_steps=v.integer(d, "n_steps"),
            g_sensitivity=gs,
        )


_GYRO_KEYS = ("lsb_per_dps", "matrix_counts_per_dps", "bias_counts", "scale_counts_per_dps", "nonorthogonality",
              "sigma", "bias_pairs", "residual_rms_dps", "chi2_per_dof", "n_steps")


class DictValidator:
    """Field checks for ``from_dict``: every failure is a :class:`CalibrationFileError` with the field path."""

    def __init__(self, path: str | None, what: str) -> None:
        self.path, self.what = path, what

    def fail(self, fld: str, expected: str):
        raise CalibrationFileError(self.path, f"{self.what}.{fld}" if fld else self.what, expected)

    @staticmethod
    def _at(where: str, key: str) -> str:
        return f"{where}.{key}" if where else key

    def keys(self, d: Any, where: str, required: set, optional: set = frozenset()) -> None:
        if not isinstance(d, dict):
            self.fail(where, "a mapping")
        missing = sorted(required - set(d))
        if missing:
            self.fail(self._at(where, missing[0]), "missing (required field)")
        unknown = sorted(set(d) - required - set(optional))
        if unknown:
            self.fail(self._at(where, str(unknown[0])), "unknown field")

    def number(self, d: dict, key: str, where: str = "", positive: bool = False, allow_nan: bool = False) -> float:
        x = d[key]
        fld = self._at(where, key)
        if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
            self.fail(fld, f"a number, got {type(x).__name__}")
        x = float(x)
        if np.isnan(x) and allow_nan:
            return x
        if not np.isfinite(x) or (positive and not x > 0):
            self.fail(fld, "a finite number" + (" > 0" if positive else "") + f", got {x}")
        return x

    def integer(self, d: dict, key: str, where: str = "") -> int:
        x = d[key]
        if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or x < 0:
            self.fail(self._at(where, key), f"a non-negative integer, got {x!r}")
        return int(x)

    def array(self, d: dict, key: str, shape: tuple, where: str = "", nonneg: bool = False) -> np.ndarray:
        fld = self._at(where, key)
        try:
            a = np.asarray(d[key], dtype=float)
        except (TypeError, ValueError):
            self.fail(fld, f"a numeric array of shape {list(shape)}")
        if a.shape != shape:
            self.fail(fld, f"shape {list(shape)}, got {list(a.shape)}")
        if not np.all(np.isfinite(a)) or (nonneg and not np.all(a >= 0)):
            self.fail(fld, "finite" + (" non-negative" if nonneg else "") + " values")
        return a

    def named(self, d: dict, key: str, names: list[str], nonneg: bool = False) -> dict:
        m = d[key]
        self.keys(m, key, set(names))
        out = {}
        for n in names:
            x = self.number(m, n, key)
            if nonneg and x < 0:
                self.fail(f"{key}.{n}", f"a value >= 0, got {x}")
            out[n] = x
        return out


# ----------------------------------------------------------------------------------------------
# solver
# ----------------------------------------------------------------------------------------------

def find_bias_pairs(steps: RateStepMeans, rel_tol: float = 1e-6) -> list[BiasPair]:
    """Zero-rate outputs from every pair of steps with opposite nominal rates.

    Each step is used at most once; steps with zero rate are skipped. For a pair
    ``b = (a_plus + a_minus) / 2`` and ``sigma = sqrt(sem_plus^2 + sem_minus^2) / 2`` (counts).
    """
    w = steps.rate_nominal_dps
    used = np.zeros(len(steps), bool)
    pairs = []
    for i in range(len(steps)):
        ri = float(np.linalg.norm(w[i]))
        if used[i] or ri == 0:
            continue
        for j in range(i + 1, len(steps)):
            if not used[j] and np.linalg.norm(w[i] + w[j]) <= rel_tol * ri:
                used[i] = used[j] = True
                dominant = np.abs(w[i]) / ri
                axis = AXES[int(np.argmax(dominant))] if dominant.max() > 1 - 1e-6 else "xyz"
                bias = 0.5 * (steps.mean_counts[i] + steps.mean_counts[j])
                sig = 0.5 * np.sqrt(steps.sem_counts[i] ** 2 + steps.sem_counts[j] ** 2)
                pairs.append(BiasPair(axis, ri, bias, sig))
                break
    return pairs


def _check_observable(w: np.ndarray) -> None:
    missing, full = input_coverage(w)
    if missing:
        names = "".join(AXES[j] for j in missing)
        about = " or ".join(AXES[j] for j in missing)
        scales = ", ".join(f"k_{AXES[j]}" for j in missing)
        couplings = ", ".join(f"m_{AXES[i]}{AXES[j]}" for j in missing for i in range(3) if i != j)
        raise ObservabilityError(f"the rate steps never spin about {about}: scale {scales} and couplings "
                                 f"{couplings} undetermined; add rate steps about {names if len(names) == 1 else ' and '.join(names)}")
    if not full:
        raise ObservabilityError(f"the {len(w)} rate steps do not determine the 12 gyro parameters (the rates "
                                 "with a constant column are rank-deficient); spin each axis both ways, e.g. "
                                 "+-25, +-40, +-63 deg/s about x, y and z")


def _sigmas(matrix: np.ndarray, fits: tuple) -> dict:
    """1-sigma of b, k (= M_ii) and m_ij = M_ij / M_ii from each output axis' covariance."""
    sig = {}
    for i in range(3):
        c = fits[i].cov  # parameters [M_i0, M_i1, M_i2, b_i]
        sig[f"b_{AXES[i]}"] = float(np.sqrt(c[3, 3]))
        sig[f"k_{AXES[i]}"] = float(np.sqrt(c[i, i]))
    for i, j in OFF_DIAGONAL:
        c = fits[i].cov
        mii, mij = matrix[i, i], matrix[i, j]
        grad = np.zeros(c.shape[0])
        grad[j] = 1.0 / mii
        grad[i] = -mij / mii**2
        sig[f"m_{AXES[i]}{AXES[j]}"] = float(np.sqrt(max(grad @ c @ grad, 0.0)))
    return {n: sig[n] for n in param_names()}


def solve_gyro(steps: RateStepMeans) -> GyroCalibration:
    """Solve the 12-parameter gyro model ``counts = M w + b`` from rate-step means.

    Parameters
    ----------
    steps : :class:`RateStepMeans` (true rates in the sensor frame, deg/s; means in counts).

    Returns
    -------
    :class:`GyroCalibration` with M and b from weighted least squares over all steps
    (per output axis, columns ``[w_x, w_y, w_z, 1]``, weights 1/sem; covariance
    scaled by chi2/dof when the misfit is significant, see :func:`calib.design.solve_wls`),
    and the + / - pair zero-rate outputs of the seed method for comparison.

    Raises
    ------
    ObservabilityError when the steps do not spin about all three axes, or the
    rates with a constant column are rank-deficient.
    """
    w = steps.rate_nominal_dps
    _check_observable(w)
    g_inputs = g_sensitivity_inputs(steps)
    if g_inputs:
        return _solve_with_g(steps, g_inputs)
    names = [[f"M_{AXES[i]}{a}" for a in AXES] + [f"b_{AXES[i]}"] for i in range(3)]
    fit = fit_affine(w, steps.mean_counts, steps.sem_counts, names)
    m, b = fit.matrix, fit.offset
    res_dps = np.linalg.solve(m, fit.residuals.T).T
    nonorth = {f"m_{AXES[i]}{AXES[j]}": float(m[i, j] / m[i, i]) for i, j in OFF_DIAGONAL}
    return GyroCalibration(
        lsb_per_dps=steps.lsb_per_dps, matrix_counts_per_dps=m, bias_counts=b,
        scale_counts_per_dps=np.diag(m).copy(), nonorthogonality=nonorth, sigma=_sigmas(m, fit.axis_fits),
        bias_pairs=find_bias_pairs(steps), residual_rms_dps=float(np.sqrt(np.mean(res_dps**2))),
        chi2_per_dof=fit.chi2_per_dof, n_steps=len(steps))


#: an input component of the specific force must vary by this much over the rate steps (g) for its
#: column of the g-sensitivity to be determined (e.g. z spins with z up vs x/y spins where gravity turns)
G_SPREAD_MIN = 0.5


def g_sensitivity_inputs(steps: RateStepMeans) -> list[int]:
    """Input axes whose g-sensitivity column the steps determine (empty without ``f_mean_g``)."""
    if steps.f_mean_g is None:
        return []
    return [k for k in range(3) if np.ptp(steps.f_mean_g[:, k]) >= G_SPREAD_MIN]


def _solve_with_g(steps: RateStepMeans, g_inputs: list[int]) -> GyroCalibration:
    """``counts = M w + b + G f``: the 12 parameters plus the determined columns of G (counts per g)."""
    w, f = steps.rate_nominal_dps, steps.f_mean_g
    design = np.column_stack([w, np.ones(len(w))] + [f[:, k] for k in g_inputs])
    fits = []
    for i in range(3):
        nm = [f"M_{AXES[i]}{a}" for a in AXES] + [f"b_{AXES[i]}"] + [f"G_{AXES[i]}{AXES[k]}" for k in g_inputs]
        fits.append(solve_wls(design, steps.mean_counts[:, i], steps.sem_counts[:, i], nm))
    m = np.array([ft.params[:3] for ft in fits])
    b = np.array([ft.params[3] for ft in fits])
    gm, gs = np.zeros((3, 3)), np.zeros((3, 3))
    for i, ft in enumerate(fits):
        for n, k in enumerate(g_inputs):
            gm[i, k] = ft.params[4 + n]
            gs[i, k] = np.sqrt(ft.cov[4 + n, 4 + n])
    res = np.column_stack([ft.residuals for ft in fits])
    res_dps = np.linalg.solve(m, res.T).T
    chi2 = sum(ft.chi2 for ft in fits)
    dof = sum(ft.dof for ft in fits)
    nonorth = {f"m_{AXES[i]}{AXES[j]}": float(m[i, j] / m[i, i]) for i, j in OFF_DIAGONAL}
    # the +/- pairs, corrected for the g-sensitivity of their own specific force
    pairs = find_bias_pairs(steps)
    return GyroCalibration(
        lsb_per_dps=steps.lsb_per_dps, matrix_counts_per_dps=m, bias_counts=b, scale_counts_per_dps=np.diag(m).copy(),
        nonorthogonality=nonorth, sigma=_sigmas(m, tuple(fits)), bias_pairs=pairs,
        residual_rms_dps=float(np.sqrt(np.mean(res_dps**2))), chi2_per_dof=chi2 / dof if dof > 0 else float("nan"),
        n_steps=len(steps),
        g_sensitivity={"inputs": [AXES[k] for k in g_inputs], "matrix_counts_per_g": gm, "sigma_counts_per_g": gs})
