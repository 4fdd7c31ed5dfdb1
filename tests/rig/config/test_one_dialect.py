"""One field dialect (calib.file.fields): the same fault says the same thing in a procedure, a calibration file
and a session manifest, as one line ``file[:line]: key.path: what was expected``."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

import calib
from calib.errors import CalibrationFileError
from calib.file import calibration as calfile
from calib.file import yamlsafe
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix
from rig.config.procedure import load_procedure_text
from rig.errors import RigInputError, SessionFormatError
from rig.session import SessionManifest

PROCEDURE = """format: rig-procedure/1
name: p
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 2}
steps:
  - pose: "+Z up"
  - pose: "-Z up"
solve: {model: triangular}
"""

MANIFEST = {"format": "rig-session/1", "id": "s", "created": "2024-01-01T00:00:00+00:00", "status": "complete",
            "procedure": {"name": "p", "text": PROCEDURE}, "software": {"name": "rig", "version": "0"},
            "rig": {"sensor": {"model": "MPU-9150", "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0}},
            "steps": [{"index": 0, "name": "+Z up", "kind": "static", "angles_deg": [0.0, 0.0, 0.0],
                       "f_nominal": [0.0, 0.0, 1.0], "status": "complete"}]}


@pytest.fixture(scope="module")
def calibration() -> dict:
    truth = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
                  np.array([3.0, -2.0, 4.0]), 27.6)
    acc = calib.solve(make_steps(truth, six_faces(), rng=np.random.default_rng(1)), thermal="off")
    return calib.CalibrationFile(created="2026-11-23T00:00:00+00:00", software={"name": "rig", "version": "0.1.0"},
                                 session="s1", sensor={"model": "MPU-9150", "address": 0x68, "serial": None},
                                 accelerometer=acc).to_dict()


def procedure_line(old: str, new: str) -> str:
    text = PROCEDURE.replace(old, new)
    assert text != PROCEDURE
    with pytest.raises(RigInputError) as exc:
        load_procedure_text(text, "p.yaml")
    return str(exc.value)


def calibration_line(doc: dict, tmp_path, edit) -> str:
    doc = yaml.safe_load(yaml.safe_dump(doc))
    edit(doc)
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    with pytest.raises(CalibrationFileError) as exc:
        calfile.read(path)
    return str(exc.value).replace(str(path), "c.yaml")


def manifest_line(edit) -> str:
    doc = yaml.safe_load(yaml.safe_dump(MANIFEST))
    edit(doc)
    with pytest.raises(SessionFormatError) as exc:
        SessionManifest.from_mapping(doc, "session.yaml")
    return str(exc.value)


def _set(d: dict, path: str, value) -> None:
    *parents, last = path.split(".")
    for p in parents:
        d = d[p]
    if value is KeyError:
        del d[last]
    else:
        d[last] = value


CASES = {  # fault -> (procedure edit, its line and key; calibration key, value; manifest key, value; what all say)
    "a word for a number": (("seconds: 2", "seconds: fast"), 4, "dwell.seconds", ("accelerometer.lsb_per_g", "fast"),
                            ("rig.sensor.sample_rate_hz", "fast"), "expected a number, got 'fast'"),
    "a negative number for a positive one": (("seconds: 2", "seconds: -1"), 4, "dwell.seconds",
                                             ("accelerometer.lsb_per_g", -1), ("rig.sensor.sample_rate_hz", -1),
                                             "expected a number > 0, got -1"),
    "true for a number": (("seconds: 2", "seconds: true"), 4, "dwell.seconds", ("accelerometer.lsb_per_g", True),
                          ("rig.sensor.sample_rate_hz", True), "expected a number, got True"),
    "a missing key": (("name: p\n", ""), 1, "name", ("accelerometer.fit", KeyError),
                      ("rig.sensor.accel_lsb_per_g", KeyError), "missing required field"),
    "a word not among the choices": (("model: triangular", "model: cubic"), 8, "solve.model",
                                     ("accelerometer.model", "cubic"), ("status", "cubic"), "got 'cubic'"),
    "a list for a mapping": (("dwell: {seconds: 2}", "dwell: [1]"), 4, "dwell", ("sensor", [1]), ("procedure", [1]),
                             "expected a mapping"),
}


@pytest.mark.parametrize("fault", CASES)
def test_the_same_fault_says_the_same_thing_in_every_format(calibration, tmp_path, fault):
    proc_edit, proc_line, proc_key, (cal_key, cal_value), (man_key, man_value), says = CASES[fault]
    lines = {"procedure": procedure_line(*proc_edit),
             "calibration": calibration_line(calibration, tmp_path, lambda d: _set(d, cal_key, cal_value)),
             "manifest": manifest_line(lambda d: _set(d, man_key, man_value))}
    assert lines["procedure"].startswith(f"p.yaml:{proc_line}: {proc_key}: "), lines
    assert lines["calibration"].startswith(f"c.yaml: {cal_key}: "), lines
    assert lines["manifest"].startswith(f"session.yaml: {man_key}: "), lines
    for line in lines.values():
        assert says in line and "\n" not in line, lines
    if fault not in ("a word not among the choices", "a list for a mapping"):  # the allowed ones, the hint differ
        assert len({line.split(": ", 2)[2] for line in lines.values()}) == 1, lines


def test_the_choices_are_named_alike():
    assert procedure_line("model: triangular", "model: cubic").endswith(
        "solve.model: expected one of triangular, full, got 'cubic'")
    assert manifest_line(lambda d: d.update(status="paused")).endswith(
        "status: expected one of running, complete, aborted, got 'paused'")


def test_an_unknown_key_names_the_allowed_ones_in_a_procedure_and_a_calibration_file(calibration, tmp_path):
    assert procedure_line("name: p\n", "name: p\nnmae: q\n").startswith(
        "p.yaml:3: nmae: unknown key (allowed: accept, description, dwell, format, name, order, ")
    assert calibration_line(calibration, tmp_path, lambda d: d["accelerometer"].update(bias_count=1)).startswith(
        "c.yaml: accelerometer.bias_count: unknown key (allowed: bias_counts, effects, fit, ")


def test_a_calibration_validated_with_the_loaders_lines_names_the_line(calibration):
    doc = yaml.safe_load(yaml.safe_dump(calibration))
    doc["accelerometer"]["lsb_per_g"] = -1
    text = yaml.safe_dump(doc, sort_keys=False)
    value, lines = yamlsafe.load_located(text)
    with pytest.raises(CalibrationFileError) as exc:
        calib.CalibrationFile.from_dict(value, "c.yaml", lines=lines)
    line = text.splitlines().index("  lsb_per_g: -1") + 1
    assert str(exc.value) == f"c.yaml:{line}: accelerometer.lsb_per_g: expected a number > 0, got -1"
