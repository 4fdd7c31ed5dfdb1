"""Monte Carlo validation of the uncertainty budget (issue 29 item 6; JCGM 101 style; docs/uncertainty.md).

Each trial draws a hidden turntable from the stated classes (``rig.simulation.geometry.GeometryClass``: angular
errors, lost motion, wobble, non-orthogonalities, the sensor's mounting), a true local g from the rig file's
gravity statement (``--site``: latitude 52 deg, 100 m, normal gravity +- the 100 mGal anomaly, rectangular;
``--unknown-site``: standard gravity +- 0.036 m/s^2) and a hidden MPU-9150 (the simulator's own
``AccelErrorModel.draw``), then runs the six-position procedure through the world model of the simulated rig:
the stage angles and arrival directions of the procedure's moves (the planner's targets, poses reached from
either side unless ``--approach``), the true specific force ``f = (g/g0) R^T e_z`` through the geometry chain,
counts = lsb (M f + b) plus the step mean's noise (400 ug/rtHz, 100 Hz, 10 s: white, the standard error the
solve is given). The session is solved (pinv, triangular), its budget made (``calib.accel.budget`` with the
rig's class figures), and each true parameter is checked against [estimate - U, estimate + U] (k = 2), and
against +-2 sigma (Type A only).

This is the measurement model of the simulated rig without its wire and chip (the emulated controllers and
the register-level chip add nothing to the pose or the step means here), so it runs at 0.1 s a trial; the
full simulated rig agrees on the same seeds (``--sessions N`` runs N of them end to end as a spot check).

Measured 2026-11-25 on this 2-core machine shared with other engineers' jobs (load about 2-3), 400 trials,
seed 0, site stated (52 deg, 100 m), poses reached from either side (226 s):

    class   U = 2 u_c  JCGM 101 95 %  2 sigma (Type A, today's sigma)  worst |err|/U
    bias        93.6%          92.8%             89.6%                      1.59
    scale       93.3%          89.8%             97.9%                      1.93
    angle      100.0%          93.3%             29.0%                      0.99

Poses approached from one side (--approach, 400 trials, 185 s): U 93.5 / 93.6 / 99.9 %, JCGM 101 92.4 / 89.1 /
93.4 %, 2 sigma 90.2 / 97.7 / 28.7 %. Characterised by reversal first (--reversal: another hidden sensor in
three mountings, the session's poses corrected, the characterised u in the budget; 200 trials, 91 s):
U 96.2 / 94.2 / 98.5 %, JCGM 101 96.0 / 93.5 / 98.3 %, 2 sigma 82.5 / 88.3 / 90.0 %. Re-measured 2026-11-26 after
the reversal's u gained the classes it aliases (the budget takes the fit-only ``u_correction_deg``; 200 trials,
61 s on a shared machine): U 97.2 / 96.5 / 98.5 %, JCGM 101 96.8 / 96.2 / 98.3 %, 2 sigma unchanged; with the
aliased classes counted inside the characterised u as well: 98.7 / 96.5 / 99.8 % (over-covered, not adopted).

With the arrival directions the sessions record (the default since 2026-11-26; --no-arrival: as before, lost motion
of unknown sign at every pose), characterised by reversal, 200 trials: seed 0 U 96.0 / 96.5 / 96.5 %, JCGM 101
95.8 / 95.5 / 95.5 %; seed 1 U 96.3 / 97.7 / 95.0 %, JCGM 101 95.5 / 96.7 / 93.8 % (13 s each, 2 cores shared with two
other sessions). Uncharacterised, 400 trials, re-measured the same day: either side U 98.0 / 99.7 / 100.0 % (the same
with --no-arrival: 97.9 / 99.7 / 100.0 %), approached from one side 98.0 / 99.5 / 99.9 %: biases and scales
over-covered against the 2026-11-25 figures (the Type A term keeps a misfit's Birge scaling the rig explains; docs
/uncertainty.md).

With the Type A scaling judged against the noise and the rig's errors as well (calib.accel.budget.judge_with_rig;
2026-11-26, same machine): characterised by reversal, 200 trials seed 0 U 94.7 / 94.2 / 96.5 %, seed 1 95.0 / 94.5 /
95.0 %, 400 trials seed 2 95.6 / 95.0 / 94.8 %: every class within 93-97 %; uncharacterised, 400 trials, either side
93.9 / 93.3 / 100.0 %, approached from one side 93.5 / 93.7 / 99.9 %.

With the Type A per axis (2026-11-26, later: each quantity's sigma before the solve's own, axis-by-axis misfit
scaling, not the session's pooled Birge ratio, calib.accel.budget.unscaled_sigma; quiet 2-core machine):
uncharacterised, 400 trials, seed 0 U 95.2 / 97.2 / 100.0 %, seed 1 95.2 / 96.2 / 100.0 %, approached from one side
94.2 / 97.2 / 99.9 %; characterised by reversal, 200 trials seed 0 93.7 / 96.3 / 97.3 %, seed 1 94.3 / 96.0 / 96.7 %,
400 trials seed 2 94.0 / 96.6 / 96.2 %. The biases and the characterised classes within 93-97 %; the uncharacterised
scales at the target's upper edge (96.2-97.2 %: the Type A of the axes the solve left unscaled is no longer divided
by the pooled ratio, which had made z's 2.4x too small on the default table; the rig's scale terms are a little
conservative); the uncharacterised angles over-covered as before (the mounting class).

The seed's verification table (--, printed last: the worst roll or pitch error per rig at its seven poses),
200 trials seed 0: uncharacterised largest 0.131 deg (95th percentile 0.114, median 0.084); --reversal largest
0.032 deg (95th percentile 0.022, median 0.012).

(target 93-97 % for every class: met by U = 2 u_c for biases and scales; the angles are over-covered at
k = 2, their U dominated by the fixture's rectangular mounting class, and the JCGM 101 interval of the
budget's own distributions brings them to 93.3 % but leaves the scales at 89.8 %, missed. Without the
rig's errors, 2 sigma covers 29 % of the angles.)

Run: ``python benchmarks/bench_budget.py [--trials 400] [--approach] [--unknown-site]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import calib
from calib.accel.budget import at_local_gravity, contributions, flat_sigma, quantities
from calib.accel.inputs import StepMeans
from calib.evaluation import roll_pitch_deg
from calib.accel.reversal import Mounting, characterise
from calib.numerics.budget import RigErrors, coverage_interval, expanded
from calib.numerics.gravity import G0_M_S2, from_site, standard_gravity
from drivers.sensors.sim.error_model import AccelErrorModel
from rig.planning.approach import pre_target
from rig.planning.poses import pose_angles_deg
from rig.planning.targets import plan_axis_target
from calib.numerics.turntable import rot_x, rot_z
from rig.simulation.geometry import GeometryClass

POSES = ("+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up")  # procedures/six_position.yaml, in its order
LSB = 8192.0
SEM_COUNTS = float(np.hypot(400e-6 * np.sqrt(100 / 2.0) * LSB, np.sqrt(1 / 12.0)) / np.sqrt(1000))
TURNS = (np.eye(3), rot_z(np.pi)[0], rot_x(np.pi)[0])  # the sensor's turns in its fixture for the reversal
CLASSES = {"bias": [f"bias_counts[{i}]" for i in range(3)], "scale": [f"scale_counts_per_g[{i}]" for i in range(3)],
           "angle": [f"misalignment.{n}" for n in ("alpha_yz", "alpha_zy", "alpha_zx")]}


#: whether the sessions record their arrival directions (--no-arrival: as before they did, lost motion of unknown
#: sign at every pose)
ARRIVAL = True


def stage_moves(approach: bool) -> tuple[np.ndarray, np.ndarray]:
    """The six poses' stage angles (K, 3) and the direction each axis arrived in (K, 3), as the planner moves
    the table from zero (with the planned overshoot when ``approach``)."""
    current = np.zeros(3)
    direction = np.ones(3)
    angles, dirs = [], []
    for name in POSES:
        wanted = pose_angles_deg(name)
        for i in range(3):
            target = plan_axis_target(current[i], wanted[i], (-400, 400), 400)
            if approach and pre_target(current[i], target, "positive", 0.5, (-400, 400)) is not None:
                current[i] = target - 0.5
            if abs(target - current[i]) > 1e-9:
                direction[i] = np.sign(target - current[i])
            current[i] = target
        angles.append(current.copy())
        dirs.append(direction.copy())
    return np.array(angles), np.array(dirs)


def true_parameters(sensor: AccelErrorModel) -> dict[str, float]:
    m = np.asarray(sensor.matrix, float) * LSB
    k = np.diag(m)
    t = np.linalg.inv(np.linalg.inv(np.diag(k)) @ m)
    q = {f"bias_counts[{i}]": float(b) * LSB for i, b in enumerate(sensor.bias_g)}
    q.update({f"scale_counts_per_g[{i}]": float(v) for i, v in enumerate(k)})
    q.update({"misalignment.alpha_yz": -t[0, 1], "misalignment.alpha_zy": t[0, 2], "misalignment.alpha_zx": -t[1, 2]})
    return q


def record(rng, geometry, sensor, angles, dirs, turn=None) -> StepMeans:
    """The six step means of ``sensor`` on ``geometry`` (turned by ``turn`` in its fixture)."""
    r = geometry.sensor_to_world(np.eye(3), angles, dirs) @ (np.eye(3) if turn is None else turn)
    f = geometry.gravity_g0() * np.transpose(r, (0, 2, 1)) @ np.array([0, 0, 1.0])
    k = len(POSES)
    counts = LSB * (f @ np.asarray(sensor.matrix, float).T + np.asarray(sensor.bias_g, float))
    counts += rng.normal(0, SEM_COUNTS, counts.shape)
    f_nom = np.array([pose_angles_to_f(a) for a in angles])
    return StepMeans(names=POSES, f_nominal_g=f_nom, mean_counts=counts, sem_counts=np.full((k, 3), SEM_COUNTS),
                     n_samples=np.full(k, 1000), temp_c=None, t_s=np.arange(k) * 15.0, lsb_per_g=LSB,
                     arrival_direction=recorded_arrival(angles, dirs) if ARRIVAL else None)


def recorded_arrival(angles: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """The arrival directions a session records (rig.session.adapter): each stage's, 0 until it first moves (the
    direction it stood in when the session began is not known)."""
    moved = np.cumsum(np.abs(np.diff(np.vstack([np.zeros(3), angles]), axis=0)) > 1e-9, axis=0) > 0
    return np.where(moved, dirs, 0.0)


def characterised(rng, geometry, angles, dirs, rig: RigErrors) -> tuple:
    """The rig characterised by reversal with another hidden sensor in three mountings (as placed, turned 180
    deg about z, about x): the characterisation and the rig errors it leaves."""
    other = AccelErrorModel.draw(rng)
    mountings = [Mounting(record(rng, geometry, other, angles, dirs, t), t) for t in TURNS]
    result = characterise(mountings, rig)
    return result, result.rig_errors(rig, "reversal (3 mountings)")


def trial(rng, angles, dirs, stated, unknown_site: bool, rig: RigErrors | None = None) -> tuple:
    """One hidden rig and sensor (characterised by reversal first when ``rig`` is given): (true parameters,
    calibration, steps, resolve, rig errors)."""
    half = 0.036 if unknown_site else 1e-3
    geometry = GeometryClass().draw(rng, stated.g_m_s2 + rng.uniform(-half, half))
    sensor = AccelErrorModel.draw(rng)
    steps = record(rng, geometry, sensor, angles, dirs)
    if rig is not None:
        result, rig = characterised(rng, geometry, angles, dirs, rig)
        steps = result.corrected(steps, rig)

    def resolve(st):
        return calib.solve(st, model="triangular", method="pinv", thermal="off")

    steps = at_local_gravity(steps, stated)  # the solve's nominal force at the stated g
    cal = resolve(steps)
    return true_parameters(sensor), cal, steps, resolve, rig, verification_error_deg(cal, sensor)


#: the seed's seven verification poses (procedures/verify_seed_table.yaml; rig.lab.exports.VERIFY_POSES): a1, a2, a3
VERIFY_ANGLES = [(0, 90, 0), (0, 60, -60), (0, 30, -30), (0, 0, 0), (0, -30, 30), (0, -60, 60), (0, 0, 90)]


def verification_error_deg(cal, sensor) -> float:
    """The worst roll or pitch error (deg) of ``cal`` on the seed's verification table: the hidden sensor's
    noise-free counts at each pose's true attitude, through the calibration, against that attitude (roll not
    scored at pitch 90 deg, gimbal lock)."""
    f = np.array([pose_angles_to_f(a) for a in VERIFY_ANGLES])
    counts = LSB * (f @ np.asarray(sensor.matrix, float).T + np.asarray(sensor.bias_g, float))
    (roll_t, pitch_t), (roll_c, pitch_c) = roll_pitch_deg(f), roll_pitch_deg(cal.apply(counts))
    roll_err = np.where(np.abs(pitch_t) < 89.0, np.abs((roll_c - roll_t + 180) % 360 - 180), 0.0)
    return float(max(np.max(roll_err), np.max(np.abs(pitch_c - pitch_t))))


def pose_angles_to_f(a) -> np.ndarray:
    a2, a3 = np.radians(a[1]), np.radians(a[2])
    f = np.array([-np.sin(a3) * np.cos(a2), np.sin(a2), np.cos(a3) * np.cos(a2)])
    f[np.abs(f) < 1e-15] = 0.0
    return f


def run(trials: int, seed: int, approach: bool, unknown_site: bool, reversal: bool = False) -> dict:
    """Coverage (%) per parameter class of U = 2 u_c, of the JCGM 101 95 % interval of the budget's
    distributions, and of 2 sigma (Type A only); and the worst |error| / U."""
    rng = np.random.default_rng(seed)
    stated = standard_gravity() if unknown_site else from_site(52.0, 100.0)
    rig = RigErrors.from_classes(GeometryClass(), stated, one_direction=approach)
    angles, dirs = stage_moves(approach)
    inside = {c: {"k2": [], "p95": [], "A": []} for c in CLASSES}
    worst = {c: 0.0 for c in CLASSES}
    attitude = []
    for _ in range(trials):
        truth, cal, steps, resolve, used, att = trial(rng, angles, dirs, stated, unknown_site,
                                                      rig if reversal else None)
        attitude.append(att)
        parts = contributions(cal, steps, resolve, used or rig)
        est, u_k2, u_95 = quantities(cal), expanded(parts, 2.0), coverage_interval(parts)
        sigma = flat_sigma(cal)  # what the calibration file reports today (Type A, misfit scaled)
        for c, names in CLASSES.items():
            for n in names:
                err = abs(est[n] - truth[n])
                inside[c]["k2"].append(err <= u_k2[n])
                inside[c]["p95"].append(err <= u_95[n])
                inside[c]["A"].append(err <= 2 * sigma[n])
                worst[c] = max(worst[c], err / u_k2[n])
    out = {c: ({k: 100 * np.mean(v) for k, v in inside[c].items()}, worst[c]) for c in CLASSES}
    out["attitude"] = (float(np.max(attitude)), float(np.percentile(attitude, 95)), float(np.median(attitude)))
    return out


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--trials", type=int, default=400)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--approach", action="store_true", help="every pose approached from the positive side")
    p.add_argument("--unknown-site", action="store_true", help="no gravity stated (standard gravity)")
    p.add_argument("--reversal", action="store_true", help="characterise each rig by reversal first")
    p.add_argument("--no-arrival", action="store_true", help="the sessions record no arrival directions")
    a = p.parse_args()
    global ARRIVAL
    ARRIVAL = not a.no_arrival
    t0 = time.perf_counter()
    out = run(a.trials, a.seed, a.approach, a.unknown_site, a.reversal)
    print(f"{a.trials} trials, seed {a.seed}, approach {'positive' if a.approach else 'none'}, "
          f"{'characterised by reversal, ' if a.reversal else ''}"
          f"gravity {'unknown site' if a.unknown_site else 'site stated (52 deg, 100 m)'}, "
          f"{time.perf_counter() - t0:.1f} s")
    print(f"{'class':6s} {'U = 2 u_c':>10s} {'JCGM 101 95 %':>14s} {'2 sigma (Type A)':>17s} {'worst |err|/U':>14s}")
    worst_deg, p95_deg, median_deg = out.pop("attitude")
    for c, (f, w) in out.items():
        print(f"{c:6s} {f['k2']:9.1f}% {f['p95']:13.1f}% {f['A']:16.1f}% {w:14.2f}")
    print(f"seed's verification table, worst roll/pitch error per rig (deg): largest {worst_deg:.4f}, 95th percentile "
          f"{p95_deg:.4f}, median {median_deg:.4f}")
    print(f"(g0 = {G0_M_S2})")


if __name__ == "__main__":
    main()
