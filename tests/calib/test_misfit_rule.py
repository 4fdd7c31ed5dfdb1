"""One misfit rule (issue 25): the solvers rescale their sigmas, ``rig solve`` warns and the report
hints on the same test, a chi-square beyond its upper MISFIT_LEVEL quantile on the fit's own degrees
of freedom (``AccelCalibration.misfit``)."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import calib
from calib.numerics.design import MISFIT_LEVEL, misfit
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

TRUTH = Truth(triangular_matrix([8100, 8250, 8200], 1e-3, -2e-3, 3e-3), np.array([60.0, -40.0, 110.0]),
              np.array([0.0, 0.0, 0.0]))
TWELVE = np.vstack([six_faces(), np.array([[1, 1, 0], [-1, 1, 0], [0, 1, 1], [0, -1, 1], [1, 0, 1], [1, 0, -1]])
                    / np.sqrt(2)])


def _solve(f, *, model="triangular", seed=1, tilt_deg=0.0, **kw):
    steps = make_steps(TRUTH, f, rng=np.random.default_rng(seed), with_temperature=False)
    if tilt_deg:  # poses not where the session says they are (hand-placed faces)
        rng = np.random.default_rng(seed + 100)
        off = np.radians(tilt_deg) * rng.standard_normal(np.shape(steps.f_nominal_g))
        nominal = steps.f_nominal_g + off
        steps = dataclasses.replace(steps, f_nominal_g=nominal / np.linalg.norm(nominal, axis=1, keepdims=True))
    return calib.solve(steps, model=model, thermal="off", **kw)


@pytest.mark.parametrize("model, method, expected", [("triangular", "pinv", 9), ("full", "pinv", 12),
                                                     ("triangular", "flip", 6)])
def test_the_parameters_counted_are_those_the_solver_estimated(model, method, expected):
    cal = _solve(TWELVE, model=model, method=method)
    assert cal.n_parameters() == expected


def test_the_degrees_of_freedom_are_the_solvers():
    """chi2/dof times the dof the calibration derives is the solver's chi-square: the p-value the rule
    gives is the one the solver's own test saw (recomputed here from the residuals)."""
    steps = make_steps(TRUTH, TWELVE, rng=np.random.default_rng(3), with_temperature=False)
    cal = calib.solve(steps, model="triangular", thermal="off")
    resid = (steps.mean_counts - cal.predict_counts(steps.f_nominal_g)) / steps.sem_counts
    dof = 3 * len(TWELVE) - cal.n_parameters()
    assert float(np.sum(resid**2)) == pytest.approx(cal.fit.chi2_per_dof * dof, rel=1e-6)
    assert cal.misfit()[1] == pytest.approx(misfit(float(np.sum(resid**2)), dof)[1], rel=1e-6)


def test_clean_sessions_are_flagged_about_as_often_as_the_level():
    flagged = sum(_solve(TWELVE, seed=s).misfit()[0] for s in range(200))
    assert flagged <= 200 * MISFIT_LEVEL + 6  # 2 expected; the binomial's 99.99 % bound is 8


def test_hand_placed_poses_are_a_misfit_and_the_command_line_says_so(capsys):
    from rig.cli.common import warn_if_misfit

    cal = _solve(TWELVE, tilt_deg=2.0)
    assert cal.misfit()[0]
    warn_if_misfit(SimpleNamespace(accelerometer=cal), "solve")  # what it reads of a calibration file
    assert "rig solve: warning: the model does not fit the data" in capsys.readouterr().err
    warn_if_misfit(SimpleNamespace(accelerometer=_solve(TWELVE)), "solve")
    assert capsys.readouterr().err == ""
