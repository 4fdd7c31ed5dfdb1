"""A unit's noise profile exported to Kalibr's imu.yaml (SI units, the largest axis) and to JSON (issue 28 item 4)."""

from __future__ import annotations

import math

import pytest
import yaml

from rig.cli import main
from rig.lab.noise_profiles import NoiseProfile, load_profile


def _term(v: float) -> dict:
    return {"value": v, "sigma": 0.1 * v, "ci95": [0.8 * v, 1.2 * v]}


def _axis(n: float, b: float, k: float) -> dict:
    return {"N": _term(n), "B": _term(b), "K": _term(k), "tau_floor_s": 300.0, "chi2_dof": 0.5}


@pytest.fixture
def profile_file(tmp_path):
    doc = {"sensor": {"key": "MPU-9150:SN1", "model": "MPU-9150"}, "measured_at": "2026-11-01T10:00:00+00:00",
           "session": "allan-1", "duration_s": 7800.0, "rate_hz": 100.0,
           "accel": {"unit": "g", "x": _axis(300e-6, 30e-6, 4e-6), "y": _axis(350e-6, 30e-6, 5e-6),
                     "z": _axis(320e-6, 30e-6, 3e-6)},
           "gyro": {"unit": "deg/s", "x": _axis(4e-3, 1e-3, 2e-4), "y": _axis(5e-3, 1e-3, 1e-4),
                    "z": _axis(4.5e-3, 1e-3, 3e-4)}}
    path = tmp_path / "unit.json"
    path.write_text(NoiseProfile.model_validate(doc).model_dump_json(indent=2))
    return path


def test_kalibr_gets_si_densities_and_random_walks_of_the_largest_axis(profile_file, tmp_path, capsys):
    out = tmp_path / "imu.yaml"
    assert main(["export", str(profile_file), "--to", "kalibr", "-o", str(out)]) == 0
    assert "cannot hold bias instability B" in capsys.readouterr().out
    imu = yaml.safe_load(out.read_text())
    assert imu["rostopic"] == "/imu0" and imu["update_rate"] == 100.0
    assert imu["accelerometer_noise_density"] == pytest.approx(350e-6 * 9.80665)
    assert imu["accelerometer_random_walk"] == pytest.approx(5e-6 * 9.80665)
    assert imu["gyroscope_noise_density"] == pytest.approx(5e-3 * math.pi / 180)
    assert imu["gyroscope_random_walk"] == pytest.approx(3e-4 * math.pi / 180)


def test_json_keeps_the_whole_profile(profile_file, tmp_path):
    out = tmp_path / "copy.json"
    assert main(["export", str(profile_file), "--to", "json", "-o", str(out)]) == 0
    assert load_profile(out) == load_profile(profile_file)


def test_a_profile_without_a_gyroscope_or_to_an_autopilot_is_refused_in_one_line(profile_file, tmp_path, capsys):
    text = profile_file.read_text()
    doc = NoiseProfile.model_validate_json(text).model_dump()
    doc["gyro"] = None
    bare = tmp_path / "bare.json"
    bare.write_text(NoiseProfile.model_validate(doc).model_dump_json())
    capsys.readouterr()
    assert main(["export", str(bare), "--to", "kalibr"]) == 2
    assert main(["export", str(profile_file), "--to", "px4"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "gyroscope_noise_density needs the gyro N" in err[0] and "not 'px4'" in err[1]
