"""``rig characterize-rig`` (issue 29 item 3): a reversal session characterises the simulated rig, the record is
stored next to the rig file (dated, tied to its sha256), the next six-position session on that rig solves with it
and its budget's rig terms name it; bad inputs are one line and exit 2; a record made on another rig file digest is
ignored, and the rig terms say so."""

from __future__ import annotations


import yaml

from conftest import PROCEDURES, RIGS
from cli_run import rig_in_process as rig


def run(procedure, rig_file, out_dir, *more) -> tuple:
    code, out, err = rig("run", procedure, "--rig", rig_file, "--time-scale", "0", "--seed", "3", "--yes", "--quiet",
                         "--out", out_dir, *more)
    assert code == 0, err
    (session,) = out_dir.iterdir()
    return session, out


def test_characterise_then_calibrate_on_the_characterised_rig(tmp_path):
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, geometry={"enabled": True})
    rig_file = tmp_path / "lab.yaml"
    rig_file.write_text(yaml.safe_dump(doc, sort_keys=False))
    reversal, printed = run(PROCEDURES / "characterize_reversal.yaml", rig_file, tmp_path / "rev")
    assert f"next: rig characterize-rig {reversal}" in printed  # the run says what its session is for

    code, out, err = rig("characterize-rig", reversal)
    assert code == 0, err
    assert "non_orthogonality.a1_a2" in out and " u " in out and "kept as classes" in out
    record = yaml.safe_load((tmp_path / "lab.characterisation.yaml").read_text())
    assert record["format"] == "rig-characterisation/1" and record["session"] == reversal.name
    assert record["rig_file"]["path"] == str(rig_file.resolve()) and len(record["rig_file"]["sha256"]) == 64
    assert record["date"] and record["dof"] > 0 and set(record["estimates"]["mounting.z"]) == {"estimate_deg", "u_deg", "u_correction_deg"}
    assert len(record["rig_file"]["table_sha256"]) == 64

    six, printed = run(PROCEDURES / "six_position.yaml", rig_file, tmp_path / "six")
    line = next(x for x in printed.splitlines() if "rig terms:" in x)
    assert "characterised by reversal" in line and "lab.characterisation.yaml" in line and record["date"][:10] in line
    cal = yaml.safe_load((six / "calibration.yaml").read_text())
    assert "lab.characterisation.yaml" in cal["accelerometer"]["uncertainty"]["rig"]
    assert cal["accelerometer"]["fit"]["chi2_per_dof"] < 5  # the table's errors left the fit (26.7 without)

    # another unit (another seed) on the same rig: the same table, so the same characterisation serves it
    other, printed = run(PROCEDURES / "six_position.yaml", rig_file, tmp_path / "other", "--seed", "7")
    truths = [yaml.safe_load((d / "sim_truth.yaml").read_text()) for d in (reversal, other)]
    assert truths[0]["geometry"] == truths[1]["geometry"] and truths[0]["accelerometer"] != truths[1]["accelerometer"]
    assert "characterised by reversal" in next(x for x in printed.splitlines() if "rig terms:" in x)
    assert yaml.safe_load((other / "calibration.yaml").read_text())["accelerometer"]["fit"]["chi2_per_dof"] < 5

    # only how fast the simulation runs edited (and a comment): the same table, the characterisation still holds
    paced = yaml.safe_load(rig_file.read_text())
    paced["sim"]["time_scale"] = 50
    rig_file.write_text(yaml.safe_dump(paced, sort_keys=False) + "# run faster\n")
    _, printed = run(PROCEDURES / "six_position.yaml", rig_file, tmp_path / "paced")
    assert "characterised by reversal" in next(x for x in printed.splitlines() if "rig terms:" in x)

    # another table (its table_seed): the characterisation is ignored, and said so
    other_table = yaml.safe_load(rig_file.read_text())
    other_table["sim"]["geometry"]["table_seed"] = 1
    rig_file.write_text(yaml.safe_dump(other_table, sort_keys=False))
    _, printed = run(PROCEDURES / "six_position.yaml", rig_file, tmp_path / "edited")
    (line,) = [x for x in printed.splitlines() if "rig terms:" in x]
    assert "characterisation lab.characterisation.yaml" in line and "ignored: made on rig file sha256" in line


def test_a_session_without_mountings_is_refused_in_one_line_exit_2(tmp_path):
    six = tmp_path / "six.yaml"
    six.write_text((PROCEDURES / "six_position.yaml").read_text().replace("{seconds: 10}", "{seconds: 2}"))
    session, _ = run(six, RIGS / "sim.yaml", tmp_path / "s")
    code, out, err = rig("characterize-rig", session)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "the session records no mounting" in err


def test_one_mounting_only_is_refused_in_one_line_exit_2(tmp_path):
    text = (PROCEDURES / "characterize_reversal.yaml").read_text()
    one = tmp_path / "one.yaml"
    one.write_text(text[:text.index("  - prompt: Turn the sensor 180 deg about its z")].replace("{seconds: 10}",
                                                                                                  "{seconds: 2}"))
    rig_file = tmp_path / "lab.yaml"
    rig_file.write_text((RIGS / "sim.yaml").read_text())
    session, _ = run(one, rig_file, tmp_path / "s")
    code, out, err = rig("characterize-rig", session)
    assert code == 2 and err.count("\n") == 1 and "one mounting only" in err
    assert not (tmp_path / "lab.characterisation.yaml").exists()
