"""Poses not where they should be (issue 32 item 4, the solver's part): when the recorded directions disagree
with the nominal poses beyond the noise, the default method says so in one line with the misplacement per step
and the command to run, and writes no calibration with false sigmas; on poses where they should be it solves."""

from __future__ import annotations

import numpy as np
import pytest

from calib.accel.placement import check_placement
from rig.cli import main
from rig.importers.recordings import import_recording
from rig.session import load_session
from rig.analysis.solve import solve_accelerometer

FACES = {"+X up": [1, 0, 0], "-X up": [-1, 0, 0], "+Y up": [0, 1, 0], "-Y up": [0, -1, 0], "+Z up": [0, 0, 1],
         "-Z up": [0, 0, -1]}
MATRIX = np.array([[16500.0, 40.0, -25.0], [0.0, 16300.0, 30.0], [0.0, 0.0, 16450.0]])
BIAS = np.array([120.0, -80.0, 200.0])


def _tilted(f, deg: float, rng) -> np.ndarray:
    """``f`` turned by ``deg`` about a random axis across it."""
    axis = np.cross(f, rng.normal(size=3))
    axis /= np.linalg.norm(axis)
    th = np.radians(deg)
    return f * np.cos(th) + np.cross(axis, f) * np.sin(th) + axis * (axis @ f) * (1 - np.cos(th))


def _session(tmp_path, tilts_deg, seed=2) -> str:
    rng = np.random.default_rng(seed)
    lines = ["# units: counts", "# lsb_per_g: 16384", "t_s,ax,ay,az,label"]
    t = 0.0
    for (name, f), tilt in zip(FACES.items(), tilts_deg):
        true_f = _tilted(np.array(f, float), tilt, rng)
        for _ in range(400):
            a = np.rint(MATRIX @ true_f + BIAS + rng.normal(0, 6.0, 3)).astype(int)
            lines.append(f"{t:.3f},{a[0]},{a[1]},{a[2]},{name}")
            t += 0.01
    (tmp_path / "r.csv").write_text("\n".join(lines) + "\n")
    return str(import_recording("csv", tmp_path / "r.csv", tmp_path / "s", "r"))


def test_hand_placed_faces_are_refused_with_the_misplacement_per_step_and_the_command(tmp_path, capsys):
    session = _session(tmp_path, [3.0, 11.0, 5.0, 7.0, 4.0, 9.0])
    capsys.readouterr()
    assert main(["solve", session]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "disagree with the nominal poses beyond the noise" in err[0]
    assert all(face in err[0] for face in FACES) and "deg" in err[0]
    assert f"rig solve {session} --method magnitude" in err[0] and "this session has 6" in err[0]
    assert not list((tmp_path / "s" / "r").glob("calibration*.yaml"))  # no file with false sigmas


def test_faces_where_they_should_be_solve_and_their_angles_are_within_the_noise(tmp_path, capsys):
    session = _session(tmp_path, [0.0] * 6)
    capsys.readouterr()
    assert main(["solve", session]) == 0
    assert "disagree" not in capsys.readouterr().err
    accel, steps, _, _ = solve_accelerometer(load_session(session))
    found = check_placement(accel, steps)
    assert not found.misplaced and np.all(found.angle_deg < 5 * found.noise_deg)


@pytest.mark.parametrize("tilt, misplaced", [(0.0, False), (4.0, True)])
def test_the_angle_left_by_the_fit_measures_the_placement(tmp_path, tilt, misplaced):
    session = _session(tmp_path, [tilt, 0.0, 0.0, 0.0, 0.0, 0.0])
    accel, steps, _, _ = solve_accelerometer(load_session(session))
    assert check_placement(accel, steps).misplaced is misplaced


def test_evaluate_names_the_placement_and_its_magnitude_method_needs_no_poses(tmp_path, capsys):
    clean = _session(tmp_path / "a", [0.0] * 6) if (tmp_path / "a").mkdir() is None else None
    assert main(["solve", clean]) == 0
    cal = str(tmp_path / "a" / "s" / "r" / "calibration.yaml")
    placed = _session(tmp_path / "b", [3.0, 11.0, 5.0, 7.0, 4.0, 9.0]) if (tmp_path / "b").mkdir() is None else None
    capsys.readouterr()
    assert main(["evaluate", cal, placed]) == 0
    assert f"rig evaluate {cal} {placed} --method magnitude" in capsys.readouterr().err
    assert main(["evaluate", cal, placed, "--method", "magnitude"]) == 0
    out = capsys.readouterr().out
    assert "6 static steps, |f| - 1 rms" in out and "pose-free" in out
    rms_ug = float(out.split("rms ")[1].split(" ug")[0])  # ug, as every residual rig prints
    assert rms_ug < 500  # the calibration is right: the faces were misplaced, the sensor was not


def test_trust_poses_solves_on_the_nominal_poses_anyway(tmp_path, capsys):
    session = _session(tmp_path, [3.0, 11.0, 5.0, 7.0, 4.0, 9.0])
    assert main(["solve", session, "--trust-poses"]) == 0
    assert (tmp_path / "s" / "r" / "calibration.yaml").is_file()
