"""Gyroscope rate table and magnetometer: recovered vs true parameters, residuals, run times.

Usage::

    .venv/bin/python benchmarks/bench_gyro_mag.py [--time-scale 10] [--seed 4]

Runs the shipped procedures on the simulated rig (gyro_rates twice: with the simulator's gyro
g-sensitivity switched off, and as drawn), compares each calibration with the simulator's hidden
truth (``sim_truth.yaml``) and reports residuals after calibration. Run time: wall time at
``--time-scale`` K times real time, times K, is the duration at real-time stage speeds (the
simulated clock is scaled exactly); the session's own time span is shown too.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from calib.file import calibration as calfile  # noqa: E402
from calib.gyro import GyroCalibration  # noqa: E402
from calib.mag import MagCalibration  # noqa: E402
from rig.session import load_session, mag_step_means, rate_step_means  # noqa: E402


def run(tmp: Path, procedure: str, seed: int, time_scale: float, sim_extra: dict | None = None) -> tuple[Path, float]:
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = time_scale
    doc["sim"].update(sim_extra or {})
    rig = tmp / f"rig-{procedure}-{len(list(tmp.iterdir()))}.yaml"
    rig.write_text(yaml.safe_dump(doc))
    out = tmp / rig.stem
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "rig.cli", "run", str(REPO / "procedures" / f"{procedure}.yaml"), "--rig",
                    str(rig), "--out", str(out), "--seed", str(seed), "--quiet"], cwd=REPO, check=True,
                   capture_output=True)
    return next(out.iterdir()), time.perf_counter() - t0


def span_s(session: Path) -> float:
    t = load_session(session).samples["t_s"]
    return float(t.max())


def gyro_report(session: Path, label: str) -> None:
    g = GyroCalibration.from_dict(calfile.read(session / "calibration.yaml").gyroscope)
    truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["gyroscope"]
    lsb = g.lsb_per_dps
    m_true = np.asarray(truth["matrix"])
    b_true = np.asarray(truth["bias_dps"])
    print(f"\n### gyroscope, {label}: chi2/dof {g.chi2_per_dof:.2f}")
    print("| parameter | true | recovered | sigma | (rec - true) / sigma |")
    print("|---|---|---|---|---|")
    for j, a in enumerate("xyz"):
        est, sig = g.bias_counts[j] / lsb, g.sigma[f"b_{a}"] / lsb
        print(f"| bias {a} (deg/s) | {b_true[j]:.4f} | {est:.5f} | {sig:.1e} | {(est - b_true[j]) / sig:+.1f} |")
    for j, a in enumerate("xyz"):
        est, sig = g.matrix_counts_per_dps[j][j] / lsb, g.sigma[f"k_{a}"] / lsb
        print(f"| scale {a} | {m_true[j, j]:.5f} | {est:.6f} | {sig:.1e} | {(est - m_true[j, j]) / sig:+.1f} |")
    for j, a in enumerate("xyz"):
        for k, c in enumerate("xyz"):
            if j != k:
                t = m_true[j, k] / m_true[j, j]
                est, sig = g.nonorthogonality[f"m_{a}{c}"], g.sigma[f"m_{a}{c}"]
                print(f"| m_{a}{c} | {t:+.5f} | {est:+.6f} | {sig:.1e} | {(est - t) / sig:+.1f} |")
    pairs = np.array([p.bias_counts for p in g.bias_pairs]) / lsb
    print(f"+/- pair biases (deg/s), mean over pairs: {np.round(pairs.mean(axis=0), 4).tolist()}, "
          f"true {np.round(b_true, 4).tolist()}")
    accel = calfile.read(session / "calibration.yaml").accelerometer
    rs = rate_step_means(load_session(session), accel)
    raw = rs.mean_counts / lsb
    cal = g.apply(rs.mean_counts, f_g=rs.f_mean_g)
    if g.g_sensitivity:
        gm = g.g_matrix() / lsb
        gt = np.asarray(truth["g_sensitivity_dps_per_g"])
        gs = np.asarray(g.g_sensitivity["sigma_counts_per_g"]) / lsb
        for k in ("xyz".index(i) for i in g.g_sensitivity["inputs"]):
            print(f"g-sensitivity column {'xyz'[k]} (deg/s/g): true {np.round(gt[:, k], 4).tolist()}, recovered "
                  f"{np.round(gm[:, k], 4).tolist()} +- {np.round(gs[:, k], 4).tolist()}")
    print(f"rate error over the 18 modes, RMS: raw {np.sqrt(np.mean((raw - rs.rate_nominal_dps) ** 2)):.3f} deg/s -> "
          f"calibrated {np.sqrt(np.mean((cal - rs.rate_nominal_dps) ** 2)):.4f} deg/s")


def mag_report(session: Path, label: str) -> None:
    m = MagCalibration.from_dict(calfile.read(session / "calibration.yaml").magnetometer)
    truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["magnetometer"]
    print(f"\n### magnetometer, {label} ({m.method}): residual {m.residual_rms_ut:.3f} uT rms, "
          f"chi2/dof {m.chi2_per_dof:.2f}" + (f", fit quality {m.fit_quality:.3f} uT" if m.fit_quality is not None else ""))
    print("| parameter | true | recovered | sigma | (rec - true) / sigma |")
    print("|---|---|---|---|---|")
    for j, a in enumerate("xyz"):
        t, est, sig = truth["hard_iron_ut"][j], m.hard_iron_ut[j], m.sigma[f"hard_iron_{a}"]
        print(f"| hard iron {a} (uT) | {t:.3f} | {est:.3f} | {sig:.3f} | {(est - t) / sig:+.1f} |")
    if m.method == "positions":
        for j, a in enumerate("xyz"):
            for k, c in enumerate("xyz"):
                t, est, sig = truth["soft_iron"][j][k], np.asarray(m.matrix)[j, k], m.sigma[f"a_{a}{c}"]
                print(f"| A_{a}{c} | {t:+.5f} | {est:+.6f} | {sig:.1e} | {(est - t) / sig:+.1f} |")
    ms = mag_step_means(load_session(session))
    field = 50.0
    raw = np.linalg.norm(ms.mean_ut, axis=1) - field
    cal = np.linalg.norm(m.apply(ms.mean_ut), axis=1) - field
    line = f"|field| - 50 uT over the steps, RMS: raw {np.sqrt(np.mean(raw ** 2)):.2f} uT -> calibrated " \
           f"{np.sqrt(np.mean(cal ** 2)):.3f} uT"
    if ms.field_nominal_ut is not None and m.method == "positions":
        vec = m.apply(ms.mean_ut) - ms.field_nominal_ut
        line += f"; vector error RMS {np.sqrt(np.mean(vec ** 2)):.3f} uT (raw " \
                f"{np.sqrt(np.mean((ms.mean_ut - ms.field_nominal_ut) ** 2)):.2f} uT)"
    print(line)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--time-scale", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=4)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-gyromag-"))
    k = args.time_scale
    times = {}
    s, wall = run(tmp, "gyro_rates", args.seed, k, {"gyro_errors": {"g_sensitivity_dps_per_g": 0.0}})
    times["gyro_rates"] = (wall, span_s(s))
    gyro_report(s, "simulator's g-sensitivity off")
    s2, _ = run(tmp, "gyro_rates", args.seed, 0)
    gyro_report(s2, "g-sensitivity as drawn (0.05 deg/s/g class)")
    s3, wall = run(tmp, "mag_eight_position", args.seed, k)
    times["mag_eight_position"] = (wall, span_s(s3))
    mag_report(s3, "eight positions")
    s4, wall = run(tmp, "mag_tumble", args.seed, k)
    times["mag_tumble"] = (wall, span_s(s4))
    mag_report(s4, "tumble, 26 orientations")
    print(f"\n### run time at real-time stage speeds (measured at time scale {k:g})")
    print("| procedure | wall at x%g | = real time | session time span |" % k)
    print("|---|---|---|---|")
    for name, (wall, span) in times.items():
        print(f"| {name} | {wall:.1f} s | {wall * k / 60:.1f} min | {span / 60:.1f} min |")


if __name__ == "__main__":
    main()
