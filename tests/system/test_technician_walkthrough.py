"""What a technician's week without an engineer stumbled on (issue 33, the walkthrough on a fresh clone): every
hint names the command as this command spells it, every number is counted the way the user counts, and nothing
printed claims more than happened. The ``rig`` commands run in this process (``rig.cli.main``) on the simulated
rig in virtual time."""

from __future__ import annotations

import io
import json
import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest

from calib.file import calibration as calfile
from rig.cli.outputs import reader_left_unread
from rig.config.procedure import load_procedure
from rig.devices.bringup import OPEN_HINTS
from rig.execution.estimate import temperature_step_s
from rig.session import load_session

from conftest import REPO
from cli_run import rig_in_process as rig


@pytest.fixture(autouse=True)
def history(tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))


# -- item 1: the simulated rig as each command spells it -------------------------------------------------------
@pytest.mark.parametrize("args, spelled", [
    (("check", "nosuch.yaml"), "'rig check sim'"),
    (("jog", "nosuch.yaml", "a1", "5"), "'rig jog sim a1 5'"),
    (("run", REPO / "procedures" / "six_position.yaml", "--rig", "nosuch.yaml"), "--rig sim"),
])
def test_a_missing_rig_file_names_the_simulated_rig_as_the_command_takes_it(args, spelled):
    """rig check and rig jog take the rig as their first argument (``rig check sim``), rig run as ``--rig``:
    the one line of a missing rig file says the form the command at hand accepts."""
    code, _, err = rig(*args)
    assert code == 2
    assert err.strip() == (f"rig {args[0]}: nosuch.yaml: no such rig file (use {spelled} for the simulated rig)")


# -- item 8: the pointers into the documents ---------------------------------------------------------------------
def test_every_hint_into_the_hardware_guide_names_one_of_its_headings():
    """A hint "(docs/hardware.md, 'Heading')" names a heading the guide has, word for word."""
    headings = {line.lstrip("#").strip() for line in (REPO / "docs" / "hardware.md").read_text().splitlines()
                if line.startswith("#")}
    pointed = [m for hint in OPEN_HINTS.values() for m in re.findall(r"docs/hardware\.md, '([^']+)'", hint)]
    assert pointed and set(pointed) <= headings, set(pointed) - headings


# -- item 2: a step named as the user counts it -----------------------------------------------------------------
def test_a_misspelt_pose_names_its_step_as_the_progress_line_counts_it(tmp_path):
    """The 5th pose of six_position misspelt: the line names ``steps[4]`` (the file's list index) and step 5, the
    number the progress line (``[5/6] +Y up``), the report and rig compare give that step."""
    bad = tmp_path / "bad.yaml"
    bad.write_text((REPO / "procedures" / "six_position.yaml").read_text().replace('"+Y up"', '"+Y upp"'))
    code, _, err = rig("run", bad, "--time-scale", 0, "--out", tmp_path / "s")
    assert code == 2
    assert re.fullmatch(rf"rig run: {re.escape(str(bad))}:\d+: steps\[4\] \(step 5\)\.pose: unknown pose '\+Y upp' "
                        r"\(allowed: .*\): did you mean '\+Y up'\?", err.strip()), err
    assert not (tmp_path / "s").exists()  # refused before anything was recorded


# -- item 3: a misspelt value of a list of choices gets a "did you mean" -------------------------------------------
SIX = (REPO / "procedures" / "six_position.yaml").read_text()
SIM_RIG = (REPO / "rigs" / "sim.yaml").read_text()


@pytest.mark.parametrize("kind, text, key, meant", [
    ("procedure", SIX.replace("method: pinv", "method: pinvv"), "solve.method", "pinv"),
    ("procedure", SIX.replace("model: triangular", "model: triangulr"), "solve.model", "triangular"),
    ("procedure", SIX.replace("solve:", "order: shortst\nsolve:"), "order", "shortest"),
    ("procedure", SIX.replace("accel_range_g: 4", "model: MPU9150, accel_range_g: 4"), "sensor.model", "MPU-9150"),
    ("rig", SIM_RIG.replace("kind: sim", "kind: simm"), "kind", "sim"),
    ("rig", SIM_RIG.replace("home: zero", "home: zer"), "home", "zero"),
    ("rig", SIM_RIG.replace("model: MPU-9150", "model: MPU-9105"), "sensor.model", "MPU-9150"),
])
def test_a_misspelt_choice_in_a_procedure_or_rig_file_says_which_one_was_meant(tmp_path, kind, text, key, meant):
    """Every enumerated value of the procedure and rig-file formats, as unknown keys and poses already do: the
    choices, what was given, and the closest choice (one place: the shared field dialect)."""
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    args = ("run", path) if kind == "procedure" else ("run", REPO / "procedures" / "six_position.yaml", "--rig", path)
    code, _, err = rig(*args, "--time-scale", 0, "--out", tmp_path / "s")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert re.search(rf"{re.escape(str(path))}:\d+: {re.escape(key)}: expected .*, got .*: did you mean "
                     rf"'{re.escape(meant)}'\?$", err.strip()), err


def test_a_number_outside_its_choices_gets_no_guess(tmp_path):
    """A range of 5 g is not a misspelling of 4 or 8: the choices are named, no guess is made."""
    path = tmp_path / "bad.yaml"
    path.write_text(SIX.replace("accel_range_g: 4", "accel_range_g: 5"))
    code, _, err = rig("run", path, "--time-scale", 0, "--out", tmp_path / "s")
    assert code == 2 and err.strip().endswith("sensor.accel_range_g: expected one of 2, 4, 8, 16, got 5"), err


# -- items 5, 6, 7: sessions of two seeds -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def two_units(tmp_path_factory) -> dict:
    """six_position sessions of two simulated units (seeds 0 and 11), each with its calibration."""
    root = tmp_path_factory.mktemp("units")
    out = {"root": root}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(root / "h.sqlite"))
        for seed in (0, 11):
            code, _, _ = rig("run", REPO / "procedures" / "six_position.yaml", "--seed", seed, "--time-scale", 0,
                             "--quiet", "--out", root / f"s{seed}")
            assert code == 0
            out[seed] = next((root / f"s{seed}").iterdir())
    return out


def test_compare_of_a_session_with_itself_says_first_that_there_is_nothing_to_compare(two_units, tmp_path):
    """rig compare S0 S0 said "A and B agree at the noise level": it is one recording, and said so first (a copy
    of the session elsewhere too); the exit code stays 0 (a report)."""
    s0 = two_units[0]
    code, out, _ = rig("compare", s0, s0)
    assert code == 0
    first = out.splitlines()[0]
    assert first == f"A and B are the same session ({s0.name}): nothing to compare.", out
    assert "agree at the noise level" not in out
    copy = tmp_path / "copy"
    shutil.copytree(s0, copy)
    code, out, _ = rig("compare", s0, copy, "--json")
    headline = json.loads(out)["headline"]
    assert code == 0 and headline[0] == (f"A and B are the same session ({s0.name}; B is a copy of A at another "
                                         "path): nothing to compare."), headline


@pytest.mark.parametrize("command", ["evaluate", "apply"])
def test_a_calibration_of_another_unit_is_said_in_one_note_naming_both(two_units, command, tmp_path):
    """Seed 0's calibration on seed 11's session: one note on stderr names both sensor identities and the evidence
    (as rig compare decides two sessions are two units); the command's output and exit code are unchanged. Its
    own session: no note."""
    cal = two_units[0] / "calibration.yaml"
    extra = ("-o", tmp_path / "out.csv") if command == "apply" else ()
    code, _, err = rig(command, cal, two_units[11], *extra)
    assert code == 0
    notes = [ln for ln in err.splitlines() if "another unit" in ln]
    assert len(notes) == 1, err
    assert notes[0].startswith(f"rig {command}: note: {cal} is the calibration of another unit "
                               "(MPU-9150@0x68#0x68/sim-seed-0) than the session recorded "
                               "(MPU-9150@0x68#0x68/sim-seed-11; simulated sensors drawn from seeds 0 and 11)"), notes
    code, _, err = rig(command, cal, two_units[0], *extra)
    assert code == 0 and "another unit" not in err, err


def test_apply_to_a_pipe_whose_reader_stops_early_never_claims_every_row_was_taken(two_units, tmp_path):
    """``rig apply CALIB SESSION -o - | head -1`` said "wrote 6000 rows to stdout" after head had closed the pipe:
    the rows fitted in the pipe, so no write failed. Now either the reader's early close ends the output silently
    (the write failed: exit 0, as for any `| head`), or the line says the reader closed it before reading them all."""
    session = two_units[0]
    run = subprocess.run(f"{shlex.quote(sys.executable)} -m rig.cli apply {shlex.quote(str(session))}/calibration.yaml "
                         f"{shlex.quote(str(session))} -o - | head -1", shell=True, capture_output=True, text=True,
                         cwd=REPO, env={**os.environ, "RIG_HISTORY": str(tmp_path / "h.sqlite")}, timeout=120)
    assert run.stdout == "t_s,step,fx,fy,fz,temp_c\n"
    assert run.stderr in ("", "rig apply: wrote 6000 rows to stdout; its reader closed it before reading them all\n"), \
        run.stderr


def test_a_pipe_closed_by_its_reader_with_bytes_unread_is_told_from_one_read_to_its_end():
    """What rig apply asks after writing to standard output (rig.cli.outputs.reader_left_unread): the reader still
    there, or gone after reading everything: no; gone with bytes unread: yes; not a pipe: no."""
    for read_all, close_reader, left in ((False, False, False), (True, True, False), (False, True, True)):
        r, w = os.pipe()
        with os.fdopen(w, "w") as writer:
            writer.write("row\n" * 100)
            writer.flush()
            if read_all:
                os.read(r, 400)
            if close_reader:
                os.close(r)
            assert reader_left_unread(writer) is left, (read_all, close_reader)
        if not close_reader:
            os.close(r)
    assert reader_left_unread(io.StringIO()) is False


# -- item 4: a fixture run's table in the one-unit run's units and verdict words --------------------------------
@pytest.mark.parametrize("procedure, verdict", [("six_position.yaml", "NO LIMITS"),
                                                ("six_position_production.yaml", "PASS")])
def test_the_batch_table_prints_bias_in_counts_and_the_one_unit_verdict_words(tmp_path, procedure, verdict):
    """The batch table printed bias in mg where every other view prints counts, and PASS for a procedure without
    accept: limits where the one-unit report says NO LIMITS. Now: bias in counts (the unit in the header, each
    slot's value its calibration file's), PASS/FAIL only against limits, NO LIMITS otherwise (exit 0 either way);
    batch.json keeps its keys (bias_mg too) and adds bias_counts and the NO LIMITS count."""
    code, out, _ = rig("run", REPO / "procedures" / procedure, "--rig", REPO / "rigs" / "sim-fixture.yaml", "--seed", 3,
                       "--time-scale", 0, "--quiet", "--out", tmp_path)
    assert code == 0, out
    lines = out.splitlines()
    head = next(ln for ln in lines if ln.startswith("slot "))
    assert "bias x,y,z (counts)" in head and "(mg)" not in out
    rows = [ln for ln in lines if re.match(r"\s+\d+  SIM-", ln)]
    assert len(rows) == 8 and all(f" {verdict} " in r for r in rows), out
    (batch_dir,) = [d for d in tmp_path.iterdir() if d.is_dir()]
    record = json.loads((batch_dir / "batch.json").read_text())
    assert record["counts"] == {"PASS": 8 if verdict == "PASS" else 0, "FAIL": 0,
                                "NO LIMITS": 8 if verdict == "NO LIMITS" else 0, "FAULT": 0, "ABSENT": 0}
    for row, slot in zip(rows, record["slots"]):
        assert slot["outcome"] == verdict and set(slot["parameters"]) == {"bias_mg", "bias_counts",
                                                                          "scale_counts_per_g", "residual_ug"}
        bias = calfile.read(batch_dir / slot["calibration"]).accelerometer.bias_counts
        printed = [float(v) for v in row.split()[-7:-4]]
        assert printed == pytest.approx(list(bias), abs=0.006) == slot["parameters"]["bias_counts"]


# -- item 8: the thermal run's plan and its first ETA ----------------------------------------------------------
def test_the_thermal_plan_is_what_the_run_takes_and_what_its_first_eta_says(tmp_path):
    """procedures/thermal.yaml planned "about 41 min" while its first ETA said 36m52s and the run took 45 min: every
    temperature step was guessed at 300 s, the first (the chamber already at 27.6 C) takes its 60 s hold and each
    5 C step about 400 s. A temperature step is now its hold plus the chamber's approach from the step before (the
    first from its own target): the plan is within 3 % of the run, and each temperature step within 5 % of what
    it took, the first one its hold (what the first ETA line counts once the sensor is in band)."""
    procedure = load_procedure(REPO / "procedures" / "thermal.yaml")
    code, _, err = rig("run", REPO / "procedures" / "thermal.yaml", "--seed", 3, "--time-scale", 0,
                       "--out", tmp_path / "s")
    assert code == 0, err
    planned_min = float(re.search(r"planned: 42 steps, about (\d+) min of rig time", err).group(1))
    session = load_session(next((tmp_path / "s").iterdir()))
    took_s = max(s.stats.t_end_s for s in session.info.steps if s.stats is not None)
    assert planned_min * 60 == pytest.approx(took_s, rel=0.03, abs=30), (planned_min, took_s)
    waited = {e["step"]: e["waited_s"] for e in session.events if e.get("kind") == "temperature"}
    steps = procedure.expanded_steps()
    last_c = None
    for step in steps:
        if step.kind == "thermal":
            assert temperature_step_s(step.temperature, last_c) == pytest.approx(waited[step.index], rel=0.05)
            last_c = step.temperature.target_c
    assert temperature_step_s(steps[0].temperature, None) == steps[0].temperature.hold_s == 60
