"""Lost motion with the arrival directions a session records (issue 29, docs/uncertainty.md "Lost motion").

A stage's lost motion leaves the table L/2 behind the motor in the direction it last turned. Without the directions
the budget takes each pose's lost motion as of unknown sign, independent from pose to pose; with them (the samples'
stage positions: :func:`rig.session.adapter.arrival_directions`) it is one parameter per stage with the recorded
signs, which is what the table does. On the six-position sequence the planner moves, the lost motion then moves no
misalignment angle at all (every reversal shifts both poses of the angle's pair alike), where the unknown-sign model
gave it a fifth of the angles' uncertainty; the Monte Carlo coverage of the angles' U, characterised by reversal,
went from 98.5 % to 95.0-96.5 % (benchmarks/bench_budget.py --reversal).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import calib
from calib.accel.budget import contributions, quantities
from calib.accel.inputs import StepMeans
from calib.accel.rig_propagation import rig_parameters, usable_arrival
from calib.errors import CalibError
from calib.numerics.budget import RigErrors, TableClass
from calib.numerics.turntable import StageErrors, TableGeometry

LSB = 8192.0
MATRIX = np.array([[1.002, 0.0, 0.0], [1.5e-3, 0.998, 0.0], [-2e-3, 8e-4, 1.001]])
BIAS_G = np.array([0.01, -0.02, 0.015])
#: the six poses' stage angles as the planner moves the table from zero (+Z, +X, -Z, -X, +Y, -Y up) and the
#: direction each stage last turned in (a stage not yet moved: +1, the direction it came from)
ANGLES = np.array([[0, 0, 0], [0, 0, -90], [0, 0, -180], [0, 0, -270], [0, 90, -360], [0, -90, -360]], float)
DIRECTIONS = np.array([[1, 1, 1], [1, 1, -1], [1, 1, -1], [1, 1, -1], [1, 1, -1], [1, -1, -1]], float)
ANGLE_NAMES = [f"misalignment.{n}" for n in ("alpha_yz", "alpha_zy", "alpha_zx")]


def _steps(table: TableGeometry, arrival: np.ndarray | None) -> StepMeans:
    """Noise-free step means of the sensor on ``table`` at the six poses (the nominal forces of a perfect table)."""
    f_true = np.einsum("kji,j->ki", table.sensor_to_world(np.eye(3), ANGLES, DIRECTIONS), [0, 0, 1.0])
    f_nominal = np.einsum("kji,j->ki", TableGeometry().sensor_to_world(np.eye(3), ANGLES, DIRECTIONS), [0, 0, 1.0])
    f_nominal[np.abs(f_nominal) < 1e-12] = 0.0
    k = len(ANGLES)
    return StepMeans(names=tuple(f"p{i}" for i in range(k)), f_nominal_g=f_nominal,
                     mean_counts=LSB * (f_true @ MATRIX.T + BIAS_G), sem_counts=np.full((k, 3), 0.5),
                     n_samples=np.full(k, 1000), temp_c=None, t_s=np.arange(k) * 15.0, lsb_per_g=LSB,
                     arrival_direction=arrival)


def _solve(steps: StepMeans):
    return calib.solve(steps, model="triangular", method="pinv", thermal="off")


def _lost_motion_only(stage: int, lost_deg: float) -> TableGeometry:
    stages = [StageErrors(), StageErrors(), StageErrors()]
    stages[stage] = StageErrors(lost_motion_deg=lost_deg)
    return TableGeometry(stages=tuple(stages))


LOST_MAX_DEG = 0.02
RIG = RigErrors.from_classes(TableClass(zero_offset_deg=0, periodic_deg=0, accumulated_deg=0, lost_motion_deg=LOST_MAX_DEG,
                                        wobble_deg=0, non_orthogonality_deg=0, mounting_deg=0))


@pytest.mark.parametrize("stage", [1, 2], ids=["a2", "a3"])
def test_with_the_directions_recorded_the_budget_moves_the_solve_as_the_table_does(stage):
    """A table whose only error is lost motion L on one stage moves each solved quantity by what the budget's
    lost-motion parameter of that stage says per L/2 (its contribution is that response at u = L_max / sqrt(12))."""
    perfect = quantities(_solve(_steps(TableGeometry(), DIRECTIONS)))
    lost_deg = 0.012
    moved = quantities(_solve(_steps(_lost_motion_only(stage, lost_deg), DIRECTIONS)))
    cal = _solve(_steps(TableGeometry(), DIRECTIONS))
    (part,) = [c for c in contributions(cal, _steps(TableGeometry(), DIRECTIONS), _solve, RIG)
               if c.name == f"lost_motion.a{stage + 1}"]
    per_half_l = {n: u * np.sqrt(12) / LOST_MAX_DEG for n, u in part.u.items()}  # |response| per deg of L/2
    for name, value in perfect.items():  # to first order: the budget's finite differences and the table's
        # second-order terms ((1 - cos) of the lost motion in the scales) are below 2e-3 counts, 2e-7 rad
        floor = 2e-7 if name.startswith("misalignment") else 2e-3
        assert abs(moved[name] - value) == pytest.approx(per_half_l[name] * lost_deg / 2, rel=2e-3, abs=floor), name
    assert max(per_half_l[f"bias_counts[{i}]"] for i in range(3)) * lost_deg / 2 > 0.25  # a first-order response


def test_the_six_position_sequences_lost_motion_moves_no_angle_and_the_budget_says_so():
    for stage in range(3):  # the table: no angle moves
        perfect = quantities(_solve(_steps(TableGeometry(), DIRECTIONS)))
        moved = quantities(_solve(_steps(_lost_motion_only(stage, LOST_MAX_DEG), DIRECTIONS)))
        assert all(abs(moved[n] - perfect[n]) < 1e-12 for n in ANGLE_NAMES), stage
    steps = _steps(TableGeometry(), DIRECTIONS)
    cal = _solve(steps)

    def lost_motion_u(st):
        parts = [c for c in contributions(cal, st, _solve, RIG) if c.source == "lost motion"]
        return max(np.sqrt(sum(c.u[n] ** 2 for c in parts)) for n in ANGLE_NAMES)

    assert lost_motion_u(steps) < 1e-6  # the directions recorded: none (finite differences aside), as on the table
    assert lost_motion_u(dataclasses.replace(steps, arrival_direction=None)) > 1e-5  # unknown signs: a fifth of U


def test_poses_before_a_stages_first_move_share_one_lost_motion_of_unknown_sign():
    arrival = DIRECTIONS.copy()
    arrival[:4, 1] = 0  # a2 first moves to the fifth pose
    names = {p.name: p for p in rig_parameters(RIG, 6, arrival) if p.group == "lost motion"}
    assert set(names) == {"lost_motion.a1", "lost_motion.a2", "lost_motion.a2@start", "lost_motion.a3"}
    assert names["lost_motion.a2@start"].directions[:, 1].tolist() == [-1, -1, -1, -1, 0, 0]
    assert names["lost_motion.a2"].directions[:, 1].tolist() == [0, 0, 0, 0, 1, -1]
    without = [p.name for p in rig_parameters(RIG, 6) if p.group == "lost motion"]
    assert len(without) == 18 and "lost_motion.a2@5" in without  # per pose and stage, as before


def test_approached_from_one_side_or_partly_so_the_recorded_directions_are_not_used():
    steps = _steps(TableGeometry(), DIRECTIONS)
    cal = _solve(steps)
    one_side = dataclasses.replace(RIG, one_direction=True)
    assert usable_arrival(steps, RIG) is not None and usable_arrival(steps, one_side) is None
    assert {c.name for c in contributions(cal, steps, _solve, one_side) if c.source == "lost motion"} == {
        "lost_motion.a2", "lost_motion.a3"}  # a constant per stage, whatever the recorded signs (a1: about the vertical)
    mixed = dataclasses.replace(RIG, mixed_approach=True)
    assert {c.name for c in contributions(cal, steps, _solve, mixed) if c.source == "lost motion"} >= {
        "lost_motion.a3@2", "lost_motion.a2@6"}  # unknown signs: the recorded ones do not say how those arrived


@pytest.mark.parametrize("bad", [np.ones((6, 2)), np.full((6, 3), 2.0), np.ones((5, 3))],
                         ids=["two stages", "not a direction", "one pose short"])
def test_arrival_directions_of_the_wrong_shape_or_values_are_refused(bad):
    with pytest.raises(CalibError, match="arrival_direction"):
        _steps(TableGeometry(), bad)
