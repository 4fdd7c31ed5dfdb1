"""The pieces of the simulation loop (docs/twin.md) without a rig: the twin's conversion of a calibration
into the simulator's error model, its chamber model and noise bandwidth against the simulator's own,
and the verdict rule of ``rig compare``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from calib.accel.result import AccelCalibration, triangular_matrix
from drivers.clock import VirtualClock
from drivers.sensors.base import SensorSettings
from drivers.sensors.chips import CHIPS
from drivers.sensors.sim.error_model import AccelErrorModel
from rig.analysis import compare as cmp
from rig.analysis import twin
from rig.simulation.settings import AccelOverrides
from rig.simulation.simrig import SimSettings, SimulatedRig
from rig.simulation.world import ChamberConfig, SimChamber

LSB = 8192.0
T0 = 31.5


def _calibration(effects: list, order: int = 2) -> AccelCalibration:
    scale = np.array([8230.0, 8170.0, 8205.0])
    angles = {"alpha_yz": 0.004, "alpha_zy": -0.002, "alpha_zx": 0.003}
    m = triangular_matrix(scale, angles)
    zeros3, zeros33 = [0.0] * 3, np.zeros((3, 3)).tolist()
    return AccelCalibration(
        model="triangular", lsb_per_g=LSB, bias_counts=[-160.0, 270.0, -80.0], scale_counts_per_g=scale.tolist(),
        misalignment=angles, matrix_counts_per_g=m.tolist(),
        temperature={"t0_c": T0, "order": order,
                     "bias_coefficients": [[-1.4, 0.01], [2.0, -0.02], [3.1, 0.005]][:3] if order == 2 else
                     [[-1.4], [2.0], [3.1]]},
        effects=effects,
        sigma={"bias_counts": zeros3, "scale_counts_per_g": zeros3, "matrix_counts_per_g": zeros33},
        fit={"steps": 30, "samples": 3000, "residual_rms_g": 1e-4, "chi2_per_dof": 1.0})


def _effect(name, unit, estimate, **extra):
    return {"name": name, "unit": unit, "axes": [], "estimate": list(estimate), "sigma": [0.0] * len(estimate),
            **extra}


ON_SENSOR = [
    _effect("scale_tempco", "1/C", [2e-4, -1e-4, 1.5e-4], t0_c=T0),
    _effect("scale_nonlinearity", "1/g", [3e-3, 0.0, -2e-3]),
    _effect("cross_axis_nonlinearity", "1/g", [0, 3e-3, 0, 0, 0, -2e-3, 2e-3, 0, 0]),
    _effect("full_misalignment", "rad", [0.0, 0.001, 0.005]),
    _effect("bias_drift", "g/s", [5e-7, -2e-7, 1e-7], t_ref_s=900.0),
    _effect("bias_tempco_cubic", "g/C^3", [1e-6, 0.0, -2e-6], t0_c=T0),
    _effect("bias_jump", "g", [2e-3, -1e-3, 0.0], t_jump_s=1200.0),
]


def _inputs(n=200, seed=3):
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(n, 3))
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    return f, rng.uniform(20, 45, n), rng.uniform(0, 2400, n)


@pytest.mark.parametrize("left_out, atol", [
    ("full_misalignment", 1e-6),  # exact
    ("scale_tempco", 1e-6),  # exact
    (None, 0.2),  # both: the simulator scales the mounting couplings with temperature too (second order)
])
def test_the_twins_error_model_reproduces_the_calibrations_forward_model(left_out, atol):
    cal = _calibration([e for e in ON_SENSOR if e["name"] != left_out])
    errors, tilt, notes = twin.error_model(cal)
    assert tilt == [0.0, 0.0] and notes == []
    AccelOverrides(**errors)  # every key is a field the rig file's schema accepts
    model = AccelErrorModel.from_dict({**AccelErrorModel().to_dict(), **errors})
    f, temp, t = _inputs()
    sim = model.output_g(f, temp, t, np.zeros(len(t))) * LSB
    expected = cal.predict_counts(f, temp_c=temp, t_s=t)
    assert np.max(np.abs(sim - expected)) < atol, "counts"


def test_a_thermal_model_at_another_reference_temperature_is_re_expanded_exactly():
    cal = _calibration([_effect("bias_tempco_quadratic", "g/C^2", [2e-5, 0, -1e-5], t0_c=T0 + 4),
                        _effect("scale_tempco", "1/C", [2e-4, 1e-4, -1e-4], t0_c=T0 - 3)], order=2)
    errors, _, _ = twin.error_model(cal)
    model = AccelErrorModel.from_dict({**AccelErrorModel().to_dict(), **errors})
    f, temp, t = _inputs()
    assert np.allclose(model.output_g(f, temp, t, np.zeros(len(t))) * LSB, cal.predict_counts(f, temp_c=temp, t_s=t),
                       atol=0.02)


def test_hysteresis_tilt_and_undetermined_parameters():
    cal = _calibration([_effect("thermal_hysteresis", "g", [1.5e-3, 0, 0], band_c=0.7),
                        _effect("table_tilt", "deg", [0.1, -0.05]),
                        {**_effect("thermal_gradient", "g/(C/s)", [0.0, 0.0, 0.0], rate_window_s=5.0),
                         "estimate": [0.01, None, 0.0]}])
    errors, tilt, notes = twin.error_model(cal)
    assert errors["thermal_hysteresis_g"] == [1.5e-3, 0, 0] and errors["hysteresis_band_c"] == 0.7
    assert tilt == [0.1, -0.05]
    assert errors["thermal_gradient_g_per_c_per_s"] == [0.01, 0.0, 0.0]
    assert any("thermal_gradient" in n for n in notes)


def test_the_chamber_model_is_the_simulators():
    clock = VirtualClock()
    chamber = SimChamber(clock, ChamberConfig(initial_c=27.6, tau_s=90.0))
    setpoints = []
    for t_set, c_set in ((5.0, 35.0), (400.0, 20.0), (650.0, 41.0)):
        clock.sleep(t_set - clock.now())
        chamber.set_target_c(c_set)
        setpoints.append(twin.ChamberCommand(t_set, c_set))
    t = np.linspace(0.0, 1200.0, 500)
    assert np.allclose(twin.chamber_temps(t, setpoints, 27.6, 90.0), chamber.temp_at(t), atol=1e-9)


def test_the_chamber_model_follows_the_simulators_ramps_from_the_sessions_events():
    """Set-points, a ramp from where the set-point is, a ramp from a stated start, and a set-point that
    cuts a ramp short: the twin's chamber (fed the ``chamber`` events as the runner writes them) is the
    simulator's to 1e-9 C."""
    clock = VirtualClock()
    chamber = SimChamber(clock, ChamberConfig(initial_c=27.6, tau_s=90.0))
    events = []
    for t_set, kind, args in ((5.0, "ramp", (52.6, 4.0, None)), (500.0, "set", 40.0),
                              (700.0, "ramp", (20.0, 3.0, 35.0)), (900.0, "set", 30.0),
                              (1000.0, "ramp", (45.0, 6.0, None))):
        clock.sleep(t_set - clock.now())
        if kind == "set":
            chamber.set_target_c(args)
            events.append({"kind": "chamber", "t_s": t_set, "setpoint_c": args})
        else:
            to_c, rate, from_c = args
            duration = chamber.ramp_to_c(to_c, rate, from_c)
            events.append({"kind": "chamber", "t_s": t_set, "ramp_to_c": to_c, "rate_c_per_min": rate,
                           "from_c": from_c, "duration_s": duration})
    t = np.linspace(0.0, 1600.0, 800)
    commands = twin.chamber_commands(events)
    assert np.allclose(twin.chamber_temps(t, commands, 27.6, 90.0), chamber.temp_at(t), atol=1e-9)


@pytest.mark.parametrize("model, rate", [("MPU-9150", 100.0), ("MPU-9150", 500.0), ("ADXL345", 100.0)])
def test_the_noise_bandwidth_is_what_the_driver_configures_in_the_simulated_chip(model, rate):
    sim = SimulatedRig(SimSettings(time_scale=0), seed=1, sensor_model=model)
    driver = CHIPS[model].driver(sim.bus, sim.sensor_address, clock=sim.clock)
    driver.configure(dataclasses.replace(SensorSettings(), sample_rate_hz=rate))
    sampler = sim.chip.sampler
    assert twin.noise_bandwidth_hz(model, rate) == pytest.approx(min(sampler.bandwidth_hz, sampler.rate_hz / 2))


def test_white_and_filtered_noise_are_told_apart_by_their_variance_inflation():
    # the MPU-9150 at 100 Hz behind its 44 Hz filter: lag-1 correlation 0.063, inflation 1.13 (white: 1)
    assert 1.05 < twin.coloured_threshold(44.0, 100.0) < 1.08
    assert 1.4 < twin.coloured_threshold(184.0, 1000.0) < 1.5  # 1 kHz behind 184 Hz: inflation 1.92
    assert twin.coloured_threshold(100.0, 100.0) == twin.VIF_COLOURED  # no correlation to tell them apart by


def test_the_verdicts_false_alarm_rate_is_at_most_the_stated_one():
    rng = np.random.default_rng(7)
    alarms = 0
    trials = 4000
    for _ in range(trials):
        z = rng.standard_normal((36, 3))
        zc, chi2, p = cmp.judge(z, 0.01)
        alarms += bool(np.any(np.abs(z) > zc) or p < 0.005)
    assert alarms / trials < 0.016  # 0.01 + 3 binomial sigma
    z = rng.standard_normal((36, 3))
    z[5, 2] = 6.0  # one step-axis cell far out is flagged
    zc, _, _ = cmp.judge(z, 0.01)
    assert 3.9 < zc < 4.2 and abs(z[5, 2]) > zc
