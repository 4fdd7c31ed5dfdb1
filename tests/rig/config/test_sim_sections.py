"""The sim: and faults: sections: owned by the simulator, registered with rig.config, never drifting."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import pytest

from rig.config.rigfile import AxisConfig, parse_rig_file
from rig.errors import RigInputError

from conftest import REPO, RIGS

RIG = (RIGS / "sim.yaml").read_text()


def _fields(cls) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


@pytest.mark.parametrize("schema_name,dataclass_path", [
    ("XimcFaultsSection", "drivers.ximc.sim.emulator:XimcFaults"),
    ("SensorFaultsSection", "drivers.sensors.sim.faults:SensorFaults"),
    ("ChamberSection", "rig.simulation.world:ChamberConfig"),
    ("RingingSection", "rig.simulation.world:RingingConfig"),
    ("FieldSection", "rig.simulation.world:FieldConfig"),
])
def test_the_schemas_have_exactly_the_simulators_fields_and_defaults(schema_name, dataclass_path):
    import importlib
    from rig.simulation import settings
    module, name = dataclass_path.split(":")
    cls = getattr(importlib.import_module(module), name)
    schema = getattr(settings, schema_name)
    assert list(schema.model_fields) == _fields(cls)
    defaults = schema().model_dump()
    assert defaults == dataclasses.asdict(cls())  # same defaults, and the dataclass takes every value
    assert cls(**defaults) == cls()


def test_every_fault_field_a_file_may_set_builds_the_simulators_dataclass():
    from drivers.ximc.sim.emulator import XimcFaults
    from drivers.sensors.sim.faults import SensorFaults
    rig = parse_rig_file(RIG + "faults:\n  ximc:\n    a1: {crc_corrupt_rate: 0.1, drop_rate: 0.1, truncate_rate: 0.1,"
                         " latency_s: 0.2, error_answer_rate: 0.1, error_answer: errc, vanish_at_s: 5,"
                         " vanish_for_s: 2, stall_at_deg: 30, limit_deg: -45, seed: 7}\n"
                         "  sensor: {oserror_rate: 0.01, oserror_window_s: [1, 2], dead_after_s: 9, stuck_after_s: 8,"
                         " saturate_after_s: 7, thermometer_fail_after_s: 6, seed: 2, failed_self_test: true}\n", "r.yaml")
    assert XimcFaults(**rig.faults["ximc"]["a1"]).stall_at_deg == 30.0
    assert SensorFaults(**rig.faults["sensor"]).oserror_window_s == [1.0, 2.0]
    assert set(rig.faults["ximc"]["a1"]) == set(_fields(XimcFaults))
    assert set(rig.faults["sensor"]) == set(_fields(SensorFaults))


def test_error_model_overrides_accept_exactly_the_error_models_fields():
    from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel, MagErrorModel
    from rig.simulation.settings import AccelOverrides, GyroOverrides, MagOverrides
    for schema, cls in ((AccelOverrides, AccelErrorModel), (GyroOverrides, GyroErrorModel),
                        (MagOverrides, MagErrorModel)):
        assert list(schema.model_fields) == _fields(cls)


#: what a fresh interpreter prints about a rig file it loads: the sections (or the one-line refusal) and whether
#: the simulator was loaded; ``{before}`` is what the program imports first, ``{wire}`` how it is wired
LOAD_PROBE = """
import json, sys
{before}
import rig.config.rigfile
from rig.errors import RigInputError
def simulator_loaded():
    return sorted({{m.split('.')[0] + '.' + m.split('.')[1] for m in sys.modules
                    if m.startswith(('rig.simulation', 'drivers.ximc.sim', 'drivers.sensors.sim'))}})
{wire}
loaded_before = simulator_loaded()
hardware = rig.config.rigfile.load_rig_file('rigs/example_hardware.yaml')
try:
    rig = rig.config.rigfile.load_rig_file('rigs/sim.yaml')
    answer = {{'sim': rig.sim, 'faults': rig.faults}}
except RigInputError as exc:
    answer = str(exc)
print(json.dumps({{'answer': answer, 'loaded_before': loaded_before, 'hardware': hardware.kind,
                  'settings': 'rig.simulation.settings' in sys.modules}}, sort_keys=True, default=str))
"""


def _load_in_a_fresh_interpreter(before: str, wire: str) -> dict:
    code = LOAD_PROBE.format(before=before, wire=wire)
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_wired_program_loads_a_simulated_rig_file_alike_whatever_it_imported_before():
    """The composition root wires the sections' provider without loading the simulator; the first sim: section
    loads it, and the answer is the same whether the simulator, the workflows or nothing was imported first."""
    wire = "import rig.composition\nrig.composition.wire()"
    plain = _load_in_a_fresh_interpreter("", wire)
    assert plain["loaded_before"] == [] and plain["settings"] and plain["hardware"] == "hardware"
    assert isinstance(plain["answer"], dict) and plain["answer"]["sim"]["time_scale"] == 10
    simulator_first = _load_in_a_fresh_interpreter("import rig.simulation", wire)
    workflows = _load_in_a_fresh_interpreter("import rig.workflow.run", "")  # wired by rig.workflow.kinds
    assert workflows["loaded_before"] == []
    assert simulator_first["answer"] == workflows["answer"] == plain["answer"]


def test_an_unwired_program_refuses_a_sim_section_whatever_it_imported_before():
    """rig.config alone imports no simulator and, unwired, refuses the sim: section on its line, also when the
    simulator was imported (its schemas registered themselves); a hardware rig file loads."""
    plain = _load_in_a_fresh_interpreter("", "")
    assert plain["loaded_before"] == [] and not plain["settings"] and plain["hardware"] == "hardware"
    assert plain["answer"].startswith("rigs/sim.yaml:16: sim: no provider of the 'sim' section is wired into this "
                                      "program") and "rig.composition.wire()" in plain["answer"]
    simulator_first = _load_in_a_fresh_interpreter("import rig.simulation", "")
    assert simulator_first["answer"] == plain["answer"]


def test_a_sim_section_is_located_and_belongs_only_to_simulated_rigs():
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(RIG.replace("chamber: {initial_c: 27.6", "chamber: {initial_c: 27.6, colour: 1"), "r.yaml")
    assert str(exc.value).startswith("r.yaml:19: sim.chamber.colour: unknown key (allowed: initial_c, tau_s)")
    hardware = (RIGS / "example_hardware.yaml").read_text()
    for extra in ("sim: {time_scale: 0}\n", "faults: {sensor: {seed: 1}}\n"):
        with pytest.raises(RigInputError, match=r"h.yaml:13: (sim|faults): a \w+ section belongs only in a rig "
                                                r"file with kind: sim"):
            parse_rig_file(hardware + extra, "h.yaml")


def test_sim_settings_come_from_the_validated_section():
    from rig.simulation.settings import SimSettings
    rig = parse_rig_file(RIG + "  effects: {table_tilt: [0.1, -0.05]}\n  gyro_errors: {g_sensitivity_dps_per_g: 0}\n",
                         "r.yaml")
    s = SimSettings.from_mapping(rig.sections["sim"])
    assert s.time_scale == 10 and s.chamber.initial_c == 27.6 and s.effects == {"table_tilt": [0.1, -0.05]}
    assert s.gyro_errors == {"g_sensitivity_dps_per_g": 0.0} and s.errors == {}
    assert SimSettings.from_mapping(rig.sim) == s  # the plain mapping gives the same settings
    with pytest.raises(RigInputError, match="^x.yaml: sim.time_scale: expected >= 0, got -2$"):
        SimSettings.from_mapping({"time_scale": -2}, "x.yaml: sim")


def test_axis_config_is_the_one_immutable_axis_type():
    rig = parse_rig_file(RIG, "r.yaml")
    a1 = rig.axes["a1"]
    assert a1.name == "a1" and a1.slip_ring and a1.port is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        a1.port = "/dev/x"
    moved = a1.with_port("/dev/pts/7", 0x5A00)
    assert (moved.port, moved.serial, moved.name, moved.speed_deg_s) == ("/dev/pts/7", 0x5A00, "a1", 20.0)
    assert dataclasses.replace(a1, port="/dev/pts/8").port == "/dev/pts/8"
    assert AxisConfig(name="a2").soft_limits_deg == (-400.0, 400.0)  # one set of defaults
    assert [f.name for f in dataclasses.fields(AxisConfig)] == [
        "name", "port", "serial", "sign", "home_offset_deg", "speed_deg_s", "accel_deg_s2", "soft_limits_deg",
        "cable_wrap_deg", "slip_ring", "approach", "overshoot_deg"]
    with pytest.raises(Exception):
        AxisConfig(name="a1", speed_deg_s=60)  # validated on construction too
    with pytest.raises(RigInputError, match=r"turntable.axes.a1.name: unknown key"):
        parse_rig_file(RIG.replace("a1: {sign: 1,", "a1: {name: a2, sign: 1,"), "r.yaml")
