"""What a technician is told before and after a run: the planned duration before anything moves,
the exact resume command when it stops."""

from __future__ import annotations

from rig.cli import main

from conftest import REPO

SIX = str(REPO / "procedures" / "six_position.yaml")


def test_the_planned_duration_is_said_before_the_session_starts(tmp_path, capsys):
    assert main(["run", SIX, "--seed", "2", "--time-scale", "0", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("planned: 6 steps, about ") and err[0].endswith("of rig time")
    assert err[1].startswith("session ")
