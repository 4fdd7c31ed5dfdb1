"""Real recordings (../shared/datasets): every comparison of issue #8 in one table each.

Issue 32: the placement check on imucal's six parts (the default triangular pinv fit) reads x_a 1.41 deg,
x_p 1.26, y_p 0.66, y_a 0.58, z_a 0.51, z_p 0.50 deg against a noise of 0.009 deg: misplaced (hand-placed
faces), so ``rig solve`` refuses it without ``--trust-poses``.

Usage::  .venv/bin/python benchmarks/bench_real_data.py
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
DATA = REPO.parent / "shared" / "datasets"

from calib import solve  # noqa: E402
from calib.accel.placement import check_placement  # noqa: E402
from calib.accel.redundancy import pair_biases  # noqa: E402
from rig.analysis.discover import discover_session, format_report, write_plot  # noqa: E402
from rig.importers.recordings import import_recording  # noqa: E402
from rig.session import load_session  # noqa: E402


def main() -> None:
    tmp = Path(tempfile.mkdtemp(prefix="bench-real-"))
    t0 = time.perf_counter()
    paths = {
        "imucal": import_recording("imucal", DATA / "imucal" / "annotated_session.csv", tmp),
        "imu_tk": import_recording("imu_tk", DATA / "imu_tk-xsens" / "xsens_acc.txt", tmp),
        "tofupilot": import_recording("tofupilot", DATA / "tofupilot-thermal" / "imu_raw_data.csv", tmp),
    }
    print(f"imported 3 recordings in {time.perf_counter() - t0:.2f} s")
    for k, p in paths.items():
        s = load_session(p)
        st = s.info.to_dict()["steps"]
        print(f"  {k}: {len(s.samples['t_s'])} samples, {s.info.to_dict()['rig']['sensor']['sample_rate_hz']:g} Hz, "
              f"{len(st)} steps ({sum(x['kind'] == 'static' for x in st)} static) from {s.info.to_dict()['import']['steps_from']}")

    # imucal: our six-position solve vs imucal's own Ferraris calibration
    golden = json.loads((DATA / "imucal" / "example_cal.json").read_text())
    m_gold = np.asarray(golden["K_a"]) @ np.asarray(golden["R_a"]) * 9.81
    b_gold = np.asarray(golden["b_a"])
    steps = load_session(paths["imucal"]).step_means()
    full = solve(steps, model="full", thermal="off")
    tri = solve(steps, model="triangular", thermal="off")
    sm, sb = np.asarray(full.sigma["matrix_counts_per_g"]), np.asarray(full.sigma["bias_counts"])
    print("\n### imucal annotated session: our 12-parameter six-position solve vs imucal's example_cal.json")
    print("| quantity | imucal | ours (full) | sigma | diff / sigma | ours (triangular, seed) |")
    print("|---|---|---|---|---|---|")
    for j, a in enumerate("xyz"):
        print(f"| bias {a} (counts) | {b_gold[j]:.2f} | {full.bias_counts[j]:.2f} | {sb[j]:.2f} | "
              f"{(full.bias_counts[j] - b_gold[j]) / sb[j]:+.2f} | {tri.bias_counts[j]:.2f} |")
    for j, a in enumerate("xyz"):
        for k, c in enumerate("xyz"):
            tri_v = tri.matrix_counts_per_g[j, k]
            print(f"| M_{a}{c} (counts/g) | {m_gold[j, k]:.2f} | {full.matrix_counts_per_g[j, k]:.2f} | {sm[j, k]:.2f} | "
                  f"{(full.matrix_counts_per_g[j, k] - m_gold[j, k]) / sm[j, k]:+.2f} | {tri_v:.2f} |")
    print(f"(sigmas inflated by the misfit: chi2/dof {full.fit.chi2_per_dof:.0f}; residual "
          f"{full.fit.residual_rms_g * 1e3:.1f} mg rms)")
    r = pair_biases(steps)
    print("\n### six-pose redundancy check (imucal): bias from each +/- pose pair")
    print(r.format_table(steps.lsb_per_g))
    found = check_placement(tri, steps)
    print("\n### placement check (imucal, the default triangular pinv fit; rig solve refuses when misplaced)")
    print(f"misplaced: {found.misplaced}; {found.per_step()} (noise {float(np.median(found.noise_deg)):.3f} deg)")

    # Xsens: magnitude method vs datasheet
    s = load_session(paths["imu_tk"])
    st = s.step_means(s.static_step_indices(unknown_pose=True))
    t0 = time.perf_counter()
    cal = solve(st, method="magnitude")
    dt = time.perf_counter() - t0
    g = s.info.to_dict()["import"]["g_ms2"]
    sig_s = np.asarray(cal.sigma["scale_counts_per_g"]) / g
    print(f"\n### imu_tk Xsens recording: magnitude method ({len(st)} static intervals, {dt * 1e3:.0f} ms) vs datasheet")
    print("| axis | scale ours (counts per m/s^2) | datasheet | offset ours (counts) | datasheet |")
    print("|---|---|---|---|---|")
    for j, (ds, do) in enumerate(zip((415, 413, 415), (33123, 33276, 32360))):
        print(f"| {'xyz'[j]} | {cal.scale_counts_per_g[j] / g:.2f} +- {sig_s[j]:.2f} | {ds} | "
              f"{cal.bias_counts[j]:.1f} +- {cal.sigma['bias_counts'][j]:.1f} | {do} |")
    print("misalignment (mrad): " + ", ".join(f"{k} {v * 1e3:.2f}" for k, v in cal.misalignment.items())
          + f"; residual | |f| - 1 g | {cal.fit.residual_rms_g * 1e3:.2f} mg rms")

    # discover on real data
    for key in ("tofupilot", "imucal"):
        t0 = time.perf_counter()
        sess, d = discover_session(paths[key])
        dt = time.perf_counter() - t0
        png = tmp / f"discover-{key}.png"
        write_plot(d, png)
        print(f"\n### rig discover on {key} ({dt:.2f} s; plot {png})")
        print("| effect named | estimate | sigma | unit | rms after (mg) |")
        print("|---|---|---|---|---|")
        for e in d.effects:
            print(f"| {e.name} | {np.round(e.estimate, 8).tolist()} | {np.round(e.sigma, 8).tolist()} | {e.unit} | "
                  f"{e.rms_after_g * 1e3:.3f} |")
        if not d.effects:
            print("| nothing significant | | | | |")
        print(f"gap {d.rms_before_g * 1e3:.3f} -> {d.rms_after_g * 1e3:.3f} mg rms (noise {d.noise_rms_g * 1e3:.3f} mg),"
              f" chi2/dof {d.chi2_per_dof_before:.0f} -> {d.chi2_per_dof_after:.0f}; aliases {d.aliases}; "
              f"unobservable {d.unobservable}")
        print("\n".join(format_report(sess, d).splitlines()[2:8]))


if __name__ == "__main__":
    main()
