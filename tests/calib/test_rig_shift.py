"""The first-order pose shift of every rig error (calib.accel.rig_propagation.first_order_shift, what the budget and
the misfit judgement use) is the exact chain's (TableGeometry.sensor_to_world) for small errors, on poses all over
the sphere and after motion in either direction."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from calib.accel.rig_propagation import EPS_DEG, first_order_shift, rig_parameters, stage_angles_deg
from calib.numerics.budget import RigErrors
from calib.numerics.turntable import TableGeometry


def _exact_shift(geometry, angles, directions):
    perfect = TableGeometry().sensor_to_world(np.eye(3), angles, np.zeros_like(angles))
    moved = geometry.sensor_to_world(np.eye(3), angles, directions)
    return np.transpose(moved, (0, 2, 1))[:, :, 2] - np.transpose(perfect, (0, 2, 1))[:, :, 2]


def _poses(n=40, seed=2):
    rng = np.random.default_rng(seed)
    f = rng.standard_normal((n, 3))
    return stage_angles_deg(f / np.linalg.norm(f, axis=1, keepdims=True))


@pytest.mark.parametrize("parameter", rig_parameters(RigErrors.from_classes(), 40), ids=lambda p: p.name)
def test_each_parameter_moves_the_poses_as_the_exact_chain_does(parameter):
    angles = _poses()
    d = parameter.directions if parameter.directions is not None else np.zeros((len(angles), 3))
    exact = _exact_shift(parameter.geometry, angles, d)
    assert np.max(np.abs(exact)) > 0 or np.max(np.abs(first_order_shift(parameter.geometry, angles, d))) == 0
    np.testing.assert_allclose(first_order_shift(parameter.geometry, angles, d), exact,
                               atol=1e-3 * np.radians(EPS_DEG))


def test_a_whole_table_of_class_sized_errors_moves_them_as_the_exact_chain_does():
    rng = np.random.default_rng(9)
    geometry = TableGeometry(
        stages=tuple(dataclasses.replace(TableGeometry().stages[0], zero_offset_deg=rng.uniform(-.01, .01),
                                         periodic_deg=.005, periodic_phase_deg=rng.uniform(0, 360),
                                         accumulated_deg=.02, accumulated_phase_deg=rng.uniform(0, 360),
                                         lost_motion_deg=.02, wobble_deg=.003, wobble_phase_deg=rng.uniform(0, 360))
                     for _ in range(3)),
        non_orthogonality_deg=tuple(rng.uniform(-.02, .02, 3)), mounting_deg=tuple(rng.uniform(-.1, .1, 3)))
    angles = _poses()
    d = rng.choice([-1.0, 1.0], size=angles.shape)
    exact = _exact_shift(geometry, angles, d)
    assert np.max(np.abs(exact)) > 1e-3  # about 0.1 deg: a first-order model must be good to its square
    np.testing.assert_allclose(first_order_shift(geometry, angles, d), exact, atol=3e-6)
