"""Discriminating experiments: when two explanations are aliases, which added steps tell them apart?

For an alias pair (A, the effect named; B, its alias) both models are fitted to the session (the final
model, and the final model with B in A's place; a jump's time searched). Added steps are blocks: a
chamber set-point (one of the session's temperature levels, reached from the previous one, so its leg
is known) and every pose of the session at it. The **T-optimal** criterion for a sequence of blocks is
the non-centrality of the test between the models: fit B to what A predicts over the session and the
added steps (whitened by their joint covariance: each step's standard error, the session's own and the
median one for an added step, plus the stated bias wander between every two steps, session and added
alike, as the search weighs a session), and take the weighted residual sum of squares; and the same with A and B exchanged: the
smaller of the two (``lambda``). The added steps are chosen greedily, one block at a time, the one that
raises ``lambda`` most, until the predicted **power** of the search's test of B's columns at level
``false_alarm / candidates`` (a non-central chi-square; Bonferroni over the jump times for a jump)
reaches ``POWER_TARGET`` or the time budget (:data:`BUDGET_S`: the chamber's settling before each block
and its steps) is spent.

A **weak candidate** (:func:`calib.discovery.select.weak_candidates`: not named, some support) gets the
same machinery with the nested pair (the final model plus the candidate at its fitted magnitude, the final
model): ``lambda`` is the weighted residual sum of squares of the final model fitted to what the model with
the candidate predicts (the only direction: the bigger model fits the smaller exactly), the power that of
the search's test of the candidate's columns at ``false_alarm / candidates``, within the same time budget. The design magnitude is the
fitted one, not the minimum detectable one: the fitted magnitude is what the data suggest, and a block that
reaches the power there also decides the candidate when it is the real effect at that size. Pure numpy/scipy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from calib.accel.inputs import StepMeans
from calib.discovery.effects import LIBRARY, EffectInputs
from calib.discovery.problem import TRIANGULAR_COLUMNS, Problem, scan_jump
from calib.discovery.search import final_problem
from calib.frames import SENSOR_AXES
from calib.numerics.wander import wander_cov_g2

POWER_TARGET = 0.9
LEVEL_GAP_C = 1.0  # session temperatures further apart than this are different levels
SETTLE_S = 900.0  # time between blocks (the chamber reaching its next set-point), s
BUDGET_S = 8 * 3600.0  # time a proposal may add (each block: the settling and its steps), s


@dataclass
class Proposal:
    """The added blocks that separate ``pair`` = (named, alias), and how well."""

    pair: tuple[str, str]
    setpoints_c: list  # in order; each block: every pose of the session at that set-point
    noncentrality: float
    power: float
    alpha: float
    added_steps: int
    power_before: float  # with the session alone
    kind: str = "alias"  # alias: pair = (named, alias); weak: pair = (the weak candidate, "": the model without it)
    added_s: float = 0.0  # the time the blocks add (settling and steps), s
    budget_s: float | None = None  # the time budget, s

    @property
    def reached(self) -> bool:
        """Whether the predicted power reaches :data:`POWER_TARGET`."""
        return self.power >= POWER_TARGET


def levels_c(temp_c) -> list[float]:
    """The session's temperature levels (steps within ``LEVEL_GAP_C`` of the previous sorted one share
    one), each the mean of its steps, C."""
    t = np.sort(np.asarray(temp_c, float))
    groups = np.split(t, np.flatnonzero(np.diff(t) > LEVEL_GAP_C) + 1)
    return [round(float(np.mean(g)), 1) for g in groups]


def _design_rows(prob: Problem, names: list, x: EffectInputs, n: int) -> tuple[np.ndarray, list]:
    """(3N, P) design rows (counts) of the baseline plus ``names`` at ``n`` new steps described by ``x``,
    and the column names in :meth:`Problem.design` order (nuisance columns are 0: the legs are known)."""
    blocks, names_out = [], []
    for j, a in enumerate(SENSOR_AXES):
        for c, nm in zip([np.ones(n)] + [x.f_g[:, i] for i in TRIANGULAR_COLUMNS[a]],
                         [f"b_{a}"] + [f"m_{a}{SENSOR_AXES[i]}" for i in TRIANGULAR_COLUMNS[a]]):
            full = np.zeros(3 * n)
            full[j * n:(j + 1) * n] = c
            blocks.append(full[:, None])
            names_out.append(("base", nm))
    for e in names:
        cols = np.transpose(LIBRARY[e].columns_g(x), (1, 0, 2)).reshape(3 * n, -1) * prob.lsb
        cols = np.concatenate([cols, np.zeros((3 * n, len(prob.keep[e]) - cols.shape[1]))], axis=1)
        keep = prob.keep[e]
        blocks.append(cols[:, keep])
        names_out += [(e, int(i)) for i in np.flatnonzero(keep)]
    return np.concatenate(blocks, axis=1), names_out


class _Model:
    """One explanation fitted to the session: its effects, fit, and jump time."""

    def __init__(self, prob: Problem, names: list) -> None:
        if "bias_jump" in names:
            scan_jump(prob, [n for n in names if n != "bias_jump"])
        self.names, self.t_jump = list(names), prob.t_jump
        self.fit = prob.fit(self.names)
        g, full = prob.design(self.names)
        kept = set(self.fit.names)
        self.mask = np.array([nm in kept for nm in full])
        self.g_old = g[:, self.mask]

    def new_rows(self, prob: Problem, x: EffectInputs, n: int) -> np.ndarray:
        x = EffectInputs(**{**x.__dict__, "t_jump_s": self.t_jump})
        g, _ = _design_rows(prob, self.names, x, n)
        return g[:, self.mask]


def _joint_factors(prob: Problem, steps: StepMeans, x: EffectInputs, n: int, sem_new: np.ndarray) -> list:
    """Per axis, the lower Cholesky factor of the covariance of the session's steps followed by the ``n``
    added ones (counts^2): the standard errors (the session's own; ``sem_new`` per axis for an added step) and
    the bias wander between every two of them (:func:`calib.numerics.wander.wander_cov_g2`)."""
    t = np.concatenate([np.asarray(steps.t_s, float), x.t_s])
    dur = None if steps.duration_s is None else np.concatenate(
        [np.asarray(steps.duration_s, float), np.full(n, float(np.median(steps.duration_s)))])
    w = wander_cov_g2(t, dur, steps.bias_stability) * prob.lsb ** 2
    sem = np.asarray(steps.sem_counts, float)
    return [np.linalg.cholesky(w + np.diag(np.concatenate([sem[:, j], np.full(n, sem_new[j])]) ** 2))
            for j in range(3)]


def _stacked(old: np.ndarray, new: np.ndarray, k: int, n: int) -> list:
    """Per axis, the session's rows (axis-major, ``k`` a axis) followed by the added ones (``n`` an axis)."""
    return [np.concatenate([old[j * k:(j + 1) * k], new[j * n:(j + 1) * n]]) for j in range(3)]


def _lambda(prob: Problem, truth: _Model, other: _Model, x: EffectInputs | None, n: int, factors: list | None) -> float:
    """Weighted RSS of ``other`` fitted to what ``truth`` predicts over the session and the new steps, whitened by
    their joint covariance (``factors``: :func:`_joint_factors`; None: the session alone)."""
    if x is None:
        a = prob.whiten(prob.rows(other.g_old))
        y = prob.whiten(prob.rows(truth.g_old @ truth.fit.theta))
    else:
        k = prob.k
        a_parts = _stacked(other.g_old, other.new_rows(prob, x, n), k, n)
        y_parts = _stacked(truth.g_old @ truth.fit.theta, truth.new_rows(prob, x, n) @ truth.fit.theta, k, n)
        a = np.concatenate([np.linalg.solve(c, m) for c, m in zip(factors, a_parts)])
        y = np.concatenate([np.linalg.solve(c, m) for c, m in zip(factors, y_parts)])
    theta, *_ = np.linalg.lstsq(a, y, rcond=None)
    r = y - a @ theta
    return float(r @ r)


def block_inputs(prob: Problem, steps: StepMeans, ctx, setpoints: list, poses: np.ndarray, step_s: float) -> tuple:
    """EffectInputs of the blocks at ``setpoints`` (every pose at each), appended after the session."""
    t_last = float(np.max(steps.t_s))
    prev = float(np.asarray(steps.temp_c, float)[np.argmax(steps.t_s)])
    f, temp, t, heat = [], [], [], []
    h = float(ctx.heating[np.argmax(steps.t_s)]) if ctx.heating is not None else 0.0
    for b, sp in enumerate(setpoints):
        h = 1.0 if sp > prev + 0.5 else (-1.0 if sp < prev - 0.5 else h)
        start = t_last + (b + 1) * SETTLE_S + b * len(poses) * step_s
        for i, p in enumerate(poses):
            f.append(p)
            temp.append(sp)
            t.append(start + i * step_s)
            heat.append(h)
        prev = sp
    x = EffectInputs(f_g=np.asarray(f, float), temp_c=np.asarray(temp, float), t_s=np.asarray(t, float),
                     heating=np.asarray(heat, float), matrix_g=prob.matrix_g, t0_c=prob.t0_c, t_ref_s=prob.t_ref_s,
                     temp_rate=np.zeros(len(f)))
    return x, len(f)


def propose(prob: Problem, steps: StepMeans, ctx, named: list, pair: tuple[str, str], n_candidates: int,
            false_alarm: float, max_blocks: int | None = None, budget_s: float = BUDGET_S) -> Proposal:
    """The blocks that separate ``pair`` = (the effect named, its alias) in the model ``named``.

    ``prob`` is the session's problem after the final refit (:func:`calib.discovery.search.discover`).
    """
    a_name, b_name = pair
    model_a = _Model(prob, named)
    model_b = _Model(prob, [b_name if n == a_name else n for n in named])
    q = int(prob.keep[b_name].sum())
    alpha = false_alarm / max(n_candidates, 1) / prob.multiplicity.get(b_name, 1)
    crit = stats.chi2.isf(alpha, q)
    sem, poses, step_s = _session_scales(prob, steps)

    def lam(sps):
        x, n = block_inputs(prob, steps, ctx, sps, poses, step_s) if sps else (None, 0)
        factors = _joint_factors(prob, steps, x, n, sem) if sps else None
        return min(_lambda(prob, model_a, model_b, x, n, factors), _lambda(prob, model_b, model_a, x, n, factors))

    def power(lam_):
        return float(stats.ncx2.sf(crit, q, lam_))

    levels = levels_c(steps.temp_c) if steps.temp_c is not None else []
    block_s = SETTLE_S + len(poses) * step_s
    chosen, best, before = _greedy(lam, power, levels, max_blocks, budget_s, block_s)
    if model_a.t_jump is not None:
        prob.set_jump(model_a.t_jump)
    return Proposal(pair, chosen, best, power(best), alpha, len(chosen) * len(poses), power(before),
                    added_s=len(chosen) * block_s, budget_s=budget_s)


def _greedy(lam, power, levels: list, max_blocks: int | None, budget_s: float | None, block_s: float) -> tuple:
    """Add the block (a set-point of ``levels``) that raises ``lam`` most, one at a time, until the power
    reaches :data:`POWER_TARGET`, ``max_blocks`` blocks are used, another block would take the added time
    beyond ``budget_s`` (each block ``block_s``), or the blocks left in the budget cannot reach the power even
    at the last block's gain (the gains do not grow: each block adds information the earlier ones already
    partly hold). Returns (set-points, lambda reached, lambda before)."""
    chosen: list = []
    before = best = lam([])
    needed = optimize.brentq(lambda x: power(x) - POWER_TARGET, 0.0, 1e6) if power(1e6) > POWER_TARGET else np.inf

    def room() -> int:
        left = [np.inf if max_blocks is None else max_blocks - len(chosen),
                np.inf if budget_s is None else np.floor(budget_s / block_s + 1e-9) - len(chosen)]
        return min(left)

    gain = np.inf
    while levels and room() >= 1 and power(best) < POWER_TARGET and best + gain * room() >= needed:
        new, sp = max((lam(chosen + [c]), c) for c in levels)
        gain, best = new - best, new
        chosen.append(sp)
    return chosen, best, before


def _session_scales(prob: Problem, steps: StepMeans) -> tuple:
    """(expected standard error of an added step per axis (counts: the median step's), the session's distinct
    poses, the step spacing s)."""
    sem = np.median(np.asarray(steps.sem_counts, float), axis=0)
    poses = np.unique(np.round(prob.f, 6), axis=0)
    step_s = float(np.median(np.diff(np.sort(steps.t_s)))) if len(steps) > 1 else 30.0
    return sem, poses, step_s


def propose_weak(prob: Problem, steps: StepMeans, ctx, named: list, name: str, n_candidates: int,
                 false_alarm: float, budget_s: float = BUDGET_S) -> Proposal:
    """The blocks that decide the weak candidate ``name`` at its fitted magnitude in the final model ``named``
    (power of the search's test of its columns at ``false_alarm / n_candidates``), within ``budget_s`` of
    added time. ``prob`` is the session's problem after the final refit; its jump time is restored."""
    t_jump = prob.t_jump
    model_a = _Model(prob, named + [name])  # the candidate at its fitted magnitude
    model_b = _Model(prob, named)
    q = int(prob.keep[name].sum())
    alpha = false_alarm / max(n_candidates, 1) / prob.multiplicity.get(name, 1)
    crit = stats.chi2.isf(alpha, q)
    sem, poses, step_s = _session_scales(prob, steps)
    block_s = SETTLE_S + len(poses) * step_s

    def lam(sps):
        x, n = block_inputs(prob, steps, ctx, sps, poses, step_s) if sps else (None, 0)
        return _lambda(prob, model_a, model_b, x, n, _joint_factors(prob, steps, x, n, sem) if sps else None)

    def power(lam_):
        return float(stats.ncx2.sf(crit, q, lam_))

    levels = levels_c(steps.temp_c) if steps.temp_c is not None else []
    chosen, best, before = _greedy(lam, power, levels, None, budget_s, block_s)
    if t_jump is not None and prob.t_jump != t_jump:
        prob.set_jump(t_jump)
    return Proposal((name, ""), chosen, best, power(best), alpha, len(chosen) * len(poses),
                    power(before), kind="weak", added_s=len(chosen) * block_s, budget_s=budget_s)


def separating(steps: StepMeans, ctx, d, false_alarm: float, max_blocks: int | None = None,
               budget_s: float = BUDGET_S) -> list[Proposal]:
    """A :class:`Proposal` for every alias of every named effect of the discovery ``d`` (none: nothing to
    separate). Sessions with unknown poses are refused by the caller (no poses to propose)."""
    named = [e.name for e in d.effects]
    pairs = [(g[0], b) for g in d.aliases if g[0] in named for b in g[1:]]
    if not pairs:
        return []
    prob, observable = final_problem(steps, ctx, named, false_alarm)
    return [propose(prob, steps, ctx, named, pair, len(observable), false_alarm, max_blocks, budget_s)
            for pair in pairs]


def deciding(steps: StepMeans, ctx, d, false_alarm: float, budget_s: float = BUDGET_S) -> list[Proposal]:
    """A :class:`Proposal` (``kind`` weak) for every weak candidate of the discovery ``d`` (``d.weak``; none:
    nothing to decide). ``rig discover --propose`` asks for these only when no alias remains: the aliases'
    experiment comes first (one question at a time)."""
    weak = [w["name"] for w in d.weak]
    if not weak:
        return []
    named = [e.name for e in d.effects]
    prob, observable = final_problem(steps, ctx, named, false_alarm)
    return [propose_weak(prob, steps, ctx, named, w, len(observable), false_alarm, budget_s) for w in weak]
