"""Discrepancy workflow: detection rate, false alarms, smallest detectable magnitude, run time.

Usage::

    .venv/bin/python benchmarks/bench_discover.py [--seeds 20] [--clean 100] [--full 0] [--sessions 'GLOB']
        [--pvalues] [--no-mdm] [--no-run-time] [--designs a,b] [--effects a,b] [--templates T26 THERMAL]

**Sample-level simulation** (the default, fast): a template session fixes the design (poses, step
times and durations, temperatures, legs, rates, outer-axis angles, samples per step). Each trial
draws a datasheet-class sensor (``AccelErrorModel.draw``), hides an effect at the stated magnitude,
evaluates the simulator's own error equation at every step, and adds the simulator's own ``dlpf``
noise (``drivers.sensors.sim.noise.NoiseProcess``: white noise through the 44 Hz DLPF, flicker and
random walk of the MPU-9150 accelerometer, one continuous process over the whole session) to every
sample; the samples are quantised to counts and reduced to step means and standard errors exactly as
``rig.session.step_means`` does (pooled VIF). Only the turntable and the chamber are not simulated.

Designs: ``tumble26`` and ``thermal`` (templates recorded on the simulated rig, dlpf noise),
``tumble26_1khz`` (the tumble26 template at 1 kHz: ten times the samples per step), ``legs`` (the
issue's design: heating steps at 15, 27.6 and 40 C, cooling steps at 33 and 21 C, six faces each,
the first leg unknown) and ``ramps`` (faces repeated while the chamber heats and cools at up to
0.02 C/s, for ``thermal_gradient``).

**Full simulated rig**: ``--full N`` runs N clean sessions per recorded design through the emulated
turntable and sensor with ``noise: dlpf``; ``--sessions GLOB`` evaluates already-recorded session
directories instead (each glob match is a session's parent directory, as written by ``rig run --out``).
A false alarm is any effect named other than ``bias_tempco`` (which every drawn sensor has); the
verdict's false alarms (``gap_closed: false`` on a clean session) are counted separately.

**Calibration of the tests** (``--pvalues``): on the same clean sessions, each candidate's p-value
of the search's test against the baseline plus ``bias_tempco``
(:func:`calib.discovery.search.candidate_pvalues`), which is uniform when the test is calibrated: the table
gives the counts below 0.001, 0.01 and 0.05 and the Kolmogorov-Smirnov p-value against the uniform,
and how many sessions Bonferroni's family (the smallest p-value times the number of candidates) puts
below 0.01 (what forward selection can name: at most 1 % of sessions).
"""

from __future__ import annotations

import argparse
import glob
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy import stats

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from calib.accel.inputs import StepMeans  # noqa: E402
from calib.numerics.stability import BiasStability  # noqa: E402
from calib.discovery.search import StepContext, candidate_pvalues, discover  # noqa: E402
from calib.discovery.effects import heating_state  # noqa: E402
from calib.numerics.uncertainty import step_standard_errors  # noqa: E402
from drivers.sensors.chips import CHIPS  # noqa: E402
from drivers.sensors.sim.error_model import AccelErrorModel  # noqa: E402
from drivers.sensors.sim.noise import NoiseProcess  # noqa: E402
from rig.analysis.discover import discover_session, step_context  # noqa: E402
from rig.session import load_session, step_means  # noqa: E402

BANDWIDTH_HZ = 44.0
LSB = 8192.0
CHIP = CHIPS["MPU-9150"]
STABILITY = BiasStability(CHIP.accel_bias_instability_g, CHIP.accel_random_walk_g_per_rts, CHIP.accel_flicker_corner_s)

#: (effect, design) -> (error-model field, pattern, stated magnitude); hidden value = pattern * magnitude
CELLS = {
    ("bias_tempco_cubic", "thermal"): ("bias_tempco3_g_per_c3", [1, -1, 1], 2e-7),
    ("bias_tempco_cubic", "legs"): ("bias_tempco3_g_per_c3", [1, -1, 1], 2e-6),
    ("thermal_gradient", "ramps"): ("thermal_gradient_g_per_c_per_s", [1, -1, 1], 0.05),
    ("bias_jump", "tumble26"): ("bias_jump_g", [1, -1, 1], 1e-3),
    ("bias_jump", "thermal"): ("bias_jump_g", [1, -1, 1], 1e-3),
    ("thermal_hysteresis", "legs"): ("thermal_hysteresis_g", [1, 1, -1], 1.5e-3),
    ("thermal_hysteresis", "tumble26"): ("thermal_hysteresis_g", [1, 1, -1], 1.5e-3),
    ("bias_drift", "tumble26"): ("bias_drift_g_per_s", [1, 1, 1], 5e-7),
    ("scale_tempco", "tumble26"): ("scale_tempco_per_c", [1, 1, 1], 2e-4),
    ("scale_nonlinearity", "tumble26"): ("scale_nonlinearity", [1, 1, 1], 3e-3),
}
FACTORS = (0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0)


class Design:
    """What a trial needs of a session: poses, times, durations, temperatures, legs, rates, angles."""

    def __init__(self, f, temp, t_mid, dur, n, heating, rate, angles, names=None) -> None:
        self.f, self.temp, self.t_mid, self.dur, self.n = f, temp, t_mid, dur, np.asarray(n, int)
        self.heating, self.rate, self.angles = heating, rate, angles
        self.names = names if names is not None else tuple(f"s{i}" for i in range(len(f)))

    @classmethod
    def from_session(cls, path, rate_factor: int = 1) -> "Design":
        s = load_session(path)
        idx = s.static_step_indices()
        st, ctx = step_means(s, idx), step_context(s, idx)
        k = len(st)
        return cls(np.asarray(st.f_nominal_g, float), np.asarray(st.temp_c, float), np.asarray(st.t_s, float),
                   st.duration_s, np.asarray(st.n_samples) * rate_factor, ctx.heating,
                   ctx.temp_rate if ctx.temp_rate is not None else np.zeros(k), ctx.angles_deg, st.names)

    def session(self, rng, field=None, value=None, jump_t_s=None):
        """(step means, context, drawn error model) of one simulated session with ``field`` = ``value`` hidden."""
        m = AccelErrorModel.draw(rng)
        m.t_ref_c = float(np.mean(self.temp))
        if field:
            setattr(m, field, list(value))
        if jump_t_s is not None:
            m.bias_jump_t_s = jump_t_s
        out = m.output_g(self.f, self.temp, self.t_mid, self.heating, self.rate)
        proc = NoiseProcess([STABILITY.bias_instability] * 3, [STABILITY.random_walk_per_rts] * 3,
                            np.random.default_rng(rng.integers(2**62)), flicker_band_s=(0.02, CHIP.accel_flicker_corner_s))
        times = [np.linspace(t - d / 2, t + d / 2, n) for t, d, n in zip(self.t_mid, self.dur, self.n)]
        noise = proc.sample(np.concatenate(times), np.asarray(m.noise_density_g_per_rthz, float), BANDWIDTH_HZ)
        blocks = np.split(np.round((np.repeat(out, self.n, axis=0) + noise) * LSB), np.cumsum(self.n)[:-1])
        sems, _ = step_standard_errors(blocks, 1 / np.sqrt(12.0))
        steps = StepMeans(names=self.names, f_nominal_g=self.f, mean_counts=np.array([b.mean(axis=0) for b in blocks]),
                          sem_counts=sems, n_samples=self.n, temp_c=self.temp, t_s=self.t_mid, lsb_per_g=LSB,
                          bias_stability=STABILITY, duration_s=self.dur)
        ctx = StepContext(heating=self.heating, temp_rate=self.rate, angles_deg=self.angles)
        return steps, ctx, m

    def trial(self, rng, field=None, value=None, jump_t_s=None):
        """Discover on one simulated session of this design with ``field`` = ``value`` hidden."""
        steps, ctx, m = self.session(rng, field, value, jump_t_s)
        return discover(steps, ctx), m


def legs_design() -> Design:
    faces = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    levels = (15.0, 27.6, 40.0, 33.0, 21.0)
    f = np.tile(faces, (len(levels), 1))
    k = len(f)
    temp = np.repeat(levels, 6) + 0.02 * np.random.default_rng(0).standard_normal(k)
    t = 300.0 + np.arange(k) * 30.0 + np.repeat(np.arange(len(levels)) * 900.0, 6)
    return Design(f, temp, t, np.full(k, 5.0), np.full(k, 500), heating_state(temp, 0.5), np.zeros(k),
                  np.zeros((k, 3)))


def ramps_design(reps: int = 10) -> Design:
    faces = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.tile(faces, (reps, 1))
    k = len(f)
    t = 60.0 + np.arange(k) * 20.0
    rate = 0.02 * np.sin(2 * np.pi * t / (k * 20.0 / 2.3))
    temp = 25.0 + np.cumsum(rate) * 20.0
    return Design(f, temp, t, np.full(k, 5.0), np.full(k, 500), heating_state(temp, 0.5), rate, np.zeros((k, 3)))


def record(tmp: Path, procedure: str, seed: int, noise: str = "dlpf") -> Path:
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["noise"] = noise
    rig = tmp / "rig.yaml"
    rig.write_text(yaml.safe_dump(doc))
    out = tmp / f"{Path(procedure).stem}-{seed}"
    subprocess.run([sys.executable, "-m", "rig.cli", "run", str(REPO / "procedures" / procedure), "--rig", str(rig),
                    "--out", str(out), "--seed", str(seed), "--quiet"], cwd=REPO, check=True, capture_output=True)
    return next(p for p in out.iterdir() if p.is_dir())


def spurious(d) -> bool:
    return any(e.name != "bias_tempco" for e in d.effects)


def detection(design: Design, cell, factor: float, seeds: int, base_seed: int = 1000) -> tuple[int, int, int]:
    """(named, named alone (+ bias_tempco), within 3 sigma) over ``seeds`` trials at ``factor`` x the magnitude."""
    effect, _ = cell
    field, pattern, mag = CELLS[cell]
    value = np.asarray(pattern, float) * mag * factor
    jump_t = float(np.median(design.t_mid)) + 7.0 if effect == "bias_jump" else None
    det = alone = within = 0
    for s in range(seeds):
        d, _ = design.trial(np.random.default_rng(base_seed + s), field, value, jump_t)
        names = [e.name for e in d.effects]
        if effect in names:
            det += 1
            alone += set(names) <= {effect, "bias_tempco"}
            e = d.effects[names.index(effect)]
            within += bool(np.all(np.abs(np.array(e.estimate) - value) < 3 * np.array(e.sigma)))
    return det, alone, within


def smallest_detected(design: Design, cell, seeds: int) -> float | None:
    """Smallest magnitude on the FACTORS grid named in >= 95 % of ``seeds`` (bisection; monotone assumed)."""
    lo, hi = 0, len(FACTORS) - 1
    if detection(design, cell, FACTORS[hi], seeds, 2000)[0] < 0.95 * seeds:
        return None
    while lo < hi:
        mid = (lo + hi) // 2
        if detection(design, cell, FACTORS[mid], seeds, 2000)[0] >= 0.95 * seeds:
            hi = mid
        else:
            lo = mid + 1
    return FACTORS[lo] * CELLS[cell][2]


def clean_rates(design: Design, n: int) -> tuple[int, int, float]:
    """(spurious names, verdict false alarms, mean chi2/dof after) over ``n`` clean trials."""
    fa = gap = 0
    chi = []
    for s in range(n):
        d, _ = design.trial(np.random.default_rng(5000 + s))
        fa += spurious(d)
        gap += not d.gap_closed
        chi.append(d.chi2_per_dof_after)
    return fa, gap, float(np.mean(chi))


def full_rig(paths) -> tuple[int, int, int, list]:
    """(sessions, spurious names, verdict false alarms, names) over recorded clean sessions."""
    fa = gap = 0
    names = []
    for p in paths:
        _, d = discover_session(p)
        fa += spurious(d)
        gap += not d.gap_closed
        if spurious(d):
            names.append([e.name for e in d.effects])
    return len(paths), fa, gap, names


def session_pvalues(paths) -> list[dict]:
    """Per recorded clean session: each candidate's p-value against the baseline plus the real bias_tempco."""
    out = []
    for p in paths:
        s = load_session(p)
        idx = s.static_step_indices()
        out.append(candidate_pvalues(step_means(s, idx), step_context(s, idx)))
    return out


def clean_pvalues(design: Design, n: int) -> list[dict]:
    """The same over ``n`` clean sample-level trials of ``design`` (the seeds of :func:`clean_rates`)."""
    return [candidate_pvalues(*design.session(np.random.default_rng(5000 + s))[:2]) for s in range(n)]


def pvalue_lines(rows: list[dict], label: str) -> list[str]:
    """Markdown rows: per candidate, how many p-values fall below 0.001, 0.01 and 0.05 (uniform under a
    calibrated test: n times that), and the Kolmogorov-Smirnov p-value against the uniform; then the
    sessions whose smallest p-value times the number of candidates is below 0.01 (Bonferroni's family)."""
    lines = []
    for name in sorted({k for r in rows for k in r}):
        p = np.array([r[name] for r in rows if name in r])
        ks = stats.kstest(p, "uniform").pvalue
        lines.append(f"| {label} | {name} | {len(p)} | {(p < 0.001).sum()} | {(p < 0.01).sum()} | {(p < 0.05).sum()} | "
                     f"{ks:.2g} |")
    fam = sum(min(r.values()) * len(r) < 0.01 for r in rows if r)
    lines.append(f"| {label} | (family: min p x candidates < 0.01) | {len(rows)} | | {fam} | | |")
    return lines


def run_time(session: Path) -> tuple[float, float, int]:
    """(CLI seconds, search seconds, steps) of one discovery on ``session`` twice over (156 steps)."""
    s = load_session(session)
    idx = s.static_step_indices()
    st, ctx = step_means(s, idx), step_context(s, idx)
    span = float(np.ptp(st.t_s)) + 60.0
    both = StepMeans(names=st.names * 2, f_nominal_g=np.vstack([st.f_nominal_g] * 2),
                     mean_counts=np.vstack([st.mean_counts] * 2), sem_counts=np.vstack([st.sem_counts] * 2),
                     n_samples=np.concatenate([st.n_samples] * 2), temp_c=np.concatenate([st.temp_c] * 2),
                     t_s=np.concatenate([st.t_s, st.t_s + span]), lsb_per_g=st.lsb_per_g,
                     bias_stability=st.bias_stability, duration_s=np.concatenate([st.duration_s] * 2))
    ctx2 = StepContext(heating=np.concatenate([ctx.heating] * 2), base_to_sensor=np.concatenate([ctx.base_to_sensor] * 2),
                       temp_rate=np.concatenate([ctx.temp_rate] * 2),
                       angles_deg=np.concatenate([ctx.angles_deg] * 2))
    t0 = time.perf_counter()
    discover(both, ctx2)
    search = time.perf_counter() - t0
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "rig.cli", "discover", str(session), "--json"], cwd=REPO, check=True,
                   capture_output=True)
    return time.perf_counter() - t0, search, len(both)


def print_run_time(template: Path) -> None:
    cli_s, search_s, k = run_time(template)
    print(f"\nrun time: the search on a {k}-step session (tumble26 twice over) {search_s:.2f} s; "
          f"`rig discover --json` on the 78-step session end to end {cli_s:.2f} s (target < 10 s)")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--clean", type=int, default=100)
    ap.add_argument("--full", type=int, default=0, help="run N full clean dlpf sessions per recorded design")
    ap.add_argument("--sessions", action="append", default=[], help="glob of recorded clean session dirs")
    ap.add_argument("--no-mdm", action="store_true", help="skip the smallest-detected-magnitude search")
    ap.add_argument("--designs", default=None, help="comma-separated designs for the clean runs (default: all)")
    ap.add_argument("--effects", default=None, help="comma-separated effects for the detection runs (default: all)")
    ap.add_argument("--pvalues", action="store_true",
                    help="report each candidate's null p-values (calibration: uniform) on the clean sessions")
    ap.add_argument("--no-run-time", action="store_true", help="skip the run-time measurement")
    ap.add_argument("--templates", nargs=2, default=None, metavar=("TUMBLE26", "THERMAL"),
                    help="recorded dlpf sessions to use as templates instead of recording them")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-discover-"))
    if args.templates:
        templates = dict(zip(("tumble26", "thermal"), map(Path, args.templates)))
    else:
        print("recording the templates (tumble26, thermal) on the simulated rig, dlpf noise ...", flush=True)
        templates = {p: record(tmp, f"{p}.yaml", 1) for p in ("tumble26", "thermal")}
    designs = {"tumble26": Design.from_session(templates["tumble26"]),
               "tumble26_1khz": Design.from_session(templates["tumble26"], rate_factor=10),
               "thermal": Design.from_session(templates["thermal"]), "legs": legs_design(), "ramps": ramps_design()}

    if not args.no_run_time:
        print_run_time(templates["tumble26"])
    PVALUE_HEAD = ("| sessions | candidate | n | p < 0.001 | p < 0.01 | p < 0.05 | KS p (uniform) |\n"
                   "|---|---|---|---|---|---|---|")
    pv_rows: list[str] = []

    print(f"\nclean sessions, sample-level dlpf simulation ({args.clean} per design):")
    print("| design | steps | spurious names | gap_closed false | mean chi2/dof after |\n|---|---|---|---|---|")
    for name, des in designs.items():
        if args.designs and name not in args.designs.split(","):
            continue
        fa, gap, chi = clean_rates(des, args.clean)
        print(f"| {name} | {len(des.f)} | {fa}/{args.clean} | {gap}/{args.clean} | {chi:.3f} |", flush=True)
        if args.pvalues:
            pv_rows += pvalue_lines(clean_pvalues(des, args.clean), f"{name} (sample level)")

    print(f"\ndetection over {args.seeds} seeds at the stated magnitude (pattern x magnitude per axis):")
    print("| effect | design | magnitude | named | named alone (+ bias_tempco) | within 3 sigma | "
          "smallest named in >= 95 % |\n|---|---|---|---|---|---|---|")
    for cell, (field, pattern, mag) in CELLS.items():
        if args.effects and cell[0] not in args.effects.split(","):
            continue
        det, alone, within = detection(designs[cell[1]], cell, 1.0, args.seeds)
        mdm = "-" if args.no_mdm else smallest_detected(designs[cell[1]], cell, args.seeds)
        mdm = mdm if isinstance(mdm, str) else (f"{mdm:.3g}" if mdm is not None else f"> {FACTORS[-1] * mag:.3g}")
        print(f"| {cell[0]} | {cell[1]} | {mag:g} | {det}/{args.seeds} | {alone}/{args.seeds} | {within}/{det or 1} | "
              f"{mdm} |", flush=True)

    paths = {}
    for pattern in args.sessions:
        for p in sorted(glob.glob(pattern)):
            inner = [q for q in Path(p).iterdir() if q.is_dir() and (q / "session.yaml").exists()]
            if inner:
                paths.setdefault(Path(p).parent.name, []).append(inner[0])
    for seed in range(args.full):
        for proc in ("tumble26", "thermal", "six_position", "thermal_ramp"):
            paths.setdefault(proc, []).append(record(tmp, f"{proc}.yaml", 100 + seed))
    if paths:
        print("\nclean full simulated-rig sessions (dlpf noise):")
        print("| design | sessions | spurious names | gap_closed false | spurious |\n|---|---|---|---|---|")
        for name, ps in paths.items():
            n, fa, gap, names = full_rig(ps)
            print(f"| {name} | {n} | {fa}/{n} | {gap}/{n} | {names} |", flush=True)
            if args.pvalues:
                pv_rows += pvalue_lines(session_pvalues(ps), f"{name} (full rig)")
    if pv_rows:
        print("\nnull p-values of each candidate against the baseline + bias_tempco (calibrated: uniform; "
              "bias_jump's is Bonferroni over the jump times, conservative):")
        print(PVALUE_HEAD)
        print("\n".join(pv_rows))


if __name__ == "__main__":
    main()
