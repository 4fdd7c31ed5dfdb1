"""Does the target stopping rule's 95 % bound hold for units unlike their family, after characterisation? (issue 28)

Target (issue 28): after characterisation, the accuracy-target stopping rule's 95 % bound covers 93-97 % of
units whose hidden N, B, K differ from the family figures by factors 0.5-2.

Each unit: the embedded simulated rig (virtual time) with ``sim: noise_spread: {white: [0.5, 2],
bias_instability: [0.5, 2], random_walk: [0.5, 2]}`` (docs/noise.md; every axis its own factors), hidden sensor
seed N, the accuracy-targeted ``procedures/six_position_rapid.yaml`` (0.03 deg at 95 %), run two ways:

- ``family``: no noise profile: the stopping rule predicts with the MPU-9150 family's figures;
- ``profile``: after characterisation: the unit's noise profile (rig-noise/1) recorded under its sensor key in
  the run's history before the run, so the run predicts with the unit's figures from its preflight on
  (rig.workflow.run.use_unit_noise) and the solve weighs the wander with them. The profile is the fit of
  ``rig characterize`` (calib.noise.fit) to a 2-hour 100 Hz static record of the unit's accelerometer drawn from
  the simulator's own noise process (drivers.sensors.sim.noise.NoiseProcess with the unit's hidden bias
  instability, random walk, white density and flicker band, read from the first run's sim_truth.yaml; a stream
  of its own, so the record is not the session's noise), as bench_unit_noise.py characterises.

Per unit and way: the stopping rule's predicted 95 % bound on the attitude error (its ``target`` event) and the
calibration's true error (bench_rapid.true_error_deg: the largest |roll|/|pitch| error at the seed's seven
verification poses against the hidden sensor, noise-free). Coverage: the share of units whose true error is
within the bound (an honest bound: 95 %; with n units its binomial spread is about sqrt(0.05 x 0.95 / n)). A unit
whose noise puts the target out of reach within the procedure's ``max_seconds`` is refused (before anything moves
when its profile says so, or at the first pose from the noise measured there): it has no bound, and is counted
apart; a unit the family's run refuses is not run with its profile either.

    python benchmarks/bench_target_coverage.py [--units 100] [--seed 1] [--ways family,profile]

Re-measured 2026-11-26 09:40-09:55 on the quiet machine with the fit from 0.6 s (``--ways profile``; ``--units 100
--seed 1`` 414 s, ``--units 60 --seed 101`` 252 s): the unit's profile covers 94 of 96 runs (98 %) and 57 of 59
(97 %): 151 of 155 (97.4 %, binomial +-1.8 %), at the upper edge of 93-97 %; 5 units refused (4, 24, 61, 88, 160).

Measured 2026-11-26 on the shared 2-core machine (load 8-10; ``--units 60 --seed 1`` in two parts, ``--units 40
--seed 61``, ``--units 40 --seed 101``: 9-14 min per 40 units; the profiles fitted from 0.1 s, before
calib.noise.fit.FIT_TAU_MIN_S became 0.6 s):

==========  ==============================  ===========================================================
way         true error within the bound     refused (out of reach within max_seconds)
==========  ==============================  ===========================================================
family      131 of 140 runs (94 %)          none
profile     131 of 136 runs (96 %)          4 of 140: unit 4 before moving, 24, 61 and 88 at the first
                                            pose; their family runs met their (family) bounds
==========  ==============================  ===========================================================

Per batch (units 1-60, 61-100, 101-140): family 95 / 90 / 95 %, profile 98 / 97 / 93 %. Target (93-97 %):
met with the profile on these 140 units (96 % +- 2 %); the family's bound also covers 94 % here: on this short
procedure (about 47 s of rig time) the wander adds little to the prediction (docs/methods.md: 1-4 % of the
variances for the rapid layout), so the profile changes the bound by little; what it changes is that a unit
whose own wander puts the target out of reach is refused.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
HISTORY_DIR = Path(tempfile.mkdtemp(prefix="bench-target-coverage-"))
os.environ["RIG_HISTORY"] = str(HISTORY_DIR / "history.sqlite")  # never the user's history

from bench_rapid import RAPID_PROC, predicted_deg, run, true_error_deg  # noqa: E402
from calib.noise.allan import allan_curve  # noqa: E402
from calib.noise.fit import fit_terms  # noqa: E402
from drivers.sensors.sim.noise import NoiseProcess, own_stream  # noqa: E402
from rig.errors import RigInputError, RunError  # noqa: E402
from rig.lab.identity import sensor_identity  # noqa: E402
from rig.lab.noise_profiles import NoiseProfile, record_profile  # noqa: E402
from rig.session import load_session  # noqa: E402

SPREAD = {"white": [0.5, 2.0], "bias_instability": [0.5, 2.0], "random_walk": [0.5, 2.0]}
RATE_HZ, BW_HZ = 100.0, 44.0  # the characterisation record: procedures/allan.yaml's rate, the MPU-9150's 44 Hz filter
RECORD_S = 7200.0
CHARACTERISE_STREAM = 0xC4A3


def rig_file(tmp: Path) -> Path:
    """rigs/sim.yaml in virtual time with the noise spread."""
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["noise_spread"] = SPREAD
    path = tmp / "sim-spread.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _term(fit) -> dict:
    return {"value": fit.value, "sigma": fit.sigma, "ci95": [fit.lo, fit.hi]}


def characterised_profile(session_dir: Path, seed: int) -> NoiseProfile:
    """The unit's rig-noise/1 profile (accelerometer) fitted to a 2-hour static record of its own noise process."""
    truth = yaml.safe_load((session_dir / "sim_truth.yaml").read_text())
    unit = truth["unit_noise"]["accel"]
    band = tuple(truth["noise"]["flicker_band_s"])
    proc = NoiseProcess(unit["bias_instability"], unit["random_walk"], own_stream(seed, CHARACTERISE_STREAM), band)
    t = np.arange(1, int(RECORD_S * RATE_HZ) + 1) / RATE_HZ
    y = proc.sample(t, np.asarray(unit["white"], float), BW_HZ)
    axes = {}
    for j, axis in enumerate("xyz"):
        fit = fit_terms(allan_curve(y[:, j], RATE_HZ))
        axes[axis] = {**{t: _term(f) for t, f in fit.terms.items()}, "tau_floor_s": fit.tau_floor_s,
                      "chi2_dof": fit.chi2_dof}
    ident = sensor_identity(load_session(session_dir).info.to_dict(), SimpleNamespace(sensor=None))
    return NoiseProfile.model_validate({
        "sensor": {"key": ident["key"], "model": ident["model"], "serial": ident["serial"]},
        "measured_at": "2026-11-01T10:00:00+00:00", "session": f"allan-bench-{seed}", "duration_s": RECORD_S,
        "rate_hz": RATE_HZ, "accel": {"unit": "g", **axes}})


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1, help="the first unit's seed")
    ap.add_argument("--ways", default="family,profile")
    args = ap.parse_args()
    ways = args.ways.split(",")
    t0 = time.perf_counter()
    covered = {w: [] for w in ways}
    refused = {w: [] for w in ways}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        rigf = rig_file(tmp)
        for seed in range(args.seed, args.seed + args.units):
            cells = []
            try:
                first = run(RAPID_PROC, rigf, tmp / "family", seed)  # no profile yet: the family's figures
            except (RigInputError, RunError) as exc:  # its white noise alone puts the target out of reach: refused
                refused["family"].append(seed)
                print(f"unit {seed}: family: refused ({str(exc).splitlines()[0][:160]})", flush=True)
                continue
            if "family" in ways:
                err, bound = true_error_deg(first), predicted_deg(first)
                covered["family"].append(bound is not None and err <= bound)
                cells.append(f"family {err:.4f} / {bound:.4f}")
            if "profile" in ways:
                record_profile(characterised_profile(first, seed))
                try:
                    d = run(RAPID_PROC, rigf, tmp / "profile", seed)
                except (RigInputError, RunError) as exc:  # the unit's own wander puts the target out of reach
                    refused["profile"].append(seed)
                    print(f"unit {seed}: {cells[0] if cells else ''}; profile: refused "
                          f"({str(exc).splitlines()[0][:160]})", flush=True)
                    continue
                used = (yaml.safe_load((d / "calibration.yaml").read_text()).get("noise") or {}).get("source")
                assert used == "unit profile", f"unit {seed}: the run did not use the unit's profile ({used})"
                err, bound = true_error_deg(d), predicted_deg(d)
                covered["profile"].append(bound is not None and err <= bound)
                cells.append(f"profile {err:.4f} / {bound:.4f}")
            print(f"unit {seed}: true error / 95 % bound (deg): " + ", ".join(cells), flush=True)
    n = args.units
    print(f"\nunits {args.seed}..{args.seed + n - 1} (noise spread 0.5-2x per axis and term), six_position_rapid.yaml:")
    for w in ways:
        k, m = int(np.sum(covered[w])), len(covered[w])
        print(f"  {w:8s}: true error within the stopping rule's 95 % bound in {k} of {m} runs ({k / max(m, 1):.0%}; "
              f"an honest bound: 95 % +- {100 * math.sqrt(0.05 * 0.95 / max(m, 1)):.0f} %)")
    for w in ways:
        print(f"  {w:8s}: refused (the target out of reach within max_seconds, before moving or at the first pose): "
              f"{len(refused[w])} of {n} units {refused[w]}")
    print(f"wall time {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
