"""Discrepancy search: where does the seed's model disagree with the data, and which effect is missing?

1. **Baseline.** Fit the seed's model (bias, scale, triangular misalignment, no
   temperature terms) to the step means; its prediction at every step's pose,
   temperature and time is what the simulator, given that model, would produce
   (the simulator's error model is the same equation plus white noise). Each
   step-axis residual is judged against the scatter of that step's own samples
   (``z = r / sem``).
2. **Localise** the disagreement: poses, axes, temperatures, heating or cooling
   leg, time span (:func:`localise`).
3. **Name** the missing effect from :data:`calib.effects.LIBRARY` by forward
   stepwise selection. At each pass every observable candidate not yet in the
   model is tested with a nested-model F test (weights 1/sem^2; the F form keeps
   the test valid when the sems are off by a common factor); the most significant
   enters if its p-value is below ``false_alarm / (candidates left)``
   (Bonferroni), so a clean session names a spurious effect with probability at
   most ``false_alarm``. A backward pass then drops any effect no longer
   significant. Two candidates that are each significant alone, but neither once
   the other is in, are reported together as **aliases** (the data cannot tell
   them apart). A candidate whose terms the session cannot determine at all
   (the coverage rule in the library, or a design column that the baseline
   already spans) is listed as **unobservable** and never named.
4. **Refit** with every named effect (the M-dependent terms re-linearised at the
   new M) and report the residual RMS after each addition.

Pure numpy/scipy; the session-side context (pose rotations, heating legs) is
computed by the caller (``rig.analysis.discover``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import stats

from calib.accel.inputs import StepMeans
from calib.accel.solve import TRIANGULAR_NAMES, assemble
from calib.design import AxisFit, misfit
from calib.effects import LIBRARY, EffectInputs
from calib.errors import CalibError
from calib.frames import AXES
from calib.magnitude import fit_magnitude

#: baseline columns: which force components enter each output axis (the seed's triangular model)
TRIANGULAR_COLUMNS = {"x": [0, 1, 2], "y": [1, 2], "z": [2]}
MIN_TEMP_SPAN_C = 2.0
MIN_JUMP_SIDE = 3  # steps a bias jump needs on each side
TEMP_EFFECTS = ("bias_tempco_quadratic", "bias_tempco_cubic")  # enter only after bias_tempco
MISFIT_P = 0.01
COLUMN_TOL = 1e-6
MIN_RADIAL_STEPS = 12  # pose-free steps the magnitude baseline (9 parameters) needs, with dof to spare


@dataclass(frozen=True)
class StepContext:
    """Per-step facts the session knows beyond :class:`StepMeans`.

    heating : (K,) +1 after heating, -1 after cooling, 0 unknown; or None.
    base_to_sensor : (K, 3, 3) rotation taking turntable-base vectors into the sensor frame; or None.
    pose_group : (K,) integer pose labels, used when the poses are unknown (f_nominal NaN):
        the baseline is then one constant per pose group and axis.
    band_c : hysteresis dead band used for ``heating``, C.
    temp_rate : (K,) rate of temperature change during each step, C/s (least-squares slope of the
        step's own temperature samples); or None (``thermal_gradient`` is then unobservable).
    rate_window_s : the window the rates were taken over (a step's duration), s; written into the
        calibration's ``thermal_gradient`` entry for ``apply``.
    angles_deg : (K, 3) turntable angles a1, a2, a3 of each step, deg; or None (used to say where an
        unexplained residual sits).
    """

    heating: np.ndarray | None = None
    base_to_sensor: np.ndarray | None = None
    pose_group: np.ndarray | None = None
    band_c: float = 0.5
    temp_rate: np.ndarray | None = None
    rate_window_s: float = 5.0
    angles_deg: np.ndarray | None = None


@dataclass
class FoundEffect:
    name: str
    axes: list
    unit: str
    estimate: list
    sigma: list
    rms_after_g: float
    p_value: float
    extra: dict = field(default_factory=dict)  # nonlinear parameters (bias_jump: t_jump_s)

    def to_json(self) -> dict:
        return {"name": self.name, "axes": list(self.axes), "estimate": _nan_none(self.estimate),
                "sigma": _nan_none(self.sigma), "unit": self.unit, "rms_after_g": self.rms_after_g,
                "p_value": self.p_value, **self.extra}


@dataclass
class StepRow:
    name: str
    temp_c: float | None
    heating: int | None
    t_s: float
    f_nominal_g: list | None
    residual_before_g: list
    residual_after_g: list
    z_before: list
    z_after: list

    def to_json(self) -> dict:
        return {k: _nan_none(v) if isinstance(v, list) else v for k, v in self.__dict__.items()}


@dataclass
class Discovery:
    """The outcome of :func:`discover`. ``to_json`` is the documented ``--json`` contract."""

    rms_before_g: float
    rms_after_g: float
    noise_rms_g: float
    chi2_per_dof_before: float
    chi2_per_dof_after: float
    effects: list[FoundEffect]
    aliases: list[list[str]]
    unobservable: list[str]
    unobservable_why: dict
    steps: list[StepRow]
    where: dict
    history: list = field(default_factory=list)  # (label, rms_g, chi2_per_dof)
    not_named: dict = field(default_factory=dict)  # candidate -> p-value at the last forward pass
    false_alarm: float = 0.01
    calibration: object = None  # AccelCalibration or None (unknown poses)
    gap_closed: bool = True  # the final chi2 is consistent with its dof at the false-alarm level
    dof_after: int = 0
    p_fit: float = 1.0  # chi-square upper-tail probability of the final model's chi2
    unexplained: dict | None = None  # where and what remains when the gap stays open
    baseline: str = "seed"  # seed (known poses) | pose_groups (a bias per unknown pose) | magnitude (|f| = 1 g)

    def to_json(self) -> dict:
        verdict = {"gap_closed": bool(self.gap_closed), "dof_after": int(self.dof_after), "p_fit": self.p_fit}
        if not self.gap_closed and self.unexplained is not None:
            verdict["unexplained"] = self.unexplained
        return {"format": "rig-discover/2", "rms_before_g": self.rms_before_g, "rms_after_g": self.rms_after_g,
                "noise_rms_g": self.noise_rms_g, "chi2_per_dof_before": self.chi2_per_dof_before,
                "chi2_per_dof_after": self.chi2_per_dof_after, **verdict, "false_alarm": self.false_alarm,
                "effects": [e.to_json() for e in self.effects], "aliases": [list(a) for a in self.aliases],
                "unobservable": list(self.unobservable),
                "unobservable_why": dict(self.unobservable_why), "where": self.where,
                "not_named": {k: {"p_value": v[0], "threshold": v[1]} for k, v in self.not_named.items()},
                "steps": [s.to_json() for s in self.steps]}


def _nan_none(v):
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_nan_none(x) for x in v]
    v = float(v)
    return None if not np.isfinite(v) else v


# -- the linear problem ---------------------------------------------------------------------
@dataclass
class _Fit:
    theta: np.ndarray
    cov0: np.ndarray
    rss: float  # weighted (chi-square)
    dof: int
    resid: np.ndarray  # (3K,) counts
    names: list  # (block, index) per column


class _Problem:
    """Stacked weighted least squares over all steps and output axes (axis-major rows)."""

    def __init__(self, steps: StepMeans, ctx: StepContext, t0_c: float, t_ref_s: float) -> None:
        self.steps = steps
        self.ctx = ctx
        self.k = len(steps)
        self.lsb = float(steps.lsb_per_g)
        self.y = np.asarray(steps.mean_counts, float).T.ravel()
        self.w = 1.0 / np.asarray(steps.sem_counts, float).T.ravel()
        f = np.asarray(steps.f_nominal_g, float)
        self.pose_free = not np.all(np.isfinite(f))
        self.f = np.where(np.isfinite(f), f, 0.0)
        self.t0_c = t0_c
        self.t_ref_s = t_ref_s
        self.base, self.base_names = self._baseline()
        self.matrix_g = np.eye(3)
        self.cols: dict[str, np.ndarray] = {}
        self.keep: dict[str, np.ndarray] = {}
        self.jump_grid = jump_times(np.asarray(steps.t_s, float))
        self.t_jump = float(np.median(self.jump_grid)) if len(self.jump_grid) else None
        self.multiplicity = {"bias_jump": max(len(self.jump_grid), 1)}  # Bonferroni cost of the time search

    def _baseline(self):
        k = self.k
        blocks, names = [], []
        for j, a in enumerate(AXES):
            if self.pose_free:
                groups = np.unique(self.ctx.pose_group) if self.ctx.pose_group is not None else np.array([0])
                labels = self.ctx.pose_group if self.ctx.pose_group is not None else np.zeros(k, int)
                cols = [(labels == g).astype(float) for g in groups]
                nm = [f"b_{a}[{g}]" for g in groups]
            else:
                cols = [np.ones(k)] + [self.f[:, c] for c in TRIANGULAR_COLUMNS[a]]
                nm = [f"b_{a}"] + [f"m_{a}{AXES[c]}" for c in TRIANGULAR_COLUMNS[a]]
            for c, n in zip(cols, nm):
                full = np.zeros(3 * k)
                full[j * k:(j + 1) * k] = c
                blocks.append(full)
                names.append(n)
        return np.stack(blocks, axis=1), names

    def inputs(self) -> EffectInputs:
        s = self.steps
        return EffectInputs(f_g=self.f, temp_c=None if s.temp_c is None else np.asarray(s.temp_c, float),
                            t_s=np.asarray(s.t_s, float), heating=self.ctx.heating,
                            base_to_sensor=self.ctx.base_to_sensor, matrix_g=self.matrix_g, t0_c=self.t0_c,
                            t_ref_s=self.t_ref_s, temp_rate=self.ctx.temp_rate, t_jump_s=self.t_jump)

    def set_jump(self, t_jump_s: float) -> None:
        """Move the bias jump to ``t_jump_s`` (rebuilds its columns)."""
        self.t_jump = float(t_jump_s)
        self.build_columns(["bias_jump"])
        self.keep["bias_jump"] = self.observable_columns("bias_jump")

    def test(self, name: str, small: "_Fit", big: "_Fit") -> tuple[float, float]:
        """F test of adding ``name`` (``big`` = ``small`` + name), its p-value multiplied by the number
        of values its nonlinear parameter was searched over (the jump time: Bonferroni)."""
        f, p = f_test(small, big)
        return f, min(1.0, p * self.multiplicity.get(name, 1))

    def build_columns(self, names) -> None:
        x = self.inputs()
        for n in names:
            c = LIBRARY[n].columns_g(x)  # (K, 3, P)
            self.cols[n] = np.transpose(c, (1, 0, 2)).reshape(3 * self.k, -1) * self.lsb

    def design(self, effects) -> tuple[np.ndarray, list]:
        mats, names = [self.base], [("base", n) for n in self.base_names]
        for e in effects:
            keep = self.keep[e]
            mats.append(self.cols[e][:, keep])
            names += [(e, i) for i in np.flatnonzero(keep)]
        return np.concatenate(mats, axis=1), names

    def fit(self, effects) -> _Fit:
        g, names = self.design(effects)
        gw = g * self.w[:, None]
        q, r = np.linalg.qr(gw)
        theta = np.linalg.solve(r, q.T @ (self.y * self.w))
        rinv = np.linalg.inv(r)
        resid = self.y - g @ theta
        return _Fit(theta, rinv @ rinv.T, float(np.sum((resid * self.w) ** 2)), g.shape[0] - g.shape[1],
                    resid, names)

    def observable_columns(self, name: str) -> np.ndarray:
        """Mask of the effect's parameters the design determines (beyond the baseline)."""
        q, _ = np.linalg.qr(self.base * self.w[:, None])
        return _independent(q, self.cols[name] * self.w[:, None])

    @property
    def baseline_name(self) -> str:
        return "pose_groups" if self.pose_free else "seed"

    def normalised(self, fit: _Fit) -> np.ndarray:
        """(K, 3) residuals in units of their standard errors (each ~N(0, 1) when the model holds)."""
        return (fit.resid * self.w).reshape(3, self.k).T

    def rms_g(self, fit: _Fit) -> float:
        """RMS residual of a fit, g."""
        return float(np.sqrt(np.mean(fit.resid ** 2)) / self.lsb)


def _independent(basis: np.ndarray, cw: np.ndarray) -> np.ndarray:
    """Mask of the (weighted) columns ``cw`` that add a direction to the orthonormal ``basis`` (and to
    the columns kept before them)."""
    keep = np.zeros(cw.shape[1], bool)
    for i in range(cw.shape[1]):
        c = cw[:, i]
        norm = np.linalg.norm(c)
        if norm == 0:
            continue
        r = c - basis @ (basis.T @ c)
        if np.linalg.norm(r) > COLUMN_TOL * norm:
            keep[i] = True
            basis = np.concatenate([basis, (r / np.linalg.norm(r))[:, None]], axis=1)
    return keep


class _RadialProblem(_Problem):
    """Sessions with unknown poses that never repeat (an imu_tk-style hand-held recording): the
    magnitude model ``|M^-1 (a - b)| = 1 g`` as the baseline.

    The fit is linearised at the magnitude solution: each step's direction ``f_i`` is estimated from
    it, and only the component of each step's residual along ``u_i = unit(U^T f_i)`` (``U = M^-1``) is
    used, the one a change of the unknown direction cannot absorb (to first order). One row per step;
    its weight is the step's standard error along ``u_i``. Residuals are reported per axis as
    ``u_i r_i`` so the localisation and the verdict read them like any other session's.
    Only bias-type effects are candidates (poses unknown).
    """

    def __init__(self, steps: StepMeans, ctx: StepContext, t0_c: float, t_ref_s: float) -> None:
        a = np.asarray(steps.mean_counts, float)
        sem = np.asarray(steps.sem_counts, float)
        mfit = fit_magnitude(a, sem, radius=1.0)
        u = np.linalg.inv(mfit.matrix)
        f = (a - mfit.bias) @ u.T
        f /= np.linalg.norm(f, axis=1)[:, None]
        super().__init__(replace(steps, f_nominal_g=f), ctx, t0_c, t_ref_s)
        proj = f @ u
        self.u = proj / np.linalg.norm(proj, axis=1)[:, None]
        self.sd = np.sqrt(np.sum((self.u * sem) ** 2, axis=1))
        self.w = np.tile(1.0 / self.sd, 3)
        self.pose_free = True  # directions estimated, not known: no calibration, no force effects

    @property
    def baseline_name(self) -> str:
        return "magnitude"

    def project(self, m: np.ndarray) -> np.ndarray:
        """(3K, ...) axis-major rows -> (K, ...) components along each step's ``u_i``."""
        k = self.k
        return sum(self.u[:, j].reshape((k,) + (1,) * (m.ndim - 1)) * m[j * k:(j + 1) * k] for j in range(3))

    def fit(self, effects) -> _Fit:
        g, names = self.design(effects)
        gp, yp = self.project(g), self.project(self.y)
        q, r = np.linalg.qr(gp / self.sd[:, None])
        theta = np.linalg.solve(r, q.T @ (yp / self.sd))
        rinv = np.linalg.inv(r)
        rows = yp - gp @ theta
        resid = (self.u * rows[:, None]).T.ravel()
        return _Fit(theta, rinv @ rinv.T, float(np.sum((rows / self.sd) ** 2)), self.k - g.shape[1], resid, names)

    def observable_columns(self, name: str) -> np.ndarray:
        q, _ = np.linalg.qr(self.project(self.base) / self.sd[:, None])
        return _independent(q, self.project(self.cols[name]) / self.sd[:, None])

    def normalised(self, fit: _Fit) -> np.ndarray:
        """Each step's radial residual in standard errors, spread over the axes as ``sqrt(3) u_i z_i``:
        a step's mean square over the axes is ``z_i^2`` (~1 when the model holds), as for other sessions."""
        return np.sqrt(3.0) * super().normalised(fit)

    def rms_g(self, fit: _Fit) -> float:
        """RMS over the steps of the radial residual, g."""
        return float(np.sqrt(np.mean(np.sum(fit.resid.reshape(3, self.k) ** 2, axis=0))) / self.lsb)


def f_test(small: _Fit, big: _Fit) -> tuple[float, float]:
    """Nested-model F statistic and p-value (``big`` adds columns to ``small``)."""
    q = small.dof - big.dof
    if q <= 0 or big.dof <= 0:
        return 0.0, 1.0
    f = max(small.rss - big.rss, 0.0) / q / (big.rss / big.dof)
    return float(f), float(stats.f.sf(f, q, big.dof))


# -- coverage -------------------------------------------------------------------------------
def jump_times(t_s: np.ndarray) -> np.ndarray:
    """Candidate bias-jump times: midpoints between consecutive distinct step times that leave at least
    ``MIN_JUMP_SIDE`` steps on each side."""
    t = np.unique(np.asarray(t_s, float))
    mids = 0.5 * (t[:-1] + t[1:])
    return mids[MIN_JUMP_SIDE - 1:len(mids) - MIN_JUMP_SIDE + 1]


def scan_jump(prob: "_Problem", others: list) -> float:
    """Put ``bias_jump`` at the step boundary that lowers chi2 most with ``others`` in the model."""
    best = (np.inf, prob.t_jump)
    for tj in prob.jump_grid:
        prob.set_jump(tj)
        rss = prob.fit(list(others) + ["bias_jump"]).rss
        if rss < best[0]:
            best = (rss, tj)
    prob.set_jump(best[1])
    return best[1]


def coverage_problem(name: str, steps: StepMeans, ctx: StepContext, pose_free: bool) -> str | None:
    """Why the session cannot observe effect ``name`` by design (None when it can)."""
    lib = LIBRARY[name]
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    if "temp" in lib.needs:
        if temps is None:
            return "no temperature readings"
        span = float(np.ptp(temps)) if len(temps) else 0.0
        if span < MIN_TEMP_SPAN_C:
            return f"temperature span {span:.2f} C < {MIN_TEMP_SPAN_C:g} C"
        if name == "bias_tempco_quadratic" and len(np.unique(np.round(temps))) < 3:
            return "fewer than 3 distinct temperatures"
        if name == "bias_tempco_cubic" and 1 + int(np.sum(np.diff(np.sort(temps)) > 1.0)) < 4:
            return "fewer than 4 distinct temperatures (more than 1 C apart)"
    if "rate" in lib.needs and (ctx.temp_rate is None or not np.all(np.isfinite(ctx.temp_rate))):
        return "no temperature rate per step (temperature samples inside each step)"
    if "time" in lib.needs and len(jump_times(np.asarray(steps.t_s, float))) == 0:
        return f"fewer than {2 * MIN_JUMP_SIDE} steps at distinct times"
    if "legs" in lib.needs:
        h = ctx.heating
        if h is None or not (np.any(h > 0) and np.any(h < 0)):
            return "no heating and cooling legs"
        hot = {int(round(t)) for t in temps[h > 0]}
        cold = {int(round(t)) for t in temps[h < 0]}
        if not any(abs(a - b) <= 1 for a in hot for b in cold):
            return "no temperature visited on both a heating and a cooling leg"
    if "rotation" in lib.needs and ctx.base_to_sensor is None:
        return "pose rotations unknown"
    if pose_free and name in FORCE_EFFECTS:
        return "poses unknown (f_nominal null)"
    return None


FORCE_EFFECTS = {"scale_tempco", "scale_nonlinearity", "cross_axis_nonlinearity", "full_misalignment",
                 "table_tilt"}


# -- the search -----------------------------------------------------------------------------
def discover(steps: StepMeans, ctx: StepContext | None = None, *, false_alarm: float = 0.01,
             candidates=None, t0_c: float | None = None) -> Discovery:
    """Run the discrepancy search on a session's step means.

    Parameters
    ----------
    steps : static step means (counts); ``f_nominal_g`` may be NaN for unknown poses.
    ctx : heating legs, pose rotations, pose groups (see :class:`StepContext`).
    false_alarm : probability of naming any effect in a session that has none (Bonferroni-split
        over the candidates at each forward pass).
    candidates : effect names to consider (default: the whole library).
    t0_c : reference temperature (default: the mean step temperature).
    """
    ctx = ctx or StepContext()
    k = len(steps)
    if k < 2:
        raise CalibError("discover needs at least 2 static steps")
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    t0 = float(t0_c) if t0_c is not None else (float(np.mean(temps)) if temps is not None else 25.0)
    t_ref = float(np.mean(steps.t_s))
    prob = _problem(steps, ctx, t0, t_ref)
    names = list(candidates) if candidates is not None else list(LIBRARY)
    unknown = [n for n in names if n not in LIBRARY]
    if unknown:
        raise CalibError(f"unknown effect(s): {', '.join(unknown)} (known: {', '.join(LIBRARY)})")

    base_fit = prob.fit([])
    if not prob.pose_free:
        prob.matrix_g = _matrix_from(prob, base_fit) / prob.lsb
    observable, unobservable, why = _triage(prob, names, steps, ctx)
    selected, aliases = _select(prob, observable, false_alarm)

    # re-linearise the M-dependent terms at the final M and refit
    if "bias_jump" in selected:
        scan_jump(prob, [n for n in selected if n != "bias_jump"])
    final = prob.fit(selected)
    if not prob.pose_free:
        prob.matrix_g = _matrix_from(prob, final) / prob.lsb
        prob.build_columns(selected)
        final = prob.fit(selected)
    cov = final.cov0  # propagated step uncertainties, not rescaled by chi2/dof
    sig = np.sqrt(np.diag(cov))
    prefix = [prob.fit(selected[:i]) for i in range(len(selected) + 1)]  # the model after each addition
    effects = _found_effects(prob, final, sig, selected, prefix)
    rows = _step_rows(steps, prob, ctx, base_fit, final)
    history = [("baseline", _rms_g(prob, base_fit), base_fit.rss / base_fit.dof)]
    history += [(e.name, e.rms_after_g, prefix[i + 1].rss / prefix[i + 1].dof) for i, e in enumerate(effects)]
    noise = float(np.sqrt(np.mean(np.asarray(steps.sem_counts, float) ** 2)) / prob.lsb)
    cal = None if prob.pose_free else _calibration(steps, prob, final, cov, selected, t0, t_ref, ctx)
    closed, p_fit = verdict(final.rss, final.dof, false_alarm)
    return Discovery(rms_before_g=_rms_g(prob, base_fit), rms_after_g=_rms_g(prob, final), noise_rms_g=noise,
                     chi2_per_dof_before=base_fit.rss / base_fit.dof, chi2_per_dof_after=final.rss / final.dof,
                     effects=effects, aliases=aliases, unobservable=unobservable, unobservable_why=why,
                     steps=rows, where=localise(steps, ctx, prob.normalised(base_fit)), history=history, false_alarm=false_alarm,
                     calibration=cal, not_named=dict(getattr(prob, "last_pass", {})), gap_closed=closed,
                     dof_after=final.dof, p_fit=p_fit, baseline=prob.baseline_name,
                     unexplained=None if closed else unexplained(steps, ctx, prob.normalised(final),
                                                                 false_alarm))


def _problem(steps: StepMeans, ctx: StepContext, t0: float, t_ref: float) -> _Problem:
    """The baseline: the seed's model (known poses), a bias per unknown pose, or, when unknown poses
    never repeat, the magnitude model; CalibError when the steps cannot determine it."""
    k = len(steps)
    prob = _Problem(steps, ctx, t0, t_ref)
    if prob.pose_free and prob.base.shape[1] >= 3 * k and k > MIN_RADIAL_STEPS:
        prob = _RadialProblem(steps, ctx, t0, t_ref)
    if prob.base.shape[1] >= (k if isinstance(prob, _RadialProblem) else 3 * k):
        raise CalibError(f"discover: {k} steps cannot determine the baseline model ({prob.base.shape[1]} parameters)")
    return prob


def verdict(chi2: float, dof: int, false_alarm: float) -> tuple[bool, float]:
    """Whether the model explains the data to the noise level: the chi-square of the final fit (weights
    1/sem^2) is not beyond its upper ``false_alarm`` quantile on ``dof``; and its upper-tail probability."""
    significant, p = misfit(chi2, dof, false_alarm)
    return not significant, p


def _triage(prob: "_Problem", names: list, steps: StepMeans, ctx: StepContext) -> tuple[list, list, dict]:
    """Split the candidate effects into observable ones and unobservable ones (with the reason)."""
    unobservable, why, observable = [], {}, []
    prob.build_columns(names)
    for n in names:
        problem = coverage_problem(n, steps, ctx, prob.pose_free)
        if problem is None:
            keep = prob.observable_columns(n)
            if not keep.any():
                problem = "every term is zero or already in the baseline model at these poses"
            else:
                prob.keep[n] = keep
        if problem:
            unobservable.append(n)
            why[n] = problem
        else:
            observable.append(n)
    return observable, unobservable, why


def _found_effects(prob: "_Problem", final, sig: np.ndarray, selected: list, prefix: list) -> list:
    """One :class:`FoundEffect` per selected effect: estimates and 1-sigma, RMS after it (g), its F-test p."""
    effects = []
    for i, n in enumerate(selected):
        lib = LIBRARY[n]
        est = np.full(len(lib.params), np.nan)
        sd = np.full(len(lib.params), np.nan)
        for col, (blk, idx) in enumerate(final.names):
            if blk == n:
                est[idx], sd[idx] = final.theta[col], sig[col]
        extra = {"t_jump_s": prob.t_jump} if n == "bias_jump" else {}
        effects.append(FoundEffect(n, list(lib.params), lib.unit, est.tolist(), sd.tolist(),
                                   _rms_g(prob, prefix[i + 1]), prob.test(n, prefix[i], prefix[i + 1])[1], extra))
    return effects


def _step_rows(steps: StepMeans, prob: "_Problem", ctx: StepContext, base_fit, final) -> list:
    """Per-step residuals (g) and normalised residuals before and after the selected effects."""
    k = len(steps)
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    z0 = prob.normalised(base_fit)
    z1 = prob.normalised(final)
    r0 = base_fit.resid.reshape(3, k).T / prob.lsb
    r1 = final.resid.reshape(3, k).T / prob.lsb
    return [StepRow(str(steps.names[i]), None if temps is None else float(temps[i]),
                    None if ctx.heating is None else int(ctx.heating[i]), float(steps.t_s[i]),
                    None if prob.pose_free else prob.f[i].tolist(), r0[i].tolist(), r1[i].tolist(),
                    z0[i].tolist(), z1[i].tolist()) for i in range(k)]


def _select(prob: _Problem, observable: list, alpha: float) -> tuple[list, list]:
    selected: list[str] = []
    aliases: list[list[str]] = []
    cache: dict = {}
    prob.last_pass = {}

    def fit(names):
        key = tuple(names) + ((prob.t_jump,) if "bias_jump" in names else ())
        if key not in cache:
            cache[key] = prob.fit(list(names))
        return cache[key]

    while True:
        remaining = [n for n in observable if n not in selected
                     and (n not in TEMP_EFFECTS or "bias_tempco" in selected)]
        if not remaining:
            break
        cur = fit(selected)
        if "bias_jump" in remaining:
            scan_jump(prob, selected)
        pvals = {n: prob.test(n, cur, fit(selected + [n])) for n in remaining}
        thr = alpha / len(remaining)
        best = min(remaining, key=lambda n: (pvals[n][1], -pvals[n][0]))
        if pvals[best][1] >= thr:
            prob.last_pass = {n: (pvals[n][1], thr) for n in remaining}
            break
        group = [best]
        for n in remaining:
            if n == best or pvals[n][1] >= thr:
                continue
            p_n = prob.test(n, fit(selected + [best]), fit(selected + [best, n]))[1]
            p_b = prob.test(best, fit(selected + [n]), fit(selected + [n, best]))[1]
            if p_n >= thr and p_b >= thr:
                group.append(n)
        if len(group) > 1:
            aliases.append(group)
        selected.append(best)
    # backward pass: drop what is no longer significant given the rest
    while selected:
        full = fit(selected)
        drops = {}
        for n in selected:
            if n == "bias_tempco" and any(e in selected for e in TEMP_EFFECTS):
                continue
            drops[n] = prob.test(n, fit([s for s in selected if s != n]), full)[1]
        if not drops:
            break
        worst = max(drops, key=drops.get)
        if drops[worst] <= alpha:
            break
        selected.remove(worst)
    return selected, aliases


def _rms_g(prob: _Problem, fit: _Fit) -> float:
    return prob.rms_g(fit)


def _matrix_from(prob: _Problem, fit: _Fit) -> np.ndarray:
    m = np.zeros((3, 3))
    for col, (blk, n) in enumerate(fit.names):
        if blk == "base" and n.startswith("m_"):
            m[AXES.index(n[2]), AXES.index(n[3])] = fit.theta[col]
    return m


def _calibration(steps, prob, final, cov, selected, t0, t_ref, ctx):
    """The augmented calibration: the seed's model, its thermal polynomial and the other effects."""
    order = 2 if "bias_tempco_quadratic" in selected else (1 if "bias_tempco" in selected else 0)
    k = prob.k
    fits = {}
    for j, a in enumerate(AXES):
        cols, names = [], []
        for col, (blk, n) in enumerate(final.names):
            if blk == "base" and n[2] == a and n.startswith(("b_", "m_")):
                cols.append(col)
                names.append(_seed_name(n))
        for s_, eff in ((1, "bias_tempco"), (2, "bias_tempco_quadratic")):
            if s_ <= order:
                col = final.names.index((eff, j)) if (eff, j) in final.names else None
                if col is None:
                    raise CalibError(f"{eff} on axis {a} was not determined")
                cols.append(col)
                names.append(f"c{s_}_{a}")
        idx = np.array(cols)
        params = final.theta[idx].copy()
        c = cov[np.ix_(idx, idx)].copy()
        for i, n in enumerate(names):
            if n.startswith("c"):
                params[i] *= prob.lsb  # g/C^s -> counts/C^s
                c[i, :] *= prob.lsb
                c[:, i] *= prob.lsb
        res = final.resid[j * k:(j + 1) * k]
        w = prob.w[j * k:(j + 1) * k]
        fits[a] = AxisFit(names, params, c, c, res, float(np.sum((res * w) ** 2)), max(final.dof // 3, 1), False)
    assert set(TRIANGULAR_NAMES["x"]) <= set(fits["x"].names)
    sig = np.sqrt(np.diag(cov))
    extra = []
    for n in selected:
        if n in ("bias_tempco", "bias_tempco_quadratic"):
            continue
        lib = LIBRARY[n]
        est = np.zeros(len(lib.params))
        sd = np.zeros(len(lib.params))
        for col, (blk, idx) in enumerate(final.names):
            if blk == n:
                est[idx], sd[idx] = final.theta[col], sig[col]
        entry = {"name": n, "unit": lib.unit, "axes": list(lib.params), "estimate": est.tolist(),
                 "sigma": sd.tolist()}
        if n in ("scale_tempco", "bias_tempco_cubic"):
            entry["t0_c"] = t0
        if n == "thermal_gradient":
            entry["rate_window_s"] = float(ctx.rate_window_s)
        if n == "bias_jump":
            entry["t_jump_s"] = float(prob.t_jump)
        if n == "bias_drift":
            entry["t_ref_s"] = t_ref
        if n == "thermal_hysteresis":
            entry["band_c"] = ctx.band_c
        extra.append(entry)
    return assemble(steps, "triangular", fits, order, t0, "discover", effects=extra)


def _seed_name(n: str) -> str:
    """Baseline column name -> the seed solver's parameter name."""
    return {"m_xx": "k_x", "m_xy": "kx_ayz", "m_xz": "kx_azy", "m_yy": "k_y", "m_yz": "ky_azx",
            "m_zz": "k_z"}.get(n, n)


# -- localisation ---------------------------------------------------------------------------
def localise(steps: StepMeans, ctx: StepContext, z: np.ndarray, false_alarm: float = 0.01) -> dict:
    """Where the baseline disagrees: significant step-axis cells and their poses, axes,
    temperature range, legs and time span; RMS of z by group."""
    k = len(steps)
    zc = float(stats.norm.isf(false_alarm / (2 * 3 * k)))
    sig = np.abs(z) > zc
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    t = np.asarray(steps.t_s, float)
    out: dict = {"z_threshold": zc, "cells": int(sig.sum()), "cells_total": int(3 * k)}
    out["by_axis"] = {a: {"significant": int(sig[:, j].sum()), "rms_z": float(np.sqrt(np.mean(z[:, j] ** 2)))}
                      for j, a in enumerate(AXES)}
    rows = np.flatnonzero(sig.any(axis=1))
    out["steps"] = [str(steps.names[i]) for i in rows]
    if len(rows):
        out["time_span_s"] = [float(t[rows].min()), float(t[rows].max())]
        if temps is not None:
            out["temp_range_c"] = [float(temps[rows].min()), float(temps[rows].max())]
    zr = np.sqrt(np.mean(z ** 2, axis=1))
    if temps is not None:
        levels = np.round(temps).astype(int)
        out["by_temperature"] = {f"{lv}": float(np.sqrt(np.mean(zr[levels == lv] ** 2)))
                                 for lv in sorted(set(levels.tolist()))}
    if ctx.heating is not None:
        out["by_leg"] = {lab: float(np.sqrt(np.mean(zr[ctx.heating == v] ** 2)))
                         for lab, v in (("heating", 1), ("cooling", -1), ("unknown", 0)) if np.any(ctx.heating == v)}
    halves = t <= np.median(t)
    out["by_time"] = {"first_half": float(np.sqrt(np.mean(zr[halves] ** 2))),
                      "second_half": float(np.sqrt(np.mean(zr[~halves] ** 2))) if np.any(~halves) else None}
    names = np.asarray(steps.names, dtype=object)
    by_pose = {}
    for n in dict.fromkeys(names.tolist()):
        by_pose[str(n)] = float(np.sqrt(np.mean(zr[names == n] ** 2)))
    out["worst_poses"] = sorted(by_pose, key=by_pose.get, reverse=True)[:5]
    return out


def summary_lines(d: dict) -> list[str]:
    """Plain sentences from :func:`localise`'s dict."""
    lines = [f"{d['cells']} of {d['cells_total']} step-axis means disagree beyond |z| > {d['z_threshold']:.1f} "
             f"(about {0.01:g} expected by chance)"]
    ax = ", ".join(f"{a}: {v['significant']} (rms z {v['rms_z']:.1f})" for a, v in d["by_axis"].items())
    lines.append(f"by axis: {ax}")
    if "temp_range_c" in d:
        lines.append(f"temperatures of the disagreeing steps: {d['temp_range_c'][0]:.1f} .. {d['temp_range_c'][1]:.1f} C")
    if "by_temperature" in d and len(d["by_temperature"]) > 1:
        lines.append("rms z by temperature: " + ", ".join(f"{k} C {v:.1f}" for k, v in d["by_temperature"].items()))
    if "by_leg" in d:
        lines.append("rms z by leg: " + ", ".join(f"{k} {v:.1f}" for k, v in d["by_leg"].items()))
    if "time_span_s" in d:
        lines.append(f"time span of the disagreeing steps: {d['time_span_s'][0]:.0f} .. {d['time_span_s'][1]:.0f} s"
                     f" (rms z first half {d['by_time']['first_half']:.1f}, second half "
                     f"{(d['by_time']['second_half'] or 0):.1f})")
    lines.append("worst poses: " + ", ".join(d["worst_poses"]))
    return lines


# -- what remains ---------------------------------------------------------------------------
def unexplained(steps: StepMeans, ctx: StepContext, z: np.ndarray, false_alarm: float = 0.01) -> dict:
    """Where the final model's normalised residual ``z`` (K, 3) sits and what structure it has.

    Plain data: RMS of z by axis, pose, temperature, leg, time block and outer-axis angle; then
    ``structure``: per axis, the residual against time, temperature and temperature rate (Pearson r),
    a step in time (best split, Bonferroni over the splits) and an offset per pose or per outer-axis
    angle (one-way F); each with its p-value, significant below ``false_alarm`` / (number of tests).
    """
    k = len(steps)
    zr = np.sqrt(np.mean(z ** 2, axis=1))
    t = np.asarray(steps.t_s, float)
    out: dict = {"rms_z": float(np.sqrt(np.mean(z ** 2))),
                 "by_axis": {a: float(np.sqrt(np.mean(z[:, j] ** 2))) for j, a in enumerate(AXES)}}
    order = np.argsort(-zr)[:5]
    out["worst_steps"] = [{"name": str(steps.names[i]), "t_s": float(t[i]), "z": z[i].tolist()} for i in order]
    groups = _groups(steps, ctx)
    for label, g in groups.items():
        out[f"by_{label}"] = {str(v): float(np.sqrt(np.mean(zr[g == v] ** 2))) for v in dict.fromkeys(g.tolist())}
    blocks = np.minimum((4 * np.argsort(np.argsort(t))) // max(k, 1), 3)
    out["by_time_block"] = {f"{t[blocks == b].min():.0f}-{t[blocks == b].max():.0f} s":
                            float(np.sqrt(np.mean(zr[blocks == b] ** 2))) for b in range(4) if np.any(blocks == b)}
    tests = _structure_tests(steps, ctx, z, groups)
    thr = false_alarm / max(len(tests), 1)
    for s_ in tests:
        s_["significant"] = bool(s_["p_value"] < thr)
    out["structure"] = tests
    out["threshold"] = thr
    return out


def _groups(steps: StepMeans, ctx: StepContext) -> dict:
    """Step labels to group the residual by: pose, temperature, leg, outer-axis angle."""
    g = {"pose": np.asarray([str(n) for n in steps.names], dtype=object)}
    if steps.temp_c is not None:
        g["temperature"] = np.round(np.asarray(steps.temp_c, float)).astype(int)
    if ctx.heating is not None:
        g["leg"] = np.asarray([{1: "heating", -1: "cooling"}.get(int(h), "unknown") for h in ctx.heating], dtype=object)
    if ctx.angles_deg is not None and np.all(np.isfinite(ctx.angles_deg)):
        g["outer_axis_deg"] = np.round(np.asarray(ctx.angles_deg, float)[:, 0] % 360).astype(int)
    return g


def _structure_tests(steps: StepMeans, ctx: StepContext, z: np.ndarray, groups: dict) -> list:
    t = np.asarray(steps.t_s, float)
    regressors = {"time": t}
    if steps.temp_c is not None:
        regressors["temperature"] = np.asarray(steps.temp_c, float)
    if ctx.temp_rate is not None and np.all(np.isfinite(ctx.temp_rate)):
        regressors["temperature_rate"] = np.asarray(ctx.temp_rate, float)
    out = []
    for j, a in enumerate(AXES):
        for kind, x in regressors.items():
            if np.ptp(x) > 0:
                r, p = stats.pearsonr(x, z[:, j])
                out.append({"kind": f"correlated_with_{kind}", "axis": a, "r": float(r), "p_value": float(p)})
        out.append({"kind": "step_in_time", "axis": a, **_best_split(t, z[:, j])})
        for label in ("pose", "outer_axis_deg"):
            if label in groups and 1 < len(set(groups[label].tolist())) < len(z):
                f, p = stats.f_oneway(*[z[groups[label] == v, j] for v in dict.fromkeys(groups[label].tolist())])
                out.append({"kind": f"offset_per_{label}", "axis": a, "f": float(f), "p_value": float(p)})
    return out


def _best_split(t: np.ndarray, zj: np.ndarray) -> dict:
    """The time split with the largest two-sample t statistic of ``zj``; p Bonferroni over the splits."""
    grid = jump_times(t)
    best = {"t_s": None, "shift_z": 0.0, "p_value": 1.0}
    tmax = -1.0
    for tj in grid:
        a, b = zj[t < tj], zj[t >= tj]
        se = np.sqrt(1.0 / len(a) + 1.0 / len(b))
        stat = abs(a.mean() - b.mean()) / se  # z is unit-variance under the model
        if stat > tmax:
            tmax = stat
            p = min(1.0, 2 * stats.norm.sf(stat) * len(grid))
            best = {"t_s": float(tj), "shift_z": float(b.mean() - a.mean()), "p_value": float(p)}
    return best


#: plain-language hints for the structures of :func:`unexplained`
HINTS = {"correlated_with_time": "something changing with time (drift that is not linear, warm-up, aging)",
         "correlated_with_temperature": "a temperature dependence the library does not describe",
         "correlated_with_temperature_rate": "a thermal lag or gradient (the temperature rate matters)",
         "step_in_time": "a sudden change (a shock, a mode change, a re-mount)",
         "offset_per_pose": "something that depends on the pose (mounting, nonlinearity, the fixture)",
         "offset_per_outer_axis_deg": "something that depends on the outer-axis angle (the turntable: "
                                      "wobble, tilt, a magnetic or electrical disturbance)"}


def unexplained_lines(u: dict) -> list[str]:
    """Plain sentences from :func:`unexplained`'s dict: where the residual sits and what to look for."""
    lines = ["residual rms z " + f"{u['rms_z']:.2f} (1 expected); by axis: "
             + ", ".join(f"{a} {v:.2f}" for a, v in u["by_axis"].items())]
    for label in ("temperature", "leg", "time_block", "outer_axis_deg"):
        if f"by_{label}" in u and len(u[f"by_{label}"]) > 1:
            lines.append(f"rms z by {label.replace('_', ' ')}: "
                         + ", ".join(f"{k} {v:.2f}" for k, v in u[f"by_{label}"].items()))
    lines.append("worst steps: " + ", ".join(f"{s['name']} ({s['t_s']:.0f} s)" for s in u["worst_steps"]))
    sig = [s for s in u["structure"] if s["significant"]]
    for kind in dict.fromkeys(s["kind"] for s in sig):
        axes = ", ".join(s["axis"] for s in sig if s["kind"] == kind)
        at = next(s for s in sig if s["kind"] == kind)
        when = f" near {at['t_s']:.0f} s" if kind == "step_in_time" and at.get("t_s") is not None else ""
        lines.append(f"{kind.replace('_', ' ')}{when} (axes {axes}): look for {HINTS[kind]}")
    if not sig:
        lines.append("no simple structure (time, temperature, rate, step, pose, angle) is significant: look for "
                     "noise larger than each step's scatter says (vibration, correlated noise)")
    return lines
