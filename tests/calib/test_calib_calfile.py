"""The calibration file rig-calibration/1: round trip, and every tampering caught with the field named."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

import calib
from calib.file import calibration as calfile
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

TRUTH = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
              np.array([3.0, -2.0, 4.0]), 27.6)


def _file(thermal=True):
    f = np.repeat(six_faces(), 3, axis=0) if thermal else six_faces()
    temps = np.tile([25.0, 30.0, 35.0], 6) if thermal else None
    s = make_steps(TRUTH, f, temp_c=temps, rng=np.random.default_rng(1))
    acc = calib.solve(s, thermal=1 if thermal else "off")
    return calib.CalibrationFile(created="2026-11-23T00:00:00+00:00", software={"name": "rig", "version": "0.1.0"},
                                 session="s1", sensor={"model": "MPU-9150", "address": 0x68, "serial": None},
                                 accelerometer=acc)


def test_round_trip_gives_identical_numbers(tmp_path):
    cal = _file()
    path = calfile.write(tmp_path / "c.yaml", cal)
    back = calfile.read(path)
    counts = np.random.default_rng(2).normal(0, 8000, (20, 3))
    temps = np.linspace(20, 40, 20)
    np.testing.assert_array_equal(back.accelerometer.apply(counts, temps), cal.accelerometer.apply(counts, temps))
    doc = yaml.safe_load(path.read_text())
    assert doc["format"] == "rig-calibration/1"
    assert set(doc["accelerometer"]) >= {"model", "lsb_per_g", "bias_counts", "scale_counts_per_g", "misalignment",
                                         "matrix_counts_per_g", "temperature", "effects", "sigma", "fit"}


def test_temperature_terms_require_a_temperature_to_apply():
    with pytest.raises(calib.CalibError, match="temp_c"):
        _file().accelerometer.apply(np.zeros((1, 3)))


def _tamper(tmp_path, edit):
    path = calfile.write(tmp_path / "c.yaml", _file())
    doc = yaml.safe_load(path.read_text())
    edit(doc)
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(calib.CalibrationFileError) as e:
        calfile.read(path)
    msg = str(e.value)
    assert str(path) in msg and "\n" not in msg
    return msg


@pytest.mark.parametrize("edit,field", [
    (lambda d: d.update(format="rig-calibration/9"), "format"),
    (lambda d: d["accelerometer"].update(model="cubic"), "accelerometer.model"),
    (lambda d: d["accelerometer"].update(bias_counts=[1, 2]), "accelerometer.bias_counts"),
    (lambda d: d["accelerometer"]["scale_counts_per_g"].__setitem__(0, -8000.0), "accelerometer.scale_counts_per_g"),
    (lambda d: d["accelerometer"]["matrix_counts_per_g"][0].__setitem__(0, 9000.0), "accelerometer.scale_counts_per_g"),
    (lambda d: d["accelerometer"]["bias_counts"].__setitem__(1, float("nan")), "accelerometer.bias_counts"),
    (lambda d: d["accelerometer"]["matrix_counts_per_g"][2].__setitem__(0, 5.0), "accelerometer.matrix_counts_per_g"),
    (lambda d: d["accelerometer"].update(misalignment=None), "accelerometer.misalignment"),
    (lambda d: d["accelerometer"]["temperature"].update(order=7), "accelerometer.temperature.order"),
    (lambda d: d["accelerometer"]["sigma"].update(bias_counts=[-1, 0, 0]), "accelerometer.sigma.bias_counts"),
    (lambda d: d["accelerometer"].pop("fit"), "accelerometer.fit"),
    (lambda d: d.pop("accelerometer"), "accelerometer"),
    (lambda d: d["accelerometer"].update(bias_counts="abc"), "accelerometer.bias_counts"),
])
def test_tampered_files_are_refused_naming_the_field(tmp_path, edit, field):
    assert field in _tamper(tmp_path, edit)


def test_not_yaml_and_missing_file(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("format: [unclosed\n")
    with pytest.raises(calib.CalibrationFileError, match="not valid YAML"):
        calfile.read(p)
    with pytest.raises(calib.CalibrationFileError, match="no such"):
        calfile.read(tmp_path / "none.yaml")


def test_write_is_atomic_and_leaves_no_temp_files(tmp_path):
    calfile.write(tmp_path / "c.yaml", _file(thermal=False))
    assert [p.name for p in tmp_path.iterdir()] == ["c.yaml"]
