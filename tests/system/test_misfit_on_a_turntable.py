"""A misfit on a turntable whose own errors the budget holds only by their classes names the rig's
characterisation as the way to take them out (issue 29); a misfit elsewhere does not."""

from __future__ import annotations

import contextlib
import io

import yaml

from rig.cli import main

from conftest import PROCEDURES, RIGS


def _run(tmp_path, sim: dict) -> str:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, **sim)
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(doc))
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(tmp_path / "rig.yaml"), "--seed", "1",
                     "--time-scale", "0", "--quiet", "--out", str(tmp_path / "s")])
    assert code == 0
    return err.getvalue()


def test_an_uncharacterised_table_with_its_own_errors_points_to_the_characterisation(tmp_path):
    err = _run(tmp_path, {"geometry": {"enabled": True}})
    line = next(x for x in err.splitlines() if "does not fit the data" in x)
    assert "the turntable's own errors" in line and "rig characterize-rig" in line


def test_a_misfit_on_a_table_without_errors_does_not_blame_the_table(tmp_path):
    err = _run(tmp_path, {"effects": {"pose_error": 1.0}})  # hand-placed poses on a perfect table
    line = next(x for x in err.splitlines() if "does not fit the data" in x)
    assert "rig characterize-rig" not in line
