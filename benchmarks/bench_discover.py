"""Discrepancy workflow: detection rate, false alarms, smallest detectable magnitude, run time.

Usage::

    .venv/bin/python benchmarks/bench_discover.py [--seeds 20] [--clean 100] [--full 20]

Step-level simulation (the default, fast): one tumble26 session is recorded on the simulated rig
(virtual time) as the template of poses, temperatures, times, heating legs and per-step noise;
each trial draws a new datasheet-class sensor (``AccelErrorModel.draw``), hides one effect at the
stated magnitude, evaluates the simulator's own error equation at the template's steps and adds
Gaussian noise with the template's standard errors (scaled by sqrt(5 s / dwell)). ``--full N``
also runs N complete clean tumble26 sessions through the emulated turntable and sensor (about
20 s each) and counts their false alarms, to check the step-level shortcut.
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

from calib.data import StepMeans  # noqa: E402
from calib.discovery import discover  # noqa: E402
from drivers.sensors.sim.error_model import AccelErrorModel  # noqa: E402
from rig.analysis.discover import step_context  # noqa: E402
from rig.planning.kinematics import rot_x, rot_y  # noqa: E402
from rig.session import load_session  # noqa: E402

#: effect -> (pattern, stated magnitude); the hidden value is pattern * magnitude
EFFECTS = {
    "bias_tempco_quadratic": (np.ones(3), 3e-5),
    "scale_tempco": (np.ones(3), 2e-4),
    "scale_nonlinearity": (np.ones(3), 3e-3),
    "cross_axis_nonlinearity": (np.array([[0, 1, 0], [0, 0, -1], [1, 0, 0]], float), 3e-3),
    "full_misalignment": (np.array([1.0]), 0.3),  # deg, mounting rotation about sensor x
    "table_tilt": (np.array([1.0, -0.5]), 0.1),  # deg
    "bias_drift": (np.ones(3), 5e-7),
    "thermal_hysteresis": (np.ones(3), 1.5e-3),
}
FIELD = {"bias_tempco_quadratic": "bias_tempco2_g_per_c2", "scale_tempco": "scale_tempco_per_c",
         "scale_nonlinearity": "scale_nonlinearity", "cross_axis_nonlinearity": "cross_axis_nonlinearity",
         "bias_drift": "bias_drift_g_per_s", "thermal_hysteresis": "thermal_hysteresis_g"}


def record_template(tmp: Path, seed: int = 0) -> Path:
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    rig = tmp / "rig.yaml"
    rig.write_text(yaml.safe_dump(doc))
    out = tmp / f"template-{seed}"
    subprocess.run([sys.executable, "-m", "rig.cli", "run", str(REPO / "procedures" / "tumble26.yaml"), "--rig",
                    str(rig), "--out", str(out), "--seed", str(seed), "--quiet"], cwd=REPO, check=True,
                   capture_output=True)
    return next(out.iterdir())


class Template:
    def __init__(self, session_dir: Path) -> None:
        s = load_session(session_dir)
        idx = s.static_step_indices()
        self.steps = s.step_means(idx)
        self.ctx = step_context(s, idx)
        self.sem_g = self.steps.sem_counts / self.steps.lsb_per_g

    def trial(self, rng, effect: str | None, magnitude: float, dwell_s: float = 5.0):
        m = AccelErrorModel.draw(rng)
        f = np.asarray(self.steps.f_nominal_g, float)
        if effect in FIELD:
            pattern = EFFECTS[effect][0]
            setattr(m, FIELD[effect], (pattern * magnitude).tolist())
        elif effect == "full_misalignment":
            a = np.radians(magnitude)
            rot = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
            m.matrix = (np.asarray(m.matrix) @ rot).tolist()
        elif effect == "table_tilt":
            tx, ty = np.radians(EFFECTS[effect][0] * magnitude)
            g_base = (rot_x(np.array([tx]))[0] @ rot_y(np.array([ty]))[0]).T @ np.array([0, 0, 1.0])
            f = self.ctx.base_to_sensor @ g_base
        heating = self.ctx.heating if self.ctx.heating is not None else np.zeros(len(f))
        out = m.output_g(f, self.steps.temp_c, self.steps.t_s, heating)
        sem = self.sem_g * np.sqrt(5.0 / dwell_s)
        lsb = self.steps.lsb_per_g
        counts = (out + rng.normal(size=out.shape) * sem) * lsb
        steps = StepMeans(names=self.steps.names, f_nominal_g=self.steps.f_nominal_g, mean_counts=counts,
                          sem_counts=sem * lsb, n_samples=self.steps.n_samples, temp_c=self.steps.temp_c,
                          t_s=self.steps.t_s, lsb_per_g=lsb)
        return discover(steps, self.ctx)


def named(d, effect) -> bool:
    return effect in [e.name for e in d.effects]


def false_alarm(d) -> bool:
    return any(e.name != "bias_tempco" for e in d.effects)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--clean", type=int, default=100)
    ap.add_argument("--full", type=int, default=0, help="also run N full clean sessions on the simulated rig")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-discover-"))
    print("recording the template tumble26 session on the simulated rig ...", flush=True)
    t0 = time.perf_counter()
    session = record_template(tmp)
    print(f"  {time.perf_counter() - t0:.1f} s wall (virtual time)")
    tpl = Template(session)

    # run time of one discovery, end to end through the CLI (load + search + report)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "rig.cli", "discover", str(session), "--json"], cwd=REPO,
                       check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    for _ in range(20):
        discover(tpl.steps, tpl.ctx)
    search_ms = (time.perf_counter() - t0) / 20 * 1e3
    print(f"\none discovery on a tumble26 session ({len(tpl.steps)} steps): `rig discover --json` "
          f"{np.median(times):.2f} s median of 5 (target < 10 s); the search alone {search_ms:.0f} ms")

    print(f"\ndetection over {args.seeds} seeds at the stated magnitude (dwell 5 s):")
    print(f"| effect | magnitude | detected | named alone (+ bias_tempco) | within 3 sigma |")
    print("|---|---|---|---|---|")
    for effect, (pattern, mag) in EFFECTS.items():
        det = alone = within = 0
        for seed in range(args.seeds):
            d = tpl.trial(np.random.default_rng(1000 + seed), effect, mag)
            if named(d, effect):
                det += 1
                alone += set(e.name for e in d.effects) <= {effect, "bias_tempco"}
                e = next(e for e in d.effects if e.name == effect)
                truth = _truth(effect, pattern, mag)
                within += bool(np.all(np.abs(np.array(e.estimate) - truth) < 3 * np.array(e.sigma)))
        unit = {"full_misalignment": " deg", "table_tilt": " deg"}.get(effect, "")
        print(f"| {effect} | {mag:g}{unit} | {det}/{args.seeds} | {alone}/{args.seeds} | {within}/{det or 1} |")

    fa = sum(false_alarm(tpl.trial(np.random.default_rng(5000 + s), None, 0.0)) for s in range(args.clean))
    print(f"\nfalse alarms on {args.clean} clean step-level sessions: {fa}/{args.clean} "
          f"({100 * fa / args.clean:.1f} %, target <= 1 %)")

    print("\nsmallest magnitude detected in >= 95 % of seeds, against dwell time per step:")
    dwells = (2.0, 5.0, 20.0)
    print("| effect | " + " | ".join(f"dwell {d:g} s" for d in dwells) + " |")
    print("|---|" + "---|" * len(dwells))
    for effect, (pattern, mag) in EFFECTS.items():
        cells = []
        for dwell in dwells:
            found = None
            for factor in (0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0):
                m = mag * factor
                hits = sum(named(tpl.trial(np.random.default_rng(2000 + s), effect, m, dwell), effect)
                           for s in range(args.seeds))
                if hits >= 0.95 * args.seeds:
                    found = m
                    break
            cells.append(f"{found:.3g}" if found is not None else f"> {2 * mag:.3g}")
        print(f"| {effect} | " + " | ".join(cells) + " |")

    if args.full:
        print(f"\nfull simulated-rig check: {args.full} clean tumble26 sessions ...", flush=True)
        fa_full = 0
        for seed in range(args.full):
            s = record_template(tmp, seed=100 + seed)
            from rig.analysis.discover import discover_session
            _, d = discover_session(s)
            fa_full += false_alarm(d)
        print(f"false alarms on {args.full} full clean sessions: {fa_full}/{args.full}")


def _truth(effect, pattern, mag):
    if effect == "full_misalignment":
        return np.array([0.0, 0.0, np.tan(np.radians(mag))])
    return (np.asarray(pattern, float) * mag).ravel()


if __name__ == "__main__":
    main()
