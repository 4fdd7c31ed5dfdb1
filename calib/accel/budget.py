"""The accelerometer's uncertainty budget (docs/uncertainty.md): ``accelerometer.uncertainty`` of the
calibration file, mirroring the keys of ``sigma`` (``bias_counts``, ``scale_counts_per_g``,
``matrix_counts_per_g``, ``misalignment``) with the expanded uncertainty ``U = k u_c``, the coverage factor
``k`` and the ``budget``: every contribution's standard uncertainty of every quantity.

Contributions:

- **Type A, noise and wander**: the solve's ``sigma`` as it is (``sigma`` keeps that meaning).
- **Type B, rig poses**: each pose's direction is off by the table's errors that differ from pose to pose
  (:meth:`RigErrors.pose_u_rad`, per axis, independent between poses); propagated by re-solving with each
  step's nominal specific force turned by a small angle about each sensor axis (the solve's own sensitivity,
  whatever its method and model).
- **Type B, rig frame**: a rotation common to every pose (the sensor's mounting in its fixture, the stage
  zeros), propagated the same way with every step turned together.
- **Type B, lost motion**: per pose, independent, unless every pose is approached from one side.
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

#: step (rad) of the finite differences: small enough to be linear (the pose errors are ~1e-3 rad), large
#: enough to stand far above the solve's rounding
EPS_RAD = 1e-5
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


def _turned(steps: StepMeans, rv_rad: np.ndarray) -> StepMeans:
    """``steps`` with each step's nominal specific force turned by its small rotation vector (K, 3), rad."""
    f = np.asarray(steps.f_nominal_g, float)
    return _replace(steps, f_nominal_g=f + np.cross(rv_rad, f))


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


def pose_sensitivities(resolve: Resolve, steps: StepMeans, base: dict[str, float]) -> tuple[list, list]:
    """The quantities' responses to each step turned alone about each sensor axis (3K of them) and to every
    step turned together about each axis (3), per rad."""
    k = len(steps)
    alone, together = [], []
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = EPS_RAD
        for i in range(k):
            rv = np.zeros((k, 3))
            rv[i] = e
            alone.append(_response(resolve, base, _turned(steps, rv), EPS_RAD))
        together.append(_response(resolve, base, _turned(steps, np.tile(e, (k, 1))), EPS_RAD))
    return alone, together


def thermometer_sensitivities(resolve: Resolve, steps: StepMeans, base: dict[str, float]) -> list:
    """The quantities' responses to each step's temperature off alone, per C."""
    out = []
    for i in range(len(steps)):
        t = np.asarray(steps.temp_c, float).copy()
        t[i] += EPS_C
        out.append(_response(resolve, base, _replace(steps, temp_c=t), EPS_C))
    return out


def contributions(cal: AccelCalibration, steps: StepMeans, resolve: Resolve, rig: RigErrors) -> list[Contribution]:
    """The budget of ``cal`` (solved from ``steps``; ``resolve`` solves perturbed steps the same way)."""
    base = quantities(cal)
    zero = {n: 0.0 for n in base}
    out = [Contribution("noise and wander", "A", "the solve's sigma (step scatter, bias wander)", flat_sigma(cal))]
    if cal.fit.method != "magnitude" and bool(np.all(steps.pose_known)):
        alone, together = pose_sensitivities(resolve, steps, base)
        out.append(Contribution("rig poses", "B", f"{rig.source}: {rig.pose_u_rad:.3g} rad per pose and axis",
                                _rss(alone, rig.pose_u_rad, base)))
        out.append(Contribution("rig frame", "B", f"{rig.source}: {rig.frame_u_rad:.3g} rad per axis, every pose",
                                _rss(together, rig.frame_u_rad, base)))
        out.append(Contribution("lost motion", "B", f"{rig.lost_motion_source}: {rig.lost_motion_u_rad:.3g} rad per "
                                "pose and axis", _rss(alone, rig.lost_motion_u_rad, base)))
    g_rel = rig.gravity.relative_u
    u_g = {n: (abs(v) * g_rel if n.startswith(("scale", "matrix")) else 0.0) for n, v in base.items()}
    out.append(Contribution("gravity", "B", f"{rig.gravity.source}: u(g)/g = {g_rel:.3g}", u_g))
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
    parts = contributions(cal, steps, resolve, rig)
    return {"k": float(k), **nest(expanded(parts, k), cal),
            "combined_standard": nest(combined(parts), cal),
            "budget": [{"name": c.name, "type": c.type, "source": c.source, **nest(c.u, cal)} for c in parts]}
