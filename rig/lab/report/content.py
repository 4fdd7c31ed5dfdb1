"""What ``rig report`` shows, computed from the session, its calibration file, ``rig discover``'s output
and the calibration history (docs/report.md). No HTML here: :mod:`rig.lab.report.render` draws it.

Every part that may be missing (no temperature, no known poses, no discover run, no history) is a
value with a ``note`` saying why, never an exception: the report always says what it could not show.
Every auxiliary file read (``rig discover`` documents and augmented calibration files in the session
folder, the history's rows) is checked first; a damaged one is left out with a note saying what is
wrong with it (``discover.json: not a rig-discover/6 document (effects: expected a list); left out``),
never a failed report.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import calib
from calib.file import calibration as calfile
from calib.discovery.effects import LIBRARY
from calib.errors import CalibError
from calib.gyro.result import NONORTHOGONALITY_NAMES
from calib.mag.result import sigma_names as mag_sigma_names
from calib.file.parameters import accel_parameters, sensor_parameters
from rig.analysis.discover import already_modelled, document_headline
from rig.analysis.solve import accelerometer_absent
from rig.errors import RigInputError
from rig.lab.bias_temperature import reference_view
from rig.lab.drift import (CalibrationRecord, drift, flagged_names, history_notes, like_with_like_lines, resolve_of,
                           sensor_history)
from rig.lab.fit import EXACTLY_DETERMINED, exactly_determined, misfit_words
from rig.lab.history import HistoryError, default_path, open_history
from rig.lab.identity import sensor_identity
from rig.lab.units import (GYRO_G_SENSITIVITY_UNIT, GYRO_NONORTHOGONALITY_UNIT, gyro_g_sensitivity_terms, shown,
                            shown_scale)
from rig.session import Session, load_session, step_means

#: the seed paper's verification procedure (an independent roll/pitch check)
VERIFY_PROCEDURE = "procedures/verify_seed_table.yaml"
#: files in the session larger than this are not read as discover output
MAX_DISCOVER_BYTES = 50_000_000
#: the rig discover contract the report reads (docs/discrepancy.md)
DISCOVER_FORMAT = "rig-discover/6"
HISTORY_TIMEOUT_S = 5.0


@dataclass
class Parameter:
    section: str
    name: str
    value: float
    sigma: float | None
    unit: str
    change: dict | None = None  # since the previous calibration of this sensor: {delta, combined_sigma, z, flagged}
    temp_c: float | None = None  # the temperature the value holds at, when the model states one (a bias at t0), C


@dataclass
class Verdict:
    """``state``: pass | fail | none (no acceptance limits). ``incomplete``: lines flagging an unfinished session."""

    state: str
    headline: str
    failed: list[str] = field(default_factory=list)
    limits: list[dict] = field(default_factory=list)
    fit: list[tuple[str, str]] = field(default_factory=list)
    incomplete: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


@dataclass
class Residuals:
    """The calibration's residual at every static step: calibrated minus nominal specific force (µg, per
    axis), or ``|f| - 1`` (µg) when the poses are unknown."""

    names: list[str] = field(default_factory=list)
    temps_c: list[float | None] = field(default_factory=list)
    values_ug: np.ndarray | None = None
    labels: tuple[str, ...] = ("x", "y", "z")
    note: str = ""

    @property
    def rms_ug(self) -> float:
        return float(np.sqrt(np.mean(self.values_ug ** 2))) if self.values_ug is not None else float("nan")


@dataclass
class SeedTable:
    evaluation: object | None = None  # calib.Evaluation
    note: str = ""


@dataclass
class DiscoverSummary:
    """What ``rig discover`` left in the session: its JSON document and/or augmented calibration files."""

    documents: list[tuple[Path, dict]] = field(default_factory=list)
    calibrations: list[tuple[Path, list[dict]]] = field(default_factory=list)
    note: str = ""
    problems: list[str] = field(default_factory=list)  # damaged documents and calibration files, left out
    lsb_per_g: float | None = None  # the sensor's nominal sensitivity, counts/g: the bias tempcos shown in counts/C^s
    headlines: list[str] = field(default_factory=list)  # per document: the verdict in words, as rig discover prints it
    modelled: list[str] = field(default_factory=list)  # effects the session's own calibration models already


@dataclass
class HistoryView:
    path: Path | None = None
    key: str = ""
    records: list[CalibrationRecord] = field(default_factory=list)
    current: int | None = None  # index of this report's calibration in records
    flagged: list[str] = field(default_factory=list)
    note: str = ""
    notes: list[str] = field(default_factory=list)  # damaged rows of the history: what is missing or left out
    reference: str = ""  # the temperature the accelerometer biases are compared at (rig.lab.bias_temperature)
    like_with_like: list[str] = field(default_factory=list)  # re-solves (not compared) and who is compared with whom
    resolve_of: int | None = None  # this report's calibration re-solves the session of records[resolve_of]


@dataclass
class UncertaintyRow:
    """One accelerometer parameter's expanded uncertainty and its budget, in the unit shown (mrad for angles)."""

    name: str
    value: float
    unit: str
    expanded: float | None
    combined: float | None
    parts: list[float | None] = field(default_factory=list)  # each contribution's standard uncertainty


@dataclass
class UncertaintyView:
    """``accelerometer.uncertainty`` of the calibration file (docs/uncertainty.md): U = k u_c per parameter and
    the budget, one column per contribution ((name, type, source)); ``note`` says why there is none."""

    k: float | None = None
    contributions: list[tuple[str, str, str]] = field(default_factory=list)
    rows: list[UncertaintyRow] = field(default_factory=list)
    rig: str = ""
    note: str = ""


@dataclass
class ReportContent:
    session: Session
    calibration: object  # calib.file.calibration.CalibrationFile
    calibration_path: Path
    verdict: Verdict
    parameters: list[Parameter]
    residuals: Residuals
    seed: SeedTable
    discover: DiscoverSummary
    history: HistoryView
    sensor_key: str
    other_calibrations: list[tuple[Path, object]] = field(default_factory=list)
    uncertainty: UncertaintyView = field(default_factory=UncertaintyView)


# ---------------------------------------------------------------------------------------------- loading

def load(session_dir, calibration=None, *, session: Session | None = None,
         calibration_file=None) -> tuple[Session, object, Path]:
    """The session and its calibration file (``SESSION/calibration.yaml`` unless ``calibration``).
    ``session``, ``calibration_file``: the session and the file's content when the caller holds them
    (the pipeline tail: then neither is read again).

    Raises SessionFormatError (not a session), RigInputError (no calibration yet, another sensor),
    CalibrationFileError (a damaged calibration file): all exit 2.
    """
    session = session if session is not None else load_session(session_dir)
    path = Path(calibration) if calibration is not None else Path(session_dir) / "calibration.yaml"
    if calibration_file is not None:
        return session, calibration_file, path
    if not path.exists():
        if calibration is None and accelerometer_absent(session):
            raise RigInputError(str(session_dir), None, None, "the session has no accelerometer data, so it has no "
                                "calibration file to report (rig-calibration/1 holds an accelerometer section): "
                                f"`rig solve {session_dir}` prints its magnetometer and gyroscope (--json keeps them)")
        if calibration is None:
            raise RigInputError(str(path), None, None, f"no calibration yet: run `rig solve {session_dir}` first "
                                "(or give one with --calibration)")
        raise RigInputError(str(path), None, "--calibration", "no such calibration file")
    cal = calfile.read(path)
    lsb = float(cal.accelerometer.lsb_per_g)
    if not math.isclose(lsb, session.lsb_per_g, rel_tol=1e-9):
        raise RigInputError(str(path), None, "accelerometer.lsb_per_g", f"the calibration is for {lsb:g} counts/g, "
                            f"the session recorded {session.lsb_per_g:g} counts/g (another range or sensor)")
    return session, cal, path


def other_calibrations(session: Session, main: Path, problems: list[str] | None = None) -> list[tuple[Path, object]]:
    """The other calibration files in the session folder (re-solves, ``rig discover -o``), readable ones;
    each unreadable one is a line in ``problems`` (``calibration-x.yaml: not a readable calibration file
    (...); left out``)."""
    out = []
    for p in sorted(session.path.glob("calibration*.yaml")):
        if p.resolve() == main.resolve():
            continue
        try:
            if not p.is_file():
                raise CalibError("not a regular file")
            out.append((p, calfile.read(p)))
        except (CalibError, OSError, ValueError) as exc:
            if problems is not None:
                why = _first_line(exc).removeprefix(f"{p}: ").removeprefix(f"{p.resolve()}: ")
                problems.append(f"{p.name}: not a readable calibration file ({why}); left out")
    return out


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


# ---------------------------------------------------------------------------------------------- verdict

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


#: the checks that are not a parameter's: (unit the file states value and limit in, unit shown, factor)
FIT_CHECK_UNITS = {"max_residual_g": ("g", "µg", 1e6), "max_attitude_error_deg": ("deg", "deg", 1.0)}


def _shown_limit(e: dict, units: dict) -> dict:
    """A check's value and limit in the unit the report shows the quantity in, the unit named beside both (angles
    in mrad, as the line and every printout state them; the residual in µg, as the fit line above it; the file
    keeps the stored unit: rad, g). ``unit``: the unit shown ("" for a ratio such as chi2/dof or sigmas)."""
    kind, _, name = e["name"].partition(" ")
    if kind in ("range", "sigma"):
        stored = units.get(name)
        to, k = shown_scale(stored)
    elif e["name"] in FIT_CHECK_UNITS:
        stored, to, k = FIT_CHECK_UNITS[e["name"]]
    else:
        return {**e, "unit": ""}
    if stored is None:
        return {**e, "unit": ""}
    value = e["value"] * k if _is_number(e["value"]) else e["value"]
    limit = _NUMBER.sub(lambda m: f"{float(m.group()) * k:.4g}", str(e["limit"]).removesuffix(f" {stored}"))
    out = {**e, "value": value, "limit": f"{limit} {to}", "unit": to}
    if e["name"] == "max_residual_g" and _is_number(e["value"]):  # the file's line states g: said in µg here
        top = _NUMBER.search(limit)
        out["line"] = (f"residual rms {value:.1f} µg {'<=' if e['passed'] else '>'} {top.group()} µg" if top
                       else out["line"])
    return out


def _field(obj, name, default=None):
    """``obj.name`` or ``obj[name]`` (the acceptance section may be a model or a plain mapping)."""
    if isinstance(obj, dict):
        return obj.get(name, default)
    return getattr(obj, name, default)


def completeness(session: Session) -> tuple[list[str], list[str]]:
    """(lines flagging an unfinished session, warnings about flagged steps)."""
    info = session.info
    incomplete, warnings = [], []
    if info.status != "complete":
        resume = f" (resume it with `rig run --resume {session.path}`)" if info.rig.kind != "import" else ""
        incomplete.append(f"session status is '{info.status}', not 'complete': the run did not finish{resume}")
    missing = [s for s in info.steps if s.status in ("pending", "failed")]
    if missing:
        names = ", ".join(f"{s.label} ({s.status})" for s in missing[:8]) + (" ..." if len(missing) > 8 else "")
        incomplete.append(f"{len(missing)} of {len(info.steps)} steps not recorded: {names}")
    for s in info.steps:
        if s.status == "flagged":
            problems = (s.stats.problems if s.stats is not None else None) or []
            warnings.append(f"step {s.label} is flagged" + (f": {'; '.join(map(str, problems))}" if problems else ""))
    return incomplete, warnings


def fit_quality(cal) -> list[tuple[str, str]]:
    """(label, text) lines of how well each section's model fits its data."""
    a = cal.accelerometer
    fit = a.fit
    chi2 = fit.chi2_per_dof
    exact = exactly_determined(fit.residual_rms_g, a.degrees_of_freedom())
    lines = [("accelerometer", f"{a.model} model by {fit.method or 'pinv'}: {fit.steps} steps used "
                               f"({fit.samples} samples), residual {fit.residual_rms_g * 1e6:.1f} µg rms, "
                               + (EXACTLY_DETERMINED if exact else "chi2/dof "
                                  + (f"{chi2:.2f}" if math.isfinite(chi2) else "n/a (no degrees of freedom)"))
                               + misfit_words(cal.accelerometer))]
    g = cal.gyroscope
    if g is not None:
        lines.append(("gyroscope", f"{g.n_steps} rate steps, residual {g.residual_rms_dps:.4f} deg/s rms, "
                                   f"chi2/dof {g.chi2_per_dof:.2f}"))
    m = cal.magnetometer
    if m is not None:
        lines.append(("magnetometer", f"{m.method}: {m.n_steps} steps, residual {m.residual_rms_ut:.3f} µT rms"))
    return lines


def verdict(session: Session, cal) -> Verdict:
    """PASS/FAIL from the calibration's acceptance section when it has one, else 'no acceptance limits';
    always the fit quality and the completeness of the session."""
    incomplete, warnings = completeness(session)
    warnings += list(session.warnings)
    coverage = getattr(cal, "coverage", None)
    if coverage is not None and not _field(coverage, "complete", True):
        pending = list(_field(coverage, "pending_steps", None) or [])
        incomplete.append(f"the calibration was solved from {_field(coverage, 'steps_recorded', '?')} of "
                          f"{_field(coverage, 'steps_planned', '?')} planned steps (session "
                          f"{_field(coverage, 'status', '?')})" + (f"; pending: {', '.join(map(str, pending[:8]))}"
                                                                    if pending else ""))
    if cal.session and cal.session != session.id:
        warnings.append(f"the calibration was solved from session {cal.session}; this report evaluates it on "
                        f"session {session.id}")
    acceptance = getattr(cal, "acceptance", None)
    v = Verdict(state="none", headline="no acceptance limits", fit=fit_quality(cal), incomplete=incomplete,
                warnings=warnings)
    if acceptance is None:
        return v
    units = {name: unit for name, _, _, unit in sensor_parameters(cal)}
    limits = [_shown_limit({"name": str(_field(e, "name", "")), "limit": _field(e, "limit"), "value": _field(e, "value"),
                            "passed": bool(_field(e, "passed", False)), "line": str(_field(e, "line", "") or "")},
                           units)
              for e in (_field(acceptance, "limits") or [])]
    passed = bool(_field(acceptance, "passed", False))
    v.state, v.limits = ("pass" if passed else "fail"), limits
    v.failed = [e["line"] or f"{e['name']}: {e['value']} beyond {e['limit']}" for e in limits if not e["passed"]]
    v.headline = (f"PASS: all {len(limits)} acceptance limits met" if passed else
                  f"FAIL: {len(v.failed)} of {len(limits)} acceptance limits not met")
    return v


# ---------------------------------------------------------------------------------------------- parameters

def _vector(out, section, prefix, values, sigmas, unit):
    for axis, v, s in zip("xyz", np.asarray(values, float).ravel(), sigmas):
        out.append(Parameter(section, f"{prefix}_{axis}", float(v), _num(s), unit))


def _num(x) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def parameters(cal) -> list[Parameter]:
    """Every parameter of the calibration file with its 1-sigma and unit (the history's names; angles in mrad, as
    ``rig run`` prints them: :mod:`rig.lab.units`); the accelerometer biases of a thermal model with the
    temperature they hold at (``temp_c``: its ``t0``)."""
    out = [Parameter("accelerometer", n, *shown(v, s, u)) for n, v, s, u in accel_parameters(cal.accelerometer)]
    temperature = cal.accelerometer.temperature
    if temperature is not None:  # a thermal model states its biases at its reference temperature t0
        for p in out:
            if p.name.startswith("accel.bias_"):
                p.temp_c = _num(temperature.t0_c)
    for e in cal.accelerometer.effects:
        lib = LIBRARY.get(e["name"])
        names = lib.params if lib is not None else [str(i) for i in range(len(e.get("estimate") or []))]
        for pname, v, s in zip(names, e.get("estimate") or [], e.get("sigma") or []):
            if v is not None:
                out.append(Parameter("accelerometer effects", f"effect.{e['name']}.{pname}",
                                     *shown(float(v), _num(s), str(e.get("unit", "-")))))
    g = cal.gyroscope
    if g is not None:
        _vector(out, "gyroscope", "gyro.bias", g.bias_counts, [g.sigma.get(f"b_{x}") for x in "xyz"], "counts")
        _vector(out, "gyroscope", "gyro.scale", g.scale_counts_per_dps, [g.sigma.get(f"k_{x}") for x in "xyz"],
                "counts/(deg/s)")
        for n in NONORTHOGONALITY_NAMES:
            out.append(Parameter("gyroscope", f"gyro.{n}", float(g.nonorthogonality[n]), _num(g.sigma.get(n)),
                                 GYRO_NONORTHOGONALITY_UNIT))
        for n, v, s in gyro_g_sensitivity_terms(g.g_sensitivity):  # the determined columns only, as rig run prints
            out.append(Parameter("gyroscope", f"gyro.g_sensitivity_{n}", v, _num(s), GYRO_G_SENSITIVITY_UNIT))
    m = cal.magnetometer
    if m is not None:
        _vector(out, "magnetometer", "mag.hard_iron", m.hard_iron_ut, [m.sigma.get(f"hard_iron_{x}") for x in "xyz"],
                "uT")
        a = np.asarray(m.matrix, float)
        for n in mag_sigma_names()[3:]:
            i, j = "xyz".index(n[2]), "xyz".index(n[3])
            out.append(Parameter("magnetometer", f"mag.{n}", float(a[i, j]), _num(m.sigma.get(n)), "-"))
    return out


# ---------------------------------------------------------------------------------------------- uncertainty

def _pick(block, name: str) -> float | None:
    """The value of parameter ``name`` (``accel.bias_x``, ``accel.alpha_yz``, ``accel.m_xy``) in a block of
    ``sigma``'s keys (the uncertainty section, u_c, one contribution)."""
    if not isinstance(block, dict):
        return None
    stem = name.removeprefix("accel.")
    try:
        if stem.startswith(("bias_", "scale_")):
            key = "bias_counts" if stem.startswith("bias_") else "scale_counts_per_g"
            return _num(block[key]["xyz".index(stem[-1])])
        if stem.startswith("alpha_"):
            return _num(block["misalignment"][stem])
        if stem.startswith("m_"):
            return _num(block["matrix_counts_per_g"]["xyz".index(stem[2])]["xyz".index(stem[3])])
    except (KeyError, IndexError, TypeError, ValueError):
        return None
    return None


def uncertainty_view(cal) -> UncertaintyView:
    """The accelerometer's expanded uncertainty and budget, per parameter (biases, scales, angles or cross-axis
    terms), in the units the parameters table uses."""
    u = cal.accelerometer.uncertainty
    if not u:
        return UncertaintyView(note="No uncertainty budget in this calibration file (made by rig run and rig solve "
                                    "for the pose methods pinv and combinations; docs/uncertainty.md).")
    budget = [c for c in u.get("budget") or [] if isinstance(c, dict)]
    view = UncertaintyView(k=_num(u.get("k")), rig=str(u.get("rig") or ""),
                           contributions=[(str(c.get("name", "?")), str(c.get("type", "?")), str(c.get("source", "")))
                                          for c in budget])
    for name, value, _, unit in accel_parameters(cal.accelerometer):
        if not name.startswith(("accel.bias_", "accel.scale_", "accel.alpha_", "accel.m_")):
            continue
        factor = shown(1.0, None, unit)[0]
        scaled = [None if x is None else x * factor for x in
                  [_pick(u, name), _pick(u.get("combined_standard"), name)] + [_pick(c, name) for c in budget]]
        view.rows.append(UncertaintyRow(name, value * factor, shown(value, None, unit)[2], scaled[0], scaled[1],
                                        scaled[2:]))
    return view


# ---------------------------------------------------------------------------------------------- residuals

def residuals(session: Session, cal) -> Residuals:
    """Calibrated minus nominal specific force at every complete static step (µg), or |f| - 1 without poses."""
    known = session.static_step_indices()
    idx = known or session.static_step_indices(unknown_pose=True)
    if not idx:
        return Residuals(note="the session has no complete static step: no residuals to show")
    try:
        means = step_means(session, idx)
        f = cal.accelerometer.apply(means.mean_counts, temp_c=means.temp_c, t_s=means.t_s)
    except (CalibError, RigInputError) as exc:
        return Residuals(note=f"the residuals cannot be computed: {exc}")
    temps = [None if t is None or not np.isfinite(t) else float(t) for t in
             (means.temp_c if means.temp_c is not None else [None] * len(idx))]
    if known:
        values, labels = (f - means.f_nominal_g) * 1e6, ("x", "y", "z")
    else:
        values, labels = (np.linalg.norm(f, axis=1, keepdims=True) - 1.0) * 1e6, ("|f| - 1",)
    note = "" if known else "the poses are unknown: the residual is |f| - 1 (the calibrated magnitude against 1 g)"
    return Residuals(names=list(means.names), temps_c=temps, values_ug=values, labels=labels, note=note)


def seed_table(session: Session, cal) -> SeedTable:
    """The seed paper's roll/pitch table (``rig evaluate``) over the steps with known poses."""
    if not session.static_step_indices():
        return SeedTable(note="no static step with a known pose: the roll/pitch table needs verification poses")
    try:
        ev = calib.evaluate(cal.accelerometer, session.step_means())
    except (CalibError, RigInputError) as exc:
        return SeedTable(note=f"the roll/pitch table cannot be computed: {exc}")
    if cal.session == session.id:
        note = (f"In-sample: these are the poses the calibration was fitted to. For an independent check run "
                f"{VERIFY_PROCEDURE} and `rig report VERIFY_SESSION --calibration {session.path}/calibration.yaml`.")
    else:
        note = f"Independent check: the calibration was solved from session {cal.session or '(unknown)'}."
    return SeedTable(evaluation=ev, note=note)


# ---------------------------------------------------------------------------------------------- discover

class DamagedDocument(ValueError):
    """A rig discover document the report cannot show; ``str()`` says where and what (``effects: expected a list``)."""


def _got(v) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _expect(ok: bool, where: str, what: str, v) -> None:
    if not ok:
        raise DamagedDocument(f"{where}: expected {what}, got {_got(v)}")


def _optional(doc: dict, key: str, check, what: str, where: str = "") -> None:
    if key in doc and doc[key] is not None:
        _expect(check(doc[key]), f"{where}{key}", what, doc[key])


def _numbers(v, n: int | None = None) -> bool:
    return isinstance(v, list) and (n is None or len(v) == n) and all(x is None or _is_number(x) for x in v)


def check_discover_document(doc) -> dict:
    """``doc`` when it is a rig discover document the report can show (what it reads has the contract's
    types: docs/schemas/discover.schema.json); DamagedDocument saying where it is not."""
    _expect(isinstance(doc, dict), "the document", "a JSON object", doc)
    fmt = doc.get("format")
    _expect(isinstance(fmt, str) and fmt.startswith("rig-discover/"), "format", f"{DISCOVER_FORMAT!r}", fmt)
    for key in ("rms_before_g", "rms_after_g", "noise_rms_g", "chi2_per_dof_before", "chi2_per_dof_after"):
        _optional(doc, key, _is_number, "a number")
    _optional(doc, "gap_closed", lambda v: isinstance(v, bool), "true or false")
    _optional(doc, "headline", lambda v: isinstance(v, str), "a text")
    _optional(doc, "unobservable", lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
              "a list of effect names")
    _optional(doc, "effects", lambda v: isinstance(v, list), "a list")
    for i, e in enumerate(doc.get("effects") or []):
        where = f"effects[{i}]"
        _expect(isinstance(e, dict), where, "a mapping", e)
        _expect(isinstance(e.get("name"), str), f"{where}.name", "a text", e.get("name"))
        _optional(e, "axes", lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v), "a list of axis names",
                  f"{where}.")
        for key in ("estimate", "sigma"):
            _optional(e, key, _numbers, "a list of numbers (null where unknown)", f"{where}.")
        _optional(e, "unit", lambda v: isinstance(v, str), "a text", f"{where}.")
        for key in ("p_value", "rms_after_g"):
            _optional(e, key, _is_number, "a number", f"{where}.")
    _optional(doc, "steps", lambda v: isinstance(v, list), "a list")
    for i, st in enumerate(doc.get("steps") or []):
        where = f"steps[{i}]"
        _expect(isinstance(st, dict), where, "a mapping", st)
        _expect(isinstance(st.get("name"), str) or _is_number(st.get("name")), f"{where}.name", "a text",
                st.get("name"))
        _optional(st, "temp_c", _is_number, "a number", f"{where}.")
        for key in ("residual_before_g", "residual_after_g"):
            _expect(_numbers(st.get(key), 3), f"{where}.{key}", "a list of 3 numbers (x, y, z; null where unknown)",
                    st.get(key))
    return doc


def _read_json(path: Path):
    """The JSON value in ``path``; DamagedDocument when it cannot be read or is not JSON."""
    try:
        if not path.is_file():
            raise DamagedDocument("not a regular file")
        if path.stat().st_size > MAX_DISCOVER_BYTES:
            raise DamagedDocument(f"larger than {MAX_DISCOVER_BYTES // 1_000_000} MB")
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise DamagedDocument(f"cannot be read: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise DamagedDocument(f"not JSON: {_first_line(exc)}") from None


def _discover_document(path: Path, problems: list[str]) -> dict | None:
    """The rig discover document in ``path``, checked. None for a file that is no such document (a JSON of
    another format; a file that is not JSON, unless its name starts with ``discover``) and for a damaged
    one: then a line in ``problems``."""
    named = path.name.lower().startswith("discover")
    try:
        doc = _read_json(path)
    except DamagedDocument as exc:
        if named:
            problems.append(f"{path.name}: not a {DISCOVER_FORMAT} document ({exc}); left out")
        return None
    fmt = doc.get("format") if isinstance(doc, dict) else None
    claims = isinstance(fmt, str) and fmt.startswith("rig-discover/")
    if not (named or claims):
        return None
    try:
        return check_discover_document(doc)
    except DamagedDocument as exc:
        shown = fmt if claims and re.fullmatch(r"rig-discover/\d+", fmt) else DISCOVER_FORMAT
        problems.append(f"{path.name}: not a {shown} document ({exc}); left out")
        return None


def discover_outputs(session: Session, others: list[tuple[Path, object]],
                     problems: list[str] | None = None) -> DiscoverSummary:
    """``rig discover`` documents (``--json`` saved in the session) and augmented calibration files (``-o``);
    ``problems``: the damaged ones found so far (calibration files), the damaged documents are added."""
    problems = list(problems or [])
    docs = [(p, d) for p in sorted(session.path.glob("*.json")) if (d := _discover_document(p, problems)) is not None]
    cals = [(p, list(c.accelerometer.effects)) for p, c in others if c.accelerometer.effects]
    note = "" if docs or cals or problems else (
        "rig discover has not been run on this session, or its output was not saved in the session folder; "
        f"to include it: rig discover {session.path} --json > {session.path}/discover.json")
    return DiscoverSummary(documents=docs, calibrations=cals, note=note, problems=problems,
                           lsb_per_g=_num(session.lsb_per_g),
                           headlines=[document_headline(session, d) for _, d in docs],
                           modelled=sorted(already_modelled(session)) if docs else [])


# ---------------------------------------------------------------------------------------------- history

def history_view(session: Session, cal, cal_path: Path, history_db=None) -> HistoryView:
    """This sensor's calibrations in the history database; a note instead when there are none."""
    key = sensor_identity(session.info.to_dict(), cal)["key"]
    path = default_path(history_db)
    if not path.exists():
        return HistoryView(path=path, key=key, note=f"no history database at {path} (docs/history.md)")
    try:
        with open_history(history_db, create=False, timeout_s=HISTORY_TIMEOUT_S) as h:
            records = sensor_history(h, key)
    except HistoryError as exc:
        return HistoryView(path=path, key=key, note=f"the history could not be read: {exc}")
    if not records:
        return HistoryView(path=path, key=key, note=f"no calibration of sensor {key} in the history {path}")
    mine = [i for i, r in enumerate(records) if r.info.get("session_id") == session.id]
    exact = [i for i in mine if _cal_path(records[i]) == str(cal_path.resolve())]
    current = (exact or mine or [None])[-1]
    return HistoryView(path=path, key=key, records=records, current=current, flagged=flagged_names(drift(records)),
                       notes=history_notes(records), reference=reference_view(records).describe(),
                       like_with_like=like_with_like_lines(records),
                       resolve_of=None if current is None else resolve_of(records, current))


def _cal_path(record: CalibrationRecord) -> str:
    return str(record.info.get("calibration_path") or "")


def attach_changes(params: list[Parameter], hist: HistoryView) -> None:
    """The change of each parameter since the previous calibration of this sensor (combined sigmas)."""
    if hist.current is None or hist.current == 0:
        return
    changes = drift(hist.records)
    for p in params:
        col = changes.get(p.name)
        if col is not None:
            p.change = col[hist.current]


# ---------------------------------------------------------------------------------------------- all of it

def gather(session_dir, *, calibration=None, history_db=None, session: Session | None = None,
           calibration_file=None) -> ReportContent:
    session, cal, cal_path = load(session_dir, calibration, session=session, calibration_file=calibration_file)
    problems: list[str] = []
    others = other_calibrations(session, cal_path, problems)
    params = parameters(cal)
    hist = history_view(session, cal, cal_path, history_db)
    attach_changes(params, hist)
    return ReportContent(session=session, calibration=cal, calibration_path=cal_path, verdict=verdict(session, cal),
                         parameters=params, residuals=residuals(session, cal), seed=seed_table(session, cal),
                         discover=discover_outputs(session, others, problems), history=hist, sensor_key=hist.key,
                         other_calibrations=others, uncertainty=uncertainty_view(cal))

