"""``sim.transport``: the emulated controllers on pseudo-terminals or in process (docs/simulated-rig.md)."""

from __future__ import annotations

import tempfile

import pytest

from conftest import RIGS
from rig.config.rigfile import load_rig_file
from rig.devices.registry import open_rig_file
from rig.errors import RigInputError
from rig.simulation import settings
from rig.simulation.simrig import SCALED_CLOCKS
from rig.simulation.simulated import TRANSPORT_ENV, TRANSPORT_OPENERS

BASE = (RIGS / "sim.yaml").read_text()


def _rig_file(tmp_path, extra: str = "", faults: str = ""):
    p = tmp_path / "rig.yaml"
    p.write_text(BASE.replace("  time_scale: 10\n", "  time_scale: 0\n" + extra) + faults)
    return load_rig_file(p)


def _moves_and_reads(rig) -> None:
    axis = rig.axes["a1"]
    axis.stage.move_deg(90.0)
    axis.stage.command_wait_for_stop()
    assert axis.stage.get_position_deg() == pytest.approx(90.0, abs=0.01)
    assert rig.describe()["sensor"]["model"] == "MPU-9150"


@pytest.mark.parametrize("transport,port,kind", [
    pytest.param("pty", "/dev/", "sim:8smc5-emulator", marks=pytest.mark.pty),
    ("memory", "ximcsim://", "sim:8smc5-emulator-in-memory")])
def test_either_transport_drives_the_same_controllers_through_the_stage_driver(tmp_path, monkeypatch, transport,
                                                                               port, kind):
    rig_file = _rig_file(tmp_path, f"  transport: {transport}\n")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))  # where the emulators make their ports' directories
    rig = open_rig_file(rig_file, seed=1)
    try:
        d = rig.describe()["turntable"]
        assert d["kind"] == kind and all(a["port"].startswith(port) for a in d["axes"].values())
        _moves_and_reads(rig)
    finally:
        rig.close()
    assert list(scratch.iterdir()) == []  # closing the rig removed what its emulators made


def test_the_environment_chooses_for_a_rig_file_that_does_not_say(tmp_path, monkeypatch):
    monkeypatch.setenv(TRANSPORT_ENV, "memory")
    rig = open_rig_file(_rig_file(tmp_path), seed=1)
    try:
        assert rig.describe()["turntable"]["kind"].endswith("in-memory")
    finally:
        rig.close()
    rig = open_rig_file(_rig_file(tmp_path, "  transport: pty\n"), seed=1)  # the file's word wins
    try:
        assert rig.describe()["turntable"]["axes"]["a1"]["port"].startswith("/dev/")
    finally:
        rig.close()


def test_a_bad_environment_value_is_one_line_naming_the_variable(tmp_path, monkeypatch):
    monkeypatch.setenv(TRANSPORT_ENV, "usb")
    with pytest.raises(RigInputError, match=r"RIG_SIM_TRANSPORT.*expected one of pty, memory, got 'usb'"):
        open_rig_file(_rig_file(tmp_path), seed=1)


def test_a_bad_transport_in_the_rig_file_names_file_line_and_key(tmp_path):
    with pytest.raises(RigInputError, match=r"rig\.yaml.*sim\.transport"):
        _rig_file(tmp_path, "  transport: usb\n")


def test_faults_of_the_serial_line_need_a_serial_line(tmp_path):
    faults = "faults:\n  ximc:\n    a2: {latency_s: 0.01}\n"
    with pytest.raises(RigInputError, match=r"faults\.ximc\.a2\.latency_s.*needs sim\.transport: pty"):
        open_rig_file(_rig_file(tmp_path, "  transport: memory\n", faults), seed=1)


def test_every_name_the_rig_file_schema_accepts_has_its_opener_and_clock():
    assert tuple(TRANSPORT_OPENERS) == settings.TRANSPORTS
    assert tuple(SCALED_CLOCKS) == settings.CLOCKS
