"""What can be known before recording is refused before a session directory exists: a procedure for
another sensor, a pose beyond the soft limits, a prompt nobody can answer (one line, exit 2)."""

from __future__ import annotations

import pytest
import yaml

from rig.cli import main

from conftest import REPO

HEAD = ("format: rig-procedure/1\nname: t\nsensor: {{accel_range_g: 4, sample_rate_hz: 100{model}}}\n"
        "dwell: {{seconds: 1}}\nsteps:\n")


@pytest.mark.parametrize("case, model, steps, expect", [
    ("other sensor", ", model: ADXL345", '  - pose: "+Z up"\n', "the procedure is for the ADXL345"),
    ("beyond the soft limits", "", '  - pose: "+Z up"\n  - angles_deg: [0, 0, 90]\n', "a3"),
    ("prompt and no operator", "", '  - prompt: "Mount the sensor"\n  - pose: "+Z up"\n', "--yes"),
])
def test_refused_with_one_line_and_no_session(tmp_path, capsys, case, model, steps, expect):
    (tmp_path / "p.yaml").write_text(HEAD.format(model=model) + steps)
    rig = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    rig["turntable"]["axes"]["a3"].update(soft_limits_deg=[-45, 45], cable_wrap_deg=45, slip_ring=False)
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(rig))
    code = main(["run", str(tmp_path / "p.yaml"), "--rig", str(tmp_path / "rig.yaml"), "--time-scale", "0",
                 "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and expect in err[0], err
    assert not (tmp_path / "s").exists()


def test_evaluate_refuses_a_calibration_of_another_range(tmp_path, capsys):
    # the shipped six positions with 1 s dwells: the ranges, not the samples, are what is refused (issue 26)
    text = (REPO / "procedures" / "six_position.yaml").read_text().replace("dwell: {seconds: 10}", "dwell: {seconds: 1}")
    six = tmp_path / "six4.yaml"
    six.write_text(text)
    assert main(["run", str(six), "--seed", "1", "--time-scale", "0", "--out", str(tmp_path / "a"), "--quiet"]) == 0
    other = text.replace("accel_range_g: 4", "accel_range_g: 8")
    (tmp_path / "six8.yaml").write_text(other)
    assert main(["run", str(tmp_path / "six8.yaml"), "--seed", "1", "--time-scale", "0", "--out",
                 str(tmp_path / "b"), "--quiet"]) == 0
    (a,), (b,) = (tmp_path / "a").iterdir(), (tmp_path / "b").iterdir()
    capsys.readouterr()
    assert main(["evaluate", str(a / "calibration.yaml"), str(b)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another range" in err[0]
    assert main(["evaluate", str(a / "calibration.yaml"), str(a)]) == 0


def test_resume_of_something_that_is_not_a_session_is_refused_and_leaves_nothing(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "file.yaml").write_text("x: 1\n")
    for target in (tmp_path / "empty", tmp_path / "file.yaml", tmp_path / "nosuch"):
        assert main(["run", "--resume", str(target)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "session.lock" not in err[0], err
    assert list((tmp_path / "empty").iterdir()) == []


def test_a_procedure_and_a_resume_together_are_refused(tmp_path, capsys):
    assert main(["run", str(REPO / "procedures" / "six_position.yaml"), "--resume", str(tmp_path)]) == 2
    assert "not both" in capsys.readouterr().err


def test_poses_that_cannot_calibrate_the_model_are_refused_before_anything_moves(tmp_path, capsys):
    """Two faces cannot determine the scale factors of x and y nor the misalignments: the run used to capture every
    pose (and wait out every chamber set-point) and only then fail in the solve, with no file or line."""
    text = ("format: rig-procedure/1\nname: two\nsensor: {accel_range_g: 4, sample_rate_hz: 100}\n"
            "dwell: {seconds: 1}\nsolve: {model: triangular, method: pinv}\nsteps:\n"
            '  - temperature: {target_c: 35}\n  - pose: "+Z up"\n  - pose: "-Z up"\n')
    (tmp_path / "two.yaml").write_text(text)
    code = main(["run", str(tmp_path / "two.yaml"), "--time-scale", "0", "--yes", "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"rig run: {tmp_path / 'two.yaml'}:5: solve: ") and "k_x" in err[0] and \
        "undetermined" in err[0] and "add poses" in err[0], err
    assert not (tmp_path / "s").exists()
    # without solve: the same poses are a recording, not a calibration: accepted
    (tmp_path / "rec.yaml").write_text(text.replace("solve: {model: triangular, method: pinv}\n", ""))
    assert main(["run", str(tmp_path / "rec.yaml"), "--time-scale", "0", "--yes", "--out", str(tmp_path / "r"),
                 "--quiet"]) == 0
