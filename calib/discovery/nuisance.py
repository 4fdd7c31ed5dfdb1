"""Lack of fit: when the named effects leave the gap open, is what remains better described by a
generic factor than by the effects that were named on the way?

Forward selection names whatever lowers chi-square most, and when the truth lies outside the library
it keeps naming effects that each soak up a little of it. So, when the gap stays open, generic
**factor models** of the residual are fitted as nuisance structure, each an offset per axis and per
level of one grouping of the steps (the ``FACTORS`` table: outer-axis angle, pose, time block,
temperature level, leg), plus a **change point** in time (a bias step per axis, its time searched,
Bonferroni over the times). A factor is used only when its levels group the steps (2 to K/2 levels).

The factor with the smallest p-value of its F test (added to the named effects; a factor is tried only
when the gap is open, when the stated noise itself is in doubt, so its scale is the scatter that
remains, not that noise) is kept when that p-value, multiplied by the number of factors tried
(Bonferroni: the best of several factors is significant at ``false_alarm`` only then), is below
``false_alarm``; every named effect is then re-tested with it in the model (backward elimination, the
least significant first, at ``false_alarm``) and those it makes unnecessary are dropped; an effect whose
columns lie wholly inside the factor's span (a bias jump at a time-block boundary) adds nothing to it
and is dropped too. The factor is reported under ``unexplained.factor`` (``p_value`` the
Bonferroni-adjusted one, ``tried`` the number of factors compared); it never enters the calibration.
"""

from __future__ import annotations

import numpy as np

from calib.discovery.problem import Problem, f_test, jump_times
from calib.frames import SENSOR_AXES

TIME_BLOCKS = 6
FINE_BLOCKS = 12
MIN_LEVEL_GAP_C = 1.0


def _angle(prob: Problem):
    a = prob.ctx.angles_deg
    if a is None or not np.all(np.isfinite(a)):
        return None
    return np.round(np.asarray(a, float)[:, 0] % 360).astype(int)


def _pose(prob: Problem):
    return np.asarray([str(n) for n in prob.steps.names], dtype=object)


def _time_blocks(n_blocks: int):
    def labels(prob: Problem):
        t = np.asarray(prob.steps.t_s, float)
        rank = np.argsort(np.argsort(t))
        return np.minimum(rank * n_blocks // max(len(t), 1), n_blocks - 1)
    return labels


def _temperature(prob: Problem):
    """Temperature levels: steps within ``MIN_LEVEL_GAP_C`` of the previous (sorted) temperature share one."""
    if prob.steps.temp_c is None:
        return None
    temp = np.asarray(prob.steps.temp_c, float)
    order = np.argsort(temp)
    levels = np.cumsum(np.concatenate([[0], np.diff(temp[order]) > MIN_LEVEL_GAP_C]))
    out = np.empty(len(temp), int)
    out[order] = levels
    return out


def _leg(prob: Problem):
    return None if prob.ctx.heating is None else np.asarray(prob.ctx.heating, int)


#: factor name -> step labels (None: the session lacks the data)
FACTORS = {"outer_axis_angle": _angle, "pose": _pose, "time_block": _time_blocks(TIME_BLOCKS),
           "time_block_fine": _time_blocks(FINE_BLOCKS), "temperature_level": _temperature,
           "leg": _leg}


def factor_columns(prob: Problem, labels) -> tuple[np.ndarray, list]:
    """(3K, 3 L) indicator columns, an offset per axis and level, and their names."""
    k = prob.k
    levels = list(dict.fromkeys(np.asarray(labels).tolist()))
    cols, names = [], []
    for j, a in enumerate(SENSOR_AXES):
        for lv in levels:
            c = np.zeros(3 * k)
            c[j * k:(j + 1) * k] = (np.asarray(labels) == lv)
            cols.append(c)
            names.append(f"{a}@{lv}")
    return np.stack(cols, axis=1), names


def _change_point(prob: Problem, selected: list, base):
    """The bias step (per axis) at the step boundary that lowers chi2 most; (p, extra, t_s)."""
    t = np.asarray(prob.steps.t_s, float)
    grid = jump_times(t)
    best = None
    for tj in grid:
        extra = factor_columns(prob, (t >= tj).astype(int))
        big = prob.fit(selected, extra)
        if best is None or big.rss < best[0].rss:
            best = (big, extra, float(tj))
    if best is None:
        return None
    _, p = f_test(base, best[0])
    return min(1.0, p * len(grid)), best[1], best[2]


def candidates(prob: Problem, selected: list, base) -> dict:
    """Every usable factor: name -> (p-value of adding it to ``selected``, (columns, names), detail)."""
    out = {}
    for name, labels_of in FACTORS.items():
        labels = labels_of(prob)
        if labels is None:
            continue
        n_levels = len(set(np.asarray(labels).tolist()))
        if not 2 <= n_levels <= prob.k // 2:
            continue
        extra = factor_columns(prob, labels)
        _, p = f_test(base, prob.fit(selected, extra))
        out[name] = (p, extra, {"levels": n_levels})
    cp = _change_point(prob, selected, base)
    if cp is not None:
        out["change_point"] = (cp[0], cp[1], {"t_s": cp[2]})
    return out


def lack_of_fit(prob: Problem, selected: list, alpha: float, fit, needs: dict) -> tuple[list, dict | None]:
    """The named effects that survive the best nuisance factor, and the factor (None when no factor is
    significant at ``alpha``, Bonferroni over the factors tried). ``fit(names, extra)`` fits (cached by
    the caller); ``needs`` maps an effect to those that need it in the model (bias_tempco under its
    higher orders)."""
    base = fit(selected, None)
    found = candidates(prob, selected, base)
    if not found:
        return selected, None
    name = min(found, key=lambda n: found[n][0])
    p, extra, detail = found[name]
    p = min(1.0, p * len(found))  # the best of len(found) factors: Bonferroni
    if p >= alpha:
        return selected, None
    kept, dropped = list(selected), []
    while kept:
        full = fit(kept, extra)
        pvals = {}
        for n in kept:
            if any(m in kept for m in needs.get(n, ())):
                continue
            small = fit([s for s in kept if s != n], extra)
            # wholly inside the factor's span (no dof of its own left): the factor makes it unnecessary
            pvals[n] = 1.0 if small.dof == full.dof else prob.test(n, small, full)[1]
        if not pvals or max(pvals.values()) <= alpha:
            break
        worst = max(pvals, key=pvals.get)
        kept.remove(worst)
        dropped.append(worst)
    with_factor = fit(kept, extra)
    without = fit(kept, None)
    return kept, {"name": name, "p_value": float(p), "tried": len(found), **detail, "dropped": dropped,
                  "chi2_drop": float(without.rss - with_factor.rss), "dof": int(without.dof - with_factor.dof),
                  "rms_with_factor_g": prob.rms_g(with_factor)}
