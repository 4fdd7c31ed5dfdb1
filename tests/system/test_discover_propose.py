"""``rig discover SESSION --propose OUT.yaml``: the experiment that tells aliases apart (issue 27 item 3).

A thermal calibration with a heating leg (30, 36, 42 C) then a cooling leg (38, 32 C), six faces at each,
runs on the simulated rig (virtual time, dlpf noise) with a hidden thermal hysteresis. On that design a
heating/cooling offset and a bias step at the leg switch are the same columns: ``rig discover`` names
the hysteresis and lists the jump as its alias. ``--propose`` writes the procedure with the set-points
that separate them; run on the same rig, its session names the hysteresis with no alias left.
"""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from conftest import PROCEDURES, RIGS
from cli_run import rig_in_process as _rig

FACES = ["+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up"]


def _procedure(tmp: Path) -> Path:
    steps = []
    for target in (30.0, 36.0, 42.0, 38.0, 32.0):
        steps.append({"temperature": {"target_c": target, "tolerance_c": 0.3, "hold_s": 60, "timeout_s": 3600,
                                      "mode": "wait"}})
        steps += [{"pose": p} for p in FACES]
    doc = {"format": "rig-procedure/1", "name": "heat_then_cool",
           "description": "Six faces on a heating leg (30, 36, 42 C) then a cooling leg (38, 32 C).",
           "sensor": {"model": "MPU-9150", "accel_range_g": 4, "sample_rate_hz": 100}, "dwell": {"seconds": 10},
           "steps": steps}
    path = tmp / "heat_then_cool.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _run(tmp: Path, procedure: Path, seed: int, name: str, effects=None) -> Path:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, noise="dlpf", effects={"thermal_hysteresis": 1.5e-3} if effects is None else effects)
    rig = tmp / "hysteresis.yaml"
    rig.write_text(yaml.safe_dump(doc))
    code, _, err = _rig("run", procedure, "--rig", rig, "--out", tmp / name, "--seed", seed, "--quiet")
    assert code == 0, err
    return next((tmp / name).iterdir())


def test_the_proposed_procedure_separates_hysteresis_from_a_jump_at_the_leg_switch(tmp_path):
    session = _run(tmp_path, _procedure(tmp_path), 5, "first")
    out = tmp_path / "separate.yaml"
    code, text, err = _rig("discover", session, "--json", "--propose", out)
    assert code == 0, err
    doc = json.loads(text)
    assert [e["name"] for e in doc["effects"]] == ["bias_tempco", "thermal_hysteresis"]
    assert ["thermal_hysteresis", "bias_jump"] in doc["aliases"]
    (power,) = doc["proposal_power"]
    assert power["alias"] == "bias_jump" and power["power"] >= 0.9 > power["power_before"], power
    proposed = yaml.safe_load(out.read_text())
    assert len(proposed["steps"]) == 35 + 7 * len(power["setpoints_c"])  # the session's steps, then the blocks
    assert "predicted power" in proposed["description"]

    second = _run(tmp_path, out, 6, "second")
    code, text, err = _rig("discover", second, "--json")
    again = json.loads(text)
    assert [e["name"] for e in again["effects"]] == ["bias_tempco", "thermal_hysteresis"], again["effects"]
    assert not any("bias_jump" in g for g in again["aliases"]), again["aliases"]


def test_without_aliases_nothing_is_proposed(tmp_path):
    session = _run(tmp_path, PROCEDURES / "six_position.yaml", 5, "clean", effects={})
    out = tmp_path / "separate.yaml"
    code, text, _ = _rig("discover", session, "--json", "--propose", out)
    assert code == 0 and not out.exists()
    assert json.loads(text)["proposal"] is None
