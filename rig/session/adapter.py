"""The one session -> calib adapter: per-step means of a loaded session for calib's solvers.

- :func:`step_means`: accelerometer, :class:`calib.accel.inputs.StepMeans` (static steps);
- :func:`rate_step_means`: gyroscope, :class:`calib.gyro.RateStepMeans` (rate steps);
- :func:`mag_step_means`: magnetometer, :class:`calib.mag.MagStepMeans` (static steps with readings).

Each carries the steps' times and capture durations and the recorded chip's bias stability from the
chip registry (:func:`bias_stability`, :func:`gyro_bias_stability`, :func:`mag_bias_stability`), so
the solvers weigh the steps with the wander between them (docs/methods.md, "Per-step standard errors").
"""

from __future__ import annotations

import dataclasses

from pathlib import Path
from typing import Protocol

import numpy as np

from calib.numerics.stability import BiasStability
from calib.accel.inputs import StepMeans
from calib.gyro import RateStepMeans
from calib.mag import MagStepMeans
from calib.numerics.uncertainty import step_standard_errors
from drivers.sensors.chips import CHIPS, ChipSpec
from rig.errors import SessionFormatError
from rig.planning.kinematics import sensor_to_world
from rig.session.manifest import MAG_COUNTS_PER_UT, SessionManifest, SiteInfo


class Session(Protocol):
    """What the adapter reads of a loaded session (:class:`rig.session.reader.Session`)."""

    path: Path
    info: SessionManifest
    samples: dict

    @property
    def has_temperature(self) -> bool: ...

    @property
    def lsb_per_g(self) -> float: ...

    def static_step_indices(self, include_flagged: bool = False, unknown_pose: bool = False) -> list[int]: ...

def recorded_chip(session) -> ChipSpec | None:
    """The registry's spec of the session's sensor (:data:`drivers.sensors.chips.CHIPS`), or None for a
    sensor the registry does not know (imports of other sensors)."""
    info = getattr(session, "info", None)
    return chip_of(getattr(getattr(getattr(info, "rig", None), "sensor", None), "model", None))


def chip_of(model) -> ChipSpec | None:
    """The registry's spec of sensor ``model``, or None for a model it does not know."""
    return CHIPS.get(model) if isinstance(model, str) else None


#: sensor -> (unit, the ChipSpec fields of its flicker floor, random walk and flicker corner)
STABILITY_FIELDS = {
    "accel": ("g", "accel_bias_instability_g", "accel_random_walk_g_per_rts", "accel_flicker_corner_s"),
    "gyro": ("deg/s", "gyro_bias_instability_dps", "gyro_random_walk_dps_per_rts", "gyro_flicker_corner_s"),
    "mag": ("uT", "mag_bias_instability_ut", "mag_random_walk_ut_per_rts", "mag_flicker_corner_s"),
}


def chip_stability(chip: ChipSpec | None, sensor: str) -> BiasStability | None:
    """The bias characterisation of ``chip``'s ``sensor`` (:data:`STABILITY_FIELDS`), or None (no chip, or
    one the registry gives no figures for that sensor; no flicker corner of its own: the accelerometer's)."""
    unit, floor, walk, corner = STABILITY_FIELDS[sensor]
    if chip is None or getattr(chip, floor) is None:
        return None
    return BiasStability(getattr(chip, floor), getattr(chip, walk) or 0.0,
                         getattr(chip, corner) or chip.accel_flicker_corner_s, unit)


def accel_stability(chip: ChipSpec | None) -> BiasStability | None:
    """The accelerometer bias characterisation of ``chip`` (None: None)."""
    return chip_stability(chip, "accel")


def bias_stability(session) -> BiasStability | None:
    """The recorded chip's accelerometer bias characterisation, or None for a sensor the registry does
    not know (imports of other sensors: their bias sigmas are the fit's alone)."""
    return unit_stability(session, "accel") or accel_stability(recorded_chip(session))


def unit_stability(session, sensor: str) -> BiasStability | None:
    """The unit's own figures for ``sensor`` when its noise profile was attached (``Session.unit_noise``), else None."""
    return (getattr(session, "unit_noise", None) or {}).get(sensor)


def gyro_bias_stability(session) -> BiasStability | None:
    """The recorded chip's gyroscope bias characterisation (deg/s), or None."""
    return unit_stability(session, "gyro") or chip_stability(recorded_chip(session), "gyro")


def mag_bias_stability(session) -> BiasStability | None:
    """The recorded chip's magnetometer offset characterisation (uT), or None."""
    return unit_stability(session, "mag") or chip_stability(recorded_chip(session), "mag")


def capture_window(t_s: np.ndarray) -> tuple[float, float]:
    """Mid-time and duration (s) of a step's capture from its samples' times ``t_s`` (n >= 2): n samples
    span n sample periods."""
    n = len(t_s)
    return 0.5 * (float(np.min(t_s)) + float(np.max(t_s))), float(np.ptp(t_s)) * n / (n - 1)


#: the standard error of a mean never goes below the quantisation of one count
_QUANTUM_SIGMA = 1.0 / np.sqrt(12.0)
#: nor a magnetometer reading's scatter below 0.01 uT (the session's resolution)
_MAG_SEM_FLOOR_UT = 0.01


def step_means(session: Session, include=None) -> StepMeans:
    """Per-step accelerometer means for the solver: the complete static steps with a known pose, or
    the steps ``include`` (indices)."""
    idx = session.static_step_indices() if include is None else list(include)
    if not idx:
        raise SessionFormatError(str(session.path), None, "steps", "no complete static step with a known pose to solve"
                                 " (steps with unknown poses: use --method magnitude)")
    rows = _StepRows(session.samples["step"], idx)
    for i, (lo, hi) in zip(idx, rows.spans):
        if hi - lo < 2:
            raise SessionFormatError(str(session.path / "samples.csv"), None, f"step {i + 1} (index {i} in samples.csv)",
                                     f"marked complete in session.yaml but has {hi - lo} samples")
    a = session.samples["accel_counts"][rows.rows].astype(float)
    blocks = [a[lo:hi] for lo, hi in rows.spans]
    t = session.samples["t_s"][rows.rows]
    windows = [capture_window(t[lo:hi]) for lo, hi in rows.spans]
    steps = [session.info.steps[i] for i in idx]
    sems, _ = step_standard_errors(blocks, _QUANTUM_SIGMA)  # correlated samples: pooled VIF per axis
    return StepMeans(names=tuple(st.label for st in steps),
                     f_nominal_g=np.array([st.f_nominal if st.f_nominal is not None else [np.nan] * 3 for st in steps],
                                          float),
                     mean_counts=np.array([b.mean(axis=0) for b in blocks]), sem_counts=sems,
                     n_samples=np.array([hi - lo for lo, hi in rows.spans], int),
                     temp_c=_step_temperatures(session, rows, idx) if session.has_temperature else None,
                     t_s=np.array([w[0] for w in windows]), lsb_per_g=session.lsb_per_g,
                     bias_stability=bias_stability(session),
                     temp_rate_c_per_s=step_temperature_rates(session, idx, rows.rows_of),
                     duration_s=np.array([w[1] for w in windows]),
                     angles_deg=_commanded_angles(steps))


def _commanded_angles(steps) -> np.ndarray | None:
    """(K, 3) the stage angles each step was commanded to, deg, or None where a step records none (hand-placed,
    imported)."""
    angles = [getattr(st, "angles_deg", None) for st in steps]
    return np.array(angles, float) if all(a is not None for a in angles) else None


def with_arrival(session: Session, steps: StepMeans, idx: list[int]) -> StepMeans:
    """``steps`` (the step means of the steps ``idx``) with their recorded arrival directions
    (:func:`arrival_directions`): what a budget's lost motion needs, read only when it does."""
    return dataclasses.replace(steps, arrival_direction=arrival_directions(session, idx))


#: a stage whose recorded position changed by less than this between two captures did not move, deg
_MOVED_DEG = 1e-6


def _resumes(session: Session) -> list[dict]:
    """The session's resume events; its events parsed only when their file mentions one."""
    try:
        text = (session.path / "events.jsonl").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    return [e for e in session.events if e.get("kind") == "resume"] if '"resume"' in text else []


def arrival_directions(session: Session, idx: list[int]) -> np.ndarray | None:
    """(K, 3) the direction (+1, -1) each stage a1, a2, a3 last turned in before the capture of each step ``idx``,
    0 where it has not moved since the session began or was resumed (where it stood before is not recorded), from
    the recorded stage positions (the samples' ``a1_deg``...: the controllers' counts, not mod 360, so a move's sign
    is its direction). None when the session records no positions (an import) or a position is missing."""
    pos = session.samples.get("angles_deg")
    if pos is None or len(pos) == 0 or not np.all(np.isfinite(pos)):
        return None
    step = session.samples["step"]
    starts = np.flatnonzero(np.r_[True, step[1:] != step[:-1]])  # the captures, in the order they were recorded
    ends = np.r_[starts[1:], len(step)] - 1
    restarts = {int(e["first_step"]) for e in _resumes(session) if "first_step" in e}
    direction, last, at = np.zeros(3), None, {}
    for lo, hi in zip(starts, ends):
        index = int(step[lo])
        if index in restarts:  # a resumed run: where the stages stood meanwhile is not recorded
            direction, last = np.zeros(3), None
        if last is not None:
            moved = np.abs(pos[lo] - last) > _MOVED_DEG
            direction[moved] = np.sign(pos[lo] - last)[moved]
        at.setdefault(index, direction.copy())
        moved = np.abs(pos[hi] - pos[lo]) > _MOVED_DEG  # a rate step turns while it captures
        direction[moved] = np.sign(pos[hi] - pos[lo])[moved]
        last = pos[hi]
    return np.array([at.get(i, np.zeros(3)) for i in idx])


class _StepRows:
    """The rows of the steps ``idx`` (indices, in that order) of a session, found by one stable sort of
    the step column: ``rows`` all of them, step after step (recording order within a step), ``spans``
    each step's (start, end) in ``rows``."""

    def __init__(self, step: np.ndarray, idx: list[int]) -> None:
        order = np.argsort(step, kind="stable")
        s_sorted = step[order]
        lo = np.searchsorted(s_sorted, idx, "left")
        hi = np.searchsorted(s_sorted, idx, "right")
        self.rows = np.concatenate([order[a:b] for a, b in zip(lo, hi)]) if len(idx) else np.zeros(0, np.int64)
        ends = np.cumsum(hi - lo)
        self.spans = list(zip((ends - (hi - lo)).tolist(), ends.tolist()))
        self._span_of = dict(zip(idx, self.spans))

    def rows_of(self, i: int) -> np.ndarray:
        """The row indices of step ``i`` (one of ``idx``)."""
        lo, hi = self._span_of[i]
        return self.rows[lo:hi]


def on_ramp(session: Session) -> bool:
    """Whether the session captured steps while the chamber ramped (``ramp`` on its planned steps)."""
    return any(getattr(st, "ramp", None) for st in session.info.steps)


def step_temperature_rates(session: Session, idx, rows_of) -> np.ndarray | None:
    """Each step's temperature rate (C/s): the least-squares slope of the sensor's thermometer against
    time over the step's samples; None unless the session has a thermometer and ramped the chamber (the
    solver fits a thermal-gradient term only then)."""
    if not session.has_temperature or not on_ramp(session):
        return None
    out = []
    for i in idx:
        rows = rows_of(i)
        t, y = session.samples["t_s"][rows], session.samples["temp_c"][rows]
        out.append(float(np.polyfit(t - t[0], y, 1)[0]) if np.ptp(t) > 0 else 0.0)
    return np.array(out)


def _step_temperatures(session: Session, rows: _StepRows, idx: list[int]) -> np.ndarray:
    """Each step's mean temperature (C); a step with rows without one is refused, naming the first."""
    tc = session.samples["temp_c"][rows.rows]
    bad = ~np.isfinite(tc)
    if bad.any():
        k = int(np.argmax(bad))
        i = next(i for i, (lo, hi) in zip(idx, rows.spans) if lo <= k < hi)
        raise SessionFormatError(str(session.path / "samples.csv"), int(rows.rows[k]) + 2,
                                 "temp_c", f"step {i + 1} (index {i} in samples.csv) has rows without a temperature")
    return np.array([float(np.mean(tc[lo:hi])) for lo, hi in rows.spans])


def rate_step_means(session: Session, accel=None) -> RateStepMeans:
    """Per-step gyroscope means of the complete rate steps, with the mean specific force of each step
    (for the g-sensitivity): from the accelerometer calibration ``accel`` when given, else the raw
    accelerometer divided by its nominal sensitivity."""
    lsb = session.info.rig.sensor.gyro_lsb_per_dps
    if "gyro_counts" not in session.samples or not lsb:
        raise SessionFormatError(str(session.path), None, "rig.sensor", "the session has no gyroscope data")
    steps = [s for s in session.info.steps if s.kind == "rate" and s.status == "complete"]
    if not steps:
        raise SessionFormatError(str(session.path), None, "steps", "no complete rate step")
    names, w, means, blocks, ns, fs, windows = [], [], [], [], [], [], []
    for st in steps:
        rows = session.samples["step"] == st.index
        g = session.samples["gyro_counts"][rows].astype(float)
        fs.append(_mean_specific_force(session, rows, accel))
        if len(g) < 2 or not np.all(np.isfinite(g)):
            raise SessionFormatError(str(session.path / "samples.csv"), None,
                                     f"step {st.index + 1} (index {st.index} in samples.csv)",
                                     "a rate step without usable gyroscope samples")
        if st.rate_nominal_dps is None:
            raise SessionFormatError(str(session.path / "session.yaml"), None, f"steps[{st.index}].rate_nominal_dps",
                                     "a rate step needs its nominal body rate [x, y, z]")
        names.append(st.name)
        w.append(st.rate_nominal_dps)
        means.append(g.mean(axis=0))
        blocks.append(without_gravity_signal(g, session.samples["accel_counts"][rows]))
        ns.append(len(g))
        windows.append(capture_window(session.samples["t_s"][rows]))
    sems, _ = step_standard_errors(blocks, _QUANTUM_SIGMA)
    t_mid, duration = np.array(windows, float).T
    return RateStepMeans(names=tuple(names), rate_nominal_dps=np.array(w, float), mean_counts=np.array(means),
                         sem_counts=sems, n_samples=np.array(ns), lsb_per_dps=float(lsb),
                         f_mean_g=np.array(fs, float), t_s=t_mid, duration_s=duration,
                         bias_stability=gyro_bias_stability(session))


def without_gravity_signal(gyro_counts: np.ndarray, accel_counts: np.ndarray) -> np.ndarray:
    """A rate step's gyroscope samples (n, 3) less their least-squares fit on the specific force the
    accelerometer saw (n, 3), counts.

    Spinning about a horizontal axis turns gravity through the sensor frame once a revolution, and the
    gyroscope's g-sensitivity ``G f`` follows it: a sinusoid of several counts within the step. It is
    not noise in the step mean (the solver models the mean with the step's mean specific force), but
    it would dominate the step's scatter and its autocorrelation (a variance inflation of 100 to 200 at
    25 deg/s and 100 Hz): the standard errors were ten times the noise's. Without usable accelerometer
    samples the gyroscope samples are returned as they are."""
    a = np.asarray(accel_counts, float)
    g = np.asarray(gyro_counts, float)
    if a.shape != g.shape or not np.all(np.isfinite(a)):
        return g
    design = np.column_stack([np.ones(len(a)), a - a.mean(axis=0)])
    coef, *_ = np.linalg.lstsq(design, g, rcond=None)
    return g - design @ coef


def _mean_specific_force(session: Session, rows: np.ndarray, accel) -> np.ndarray:
    """The mean specific force of the rows (g): calibrated by ``accel`` when given, else nominal."""
    a_mean = session.samples["accel_counts"][rows].mean(axis=0)
    if accel is None:
        return a_mean / session.lsb_per_g
    tc = session.samples["temp_c"][rows]
    t_mean = float(np.mean(tc)) if np.all(np.isfinite(tc)) and len(tc) else None
    return accel.apply(a_mean[None, :], temp_c=t_mean, t_s=float(np.mean(session.samples["t_s"][rows])))[0]


def site_field_world(site: SiteInfo | None) -> np.ndarray | None:
    """The local geomagnetic field in the world frame (uT), or None when the site is unknown."""
    if site is None:
        return None
    inc, dec = np.radians(site.inclination_deg), np.radians(site.declination_deg)
    hor = site.field_ut * np.cos(inc)
    return np.array([hor * np.cos(dec), hor * np.sin(dec), -site.field_ut * np.sin(inc)])


def mag_counts_per_ut(session: Session) -> float:
    """The stored magnetometer counts per uT of the session (its manifest's, else the recorder's default)."""
    mag_info = session.info.rig.sensor.magnetometer
    return float((mag_info.mag_lsb_per_ut if mag_info is not None else None) or MAG_COUNTS_PER_UT)


def mag_turning_samples(session: Session) -> tuple[np.ndarray, int] | None:
    """The magnetometer's samples (N, 3), uT, in recording order, of the complete steps in which the sensor turns
    (kind ``rotation``: a recording turned by hand without rests, ``rig import --continuous``), and how many such
    steps; None when there are none with at least 2 finite readings."""
    if "mag_counts" not in session.samples:
        return None
    lsb = mag_counts_per_ut(session)
    blocks = []
    for st in session.info.steps:
        if st.kind != "rotation" or st.status != "complete":
            continue
        m = session.samples["mag_counts"][session.samples["step"] == st.index]
        m = m[np.all(np.isfinite(m), axis=1)]
        if len(m) >= 2:
            blocks.append(m / lsb)
    if not blocks:
        return None
    return np.concatenate(blocks), len(blocks)


def mag_step_means(session: Session, known_field: bool = True) -> MagStepMeans | None:
    """Per-step magnetometer means of the complete static steps that have readings; with
    ``known_field`` the nominal field in the sensor frame from the site field and the step's stage
    angles (None when the session records no site field). None when there are no readings.

    Standard errors from each step's scatter with the variance inflation of correlated readings
    pooled over the steps (:func:`calib.numerics.uncertainty.step_standard_errors`), never below 0.01 uT; the
    times and durations are those of the readings (the first ``mag_samples`` of a step)."""
    if "mag_counts" not in session.samples:
        return None
    lsb = mag_counts_per_ut(session)
    h_world = site_field_world(session.info.rig.site) if known_field else None
    names, h, blocks, windows = [], [], [], []
    for st in session.info.steps:
        if not st.is_static or st.status != "complete":
            continue
        rows = session.samples["step"] == st.index
        m = session.samples["mag_counts"][rows]
        ok = np.all(np.isfinite(m), axis=1)
        if ok.sum() < 2:
            continue
        names.append(st.name)
        if h_world is not None and st.angles_deg is not None:
            r = sensor_to_world(np.asarray([st.angles_deg], float))[0]
            h.append(r.T @ h_world)
        blocks.append(m[ok] / lsb)
        windows.append(capture_window(session.samples["t_s"][rows][ok]))
    if not names:
        return None
    sems, _ = step_standard_errors(blocks, _MAG_SEM_FLOOR_UT)
    t_mid, duration = np.array(windows, float).T
    field = np.array(h, float) if len(h) == len(names) else None
    return MagStepMeans(names=tuple(names), field_nominal_ut=field, mean_ut=np.array([b.mean(axis=0) for b in blocks]),
                        sem_ut=sems, n_samples=np.array([len(b) for b in blocks]), t_s=t_mid, duration_s=duration,
                        bias_stability=mag_bias_stability(session))
