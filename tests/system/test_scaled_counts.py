"""Counts of another range or scale (the adversarial campaign's `samples.csv (scaled)` family): `rig solve`
refuses them naming the session, and `rig evaluate` never reports angle errors for data its calibration does
not describe."""

from __future__ import annotations

import shutil

import pytest

from rig.cli import main

from conftest import scale_counts, unseal


def _scaled(session, dest, factor: float):
    d = dest / f"scaled-{factor:g}"
    shutil.copytree(session, d, ignore=shutil.ignore_patterns("calibration*.yaml", "report.html"))
    unseal(d)
    scale_counts(d, factor)
    return d


@pytest.mark.parametrize("factor", [2.0, 0.5])
def test_solve_refuses_scaled_counts_naming_the_session(simulated_lab, tmp_path, monkeypatch, capsys, factor):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))
    d = _scaled(simulated_lab["six"], tmp_path, factor)
    assert main(["solve", str(d), "-o", str(tmp_path / "c.yaml")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"rig solve: {d}: the fitted ") and "times the sensor's nominal" in line
    assert not (tmp_path / "c.yaml").exists()


@pytest.mark.parametrize("factor", [2.0, 0.5])
def test_evaluate_refuses_counts_its_calibration_does_not_describe(simulated_lab, tmp_path, capsys, factor):
    d = _scaled(simulated_lab["six"], tmp_path, factor)
    cal = simulated_lab["six"] / "calibration.yaml"
    assert main(["evaluate", str(cal), str(d)]) == 2
    captured = capsys.readouterr()
    (line,) = captured.err.strip().splitlines()
    assert f"{d}: with {cal} the sensor at rest reads {factor:g}" in line and "1 g expected" in line
    assert captured.out == ""  # no table of angle errors for data the calibration does not describe
    assert main(["evaluate", str(cal), str(simulated_lab["six"])]) == 0  # its own session: evaluated
