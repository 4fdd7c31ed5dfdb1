"""A turntable session's misfit is judged against the noise and against the rig's own errors (issue 29;
calib.accel.rig_misfit): a table with its own errors at its classes fits once they are counted, and the run says
so in a note naming the characterisation that takes them out; a real misfit on that table (poses placed by hand,
1 deg) is still a warning; a misfit on a table without errors does not blame the table."""

from __future__ import annotations

import contextlib
import io

import yaml

from rig.cli import main

from conftest import PROCEDURES, RIGS


def _run(tmp_path, sim: dict) -> tuple[str, dict]:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, **sim)
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(doc))
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(tmp_path / "rig.yaml"), "--seed", "1",
                     "--time-scale", "0", "--quiet", "--out", str(tmp_path / "s")])
    assert code == 0
    (session,) = (tmp_path / "s").iterdir()
    return err.getvalue(), yaml.safe_load((session / "calibration.yaml").read_text())["accelerometer"]


def test_a_table_with_its_own_errors_fits_once_they_are_counted_and_the_note_names_the_characterisation(tmp_path):
    err, accel = _run(tmp_path, {"geometry": {"enabled": True}})
    assert accel["fit"]["chi2_per_dof"] > 3  # beyond the noise alone: the table's errors are several counts
    judged = accel["uncertainty"]["misfit_with_rig"]
    assert not judged["significant"] and judged["dof"] == 9 and judged["chi2_per_dof"] < 2
    assert "does not fit the data" not in err
    note = next(x for x in err.splitlines() if "note: the fit is worse than the noise alone" in x)
    assert "the turntable's own errors" in note and "rig characterize-rig" in note


def test_poses_placed_by_hand_on_that_table_are_still_a_misfit(tmp_path):
    err, accel = _run(tmp_path, {"geometry": {"enabled": True}, "effects": {"pose_error": 1.0}})
    assert accel["uncertainty"]["misfit_with_rig"]["significant"]
    line = next(x for x in err.splitlines() if "does not fit the data" in x)
    assert "the turntable's own errors" in line and "rig characterize-rig" in line


def test_a_misfit_on_a_table_without_errors_does_not_blame_the_table(tmp_path):
    err, accel = _run(tmp_path, {"effects": {"pose_error": 1.0}, "geometry": {"enabled": False}})  # hand-placed, perfect table
    assert accel["uncertainty"]["misfit_with_rig"]["significant"]
    line = next(x for x in err.splitlines() if "does not fit the data" in x)
    assert "rig characterize-rig" not in line
