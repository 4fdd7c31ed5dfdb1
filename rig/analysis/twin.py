"""The digital twin of a measured sensor: ``rig discover SESSION --twin RIG.yaml`` (docs/twin.md).

The twin is a simulated-rig file (``rig-file/1``, ``kind: sim``) whose hidden accelerometer is the
model fitted to a session -- bias, scale factors, misalignment, the thermal polynomial and every
named effect -- converted into the simulator's error model (``sim: errors:``, g units), with the
session's own rig around it: the axes (signs, home offsets and, when the session's rig file is
still there unchanged, speeds, accelerations and limits), the sensor model and address, the
chamber (start temperature and time constant fitted to the session's temperature record) and
noise matched to the session's per-step scatter. ``rig run PROCEDURE --rig TWIN.yaml`` then
re-simulates the procedure (its text is written beside the twin) and ``rig compare`` tells where
the re-simulated session and the measured one disagree.

The twin is written as YAML text and validated by the ordinary rig-file loader; nothing here
imports the simulator: an effect's error-model field is the effect library's
(:attr:`calib.discovery.effects.Effect.sim_field`, the map the simulated rig reads too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from scipy.optimize import minimize_scalar

from calib.accel.result import AccelCalibration
from calib.discovery.effects import LIBRARY
from calib.discovery.search import Discovery, discover
from calib.numerics.uncertainty import pooled_vif
from drivers.sensors.regs.mpu9150 import DLPF_BW_HZ
from rig.analysis.discover import step_context
from rig.analysis.twin_sensors import other_sensors
from rig.analysis.uncertainty import session_rig_file
from rig.config.rigfile import AxisConfig, parse_rig_file, simulated_table
from rig.errors import RigInputError
from rig.planning.kinematics import STAGE_AXES
from rig.session import Session, load_session, step_means

#: bias polynomial effects -> power of (T - t0)
BIAS_POWERS = {"bias_tempco": 1, "bias_tempco_quadratic": 2, "bias_tempco_cubic": 3}
#: error-model fields of the bias polynomial about ``t_ref_c``, power 0..3 (the effects' own fields, the bias's)
POLY_FIELDS = ("bias_g", *(LIBRARY[name].sim_field for name in sorted(BIAS_POWERS, key=BIAS_POWERS.get)))
#: the axis keys a twin carries over from the session's rig file
AXIS_KEYS = ("sign", "home_offset_deg", "speed_deg_s", "accel_deg_s2", "soft_limits_deg", "cable_wrap_deg",
             "slip_ring")
#: the simulator's environment carried over from a simulated session's rig file (never its errors or effects)
SIM_KEYS = ("ringing", "field", "serial_base")
VIF_COLOURED = 1.5  # a pooled variance inflation above this: correlated noise (when the filter's is too small to tell)
QUANTUM_VAR = 1.0 / 12.0  # counts^2: rounding to counts, which the simulated chip adds itself
DEFAULT_TAU_S = 120.0


@dataclass
class Twin:
    """A twin rig file (``document``, its ``text``) and what it could not reproduce (``notes``)."""

    document: dict
    text: str
    procedure_text: str | None
    run_seed: int
    notes: list[str] = field(default_factory=list)
    chamber_rms_c: float | None = None


# -- the sensor: calibration -> error model ---------------------------------------------------------------
def _estimate(entry: dict, notes: list) -> np.ndarray:
    v = np.asarray([np.nan if x is None else x for x in entry["estimate"]], float)
    if not np.all(np.isfinite(v)):
        notes.append(f"{entry['name']}: a parameter the session could not determine is 0 in the twin")
    return np.nan_to_num(v)


def _add_power(poly: np.ndarray, coeff: np.ndarray, power: int, shift_c: float) -> None:
    """Add ``coeff (T - t0)^power`` to the polynomial ``poly`` (3, 4) about ``t_ref = t0 + shift_c``:
    ``(dT + shift)^power`` expanded by the binomial theorem."""
    for k in range(power + 1):
        poly[:, k] += coeff * math.comb(power, k) * shift_c ** (power - k)


def reference_temperature(cal: AccelCalibration) -> float:
    """The twin's ``t_ref_c``: the calibration's thermal reference, else an effect's, else 25 C."""
    if cal.temperature is not None:
        return float(cal.temperature.t0_c)
    return next((float(e["t0_c"]) for e in cal.effects if "t0_c" in e), 25.0)


def error_model(cal: AccelCalibration) -> tuple[dict, list, list]:
    """The simulator's accelerometer error model (``sim: errors:`` fields, g units) reproducing ``cal``,
    the table tilt [x, y] (deg) and notes on what was approximated."""
    lsb = float(cal.lsb_per_g)
    t_ref = reference_temperature(cal)
    poly = np.zeros((3, 4))
    poly[:, 0] = np.asarray(cal.bias_counts, float) / lsb
    if cal.temperature is not None:
        coeff = np.asarray(cal.temperature.coefficients, float) / lsb
        for s in range(cal.temperature.order):
            _add_power(poly, coeff[:, s], s + 1, t_ref - float(cal.temperature.t0_c))
    matrix = np.asarray(cal.matrix_counts_per_g, float) / lsb
    errors: dict = {"t_ref_c": t_ref}
    tilt, notes, row_scale = [0.0, 0.0], [], np.ones(3)
    for e in cal.effects:
        name, p = e["name"], _estimate(e, notes)
        if name in BIAS_POWERS:
            _add_power(poly, p, BIAS_POWERS[name], t_ref - float(e.get("t0_c", t_ref)))
        elif name == "scale_tempco":  # 1 + s (T - t0) = (1 + s d) (1 + s / (1 + s d) (T - t_ref)), d = t_ref - t0
            row_scale = 1.0 + p * (t_ref - float(e.get("t0_c", t_ref)))
            errors[LIBRARY[name].sim_field] = (p / row_scale).tolist()
        elif name == "full_misalignment":  # y += p_yx Mn_yy fx, z += Mn_zz (p_zx fx + p_zy fy)
            matrix[1, 0] += p[0] * matrix[1, 1]
            matrix[2, 0] += p[1] * matrix[2, 2]
            matrix[2, 1] += p[2] * matrix[2, 2]
        elif name == "table_tilt":
            tilt = [float(p[0]), float(p[1])]
        else:
            _effect_fields(errors, poly, name, p, e)
    errors["matrix"] = (matrix * row_scale[:, None]).tolist()
    for k, key in enumerate(POLY_FIELDS):
        errors[key] = poly[:, k].tolist()
    return errors, tilt, notes


def _effect_fields(errors: dict, poly: np.ndarray, name: str, p: np.ndarray, entry: dict) -> None:
    """The error-model fields of one effect (its library field, :attr:`calib.discovery.effects.Effect.sim_field`,
    and its reference: drift time, jump time, hysteresis band)."""
    errors[LIBRARY[name].sim_field] = p.reshape(3, 3).tolist() if name == "cross_axis_nonlinearity" else p.tolist()
    if name == "bias_drift":  # b + p (t - t_ref_s) = (b - p t_ref_s) + p t
        poly[:, 0] -= p * float(entry.get("t_ref_s", 0.0))
    elif name == "bias_jump":
        errors["bias_jump_t_s"] = float(entry["t_jump_s"])
    elif name == "thermal_hysteresis":
        errors["hysteresis_band_c"] = float(entry.get("band_c", 0.5))


# -- the noise ------------------------------------------------------------------------------------------------
def noise_bandwidth_hz(model: str, rate_hz: float) -> float:
    """The accelerometer's noise bandwidth as the runtime drivers configure the chip: the MPU-9150's
    DLPF 3 (44 Hz) up to 200 Hz, else DLPF 1 (184 Hz) (``drivers/sensors/mpu9150.py``); the ADXL345's
    rate / 2. Never above the Nyquist frequency."""
    bw = rate_hz / 2 if model == "ADXL345" else DLPF_BW_HZ[3 if rate_hz <= 200 else 1]
    return float(min(bw, rate_hz / 2))


def coloured_threshold(bandwidth_hz: float, rate_hz: float) -> float:
    """The pooled variance inflation above which a session's noise is taken as the chip's low-pass filtered
    noise: halfway between white (1) and the first-order filter's ``(1 + r) / (1 - r)``,
    ``r = exp(-2 pi B / rate)`` (1.13 for the MPU-9150 at 100 Hz); 1.5 when the two are too close to tell."""
    r = math.exp(-2 * math.pi * bandwidth_hz / rate_hz)
    expected = (1 + r) / (1 - r)
    return 0.5 * (1 + expected) if expected > 1.05 else VIF_COLOURED


def noise_settings(session: Session, idx: list) -> tuple[str, list, list]:
    """``sim: noise`` and ``noise_density_g_per_rthz`` (3,) matching the session's per-step scatter,
    and notes. The dlpf model when the samples are correlated like the chip's filter makes them
    (:func:`coloured_threshold`), else white."""
    rows = session.samples["step"]
    blocks = [session.samples["accel_counts"][rows == i].astype(float) for i in idx]
    blocks = [b for b in blocks if len(b) >= 2]
    s2 = np.array([b.var(axis=0, ddof=1) for b in blocks])  # (K, 3) counts^2
    sigma_g = np.sqrt(np.maximum(s2.mean(axis=0) - QUANTUM_VAR, 1e-12)) / session.lsb_per_g
    vif = pooled_vif(blocks)
    sensor = session.info.rig.sensor
    bw = noise_bandwidth_hz(str(sensor.model), float(sensor.sample_rate_hz))
    model = "dlpf" if float(np.mean(vif)) > coloured_threshold(bw, float(sensor.sample_rate_hz)) else "white"
    density = sigma_g / math.sqrt(math.pi / 2 * bw)  # white: sigma = density sqrt(pi/2 B); dlpf: its filter's
    notes = []
    spread = np.sqrt(s2.max(axis=0) / np.maximum(s2.min(axis=0), 1e-12))
    if len(blocks) > 2 and float(np.max(spread)) > 1.3:
        notes.append(f"the session's noise varies between steps (largest/smallest scatter {np.max(spread):.2f}); "
                     "the twin's is the same in every step")
    if model == "dlpf":
        notes.append(f"correlated noise (variance inflation {', '.join(f'{v:.2f}' for v in vif)}): the twin uses "
                     "the dlpf model, whose bias instability and random walk are the chip's datasheet class, "
                     "not fitted")
    return model, density.tolist(), notes


# -- the chamber ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ChamberCommand:
    """One command a session gave its chamber (an ``events.jsonl`` ``chamber`` event).

    A set-point: hold ``to_c`` from ``t_s`` on (``rate_c_per_s`` 0). A ramp: move the set-point from
    ``from_c`` (None: where it is at ``t_s``) to ``to_c`` at ``rate_c_per_s`` (magnitude, C/s) over
    ``duration_s`` (as the chamber reported it), then hold ``to_c``.
    """

    t_s: float
    to_c: float
    rate_c_per_s: float = 0.0
    from_c: float | None = None
    duration_s: float = 0.0


def setpoint_segments(commands: list, initial_c: float) -> list[tuple[float, float, float]]:
    """The chamber's set-point as time-ordered linear segments ``(t_start_s, setpoint_c, rate_c_per_s)``,
    from ``initial_c`` held since forever; a command replaces what the previous one had planned
    (rig/simulation/world.py ``SimChamber``)."""
    segs = [(-math.inf, float(initial_c), 0.0)]
    for cmd in sorted(commands, key=lambda c: c.t_s):
        segs = [sg for sg in segs if sg[0] <= cmd.t_s]
        if not cmd.rate_c_per_s:
            segs.append((cmd.t_s, cmd.to_c, 0.0))
            continue
        t0, c0, r0 = segs[-1]
        start_c = cmd.from_c if cmd.from_c is not None else c0 + r0 * (cmd.t_s - t0 if r0 else 0.0)
        rate = abs(cmd.rate_c_per_s) * (1.0 if cmd.to_c >= start_c else -1.0)
        segs += [(cmd.t_s, start_c, rate), (cmd.t_s + cmd.duration_s, cmd.to_c, 0.0)]
    return segs


def chamber_temps(t_s: np.ndarray, commands: list, initial_c: float, tau_s: float) -> np.ndarray:
    """The simulated chamber's sensor temperature at ``t_s`` (C): a first-order lag ``tau_s`` behind the
    set-point of :func:`setpoint_segments`, in closed form per segment (with set-point ``S0 + r dt``,
    ``T = S0 + r dt - r tau + (T0 - S0 + r tau) exp(-dt / tau)``), starting at ``initial_c``.

    ``commands``: :class:`ChamberCommand` entries (:func:`chamber_commands`)."""
    segs = setpoint_segments(commands, initial_c)
    t = np.asarray(t_s, float)
    out = np.full(len(t), float(initial_c))
    c_now = float(initial_c)
    for i, (t0, s0, r) in enumerate(segs):
        if i == 0:
            continue
        if i > 1:  # the temperature at this segment's start, from the previous segment
            tp, sp, rp = segs[i - 1]
            dt = t0 - tp
            c_now = sp + rp * dt - rp * tau_s + (c_now - sp + rp * tau_s) * math.exp(-dt / tau_s)
        t_end = segs[i + 1][0] if i + 1 < len(segs) else np.inf
        sel = (t >= t0) & (t < t_end)
        dt = t[sel] - t0
        out[sel] = s0 + r * dt - r * tau_s + (c_now - s0 + r * tau_s) * np.exp(-dt / tau_s)
    return out


def chamber_commands(events: list) -> list[ChamberCommand]:
    """The chamber commands among a session's events (set-points and ramps), time-ordered."""
    out = []
    for e in events:
        t = e.get("t_s")
        if e.get("kind") != "chamber" or not isinstance(t, (int, float)):
            continue
        if isinstance(e.get("setpoint_c"), (int, float)):
            out.append(ChamberCommand(float(t), float(e["setpoint_c"])))
        elif all(isinstance(e.get(k), (int, float)) for k in ("ramp_to_c", "rate_c_per_min", "duration_s")):
            from_c = e.get("from_c")
            out.append(ChamberCommand(float(t), float(e["ramp_to_c"]), abs(float(e["rate_c_per_min"])) / 60.0,
                                      float(from_c) if isinstance(from_c, (int, float)) else None,
                                      float(e["duration_s"])))
    return sorted(out, key=lambda c: c.t_s)


def _temperature_record(session: Session, idx: list) -> tuple[list, np.ndarray, np.ndarray]:
    """The chamber commands and the observed (t_s, temp_c): each static step's mean and each temperature
    step's first reading (1 s after its setpoint)."""
    events = session.events
    t_obs, c_obs = [], []
    for e in events:
        t = e.get("t_s")
        if (e.get("kind") == "temperature" and isinstance(t, (int, float))
                and isinstance(e.get("start_c"), (int, float))):
            t_obs.append(float(t) - float(e.get("waited_s", 0.0)) + 1.0)
            c_obs.append(float(e["start_c"]))
    for i in idx:
        s = session.step_samples(i)
        ok = np.isfinite(s["temp_c"])
        if ok.any():
            t_obs.append(float(np.mean(s["t_s"][ok])))
            c_obs.append(float(np.mean(s["temp_c"][ok])))
    return chamber_commands(events), np.asarray(t_obs), np.asarray(c_obs)


def fit_chamber(session: Session, idx: list) -> tuple[float, float, float | None, list]:
    """(initial_c, tau_s) of the simulated chamber fitted to the session's temperature record (set-points
    and ramps), the RMS misfit (C, None without a thermometer) and notes. ``initial_c`` enters affinely
    (solved for each tau about the first reading); tau by a bounded scalar search over log tau."""
    if not session.has_temperature:
        return 25.0, DEFAULT_TAU_S, None, ["the session has no thermometer: the twin's chamber is held at 25 C"]
    commands, t, c = _temperature_record(session, idx)
    if len(c) == 0:
        return 25.0, DEFAULT_TAU_S, None, ["no temperature readings: the twin's chamber is held at 25 C"]
    if not commands:
        notes = [] if np.ptp(c) < 0.5 else [f"the temperature changed by {np.ptp(c):.1f} C without chamber "
                                            "setpoints: the twin holds it constant"]
        return float(np.mean(c)), DEFAULT_TAU_S, float(np.std(c)), notes
    c_first = float(c[np.argmin(t)])

    def solve(log_tau: float) -> tuple[float, float]:
        tau = math.exp(log_tau)
        base = chamber_temps(t, commands, c_first, tau)
        gain = chamber_temps(t, commands, c_first + 1.0, tau) - base
        t0 = c_first + (float(np.dot(gain, c - base) / np.dot(gain, gain)) if np.dot(gain, gain) > 1e-12 else 0.0)
        return t0, float(np.sqrt(np.mean((chamber_temps(t, commands, t0, tau) - c) ** 2)))

    best = minimize_scalar(lambda x: solve(x)[1], bounds=(math.log(1.0), math.log(1e5)), method="bounded",
                           options={"xatol": 1e-4})
    initial, rms = solve(float(best.x))
    tau = float(math.exp(best.x))
    notes = [] if rms < 0.1 else [f"the chamber model fits the session's temperatures to {rms:.2f} C rms only"]
    return float(np.clip(initial, -100, 200)), float(np.clip(tau, 1.0, 1e6)), rms, notes


# -- the rig around the sensor ---------------------------------------------------------------------------
def rig_settings(session: Session) -> tuple[dict, str, dict, list]:
    """The twin's axes (name -> mapping), home policy, carried ``sim:`` environment and notes."""
    original = session_rig_file(session)
    axes, notes = {}, []
    recorded = session.info.rig.turntable.axes if session.info.rig.turntable is not None else None
    for name in STAGE_AXES:
        ax = original.axes[name] if original is not None else AxisConfig(slip_ring=True)
        doc = {k: getattr(ax, k) for k in AXIS_KEYS}
        doc["soft_limits_deg"] = list(doc["soft_limits_deg"])
        info = (recorded or {}).get(name)
        if info is not None and info.sign is not None:
            doc["sign"] = int(info.sign)
        if info is not None and info.home_offset_deg is not None:
            doc["home_offset_deg"] = float(info.home_offset_deg)
        axes[name] = doc
    if original is None:
        notes.append(f"the session's rig file ({session.info.rig.rig_file or 'not recorded'}) is not available "
                     "unchanged: the twin's speeds, accelerations and limits are the defaults (slip rings on), "
                     "so its timeline may differ")
    env = {k: v for k, v in ((original.sim or {}) if original is not None else {}).items() if k in SIM_KEYS}
    env["geometry"], table_note = twin_table(original)
    notes.append(table_note)
    return axes, (original.home_policy if original is not None else "zero"), env, notes


def twin_table(original) -> tuple[dict, str]:
    """The twin's ``sim.geometry``: the session's own simulated table (its rig file's section: the same hidden
    table, its classes and ``table_seed``), so that the twin's steps carry the same pose errors as the session's;
    a perfect table when the session's table is not a simulated one known unchanged (a hardware rig, an import, a
    changed rig file): its errors are not known, so they are not reproduced. With its note."""
    if original is None or not original.is_simulated:
        return {"enabled": False}, ("the twin's turntable lands where commanded: the session's table errors are not "
                                    "known (not a simulated rig file available unchanged), so a comparison sees them")
    section = simulated_table(original.sim)
    if section is None:
        return {"enabled": False}, "the twin's turntable is the session's: it lands where commanded (sim.geometry off)"
    return ({**section, "enabled": True},
            "the twin's turntable is the session's simulated table (its sim.geometry: the same hidden errors)")


# -- the twin ------------------------------------------------------------------------------------------------
def build_twin(session: Session, cal: AccelCalibration, *, label: str = "discover") -> Twin:
    """The twin rig file of ``session`` whose hidden sensor is ``cal`` (``label``: where ``cal`` came from)."""
    idx = session.static_step_indices(unknown_pose=True)
    errors, tilt, notes = error_model(cal)
    model, density, noise_notes = noise_settings(session, idx)
    errors["noise_density_g_per_rthz"] = density
    initial_c, tau_s, chamber_rms, chamber_notes = fit_chamber(session, idx)
    axes, home, env, rig_notes = rig_settings(session)
    sensor = session.info.rig.sensor
    gyro, mag, sensor_notes = other_sensors(session)
    sim = {"time_scale": 0, "chamber": {"initial_c": round(initial_c, 4), "tau_s": round(tau_s, 3)}, **env,
           "table_tilt_deg": tilt, "noise": model, "errors": errors}
    sim.update({k: v for k, v in (("gyro_errors", gyro), ("mag_errors", mag)) if v})
    unit = getattr(session, "unit_noise", None) or {}  # the unit's own wander, when its noise profile was attached
    accel = unit.get("accel")
    if accel is not None and getattr(accel, "axes", None):
        sim["noise_figures"] = {"accel_bias_instability_g": [float(a.bias_instability) for a in accel.axes],
                                "accel_random_walk_g_per_rts": [float(a.random_walk_per_rts) for a in accel.axes]}
        noise_notes = noise_notes + ["the accelerometer's bias wander is the unit's own (its noise profile), not "
                                     "the chip family's"]
    doc = {"format": "rig-file/1", "name": f"twin-{session.id}"[:200],
           "description": f"digital twin of session {session.id}: the sensor's {label} model "
                          f"({', '.join(e['name'] for e in cal.effects) or 'no effects beyond the seed model'}"
                          f"{', thermal order %d' % cal.temperature.order if cal.temperature else ''})",
           "kind": "sim", "home": home, "turntable": {"axes": axes},
           "sensor": {"model": str(sensor.model)} | ({"address": int(sensor.address)} if sensor.address else {}),
           "sim": sim}
    notes = notes + noise_notes + chamber_notes + rig_notes + sensor_notes
    header = [f"# Digital twin of session {session.id} (rig discover --twin; docs/twin.md).",
              f"# Re-simulate: rig run PROCEDURE --rig THIS_FILE --seed {_run_seed(session)} (a seed other than "
              "the session's: independent noise)", *(f"# note: {n}" for n in notes)]
    text = "\n".join(header) + "\n" + yaml.safe_dump(_plain(doc), sort_keys=False, width=120)
    return Twin(document=doc, text=text, procedure_text=session.info.procedure.text, run_seed=_run_seed(session),
                notes=notes, chamber_rms_c=chamber_rms)


def _run_seed(session: Session) -> int:
    """A seed for re-simulating: not the session's (a simulated session re-run with its own seed would
    repeat its noise draws)."""
    return (int(session.info.seed) + 1) % (2**31) if session.info.seed is not None else 1


def _plain(v):
    """Plain Python numbers and lists for YAML."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


def write_twin(twin: Twin, path) -> dict:
    """Write the twin rig file (validated by the rig-file loader first) and, beside it, the session's
    procedure (``NAME.procedure.yaml``). ``path`` a file, or a directory (``twin-SESSION.yaml`` inside).
    Returns what was written: ``twin``, ``twin_procedure`` (when the session carries its text),
    ``twin_run`` (the command that re-simulates the session) and ``twin_notes``."""
    p = Path(path)
    if p.is_dir():
        p = p / f"{twin.document['name']}.yaml"
    parse_rig_file(twin.text, str(p))  # the ordinary loader's checks, before anything is written
    p.write_text(twin.text)
    out = {"twin": str(p.resolve())}
    run_proc = "PROCEDURE"
    if twin.procedure_text:
        proc = p.with_name(p.name[:-len(p.suffix)] + ".procedure.yaml" if p.suffix else p.name + ".procedure.yaml")
        proc.write_text(twin.procedure_text)
        out["twin_procedure"] = run_proc = str(proc.resolve())
    out["twin_run"] = f"rig run {run_proc} --rig {out['twin']} --seed {twin.run_seed}"
    out["twin_notes"] = "; ".join(twin.notes)
    return out


def write_for_discovery(session: Session, d: Discovery, path) -> dict:
    """``rig discover --twin``: the twin of the discovery's model (the seed model plus the named effects)."""
    if d.calibration is None:
        raise RigInputError(str(session.path), None, None,
                            "cannot build a twin: the session's poses are unknown, so discover has no calibration "
                            "(the twin needs the sensor's model a = M f + b + effects)")
    return write_twin(build_twin(session, d.calibration), path)


def twin_of_session(session_dir, path, *, candidates=None, false_alarm: float = 0.01) -> tuple[Discovery, dict]:
    """Discover (``candidates``: the effects it may name; default the whole library) and write the twin of
    the resulting model: with ``candidates=[]`` the twin of the seed's model alone, with
    ``["bias_tempco"]`` the seed's model with its thermal bias."""
    session = load_session(session_dir)
    idx = session.static_step_indices() or session.static_step_indices(unknown_pose=True)
    d = discover(step_means(session, idx), step_context(session, idx), false_alarm=false_alarm, candidates=candidates)
    return d, write_for_discovery(session, d, path)
