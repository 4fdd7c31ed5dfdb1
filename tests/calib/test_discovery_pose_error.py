"""Poses that are not where they should be (issue 32, item 4, the discovery part).

Six faces placed by hand on a table, each recorded as four consecutive 10 s windows (as an import of a
six-face recording makes them), the faces 3-11 deg off nominal (the real recording of the issue:
3-11 deg). The sensor is the simulator's own error model with the MPU-9150's wander; the session knows
only the nominal faces, no turntable angles.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calib.discovery.search import StepContext, discover
from calib.synthetic import steps_from_output
from drivers.sensors.sim.error_model import AccelErrorModel
from test_discovery_matrix import FACES, MPU, SEM_G, run, tumble

WINDOWS = 4


def hand_placed(seed: int, tilt_deg=(3.0, 11.0), windows: int = WINDOWS):
    """Step means of six hand-placed faces, each turned by a random angle in ``tilt_deg`` about a random
    axis perpendicular to it; and the angles (deg)."""
    rng = np.random.default_rng(seed)
    m = AccelErrorModel.draw(rng)
    m.t_ref_c = 25.0
    f_nominal = np.repeat(FACES, windows, axis=0)
    f_true = np.empty_like(f_nominal)
    angles = rng.uniform(*tilt_deg, size=6)
    for b, face in enumerate(FACES):
        axis = rng.standard_normal(3)
        axis -= (axis @ face) * face
        f_true[b * windows:(b + 1) * windows] = Rotation.from_rotvec(
            np.radians(angles[b]) * axis / np.linalg.norm(axis)).apply(face)
    k = len(f_nominal)
    t = 5.0 + np.arange(k) * 10.0 + np.repeat(np.arange(6) * 20.0, windows)
    temp = 25.0 + 0.01 * rng.standard_normal(k)
    out = m.output_g(f_true, temp, t, np.zeros(k), np.zeros(k))
    steps = steps_from_output(f_nominal, out, temp_c=temp, t_s=t, sem_g=SEM_G, rng=rng, stability=MPU,
                              duration_s=10.0)
    return steps, angles


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_hand_placed_faces_off_nominal_are_named_a_pose_error_not_a_shock(seed):
    """Before: a bias_jump at a change of face (a shock, a re-mount) with full_misalignment and
    scale_nonlinearity (seed 0), or nothing named and the gap open at chi2/dof 9e4-2e5 (seeds 1-3)."""
    steps, _ = hand_placed(seed)
    d = discover(steps, StepContext())
    assert [e.name for e in d.effects] == ["pose_error"], [e.name for e in d.effects]
    assert d.gap_closed and d.chi2_per_dof_before > 1e3, (d.chi2_per_dof_before, d.chi2_per_dof_after)
    e = d.effects[0]
    assert e.unit == "deg" and len(e.axes) == 12 and e.axes[:2] == ["placement0_u", "placement0_v"]
    assert d.calibration is not None and not d.calibration.effects  # the recording's, never the sensor's


@pytest.mark.parametrize("seed", [10, 11, 12])
def test_faces_placed_where_they_should_be_name_nothing(seed):
    steps, _ = hand_placed(seed, tilt_deg=(0.0, 0.0))
    d = discover(steps, StepContext())
    assert d.effects == [] and "pose_error" in d.observability


def test_poses_set_by_the_turntable_have_no_pose_error_candidate():
    d, _ = run(tumble(), 5)
    assert "pose_error" in d.unobservable
    assert "turntable" in d.unobservable_why["pose_error"]


def test_one_step_per_hand_placed_face_cannot_test_a_pose_error_and_says_so():
    """Six faces, one window each (the imucal recording's design): two tilts per placement would absorb all
    nine residual degrees of freedom. The candidate is unobservable with that reason, never named into a
    saturated model (which has no dof to judge it by)."""
    steps, _ = hand_placed(0, windows=1)
    d = discover(steps, StepContext())
    assert "pose_error" not in [e.name for e in d.effects]
    assert "absorb every residual degree of freedom" in d.unobservable_why["pose_error"]
    assert not d.gap_closed and d.dof_after > 0
