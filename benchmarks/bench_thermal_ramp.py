"""Thermal calibration without hold points (issue 16, item 6): chamber time of procedures/thermal_ramp.yaml
against procedures/thermal.yaml (the seed's six hold points) for the same sigma of the bias temperature
coefficients, on the same hidden sensors.

On the embedded simulated rig (rigs/sim.yaml in virtual time, the ``dlpf`` noise model: the chip's
low-pass filter, flicker bias instability and bias random walk; chamber time constant 120 s), with a
hidden thermal-gradient term switched on (``sim.effects.thermal_gradient``, g per C/s; ``--gradient 0``
switches it off), for hidden sensors drawn from seeds 1..N and ramp rates (C/min):

- hold: ``thermal.yaml`` run to the end. Its chamber time is the session clock at its last step. The sigma
  of its bias tempco c_j (counts/C) is given twice: as the shipped solve reports it (weighted least squares
  from the within-step scatter, ``reported``), and with the chip's bias wander between steps
  (``calib.accel.solve.wander_covariance``, generalised least squares: the ``honest`` sigma, the one the ramp
  solve reports).
- ramp: ``thermal_ramp.yaml`` at the rate (same range 27.6 -> 52.6 -> 27.6 C, six faces cycled, 10 s dwell)
  run to the end, then solved on the first k captures for k = 1.. (time order): the chamber time to reach
  the hold's sigma is the session clock at the end of the first capture k whose solve has every axis' c_j
  sigma at or below the hold's (honest against honest; and, in the last columns, both without the wander,
  as weighted least squares).
- z: (estimate - hidden truth) / sigma of c_j (and of the thermal-gradient term g_j) at the match and at
  the end of the ramp; hidden truth from sim_truth.yaml (``bias_tempco_g_per_c``,
  ``thermal_gradient_g_per_c_per_s``, times lsb_per_g).

Target (issue 16): ramp chamber time <= 40 % of the hold procedure's at the same sigma, with the coefficients
within 3 sigma of the truth.

Usage: python benchmarks/bench_thermal_ramp.py [--seeds N] [--rates 1 2 4] [--gradient GX GY GZ]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("RIG_HISTORY", str(Path(tempfile.mkdtemp(prefix="bench-ramp-")) / "history.sqlite"))

import calib  # noqa: E402
from calib.file import calibration as calfile  # noqa: E402
from calib.accel.solve import base_model, solve_gls, wander_covariance  # noqa: E402
from calib.numerics.design import SENSOR_AXES, Inputs, temp_term  # noqa: E402
from calib.errors import CalibError  # noqa: E402
from rig.session import load_session, step_means  # noqa: E402
from rig.workflow.run import run_procedure  # noqa: E402

HOLD_PROC = REPO / "procedures" / "thermal.yaml"
RAMP_PROC = REPO / "procedures" / "thermal_ramp.yaml"
SHIPPED_RATE = "rate_c_per_min: 4}"


def rig_variant(tmp: Path, gradient: list[float]) -> Path:
    """rigs/sim.yaml in virtual time on the dlpf noise model, with the hidden thermal gradient."""
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, noise="dlpf")
    if any(gradient):
        doc["sim"].setdefault("effects", {})["thermal_gradient"] = list(gradient)
    path = tmp / "sim-ramp.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def ramp_variant(tmp: Path, rate: float) -> Path:
    text = RAMP_PROC.read_text()
    assert text.count(SHIPPED_RATE) == 2, "thermal_ramp.yaml's legs are expected at 4 C/min"
    path = tmp / f"thermal_ramp-{rate:g}.yaml"
    path.write_text(text.replace(SHIPPED_RATE, f"rate_c_per_min: {rate:g}}}"))
    return path


def run(proc: Path, rig_file: Path, out: Path, seed: int) -> Path:
    return run_procedure(str(proc), rig_spec=str(rig_file), out_dir=out, seed=seed, time_scale=0).session_dir


def truth(session_dir: Path, lsb: float) -> tuple[np.ndarray, np.ndarray]:
    """Hidden bias tempco (counts/C) and thermal gradient (counts per C/s)."""
    t = yaml.safe_load((session_dir / "sim_truth.yaml").read_text())["accelerometer"]
    return (np.asarray(t["bias_tempco_g_per_c"], float) * lsb,
            np.asarray(t["thermal_gradient_g_per_c_per_s"], float) * lsb)


def hold_tempco_gls(steps) -> tuple[np.ndarray, np.ndarray]:
    """The hold session's bias tempco and its honest sigma: the shipped linear thermal model solved by
    generalised least squares with the bias wander between steps, counts/C."""
    lm, x = base_model("triangular"), Inputs.from_steps(steps)
    est, sig = np.zeros(3), np.zeros(3)
    for j, a in enumerate(SENSOR_AXES):
        lm = lm.with_terms(a, [temp_term(a, 1)])
        fit = solve_gls(lm.design(a, x), steps.mean_counts[:, j], wander_covariance(steps, steps.sem_counts[:, j]),
                        lm.names(a))
        i = fit.names.index(f"c1_{a}")
        est[j], sig[j] = fit.params[i], np.sqrt(fit.cov[i, i])
    return est, sig


def hold_row(seed: int, rig_file: Path, out: Path) -> dict:
    d = run(HOLD_PROC, rig_file, out, seed)
    session = load_session(d)
    steps = step_means(session)
    cal = calfile.read(d / "calibration.yaml").accelerometer
    c_true, _ = truth(d, steps.lsb_per_g)
    c_rep = np.asarray(cal.temperature.coefficients, float)[:, 0]
    s_rep = np.asarray(cal.sigma["temperature"]["coefficients"], float)[:, 0]
    c_gls, s_gls = hold_tempco_gls(steps)
    return {"seed": seed, "chamber_s": chamber_time_s(session), "sigma_reported": s_rep, "sigma": s_gls,
            "z_reported": (c_rep - c_true) / s_rep, "z": (c_gls - c_true) / s_gls}


def chamber_time_s(session) -> float:
    return max(s.stats.t_end_s for s in session.info.steps if s.stats is not None and s.stats.t_end_s is not None)


def thermal_terms(cal) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(c, sigma c) counts/C and (g, sigma g) counts per C/s of a ramp solve."""
    c = np.asarray(cal.temperature.coefficients, float)[:, 0]
    sc = np.asarray(cal.sigma["temperature"]["coefficients"], float)[:, 0]
    grad = next(e for e in cal.effects if e["name"] == "thermal_gradient")
    return c, sc, np.asarray(grad["estimate"], float) * cal.lsb_per_g, np.asarray(grad["sigma"], float) * cal.lsb_per_g


def first_match(steps, ends_s: np.ndarray, sigma_ref: np.ndarray, wander: bool):
    """The first prefix of the captures (time order) whose solve reaches ``sigma_ref`` on every axis:
    (chamber time s, its solve) or (None, None). Bisection on the prefix length (the sigmas shrink as
    captures are added)."""
    order = np.argsort(steps.t_s)
    if not wander:
        steps = dataclasses.replace(steps, bias_stability=None)

    def reached(k: int):
        try:
            cal = calib.solve(steps.subset(order[:k]), thermal=1)
        except CalibError:
            return None
        return cal if cal.temperature is not None and np.all(thermal_terms(cal)[1] <= sigma_ref) else None

    lo, hi = 11, len(order)  # reached(lo) is False (too few captures); find the least k that reaches it
    if reached(hi) is None:
        return None, None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if reached(mid) is not None else (mid, hi)
    return float(ends_s[order[hi - 1]]), reached(hi)


def ramp_row(seed: int, proc: Path, rig_file: Path, out: Path, hold: dict) -> dict:
    d = run(proc, rig_file, out, seed)
    session = load_session(d)
    idx = session.static_step_indices()
    steps = step_means(session, idx)
    ends = np.array([session.info.steps[i].stats.t_end_s for i in idx], float)
    c_true, g_true = truth(d, steps.lsb_per_g)
    full = calib.solve(steps, thermal=1)
    c, sc, g, sg = thermal_terms(full)
    row = {"seed": seed, "chamber_s": chamber_time_s(session), "sigma": sc, "z": (c - c_true) / sc,
           "z_g": (g - g_true) / sg}
    for key, wander, ref in (("gls", True, hold["sigma"]), ("wls", False, hold["sigma_reported"])):
        t_match, cal = first_match(steps, ends, ref, wander)
        row[f"match_{key}_s"] = t_match
        if cal is not None:
            cm, scm, gm, sgm = thermal_terms(cal)
            row[f"z_{key}"] = np.concatenate([(cm - c_true) / scm, (gm - g_true) / sgm])
    return row


def fmt_z(z) -> str:
    return "n/a" if z is None else f"{np.max(np.abs(z)):.1f}"


def pct(t, ref) -> str:
    return "not reached" if t is None else f"{t:6.0f} s {100 * t / ref:4.0f} %"


def print_tables(holds: list[dict], ramps: dict[float, list[dict]]) -> None:
    print("\nhold points (procedures/thermal.yaml): chamber time, sigma of c (counts/C, max over axes), max |z| of c")
    print("seed  chamber_s  sigma_reported  |z|_reported  sigma_honest  |z|_honest")
    for h in holds:
        print(f"{h['seed']:4d}  {h['chamber_s']:9.0f}  {np.max(h['sigma_reported']):14.4f}  {fmt_z(h['z_reported']):>12}"
              f"  {np.max(h['sigma']):12.4f}  {fmt_z(h['z']):>10}")
    for rate, rows in ramps.items():
        print(f"\nramp at {rate:g} C/min (procedures/thermal_ramp.yaml): whole run, then the chamber time to the hold's "
              "sigma (and % of the hold's chamber time)")
        print("seed  run_s  sigma_c  |z|c  |z|g   honest: to hold sigma     |z|c,g   white: to hold sigma     |z|c,g")
        for h, r in zip(holds, rows):
            print(f"{r['seed']:4d}  {r['chamber_s']:5.0f}  {np.max(r['sigma']):7.4f}  {fmt_z(r['z']):>4}  {fmt_z(r['z_g']):>4}"
                  f"   {pct(r['match_gls_s'], h['chamber_s']):>20}  {fmt_z(r.get('z_gls')):>7}"
                  f"   {pct(r['match_wls_s'], h['chamber_s']):>20}  {fmt_z(r.get('z_wls')):>7}")
        ratios = [r["match_gls_s"] / h["chamber_s"] for h, r in zip(holds, rows) if r["match_gls_s"] is not None]
        reached = len(ratios)
        print(f"  honest: reached by {reached} of {len(rows)} sensors" +
              (f", chamber time {100 * min(ratios):.0f}-{100 * max(ratios):.0f} % of the hold's (median "
               f"{100 * float(np.median(ratios)):.0f} %)" if ratios else ""))


def progress(row: dict, what: str) -> dict:
    """Say on stderr that a run is done (the tables come at the end)."""
    print(f"  {what}, seed {row['seed']}: chamber time {row['chamber_s']:.0f} s", file=sys.stderr, flush=True)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--rates", type=float, nargs="+", default=[1.0, 2.0, 4.0])
    ap.add_argument("--gradient", type=float, nargs=3, default=[2e-3, -2e-3, 3e-3],
                    help="hidden thermal gradient, g per C/s (0 0 0: off)")
    args = ap.parse_args()
    seeds = list(range(1, args.seeds + 1))
    t0 = time.perf_counter()
    print(f"machine: {platform.node()} {platform.machine()} {os.cpu_count()} cpus, Python {platform.python_version()}, "
          f"numpy {np.__version__}; rigs/sim.yaml in virtual time, noise dlpf, chamber tau 120 s; hidden sensors: "
          f"seeds {seeds[0]}..{seeds[-1]}; hidden thermal gradient {args.gradient} g/(C/s); rates {args.rates} C/min")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        rig_file = rig_variant(tmp, args.gradient)
        holds = [progress(hold_row(s, rig_file, tmp / "hold"), "hold") for s in seeds]
        ramps = {rate: [progress(ramp_row(s, ramp_variant(tmp, rate), rig_file, tmp / f"ramp{rate:g}", h),
                                 f"ramp {rate:g} C/min") for s, h in zip(seeds, holds)] for rate in args.rates}
        print_tables(holds, ramps)
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
