"""The magnetometer's uncertainty budget on a turntable, positions method (docs/uncertainty.md, "The magnetometer"):
the sensor's mounting in its fixture turns the field every pose puts in the sensor frame, which the soft-iron
matrix takes in beyond its Type A sigma; each pose's own error moves the hard iron too. U holds them, the
contributions add up, a table without errors leaves U = k sigma, and the section round-trips through the file."""

from __future__ import annotations

import numpy as np
import pytest

from calib.errors import CalibrationFileError
from calib.mag import MagCalibration, MagStepMeans, solve_mag_positions
from calib.mag.budget import contributions, uncertainty_section
from calib.numerics.budget import RigErrors, TableClass
from calib.numerics.turntable import TableGeometry
from drivers.sensors.sim.error_model import MagErrorModel

from test_gyro_budget import PERFECT
from test_calib_gyro_mag import eight_positions, field_in_sensor

MOUNTING_DEG = (0.09, -0.07, 0.08)
RIG = RigErrors.from_classes(TableClass())
QUIET_UT = 0.002  # a step's standard error, uT: quiet enough that the mounting stands out of the noise


def _mounted_session(seed: int) -> tuple[MagCalibration, MagStepMeans, MagErrorModel]:
    """The eight positions, felt by a sensor turned in its fixture by MOUNTING_DEG."""
    model = MagErrorModel.draw(np.random.default_rng(seed))
    h = field_in_sensor(eight_positions())  # where each pose should put the field
    felt = h @ TableGeometry(mounting_deg=MOUNTING_DEG).mounting()  # rows: M^T h
    sem = np.full(h.shape, QUIET_UT)
    mean = model.output_ut(felt) + np.random.default_rng(seed + 1).normal(size=h.shape) * sem
    steps = MagStepMeans(tuple(f"p{k}" for k in range(len(h))), h, mean, sem, np.full(len(h), 100))
    return solve_mag_positions(steps), steps, model


def test_the_mounting_is_in_the_matrix_beyond_sigma_and_within_u():
    cal, steps, model = _mounted_session(31)
    u = uncertainty_section(cal, steps, RIG)
    a_true = np.asarray(model.soft_iron)
    errors = {f"a_{r}{c}": abs(cal.matrix[i][j] - a_true[i, j]) for i, r in enumerate("xyz")
              for j, c in enumerate("xyz")}
    assert max(errors[n] / cal.sigma[n] for n in errors) > 20  # the mounting, not the noise
    assert all(errors[n] < u[n] for n in errors), {n: (errors[n], u[n]) for n in errors}


def test_the_contributions_add_up_and_a_table_without_errors_leaves_k_sigma():
    cal, steps, _ = _mounted_session(32)
    u = uncertainty_section(cal, steps, RIG, k=2.0)
    assert [c["name"] for c in u["budget"]] == [c.name for c in contributions(cal, steps, RIG)]
    for name in cal.sigma:
        rss = np.sqrt(sum(c[name] ** 2 for c in u["budget"]))
        assert u[name] == pytest.approx(2.0 * rss, rel=1e-12)
    poses = {c["name"]: c for c in u["budget"]}["rig poses (stage errors, wobble, non-orthogonality, lost motion)"]
    assert poses["hard_iron_x"] > 0  # each pose's own error moves the hard iron; the frame's barely does
    perfect = uncertainty_section(cal, steps, PERFECT)
    assert all(perfect[n] == pytest.approx(2.0 * s, rel=1e-12) for n, s in cal.sigma.items())


def test_the_section_round_trips_and_a_budget_without_types_is_refused():
    cal, steps, _ = _mounted_session(33)
    with_u = cal.model_copy(update={"uncertainty": uncertainty_section(cal, steps, RIG)})
    assert MagCalibration.from_dict(with_u.to_dict()) == with_u
    assert "uncertainty" not in cal.to_dict()
    bad = with_u.to_dict()
    bad["uncertainty"]["budget"] = [{"name": "noise"}]
    with pytest.raises(CalibrationFileError, match=r"uncertainty.budget.*type A or B"):
        MagCalibration.from_dict(bad)
