"""The budget's Type A term when the solve scaled its sigmas for a misfit (issue 29, docs/uncertainty.md).

A six-position session on a turntable with its own errors misfits against its noise: the solve scales every sigma
by the Birge ratio. That misfit is the table's, which the budget's Type B terms hold, so the Type A term takes the
scaling back, for every quantity as the solve applied it, when the residuals judged against the noise and the
rig's errors (``misfit_with_rig``) show no misfit; and keeps the part they leave when they do. Before, it took
back only each quantity's own rig terms, which are tiny for the scale factors: their U was twice their error's
spread (Monte Carlo coverage 99.7 % on uncharacterised rigs; now 93.3 %, benchmarks/bench_budget.py).
"""

from __future__ import annotations

import numpy as np
import pytest

import calib
from calib.accel.budget import contributions, flat_sigma, judge_with_rig, linear_solve, unscaled_sigma
from calib.accel.inputs import StepMeans
from calib.numerics.budget import RigErrors, TableClass
from calib.numerics.turntable import TableGeometry
from calib.synthetic import triangular_matrix

LSB = 8192.0
#: the sensor (counts per g) in the triangular model the solve fits
MATRIX = triangular_matrix([8200.0, 8150.0, 8230.0], 1e-3, -2e-3, 5e-4)
ANGLES = np.array([[0, 0, 0], [0, 0, -90], [0, 0, -180], [0, 0, -270], [0, 90, -360], [0, -90, -360]], float)
DIRECTIONS = np.array([[1, 1, 1], [1, 1, -1], [1, 1, -1], [1, 1, -1], [1, 1, -1], [1, -1, -1]], float)
SEM_COUNTS = 0.3
#: the table: its brackets 0.02 deg off orthogonal (the class's half-width), nothing else
TABLE = TableGeometry(non_orthogonality_deg=(0.02, -0.02, 0.015))
RIG = RigErrors.from_classes(TableClass(zero_offset_deg=0, periodic_deg=0, accumulated_deg=0, lost_motion_deg=0,
                                        wobble_deg=0, non_orthogonality_deg=0.02, mounting_deg=0))


def _steps(jump_counts: float = 0.0) -> StepMeans:
    f_true = np.einsum("kji,j->ki", TABLE.sensor_to_world(np.eye(3), ANGLES, DIRECTIONS), [0, 0, 1.0])
    f_nominal = np.einsum("kji,j->ki", TableGeometry().sensor_to_world(np.eye(3), ANGLES, DIRECTIONS), [0, 0, 1.0])
    f_nominal[np.abs(f_nominal) < 1e-12] = 0.0
    k = len(ANGLES)
    counts = f_true @ MATRIX.T + [40.0, -25.0, 60.0]
    counts[3:, 1] += jump_counts  # the y bias jumps before the fourth pose
    counts += np.random.default_rng(4).normal(0, SEM_COUNTS, counts.shape)
    return StepMeans(names=tuple(f"p{i}" for i in range(k)), f_nominal_g=f_nominal, mean_counts=counts,
                     sem_counts=np.full((k, 3), SEM_COUNTS), n_samples=np.full(k, 1000), temp_c=None,
                     t_s=np.arange(k) * 15.0, lsb_per_g=LSB, arrival_direction=DIRECTIONS)


def _solve(steps: StepMeans):
    return calib.solve(steps, model="triangular", method="pinv", thermal="off")


def _type_a(steps: StepMeans):
    cal = _solve(steps)
    (part,) = [c for c in contributions(cal, steps, _solve, RIG) if c.type == "A"]
    return cal, part


def test_a_misfit_the_rigs_errors_explain_leaves_every_quantity_its_unscaled_sigma():
    steps = _steps()
    cal, part = _type_a(steps)
    assert cal.misfit()[0] and cal.fit.chi2_per_dof > 4  # the table's errors: the solve scaled its sigmas
    judged = judge_with_rig(cal, steps, RIG)
    assert not judged.significant  # against the noise and the rig's errors: no misfit
    own = unscaled_sigma(linear_solve(cal, steps))  # each axis's sigma before the solve scaled it
    sigma = flat_sigma(cal)
    for name in ("scale_counts_per_g[0]", "scale_counts_per_g[2]", "bias_counts[1]", "misalignment.alpha_zx"):
        assert part.u[name] == pytest.approx(own[name], rel=1e-12), name
        assert part.u[name] < sigma[name], name
    assert "which the rig's errors explain" in part.source


def test_a_misfit_they_do_not_explain_keeps_the_scaling_they_leave():
    steps = _steps(jump_counts=6.0)  # an effect the model lacks, beyond the table's errors
    cal, part = _type_a(steps)
    judged = judge_with_rig(cal, steps, RIG)
    assert judged.significant
    birge, left = np.sqrt(cal.fit.chi2_per_dof), np.sqrt(judged.chi2_per_dof)
    assert 1 < left < birge
    sigma, own = flat_sigma(cal), unscaled_sigma(linear_solve(cal, steps))
    for name in ("scale_counts_per_g[1]", "bias_counts[0]"):
        assert part.u[name] == pytest.approx(min(own[name] * left, sigma[name]), rel=1e-12), name


def test_an_axis_the_solve_did_not_scale_keeps_its_whole_sigma():
    """The solve scales axis by axis (``session_rule``): on the default simulated table a six-position session's y
    misfits and its z does not. The Type A of z's quantities is then z's own sigma, not that sigma over the
    session's pooled Birge ratio (2.4x too small before 2026-11-26)."""
    steps = _steps()
    counts = np.array(steps.mean_counts, float)
    counts[:, 2] = (steps.f_nominal_g @ MATRIX.T)[:, 2] + 60.0 + np.random.default_rng(9).normal(0, SEM_COUNTS, 6)
    steps = StepMeans(**{**{k: getattr(steps, k) for k in steps.__dataclass_fields__}, "mean_counts": counts})
    cal, part = _type_a(steps)  # z: on the nominal poses, no misfit of its own; x and y: the table's
    own, sigma = unscaled_sigma(linear_solve(cal, steps)), flat_sigma(cal)
    assert sigma["bias_counts[2]"] == pytest.approx(own["bias_counts[2]"], rel=1e-8)  # the solve left z unscaled
    assert sigma["bias_counts[1]"] > 1.5 * own["bias_counts[1]"]  # and scaled y
    birge = np.sqrt(cal.fit.chi2_per_dof)
    assert birge > 1.5
    for name in ("bias_counts[2]", "scale_counts_per_g[2]"):
        assert part.u[name] == pytest.approx(sigma[name], rel=1e-8), name  # not sigma / birge
