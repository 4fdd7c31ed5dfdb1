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

import dataclasses
from typing import Callable

import numpy as np

from calib.accel.combinations import _scatter_add, choose_subsets, determined_blocks
from calib.accel.inputs import StepMeans
from calib.accel.result import MISALIGNMENT_NAMES, AccelCalibration
from calib.errors import CalibError
from calib.numerics.design import SENSOR_AXES, Inputs
from calib.numerics.budget import DEFAULT_K, Contribution, RigErrors, combined, expanded
from calib.accel.solve import (TRIANGULAR_NAMES, _model_with_thermal, axis_wander_counts2, weighs_wander,
                               wander_covariance)
from calib.accel.rig_misfit import RigMisfit, has_pose_errors, rig_misfit
from calib.accel.rig_propagation import (EPS_DEG, GROUPS, pose_shifts, rig_parameters, stacked_parameters,
                                         pose_angles_deg, usable_arrival)
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


def quantities_of_parameters(model: str, p: dict) -> dict[str, float]:
    """:func:`quantities` of the calibration the per-axis fitted parameters ``p`` (axis -> {name: value}) make, as
    :func:`calib.accel.solve.assemble` maps them, without building the calibration (the budget's linear map
    differentiates it ten times a solve: building and validating each cost 0.56 ms)."""
    m = np.zeros((3, 3))
    b = np.zeros(3)
    for j, a in enumerate(SENSOR_AXES):
        b[j] = p[a][f"b_{a}"]
        if model == "triangular":
            for name, c in zip(TRIANGULAR_NAMES[a][1:], {"x": [0, 1, 2], "y": [1, 2], "z": [2]}[a]):
                m[j, c] = p[a][name]
        elif model == "full":
            for c, cc in enumerate(SENSOR_AXES):
                m[j, c] = p[a][f"m_{a}{cc}"]
        else:
            m[j, j] = p[a][f"k_{a}"]
    q = {f"bias_counts[{i}]": float(v) for i, v in enumerate(b)}
    q.update({f"scale_counts_per_g[{i}]": float(m[i, i]) for i in range(3)})
    q.update({f"matrix_counts_per_g[{i}][{j}]": float(m[i, j]) for i in range(3) for j in range(3)})
    if model == "triangular":  # calib.accel.solve._angles
        px, py = p["x"], p["y"]
        a_yz = px["kx_ayz"] / px["k_x"]
        a_zx = py["ky_azx"] / py["k_y"]
        a_zy = -px["kx_azy"] / px["k_x"] + a_yz * a_zx
        q.update({"misalignment.alpha_yz": float(a_yz), "misalignment.alpha_zy": float(a_zy),
                  "misalignment.alpha_zx": float(a_zx)})
    return q


def birge_ratio(cal: AccelCalibration) -> float:
    """The factor the solve scaled its sigmas by for a misfit (sqrt(chi2/dof) when :meth:`AccelCalibration.misfit`
    says it did, else 1). On a turntable the misfit is mostly the rig's geometry, which the budget's Type B
    terms hold: the budget's Type A is ``sigma`` without it, so that nothing is counted twice."""
    scaled, _ = cal.misfit()
    chi2 = cal.fit.chi2_per_dof
    return float(np.sqrt(chi2)) if scaled and chi2 is not None and np.isfinite(chi2) and chi2 > 1 else 1.0


def unscaled_sigma(linear: "LinearSolve") -> dict[str, float] | None:
    """Each quantity's sigma as the solve had it before any misfit scaling: the step means' own covariance (noise
    and wander, as the solve weighed them) through the solve's linear map, axis by axis (``(D^T C^-1 D)^-1``); None
    for a solve without one (combinations)."""
    blocks = [linear.residual_terms.get(a) for a in SENSOR_AXES]
    if any(b is None for b in blocks):
        return None
    n = sum(b[0].shape[0] for b in blocks)
    cov, at = np.zeros((n, n)), 0
    for n_inv, _ in blocks:
        p = n_inv.shape[0]
        cov[at:at + p, at:at + p] = n_inv
        at += p
    var = np.einsum("qi,ij,qj->q", linear.jacobian, cov, linear.jacobian)
    return dict(zip(linear.names, map(float, np.sqrt(np.maximum(var, 0.0)))))


def type_a_contribution(cal: AccelCalibration, birge: float, rig_terms: list[Contribution],
                        judged: "RigMisfit | None" = None, linear: "LinearSolve | None" = None) -> Contribution:
    """The Type A entry: the solve's sigma. When the solve scaled it for a misfit (``birge`` > 1), the part of that
    scaling the rig's geometry explains is left out, so nothing is counted twice. With the misfit judged against the
    noise and the rig's errors (``judged``, :func:`calib.accel.rig_misfit.rig_misfit`): the sigma unscaled when the
    rig's errors explain it, else scaled by the Birge ratio they leave (``sqrt(chi2/dof)`` of that judgement), never
    beyond the solve's own sigma. The solve scales axis by axis (an axis whose own fit is no misfit keeps its
    sigma, :func:`calib.numerics.design.session_rule`), so with the solve's linear map (``linear``) the unscaled
    sigma is each quantity's own (:func:`unscaled_sigma`); without it the sigma over the session's pooled ``birge``
    for every quantity alike. Without ``judged``, per quantity from the rig's own terms
    (``rig_terms``): ``u_A^2 = max(sigma^2 / birge^2, sigma^2 - u_rig^2)``, which keeps the whole scaling of the
    quantities the rig's terms barely move (the scales). A session that misfits on a rig without geometry errors
    keeps its whole sigma either way."""
    sigma = flat_sigma(cal)
    if birge <= 1:
        return Contribution("noise and wander", "A", "the solve's sigma (step scatter, bias wander)", sigma)
    if judged is not None and judged.dof > 0:
        left = min(float(np.sqrt(judged.chi2_per_dof)), birge) if judged.significant else 1.0
        own = unscaled_sigma(linear) if linear is not None else None
        u_a = {n: (min(own[n] * left, v) if own is not None and n in own else v * left / birge)
               if np.isfinite(v) else v for n, v in sigma.items()}
        why = ("which the rig's errors explain (against the noise and the rig: chi2/dof "
               f"{judged.chi2_per_dof:.2f}, p = {judged.p:.2g})" if not judged.significant else
               f"less what the rig's errors explain: scaled by the Birge ratio they leave, {left:.2f}")
        return Contribution("noise and wander", "A", f"the solve's sigma (step scatter, bias wander) without its "
                            f"misfit scaling (Birge ratio {birge:.2f}) {why}", u_a)
    u_rig2 = {n: 0.0 for n in sigma}
    for c in rig_terms:
        for n, u in c.u.items():
            if n in u_rig2 and np.isfinite(u):
                u_rig2[n] += float(u) ** 2
    u_a = {n: float(np.sqrt(max(v**2 / birge**2, v**2 - u_rig2[n]))) if np.isfinite(v) else v for n, v in sigma.items()}
    kept = max((u_a[n] ** 2 - (v / birge) ** 2) / max(v**2 - (v / birge) ** 2, 1e-300)
               for n, v in sigma.items() if np.isfinite(v) and v > 0) if sigma else 0.0
    return Contribution("noise and wander", "A", f"the solve's sigma (step scatter, bias wander) with its misfit "
                        f"scaling (Birge ratio {birge:.2f}) less what the rig's geometry below explains (up to "
                        f"{100 * min(max(kept, 0.0), 1.0):.0f} % of the scaling kept)", u_a)


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


def rig_contributions(resolve: Resolve, steps: StepMeans, base: dict[str, float], rig: RigErrors,
                      linear: "LinearSolve | None" = None) -> list:
    """One contribution per geometry error of the rig (:mod:`calib.accel.rig_propagation`): the quantities'
    response to the poses moved as that error moves them, times its standard uncertainty. With ``linear`` (the
    solve's linear sensitivity, :func:`linear_solve`) no re-solve: lost motion at every pose of a stage is then
    one contribution (``lost_motion.a3@1..K``: the root sum of squares over the poses)."""
    if linear is not None:
        return _rig_contributions_linear(linear, steps, rig)
    angles = pose_angles_deg(steps)
    f = np.asarray(steps.f_nominal_g, float)
    out = []
    params = rig_parameters(rig, len(steps), usable_arrival(steps, rig))
    for p, shift in zip(params, pose_shifts(params, angles)):  # one chain of the table for every parameter
        if p.u_deg == 0 or not np.any(np.abs(shift) > 1e-12):
            continue
        moved = _replace(steps, f_nominal_g=f - EPS_DEG * shift)  # the data saw f + shift; the solve assumes f
        r = _response(resolve, base, moved, EPS_DEG)
        out.append(Contribution(p.name, "B", p.group, {n: abs(v) * p.u_deg for n, v in r.items()},
                                GROUPS[p.group]))
    return out


def _rig_contributions_linear(linear: "LinearSolve", steps: StepMeans, rig: RigErrors) -> list:
    angles = pose_angles_deg(steps)
    f = np.asarray(steps.f_nominal_g, float)
    k = len(steps)
    out = []
    params, per_pose = stacked_parameters(steps, rig)
    for p, shift in zip(params, pose_shifts(params, angles)):
        if not np.any(np.abs(shift) > 1e-12):
            continue
        r = linear.responses(_replace(steps, f_nominal_g=f - EPS_DEG * shift), EPS_DEG)  # (Q, K)
        if per_pose and p.name.startswith("lost_motion."):
            u = p.u_deg * np.sqrt(np.sum(r ** 2, axis=1))
            name = f"{p.name}@1..{k}"
        else:
            u = p.u_deg * np.abs(np.sum(r, axis=1))
            name = p.name
        out.append(Contribution(name, "B", p.group, dict(zip(linear.names, map(float, u))), GROUPS[p.group]))
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


def judge_with_rig(cal: AccelCalibration, steps: StepMeans, rig: RigErrors,
                   linear: "LinearSolve | None" = None) -> RigMisfit | None:
    """The fit's residuals judged against the noise and the rig's errors (:func:`calib.accel.rig_misfit.rig_misfit`;
    on a table without errors, the solve's own judgement); None where that is not made: poses unknown, a method
    without a linear map (``linear``, built here when not given), more steps than it takes."""
    if not bool(np.all(steps.pose_known)):
        return None
    if not has_pose_errors(rig):
        significant, p = cal.misfit()
        dof = cal.degrees_of_freedom()
        return RigMisfit(float(cal.fit.chi2_per_dof or 0.0) * dof, dof, p, significant)
    if linear is None:
        if not has_linear_map(cal):
            return None
        linear = linear_solve(cal, steps)
    return rig_misfit(linear, steps, rig, cal.matrix_counts_per_g)


def contributions(cal: AccelCalibration, steps: StepMeans, resolve: Resolve, rig: RigErrors,
                  linear: "LinearSolve | None" = None, judged: "RigMisfit | None" = None) -> list[Contribution]:
    """The budget of ``cal`` (solved from ``steps``; ``resolve`` solves perturbed steps the same way), one
    contribution per rig parameter (:func:`grouped` sums them as the file lists them). ``linear``: the solve's
    linear sensitivity (:func:`linear_solve`) in place of the re-solves (linear in the steps, not quadratic);
    ``judged``: the fit judged against the noise and the rig (:func:`judge_with_rig`), made here when the solve
    scaled its sigmas and not given."""
    base = quantities(cal)
    zero = {n: 0.0 for n in base}
    birge = birge_ratio(cal)
    rig_terms = (rig_contributions(resolve, steps, base, rig, linear)
                 if cal.fit.method != "magnitude" and bool(np.all(steps.pose_known)) else [])
    own = None  # the solve's linear map for the Type A's unscaled sigma (judged: the rig explains the misfit or not)
    if birge > 1 and rig_terms:
        own = linear if linear is not None else (linear_solve(cal, steps) if has_linear_map(cal) else None)
        if judged is None:
            judged = judge_with_rig(cal, steps, rig, own)
    out = [type_a_contribution(cal, birge, rig_terms, judged, own)] + rig_terms
    g_rel = rig.gravity.relative_u
    u_g = {n: (abs(v) * g_rel if n.startswith(("scale", "matrix")) else 0.0) for n, v in base.items()}
    out.append(Contribution("gravity", "B", f"{rig.gravity.source}: u(g)/g = {g_rel:.3g}", u_g,
                            "normal" if rig.gravity.source == "measured" else "rectangular"))
    if cal.temperature is not None and steps.temp_c is not None:
        if linear is not None:
            r = linear.responses(_replace(steps, temp_c=np.asarray(steps.temp_c, float) + EPS_C), EPS_C)
            u_t = dict(zip(linear.names, map(float, rig.thermometer_u_c * np.sqrt(np.sum(r ** 2, axis=1)))))
        else:
            u_t = _rss(thermometer_sensitivities(resolve, steps, base), rig.thermometer_u_c, base)
        out.append(Contribution("thermometer", "B", f"{rig.thermometer_u_c:g} C per step (non-repeatability)", u_t))
    else:
        out.append(Contribution("thermometer", "B", "no thermal model: the biases do not depend on it", zero))
    return out


def uncertainty_section(cal: AccelCalibration, steps: StepMeans, resolve: Resolve, rig: RigErrors,
                        k: float = DEFAULT_K, linear: "LinearSolve | None" = None) -> dict:
    """``accelerometer.uncertainty``: ``U = k u_c`` in ``sigma``'s keys, ``k``, the combined standard
    uncertainty and the ``budget`` (each contribution's standard uncertainties, same keys). ``linear``: the
    solve's linear sensitivity (:func:`linear_solve`) in place of one re-solve per perturbation."""
    judged = judge_with_rig(cal, steps, rig, linear) if linear is not None else None  # noise and rig
    parts = grouped(contributions(cal, steps, resolve, rig, linear, judged), rig)
    section = {"k": float(k), "rig": rig.source, **nest(expanded(parts, k), cal),
               "combined_standard": nest(combined(parts), cal),
               "budget": [{"name": c.name, "type": c.type, "source": c.source, "distribution": c.distribution,
                           **nest(c.u, cal)} for c in parts]}
    if judged is not None:
        section["misfit_with_rig"] = judged.as_dict()
    return section


# -- the solve's linear sensitivity (docs/uncertainty.md, "Cost") ------------------------------------------------
#
# A pose error (or a thermometer error) at step j moves row j of the solve's design D by dD_j. To first order a
# weighted least-squares estimate moves by dtheta = -A (dD theta) + N^-1 dD^T C^-1 r, A = N^-1 D^T C^-1 its linear
# map from the step means to the parameters, N = D^T C^-1 D (pinv, with the solve's own weights, its wander
# covariance included); the combinations method's average of the subsets' solutions by the same rule applied to
# every subset with its own solution and residuals (a subset's solution differs from the average by its noise,
# which is not small on an ill-conditioned subset). Every perturbation then costs one design evaluation and a
# (P, K) product (combinations: a pass over the subsets, at most BUDGET_MAX_SUBSETS) instead of a re-solve,
# and the per-step ones (lost motion at every pose, the thermometer at every step) all come out of the same
# product: the budget grows linearly with the steps, not with their square.

#: the methods whose solve is a fixed linear map of the step means (the linear sensitivity applies)
LINEAR_METHODS = ("pinv", "combinations")


@dataclasses.dataclass
class LinearSolve:
    """A session's solve as the linear map it is at the session's inputs (:func:`linear_solve`)."""

    steps: StepMeans
    model: str
    method: str
    order: int
    t0_c: float
    lm: object  # calib.numerics.design.LinearModel
    designs: dict  # axis -> (K, P_a)
    maps: dict  # axis -> (P_a, K): the step means -> the parameters
    params: dict  # axis -> (P_a,)
    residual_terms: dict  # axis -> (N^-1 (P_a, P_a), C^-1 r (K,)) for pinv
    subsets: list | None  # combinations: per block (subsets (c, n), per axis (map (c, P, n), solution (c, P),
    count: int  # residuals (c, n), N^-1 (c, P, P))) of the subsets that determine every axis; their number
    jacobian: np.ndarray  # (Q, sum P_a): the quantities (:func:`quantities` order) per parameter
    names: list  # the quantities' names, in the jacobian's row order

    def responses(self, steps: StepMeans, eps: float) -> np.ndarray:
        """(Q, K): the quantities' response to each step's inputs moved alone as ``steps`` moves them all (by
        ``eps`` of the perturbation: f_nominal or temp_c), per unit of the perturbation. A perturbation common to
        every step (a stage zero) is the sum over the columns."""
        x = Inputs.from_steps(steps, self.t0_c)
        cols = []
        for j, a in enumerate(SENSOR_AXES):
            d_design = (self.lm.design(a, x) - self.designs[a]) / eps  # (K, P): row j moved by step j alone
            if self.subsets is not None:
                cols.append(self._subset_responses(j, d_design))
                continue
            col = -self.maps[a] * (d_design @ self.params[a])[None, :]  # (P, K)
            if self.residual_terms.get(a) is not None:
                n_inv, c_inv_r = self.residual_terms[a]
                col = col + n_inv @ (d_design * c_inv_r[:, None]).T
            cols.append(col)
        return self.jacobian @ np.vstack(cols)

    def _subset_responses(self, axis: int, d_design: np.ndarray) -> np.ndarray:
        """(P, K) of the combinations average: every subset's own first-order response, averaged."""
        acc = np.zeros((d_design.shape[1], len(self.steps)))
        for s, per_axis in self.subsets:
            local, theta, res, n_inv = per_axis[axis]
            dd = d_design[s]  # (c, n, P)
            moved = -local * np.einsum("cnp,cp->cn", dd, theta)[:, None, :]  # (c, P, n)
            moved += np.einsum("cpq,cnq->cpn", n_inv, dd) * res[:, None, :]
            _scatter_add(acc, s, moved)
        return acc / max(self.count, 1)


#: the combinations method's subsets the budget's linear map averages over: all of them up to this many, else a
#: random sample of this many (the solve's own sample is 32,768: its responses cost 0.6 s on 26 directions; the
#: budget's Type B sensitivities are averages over subsets whose spread is small, and a tenth of a standard
#: uncertainty is far below what the classes themselves are known to)
BUDGET_MAX_SUBSETS = 2048


def solve_method(cal: AccelCalibration) -> str:
    """``cal``'s solve method without its details (``combinations(924 subsets of 6)``: ``combinations``)."""
    return cal.fit.method.split(" ")[0].split("(")[0]


def has_linear_map(cal: AccelCalibration) -> bool:
    """Whether ``cal``'s solve is linear in the step means (:data:`LINEAR_METHODS`): :func:`linear_solve` takes it."""
    return solve_method(cal) in LINEAR_METHODS


def linear_solve(cal: AccelCalibration, steps: StepMeans) -> LinearSolve:
    """The linear map of ``cal``'s solve (method pinv or combinations, its model, thermal order and t0 fixed)."""
    method = solve_method(cal)
    if method not in LINEAR_METHODS:
        raise CalibError(f"the linear sensitivity needs a pinv or combinations solve, not {cal.fit.method!r}")
    order = cal.temperature.order if cal.temperature is not None else 0
    t0 = cal.temperature.t0_c if cal.temperature is not None else None
    lm, x, order = _model_with_thermal(steps, cal.model, order if order else "off", t0)
    designs = {a: lm.design(a, x) for a in SENSOR_AXES}
    y = {a: np.asarray(steps.mean_counts, float)[:, j] for j, a in enumerate(SENSOR_AXES)}
    maps, c_inv_d, blocks, count = {}, {}, None, 0
    if method == "combinations":
        n = max(len(lm.terms[a]) for a in SENSOR_AXES)
        subsets, total, sampled = choose_subsets(len(steps), n, BUDGET_MAX_SUBSETS, 0)
        blocks, count, avg_maps = _subset_blocks([designs[a] for a in SENSOR_AXES], [y[a] for a in SENSOR_AXES],
                                                 subsets)
        maps = dict(zip(SENSOR_AXES, avg_maps))
    else:
        wander = weighs_wander(steps)  # the solve's own weights
        w_axes = axis_wander_counts2(steps) if wander else None
        c_inv_y = {}
        for j, a in enumerate(SENSOR_AXES):  # one factorisation of C per axis: C^-1 [D, y]
            sem = np.asarray(steps.sem_counts, float)[:, j]
            d = designs[a]
            both = np.column_stack([d, y[a]])
            both = (np.linalg.solve(wander_covariance(steps, sem, w_axes[j]), both) if wander
                    else both / sem[:, None] ** 2)
            c_inv_d[a], c_inv_y[a] = both[:, :-1], both[:, -1]
            maps[a] = np.linalg.solve(d.T @ c_inv_d[a], c_inv_d[a].T)
    params = {a: maps[a] @ y[a] for a in SENSOR_AXES}
    residual_terms = {}
    for a in c_inv_d:  # C^-1 r = C^-1 y - C^-1 D theta
        residual_terms[a] = (np.linalg.inv(designs[a].T @ c_inv_d[a]), c_inv_y[a] - c_inv_d[a] @ params[a])

    def q_of(p: dict) -> dict:
        return quantities_of_parameters(cal.model, {a: dict(zip(lm.names(a), p[a])) for a in SENSOR_AXES})

    base = q_of(params)
    names = list(base)
    columns = []
    for a in SENSOR_AXES:  # the quantities are smooth functions of the parameters (the angles are ratios)
        for i in range(len(params[a])):
            h = 1e-7 * max(abs(params[a][i]), 1.0)
            moved = {b: params[b].copy() for b in SENSOR_AXES}
            moved[a][i] += h
            q = q_of(moved)
            columns.append([(q[n] - base[n]) / h for n in names])
    return LinearSolve(steps, cal.model, method, order, x.t0_c, lm, designs, maps, params, residual_terms, blocks,
                       count, np.array(columns).T, names)


def _subset_blocks(designs: list, data: list, subsets: np.ndarray) -> tuple[list, int, list]:
    """The combinations method's subsets that determine every axis (:func:`calib.accel.combinations.determined_blocks`),
    each with its map, its own solution, residuals and N^-1 per axis: what :meth:`LinearSolve.responses` needs; their
    count; and the average map per axis (``subset_average_maps``' maps, from the same pass)."""
    out, count = [], 0
    sums = [np.zeros((d.shape[1], d.shape[0])) for d in designs]
    for s, locals_ in determined_blocks(designs, subsets):
        per_axis = []
        for d, y, local, acc in zip(designs, data, locals_, sums):
            _scatter_add(acc, s, local)
            ds, ys = d[s], np.asarray(y, float)[s]
            theta = np.einsum("cpn,cn->cp", local, ys)
            res = ys - np.einsum("cnp,cp->cn", ds, theta)
            n_inv = np.linalg.pinv(np.swapaxes(ds, 1, 2) @ ds)
            per_axis.append((local, theta, res, n_inv))
        out.append((s, per_axis))
        count += len(s)
    return out, count, [acc / count if count else acc for acc in sums]
