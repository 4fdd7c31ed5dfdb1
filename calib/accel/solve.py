"""Solvers: the seed's six-position pseudo-inverse (with its thermal bias model) and the peers' methods.

- ``method="pinv"``: the seed's per-axis pseudo-solution p_j = G_j^+ a_j, here with
  1/sem^2 weights (equal weights give exactly the paper's G_j^+ a_j when every step
  has the same scatter); ``model="triangular"`` (the paper) or ``"full"`` (12 parameters).
- ``method="flip"``: the two-position (test-rotation) method: bias and scale from +/- pairs.
- ``method="combinations"``: the average of the exactly-determined solutions over all
  C(m, N) subsets of the m poses (the 12- and 6-position schemes of the paper's references).
- ``thermal``: "auto" | "off" | S adds the bias polynomial of order S in (T - t0) (eq. 4/5),
  solved jointly with the static model (the overdetermined least squares of eq. 7). Steps captured
  on a thermal ramp (``StepMeans.temp_rate_c_per_s``) add, with any thermal order, the thermal-gradient
  term ``g_j dT/dt`` on every axis and the scale tempco ``s_j (T - t0) f_j`` on every axis whose poses
  determine it; both come out as the calibration's ``thermal_gradient`` and ``scale_tempco`` effects.
- Whenever the sensor's bias stability is known (``StepMeans.bias_stability``), the pinv solve is
  generalised least squares with the chip's bias wander between the steps (:func:`wander_covariance`):
  the wander is common to near steps and aliases into the biases and, over a thermal run or a ramp,
  into the thermal terms; only this covariance makes their sigmas honest.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from calib.accel.combinations import choose_subsets, subset_average_maps
from calib.accel.inputs import StepMeans
from calib.accel.result import AccelCalibration, FitSummary, ThermalModel
from calib.numerics.design import (SENSOR_AXES, AxisFit, Inputs, LinearModel, Term, check_model, check_rank, const_term, force_term,
                          session_rule, solve_gls, solve_wls, temp_term, undetermined)
from calib.errors import CalibError, ObservabilityError
from calib.numerics.magnitude import fit_magnitude
from calib.numerics.stability import axis_cov
from calib.numerics.wander import wander_cov_g2

THERMAL_AUTO_MIN_SPAN_C = 2.0
#: ``method="combinations"`` averages every pose subset up to this many, else this many drawn at random
COMBINATIONS_MAX_SUBSETS = 32768
#: the window ``apply`` takes a sample series' temperature rate over for the thermal-gradient term, s
RAMP_RATE_WINDOW_S = 10.0

TRIANGULAR_NAMES = {"x": ["b_x", "k_x", "kx_ayz", "kx_azy"], "y": ["b_y", "k_y", "ky_azx"], "z": ["b_z", "k_z"]}


def triangular_model() -> LinearModel:
    """The seed's model: G_x = [1, gx, gy, gz], G_y = [1, gy, gz], G_z = [1, gz]."""
    return LinearModel({
        "x": [const_term("x"), force_term("k_x", 0), force_term("kx_ayz", 1), force_term("kx_azy", 2)],
        "y": [const_term("y"), force_term("k_y", 1), force_term("ky_azx", 2)],
        "z": [const_term("z"), force_term("k_z", 2)],
    })


def full_model() -> LinearModel:
    """Bias + full 3x3 matrix (12 parameters)."""
    return LinearModel({a: [const_term(a)] + [force_term(f"m_{a}{c}", i) for i, c in enumerate(SENSOR_AXES)] for a in SENSOR_AXES})


def base_model(model: str) -> LinearModel:
    if model == "triangular":
        return triangular_model()
    if model == "full":
        return full_model()
    raise CalibError(f"unknown model {model!r} (allowed: triangular, full)")


def thermal_order(steps: StepMeans, thermal) -> int:
    """Resolve thermal='auto'|'off'|S to an order (0 = no temperature terms)."""
    if thermal in ("off", None, 0, False):
        return 0
    if thermal == "auto":
        if steps.temp_c is None:
            return 0
        return 1 if np.ptp(steps.temp_c) >= THERMAL_AUTO_MIN_SPAN_C else 0
    if isinstance(thermal, (int, np.integer)) and not isinstance(thermal, bool) and 1 <= thermal <= 3:
        if steps.temp_c is None:
            raise ObservabilityError("thermal model requested but the session has no temperatures "
                                     "(the sensor has no thermometer): use thermal off")
        return int(thermal)
    raise CalibError(f"thermal must be auto, off or an order 1..3, got {thermal!r}")


def solve(steps: StepMeans, *, model: str = "triangular", method: str = "pinv", thermal="auto",
          t0_c: float | None = None) -> AccelCalibration:
    """Solve a calibration from per-step means. See the module docstring for the choices."""
    if method == "magnitude":
        return solve_magnitude(steps)
    unknown = int(np.sum(~steps.pose_known))
    if unknown:
        raise ObservabilityError(f"{unknown} of {len(steps)} steps have unknown poses (f_nominal null): "
                                 "use the magnitude method")
    if method == "pinv":
        return _solve_linear(steps, model, thermal, t0_c, "pinv")
    if method == "flip":
        return solve_flip(steps, thermal=thermal)
    if method == "combinations":
        return solve_combinations(steps, model=model, thermal=thermal, t0_c=t0_c)
    raise CalibError(f"unknown method {method!r} (allowed: pinv, flip, combinations, magnitude)")


def check_poses(f_nominal_g, model: str = "triangular", method: str = "pinv") -> None:
    """Raise :class:`ObservabilityError` naming the parameters of the static ``model`` that the poses
    ``f_nominal_g`` (K, 3) leave undetermined, or, for the flip ``method``, the axis without its + and - pose:
    what a procedure's poses can be judged by before anything is recorded (temperature terms aside: they
    depend on the temperatures reached)."""
    f = np.atleast_2d(np.asarray(f_nominal_g, float))
    if method == "flip":
        for j, a in enumerate(SENSOR_AXES):
            e = np.zeros(3)
            e[j] = 1
            plus, minus = (int(np.sum(np.linalg.norm(f - s_ * e, axis=1) < FLIP_TOL_G)) for s_ in (1, -1))
            if not plus or not minus:
                raise ObservabilityError(f"the flip method needs poses with gravity along +{a.upper()} and "
                                         f"-{a.upper()}; the procedure has {plus} and {minus}")
        return
    x = Inputs(f, None, np.zeros(len(f)))
    lm = base_model(model)
    check_model({a: (lm.design(a, x), lm.names(a), lm.terms[a]) for a in SENSOR_AXES})


def _model_with_thermal(steps, model, thermal, t0_c):
    order = thermal_order(steps, thermal)
    lm = base_model(model)
    if order:
        for a in SENSOR_AXES:
            lm = lm.with_terms(a, [temp_term(a, s) for s in range(1, order + 1)])
    x = Inputs.from_steps(steps, t0_c)
    if order and steps.temp_rate_c_per_s is not None:
        lm = with_ramp_terms(lm, x, np.asarray(steps.temp_rate_c_per_s, float))
    return lm, x, order


def gradient_term(axis: str, rate_c_per_s: np.ndarray) -> Term:
    """The thermal-gradient term of ``axis``: bias proportional to the step's temperature rate, counts/(C/s)."""
    return Term(f"g_{axis}", "counts/(C/s)", lambda x, r=rate_c_per_s: r, needs=("temp",),
                hint="steps at different temperature rates (a ramp up and a ramp down)")


def scale_tempco_term(axis: str) -> Term:
    """The scale tempco of ``axis`` to first order: ``(T - t0) f_axis``, counts/(g C) (= k s, s in 1/C)."""
    j = SENSOR_AXES.index(axis)
    return Term(f"s_{axis}", "counts/(g C)", lambda x, c=j: (x.temp_c - x.t0_c) * x.f_g[:, c], needs=("temp",),
                hint=f"poses with gravity along +{axis.upper()} and -{axis.upper()} at several temperatures")


def with_ramp_terms(lm: LinearModel, x: Inputs, rate_c_per_s: np.ndarray) -> LinearModel:
    """``lm`` with the thermal-gradient term on every axis and the scale tempco on the axes whose poses
    determine it (their design stays of full rank with it)."""
    for a in SENSOR_AXES:
        lm = lm.with_terms(a, [gradient_term(a, rate_c_per_s)])
        trial = lm.with_terms(a, [scale_tempco_term(a)])
        if not undetermined(trial.design(a, x), trial.names(a)):
            lm = trial
    return lm


def ramp_effects(fits: dict, lsb_per_g: float, t0_c: float) -> list[dict]:
    """The fitted thermal-gradient and scale-tempco terms as calibration-file effects (docs/discrepancy.md):
    ``thermal_gradient`` in g/(C/s), ``scale_tempco`` in 1/C (null on an axis whose poses left it out)."""
    if "g_x" not in fits["x"].names:
        return []
    est = {"g": [None] * 3, "s": [None] * 3}
    sig = {"g": [None] * 3, "s": [None] * 3}
    for j, a in enumerate(SENSOR_AXES):
        fit = fits[a]
        p = dict(zip(fit.names, fit.params))
        sd = dict(zip(fit.names, np.sqrt(np.diag(fit.cov))))
        k = p[f"k_{a}"] if f"k_{a}" in p else p[f"m_{a}{a}"]
        for kind, divisor in (("g", lsb_per_g), ("s", k)):
            if f"{kind}_{a}" in p:
                est[kind][j], sig[kind][j] = float(p[f"{kind}_{a}"] / divisor), float(sd[f"{kind}_{a}"] / abs(divisor))
    out = [{"name": "thermal_gradient", "unit": "g/(C/s)", "axes": list(SENSOR_AXES), "estimate": est["g"],
            "sigma": sig["g"], "rate_window_s": RAMP_RATE_WINDOW_S}]
    if any(v is not None for v in est["s"]):
        out.append({"name": "scale_tempco", "unit": "1/C", "axes": list(SENSOR_AXES), "estimate": est["s"],
                    "sigma": sig["s"], "t0_c": float(t0_c)})
    return out


def _solve_linear(steps: StepMeans, model: str, thermal, t0_c, method: str) -> AccelCalibration:
    lm, x, order = _model_with_thermal(steps, model, thermal, t0_c)
    designs = {a: lm.design(a, x) for a in SENSOR_AXES}
    check_model({a: (designs[a], lm.names(a), lm.terms[a]) for a in SENSOR_AXES})
    # the wander's covariance is dense (K, K) per axis: beyond MAX_WANDER_STEPS steps (a 10,000-step session: 0.8 GB a
    # matrix, 24 GB with the solve's copies) the steps are weighed by their own errors and the bias sigma gets the
    # chip's bias-stability term instead (docs/methods.md, "Step uncertainty")
    wander = weighs_wander(steps)
    w_axes = axis_wander_counts2(steps) if wander else None  # (3, K, K): the same for the three axes unless a unit's
    fits = {}                                                 # own figures differ per axis (docs/noise.md)
    for j, a in enumerate(SENSOR_AXES):
        y, sem = steps.mean_counts[:, j], steps.sem_counts[:, j]
        fits[a] = (solve_gls(designs[a], y, wander_covariance(steps, sem, w_axes[j]), lm.names(a)) if wander
                   else solve_wls(designs[a], y, sem, lm.names(a)))
    fits = session_rule(fits)
    if wander:  # the wander is in the fit's covariance already: not added to the bias sigma again
        steps = dataclasses.replace(steps, bias_stability=None)
    return assemble(steps, model, fits, order, x.t0_c, method, effects=ramp_effects(fits, steps.lsb_per_g, x.t0_c))


#: the most steps whose bias wander is weighed as a dense (K, K) covariance (32 MB a matrix)
MAX_WANDER_STEPS = 2000


def weighs_wander(steps: StepMeans) -> bool:
    """Whether the solve weighs ``steps`` with the bias wander's covariance: a bias stability known and at most
    :data:`MAX_WANDER_STEPS` steps (the budget and the misfit judgement weigh them as the solve did)."""
    return steps.bias_stability is not None and len(steps) <= MAX_WANDER_STEPS


def wander_covariance(steps: StepMeans, sem_counts: np.ndarray, w_counts2: np.ndarray | None = None) -> np.ndarray:
    """Covariance (K, K) of the step means of one axis, counts^2: each step's own standard error on the
    diagonal plus the chip's bias wander between the steps' capture windows
    (:func:`calib.numerics.wander.wander_cov_g2`: flicker and random walk of
    :class:`calib.numerics.stability.BiasStability`, exact for window means), times ``lsb_per_g^2``.

    Over a session the wander is common to steps close in time and differs between distant ones: a
    six-position run sees it mostly as one offset of all its biases (what the bias-stability term
    used to add), a thermal run also as slopes that alias into the temperature coefficients. Weighing
    the steps with this covariance makes both sigmas honest (docs/methods.md, "Step uncertainty").

    ``w_counts2``: the wander part, :func:`wander_counts2` of the same steps, when the caller has it
    already (it is the same for every output axis)."""
    w = wander_counts2(steps) if w_counts2 is None else w_counts2
    return np.diag(np.asarray(sem_counts, float) ** 2) + w


def axis_wander_counts2(steps: StepMeans) -> np.ndarray:
    """:func:`wander_counts2` per output axis, (3, K, K): each axis's own wander when the stability has per-axis
    figures (:class:`calib.numerics.stability.AxisStability`), else the one wander (computed once) for all three.
    Read-only; the last one is kept for the same steps' times, durations, stability and sensitivity (the budget
    weighs a session as its solve did: at 2,000 steps computing it again cost 10 s)."""
    t = np.asarray(steps.t_s, float)
    dur = None if steps.duration_s is None else np.asarray(steps.duration_s, float)
    key = (steps.bias_stability, float(steps.lsb_per_g))
    last = _WANDER_MEMO.get("last")
    if last is not None and last[0] == key and np.array_equal(last[1], t) and (
            (last[2] is None and dur is None) or (last[2] is not None and dur is not None and np.array_equal(last[2], dur))):
        return last[3]
    w = float(steps.lsb_per_g) ** 2 * axis_cov(steps.bias_stability, t, steps.duration_s, len(SENSOR_AXES))
    w.setflags(write=False)
    _WANDER_MEMO["last"] = (key, t.copy(), None if dur is None else dur.copy(), w)
    return w


#: the last :func:`axis_wander_counts2` (one entry: a solve and its budget, one after the other)
_WANDER_MEMO: dict = {}


def wander_counts2(steps: StepMeans) -> np.ndarray:
    """The wander part of :func:`wander_covariance`, counts^2: ``lsb_per_g^2`` times
    :func:`calib.numerics.wander.wander_cov_g2` over the steps' capture windows (the same for every output axis)."""
    return float(steps.lsb_per_g) ** 2 * wander_cov_g2(np.asarray(steps.t_s, float), steps.duration_s,
                                                       steps.bias_stability)


def assemble(steps: StepMeans, model: str, fits: dict, order: int, t0_c: float, method: str,
             effects: list | None = None) -> AccelCalibration:
    """Map per-axis fitted parameters to the calibration's named quantities (with sigmas)."""
    m = np.zeros((3, 3))
    sm = np.zeros((3, 3))
    b = np.zeros(3)
    sb = np.zeros(3)
    coef = np.zeros((3, max(order, 1)))
    scoef = np.zeros((3, max(order, 1)))
    for j, a in enumerate(SENSOR_AXES):
        fit = fits[a]
        p = dict(zip(fit.names, fit.params))
        s = dict(zip(fit.names, np.sqrt(np.diag(fit.cov))))
        b[j], sb[j] = p[f"b_{a}"], math.hypot(s[f"b_{a}"], steps.bias_stability_counts())
        for s_ in range(1, order + 1):
            coef[j, s_ - 1], scoef[j, s_ - 1] = p[f"c{s_}_{a}"], s[f"c{s_}_{a}"]
        if model == "triangular":
            names = TRIANGULAR_NAMES[a]
            cols = {"x": [0, 1, 2], "y": [1, 2], "z": [2]}[a]
            for name, c in zip(names[1:], cols):
                m[j, c], sm[j, c] = p[name], s[name]
        elif model == "full":
            for c, cc in enumerate(SENSOR_AXES):
                m[j, c], sm[j, c] = p[f"m_{a}{cc}"], s[f"m_{a}{cc}"]
        else:  # diagonal
            m[j, j], sm[j, j] = p[f"k_{a}"], s[f"k_{a}"]
    if np.any(np.diag(m) <= 0):
        raise CalibError("solved scale factor is not positive: the poses' f_nominal do not match the data "
                         "(wrong pose labels or sensor axes?)")
    misalignment = smis = None
    if model == "triangular":
        misalignment, smis = _angles(fits)
    res = np.concatenate([fits[a].residuals for a in SENSOR_AXES])
    chi2 = sum(fits[a].chi2 for a in SENSOR_AXES)
    dof = sum(fits[a].dof for a in SENSOR_AXES)
    sigma = {"bias_counts": sb.tolist(), "scale_counts_per_g": np.diag(sm).tolist(),
             "matrix_counts_per_g": sm.tolist(), "misalignment": smis,
             "temperature": {"coefficients": scoef[:, :order].tolist()} if order else None}
    thermal = ThermalModel(t0_c=float(t0_c), order=order, coefficients=coef[:, :order]) if order else None
    fit = FitSummary(steps=len(steps), samples=int(np.sum(steps.n_samples)),
                     residual_rms_g=float(np.sqrt(np.mean(res**2)) / steps.lsb_per_g),
                     chi2_per_dof=chi2_per_dof(chi2, dof), method=method)
    return AccelCalibration(model=model, lsb_per_g=float(steps.lsb_per_g), bias_counts=b,
                            scale_counts_per_g=np.diag(m).copy(), misalignment=misalignment,
                            matrix_counts_per_g=m, temperature=thermal, sigma=sigma, fit=fit,
                            effects=list(effects or []))


def chi2_per_dof(chi2: float, dof: int) -> float:
    """chi2/dof; 0 for an exactly determined fit (no redundancy: chi2 = 0), never NaN."""
    return float(chi2 / dof) if dof > 0 else 0.0


def _angles(fits) -> tuple[dict, dict]:
    """The paper's angles from the pseudo-solution, with delta-method sigmas.

    With T = [[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]] and a = k T^-1 g + b:
    p_x = [b_x, k_x, k_x a_yz, -k_x (a_zy - a_yz a_zx)], p_y = [b_y, k_y, k_y a_zx], p_z = [b_z, k_z], so
    a_yz = p_x3/p_x2, a_zx = p_y3/p_y2, a_zy = -p_x4/p_x2 + a_yz a_zx (radians).
    """
    px, py = fits["x"].params, fits["y"].params
    cx, cy = fits["x"].cov, fits["y"].cov
    a_yz = px[2] / px[1]
    a_zx = py[2] / py[1]
    a_zy = -px[3] / px[1] + a_yz * a_zx
    # Jacobians (first 4 params of x, first 3 of y)
    j_yz = np.zeros(4); j_yz[1] = -px[2] / px[1] ** 2; j_yz[2] = 1 / px[1]
    j_zx = np.zeros(3); j_zx[1] = -py[2] / py[1] ** 2; j_zx[2] = 1 / py[1]
    jx = np.zeros(4)
    jx[1] = px[3] / px[1] ** 2 + a_zx * j_yz[1]
    jx[2] = a_zx * j_yz[2]
    jx[3] = -1 / px[1]
    jy = a_yz * j_zx
    s_yz = float(np.sqrt(j_yz @ cx[:4, :4] @ j_yz))
    s_zx = float(np.sqrt(j_zx @ cy[:3, :3] @ j_zx))
    s_zy = float(np.sqrt(jx @ cx[:4, :4] @ jx + jy @ cy[:3, :3] @ jy))
    return ({"alpha_yz": float(a_yz), "alpha_zy": float(a_zy), "alpha_zx": float(a_zx)},
            {"alpha_yz": s_yz, "alpha_zy": s_zy, "alpha_zx": s_zx})


#: how close (g) a pose's gravity must be to +-axis for the flip method
FLIP_TOL_G = 0.05


def solve_flip(steps: StepMeans, *, thermal="off", tol: float = FLIP_TOL_G) -> AccelCalibration:
    """Two-position flip method: bias = (u+ + u-)/2, scale = (u+ - u-)/2 per axis.

    Needs, for each axis, a step with gravity along +axis and one along -axis
    (within ``tol`` g of the unit vector). Off-diagonal terms are not estimated.
    """
    if thermal not in ("off", "auto", None):
        raise CalibError("the flip method has no thermal model: use thermal off")
    f = steps.f_nominal_g
    fits = {}
    for j, a in enumerate(SENSOR_AXES):
        e = np.zeros(3); e[j] = 1
        plus = np.flatnonzero(np.linalg.norm(f - e, axis=1) < tol)
        minus = np.flatnonzero(np.linalg.norm(f + e, axis=1) < tol)
        if len(plus) == 0 or len(minus) == 0:
            raise ObservabilityError(f"the flip method needs poses with gravity along +{a.upper()} and "
                                     f"-{a.upper()}; the session has {len(plus)} and {len(minus)}")
        up, um = steps.mean_counts[plus, j], steps.mean_counts[minus, j]
        sp, smn = steps.sem_counts[plus, j], steps.sem_counts[minus, j]
        # weighted means of the + and - groups
        wp, wm = 1 / sp**2, 1 / smn**2
        mp, mm = np.sum(wp * up) / np.sum(wp), np.sum(wm * um) / np.sum(wm)
        vp, vm = 1 / np.sum(wp), 1 / np.sum(wm)
        params = np.array([(mp + mm) / 2, (mp - mm) / 2])
        cov = np.array([[vp + vm, vp - vm], [vp - vm, vp + vm]]) / 4
        res = np.concatenate([up - mp, um - mm])
        w = np.concatenate([1 / sp, 1 / smn])
        chi2 = float(np.sum((res * w) ** 2))
        fits[a] = AxisFit([f"b_{a}", f"k_{a}"], params, cov, cov, res, chi2, len(res) - 2, False)
    return assemble(steps, "diagonal", fits, 0, 25.0, "flip")


def solve_combinations(steps: StepMeans, *, model: str = "triangular", thermal="auto",
                       t0_c: float | None = None, max_subsets: int = COMBINATIONS_MAX_SUBSETS,
                       seed: int = 0) -> AccelCalibration:
    """Average of the exactly-determined solutions over C(m, N) pose subsets.

    N is the largest parameter count of any axis; subsets whose design is singular on some axis
    are skipped. Every subset is evaluated when there are at most ``max_subsets``; beyond that,
    ``max_subsets`` of them drawn at random (seeded by ``seed``: the same steps give the same
    numbers), and the method's name says so with the largest sampling error in sigmas
    (docs/methods.md, "Peers"). The average is a fixed linear map of the step means, so its
    covariance is exact: cov = A diag(sem^2) A^T.
    """
    lm, x, order = _model_with_thermal(steps, model, thermal, t0_c)
    k = len(steps)
    n = max(len(lm.terms[a]) for a in SENSOR_AXES)
    if k < n:
        raise ObservabilityError(f"combinations need at least {n} poses, the session has {k}")
    designs = {a: lm.design(a, x) for a in SENSOR_AXES}
    check_model({a: (designs[a], lm.names(a), lm.terms[a]) for a in SENSOR_AXES})
    subsets, total, sampled = choose_subsets(k, n, max_subsets, seed)
    avg = subset_average_maps([designs[a] for a in SENSOR_AXES], subsets, total, sampled,
                              [steps.mean_counts[:, j] for j in range(3)])
    if avg.count == 0:
        raise ObservabilityError("no subset of the poses determines the model exactly")
    fits = {}
    for j, a in enumerate(SENSOR_AXES):
        amap = avg.maps[j]
        y = steps.mean_counts[:, j]
        params = amap @ y
        cov = amap @ np.diag(steps.sem_counts[:, j] ** 2) @ amap.T
        res = y - designs[a] @ params
        chi2 = float(np.sum((res / steps.sem_counts[:, j]) ** 2))
        fits[a] = AxisFit(lm.names(a), params, cov, cov, res, chi2, k - len(params), False)
    return assemble(steps, model, fits, order, x.t0_c, combinations_label(avg, n, fits),
                    effects=ramp_effects(fits, steps.lsb_per_g, x.t0_c))


def combinations_label(avg, n: int, fits: dict) -> str:
    """The method's name in the fit summary: how many subsets of how many, and for a random sample
    of them its largest sampling error in units of the parameter's sigma."""
    if not avg.sampled:
        return f"combinations({avg.count} subsets of {n})"
    ratio = max(float(np.max(se / np.sqrt(np.diag(fits[a].cov)))) for se, a in zip(avg.sampling_se, SENSOR_AXES))
    return (f"combinations({avg.count} subsets of {n}, a random sample of the {avg.total}; "
            f"sampling error up to {ratio:.2g} sigma)")


def solve_batch(mean_counts: np.ndarray, f_nominal_g: np.ndarray, model: str = "triangular") -> dict:
    """Solve many sessions with the same poses at once (equal weights: the paper's G_j^+ a_j).

    Parameters
    ----------
    mean_counts : (B, K, 3) step means of B sessions.
    f_nominal_g : (K, 3) the common poses.

    Returns
    -------
    dict with ``bias_counts`` (B, 3) and ``matrix_counts_per_g`` (B, 3, 3).
    """
    y = np.asarray(mean_counts, float)
    lm = base_model(model)
    x = Inputs(np.asarray(f_nominal_g, float), None, np.zeros(len(f_nominal_g)))
    bsz = y.shape[0]
    bias = np.zeros((bsz, 3))
    mat = np.zeros((bsz, 3, 3))
    for j, a in enumerate(SENSOR_AXES):
        g = lm.design(a, x)
        check_rank(g, lm.names(a), lm.terms[a], a)
        p = np.einsum("pk,bk->bp", np.linalg.pinv(g), y[:, :, j])
        bias[:, j] = p[:, 0]
        cols = {"x": [0, 1, 2], "y": [1, 2], "z": [2]}[a] if model == "triangular" else [0, 1, 2]
        mat[:, j, cols] = p[:, 1:]
    return {"bias_counts": bias, "matrix_counts_per_g": mat}


def solve_magnitude(steps: StepMeans) -> AccelCalibration:
    """Calibration without known poses: |f| = 1 g in every static step (imu_tk / ArduPilot approach).

    Levenberg-Marquardt fit of bias and an upper-triangular U (``M = U^-1``, the seed's
    triangular model) by :func:`calib.numerics.magnitude.fit_magnitude`; the poses (``f_nominal_g``)
    are not used. No temperature terms. Needs at least 10 well-spread static steps.
    """
    fit = fit_magnitude(steps.mean_counts, steps.sem_counts, radius=1.0)
    m = np.asarray(fit.matrix, float)
    m[np.tril_indices(3, -1)] = 0.0  # exactly upper triangular (U^-1 of an upper-triangular U)
    if np.any(np.diag(m) <= 0):
        # the fit is sign-ambiguous per axis only through U's diagonal; a negative one means a flipped axis
        raise CalibError("the magnitude fit gave a negative scale factor: the data do not constrain the axes' signs")
    k = np.diag(m)
    t = np.linalg.inv(np.diag(1.0 / k) @ m)  # T of the seed's model: M = diag(k) T^-1
    mis = {"alpha_yz": float(-t[0, 1]), "alpha_zy": float(t[0, 2]), "alpha_zx": float(-t[1, 2])}
    sm = np.asarray(fit.sigma_matrix, float)
    smis = {"alpha_yz": float(sm[0, 1] / k[0]), "alpha_zy": float(sm[0, 2] / k[0]),
            "alpha_zx": float(sm[1, 2] / k[1])}
    sb = np.hypot(np.asarray(fit.sigma_bias, float), steps.bias_stability_counts())
    sigma = {"bias_counts": sb.tolist(), "scale_counts_per_g": np.diag(sm).tolist(),
             "matrix_counts_per_g": sm.tolist(), "misalignment": smis, "temperature": None}
    summary = FitSummary(steps=len(steps), samples=int(np.sum(steps.n_samples)),
                         residual_rms_g=float(fit.residual_rms), chi2_per_dof=float(fit.chi2_per_dof),
                         method="magnitude")
    return AccelCalibration(model="triangular", lsb_per_g=float(steps.lsb_per_g),
                            bias_counts=np.asarray(fit.bias, float), scale_counts_per_g=k.copy(),
                            misalignment=mis, matrix_counts_per_g=m, temperature=None, sigma=sigma, fit=summary)
