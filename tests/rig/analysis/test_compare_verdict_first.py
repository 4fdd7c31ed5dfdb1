"""`rig compare` begins with what a technician can act on (issue 33 item 3).

Sessions are `rig run`s of six_position.yaml on the simulated rig in virtual time: the same seed is the same
simulated unit (and the same noise draws), another seed another unit; a rig file hiding a bias jump at 45 s
makes the same unit change mid-run. The statistics come with --details and always in --json.
"""

from __future__ import annotations

import hashlib
import json

import pytest
import yaml

from rig.analysis.same_unit import units_of
from rig.cli import main

from conftest import PROCEDURES, RIGS


def _run(out, seed: int, rig=None):
    args = ["run", str(PROCEDURES / "six_position.yaml"), "--seed", str(seed), "--time-scale", "0", "--out", str(out),
            "--quiet"] + (["--rig", str(rig)] if rig else [])
    assert main(args) == 0
    (s,) = [p for p in out.iterdir() if p.is_dir()]
    return s


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cmp")
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["effects"] = {"bias_jump": [3e-3, 0.0, 0.0], "bias_jump_t_s": 45.0}  # 3 mg on x at 45 s
    jumped = tmp / "jump-rig.yaml"
    jumped.write_text(yaml.safe_dump(doc))
    doc["sim"]["effects"] = {"scale_nonlinearity": 2e-3}  # 2 mg per g^2 on every axis: on the loaded axes only
    scaled = tmp / "scale-rig.yaml"
    scaled.write_text(yaml.safe_dump(doc))
    return {"a3": _run(tmp / "a3", 3), "b3": _run(tmp / "b3", 3), "c7": _run(tmp / "c7", 7),
            "jump3": _run(tmp / "j3", 3, jumped), "scale3": _run(tmp / "s3", 3, scaled)}


def _compare(capsys, a, b, *extra) -> list[str]:
    capsys.readouterr()
    assert main(["compare", str(a), str(b), *extra]) == 0
    return capsys.readouterr().out.splitlines()


def test_two_different_units_are_said_first_and_no_shock_is_suggested(sessions, capsys):
    lines = _compare(capsys, sessions["a3"], sessions["c7"])
    assert lines[0].startswith("These are two different units (MPU-9150@0x68#0x68/sim-seed-3 vs "
                               "MPU-9150@0x68#0x68/sim-seed-7; ")
    assert "nothing to compare" in lines[0]
    text = "\n".join(lines)
    assert "shock" not in text and "step in time" not in text and "chi2" not in text  # statistics: --details
    assert len(lines) <= 3
    details = "\n".join(_compare(capsys, sessions["a3"], sessions["c7"], "--details"))
    assert details.startswith(lines[0]) and "chi2 " in details and "look for" not in details
    doc = json.loads("\n".join(_compare(capsys, sessions["a3"], sessions["c7"], "--json")))
    assert doc["units"]["different"] and doc["headline"][0] == lines[0] and "chi2" in doc and doc["steps"]


def test_the_same_unit_changed_mid_run_says_where_and_what_to_look_for(sessions, capsys):
    lines = _compare(capsys, sessions["a3"], sessions["jump3"])
    assert lines[0].startswith("A and B differ beyond the noise at ") and "look for" in lines[0], lines
    assert "step in time near" in lines[0] and lines[1].startswith("Re-run the procedure")
    assert not any("different units" in x for x in lines)
    details = _compare(capsys, sessions["a3"], sessions["jump3"], "--details")
    assert details[:2] == lines[:2] and any(x.startswith("verdict: A and B disagree") for x in details)
    assert any(x.startswith("chi2 ") for x in details)


def test_the_same_unit_twice_agrees_and_nothing_is_to_be_done(sessions, capsys):
    lines = _compare(capsys, sessions["a3"], sessions["b3"])
    assert lines[0] == "A and B agree at the noise level (6 steps x 3 axes): nothing to act on."
    doc = json.loads("\n".join(_compare(capsys, sessions["a3"], sessions["b3"], "--json")))
    assert doc["units"]["different"] is False and doc["agree"] is True


def _manifest(sid: str, seed=None, serial=None, rig_file=None, model="MPU-9150") -> dict:
    rig = {"sensor": {"model": model, "address": 0x68, "identity": {"identity_value": 0x68},
                      **({"serial": serial} if serial else {})}, "turntable": {"kind": "sim:8smc5-emulator"}}
    if rig_file is not None:
        rig |= {"rig_file": str(rig_file), "rig_file_sha256": hashlib.sha256(rig_file.read_bytes()).hexdigest()}
    return {"id": sid, "rig": rig, **({"seed": seed} if seed is not None else {})}


def test_the_evidence_for_two_units(tmp_path):
    twin = tmp_path / "t.yaml"
    twin.write_text("# Digital twin\nformat: rig-file/1\nname: twin-thermal-1\nkind: sim\n")
    assert units_of(_manifest("thermal-1", 5), _manifest("x", 6, rig_file=twin)).twin.startswith(
        "B was recorded on the digital twin of A")
    recorded = _manifest("x", 6, rig_file=twin)
    assert not units_of(_manifest("thermal-1", 5), recorded).different
    twin.write_text(twin.read_text() + "# edited since\n")  # not the rig file the session recorded
    assert units_of(_manifest("thermal-1", 5), recorded).different
    assert units_of(_manifest("a", serial="SN1"), _manifest("b", serial="SN2")).why == "serials SN1 and SN2"
    assert not units_of(_manifest("a", serial="SN1"), _manifest("b", serial="SN1")).different
    assert not units_of(_manifest("a", serial="SN1"), _manifest("b")).different  # cannot tell: nothing said
    assert units_of(_manifest("a"), _manifest("b", model="ADXL345")).why == "sensor models MPU-9150 and ADXL345"


def test_a_difference_on_the_loaded_axes_only_is_called_scale_like_not_a_shock(sessions, capsys):
    """The walkthrough's case: a scale change was headlined 'step in time near 47 s: look for a sudden change (a shock
    ...)' while the statistics said the difference sat on the axes carrying gravity only."""
    lines = _compare(capsys, sessions["a3"], sessions["scale3"])
    assert "scale-like" in lines[0] and "shock" not in lines[0] and "step in time" not in lines[0], lines
    assert lines[-1].startswith(f"A is {sessions['a3']}, B is {sessions['scale3']}; the statistics behind this: "
                                f"rig compare {sessions['a3']} {sessions['scale3']} --details")
    details = "\n".join(_compare(capsys, sessions["a3"], sessions["scale3"], "--details"))
    assert "shock" not in details and "scale-like" in details, details  # the statistics say what the headline says
    jump = _compare(capsys, sessions["a3"], sessions["jump3"])  # a bias jump is on every axis alike: not scale-like
    assert "scale-like" not in jump[0]
