"""The thermal-ramp solve: step means captured while the chamber ramps, with each step's mean temperature
and temperature rate, give the bias tempco, the thermal-gradient term and the scale tempco with honest
sigmas (docs/methods.md, "Thermal ramp")."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from calib.file import calibration as calfile
from calib.accel import solve
from calib.accel.inputs import StepMeans
from calib.numerics.stability import BiasStability

LSB = 8192.0
FACES = np.array([[0, 0, 1], [1, 0, 0], [0, 0, -1], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)
TAU_S = 120.0  # the sensor follows the chamber with this time constant
DWELL_S, MOVE_S, DT_S = 10.0, 6.0, 0.5


@dataclasses.dataclass
class Hidden:
    """A hidden sensor: a = M f + lsb (b + c (T - 25) + g dT/dt) + s (T - 25) M f, counts."""

    matrix: np.ndarray = dataclasses.field(default_factory=lambda: LSB * np.array(
        [[0.994, 0.0165, -0.0012], [0.0, 1.004, -0.0018], [0.0, 0.0, 0.998]]))
    bias_g: np.ndarray = dataclasses.field(default_factory=lambda: np.array([0.04, -0.05, 0.01]))
    tempco_g_per_c: np.ndarray = dataclasses.field(default_factory=lambda: np.array([-6e-4, 1e-4, 4e-4]))
    gradient_g_per_c_per_s: np.ndarray = dataclasses.field(default_factory=lambda: np.array([0.01, -0.008, 0.012]))
    scale_tempco_per_c: np.ndarray = dataclasses.field(default_factory=lambda: np.array([1e-4, -5e-5, 0.0]))


def sensor_temperature(legs, start_c: float = 25.0):
    """Times (s) and the sensor's temperature (C) while the chamber's set-point ramps through ``legs``
    [(to_c, rate C/min), ...], the sensor following as a first-order lag (Euler at 0.5 s)."""
    t, setpoint, temp = [0.0], start_c, start_c
    temps = [temp]
    for to_c, rate in legs:
        step = np.sign(to_c - setpoint) * rate / 60.0 * DT_S
        while abs(to_c - setpoint) > 1e-9:
            setpoint = to_c if abs(to_c - setpoint) <= abs(step) else setpoint + step
            temp += (setpoint - temp) * DT_S / TAU_S
            t.append(t[-1] + DT_S)
            temps.append(temp)
    return np.array(t), np.array(temps)


def ramp_step_means(hidden: Hidden, legs, rng, sem_counts: float = 0.6, walk_g_per_rts: float = 0.0) -> StepMeans:
    """The six faces cycled through the ramp: a 10 s capture every 16 s, its mean temperature and the
    least-squares slope of the temperature over it; step means with white noise of ``sem_counts`` plus a
    bias random walk of ``walk_g_per_rts`` (then the steps carry that bias stability)."""
    t, temp = sensor_temperature(legs)
    starts = np.arange(0.0, t[-1] - DWELL_S, DWELL_S + MOVE_S)
    f = FACES[np.arange(len(starts)) % 6]
    inside = [(t >= s) & (t <= s + DWELL_S) for s in starts]
    temp_c = np.array([temp[m].mean() for m in inside])
    rate = np.array([np.polyfit(t[m], temp[m], 1)[0] for m in inside])
    d_t = (temp_c - 25.0)[:, None]
    mf = f @ hidden.matrix.T
    walk = np.cumsum(rng.normal(0, walk_g_per_rts * np.sqrt(DWELL_S + MOVE_S), (len(starts), 3)), axis=0)
    counts = (mf * (1 + hidden.scale_tempco_per_c * d_t)
              + LSB * (hidden.bias_g + hidden.tempco_g_per_c * d_t + walk
                       + hidden.gradient_g_per_c_per_s * rate[:, None])
              + rng.normal(0, sem_counts, mf.shape))
    stability = BiasStability(1e-9, walk_g_per_rts, 1.0) if walk_g_per_rts else None
    return StepMeans(names=tuple(f"step {i}" for i in range(len(starts))), f_nominal_g=f, mean_counts=counts,
                     sem_counts=np.full(mf.shape, sem_counts), n_samples=np.full(len(starts), 1000),
                     temp_c=temp_c, t_s=starts + DWELL_S / 2, lsb_per_g=LSB, bias_stability=stability,
                     temp_rate_c_per_s=rate)


#: up 25 -> 55 C at 2 C/min, then down to 40 C at 1 C/min: the rates differ between the legs and correlate
#: with temperature, so a solve without the rate term would mistake the gradient for tempco
LEGS = [(55.0, 2.0), (40.0, 1.0)]


def z_scores(cal, hidden: Hidden) -> dict[str, np.ndarray]:
    """(estimate - truth) / sigma of the bias tempco, the thermal gradient and the scale tempco."""
    c = np.asarray(cal.temperature.coefficients, float)[:, 0]
    sc = np.asarray(cal.sigma["temperature"]["coefficients"], float)[:, 0]
    effects = {e["name"]: e for e in cal.effects}
    grad, scale = effects["thermal_gradient"], effects["scale_tempco"]
    return {"bias_tempco": (c - hidden.tempco_g_per_c * LSB) / sc,
            "thermal_gradient": ((np.asarray(grad["estimate"]) - hidden.gradient_g_per_c_per_s)
                                 / np.asarray(grad["sigma"])),
            "scale_tempco": (np.asarray(scale["estimate"]) - hidden.scale_tempco_per_c) / np.asarray(scale["sigma"])}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_hidden_thermal_coefficients_are_recovered_within_three_sigma(seed):
    hidden = Hidden()
    cal = solve(ramp_step_means(hidden, LEGS, np.random.default_rng(seed)), thermal=1)
    for name, z in z_scores(cal, hidden).items():
        assert np.all(np.abs(z) < 3.0), (name, z)
    sigma_g = np.asarray(next(e for e in cal.effects if e["name"] == "thermal_gradient")["sigma"])
    assert np.all(sigma_g < np.abs(hidden.gradient_g_per_c_per_s) / 5)  # the gradient is measured, not just bounded


def test_with_a_bias_random_walk_the_sigmas_include_the_wander():
    """A bias wander between steps aliases into the thermal terms; the solve's covariance carries it."""
    hidden, z_all = Hidden(), []
    for seed in range(8):
        steps = ramp_step_means(hidden, LEGS, np.random.default_rng(100 + seed), walk_g_per_rts=2e-5)
        z_all.append(np.concatenate(list(z_scores(solve(steps, thermal=1), hidden).values())))
    z = np.array(z_all)
    assert np.all(np.abs(z) < 4.0) and np.sqrt(np.mean(z**2)) < 1.5, z


def test_dropping_the_rate_term_biases_the_tempco():
    """Why the rate term: the same steps solved without each step's temperature rate put the thermal
    gradient into the bias tempco, more than 3 sigma off the truth."""
    hidden = Hidden()
    steps = ramp_step_means(hidden, LEGS, np.random.default_rng(1))
    without = solve(dataclasses.replace(steps, temp_rate_c_per_s=None), thermal=1)
    c = np.asarray(without.temperature.coefficients, float)[:, 0]
    sc = np.asarray(without.sigma["temperature"]["coefficients"], float)[:, 0]
    assert np.max(np.abs(c - hidden.tempco_g_per_c * LSB) / sc) > 3.0
    assert not without.effects


def test_the_thermal_terms_are_written_and_read_back_with_their_sigmas(tmp_path):
    cal = solve(ramp_step_means(Hidden(), LEGS, np.random.default_rng(5)), thermal=1)
    path = tmp_path / "calibration.yaml"
    calfile.write(path, calfile.CalibrationFile(created="2026-01-01T00:00:00+00:00",
                                                software={"name": "t", "version": "0"}, session=None,
                                                sensor={"model": "MPU-9150"}, accelerometer=cal))
    back = calfile.read(path).accelerometer
    assert {e["name"] for e in back.effects} == {"thermal_gradient", "scale_tempco"}
    assert back.sigma["temperature"]["coefficients"] == cal.sigma["temperature"]["coefficients"]
    grad = next(e for e in back.effects if e["name"] == "thermal_gradient")
    assert all(s > 0 for s in grad["sigma"]) and grad["unit"] == "g/(C/s)"


def test_a_single_ramp_leg_cannot_tell_the_gradient_from_the_bias():
    """One leg at one rate: dT/dt is nearly constant, so the gradient is all but collinear with the bias and
    its sigma says so (it needs a second leg at another rate, e.g. the ramp back down)."""
    hidden = Hidden()
    cal = solve(ramp_step_means(hidden, [(55.0, 2.0)], np.random.default_rng(2)), thermal=1)
    sigma_g = np.asarray(next(e for e in cal.effects if e["name"] == "thermal_gradient")["sigma"])
    both = solve(ramp_step_means(hidden, LEGS, np.random.default_rng(2)), thermal=1)
    sigma_both = np.asarray(next(e for e in both.effects if e["name"] == "thermal_gradient")["sigma"])
    assert np.all(sigma_g > 3 * sigma_both)
