"""A recorded run's per-step durability is unchanged by the import's batched fsyncs (docs/faults.md, kill -9):
each finished step is fsynced (samples.csv) and recorded by one fsynced line of the steps journal; only a writer
made with ``durable_steps=False`` (an import, renamed into place complete) batches them. And the cost of a
finished step does not grow with the session: setting the manifest's ``samples_committed_bytes`` does not check
every step again (it did: a 10,000-step import spent 12 s there)."""

from __future__ import annotations

import os

import pytest

from rig.errors import SessionFormatError
from rig.session import SessionManifest, SessionWriter
from rig.session.journal import JOURNAL_NAME
from rig.session.manifest import ProcedureInfo, RigInfo, SensorInfo, StepRecord


def _manifest(sid: str, steps: int) -> SessionManifest:
    return SessionManifest(id=sid, procedure=ProcedureInfo(name="p"),
                           rig=RigInfo(kind="sim", sensor=SensorInfo(accel_lsb_per_g=16384, sample_rate_hz=100)),
                           steps=[StepRecord(index=i, name=f"s{i}", f_nominal=[0, 0, 1]) for i in range(steps)])


def _record(tmp_path, monkeypatch, durable: bool, steps: int = 5):
    calls = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (calls.append(fd), real(fd))[1])
    w = SessionWriter.create(tmp_path, f"d{int(durable)}", _manifest(f"d{int(durable)}", steps),
                             durable_steps=durable)
    per_step, journal_seen = [], []
    for i in range(steps):
        before = len(calls)
        w.append_samples(i, [i + 0.0, i + 0.5], [[0, 0, 16384], [1, 0, 16383]])
        w.complete_step(i, {"n_samples": 2})
        per_step.append(len(calls) - before)
        journal_seen.append((w.session_dir / JOURNAL_NAME).exists())
    w.set_status("complete")
    monkeypatch.undo()
    return w, per_step, journal_seen


def test_a_recorded_run_fsyncs_every_finished_step(tmp_path, monkeypatch):
    w, per_step, journal_seen = _record(tmp_path, monkeypatch, durable=True)
    assert per_step == [2] * 5  # samples.csv, then the step's journal line
    assert all(journal_seen)
    info, _ = SessionManifest.load(w.session_dir)
    assert [s.status for s in info.steps] == ["complete"] * 5 and info.seal is not None


def test_only_an_import_writer_batches_its_fsyncs(tmp_path, monkeypatch):
    w, per_step, journal_seen = _record(tmp_path, monkeypatch, durable=False)
    assert per_step == [0] * 5 and not any(journal_seen)
    info, _ = SessionManifest.load(w.session_dir)  # the same session at the end, sealed
    assert [s.status for s in info.steps] == ["complete"] * 5 and info.seal is not None
    assert info.samples_committed_bytes == (w.session_dir / "samples.csv").stat().st_size


class _Counting(list):
    iterated = 0

    def __iter__(self):
        type(self).iterated += 1
        return super().__iter__()


def test_setting_a_field_does_not_check_every_step_again(tmp_path):
    info = _manifest("c", 50)
    object.__setattr__(info, "__dict__", {**info.__dict__, "steps": _Counting(info.steps)})
    _Counting.iterated = 0
    info.samples_committed_bytes = 1234
    info.status = "complete"
    assert _Counting.iterated == 0
    assert info.samples_committed_bytes == 1234


def test_a_step_out_of_place_is_still_refused(tmp_path):
    doc = _manifest("x", 3).to_dict()
    doc["steps"][1]["index"] = 3
    with pytest.raises(SessionFormatError, match=r"steps\[1\]: expected a step mapping with index 1, got index 3"):
        SessionManifest.from_mapping(doc)
