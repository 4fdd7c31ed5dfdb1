"""rig characterize's fit against units whose hidden noise differs from their family's (issue 28 targets).

Target 1: on simulated units whose hidden N, B, K differ from the family figures by factors 0.5-2, the
fitted terms fall within their stated (95 %) confidence intervals in at least 90 % of units.
Target 4: a 2-hour 100 Hz recording characterised in under 30 s and 1 GB.

Two sources of units, each drawn with factors log-uniform in [0.5, 2] per axis and term:

- ``synthetic``: calib.noise.synthetic (white noise, band-limited flicker, random walk), the MPU-9150
  accelerometer's figures (N 330 ug/rtHz: what its 400 ug/rtHz density gives at 100 Hz through the 44 Hz
  filter; floor 40/sqrt(2) ug; K 4 ug/sqrt(s));
- ``chip``: the simulated MPU-9150's own sample path (Mpu9150Model, dlpf noise, 44 Hz filter, 100 Hz,
  quantised), the unit drawn by drivers.sensors.sim.unit_noise as the rig file's ``sim: noise_spread:`` does;
  the true Allan N of the filtered white noise is density x sqrt(pi B / 2 x (1 + phi) / (1 - phi) / rate),
  phi = exp(-2 pi B / rate), and the true floor the registry's B / sqrt(2) (docs/noise.md).

    python benchmarks/bench_allan.py [--units 60] [--chip-units 20] [--seconds 7200] [--seed 1000]

Measured 2026-11-26 on the shared 2-core machine (other sessions' benchmarks running), 2 h at 100 Hz, each
unit's x axis, the share of units whose fitted term lies inside its stated 95 % interval (the profile-likelihood
interval, the fit from 0.6 s: calib.noise.fit; ``--units 60 --chip-units 20``, ``--units 120 --chip-units 20
--seed 5000`` and ``--units 0 --chip-units 20 --seed 8000``):

==============================  =====  =====  =====  ==========  =================================
source (seeds)                  N      B      K      all three   target (>= 90 % per term)
==============================  =====  =====  =====  ==========  =================================
synthetic, 60 (1000-1059)       97 %   98 %   98 %   93 %        met
synthetic, 120 (5000-5119)      99 %   93 %   98 %   90 %        met
chip, 20 (2000-2019)            100 %  90 %   95 %   85 %        met
chip, 20 (6000-6019)            100 %  95 %   100 %  95 %        met
chip, 20 (9000-9019)            100 %  100 %  100 %  100 %       met
==============================  =====  =====  =====  ==========  =================================

Before 2026-11-26 (the symmetric interval ``c +- 1.96 sigma`` of each squared figure, the fit from 0.1 s): synthetic
seeds 1000-1059 N 97 %, B 98 %, K 87 % (every K miss a walk fitted low, its truth above the upper bound); chip
seeds 2000-2019 N 85 %, B 90 %, K 95 %. With the profile-likelihood intervals and the fit still from 0.1 s: synthetic
1000-1059 K 97 %, 5000-5119 K 98 %; chip N 85 % on both chip sets (3 of 20 each): from 0.1 s the 44 Hz filter pulls
the fitted N 0.4-0.5 % low against intervals of +-0.65 % (fitted / true N 0.995, sd 0.002, seeds 2000-2019); from
0.6 s 1.000, sd 0.004, intervals +-1.35 %. The 0.6 s was chosen on the chip seeds 2000-2019 and 6000-6019; seeds
9000-9019 are the independent check.

Timing (target < 30 s, < 1 GB): 9 axes (accelerometer, gyroscope, magnetometer) x 2 h at 100 Hz,
characterised in process in 0.8-2.6 s (load 8-9 on 2 cores) (0.7 s before the profile-likelihood intervals), peak
RSS 183 MB (the whole benchmark process, data included).
``rig characterize`` on a 2 h 10 min simulated session, end to end (reading samples.csv): see docs/noise.md.
"""

from __future__ import annotations

import argparse
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from calib.noise.allan import allan_curve
from calib.noise.characterize import characterize
from calib.noise.fit import fit_terms
from calib.noise.synthetic import noise
from calib.noise.terms import NoiseFigures
from drivers.clock import VirtualClock
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.noise import NoiseConfig
from drivers.sensors.sim.physics import StaticPhysics
from drivers.sensors.sim.unit_noise import draw_unit_noise

RATE_HZ = 100.0
SPREAD = {"white": (0.5, 2.0), "bias_instability": (0.5, 2.0), "random_walk": (0.5, 2.0)}
FAMILY = NoiseFigures(N=330e-6, B=40e-6 / math.sqrt(2), K=4e-6)
DLPF_HZ = 44.0  # MPU-9150 DLPF_CFG 3


def synthetic_unit(seed: int, n: int) -> tuple[NoiseFigures, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = np.exp(rng.uniform(math.log(0.5), math.log(2.0), 3))
    truth = NoiseFigures(N=FAMILY.N * f[0], B=FAMILY.B * f[1], K=FAMILY.K * f[2])
    return truth, noise(NoiseFigures(N=truth.N, B=truth.B * math.sqrt(2), K=truth.K), n, RATE_HZ, rng)


def chip_unit(seed: int, seconds: float) -> tuple[NoiseFigures, np.ndarray]:
    """The x axis of a simulated MPU-9150 unit drawn with the spread, lying still, 100 Hz / 44 Hz, quantised."""
    errors = AccelErrorModel(noise_density_g_per_rthz=[400e-6] * 3)
    unit = draw_unit_noise(seed, NoiseConfig.for_chip("MPU-9150", "dlpf"), {"accel": errors}, SPREAD)
    clock = VirtualClock()
    chip = Mpu9150Model(StaticPhysics((0.0, 0.0, 1.0)), errors, clock=clock, seed=seed, noise=unit.noise)
    chip.regs[0x1A], chip.regs[0x19], chip.regs[0x6B] = 3, int(round(1000 / RATE_HZ)) - 1, 0x01
    chip._restart_grid()
    out = []
    for _ in range(int(math.ceil(seconds / 600.0))):
        clock.sleep(600.0)
        out.append(np.round(chip.sampler.catch_up(keep_last=10**9)["accel_g"][:, 0] * 8192) / 8192)
    phi = math.exp(-2 * math.pi * DLPF_HZ / RATE_HZ)
    n_eff = errors.noise_density_g_per_rthz[0] * math.sqrt(math.pi * DLPF_HZ / 2 * (1 + phi) / (1 - phi) / RATE_HZ)
    truth = NoiseFigures(N=n_eff, B=unit.noise.accel_bias_instability_g[0] / math.sqrt(2),
                         K=unit.noise.accel_random_walk_g_per_rts[0])
    return truth, np.concatenate(out)[: int(seconds * RATE_HZ)]


def coverage(units) -> dict:
    hits = {t: 0 for t in "NBK"}
    every = 0
    for truth, y in units:
        fit = fit_terms(allan_curve(y, RATE_HZ))
        inside = {t: fit.terms[t].covers(getattr(truth, t)) for t in "NBK"}
        for t, ok in inside.items():
            hits[t] += ok
        every += all(inside.values())
    n = len(units)
    return {**{t: hits[t] / n for t in "NBK"}, "all": every / n, "units": n}


def timing(seconds: float) -> dict:
    """Characterise a 2-hour 100 Hz record of nine axes (accelerometer, gyroscope, magnetometer), in process."""
    rng = np.random.default_rng(1)
    n = int(seconds * RATE_HZ)
    fam = {"accel": FAMILY, "gyro": NoiseFigures(N=4.4e-3, B=2e-3 / math.sqrt(2), K=2e-4),
           "mag": NoiseFigures(N=0.03, B=0.1 / math.sqrt(2), K=0.01)}
    series = {s: np.column_stack([noise(NoiseFigures(N=f.N, B=f.B * math.sqrt(2), K=f.K), n, RATE_HZ, rng)
                                  for _ in range(3)]) + ([0, 0, 1] if s == "accel" else 0) for s, f in fam.items()}
    t = np.arange(n) / RATE_HZ
    start = time.perf_counter()
    characterize(t, series, RATE_HZ, ("N", "B", "K"), fam)
    wall = time.perf_counter() - start
    return {"wall_s": wall, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=60)
    ap.add_argument("--chip-units", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=7200.0)
    ap.add_argument("--seed", type=int, default=1000, help="the first synthetic unit's seed (chip units: seed + 1000)")
    args = ap.parse_args()
    n = int(args.seconds * RATE_HZ)
    tm = timing(args.seconds)
    print(f"timing: 9 axes x {args.seconds:.0f} s at {RATE_HZ:g} Hz characterised in {tm['wall_s']:.1f} s, "
          f"peak RSS {tm['peak_rss_mb']:.0f} MB (target < 30 s, < 1 GB)")
    if args.units:
        syn = coverage([synthetic_unit(args.seed + i, n) for i in range(args.units)])
        print("synthetic: " + ", ".join(f"{k} {v:.0%}" if k != "units" else f"{v} units" for k, v in syn.items()))
    if args.chip_units:
        chip = coverage([chip_unit(args.seed + 1000 + i, args.seconds) for i in range(args.chip_units)])
        print("chip:      " + ", ".join(f"{k} {v:.0%}" if k != "units" else f"{v} units" for k, v in chip.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
