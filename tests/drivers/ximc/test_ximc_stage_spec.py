"""Stage facts live in one place (drivers.ximc.stage_spec) and the driver and the emulator agree with them."""

from __future__ import annotations

import dataclasses

import pytest

from drivers.ximc.sim.emulator import StageModel
from drivers.ximc.stage import Stage
from drivers.ximc.stage_spec import MAX_SPEED_DEG_S, MR191, StageSpec


def test_the_8mr191_turns_at_most_48_deg_per_second():
    assert MR191.deg_per_step == 0.01 and MR191.nom_speed_steps_s == 4800
    assert MAX_SPEED_DEG_S == MR191.max_speed_deg_s == pytest.approx(48.0)
    assert MR191.steps_per_table_rev == 36000


def test_stage_spec_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        MR191.deg_per_step = 0.02  # type: ignore[misc]
    assert isinstance(MR191, StageSpec)


def test_driver_and_emulator_default_to_the_8mr191():
    assert Stage("loop://").deg_per_step == MR191.deg_per_step
    model = StageModel()
    assert (model.deg_per_step, model.steps_per_rev, model.nom_speed_steps_s) == (
        MR191.deg_per_step, MR191.steps_per_rev, MR191.nom_speed_steps_s)
