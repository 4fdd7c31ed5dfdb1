"""Fault campaign: under faults and bad input the rig keeps its data, stops its motors and says what went wrong."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from calib.file import calibration as calfile
from calib.errors import CalibrationFileError
from drivers.clock import VirtualClock
from drivers.ximc.sim.emulator import ControllerEmulator, XimcFaults
from drivers.ximc.stage import Stage
from rig.cli import main
from rig.errors import RigInputError, SessionFormatError
from rig.config.procedure import load_procedure_text
from rig.config.rigfile import parse_rig_file
from rig.session import load_session

from conftest import PROCEDURES, RIGS

SIX = str(PROCEDURES / "six_position.yaml")


def _rig_file(tmp_path: Path, extra: str = "", **replace) -> Path:
    text = (RIGS / "sim.yaml").read_text().replace("time_scale: 10", "time_scale: 0")
    for old, new in replace.items():
        text = text.replace(old, new)
    p = tmp_path / "rig.yaml"
    p.write_text(text + extra)
    return p


def _session(root: Path) -> Path:
    (d,) = [p for p in root.iterdir() if p.is_dir()]
    return d


@pytest.mark.pty
def test_200_ms_answer_latency_is_tolerated():
    clock = VirtualClock()
    emu = ControllerEmulator(5, clock=clock, faults=XimcFaults(latency_s=0.2))
    stage = Stage(emu.start(), clock=clock, name="a1", timeout_s=0.5)
    try:
        stage.open()
        stage.move_deg(1.0)
        assert stage.get_position_deg() == pytest.approx(0.0, abs=1.0)  # answers arrive, late
        assert stage.get_serial_number() == 5
    finally:
        stage.close()
        emu.stop()


def test_a_burst_of_i2c_errors_is_survived_by_measuring_the_step_again(tmp_path):
    rig = _rig_file(tmp_path, "faults:\n  sensor: {oserror_window_s: [37.0, 37.5]}\n")
    assert main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "s"), "--quiet"]) == 0
    d = _session(tmp_path / "s")
    events = [json.loads(x) for x in (d / "events.jsonl").read_text().splitlines()]
    assert any("measuring step" in e.get("message", "") for e in events)
    s = load_session(d)
    assert all(len(s.step_samples(i)["t_s"]) == 1000 for i in range(6))


def test_poses_beyond_the_soft_limits_are_refused_before_anything_moves(tmp_path, capsys):
    rig = _rig_file(tmp_path, **{"soft_limits_deg: [-400, 400], cable_wrap_deg: 400}\n    a3":
                                 "soft_limits_deg: [-400, 400], cable_wrap_deg: 400}\n    a3"})
    rig.write_text(rig.read_text().replace(
        "a3: {sign: 1, speed_deg_s: 20, accel_deg_s2: 40, soft_limits_deg: [-400, 400], cable_wrap_deg: 400, slip_ring: true}",
        "a3: {sign: 1, speed_deg_s: 20, accel_deg_s2: 40, soft_limits_deg: [-100, 100], cable_wrap_deg: 400, slip_ring: true}"))
    code = main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err[-1].startswith("rig run: ") and "six_position.yaml:" in err[-1] and "-Z up: a3" in err[-1]
    assert "unreachable" in err[-1]
    # refused before a session directory exists, so certainly before any move command left
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())


def test_speed_caps_are_enforced_before_any_command_is_sent(tmp_path):
    with pytest.raises(RigInputError, match="at most 48"):
        parse_rig_file((RIGS / "sim.yaml").read_text().replace("speed_deg_s: 20", "speed_deg_s: 50"), "r.yaml")


@pytest.fixture
def tiny_disk(tmp_path):
    mnt = tmp_path / "disk"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=160k", "tmpfs", str(mnt)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {r.stderr.decode().strip()}")
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def test_a_full_disk_is_one_clear_line_and_loses_nothing_already_written(tmp_path, tiny_disk, capsys):
    code = main(["run", SIX, "--out", str(tiny_disk), "--time-scale", "0", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert err[-1].startswith("rig run: No space left on device")
    d = _session(tiny_disk)
    copy = tmp_path / "copy"
    shutil.copytree(d, copy)
    s = load_session(copy)  # the manifest and the committed samples are intact
    done = [st_["index"] for st_ in s.info.to_dict()["steps"] if st_["status"] == "complete"]
    assert done, "some steps were written before the disk filled"
    for i in done:
        assert len(s.step_samples(i)["t_s"]) == 1000


# -- fuzzing the three loaders: either a value or one located error, never anything else -------------------
SIX_TEXT = (PROCEDURES / "six_position.yaml").read_text()
RIG_TEXT = (RIGS / "sim.yaml").read_text()


def _mutations(text: str):
    return st.tuples(st.integers(0, len(text)), st.integers(0, 12),
                     st.text(alphabet=st.sampled_from(list(":-[]{}\n #\"'!&*|>%@,0123456789abcxyzXYZ.")), max_size=12))


def _mutate(text, m):
    i, n, ins = m
    return text[:i] + ins + text[i + n:]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_mutations(SIX_TEXT))
def test_fuzzed_procedures_load_or_fail_with_one_located_line(m):
    try:
        load_procedure_text(_mutate(SIX_TEXT, m), "p.yaml")
    except RigInputError as exc:
        assert str(exc).startswith("p.yaml") and "\n" not in str(exc)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_mutations(RIG_TEXT))
def test_fuzzed_rig_files_load_or_fail_with_one_located_line(m):
    try:
        parse_rig_file(_mutate(RIG_TEXT, m), "r.yaml")
    except RigInputError as exc:
        assert str(exc).startswith("r.yaml") and "\n" not in str(exc)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec")
    assert main(["run", SIX, "--out", str(out), "--time-scale", "0", "--quiet"]) == 0
    return _session(out)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.data())
def test_fuzzed_sessions_and_calibrations_load_or_fail_with_one_line(recorded, tmp_path_factory, data):
    d = tmp_path_factory.mktemp("fz") / "s"
    shutil.copytree(recorded, d)
    target = data.draw(st.sampled_from(["session.yaml", "samples.csv", "calibration.yaml"]))
    text = (d / target).read_text()
    m = data.draw(_mutations(text[:4000]))
    (d / target).write_text(_mutate(text, m))
    try:
        if target == "calibration.yaml":
            cal = calfile.read(d / target)
            assert np.all(np.isfinite(cal.accelerometer.matrix_counts_per_g))
        else:
            s = load_session(d)
            s.step_means()
    except (SessionFormatError, CalibrationFileError) as exc:
        assert "\n" not in str(exc)
