"""Acceptance limits: does a calibration pass what the procedure demands? (docs/procedures.md, ``accept:``)

Pure: the caller supplies the calibration, the limits and the two figures that need more than the
calibration (the largest roll/pitch error over the session's poses, and the drift since this
sensor's previous calibration). Every limit becomes one :class:`LimitCheck` with a one-line
explanation; a limit that cannot be evaluated (a parameter this calibration does not have, a NaN
chi2/dof, no earlier figure) **fails** and says why: an acceptance never passes by default.

Parameter names are those of :mod:`calib.file.parameters` (``accel.bias_x`` ...); limits may use
shell-style patterns (``accel.bias_*``), each matching parameter is checked on its own.
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass, field

from calib.file.parameters import accel_parameters, sensor_parameters

#: every parameter name a calibration may carry (patterns in limits must match at least one)
PARAMETER_NAMES: tuple[str, ...] = tuple(
    [f"accel.{q}_{a}" for q in ("bias", "scale") for a in "xyz"]
    + ["accel.alpha_yz", "accel.alpha_zy", "accel.alpha_zx"]
    + [f"accel.m_{i}{j}" for i in "xyz" for j in "xyz" if i != j]
    + ["accel.t0_c"] + [f"accel.tempco{s}_{a}" for s in (1, 2, 3) for a in "xyz"]
    + [f"gyro.{q}_{a}" for q in ("bias", "scale") for a in "xyz"]
    + [f"mag.hard_iron_{a}" for a in "xyz"])


def known_pattern(pattern: str) -> bool:
    """Whether ``pattern`` names at least one parameter a calibration may carry."""
    return any(fnmatch.fnmatchcase(n, pattern) for n in PARAMETER_NAMES)


@dataclass(frozen=True)
class AcceptanceLimits:
    """What a calibration must achieve (all optional; units in the names).

    ranges : {parameter pattern: (low, high)} in the parameter's unit.
    max_sigma : {parameter pattern: largest 1-sigma} in the parameter's unit.
    max_chi2_per_dof : largest accelerometer chi2/dof.
    max_residual_g : largest accelerometer residual RMS, g.
    max_attitude_error_deg : largest roll or pitch error over the session's static poses, deg.
    max_drift_sigma : largest change of any parameter since the sensor's previous calibration,
        in combined sigmas.
    """

    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)
    max_sigma: dict[str, float] = field(default_factory=dict)
    max_chi2_per_dof: float | None = None
    max_residual_g: float | None = None
    max_attitude_error_deg: float | None = None
    max_drift_sigma: float | None = None


@dataclass(frozen=True)
class LimitCheck:
    """One limit applied: ``name`` (e.g. ``range accel.bias_x``), the ``limit`` as text, the ``value``
    found (None when it could not be evaluated), ``passed`` and a one-line ``line`` for people."""

    name: str
    limit: str
    value: float | None
    passed: bool
    line: str

    def to_dict(self) -> dict:
        return {"name": self.name, "limit": self.limit, "value": self.value, "passed": self.passed, "line": self.line}


@dataclass(frozen=True)
class Acceptance:
    """The verdict: passed only when every check passed (and there is at least one)."""

    checks: tuple[LimitCheck, ...]

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks)

    @property
    def verdict(self) -> str:
        return "PASS" if self.passed else "FAIL"

    def failed(self) -> list[LimitCheck]:
        return [c for c in self.checks if not c.passed]

    def to_dict(self) -> dict:
        """The calibration file's ``acceptance`` section."""
        return {"passed": self.passed, "limits": [c.to_dict() for c in self.checks]}


@dataclass(frozen=True)
class Drift:
    """The largest change since the previous calibration: parameter, change in combined sigmas, and
    when that calibration was made (None when there is none)."""

    previous_created: str | None
    parameter: str | None = None
    z: float | None = None


#: a range check whose value lies within this many sigmas of a limit says it is marginal (the verdict stays the
#: limit's: the procedure's limits decide; the words tell a technician a re-test may decide otherwise)
MARGINAL_K = 2.0
#: the unit the residual's line states it in (the fit line of rig run and rig solve: ``residual 91.9 ug rms``)
RESIDUAL_LINE_UNIT = ("ug", 1e6)


def _g(x: float) -> str:
    return f"{x:.4g}"


def stored_unit(unit: str | None) -> tuple[str | None, float]:
    """The default ``shown`` of :func:`evaluate`: every quantity in its stored unit."""
    return unit, 1.0


def type_a_sigmas(accel) -> dict[str, float]:
    """The accelerometer parameters' Type A standard uncertainty as the budget states it (``uncertainty.budget``'s
    Type A entry, docs/uncertainty.md): the solve's ``sigma`` without the part of its misfit scaling the
    turntable's own errors explain (on a table that lands where commanded, and when the solve did not scale,
    ``sigma`` itself). {parameter name: sigma}, only where the budget states one; empty without a budget."""
    entry = next((c for c in ((getattr(accel, "uncertainty", None) or {}).get("budget") or [])
                  if c.get("type") == "A"), None)
    if entry is None:
        return {}
    stated = {k: entry[k] for k in ("bias_counts", "scale_counts_per_g", "matrix_counts_per_g", "misalignment")
              if k in entry}
    rows = accel_parameters(accel.model_copy(update={"sigma": stated}))
    return {name: s for name, _v, s, _u in rows if s is not None}


def _parameter_checks(limits: AcceptanceLimits, params: dict, shown=stored_unit,
                      type_a: dict | None = None) -> list[LimitCheck]:
    """The range and sigma limits; each check's ``value`` in the stored unit, its ``line`` for people in the unit
    ``shown(unit) -> (unit shown, factor)`` gives (limits and values alike). ``type_a``: {name: sigma} the sigma
    limits judge instead of the solve's sigma (:func:`type_a_sigmas`)."""
    type_a = type_a or {}
    def line_range(name, v, s, u, lo, hi):
        to, k = shown(u)
        line = (f"{name} = {_g(v * k)} {to}: {'within' if lo <= v <= hi else 'outside'} "
                f"[{_g(lo * k)}, {_g(hi * k)}] {to}")
        edge = min(abs(v - lo), abs(v - hi))
        if s is not None and math.isfinite(float(s)) and s > 0 and edge <= MARGINAL_K * s:
            line += (f" (marginal: {_g(edge * k)} {to} from the limit, within {MARGINAL_K:g} sigma, "
                     f"{_g(MARGINAL_K * s * k)} {to}: a re-test may decide otherwise)")
        return line

    def line_sigma(name, s, u, top, solved=None):
        to, k = shown(u)
        if s is None:
            return f"{name}: no sigma to compare with {_g(top * k)} {to}"
        line = f"{name}: sigma {_g(s * k)} {to} {'<=' if s <= top else '>'} {_g(top * k)} {to}"
        if solved is not None and not math.isclose(solved, s, rel_tol=1e-9):
            line += (f" (Type A: the solve's {_g(solved * k)} {to} less the misfit scaling the turntable's own "
                     f"errors explain, which the expanded uncertainty holds)")
        return line

    def judge_sigma(name, s, u, top):
        a = type_a.get(name, s)
        return a, a is not None and a <= top, line_sigma(name, a, u, top, s)

    out = []
    for pattern, (lo, hi) in limits.ranges.items():
        out += _each(pattern, params, "range", f"[{_g(lo)}, {_g(hi)}]",
                     lambda name, v, s, u: (v, lo <= v <= hi, line_range(name, v, s, u, lo, hi)))
    for pattern, top in limits.max_sigma.items():
        out += _each(pattern, params, "sigma", f"<= {_g(top)}",
                     lambda name, v, s, u: judge_sigma(name, s, u, top))
    return out


def _each(pattern: str, params: dict, kind: str, limit: str, judge) -> list[LimitCheck]:
    names = [n for n in params if fnmatch.fnmatchcase(n, pattern)]
    if not names:
        return [LimitCheck(f"{kind} {pattern}", limit, None, False,
                           f"{pattern}: this calibration has no such parameter, so the {kind} limit cannot be checked")]
    checks = []
    for name in names:
        value, sigma, unit = params[name]
        shown, ok, line = judge(name, value, sigma, unit)
        checks.append(LimitCheck(f"{kind} {name}", limit, shown, bool(ok), line))
    return checks


def _upper(name: str, value, top: float, what: str, unit: str, missing: str,
           line_unit: tuple[str, float] | None = None) -> LimitCheck:
    """``value <= top``; a missing or non-finite value fails with ``missing``. ``line_unit``: (unit, factor) the
    line for people states value and limit in (the check's ``value`` and ``limit`` keep ``unit``)."""
    unit_s = f" {unit}" if unit else ""
    if value is None or not math.isfinite(float(value)):
        return LimitCheck(name, f"<= {_g(top)}{unit_s}", None, False, f"{what}: cannot be checked: {missing}")
    ok = float(value) <= top
    to, k = line_unit or (unit, 1.0)
    to_s = f" {to}" if to else ""
    return LimitCheck(name, f"<= {_g(top)}{unit_s}", float(value), ok,
                      f"{what} {_g(float(value) * k)}{to_s} {'<=' if ok else '>'} {_g(top * k)}{to_s}")


def evaluate(cal, limits: AcceptanceLimits, *, attitude_error_deg: float | None = None,
             drift: Drift | None = None, shown=stored_unit) -> Acceptance:
    """Apply ``limits`` to calibration file ``cal``.

    Parameters
    ----------
    cal : :class:`calib.CalibrationFile`.
    limits : :class:`AcceptanceLimits`.
    attitude_error_deg : largest |roll| or |pitch| error over the session's static poses (deg), or None.
    drift : the largest change since the sensor's previous calibration, or None when not looked up.
    shown : ``unit -> (unit shown, factor)``: the unit each check's line states a parameter in (values and
        limits stay in the stored unit; default: the stored unit).
    """
    params = {name: (v, s, u) for name, v, s, u in sensor_parameters(cal)}
    checks = _parameter_checks(limits, params, shown, type_a_sigmas(cal.accelerometer))
    fit = cal.accelerometer.fit
    if limits.max_chi2_per_dof is not None:
        checks.append(_chi2_check(cal.accelerometer, limits.max_chi2_per_dof))
    if limits.max_residual_g is not None:
        checks.append(_upper("max_residual_g", fit.residual_rms_g, limits.max_residual_g, "residual rms", "g",
                             "no residual", line_unit=RESIDUAL_LINE_UNIT))
    if limits.max_attitude_error_deg is not None:
        checks.append(_upper("max_attitude_error_deg", attitude_error_deg, limits.max_attitude_error_deg,
                             "largest roll/pitch error over the session's poses", "deg",
                             "the session has no static steps with known poses"))
    if limits.max_drift_sigma is not None:
        checks.append(_drift_check(drift, limits.max_drift_sigma))
    return Acceptance(tuple(checks))


def _chi2_check(accel, top: float) -> LimitCheck:
    """chi2/dof against the noise and the turntable's own errors when the budget judged the fit so
    (``uncertainty.misfit_with_rig``: a real table moves every pose by a few hundredths of a degree, several times a
    step's noise), else against the noise alone. A loose mount or a sensor that is not rigid fails either."""
    with_rig = (getattr(accel, "uncertainty", None) or {}).get("misfit_with_rig")
    alone = accel.fit.chi2_per_dof
    missing = "no degrees of freedom left (too few steps for the model)"
    if not with_rig or with_rig.get("chi2_per_dof") is None or not math.isfinite(float(with_rig["chi2_per_dof"])):
        return _upper("max_chi2_per_dof", alone, top, "chi2/dof", "", missing)
    check = _upper("max_chi2_per_dof", float(with_rig["chi2_per_dof"]), top,
                   "chi2/dof against the noise and the turntable's own errors", "", missing)
    alone_s = f"{_g(float(alone))}" if alone is not None and math.isfinite(float(alone)) else "none"
    return LimitCheck(check.name, check.limit, check.value, check.passed,
                      f"{check.line} (against the noise alone {alone_s})")


def _drift_check(drift: Drift | None, top: float) -> LimitCheck:
    name, limit = "max_drift_sigma", f"<= {_g(top)} sigma"
    if drift is None:
        return LimitCheck(name, limit, None, False, "drift: cannot be checked: the calibration history was not read")
    if drift.previous_created is None:
        return LimitCheck(name, limit, None, True, "drift: first calibration of this sensor, nothing to compare with")
    if drift.z is None or not math.isfinite(drift.z):
        return LimitCheck(name, limit, None, False,
                          f"drift: cannot be checked: no parameter with sigmas in common with the calibration "
                          f"of {drift.previous_created}")
    ok = abs(drift.z) <= top
    return LimitCheck(name, limit, drift.z, ok,
                      f"drift since {drift.previous_created}: {drift.parameter} moved {drift.z:+.1f} sigma "
                      f"({'within' if ok else 'beyond'} {_g(top)} sigma)")


def largest_drift(current: list[tuple], previous: dict, previous_created: str | None) -> Drift:
    """The parameter that moved most, in combined sigmas, between ``current`` (rows of
    :func:`calib.file.parameters.sensor_parameters`) and ``previous`` ({name: (value, sigma, unit)})."""
    if previous_created is None:
        return Drift(None)
    worst: tuple[str | None, float | None] = (None, None)
    for name, value, sigma, _unit in current:
        if name not in previous or name == "accel.t0_c":
            continue
        v0, s0, _ = previous[name]
        if sigma is None or s0 is None or not math.hypot(sigma, s0) > 0:
            continue
        z = (value - v0) / math.hypot(sigma, s0)
        if worst[1] is None or abs(z) > abs(worst[1]):
            worst = (name, z)
    return Drift(previous_created, *worst)
