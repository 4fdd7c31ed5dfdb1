"""Calibration sections: the common base class, a three-line round trip per section, the JSON Schema."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml

import calib
from calib.file import calibration as calfile
from calib.gyro import GyroCalibration, RateStepMeans, solve_gyro
from calib.mag import MagCalibration, MagStepMeans, solve_mag_ellipsoid, solve_mag_positions
from calib.file.section import CalibrationSection, section_class
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

SCHEMA_FILE = Path(__file__).resolve().parents[2] / "docs" / "schemas" / "calibration.schema.json"
TRUTH = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
              np.array([3.0, -2.0, 4.0]), 27.6)


def _gyro() -> GyroCalibration:
    rng = np.random.default_rng(7)
    w = np.concatenate([s * r * np.eye(3)[k][None] for k in range(3) for r in (25.0, 40.0, 63.0) for s in (1, -1)])
    m = 32.8 * (np.eye(3) + rng.normal(0, 0.01, (3, 3)))
    sem = np.full((len(w), 3), 0.5)
    counts = w @ m.T + np.array([20.0, -15.0, 8.0]) + rng.normal(0, 0.5, w.shape)
    return solve_gyro(RateStepMeans(tuple(f"r{i}" for i in range(len(w))), w, counts, sem, np.full(len(w), 1000),
                                    32.8))


def _mag(method: str) -> MagCalibration:
    rng = np.random.default_rng(8)
    h = rng.normal(0, 1, (26, 3))
    h = 50.0 * h / np.linalg.norm(h, axis=1)[:, None]
    a = np.eye(3) + rng.normal(0, 0.02, (3, 3))
    sem = np.full(h.shape, 0.1)
    m = h @ a.T + np.array([10.0, -5.0, 3.0]) + rng.normal(0, 0.1, h.shape)
    known = h if method == "positions" else None
    steps = MagStepMeans(tuple(f"p{i}" for i in range(len(h))), known, m, sem, np.full(len(h), 50))
    return solve_mag_positions(steps) if method == "positions" else solve_mag_ellipsoid(steps, 50.0)


def _file(mag: str = "positions") -> calib.CalibrationFile:
    steps = make_steps(TRUTH, np.repeat(six_faces(), 3, axis=0), temp_c=np.tile([25.0, 30.0, 35.0], 6),
                       rng=np.random.default_rng(1))
    return calib.CalibrationFile(created="2026-11-23T00:00:00+00:00", software={"name": "rig", "version": "0.1.0"},
                                 session="s1", sensor={"model": "MPU-9150", "address": 0x68, "serial": None},
                                 accelerometer=calib.solve(steps, thermal=1), gyroscope=_gyro(),
                                 magnetometer=_mag(mag))


@pytest.fixture(scope="module")
def cal() -> calib.CalibrationFile:
    return _file()


# ---------------------------------------------------------------- round trips: write -> read -> equal

@pytest.mark.parametrize("section", ["accelerometer", "gyroscope", "magnetometer"])
def test_each_section_survives_write_and_read(tmp_path, cal, section):
    back = calfile.read(calfile.write(tmp_path / "c.yaml", cal))
    assert getattr(back, section) == getattr(cal, section)


def test_accelerometer_round_trip(tmp_path, cal):
    back = calfile.read(calfile.write(tmp_path / "c.yaml", cal))
    assert back.accelerometer == cal.accelerometer and back.accelerometer.temperature == cal.accelerometer.temperature


def test_gyroscope_round_trip(tmp_path, cal):
    back = calfile.read(calfile.write(tmp_path / "c.yaml", cal))
    assert isinstance(back.gyroscope, GyroCalibration) and back.gyroscope == cal.gyroscope


@pytest.mark.parametrize("method", ["positions", "ellipsoid"])
def test_magnetometer_round_trip(tmp_path, method):
    cal = _file(method)
    assert calfile.read(calfile.write(tmp_path / "c.yaml", cal)).magnetometer == cal.magnetometer


def test_whole_file_round_trip(tmp_path, cal):
    back = calfile.read(calfile.write(tmp_path / "c.yaml", cal))
    assert back == cal and back.to_dict() == yaml.safe_load((tmp_path / "c.yaml").read_text())


@pytest.mark.parametrize("section", ["accelerometer", "gyroscope", "magnetometer"])
def test_each_section_round_trips_alone_through_yaml(cal, section):
    s = getattr(cal, section)
    assert type(s).from_dict(yaml.safe_load(yaml.safe_dump(s.to_dict()))) == s


# ---------------------------------------------------------------- the base class

def test_sections_share_one_base_class_and_dispatch_on_their_type_tag(cal):
    for tag in ("accelerometer", "gyroscope", "magnetometer"):
        cls = section_class(tag)
        assert issubclass(cls, CalibrationSection) and cls.CAL_TYPE == tag
        assert isinstance(getattr(cal, tag), cls)
        assert set(cls.units()) <= set(cls.model_fields) | {"bias_coefficients"}


def test_units_are_declared_with_the_fields():
    assert calib.AccelCalibration.units()["scale_counts_per_g"] == "counts/g"
    assert calib.AccelCalibration.units()["misalignment"] == "rad"
    assert calib.ThermalModel.units()["bias_coefficients"] == "counts/C^s"
    assert GyroCalibration.units()["matrix_counts_per_dps"] == "counts/(deg/s)"
    assert MagCalibration.units()["hard_iron_ut"] == "uT"


def test_plain_dict_sections_are_validated_into_typed_sections(cal):
    f = calib.CalibrationFile(created=cal.created, software=cal.software, session=None, sensor=cal.sensor,
                              accelerometer=cal.accelerometer, gyroscope=cal.gyroscope.to_dict(),
                              magnetometer=cal.magnetometer.to_dict())
    assert isinstance(f.gyroscope, GyroCalibration) and f.gyroscope == cal.gyroscope
    assert GyroCalibration.from_dict(f.gyroscope) is f.gyroscope  # old call sites pass the section back in


@pytest.mark.parametrize("edit,field", [
    (lambda d: d["gyroscope"].update(bias_counts=[1.0, 2.0]), "gyroscope.bias_counts"),
    (lambda d: d["gyroscope"]["bias_pairs"][1].update(sigma_counts=[-1.0, 0.0, 0.0]),
     "gyroscope.bias_pairs[1].sigma_counts"),
    (lambda d: d["gyroscope"]["scale_counts_per_dps"].__setitem__(0, 1.0), "gyroscope.scale_counts_per_dps"),
    (lambda d: d["magnetometer"].update(method="guess"), "magnetometer.method"),
    (lambda d: d["magnetometer"]["sigma"].pop("a_zz"), "magnetometer.sigma.a_zz"),
    (lambda d: d.pop("format"), "format"),
    (lambda d: d.update(sensor=[1, 2]), "sensor"),
])
def test_tampered_gyro_and_mag_sections_are_refused_naming_the_field(tmp_path, cal, edit, field):
    path = calfile.write(tmp_path / "c.yaml", cal)
    doc = yaml.safe_load(path.read_text())
    edit(doc)
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(calib.CalibrationFileError) as e:
        calfile.read(path)
    assert str(e.value).startswith(f"{path}: {field}:") and "\n" not in str(e.value)


# ---------------------------------------------------------------- JSON Schema

def test_committed_json_schema_equals_the_generated_one():
    assert json.loads(SCHEMA_FILE.read_text()) == calfile.json_schema(), (
        "regenerate: python -c 'from calib.file.calibration import write_json_schema; write_json_schema()'")


def test_written_files_validate_against_the_json_schema(tmp_path, cal):
    validator = jsonschema.Draft202012Validator(json.loads(SCHEMA_FILE.read_text()))
    for i, c in enumerate([cal, _file("ellipsoid")]):
        validator.validate(yaml.safe_load(calfile.write(tmp_path / f"c{i}.yaml", c).read_text()))
    doc = yaml.safe_load((tmp_path / "c0.yaml").read_text())
    doc["gyroscope"]["bias_counts"] = [1.0, 2.0]
    assert not validator.is_valid(doc)
