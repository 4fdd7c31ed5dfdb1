"""Thermal calibration without hold points: procedures/thermal_ramp.yaml from the CLI on the simulated rig.

The chamber ramps up and down while the six faces are cycled; the calibration file carries the bias tempco,
the thermal-gradient term and the scale tempco, each with its sigma; an abort mid-ramp resumes; bad ramp
values are refused with one line, exit 2.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main
from rig.execution.operator import SilentOperator
from rig.execution.context import RunAborted
from rig.session import load_session
from rig.workflow.run import run_procedure

from conftest import PROCEDURES, RIGS

SHIPPED = PROCEDURES / "thermal_ramp.yaml"


def short_ramp(tmp_path, **changes) -> str:
    """The shipped procedure on a shorter range with a shorter dwell (the same steps, a test's run time)."""
    text = SHIPPED.read_text()
    for old, new in {"dwell: {seconds: 10}": "dwell: {seconds: 3}", "to_c: 52.6": "to_c: 33.6",
                     "rate_c_per_min: 4}": "rate_c_per_min: 3}", **changes}.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "thermal_ramp.yaml"
    path.write_text(text)
    return str(path)


def virtual_rig(tmp_path) -> str:
    path = tmp_path / "rig.yaml"
    path.write_text((RIGS / "sim.yaml").read_text().replace("time_scale: 10", "time_scale: 0"))
    return str(path)


def _duration_s(text: str) -> float:
    """``2 min``, ``1 h 05 min``, ``40 s`` ... as seconds."""
    units = {"h": 3600.0, "min": 60.0, "s": 1.0}
    return sum(float(n) * units[u] for n, u in re.findall(r"(\d+(?:\.\d+)?)\s*(h|min|s)\b", text))


def only_session(root):
    dirs = [d for d in root.iterdir() if d.is_dir()]
    assert len(dirs) == 1
    return dirs[0]


def test_the_ramp_runs_from_the_cli_and_the_calibration_has_the_thermal_terms_with_sigmas(tmp_path, capsys):
    assert main(["run", short_ramp(tmp_path), "--rig", virtual_rig(tmp_path), "--out", str(tmp_path / "s"),
                 "--seed", "4"]) == 0
    progress = capsys.readouterr().err
    assert "(ramp 1 to 33.6 C: +" in progress and "C/min, 5/" in progress  # the progress shows the ramp
    d = only_session(tmp_path / "s")
    session = load_session(d)
    # the planned rig time counts the ramps' captures, not a temperature hold per ramp start (the first
    # step, counted from its own target, is its hold: 0 s here)
    planned_s = _duration_s(re.search(r"planned: \d+ steps, about (.+) of rig time", progress).group(1))
    actual_s = max(s.stats.t_end_s for s in session.info.steps if s.stats is not None and s.stats.t_end_s)
    assert 0.8 < planned_s / actual_s < 1.25, (planned_s, actual_s)
    captures = [s for s in session.info.steps if s.kind == "static"]
    assert captures and all(s.status == "complete" and s.stats.ramp["temp_rate_c_per_min"] for s in captures)
    rates = np.array([s.stats.ramp["temp_rate_c_per_min"] for s in captures])
    assert rates.max() > 1.0 and rates.min() < -1.0  # captured on the move, up and down
    cal = calfile.read(d / "calibration.yaml").accelerometer
    assert cal.temperature is not None and cal.temperature.order == 1
    assert all(s > 0 for s in np.ravel(cal.sigma["temperature"]["coefficients"]))
    effects = {e["name"]: e for e in cal.effects}
    assert set(effects) == {"thermal_gradient", "scale_tempco"}
    assert all(s > 0 for s in effects["thermal_gradient"]["sigma"])
    truth = yaml.safe_load((d / "sim_truth.yaml").read_text())["accelerometer"]
    z = (np.asarray(cal.temperature.coefficients)[:, 0] - np.asarray(truth["bias_tempco_g_per_c"]) * cal.lsb_per_g) \
        / np.asarray(cal.sigma["temperature"]["coefficients"])[:, 0]
    assert np.all(np.abs(z) < 4), z
    # the recording replays to the identical calibration (the dwell is fixed; the chamber's ramp is re-enacted)
    assert main(["replay", str(d), "--out", str(tmp_path / "r")]) == 0
    again = calfile.read(only_session(tmp_path / "r") / "calibration.yaml").accelerometer
    assert again.temperature.coefficients.tolist() == cal.temperature.coefficients.tolist()
    assert again.effects == cal.effects


class CtrlCAfter:
    """A technician who presses Ctrl-C once the run has captured ``n`` poses of the ramp."""

    def __init__(self, n: int) -> None:
        self.n, self.inner = n, SilentOperator()

    def progress(self, p) -> None:
        if f", {self.n}/" in p.name:
            raise KeyboardInterrupt

    def __getattr__(self, name):
        return getattr(self.inner, name)


def test_an_abort_mid_ramp_resumes_from_the_ramp_and_solves(tmp_path, capsys):
    with pytest.raises(RunAborted):
        run_procedure(short_ramp(tmp_path), rig_spec=virtual_rig(tmp_path), out_dir=tmp_path / "s", seed=6,
                      ui=CtrlCAfter(4))
    d = only_session(tmp_path / "s")
    before = yaml.safe_load((d / "session.yaml").read_text())
    assert before["status"] == "aborted"
    done = [s for s in before["steps"] if s["status"] == "complete"]
    assert len(done) == 2 + 4  # the hold, the ramp's start, four captures
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    session = load_session(d)
    assert session.info.status == "complete" and all(s.status == "complete" for s in session.info.steps)
    events = [yaml.safe_load(line) for line in (d / "events.jsonl").read_text().splitlines()]
    restored = [e for e in events if e["kind"] == "temperature" and e.get("restored")]
    assert len(restored) == 1  # the chamber was brought back to where the ramp stopped ...
    last_c = before["steps"][len(done) - 1]["stats"]["temp_c"]
    assert abs(restored[0]["temp_c"] - last_c) < 0.5
    ramps = [e for e in events if e["kind"] == "chamber" and "ramp_to_c" in e]
    assert len(ramps) == 3 and ramps[1]["ramp_to_c"] == 33.6  # ... and ramped on to 33.6 C, then down
    resumed = [s for s in session.info.steps if s.kind == "static"][4:]
    rates = [s.stats.ramp["temp_rate_c_per_min"] for s in resumed[:3]]
    assert all(r > 0.05 for r in rates) and rates == sorted(rates)  # heating again, the sensor getting up to speed
    cal = calfile.read(d / "calibration.yaml").accelerometer
    assert {e["name"] for e in cal.effects} == {"thermal_gradient", "scale_tempco"}


class CtrlCAtTheEndOfTheFirstLeg(CtrlCAfter):
    """A technician who presses Ctrl-C as the first leg's last capture is recorded."""

    def __init__(self) -> None:
        super().__init__(-1)

    def info(self, message: str) -> None:
        if message.startswith("ramp 1 "):
            raise KeyboardInterrupt


def test_a_resume_between_two_legs_holds_the_first_leg_s_end_then_ramps_the_second(tmp_path):
    with pytest.raises(RunAborted):
        run_procedure(short_ramp(tmp_path), rig_spec=virtual_rig(tmp_path), out_dir=tmp_path / "s", seed=7,
                      ui=CtrlCAtTheEndOfTheFirstLeg())
    d = only_session(tmp_path / "s")
    steps = yaml.safe_load((d / "session.yaml").read_text())["steps"]
    first_pending = next(s for s in steps if s["status"] == "pending")
    assert first_pending["kind"] == "thermal" and first_pending["ramp"]["leg"] == 2
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    session = load_session(d)
    events = [yaml.safe_load(line) for line in (d / "events.jsonl").read_text().splitlines()]
    restored = [e for e in events if e["kind"] == "temperature" and e.get("restored")]
    assert len(restored) == 1 and abs(restored[0]["temp_c"] - 33.6) < 0.5  # held the first leg's end ...
    second = [s for s in session.info.steps if s.kind == "static" and s.ramp["leg"] == 2]
    assert np.median([s.stats.ramp["temp_rate_c_per_min"] for s in second]) < -1.0  # ... then ramped down


@pytest.mark.parametrize("ramp, key, expected", [
    ("{to_c: 52.6, rate_c_per_min: 0}", "steps[1] (step 2).ramp.rate_c_per_min", "expected a number > 0, got 0"),
    ("{to_c: 52.6, rate_c_per_min: -2}", "steps[1] (step 2).ramp.rate_c_per_min", "expected a number > 0, got -2"),
    ("{to_c: 52.6, rate_c_per_min: 50}", "steps[1] (step 2).ramp.rate_c_per_min", "expected <= 20, got 50"),
    ("{to_c: 52.6, rate_c_per_min: fast}", "steps[1] (step 2).ramp.rate_c_per_min", "expected a number, got 'fast'"),
    ("{to_c: 200, rate_c_per_min: 2}", "steps[1] (step 2).ramp.to_c", "expected <= 85, got 200"),
    ("{rate_c_per_min: 2}", "steps[1] (step 2).ramp.to_c", "missing required field"),
    ("{to_c: 52.6, rate_c_per_min: 2, cycles: 0}", "steps[1] (step 2).ramp.cycles", "expected a number > 0, got 0"),
    ("{to_c: 52.6, rate_c_per_min: 2, speed: 3}", "steps[1] (step 2).ramp.speed", "unknown key (allowed: cycles, from_c, "
                                                                        "move_settle_s, rate_c_per_min, to_c)"),
    ("{to_c: 27.6, rate_c_per_min: 2}", "steps[1] (step 2).ramp.to_c", "leaves nothing to ramp"),
])
def test_bad_ramp_values_are_refused_with_one_line(tmp_path, capsys, ramp, key, expected):
    text = SHIPPED.read_text().replace("  - ramp: {to_c: 52.6, rate_c_per_min: 4}", f"  - ramp: {ramp}")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    line = text.splitlines().index(f"  - ramp: {ramp}") + 1
    assert main(["run", str(path), "--rig", virtual_rig(tmp_path), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"rig run: {path}:{line}: {key}: ") and expected in err[0], err
    assert not (tmp_path / "s").exists()  # refused before anything was recorded


@pytest.mark.parametrize("steps, key, expected", [
    ("  - ramp: {to_c: 52.6, rate_c_per_min: 2}\n    steps: [{pose: '+Z up'}]\n",
     "steps[0] (step 1).ramp", "a ramp needs a temperature to start from"),
    ("  - temperature: {target_c: 27.6}\n  - ramp: {to_c: 52.6, rate_c_per_min: 2}\n"
     "    steps: [{pose: '+Z up'}, {prompt: 'hello'}]\n", "steps[1] (step 2).steps[1]", "a ramp cycles pose steps"),
    ("  - {pose: '+Z up', name: ''}\n", "steps[0] (step 1).name", "expected a non-empty name, got ''"),
    ("  - {pose: '+Z up', name: '   '}\n", "steps[0] (step 1).name", "expected a non-empty name, got '   '"),
    ("  - temperature: {target_c: 27.6}\n  - ramp: {to_c: 52.6, rate_c_per_min: 2}\n"
     "    steps: [{pose: '+Z up'}, {pose: '-Z up'}]\norder: fastest\n", "order", "would regroup the poses"),
])
def test_ramps_without_a_start_or_with_other_steps_and_blank_names_are_refused(tmp_path, capsys, steps, key,
                                                                                 expected):
    path = tmp_path / "bad.yaml"
    path.write_text("format: rig-procedure/1\nname: bad\nsteps:\n" + steps)
    assert main(["run", str(path), "--rig", virtual_rig(tmp_path), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f": {key}: " in err[0] and expected in err[0], err


def test_the_twin_of_a_ramp_session_re_simulates_its_chamber_and_agrees_with_it(tmp_path, capsys):
    """The loop of docs/twin.md on a ramp: the twin's chamber (fitted to the set-points and ramps in the
    session's events) reproduces the measured temperatures, so the re-simulated session agrees step by step."""
    rig = virtual_rig(tmp_path)
    assert main(["run", short_ramp(tmp_path), "--rig", rig, "--out", str(tmp_path / "a"), "--seed", "3",
                 "--quiet"]) == 0
    measured = only_session(tmp_path / "a")
    capsys.readouterr()
    assert main(["discover", str(measured), "--json", "--twin", str(tmp_path / "twin.yaml")]) == 0
    doc = json.loads(capsys.readouterr().out)
    chamber = yaml.safe_load((tmp_path / "twin.yaml").read_text())["sim"]["chamber"]
    assert chamber["tau_s"] == pytest.approx(120.0, rel=0.02)  # rigs/sim.yaml's chamber
    assert "chamber model fits" not in doc["twin_notes"]
    seed = doc["twin_run"].split("--seed")[1].split()[0]
    assert main(["run", doc["twin_procedure"], "--rig", doc["twin"], "--out", str(tmp_path / "b"), "--seed", seed,
                 "--quiet"]) == 0
    capsys.readouterr()
    main(["compare", str(measured), str(only_session(tmp_path / "b")), "--json"])
    cmp = json.loads(capsys.readouterr().out)
    a, b = load_session(measured), load_session(only_session(tmp_path / "b"))
    ta = [np.mean(a.step_samples(i)["temp_c"]) for i in a.static_step_indices()]
    tb = [np.mean(b.step_samples(i)["temp_c"]) for i in b.static_step_indices()]
    assert np.max(np.abs(np.subtract(ta, tb))) < 0.05  # C: the same temperatures at the same steps
    assert cmp["agree"], cmp
