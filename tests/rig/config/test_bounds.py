"""Absurd values get bounds at validation, each refused with one located line."""

from __future__ import annotations

import pytest

from rig.config.procedure import load_procedure_text
from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError

from conftest import RIGS

GOOD = """format: rig-procedure/1
name: p
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 2}
settle: {window_s: 0.5, threshold_g: 0.01, timeout_s: 30}
steps:
  - pose: "+Z up"
  - pose: "-Z up"
"""
RIG = (RIGS / "sim.yaml").read_text()


def _proc_err(text):
    with pytest.raises(RigInputError) as exc:
        load_procedure_text(text, "p.yaml")
    assert "\n" not in str(exc.value)
    return str(exc.value)


def _rig_err(text):
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(text, "r.yaml")
    assert "\n" not in str(exc.value)
    return str(exc.value)


def test_the_good_procedure_loads():
    assert len(load_procedure_text(GOOD, "p.yaml").steps) == 2


@pytest.mark.parametrize("old,new,expect", [
    ("seconds: 2", "samples: 1000000000000", "p.yaml:4: dwell.samples: expected <= 86400000"),
    ("timeout_s: 30", "timeout_s: 1.0e+300", "p.yaml:5: settle.timeout_s: expected <= 86400"),
    ("timeout_s: 30", "timeout_s: 30, min_s: 1.0e+300", "p.yaml:5: settle.min_s: expected <= 3600"),
    ("threshold_g: 0.01", "threshold_g: 1.0e+300", "p.yaml:5: settle.threshold_g: expected <= 16"),
    ("window_s: 0.5", "window_s: 60", "p.yaml:5: settle: window_s 60 s is longer than timeout_s 30 s"),
    ('  - pose: "-Z up"\n', '  - {pose: "-Z up", settle: {window_s: 40}}\n',
     "p.yaml:8: steps[1] (step 2).settle: window_s 40 s is longer than timeout_s 30 s"),
    ('  - pose: "-Z up"\n', "  - temperature: {target_c: 30, hold_s: 7200, timeout_s: 3600}\n",
     "p.yaml:8: steps[1] (step 2).temperature.hold_s: hold_s 7200 s is longer than timeout_s 3600 s"),
    ('  - pose: "-Z up"\n', "  - temperature: {target_c: 30, hold_s: 5000}\n", "is longer than timeout_s 3600 s"),
    ("seconds: 2", "seconds: 0.01", "p.yaml:4: dwell: a dwell of 0.01 s at 100 Hz gives fewer than 2 samples"),
    ('  - pose: "-Z up"\n', '  - {pose: "-Z up", dwell: {seconds: 0.015}}\n',
     "p.yaml:8: steps[1] (step 2).dwell: a dwell of 0.015 s at 100 Hz gives fewer than 2 samples"),
    ("seconds: 2", "sem_g: 1.0e-5, max_seconds: 0.001", "dwell: a dwell of 0.001 s at 100 Hz gives fewer than 2"),
    ("seconds: 2", "samples: 1", "p.yaml:4: dwell.samples: expected >= 2"),
    ('  - pose: "-Z up"\n', "  - {rate: {axis: a1, rate_deg_s: 10, seconds: 0.001}}\n",
     "p.yaml:8: steps[1] (step 2).rate.seconds: a dwell of 0.001 s at 100 Hz gives fewer than 2 samples"),
    ("seconds: 2", "seconds: .nan", "p.yaml:4: dwell.seconds: expected a number, got nan"),
    ('  - pose: "-Z up"\n', '  - {pose: "-Z up", a1_deg: 1.0e+300}\n', "steps[1] (step 2).a1_deg: expected <= 3600"),
    ('  - pose: "-Z up"\n', "  - {repeat: 1000000000000, steps: [{pose: \"-Z up\"}]}\n",
     "steps[1] (step 2).repeat: expected <= 1000"),
])
def test_absurd_procedure_values_are_refused(old, new, expect):
    assert old in GOOD
    assert expect in _proc_err(GOOD.replace(old, new, 1))


@pytest.mark.parametrize("old,new,expect", [
    ("accel_deg_s2: 40,", "accel_deg_s2: 1.0e+300,", "r.yaml:10: turntable.axes.a1.accel_deg_s2: expected at most 655.35"),
    ("sign: 1,", "sign: 1, home_offset_deg: 1.0e+300,", "r.yaml:10: turntable.axes.a1.home_offset_deg: expected <= 3600"),
    ("cable_wrap_deg: 400,", "cable_wrap_deg: 1.0e+300,", "turntable.axes.a1.cable_wrap_deg: expected <= 1000000"),
    ("time_scale: 10", "time_scale: .nan", "r.yaml:18: sim.time_scale: expected a number, got nan"),
    ("time_scale: 10", "time_scale: -1", "r.yaml:18: sim.time_scale: expected >= 0, got -1"),
    ("tau_s: 120", "tau_s: -5", "r.yaml:19: sim.chamber.tau_s: expected a number > 0, got -5"),
    ("tau_s: 120", "tau_s: .inf", "sim.chamber.tau_s: expected a number, got inf"),
    ("time_scale: 10", "time_scale: 10\n  ringing: {amplitude_g: -0.1}", "r.yaml:19: sim.ringing.amplitude_g: expected >= 0"),
    ("time_scale: 10", "time_scale: 10\n  effects: {bias_drift: .nan}", "r.yaml:19: sim.effects.bias_drift: expected a finite"),
])
def test_absurd_rig_values_are_refused(old, new, expect):
    assert old in RIG
    assert expect in _rig_err(RIG.replace(old, new, 1))


@pytest.mark.parametrize("faults,expect", [
    ("faults:\n  ximc:\n    a2: {crc_corrupt_rate: 1.5}\n", "r.yaml:22: faults.ximc.a2.crc_corrupt_rate: expected <= 1, got 1.5"),
    ("faults:\n  sensor: {oserror_rate: 2}\n", "r.yaml:21: faults.sensor.oserror_rate: expected <= 1, got 2"),
    ("faults:\n  ximc:\n    a1: {drop_rate: -0.1}\n", "faults.ximc.a1.drop_rate: expected >= 0"),
    ("faults:\n  sensor: {oserror_window_s: [5, 1]}\n", "faults.sensor.oserror_window_s: expected [start_s, end_s]"),
    ("faults:\n  ximc:\n    a1: {error_answer: boom}\n", "faults.ximc.a1.error_answer: expected one of errc, errd, errv"),
    ("faults:\n  ximc:\n    a1:\n", "r.yaml:22: faults.ximc.a1: expected a mapping"),
])
def test_fault_rates_and_values_are_bounded(faults, expect):
    assert expect in _rig_err(RIG + faults)


def test_valid_faults_pass_through_as_plain_mappings():
    rig = parse_rig_file(RIG + "faults:\n  ximc:\n    a1: {crc_corrupt_rate: 0.01, seed: 3}\n"
                               "  sensor: {oserror_window_s: [37.0, 37.5]}\n", "r.yaml")
    assert rig.faults == {"ximc": {"a1": {"crc_corrupt_rate": 0.01, "seed": 3}},
                          "sensor": {"oserror_window_s": [37.0, 37.5]}}
