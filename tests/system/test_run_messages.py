"""What a technician is told before and after a run: the planned duration before anything moves,
the exact resume command when it stops."""

from __future__ import annotations

from rig.cli import main

from conftest import REPO

#: the shipped six-position procedure with 1 s dwells: what is said is the same, the run a fifth as long
#: (the lines, not the data, are what this file checks; issue 26)
SIX_SHORT = (REPO / "procedures" / "six_position.yaml").read_text().replace("dwell: {seconds: 10}", "dwell: {seconds: 1}")


def test_the_planned_duration_is_said_before_the_session_starts(tmp_path, capsys):
    six = tmp_path / "six_position.yaml"
    six.write_text(SIX_SHORT)
    assert main(["run", str(six), "--seed", "2", "--time-scale", "0", "--out", str(tmp_path / "s")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("planned: 6 steps, about ") and err[0].endswith("of rig time")
    assert err[1].startswith("session ")
