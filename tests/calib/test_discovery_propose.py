"""The discriminating experiment at the step level (issue 27 item 3): the set-points that separate an alias
pair, with their predicted power (``calib.discovery.propose``)."""

from __future__ import annotations

from calib.discovery.propose import separating
from calib.discovery.search import discover
from test_discovery_matrix import session, tumble
from test_discovery_occam import HYSTERESIS_G, heating_then_cooling


def test_hysteresis_aliased_with_a_jump_at_the_leg_switch_gets_a_block_that_separates_them():
    steps, ctx, _ = session(heating_then_cooling(), 100, thermal_hysteresis_g=HYSTERESIS_G)
    d = discover(steps, ctx)
    (p,) = separating(steps, ctx, d, d.false_alarm)
    assert p.pair == ("thermal_hysteresis", "bias_jump")
    assert p.power_before < 0.01 and p.power >= 0.9, (p.power_before, p.power)
    assert len(p.setpoints_c) == 1 and p.setpoints_c[0] > 26.5  # heat again from the last (cooling) level
    assert p.added_steps == 6


def test_no_aliases_no_proposal():
    steps, ctx, _ = session(tumble(), 21)
    d = discover(steps, ctx)
    assert d.aliases == [] and separating(steps, ctx, d, d.false_alarm) == []
