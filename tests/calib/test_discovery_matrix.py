"""The hidden-effect matrix at the step level: each new effect hidden, two at once, an effect outside
the library, designs with ramps and with legs at different temperatures, and clean sessions of each
design; every session carries the MPU-9150's bias wander (flicker + random walk, ``calib.numerics.wander``)
on top of each step's own noise, as the simulator's ``dlpf`` noise does.

Pass: the hidden effects named and within 3 sigma, nothing else named but the sensor's real
bias_tempco, the gap closed where the library describes the truth; ``gap_closed: false`` and no
wrong names where it does not.
"""

from __future__ import annotations

import numpy as np
import pytest

from calib.numerics.stability import BiasStability
from calib.discovery.search import StepContext, discover
from calib.discovery.effects import heating_state
from calib.synthetic import steps_from_output
from drivers.sensors.sim.error_model import AccelErrorModel

MPU = BiasStability(40e-6, 4e-6, 5000.0)  # the chip registry's MPU-9150 accelerometer figures
SEM_G = 126e-6  # 5 s at 100 Hz through the 44 Hz DLPF: density / sqrt(2 T)
DWELL_S = 5.0
FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _tumble_poses() -> np.ndarray:
    """The 26 directions of tumble26: faces, edges, corners."""
    d = [np.array(v, float) for v in np.ndindex(3, 3, 3)]
    d = [v - 1 for v in d if np.any(v != 1)]
    return np.array([v / np.linalg.norm(v) for v in d])


def tumble(levels=(20.0, 27.5, 35.0, 27.5, 20.0), start_c=25.0, poses=None):
    """Poses repeated at each chamber level, steps every 40 s; legs from the temperature series."""
    poses = _tumble_poses()[::2] if poses is None else poses
    f = np.tile(poses, (len(levels), 1))
    k = len(f)
    temp = np.repeat(levels, len(poses)) + 0.02 * np.random.default_rng(99).standard_normal(k)
    t = 60.0 + np.arange(k) * 40.0 + np.repeat(np.arange(len(levels)) * 600.0, len(poses))
    h = heating_state(np.concatenate([[start_c], temp]), 0.5)[1:] if start_c is not None else \
        heating_state(temp, 0.5)
    a1 = np.tile(np.arange(len(poses)) * 90.0 % 360.0, len(levels))
    return {"f": f, "temp": temp, "t": t, "heating": h, "rate": np.zeros(k), "a1": a1}


def ramps(reps=8):
    """Faces repeated while the chamber heats and cools at different rates (steps taken on ramps)."""
    f = np.tile(FACES, (reps, 1))
    k = len(f)
    t = 60.0 + np.arange(k) * 20.0
    rate = 0.02 * np.sin(2 * np.pi * t / (k * 20.0 / 2.3))
    temp = 25.0 + np.cumsum(rate) * 20.0
    return {"f": f, "temp": temp, "t": t, "heating": heating_state(temp, 0.5), "rate": rate,
            "a1": np.zeros(k)}


def legs():
    """The issue's design: heating steps at 15, 27.6 and 40 C, cooling steps at 33 and 21 C (no
    temperature visited on both legs). The session does not know the leg of the first level (h = 0);
    the sensor was in fact cooled to it from 25 C (``true_heating``)."""
    d = tumble(levels=(15.0, 27.6, 40.0, 33.0, 21.0), start_c=None, poses=FACES)
    d["true_heating"] = heating_state(np.concatenate([[25.0], d["temp"]]), 0.5)[1:]
    return d


DESIGNS = {"tumble": tumble, "ramps": ramps, "legs": legs}


def session(design: dict, seed: int, stability=MPU, outside=None, sem_g=SEM_G, duration_s=DWELL_S, **hidden):
    """Step means and context of a drawn sensor with ``hidden`` error-model fields set (g units) on
    ``design``, each step ``duration_s`` long with standard error ``sem_g`` (g); and the sensor."""
    rng = np.random.default_rng(seed)
    m = AccelErrorModel.draw(rng)
    m.t_ref_c = float(np.mean(design["temp"]))  # centred like the search (t0 = mean step temperature)
    for k_, v in hidden.items():
        setattr(m, k_, v)
    true_legs = design.get("true_heating", design["heating"])  # what the sensor went through
    out = m.output_g(design["f"], design["temp"], design["t"], true_legs, design["rate"])
    if outside is not None:
        out = out + outside(design)
    k = len(design["f"])
    steps = steps_from_output(design["f"], out, temp_c=design["temp"], t_s=design["t"], sem_g=sem_g, rng=rng,
                              stability=stability, duration_s=duration_s)
    ctx = StepContext(heating=design["heating"], temp_rate=design["rate"],
                      angles_deg=np.stack([design["a1"], np.zeros(k), np.zeros(k)], axis=1))
    return steps, ctx, m


def run(design: dict, seed: int, stability=MPU, outside=None, **hidden):
    """Discover on step means of a drawn sensor with ``hidden`` error-model fields set (g units)."""
    steps, ctx, m = session(design, seed, stability, outside, **hidden)
    return discover(steps, ctx), m


def _within_3_sigma(d, name, truth):
    e = next(e for e in d.effects if e.name == name)
    est, sig = np.array(e.estimate, float), np.array(e.sigma, float)
    return bool(np.all(np.abs(est - np.ravel(truth)) < 3 * sig)), (est, sig, truth)


HIDDEN = [  # (design, effect, error-model field, value)
    ("legs", "bias_tempco_cubic", "bias_tempco3_g_per_c3", [2e-6, -2e-6, 1.5e-6]),
    ("ramps", "thermal_gradient", "thermal_gradient_g_per_c_per_s", [0.05, -0.04, 0.05]),
    ("tumble", "bias_jump", "bias_jump_g", [1.5e-3, -1e-3, 1.2e-3]),
    ("legs", "thermal_hysteresis", "thermal_hysteresis_g", [1.5e-3, 1.2e-3, -1.5e-3]),
]


@pytest.mark.parametrize("design, effect, field, value", HIDDEN, ids=[h[1] for h in HIDDEN])
def test_each_new_effect_hidden_is_named_within_3_sigma_and_the_gap_closes(design, effect, field, value):
    des = DESIGNS[design]()
    extra = {"bias_jump_t_s": float(des["t"][len(des["t"]) // 2] - 10.0)} if effect == "bias_jump" else {}
    d, _ = run(des, 11, **{field: value}, **extra)
    named = [e.name for e in d.effects]
    assert effect in named and set(named) <= {effect, "bias_tempco"}, named
    ok, why = _within_3_sigma(d, effect, value)
    assert ok, why
    assert d.gap_closed, d.chi2_per_dof_after


def test_two_effects_at_once_are_both_named_within_3_sigma():
    d, _ = run(tumble(), 12, scale_tempco_per_c=[2e-4, 2e-4, -2e-4], scale_nonlinearity=[3e-3, -3e-3, 3e-3])
    named = [e.name for e in d.effects]
    assert {"scale_tempco", "scale_nonlinearity"} <= set(named) <= {"scale_tempco", "scale_nonlinearity",
                                                                     "bias_tempco"}, named
    assert _within_3_sigma(d, "scale_nonlinearity", [3e-3, -3e-3, 3e-3])[0]
    assert d.gap_closed


def _sin_a1(design):
    """A bias in sin(a1) on every axis: the outer axis disturbs the sensor (no library effect)."""
    return 1.5e-3 * np.sin(np.radians(design["a1"]))[:, None] * np.ones(3)


def _periodic(design):
    """A bias periodic in time (period 700 s): nothing in the library describes it."""
    return 1.5e-3 * np.sin(2 * np.pi * design["t"] / 700.0)[:, None] * np.array([1.0, -1.0, 0.5])


@pytest.mark.parametrize("outside", [_sin_a1, _periodic], ids=["bias_in_sin_a1", "periodic_bias"])
def test_an_effect_outside_the_library_leaves_the_gap_open_without_wrong_names(outside):
    d, _ = run(tumble(), 13, outside=outside)
    names = [e.name for e in d.effects]
    assert set(names) <= {"bias_tempco"}, (names, d.dropped)
    j = d.to_json()
    assert j["gap_closed"] is False and "factor" in j["unexplained"]


def test_the_outer_axis_factor_is_reported_for_a_bias_in_sin_a1():
    d, _ = run(tumble(), 14, outside=_sin_a1)
    assert d.unexplained["factor"]["name"] in ("outer_axis_angle", "pose")


@pytest.mark.parametrize("design", list(DESIGNS))
@pytest.mark.parametrize("seed", [21, 22])
def test_a_clean_session_of_each_design_names_only_the_real_bias_tempco(design, seed):
    d, m = run(DESIGNS[design](), seed)
    assert [e.name for e in d.effects] == ["bias_tempco"], [e.name for e in d.effects]
    assert _within_3_sigma(d, "bias_tempco", m.bias_tempco_g_per_c)[0]
    assert d.gap_closed


def test_the_issue_design_observes_hysteresis_and_reports_its_detectable_magnitude():
    d, _ = run(legs(), 31)
    assert "thermal_hysteresis" not in d.unobservable
    mdm = d.observability["thermal_hysteresis"]["mdm"]
    assert all(0 < x < 1.5e-3 for x in mdm), mdm  # the 1.5 mg of the hidden-effect cell is detectable


@pytest.mark.slow
def test_the_bias_wander_is_not_taken_for_an_effect_over_twenty_clean_sessions():
    """The false-alarm target (1 %) under realistic noise: a search that treated the step means as
    independent names a bias_drift or a jump in most of these sessions and calls the gap open."""
    spurious = gap_open = 0
    for seed in range(200, 220):
        d, _ = run(tumble(), seed)
        spurious += any(e.name != "bias_tempco" for e in d.effects)
        gap_open += not d.gap_closed
    assert spurious <= 1 and gap_open <= 1, (spurious, gap_open)


def test_an_effect_at_its_reported_minimum_detectable_magnitude_is_named_about_80_percent_of_the_time():
    mdm = np.array(run(legs(), 500)[0].observability["thermal_hysteresis"]["mdm"], float)
    value = mdm * np.array([1.0, 0.0, 0.0])  # on x alone: the MDM is per parameter, the others zero
    named = sum("thermal_hysteresis" in [e.name for e in run(legs(), 600 + s, thermal_hysteresis_g=value)[0].effects]
                for s in range(40))
    assert 0.6 * 40 <= named <= 0.97 * 40, named
