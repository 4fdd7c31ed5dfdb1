"""Which effects are named: forward selection, aliases, backward elimination and the final re-test.

1. **Forward** stepwise selection with the search's nested test (:func:`calib.discovery.problem.nested_test`),
   Bonferroni over the candidates left; the jump's time is searched over the step boundaries and its
   p-value multiplied by the number of times tried.
2. **Aliases**: candidates each significant alone but neither once the other is in the model are
   reported together; :func:`preference` (not the p-value) picks the one used. Occam counts every fitted
   parameter: the linear columns (nuisance columns included) **and** the nonlinear ones (:data:`NONLINEAR`,
   the jump's time); a jump whose best time coincides with a design boundary (a leg switch, a change of
   temperature level, the end of a pose block: :func:`design_boundaries`) is a coincidence the design
   explains, so any other explanation aliased with it is preferred.
3. **Backward** elimination: what a later entry made unnecessary is removed (the order of selection must
   not decide the names), the jump's time re-searched in every model compared.
4. **Supported** (:func:`supported`): after the final refit (M re-linearised, the jump re-searched) every
   named effect is re-tested in the final model (its drop-one test); one whose p-value there is above
   the false-alarm rate is dropped, the least supported first, and reported as ``unsupported``. The
   p-value reported with a named effect is this final-model one.
5. **Weak candidates** (:func:`weak_candidates`): an observable effect left unnamed whose test in the final
   model (the search's nested test, the jump's time searched) has a p-value that, times the candidates
   tested, is below :data:`WEAK_LEVEL` (Bonferroni at a looser family level than the false-alarm rate: on a
   clean session at most about 20 % of sessions list one) is reported as *weak*, never named, with its
   fitted magnitude, that p-value and the design's minimum detectable magnitude; an alias of a named effect
   is not (its own proposal separates it), nor an estimate beyond the physically plausible.
"""

from __future__ import annotations

import numpy as np

from calib.discovery.effects import LIBRARY, plausible
from calib.discovery.problem import Problem, scan_jump

TEMP_EFFECTS = ("bias_tempco_quadratic", "bias_tempco_cubic")  # enter only after bias_tempco
NEEDS = {"bias_tempco": TEMP_EFFECTS}  # bias_tempco stays while a higher order is in
POLYNOMIAL = ("bias_tempco",) + TEMP_EFFECTS  # the seed's thermal model: preferred among aliases
ORDER = list(LIBRARY)  # among equally simple aliases, the library's order (the more common physics first)
#: fitted parameters of an effect beyond its linear columns (the jump's time)
NONLINEAR = {"bias_jump": 1}
LEVEL_GAP_C = 1.0  # consecutive steps further apart than this in temperature: a change of level
#: a design boundary's kind -> the nuisance factor (calib.discovery.nuisance.FACTORS) that is an offset per
#: its levels: a jump there is aliased with that factor
BOUNDARY_FACTOR = {"leg switch": "leg", "temperature change": "temperature_level", "pose change": "pose"}
#: family level of the weak candidates: p-value in the final model times the candidates tested below this
WEAK_LEVEL = 0.2


def parameters(prob: Problem, name: str) -> int:
    """Every parameter effect ``name`` fits: its determined columns (nuisance columns included) and its
    nonlinear parameters."""
    return int(prob.keep[name].sum()) + NONLINEAR.get(name, 0)


def design_boundaries(prob: Problem) -> dict:
    """Midpoints between consecutive steps (in time) where the design changes -> the kinds of change:
    ``leg switch`` (the heating/cooling leg changes), ``temperature change`` (more than
    :data:`LEVEL_GAP_C` between the steps), ``pose change`` (only when poses come in blocks: fewer than
    half of the consecutive steps change pose; otherwise every boundary would be one)."""
    t = np.asarray(prob.steps.t_s, float)
    order = np.argsort(t, kind="stable")
    mids = 0.5 * (t[order][:-1] + t[order][1:])
    kinds: dict = {}
    changes = {}
    h = prob.ctx.heating
    if h is not None:
        hh = np.asarray(h, float)[order]
        changes["leg switch"] = hh[1:] != hh[:-1]
    if prob.steps.temp_c is not None:
        tc = np.asarray(prob.steps.temp_c, float)[order]
        changes["temperature change"] = np.abs(np.diff(tc)) > LEVEL_GAP_C
    pose = _pose_labels(prob)[order]
    moved = pose[1:] != pose[:-1]
    if moved.mean() < 0.5:
        changes["pose change"] = moved
    for kind, mask in changes.items():
        for m in mids[mask]:
            kinds.setdefault(float(m), []).append(kind)
    return kinds


def _pose_labels(prob: Problem) -> np.ndarray:
    if prob.pose_free and prob.ctx.pose_group is not None:
        return np.asarray(prob.ctx.pose_group)
    return np.unique(np.round(prob.f, 6), axis=0, return_inverse=True)[1].ravel()


def jump_boundary(prob: Problem) -> list:
    """The design boundaries the jump's current time coincides with (empty: none)."""
    if prob.t_jump is None:
        return []
    return next((v for m, v in design_boundaries(prob).items() if abs(m - prob.t_jump) <= 1e-6 * max(1, abs(m))), [])


def preference(prob: Problem, name: str) -> tuple:
    """Sort key among aliases, the preferred first: a term of the temperature polynomial (the seed's own
    thermal model), then anything but a jump sitting on a design boundary (the boundary explains it
    without a free time), then the fewest fitted parameters (:func:`parameters`), then the library's order."""
    return (name not in POLYNOMIAL, name == "bias_jump" and bool(jump_boundary(prob)), parameters(prob, name),
            ORDER.index(name))


def remaining(observable: list, selected: list) -> list:
    """The candidates that may enter a model holding ``selected``: the observable ones not in it, the
    higher temperature orders only once ``bias_tempco`` is in."""
    return [n for n in observable if n not in selected and (n not in TEMP_EFFECTS or "bias_tempco" in selected)]


def select(prob: Problem, observable: list, alpha: float, fit, progress=None) -> tuple[list, list]:
    """Forward stepwise selection (Bonferroni over the candidates left), aliases, then backward elimination.

    When the most significant candidate has aliases (neither it nor they significant once the other
    is in), a physically plausible estimate (:func:`calib.discovery.effects.plausible`) and then
    :func:`preference` decide which enters; the group is reported, that one first.
    """
    selected: list[str] = []
    aliases: list[list[str]] = []
    prob.last_pass = {}
    while True:
        left = remaining(observable, selected)
        if not left:
            break
        if progress is not None:
            progress(f"forward pass {len(selected) + 1}: {len(left)} candidates tested")
        cur = fit(selected)
        if "bias_jump" in left:
            scan_jump(prob, selected)
        pvals = {n: prob.test(n, cur, fit(selected + [n])) for n in left}
        thr = alpha / len(left)
        best = min(left, key=lambda n: (pvals[n][1], -pvals[n][0]))
        if pvals[best][1] >= thr:
            prob.last_pass = {n: (pvals[n][1], thr) for n in left}
            break
        group = [best] + [n for n in left if n != best and pvals[n][1] < thr and aliased(prob, fit, selected,
                                                                                        best, n, thr)]
        chosen = min(group, key=lambda n: (not plausible(n, estimate(fit(selected + [n]), n, len(prob.labels[n]))),
                                           *preference(prob, n)))
        if len(group) > 1:
            aliases.append([chosen] + [n for n in group if n != chosen])
        selected.append(chosen)
    return backward(prob, selected, alpha, fit), aliases


def estimate(fit, name: str, n_params: int) -> np.ndarray:
    """Effect ``name``'s parameters in ``fit`` (its unit; NaN where not determined)."""
    est = np.full(n_params, np.nan)
    for col, (blk, idx) in enumerate(fit.names):
        if blk == name and idx < n_params:
            est[idx] = fit.theta[col]
    return est


def aliased(prob: Problem, fit, selected: list, best: str, n: str, thr: float) -> bool:
    """Neither ``best`` nor ``n`` is significant once the other is in the model."""
    p_n = prob.test(n, fit(selected + [best]), fit(selected + [best, n]))[1]
    p_b = prob.test(best, fit(selected + [n]), fit(selected + [n, best]))[1]
    return p_n >= thr and p_b >= thr


def drop_one(prob: Problem, selected: list, name: str, fit) -> float:
    """The p-value of ``name`` in the model ``selected``: the nested test of the model without it (and
    without what needs it: the higher temperature orders with ``bias_tempco``) against the model, the
    jump's time searched in each (restored after)."""
    gone = {name, *[m for m in NEEDS.get(name, ()) if m in selected]}
    small = [s for s in selected if s not in gone]
    t_jump = prob.t_jump
    if "bias_jump" in selected:
        scan_jump(prob, [s for s in selected if s != "bias_jump"])
    big = fit(selected)
    if "bias_jump" in small:
        scan_jump(prob, [s for s in small if s != "bias_jump"])
    p = prob.test(name, fit(small), big)[1]
    if "bias_jump" in selected and t_jump is not None:
        prob.set_jump(t_jump)
    return p


def backward(prob: Problem, selected: list, alpha: float, fit) -> list:
    """Drop, the least significant first, what is no longer significant given the rest (the jump's time
    re-searched in every model compared)."""
    selected = list(selected)
    while selected:
        drops = {n: drop_one(prob, selected, n, fit) for n in selected
                 if not any(m in selected for m in NEEDS.get(n, ()))}
        if not drops:
            break
        worst = max(drops, key=drops.get)
        if drops[worst] <= alpha:
            break
        selected.remove(worst)
    if "bias_jump" in selected:
        scan_jump(prob, [s for s in selected if s != "bias_jump"])
    return selected


def supported(prob: Problem, selected: list, alpha: float, refit, cache) -> tuple:
    """Re-test every named effect in the final model; drop, the least supported first, those whose
    p-value there is above ``alpha``, refitting after each.

    ``refit(prob, names)`` is the final refit (M re-linearised, the jump re-searched); ``cache(prob)``
    a fresh fit cache (the columns change with M). Returns (names kept, their final fit, name ->
    final-model p-value, [(dropped name, its p-value)]).
    """
    selected, unsupported = list(selected), []
    while True:
        final = refit(prob, selected)
        fit = cache(prob)
        pvals = {n: drop_one(prob, selected, n, fit) for n in selected}
        worst = max(pvals, key=pvals.get) if pvals else None
        if worst is None or pvals[worst] <= alpha:
            return selected, final, pvals, unsupported
        unsupported.append((worst, pvals[worst]))
        gone = {worst, *NEEDS.get(worst, ())}
        selected = [s for s in selected if s not in gone]


def weak_candidates(prob: Problem, selected: list, observable: list, aliases: list, fit,
                    level: float = WEAK_LEVEL) -> list:
    """The effects not named with some support in the final model ``selected`` (see the module's item 5).

    ``fit`` is a fit cache of ``prob`` after the final refit. Each candidate that may enter
    (:func:`remaining`), is not an alias of a named effect and has a plausible estimate is added alone to
    the final model and tested (the jump's time searched; restored after). Returns, the most supported first,
    ``[{name, axes, estimate, sigma, p_value, p_family, threshold}]``: the estimate and its 1-sigma in the
    effect's unit, ``p_value`` the test's (times the jump times for a jump), ``p_family`` that times the
    candidates tested, ``threshold`` the p-value below which a candidate is weak (``level`` / candidates).
    """
    aliased_ = {n for g in aliases if g[0] in selected for n in g[1:]}
    left = [n for n in remaining(observable, selected) if n not in aliased_]
    if not left:
        return []
    t_jump = prob.t_jump
    cur = fit(selected)
    out = []
    for n in left:
        if n == "bias_jump":
            scan_jump(prob, selected)
        big = fit(selected + [n])
        p = prob.test(n, cur, big)[1]
        est = estimate(big, n, len(prob.labels[n]))
        if p * len(left) >= level or not plausible(n, est):
            continue
        sig = np.sqrt(np.diag(big.cov0))
        sd = np.full(len(est), np.nan)
        for col, (blk, idx) in enumerate(big.names):
            if blk == n and idx < len(sd):
                sd[idx] = sig[col]
        out.append({"name": n, "axes": list(prob.labels[n]), "estimate": est.tolist(), "sigma": sd.tolist(),
                    "p_value": float(p), "p_family": float(min(1.0, p * len(left))),
                    "threshold": level / len(left)})
    if t_jump is not None and prob.t_jump != t_jump:
        prob.set_jump(t_jump)
    return sorted(out, key=lambda w: w["p_value"])
