"""``rig discover`` on more steps than it can fit in reasonable time is refused at once, in one line naming the
limit and the reason (issue 32 item 5: "grows at most as n log n, or refuses with the limit and the reason"); it
was minutes to hours (600 steps: 69 s, 10,000 steps: not finished)."""

from __future__ import annotations

from rig.analysis import discover as dsc
from rig.cli import main
from rig.importers.recordings import import_recording

from test_import_fsync import _csv


def test_more_steps_than_the_limit_are_refused_with_the_limit_and_the_reason(tmp_path, capsys, monkeypatch):
    final = import_recording("csv", _csv(tmp_path / "r.csv", 12), tmp_path / "s", "r")
    monkeypatch.setattr(dsc, "MAX_DISCOVER_STEPS", 11)
    assert main(["discover", str(final)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "12 static steps: rig discover fits at most 11" in err and "the square to the cube of the steps" in err
    assert "rig solve" in err


def test_the_limit_is_where_a_discovery_takes_well_under_a_minute():
    assert dsc.MAX_DISCOVER_STEPS == 400  # the slowest path seen at 450 steps took 31 s (2 cores)
