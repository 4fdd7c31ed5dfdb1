"""Acceptance limits on a calibration: each limit is one check with one line; anything that cannot be
evaluated fails (an acceptance never passes by default); the verdict round-trips through the file."""

from __future__ import annotations

import numpy as np
import pytest

import calib
from calib.file import calibration as calfile
from calib.accel.budget import linear_solve, uncertainty_section
from calib.acceptance import AcceptanceLimits, Drift, evaluate, known_pattern, largest_drift
from calib.errors import CalibrationFileError
from calib.file.parameters import sensor_parameters
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix
from test_budget_type_a import RIG, SEM_COUNTS, _solve, _steps


@pytest.fixture(scope="module")
def cal():
    truth = Truth(triangular_matrix([8150.0, 8230.0, 8190.0], 0.004, -0.003, 0.002), np.array([120.0, -75.0, 210.0]),
                  np.zeros(3))
    accel = calib.solve(make_steps(truth, six_faces(), rng=np.random.default_rng(1)), thermal="off")
    return calib.CalibrationFile(created="2026-11-23T00:00:00+00:00", software={"name": "t", "version": "0"},
                                 sensor={"model": "MPU-9150", "address": 104, "serial": None}, accelerometer=accel)


def test_ranges_check_every_parameter_the_pattern_matches(cal):
    acc = evaluate(cal, AcceptanceLimits(ranges={"accel.bias_*": (-150.0, 150.0)}))
    assert [c.name for c in acc.checks] == ["range accel.bias_x", "range accel.bias_y", "range accel.bias_z"]
    assert acc.verdict == "FAIL" and [c.name for c in acc.failed()] == ["range accel.bias_z"]
    assert acc.failed()[0].line.startswith("accel.bias_z = 210") and "outside [-150, 150] counts" in acc.failed()[0].line


def test_sigma_chi2_and_residual_limits(cal):
    fit = cal.accelerometer.fit
    ok = evaluate(cal, AcceptanceLimits(max_sigma={"accel.scale_*": 10.0}, max_chi2_per_dof=fit.chi2_per_dof * 1.01,
                                        max_residual_g=fit.residual_rms_g * 1.01))
    assert ok.passed, [c.line for c in ok.failed()]
    bad = evaluate(cal, AcceptanceLimits(max_sigma={"accel.scale_x": 1e-6}, max_residual_g=fit.residual_rms_g / 2))
    assert [c.name for c in bad.failed()] == ["sigma accel.scale_x", "max_residual_g"]


def test_what_cannot_be_evaluated_fails_and_says_why(cal):
    acc = evaluate(cal, AcceptanceLimits(ranges={"gyro.bias_*": (-1.0, 1.0)}, max_attitude_error_deg=0.1,
                                         max_drift_sigma=3.0))
    lines = [c.line for c in acc.failed()]
    assert len(lines) == 3 and not acc.passed
    assert "has no such parameter" in lines[0] and "no static steps" in lines[1] and "history was not read" in lines[2]


def test_drift_passes_for_a_first_calibration_and_fails_beyond_the_limit(cal):
    first = evaluate(cal, AcceptanceLimits(max_drift_sigma=3.0), drift=Drift(None))
    assert first.passed and "first calibration" in first.checks[0].line
    previous = {n: (v, s, u) for n, v, s, u in sensor_parameters(cal)}
    moved = [(n, v + (10 * s if n == "accel.bias_y" else 0.0), s, u) for n, v, s, u in sensor_parameters(cal)]
    d = largest_drift(moved, previous, "2026-01-01")
    assert d.parameter == "accel.bias_y" and d.z == pytest.approx(10 / np.sqrt(2))
    acc = evaluate(cal, AcceptanceLimits(max_drift_sigma=3.0), drift=d)
    assert not acc.passed and "accel.bias_y moved +7.1 sigma" in acc.checks[0].line


def test_an_empty_set_of_checks_is_not_a_pass(cal):
    assert not evaluate(cal, AcceptanceLimits()).passed


def test_patterns_are_checked_against_the_names_a_calibration_may_carry():
    assert known_pattern("accel.bias_*") and known_pattern("gyro.scale_x") and known_pattern("accel.tempco2_*")
    assert not known_pattern("accel.bias") and not known_pattern("accel.foo")


def test_the_verdict_round_trips_through_the_calibration_file(cal, tmp_path):
    acc = evaluate(cal, AcceptanceLimits(ranges={"accel.scale_*": (8000.0, 8400.0)}))
    with_verdict = cal.model_copy(update={"acceptance": acc.to_dict()})
    back = calfile.read(calfile.write(tmp_path / "c.yaml", with_verdict))
    assert back.acceptance == acc.to_dict() and back.to_dict() == with_verdict.to_dict()
    assert "acceptance" not in calfile.read(calfile.write(tmp_path / "plain.yaml", cal)).to_dict()


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(acceptance={"passed": "yes", "limits": []}), "acceptance.passed"),
    (lambda d: d.update(gyroscpe=None), "gyroscpe: unknown key (allowed: accelerometer, acceptance, coverage, created, format"),
    (lambda d: d["accelerometer"].update(bias_count=[1, 2, 3]), "accelerometer.bias_count: unknown key (allowed: bias_counts, effects, fit"),
    (lambda d: d["accelerometer"]["bias_counts"].__setitem__(0, "34.2"), "numbers, got the string '34.2'"),
    (lambda d: d.update(coverage={"complete": False, "status": "aborted", "steps_planned": 6, "steps_recorded": -1,
                                  "pending_steps": []}), "coverage.steps_recorded"),
])
def test_a_tampered_or_misspelt_file_is_refused_naming_the_field(cal, edit, message):
    d = cal.to_dict()
    edit(d)
    with pytest.raises(CalibrationFileError, match=message.replace("(", r"\(").replace(".", r"\.")):
        calfile.from_dict(d, "c.yaml")


def test_a_value_within_two_sigma_of_a_limit_is_said_marginal_and_the_verdict_is_the_limits(cal):
    bias_x, sigma_x = float(cal.accelerometer.bias_counts[0]), float(cal.accelerometer.sigma["bias_counts"][0])
    just_out = evaluate(cal, AcceptanceLimits(ranges={"accel.bias_x": (bias_x + 0.5 * sigma_x, 1e4)}))
    (check,) = just_out.checks
    assert not check.passed and "outside" in check.line and "(marginal: " in check.line and "re-test" in check.line
    just_in = evaluate(cal, AcceptanceLimits(ranges={"accel.bias_x": (bias_x - 1.5 * sigma_x, 1e4)}))
    assert just_in.checks[0].passed and "(marginal: " in just_in.checks[0].line
    clear = evaluate(cal, AcceptanceLimits(ranges={"accel.bias_x": (bias_x - 5 * sigma_x, bias_x + 5 * sigma_x)}))
    assert clear.checks[0].passed and "marginal" not in clear.checks[0].line


def _on_a_table_with_errors(jump_counts: float = 0.0):
    """A six-position calibration on a table whose brackets are off orthogonal, with its budget (test_budget_type_a's
    session; ``jump_counts``: a y bias jump before the fourth pose, which no table error explains)."""
    steps = _steps(jump_counts)
    accel = _solve(steps)
    accel = accel.model_copy(update={"uncertainty": uncertainty_section(accel, steps, _solve, RIG,
                                                                               linear=linear_solve(accel, steps))})
    return calib.CalibrationFile(created="2026-11-26T00:00:00+00:00", software={"name": "t", "version": "0"},
                                 sensor={"model": "MPU-9150", "address": 104, "serial": None}, accelerometer=accel)


def test_on_a_table_with_its_own_errors_chi2_and_sigma_are_judged_without_what_the_table_explains():
    cal = _on_a_table_with_errors()
    fit, u = cal.accelerometer.fit, cal.accelerometer.uncertainty
    assert fit.chi2_per_dof > 4 and not u["misfit_with_rig"]["significant"]  # the table's misfit, held by U
    sigma_y = cal.accelerometer.sigma["bias_counts"][1]
    acc = evaluate(cal, AcceptanceLimits(max_sigma={"accel.bias_y": sigma_y * 0.8}, max_chi2_per_dof=3.0))
    assert acc.passed, [c.line for c in acc.failed()]
    chi2, sig = {c.name: c for c in acc.checks}["max_chi2_per_dof"], acc.checks[0]
    assert chi2.value == pytest.approx(u["misfit_with_rig"]["chi2_per_dof"])
    assert "against the noise and the turntable's own errors" in chi2.line and f"{fit.chi2_per_dof:.4g}" in chi2.line
    # the Type A: y's sigma before the solve scaled it (each face's mean to 0.3 counts, the bias their mean)
    assert sig.value == pytest.approx(SEM_COUNTS / np.sqrt(6), rel=1e-6) and "Type A" in sig.line


def test_a_misfit_the_table_does_not_explain_still_fails_the_chi2_limit():
    cal = _on_a_table_with_errors(jump_counts=25.0)
    assert cal.accelerometer.uncertainty["misfit_with_rig"]["significant"]
    acc = evaluate(cal, AcceptanceLimits(max_chi2_per_dof=5.0))
    assert not acc.passed and "against the noise and the turntable's own errors" in acc.checks[0].line
