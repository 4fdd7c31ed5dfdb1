"""Lazy sample generation shared by the chip models.

Sample k of a stream is taken at ``t_start + k / rate``; samples are produced
only when the host looks (``catch_up(now)``), vectorised, from the physics
source and the error model, so a simulated chip costs nothing while nobody
reads it and is exact under any clock.
"""

from __future__ import annotations

import math

import numpy as np

from drivers.clock import ElasticClock
from drivers.sensors.sim.error_model import AccelErrorModel, HysteresisState
from drivers.sensors.sim.noise import NoiseConfig, NoiseProcess, own_stream
from drivers.sensors.sim.physics import advance, temperature_at

#: own random streams of the dlpf noise model (the sampler's generator keeps today's draws)
ACCEL_NOISE_STREAM, GYRO_NOISE_STREAM = 0xD1F0, 0xD1F1


class LazySampler:
    """Samples of one chip on its output grid, with the noise model ``noise`` (default: the MPU-9150's figures with :data:`~drivers.sensors.sim.noise.DEFAULT_NOISE_MODEL`)."""

    def __init__(self, physics, accel_errors: AccelErrorModel, clock, seed: int, gyro_errors=None,
                 noise: NoiseConfig | None = None) -> None:
        self.physics = physics
        self.accel = accel_errors
        self.gyro = gyro_errors
        self.clock = clock
        self.rng = np.random.default_rng(seed)
        self.noise = noise or NoiseConfig()
        n = self.noise
        self.accel_noise = NoiseProcess(n.accel_bias_instability_g, n.accel_random_walk_g_per_rts,
                                        own_stream(seed, ACCEL_NOISE_STREAM), n.flicker_band_s)
        self.gyro_noise = NoiseProcess(n.gyro_bias_instability_dps, n.gyro_random_walk_dps_per_rts,
                                       own_stream(seed, GYRO_NOISE_STREAM), n.gyro_flicker_band_s)
        self.hyst = HysteresisState(accel_errors.hysteresis_band_c)
        self.rate_hz = 100.0
        self.bandwidth_hz = 44.0
        self.gyro_bandwidth_hz = 44.0
        self.delay_s = 0.0
        self.running = False
        self.t_start = 0.0
        self.next_k = 0

    def restart(self, rate_hz: float, bandwidth_hz: float, *, delay_s: float = 0.0,
                gyro_bandwidth_hz: float | None = None) -> None:
        """(Re)start the sample grid now (power-up, rate change). ``bandwidth_hz`` is the accelerometer's
        low-pass; ``delay_s`` its group delay and ``gyro_bandwidth_hz`` the gyroscope's (dlpf model only)."""
        self.rate_hz = float(rate_hz)
        self.bandwidth_hz = float(bandwidth_hz)
        self.gyro_bandwidth_hz = float(gyro_bandwidth_hz or bandwidth_hz)
        self.delay_s = float(delay_s)
        self.t_start = self.clock.now()
        self.next_k = 1
        self.running = True

    def stop(self) -> None:
        self.running = False

    def freeze(self, owner: object) -> None:
        """Stop an elastic clock for the length of one register access by ``owner`` (the access then
        paces it: :meth:`pace`): the room left in the FIFO is counted at the time it is read, never after
        time has moved on (at a large time scale, microseconds of this machine's time are samples)."""
        if isinstance(self.clock, ElasticClock):
            self.clock.hold_now(owner)

    def pace(self, owner: object, free_samples: int | None) -> None:
        """Let an elastic clock (:class:`~drivers.clock.ElasticClock`) run only until ``free_samples`` more
        samples are due (the room left in ``owner``'s FIFO: it fills, never overflows, however late its
        reader is); ``None`` (no FIFO running) lifts ``owner``'s hold. A clock that keeps its own pace
        (wall time, virtual time) is not held: there a late reader loses samples, as on hardware."""
        if not isinstance(self.clock, ElasticClock):
            return
        if free_samples is None or not self.running:
            self.clock.release(owner)
        else:
            self.clock.hold(owner, self.t_start + (self.next_k + max(free_samples, 0) - 1) / self.rate_hz)

    def _temp_rate(self, t: np.ndarray, h: float = 0.5) -> np.ndarray:
        """True dT/dt (C/s) of the physics' sensor temperature (central difference over +-h s)."""
        return (temperature_at(self.physics, t + h) - temperature_at(self.physics, t - h)) / (2 * h)

    def due(self) -> bool:
        """Whether :meth:`catch_up` would produce a sample now (a register access between two samples asks
        first: most of a host's accesses fall between samples, and the chip's own bookkeeping of what to keep is
        only needed when one is due)."""
        if not self.running:
            return False
        return math.floor((self.clock.now() - self.t_start) * self.rate_hz + 1e-9) >= self.next_k

    def catch_up(self, keep_last: int):
        """Samples due since the last call: dict of arrays (t_s, accel_g, temp_c, gyro_dps, skipped).

        At most ``keep_last`` samples are fully produced; earlier ones (that would
        overflow the FIFO anyway) are only counted in ``skipped`` (their physics
        is still evaluated on a coarse grid so stateful effects follow).
        """
        if not self.running:
            return None
        now = self.clock.now()
        last_k = int(np.floor((now - self.t_start) * self.rate_hz + 1e-9))
        if last_k < self.next_k:
            return None
        n = last_k - self.next_k + 1
        skipped = max(0, n - keep_last)
        if skipped:
            ts_skip = self.t_start + np.arange(self.next_k, self.next_k + skipped, max(1, int(self.rate_hz * 0.05))) / self.rate_hz
            self.hyst.update(advance(self.physics, ts_skip))
        k = np.arange(self.next_k + skipped, last_k + 1)
        self.next_k = last_k + 1
        t = self.t_start + k / self.rate_hz
        dlpf = self.noise.dlpf
        ph = self.physics(t - self.delay_s if dlpf else t)
        heating = self.hyst.update(ph.temp_c)
        rate = self._temp_rate(t - self.delay_s if dlpf else t) if self.accel.needs_rate() else None
        a = self.accel.output_g(ph.specific_force_g, ph.temp_c, t, heating, rate)
        # the sampler's own draws of one sample together, sample after sample (white accel x y z, white gyro
        # x y z, thermometer): a sample's noise does not depend on how the samples were split between reads
        white_gyro = not dlpf and self.gyro is not None
        draws = self.rng.standard_normal((len(t), 1 + (0 if dlpf else 3) + (3 if white_gyro else 0)))
        if dlpf:
            a = a + self.accel_noise.sample(t, self.accel.noise_density_g_per_rthz, self.bandwidth_hz)
        else:
            sigma = np.asarray(self.accel.noise_density_g_per_rthz) * np.sqrt(min(self.bandwidth_hz, self.rate_hz / 2) * np.pi / 2)
            a = a + draws[:, 1:4] * sigma
        g = np.asarray(ph.angular_rate_dps, float)  # an ideal gyro unless an error model is given
        if self.gyro is not None:
            g = self.gyro.output_dps(ph.angular_rate_dps, ph.specific_force_g)
            if dlpf:
                g = g + self.gyro_noise.sample(t, self.gyro.noise_density_dps_per_rthz, self.gyro_bandwidth_hz)
            else:
                gs = np.asarray(self.gyro.noise_density_dps_per_rthz) * np.sqrt(min(self.bandwidth_hz, self.rate_hz / 2) * np.pi / 2)
                g = g + draws[:, 4:7] * gs
        temp = ph.temp_c + 0.02 * draws[:, 0]
        return {"t_s": t, "accel_g": a, "temp_c": temp, "gyro_dps": g, "mag_ut": ph.magnetic_field_ut,
                "skipped": skipped}
