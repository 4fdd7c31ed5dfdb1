"""The accelerometer's uncertainty budget (docs/uncertainty.md): ``accelerometer.uncertainty`` of the
calibration file, mirroring the keys of ``sigma`` (``bias_counts``, ``scale_counts_per_g``,
``matrix_counts_per_g``, ``misalignment``) with the expanded uncertainty ``U = k u_c``, the coverage factor
``k`` and the ``budget``: every contribution's standard uncertainty of every quantity.

Contributions:

- **Type A, noise and wander**: the solve's ``sigma`` (``sigma`` keeps its meaning in the file), without the
  misfit scaling the solve gives it (:func:`birge_ratio`): on a turntable that misfit is the rig's geometry,
  which the Type B terms below hold.
- **Type B, the rig's geometry** (:mod:`calib.accel.rig_propagation`): every error of the turntable (the
  sensor's mounting and the stage zeros; the non-orthogonalities; each stage's periodic and accumulated
  angular errors and wobble; lost motion, per pose unless every pose is approached from one side) moves the
  poses as it does on the table, correlated between poses, and the session is solved again: the solve's own
  sensitivity, whatever its method and model, times the error's standard uncertainty (its class, or its
  characterised value). Listed in four groups.
- **Type B, gravity**: the stated local g's relative uncertainty scales M (scale factors and matrix; biases
  and angles do not depend on it).
- **Type B, thermometer**: each step's temperature off by the thermometer's non-repeatability, propagated by
  re-solving (only with a thermal model; a constant thermometer offset cancels: the same thermometer is read
  when the calibration is applied).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from calib.accel.inputs import StepMeans
from calib.accel.result import MISALIGNMENT_NAMES, AccelCalibration
from calib.numerics.budget import DEFAULT_K, Contribution, RigErrors, combined, expanded
from calib.accel.rig_propagation import EPS_DEG, GROUPS, pose_shift, rig_parameters, stage_angles_deg
from calib.numerics.gravity import G0_M_S2, Gravity

#: step of the thermometer's finite differences, C
EPS_C = 1e-3

Resolve = Callable[[StepMeans], AccelCalibration]


def quantities(cal: AccelCalibration) -> dict[str, float]:
    """Every quantity of ``sigma``'s keys as a flat name -> value map (``bias_counts[0]``, ...)."""
    q = {}
    for key in ("bias_counts", "scale_counts_per_g"):
        q.update({f"{key}[{i}]": float(v) for i, v in enumerate(np.asarray(getattr(cal, key), float))})
    m = np.asarray(cal.matrix_counts_per_g, float)
    q.update({f"matrix_counts_per_g[{i}][{j}]": float(m[i, j]) for i in range(3) for j in range(3)})
    if cal.misalignment is not None:
        q.update({f"misalignment.{n}": float(cal.misalignment[n]) for n in MISALIGNMENT_NAMES})
    return q


def birge_ratio(cal: AccelCalibration) -> float:
    """The factor the solve scaled its sigmas by for a misfit (sqrt(chi2/dof) when :meth:`AccelCalibration.misfit`
    says it did, else 1). On a turntable the misfit is mostly the rig's geometry, which the budget's Type B
    terms hold: the budget's Type A is ``sigma`` without it, so that nothing is counted twice."""
    scaled, _ = cal.misfit()
    chi2 = cal.fit.chi2_per_dof
    return float(np.sqrt(chi2)) if scaled and chi2 is not None and np.isfinite(chi2) and chi2 > 1 else 1.0


def flat_sigma(cal: AccelCalibration) -> dict[str, float]:
    """``sigma`` flattened like :func:`quantities` (NaN where it has no value)."""
    sig = cal.sigma
    out = {}
    for name in quantities(cal):
        key, _, rest = name.partition("[") if "[" in name else name.partition(".")
        value = sig.get(key)
        if value is None:
            out[name] = float("nan")
        elif isinstance(value, dict):
            out[name] = float(value.get(rest, float("nan")))
        else:
            idx = [int(x) for x in rest.replace("]", "").split("[") if x]
            out[name] = float(np.asarray(value, float)[tuple(idx)])
    return out


def nest(flat: dict[str, float], like: AccelCalibration) -> dict:
    """A flat map back in ``sigma``'s shape: lists of 3, a 3x3 list, the misalignment mapping."""
    out = {"bias_counts": [flat[f"bias_counts[{i}]"] for i in range(3)],
           "scale_counts_per_g": [flat[f"scale_counts_per_g[{i}]"] for i in range(3)],
           "matrix_counts_per_g": [[flat[f"matrix_counts_per_g[{i}][{j}]"] for j in range(3)] for i in range(3)]}
    if like.misalignment is not None:
        out["misalignment"] = {n: flat[f"misalignment.{n}"] for n in MISALIGNMENT_NAMES}
    return out


def at_local_gravity(steps: StepMeans, gravity: Gravity) -> StepMeans:
    """``steps`` with the nominal specific force of the site: ``f_nominal`` times g / g0 (the file's unit is g0;
    a rig where gravity is g sees g / g0 at rest). Without it a solve's scale factors carry g / g0 - 1
    (6.3e-4 at 52 deg latitude): the gravity contribution of the budget then does not cover them."""
    return _replace(steps, f_nominal_g=np.asarray(steps.f_nominal_g, float) * (gravity.g_m_s2 / G0_M_S2))


def _replace(steps: StepMeans, **changes) -> StepMeans:
    fields = {k: getattr(steps, k) for k in steps.__dataclass_fields__}
    fields.update(changes)
    return StepMeans(**fields)


def _response(resolve: Resolve, base: dict[str, float], steps: StepMeans, eps: float) -> dict[str, float]:
    """d quantity / d perturbation of ``steps`` (already perturbed by ``eps``)."""
    q = quantities(resolve(steps))
    return {n: (q[n] - base[n]) / eps for n in base}


def _rss(responses: list[dict[str, float]], u: float, base: dict[str, float]) -> dict[str, float]:
    return {n: float(u * np.sqrt(sum(r[n] ** 2 for r in responses))) for n in base}


def rig_contributions(resolve: Resolve, steps: StepMeans, base: dict[str, float], rig: RigErrors) -> list:
    """One contribution per geometry error of the rig (:mod:`calib.accel.rig_propagation`): the quantities'
    response to the poses moved as that error moves them, times its standard uncertainty."""
    angles = stage_angles_deg(steps.f_nominal_g)
    f = np.asarray(steps.f_nominal_g, float)
    out = []
    for p in rig_parameters(rig, len(steps)):
        shift = pose_shift(p, angles)
        if p.u_deg == 0 or not np.any(np.abs(shift) > 1e-12):
            continue
        moved = _replace(steps, f_nominal_g=f - EPS_DEG * shift)  # the data saw f + shift; the solve assumes f
        r = _response(resolve, base, moved, EPS_DEG)
        out.append(Contribution(p.name, "B", p.group, {n: abs(v) * p.u_deg for n, v in r.items()},
                                GROUPS[p.group]))
    return out


def grouped(parts: list[Contribution], rig: RigErrors) -> list[Contribution]:
    """The rig's per-parameter contributions summed (RSS) into their groups, in :data:`GROUPS` order; the
    others as they are."""
    out, groups = [], {}
    for c in parts:
        if c.source in GROUPS:
            groups.setdefault(c.source, []).append(c)
        else:
            out.append(c)
    for g in GROUPS:
        members = groups.get(g, [])
        names = ", ".join(c.name for c in members[:4]) + (", ..." if len(members) > 4 else "")
        u = combined(members) if members else {n: 0.0 for n in out[0].u}
        out.append(Contribution(g, "B", f"{rig.source}: {len(members)} parameters ({names})", u, GROUPS[g]))
    order = ["noise and wander", *GROUPS, "gravity", "thermometer"]
    return sorted(out, key=lambda c: order.index(c.name))


def thermometer_sensitivities(resolve: Resolve, steps: StepMeans, base: dict[str, float]) -> list:
    """The quantities' responses to each step's temperature off alone, per C."""
    out = []
    for i in range(len(steps)):
        t = np.asarray(steps.temp_c, float).copy()
        t[i] += EPS_C
        out.append(_response(resolve, base, _replace(steps, temp_c=t), EPS_C))
    return out


def contributions(cal: AccelCalibration, steps: StepMeans, resolve: Resolve, rig: RigErrors) -> list[Contribution]:
    """The budget of ``cal`` (solved from ``steps``; ``resolve`` solves perturbed steps the same way), one
    contribution per rig parameter (:func:`grouped` sums them as the file lists them)."""
    base = quantities(cal)
    zero = {n: 0.0 for n in base}
    birge = birge_ratio(cal)
    type_a = {n: v / birge for n, v in flat_sigma(cal).items()}
    out = [Contribution("noise and wander", "A", "the solve's sigma (step scatter, bias wander)" + (
        f" without its misfit scaling (Birge ratio {birge:.2f}: the rig's geometry below)" if birge > 1 else ""),
        type_a)]
    if cal.fit.method != "magnitude" and bool(np.all(steps.pose_known)):
        out += rig_contributions(resolve, steps, base, rig)
    g_rel = rig.gravity.relative_u
    u_g = {n: (abs(v) * g_rel if n.startswith(("scale", "matrix")) else 0.0) for n, v in base.items()}
    out.append(Contribution("gravity", "B", f"{rig.gravity.source}: u(g)/g = {g_rel:.3g}", u_g,
                            "normal" if rig.gravity.source == "measured" else "rectangular"))
    if cal.temperature is not None and steps.temp_c is not None:
        out.append(Contribution("thermometer", "B", f"{rig.thermometer_u_c:g} C per step (non-repeatability)",
                                _rss(thermometer_sensitivities(resolve, steps, base), rig.thermometer_u_c, base)))
    else:
        out.append(Contribution("thermometer", "B", "no thermal model: the biases do not depend on it", zero))
    return out


def uncertainty_section(cal: AccelCalibration, steps: StepMeans, resolve: Resolve, rig: RigErrors,
                        k: float = DEFAULT_K) -> dict:
    """``accelerometer.uncertainty``: ``U = k u_c`` in ``sigma``'s keys, ``k``, the combined standard
    uncertainty and the ``budget`` (each contribution's standard uncertainties, same keys)."""
    parts = grouped(contributions(cal, steps, resolve, rig), rig)
    return {"k": float(k), **nest(expanded(parts, k), cal),
            "combined_standard": nest(combined(parts), cal),
            "budget": [{"name": c.name, "type": c.type, "source": c.source, "distribution": c.distribution,
                        **nest(c.u, cal)} for c in parts]}
