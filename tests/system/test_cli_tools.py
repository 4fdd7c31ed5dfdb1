"""`rig sim`, `rig ports` and the progress a technician sees."""

from __future__ import annotations

import io
import re

from rig.cli import main
from rig.cli.console import ConsoleUI
from rig.execution.operator import OperatorAbsent, StepProgress

import pytest


@pytest.mark.pty
def test_rig_sim_starts_controllers_libximc_can_open_and_shows_the_sensor(capsys):
    assert main(["sim", "--once", "--time-scale", "5"]) == 0
    out = capsys.readouterr().out.splitlines()
    ports = [line for line in out if "xi-com:" in line]
    assert len(ports) == 3 and all(re.search(r"/dev/pts/\d+", p) for p in ports)
    assert any(line.startswith("sensor  MPU-9150 at 0x68") and "g" in line for line in out)


def test_rig_ports_lists_what_it_finds_without_failing(capsys):
    assert main(["ports"]) == 0
    out = capsys.readouterr().out
    assert "serial" in out and "i2c" in out


def test_plain_progress_is_one_line_per_phase_with_eta_and_the_captures_noise_when_it_is_done():
    buf = io.StringIO()
    ui = ConsoleUI(buf)
    for phase, noise_ug in (("move", None), ("settle", None), ("capture", 5500.0), ("capture", 3300.0)):
        ui.progress(StepProgress(2, 6, "+X up", phase, eta_s=9.0, noise_ug=noise_ug, run_eta_s=75.0))
    assert buf.getvalue().splitlines()[-1] == "[3/6] +X up: capture  ETA 9s  run ETA 1m15s"
    ui.progress(StepProgress(3, 6, "-Z up", "move", run_eta_s=60.0))
    lines = buf.getvalue().splitlines()
    assert len(lines) == 5
    assert lines[-2] == "[3/6] +X up: done  noise 3300 ug  run ETA 1m15s"  # all the capture's samples


def test_an_aborted_capture_is_not_reported_done():
    buf = io.StringIO()
    ui = ConsoleUI(buf)
    ui.progress(StepProgress(0, 6, "+Z up", "capture", noise_ug=3300.0))
    ui.close()
    assert "done" not in buf.getvalue()
    ui = ConsoleUI(buf)
    ui.progress(StepProgress(5, 6, "-Y up", "capture", noise_ug=3300.0))
    ui.close(finished=True)
    assert buf.getvalue().splitlines()[-1] == "[6/6] -Y up: done  noise 3300 ug"


def test_prompts_without_a_terminal_fail_clearly_unless_confirmed():
    ui = ConsoleUI(io.StringIO(), interactive=False)
    with pytest.raises(OperatorAbsent, match="--yes"):
        ui.confirm("Set the chamber to 30 C")
    assert ConsoleUI(io.StringIO(), assume_yes=True).confirm("Set the chamber to 30 C")
