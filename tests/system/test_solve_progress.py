"""A long session's solve and discover say their stages on stderr as they start (issue 32 item 5: progress on long
inputs); a short one's stay as they were, and the progress never changes what stdout says."""

from __future__ import annotations


import pytest

from rig.cli.commands import discover as discover_command
from rig.cli.commands import solve as solve_command

from conftest import PROCEDURES
from cli_run import rig_in_process as _rig


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    out = tmp_path_factory.mktemp("progress")
    code, _, err = _rig("run", PROCEDURES / "six_position.yaml", "--time-scale", "0", "--seed", "4", "--quiet",
                        "--out", out)
    assert code == 0, err
    return next(p for p in out.iterdir() if p.is_dir())


def test_a_long_sessions_stages_go_to_stderr_in_order_and_stdout_is_unchanged(session, tmp_path, monkeypatch):
    code, quiet_out, quiet_err = _rig("solve", session, "-o", tmp_path / "a.yaml")
    assert code == 0 and "rig solve: reading" not in quiet_err
    monkeypatch.setattr(solve_command, "LONG_BYTES", 0)  # this session counts as long
    code, out, err = _rig("solve", session, "-o", tmp_path / "b.yaml")
    assert code == 0
    lines = [x for x in err.splitlines() if x.startswith("rig solve: ") and x.endswith(" s)")]
    assert [x.split(" (")[0] for x in lines] == ["rig solve: reading the session", "rig solve: solving 6 steps",
                                                 "rig solve: done: calibration written and recorded"], lines
    assert out.replace("b.yaml", "a.yaml") == quiet_out


def test_a_session_of_many_steps_is_long_whatever_its_size(session, tmp_path, monkeypatch):
    monkeypatch.setattr(solve_command, "LONG_STEPS", 5)
    code, _, err = _rig("solve", session, "-o", tmp_path / "c.yaml")
    assert code == 0 and "rig solve: solving 6 steps (" in err and "rig solve: reading" not in err


def test_a_long_sessions_discovery_says_its_passes_and_stdout_is_unchanged(session, monkeypatch):
    code, quiet_out, quiet_err = _rig("discover", session)
    assert code == 0 and "rig discover: " not in quiet_err
    monkeypatch.setattr(discover_command, "LONG_STEPS", 3)  # six static steps count as long
    code, out, err = _rig("discover", session)
    assert code == 0 and out == quiet_out
    stages = [x.split(" (")[0] for x in err.splitlines() if x.startswith("rig discover: ") and x.endswith(" s)")]
    assert stages[0] == "rig discover: the step means" and stages[-1] == "rig discover: done", stages
    assert "rig discover: what 6 steps observe of 13 candidate effects" in stages
    assert any(x.startswith("rig discover: forward pass 1: ") for x in stages), stages
