"""The steps journal, ``SESSION/steps.jsonl``: one line per finished step while a session is recorded.

A finished step is recorded by appending one JSON line (``index``, ``status``, ``stats``,
``samples_committed_bytes``) and fsyncing it, instead of rewriting the whole manifest: the cost of a step
no longer grows with the number of steps. ``session.yaml`` is compacted (the journal folded in, the
journal removed) when the session ends (complete or aborted); a crash leaves ``session.yaml`` plus
``steps.jsonl``, and every reader folds the journal in (:func:`fold`). A torn last line (no newline: the
crash came while it was written) is ignored: that step was not finished. Any other damage is refused, one
line naming ``steps.jsonl`` and the line.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from rig.errors import SessionFormatError

JOURNAL_NAME = "steps.jsonl"
#: the statuses a journal line may record: only finished steps are journalled
FINISHED = ("complete", "flagged")
#: a journal line is about 300 bytes (a ramp step's stats about 600); 10,000 steps stay far below this
MAX_BYTES = 64 * 1024 * 1024
KEYS = ("index", "status", "stats", "samples_committed_bytes")


def journal_path(session_dir) -> Path:
    return Path(session_dir) / JOURNAL_NAME


def record_line(index: int, status: str, stats, committed: int) -> bytes:
    """The journal line of one finished step (``stats`` plain values: NaN already None)."""
    rec = {"index": int(index), "status": status, "stats": stats, "samples_committed_bytes": int(committed)}
    return (json.dumps(rec, separators=(",", ":")) + "\n").encode()


def append(fh, line: bytes) -> None:
    """Append one line and make it durable (the step is finished when this returns)."""
    fh.write(line)
    fh.flush()
    os.fsync(fh.fileno())


def read(session_dir) -> tuple[list[dict], int]:
    """The whole lines of the journal (parsed) and the length of a torn last line in bytes (0: none);
    ``([], 0)`` without a journal. Damage other than a torn last line is one SessionFormatError."""
    path = journal_path(session_dir)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_BYTES + 1)
    except FileNotFoundError:
        return [], 0
    except IsADirectoryError:
        raise SessionFormatError(str(path), None, None, "is a directory, expected the steps journal") from None
    if len(data) > MAX_BYTES:
        raise SessionFormatError(str(path), None, None, f"larger than {MAX_BYTES // (1024 * 1024)} MiB: not a steps "
                                 "journal")
    whole = data.rfind(b"\n") + 1
    records = []
    for number, line in enumerate(data[:whole].split(b"\n")[:-1], start=1):
        try:
            rec = json.loads(line)
        except ValueError:
            raise SessionFormatError(str(path), number, None, "not a JSON line (the journal was damaged)") from None
        records.append(_checked(rec, path, number))
    return records, len(data) - whole


def _checked(rec, path: Path, number: int) -> dict:
    if not isinstance(rec, dict) or set(rec) != set(KEYS):
        raise SessionFormatError(str(path), number, None, f"expected a mapping of {', '.join(KEYS)}")
    index, committed = rec["index"], rec["samples_committed_bytes"]
    if not isinstance(index, int) or isinstance(index, bool) or index < 0:
        raise SessionFormatError(str(path), number, "index", f"expected a step index (0, 1, ...), got {index!r}")
    if rec["status"] not in FINISHED:
        raise SessionFormatError(str(path), number, "status", f"expected complete or flagged, got {rec['status']!r}")
    if not isinstance(rec["stats"], dict):
        raise SessionFormatError(str(path), number, "stats", "expected a mapping")
    if not isinstance(committed, int) or isinstance(committed, bool) or committed < 0:
        raise SessionFormatError(str(path), number, "samples_committed_bytes",
                                 f"expected a byte count (0, 1, ...), got {committed!r}")
    return rec


def fold(doc, records: list[dict], session_dir) -> None:
    """Apply the journal's lines to the manifest mapping ``doc`` as read (in place): each line sets its step's
    ``status`` and ``stats`` and the manifest's ``samples_committed_bytes``. Folding a journal twice (a crash
    between the compacted manifest and the journal's removal) changes nothing."""
    if not records or not isinstance(doc, dict) or not isinstance(doc.get("steps"), list):
        return  # nothing to fold, or a manifest the model refuses anyway
    steps = doc["steps"]
    for number, rec in enumerate(records, start=1):
        i = rec["index"]
        if i >= len(steps) or not isinstance(steps[i], dict):
            raise SessionFormatError(str(journal_path(session_dir)), number, "index",
                                     f"step {i} is not in the manifest (0..{len(steps) - 1})")
        steps[i]["status"] = rec["status"]
        steps[i]["stats"] = rec["stats"]
        doc["samples_committed_bytes"] = rec["samples_committed_bytes"]


def remove(session_dir) -> None:
    """Remove the journal once the manifest holds what it said (the manifest was written and fsynced first)."""
    try:
        os.unlink(journal_path(session_dir))
    except FileNotFoundError:
        return
    fd = os.open(session_dir, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
