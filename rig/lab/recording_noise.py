"""Without a noise profile, the recording speaks first (issue 28 item 5; docs/noise.md, "Without a profile"): a
session's bias wander estimated from its own static steps, the chip family's figures as the prior
(:mod:`calib.noise.steps`), and attached the way a unit's profile is (``Session.unit_noise``, read by the
adapter's stability lookups), for the accelerometer and, in a session with rate steps, the gyroscope whose rate
solve weighs its steps with the same wander.

The rules, each tested (tests/rig/lab/test_recording_noise.py):

- a unit's profile comes first: the pipeline asks this module only when there is none;
- the family's figures stay (nothing attached, no ``noise:`` in the calibration file, as without this module) for a
  sensor the chip registry states no figures for, for a session recorded on a temperature ramp (the bias follows
  the temperature within each step: drift, not noise), when the steps are too short to show the wander
  (:func:`calib.noise.steps.steps_show_wander` on no axis: an MPU-9150 at 100 Hz needs steps of 164 s or more),
  and when the answer is the prior within :data:`calib.noise.steps.NEAR_PRIOR` on every axis and figure;
- the accelerometer's fit weighs the static steps' means too (:func:`accel_step_means`: their residuals about the
  affine model of the nominal gravity, the table's pose errors stated from the rig file's classes, :func:`pose_u_rad`),
  which show the wander between steps minutes apart that sets a long session's bias sigma;
- otherwise each axis's floor (as B in the registry's convention, ``/`` :data:`calib.noise.terms.REGISTRY_B_FLOOR`)
  and walk K are used (:func:`calib.noise.steps.posterior_figures`: the posterior means of their squares), with
  the family's flicker corner, and the calibration file's ``noise:`` says ``source: recording``, the figures, and
  the static steps and seconds they rest on.

Cost: the length rule reads 64 clusters of 0.64 s of the longest static step only (0.11 ms CPU on a
six-position session); the fit runs only on steps that pass it (50-75 ms a sensor, Greenhall's degrees of freedom
through allantools, whose import takes 0.6-1.2 s once per process on the shared machine; the posterior mean's grid
about 6 ms an axis more).
"""

from __future__ import annotations

import math
from datetime import datetime, timezone
from types import SimpleNamespace

import numpy as np

from calib.noise.steps import (STEPS_TAU_FRACTION, StepMeansOfAxis, moved_off, pooled_allan, posterior_figures,
                               step_means_of_axis, steps_show_wander)
from calib.noise.terms import REGISTRY_B_FLOOR, NoiseFigures
from calib.numerics.stability import AxisStability, BiasStability
from rig.analysis.uncertainty import session_rig_errors
from rig.lab.identity import sensor_identity
from rig.lab.noise_profiles import figures_used
from rig.session.adapter import capture_window, chip_stability, on_ramp, recorded_chip

#: sensor -> its samples' column (counts)
COLUMNS = {"accel": "accel_counts", "gyro": "gyro_counts"}


def _counts_per_unit(session, sensor: str) -> float | None:
    """Counts per g (accelerometer) or per deg/s (gyroscope) of the session's sensor, or None."""
    return session.lsb_per_g if sensor == "accel" else session.info.rig.sensor.gyro_lsb_per_dps


def _sensors(session) -> list[str]:
    """The sensors whose wander the solve weighs: the accelerometer; the gyroscope when the session has complete
    rate steps (its rate solve) and gyroscope samples."""
    rate = any(s.kind == "rate" and s.status == "complete" for s in session.info.steps)
    return ["accel"] + (["gyro"] if rate and "gyro_counts" in session.samples and _counts_per_unit(session, "gyro")
                        else [])


def axis_records(session, sensor: str, idx: list[int]) -> list[list[np.ndarray]]:
    """Per axis (x, y, z), the static steps ``idx``'s samples of ``sensor`` in its unit (g, deg/s), each step a
    (n_i,) array; a step with a non-finite sample is left out."""
    values = session.samples[COLUMNS[sensor]]
    step = session.samples["step"]
    order = np.argsort(step, kind="stable")
    lo, hi = np.searchsorted(step[order], idx, "left"), np.searchsorted(step[order], idx, "right")
    blocks = [values[order[a:b]].astype(float) / _counts_per_unit(session, sensor) for a, b in zip(lo, hi)]
    blocks = [b for b in blocks if len(b) and np.all(np.isfinite(b))]
    return [[b[:, j] for b in blocks] for j in range(3)]


def longest_step(session, sensor: str, idx: list[int]) -> list[np.ndarray]:
    """Per axis, the samples of ``sensor`` (its unit) in the static step of ``idx`` that holds the most (one pass
    over the step column: no sort)."""
    step = session.samples["step"]
    counts = np.bincount(step.astype(np.int64), minlength=max(idx) + 1)
    rows = step == max(idx, key=lambda i: counts[i])
    block = session.samples[COLUMNS[sensor]][rows].astype(float) / _counts_per_unit(session, sensor)
    return [block[:, j] for j in range(3)] if np.all(np.isfinite(block)) else [[], [], []]


def pose_u_rad(session) -> float:
    """Standard uncertainty (rad, per axis) of each pose's direction from the turntable's errors that differ from
    pose to pose (its per-pose classes and lost motion, :func:`rig.analysis.uncertainty.session_rig_errors`: 0 for
    a simulated table without geometry errors)."""
    rig = session_rig_errors(session)
    return math.hypot(rig.table.pose_u_rad(), rig.table.lost_motion_u_rad(rig.one_direction))


def accel_step_means(session, idx: list[int], corner_s: float, pose_u: float) -> list[StepMeansOfAxis | None]:
    """Per axis (x, y, z), the means (g) of the static steps ``idx`` with a known pose and what the wander makes of
    them between the steps (:func:`calib.noise.steps.step_means_of_axis`, the family's flicker corner
    ``corner_s``, s), a pose of standard uncertainty ``pose_u`` (rad) moving gravity across axis j by
    ``pose_u^2 (1 - f_j^2)``; None per axis when the steps leave no residual degree of freedom."""
    known = [i for i in idx if session.info.steps[i].f_nominal is not None]
    step, values, t = session.samples["step"], session.samples["accel_counts"], session.samples.get("t_s")
    if t is None:
        return [None, None, None]
    means, f, start, end = [], [], [], []
    for i in known:
        rows = step == i
        if rows.sum() < 2 or not np.all(np.isfinite(values[rows])):
            continue
        mid, dur = capture_window(t[rows])
        means.append(values[rows].astype(float).mean(axis=0) / session.lsb_per_g)
        f.append(session.info.steps[i].f_nominal), start.append(mid - dur / 2), end.append(mid + dur / 2)
    if not means:
        return [None, None, None]
    means, f = np.array(means), np.array(f, float)
    return [step_means_of_axis(means[:, j], f, start, end, corner_s, pose_u**2 * (1.0 - f[:, j] ** 2))
            for j in range(3)]


def estimate(records: list[list[np.ndarray]], rate_hz: float, family: BiasStability,
             between: list[StepMeansOfAxis | None] | None = None) -> AxisStability | None:
    """The wander per axis from ``records`` (per axis, the static steps' samples, in ``family.unit``) at
    ``rate_hz`` (Hz), the ``family``'s figures (registry convention) as the prior, and with ``between`` (per axis,
    :func:`accel_step_means`) the residuals of the steps' means about the calibration's affine model, which show the
    wander between steps minutes apart that no step reaches on its own; None where the family's stay (the steps too
    short on every axis, or the answer within :data:`calib.noise.steps.NEAR_PRIOR` of the prior on every axis)."""
    prior = NoiseFigures(B=family.bias_instability * REGISTRY_B_FLOOR, K=family.random_walk_per_rts)
    if not any(steps_show_wander(axis, rate_hz, prior) for axis in records):
        return None
    between = between or [None] * len(records)
    fits = [posterior_figures(pooled_allan(axis, rate_hz, max_fraction=STEPS_TAU_FRACTION), prior, between=b)
            for axis, b in zip(records, between)]
    if not any(moved_off(f, prior) for f in fits):
        return None
    return AxisStability.of(BiasStability(f.B / REGISTRY_B_FLOOR, f.K, family.flicker_corner_s, family.unit)
                            for f in fits)


def use_recording_noise(session) -> dict | None:
    """Attach the wander ``session``'s own static steps show (``Session.unit_noise``, per sensor) and return the
    calibration file's ``noise`` record (``source: recording``); None (nothing attached: the family's figures) by
    the module's rules. Call only when the unit has no profile."""
    chip = recorded_chip(session)
    idx = session.static_step_indices(unknown_pose=True)
    if chip is None or not idx or on_ramp(session):
        return None
    rate_hz = float(session.info.rig.sensor.sample_rate_hz)
    used, rested = {}, None
    for sensor in _sensors(session):
        family = chip_stability(chip, sensor)
        if family is None:
            continue
        prior = NoiseFigures(B=family.bias_instability * REGISTRY_B_FLOOR, K=family.random_walk_per_rts)
        if not any(steps_show_wander([axis], rate_hz, prior) for axis in longest_step(session, sensor, idx)):
            continue  # the cheap rule first, on the longest step alone: a six-position session stops here
        records = axis_records(session, sensor, idx)
        between = (accel_step_means(session, idx, family.flicker_corner_s, pose_u_rad(session)) if sensor == "accel"
                   else None)
        found = estimate(records, rate_hz, family, between)
        if found is not None:
            used[sensor] = found
            rested = rested or (len(records[0]), sum(len(r) for r in records[0]) / rate_hz)
    if not used:
        return None
    session.unit_noise = used
    key = sensor_identity(session.info.to_dict(), SimpleNamespace(sensor=None))["key"]
    created = session.info.created or datetime.now(timezone.utc).isoformat(timespec="seconds")
    return {"source": "recording", "sensor_key": key, "measured_at": str(created), "session": session.id,
            "sensors": figures_used(used), "steps": rested[0], "seconds": round(rested[1], 3)}
