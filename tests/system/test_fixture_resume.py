"""An interrupted fixture batch resumes like a session (issue 30 item 6): `rig run --resume BATCH_DIR` continues
every recording slot's session from its last finished step, on the same rig file, seed and slots only; a slot
quarantined before the interruption stays quarantined, a finished batch is not resumed, and the batch ends with its
table, record and report as an uninterrupted one does.

The interruptions run in this process (an operator that presses Ctrl-C when a pose's capture starts: the engine's
own abort path), the resumes through ``rig.cli.main``; one kill -9 runs in another process, as the one-sensor
resume tests do (tests/system/test_faults_and_resume.py). The fixture is ``rigs/sim-fixture.yaml``'s first four
slots (four designs, every slot of the batch its own session: what a resume does per slot does not depend on how
many there are; the eight-slot batch is tests/system/test_fixture_run.py's).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main
from rig.execution.context import RunAborted
from rig.session import load_session
from rig.workflow.run import run_procedure

from conftest import PROCEDURES, REPO
from fixture_runs import CtrlCAt, fixture_rig_file

SIX = str(PROCEDURES / "six_position.yaml")
SEED = 3
#: the slots of the module's fixture
SLOTS = 4


def _interrupt(out: Path, rig: Path, at_index: int) -> Path:
    """A batch of seed 3 on ``rig``, stopped by Ctrl-C at step ``at_index``; returns its directory."""
    with pytest.raises(RunAborted) as stopped:
        run_procedure(SIX, rig_spec=str(rig), out_dir=out, seed=SEED, time_scale=0, ui=CtrlCAt(at_index))
    batch = stopped.value.session_dir  # what the resume command shows: the batch, not a slot's session
    assert batch is not None and (Path(batch) / "batch.json").is_file()
    return Path(batch)


def _record(batch: Path) -> dict:
    return json.loads((batch / "batch.json").read_text())


def _manifest(session: Path) -> dict:
    return yaml.safe_load((session / "session.yaml").read_text())


def _events(session: Path) -> list[str]:
    return [json.loads(line)["kind"] for line in (session / "events.jsonl").read_text().splitlines() if line.strip()]


def _tree(batch: Path) -> dict:
    return {p.relative_to(batch): p.read_bytes() for p in batch.rglob("*") if p.is_file() and p.name != "session.lock"}


@pytest.fixture(scope="module")
def fixture_rig(tmp_path_factory) -> Path:
    """``rigs/sim-fixture.yaml`` with its first :data:`SLOTS` slots."""
    return fixture_rig_file(tmp_path_factory.mktemp("rig"), SLOTS)


def _rig_doc(fixture_rig: Path) -> dict:
    return yaml.safe_load(fixture_rig.read_text())


@pytest.fixture(scope="module")
def whole(tmp_path_factory, fixture_rig) -> Path:
    """The uninterrupted batch of seed 3 (read only)."""
    out = tmp_path_factory.mktemp("whole")
    assert main(["run", SIX, "--rig", str(fixture_rig), "--out", str(out), "--seed", str(SEED),
                 "--time-scale", "0", "--quiet"]) == 0
    (batch,) = [p for p in out.iterdir() if p.is_dir()]
    return batch


@pytest.fixture(scope="module")
def stopped(tmp_path_factory, fixture_rig) -> Path:
    """The batch of seed 3 stopped by Ctrl-C during pose 4 (read only: copy it to resume it)."""
    return _interrupt(tmp_path_factory.mktemp("stopped"), fixture_rig, 3)


def _copy(batch: Path, tmp_path: Path) -> Path:
    target = tmp_path / batch.name
    shutil.copytree(batch, target)
    return target


def test_an_interrupted_batch_says_so_in_its_record_and_every_slot_session_is_aborted(stopped, capsys):
    record = _record(stopped)
    assert record["status"] == "aborted" and record["rig_file_sha256"]
    assert all(s["outcome"] is None and s["session"] for s in record["slots"])
    for s in record["slots"]:
        m = _manifest(stopped / s["session"])
        assert m["status"] == "aborted"
        assert [st["status"] for st in m["steps"]] == ["complete"] * 3 + ["pending"] * 3
    assert main(["report", str(stopped)]) == 2  # its results are not there yet: the report says how to resume
    assert f"rig run --resume {stopped}" in capsys.readouterr().err


def test_a_resumed_batch_ends_as_an_uninterrupted_one_with_the_same_calibrations(stopped, whole, tmp_path, capsys):
    batch = _copy(stopped, tmp_path)
    before = _record(batch)
    assert main(["run", "--resume", str(batch), "--time-scale", "0"]) == 0
    printed = capsys.readouterr()
    assert f"0 PASS, 0 FAIL, {SLOTS} NO LIMITS, 0 FAULT" in printed.out and "batch report:" in printed.out, printed
    assert f"resuming batch {batch}: slot 0 at step 4" in printed.err
    record = _record(batch)
    assert record["status"] == "complete" and (batch / "batch-report.html").is_file()
    assert {k: record[k] for k in ("id", "created", "procedure", "seed")} == {k: before[k] for k in
                                                                               ("id", "created", "procedure", "seed")}
    assert record["resumes"][0]["slots"] == [{"slot": i, "first_step_index": 3} for i in range(SLOTS)]
    assert not (batch / "session.lock").exists()
    reference = {s["slot"]: s for s in _record(whole)["slots"]}
    for s in record["slots"]:
        d = batch / s["session"]
        session = load_session(d)
        assert session.info.to_dict()["status"] == "complete" and "resume" in _events(d)
        for step in session.info.to_dict()["steps"]:  # every step once, none lost, none doubled
            assert len(session.step_samples(step["index"])["t_s"]) == 1000, (s["slot"], step["index"])
        got = calfile.read(batch / s["calibration"]).accelerometer
        want = calfile.read(whole / reference[s["slot"]]["calibration"]).accelerometer
        for key, got_v, want_v in (("bias_counts", got.bias_counts, want.bias_counts),
                                   ("scale_counts_per_g", got.scale_counts_per_g, want.scale_counts_per_g)):
            sigma = np.hypot(got.sigma[key], want.sigma[key])  # the same unit, measured again from pose 4 on
            assert np.all(np.abs(np.asarray(got_v) - want_v) < 5 * sigma), (s["slot"], key, got_v, want_v)
        assert s["outcome"] == "NO LIMITS" and s["bin"] == "good"


def test_a_slot_cut_mid_pose_has_its_step_in_progress_and_torn_line_cut_and_redone(stopped, tmp_path, capsys):
    """What a crash leaves in one slot's samples past its finished steps (rows of the step in progress, a torn last
    line) is cut as a one-sensor resume cuts it, and the step recorded again."""
    batch = _copy(stopped, tmp_path)
    last = batch / _record(batch)["slots"][SLOTS - 1]["session"]
    rows = (last / "samples.csv").read_text().splitlines()[-5:]
    in_progress = "".join(",".join([f[0], "3", *f[2:]]) + "\n" for f in (r.split(",") for r in rows))
    with open(last / "samples.csv", "a") as fh:
        fh.write(in_progress + "12.345,3,41")  # five rows of step 4, then a line torn mid-write
    assert main(["run", "--resume", str(batch), "--time-scale", "0", "--quiet"]) == 0
    events = [json.loads(line) for line in (last / "events.jsonl").read_text().splitlines()]
    cut = [e["message"] for e in events if e["kind"] == "warning" and "discarded" in e.get("message", "")]
    assert len(cut) == 1 and "5 rows of step 4" in cut[0] and "a torn last line" in cut[0], cut
    session = load_session(last)
    assert [len(session.step_samples(i)["t_s"]) for i in range(6)] == [1000] * 6
    assert _record(batch)["slots"][SLOTS - 1]["outcome"] == "NO LIMITS"


def test_slots_that_had_concluded_stay_untouched_and_keep_their_outcome(whole, tmp_path, capsys):
    """A batch stopped while it concluded its slots: the ones concluded keep their sessions, calibrations and
    outcomes (one whose outcome the record did not hold yet gets it from its session), and only the end is made."""
    batch = _copy(whole, tmp_path)
    record = _record(batch)
    record["status"] = "aborted"
    record["slots"][2].update(outcome=None, bin=None, calibration=None, parameters=None)  # stopped before its line
    (batch / "batch.json").write_text(json.dumps(record))
    (batch / "batch-report.html").unlink()
    sessions = {p: b for p, b in _tree(batch).items() if p.parts[0] != "batch.json"}
    assert main(["run", "--resume", str(batch), "--time-scale", "0"]) == 0
    printed = capsys.readouterr()
    assert "no slot to record, only the end of the batch" in printed.err
    assert f"0 PASS, 0 FAIL, {SLOTS} NO LIMITS, 0 FAULT" in printed.out, printed.out
    assert {p: b for p, b in _tree(batch).items() if p in sessions} == sessions  # nothing of a slot rewritten
    ended = _record(batch)
    assert ended["status"] == "complete" and (batch / "batch-report.html").is_file()
    assert ended["resumes"][0]["slots"] == []
    assert ended["slots"] == _record(whole)["slots"]


def test_a_finished_batch_is_not_resumed(whole, capsys):
    before = _tree(whole)
    assert main(["run", "--resume", str(whole), "--time-scale", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the batch is already complete; nothing to resume" in err[0], err
    assert _tree(whole) == before


def test_a_resume_on_another_rig_file_or_seed_is_refused_before_anything_is_touched(stopped, fixture_rig, tmp_path,
                                                                                    capsys):
    batch = _copy(stopped, tmp_path)
    before = _tree(batch)
    other = tmp_path / "other.yaml"
    doc = _rig_doc(fixture_rig)
    doc["sim"]["chamber"]["initial_c"] = 20.0
    other.write_text(yaml.safe_dump(doc))
    for extra, why in ((["--rig", str(other)], "has other contents than the one recorded"),
                       (["--seed", "4"], "seed 4 (recorded 3)")):
        assert main(["run", "--resume", str(batch), "--time-scale", "0", *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "cannot resume on another rig or sensor" in err[0] and why in err[0], err
    assert _tree(batch) == before


def test_a_slot_remounted_in_the_rig_file_is_another_fixture_and_refused(stopped, fixture_rig, tmp_path, capsys):
    batch = _copy(stopped, tmp_path)
    swapped = tmp_path / "swapped.yaml"
    doc = _rig_doc(fixture_rig)
    assert doc["fixture"]["slots"][3]["serial"] == "SIM-3"
    doc["fixture"]["slots"][3]["serial"] = "B-3"
    swapped.write_text(yaml.safe_dump(doc))
    assert main(["run", "--resume", str(batch), "--time-scale", "0", "--rig", str(swapped)]) == 2
    err = capsys.readouterr().err
    assert "slot 3 serial B-3 (recorded SIM-3)" in err, err


def test_one_slots_session_is_not_resumed_alone(stopped, tmp_path, capsys):
    batch = _copy(stopped, tmp_path)
    before = _tree(batch)
    slot = batch / _record(batch)["slots"][2]["session"]
    assert main(["run", "--resume", str(slot), "--time-scale", "0"]) == 2
    err = capsys.readouterr().err
    assert "is slot 2 of a fixture batch: resume the batch" in err and f"rig run --resume {batch.resolve()}" in err
    assert _tree(batch) == before


@pytest.mark.parametrize("known_by", ["the record", "its session only"])
def test_a_slot_quarantined_before_the_interruption_stays_quarantined(fixture_rig, tmp_path, capsys, known_by):
    rig = _rig_doc(fixture_rig)
    rig["faults"] = {"slots": {3: {"dead_after_s": 55.0}}}  # slot 3 stops answering during pose 4
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(rig))
    batch = _interrupt(tmp_path / "out", tmp_path / "rig.yaml", 4)  # Ctrl-C during pose 5
    bad = _record(batch)["slots"][3]
    assert bad["outcome"] == "FAULT" and "step 4 (-X up)" in bad["reason"], bad
    if known_by == "its session only":  # stopped before the record said so: the quarantine's error event does
        record = _record(batch)
        record["slots"][3].update(outcome=None, bin=None, reason=None)
        (batch / "batch.json").write_text(json.dumps(record))
    slot3 = batch / bad["session"]
    before = (slot3 / "session.yaml").read_bytes(), (slot3 / "samples.csv").read_bytes()
    assert main(["run", "--resume", str(batch), "--time-scale", "0"]) == 3  # a unit did not pass
    printed = capsys.readouterr()
    assert f"0 PASS, 0 FAIL, {SLOTS - 1} NO LIMITS, 1 FAULT" in printed.out, printed
    record = _record(batch)
    assert record["status"] == "complete" and record["slots"][3]["outcome"] == "FAULT"
    assert record["slots"][3]["reason"] == bad["reason"]
    assert 3 not in [s["slot"] for s in record["resumes"][0]["slots"]]
    assert ((slot3 / "session.yaml").read_bytes(), (slot3 / "samples.csv").read_bytes()) == before  # not re-tried
    assert "resume" not in _events(slot3)
    for s in record["slots"]:
        if s["slot"] != 3:
            assert s["outcome"] == "NO LIMITS" and _manifest(batch / s["session"])["status"] == "complete"


def _spawn(args):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.Popen([sys.executable, "-X", "faulthandler", "-m", "rig.cli", *args], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_slot_steps(out: Path, n: int, proc, timeout_s: float = 60) -> Path:
    """The batch directory once slot 0's session has ``n`` finished steps (its steps journal)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for journal in out.glob("*/*-slot0/steps.jsonl"):
            if len(journal.read_text().splitlines()) >= n:
                return journal.parent.parent
        if proc.poll() is not None:
            raise AssertionError(f"run ended early: {proc.stderr.read()}")
        time.sleep(0.02)
    raise AssertionError("run did not get that far")


@pytest.mark.realtime
def test_kill_9_mid_batch_then_resume_keeps_every_step_of_every_slot_once(tmp_path, fixture_rig, whole):
    out = tmp_path / "out"
    proc = _spawn(["run", SIX, "--rig", str(fixture_rig), "--out", str(out), "--seed", str(SEED),
                   "--time-scale", "16", "--quiet"])
    batch = _wait_for_slot_steps(out, 3, proc)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert _record(batch)["status"] == "running"  # it never got to say
    assert main(["run", "--resume", str(batch), "--time-scale", "0", "--quiet"]) == 0
    record = _record(batch)
    assert record["status"] == "complete" and record["counts"]["NO LIMITS"] == SLOTS
    reference = {s["slot"]: s for s in _record(whole)["slots"]}
    for s in record["slots"]:
        session = load_session(batch / s["session"])
        for step in session.info.to_dict()["steps"]:
            assert len(session.step_samples(step["index"])["t_s"]) == 1000, (s["slot"], step["index"])
        got = calfile.read(batch / s["calibration"]).accelerometer
        want = calfile.read(whole / reference[s["slot"]]["calibration"]).accelerometer
        sigma = np.hypot(got.sigma["scale_counts_per_g"], want.sigma["scale_counts_per_g"])
        assert np.all(np.abs(np.asarray(got.scale_counts_per_g) - want.scale_counts_per_g) < 5 * sigma), s["slot"]
