"""Rig characterisation by reversal (issue 29 item 3): one sensor at the same poses in several mountings in its
fixture separates the table's errors (fixture misalignment, a2's zero, non-orthogonalities) from the sensor's;
the estimates come with their standard uncertainties, replace the classes in the budget, and inputs that cannot
separate them are refused with the reason."""

from __future__ import annotations

import numpy as np
import pytest

import calib
from calib.accel.inputs import StepMeans
from calib.accel.reversal import Mounting, characterise
from calib.accel.rig_propagation import rig_parameters, stage_angles_deg
from calib.errors import CalibError
from calib.numerics.budget import RigErrors
from calib.numerics.turntable import StageErrors, TableGeometry, rot_x, rot_z
from calib.synthetic import six_faces, triangular_matrix

HIDDEN = TableGeometry(stages=(StageErrors(), StageErrors(zero_offset_deg=0.008), StageErrors()),
                       non_orthogonality_deg=(0.015, -0.012, 0.0), mounting_deg=(0.05, -0.08, 0.07))
TRUE = {"mounting.x": 0.05, "mounting.y": -0.08, "mounting.z": 0.07, "zero_offset.a2": 0.008,
        "non_orthogonality.a1_a2": 0.015, "non_orthogonality.a2_a3": -0.012}
SENSOR = triangular_matrix([8200.0, 8150.0, 8230.0], 1e-3, -2e-3, 5e-4) + np.array([[0, 0, 0], [-10, 0, 0], [15, 4, 0]])
BIAS = np.array([40.0, -25.0, 60.0])
SEM = 0.3
Z180, X180 = rot_z(np.pi)[0], rot_x(np.pi)[0]


def mounting(turn, rng, poses=None) -> Mounting:
    """The hidden table and sensor recorded at ``poses`` with the sensor turned by ``turn`` in its fixture."""
    f_nom = six_faces() if poses is None else poses
    angles = stage_angles_deg(f_nom)
    r = HIDDEN.sensor_to_world(np.eye(3), angles, np.zeros_like(angles)) @ turn
    f = np.transpose(r, (0, 2, 1)) @ np.array([0.0, 0.0, 1.0])
    counts = f @ SENSOR.T + BIAS + rng.normal(0, SEM, f.shape)
    k = len(f_nom)
    steps = StepMeans(names=tuple(f"p{i}" for i in range(k)), f_nominal_g=f_nom, mean_counts=counts,
                      sem_counts=np.full((k, 3), SEM), n_samples=np.full(k, 1000), temp_c=None,
                      t_s=np.arange(k) * 15.0, lsb_per_g=8192.0)
    return Mounting(steps, turn)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_three_mountings_recover_the_hidden_non_orthogonality_within_its_stated_uncertainty(seed):
    rng = np.random.default_rng(seed)
    result = characterise([mounting(np.eye(3), rng), mounting(Z180, rng), mounting(X180, rng)],
                          RigErrors.from_classes())
    assert set(result.estimate_deg) == set(TRUE)
    for name, truth in TRUE.items():
        assert abs(result.estimate_deg[name] - truth) < 3 * result.u_deg[name], name
    for name in ("non_orthogonality.a1_a2", "non_orthogonality.a2_a3"):
        # inside the class it replaces; not far inside: the stages' periodic and accumulated errors at the six
        # faces' angles (their classes, kept) look the same in every mounting and stay in the estimates' u
        assert result.u_deg[name] < 0.02 / np.sqrt(3) / 2
    assert 0.3 < result.chi2_per_dof < 2.0


def test_the_characterisation_replaces_the_classes_in_later_budgets():
    rng = np.random.default_rng(5)
    result = characterise([mounting(np.eye(3), rng), mounting(Z180, rng), mounting(X180, rng)],
                          RigErrors.from_classes())
    rig = result.rig_errors(RigErrors.from_classes(), "reversal 2026-11-25")
    u = {p.name: p.u_deg for p in rig_parameters(rig, 6)}
    # the fit's u (how well it corrects the poses): the classes it aliases keep their own terms in the budget
    assert u["non_orthogonality.a2_a3"] == result.u_correction_deg["non_orthogonality.a2_a3"]
    assert result.u_correction_deg["non_orthogonality.a2_a3"] < result.u_deg["non_orthogonality.a2_a3"]
    assert u["non_orthogonality.a1_a3"] == 0.0  # a2's zero and the fixture's x turn under another name
    assert u["accumulated_sin.a3"] == pytest.approx(0.02 / np.sqrt(6))  # not characterised: its class
    assert rig.source == "reversal 2026-11-25"


def test_one_mounting_is_refused_with_the_reason():
    with pytest.raises(CalibError, match="one mounting only: the table's errors and the sensor's are the same unknowns"):
        characterise([mounting(np.eye(3), np.random.default_rng(0))], RigErrors.from_classes())


@pytest.mark.parametrize("turns, undetermined", [
    ((np.eye(3), np.eye(3)), "mounting.x, mounting.y, mounting.z"),   # the sensor never turned
    ((np.eye(3), Z180), "mounting.z, non_orthogonality.a2_a3"),       # a turn about z alone leaves these
])
def test_mountings_that_do_not_separate_table_and_sensor_are_refused_naming_what_is_left(turns, undetermined):
    rng = np.random.default_rng(0)
    with pytest.raises(CalibError, match="do not separate the table from the sensor") as exc:
        characterise([mounting(t, rng) for t in turns], RigErrors.from_classes())
    assert undetermined in str(exc.value)


def test_mountings_at_other_poses_are_refused():
    rng = np.random.default_rng(0)
    other = six_faces()[[1, 0, 2, 3, 4, 5]]
    with pytest.raises(CalibError, match="mounting 2 was recorded at other poses"):
        characterise([mounting(np.eye(3), rng), mounting(Z180, rng, other)], RigErrors.from_classes())


def test_a_later_calibration_on_the_characterised_rig_loses_the_tables_errors():
    """The calibration session's poses put where the characterised table puts them: the fixture's turn and the
    non-orthogonalities leave the sensor's angles (they were 1 mrad off, the fixture's 0.05-0.08 deg)."""
    rng = np.random.default_rng(7)
    rig = RigErrors.from_classes()
    result = characterise([mounting(np.eye(3), rng), mounting(Z180, rng), mounting(X180, rng)], rig)
    session = mounting(np.eye(3), rng).steps
    full = calib.solve(session, model="full", method="pinv", thermal="off")
    fixed = calib.solve(result.corrected(session, rig), model="full", method="pinv", thermal="off")
    off = lambda cal: np.max(np.abs(np.asarray(cal.matrix_counts_per_g) - SENSOR)) / 8200.0
    assert off(full) > 8e-4
    assert off(fixed) < 1.5e-4
