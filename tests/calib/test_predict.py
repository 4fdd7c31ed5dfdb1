"""Predicting a calibration's accuracy from its poses and standard errors (calib.accel.predict).

The prediction is checked against what it predicts: calibrations of simulated sensors solved by
the real solver, their true roll/pitch errors at the seed's verification poses counted against the
predicted 95 % bound.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydantic import TypeAdapter

import calib
from calib.accel import StepMeans
from calib.numerics.stability import BiasStability
from calib.accel.predict import Goal, Predictor, plan_dwell, planned_sems, seed_table_f, target_record
from calib.accel.result import triangular_matrix
from calib.accel.target_record import TargetRecord
from calib.errors import CalibError, ObservabilityError
from calib.evaluation import GIMBAL_LOCK_COS, roll_pitch_deg

LSB = 8192.0
FACES = np.array([[0, 0, 1], [0, -1, 0], [-1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, -1]], float)  # +Z -Y -X +Y +X -Z


def steps_for(f, mean_counts, sem):
    k = len(f)
    return StepMeans(names=tuple(map(str, range(k))), f_nominal_g=f, mean_counts=mean_counts, sem_counts=sem,
                     n_samples=np.full(k, 200), temp_c=None, t_s=np.arange(k, dtype=float), lsb_per_g=LSB)


def true_max_error_deg(cal, m, b, f_verify) -> float:
    """Largest |roll|/|pitch| error of ``cal`` for a sensor ``a = m f + b`` at the verification poses."""
    f_cal = cal.apply(f_verify @ m.T + b)
    r, p = roll_pitch_deg(f_cal)
    r0, p0 = roll_pitch_deg(f_verify)
    er = np.where(np.abs(np.cos(np.radians(p0))) < GIMBAL_LOCK_COS, 0.0, (r - r0 + 180) % 360 - 180)
    ep = (p - p0 + 180) % 360 - 180
    return float(max(np.abs(er).max(), np.abs(ep).max()))


@pytest.mark.slow
def test_the_predicted_95_percent_bound_holds_for_95_percent_of_simulated_calibrations():
    rng = np.random.default_rng(16)
    sem = np.tile(2.4 / np.sqrt([[3.75], [2.0], [1.25], [2.0], [0.75], [0.5]]), (1, 3))  # uneven dwell, counts
    bound = Predictor(Goal(attitude_error_deg=0.03), LSB).predict(FACES, sem).attitude_error_deg
    errors = []
    for _ in range(1500):
        angles = dict(zip(("alpha_yz", "alpha_zy", "alpha_zx"), rng.normal(0, 0.005, 3)))
        m = triangular_matrix(LSB * (1 + rng.normal(0, 0.01, 3)), angles)
        b = rng.normal(0, 300, 3)
        noisy = FACES @ m.T + b + rng.standard_normal((6, 3)) * sem
        errors.append(true_max_error_deg(calib.solve(steps_for(FACES, noisy, sem), thermal="off"), m, b, seed_table_f()))
    errors = np.array(errors)
    assert 0.035 <= np.mean(errors > bound) <= 0.07
    assert np.quantile(errors, 0.95) == pytest.approx(bound, rel=0.08)


def test_the_predicted_sigmas_are_those_the_solver_reports():
    rng = np.random.default_rng(3)
    sem = rng.uniform(0.5, 2.0, (6, 3))
    m = triangular_matrix(np.full(3, LSB), {"alpha_yz": 0.0, "alpha_zy": 0.0, "alpha_zx": 0.0})
    cal = calib.solve(steps_for(FACES, FACES @ m.T, sem), thermal="off")  # noise-free: no Birge rescaling
    goal = Goal(sigma={"accel.*": 1.0})
    p = Predictor(goal, LSB).predict(FACES, sem)
    for j, a in enumerate("xyz"):
        assert p.sigmas[f"accel.bias_{a}"] == pytest.approx(cal.sigma["bias_counts"][j], rel=1e-9)
        assert p.sigmas[f"accel.scale_{a}"] == pytest.approx(cal.sigma["scale_counts_per_g"][j], rel=1e-9)
    for name in ("alpha_yz", "alpha_zy", "alpha_zx"):
        assert p.sigmas[f"accel.{name}"] == pytest.approx(cal.sigma["misalignment"][name], rel=1e-6)


def test_with_the_steps_timeline_the_predicted_sigmas_are_the_solvers_generalised_least_squares():
    """The chip's wander between the capture windows, not only its common part: the prediction is the
    covariance the solver reports for the same steps (calib.accel.solve: GLS with the wander)."""
    rng = np.random.default_rng(4)
    sem = rng.uniform(0.5, 2.0, (6, 3))
    t_s, duration_s = 5.0 + 40.0 * np.arange(6), np.full(6, 30.0)  # 30 s dwells, 10 s moves
    stability = BiasStability(40e-6, 4e-6, 5000.0)  # the MPU-9150's figures, g
    m = triangular_matrix(np.full(3, LSB), {"alpha_yz": 0.0, "alpha_zy": 0.0, "alpha_zx": 0.0})
    steps = dataclasses.replace(steps_for(FACES, FACES @ m.T, sem), t_s=t_s, duration_s=duration_s,
                                bias_stability=stability)
    cal = calib.solve(steps, thermal="off")  # noise-free: no Birge rescaling
    pred = Predictor(Goal(sigma={"accel.*": 1.0}), LSB, stability=stability)
    floor_only = Predictor(Goal(sigma={"accel.*": 1.0}), LSB, steps.bias_stability_counts()).predict(FACES, sem).sigmas
    pred.timeline = (t_s, duration_s)
    p = pred.predict(FACES, sem).sigmas
    for j, a in enumerate("xyz"):
        assert p[f"accel.bias_{a}"] == pytest.approx(cal.sigma["bias_counts"][j], rel=1e-9)
        assert p[f"accel.scale_{a}"] == pytest.approx(cal.sigma["scale_counts_per_g"][j], rel=1e-9)
        assert p[f"accel.scale_{a}"] > 1.02 * floor_only[f"accel.scale_{a}"]  # the floor misses the between-step part
    for name in ("alpha_yz", "alpha_zy", "alpha_zx"):
        assert p[f"accel.{name}"] == pytest.approx(cal.sigma["misalignment"][name], rel=1e-6)


def test_the_bias_stability_adds_to_every_bias_and_nothing_else():
    sem = np.ones((6, 3))
    goal = Goal(sigma={"accel.bias_*": 1.0, "accel.scale_*": 1.0})
    plain = Predictor(goal, LSB).predict(FACES, sem).sigmas
    floored = Predictor(goal, LSB, bias_floor_counts=0.5).predict(FACES, sem).sigmas
    for a in "xyz":
        assert floored[f"accel.bias_{a}"] == pytest.approx(np.hypot(plain[f"accel.bias_{a}"], 0.5))
        assert floored[f"accel.scale_{a}"] == plain[f"accel.scale_{a}"]


def test_the_prediction_scales_with_the_standard_errors_and_is_deterministic():
    pred = Predictor(Goal(attitude_error_deg=0.03), LSB)
    sem = np.full((6, 3), 1.3)
    once, again, doubled = pred.predict(FACES, sem), pred.predict(FACES, sem), pred.predict(FACES, 2 * sem)
    assert once == again
    assert doubled.attitude_error_deg == pytest.approx(2 * once.attitude_error_deg, rel=1e-12)


def test_the_plan_meets_the_goal_with_less_dwell_than_equal_shares_and_favours_the_poses_the_table_needs():
    pred = Predictor(Goal(attitude_error_deg=0.03), LSB)
    unit, free, least = np.full(3, 2.46), np.ones(6, bool), np.full(6, 0.5)
    plan = plan_dwell(pred, FACES, np.ones((6, 3)), unit, free, least, 1000.0)
    assert plan.feasible and plan.ratio <= 1.0
    assert pred.predict(FACES, planned_sems(np.ones((6, 3)), unit, plan.dwell_s, free)).met
    equal = next(t for t in np.arange(0.5, 20, 0.01) if pred.predict(FACES, np.tile(unit / np.sqrt(t), (6, 1))).met)
    assert plan.total_s < 0.95 * 6 * equal
    # the seed's table lies above the horizon: +Z is worth more than -Z
    assert plan.dwell_s[0] > 2 * plan.dwell_s[5]


def test_a_plan_that_cannot_fit_its_time_is_infeasible_and_says_how_close_it_gets():
    pred = Predictor(Goal(attitude_error_deg=0.03), LSB)
    plan = plan_dwell(pred, FACES, np.ones((6, 3)), np.full(3, 2.46), np.ones(6, bool), np.full(6, 0.5), 4.0)
    assert not plan.feasible
    assert plan.total_s == pytest.approx(4.0, rel=1e-3)
    assert plan.ratio > 1.0


def test_poses_that_do_not_determine_the_model_are_refused():
    with pytest.raises(ObservabilityError, match="do not determine"):
        Predictor(Goal(attitude_error_deg=0.03), LSB).predict(FACES[:3], np.ones((3, 3)))


@pytest.mark.parametrize("kwargs, message", [
    ({}, "needs an attitude error or at least one sigma"),
    ({"attitude_error_deg": 0.03, "confidence": 1.0}, "confidence must be in"),
    ({"sigma": {"accel.alpha_*": 1e-4}, "model": "full"}, "names no parameter of the full model"),
    ({"sigma": {"gyro.bias_x": 1.0}}, "names no parameter"),
])
def test_goals_that_cannot_be_predicted_are_refused(kwargs, message):
    with pytest.raises(CalibError, match=message):
        Goal(**kwargs)


def test_the_target_record_is_the_calibration_file_section():
    goal = Goal(attitude_error_deg=0.03, sigma={"accel.bias_*": 2.0})
    p = Predictor(goal, LSB).predict(FACES, np.full((6, 3), 1.0))
    record = target_record(goal, p, poses="seed_table", max_seconds=90.0, rig_time_s=38.5)
    TypeAdapter(TargetRecord).validate_python(record)
    assert record["met"] is p.met and [s["parameter"] for s in record["sigma"]] == [f"accel.bias_{a}" for a in "xyz"]
    assert record["summary"].startswith("met: max roll/pitch error")
