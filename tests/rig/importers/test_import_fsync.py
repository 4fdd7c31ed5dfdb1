"""An import fsyncs at the points that matter for an import (issue 32 item 5, issue 34 items 4 and 7): it writes
into a partial directory renamed into place at the end, so each file is fsynced once before the rename and the
sessions directory once after it, whatever the number of steps (it was two fsyncs a step: samples.csv and the steps
journal, a recorded run's per-step durability). A recorded run keeps its per-step durability
(tests/rig/session/test_writer_durability.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from rig.importers.recordings import import_recording
from rig.session.seal import verify_session

HEAD = "# units: g\nt_s,ax,ay,az,label\n"
FACES = [("+X up", (1, 0, 0)), ("-X up", (-1, 0, 0)), ("+Y up", (0, 1, 0)), ("-Y up", (0, -1, 0)),
         ("+Z up", (0, 0, 1)), ("-Z up", (0, 0, -1))]


def _csv(path: Path, steps: int, rows: int = 10) -> Path:
    lines, t = [], 0.0
    for k in range(steps):
        name, f = FACES[k % 6]
        for i in range(rows):
            noise = 0.001 * ((i * 7 + k) % 5 - 2)
            lines.append(f"{t:.2f},{f[0] + noise:.4f},{f[1] - noise:.4f},{f[2] + 0.5 * noise:.4f},{name}")
            t += 0.01
    path.write_text(HEAD + "\n".join(lines) + "\n")
    return path


def _fsyncs(monkeypatch) -> list[str]:
    """What each os.fsync call makes durable (the path of its descriptor, read from /proc)."""
    calls: list[str] = []
    real = os.fsync

    def counting(fd):
        fd = fd if isinstance(fd, int) else fd.fileno()
        try:
            calls.append(os.readlink(f"/proc/self/fd/{fd}"))
        except OSError:
            calls.append("?")
        return real(fd)
    monkeypatch.setattr(os, "fsync", counting)
    return calls


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc to name the files fsynced")
def test_an_import_fsyncs_each_file_once_whatever_its_steps(tmp_path, monkeypatch):
    counts = {}
    for steps in (12, 60):
        src = _csv(tmp_path / f"r{steps}.csv", steps)
        root = tmp_path / f"s{steps}"
        calls = _fsyncs(monkeypatch)
        final = import_recording("csv", src, root, f"r{steps}")
        monkeypatch.undo()
        counts[steps] = len(calls)
        names = [Path(c).name for c in calls]
        # samples.csv and events.jsonl once each (at the end), session.yaml by its atomic writes (the manifest,
        # then the seal appended), the session directory with them, the sessions directory after the rename
        assert names.count("samples.csv") == 1, calls
        assert names.count("events.jsonl") == 1, calls
        assert not any("steps.jsonl" in c for c in calls), calls  # no steps journal in an import
        assert sum(".session.yaml." in c for c in calls) >= 1, calls
        assert str(root.resolve()) == calls[-1], calls  # the rename made durable: the sessions directory, last
        assert len(calls) <= 8, calls
        # the session written without per-step fsyncs is sealed and intact, and has no journal left
        found = verify_session(final)
        assert found.sealed and found.steps == steps
        assert not (final / "steps.jsonl").exists()
    assert counts[12] == counts[60], counts  # was 2 per step: 2 * 12 + c vs 2 * 60 + c
