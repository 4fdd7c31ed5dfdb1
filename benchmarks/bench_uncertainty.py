"""Do the reported uncertainties hold on realistic (DLPF + bias instability + random walk) noise? (issue 14, item 8)

Usage::

    .venv/bin/python benchmarks/bench_uncertainty.py [--quick] [--sessions N] [--full K]
    .venv/bin/python benchmarks/bench_uncertainty.py --gyro-mag [--sessions N]

Step-level Monte Carlo (the default, fast): a six-position session (gravity along +-X, +-Y, +-Z,
10 s per pose, 6 s between poses) of one MPU-9150-class sensor (error model drawn once, seed 14), +-4 g
(8192 counts/g). Each session's sample stream comes from the simulator's own ``dlpf`` noise model
(:class:`drivers.sensors.sim.noise.NoiseProcess`: white 400 ug/rtHz through the first-order DLPF,
40 ug bias instability, 4 ug/rts random walk; a fresh process per session), added to the error
model's output and rounded to counts; the session goes through the SAME adapter
(:func:`rig.session.adapter.step_means`) and solver (:func:`calib.solve`) as ``rig solve``, and
through :func:`calib.discovery.search.discover` as ``rig discover``. Per configuration: observed
scatter / reported sigma (median over sessions) for each of the nine parameters, the median
chi2/dof, the fraction of sessions whose every reported sigma is within 25 % of the observed scatter
(and of those outside, the share with some sigma above the band: the Birge rescale of a chance
significant misfit, or below it), each session's reported/true sigma at the 5th and 95th
percentile, and the discover false-alarm rate. The error of a session is its solution minus the noise-free
solution of the same sensor (the solver is linear in the step means, so that is exactly the noise's
part). ``--full K`` also records K clean six-position sessions on the simulated rig with
``sim: {noise: dlpf}`` (virtual time) at 1 kHz (the driver sets the 184 Hz filter there) and reports their chi2/dof.

``--gyro-mag`` (instead): the same for the gyroscope's rate table and the magnetometer's eight positions
and ellipsoid (the section "gyroscope and magnetometer" below; tests/calib/test_gyro_mag_uncertainty.py
runs it): each session's samples from the simulator's gyro / magnetometer noise process, through :func:`rig.session.adapter.rate_step_means` /
:func:`~rig.session.adapter.mag_step_means` and the solvers, with the chip's bias stability and, for
comparison, without it (the solvers before the wander covariance).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from types import SimpleNamespace
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import calib  # noqa: E402
from calib.discovery.search import StepContext, discover  # noqa: E402
from calib.gyro import param_names, solve_gyro  # noqa: E402
from calib.mag import sigma_names, solve_mag_ellipsoid, solve_mag_positions  # noqa: E402
from calib.synthetic import six_faces  # noqa: E402
from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel, MagErrorModel  # noqa: E402
from drivers.sensors.sim.noise import NoiseConfig, NoiseProcess, own_stream  # noqa: E402
from rig.planning.kinematics import sensor_to_world  # noqa: E402
from rig.session import adapter, load_session  # noqa: E402

LSB = 8192.0
DWELL_S, GAP_S = 10.0, 6.0
CONFIGS = [("100 Hz / 44 Hz", 100.0, 44.0), ("1 kHz / 44 Hz", 1000.0, 44.0), ("1 kHz / 184 Hz", 1000.0, 184.0)]
PARAMS = ["b_x", "b_y", "b_z", "k_x", "k_y", "k_z", "a_yz", "a_zy", "a_zx"]


@dataclass
class _Step:
    label: str
    f_nominal: list


@dataclass
class _Info:
    steps: list
    rig: object = field(default_factory=lambda: SimpleNamespace(sensor=SimpleNamespace(model="MPU-9150")))  # the adapter reads the chip's bias stability


class StepSession:
    """What the adapter reads of a session (:class:`rig.session.adapter.Session`), built in memory."""

    def __init__(self, samples: dict, f: np.ndarray) -> None:
        self.path = Path("<step-level>")
        self.samples = samples
        self.info = _Info([_Step(f"pose {i}", list(map(float, r))) for i, r in enumerate(f)])
        self.has_temperature = False
        self.lsb_per_g = LSB

    def static_step_indices(self, include_flagged: bool = False, unknown_pose: bool = False) -> list[int]:
        return list(range(len(self.info.steps)))


def simulate(err: AccelErrorModel, f: np.ndarray, rate: float, bw: float, seed: int, noise: bool = True,
             wander: bool = True) -> StepSession:
    """One six-position session's sample stream (counts) with the dlpf noise model (``wander`` False:
    without its bias instability and random walk, the filtered white noise alone)."""
    cfg = NoiseConfig.for_chip("MPU-9150", "dlpf")
    keep = 1.0 if wander else 0.0
    proc = NoiseProcess(np.multiply(cfg.accel_bias_instability_g, keep), np.multiply(cfg.accel_random_walk_g_per_rts, keep),
                        own_stream(seed, 0xD1F0), cfg.flicker_band_s)
    n = int(round(DWELL_S * rate))
    t_all, a_all, step = [], [], []
    for i, fi in enumerate(f):
        t = i * (DWELL_S + GAP_S) + np.arange(1, n + 1) / rate
        a = err.output_g(np.tile(fi, (n, 1)), np.full(n, err.t_ref_c), t, np.zeros(n))
        if noise:
            a = a + proc.sample(t, err.noise_density_g_per_rthz, bw)
        # the noise-free reference is the unrounded physics: rounding a noiseless constant would offset
        # each step mean by up to half a count (noise dithers that away in the real sessions)
        t_all.append(t), a_all.append(np.round(a * LSB) if noise else a * LSB), step.append(np.full(n, i))
    counts = np.concatenate(a_all)
    samples = {"t_s": np.concatenate(t_all), "accel_counts": counts.astype(np.int64) if noise else counts,
               "step": np.concatenate(step), "temp_c": np.full(n * len(f), np.nan)}
    return StepSession(samples, f)


def param_vector(cal) -> tuple[np.ndarray, np.ndarray]:
    mis, smis = cal.misalignment, cal.sigma["misalignment"]
    p = np.r_[cal.bias_counts, cal.scale_counts_per_g, [mis[k] for k in ("alpha_yz", "alpha_zy", "alpha_zx")]]
    s = np.r_[cal.sigma["bias_counts"], cal.sigma["scale_counts_per_g"],
              [smis[k] for k in ("alpha_yz", "alpha_zy", "alpha_zx")]]
    return p, s


def run_config(rate: float, bw: float, n_sessions: int, n_discover: int) -> dict:
    err = AccelErrorModel.draw(np.random.default_rng(14), "MPU-9150")
    f = six_faces()
    p0, _ = param_vector(calib.solve(adapter.step_means(simulate(err, f, rate, bw, 0, noise=False)), thermal="off"))
    errs, sigs, chi2, alarms = [], [], [], 0
    for k in range(n_sessions):
        sm = adapter.step_means(simulate(err, f, rate, bw, 1000 + k))
        cal = calib.solve(sm, thermal="off")
        p, s = param_vector(cal)
        errs.append(p - p0), sigs.append(s), chi2.append(cal.fit.chi2_per_dof)
        if k < n_discover:
            alarms += bool(discover(sm, StepContext()).effects)
    errs, sigs = np.array(errs), np.array(sigs)
    true_sigma = np.sqrt(np.mean(errs**2, axis=0))
    ratio = true_sigma / np.median(sigs, axis=0)
    rel = sigs / true_sigma  # each session's reported sigma over the true one, per parameter
    within = np.mean(np.all(np.abs(rel - 1) <= 0.25, axis=1))
    # a session outside the band is either rescaled by a (chance) significant misfit (some sigma far
    # above: the Birge ratio) or short of noise it did not see (some sigma below)
    above, below = np.mean(np.any(rel > 1.25, axis=1)), np.mean(np.any(rel < 0.75, axis=1))
    return {"ratio": ratio, "chi2": float(np.median(chi2)), "within": float(within), "above": float(above),
            "below": float(below), "spread": np.percentile(rel, [5, 95], axis=0),
            "alarms": alarms, "n_discover": n_discover, "n": n_sessions}


def full_sessions(k: int) -> dict:
    """K clean six-position sessions on the simulated rig with sim: {noise: dlpf} at 1 kHz (184 Hz filter)."""
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, noise="dlpf")
    proc = yaml.safe_load((REPO / "procedures" / "six_position.yaml").read_text())
    proc["sensor"]["sample_rate_hz"] = 1000
    chi2, sig_b = [], []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "rig.yaml").write_text(yaml.safe_dump(doc))
        (tmp / "proc.yaml").write_text(yaml.safe_dump(proc))
        for i in range(k):
            out = tmp / f"s{i}"
            r = subprocess.run([sys.executable, "-m", "rig.cli", "run", str(tmp / "proc.yaml"), "--rig",
                                str(tmp / "rig.yaml"), "--out", str(out), "--seed", str(7 + i), "--quiet"], cwd=REPO,
                               capture_output=True, text=True)
            if r.returncode != 0:
                print("  full session failed:", (r.stderr or r.stdout).strip().splitlines()[-1:])
                return {}
            s = load_session(next(out.rglob("session.yaml")).parent)
            cal = calib.solve(s.step_means(), thermal="off")
            chi2.append(cal.fit.chi2_per_dof), sig_b.append(cal.sigma["bias_counts"])
    return {"chi2": chi2, "sigma_bias": np.array(sig_b)}


# ------------------------------------------------------------------ gyroscope and magnetometer (--gyro-mag)

GM_NOISE = NoiseConfig.for_chip("MPU-9150", "dlpf")
#: MPU-9150 at a 10 Hz output rate with its 5 Hz filter (DLPF_CFG 6), +-250 deg/s
GYRO_RATE_HZ, GYRO_BW_HZ, LSB_PER_DPS = 10.0, 5.0, 131.0
#: procedures/gyro_rates.yaml: 18 rate steps of 100 s after six static poses, a few seconds between them
RATE_STEP_S, RATE_GAP_S, RATE_START_S = 100.0, 8.0, 110.0
#: procedures/mag_eight_position.yaml as the simulated rig runs it: the stage angles (deg) of its 12 steps
#: and the mid-times (s) of their 50 readings at 100 Hz (0.5 s)
MAG_ANGLES_DEG = [(0, 0, -90), (0, 0, 90), (0, 90, 0), (0, -90, 0), (0, 0, 0), (90, 0, 0), (180, 0, 0), (270, 0, 0),
                  (0, 0, -180), (90, 0, -180), (180, 0, -180), (270, 0, -180)]
MAG_T_S = [6.3, 22.2, 33.65, 49.6, 61.05, 72.5, 83.95, 95.4, 111.35, 131.75, 143.15, 154.55]
MAG_READINGS, MAG_RATE_HZ = 50, 100.0
#: the AK8975's resolution (uT per count) and the session's (counts per uT)
AK8975_UT_PER_LSB, SESSION_COUNTS_PER_UT = 0.3, 100.0
SITE = SimpleNamespace(field_ut=50.0, inclination_deg=65.0, declination_deg=0.0)


def _gm_session(samples: dict, steps: list, **sensor) -> SimpleNamespace:
    """What the adapter reads of a gyro / magnetometer session, in memory."""
    rig = SimpleNamespace(sensor=SimpleNamespace(model="MPU-9150", **sensor), site=SITE)
    return SimpleNamespace(path=Path("<step-level>"), info=SimpleNamespace(rig=rig, steps=steps), samples=samples,
                           lsb_per_g=LSB)


def rate_table() -> np.ndarray:
    """(18, 3) body rates of procedures/gyro_rates.yaml, deg/s: +-25, +-40, +-48 about x, y and z."""
    rates = []
    for j in range(3):
        for r in (25.0, 40.0, 48.0):
            for sign in (1.0, -1.0):
                w = np.zeros(3)
                w[j] = sign * r
                rates.append(w)
    return np.array(rates)


def rate_session(model: GyroErrorModel, seed: int) -> SimpleNamespace:
    """One rate-table session: gyro counts of ``model`` (no g-sensitivity: the specific force stays
    still) plus the simulator's gyro noise process (a fresh one per seed)."""
    proc = NoiseProcess(GM_NOISE.gyro_bias_instability_dps, GM_NOISE.gyro_random_walk_dps_per_rts,
                        own_stream(seed, 0xD1F1), GM_NOISE.gyro_flicker_band_s)
    n = int(RATE_STEP_S * GYRO_RATE_HZ)
    t_all, g_all, steps = [], [], []
    for i, w in enumerate(rate_table()):
        t = RATE_START_S + i * (RATE_STEP_S + RATE_GAP_S) + np.arange(1, n + 1) / GYRO_RATE_HZ
        out = model.output_dps(np.tile(w, (n, 1)), np.zeros((n, 3)))
        g_all.append(np.round((out + proc.sample(t, model.noise_density_dps_per_rthz, GYRO_BW_HZ)) * LSB_PER_DPS))
        t_all.append(t)
        steps.append(SimpleNamespace(kind="rate", status="complete", index=i, name=f"rate {i}",
                                     rate_nominal_dps=list(w)))
    k = len(steps)
    samples = {"t_s": np.concatenate(t_all), "gyro_counts": np.concatenate(g_all),
               "step": np.repeat(np.arange(k), n), "accel_counts": np.tile([0.0, 0.0, LSB], (k * n, 1)),
               "temp_c": np.full(k * n, np.nan)}
    return _gm_session(samples, steps, gyro_lsb_per_dps=LSB_PER_DPS)


def gyro_vector(cal) -> tuple[np.ndarray, np.ndarray]:
    """b (counts), k (counts per deg/s), m_ij (-) of a gyro calibration and their sigmas, in
    :func:`calib.gyro.param_names` order."""
    m = cal.matrix_counts_per_dps
    p = np.r_[cal.bias_counts, np.diag(m), [m[i, j] / m[i, i] for i in range(3) for j in range(3) if i != j]]
    return p, np.array([cal.sigma[n] for n in param_names()])


def gyro_truth(model: GyroErrorModel) -> np.ndarray:
    m = np.asarray(model.matrix)
    return np.r_[LSB_PER_DPS * np.asarray(model.bias_dps), LSB_PER_DPS * np.diag(m),
                 [m[i, j] / m[i, i] for i in range(3) for j in range(3) if i != j]]


def mag_session(model: MagErrorModel, angles_deg, t_mid_s, seed: int) -> SimpleNamespace:
    """One static magnetometer session: 50 readings at 100 Hz per step of ``model`` in the site's field
    at the stage angles, plus the simulator's magnetometer noise process (white readings of
    ``noise_ut``, flicker, random walk), at the AK8975's 0.3 uT resolution."""
    proc = NoiseProcess(GM_NOISE.mag_bias_instability_ut, GM_NOISE.mag_random_walk_ut_per_rts,
                        own_stream(seed, 0xD1F2), GM_NOISE.mag_flicker_band_s)
    h_world = adapter.site_field_world(SITE)
    t_all, m_all, steps = [], [], []
    for i, (angles, mid) in enumerate(zip(angles_deg, t_mid_s)):
        t = mid - MAG_READINGS / MAG_RATE_HZ / 2 + (np.arange(MAG_READINGS) + 0.5) / MAG_RATE_HZ
        h = sensor_to_world(np.asarray([angles], float))[0].T @ h_world
        m = model.output_ut(np.tile(h, (MAG_READINGS, 1))) + proc.sample(t, [model.noise_ut] * 3, None)
        m_all.append(np.round(np.round(m / AK8975_UT_PER_LSB) * AK8975_UT_PER_LSB * SESSION_COUNTS_PER_UT))
        t_all.append(t)
        steps.append(SimpleNamespace(is_static=True, status="complete", index=i, name=f"pose {i}",
                                     angles_deg=list(map(float, angles))))
    samples = {"t_s": np.concatenate(t_all), "mag_counts": np.concatenate(m_all),
               "step": np.repeat(np.arange(len(steps)), MAG_READINGS)}
    return _gm_session(samples, steps, magnetometer=SimpleNamespace(mag_lsb_per_ut=SESSION_COUNTS_PER_UT))


def mag_vector(cal) -> tuple[np.ndarray, np.ndarray]:
    """hard_iron_x..z (uT) and a_xx..a_zz (-) of a magnetometer calibration and their sigmas, in
    :func:`calib.mag.sigma_names` order."""
    return np.r_[cal.hard_iron_ut, np.asarray(cal.matrix).ravel()], np.array([cal.sigma[n] for n in sigma_names()])


def upper_triangular_representative(a: np.ndarray) -> np.ndarray:
    """The upper-triangular M (positive diagonal) with ``M M^T = A A^T``: what the ellipsoid fit
    determines of A (A up to a rotation)."""
    flip = np.eye(3)[::-1]
    return flip @ np.linalg.cholesky(flip @ a @ a.T @ flip) @ flip


def tumble_directions() -> tuple[list, list]:
    """Stage angles (deg) of 26 well-spread orientations (a fixed random draw) and their readings'
    mid-times (s): procedures/mag_tumble.yaml's count and spacing (3 s dwell plus the moves)."""
    euler = Rotation.random(26, random_state=np.random.default_rng(26)).as_euler("ZYX", degrees=True)
    return [tuple(e) for e in euler], [6.0 + 9.0 * i for i in range(26)]


def gm_monte_carlo(draw, solve, vector, truth, n_sessions: int) -> dict:
    """Observed scatter about ``truth`` / median reported sigma per parameter and the median chi2/dof
    over ``n_sessions`` sessions ``draw(seed)`` (step means), solved with the chip's bias stability
    (``with``) and without it (``without``: the solvers before the wander covariance)."""
    out = {key: {"err": [], "sig": [], "chi2": []} for key in ("with", "without")}
    for k in range(n_sessions):
        steps = draw(1000 + k)
        for key, s in (("with", steps), ("without", dataclasses.replace(steps, bias_stability=None))):
            cal = solve(s)
            p, sig = vector(cal)
            out[key]["err"].append(p - truth), out[key]["sig"].append(sig), out[key]["chi2"].append(cal.chi2_per_dof)
    with np.errstate(invalid="ignore", divide="ignore"):  # the ellipsoid's lower triangle: 0 / 0
        return {key: {"ratio": np.sqrt(np.mean(np.square(v["err"]), axis=0)) / np.median(v["sig"], axis=0),
                      "chi2": float(np.median(v["chi2"])), "n": n_sessions} for key, v in out.items()}


def gyro_rate_table(n_sessions: int) -> dict:
    """:func:`gm_monte_carlo` of the rate table (one gyro error model, seed 14, without g-sensitivity)."""
    model = GyroErrorModel.draw(np.random.default_rng(14))
    model.g_sensitivity_dps_per_g = np.zeros((3, 3)).tolist()
    return gm_monte_carlo(lambda seed: adapter.rate_step_means(rate_session(model, seed)), solve_gyro,
                          gyro_vector, gyro_truth(model), n_sessions)


def mag_eight_positions(n_sessions: int, model: MagErrorModel | None = None) -> dict:
    """:func:`gm_monte_carlo` of the eight-position run (12 steps; magnetometer error model seed 15)."""
    model = model or MagErrorModel.draw(np.random.default_rng(15))
    truth = np.r_[model.hard_iron_ut, np.asarray(model.soft_iron).ravel()]
    return gm_monte_carlo(lambda seed: adapter.mag_step_means(mag_session(model, MAG_ANGLES_DEG, MAG_T_S, seed)),
                          solve_mag_positions, mag_vector, truth, n_sessions)


def mag_ellipsoid(n_sessions: int, model: MagErrorModel | None = None) -> dict:
    """:func:`gm_monte_carlo` of the ellipsoid fit of a 26-direction tumble (A's upper-triangular
    representative; its lower triangle is 0 with sigma 0)."""
    model = model or MagErrorModel.draw(np.random.default_rng(15))
    angles, times = tumble_directions()
    truth = np.r_[model.hard_iron_ut, upper_triangular_representative(np.asarray(model.soft_iron)).ravel()]
    return gm_monte_carlo(lambda seed: adapter.mag_step_means(mag_session(model, angles, times, seed),
                                                              known_field=False),
                          lambda s: solve_mag_ellipsoid(s, SITE.field_ut), mag_vector, truth, n_sessions)


def report_gyro_mag(n: int) -> None:
    """Print the gyro / magnetometer Monte Carlo: observed / reported sigma and median chi2/dof."""
    t0 = time.perf_counter()
    print(f"gyro rate table (18 x 100 s, 10 Hz / 5 Hz) and magnetometer (eight positions: 12 steps; ellipsoid: "
          f"26 directions; 50 readings at 100 Hz), MPU-9150 dlpf noise; {n} sessions each")
    for name, run, names in (("gyro rate table", gyro_rate_table, param_names()),
                             ("mag positions", mag_eight_positions, sigma_names()),
                             ("mag ellipsoid", mag_ellipsoid, sigma_names())):
        r = run(n)
        widths = [max(len(x), 6) for x in names]
        print(f"{name:22} {' '.join(f'{x:>{w}}' for x, w in zip(names, widths))} | med chi2/dof")
        for key in ("with", "without"):
            cells = " ".join(f"{'-':>{w}}" if not np.isfinite(x) else f"{x:{w}.2f}"
                             for x, w in zip(r[key]["ratio"], widths))
            print(f"  {key + ' stability':20} {cells} | {r[key]['chi2']:6.2f}")
    print(f"run time {time.perf_counter() - t0:.0f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="100 sessions per configuration, 50 discover runs")
    ap.add_argument("--sessions", type=int, default=None)
    ap.add_argument("--discover", type=int, default=None)
    ap.add_argument("--old-sem", action="store_true", help="the old per-step sem (s / sqrt(n)), for comparison")
    ap.add_argument("--full", type=int, default=0, help="also K full simulated-rig sessions (1 kHz / 184 Hz)")
    ap.add_argument("--gyro-mag", action="store_true", help="the gyroscope and magnetometer solvers instead")
    a = ap.parse_args()
    n = a.sessions or (100 if a.quick else 400)
    if a.gyro_mag:
        report_gyro_mag(a.sessions or (100 if a.quick else 300))
        return
    nd = a.discover if a.discover is not None else (50 if a.quick else 100)
    if a.old_sem:
        adapter.step_standard_errors = lambda blocks, floor: (np.array(
            [np.maximum(np.std(b, axis=0, ddof=1), floor) / np.sqrt(len(b)) for b in blocks]), None)
    t0 = time.perf_counter()
    print(f"six-position, MPU-9150 class, dlpf noise; {n} sessions per configuration; "
          f"machine: {os.cpu_count()} cores")
    head = " ".join(f"{p:>6}" for p in PARAMS)
    print(f"{'configuration':16} | observed/reported sigma: {head} | med chi2/dof | sigma within 25% "
          f"(some above / below) | discover FA")
    spreads = []
    for name, rate, bw in CONFIGS:
        r = run_config(rate, bw, n, nd if rate == 1000.0 else min(nd, 20))
        print(f"{name:16} | {'':25}{' '.join(f'{x:6.2f}' for x in r['ratio'])} | {r['chi2']:12.2f} | "
              f"{r['within']:7.0%} ({r['above']:4.0%} / {r['below']:4.0%}) | {r['alarms']}/{r['n_discover']}")
        spreads.append((name, r["spread"]))
    print("each session's reported / true sigma, 5th-95th percentile over sessions:")
    for name, (lo, hi) in spreads:
        for label, row in (("5 %", lo), ("95 %", hi)):
            print(f"{name:16} | {label:>24} {' '.join(f'{x:6.2f}' for x in row)}")
    if a.full:
        f = full_sessions(a.full)
        if f:
            print(f"full simulated rig, 1 kHz / 184 Hz, sim: {{noise: dlpf}}, {a.full} sessions: chi2/dof "
                  + ", ".join(f"{c:.2f}" for c in f["chi2"]))
    print(f"run time {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
