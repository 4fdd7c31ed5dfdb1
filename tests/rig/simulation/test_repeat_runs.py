"""``sim.repeat``: the same hidden sensor recorded again with new noise (a repeatability study). The walkthrough: two
runs with one seed are the same session bit for bit (history +0.0 sigma, compare chi2 0.0), so the simulated rig
could not show how a calibration repeats; another seed is another sensor."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main

from conftest import PROCEDURES, RIGS


def _run(tmp_path, name: str, repeat: int | None):
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    if repeat is not None:
        doc["sim"]["repeat"] = repeat
    rig = tmp_path / f"{name}.yaml"
    rig.write_text(yaml.safe_dump(doc))
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(rig), "--seed", "3", "--time-scale", "0",
                     "--out", str(tmp_path / name), "--quiet"]) == 0
    (s,) = (tmp_path / name).iterdir()
    return s, yaml.safe_load((s / "sim_truth.yaml").read_text()), calfile.read(s / "calibration.yaml").accelerometer


def test_a_repeated_run_is_the_same_sensor_with_new_noise(tmp_path):
    s0, truth0, cal0 = _run(tmp_path, "first", None)
    s0b, _, cal0b = _run(tmp_path, "again", 0)  # repeat 0: the seed's own draws, as without the key
    s1, truth1, cal1 = _run(tmp_path, "repeat1", 1)
    _, _, cal2 = _run(tmp_path, "repeat2", 2)
    assert (s0 / "samples.csv").read_bytes() == (s0b / "samples.csv").read_bytes()
    assert truth1["repeat"] == 1 and truth0["repeat"] == 0
    assert truth1["accelerometer"] == truth0["accelerometer"]  # the same hidden sensor
    b = np.array([c.bias_counts for c in (cal0, cal1, cal2)])
    s = np.array([c.sigma["bias_counts"] for c in (cal0, cal1, cal2)])
    assert len({tuple(x) for x in b}) == 3  # new noise each time
    assert np.all(np.abs(b - b.mean(axis=0)) < 5 * s)  # ... of one sensor: within its sigmas
    assert (s0 / "samples.csv").read_bytes() != (s1 / "samples.csv").read_bytes()


@pytest.mark.parametrize("bad", [-1, 1.5, "two"])
def test_a_bad_repeat_is_refused_with_one_line(tmp_path, capsys, bad):
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["repeat"] = bad
    rig = tmp_path / "rig.yaml"
    rig.write_text(yaml.safe_dump(doc))
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(rig), "--time-scale", "0", "--out",
                 str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sim.repeat" in err[0], err
