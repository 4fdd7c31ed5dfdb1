"""The library of candidate physical effects beyond the seed's accelerometer model.

The seed's model is ``a = M f + b`` (counts). Each effect here adds a term to
the sensor output, written in g of output (multiplied by ``lsb_per_g`` to give
counts) and *linear in its parameters*, so the discrepancy search can test it
with the same weighted least squares as the baseline::

    a = M f + b + lsb_per_g * sum_effects contribution_g(params, inputs)

The equations match the simulator's error model (drivers/sensors/sim/error_model.py
and rig/simulation/world.py; docs/discrepancy.md), so a hidden effect's estimate compares
directly with the value switched on in a rig file. Each effect of the sensor names the
error-model field that holds it (``Effect.sim_field``): the one map from an effect to the
simulator, read by the simulated rig (``sim: effects:`` of a rig file,
rig/simulation/settings.py) and by the digital twin (rig/analysis/twin.py), which calib
may not import and which may not import each other.

=========================  =========  ===========================================================
name                       unit       output term (axis j; dT = T - t0_c, Mn = M / lsb_per_g)
=========================  =========  ===========================================================
bias_tempco                g/C        p_j dT
bias_tempco_quadratic      g/C^2      p_j dT^2
scale_tempco               1/C        p_j dT (Mn f)_j
scale_nonlinearity         1/g        p_j f_j^2
cross_axis_nonlinearity    1/g        sum_k P_jk q_k,  q = (fx fy, fy fz, fz fx)
full_misalignment          rad        couplings below the diagonal: y += p_yx Mn_yy fx,
                                      z += p_zx Mn_zz fx + p_zy Mn_zz fy
table_tilt                 deg        f -> f + (tx * B e_y - ty * B e_x), B = base -> sensor rotation
bias_drift                 g/s        p_j (t - t_ref_s)
thermal_hysteresis         g          p_j / 2 * h,  h = +1 after heating, -1 after cooling, 0 unknown
bias_tempco_cubic          g/C^3      p_j dT^3
thermal_gradient           g/(C/s)    p_j dT/dt  (rate of temperature change, C/s)
bias_jump                  g          p_j [t >= t_jump_s]  (t_jump_s: a nonlinear parameter, searched)
pose_error                 deg        Mn (theta_b x f), theta_b = u_b p_bu + v_b p_bv: each placement b
                                      (consecutive steps at one nominal pose) turned off nominal
=========================  =========  ===========================================================

``pose_error`` belongs to the recording (poses placed by hand), not the sensor: its parameters are
per placement (two angles each, about the two axes perpendicular to the nominal force), it is a
candidate only when no turntable set the poses, and it never enters a calibration file.

``thermal_gradient`` needs the temperature rate. In the search it is the least-squares
slope of temp_c against t_s over each step's own samples; at ``apply`` time it is the
least-squares slope over the samples within ``rate_window_s`` / 2 of each sample
(:func:`temperature_rate`; the samples given must be one time-ordered record).

``table_tilt`` belongs to the turntable, not the sensor: it changes the true
specific force of each pose, so :func:`effect_counts` (used by ``apply``) leaves
it out. Everything else is honoured by ``AccelCalibration.apply``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from calib.errors import CalibError
from calib.frames import SENSOR_AXES



@dataclass(frozen=True)
class EffectInputs:
    """What effect terms are functions of, one row per step (or sample).

    f_g : (K, 3) specific force in the sensor frame, g.
    temp_c : (K,) sensor temperature, C, or None.
    t_s : (K,) time from session start, s.
    heating : (K,) +1 after heating, -1 after cooling, 0 unknown; or None.
    base_to_sensor : (K, 3, 3) rotation taking turntable-base vectors into the sensor frame, or None.
    matrix_g : (3, 3) the fitted M divided by lsb_per_g (dimensionless).
    t0_c : reference temperature of the temperature terms, C.
    t_ref_s : reference time of the drift term, s.
    temp_rate : (K,) rate of temperature change, C/s, or None (its terms are then zero).
    t_jump_s : time of the bias jump, s, or None (its terms are then zero).
    pose_block : (K,) integer label of each step's placement (a run of consecutive steps at one nominal
        pose), or None (``pose_error`` then has no parameters).
    """

    f_g: np.ndarray
    temp_c: np.ndarray | None
    t_s: np.ndarray
    heating: np.ndarray | None = None
    base_to_sensor: np.ndarray | None = None
    matrix_g: np.ndarray | None = None
    t0_c: float = 25.0
    t_ref_s: float = 0.0
    temp_rate: np.ndarray | None = None
    t_jump_s: float | None = None
    pose_block: np.ndarray | None = None

    def mn(self) -> np.ndarray:
        return np.eye(3) if self.matrix_g is None else np.asarray(self.matrix_g, float)

    def dt_c(self) -> np.ndarray:
        if self.temp_c is None:  # no thermometer: temperature terms are unobservable, their columns zero
            return np.zeros(len(self.f_g))
        return np.asarray(self.temp_c, float) - self.t0_c


@dataclass(frozen=True)
class Effect:
    """One candidate effect.

    Attributes
    ----------
    name : canonical name.
    description : one line for reports.
    unit : unit of every parameter.
    params : parameter labels (their order in ``estimate``).
    needs : input the effect needs beyond poses: "temp", "legs", "rotation" (pose rotations),
        "rate" (temperature rate per step), "time" (step times), or "".
    coverage : the pose / temperature coverage that makes it observable (for reports).
    on_sensor : False for properties of the rig (applied by nobody at ``apply`` time).
    contribution : (params (P,), EffectInputs) -> (K, 3) output term, g.
    sim_field : the field of the simulator's accelerometer error model
        (``drivers.sensors.sim.error_model.AccelErrorModel``) that holds this effect's parameters, in
        the same unit and order (a 3x3 field row by row); None for an effect the simulated world
        injects otherwise (``table_tilt``: the table's tilt; ``full_misalignment``: a mounting rotation).
    """

    name: str
    description: str
    unit: str
    params: tuple[str, ...]
    needs: tuple[str, ...]
    coverage: str
    on_sensor: bool
    contribution: Callable[[np.ndarray, EffectInputs], np.ndarray]
    sim_field: str | None = None
    labels: Callable[[EffectInputs], tuple] | None = None  # per-session parameters (pose_error), else params

    def param_labels(self, x: EffectInputs) -> tuple:
        """The parameters of this effect in a session (``params`` unless they depend on the session)."""
        return self.params if self.labels is None else self.labels(x)

    def columns_g(self, x: EffectInputs) -> np.ndarray:
        """Design columns (K, 3, P): the output term per unit of each parameter, g."""
        k = len(x.f_g)
        n = len(self.param_labels(x))
        out = np.zeros((k, 3, n))
        for i in range(n):
            e = np.zeros(n)
            e[i] = 1.0
            out[:, :, i] = self.contribution(e, x)
        return out


def _per_axis(col: Callable[[EffectInputs], np.ndarray]):
    def contribution(p, x):
        return np.asarray(p, float)[None, :] * col(x)
    return contribution


def _scale_tempco(p, x):
    return np.asarray(p, float)[None, :] * x.dt_c()[:, None] * (x.f_g @ x.mn().T)


def _products(f):
    return np.stack([f[:, 0] * f[:, 1], f[:, 1] * f[:, 2], f[:, 2] * f[:, 0]], axis=1)


def _cross(p, x):
    return _products(x.f_g) @ np.asarray(p, float).reshape(3, 3).T


def _full_mis(p, x):
    f, mn = x.f_g, x.mn()
    out = np.zeros_like(f)
    out[:, 1] = p[0] * mn[1, 1] * f[:, 0]
    out[:, 2] = mn[2, 2] * (p[1] * f[:, 0] + p[2] * f[:, 1])
    return out


def _tilt(p, x):
    if x.base_to_sensor is None:
        return np.zeros_like(x.f_g)
    b = np.asarray(x.base_to_sensor, float)
    tx, ty = np.radians(np.asarray(p, float))
    df = tx * b[:, :, 1] - ty * b[:, :, 0]  # B e_y, B e_x: columns of B
    return df @ x.mn().T


def _rate(x):
    return np.zeros(len(x.f_g)) if x.temp_rate is None else np.asarray(x.temp_rate, float)


def _jump(x):
    if x.t_jump_s is None:
        return np.zeros(len(x.f_g))
    return (np.asarray(x.t_s, float) >= x.t_jump_s).astype(float)


def _perpendicular(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to each row of ``f`` (K, 3) and to each other: the axes a small
    misplacement of that pose can turn about (a turn about ``f`` itself changes nothing)."""
    n = f / np.maximum(np.linalg.norm(f, axis=1), 1e-12)[:, None]
    helper = np.where(np.abs(n[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u1 = np.cross(n, helper)
    u1 /= np.linalg.norm(u1, axis=1)[:, None]
    return u1, np.cross(n, u1)


def _placements(x) -> tuple:
    if x.pose_block is None:
        return ()
    return tuple(f"placement{int(b)}_{a}" for b in np.unique(x.pose_block) for a in ("u", "v"))


def _pose_error(p, x):
    """Each placement turned by the small angles (p_u, p_v) deg about its two perpendicular axes:
    f -> f + (theta x f), output Mn (theta x f)."""
    if x.pose_block is None:
        return np.zeros_like(x.f_g)
    u1, u2 = _perpendicular(x.f_g)
    idx = np.searchsorted(np.unique(x.pose_block), x.pose_block)
    pp = np.radians(np.asarray(p, float)).reshape(-1, 2)[idx]
    theta = pp[:, [0]] * u1 + pp[:, [1]] * u2
    return np.cross(theta, x.f_g) @ x.mn().T


def _heating(x):
    return np.zeros(len(x.f_g)) if x.heating is None else np.asarray(x.heating, float)


LIBRARY: dict[str, Effect] = {e.name: e for e in [
    Effect("bias_tempco", "bias linear in temperature", "g/C", SENSOR_AXES, ("temp",),
           "steps spread over at least 2 C", True, _per_axis(lambda x: x.dt_c()[:, None]),
           sim_field="bias_tempco_g_per_c"),
    Effect("bias_tempco_quadratic", "bias quadratic in temperature", "g/C^2", SENSOR_AXES, ("temp",),
           "steps at 3 or more temperatures spread over at least 2 C", True,
           _per_axis(lambda x: x.dt_c()[:, None] ** 2), sim_field="bias_tempco2_g_per_c2"),
    Effect("scale_tempco", "scale factor linear in temperature", "1/C", SENSOR_AXES, ("temp",),
           "+ and - poses of each axis at 2 or more temperatures", True, _scale_tempco,
           sim_field="scale_tempco_per_c"),
    Effect("scale_nonlinearity", "output quadratic in the input along the same axis", "1/g", SENSOR_AXES, (),
           "three or more levels of each axis' input (e.g. -1, 0, +1 g)", True,
           _per_axis(lambda x: x.f_g ** 2), sim_field="scale_nonlinearity"),
    Effect("cross_axis_nonlinearity", "output depending on products of two input components", "1/g",
           tuple(f"{o}_{q}" for o in SENSOR_AXES for q in ("xy", "yz", "zx")), (),
           "edge or corner poses (two input components non-zero at once)", True, _cross,
           sim_field="cross_axis_nonlinearity"),
    Effect("full_misalignment", "couplings below the triangular model's diagonal (mounting rotation)", "rad",
           ("yx", "zx", "zy"), (), "poses along all three axes", True, _full_mis),
    Effect("table_tilt", "turntable base out of level (about base x, base y)", "deg", ("x", "y"),
           ("rotation",), "the outer axis turned between poses", False, _tilt),
    Effect("bias_drift", "bias changing linearly with time", "g/s", SENSOR_AXES, (),
           "steps spread in time, not in step with temperature", True,
           _per_axis(lambda x: (np.asarray(x.t_s, float) - x.t_ref_s)[:, None]), sim_field="bias_drift_g_per_s"),
    Effect("thermal_hysteresis", "bias offset after heating versus after cooling (+h/2, -h/2)", "g", SENSOR_AXES,
           ("temp", "legs"), "the same temperatures visited on a heating and a cooling leg", True,
           _per_axis(lambda x: 0.5 * _heating(x)[:, None]), sim_field="thermal_hysteresis_g"),
    Effect("bias_tempco_cubic", "bias cubic in temperature", "g/C^3", SENSOR_AXES, ("temp",),
           "steps at 4 or more temperatures spread over at least 2 C", True,
           _per_axis(lambda x: x.dt_c()[:, None] ** 3), sim_field="bias_tempco3_g_per_c3"),
    Effect("thermal_gradient", "bias proportional to the rate of temperature change dT/dt", "g/(C/s)", SENSOR_AXES,
           ("temp", "rate"), "steps captured at different temperature rates (while the chamber ramps)", True,
           _per_axis(lambda x: _rate(x)[:, None]), sim_field="thermal_gradient_g_per_c_per_s"),
    Effect("bias_jump", "a bias step at a time found by the search (shock, mode change)", "g", SENSOR_AXES, ("time",),
           "steps before and after the jump (at least 3 on each side)", True,
           _per_axis(lambda x: _jump(x)[:, None]), sim_field="bias_jump_g"),
    Effect("pose_error", "poses not where they should be: each hand placement turned off its nominal pose", "deg",
           (), ("placement",), "poses placed by hand (no turntable angles), known nominal poses", False, _pose_error,
           labels=_placements),
]}

#: the largest |parameter| of each effect a MEMS accelerometer plausibly has, in the effect's unit: about ten times
#: the worst datasheet figures of the class (MPU-9150, ADXL345: zero-g tempco <= 1.5 mg/C, sensitivity tempco
#: <= 0.02 %/C, nonlinearity <= 0.5 % of full scale, cross-axis <= 2 %). An estimate beyond it says the effect is
#: not what the data hold: among aliases, a plausible explanation is preferred to an implausible one (a scale
#: change named as a scale tempco of 300 %/C from a session whose temperature moved by a fraction of a degree)
PLAUSIBLE_MAX = {"bias_tempco": 1e-2, "bias_tempco_quadratic": 1e-3, "bias_tempco_cubic": 1e-4, "scale_tempco": 1e-2,
                 "scale_nonlinearity": 5e-2, "cross_axis_nonlinearity": 5e-2, "full_misalignment": 0.1,
                 "table_tilt": 5.0, "bias_drift": 1e-4, "thermal_hysteresis": 5e-2, "bias_jump": 0.5}


def plausible(name: str, estimate) -> bool:
    """Whether every parameter of ``name``'s ``estimate`` (its unit) is within :data:`PLAUSIBLE_MAX` (no bound:
    always)."""
    bound = PLAUSIBLE_MAX.get(name)
    est = np.asarray(estimate, float)
    return bound is None or not np.any(np.abs(est[np.isfinite(est)]) > bound)


#: extra fields an effect entry of a calibration file carries, per effect
EXTRA_FIELDS = {"bias_tempco": ("t0_c",), "bias_tempco_quadratic": ("t0_c",), "scale_tempco": ("t0_c",),
                "bias_drift": ("t_ref_s",), "thermal_hysteresis": ("band_c",), "bias_tempco_cubic": ("t0_c",),
                "thermal_gradient": ("rate_window_s",), "bias_jump": ("t_jump_s",)}
TIME_EFFECTS = ("bias_drift", "bias_jump", "thermal_gradient")


def temperature_rate(temp_c, t_s, window_s: float) -> np.ndarray:
    """dT/dt (C/s) at each sample: least-squares slope of ``temp_c`` against ``t_s`` over the samples
    within ``window_s / 2`` of it (one time-ordered record). 0 where fewer than 2 distinct times."""
    t = np.asarray(t_s, float)
    y = np.asarray(temp_c, float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) < 0):
        raise CalibError("thermal_gradient: apply() needs time-ordered t_s and temp_c of one record (>= 2 samples)")
    lo = np.searchsorted(t, t - window_s / 2, "left")
    hi = np.searchsorted(t, t + window_s / 2, "right")
    tc = t - t[0]  # conditioning

    def win(v):
        c = np.concatenate([[0.0], np.cumsum(v)])
        return c[hi] - c[lo]
    n, st, sy = hi - lo, win(tc), win(y)
    sxx = win(tc * tc) - st * st / n
    sxy = win(tc * y) - st * sy / n
    ok = sxx > 1e-12 * np.maximum(win(tc * tc), 1.0)
    return np.where(ok, sxy / np.where(ok, sxx, 1.0), 0.0)


def heating_state(temp_c, band_c: float = 0.5, initial: int = 0) -> np.ndarray:
    """Whether each temperature in a time-ordered series was reached after heating (+1) or cooling (-1).

    The state changes once the temperature moves more than ``band_c`` (C) away from the extreme of
    the current leg; 0 until the first such move. Same rule as the simulator's hysteresis.
    """
    t = np.asarray(temp_c, float)
    out = np.zeros(len(t))
    state, ref = initial, None
    for i, v in enumerate(t):
        if not np.isfinite(v):
            out[i] = state
            continue
        if ref is None:
            ref = v
        if state >= 0 and v < ref - band_c:
            state, ref = -1, v
        elif state <= 0 and v > ref + band_c:
            state, ref = 1, v
        elif (state > 0 and v > ref) or (state < 0 and v < ref):
            ref = v
        out[i] = state
    return out


def effect_counts(effects: list, f_g, temp_c, t_s, lsb_per_g: float, matrix_counts_per_g=None) -> np.ndarray:
    """Output (N, 3) in counts of a calibration file's ``effects`` at specific force ``f_g`` (N, 3), g.

    ``temp_c`` (N,) and ``t_s`` (N,) are needed by the temperature and time effects
    (a clear error otherwise). Hysteresis follows the temperature series given;
    ``thermal_gradient`` uses :func:`temperature_rate` of that series (so the samples
    must be one time-ordered record); ``bias_jump`` adds its step from ``t_jump_s`` on.
    ``table_tilt`` (a property of the rig) contributes nothing here.
    """
    f = np.atleast_2d(np.asarray(f_g, float))
    n = len(f)
    out = np.zeros((n, 3))
    mg = None if matrix_counts_per_g is None else np.asarray(matrix_counts_per_g, float) / lsb_per_g
    for e in effects:
        lib = LIBRARY[e["name"]]
        if not lib.on_sensor:
            continue
        temp = None
        if "temp" in lib.needs:
            if temp_c is None:
                raise CalibError(f"this calibration has the effect {lib.name}: apply() needs temp_c")
            temp = np.broadcast_to(np.asarray(temp_c, float), (n,))
            if not np.all(np.isfinite(temp)):
                raise CalibError(f"apply(): temp_c has NaN values but the calibration has the effect {lib.name}")
        t = None
        if lib.name in TIME_EFFECTS:
            if t_s is None:
                raise CalibError(f"this calibration has the effect {lib.name}: apply() needs t_s")
            t = np.broadcast_to(np.asarray(t_s, float), (n,))
        heating = heating_state(temp, float(e.get("band_c", 0.5))) if lib.name == "thermal_hysteresis" else None
        rate = temperature_rate(temp, t, float(e.get("rate_window_s", 5.0))) if lib.name == "thermal_gradient" else None
        x = EffectInputs(f_g=f, temp_c=temp, t_s=t if t is not None else np.zeros(n), heating=heating,
                         matrix_g=mg, t0_c=float(e.get("t0_c", 25.0)), t_ref_s=float(e.get("t_ref_s", 0.0)),
                         temp_rate=rate, t_jump_s=float(e["t_jump_s"]) if "t_jump_s" in e else None)
        p = np.nan_to_num(np.asarray(e["estimate"], float).ravel())
        out += lib.contribution(p, x)
    return out * lsb_per_g


def validate_effect(e) -> str | None:
    """What is wrong with one ``effects`` entry of a calibration file, or None."""
    if not isinstance(e, dict):
        return "expected a mapping"
    name = e.get("name")
    if name not in LIBRARY:
        return f"unknown effect {name!r} (known: {', '.join(LIBRARY)})"
    lib = LIBRARY[name]
    if lib.labels is not None:
        return f"{name} describes a recording (its placements), not the sensor: never a calibration effect"
    if e.get("unit") != lib.unit:
        return f"unit: expected {lib.unit!r}, got {e.get('unit')!r}"
    for key in ("estimate", "sigma"):
        try:
            v = np.asarray([np.nan if x is None else x for x in e.get(key) or []], float)
        except (TypeError, ValueError):
            return f"{key}: expected {len(lib.params)} numbers"
        if v.shape != (len(lib.params),):
            return f"{key}: expected {len(lib.params)} numbers ({', '.join(lib.params)}), got {v.shape}"
        if key == "estimate" and not np.all(np.isfinite(v) | np.isnan(v)):
            return "estimate: not finite"
        if key == "sigma" and np.any(v[np.isfinite(v)] < 0):
            return "sigma: must be >= 0"
    for extra in EXTRA_FIELDS.get(name, ()):
        x = e.get(extra)
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not np.isfinite(x):
            return f"{extra}: expected a number"
    return None
