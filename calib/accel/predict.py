"""Predicting a calibration's accuracy before it is measured, and the dwell that reaches a target
(docs/methods.md, "Accuracy targets: predicted uncertainty and the stopping rule").

The accelerometer solve is linear least squares per output axis, so the covariance of its
parameters, ``C_j = (G_j^T W_j G_j)^-1``, depends only on the poses (``G_j``), the per-step standard
errors and the steps' capture windows (``W_j = V_j^-1``, ``V_j = diag(sem^2) + lsb^2 W`` with the
chip's bias wander ``W`` between the windows, the solver's generalised least squares; or
``diag(1 / sem^2)`` plus a bias floor without a timeline), never on the readings themselves. A step's standard
error is ``u / sqrt(t)`` for a dwell of ``t`` seconds, ``u`` the noise measured so far with the
correlation-aware inflation of :mod:`calib.numerics.uncertainty`. Everything a target asks for is therefore
known before the dwell is spent:

- **attitude**: the roll/pitch error at a verification pose is, to first order, linear in the
  parameter errors (``delta f = -M^-1 delta a``, ``delta a_j = g_j(f) . delta p_j``; ``M`` taken at
  its nominal ``lsb * I``); the errors at all poses are jointly normal with covariance
  ``J C J^T``, and the ``confidence`` quantile of their largest absolute value over the poses is
  taken from :data:`DRAWS` fixed draws (common random numbers: the prediction is deterministic and
  scales exactly with the standard errors);
- **per-parameter sigmas**: the diagonal of ``C`` (the misalignment angles to first order at the
  nominal scale).

:func:`plan_dwell` spreads dwell over the steps still to capture so that the target is met with the
least total dwell: the marginal gain of a second is made equal at every pose (the proxy ``trace``
of the normalised target variances), then the whole allocation is scaled by bisection on the exact
prediction.

Pure numpy; imports nothing from ``rig`` or ``drivers``.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field

import numpy as np

from calib.numerics.stability import BiasStability
from calib.accel.solve import base_model
from calib.numerics.design import SENSOR_AXES, Inputs
from calib.errors import CalibError, ObservabilityError
from calib.evaluation import GIMBAL_LOCK_COS, f_from_roll_pitch
from calib.numerics.wander import wander_cov_g2

#: the seed paper's seven verification poses, (roll, pitch) in degrees
SEED_TABLE_ROLL_PITCH_DEG = ((0, 90), (-60, 60), (-30, 30), (0, 0), (30, -30), (60, -60), (90, 0))
#: Monte Carlo draws of the largest roll/pitch error (fixed seed: deterministic, replay-safe)
DRAWS = 4096
DRAW_SEED = 2015
#: parameter names a sigma target may use (calib.file.parameters naming), per model
PARAMETERS = {
    "triangular": {"x": ["accel.bias_x", "accel.scale_x", "accel.alpha_yz", "accel.alpha_zy"],
                   "y": ["accel.bias_y", "accel.scale_y", "accel.alpha_zx"], "z": ["accel.bias_z", "accel.scale_z"]},
    "full": {a: [f"accel.bias_{a}"] + [f"accel.scale_{a}" if a == c else f"accel.m_{a}{c}" for c in SENSOR_AXES]
             for a in SENSOR_AXES},
}
#: parameters whose sigma is a ratio to the scale (rad), not a design coefficient
ANGLES = ("accel.alpha_yz", "accel.alpha_zy", "accel.alpha_zx")


def seed_table_f() -> np.ndarray:
    """Specific force (7, 3), g, at the seed's verification poses."""
    rp = np.array(SEED_TABLE_ROLL_PITCH_DEG, float)
    return f_from_roll_pitch(rp[:, 0], rp[:, 1])


def parameter_names(model: str) -> list[str]:
    """Every parameter a sigma target may name for ``model`` (triangular, full)."""
    if model not in PARAMETERS:
        raise CalibError(f"accuracy targets predict the triangular or full model, not {model!r}")
    return [n for a in SENSOR_AXES for n in PARAMETERS[model][a]]


@dataclass(frozen=True)
class Goal:
    """What a calibration must achieve (at least one of the two).

    attitude_error_deg : largest |roll| or |pitch| error over ``poses_f`` at ``confidence``, deg.
    confidence : probability of the attitude bound, in (0, 1).
    poses_f : (P, 3) nominal specific force of the verification poses, g (default the seed's table).
    sigma : {parameter name or shell pattern: largest 1-sigma in the parameter's unit}
        (``accel.bias_x`` counts, ``accel.scale_*`` counts/g, ``accel.alpha_yz`` rad, ``accel.m_xy`` counts/g).
    model : the model the session is solved with (triangular or full).
    """

    attitude_error_deg: float | None = None
    confidence: float = 0.95
    poses_f: np.ndarray = field(default_factory=seed_table_f)
    sigma: dict = field(default_factory=dict)
    model: str = "triangular"

    def __post_init__(self) -> None:
        if self.attitude_error_deg is None and not self.sigma:
            raise CalibError("a goal needs an attitude error or at least one sigma target")
        if not 0.0 < self.confidence < 1.0:
            raise CalibError(f"confidence must be in (0, 1), got {self.confidence!r}")
        names = parameter_names(self.model)
        for pattern, top in self.sigma.items():
            if not [n for n in names if fnmatch.fnmatchcase(n, pattern)]:
                raise CalibError(f"sigma target {pattern!r} names no parameter of the {self.model} model "
                                 f"({', '.join(names)})")
            if not top > 0:
                raise CalibError(f"sigma target {pattern!r} must be > 0, got {top!r}")

    def sigma_targets(self) -> dict[str, float]:
        """{parameter: largest sigma}: each pattern expanded; the tightest limit wins."""
        out: dict[str, float] = {}
        for pattern, top in self.sigma.items():
            for n in parameter_names(self.model):
                if fnmatch.fnmatchcase(n, pattern):
                    out[n] = min(out.get(n, np.inf), float(top))
        return out


@dataclass(frozen=True)
class Prediction:
    """The predicted outcome: the attitude quantile (deg, None without an attitude target), the
    predicted sigma of every parameter with a target, and ``ratio``, the largest predicted/target
    over all targets (<= 1: met; every prediction scales linearly with the standard errors)."""

    attitude_error_deg: float | None
    sigmas: dict
    ratio: float
    worst: str

    @property
    def met(self) -> bool:
        return bool(self.ratio <= 1.0)


class Predictor:
    """The prediction for one goal and sensitivity (``lsb_per_g``); reusable for any poses and
    standard errors (the verification-pose Jacobians and the draws are computed once).

    Two ways to hold the chip's bias wander, the second the solver's own:

    - ``bias_floor_counts``: 1-sigma by which the session's bias stands off the sensor's long-run
      bias (:meth:`calib.accel.inputs.StepMeans.bias_stability_counts`), added to every bias's
      variance (what is common to the whole session; not the wander *between* the steps);
    - ``stability`` (:class:`calib.numerics.stability.BiasStability`) and a ``timeline``, the steps'
      capture windows ``(t_mid_s (K,), duration_s (K,))``: the covariance is that of the solver's
      generalised least squares, ``(G^T V^-1 G)^-1`` with ``V = diag(sem^2) + lsb^2 W`` and ``W`` the
      wander between the windows (:func:`calib.numerics.wander.wander_cov_g2`), which holds both the common part
      and what differs between steps far apart in time. ``bias_floor`` is then not added. The
      timeline is state (set before a prediction, as the run's plan moves); without one the floor
      is used.
    """

    def __init__(self, goal: Goal, lsb_per_g: float, bias_floor_counts: float = 0.0,
                 stability: BiasStability | None = None) -> None:
        self.goal = goal
        self.lsb = float(lsb_per_g)
        self.bias_floor = float(bias_floor_counts)
        self.stability = stability
        self.timeline: tuple[np.ndarray, np.ndarray] | None = None
        self.model = base_model(goal.model)
        self.targets = goal.sigma_targets()
        self.rows = {}  # axis -> (E, P_j): d(roll/pitch errors, rad) / d(parameter errors, counts)
        self.draws = None
        if goal.attitude_error_deg is not None:
            self._attitude_jacobians(np.atleast_2d(np.asarray(goal.poses_f, float)))

    def _attitude_jacobians(self, f: np.ndarray) -> None:
        f = f / np.linalg.norm(f, axis=1, keepdims=True)
        gx, gy, gz = f[:, 0], f[:, 1], f[:, 2]
        r2 = gx**2 + gz**2
        r = np.sqrt(r2)
        locked = r < GIMBAL_LOCK_COS  # |cos pitch| small: roll is undefined and not scored
        with np.errstate(invalid="ignore", divide="ignore"):
            d_roll = np.stack([-gz / r2, np.zeros_like(gx), gx / r2], axis=1)  # psi = atan2(-gx, gz)
            dr = np.stack([gx / r, np.zeros_like(gx), gz / r], axis=1)
            d_pitch = (np.stack([np.zeros_like(gx), r, np.zeros_like(gx)], axis=1) - gy[:, None] * dr) / (r2 + gy**2)[:, None]
        d_pitch[locked] = [0.0, 1.0, 0.0]  # theta = atan2(gy, r) at r = 0
        de_df = np.concatenate([d_roll[~locked], d_pitch])  # (E, 3): error per unit change of f
        x = Inputs(f, None, np.zeros(len(f)))
        for j, a in enumerate(SENSOR_AXES):
            g = self.model.design(a, x)  # (P_poses, P_j): delta a_j at each pose per parameter
            g_e = np.concatenate([g[~locked], g])  # rows matching de_df
            self.rows[a] = -(de_df[:, j:j + 1] * g_e) / self.lsb
        n_err = len(de_df)
        self.draws = np.random.default_rng(DRAW_SEED).standard_normal((DRAWS, n_err))

    def covariances(self, f_steps, sem_counts) -> dict:
        """{axis: (names, C_j)} of the weighted least squares on these poses and standard errors
        (counts); ObservabilityError when the poses do not determine a parameter."""
        f = np.asarray(f_steps, float)
        sem = np.asarray(sem_counts, float)
        x = Inputs(f, None, np.zeros(len(f)))
        wander = self.wander_counts2(len(f))
        out = {}
        for j, a in enumerate(SENSOR_AXES):
            g = self.model.design(a, x)
            if wander is None:
                info = g.T @ (g / sem[:, j:j + 1] ** 2)
            else:
                info = g.T @ np.linalg.solve(np.diag(sem[:, j] ** 2) + wander, g)
            if len(f) < g.shape[1] or np.linalg.cond(info) > 1e12:
                raise ObservabilityError(f"the poses do not determine the {self.goal.model} model's "
                                         f"{a} axis ({len(f)} steps, {g.shape[1]} parameters)")
            cov = np.linalg.inv(info)
            if wander is None:
                cov[0, 0] += self.bias_floor**2  # the bias is every model's first term
            out[a] = (self.model.names(a), cov)
        return out

    def wander_counts2(self, k: int) -> np.ndarray | None:
        """(K, K) covariance (counts^2) of the bias wander between the timeline's K windows, or None
        (no stability or no timeline: the bias floor is used instead)."""
        if self.stability is None or self.timeline is None:
            return None
        t_mid_s, duration_s = (np.asarray(v, float) for v in self.timeline)
        if len(t_mid_s) != k or len(duration_s) != k:
            raise CalibError(f"the prediction's timeline has {len(t_mid_s)} windows for {k} steps")
        return self.lsb**2 * wander_cov_g2(t_mid_s, duration_s, self.stability)

    def predict(self, f_steps, sem_counts) -> Prediction:
        """The prediction for steps at ``f_steps`` (K, 3) with standard errors ``sem_counts`` (K, 3)."""
        covs = self.covariances(f_steps, sem_counts)
        ratios = {}
        attitude = None
        if self.draws is not None:
            attitude = self.attitude_quantile_deg(covs)
            ratios["attitude"] = attitude / self.goal.attitude_error_deg
        sigmas = self.parameter_sigmas(covs)
        for name, top in self.targets.items():
            ratios[name] = sigmas[name] / top
        worst = max(ratios, key=ratios.get)
        return Prediction(attitude, {n: sigmas[n] for n in self.targets}, float(ratios[worst]), worst)

    def error_covariance(self, covs: dict) -> np.ndarray:
        """Covariance (E, E), rad^2, of the roll and pitch errors at the verification poses."""
        return sum(self.rows[a] @ covs[a][1] @ self.rows[a].T for a in SENSOR_AXES)

    def attitude_quantile_deg(self, covs: dict) -> float:
        """The ``confidence`` quantile of the largest |roll| or |pitch| error over the poses, deg."""
        vals, vecs = np.linalg.eigh(self.error_covariance(covs))
        root = vecs * np.sqrt(np.clip(vals, 0.0, None))
        # einsum, not @: a multithreaded BLAS spends longer starting threads than on this product
        worst = np.max(np.abs(np.einsum("de,fe->df", self.draws, root)), axis=1)
        return float(np.degrees(np.quantile(worst, self.goal.confidence)))

    def parameter_sigmas(self, covs: dict) -> dict[str, float]:
        """1-sigma of every named parameter (counts, counts/g; angles in rad at the nominal scale)."""
        out = {}
        for a in SENSOR_AXES:
            _, c = covs[a]
            for name, var in zip(PARAMETERS[self.goal.model][a], np.diag(c)):
                out[name] = float(np.sqrt(var) / (self.lsb if name in ANGLES else 1.0))
        return out

    def proxy_gains(self, f_steps, sem_counts) -> np.ndarray:
        """Decrease per second of dwell at each step (K,) of the proxy ``sum of target variances /
        target^2`` (the attitude errors' trace over the bound's square): where a second pays most."""
        f = np.asarray(f_steps, float)
        sem = np.asarray(sem_counts, float)
        covs = self.covariances(f, sem)
        x = Inputs(f, None, np.zeros(len(f)))
        gains = np.zeros(len(f))
        for j, a in enumerate(SENSOR_AXES):
            g = self.model.design(a, x)
            c = covs[a][1]
            b = self._proxy_metric(a, len(c))
            cg = g @ c  # (K, P_j)
            q = np.einsum("kp,pq,kq->k", cg, b, cg)  # g_k^T C B C g_k
            gains += q / sem[:, j] ** 2  # (d proxy / d var) * var: per unit of log-dwell
        return gains

    def _proxy_metric(self, axis: str, size: int) -> np.ndarray:
        b = np.zeros((size, size))
        if self.draws is not None:
            b += self.rows[axis].T @ self.rows[axis] / np.radians(self.goal.attitude_error_deg) ** 2
        for i, name in enumerate(PARAMETERS[self.goal.model][axis]):
            if name in self.targets:
                scale = self.lsb if name in ANGLES else 1.0
                b[i, i] += 1.0 / (self.targets[name] * scale) ** 2
        return b


@dataclass(frozen=True)
class Plan:
    """Dwell per step (s; the fixed steps' entries are 0), the predicted ratio with it, and whether
    the target is reachable at all within the allowed total."""

    dwell_s: np.ndarray
    ratio: float
    feasible: bool

    @property
    def total_s(self) -> float:
        return float(np.sum(self.dwell_s))


def planned_sems(sem_fixed: np.ndarray, unit_sem: np.ndarray, dwell_s: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Standard errors (K, 3): the fixed steps' own, ``unit_sem / sqrt(dwell)`` for the free ones
    (``unit_sem`` (3,) for all, or (K, 3) per step: the standard error of a 1 s mean)."""
    out = np.array(sem_fixed, float, copy=True)
    unit = np.broadcast_to(np.asarray(unit_sem, float), out.shape)
    out[free] = unit[free] / np.sqrt(np.maximum(np.asarray(dwell_s, float)[free], 1e-12))[:, None]
    return out


def allocation_shape(predictor: Predictor, f_steps, sem_fixed, unit_sem, free, min_s, level: float,
                     iterations: int = 12) -> np.ndarray:
    """Relative dwell of the free steps (sums to 1) that equalises the proxy's gain per second when
    ``level`` seconds are spread over them (the shape depends on the level only through the fixed
    steps and the minimums)."""
    free = np.asarray(free, bool)
    shape = np.where(free, 1.0 / free.sum(), 0.0)
    for _ in range(iterations):
        t = np.maximum(shape * level, min_s)
        gains = predictor.proxy_gains(f_steps, planned_sems(sem_fixed, unit_sem, t, free))
        per_second = gains[free] / t[free]
        update = shape[free] * np.sqrt(per_second / np.mean(per_second))
        shape[free] = update / update.sum()
    return shape


def plan_dwell(predictor: Predictor, f_steps, sem_fixed, unit_sem, free, min_s, max_total_s: float) -> Plan:
    """The least total dwell of the ``free`` steps (K,) that meets the goal.

    Parameters
    ----------
    f_steps : (K, 3) nominal specific force of every step, captured or to come.
    sem_fixed : (K, 3) standard errors (counts) of the steps whose data is final (others ignored).
    unit_sem : (3,) or (K, 3) standard error of a one-second mean (counts), from the noise measured so far.
    free : (K,) bool, the steps whose dwell is to be planned.
    min_s : (K,) least dwell of each free step (s): what it already has, or the minimum.
    max_total_s : the most dwell the free steps may have in total (s).
    """
    free = np.asarray(free, bool)
    min_s = np.asarray(min_s, float)
    if not free.any():
        p = predictor.predict(f_steps, sem_fixed)
        return Plan(np.zeros(len(free)), p.ratio, p.met)
    level = 10.0 * free.sum()
    for _ in range(2):  # the shape at a first guess of the level, then at the level found with it
        shape = allocation_shape(predictor, f_steps, sem_fixed, unit_sem, free, min_s, level)
        plan, level = _scale_to_goal(predictor, f_steps, sem_fixed, unit_sem, free, min_s, shape, max_total_s)
    return plan


def _scale_to_goal(predictor, f_steps, sem_fixed, unit_sem, free, min_s, shape, max_total_s):
    """The smallest multiple of ``shape`` that meets the goal within ``max_total_s`` (bisection)."""
    def dwell(level: float) -> np.ndarray:
        return np.where(free, np.maximum(shape * level, min_s), 0.0)

    def ratio(level: float) -> float:
        return predictor.predict(f_steps, planned_sems(sem_fixed, unit_sem, dwell(level), free)).ratio

    lo, hi = 0.0, _level_for_total(dwell, max_total_s)
    if ratio(hi) > 1.0:
        return Plan(dwell(hi), ratio(hi), False), hi
    if ratio(lo) <= 1.0:
        return Plan(dwell(lo), ratio(lo), True), max(float(np.sum(dwell(lo))), 1e-3)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ratio(mid) > 1.0 else (lo, mid)
        if hi - lo < 5e-3 * hi:
            break
    return Plan(dwell(hi), ratio(hi), True), hi


def _level_for_total(dwell, total_s: float) -> float:
    """The largest scale whose allocation fits ``total_s`` (bisection; the minimums may exceed it)."""
    lo, hi = 0.0, max(total_s, 1e-9)
    while dwell(hi).sum() < total_s and hi < 1e9:
        lo, hi = hi, 2 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if dwell(mid).sum() <= total_s else (lo, mid)
    return lo


UNITS = {"accel.bias": "counts", "accel.scale": "counts/g", "accel.alpha": "rad", "accel.m": "counts/g"}


def unit_of(parameter: str) -> str:
    """The unit of a sigma target's parameter."""
    return next(u for prefix, u in UNITS.items() if parameter.startswith(prefix))


def describe(goal: Goal, prediction: Prediction) -> str:
    """One line: the attitude target, then each sigma target (the furthest from its limit first)."""
    parts = []
    if prediction.attitude_error_deg is not None:
        parts.append(f"max roll/pitch error {prediction.attitude_error_deg:.4g} deg at {goal.confidence:.0%} "
                     f"{'<=' if prediction.attitude_error_deg <= goal.attitude_error_deg else '>'} "
                     f"{goal.attitude_error_deg:g} deg")
    targets = goal.sigma_targets()
    for name in sorted(prediction.sigmas, key=lambda n: -prediction.sigmas[n] / targets[n]):
        s, top = prediction.sigmas[name], targets[name]
        parts.append(f"{name} sigma {s:.3g} {'<=' if s <= top else '>'} {top:g} {unit_of(name)}")
    return "; ".join(parts)


def target_record(goal: Goal, prediction: Prediction, *, poses, max_seconds: float,
                  rig_time_s: float | None) -> dict:
    """The calibration file's ``target`` section (:class:`calib.accel.target_record.TargetRecord`)."""
    targets = goal.sigma_targets()
    return {
        "met": prediction.met,
        "attitude_error_deg": goal.attitude_error_deg,
        "confidence": goal.confidence if goal.attitude_error_deg is not None else None,
        "poses": poses,
        "predicted_attitude_error_deg": prediction.attitude_error_deg,
        "sigma": [{"parameter": n, "target": targets[n], "predicted": prediction.sigmas[n]} for n in sorted(targets)],
        "max_seconds": float(max_seconds),
        "rig_time_s": None if rig_time_s is None else float(rig_time_s),
        "summary": ("met: " if prediction.met else "not met: ") + describe(goal, prediction),
    }
