"""Session -> calibration, in memory: the solve step of the pipeline tail (:func:`rig.workflow.conclude.conclude`,
which writes the file)."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np

import calib
from calib.accel.placement import check_placement
from calib.accel.rig_propagation import needs_arrival
from calib.errors import CalibError, ObservabilityError
from calib.gyro import solve_gyro
from calib.gyro.static_bias import StaticGyroBias, static_gyro_bias
from calib.mag import solve_mag_ellipsoid, solve_mag_positions
from calib.mag.continuous import solve_mag_ellipsoid_samples
from calib.numerics.budget import RigErrors
from rig import __version__
from rig.analysis.coverage import session_coverage
from rig.analysis.target import calibration_record
from rig.analysis.uncertainty import session_rig_errors, with_budget, with_gyro_budget, with_mag_budget
from rig.session import Session, load_session, mag_step_means, rate_step_means, step_means
from rig.session.adapter import mag_turning_samples, with_arrival

SOFTWARE = {"name": "rig-calibration", "version": __version__}


def calibrate_session(session_dir, *, model: str | None = None, method: str | None = None, thermal=None,
                      session=None) -> calib.CalibrationFile:
    """The calibration of a recorded session, in memory (:func:`rig.workflow.conclude.conclude` judges and writes it):
    the session loaded (or ``session``, loaded already), the procedure's ``solve:`` settings unless
    overridden, the accelerometer solved, the gyroscope and magnetometer sections when recorded. A pose
    method's accelerometer (pinv, combinations) carries its uncertainty budget (``accelerometer.uncertainty``,
    :mod:`rig.analysis.uncertainty`: the session's rig file when it is there unchanged, else the turntable's
    datasheet classes, the budget saying which); the magnitude method's has none (no poses to be wrong)."""
    session = session or load_session(session_dir)
    if accelerometer_absent(session):
        raise AbsentSensor(f"{session.path}: {ABSENT_ACCEL}: nothing calibrates an accelerometer (rig solve "
                           "solves the sensors it has)")
    spec = session.solve_spec or {}
    accel, steps, model, method = solve_accelerometer(session, model=model, method=method, thermal=thermal)
    rig = session_rig_errors(session)  # read once: the budgets of every sensor on this table
    gyro, mag = solve_gyro_and_mag(session, spec, accel, rig)
    if gyro is not None:  # the rate steps turn about the table's axes (docs/uncertainty.md, "The gyroscope")
        gyro = with_gyro_budget(gyro, rig)
    if method in POSE_METHODS:  # the uncertainty budget (docs/uncertainty.md); sigma as the solve gave it
        budget_steps = with_arrival(session, steps, session.static_step_indices()) if needs_arrival(rig) else steps
        accel = with_budget(accel, budget_steps, model, method, rig)
    return calib.CalibrationFile(
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        software=dict(SOFTWARE),
        session=session.id,
        sensor=sensor_section(session),
        accelerometer=accel,
        gyroscope=gyro,
        magnetometer=mag,
        coverage=session_coverage(session),
        target=calibration_record(session, steps, model, method),
    )


#: the last accelerometer solve: (session, options, result); ``rig solve`` checks the placement and then
#: concludes with the same options, and the second asks for the same solve (a 10,000-step session: seconds)
_LAST: list = [None, None, None]


def solve_accelerometer(session: Session, *, model: str | None = None, method: str | None = None, thermal=None):
    """The accelerometer of a loaded session with the procedure's ``solve:`` settings unless overridden:
    (calibration, the step means it used, model, method). The same session object with the same options
    gets the result of the last call again (a session is not changed once loaded)."""
    key = (model, method, repr(thermal))
    if _LAST[0] is session and _LAST[1] == key:
        return _LAST[2]
    result = _solve_accelerometer(session, model=model, method=method, thermal=thermal)
    _LAST[:] = [session, key, result]
    return result


def _solve_accelerometer(session: Session, *, model: str | None, method: str | None, thermal):
    spec = session.solve_spec or {}
    model = model or spec.get("model") or "triangular"
    method = method or spec.get("method") or "pinv"
    option = "--thermal" if thermal is not None else "the procedure's solve: thermal:"
    thermal = thermal if thermal is not None else spec.get("thermal", "auto")
    if method == "magnitude":
        steps = step_means(session, session.static_step_indices(unknown_pose=True))
    else:
        steps = step_means(session)
    if method in ("pinv", "combinations"):
        check_temperature_levels(steps, thermal, f"{session.path}: {option} {thermal}")
    accel = calib.solve(steps, model=model, method=method, thermal=thermal)
    check_plausible(accel, steps.lsb_per_g, where=session.path)
    return accel, steps, model, method


#: the methods that trust the nominal poses and have residuals to judge them by
POSE_METHODS = ("pinv", "combinations")


def placement(session: Session, *, model: str | None = None, method: str | None = None, thermal=None):
    """The recorded directions against the nominal poses (:class:`calib.accel.placement.Placement`) under the
    method the options resolve to, for a session whose poses were placed without a turntable (imports, faces
    placed by hand); None for a pose-free method, a turntable's poses or a session without an accelerometer."""
    if accelerometer_absent(session) or session.info.rig.turntable is not None:
        return None  # no accelerometer; or the poses are a turntable's (a misfit there is an effect: rig discover)
    resolved = method or (session.solve_spec or {}).get("method") or "pinv"
    if resolved not in POSE_METHODS:
        return None
    accel, steps, _, _ = solve_accelerometer(session, model=model, method=method, thermal=thermal)
    return check_placement(accel, steps)


def refuse_misplaced_poses(session: Session, **options) -> None:
    """Raise :class:`PosesMisplaced` (one line: the misplacement per step, the command to run) when the poses
    are not where the session says beyond the noise (a pose-trusting method would give false sigmas)."""
    found = placement(session, **options)
    if found is not None and found.misplaced:
        n_static = len(session.static_step_indices(unknown_pose=True))
        raise PosesMisplaced(found.message(str(session.path), n_static))


class PosesMisplaced(CalibError):
    """The nominal poses disagree with the recorded directions beyond the noise."""


#: a thermal model of order S needs steps at S + 1 or more temperatures at least this far apart (C)
THERMAL_MIN_STEP_C = 1.0


def temperature_levels(temp_c, min_step_c: float = THERMAL_MIN_STEP_C) -> int:
    """How many of the steps' temperatures lie at least ``min_step_c`` above the previous level (sorted)."""
    levels, last = 0, -np.inf
    for t in np.sort(np.asarray(temp_c, float)):
        if t - last >= min_step_c:
            levels, last = levels + 1, t
    return levels


def check_temperature_levels(steps, thermal, what: str) -> None:
    """Refuse an explicit thermal order the session's temperatures cannot determine: a tempco fitted across
    a span of a few millikelvin is noise divided by nearly zero (a huge sigma, or a wrong number)."""
    if isinstance(thermal, bool) or not isinstance(thermal, (int, np.integer)) or thermal < 1 or steps.temp_c is None:
        return  # auto, off (auto turns itself off below its span), or no thermometer (calib says so)
    temps = np.asarray(steps.temp_c, float)
    if temperature_levels(temps) < thermal + 1:
        raise ObservabilityError(
            f"{what}: the session's temperature span is {np.ptp(temps):.1f} C ({temps.min():.2f} to "
            f"{temps.max():.2f} C over {len(temps)} steps): a thermal model of order {thermal} needs steps at "
            f"{thermal + 1} or more different temperatures at least {THERMAL_MIN_STEP_C:g} C apart (a temperature "
            "procedure such as procedures/thermal.yaml); use --thermal off or auto")


#: a fitted scale further than this factor from the sensor's nominal counts/g is not this sensor's data
SCALE_FACTOR_LIMIT = 1.5


def check_plausible(accel, lsb_per_g: float, where=None) -> None:
    """Refuse a calibration whose scale factors are far from the declared sensor's nominal sensitivity:
    the data are not this accelerometer's (a gyroscope file imported as accelerometer data, another
    range), and the numbers would be wrong however well they fit."""
    ratio = np.asarray(accel.scale_counts_per_g, float) / float(lsb_per_g)
    bad = ~((ratio > 1 / SCALE_FACTOR_LIMIT) & (ratio < SCALE_FACTOR_LIMIT))
    if bad.any():
        j = int(np.argmax(bad))
        prefix = f"{where}: " if where is not None else ""  # the session the numbers came from
        raise CalibError(f"{prefix}the fitted {'xyz'[j]} scale of {accel.scale_counts_per_g[j]:.4g} counts/g is "
                         f"{ratio[j]:.3g} times the sensor's nominal {lsb_per_g:g} counts/g: these are not this "
                         "accelerometer's data at this range (wrong file, wrong column, or another sensor)")


def sensor_section(session: Session) -> dict:
    """The calibration file's ``sensor`` section: which sensor the session recorded."""
    sensor = session.info.rig.sensor
    return {"model": sensor.model, "address": sensor.address, "serial": sensor.serial}


def solve_gyro_and_mag(session: Session, spec: dict, accel=None, rig: RigErrors | None = None
                       ) -> tuple[dict | None, dict | None]:
    """The gyroscope (rate steps) and magnetometer sections, when the session has their data (``rig``: the
    session's :func:`~rig.analysis.uncertainty.session_rig_errors`, read here when not given)."""
    return solve_gyro_section(session, accel), solve_mag_section(session, spec, rig)


def solve_gyro_section(session: Session, accel=None) -> dict | None:
    """The gyroscope section from the rate steps (None without rate steps)."""
    if any(s.kind == "rate" for s in session.info.steps):
        return solve_gyro(rate_step_means(session, accel)).to_dict()
    return None


#: fewer rests than this, with turning steps beside them: the magnetometer is fitted on the turning samples (the
#: ellipsoid fit on rests needs 10, calib.numerics.magnitude)
MIN_MAG_RESTS = 10


def solve_mag_section(session: Session, spec: dict, rig: RigErrors | None = None) -> dict | None:
    """The magnetometer section (None without magnetometer readings); a positions solve with its budget on the
    session's table (``rig``, read here when not given)."""
    mag_steps = mag_step_means(session)
    turning = mag_turning_samples(session)
    site = session.info.rig.site
    field_ut = float(site.field_ut if site is not None else 1.0)
    if turning is not None and (mag_steps is None or len(mag_steps) < MIN_MAG_RESTS) \
            and spec.get("magnetometer") in (None, "ellipsoid"):
        # a magnetometer turned without (enough) rests: the ellipsoid on its samples, never on block means
        return solve_mag_ellipsoid_samples(turning[0], field_ut, n_steps=turning[1]).to_dict()
    if mag_steps is None:
        return None
    method = spec.get("magnetometer") or ("positions" if mag_steps.field_nominal_ut is not None else "ellipsoid")
    if method == "positions":
        if mag_steps.field_nominal_ut is None:
            raise ObservabilityError("the magnetometer position method needs the local field: add a site: "
                                     "section to the rig file, or use solve: {magnetometer: ellipsoid}")
        # the poses' own errors (docs/uncertainty.md, "The magnetometer")
        return with_mag_budget(solve_mag_positions(mag_steps), mag_steps, rig or session_rig_errors(session))
    return solve_mag_ellipsoid(mag_steps, field_ut).to_dict()


# -- the sensors a session has ---------------------------------------------------------------------

#: how an absent accelerometer is named (one line, never a singular Jacobian)
ABSENT_ACCEL = "the session has no accelerometer data (ax, ay, az are 0 counts: recorded or imported without them)"


class AbsentSensor(CalibError):
    """A sensor the session did not record was asked for."""


def accelerometer_absent(session: Session) -> bool:
    """Whether the session holds no accelerometer data: an import without its columns (``import.units``
    ``accelerometer none``, docs/import.md), or every count exactly 0 (no accelerometer reads that)."""
    imp = session.info.import_
    if imp is not None and (imp.units or "").startswith("accelerometer none"):
        return True
    counts = session.samples["accel_counts"]
    return len(counts) > 0 and not np.any(counts)


def static_gyro(session: Session) -> StaticGyroBias | None:
    """The gyroscope's zero-rate output from the complete static steps (None without gyroscope data or rests)."""
    lsb = session.info.rig.sensor.gyro_lsb_per_dps
    if "gyro_counts" not in session.samples or not lsb:
        return None
    blocks = []
    for st in session.info.steps:
        if st.is_static and st.status == "complete":
            g = session.samples["gyro_counts"][session.samples["step"] == st.index]
            if len(g) >= 2 and np.all(np.isfinite(g)):
                blocks.append(g)
    return static_gyro_bias(blocks, float(lsb)) if blocks else None


def magnetometer_units(session: Session) -> str:
    """``counts`` for a magnetometer imported in unknown units (its figures are counts), else ``uT``."""
    mag = session.info.rig.sensor.magnetometer
    return "counts" if mag is not None and "unknown" in (mag.model or "") else "uT"


@dataclass
class SensorResults:
    """What a session without an accelerometer gives: each sensor it has, solved, and the ones it lacks."""

    absent: list[str]
    gyroscope: dict | None = None
    gyro_static: StaticGyroBias | None = None
    magnetometer: dict | None = None
    problems: list[str] = field(default_factory=list)


def solve_present_sensors(session: Session) -> SensorResults:
    """Solve the gyroscope and magnetometer of a session without an accelerometer (each alone; a sensor
    that cannot be solved says why in ``problems``). Raises :class:`AbsentSensor` when it has none of them."""
    has_gyro = "gyro_counts" in session.samples and bool(session.info.rig.sensor.gyro_lsb_per_dps)
    has_mag = "mag_counts" in session.samples
    absent = ["accelerometer"] + ([] if has_gyro else ["gyroscope"]) + ([] if has_mag else ["magnetometer"])
    if not (has_gyro or has_mag):
        raise AbsentSensor(f"{session.path}: the session has no sensor data (no accelerometer, gyroscope or "
                           "magnetometer columns): nothing to solve")
    out = SensorResults(absent)
    if has_gyro:
        out.gyro_static = static_gyro(session)
    spec = session.solve_spec or {}
    for name, solve in (("gyroscope", lambda: solve_gyro_section(session)),
                        ("magnetometer", lambda: solve_mag_section(session, spec))):
        try:
            setattr(out, name, solve())
        except CalibError as exc:
            out.problems.append(f"{name}: {exc}")
    return out
