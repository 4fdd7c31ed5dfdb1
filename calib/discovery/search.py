"""Discrepancy search: where does the seed's model disagree with the data, and which effect is missing?

1. **Baseline.** Fit the seed's model (bias, scale, triangular misalignment, no temperature terms)
   to the step means by generalised least squares: each mean's covariance is its own standard error
   (the scatter of the step's samples) plus the slow wander of the bias between steps that the
   sensor's stated bias stability implies (:mod:`calib.numerics.wander`, :mod:`calib.discovery.problem`).
   Residuals are judged as whitened innovations (~N(0, 1) when the model holds).
2. **Localise** the disagreement: poses, axes, temperatures, legs, time span
   (:func:`calib.discovery.report.localise`).
3. **Observability** from the data (:mod:`calib.discovery.observe`): a candidate is tested when the
   session has the data it needs and its columns add rank to the model without hopeless conditioning;
   every candidate gets its minimum detectable magnitude at the stated false-alarm rate and 80 % power.
4. **Name** the missing effect from :data:`calib.discovery.effects.LIBRARY` by forward stepwise selection with
   nested-model tests (:func:`calib.discovery.problem.nested_test`), Bonferroni over the candidates
   left (a clean session names a spurious effect with probability at most ``false_alarm``); backward
   elimination drops what is no longer significant; effects the data cannot tell apart are reported as
   **aliases**, the simpler explanation used (every fitted parameter counted, the jump's time too; a jump
   on a design boundary last): :mod:`calib.discovery.select`.
5. **Lack of fit** (:mod:`calib.discovery.nuisance`): when the gap stays open, the best generic
   factor model of the residual is kept as nuisance structure, every named effect is re-tested with
   it and those it makes unnecessary are dropped; the factor is reported under ``unexplained``.
6. **Refit** with every named effect (the M-dependent terms re-linearised at the new M); every named
   effect is re-tested in the final model and dropped (``unsupported``) when not significant there;
   the verdict is the generalised chi-square of the final model against its dof.
7. **Weak candidates** (:func:`calib.discovery.select.weak_candidates`): effects not named whose test in
   the final model has some support (a looser family level than the false-alarm rate) are listed apart,
   never named, with their fitted magnitude, p-value and this design's minimum detectable magnitude;
   ``rig discover --propose`` designs the steps that would decide them (:mod:`calib.discovery.propose`).

Pure numpy/scipy; the session-side context (pose rotations, heating legs, step durations) is
computed by the caller (``rig.analysis.discover``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from calib.accel.inputs import StepMeans
from calib.accel.solve import TRIANGULAR_NAMES, assemble
from calib.numerics.design import MISFIT_LEVEL, AxisFit, misfit
from calib.discovery.nuisance import lack_of_fit
from calib.discovery.observe import missing_data, observability, triage
from calib.discovery.problem import (Fit, Problem, RadialProblem,
                                     jump_times, scan_jump)
from calib.discovery.report import localise, unexplained
from calib.discovery.select import (BOUNDARY_FACTOR, NEEDS, NONLINEAR, jump_boundary, remaining, select,
                                    supported, weak_candidates)
from calib.discovery.effects import LIBRARY
from calib.errors import CalibError
from calib.frames import SENSOR_AXES
from calib.numerics.wander import wander_rms_g

__all__ = ["Discovery", "FoundEffect", "StepContext", "StepRow", "candidate_pvalues", "coverage_problem", "discover",
           "final_problem", "remaining", "verdict"]

FORMAT = "rig-discover/6"
MIN_RADIAL_STEPS = 12  # pose-free steps the magnitude baseline (9 parameters) needs, with dof to spare


@dataclass(frozen=True)
class StepContext:
    """Per-step facts the session knows beyond :class:`StepMeans`.

    heating : (K,) +1 after heating, -1 after cooling, 0 unknown (before the first known transition:
        such steps get an offset of their own in ``thermal_hysteresis``, never a forced 0); or None.
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
    rig_cov_counts2 : (3K, 3K) covariance of the step means (axis-major: x of every step, then y, then z) from
        the turntable's own errors at their standard uncertainties, counts^2
        (:func:`calib.accel.rig_misfit.rig_step_covariance`); or None (a table that lands where commanded, or
        poses not set by a turntable): the search then judges residuals against the noise and wander alone.

    The duration of each step's capture is the step means' own (``StepMeans.duration_s``).
    """

    heating: np.ndarray | None = None
    base_to_sensor: np.ndarray | None = None
    pose_group: np.ndarray | None = None
    band_c: float = 0.5
    temp_rate: np.ndarray | None = None
    rate_window_s: float = 5.0
    angles_deg: np.ndarray | None = None
    rig_cov_counts2: np.ndarray | None = None


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
    false_alarm: float = MISFIT_LEVEL
    calibration: object = None  # AccelCalibration or None (unknown poses)
    gap_closed: bool = True  # the final chi2 is consistent with its dof at the false-alarm level
    dof_after: int = 0
    p_fit: float = 1.0  # chi-square upper-tail probability of the final model's chi2
    unexplained: dict | None = None  # where and what remains when the gap stays open
    baseline: str = "seed"  # seed (known poses) | pose_groups (a bias per unknown pose) | magnitude (|f| = 1 g)
    wander_rms_g: float = 0.0  # rms bias wander between the step means the stated stability implies
    observability: dict = field(default_factory=dict)  # candidate -> rank, conditioning, MDM
    dropped: list = field(default_factory=list)  # named on the way, made unnecessary by the nuisance factor
    unsupported: list = field(default_factory=list)  # {name, p_value}: selected, not significant in the final model
    #: {name, axes, estimate, sigma, unit, p_value, p_family, threshold, mdm}: not named, some support (select.py)
    weak: list = field(default_factory=list)

    def to_json(self) -> dict:
        verdict_ = {"gap_closed": bool(self.gap_closed), "dof_after": int(self.dof_after), "p_fit": self.p_fit}
        if not self.gap_closed and self.unexplained is not None:
            verdict_["unexplained"] = self.unexplained
        return {"format": FORMAT, "baseline": self.baseline, "rms_before_g": self.rms_before_g,
                "rms_after_g": self.rms_after_g, "noise_rms_g": self.noise_rms_g, "wander_rms_g": self.wander_rms_g,
                "chi2_per_dof_before": self.chi2_per_dof_before,
                "chi2_per_dof_after": self.chi2_per_dof_after, **verdict_, "false_alarm": self.false_alarm,
                "effects": [e.to_json() for e in self.effects], "aliases": [list(a) for a in self.aliases],
                "dropped_by_lack_of_fit": list(self.dropped), "unsupported": list(self.unsupported),
                "weak_candidates": [{**w, "estimate": _nan_none(w["estimate"]), "sigma": _nan_none(w["sigma"]),
                                     "mdm": _nan_none(w["mdm"])} for w in self.weak],
                "unobservable": list(self.unobservable),
                "unobservable_why": dict(self.unobservable_why), "observability": _nan_none_dict(self.observability),
                "where": self.where,
                "not_named": {k: {"p_value": v[0], "threshold": v[1]} for k, v in self.not_named.items()},
                "steps": [s.to_json() for s in self.steps]}


def _nan_none(v):
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_nan_none(x) for x in v]
    if v is None:
        return None
    v = float(v)
    return None if not np.isfinite(v) else v


def _nan_none_dict(d: dict) -> dict:
    return {k: {kk: (_nan_none(vv) if isinstance(vv, (list, float)) else vv) for kk, vv in v.items()}
            for k, v in d.items()}


def coverage_problem(name: str, steps: StepMeans, ctx: StepContext, pose_free: bool) -> str | None:
    """What data the session lacks for effect ``name`` (None when it has it all); the design itself
    is judged by the candidate's columns (:func:`calib.discovery.observe.observability`)."""
    return missing_data(name, steps, ctx, pose_free, len(jump_times(np.asarray(steps.t_s, float))))


# -- the search -----------------------------------------------------------------------------
def discover(steps: StepMeans, ctx: StepContext | None = None, *, false_alarm: float = MISFIT_LEVEL,
             candidates=None, t0_c: float | None = None, progress=None) -> Discovery:
    """Run the discrepancy search on a session's step means.

    Parameters
    ----------
    steps : static step means (counts); ``f_nominal_g`` may be NaN for unknown poses; its
        ``bias_stability`` (None: no wander) sets the wander covariance between the means.
    ctx : heating legs, pose rotations, pose groups, step durations (see :class:`StepContext`).
    false_alarm : probability of naming any effect in a session that has none (Bonferroni-split
        over the candidates at each forward pass).
    candidates : effect names to consider (default: the whole library).
    t0_c : reference temperature (default: the mean step temperature).
    progress : called with each stage's name as it starts (a long session's progress), or None.
    """
    ctx = ctx or StepContext()
    if len(steps) < 2:
        raise CalibError("discover needs at least 2 static steps")
    names = list(candidates) if candidates is not None else list(LIBRARY)
    unknown = [n for n in names if n not in LIBRARY]
    if unknown:
        raise CalibError(f"unknown effect(s): {', '.join(unknown)} (known: {', '.join(LIBRARY)})")
    say = progress or (lambda stage: None)
    say(f"what {len(steps)} steps observe of {len(names)} candidate effects")
    prob, t0, t_ref, base_fit, (observable, unobservable, why, _) = _prepared(steps, ctx, names, false_alarm, t0_c)
    fit = _Cache(prob)
    selected, aliases = select(prob, observable, false_alarm, fit, progress=say)
    factor, dropped = None, []
    if not verdict(fit(selected).rss, fit(selected).dof, false_alarm)[0]:
        say("the fit's lack of fit")
        kept, factor = lack_of_fit(prob, selected, false_alarm, fit, NEEDS)
        if factor is not None:
            dropped, selected = factor["dropped"], kept
    say(f"the {len(selected)} named effects tested again in the final model")
    selected, final, pvals, unsupported = supported(prob, selected, false_alarm, _refit, _Cache)
    d = _outcome(steps, ctx, prob, base_fit, final, selected, aliases, (unobservable, why), factor, dropped,
                 false_alarm, t0, t_ref, observable, pvals)
    d.unsupported = [{"name": n, "p_value": p} for n, p in unsupported]
    say("the candidates not named, tested in the final model")
    d.weak = [{**w, "unit": LIBRARY[w["name"]].unit, "mdm": d.observability[w["name"]]["mdm"]}
              for w in weak_candidates(prob, selected, observable, aliases, _Cache(prob))]
    return d


def candidate_pvalues(steps: StepMeans, ctx: StepContext | None = None, model=("bias_tempco",),
                      false_alarm: float = MISFIT_LEVEL, test: str = "search") -> dict:
    """The p-value of adding each observable candidate, alone, to the baseline plus ``model``.

    A calibration check, not part of the search: on sessions whose truth is the baseline plus
    ``model`` (a clean simulated sensor: its real ``bias_tempco``) each p-value is uniform on [0, 1]
    when its test is calibrated, so the fraction below ``u`` is ``u``. ``test`` is the search's own
    (``search``, :func:`calib.discovery.problem.nested_test`), or either of its ingredients alone
    (``known_noise``: the chi-square drop with V known; ``scatter``: the F test). ``bias_jump``'s
    p-value is the best jump time's, multiplied by the number of times (conservative, not uniform).
    Effects of ``model`` the session cannot observe are left out of it.

    Returns
    -------
    dict : candidate -> p-value, for every observable candidate not in ``model``.
    """
    prob, _, _, _, triaged = _prepared(steps, ctx or StepContext(), list(LIBRARY), false_alarm)
    observable = triaged[0]
    fit = _Cache(prob)
    held = [n for n in model if n in observable]
    cur = fit(held)
    out = {}
    for n in remaining(observable, held):
        if n == "bias_jump":
            scan_jump(prob, held)
        out[n] = prob.test(n, cur, fit(held + [n]), test)[1]
    return out


def final_problem(steps: StepMeans, ctx: StepContext | None, names: list, false_alarm: float = MISFIT_LEVEL,
                  t0_c: float | None = None) -> tuple[Problem, list]:
    """The search's problem of ``steps`` refitted with the effects ``names`` as :func:`discover` leaves it
    (M re-linearised, the jump's time searched), and the observable candidates."""
    prob, _, _, _, triaged = _prepared(steps, ctx or StepContext(), list(LIBRARY), false_alarm, t0_c)
    _refit(prob, list(names))
    return prob, triaged[0]


def _prepared(steps: StepMeans, ctx: StepContext, names: list, false_alarm: float, t0_c: float | None = None):
    """The search's problem for ``steps``, its reference temperature (``t0_c`` or the mean step
    temperature, C) and time (the mean step time, s), the baseline fit (whose matrix the force effects
    use) and the triage of candidates ``names`` (:func:`calib.discovery.observe.triage`)."""
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    t0 = float(t0_c) if t0_c is not None else (float(np.mean(temps)) if temps is not None else 25.0)
    t_ref = float(np.mean(steps.t_s))
    prob = _problem(steps, ctx, t0, t_ref)
    base_fit = prob.fit([])
    if not prob.pose_free:
        prob.matrix_g = _matrix_from(base_fit) / prob.lsb
    return prob, t0, t_ref, base_fit, triage(prob, names, false_alarm)


class _Cache:
    """Fits of the problem by (effects, nuisance factor), computed once (the jump time is part of the key)."""

    def __init__(self, prob: Problem) -> None:
        self.prob = prob
        self.store: dict = {}

    def __call__(self, names, extra=None) -> Fit:
        key = (tuple(names), prob_jump(self.prob, names), None if extra is None else id(extra[0]))
        if key not in self.store:
            self.store[key] = self.prob.fit(list(names), extra)
        return self.store[key]


def prob_jump(prob: Problem, names) -> float | None:
    return prob.t_jump if "bias_jump" in names else None


def _refit(prob: Problem, selected: list) -> Fit:
    """The final model: the jump time re-searched, the M-dependent terms re-linearised at the new M."""
    if "bias_jump" in selected:
        scan_jump(prob, [n for n in selected if n != "bias_jump"])
    final = prob.fit(selected)
    if not prob.pose_free:
        prob.matrix_g = _matrix_from(final) / prob.lsb
        prob.build_columns(selected)
        final = prob.fit(selected)
    return final


def _outcome(steps, ctx, prob, base_fit, final, selected, aliases, unobs, factor, dropped, false_alarm, t0, t_ref,
             observable, pvals) -> Discovery:
    """Assemble the :class:`Discovery` from the fits (``pvals``: each named effect's final-model p-value)."""
    sig = np.sqrt(np.diag(final.cov0))  # propagated step uncertainties, not rescaled by chi2/dof
    prefix = [prob.fit(selected[:i]) for i in range(len(selected) + 1)]  # the model after each addition
    effects = _found_effects(prob, final, sig, selected, prefix, pvals)
    final.dof -= sum(NONLINEAR.get(n, 0) for n in selected)  # the jump's time is a fitted parameter too
    history = [("baseline", prob.rms_g(base_fit), base_fit.rss / base_fit.dof)]
    history += [(e.name, e.rms_after_g, prefix[i + 1].rss / prefix[i + 1].dof) for i, e in enumerate(effects)]
    noise = float(np.sqrt(np.mean(np.asarray(steps.sem_counts, float) ** 2)) / prob.lsb)
    cal = None if prob.pose_free else _calibration(steps, prob, final, final.cov0, selected, t0, t_ref, ctx)
    closed, p_fit = verdict(final.rss, final.dof, false_alarm)
    left = None
    if not closed:
        left = unexplained(steps, ctx, prob.marginal(final), false_alarm)
        if factor is not None:
            left["factor"] = factor
    obs = {n: _observability_json(prob, n, selected, false_alarm / max(len(observable), 1)) for n in observable}
    return Discovery(rms_before_g=prob.rms_g(base_fit), rms_after_g=prob.rms_g(final), noise_rms_g=noise,
                     chi2_per_dof_before=base_fit.rss / base_fit.dof, chi2_per_dof_after=final.rss / final.dof,
                     effects=effects, aliases=aliases, unobservable=unobs[0], unobservable_why=unobs[1],
                     steps=_step_rows(steps, prob, ctx, base_fit, final),
                     where=localise(steps, ctx, prob.marginal(base_fit)), history=history,
                     false_alarm=false_alarm, calibration=cal, not_named=dict(getattr(prob, "last_pass", {})),
                     gap_closed=closed, dof_after=final.dof, p_fit=p_fit, baseline=prob.baseline_name,
                     unexplained=left, wander_rms_g=wander_rms_g(steps.t_s, steps.duration_s, steps.bias_stability),
                     observability=obs, dropped=dropped)


def _observability_json(prob: Problem, name: str, selected: list, alpha: float) -> dict:
    """Rank, conditioning and MDM of one candidate against the final model (without itself)."""
    model = [s for s in selected if s != name]
    keep = prob.keep[name]
    info = observability(prob, name, alpha, model)
    prob.keep[name] = keep
    info.pop("keep")
    info.pop("dof")
    return info


def _problem(steps: StepMeans, ctx: StepContext, t0: float, t_ref: float) -> Problem:
    """The baseline: the seed's model (known poses), a bias per unknown pose, or, when unknown poses
    never repeat, the magnitude model; CalibError when the steps cannot determine it."""
    k = len(steps)
    prob = Problem(steps, ctx, t0, t_ref)
    if prob.pose_free and prob.base.shape[1] >= 3 * k and k > MIN_RADIAL_STEPS:
        prob = RadialProblem(steps, ctx, t0, t_ref)
    if prob.base.shape[1] >= (k if isinstance(prob, RadialProblem) else 3 * k):
        raise CalibError(f"discover: {k} steps cannot determine the baseline model ({prob.base.shape[1]} parameters)")
    return prob


def verdict(chi2: float, dof: int, false_alarm: float) -> tuple[bool, float]:
    """Whether the model explains the data to the noise level: the generalised chi-square of the final
    fit is not beyond its upper ``false_alarm`` quantile on ``dof``; and its upper-tail probability."""
    significant, p = misfit(chi2, dof, false_alarm)
    return not significant, p


def _params_of(fit: Fit, name: str, values: np.ndarray, n_params: int) -> tuple[np.ndarray, np.ndarray]:
    """The effect's parameters (NaN where not determined) from a fit's columns."""
    est = np.full(n_params, np.nan)
    out = np.full(n_params, np.nan)
    for col, (blk, idx) in enumerate(fit.names):
        if blk == name and idx < n_params:
            est[idx], out[idx] = fit.theta[col], values[col]
    return est, out


def _found_effects(prob: Problem, final: Fit, sig: np.ndarray, selected: list, prefix: list, pvals: dict) -> list:
    """One :class:`FoundEffect` per selected effect: estimates and 1-sigma, RMS after it (g), its p-value in
    the final model; a jump says which design boundaries its time coincides with (``t_jump_boundary``) and
    the nuisance factors that are offsets per those boundaries' levels (``aliased_with_factor``)."""
    effects = []
    for i, n in enumerate(selected):
        lib = LIBRARY[n]
        est, sd = _params_of(final, n, sig, len(prob.labels[n]))
        extra = {}
        if n == "bias_jump":
            kinds = jump_boundary(prob)
            extra = {"t_jump_s": prob.t_jump, "t_jump_boundary": kinds,
                     "aliased_with_factor": [BOUNDARY_FACTOR[k] for k in kinds]}
        effects.append(FoundEffect(n, list(prob.labels[n]), lib.unit, est.tolist(), sd.tolist(),
                                   prob.rms_g(prefix[i + 1]), float(pvals[n]), extra))
    return effects


def _step_rows(steps: StepMeans, prob: Problem, ctx: StepContext, base_fit: Fit, final: Fit) -> list:
    """Per-step residuals (g) and residuals in their marginal standard deviations before and after the
    selected effects."""
    k = len(steps)
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    z0 = prob.marginal(base_fit)
    z1 = prob.marginal(final)
    r0 = base_fit.resid.reshape(3, k).T / prob.lsb
    r1 = final.resid.reshape(3, k).T / prob.lsb
    return [StepRow(str(steps.names[i]), None if temps is None else float(temps[i]),
                    None if ctx.heating is None else int(ctx.heating[i]), float(steps.t_s[i]),
                    None if prob.pose_free else prob.f[i].tolist(), r0[i].tolist(), r1[i].tolist(),
                    z0[i].tolist(), z1[i].tolist()) for i in range(k)]


def _matrix_from(fit: Fit) -> np.ndarray:
    m = np.zeros((3, 3))
    for col, (blk, n) in enumerate(fit.names):
        if blk == "base" and n.startswith("m_"):
            m[SENSOR_AXES.index(n[2]), SENSOR_AXES.index(n[3])] = fit.theta[col]
    return m


#: extra fields of an effect's calibration entry: field -> value from (t0_c, t_ref_s, ctx, problem)
ENTRY_FIELDS = {"scale_tempco": ("t0_c", lambda t0, tr, c, p: t0),
                "bias_tempco_cubic": ("t0_c", lambda t0, tr, c, p: t0),
                "thermal_gradient": ("rate_window_s", lambda t0, tr, c, p: float(c.rate_window_s)),
                "bias_jump": ("t_jump_s", lambda t0, tr, c, p: float(p.t_jump)),
                "bias_drift": ("t_ref_s", lambda t0, tr, c, p: tr),
                "thermal_hysteresis": ("band_c", lambda t0, tr, c, p: c.band_c)}


def _axis_fit(prob: Problem, final: Fit, cov: np.ndarray, j: int, order: int, chi2: float) -> AxisFit:
    """One output axis's seed parameters and thermal polynomial as the seed solver's AxisFit."""
    a = SENSOR_AXES[j]
    cols, names = [], []
    for col, (blk, n) in enumerate(final.names):
        if blk == "base" and n[2] == a and n.startswith(("b_", "m_")):
            cols.append(col)
            names.append(_seed_name(n))
    for s_, eff in ((1, "bias_tempco"), (2, "bias_tempco_quadratic"))[:order]:
        if (eff, j) not in final.names:
            raise CalibError(f"{eff} on axis {a} was not determined")
        cols.append(final.names.index((eff, j)))
        names.append(f"c{s_}_{a}")
    idx = np.array(cols)
    scale = np.array([prob.lsb if n.startswith("c") else 1.0 for n in names])  # g/C^s -> counts/C^s
    params = final.theta[idx] * scale
    c = cov[np.ix_(idx, idx)] * np.outer(scale, scale)
    res = final.resid[j * prob.k:(j + 1) * prob.k]
    return AxisFit(names, params, c, c, res, chi2, max(final.dof // 3, 1), False)


def _calibration(steps, prob, final, cov, selected, t0, t_ref, ctx):
    """The augmented calibration: the seed's model, its thermal polynomial and the other effects."""
    order = 2 if "bias_tempco_quadratic" in selected else (1 if "bias_tempco" in selected else 0)
    chi2 = prob.axis_chi2(final)
    fits = {a: _axis_fit(prob, final, cov, j, order, float(chi2[j])) for j, a in enumerate(SENSOR_AXES)}
    assert set(TRIANGULAR_NAMES["x"]) <= set(fits["x"].names)
    sig = np.sqrt(np.diag(cov))
    extra = []
    for n in selected:
        lib = LIBRARY[n]
        if n in ("bias_tempco", "bias_tempco_quadratic") or lib.labels is not None:  # pose_error: the recording's
            continue
        est, sd = (np.nan_to_num(v) for v in _params_of(final, n, sig, len(lib.params)))
        entry = {"name": n, "unit": lib.unit, "axes": list(lib.params), "estimate": est.tolist(),
                 "sigma": sd.tolist()}
        if n in ENTRY_FIELDS:
            key, value = ENTRY_FIELDS[n]
            entry[key] = value(t0, t_ref, ctx, prob)
        extra.append(entry)
    return assemble(steps, "triangular", fits, order, t0, "discover", effects=extra)


def _seed_name(n: str) -> str:
    """Baseline column name -> the seed solver's parameter name."""
    return {"m_xx": "k_x", "m_xy": "kx_ayz", "m_xz": "kx_azy", "m_yy": "k_y", "m_yz": "ky_azx",
            "m_zz": "k_z"}.get(n, n)
