"""A unit's noise profile (rig-noise/1) replaces the family's figures in its calibrations (issue 28 item 3): the
solve weighs the bias wander with the unit's figures and the calibration file says which it used."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from rig.cli import main
from rig.lab.noise_profiles import NoiseProfile, load_profile, profiles_dir, record_profile

PROCEDURES = Path(__file__).resolve().parents[2] / "procedures"
KEY = "MPU-9150@0x68#0x68/sim-seed-9"


def _term(v: float) -> dict:
    return {"value": v, "sigma": 0.1 * v, "ci95": [0.8 * v, 1.2 * v]}


def _profile(b_floor_g: float, k_g: float) -> NoiseProfile:
    axis = {"N": _term(350e-6), "B": _term(b_floor_g), "K": _term(k_g), "tau_floor_s": 300.0, "chi2_dof": 0.5}
    return NoiseProfile.model_validate({
        "sensor": {"key": KEY, "model": "MPU-9150"}, "measured_at": "2026-11-01T10:00:00+00:00", "session": "allan-1",
        "duration_s": 7800.0, "rate_hz": 100.0, "accel": {"unit": "g", "x": axis, "y": axis, "z": axis}})


def _six_position(root: Path, name: str, monkeypatch) -> dict:
    monkeypatch.setenv("RIG_HISTORY", str(root / "history.sqlite"))
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "9", "--time-scale", "0", "--out",
                 str(root / name), "--quiet"]) == 0
    return yaml.safe_load((next((root / name).iterdir()) / "calibration.yaml").read_text())


def test_the_units_profile_sets_the_bias_wander_and_the_file_says_so(tmp_path, monkeypatch):
    family = _six_position(tmp_path, "family", monkeypatch)
    assert "noise" not in family  # no profile: the family's figures, and the file as it always was
    record_profile(_profile(4 * 40e-6 / math.sqrt(2), 4 * 4e-6), tmp_path / "history.sqlite")  # a unit 4x noisier
    unit = _six_position(tmp_path, "unit", monkeypatch)
    used = unit["noise"]
    assert used["source"] == "unit profile" and used["sensor_key"] == KEY
    assert used["measured_at"] == "2026-11-01T10:00:00+00:00" and used["session"] == "allan-1"
    accel = used["sensors"]["accel"]
    assert math.isclose(accel["bias_instability"], 160e-6, rel_tol=1e-9) and math.isclose(accel["random_walk"], 16e-6)
    assert accel["random_walk_xyz"] == pytest.approx([16e-6] * 3)
    ratio = [u / f for u, f in zip(_type_a(unit)["bias_counts"], _type_a(family)["bias_counts"])]
    assert all(ratio_j > 1.5 for ratio_j in ratio), ratio  # the wander dominates a six-position bias sigma


def _type_a(cal: dict) -> dict:
    """The budget's Type A term: sigma without the misfit scaling the simulated table's own errors explain."""
    (part,) = [c for c in cal["accelerometer"]["uncertainty"]["budget"] if c["type"] == "A"]
    return part


def test_characterize_writes_and_records_a_valid_profile(tmp_path, capsys):
    text = (PROCEDURES / "allan.yaml").read_text().replace("seconds: 7800", "seconds: 120")
    (tmp_path / "a.yaml").write_text(text)
    assert main(["run", str(tmp_path / "a.yaml"), "--seed", "9", "--time-scale", "0", "--out", str(tmp_path / "s"),
                 "--quiet"]) == 0
    session = next((tmp_path / "s").iterdir())
    db = tmp_path / "h.sqlite"
    capsys.readouterr()
    assert main(["characterize", str(session), "--terms", "N", "--record", "--history", str(db), "-o",
                 str(tmp_path / "p.json"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    stored = load_profile(doc["recorded"])
    assert stored == load_profile(tmp_path / "p.json") and stored.sensor.key == KEY
    assert Path(doc["recorded"]).parent.parent == profiles_dir(db)
    assert stored.accel.x.B is None and stored.gyro is not None and 20 < stored.temperature_c < 35


def test_a_damaged_profile_never_hides_a_valid_one_and_alone_leaves_the_family_figures(tmp_path, monkeypatch):
    good = record_profile(_profile(4 * 40e-6 / math.sqrt(2), 4 * 4e-6), tmp_path / "history.sqlite")
    (good.parent / "20261102T100000.json").write_text('{"sensor": {"key": "' + KEY + '"}, "accel": 3')  # cut short
    cal = _six_position(tmp_path, "a", monkeypatch)
    assert cal["noise"]["source"] == "unit profile" and cal["noise"]["measured_at"].startswith("2026-11-01")
    good.unlink()  # only the damaged file is left: the family's figures, and the file says nothing of a profile
    cal = _six_position(tmp_path, "b", monkeypatch)
    assert "noise" not in cal or cal["noise"] is None


def _rapid(root: Path, name: str, monkeypatch, capsys) -> tuple[int, str, dict]:
    monkeypatch.setenv("RIG_HISTORY", str(root / "history.sqlite"))
    capsys.readouterr()
    code = main(["run", str(PROCEDURES / "six_position_rapid.yaml"), "--seed", "9", "--time-scale", "0", "--out",
                 str(root / name)])
    printed = capsys.readouterr()
    session = next((root / name).iterdir())
    return code, printed.out + printed.err, yaml.safe_load((session / "session.yaml").read_text())


def test_an_accuracy_target_is_predicted_with_the_units_profile(tmp_path, monkeypatch, capsys):
    code, printed, family = _rapid(tmp_path, "family", monkeypatch, capsys)
    assert code == 0 and "unit's own noise figures" not in printed
    record_profile(_profile(1.6 * 40e-6 / math.sqrt(2), 1.6 * 4e-6), tmp_path / "history.sqlite")  # 1.6x the family
    code, printed, unit = _rapid(tmp_path, "unit", monkeypatch, capsys)
    assert code == 0 and "accuracy target: predicted with the unit's own noise figures (its profile of 2026-11-01" in printed
    dwell = [sum(s["stats"]["n_samples"] for s in m["steps"] if s["kind"] == "static") for m in (family, unit)]
    assert dwell[1] > 1.2 * dwell[0], dwell  # more wander to average down: longer dwells


def test_a_unit_too_unstable_for_the_target_is_refused_before_anything_moves_naming_its_profile(tmp_path, monkeypatch,
                                                                                                    capsys):
    record_profile(_profile(4 * 40e-6 / math.sqrt(2), 4 * 4e-6), tmp_path / "history.sqlite")  # 4x the family
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "history.sqlite"))
    capsys.readouterr()
    code = main(["run", str(PROCEDURES / "six_position_rapid.yaml"), "--seed", "9", "--time-scale", "0", "--out",
                 str(tmp_path / "unit")])
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "unit").exists()  # the preflight: no session, nothing moved
    assert "target: out of reach" in err and "with this unit's bias stability (its noise profile)" in err


def test_discover_weighs_the_wander_with_the_units_profile_and_says_so(tmp_path, monkeypatch, capsys):
    _six_position(tmp_path, "s", monkeypatch)
    session = next((tmp_path / "s").iterdir())
    capsys.readouterr()
    assert main(["discover", str(session), "--json"]) == 0
    family = json.loads(capsys.readouterr().out)
    assert "noise" not in family
    record_profile(_profile(4 * 40e-6 / math.sqrt(2), 4 * 4e-6), tmp_path / "history.sqlite")  # a unit 4x noisier
    assert main(["discover", str(session), "--json"]) == 0
    unit = json.loads(capsys.readouterr().out)
    assert unit["noise"]["source"] == "unit profile" and unit["noise"]["sensor_key"] == KEY
    assert unit["wander_rms_g"] > 2 * family["wander_rms_g"]  # the wander the unit has, not the family's
    assert main(["discover", str(session)]) == 0
    assert "the bias wander is the unit's own (its noise profile of 2026-11-01)" in capsys.readouterr().err


def test_the_twin_of_a_characterised_unit_carries_its_own_wander(tmp_path, monkeypatch, capsys):
    _six_position(tmp_path, "s", monkeypatch)
    session = next((tmp_path / "s").iterdir())
    record_profile(_profile(4 * 40e-6 / math.sqrt(2), 4 * 4e-6), tmp_path / "history.sqlite")
    assert main(["discover", str(session), "--twin", str(tmp_path / "twin.yaml")]) == 0
    twin = yaml.safe_load((tmp_path / "twin.yaml").read_text())
    figures = twin["sim"]["noise_figures"]
    assert figures["accel_random_walk_g_per_rts"] == pytest.approx([16e-6] * 3)
    assert figures["accel_bias_instability_g"] == pytest.approx([160e-6] * 3)  # B in the registry's convention
    assert "the unit's own (its noise profile)" in (tmp_path / "twin.yaml").read_text()
    capsys.readouterr()
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(tmp_path / "twin.yaml"), "--seed", "4",
                 "--time-scale", "0", "--out", str(tmp_path / "on-twin"), "--quiet"]) == 0
    truth = yaml.safe_load((next((tmp_path / "on-twin").iterdir()) / "sim_truth.yaml").read_text())
    assert truth["noise"]["accel_random_walk_g_per_rts"] == pytest.approx([16e-6] * 3)
