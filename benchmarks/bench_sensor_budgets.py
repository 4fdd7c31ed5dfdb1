"""Monte Carlo coverage of the gyroscope's and magnetometer's uncertainty budgets on simulated tables (issue 29;
docs/uncertainty.md, "The gyroscope", "The magnetometer").

Usage::

    .venv/bin/python benchmarks/bench_sensor_budgets.py [--trials 100] [--seed 0] [--sensor gyro|mag|both]
        [--rate-seconds 100] [--perfect-table]

Each trial draws another hidden table (``sim.geometry.table_seed``) and another hidden sensor (``--seed``), runs
``gyro_rates.yaml`` (its rate steps ``--rate-seconds`` long, 100 as shipped; shorter ones leave the gyroscope's own
Type A sigma too small even on a perfect table: 10 s steps cover its scales and nonorthogonalities in about half the
cases, a finding of this benchmark, not of the budget) and ``mag_eight_position.yaml`` on the simulated rig in
virtual time (in process, the command line's own entry point), and compares each calibration with the simulator's
hidden sensor (``sim_truth.yaml``: the sensor's own parameters, its frame the package's, not the table's). Per class,
the fraction of true values inside [estimate - U, estimate + U] (k = 2), and inside +-2 sigma (Type A alone).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from calib.file import calibration as calfile  # noqa: E402
from rig.cli.main import main  # noqa: E402


def _run(tmp: Path, procedure: Path, trial: int, seed: int, geometry: bool = True) -> Path:
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, transport="memory",
                      geometry={"table_seed": 1000 + seed * 10_000 + trial, "enabled": geometry})
    rig = tmp / f"rig-{trial}.yaml"
    rig.write_text(yaml.safe_dump(doc))
    out = tmp / f"{procedure.stem}-{trial}"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(["run", str(procedure), "--rig", str(rig), "--out", str(out), "--seed", str(seed * 10_000 + trial),
                     "--quiet"])
    if code != 0:
        raise SystemExit(f"trial {trial}: rig run {procedure.name} exited {code}")
    return next(out.iterdir())


def gyro_trial(session: Path) -> dict[str, list[tuple[float, float, float]]]:
    """{class: [(|error|, U, sigma)]} of one gyroscope calibration against its hidden sensor."""
    g = calfile.read(session / "calibration.yaml").gyroscope
    truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["gyroscope"]
    m_true = np.asarray(truth["matrix"]) * g.lsb_per_dps
    b_true = np.asarray(truth["bias_dps"]) * g.lsb_per_dps
    out: dict[str, list] = {"biases": [], "scales": [], "nonorthogonalities": []}
    for j, a in enumerate("xyz"):
        out["biases"].append((abs(g.bias_counts[j] - b_true[j]), g.uncertainty[f"b_{a}"], g.sigma[f"b_{a}"]))
        out["scales"].append((abs(g.matrix_counts_per_dps[j][j] - m_true[j, j]), g.uncertainty[f"k_{a}"],
                              g.sigma[f"k_{a}"]))
        for k, c in enumerate("xyz"):
            if j != k:
                n = f"m_{a}{c}"
                err = abs(g.nonorthogonality[n] - m_true[j, k] / g.matrix_counts_per_dps[j][j])
                out["nonorthogonalities"].append((err, g.uncertainty[n], g.sigma[n]))
    return out


def mag_trial(session: Path) -> dict[str, list[tuple[float, float, float]]]:
    """{class: [(|error|, U, sigma)]} of one magnetometer (positions) calibration against its hidden sensor."""
    m = calfile.read(session / "calibration.yaml").magnetometer
    truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["magnetometer"]
    a_true, b_true = np.asarray(truth["soft_iron"]), np.asarray(truth["hard_iron_ut"])
    out: dict[str, list] = {"hard iron": [], "A diagonal": [], "A off-diagonal": []}
    for i, r in enumerate("xyz"):
        n = f"hard_iron_{r}"
        out["hard iron"].append((abs(m.hard_iron_ut[i] - b_true[i]), m.uncertainty[n], m.sigma[n]))
        for j, c in enumerate("xyz"):
            n = f"a_{r}{c}"
            out["A diagonal" if i == j else "A off-diagonal"].append(
                (abs(m.matrix[i][j] - a_true[i, j]), m.uncertainty[n], m.sigma[n]))
    return out


def report(title: str, rows: dict[str, list]) -> None:
    print(f"\n### {title}\n")
    print("| class | values | inside U (k = 2) | inside 2 sigma (Type A) | median |err|/U | worst |err|/U |")
    print("|---|---|---|---|---|---|")
    for name, vals in rows.items():
        e, u, s = (np.array(x, float) for x in zip(*vals))
        print(f"| {name} | {len(e)} | {100 * np.mean(e <= u):.1f} % | {100 * np.mean(e <= 2 * s):.1f} % | "
              f"{np.median(e / u):.2f} | {np.max(e / u):.2f} |")


def main_() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sensor", choices=("gyro", "mag", "both"), default="both")
    ap.add_argument("--rate-seconds", type=float, default=100.0)
    ap.add_argument("--perfect-table", action="store_true", help="sim.geometry off: the Type A terms alone")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        os.environ["RIG_HISTORY"] = str(tmp / "history.sqlite")
        gyro_proc = tmp / "gyro_rates.yaml"
        gyro_proc.write_text((REPO / "procedures" / "gyro_rates.yaml").read_text()
                             .replace("seconds: 100", f"seconds: {args.rate_seconds:g}"))
        mag_proc = REPO / "procedures" / "mag_eight_position.yaml"
        gyro_rows: dict[str, list] = {}
        mag_rows: dict[str, list] = {}
        t0 = time.perf_counter()
        for trial in range(args.trials):
            if args.sensor in ("gyro", "both"):
                for k, v in gyro_trial(_run(tmp, gyro_proc, trial, args.seed, not args.perfect_table)).items():
                    gyro_rows.setdefault(k, []).extend(v)
            if args.sensor in ("mag", "both"):
                for k, v in mag_trial(_run(tmp, mag_proc, trial, args.seed, not args.perfect_table)).items():
                    mag_rows.setdefault(k, []).extend(v)
        print(f"{args.trials} trials (hidden tables and sensors), seed {args.seed}, {time.perf_counter() - t0:.0f} s")
        if gyro_rows:
            report(f"gyroscope, gyro_rates.yaml with {args.rate_seconds:g} s rate steps", gyro_rows)
        if mag_rows:
            report("magnetometer, mag_eight_position.yaml (positions)", mag_rows)


if __name__ == "__main__":
    main_()
