"""The discrepancy search at the step level: aliases, unobservables, and the effect library's
equations against the simulator's error model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from calib.accel.inputs import StepMeans
from calib.discovery.search import StepContext, discover
from calib.discovery.effects import LIBRARY, EffectInputs, effect_counts, heating_state, validate_effect
from drivers.sensors.sim.error_model import AccelErrorModel, HysteresisState

LSB = 8192.0
FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _steps(f, temp, t, out_g, sem_g=1e-4, seed=0):
    rng = np.random.default_rng(seed)
    k = len(f)
    counts = (out_g + rng.normal(0, sem_g, out_g.shape)) * LSB
    return StepMeans(names=tuple(f"s{i}" for i in range(k)), f_nominal_g=f, mean_counts=counts,
                     sem_counts=np.full((k, 3), sem_g * LSB), n_samples=np.full(k, 500), temp_c=temp, t_s=t,
                     lsb_per_g=LSB)


def test_effects_that_the_data_cannot_tell_apart_are_reported_as_aliases():
    # six faces repeated four times while the temperature rises steadily with time: a bias linear
    # in temperature and a bias linear in time predict the same thing
    f = np.tile(FACES, (4, 1))
    t = np.arange(len(f)) * 60.0
    temp = 20.0 + t / 100.0
    m = AccelErrorModel(bias_tempco_g_per_c=[5e-4, -3e-4, 4e-4])
    out = m.output_g(f, temp, t, np.zeros(len(f)))
    d = discover(_steps(f, temp, t, out), StepContext())
    assert d.effects and d.effects[0].name in ("bias_tempco", "bias_drift")
    assert any({"bias_tempco", "bias_drift"} <= set(g) for g in d.aliases), d.aliases


def test_terms_that_are_zero_at_every_pose_are_unobservable_and_never_named():
    f = FACES
    t = np.arange(6) * 30.0
    m = AccelErrorModel(cross_axis_nonlinearity=np.full((3, 3), 5e-3).tolist())
    out = m.output_g(f, np.full(6, 25.0), t, np.zeros(6))
    d = discover(_steps(f, np.full(6, 25.0), t, out), StepContext())
    assert "cross_axis_nonlinearity" in d.unobservable
    assert d.effects == []


#: a value of each effect the simulator injects through its error model, shaped as the effect's field
SIM_VALUES = {
    "bias_tempco": [1e-3, -2e-3, 3e-3],
    "bias_tempco_quadratic": [1e-5, -2e-5, 3e-5],
    "scale_tempco": [1e-4, -2e-4, 3e-4],
    "scale_nonlinearity": [1e-3, -2e-3, 3e-3],
    "cross_axis_nonlinearity": [[1e-3, 2e-3, 3e-3], [4e-3, 5e-3, 6e-3], [7e-3, 8e-3, 9e-3]],
    "bias_drift": [1e-6, -2e-6, 3e-6],
    "thermal_hysteresis": [1e-3, -2e-3, 3e-3],
    "bias_tempco_cubic": [1e-7, -2e-7, 3e-7],
    "thermal_gradient": [0.05, -0.04, 0.05],
    "bias_jump": [2e-3, -1e-3, 5e-4],
}
JUMP_T_S = 1500.0


def test_every_effect_with_a_simulator_field_has_its_equation_checked():
    assert set(SIM_VALUES) == {n for n, e in LIBRARY.items() if e.sim_field is not None}


@pytest.mark.parametrize("name", list(SIM_VALUES))
def test_each_library_term_is_the_simulators_own_equation(name):
    """The library's term of each effect equals what its simulator field (``Effect.sim_field``) adds to
    the simulator's output, set to the same value."""
    value = SIM_VALUES[name]
    rng = np.random.default_rng(3)
    f = rng.normal(size=(40, 3))
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    temp = rng.uniform(15, 40, 40)
    t = rng.uniform(0, 3000, 40)
    heating = rng.choice([-1.0, 0.0, 1.0], 40)
    rate = rng.uniform(-0.05, 0.05, 40)
    base = AccelErrorModel(matrix=(np.eye(3) * 1.01).tolist(), t_ref_c=25.0, bias_jump_t_s=JUMP_T_S)
    with_effect = dataclasses.replace(base, **{LIBRARY[name].sim_field: value})
    diff = with_effect.output_g(f, temp, t, heating, rate) - base.output_g(f, temp, t, heating, rate)
    x = EffectInputs(f_g=f, temp_c=temp, t_s=t, heating=heating, matrix_g=np.eye(3) * 1.01, t0_c=25.0,
                     temp_rate=rate, t_jump_s=JUMP_T_S)
    got = LIBRARY[name].contribution(np.asarray(value, float).ravel(), x)
    assert np.any(diff) and np.allclose(got, diff, rtol=1e-12, atol=1e-15)


def test_heating_state_follows_the_simulators_hysteresis_rule():
    temps = np.concatenate([np.linspace(27.6, 20, 50), np.full(20, 20.0), np.linspace(20, 35, 50),
                            np.linspace(35, 20, 60)])
    assert np.array_equal(heating_state(temps, 0.5), HysteresisState(0.5).update(temps))


def test_effect_counts_and_validation_of_file_entries():
    e = {"name": "scale_nonlinearity", "unit": "1/g", "axes": ["x", "y", "z"], "estimate": [1e-3, 0, 0],
         "sigma": [1e-5, 1e-5, 1e-5]}
    assert validate_effect(e) is None
    out = effect_counts([e], np.array([[1.0, 0, 0], [0.5, 0, 0]]), None, None, LSB)
    assert np.allclose(out[:, 0], [1e-3 * LSB, 0.25e-3 * LSB])
    assert "unit" in validate_effect(dict(e, unit="g"))
    assert "unknown effect" in validate_effect(dict(e, name="gremlins"))
    with pytest.raises(Exception, match="temp_c"):
        effect_counts([dict(e, name="bias_tempco", unit="g/C", t0_c=25.0)], np.zeros((1, 3)), None, None, LSB)
