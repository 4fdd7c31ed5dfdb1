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
    assert err[0].startswith("planned: 6 steps, about ") and err[0].endswith(
        "of rig time (virtual time: as fast as this machine runs it)")
    assert err[1].startswith("session ")


def test_the_planned_duration_says_the_wall_time_of_a_time_scaled_rig():
    """The walkthrough: 'planned: 6 steps, about 2 min of rig time' and the run was over in 12 s (time scale 10)."""
    from types import SimpleNamespace

    from rig.workflow.run import wall_clock_words

    assert wall_clock_words(120.0, SimpleNamespace(time_scale=10.0)) == " (about 12 s at time scale 10)"
    assert wall_clock_words(120.0, SimpleNamespace(time_scale=1.0)) == ""  # hardware, or real time: the same
    assert wall_clock_words(120.0, SimpleNamespace(time_scale=None)) == " (virtual time: as fast as this machine runs it)"


def test_a_controller_port_that_is_not_there_says_what_to_do_as_rig_check_does(tmp_path, capsys):
    """The walkthrough: rig run (and rig jog) on the example hardware rig without its controllers gave the raw
    'cannot open port ([Errno 2] could not open port /dev/ximc/00003A5C: [Errno 2] No such file or directory: ...)'
    while rig check gave the cause and the fix."""
    code = main(["run", str(REPO / "procedures" / "six_position.yaml"), "--rig", str(REPO / "rigs" / "example_hardware.yaml"),
                 "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith("rig run: a1 /dev/ximc/") and "cannot open (no such file or directory)" in err[0]
    assert "udev rule" in err[0] and "rig ports" in err[0] and "Errno" not in err[0], err
    assert not (tmp_path / "s").exists()
