"""Weak candidates (issue 27, the remaining target): an effect with some support in the final model but not
enough to be named at the false-alarm rate is listed apart (``Discovery.weak``, ``weak_candidates`` in the
``rig-discover/6`` document), never named, with its fitted magnitude, p-value and the design's smallest
detectable magnitude; the experiment that decides it (``calib.discovery.propose.deciding``) states its
predicted power, and run on the same sensor it names the effect.

Step level (``test_discovery_matrix.session``): six faces at 22, 30, 38, 46 C heating then 42, 34, 26 C
cooling, the MPU-9150's bias wander, each hidden effect below what the design detects at the false-alarm rate.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from calib.discovery.propose import POWER_TARGET, block_inputs, deciding
from calib.discovery.search import discover, final_problem
from test_discovery_matrix import session
from test_discovery_occam import heating_then_cooling

WEAK_QUADRATIC = {"bias_tempco2_g_per_c2": [1.5e-6, -1.5e-6, 1.5e-6]}  # g/C^2, below the design's MDM
WEAK_HYSTERESIS = {"thermal_hysteresis_g": [5e-4, 5e-4, -5e-4]}  # g
SCHEMA = json.loads((Path(__file__).resolve().parents[2] / "docs" / "schemas" / "discover.schema.json").read_text())


def extended(design: dict, x) -> dict:
    """``design`` with the proposed blocks ``x`` (:func:`calib.discovery.propose.block_inputs`) appended: their
    legs known to the session and lived by the sensor, as running the proposed procedure gives."""
    k = len(x.f_g)
    true = design.get("true_heating", design["heating"])
    return {"f": np.vstack([design["f"], x.f_g]), "temp": np.concatenate([design["temp"], x.temp_c]),
            "t": np.concatenate([design["t"], x.t_s]), "heating": np.concatenate([design["heating"], x.heating]),
            "rate": np.zeros(len(design["f"]) + k), "a1": np.concatenate([design["a1"], np.zeros(k)]),
            "true_heating": np.concatenate([true, x.heating])}


def _weak(d) -> dict:
    return {w["name"]: w for w in d.weak}


@pytest.mark.parametrize("seed, hidden, name", [(6, WEAK_QUADRATIC, "bias_tempco_quadratic"),
                                                (0, WEAK_HYSTERESIS, "thermal_hysteresis")],
                         ids=["quadratic", "hysteresis"])
def test_a_weak_effect_is_listed_as_a_weak_candidate_and_never_named(seed, hidden, name):
    steps, ctx, _ = session(heating_then_cooling(), seed, **hidden)
    d = discover(steps, ctx)
    assert [e.name for e in d.effects] == ["bias_tempco"]
    w = _weak(d)[name]
    assert d.weak[0]["name"] == name  # the most supported first
    assert w["p_value"] < w["threshold"] and w["p_family"] < 0.2 and w["p_value"] > d.false_alarm / 10
    assert len(w["estimate"]) == len(w["sigma"]) == len(w["mdm"]) == 3 and w["unit"]
    # not named because the design cannot show it at this size: the estimate is below what it detects
    assert np.max(np.abs(w["estimate"])) < np.max(w["mdm"]), (w["estimate"], w["mdm"])
    doc = json.loads(json.dumps(d.to_json()))
    assert doc["format"] == "rig-discover/6" and doc["weak_candidates"][0]["name"] == name
    jsonschema = pytest.importorskip("jsonschema")
    assert not list(jsonschema.Draft202012Validator(SCHEMA).iter_errors(doc))


@pytest.mark.parametrize("seed, hidden, name", [(6, WEAK_QUADRATIC, "bias_tempco_quadratic"),
                                                (0, WEAK_HYSTERESIS, "thermal_hysteresis")],
                         ids=["quadratic", "hysteresis"])
def test_the_experiment_that_decides_a_weak_candidate_reaches_its_power_and_names_it(seed, hidden, name):
    design = heating_then_cooling()
    steps, ctx, _ = session(design, seed, **hidden)
    d = discover(steps, ctx)
    p = next(p for p in deciding(steps, ctx, d, d.false_alarm) if p.pair[0] == name)
    assert p.kind == "weak" and p.reached and p.power >= POWER_TARGET > p.power_before, (p.power, p.power_before)
    assert 0 < p.added_s <= p.budget_s and p.added_steps == 6 * len(p.setpoints_c)
    prob, _ = final_problem(steps, ctx, [e.name for e in d.effects], d.false_alarm)
    x, _ = block_inputs(prob, steps, ctx, p.setpoints_c, np.unique(np.round(prob.f, 6), axis=0), 40.0)
    more, ctx2, _ = session(extended(design, x), seed, **hidden)  # the same sensor, the procedure run again
    after = discover(more, ctx2)
    assert [e.name for e in after.effects] == ["bias_tempco", name], [e.name for e in after.effects]
    assert all(e.p_value <= after.false_alarm for e in after.effects)


def test_a_weak_candidate_no_experiment_decides_within_the_budget_is_said_so():
    steps, ctx, _ = session(heating_then_cooling(), 0, **WEAK_HYSTERESIS)
    d = discover(steps, ctx)
    jump = next(p for p in deciding(steps, ctx, d, d.false_alarm) if p.pair[0] == "bias_jump")
    assert not jump.reached and jump.power < POWER_TARGET  # set-points after the session hardly place a jump in it
    short = next(p for p in deciding(steps, ctx, d, d.false_alarm, budget_s=600.0) if p.pair[0] == "thermal_hysteresis")
    assert short.setpoints_c == [] and not short.reached  # a block (settling + six faces) takes longer than 600 s


def test_clean_sessions_seldom_list_a_weak_candidate():
    """At the weak level (0.2 for the family of candidates) a clean session lists one in about 1 in 5 at most
    (measured: 1 of 20 seeds); all five here list none but one at most."""
    listed = []
    for seed in range(1, 6):
        steps, ctx, _ = session(heating_then_cooling(), seed)
        d = discover(steps, ctx)
        assert [e.name for e in d.effects] == ["bias_tempco"]
        listed += [seed] if d.weak else []
    assert len(listed) <= 1, listed
