"""The verdict (is the gap closed to the noise level?), what remains when it is not, and the new
effects at the step level (thermal_gradient needs steps at different temperature rates)."""

from __future__ import annotations

import numpy as np

from calib.accel.inputs import StepMeans
from calib.discovery.search import StepContext, discover, verdict
from calib.discovery.effects import LIBRARY, effect_counts, temperature_rate
from drivers.sensors.sim.error_model import AccelErrorModel

LSB = 8192.0
DIRS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
                 [1, 1, 0], [1, 0, 1], [0, 1, 1], [-1, 1, 1]], float)
DIRS = DIRS / np.linalg.norm(DIRS, axis=1)[:, None]
TEMPCO = [2e-4, -3e-4, 1e-4]


def _ramp_design(reps=6):
    """Poses repeated while the chamber heats and cools at different rates (steps taken on ramps)."""
    f = np.tile(DIRS, (reps, 1))
    k = len(f)
    t = np.arange(k) * 20.0
    rate = 0.02 * np.sin(2 * np.pi * t / (k * 20.0 / 2.3))  # C/s, heating and cooling ramps
    temp = 25.0 + np.cumsum(rate) * 20.0
    return f, temp, t, rate


def _steps(f, temp, t, out_g, sem_g=1e-4, seed=1):
    rng = np.random.default_rng(seed)
    k = len(f)
    counts = (out_g + rng.normal(0, sem_g, out_g.shape)) * LSB
    return StepMeans(names=tuple(f"s{i % len(DIRS)}" for i in range(k)), f_nominal_g=f, mean_counts=counts,
                     sem_counts=np.full((k, 3), sem_g * LSB), n_samples=np.full(k, 500), temp_c=temp, t_s=t,
                     lsb_per_g=LSB)


def test_the_verdict_is_a_chi_square_test_at_the_false_alarm_level():
    assert verdict(100.0, 100, 0.01)[0]
    assert not verdict(150.0, 100, 0.01)[0]
    assert verdict(0.0, 0, 0.01) == (True, 1.0)


def test_a_thermal_gradient_on_ramps_is_named_within_3_sigma_and_the_gap_closes():
    f, temp, t, rate = _ramp_design()
    truth = [0.05, -0.03, 0.04]  # g per C/s: 1 mg at 0.02 C/s
    m = AccelErrorModel(bias_tempco_g_per_c=TEMPCO, thermal_gradient_g_per_c_per_s=truth)
    out = m.output_g(f, temp, t, np.zeros(len(f)), rate)
    d = discover(_steps(f, temp, t, out), StepContext(temp_rate=rate))
    names = [e.name for e in d.effects]
    assert "thermal_gradient" in names and set(names) <= {"thermal_gradient", "bias_tempco"}, names
    e = next(e for e in d.effects if e.name == "thermal_gradient")
    assert np.all(np.abs(np.array(e.estimate) - truth) < 3 * np.array(e.sigma)), (e.estimate, e.sigma)
    assert d.gap_closed and d.to_json()["gap_closed"] is True
    assert "unexplained" not in d.to_json()


def test_without_step_rates_the_thermal_gradient_is_unobservable():
    f, temp, t, rate = _ramp_design()
    out = AccelErrorModel(bias_tempco_g_per_c=TEMPCO).output_g(f, temp, t, np.zeros(len(f)))
    d = discover(_steps(f, temp, t, out), StepContext())
    assert "thermal_gradient" in d.unobservable
    assert [e.name for e in d.effects] == ["bias_tempco"] and d.gap_closed


def test_a_residual_outside_the_library_leaves_the_gap_open_and_says_where():
    f, temp, t, rate = _ramp_design()
    out = AccelErrorModel(bias_tempco_g_per_c=TEMPCO).output_g(f, temp, t, np.zeros(len(f)))
    out[:, 2] += 1.5e-3 * np.sin(t / 150.0) ** 2 * np.sign(np.sin(t / 97.0))  # nothing in the library
    d = discover(_steps(f, temp, t, out), StepContext(temp_rate=rate), candidates=["bias_tempco"])
    j = d.to_json()
    assert j["format"] == "rig-discover/6" and j["gap_closed"] is False
    assert j["chi2_per_dof_after"] > 1.5 and "chi2_per_dof_before" in j
    u = j["unexplained"]
    assert max(u["by_axis"], key=u["by_axis"].get) == "z"
    assert {"by_pose", "by_temperature", "by_time_block", "structure", "worst_steps"} <= set(u)


def test_apply_honours_the_new_effects():
    n = 2001
    t = np.linspace(0, 200, n)
    temp = 25 + 0.05 * t  # 0.05 C/s
    assert np.allclose(temperature_rate(temp, t, 5.0), 0.05)
    f = np.tile([0.0, 0.0, 1.0], (n, 1))
    eff = [{"name": "thermal_gradient", "unit": "g/(C/s)", "estimate": [0.1, 0, 0], "sigma": [0, 0, 0],
            "rate_window_s": 5.0},
           {"name": "bias_jump", "unit": "g", "estimate": [0, 2e-3, 0], "sigma": [0, 0, 0], "t_jump_s": 100.0},
           {"name": "bias_tempco_cubic", "unit": "g/C^3", "estimate": [0, 0, 1e-6], "sigma": [0, 0, 0],
            "t0_c": 25.0}]
    out = effect_counts(eff, f, temp, t, LSB) / LSB
    assert np.allclose(out[:, 0], 0.005)
    assert np.allclose(out[:, 1], np.where(t >= 100, 2e-3, 0))
    assert np.allclose(out[:, 2], 1e-6 * (temp - 25) ** 3)
    assert {"bias_tempco_cubic", "thermal_gradient", "bias_jump"} <= set(LIBRARY)
