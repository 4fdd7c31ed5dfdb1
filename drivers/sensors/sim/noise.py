"""Sensor noise of the simulated chips: the DLPF model of a real MEMS sensor (the default), or white.

Two models, chosen by :class:`NoiseConfig` ``model`` (a rig file: ``sim: {noise: white | dlpf}``):

``"dlpf"`` (the default, :data:`DEFAULT_NOISE_MODEL`: the simulator must not be kinder than the chip)
    what the chip does: white noise of the datasheet density passes the digital low-pass filter set
    in the chip's registers (modelled as a first-order filter of that -3 dB bandwidth B, stationary
    sigma = density * sqrt(pi B / 2), lag-1 correlation exp(-2 pi B / rate)), so a mean over T
    seconds scatters like density / sqrt(2 T); the signal is delayed by the filter's group delay
    from the register map; plus bias instability (flicker: a sum of first-order Gauss-Markov
    processes, two per decade of correlation time tiling ``flicker_band_s``, whose Allan deviation
    is flat at ``*_bias_instability``) and a random walk of the bias (Allan deviation
    K sqrt(tau / 3)). Every draw comes from the process's own generator, never the sampler's.

``"white"``
    independent samples with sigma = density * sqrt(pi/2 * min(bandwidth, rate/2)), drawn from the
    sampler's own generator, no wander (what the simulator did before; the golden recordings use it).

Parameters per chip (:meth:`NoiseConfig.for_chip`) come from the chip registry,
:class:`drivers.sensors.chips.ChipSpec` (``accel_*``, ``gyro_*``, ``mag_*`` bias instability, random
walk and flicker corner), the one source the solvers read too ("datasheet class": the datasheets give
noise density only, so bias instability and random walk are typical Allan-variance figures of
consumer MEMS parts of these families, stated in docs/sensors.md):

=========================  ==================  ==================  ===========================
quantity                   MPU-9150 accel      ADXL345             MPU-9150 gyro / AK8975
=========================  ==================  ==================  ===========================
bias instability (ADEV)    40 ug               100 ug              0.002 deg/s / 0.1 uT
random walk K              4 ug/sqrt(s)        10 ug/sqrt(s)       2e-4 deg/s/sqrt(s) / 0.01 uT/sqrt(s)
flicker corner             5000 s              5000 s              5000 s / 5000 s
=========================  ==================  ==================  ===========================
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from drivers.sensors.chips import CHIPS

NOISE_MODELS = ("white", "dlpf")
#: the model a chip uses when none is given: the honest one (the simulator must not be kinder than the hardware)
DEFAULT_NOISE_MODEL = "dlpf"
#: Allan deviation floor of flicker noise = sqrt(2 ln 2 / pi) * B (IEEE Std 952, annex C)
FLICKER_FLOOR = math.sqrt(2 * math.log(2) / math.pi)
#: the chip whose figures a NoiseConfig built without one carries
DEFAULT_CHIP = "MPU-9150"
#: shortest correlation time of the simulated flicker, s
FLICKER_TAU_MIN_S = 0.02


def _chip_params(chip: str) -> dict:
    """The chip registry's bias characterisation of ``chip`` (one source for the simulator and the
    solver): per-axis lists of bias instability and random walk, and each sensor's flicker band (s).
    A sensor the chip does not have gets no wander (zeros)."""
    spec = CHIPS.get(chip, CHIPS[DEFAULT_CHIP])
    out = {}
    for sensor, b_unit, k_unit in (("accel", "g", "g_per_rts"), ("gyro", "dps", "dps_per_rts"),
                                   ("mag", "ut", "ut_per_rts")):
        for key in (f"{sensor}_bias_instability_{b_unit}", f"{sensor}_random_walk_{k_unit}"):
            out[key] = [float(getattr(spec, key) or 0.0)] * 3
        corner = getattr(spec, f"{sensor}_flicker_corner_s") or spec.accel_flicker_corner_s
        out["flicker_band_s" if sensor == "accel" else f"{sensor}_flicker_band_s"] = (FLICKER_TAU_MIN_S, float(corner))
    return out


def _chip(key: str):
    """A NoiseConfig field defaulting to :data:`DEFAULT_CHIP`'s registry figure."""
    return field(default_factory=lambda: _chip_params(DEFAULT_CHIP)[key])


@dataclass
class NoiseConfig:
    """Which noise model a simulated chip uses and the parameters of the coloured terms.

    White-noise densities stay in the error models (``noise_density_g_per_rthz``,
    ``noise_density_dps_per_rthz``, ``noise_ut``); the filter comes from the chip's registers. The
    bias instabilities (sensor units), random walks (sensor units / sqrt(s)) and flicker bands
    ``(tau_min, tau_max)`` (s; ``flicker_band_s`` the accelerometer's) default to the MPU-9150's
    figures in the chip registry (:class:`drivers.sensors.chips.ChipSpec`).
    """

    model: str = DEFAULT_NOISE_MODEL
    accel_bias_instability_g: list = _chip("accel_bias_instability_g")
    accel_random_walk_g_per_rts: list = _chip("accel_random_walk_g_per_rts")
    gyro_bias_instability_dps: list = _chip("gyro_bias_instability_dps")
    gyro_random_walk_dps_per_rts: list = _chip("gyro_random_walk_dps_per_rts")
    mag_bias_instability_ut: list = _chip("mag_bias_instability_ut")
    mag_random_walk_ut_per_rts: list = _chip("mag_random_walk_ut_per_rts")
    flicker_band_s: tuple = _chip("flicker_band_s")
    gyro_flicker_band_s: tuple = _chip("gyro_flicker_band_s")
    mag_flicker_band_s: tuple = _chip("mag_flicker_band_s")

    def __post_init__(self) -> None:
        if self.model not in NOISE_MODELS:
            raise ValueError(f"noise model {self.model!r} not one of {', '.join(NOISE_MODELS)}")

    @property
    def dlpf(self) -> bool:
        return self.model == "dlpf"

    @classmethod
    def for_chip(cls, chip: str = DEFAULT_CHIP, model: str | None = None) -> "NoiseConfig":
        """The chip registry's parameters of ``chip`` with ``model`` (default :data:`DEFAULT_NOISE_MODEL`)."""
        return cls(model=model or DEFAULT_NOISE_MODEL, **_chip_params(chip))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def resolve_noise(noise, chip: str) -> NoiseConfig:
    """A NoiseConfig from None (the default model), a model name, a mapping or a NoiseConfig."""
    if noise is None or isinstance(noise, str):
        return NoiseConfig.for_chip(chip, noise)
    if isinstance(noise, dict):
        base = NoiseConfig.for_chip(chip, noise.get("model")).to_dict()
        base.update(noise)
        return NoiseConfig(**base)
    return noise


def own_stream(seed: int, tag: int) -> np.random.Generator:
    """A generator of its own for ``seed`` and ``tag``, independent of ``default_rng(seed)``."""
    return np.random.default_rng([int(seed) % 2**63, tag])


def _first_order(x_prev, dt: np.ndarray, tau: float, sigma, n: np.ndarray) -> np.ndarray:
    """Exact samples of a stationary first-order Gauss-Markov process (time constant tau, sigma)
    at time steps ``dt`` (N,) after the state ``x_prev`` (3,) (None: a fresh stationary draw)."""
    phi = np.exp(-dt / tau) if tau > 0 else np.zeros_like(dt)
    e = np.asarray(sigma) * np.sqrt(1.0 - phi**2)[:, None] * n
    x0 = np.asarray(sigma) * n[0] if x_prev is None else phi[0] * x_prev + e[0]
    if len(dt) == 1:
        return x0[None, :]
    p = phi[1:]
    if p.max() - p.min() <= 1e-9 * p.max():  # a uniform grid (np.allclose costs more than the filter)
        from scipy.signal import lfilter  # deferred: 0.4-0.9 s to import; only when noise is drawn
        rest, _ = lfilter([1.0], [1.0, -p[0]], e[1:], axis=0, zi=(p[0] * x0)[None, :])
        return np.vstack([x0[None, :], rest])
    out = np.empty_like(e)
    out[0] = x0
    for k in range(1, len(dt)):
        out[k] = p[k - 1] * out[k - 1] + e[k]
    return out


#: blocks up to this many samples step the bank sample by sample (all components at once); longer ones
#: run one exact recursive filter per component. A read of a few samples is the common case: with a
#: filter set-up per component it cost 1.6 ms, and a time-scaled simulated rig on a busy machine lost
#: samples (a 100 Hz MPU-9150 read through the bus: 3x the white model's time before, 1.5x now)
BANK_LOOP_MAX = 64
#: within the loop's blocks, those of this many samples run as one product per time constant instead (measured
#: for 11 time constants: 47 against 71 us at 18 samples, 105 against 145 at 40; slower below 8 and at 64)
BANK_PRODUCT_SAMPLES = (8, 40)


def _first_order_bank(x_prev, dt: np.ndarray, taus: np.ndarray, sigma, n: np.ndarray):
    """:func:`_first_order` for a bank of T processes of time constants ``taus`` (T,) and sigmas ``sigma``
    ((3,) shared, or (T, 3) each its own); ``n`` (T, N, 3) standard normals, ``x_prev`` (T, 3) or None.
    Returns (their sum (N, 3), the last state (T, 3))."""
    sigma = np.broadcast_to(np.asarray(sigma, float), (len(taus), n.shape[2]))
    if len(dt) > BANK_LOOP_MAX:
        xs = [_first_order(None if x_prev is None else x_prev[i], dt, tau, sigma[i], n[i])
              for i, tau in enumerate(taus)]
        return np.sum(xs, axis=0), np.array([x[-1] for x in xs])
    phi = np.exp(-dt[None, :] / taus[:, None])  # (T, N)
    e = sigma[:, None, :] * np.sqrt(1.0 - phi**2)[:, :, None] * n
    x = sigma * n[:, 0] if x_prev is None else phi[:, 0, None] * x_prev + e[:, 0]
    if not BANK_PRODUCT_SAMPLES[0] <= len(dt) <= BANK_PRODUCT_SAMPLES[1]:
        out = np.empty((len(dt), n.shape[2]))
        out[0] = x.sum(axis=0)
        for k in range(1, len(dt)):
            x = phi[:, k, None] * x + e[:, k]
            out[k] = x.sum(axis=0)
        return out, x
    # x_k = sum_j exp(-(s_k - s_j) / tau) e_j (e_0 = x_0; s: time since the block's first sample): the recursion
    # x_k = phi_k x_(k-1) + e_k as one product per time constant, exp of the summed steps for the product of the
    # phi (equal to rounding: 1e-15 relative), instead of a loop over the samples (numpy calls per sample)
    e[:, 0] = x
    s = np.concatenate([[0.0], np.cumsum(dt[1:])])
    lag = np.maximum(s[:, None] - s[None, :], 0.0)  # (N, N): s_k - s_j; only j <= k is used
    decay = np.exp(-lag[None, :, :] / taus[:, None, None]) * np.tri(len(s), dtype=bool)[None, :, :]
    states = decay @ e  # (T, N, 3)
    return states.sum(axis=0), states[:, -1]


class NoiseProcess:
    """Coloured noise of one three-axis sensor at increasing times (the ``dlpf`` model).

    Parameters
    ----------
    bias_instability : (3,) Allan deviation floor of the flicker term, sensor units.
    random_walk : (3,) K of the bias random walk, sensor units / sqrt(s).
    rng : numpy Generator (its own stream).
    flicker_band_s : (tau_min, tau_max) correlation times spanned by the flicker approximation, s.
    """

    PER_DECADE = 2

    def __init__(self, bias_instability, random_walk, rng: np.random.Generator,
                 flicker_band_s=(0.02, 5000.0)) -> None:
        self.rng = rng
        lo, hi = (math.log10(x) for x in flicker_band_s)
        # the nodes' log-intervals tile [tau_min, tau_max] exactly (a node at each end would add half an
        # interval beyond the flicker corner: 13 % more session-mean wander than the chip's figures say)
        n = max(1, int(round((hi - lo) * self.PER_DECADE)))
        width = (hi - lo) / n  # decades per node
        self.taus = 10.0 ** (lo + width * (np.arange(n) + 0.5))
        spacing = math.log(10) * width
        coeff = np.asarray(bias_instability, float) / FLICKER_FLOOR  # flicker coefficient B: S(f) = B^2 / (2 pi f)
        self.flicker_sigma = coeff * math.sqrt(spacing / (2 * math.pi))
        self.random_walk = np.asarray(random_walk, float)
        # fixed for the process's life: asked once, not at every block (a read of 18 samples is the common case)
        self._has_flicker = bool(np.any(self.flicker_sigma > 0))
        self._has_walk = bool(np.any(self.random_walk > 0))
        self._banks: dict = {}  # (density, bandwidth) -> the joint bank's time constants and sigmas
        self.t_last: float | None = None
        self.filtered: np.ndarray | None = None
        self.flicker: np.ndarray | None = None  # (n, 3) state of the flicker bank
        self.walk = np.zeros(3)

    def _joint_bank(self, density: np.ndarray, bandwidth_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """The time constants (T,) and sigmas (T, 3) of the filtered white noise (first) and the flicker's bank
        together, made once per density and bandwidth (a chip's configuration changes them, rarely)."""
        key = (density.tobytes(), float(bandwidth_hz))
        bank = self._banks.get(key)
        if bank is None:
            if len(self._banks) >= 16:
                self._banks.clear()
            taus = np.concatenate([[1 / (2 * math.pi * bandwidth_hz)], self.taus])
            sigmas = np.vstack([density * math.sqrt(math.pi * bandwidth_hz / 2),
                                np.broadcast_to(self.flicker_sigma, (len(self.taus), 3))])
            bank = self._banks[key] = (taus, sigmas)
        return bank

    def sample(self, t_s, density, bandwidth_hz: float | None) -> np.ndarray:
        """Noise (N, 3) at times ``t_s``: white ``density`` (units/sqrt(Hz)) through a first-order
        low-pass of ``bandwidth_hz``, or, for None, white with sigma ``density`` per sample."""
        t = np.atleast_1d(np.asarray(t_s, float))
        fresh = self.t_last is None
        dt = np.diff(np.concatenate([[t[0] - 1e9 if fresh else self.t_last], t]))
        self.t_last = float(t[-1])
        density = np.asarray(density, float)
        flicker, walk = self._has_flicker, self._has_walk
        # every draw of one sample together, sample after sample: the noise of a sample does not depend
        # on how the samples were split between calls (how often, and when, the host read the FIFO)
        draws = self.rng.standard_normal((len(t), 1 + (len(self.taus) if flicker else 0) + walk, 3))
        if bandwidth_hz is None:
            out = density * draws[:, 0]
        elif flicker and (self.filtered is None) == (self.flicker is None):
            # the filtered white noise is one more first-order process: one bank with the flicker's (its own
            # sigma and time constant first), summed in one pass
            taus, sigmas = self._joint_bank(density, bandwidth_hz)
            prev = None if self.filtered is None else np.vstack([self.filtered[None, :], self.flicker])
            out, state = _first_order_bank(prev, dt, taus, sigmas, draws[:, :len(taus)].transpose(1, 0, 2))
            self.filtered, self.flicker = state[0], state[1:]
            flicker = False  # drawn
        else:
            sigma = density * math.sqrt(math.pi * bandwidth_hz / 2)
            out, state = _first_order_bank(None if self.filtered is None else self.filtered[None, :], dt,
                                           np.array([1 / (2 * math.pi * bandwidth_hz)]), sigma,
                                           draws[None, :, 0])
            self.filtered = state[0]
        if flicker:
            total, self.flicker = _first_order_bank(self.flicker, dt, self.taus, self.flicker_sigma,
                                                    draws[:, 1:1 + len(self.taus)].transpose(1, 0, 2))
            out = out + total
        if walk:
            steps = self.random_walk * np.sqrt(dt)[:, None] * draws[:, -1]
            if fresh:
                steps[0] = 0.0  # the walk starts at 0 with the first sample
            w = self.walk + np.cumsum(steps, axis=0)
            self.walk = w[-1]
            out = out + w
        return out
