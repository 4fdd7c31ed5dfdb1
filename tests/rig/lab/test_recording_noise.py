"""Without a noise profile the recording speaks first (issue 28 item 5): a session whose static steps are long
enough to show the bias wander is weighed with the wander they show (the family's figures the prior), and the
calibration file says so (``noise: {source: recording}``); short steps leave the family's figures and the file as
it was; a unit's profile still comes first."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml

from rig.analysis.solve import calibrate_session
from rig.lab.recording_noise import accel_step_means, pose_u_rad
from rig.session import load_session
from rig.lab.noise_profiles import NoiseProfile, record_profile
from cli_run import rig_in_process

ROOT = Path(__file__).resolve().parents[3]
SCHEMA = json.loads((ROOT / "docs" / "schemas" / "calibration.schema.json").read_text())
FAMILY_B_G, FAMILY_K_G = 40e-6, 4e-6  # the MPU-9150's registry figures (B in the registry's convention)
UNIT_B_G, UNIT_K_G = 3 * FAMILY_B_G, 3 * FAMILY_K_G  # the simulated unit: 3x its family's wander
KEY = "MPU-9150@0x68#0x68/sim-seed-3"


def _unit_rig(folder: Path, geometry: bool = False) -> Path:
    """The simulated rig in virtual time, its MPU-9150 a unit whose bias wanders 3x its family's, its table perfect
    (``sim.geometry`` off: the steps' means differ by the wander alone) unless ``geometry``."""
    rig = yaml.safe_load((ROOT / "rigs" / "sim.yaml").read_text())
    rig["sim"]["time_scale"] = 0
    rig["sim"]["geometry"] = {"enabled": geometry}
    rig["sim"]["noise_figures"] = {"accel_bias_instability_g": [UNIT_B_G] * 3,
                                   "accel_random_walk_g_per_rts": [UNIT_K_G] * 3}
    path = folder / "unit3x.yaml"
    path.write_text(yaml.safe_dump(rig))
    return path


def _six_position(folder: Path, dwell_s: float, monkeypatch, geometry: bool = False) -> tuple[Path, dict]:
    """A six-position session of the unit with ``dwell_s`` seconds a pose, run and concluded by ``rig run``."""
    monkeypatch.setenv("RIG_HISTORY", str(folder / "history.sqlite"))
    procedure = yaml.safe_load((ROOT / "procedures" / "six_position.yaml").read_text())
    procedure["dwell"]["seconds"] = dwell_s
    (folder / "p.yaml").write_text(yaml.safe_dump(procedure))
    code, _, err = rig_in_process("run", folder / "p.yaml", "--rig", _unit_rig(folder, geometry), "--seed", 3,
                                  "--out", folder / "s", "--quiet")
    assert code == 0, err
    session = next((folder / "s").iterdir())
    return session, yaml.safe_load((session / "calibration.yaml").read_text())


@pytest.fixture(scope="module")
def long_steps(tmp_path_factory):
    """Six 200 s steps (a quarter of each reaches 82 s, past a quarter of the crossing of white noise and floor)."""
    with pytest.MonkeyPatch.context() as mp:
        return _six_position(tmp_path_factory.mktemp("long"), 200.0, mp)


def test_long_steps_of_a_unit_unlike_its_family_weigh_its_own_wander_and_the_file_says_recording(long_steps):
    session, cal = long_steps
    noise = cal["noise"]
    assert noise["source"] == "recording" and noise["sensor_key"] == KEY and noise["session"] == session.name
    assert noise["steps"] == 6 and noise["seconds"] == pytest.approx(1200.0, abs=1.0)
    accel = noise["sensors"]["accel"]
    for b in accel["bias_instability_xyz"]:  # nearer the unit's floor than its family's
        assert abs(math.log(b / UNIT_B_G)) < abs(math.log(b / FAMILY_B_G)), accel
    assert accel["flicker_corner_s"] == 5000.0 and accel["unit"] == "g"
    family = calibrate_session(session)  # the same session weighed with the family's figures
    ratio = [u / f for u, f in zip(cal["accelerometer"]["sigma"]["bias_counts"], family.accelerometer.sigma["bias_counts"])]
    # the wander dominates a six-position bias sigma: larger on the whole (an axis whose steps disagree beyond the
    # family's wander has its family sigma scaled up by the misfit, which the unit's wander explains)
    assert math.sqrt(sum(r * r for r in ratio) / 3) > 1.3, ratio
    jsonschema.Draft202012Validator(SCHEMA).validate(cal)


def test_short_steps_leave_the_familys_figures_and_the_file_as_it_was(tmp_path, monkeypatch):
    session, cal = _six_position(tmp_path, 10.0, monkeypatch)  # the README's six-position job
    assert "noise" not in cal  # 10 s steps reach 1.3 s: the family's, and the file as it always was
    family = calibrate_session(session)
    assert cal["accelerometer"]["sigma"]["bias_counts"] == pytest.approx(list(family.accelerometer.sigma["bias_counts"]),
                                                                         rel=1e-12)


def _profile(b_floor_g: float, k_g: float) -> NoiseProfile:
    term = lambda v: {"value": v, "sigma": 0.1 * v, "ci95": [0.8 * v, 1.2 * v]}
    axis = {"N": term(350e-6), "B": term(b_floor_g), "K": term(k_g), "tau_floor_s": 300.0, "chi2_dof": 0.5}
    return NoiseProfile.model_validate({
        "sensor": {"key": KEY, "model": "MPU-9150"}, "measured_at": "2026-11-01T10:00:00+00:00", "session": "allan-1",
        "duration_s": 7800.0, "rate_hz": 100.0, "accel": {"unit": "g", "x": axis, "y": axis, "z": axis}})


def test_a_units_profile_still_comes_first(long_steps, tmp_path):
    session, _ = long_steps
    history = tmp_path / "history.sqlite"
    record_profile(_profile(2 * FAMILY_B_G / math.sqrt(2), 2 * FAMILY_K_G), history)
    code, _, err = rig_in_process("solve", session, "-o", tmp_path / "c.yaml", "--no-record", "--history", history)
    assert code == 0, err
    noise = yaml.safe_load((tmp_path / "c.yaml").read_text())["noise"]
    assert noise["source"] == "unit profile" and noise["measured_at"].startswith("2026-11-01")
    assert noise["sensors"]["accel"]["bias_instability_xyz"] == pytest.approx([2 * FAMILY_B_G] * 3)
    assert "steps" not in noise


def test_a_session_with_rate_steps_weighs_the_gyroscope_with_its_static_steps_wander_too(tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "history.sqlite"))
    procedure = yaml.safe_load((ROOT / "procedures" / "gyro_rates.yaml").read_text())
    procedure["dwell"]["seconds"] = 200.0  # six long static steps, then the rate steps, shortened
    for step in procedure["steps"]:
        if "rate" in step:
            step["rate"]["seconds"] = 20
    (tmp_path / "g.yaml").write_text(yaml.safe_dump(procedure))
    code, _, err = rig_in_process("run", tmp_path / "g.yaml", "--rig", _unit_rig(tmp_path), "--seed", 3, "--out",
                                  tmp_path / "s", "--quiet")
    assert code == 0, err
    cal = yaml.safe_load((next((tmp_path / "s").iterdir()) / "calibration.yaml").read_text())
    sensors = cal["noise"]["sensors"]
    assert set(sensors) == {"accel", "gyro"} and sensors["gyro"]["unit"] == "deg/s"
    for b in sensors["gyro"]["bias_instability_xyz"]:  # this unit's gyroscope is its family's (0.002 deg/s)
        assert 0.5 < b / 0.002 < 2.0, sensors["gyro"]
    assert cal["noise"]["steps"] == 6 and cal["gyroscope"] is not None
    jsonschema.Draft202012Validator(SCHEMA).validate(cal)


def test_the_step_means_are_weighed_about_the_affine_model_with_the_tables_pose_errors(long_steps, tmp_path,
                                                                                    monkeypatch):
    # the steps' means show the wander between steps minutes apart (calib.noise.steps.StepMeansOfAxis); a table
    # with errors moves them too, by what its classes state (the budget's per-pose classes and lost motion), which
    # is not taken for wander; a simulated table without errors states none
    session = load_session(long_steps[0])
    assert pose_u_rad(session) == 0.0
    between = accel_step_means(session, session.static_step_indices(), 5000.0, 0.0)
    assert all(b is not None and b.dof == 2 and np.all(b.pose_var == 0) for b in between)
    tilted, _ = _six_position(tmp_path, 10.0, monkeypatch, geometry=True)
    u = pose_u_rad(load_session(tilted))
    assert math.radians(0.005) < u < math.radians(0.05)  # the datasheet classes: about 0.015 deg a pose
