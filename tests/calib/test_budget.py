"""The accelerometer's uncertainty budget (issue 29 item 5): Type A (the solve's sigma, unchanged) and Type B
(rig poses, rig frame, lost motion, gravity, thermometer) contributions in ``sigma``'s keys, combined by root
sum of squares, expanded with k = 2; ``accelerometer.uncertainty`` in the calibration file, absent when no
budget was made."""

from __future__ import annotations

import numpy as np
import pytest

import calib
from calib.accel.budget import contributions, flat_sigma, quantities, uncertainty_section
from calib.accel.rig_propagation import pose_shift, rig_parameters, stage_angles_deg
from calib.accel.result import AccelCalibration
from calib.errors import CalibrationFileError
from calib.numerics.budget import Contribution, RigErrors, TableClass, combined, expanded
from calib.numerics.gravity import from_site, standard_gravity
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

LSB = 8192.0
TRUTH = Truth(matrix_counts_per_g=triangular_matrix([8200.0, 8150.0, 8230.0], 1e-3, -2e-3, 5e-4),
              bias_counts=np.array([40.0, -25.0, 60.0]), tempco_counts_per_c=np.array([0.0, 0.0, 0.0]))


def _solve(steps):
    return calib.solve(steps, model="triangular", method="pinv", thermal="off")


@pytest.fixture(scope="module")
def six():
    steps = make_steps(TRUTH, six_faces(), rng=np.random.default_rng(1), with_temperature=False)
    return _solve(steps), steps


GROUPS = ["noise and wander", "rig frame (mounting, stage zeros)", "rig axes (non-orthogonality)",
          "stage angular errors and wobble", "lost motion", "gravity", "thermometer"]


def test_the_contributions_add_up_to_the_combined_and_expanded_uncertainty(six):
    cal, steps = six
    parts = contributions(cal, steps, _solve, RigErrors.from_classes())
    assert parts[0].type == "A" and all(c.type == "B" for c in parts[1:])
    u_c = combined(parts)
    for name in quantities(cal):
        rss = np.sqrt(sum(np.nan_to_num(c.u[name]) ** 2 for c in parts))
        assert u_c[name] == pytest.approx(rss, rel=1e-12)
        assert expanded(parts, 3.0)[name] == pytest.approx(3.0 * rss, rel=1e-12)
    section = uncertainty_section(cal, steps, _solve, RigErrors.from_classes())
    assert [c["name"] for c in section["budget"]] == GROUPS
    assert section["k"] == 2.0
    assert section["bias_counts"] == pytest.approx([2 * u_c[f"bias_counts[{i}]"] for i in range(3)])
    assert section["misalignment"]["alpha_zx"] == pytest.approx(2 * u_c["misalignment.alpha_zx"])
    for i in range(3):  # the groups in the file add up to the same combined uncertainty
        rss = np.sqrt(sum(c["bias_counts"][i] ** 2 for c in section["budget"]))
        assert section["combined_standard"]["bias_counts"][i] == pytest.approx(rss, rel=1e-12)
    assert set(section) >= {"bias_counts", "scale_counts_per_g", "matrix_counts_per_g", "misalignment", "budget",
                            "combined_standard"}


def test_type_a_is_the_solves_sigma_unchanged_without_a_misfit(six):
    cal, steps = six
    assert not cal.misfit()[0]
    type_a = contributions(cal, steps, _solve, RigErrors.from_classes())[0]
    assert type_a.u == flat_sigma(cal)
    assert type_a.u["bias_counts[1]"] == cal.sigma["bias_counts"][1]
    assert type_a.u["misalignment.alpha_yz"] == cal.sigma["misalignment"]["alpha_yz"]


def _groups(cal, steps, rig):
    return {c["name"]: c for c in uncertainty_section(cal, steps, _solve, rig)["budget"]}


def test_the_fixture_mounting_enters_the_angles_one_to_one_and_gravity_only_the_scales(six):
    cal, steps = six
    site = from_site(52.0, 100.0)
    parts = _groups(cal, steps, RigErrors.from_classes(gravity=site))
    frame = parts["rig frame (mounting, stage zeros)"]["misalignment"]
    mounting_u = np.radians(TableClass().mounting_deg / np.sqrt(3))
    for n in ("alpha_yz", "alpha_zy", "alpha_zx"):  # a small rotation of every pose is a misalignment of its size
        assert mounting_u <= frame[n] <= TableClass().frame_u_rad() * 1.001
    for i in range(3):
        assert parts["gravity"]["scale_counts_per_g"][i] == pytest.approx(
            cal.scale_counts_per_g[i] * site.u_m_s2 / site.g_m_s2, rel=1e-12)
        assert parts["gravity"]["bias_counts"][i] == 0.0
    unknown = _groups(cal, steps, RigErrors.from_classes(gravity=standard_gravity()))
    assert unknown["gravity"]["scale_counts_per_g"][0] > 30 * parts["gravity"]["scale_counts_per_g"][0]


def test_approaching_from_one_side_makes_lost_motion_a_constant_of_each_stage_like_its_zero(six):
    """Poses reached from either side: lost motion scatters every pose (one parameter per pose and stage); from
    one side: one constant per stage, which moves the poses exactly as that stage's zero offset does (so a
    characterisation of the stage zeros takes it in)."""
    cal, steps = six
    table = TableClass()
    either = {c.name: c.u for c in contributions(cal, steps, _solve, RigErrors.from_classes(table))}
    one = {c.name: c.u for c in contributions(cal, steps, _solve, RigErrors.from_classes(table, one_direction=True))}
    assert sum(n.startswith("lost_motion.a3@") for n in either) == 4  # every pose but +-Y, which lie on its axis
    ratio = (table.lost_motion_deg / np.sqrt(12)) / (table.zero_offset_deg / np.sqrt(3))
    for s in ("a2", "a3"):
        assert f"lost_motion.{s}@1" not in one
        for name, u in one[f"lost_motion.{s}"].items():
            assert u == pytest.approx(ratio * one[f"zero_offset.{s}"][name], rel=1e-6, abs=1e-12)


def test_a_non_orthogonality_moves_the_poses_as_on_the_table():
    rig = RigErrors.from_classes()
    (p,) = [p for p in rig_parameters(rig, 1) if p.name == "non_orthogonality.a1_a2"]
    y_up = stage_angles_deg(np.array([[0.0, 1.0, 0.0]]))
    assert y_up[0] == pytest.approx([0, 90, 0])
    shift = pose_shift(p, y_up)[0]  # a2's axis tilted towards z: +Y up reads f_x = sin(d) cos(d)
    assert shift == pytest.approx([np.radians(1.0), 0.0, 0.0], abs=1e-6)  # second order: eps / 2


def test_the_thermometer_enters_through_the_thermal_model():
    truth = Truth(matrix_counts_per_g=TRUTH.matrix_counts_per_g, bias_counts=TRUTH.bias_counts,
                  tempco_counts_per_c=np.array([2.0, -1.5, 3.0]))
    f = np.tile(six_faces(), (3, 1))
    temps = np.repeat([15.0, 25.0, 35.0], 6)
    steps = make_steps(truth, f, temp_c=temps, rng=np.random.default_rng(4))

    def solve(st):
        return calib.solve(st, model="triangular", method="pinv", thermal=1, t0_c=25.0)

    cal = solve(steps)
    parts = {c.name: c.u for c in contributions(cal, steps, solve, RigErrors.from_classes())}
    flat = parts["thermometer"]
    assert flat["bias_counts[2]"] > 0
    assert all(flat[f"bias_counts[{i}]"] < abs(truth.tempco_counts_per_c[i]) * 0.1 for i in range(3))


def test_the_calibration_file_holds_the_uncertainty_only_when_a_budget_was_made(six):
    cal, steps = six
    assert "uncertainty" not in cal.to_dict()  # files without a budget are unchanged
    with_u = cal.model_copy(update={"uncertainty": uncertainty_section(cal, steps, _solve, RigErrors.from_classes())})
    d = with_u.to_dict()
    assert AccelCalibration.from_dict(d) == with_u and d["sigma"] == cal.to_dict()["sigma"]
    d["uncertainty"] = dict(d["uncertainty"], k=0)
    with pytest.raises(CalibrationFileError, match="uncertainty.k"):
        AccelCalibration.from_dict(d)


def test_a_contribution_is_type_a_or_b():
    with pytest.raises(ValueError):
        Contribution("x", "C", "", {})
