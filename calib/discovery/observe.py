"""Which candidate effects a session can observe, decided by the data.

Only facts that are genuinely missing data are rules (:func:`missing_data`): no temperatures, no
temperature rate per step, no pose rotations, poses unknown, no heating/cooling record, too few
steps in time for a jump. Everything else is decided by the candidate's columns against the model
(:func:`observability`), in the whitened metric of the fit:

- **rank**: the columns whose part outside the model's span is below ``COLUMN_TOL`` of their norm
  add nothing (dropped); none left: unobservable;
- **conditioning**: the variance inflation of each parameter, ``VIF = |c|^2 / |P c|^2`` (P projects
  out the model); above ``MAX_VIF`` the parameter is confounded with the model to the point that
  its estimate means nothing: unobservable, with the VIF said;
- **minimum detectable magnitude** (MDM) per parameter: the search's test of the candidate (q
  columns, ``d`` dof left after it; :func:`calib.discovery.problem.nested_test`) at level ``alpha``
  (the false-alarm rate split over the candidates, and over the jump times for ``bias_jump``) reaches
  power ``POWER`` when its non-centrality ``lambda = theta_j^2 |P c_j|^2`` reaches ``lambda*``
  (:func:`critical_noncentrality`); ``MDM_j = sqrt(lambda* / |P c_j|^2)``, in the effect's unit, the
  parameter acting alone.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import optimize

from calib.discovery.problem import Problem, determined, floored_sf, independent
from calib.discovery.effects import LIBRARY

POWER = 0.8
MAX_VIF = 1e4
FORCE_EFFECTS = {"scale_tempco", "scale_nonlinearity", "cross_axis_nonlinearity", "full_misalignment",
                 "table_tilt", "pose_error"}

#: need -> (is it missing?, why): only missing data, never a design rule
MISSING = {
    "temp": (lambda s, c: s.temp_c is None, "no temperature readings"),
    "rate": (lambda s, c: c.temp_rate is None or not np.all(np.isfinite(c.temp_rate)),
             "no temperature rate per step (temperature samples inside each step)"),
    "legs": (lambda s, c: c.heating is None, "no heating/cooling record"),
    "rotation": (lambda s, c: c.base_to_sensor is None, "pose rotations unknown"),
    "placement": (lambda s, c: c.angles_deg is not None or c.base_to_sensor is not None,
                  "the poses were set by the turntable (its angles are recorded), not placed by hand"),
}


def missing_data(name: str, steps, ctx, pose_free: bool, n_jump_times: int) -> str | None:
    """What data the session lacks for effect ``name`` (None when it has it all)."""
    for need in LIBRARY[name].needs:
        if need in MISSING and MISSING[need][0](steps, ctx):
            return MISSING[need][1]
    if name == "bias_jump" and n_jump_times == 0:
        return "fewer than 6 steps at distinct times (no jump time with 3 steps on each side)"
    if pose_free and name in FORCE_EFFECTS:
        return "poses unknown (f_nominal null)"
    return None


@functools.lru_cache(maxsize=512)
def critical_value(q: int, dof: int, alpha: float) -> float:
    """The statistic of :func:`calib.discovery.problem.nested_test` exceeded with probability ``alpha``
    under the null (``q`` columns, ``dof`` left after them)."""
    return float(optimize.brentq(lambda t: floored_sf(t, q, dof) - alpha, 1e-9, 1e6))


@functools.lru_cache(maxsize=512)
def critical_noncentrality(q: int, alpha: float, dof: int = 0, power: float = POWER) -> float:
    """lambda* at which the search's test of ``q`` columns, ``dof`` dof left after them, at level
    ``alpha`` reaches ``power`` (:func:`calib.discovery.problem.floored_sf` at that non-centrality)."""
    crit = critical_value(q, dof, alpha)
    return float(optimize.brentq(lambda lam: floored_sf(crit, q, dof, lam) - power, 1e-9, 1e6))


def observability(prob: Problem, name: str, alpha: float, model: list | None = None) -> dict:
    """Rank, conditioning and MDM of candidate ``name`` against the baseline plus ``model`` effects.

    Returns ``{"rank", "columns", "max_vif", "mdm", "unit", "alpha", "power", "keep"}``; ``mdm`` per
    parameter in the effect's unit (None where the parameter is not determined).
    """
    lib = LIBRARY[name]
    g, _ = prob.design(list(model or []))
    gw = prob.whiten(prob.rows(g))
    q_basis, _ = np.linalg.qr(gw)
    cw = prob.whiten(prob.rows(prob.cols[name]))
    keep = independent(q_basis, cw)
    norms2 = np.sum(cw ** 2, axis=0)
    outside2 = np.sum((cw - q_basis @ (q_basis.T @ cw)) ** 2, axis=0)
    vif = np.where(keep & (outside2 > 0), norms2 / np.where(outside2 > 0, outside2, 1.0), np.inf)
    keep &= vif <= MAX_VIF
    n_par = len(prob.labels[name])
    q = int(keep.sum())
    a = alpha / prob.multiplicity.get(name, 1)
    dof = len(cw) - int(determined(gw).sum()) - q  # left after the candidate
    lam = critical_noncentrality(q, a, dof) if q else np.inf
    mdm = [float(np.sqrt(lam / outside2[i])) if keep[i] else None for i in range(n_par)]
    finite = vif[:n_par][np.isfinite(vif[:n_par])]
    return {"rank": int(keep[:n_par].sum()), "columns": n_par, "max_vif": float(finite.max()) if len(finite) else None,
            "mdm": mdm, "unit": lib.unit, "alpha": a, "power": POWER, "keep": keep, "dof": dof}


def why_unobservable(info: dict) -> str:
    """The reason, in words, for a candidate whose columns the data cannot determine."""
    if info["rank"] and info["dof"] <= 0:
        return (f"its {info['rank']} parameters would absorb every residual degree of freedom (nothing left to "
                "test it against: more steps per placement, pose or level are needed)")
    if info["max_vif"] is not None and info["max_vif"] > MAX_VIF:
        return (f"ill-conditioned: its columns lie almost wholly in the model's span (variance inflation "
                f"{info['max_vif']:.3g} > {MAX_VIF:g})")
    return "every term is zero or already in the baseline model at these poses (rank 0 beyond the model)"


def triage(prob: Problem, names: list, alpha: float) -> tuple[list, list, dict, dict]:
    """Split the candidates into observable and unobservable ones (with the reason) and give each
    observable one its rank, conditioning and MDM (:func:`observability`; alpha split over them)."""
    unobservable, why, observable, info = [], {}, [], {}
    lacking = {n: missing_data(n, prob.steps, prob.ctx, prob.pose_free, len(prob.jump_grid)) for n in names}
    prob.build_columns([n for n in names if lacking[n] is None])  # columns only where the data exist
    for n in names:
        problem = lacking[n]
        if problem is None:
            keep = prob.observable_columns(n)
            if keep[:len(prob.labels[n])].any():
                prob.keep[n] = keep
                observable.append(n)
                continue
            problem = "every term is zero or already in the baseline model at these poses"
        unobservable.append(n)
        why[n] = problem
    for n in list(observable):
        info[n] = observability(prob, n, alpha / max(len(observable), 1))
        if info[n]["rank"] == 0 or info[n]["dof"] <= 0:
            observable.remove(n)
            unobservable.append(n)
            why[n] = why_unobservable(info[n])
            continue
        prob.keep[n] = info[n].pop("keep")
        info[n].pop("dof")
    for n in why:
        info.pop(n, None)
    return observable, unobservable, why, info
