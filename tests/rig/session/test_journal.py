"""The steps journal (issue 34 item 7): a finished step is one fsynced line of ``steps.jsonl``, not a rewrite of
the whole manifest, so a step costs the same at step 10 as at step 10,000; ``session.yaml`` is compacted (the
journal folded in, the journal removed) when the session ends, and every reader folds a journal left by a crash.
"""

from __future__ import annotations

import copy
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import yaml

from rig.cli import main
from rig.errors import SessionFormatError
from rig.session import ProcedureInfo, RigInfo, SensorInfo, SessionManifest, SessionWriter, StepRecord, load_session
from rig.session import writer as session_writer
from rig.session.writer import dump_yaml

from conftest import PROCEDURES, REPO

SENSOR = {"model": "MPU-9150", "address": 104, "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0,
          "has_temperature": True}
STAMP = "2024-01-01T00:00:00.000+00:00"


def _manifest(n_steps: int) -> SessionManifest:
    return SessionManifest(id="sess-1", created=STAMP, software={"name": "rig", "version": "0"},
                           procedure=ProcedureInfo(name="p", file=None, sha256=None, text="solve: {model: full}\n"),
                           rig=RigInfo(kind="test", sensor=SensorInfo(**SENSOR)),
                           steps=[StepRecord(index=i, name=f"s{i}", angles_deg=[0, 0, 0], f_nominal=[0, 0, 1])
                                  for i in range(n_steps)])


def _step(w: SessionWriter, i: int, n: int = 5) -> None:
    w.append_samples(i, np.arange(n) * 0.01 + i, np.tile([1, 2, 8192], (n, 1)), temp_c=np.full(n, 25.0))
    w.complete_step(i, {"n_samples": n, "t_start_s": float(i), "t_end_s": i + 0.04, "temp_c": 25.0,
                        "noise_g": [1e-3, 2e-3, np.nan], "problems": [], "attempts": 1})


def _journal_lines(d: Path) -> list[dict]:
    return [json.loads(x) for x in (d / "steps.jsonl").read_bytes().splitlines()]


def test_a_finished_step_is_one_journal_line_and_the_manifest_is_compacted_at_the_end(tmp_path):
    w = SessionWriter.create(tmp_path, "sess-1", _manifest(3))
    d = w.session_dir
    manifest_at_start = (d / "session.yaml").read_bytes()
    _step(w, 0)
    _step(w, 1)
    assert (d / "session.yaml").read_bytes() == manifest_at_start  # not rewritten per step
    lines = _journal_lines(d)
    assert [(x["index"], x["status"]) for x in lines] == [(0, "complete"), (1, "complete")]
    assert lines[-1]["samples_committed_bytes"] == (d / "samples.csv").stat().st_size
    assert lines[0]["stats"]["n_samples"] == 5 and lines[0]["stats"]["noise_g"][2] is None  # NaN as in the manifest
    info, _ = SessionManifest.load(d)  # the journal folded in, as every reader does
    assert [s.status for s in info.steps] == ["complete", "complete", "pending"]
    assert info.samples_committed_bytes == lines[-1]["samples_committed_bytes"]
    assert info.to_dict() == w.info.to_dict()
    w.set_status("aborted")
    assert not (d / "steps.jsonl").exists()
    assert yaml.safe_load((d / "session.yaml").read_text())["steps"][1]["status"] == "complete"


class EveryStepWriter(SessionWriter):
    """The writer as it was: the whole manifest rewritten after every step (the reference format)."""

    def _record_step(self, index: int) -> None:
        self._write_manifest()


def _record(root: Path, cls, n_steps: int = 4, end: str | None = "complete") -> Path:
    w = cls.create(root, "sess-1", _manifest(n_steps))
    for i in range(n_steps - 1):
        _step(w, i)
    w.complete_step(n_steps - 1, {"t_end_s": 9.0, "temp_c": 25.0})  # a step without samples (a temperature step)
    if end is not None:
        w.set_status(end)
    return w.session_dir


@pytest.fixture
def frozen_clock(monkeypatch):
    monkeypatch.setattr(session_writer, "utc_now", lambda: STAMP)
    sealing = sys.modules.get("rig.session.seal")  # the seal's time stamp too, where sessions are sealed
    if sealing is not None:
        monkeypatch.setattr(sealing, "utc_now", lambda: STAMP)


@pytest.mark.parametrize("end", ["complete", "aborted"])
def test_the_compacted_session_is_byte_for_byte_the_session_written_without_a_journal(tmp_path, frozen_clock, end):
    new = _record(tmp_path / "journal", SessionWriter, end=end)
    old = _record(tmp_path / "every-step", EveryStepWriter, end=end)
    assert sorted(p.name for p in new.iterdir()) == sorted(p.name for p in old.iterdir())
    assert not (new / "steps.jsonl").exists()
    for p in old.iterdir():
        assert (new / p.name).read_bytes() == p.read_bytes(), p.name
    assert load_session(new).info.to_dict() == load_session(old).info.to_dict()


def test_a_session_killed_mid_run_reads_as_the_manifest_written_without_a_journal(tmp_path, frozen_clock):
    new = _record(tmp_path / "journal", SessionWriter, end=None)  # never ended: session.yaml + steps.jsonl
    old = _record(tmp_path / "every-step", EveryStepWriter, end=None)
    assert len(_journal_lines(new)) == 4
    assert SessionManifest.load(new)[0].to_dict() == yaml.safe_load((old / "session.yaml").read_text())
    assert SessionManifest.load(new)[0].to_dict() == SessionManifest.load(old)[0].to_dict()


def test_the_per_step_write_is_constant_whatever_the_number_of_steps(tmp_path):
    """Bytes written per step (the journal's growth; session.yaml untouched) at the start and at the end of a long
    session, and in a short one: the same, within the digits of the numbers."""
    grown = {}
    for n_steps in (10, 3000):
        w = SessionWriter.create(tmp_path / str(n_steps), "sess-1", _manifest(n_steps))
        d = w.session_dir
        inode = os.stat(d / "session.yaml").st_ino
        sizes = []
        for i in list(range(5)) + list(range(n_steps - 5, n_steps)):
            before = (d / "steps.jsonl").stat().st_size if (d / "steps.jsonl").exists() else 0
            _step(w, i)
            sizes.append((d / "steps.jsonl").stat().st_size - before)
        assert os.stat(d / "session.yaml").st_ino == inode  # never replaced while the steps ran
        grown[n_steps] = sizes
        w.close()
    every = grown[10] + grown[3000]
    assert max(every) - min(every) <= 16 and max(every) < 600, grown


def test_a_torn_last_journal_line_is_a_step_that_was_not_finished(tmp_path):
    w = SessionWriter.create(tmp_path, "sess-1", _manifest(4))
    _step(w, 0)
    _step(w, 1)
    d = w.session_dir
    whole = (d / "steps.jsonl").read_bytes()
    assert len(whole.splitlines()) == 2
    w.append_samples(2, np.arange(5) * 0.01 + 2, np.tile([1, 2, 8192], (5, 1)), temp_c=np.full(5, 25.0))
    w._samples.flush()
    with open(d / "steps.jsonl", "ab") as fh:  # killed while step 3's line was written
        fh.write(b'{"index":2,"status":"complete","stats":{"n_sam')
    w.close()
    info, _ = SessionManifest.load(d)
    assert [s.status for s in info.steps] == ["complete", "complete", "pending", "pending"]
    assert load_session(d).step_samples(2)["t_s"].size == 5  # rows of the step in progress: not checked, not used
    w2, first = SessionWriter.resume(d)
    assert first == 2 and not (d / "steps.jsonl").exists()
    assert [s["status"] for s in yaml.safe_load((d / "session.yaml").read_text())["steps"]] == \
        ["complete", "complete", "pending", "pending"]
    assert load_session(d).step_samples(2)["t_s"].size == 0  # cut back to the committed point
    w2.close()


@pytest.mark.parametrize("damage,expect", [
    (lambda b: b.replace(b'"status":"complete"', b'"status":"done"', 1), "steps.jsonl:1: status: expected complete"),
    (lambda b: b"not json\n" + b, "steps.jsonl:1: not a JSON line"),
    (lambda b: b + b'{"index":9,"status":"complete","stats":{},"samples_committed_bytes":1}\n',
     "steps.jsonl:3: index: step 9 is not in the manifest"),
])
def test_a_damaged_journal_is_refused_naming_the_line(tmp_path, damage, expect):
    w = SessionWriter.create(tmp_path, "sess-1", _manifest(3))
    _step(w, 0)
    _step(w, 1)
    w.close()
    path = w.session_dir / "steps.jsonl"
    path.write_bytes(damage(path.read_bytes()))
    with pytest.raises(SessionFormatError, match=expect.replace("(", r"\(")):
        SessionManifest.load(w.session_dir)


CHILD = """
import os, signal, sys
from rig.workflow import kinds
from rig.session import journal, writer
from rig.workflow.run import run_procedure
where = sys.argv[2]
if where == "after-journal-line":
    original = writer.SessionWriter.complete_step
    def complete_step(self, index, *args, **kwargs):
        original(self, index, *args, **kwargs)
        if index == 2:
            os.kill(os.getpid(), signal.SIGKILL)
    writer.SessionWriter.complete_step = complete_step
else:  # the manifest compacted at completion, the journal not yet removed
    def remove(session_dir):
        os.kill(os.getpid(), signal.SIGKILL)
    journal.remove = remove
run_procedure(sys.argv[1], out_dir=sys.argv[3], seed=8, time_scale=0)
"""


def _killed_run(tmp_path: Path, where: str) -> Path:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(CHILD), str(PROCEDURES / "six_position.yaml"), where,
                           str(tmp_path / "s")], cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == -signal.SIGKILL, proc.stderr[-3000:]
    (d,) = list((tmp_path / "s").iterdir())
    return d


def test_kill_9_after_a_journal_line_leaves_a_session_that_reads_and_resumes(tmp_path):
    d = _killed_run(tmp_path, "after-journal-line")
    raw = yaml.safe_load((d / "session.yaml").read_text())
    assert raw["status"] == "running" and {s["status"] for s in raw["steps"]} == {"pending"}  # never rewritten
    assert [x["index"] for x in _journal_lines(d)] == [0, 1, 2]
    info, _ = SessionManifest.load(d)
    assert [s.status for s in info.steps] == ["complete"] * 3 + ["pending"] * 3
    assert info.samples_committed_bytes == (d / "samples.csv").stat().st_size
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    s = load_session(d)
    assert s.info.status == "complete" and [s.step_samples(i)["t_s"].size for i in range(6)] == [1000] * 6
    assert not (d / "steps.jsonl").exists() and (d / "calibration.yaml").is_file()


def test_kill_9_between_the_compacted_manifest_and_the_journal_s_removal_changes_nothing(tmp_path, capsys):
    d = _killed_run(tmp_path, "between-manifest-and-journal")
    assert len(_journal_lines(d)) == 6 and yaml.safe_load((d / "session.yaml").read_text())["status"] == "complete"
    folded = SessionManifest.load(d)[0].to_dict()
    alone = copy.deepcopy(yaml.safe_load((d / "session.yaml").read_text()))
    assert folded == SessionManifest.from_mapping(alone).to_dict()  # folding it again changes nothing
    assert main(["solve", str(d), "-o", str(tmp_path / "again.yaml")]) == 0
    assert main(["run", "--resume", str(d), "--time-scale", "0"]) == 2
    assert "already complete" in capsys.readouterr().err


def test_a_manifest_of_ten_thousand_steps_is_read(tmp_path):
    """The most steps a procedure may have, each with the stats a static step records: about 7 MB, beyond the
    4 MiB the reader once refused."""
    w = SessionWriter.create(tmp_path, "sess-1", _manifest(2))
    _step(w, 0)
    w.set_status("aborted")
    doc = yaml.safe_load((w.session_dir / "session.yaml").read_text())
    step = doc["steps"][0]
    step["stats"].update(angles_measured_deg=[0.0, 0.0, 0.0], settle_s=0.0050000000000000044,
                         samples_bytes=[55, 70164], events_bytes=[0, 573], sha256="d4" * 32, events_sha256="14" * 32,
                         noise_g=[0.003379999566692961, 0.003356737249090928, 0.003176692789251002])
    block = dump_yaml([dict(step, index=123456789, name="+Z up #123456789")])  # one step's text, then 10,000
    doc.pop("steps")
    steps = "".join(block.replace("123456789", str(i)) for i in range(10_000))
    (w.session_dir / "session.yaml").write_text(dump_yaml(doc) + "steps:\n" + steps)
    assert (w.session_dir / "session.yaml").stat().st_size > 6 * 1024 * 1024
    info, _ = SessionManifest.load(w.session_dir)
    assert len(info.steps) == 10_000 and info.steps[-1].stats.n_samples == 5
