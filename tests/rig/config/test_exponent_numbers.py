"""A number in exponent form is a number (issue 34 item 9): YAML 1.1 reads ``1.0e9`` and ``1e3`` as strings (its
float needs a dot and a signed exponent); every field that expects a number (calib.file.fields.number: procedures,
rig files, calibration files, manifests) takes them as the number they write, and its bounds then refuse a
value for what it is, in one line that shows the value as written."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

import calib
from calib.errors import CalibrationFileError
from calib.file import calibration as calfile
from calib.file import yamlsafe
from calib.file.fields import as_number, number
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix
from pydantic import TypeAdapter, ValidationError
from rig.config.procedure import load_procedure_text
from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError
from rig.session import SessionManifest

from conftest import PROCEDURES, RIGS

SIX = (PROCEDURES / "six_position.yaml").read_text()
SIM = (RIGS / "sim.yaml").read_text()


def procedure(seconds: str):
    text = SIX.replace("dwell: {seconds: 10}", f"dwell: {{seconds: {seconds}}}")
    assert text != SIX
    return load_procedure_text(text, "p.yaml")


def procedure_error(seconds: str) -> str:
    with pytest.raises(RigInputError) as exc:
        procedure(seconds)
    return str(exc.value)


@pytest.mark.parametrize("written, value", [("1e3", 1000.0), ("1.0e3", 1000.0), ("1E3", 1000.0), ("+25e-2", 0.25),
                                            (".5e1", 5.0), ("1.e2", 100.0)])
def test_a_dwell_in_exponent_form_is_a_number(written, value):
    assert yamlsafe.load(f"x: {written}")["x"] == written  # YAML 1.1: a string...
    assert procedure(written).dwell.seconds == value  # ...that the number field reads


def test_a_dwell_of_1e9_seconds_is_refused_as_too_long_in_one_line():
    line = procedure_error("1.0e9")
    assert line == "p.yaml:8: dwell.seconds: expected <= 86400, got 1.0e9"
    assert procedure_error("1.0e+9") == "p.yaml:8: dwell.seconds: expected <= 86400, got 1000000000.0"
    assert procedure_error("-1e3") == "p.yaml:8: dwell.seconds: expected a number > 0, got -1e3"


@pytest.mark.parametrize("written", ["'1.5'", "fast", "1_0e3", "0x1p3", "1e", "e3", "1e3.5", "'1e3 '", "inf",
                                     "1e3e3"])
def test_other_strings_are_still_refused(written):
    assert "expected a number, got '" in procedure_error(written)


def test_the_one_place_decides_and_integers_follow():
    assert as_number("2e3") == 2000.0 and as_number("2.5") == "2.5" and as_number("x" * 100 + "e3") == "x" * 100 + "e3"
    whole = TypeAdapter(number(integer=True, ge=0, le=10_000))
    assert whole.validate_python("1e3") == 1000 and isinstance(whole.validate_python("1e3"), int)
    with pytest.raises(ValidationError, match="expected a whole number, got 1.5e0"):
        whole.validate_python("1.5e0")
    kept = TypeAdapter(number(keep_type=True))
    assert kept.validate_python("1e3") == 1000.0 and isinstance(kept.validate_python("1e3"), float)
    ranged = TypeAdapter(number(ge=0, le=1, in_range=True))
    with pytest.raises(ValidationError, match=r"expected a number in \[0, 1\], got 2e0"):
        ranged.validate_python("2e0")


def test_a_rig_file_reads_exponent_form_and_says_the_limit():
    rig = parse_rig_file(SIM.replace("speed_deg_s: 20,", "speed_deg_s: 1.5e1,", 1), "r.yaml")
    assert rig.axes["a1"].speed_deg_s == 15.0
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(SIM.replace("speed_deg_s: 20,", "speed_deg_s: 1e9,", 1), "r.yaml")
    assert "a1.speed_deg_s: expected at most" in str(exc.value) and str(exc.value).endswith("got 1e9")
    assert "\n" not in str(exc.value)


def test_a_calibration_file_and_a_manifest_read_exponent_form(tmp_path):
    truth = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
                  np.array([3.0, -2.0, 4.0]), 27.6)
    acc = calib.solve(make_steps(truth, six_faces(), rng=np.random.default_rng(1)), thermal="off")
    cal = calib.CalibrationFile(created="2026-11-23T00:00:00+00:00", software={"name": "rig", "version": "0.1.0"},
                                session="s1", sensor={"model": "MPU-9150", "address": 0x68, "serial": None},
                                accelerometer=acc)
    path = tmp_path / "c.yaml"
    calfile.write(path, cal)
    text = path.read_text()
    lsb = f"lsb_per_g: {yaml.safe_load(text)['accelerometer']['lsb_per_g']}"
    assert lsb in text
    path.write_text(text.replace(lsb, "lsb_per_g: 8.192e3"))
    assert calfile.read(path).accelerometer.lsb_per_g == 8192.0
    path.write_text(text.replace(lsb, "lsb_per_g: -8e3"))
    with pytest.raises(CalibrationFileError, match="accelerometer.lsb_per_g: expected a number > 0, got -8e3"):
        calfile.read(path)

    manifest = {"format": "rig-session/1", "id": "s", "created": "2024-01-01T00:00:00+00:00", "status": "complete",
                "procedure": {"name": "p", "text": SIX}, "software": {"name": "rig", "version": "0"},
                "rig": {"sensor": {"model": "MPU-9150", "accel_lsb_per_g": 8192.0, "sample_rate_hz": "1e2"}},
                "steps": []}
    assert SessionManifest.from_mapping(manifest, "session.yaml").rig.sensor.sample_rate_hz == 100.0


@pytest.mark.parametrize("text", ["x: 1.0e9\n", "x: 1e3\n", "x: [1e3, 1.0e+3, -2E-2, .5e1]\n", "{a: 1e3, b: 1.0e9}\n",
                                  "- 1e3\n- '1e3'\n- 1.0e+9\n"])
def test_the_fast_path_and_the_located_path_read_exponent_form_alike(text):
    fast = yamlsafe._load_plain(text)  # the fast path itself (load() falls back to load_located when it declines)
    located = yamlsafe.load_located(text)[0]
    assert fast == located == yaml.safe_load(text)
    assert repr(fast) == repr(located)  # the same types too: '1e3' a string, 1.0e+3 a float
