"""Rig-file values the adversarial campaign found accepted or crashing later: an empty name, fault values
of the wrong type, error-model overrides and effects of the wrong shape. Each is refused when the file is
loaded, as one line naming the file, line and key; nothing reaches the simulator."""

from __future__ import annotations

import dataclasses

import pytest
import yaml

from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError

from conftest import RIGS

RIG = (RIGS / "sim.yaml").read_text()


def _refused(text: str) -> str:
    with pytest.raises(RigInputError) as e:
        parse_rig_file(text, "r.yaml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("r.yaml:"), msg
    return msg


@pytest.mark.parametrize("name", ['""', "'   '"])
def test_an_empty_rig_name_is_refused(name):
    msg = _refused(RIG.replace("name: sim", f"name: {name}"))
    assert msg.startswith("r.yaml:5: name: expected a non-empty name"), msg


def test_a_rig_name_that_is_a_number_is_still_its_text():
    assert parse_rig_file(RIG.replace("name: sim", "name: 7"), "r.yaml").name == "7"


def _fault_fields():
    from drivers.sensors.sim.faults import SensorFaults
    from drivers.ximc.sim.emulator import XimcFaults
    return ([("ximc.a1", f.name) for f in dataclasses.fields(XimcFaults)]
            + [("sensor", f.name) for f in dataclasses.fields(SensorFaults)])


WRONG_TYPES = {"a word": "soon", "a numeric string": "0.5", "a list": [0.1], "a mapping": {"rate": 0.1},
               "a nested list": [[1, 2]]}


@pytest.mark.parametrize("where,field", _fault_fields())
@pytest.mark.parametrize("kind", sorted(WRONG_TYPES))
def test_every_fault_field_refuses_values_of_the_wrong_type(where, field, kind):
    value = WRONG_TYPES[kind]
    if field == "oserror_window_s" and kind == "a list":
        value = ["0", "5"]
    section = {"ximc": {"a1": {field: value}}} if where == "ximc.a1" else {"sensor": {field: value}}
    msg = _refused(RIG + yaml.safe_dump({"faults": section}, default_flow_style=None))
    assert f"faults.{where}.{field}: expected" in msg, msg


def test_the_largest_seed_is_a_whole_number():
    rig = parse_rig_file(RIG + f"faults: {{sensor: {{seed: {2**63 - 1}}}}}\n", "r.yaml")
    assert rig.faults["sensor"]["seed"] == 2**63 - 1


@pytest.mark.parametrize("sim,expect", [
    ("errors: {bias_g: [0.1, 0.2]}", "sim.errors.bias_g: expected a number or 3 numbers"),
    ("errors: {matrix: [1, 2, 3]}", "sim.errors.matrix: expected a 3x3 list of numbers"),
    ("errors: {matrix: [[1, 0], [0, 1]]}", "sim.errors.matrix: expected a 3x3 list of numbers"),
    ("errors: {t_ref_c: [1, 2, 3]}", "sim.errors.t_ref_c: expected a number"),
    ("errors: {bias_jump_t_s: [1, 2]}", "sim.errors.bias_jump_t_s: expected a number"),
    ("errors: {noise_density_g_per_rthz: [-1, 0, 0]}", "sim.errors.noise_density_g_per_rthz: expected numbers >= 0"),
    ("effects: {table_tilt: [1, 2, 3]}", "sim.effects.table_tilt: expected a number or 2 numbers"),
    ("effects: {full_misalignment: [[1]]}", "sim.effects.full_misalignment: expected a number"),
    ("effects: {bias_tempco: [[1, 2], [3]]}", "sim.effects.bias_tempco: expected a number or 3 numbers"),
    ("effects: {bias_jump_t_s: [1, 2, 3]}", "sim.effects.bias_jump_t_s: expected a number"),
    ("mag_errors: {hard_iron_ut: [[1]]}", "sim.mag_errors.hard_iron_ut: expected a number or 3 numbers"),
    ("gyro_errors: {matrix: [1, 2]}", "sim.gyro_errors.matrix: expected a number or a 3x3 list"),
])
def test_error_model_overrides_and_effects_of_the_wrong_shape_are_refused_on_load(sim, expect):
    msg = _refused(RIG + f"  {sim}\n")
    assert expect in msg, msg


def test_overrides_of_the_right_shape_are_kept_as_given():
    rig = parse_rig_file(RIG + "  errors: {bias_g: 0.01, matrix: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}\n"
                         "  gyro_errors: {g_sensitivity_dps_per_g: 0}\n"
                         "  effects: {table_tilt: 0.1, full_misalignment: [0.3], scale_nonlinearity: [0.002, 0, 0]}\n",
                         "r.yaml")
    assert rig.sim["errors"] == {"bias_g": 0.01, "matrix": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}
    assert rig.sim["gyro_errors"] == {"g_sensitivity_dps_per_g": 0.0}
    assert rig.sim["effects"] == {"table_tilt": 0.1, "full_misalignment": [0.3], "scale_nonlinearity": [0.002, 0.0, 0.0]}
