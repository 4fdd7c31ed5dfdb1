"""Allan deviation of the simulated MPU-9150's static accelerometer output under the DLPF noise model.

Simulates a sensor lying still (the chip's own sample path: error model, dlpf noise, quantisation at
+-2 g) at 1 kHz with the 44 Hz filter and at 100 Hz with the 44 Hz filter, computes the overlapping
Allan deviation (allantools.oadev) and plots it against the configured lines: white noise
density / sqrt(2 tau), bias instability (flat) and random walk K sqrt(tau / 3). Prints ADEV at
0.01, 0.1, 1, 10, 100 s, the lag-1 correlation and the scatter of 1 s means.

    python benchmarks/bench_noise.py [--seconds 1200] [--out benchmarks/out/allan_noise.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.clock import VirtualClock
from drivers.sensors.regs.mpu9150 import ACCEL_LSB_PER_G
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import StaticPhysics

TAUS_REPORTED = (0.01, 0.1, 1.0, 10.0, 100.0)
DENSITY = 400e-6  # g/sqrt(Hz), MPU-9150 accelerometer


def simulate(rate_hz: float, dlpf_cfg: int, seconds: float, seed: int = 7) -> np.ndarray:
    """Static accelerometer output (N, 3), g, quantised at +-2 g, from the chip's sampler."""
    clock = VirtualClock()
    chip = Mpu9150Model(StaticPhysics((0.0, 0.0, 1.0)), AccelErrorModel(noise_density_g_per_rthz=[DENSITY] * 3),
                        clock=clock, seed=seed, noise="dlpf")
    chip.regs[0x1A], chip.regs[0x19], chip.regs[0x6B] = dlpf_cfg, int(round(1000 / rate_hz)) - 1, 0x01
    chip._restart_grid()
    out = []
    chunk = max(1.0, 2000 / rate_hz)
    for _ in range(int(np.ceil(seconds / chunk))):
        clock.sleep(chunk)
        s = chip.sampler.catch_up(keep_last=10**9)
        out.append(np.round(s["accel_g"] * ACCEL_LSB_PER_G[0]) / ACCEL_LSB_PER_G[0])
    return np.concatenate(out)


def figures(a: np.ndarray, rate_hz: float) -> dict:
    import allantools

    x = a[:, 0] - a[:, 0].mean()
    taus = np.logspace(np.log10(1 / rate_hz), np.log10(len(x) / rate_hz / 8), 40)
    t, adev, _, _ = allantools.oadev(x, rate=rate_hz, data_type="freq", taus=taus)
    at = {tau: float(np.interp(np.log(tau), np.log(t), adev)) if t[0] <= tau <= t[-1] else float("nan")
          for tau in TAUS_REPORTED}
    n1 = int(rate_hz)
    means = x[: len(x) // n1 * n1].reshape(-1, n1).mean(axis=1)
    lag1 = float(np.sum(x[1:] * x[:-1]) / np.sum(x * x))
    return {"taus": t, "adev": adev, "at": at, "lag1": lag1, "mean1s": float(means.std())}


def plot(results: dict, noise, out: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    tau = np.logspace(-3, 3, 200)
    for label, r in results.items():
        ax.loglog(r["taus"], r["adev"] * 1e6, label=f"simulated, {label}")
    bi, rw = noise.accel_bias_instability_g[0], noise.accel_random_walk_g_per_rts[0]
    ax.loglog(tau, DENSITY / np.sqrt(2 * tau) * 1e6, "k--", lw=1, label=f"white {DENSITY * 1e6:.0f} ug/rtHz")
    ax.loglog(tau, np.full_like(tau, bi * 1e6), "k:", lw=1, label=f"bias instability {bi * 1e6:.0f} ug")
    ax.loglog(tau, rw * np.sqrt(tau / 3) * 1e6, "k-.", lw=1, label=f"random walk {rw * 1e6:.0f} ug/rts")
    ax.set_xlabel("tau, s")
    ax.set_ylabel("Allan deviation, ug")
    ax.set_ylim(1, 1e4)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("MPU-9150 accelerometer x, dlpf noise model (overlapping ADEV)")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120, bbox_inches="tight")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=1200.0, help="simulated seconds per case")
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "out" / "allan_noise.png")
    args = p.parse_args(argv)
    from drivers.sensors.sim.noise import NoiseConfig
    noise = NoiseConfig.for_chip("MPU-9150", "dlpf")
    results = {}
    for label, rate, cfg in (("1 kHz / 44 Hz", 1000.0, 3), ("100 Hz / 44 Hz", 100.0, 3)):
        results[label] = figures(simulate(rate, cfg, args.seconds), rate)
    print(f"{'case':<16}" + "".join(f"{'ADEV ' + format(t, 'g') + ' s':>14}" for t in TAUS_REPORTED)
          + f"{'lag-1':>8}{'1 s mean sd':>13}")
    for label, r in results.items():
        print(f"{label:<16}" + "".join(f"{r['at'][t] * 1e6:>11.1f} ug" for t in TAUS_REPORTED)
              + f"{r['lag1']:>8.3f}{r['mean1s'] * 1e6:>10.1f} ug")
    print(f"expected: white density/sqrt(2 tau) = {DENSITY / np.sqrt(2) * 1e6:.0f} ug at 1 s; lag-1 "
          f"exp(-2 pi 44/1000) = {np.exp(-2 * np.pi * 44 / 1000):.3f} at 1 kHz, "
          f"{np.exp(-2 * np.pi * 44 / 100):.3f} at 100 Hz; bias instability "
          f"{noise.accel_bias_instability_g[0] * 1e6:.0f} ug; random walk "
          f"{noise.accel_random_walk_g_per_rts[0] * 1e6:.0f} ug/sqrt(s)")
    plot(results, noise, args.out)
    print(f"plot: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
