"""A turntable session's residuals judged against the noise and the rig's own errors (calib.accel.rig_misfit): on
a table without errors it is the solve's own chi-square; on tables whose errors are drawn at their budget's
standard uncertainties it is chi-square on the fit's degrees of freedom (p uniform), where the noise alone calls
nearly every session a misfit; a real misfit (poses a degree off) is still one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import calib
from calib.accel.budget import linear_solve
from calib.accel.rig_misfit import rig_misfit, rig_step_covariance
from calib.accel.rig_propagation import pose_shift, rig_parameters, stage_angles_deg
from calib.numerics.budget import RigErrors, TableClass
from calib.numerics.gravity import standard_gravity
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

TRUTH = Truth(matrix_counts_per_g=triangular_matrix([8200.0, 8150.0, 8230.0], 1e-3, -2e-3, 5e-4),
              bias_counts=np.array([40.0, -25.0, 60.0]), tempco_counts_per_c=np.array([0.0, 0.0, 0.0]))
CLASSES = RigErrors.from_classes()
PERFECT = RigErrors.from_classes(TableClass(**{f.name: 0.0 for f in dataclasses.fields(TableClass)
                                               if f.name != "period_deg"}), standard_gravity())


def _judged(steps, rig, model="triangular"):
    cal = calib.solve(steps, model=model, method="pinv", thermal="off")
    return cal, rig_misfit(linear_solve(cal, steps), steps, rig, cal.matrix_counts_per_g)


def _on_a_drawn_table(rng, f=None, rig=CLASSES, extra_deg=0.0):
    """Six faces whose poses a table with errors drawn (normal) at ``rig``'s standard uncertainties moved."""
    f = six_faces() if f is None else f
    angles = stage_angles_deg(f)
    moved = f.copy()
    for p in rig_parameters(rig, len(f)):
        moved = moved + pose_shift(p, angles) * p.u_deg * rng.standard_normal()
    moved = moved + np.radians(extra_deg) * rng.standard_normal((len(f), 3))
    steps = make_steps(TRUTH, moved, rng=rng, with_temperature=False)
    return dataclasses.replace(steps, f_nominal_g=f)  # the solve is told the nominal poses


@pytest.mark.parametrize("model", ["triangular", "full"])
def test_on_a_table_without_errors_it_is_the_solves_own_chi_square(model):
    steps = make_steps(TRUTH, six_faces(), rng=np.random.default_rng(3), with_temperature=False)
    cal, judged = _judged(steps, PERFECT, model)
    assert judged.dof == cal.degrees_of_freedom()
    assert judged.chi2_per_dof == pytest.approx(cal.fit.chi2_per_dof, rel=1e-9)


def test_the_rigs_covariance_is_several_counts_per_axis_at_the_classes():
    steps = make_steps(TRUTH, six_faces(), rng=np.random.default_rng(3), with_temperature=False)
    sd = np.sqrt(np.diag(rig_step_covariance(steps, CLASSES, TRUTH.matrix_counts_per_g))).reshape(3, -1).T  # (K, 3)
    across = np.abs(steps.f_nominal_g) < 0.5  # the axes across gravity: a pose error turns gravity into them
    assert np.all(sd[across] > 3 * steps.sem_counts[across])  # the table, not the noise, sets their scatter
    assert np.all(sd[~across] < 0.1 * steps.sem_counts[~across])  # along gravity: second order


def test_on_tables_drawn_at_their_classes_it_is_chi_square_and_the_noise_alone_is_not():
    rng = np.random.default_rng(29)
    p_rig, noise_only = [], []
    for _ in range(300):
        steps = _on_a_drawn_table(rng)
        cal, judged = _judged(steps, CLASSES)
        p_rig.append(judged.p)
        noise_only.append(cal.misfit()[0])
    p_rig = np.array(p_rig)
    assert np.mean(p_rig < 0.01) <= 0.03  # its own false-alarm level (0.01), within the sampling error
    assert np.mean(p_rig < 0.5) == pytest.approx(0.5, abs=0.08)  # p uniform under the null
    assert np.mean(noise_only) > 0.6  # judged against the noise alone, most of these tables "misfit"


def test_poses_a_degree_off_on_such_a_table_are_still_a_misfit():
    rng = np.random.default_rng(7)
    flagged = [_judged(_on_a_drawn_table(rng, extra_deg=1.0), CLASSES)[1].significant for _ in range(20)]
    assert np.mean(flagged) >= 0.9



def test_poses_moved_off_nominal_keep_the_stage_angles_the_table_held():
    """At a2 = +-90 deg (a face with y up or down) the specific force does not say a3: a3 then turns about the
    vertical too. A characterised rig's poses are moved off nominal by hundredths of a degree
    (``Characterisation.corrected``), and the angles that put such an f up have an arbitrary a3; the step means'
    covariance places each pose at its recorded stage angles (``StepMeans.angles_deg``) instead."""
    f = six_faces()
    rec = stage_angles_deg(f)
    assert np.abs(np.abs(rec[:, 1]) - 90.0).min() < 1e-9  # the faces include a2 = +-90 deg
    steps = dataclasses.replace(make_steps(TRUTH, f, rng=np.random.default_rng(0), with_temperature=False),
                                angles_deg=rec)
    moved_f = f + 1e-4 * np.random.default_rng(1).standard_normal(f.shape)  # a corrected pose, 0.006 deg off
    moved = dataclasses.replace(steps, f_nominal_g=moved_f)
    m = TRUTH.matrix_counts_per_g
    held = rig_step_covariance(steps, CLASSES, m)
    np.testing.assert_allclose(rig_step_covariance(moved, CLASSES, m), held, rtol=0, atol=1e-6 * np.abs(held).max())
    lost = rig_step_covariance(dataclasses.replace(moved, angles_deg=None), CLASSES, m)  # a3 from the moved f
    assert np.abs(lost - held).max() > 0.05 * np.abs(held).max()
