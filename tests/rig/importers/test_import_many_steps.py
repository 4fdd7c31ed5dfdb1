"""An import takes as many steps as a session holds (10,000), and does not try the follow-up commands on
more than 100 steps (rig discover refits at every step boundary: minutes on thousands of steps)."""

from __future__ import annotations

import pytest

from rig.cli import main
from rig.cli.commands import import_ as command

HEAD = "# units: g\nt_s,ax,ay,az,label\n"


def _steps(path, steps: int, rows: int) -> None:
    faces = ["+Z up", "-Z up"]
    lines, t = [], 0.0
    for k in range(steps):
        z = 1 if k % 2 == 0 else -1
        for i in range(rows):
            lines.append(f"{t:.2f},0.001,{0.002 * (i % 3):.3f},{z},{faces[k % 2]}")
            t += 0.01
    path.write_text(HEAD + "\n".join(lines) + "\n")


@pytest.mark.parametrize("steps, expected", [(6000, "a static step needs at least 10"),
                                             (10001, "changes more than 10000 times")])
def test_up_to_10000_steps_are_read(tmp_path, capsys, steps, expected):
    _steps(tmp_path / "r.csv", steps, 1)
    assert main(["import", "--from", "csv", str(tmp_path / "r.csv"), "-o", str(tmp_path / "s")]) == 2
    assert expected in capsys.readouterr().err


def test_the_follow_up_commands_are_not_tried_on_more_than_100_steps(tmp_path, capsys):
    _steps(tmp_path / "r.csv", 150, 10)
    assert main(["import", "--from", "csv", str(tmp_path / "r.csv"), "-o", str(tmp_path / "s"), "--id", "r"]) == 0
    assert "next (not tried on 1500 samples in 150 steps)" in capsys.readouterr().out


def test_a_long_import_shows_its_progress(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(command, "PROGRESS_STEPS", 100)
    _steps(tmp_path / "r.csv", 150, 10)
    assert main(["import", "--from", "csv", str(tmp_path / "r.csv"), "-o", str(tmp_path / "s"), "--id", "r"]) == 0
    assert "rig import: 150 of 150 steps written" in capsys.readouterr().err
