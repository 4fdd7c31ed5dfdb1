"""Mounting rotations: the 24 cube rotations by name (where the slot's +x and +z point) and the check that a
matrix is a proper rotation."""

from __future__ import annotations

import numpy as np
import pytest

from rig.config.rotations import CUBE_ROTATIONS, TOLERANCE, angle_deg, name_of, rotation_problem


def test_there_are_24_names_and_24_different_proper_rotations():
    assert len(CUBE_ROTATIONS) == 24
    mats = list(CUBE_ROTATIONS.values())
    for m in mats:
        assert rotation_problem(m) is None
        assert set(np.abs(m).ravel()) == {0.0, 1.0}
    assert len({m.tobytes() for m in mats}) == 24


@pytest.mark.parametrize("name,x,z", [("x+z+", (1, 0, 0), (0, 0, 1)), ("y+z+", (0, 1, 0), (0, 0, 1)),
                                      ("x-z-", (-1, 0, 0), (0, 0, -1)), ("z+x-", (0, 0, 1), (-1, 0, 0))])
def test_a_name_says_where_the_slots_x_and_z_axes_point_on_the_table(name, x, z):
    r = CUBE_ROTATIONS[name]
    assert r @ np.array([1, 0, 0]) == pytest.approx(x)
    assert r @ np.array([0, 0, 1]) == pytest.approx(z)


@pytest.mark.parametrize("name,rows", [
    ("x+z+", [[1, 0, 0], [0, 1, 0], [0, 0, 1]]),
    ("y+z+", [[0, -1, 0], [1, 0, 0], [0, 0, 1]]),  # 90 deg about z
    ("x-z-", [[-1, 0, 0], [0, 1, 0], [0, 0, -1]]),  # 180 deg about y: upside down
    ("x+y-", [[1, 0, 0], [0, 0, -1], [0, 1, 0]]),  # +90 deg about x: slot y up, slot z along table -y
])
def test_the_matrix_of_a_name_row_by_row(name, rows):
    assert CUBE_ROTATIONS[name].tolist() == rows
    assert name_of(rows) == name


def test_the_identity_and_a_half_turn_have_their_angles():
    assert angle_deg(CUBE_ROTATIONS["x+z+"]) == 0.0
    assert angle_deg(CUBE_ROTATIONS["x-z-"]) == pytest.approx(180.0)
    assert angle_deg(CUBE_ROTATIONS["y+z+"]) == pytest.approx(90.0)


def test_a_tilted_mounting_is_a_rotation_without_a_name():
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    tilted = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    assert rotation_problem(tilted) is None and name_of(tilted) is None


def test_a_matrix_within_the_tolerance_is_a_rotation_and_beyond_it_not():
    near = np.eye(3)
    near[0, 0] += 0.4 * TOLERANCE
    assert rotation_problem(near) is None
    near[0, 0] += TOLERANCE
    assert rotation_problem(near).startswith("expected a rotation: R R^T differs from the identity by 2.8e-06")


@pytest.mark.parametrize("matrix,message", [
    ([[1, 0, 0], [0, 1, 0], [0, 0, -1]], "expected a proper rotation (det +1), got det -1"),
    ([[1, 0, 0], [0, 1, 0], [0, 0, 2]], "expected a rotation: R R^T differs from the identity by 3"),
    ([[1, 0], [0, 1]], "expected a 3x3 list of numbers, got shape [2, 2]"),
    ([[1, 0, 0], [0, 1, 0], [0, 0, float("nan")]], "expected finite numbers"),
    ([[1, 0, 0], [0, 1, 0], [0, 0, "one"]], "expected a 3x3 list of numbers"),
])
def test_a_matrix_that_is_not_a_rotation_says_why(matrix, message):
    assert rotation_problem(matrix).startswith(message)
