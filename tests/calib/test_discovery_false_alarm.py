"""False alarms of the discrepancy search on clean sessions (issue 15: at most the stated rate).

Every simulated sensor has a real ``bias_tempco``; anything else named on a clean session is a false
alarm. The nested tests themselves are calibrated (uniform p-values under the null, docs/discrepancy.md);
these tests pin the ways the search went beyond the stated rate: an alias of the real effect
entering in its place (about 5 % of clean sessions of the thermal design), the best of several
nuisance factors reported as if it had been the only one tried (about 5 % of sessions whose gap is
open for no reason a factor describes), and an F test on the few dof a six-position session leaves
(a chance drop against a small residual mean square).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from calib.discovery.search import candidate_pvalues, discover
from calib.discovery.observe import critical_noncentrality, critical_value
from calib.discovery.problem import floored_sf
from calib.discovery.effects import heating_state
from test_discovery_matrix import FACES, SEM_G, legs, run, session, tumble


def thermal(levels=(27.6, 32.6, 37.6, 42.6, 47.6, 52.6)):
    """procedures/thermal.yaml at the step level: six faces at each of six chamber levels 5 C apart,
    steps 16 s apart, 10 minutes between levels (the temperature rises with time: a bias linear in
    temperature and one linear in time differ only by the steps' order within a level)."""
    f = np.tile(FACES, (len(levels), 1))
    k = len(f)
    temp = np.repeat(levels, 6) + 0.02 * np.random.default_rng(99).standard_normal(k)
    t = 60.0 + np.arange(k) * 16.0 + np.repeat(np.arange(len(levels)) * 600.0, 6)
    return {"f": f, "temp": temp, "t": t, "heating": heating_state(temp, 0.5), "rate": np.zeros(k), "a1": np.zeros(k)}


@pytest.mark.parametrize("seed", [38, 48, 50])
def test_a_clean_thermal_session_whose_wander_looks_like_a_drift_names_the_real_bias_tempco(seed):
    """The wander of these sessions fits a drift slightly better than the real tempco, and neither is
    significant once the other is in: the data cannot tell them apart, so the stated preference (the
    temperature polynomial, the seed's own thermal model) decides, and the drift is reported as its
    alias, not named. Before, the more significant one was named: bias_drift in 15 of 300 seeds."""
    d, _ = run(thermal(), seed)
    assert [e.name for e in d.effects] == ["bias_tempco"], [e.name for e in d.effects]
    assert ["bias_tempco", "bias_drift"] in d.aliases, d.aliases
    assert d.gap_closed


def _understated(seed, factor=0.6):
    """A clean tumble session of white noise whose stated standard errors are ``factor`` x the true
    ones: the gap is open (chi2/dof ~ 1 / factor^2) but what remains has no structure at all."""
    steps, ctx, _ = session(tumble(), seed, stability=None)
    return discover(replace(steps, sem_counts=np.asarray(steps.sem_counts) * factor), ctx)


@pytest.mark.parametrize("seed", [88, 118, 158])
def test_the_best_of_several_nuisance_factors_is_judged_as_the_best_of_several(seed):
    """Six factors are tried on what remains; under the null the smallest of six p-values falls below
    0.01 about 5 % of the time (15 of 300 such sessions). In these sessions it does (0.002..0.007), and
    after Bonferroni over the six it is not significant: no factor is reported, nothing is dropped."""
    d = _understated(seed)
    assert not d.gap_closed and d.chi2_per_dof_after > 2.0
    assert "factor" not in d.unexplained and d.dropped == [], d.unexplained.get("factor")
    assert [e.name for e in d.effects] == ["bias_tempco"]


def test_a_reported_factor_carries_its_bonferroni_p_value_and_the_number_tried():
    d = _understated(190)  # the best factor's own p-value 6e-4: significant over six
    f = d.unexplained["factor"]
    assert f["tried"] == 6 and f["p_value"] < 0.01 and f["p_value"] == pytest.approx(6 * 6e-4, rel=0.1)


@pytest.mark.slow
def test_every_candidate_test_is_calibrated_on_clean_sessions():
    """The p-values of the candidates' tests against the baseline + the real bias_tempco are uniform
    on clean sessions (pooled over 40 sessions of the issue's legs design and its 7 candidates; the
    jump's, Bonferroni over its times, left out). A test that ignored the wander would fail this."""
    pvals = []
    for seed in range(300, 340):
        steps, ctx, _ = session(legs(), seed)
        pvals += [p for n, p in candidate_pvalues(steps, ctx).items() if n != "bias_jump"]
    pvals = np.array(pvals)
    assert len(pvals) == 40 * 7
    assert stats.kstest(pvals, "uniform").pvalue > 1e-3
    assert 0.02 <= np.mean(pvals < 0.05) <= 0.09 and np.mean(pvals < 0.01) <= 0.03


def six_position():
    """procedures/six_position.yaml at the step level: the six faces 25 s apart, 10 s each, at one
    chamber temperature (the thermometer's millikelvin scatter: the temperature terms are full rank)."""
    k = 6
    temp = 27.6 + 0.0005 * np.random.default_rng(7).standard_normal(k)
    return {"f": FACES.copy(), "temp": temp, "t": 30.0 + 25.0 * np.arange(k), "heating": np.zeros(k),
            "rate": np.zeros(k), "a1": np.zeros(k)}


def _six_session(seed):
    steps, ctx, _ = session(six_position(), seed, sem_g=SEM_G / np.sqrt(2), duration_s=10.0)
    return steps, ctx


@pytest.mark.parametrize("seed, effect", [(23, "scale_nonlinearity"), (206, "bias_tempco")])
def test_a_chance_drop_against_the_small_scatter_of_seven_dof_is_not_named(seed, effect):
    """Six steps leave 9 dof to the baseline, 6-7 to a candidate. In these clean sessions the F test
    alone, the drop per column over the residual mean square the candidate leaves, is below the
    Bonferroni threshold only because that mean square is small (the residual happens to be quiet):
    against the stated noise the same drop is ordinary. The search's test divides by the larger of the
    two and names nothing. (On the full rig the F test alone named an effect in 4 of 214 clean
    six-position sessions: table_tilt, scale_tempco, scale_nonlinearity, thermal_gradient.)"""
    steps, ctx = _six_session(seed)
    scatter = candidate_pvalues(steps, ctx, model=(), test="scatter")
    assert scatter[effect] * len(scatter) < 0.01  # the F test alone would name it
    assert candidate_pvalues(steps, ctx, model=(), test="known_noise")[effect] * len(scatter) > 0.01
    d = discover(steps, ctx)
    assert d.effects == [] and d.gap_closed, [e.name for e in d.effects]


@pytest.mark.slow
def test_the_search_test_is_calibrated_at_a_six_position_sessions_few_dof():
    """Over 150 clean six-position sessions, each candidate's p-values against the baseline alone are
    uniform for the search's test (its reference distribution is exact at 6-7 dof, not only
    asymptotically) and for each of its two ingredients alone: the F test, and the chi-square drop
    with V known, which needs V itself right (the step means' wander over their 10 s windows)."""
    pooled: dict = {}
    for seed in range(400, 550):
        steps, ctx = _six_session(seed)
        for kind in ("search", "known_noise", "scatter"):
            for n, p in candidate_pvalues(steps, ctx, model=(), test=kind).items():
                pooled.setdefault((kind, n), []).append(p)
    assert {n for _, n in pooled} >= {"bias_tempco", "scale_nonlinearity", "full_misalignment", "bias_drift"}
    for key, p in pooled.items():
        p = np.array(p)
        assert len(p) == 150 and stats.kstest(p, "uniform").pvalue > 1e-3, key
        assert np.sum(p < 0.05) <= 17, key  # binomial(150, 0.05): P(>= 18) = 6e-4


@pytest.mark.parametrize("q, dof", [(2, 7), (3, 60)])
def test_the_nested_tests_null_tail_and_power_are_those_of_its_statistic(q, dof):
    """T = (drop / q) / max(1, R / dof) with the drop chi-square on q and the residual R on dof, drawn
    200 000 times: T exceeds the critical value at level 0.01 in 1 % of draws, and with the drop
    non-central at the MDM's lambda* in 80 %; its p-value is uniform."""
    rng = np.random.default_rng(q * 100 + dof)
    r = rng.chisquare(dof, 200_000)
    t0 = rng.chisquare(q, 200_000) / q / np.maximum(1.0, r / dof)
    assert np.mean(t0 > critical_value(q, dof, 0.01)) == pytest.approx(0.01, abs=0.0007)
    lam = critical_noncentrality(q, 0.01, dof)
    t1 = rng.noncentral_chisquare(q, lam, 200_000) / q / np.maximum(1.0, r / dof)
    assert np.mean(t1 > critical_value(q, dof, 0.01)) == pytest.approx(0.8, abs=0.005)
    p = np.array([floored_sf(t, q, dof) for t in t0[:2000]])
    assert stats.kstest(p, "uniform").pvalue > 1e-3
