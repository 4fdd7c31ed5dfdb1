"""Sigmas of units unlike their family, before and after characterisation (issue 28, targets 2 and 3).

Each unit: an MPU-9150-class accelerometer whose hidden white-noise density, bias instability and random
walk are its family's times factors drawn log-uniform in [0.5, 2] (per axis, as the rig file's
``sim: noise_spread:`` draws them: drivers.sensors.sim.unit_noise; ``--same-axes``: one factor per term
for the three axes). Six-position sessions of the unit (10 s per pose, 6 s between poses, 100 Hz through
the 44 Hz filter: benchmarks/bench_uncertainty.py's step-level simulation, the simulator's own noise
process) go through the adapter and solver of ``rig solve`` three ways:

- ``family``: as today, the chip family's figures weigh the bias wander;
- ``profile``: after characterisation: the unit's figures fitted by ``rig characterize``'s fit
  (calib.noise) on a 2-hour 100 Hz static record of the same unit, used as ``rig solve`` uses a stored
  profile (rig.lab.noise_profiles: B = sqrt(2) x the fitted floor and K of each axis; the pinv solve gives each
  axis its own wander, calib.numerics.stability.AxisStability);
- ``truth``: the unit's true figures, each axis its own;
- ``recording`` (issue 28 item 5, what ``rig solve`` does without a profile since 2026-11-26): the wander estimated
  from the session's own steps where they are long enough (rig.lab.recording_noise.estimate: calib.noise.steps'
  pooled Allan variances per axis and, since the later 2026-11-26 change, the steps' means about the affine model,
  the family's figures as a log-normal prior, sd 0.8 in ln, 1.6 since that change; the family's figures
  where the steps are too short or the answer within 10 % of them), each axis its own.

Each session is simulated once and solved every way asked (until 2026-11-26 each way drew the same sessions anew).

Per unit and way: observed scatter / reported sigma (RMS error over the sessions / median reported sigma)
for each of the nine parameters, and the spread (RMS) of each session's error over that session's own reported sigma
(the issue's measure; for a sigma estimated from the session it exceeds the first, as a Student t's spread exceeds 1).
The target (after characterisation): within 0.8-1.25 for every parameter.

    python benchmarks/bench_unit_noise.py [--units 8] [--sessions 100] [--same-axes] [--faces six|26] [--dwell 10]
        [--seed 0] [--only 11,14] [--geometry TABLE_SEED] [--characterise-hours 2]

``--dwell`` sets the seconds per pose (600: six faces make an hour's session, whose steps show the wander); ``--seed``
the first unit (units seed, seed + 1, ...; the sessions' noise streams 5000 + 1000 x seed on, so another seed is
another set of units and sessions); ``--only`` runs some units of the seed's set on the same sessions as the whole set's
run. ``--geometry`` puts the simulated turntable's own errors in (``sim.geometry``, the simulator's default since
2026-11-26; without it the steps are those of a perfect table): :func:`table_forces`, the pose uncertainty rig solve
states handed to the steps' means, and the scatter compared with the solve's sigma before its misfit scaling
(:func:`solve_unscaled`: what the calibration file's Type A keeps where the rig's errors explain the misfit).

Measured 2026-11-25 on the shared 2-core machine (``--units 8 --sessions 200``, 7.6 min with other load),
observed scatter / reported sigma, min-max over the 8 units (each unit 200 sessions: the ratio's own
sampling error about 5 %):

==========  ===========  ===========  ===============  =========================================
way         biases       scales       misalignments    units with all nine within 0.8-1.25
==========  ===========  ===========  ===============  =========================================
family      0.72-1.59    0.93-1.14    0.90-1.12        2 of 8 (25 %)
profile     0.78-1.21    0.97-1.03    0.87-1.02        7 of 8 (88 %): one bias at 0.78 (unit 4's x,
                                                       its fitted B above the truth)
truth       0.93-1.12    0.99-1.03    0.89-1.02        8 of 8
==========  ===========  ===========  ===============  =========================================

Target (after characterisation, every parameter within 0.8-1.25): met on 7 of 8 units, missed on one
(0.78); the family's figures miss it on 6 of 8 (0.72-1.59).

Measured 2026-11-26 (load 8-10 on 2 cores), same table, other units and sessions:

- six faces, units 8-15 (``--seed 8 --units 8 --sessions 200 --ways family,profile``): family biases 0.65-1.63,
  scales 0.91-1.21, misalignments 0.89-1.07, 2 of 8 units within; profile biases 0.73-1.06, scales 0.91-0.99,
  misalignments 0.88-1.00, 6 of 8 within (units 11 and 14: z bias 0.73, both units whose z floor is 0.5-0.7x the
  family's; not checked whether their fitted floor lies above the truth, as unit 4's does);
- 26 directions, units 0-7 (``--faces 26 --units 8 --sessions 200``): family biases 0.66-1.46, scales 0.90-1.54,
  misalignments 0.95-1.26, 1 of 8 within; profile biases 0.80-1.09, scales 0.96-1.17, misalignments 0.99-1.09,
  8 of 8; truth 0.91-1.10, 8 of 8;
- one-hour six-face sessions (``--dwell 600 --ways family,recording,truth``), units 0-5, 20 sessions a unit (the
  ratios' own sampling error about 16 %): all nine parameters, family 0.52-1.78 (unit 1's z bias 0.52),
  recording 0.60-1.36, truth 0.68-1.24; units 1-5, share of the 45 ratios within 0.8-1.25: family 58 %,
  recording 64 %, truth 91 %; unit 0 alone with 100 sessions: family 1.01-1.84, truth 0.91-1.13.

With the fit from 0.6 s (calib.noise.fit.FIT_TAU_MIN_S, 2026-11-26; ``--ways profile``): units 0-7 biases 0.81-1.25,
scales 0.98-1.03, misalignments 0.88-1.02, 8 of 8 within; units 8-15 biases 0.72-1.06, scales 0.91-0.99,
misalignments 0.89-1.00, 6 of 8.

Measured 2026-11-26 with the recording way as rig solve now does it (rig.lab.recording_noise; each session simulated
once and solved every way; two processes ``--units 4 --seed 0`` and ``--seed 4``, units 0-7, on the shared 2-core
machine at load 3-7), observed scatter / reported sigma over all nine parameters, and how many of the 72 ratios lie
within 0.8-1.25:

- one-hour six-face sessions (``--dwell 600 --sessions 100``, each ratio's sampling sd about 7 %): family 0.53-1.84
  (42 of 72), recording 0.69-1.48 (60 of 72; the steps' own figures in 799 of 800 sessions), truth 0.89-1.13 (72);
  the rms of ln(ratio) beyond the sampling's: family 0.26, recording 0.15, truth 0;
- three-hour six-face sessions (``--dwell 1800 --sessions 50``, sampling sd about 10 %): family 0.50-2.01 (29 of 72),
  recording 0.76-1.28 (70 of 72), truth 0.79-1.24 (71 of 72); beyond sampling: 0.32, 0.07, 0.02;
- 10 s steps (six faces, 3 units x 20 sessions; 26 directions, 2 x 10): recording and family the same to the digit
  (the steps too short for the length rule: rig solve keeps the family's figures).

With the steps' means (2026-11-26 later: calib.noise.steps.StepMeansOfAxis, the Allan variances to half of each step,
the prior 1.6 in ln; the same units and sessions, one process at a time, nice'd, load 1-7 from other sessions):

- one-hour six-face sessions (``--dwell 600 --sessions 100 --ways family,recording,truth``, seeds 0 and 4):
  recording biases 0.95-1.19, scales 0.89-1.29, misalignments 0.93-1.32, 69 of 72 within, 5 of 8 units all nine,
  beyond sampling 0.07 (0.15 before); the three misses (a_zx 1.32, 1.29; k_x 1.29), which the truth puts at 1.11-1.13,
  are each the difference of two adjacent steps on an axis whose walk the hour shows to 2-4 degrees of freedom
  (a_zx is the y axis's coefficient on f_z, not of the first two steps as said here before): their reported sigma is
  0.86-0.88 of the truth's at the median over the sessions (docs/noise.md, "Why three one-hour ratios miss");
  recording vs truth 0.075 rms in ln, +6 % on average;
- three-hour six-face sessions (``--dwell 1800 --sessions 20``, units 0-3, sampling sd about 16 %): recording
  0.78-1.21 (35 of 36 within; the miss a_zx 0.78, truth 0.79), truth 0.79-1.19 (35 of 36): met within the sampling;
- 10 s steps (six faces, 3 units x 20 sessions; 26 directions, 2 x 10): recording and family the same to the digit.

Measured 2026-11-26 later (load 6-13 from other sessions, nice'd):

- with the table's own errors (``--dwell 600 --ways recording,truth --units 4 --sessions 40 --geometry 0``, and
  ``--only 4,5,6,7``; sampling sd about 11 %), units 0-7: recording 0.60-1.29, 65 of 72 within; the same sessions on a
  perfect table 0.67-1.23, 66 of 72; truth 0.73-1.14, 65 of 72, the same to the digit with and without the table;
  beyond sampling: 0.09, 0.07, 0.06;
- after characterisation, units 11 and 14 (``--seed 8 --only 11,14 --sessions 200 --ways family,profile,truth``): z
  bias profile 0.76 and 0.72, truth 0.86 and 0.87, family 0.77 and 0.65: the profile's z floor is 1.44x and 1.69x the
  truth (a floor the walk hides, docs/noise.md), not the model's.

With the posterior mean (2026-11-26 later, calib.noise.steps.posterior_figures: B and K the square roots of the
posterior means of their squares, not the mode; quiet machine, two processes, nice'd):

- one-hour six-face sessions (``--dwell 600 --sessions 100 --ways recording,truth``, seeds 0 and 4, units 0-7):
  recording biases 0.86-1.16, scales 0.85-1.23, misalignments 0.89-1.28, 71 of 72 within (the miss unit 0's a_zx
  1.28, truth 1.13), 7 of 8 units all nine, beyond sampling 0.063 and 0.051; truth 0.89-1.13, 72 of 72. The spread
  of each session's error over its own sigma (printed since then): recording 0.85-1.32, 68 of 72 within; truth the
  same as its ratio (its sigma does not depend on the session).
- with the table's errors (``--geometry 0``, and ``--only 4,5,6,7``): one-hour sessions, 100 a unit: recording
  0.76-1.31, 68 of 72 within (truth 72 of 72); three-hour sessions (``--dwell 1800 --sessions 30``): 0.85-1.31, 70 of
  72 (truth 72 of 72).
- after characterisation with 8-hour records (``--seed 8 --units 4 --sessions 200 --ways profile,truth
  --characterise-hours 8``, and ``--only 12,13,14,15``): units 8-15 biases 0.79-1.03, scales 0.92-0.99,
  misalignments 0.91-0.99, 7 of 8 units all nine (2-hour records: 6 of 8); units 11 and 14's z biases 0.91 and 0.83
  (2 hours: 0.76, 0.72); the miss unit 12's b_z 0.79 (truth 0.87).

The issue's own measure, pooled per parameter class (the RMS of error / own sigma over every session, unit and axis
of a class; printed since 2026-11-26 evening): after a 2-hour characterisation (``--seed 8 --units 8 --sessions 200
--ways profile,truth``) profile biases 0.90, scales 0.94, misalignments 0.94 (truth 0.93, 0.95, 0.95); the other
configurations above, from their per-unit figures: docs/noise.md, "The issue's measure, pooled per parameter class".

The target stopping rule's coverage: benchmarks/bench_target_coverage.py.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import calib
from bench_uncertainty import LSB, PARAMS, StepSession, param_vector
from calib.noise.allan import allan_curve
from calib.noise.fit import fit_terms
from calib.numerics.stability import AxisStability, BiasStability
from calib.synthetic import six_faces
from drivers.sensors.chips import CHIPS
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.noise import NoiseConfig, NoiseProcess, own_stream
from rig.lab.recording_noise import accel_step_means, estimate
from rig.planning.kinematics import angles_for_direction
from rig.simulation.geometry import GeometryClass
from rig.simulation.simrig import GEOMETRY_STREAM
from rig.session import adapter
from rig.session.adapter import chip_stability

RATE_HZ, BW_HZ = 100.0, 44.0
DWELL_S, GAP_S = 10.0, 6.0
CORNER_S = 5000.0


def directions26() -> np.ndarray:
    """The 26 face, edge and corner directions of a cube, unit vectors (procedures/tumble26.yaml's poses)."""
    d = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)], float)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def draw_unit(seed: int, same_axes: bool) -> dict:
    rng = np.random.default_rng([seed, 0xB0])
    size = 1 if same_axes else 3
    f = {t: np.broadcast_to(np.exp(rng.uniform(math.log(0.5), math.log(2.0), size)), 3).copy() for t in "NBK"}
    cfg = NoiseConfig.for_chip("MPU-9150", "dlpf")
    return {"density": 400e-6 * f["N"], "B": np.asarray(cfg.accel_bias_instability_g) * f["B"],
            "K": np.asarray(cfg.accel_random_walk_g_per_rts) * f["K"], "factors": f}


def table_forces(f: np.ndarray, table_seed: int) -> np.ndarray:
    """The specific force (K, 3), g, that the simulated turntable's own errors (``sim.geometry``, on by default in the
    simulator: rig.simulation.geometry, its default datasheet classes, the table drawn from ``table_seed`` on the
    simulator's own stream) put on the sensor at the nominal directions ``f`` (K, 3): each pose reached by the
    kinematic angles of its direction (rig.planning.kinematics.angles_for_direction) in the order given, each stage
    approaching from the side it last moved to (the lost motion). The same for every session on that table."""
    geometry = GeometryClass().draw(np.random.default_rng([table_seed, GEOMETRY_STREAM]))
    angles = np.array([angles_for_direction(fi) for fi in f])
    last, direction, dirs = np.zeros(3), np.ones(3), []
    for a in angles:
        direction = np.where(a > last, 1.0, np.where(a < last, -1.0, direction))
        dirs.append(direction.copy()), last.__setitem__(slice(None), a)
    r = geometry.sensor_to_world(np.eye(3), angles, np.array(dirs))
    return geometry.gravity_g0() * (np.transpose(r, (0, 2, 1)) @ np.array([0.0, 0.0, 1.0]))


def table_pose_u_rad() -> float:
    """What rig solve states for such a table's pose errors (rig.lab.recording_noise.pose_u_rad: the default
    classes' per-pose errors and lost motion, poses approached from either side), rad."""
    table = GeometryClass()
    return math.hypot(table.pose_u_rad(), table.lost_motion_u_rad(False))


def session(err: AccelErrorModel, unit: dict, f: np.ndarray, seed: int, noise: bool = True,
            dwell_s: float = DWELL_S, f_true: np.ndarray | None = None) -> StepSession:
    """One session (counts) at the nominal directions ``f`` (what the solve is told), the sensor seeing ``f_true``
    (a table with its own errors, :func:`table_forces`; None: ``f``)."""
    proc = NoiseProcess(unit["B"], unit["K"], own_stream(seed, 0xD1F0), (0.02, CORNER_S))
    n = int(round(dwell_s * RATE_HZ))
    t_all, a_all, step = [], [], []
    for i, fi in enumerate(f if f_true is None else f_true):
        t = i * (dwell_s + GAP_S) + np.arange(1, n + 1) / RATE_HZ
        a = err.output_g(np.tile(fi, (n, 1)), np.full(n, err.t_ref_c), t, np.zeros(n))
        if noise:
            a = a + proc.sample(t, unit["density"], BW_HZ)
        t_all.append(t), a_all.append(np.round(a * LSB) if noise else a * LSB), step.append(np.full(n, i))
    counts = np.concatenate(a_all)
    return StepSession({"t_s": np.concatenate(t_all), "accel_counts": counts.astype(np.int64) if noise else counts,
                        "step": np.concatenate(step), "temp_c": np.full(n * len(f), np.nan)}, f)


def characterised(unit: dict, seed: int, seconds: float = 7200.0) -> BiasStability:
    """The unit's figures as rig characterize fits them on a 2-hour static record, per axis as rig solve uses them."""
    proc = NoiseProcess(unit["B"], unit["K"], own_stream(seed, 0xC4A2), (0.02, CORNER_S))
    t = np.arange(1, int(seconds * RATE_HZ) + 1) / RATE_HZ
    y = proc.sample(t, unit["density"], BW_HZ)
    axes = []
    for j in range(3):
        fit = fit_terms(allan_curve(y[:, j], RATE_HZ))
        axes.append(BiasStability(fit.figures.B * math.sqrt(2), fit.figures.K, CORNER_S, "g"))
    return AxisStability.of(axes)


def from_recording(s: StepSession, pose_u: float = 0.0) -> AxisStability | None:
    """The unit's wander per axis as rig solve takes it from the session's own steps when the unit has no profile
    (rig.lab.recording_noise.estimate: the same rules, calib.noise.steps' pooled Allan variances and the steps'
    means about the affine model, with the family's figures as the prior); None where rig solve keeps the family's
    (steps too short, or the answer within 10 %). ``pose_u`` (rad): the table's pose errors as rig solve states
    them (0: a perfect table, a simulated rig with ``sim.geometry`` off; :func:`table_pose_u_rad` with ``--geometry``)."""
    counts, step = s.samples["accel_counts"].astype(float) / LSB, s.samples["step"]
    idx = [int(i) for i in np.unique(step)]
    records = [[counts[step == i, j] for i in idx] for j in range(3)]
    family = chip_stability(CHIPS["MPU-9150"], "accel")
    between = accel_step_means(s, idx, family.flicker_corner_s, pose_u=pose_u)
    return estimate(records, RATE_HZ, family, between)


def solve_unscaled(steps):
    """``rig solve``'s solve of the step means ``steps`` (calib.accel.inputs.StepMeans) with its sigmas before any misfit (Birge) scaling: on a table with its own errors
    every session misfits the noise alone (docs/uncertainty.md, "Misfit and the rig": chi2/dof 5-7), the solve scales
    each axis's sigma by its chi2/dof, and the calibration file's Type A takes that scaling out again where the rig's
    errors explain it (calib.accel.budget.type_a_contribution). What is compared with the scatter here is the noise
    and wander part alone: the session rule run at level 0 (no misfit is ever significant), for this solve only."""
    solve_module = sys.modules["calib.accel.solve"]  # the module (the name calib.accel.solve is its function)
    rule = solve_module.session_rule
    solve_module.session_rule = lambda fits: rule(fits, level=0.0)
    try:
        return calib.solve(steps, thermal="off")
    finally:
        solve_module.session_rule = rule


def ratios(err, unit, f, p0, stabilities: dict, n_sessions: int, dwell_s: float = DWELL_S,
           first: int = 5000, f_true: np.ndarray | None = None, pose_u: float = 0.0) -> tuple[dict, dict, dict]:
    """Per way (``stabilities``: way -> the figures to weigh with, None the family's, "recording" the session's own),
    the nine parameters' observed scatter / median reported sigma over ``n_sessions`` sessions, each simulated once
    and solved every way; per way the share of sessions whose own steps replaced the family's figures; and per way
    the spread (RMS) of each session's error / its own reported sigma (the issue's "spread of (error / reported
    sigma)": where the sigma is estimated from the session, as the recording's is, its own scatter widens this
    beyond the first ratio, as a Student t's spread exceeds 1)."""
    errs = {w: [] for w in stabilities}
    clean = (None if f_true is None else
             adapter.step_means(session(err, unit, f, 0, noise=False, dwell_s=dwell_s, f_true=f_true)).mean_counts)
    sigs = {w: [] for w in stabilities}
    moved = {w: 0 for w in stabilities}
    for k in range(n_sessions):
        s = session(err, unit, f, first + k, dwell_s=dwell_s, f_true=f_true)
        for way, stability in stabilities.items():
            used = from_recording(s, pose_u) if stability == "recording" else stability
            moved[way] += stability == "recording" and used is not None
            s.unit_noise = {"accel": used} if used is not None else {}
            if f_true is None:
                p, sg = param_vector(calib.solve(adapter.step_means(s), thermal="off"))
                errs[way].append(p - p0), sigs[way].append(sg)
                continue
            # the table's pose errors leave residuals no model term takes up, so the estimate depends on the weights
            # (the noise's own and the wander's): its noise-free reference is the same solve, the same weights, of
            # the noise-free means (the solve is linear in the means)
            steps = adapter.step_means(s)
            p, sg = param_vector(solve_unscaled(steps))
            p_clean, _ = param_vector(solve_unscaled(dataclasses.replace(steps, mean_counts=clean)))
            errs[way].append(p - p_clean), sigs[way].append(sg)
    out = {w: np.sqrt(np.mean(np.array(errs[w]) ** 2, axis=0)) / np.median(np.array(sigs[w]), axis=0)
           for w in stabilities}
    spread = {w: np.sqrt(np.mean((np.array(errs[w]) / np.array(sigs[w])) ** 2, axis=0)) for w in stabilities}
    return out, {w: moved[w] / n_sessions for w in stabilities}, spread


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=8)
    ap.add_argument("--sessions", type=int, default=100)
    ap.add_argument("--same-axes", action="store_true")
    ap.add_argument("--ways", default="family,profile,truth",
                    help="comma-separated subset of family,profile,truth,recording")
    ap.add_argument("--faces", default="six", choices=("six", "26"), help="six faces or 26 directions")
    ap.add_argument("--dwell", type=float, default=DWELL_S, help="seconds per pose (long steps show the wander)")
    ap.add_argument("--seed", type=int, default=0, help="the first unit's seed (sessions: 5000 + 1000 x seed on)")
    ap.add_argument("--only", default="", help="comma-separated units to run of the seed's set (the same sessions as "
                    "in the whole set's run: 5000 + 1000 x seed on), e.g. --seed 8 --only 11,14")
    ap.add_argument("--geometry", type=int, default=None, metavar="TABLE_SEED",
                    help="the turntable's own errors on (sim.geometry, the simulator's default): the table drawn from "
                    "TABLE_SEED + unit, its pose errors stated to the recording's estimate as rig solve states them")
    ap.add_argument("--characterise-hours", type=float, default=2.0,
                    help="the profile way's static record, hours (procedures/allan.yaml: 2; a floor the record does "
                    "not resolve, `rig characterize`'s note, is stated better by a longer one)")
    args = ap.parse_args()
    f = six_faces() if args.faces == "six" else directions26()
    table = {"family": [], "profile": [], "truth": [], "recording": []}
    spreads = {w: [] for w in table}
    units = [int(u) for u in args.only.split(",")] if args.only else range(args.seed, args.seed + args.units)
    for u in units:
        unit = draw_unit(u, args.same_axes)
        err = AccelErrorModel.draw(np.random.default_rng(100 + u), "MPU-9150")
        f_true = None if args.geometry is None else table_forces(f, args.geometry + u)
        pose_u = 0.0 if args.geometry is None else table_pose_u_rad()
        p0, _ = param_vector(calib.solve(adapter.step_means(session(err, unit, f, 0, noise=False, dwell_s=args.dwell,
                                                                    f_true=f_true)), thermal="off"))
        truth = AxisStability.of(BiasStability(b, k, CORNER_S, "g") for b, k in zip(unit["B"], unit["K"]))
        ways = {"family": None, "profile": "profile", "truth": truth, "recording": "recording"}
        ways = {k: v for k, v in ways.items() if k in args.ways.split(",")}
        if "profile" in ways:
            ways["profile"] = characterised(unit, 900 + u, 3600.0 * args.characterise_hours)
        found, moved, spread = ratios(err, unit, f, p0, ways, args.sessions, args.dwell, 5000 + 1000 * args.seed,
                                      f_true, pose_u)
        for way, r in found.items():
            table[way].append(r)
            spreads[way].append(spread[way])
            note = f" (the steps' own figures in {moved[way]:.0%} of sessions)" if way == "recording" else ""
            print(f"unit {u} (B x {np.round(unit['factors']['B'], 2)}, K x {np.round(unit['factors']['K'], 2)}) "
                  f"{way:8s}: " + " ".join(f"{p} {x:.2f}" for p, x in zip(PARAMS, r)) + note, flush=True)
            print(f"{'':>{len(str(u)) + 5}} spread of error / own sigma: "
                  + " ".join(f"{p} {x:.2f}" for p, x in zip(PARAMS, spread[way])), flush=True)
    # an honest ratio of n sessions still scatters: the RMS of n normal errors over their sigma is sqrt(chi2_n / n),
    # whose ln has sd about 1 / sqrt(2 n) (0.158 at 20 sessions, 0.071 at 100); what a way adds is beyond that
    sampling_rms = 1.0 / math.sqrt(2.0 * args.sessions)
    print("\nobserved scatter / reported sigma over units (min-max per parameter class; target 0.8-1.25):")
    for way, rows in table.items():
        if not rows:
            continue
        r = np.array(rows)
        inside = np.mean(np.all((r >= 0.8) & (r <= 1.25), axis=1))
        print(f"  {way:8s}: biases {r[:, :3].min():.2f}-{r[:, :3].max():.2f}, scales {r[:, 3:6].min():.2f}-"
              f"{r[:, 3:6].max():.2f}, misalignments {r[:, 6:].min():.2f}-{r[:, 6:].max():.2f}; units with every "
              f"parameter in 0.8-1.25: {inside:.0%}; ratios within: {np.mean((r >= 0.8) & (r <= 1.25)):.0%}; "
              f"rms ln(ratio) {np.sqrt(np.mean(np.log(r) ** 2)):.3f} (sampling alone: {sampling_rms:.3f})")
    print("spread of (error / the session's own reported sigma) over units (min-max per parameter class):")
    for way, rows in spreads.items():
        if rows:
            r = np.array(rows)
            print(f"  {way:8s}: biases {r[:, :3].min():.2f}-{r[:, :3].max():.2f}, scales {r[:, 3:6].min():.2f}-"
                  f"{r[:, 3:6].max():.2f}, misalignments {r[:, 6:].min():.2f}-{r[:, 6:].max():.2f}; within 0.8-1.25: "
                  f"{np.mean((r >= 0.8) & (r <= 1.25)):.0%}")
    # the issue's own figures (0.57, 0.38, 0.14 for the bias) are of a parameter class over many units: the RMS of
    # error / own sigma over every session, unit and axis of the class (equal sessions a unit: the RMS of the rows)
    print("pooled per parameter class over units and axes, RMS (the issue's measure; target 0.8-1.25):")
    for way in table:
        if table[way]:
            r, s = np.array(table[way]), np.array(spreads[way])
            print(f"  {way:8s}: " + ", ".join(
                f"{name} ratio {np.sqrt(np.mean(r[:, cols] ** 2)):.3f} spread {np.sqrt(np.mean(s[:, cols] ** 2)):.3f}"
                for name, cols in (("biases", slice(0, 3)), ("scales", slice(3, 6)), ("misalignments", slice(6, 9)))))
    print(f"  pooled over units, rms ln(ratio) less the sampling's, sqrt(rms^2 - {sampling_rms:.3f}^2): " + ", ".join(
        f"{way} {math.sqrt(max(np.mean(np.log(np.array(rows)) ** 2) - sampling_rms**2, 0.0)):.3f}"
        for way, rows in table.items() if rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
