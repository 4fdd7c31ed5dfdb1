"""Do the reported uncertainties hold on realistic (DLPF + bias instability + random walk) noise? (issue 14, item 8)

Usage::

    .venv/bin/python benchmarks/bench_uncertainty.py [--quick] [--sessions N] [--full K]

Step-level Monte Carlo (the default, fast): a six-position session (gravity along +-X, +-Y, +-Z,
10 s per pose, 6 s between poses) of one MPU-9150-class sensor (error model drawn once, seed 14), +-4 g
(8192 counts/g). Each session's sample stream comes from the simulator's own ``dlpf`` noise model
(:class:`drivers.sensors.sim.noise.NoiseProcess`: white 400 ug/rtHz through the first-order DLPF,
40 ug bias instability, 4 ug/rts random walk; a fresh process per session), added to the error
model's output and rounded to counts; the session goes through the SAME adapter
(:func:`rig.session.adapter.step_means`) and solver (:func:`calib.solve`) as ``rig solve``, and
through :func:`calib.discovery.discover` as ``rig discover``. Per configuration: observed
scatter / reported sigma (median over sessions) for each of the nine parameters, the median
chi2/dof, the fraction of sessions whose every reported sigma is within 25 % of the observed scatter
(and of those outside, the share with some sigma above the band: the Birge rescale of a chance
significant misfit, or below it), each session's reported/true sigma at the 5th and 95th
percentile, and the discover false-alarm rate. The error of a session is its solution minus the noise-free
solution of the same sensor (the solver is linear in the step means, so that is exactly the noise's
part). ``--full K`` also records K clean six-position sessions on the simulated rig with
``sim: {noise: dlpf}`` (virtual time) at 1 kHz (the driver sets the 184 Hz filter there) and reports their chi2/dof.
"""

from __future__ import annotations

import argparse
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

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import calib  # noqa: E402
from calib.discovery import StepContext, discover  # noqa: E402
from calib.synthetic import six_faces  # noqa: E402
from drivers.sensors.sim.error_model import AccelErrorModel  # noqa: E402
from drivers.sensors.sim.noise import NoiseConfig, NoiseProcess, own_stream  # noqa: E402
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="100 sessions per configuration, 50 discover runs")
    ap.add_argument("--sessions", type=int, default=None)
    ap.add_argument("--discover", type=int, default=None)
    ap.add_argument("--old-sem", action="store_true", help="the old per-step sem (s / sqrt(n)), for comparison")
    ap.add_argument("--full", type=int, default=0, help="also K full simulated-rig sessions (1 kHz / 184 Hz)")
    a = ap.parse_args()
    n = a.sessions or (100 if a.quick else 400)
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
