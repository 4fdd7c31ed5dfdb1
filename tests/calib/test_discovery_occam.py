"""Occam counts every fitted parameter, and only supported effects are named (issue 27, items 1 and 2).

The design is a thermal calibration as people record it: the six faces at each chamber level, a heating
leg then a cooling leg (22 -> 46 C, then 42 -> 26 C), the session with no record of how the chamber
reached its first level (that level's leg unknown, h = 0; the sensor was in fact heated to it from
20 C). On it a heating/cooling offset and a bias step at the leg switch are the same columns: the
data cannot tell them apart, the design can. Step means of the simulator's own error model with the
MPU-9150's bias wander (``test_discovery_matrix.session``).
"""

from __future__ import annotations

import numpy as np
import pytest

from calib.discovery.effects import heating_state
from test_discovery_matrix import FACES, legs, run, tumble

HYSTERESIS_G = [1.5e-3, 1.2e-3, -1.5e-3]


def heating_then_cooling(levels=(22.0, 30.0, 38.0, 46.0, 42.0, 34.0, 26.0), start_c=20.0) -> dict:
    """Faces at each level, heating then cooling; the first level's leg unknown to the session."""
    d = tumble(levels=levels, start_c=None, poses=FACES)
    d["true_heating"] = heating_state(np.concatenate([[start_c], d["temp"]]), 0.5)[1:]
    return d


def _leg_switch_s(design: dict) -> float:
    """The midpoint between the last heating step and the first cooling step, s."""
    i = int(np.flatnonzero(design["heating"] < 0)[0])
    return 0.5 * (design["t"][i - 1] + design["t"][i])


@pytest.mark.parametrize("seed", [100, 101, 102])
def test_hidden_hysteresis_is_named_not_a_bias_jump_fitted_to_the_leg_switch(seed):
    """The jump's fitted time is a parameter too, and it fell on the leg switch (the design explains it):
    the physically simpler effect is named, the jump listed as its alias. Before: bias_jump, its time at
    the switch, in every seed (the preference counted the hysteresis' three initial-leg columns against
    it and not the jump's time)."""
    d, _ = run(heating_then_cooling(), seed, thermal_hysteresis_g=HYSTERESIS_G)
    assert [e.name for e in d.effects] == ["bias_tempco", "thermal_hysteresis"], [e.name for e in d.effects]
    assert ["thermal_hysteresis", "bias_jump"] in d.aliases, d.aliases
    e = d.effects[1]
    assert np.all(np.abs(np.array(e.estimate) - HYSTERESIS_G) < 3 * np.array(e.sigma)), (e.estimate, e.sigma)
    assert d.gap_closed


def test_a_jump_fitted_to_a_design_boundary_is_reported_as_aliased_with_that_boundary_factor():
    """Without a heating/cooling record hysteresis cannot be tested, and the step at the leg switch is
    named as a jump; the report says the jump's time is the leg switch and a change of temperature
    level, so an offset per leg or per temperature level describes it as well."""
    design = heating_then_cooling()
    steps_ctx_free = dict(design, heating=np.zeros(len(design["t"])))  # the session has no leg record
    d, _ = run(steps_ctx_free, 103, thermal_hysteresis_g=HYSTERESIS_G)
    j = next(e for e in d.to_json()["effects"] if e["name"] == "bias_jump")
    assert j["t_jump_s"] == pytest.approx(_leg_switch_s(design))
    assert j["t_jump_boundary"] == ["temperature change"] and j["aliased_with_factor"] == ["temperature_level"]


def test_a_jump_away_from_any_design_boundary_is_not_aliased_with_a_factor():
    design = heating_then_cooling()
    t_jump = float(design["t"][9] - 10.0)  # within the second level, between two faces
    d, _ = run(design, 104, bias_jump_g=[1.5e-3, -1e-3, 1.2e-3], bias_jump_t_s=t_jump)
    j = next(e for e in d.to_json()["effects"] if e["name"] == "bias_jump")
    assert design["t"][8] < j["t_jump_s"] < design["t"][9]
    assert j["t_jump_boundary"] == [] and j["aliased_with_factor"] == []


#: the issue's second failure at the step level: a quadratic tempco with a small hysteresis and a small
#: step at a change of level, on the project's own legs design (seed 927 of a random-mixture scan)
MIXED = dict(bias_tempco2_g_per_c2=[2.5e-6, 1.55e-6, 1.93e-6], thermal_hysteresis_g=[-5.4e-4, 4.3e-4, -0.84e-4],
             bias_jump_g=[-0.95e-4, 5.6e-4, -2.2e-4], bias_jump_t_s=3418.6)


def test_no_effect_is_named_with_a_final_model_p_value_above_the_false_alarm_rate():
    """Before: bias_jump named with p = 0.38 (its time moved to 2600 s by the final refit, where the final
    model has no use for it) beside a spurious bias_tempco_cubic; chi2/dof 0.98, nothing to warn. Every
    named effect is now re-tested in the final model, and the p-value reported is that test's."""
    d, _ = run(legs(), 927, **MIXED)
    names = [e.name for e in d.effects]
    assert all(e.p_value <= d.false_alarm for e in d.effects), [(e.name, e.p_value) for e in d.effects]
    assert {"bias_tempco", "bias_tempco_quadratic", "thermal_hysteresis"} <= set(names), names
    assert "bias_tempco_cubic" not in names and d.gap_closed
