"""Simulated units unlike their family (issue 28 item 6): ``sim: noise_spread:`` draws each unit's noise figures
about the chip registry's, records them in sim_truth.yaml and leaves every other draw of the seed as it was."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.sensors.chips import CHIPS
from rig.errors import RigInputError
from rig.simulation.settings import SimSettings
from rig.simulation.simrig import SimulatedRig

SPREAD = {"white": [0.5, 2.0], "bias_instability": [0.5, 2.0], "random_walk": [0.5, 2.0]}


def _rig(seed: int, **sim) -> SimulatedRig:
    return SimulatedRig(SimSettings.from_mapping({"time_scale": 0, "transport": "memory", **sim}), seed=seed)


def test_each_unit_draws_its_own_figures_within_the_spread():
    spec = CHIPS["MPU-9150"]
    units = [_rig(seed, noise_spread=SPREAD) for seed in range(8)]
    b = np.array([u.chip.noise.accel_bias_instability_g for u in units]) / spec.accel_bias_instability_g
    k = np.array([u.chip.noise.gyro_random_walk_dps_per_rts for u in units]) / spec.gyro_random_walk_dps_per_rts
    n = np.array([u.accel_errors.noise_density_g_per_rthz for u in units]) / np.array(spec.accel_noise_density_g_rthz)
    for f in (b, k, n):
        assert f.min() >= 0.5 and f.max() <= 2.0 and f.min() < 0.75 and f.max() > 1.4  # spread, not one figure
        assert len(np.unique(np.round(f, 12))) == f.size  # every axis of every unit its own
    assert units[3].chip.sampler.accel_noise.random_walk.tolist() == units[3].chip.noise.accel_random_walk_g_per_rts


def test_the_truth_records_the_factors_and_figures_and_nothing_else_of_the_seed_changes():
    family, unit = _rig(5), _rig(5, noise_spread=SPREAD)
    truth = unit.truth()["unit_noise"]
    assert set(truth) == {"accel", "gyro", "mag"}
    accel = truth["accel"]
    assert accel["bias_instability"] == pytest.approx(
        np.array(accel["factors"]["bias_instability"]) * CHIPS["MPU-9150"].accel_bias_instability_g)
    assert accel["bias_instability_allan_floor"] == pytest.approx(np.array(accel["bias_instability"]) / np.sqrt(2))
    assert truth["mag"]["white"] == pytest.approx(0.3 * truth["mag"]["factors"]["white"][0])
    assert family.accel_errors.bias_g == unit.accel_errors.bias_g and family.mag_errors.hard_iron_ut == \
        unit.mag_errors.hard_iron_ut
    assert "unit_noise" not in family.truth()


def test_a_bad_spread_is_one_line_naming_the_key():
    with pytest.raises(RigInputError, match=r"^r.yaml: sim.noise_spread.white: expected \[lo, hi\] factors with "
                                            r"0.01 <= lo <= hi <= 100, got \[2, 0.5\]$"):
        SimSettings.from_mapping({"noise_spread": {"white": [2, 0.5]}}, "r.yaml: sim")
    with pytest.raises(RigInputError, match="sim.noise_spread.flicker: unknown key"):
        SimSettings.from_mapping({"noise_spread": {"flicker": [1, 2]}}, "r.yaml: sim")
