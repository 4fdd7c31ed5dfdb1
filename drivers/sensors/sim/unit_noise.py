"""Simulated units unlike their family: each unit's noise figures drawn about the chip registry's.

A real unit is quieter or noisier than its family's figures (``ChipSpec``). With a spread configured
(the rig file's ``sim: noise_spread:``, docs/noise.md), every axis of every sensor of the
simulated unit gets its own factor per term, log-uniform in ``[lo, hi]``: the white-noise density
(the error models' ``noise_density_*``; the magnetometer's ``noise_ut``, one factor for its three
axes), the bias instability and the random walk (:class:`~drivers.sensors.sim.noise.NoiseConfig`).
The factors come from a stream of their own (``[seed, 0xD1F8]``), so no other draw of the seed
changes; ``sim_truth.yaml`` records them with the resulting figures (:meth:`UnitNoise.truth`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drivers.sensors.sim.noise import NoiseConfig, own_stream

UNIT_NOISE_STREAM = 0xD1F8
#: the terms a spread draws a factor for
SPREAD_TERMS = ("white", "bias_instability", "random_walk")
#: sensor -> (its error model's white-noise field, NoiseConfig's bias instability field, random walk field)
FIELDS = {
    "accel": ("noise_density_g_per_rthz", "accel_bias_instability_g", "accel_random_walk_g_per_rts"),
    "gyro": ("noise_density_dps_per_rthz", "gyro_bias_instability_dps", "gyro_random_walk_dps_per_rts"),
    "mag": ("noise_ut", "mag_bias_instability_ut", "mag_random_walk_ut_per_rts"),
}


@dataclass
class UnitNoise:
    """One simulated unit's factors: ``factors[sensor][term]`` (3 per axis) and the noise config they give."""

    factors: dict
    noise: NoiseConfig
    white: dict  # sensor -> the unit's white-noise figure as its error model holds it

    def truth(self) -> dict:
        """For sim_truth.yaml: per sensor the factors and figures (bias instability as the registry states it and
        as the Allan deviation's floor, ``/ sqrt(2)``: docs/noise.md)."""
        out = {}
        for sensor, (_, b_field, k_field) in FIELDS.items():
            if sensor not in self.factors:
                continue
            b = list(map(float, getattr(self.noise, b_field)))
            out[sensor] = {"factors": {t: list(map(float, f)) for t, f in self.factors[sensor].items()},
                           "white": _plain(self.white[sensor]), "bias_instability": b,
                           "bias_instability_allan_floor": [x / math.sqrt(2) for x in b],
                           "random_walk": list(map(float, getattr(self.noise, k_field)))}
        return out


def _plain(v):
    return float(v) if np.isscalar(v) else [float(x) for x in v]


def draw_unit_noise(seed: int, base: NoiseConfig, errors: dict, spread: dict) -> UnitNoise:
    """Draw a unit's factors and apply them: ``errors`` (sensor -> its error model, or None for a sensor the chip
    lacks) have their white noise scaled in place; returns the factors and the scaled :class:`NoiseConfig`.
    ``spread``: term -> (lo, hi) factor range (a term not given: (1, 1))."""
    rng = own_stream(seed, UNIT_NOISE_STREAM)
    config = NoiseConfig(**base.to_dict())
    factors, white = {}, {}
    for sensor, (w_field, b_field, k_field) in FIELDS.items():
        draws = {t: np.exp(rng.uniform(*np.log(spread.get(t, (1.0, 1.0))), 3)) for t in SPREAD_TERMS}
        model = errors.get(sensor)
        if model is None:
            continue
        factors[sensor] = draws
        w = getattr(model, w_field)
        if np.isscalar(w):  # one figure for the three axes: one factor
            draws["white"] = np.full(3, draws["white"][0])
        w = float(w) * float(draws["white"][0]) if np.isscalar(w) else (np.asarray(w, float) * draws["white"]).tolist()
        setattr(model, w_field, w)
        white[sensor] = w
        setattr(config, b_field, (np.asarray(getattr(config, b_field), float) * draws["bias_instability"]).tolist())
        setattr(config, k_field, (np.asarray(getattr(config, k_field), float) * draws["random_walk"]).tolist())
    return UnitNoise(factors, config, white)
