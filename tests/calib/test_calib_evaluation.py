"""Evaluation in the seed's table layout: roll/pitch by the Euler-Krylov formulas, angle error, |f| - 1."""

from __future__ import annotations

import numpy as np
import pytest

import calib
from calib.evaluation import roll_pitch_deg
from calib.evaluation import f_from_roll_pitch
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

SEED_POSES = [(0, 90), (-60, 60), (-30, 30), (0, 0), (30, -30), (60, -60), (90, 0)]


def test_euler_krylov_formulas_invert_the_pose():
    for r, p in SEED_POSES[1:]:
        rr, pp = roll_pitch_deg(f_from_roll_pitch(r, p))
        assert rr[0] == pytest.approx(r) and pp[0] == pytest.approx(p)
    # quadrant safety: upside down
    rr, pp = roll_pitch_deg(np.array([[0.0, 0.0, -1.0]]))
    assert abs(rr[0]) == pytest.approx(180.0) and pp[0] == pytest.approx(0.0)


def test_a_perfect_calibration_scores_zero_and_a_biased_one_does_not():
    truth = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
                  np.zeros(3), 25.0)
    s = make_steps(truth, six_faces(), rng=np.random.default_rng(0), noise_g_per_rthz=0.0)
    s = calib.StepMeans(**{**s.__dict__, "mean_counts": six_faces() @ truth.matrix_counts_per_g.T + truth.bias_counts})
    cal = calib.solve(s, thermal="off")
    f = f_from_roll_pitch([r for r, _ in SEED_POSES], [p for _, p in SEED_POSES])
    v = make_steps(truth, f, rng=np.random.default_rng(1), noise_g_per_rthz=0.0)
    v = calib.StepMeans(**{**v.__dict__, "mean_counts": f @ truth.matrix_counts_per_g.T + truth.bias_counts})
    ev = calib.evaluate(cal, v)
    assert ev.max_abs("angle_error_deg") < 1e-6
    assert ev.rows[0].roll_error_deg is None  # roll is undefined at pitch 90
    table = ev.format_table()
    assert "roll/pitch" in table and len(table.splitlines()) == 2 + 7 + 1
    bad = calib.AccelCalibration(**{**cal.__dict__, "bias_counts": cal.bias_counts + np.array([82.0, 0, 0])})
    ev2 = calib.evaluate(bad, v)
    assert ev2.max_abs("angle_error_deg") > 0.5  # 10 mg of bias is ~0.6 deg of tilt
    d = ev2.to_dict()
    assert len(d["steps"]) == 7 and d["max_angle_error_deg"] == pytest.approx(ev2.max_abs("angle_error_deg"))


def test_a_nominal_zero_angle_is_printed_0_0_never_minus_0_0():
    from calib.evaluation import Evaluation, EvaluationRow
    row = EvaluationRow("+Z up", -0.0004, -1e-9, 0.001, -0.002, 0.0021, 1e-6)  # tiny negatives of a level pose
    line = Evaluation([row]).format_table().splitlines()[2]
    assert line.split()[2] == "0.0/0.0", line  # the nominal roll/pitch column, after the step name "+Z up"
