"""Discriminating experiments: when two explanations are aliases, which added steps tell them apart?

For an alias pair (A, the effect named; B, its alias) both models are fitted to the session (the final
model, and the final model with B in A's place; a jump's time searched). Added steps are blocks: a
chamber set-point (one of the session's temperature levels, reached from the previous one, so its leg
is known) and every pose of the session at it. The **T-optimal** criterion for a sequence of blocks is
the non-centrality of the test between the models: fit B to what A predicts over the session and the
added steps (the session's rows whitened by its covariance, the added steps' by their expected
standard error: the median step standard error and the stated bias wander, independent between the
added steps), and take the weighted residual sum of squares; and the same with A and B exchanged: the
smaller of the two (``lambda``). The added steps are chosen greedily, one block at a time, the one that
raises ``lambda`` most, until the predicted **power** of the search's test of B's columns at level
``false_alarm / candidates`` (a non-central chi-square; Bonferroni over the jump times for a jump)
reaches ``POWER_TARGET`` or the block budget is spent. Pure numpy/scipy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from calib.accel.inputs import StepMeans
from calib.discovery.effects import LIBRARY, EffectInputs
from calib.discovery.problem import TRIANGULAR_COLUMNS, Problem, scan_jump
from calib.discovery.search import final_problem
from calib.frames import SENSOR_AXES

POWER_TARGET = 0.9
LEVEL_GAP_C = 1.0  # session temperatures further apart than this are different levels
SETTLE_S = 900.0  # time between blocks (the chamber reaching its next set-point), s


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


def _lambda(prob: Problem, truth: _Model, other: _Model, x: EffectInputs | None, n: int, sd: np.ndarray) -> float:
    """Weighted RSS of ``other`` fitted to what ``truth`` predicts over the session and the new steps."""
    rows = [prob.whiten(prob.rows(other.g_old))]
    target = [prob.whiten(prob.rows(truth.g_old @ truth.fit.theta))]
    if x is not None:
        w = np.repeat(sd, n)[:, None]
        rows.append(other.new_rows(prob, x, n) / w)
        target.append((truth.new_rows(prob, x, n) @ truth.fit.theta) / w[:, 0])
    a, y = np.concatenate(rows), np.concatenate(target)
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
            false_alarm: float, max_blocks: int = 4) -> Proposal:
    """The blocks that separate ``pair`` = (the effect named, its alias) in the model ``named``.

    ``prob`` is the session's problem after the final refit (:func:`calib.discovery.search.discover`).
    """
    a_name, b_name = pair
    model_a = _Model(prob, named)
    model_b = _Model(prob, [b_name if n == a_name else n for n in named])
    q = int(prob.keep[b_name].sum())
    alpha = false_alarm / max(n_candidates, 1) / prob.multiplicity.get(b_name, 1)
    crit = stats.chi2.isf(alpha, q)
    sem = np.median(np.asarray(steps.sem_counts, float), axis=0)
    sd = np.sqrt(sem ** 2 + (np.sqrt(np.mean(np.diag(prob.wander_g2))) * prob.lsb) ** 2)
    poses = np.unique(np.round(prob.f, 6), axis=0)
    step_s = float(np.median(np.diff(np.sort(steps.t_s)))) if len(steps) > 1 else 30.0

    def lam(sps):
        x, n = block_inputs(prob, steps, ctx, sps, poses, step_s) if sps else (None, 0)
        return min(_lambda(prob, model_a, model_b, x, n, sd), _lambda(prob, model_b, model_a, x, n, sd))

    def power(lam_):
        return float(stats.ncx2.sf(crit, q, lam_))

    chosen: list = []
    levels = levels_c(steps.temp_c) if steps.temp_c is not None else []
    before = lam([])
    best = before
    while levels and len(chosen) < max_blocks and power(best) < POWER_TARGET:
        best, sp = max((lam(chosen + [c]), c) for c in levels)
        chosen.append(sp)
    if model_a.t_jump is not None:
        prob.set_jump(model_a.t_jump)
    return Proposal(pair, chosen, best, power(best), alpha, len(chosen) * len(poses), power(before))


def separating(steps: StepMeans, ctx, d, false_alarm: float, max_blocks: int = 4) -> list[Proposal]:
    """A :class:`Proposal` for every alias of every named effect of the discovery ``d`` (none: nothing to
    separate). Sessions with unknown poses are refused by the caller (no poses to propose)."""
    named = [e.name for e in d.effects]
    pairs = [(g[0], b) for g in d.aliases if g[0] in named for b in g[1:]]
    if not pairs:
        return []
    prob, observable = final_problem(steps, ctx, named, false_alarm)
    return [propose(prob, steps, ctx, named, pair, len(observable), false_alarm, max_blocks) for pair in pairs]
