"""Failure bins (issue 30 item 5): every unit of a batch is sorted by its outcome and what failed, by table."""

from __future__ import annotations

import pytest

from rig.lab.bins import BINS, GOOD, LIMIT_BINS, OUTCOME_BINS, REASON_BINS, bin_counts, failure_bin


@pytest.mark.parametrize("outcome, bin_", [("PASS", "good"), ("NO LIMITS", "good"), ("FAULT", "sensor fault"),
                                           ("ABSENT", "absent")])
def test_an_outcome_that_says_it_all_is_its_own_bin(outcome, bin_):
    assert failure_bin(outcome, "whatever the reason", ["range accel.bias_x"]) == bin_


@pytest.mark.parametrize("limit, bin_", [
    ("range accel.bias_y", "bias"), ("range accel.scale_z", "scale"), ("range accel.alpha_zx", "misalignment"),
    ("range accel.m_xy", "misalignment"), ("range accel.tempco1_x", "tempco"), ("sigma accel.bias_x", "sigma"),
    ("max_chi2_per_dof", "fit"), ("max_residual_g", "fit"), ("max_attitude_error_deg", "attitude"),
    ("max_drift_sigma", "drift"), ("range gyro.bias_z", "bias"), ("range mag.hard_iron_x", "bias"),
])
def test_a_failed_limit_puts_the_unit_in_its_parameter_family(limit, bin_):
    assert failure_bin("FAIL", "acceptance: ...", [limit]) == bin_


def test_several_failed_limits_go_to_the_first_row_of_the_table_that_matches():
    assert failure_bin("FAIL", None, ["max_chi2_per_dof", "range accel.scale_x", "range accel.bias_z"]) == "bias"
    assert failure_bin("FAIL", None, ["sigma accel.bias_x", "max_drift_sigma"]) == "drift"


@pytest.mark.parametrize("reason, bin_", [("steps flagged: 2, 4", "flagged steps"),
                                          ("fit residual 1500 ug rms > 1000 ug", "fit"),
                                          ("cannot solve: too few steps", "no solve"),
                                          ("acceptance: something unnamed", "limits"), ("?", "other"), (None, "other")])
def test_a_fail_without_a_failed_limit_is_sorted_by_its_reason(reason, bin_):
    assert failure_bin("FAIL", reason) == bin_


def test_every_bin_is_counted_in_one_order_zero_included():
    assert set(BINS) == {GOOD, "other", *LIMIT_BINS.values(), *REASON_BINS.values(), *OUTCOME_BINS.values()}
    counts = bin_counts(["good", "bias", "good", "sensor fault"])
    assert list(counts) == list(BINS) and counts["good"] == 2 and counts["bias"] == 1 and counts["scale"] == 0
