"""The rig file's optional ``fixture:`` section (docs/fixture.md): N slots, each on its bus, behind an optional
TCA9548A channel, with its chip, its mounting rotation and its unit's serial. A file without it reads as before;
a bad fixture is refused when the file is loaded, one line naming file, line and key (exit 2 from the command
line), before anything moves: two chips answering at one address, a channel the multiplexer does not have, a
rotation that is not one, a serial twice, more slots than the bus reads at the rate."""

from __future__ import annotations

import numpy as np
import pytest

from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError

from conftest import PROCEDURES, RIGS

RIG = (RIGS / "sim.yaml").read_text()


def _fixture(*slots: str, head: str = "") -> str:
    return RIG + "fixture:\n" + head + "  slots:\n" + "".join(f"    - {{{s}}}\n" for s in slots)


def _refused(text: str) -> str:
    with pytest.raises(RigInputError) as e:
        parse_rig_file(text, "r.yaml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("r.yaml:"), msg
    return msg


FIRST_SLOT_LINE = len(RIG.splitlines()) + 3  # "fixture:", "  slots:", then the slots


def test_a_rig_file_without_a_fixture_reads_as_before():
    assert parse_rig_file(RIG, "r.yaml").fixture is None


def test_eight_slots_behind_one_multiplexer_each_mounted_its_own_way():
    names = ["x+z+", "y+z+", "x-z+", "y-z+", "x+z-", "y+z-", "z+x+", "z-y+"]
    rig = parse_rig_file(_fixture(*(f"bus: sim, mux: 0x70, channel: {c}, rotation: {n}, serial: U{c}"
                                    for c, n in enumerate(names))), "r.yaml")
    fx = rig.fixture
    assert len(fx.slots) == 8 and fx.rate_hz == 100.0 and fx.bus_clock_hz == 400_000
    s = fx.slots[1]
    assert (s.bus, s.mux, s.channel, s.model, s.address, s.serial) == ("sim", 0x70, 1, "MPU-9150", 0x68, "U1")
    assert s.rotation.name == "y+z+"
    assert s.rotation.as_array() @ np.array([1.0, 0.0, 0.0]) == pytest.approx([0.0, 1.0, 0.0])
    assert fx.loads()["sim"].share == pytest.approx(0.3107, abs=1e-4)


def test_a_bus_is_a_device_path_or_its_number_and_both_name_one_bus():
    fx = parse_rig_file(_fixture("bus: 1, mux: 0x70, channel: 0, rotation: x+z+",
                                 "bus: /dev/i2c-1, mux: 0x70, channel: 1, rotation: x+z+"), "r.yaml").fixture
    assert [s.bus for s in fx.slots] == ["/dev/i2c-1", "/dev/i2c-1"] and list(fx.buses()) == ["/dev/i2c-1"]


def test_a_rotation_may_be_a_matrix_and_is_named_when_it_is_a_cube_rotation():
    fx = parse_rig_file(_fixture("bus: 1, rotation: [[0, -1, 0], [1, 0, 0], [0, 0, 1]]",
                                 "bus: 2, rotation: [[0.8660254037844387, 0, 0.5], [0, 1, 0], [-0.5, 0, 0.8660254037844387]]"),
                        "r.yaml").fixture
    assert fx.slots[0].rotation.name == "y+z+" and fx.slots[1].rotation.name is None


def test_slots_on_different_channels_buses_or_multiplexers_may_share_an_address():
    fx = parse_rig_file(_fixture("bus: 1, mux: 0x70, channel: 0, rotation: x+z+",
                                 "bus: 1, mux: 0x71, channel: 0, rotation: x+z+",
                                 "bus: 2, rotation: x+z+",
                                 "bus: 3, rotation: x+z+, model: ADXL345",
                                 "bus: 3, rotation: x+z+, model: ADXL345, address: 0x1D"), "r.yaml").fixture
    assert len(fx.slots) == 5


L = FIRST_SLOT_LINE
REFUSED = {
    "two chips at one address on one channel": (
        ("bus: sim, mux: 0x70, channel: 3, rotation: x+z+", "bus: sim, mux: 0x70, channel: 3, rotation: y+z+"),
        f"r.yaml:{L + 1}: fixture.slots[1].address: slot 0 and this slot both answer at 0x68 on sim, TCA9548A 0x70 "
        "channel 3, each with its MPU-9150; put them on different channels or buses"),
    "two MPU-9150s at 0x68 and 0x69 on one channel (the AK8975s behind their bypasses)": (
        ("bus: 1, mux: 0x70, channel: 0, rotation: x+z+", "bus: 1, mux: 0x70, channel: 0, address: 0x69, rotation: x+z+"),
        f"r.yaml:{L + 1}: fixture.slots[1].address: slot 0 and this slot both answer at 0x0c on /dev/i2c-1, "
        "TCA9548A 0x70 channel 0, each with its AK8975 magnetometer"),
    "a chip on the bus itself and one behind the multiplexer at the same address": (
        ("bus: 1, rotation: x+z+, model: ADXL345", "bus: 1, mux: 0x71, channel: 4, model: ADXL345, rotation: x+z+"),
        f"r.yaml:{L + 1}: fixture.slots[1].address: slot 0 and this slot both answer at 0x53 (slot 0 on /dev/i2c-1, "
        "on the bus itself, this one on /dev/i2c-1, TCA9548A 0x71 channel 4), each with its ADXL345"),
    "a channel beyond the multiplexer": (
        ("bus: 1, mux: 0x70, channel: 8, rotation: x+z+",),
        f"r.yaml:{L}: fixture.slots[0].channel: expected a channel of the TCA9548A, 0..7, got 8"),
    "a channel without a multiplexer": (
        ("bus: 1, channel: 2, rotation: x+z+",),
        f"r.yaml:{L}: fixture.slots[0].channel: a channel needs the TCA9548A it belongs to (mux: 0x70..0x77)"),
    "a multiplexer without a channel": (
        ("bus: 1, mux: 0x70, rotation: x+z+",),
        f"r.yaml:{L}: fixture.slots[0].mux: expected the TCA9548A channel of this slot (0..7)"),
    "a multiplexer address outside 0x70..0x77": (
        ("bus: 1, mux: 0x68, channel: 1, rotation: x+z+",),
        f"r.yaml:{L}: fixture.slots[0].mux: expected a TCA9548A address, 0x70..0x77, got 0x68"),
    "a rotation name that is not one": (
        ("bus: 1, rotation: x+x+",),
        f"r.yaml:{L}: fixture.slots[0].rotation: expected a rotation name such as x+z+ (where the slot's +x and +z "
        "point: one of x+y+, "),
    "a matrix that is not a rotation": (
        ("bus: 1, rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1.01]]",),
        f"r.yaml:{L}: fixture.slots[0].rotation: expected a rotation: R R^T differs from the identity by 0.0201"),
    "a mirror image": (
        ("bus: 1, rotation: [[1, 0, 0], [0, 1, 0], [0, 0, -1]]",),
        f"r.yaml:{L}: fixture.slots[0].rotation: expected a proper rotation (det +1), got det -1"),
    "a slot without its rotation": (
        ("bus: 1",), f"r.yaml:{L}: fixture.slots[0]: missing rotation (where the slot's +x and +z point, e.g. x+z+)"),
    "a serial twice": (
        ("bus: 1, mux: 0x70, channel: 0, rotation: x+z+, serial: A1",
         "bus: 1, mux: 0x70, channel: 1, rotation: x+z+, serial: A1"),
        f"r.yaml:{L + 1}: fixture.slots[1].serial: serial 'A1' is also slot 0's: each unit has its own"),
    "an address the chip cannot have": (
        ("bus: 1, rotation: x+z+, address: 0x53",),
        f"r.yaml:{L}: fixture.slots[0].address: expected one of 0x68, 0x69 for the MPU-9150, got 83"),
    "a device path that is not an I2C bus": (
        ("bus: /dev/i2c1, rotation: x+z+",),
        f"r.yaml:{L}: fixture.slots[0].bus: expected /dev/i2c-N (an I2C bus device), got '/dev/i2c1'"),
    "a misspelt key": (
        ("bus: 1, rotaton: x+z+",),
        f"r.yaml:{L}: fixture.slots[0].rotaton: unknown key (allowed: address, bus, channel, model, mux, rotation, "
        "serial): did you mean 'rotation'?"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_a_bad_fixture_is_one_line_at_its_key(case):
    slots, expect = REFUSED[case]
    assert _refused(_fixture(*slots)).startswith(expect)


def test_a_fixture_needs_slots():
    assert _refused(RIG + "fixture:\n  rate_hz: 100\n").endswith("fixture: missing slots (a list: one mapping per slot)")
    assert "fixture.slots: expected a list of at least one slot, got []" in _refused(RIG + "fixture:\n  slots: []\n")


def test_a_rate_some_chip_cannot_run_at_is_refused_at_the_rate():
    msg = _refused(_fixture("bus: 1, model: ADXL345, rotation: x+z+", head="  rate_hz: 1000\n"))
    assert msg == (f"r.yaml:{L - 1}: fixture.rate_hz: expected a rate every slot's chip runs at: the ADXL345 of slot 0 "
                   "cannot run at 1000 Hz")


EIGHT = tuple(f"bus: 1, mux: 0x70, channel: {c}, rotation: x+z+" for c in range(8))


def test_eight_mpu9150_slots_on_one_bus_at_100_hz_fit():
    assert parse_rig_file(_fixture(*EIGHT, head="  rate_hz: 100\n"), "r.yaml").fixture.loads()["/dev/i2c-1"].share < 0.5


def test_eight_mpu9150_slots_on_one_bus_at_1_khz_are_refused_with_the_numbers():
    msg = _refused(_fixture(*EIGHT, head="  rate_hz: 1000\n"))
    assert msg == (f"r.yaml:{L + 2}: fixture.slots[1].bus: bus /dev/i2c-1 cannot carry its 8 slots at 1000 Hz: "
                   "1243 kbit/s of wire time of its 400 kbit/s (311 %; a fixture may plan 50 %): it carries the first "
                   "1 at this rate, or at most 142.857 Hz for these 8 (docs/fixture.md, \"Bus budget\")")


def test_the_same_eight_slots_at_1_khz_on_eight_buses_fit():
    slots = tuple(f"bus: {c}, rotation: x+z+" for c in range(8))
    assert len(parse_rig_file(_fixture(*slots, head="  rate_hz: 1000\n"), "r.yaml").fixture.slots) == 8


def test_a_slow_bus_clock_carries_fewer():
    msg = _refused(_fixture(*EIGHT, head="  rate_hz: 100\n  bus_clock_hz: 100000\n"))
    assert "bus /dev/i2c-1 cannot carry its 8 slots at 100 Hz: 124 kbit/s of wire time of its 100 kbit/s" in msg


def test_a_bad_fixture_is_exit_2_from_the_command_line_before_anything_moves(tmp_path, capsys):
    from rig.cli import main
    p = tmp_path / "r.yaml"
    p.write_text(_fixture("bus: 1, mux: 0x70, channel: 9, rotation: x+z+"))
    code = main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(p), "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "fixture.slots[0].channel: expected a channel of the TCA9548A" in err[0]
    assert not (tmp_path / "s").exists()
