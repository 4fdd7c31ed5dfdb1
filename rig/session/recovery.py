"""Before a resume or a repair touches a session: do ``samples.csv`` and the manifest agree?

A resume cuts ``samples.csv`` back to ``samples_committed_bytes`` and continues at the first unfinished step;
cutting on the manifest's word alone once cut away finished steps for good (a ``samples_committed_bytes`` of
0 took the header and every row with it). So :func:`check_samples` reads the file first, touching nothing,
and refuses (one SessionFormatError naming the file, the step and the numbers) unless:

- the header is the manifest's ``columns``;
- every finished (complete or flagged) step has as many rows as its ``stats.n_samples``;
- the rows of the finished steps come first, and ``samples_committed_bytes`` is exactly where they end;
- past that point there are only rows of the step in progress (the first unfinished step) and perhaps a
  torn last line (a crash while it was written).

What lies past the committed point is then provably not part of any finished step: a resume cuts it
(:meth:`rig.session.writer.SessionWriter.resume`), and ``rig repair`` (:func:`repair`) cuts it after a
backup, without running anything.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.session import journal
from rig.session.manifest import BASE_COLUMNS, SessionManifest

FINISHED = ("complete", "flagged")
_BLOCK_BYTES = 4 << 20  # samples.csv is scanned in blocks of about this many bytes (whole lines)
_MAX_HEADER_BYTES = 64 * 1024
_MAX_INDEX_DIGITS = 9
_NOTHING_CHANGED = "nothing was changed (rig repair cuts only what lies past the finished steps)"


@dataclass(frozen=True)
class SamplesState:
    """``samples.csv`` as checked against the manifest: ``committed`` is where the finished steps' rows end;
    past it, ``tail_rows`` whole rows of step ``first_step`` (the step in progress) and a torn last line of
    ``torn_bytes``."""

    path: Path
    size: int
    committed: int
    first_step: int
    finished_steps: int
    finished_rows: int
    tail_rows: int
    torn_bytes: int

    @property
    def cut_bytes(self) -> int:
        return self.size - self.committed

    def describe_cut(self) -> str:
        """What lies past the committed point, in words (empty when nothing does)."""
        parts = []
        if self.tail_rows:
            parts.append(f"{self.tail_rows} rows of step {self.first_step + 1} (in progress when the session stopped)")
        if self.torn_bytes:
            parts.append(f"a torn last line of {self.torn_bytes} bytes")
        return " and ".join(parts)


def check_resumable(session_dir, info: SessionManifest) -> SamplesState:
    """Whether the session can be resumed as it is (complete sessions and any disagreement refused);
    reads only."""
    d = Path(session_dir)
    if info.status == "complete":
        raise SessionFormatError(str(d / "session.yaml"), None, "status",
                                 "session is already complete; nothing to resume")
    return check_samples(d, info)


def check_samples(session_dir, info: SessionManifest) -> SamplesState:
    """Check ``samples.csv`` against the manifest (module docstring); reads only, refuses any disagreement."""
    d = Path(session_dir)
    path = d / "samples.csv"
    committed = info.samples_committed_bytes
    if committed is None:
        raise SessionFormatError(str(d / "session.yaml"), None, "samples_committed_bytes",
                                 "missing: where the finished steps' samples end is unknown; " + _NOTHING_CHANGED)
    finished = [s.index for s in info.steps if s.status in FINISHED]
    first = next((s.index for s in info.steps if s.status not in FINISHED), len(info.steps))
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            header_end = _check_header(fh, path, info)
            scan = _Scan(path, info, finished, first)
            scan.read(fh, header_end)
    except FileNotFoundError:
        raise SessionFormatError(str(path), None, None, "missing: the session's samples are gone") from None
    rows_end = max(_check_steps(scan, info, first), header_end)
    if committed > size:
        raise SessionFormatError(str(path), None, None, f"{size} bytes, shorter than the {committed} bytes the manifest "
                                 "records as committed (samples_committed_bytes): the file was cut; " + _NOTHING_CHANGED)
    finished_rows = int(scan.counts[finished].sum())
    if committed != rows_end:
        raise SessionFormatError(str(d / "session.yaml"), None, "samples_committed_bytes",
                                 f"{committed}, but the {len(finished)} finished steps' {finished_rows} rows end at "
                                 f"byte {rows_end} of samples.csv ({scan.last_finished_row()}; the header ends at byte "
                                 f"{header_end}): the manifest and the samples disagree; {_NOTHING_CHANGED}")
    return SamplesState(path, size, committed, first, len(finished), finished_rows,
                        int(scan.counts[first]) if first < len(info.steps) else 0, scan.torn_bytes)


def _check_header(fh, path: Path, info: SessionManifest) -> int:
    """The header must be the manifest's columns; returns where it ends (bytes)."""
    expected = ",".join(info.columns or BASE_COLUMNS)
    line = fh.readline(_MAX_HEADER_BYTES)
    if not line:
        raise SessionFormatError(str(path), None, None, "empty: the header and every row are gone; " + _NOTHING_CHANGED)
    got = line.decode("utf-8", "replace").rstrip("\n")
    if not line.endswith(b"\n") or got != expected or "step" not in expected.split(","):
        raise SessionFormatError(str(path), 1, None, f"the header is {_short(got)!r}, but the manifest's columns are "
                                 f"{_short(expected)!r}; " + _NOTHING_CHANGED)
    return len(line)


def _check_steps(scan: "_Scan", info: SessionManifest, first: int) -> int:
    """Row counts and order; returns the byte where the finished steps' rows end (0: no such row)."""
    for step in info.steps:
        n = step.stats.n_samples if step.stats is not None else None
        if step.status in FINISHED and n is not None and int(scan.counts[step.index]) != int(n):
            raise SessionFormatError(str(scan.path), None, _step_key(step.index),
                                     f"{int(scan.counts[step.index])} rows, but the manifest recorded {int(n)} samples "
                                     f"for this {step.status} step (rows lost or duplicated); {_NOTHING_CHANGED}")
    if scan.stray is not None:
        line, index = scan.stray
        raise SessionFormatError(str(scan.path), line, _step_key(index),
                                 f"a row of step {index + 1}, which the manifest records as "
                                 f"{info.steps[index].status} (only the step in progress, {first + 1}, may have rows "
                                 f"past the finished ones); {_NOTHING_CHANGED}")
    if scan.first_current is not None and scan.first_current[1] < scan.last_finished_end:
        raise SessionFormatError(str(scan.path), scan.first_current[0], _step_key(first),
                                 f"a row of step {first + 1} (not finished) among the rows of the finished steps; "
                                 + _NOTHING_CHANGED)
    return scan.last_finished_end


def _step_key(index: int) -> str:
    """A step as messages that point into samples.csv name it: counted from 1, with its index in the file."""
    return f"step {index + 1} (index {index} in samples.csv)"


def _short(text: str, limit: int = 120) -> str:
    return text if len(text) <= limit else text[:limit] + "..."


class _Scan:
    """The step column of ``samples.csv``, block by block (memory: one block): the rows of every step, where
    the last row of a finished step ends, the first row of the step in progress (file line, where it ends) and
    the first row of any other unfinished step (``stray``: file line, step index)."""

    def __init__(self, path: Path, info: SessionManifest, finished: list[int], first: int) -> None:
        columns = list(info.columns or BASE_COLUMNS)
        self.path, self.n_steps, self.first = path, len(info.steps), first
        self.col, self.ncol = columns.index("step"), len(columns)
        self.counts = np.zeros(max(self.n_steps, 1), np.int64)
        self.done = np.zeros(len(self.counts), bool)
        self.done[finished] = True
        self.torn_bytes = 0
        self.last_finished_end = 0
        self.last_finished: tuple[int, int] | None = None  # (file line, step index) of the last finished row
        self.first_current: tuple[int, int] | None = None
        self.stray: tuple[int, int] | None = None

    def last_finished_row(self) -> str:
        if self.last_finished is None:
            return "no finished step has rows"
        line, index = self.last_finished
        return f"the last, line {line}, is of step {index + 1}"

    def read(self, fh, start: int) -> None:
        offset, line, rest = start, 2, b""
        while True:
            block = fh.read(_BLOCK_BYTES)
            data = rest + block
            if not block:
                self.torn_bytes = len(data)
                return
            whole = data.rfind(b"\n") + 1
            rest = data[whole:]
            if whole:
                steps, ends = self._parse(data[:whole], line)
                self._note(steps, ends + offset, line)
                offset += whole
                line += len(steps)

    def _note(self, steps: np.ndarray, ends: np.ndarray, line: int) -> None:
        self.counts += np.bincount(steps, minlength=len(self.counts))
        done = self.done[steps]
        if done.any():
            k = int(np.flatnonzero(done)[-1])
            self.last_finished_end, self.last_finished = int(ends[k]), (line + k, int(steps[k]))
        stray = ~done & (steps != self.first)
        if self.stray is None and stray.any():
            k = int(np.argmax(stray))
            self.stray = (line + k, int(steps[k]))
        current = np.flatnonzero(steps == self.first)
        if self.first_current is None and len(current):
            self.first_current = (line + int(current[0]), int(ends[current[0]]))

    def _parse(self, buf: bytes, first_line: int) -> tuple[np.ndarray, np.ndarray]:
        """The step index of every line of ``buf`` (whole lines) and where each line ends in ``buf``."""
        a = np.frombuffer(buf, np.uint8)
        nl = np.flatnonzero(a == 10)
        commas = np.flatnonzero(a == 44)
        per_line = np.diff(np.concatenate([[0], np.searchsorted(commas, nl)]))
        ragged = np.flatnonzero(per_line != self.ncol - 1)
        if len(ragged):
            raise SessionFormatError(str(self.path), first_line + int(ragged[0]), None,
                                     f"expected {self.ncol} comma-separated fields as in the header; {_NOTHING_CHANGED}")
        commas = commas.reshape(len(nl), self.ncol - 1)
        lo = np.concatenate([[0], nl[:-1] + 1]) if self.col == 0 else commas[:, self.col - 1] + 1
        hi = nl if self.col == self.ncol - 1 else commas[:, self.col]
        return self._indices(a, lo, hi, first_line), nl + 1

    def _indices(self, a: np.ndarray, lo: np.ndarray, hi: np.ndarray, first_line: int) -> np.ndarray:
        """The step cells as integers (plain digits, as the writer writes them); anything else is refused."""
        width = hi - lo
        value = np.zeros(len(lo), np.int64)
        bad = (width < 1) | (width > _MAX_INDEX_DIGITS)
        for j in range(0 if bad.any() else int(width.max(initial=0))):
            use = width > j
            digit = a[np.where(use, lo + j, 0)].astype(np.int64) - 48
            bad |= use & ((digit < 0) | (digit > 9))
            value = np.where(use, value * 10 + digit, value)
        bad |= value >= self.n_steps
        if bad.any():
            k = int(np.argmax(bad))
            cell = bytes(a[lo[k]:hi[k]]).decode("utf-8", "replace")
            raise SessionFormatError(str(self.path), first_line + k, "step",
                                     f"expected a step of the manifest (0..{self.n_steps - 1}), got {_short(cell, 40)!r}; "
                                     + _NOTHING_CHANGED)
        return value


# -- rig repair ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Repair:
    """What :func:`repair` did: ``cut`` (the state it cut back, None when nothing lay past the finished steps),
    the backups written, and a torn journal line dropped (bytes)."""

    session_dir: Path
    state: SamplesState
    backups: tuple[Path, ...]
    journal_torn_bytes: int

    @property
    def changed(self) -> bool:
        return bool(self.backups)

    def summary(self) -> str:
        if not self.changed:
            return (f"{self.session_dir}: nothing to cut: samples.csv ends where its {self.state.finished_steps} "
                    f"finished steps end ({self.state.finished_rows} rows, {self.state.committed} bytes)")
        cut = []
        if self.state.cut_bytes:
            cut.append(f"{self.state.cut_bytes} bytes of samples.csv past its {self.state.finished_steps} finished "
                       f"steps: {self.state.describe_cut()}")
        if self.journal_torn_bytes:
            cut.append(f"a torn last line of steps.jsonl ({self.journal_torn_bytes} bytes: a step that was not finished)")
        return (f"{self.session_dir}: cut {'; and '.join(cut)}; backup: "
                + ", ".join(str(p) for p in self.backups))


def repair(session_dir, now: datetime | None = None) -> Repair:
    """Cut back what is provably past the last finished step (:func:`check_samples`: the rows of the step in
    progress, a torn last line; and a torn last line of the steps journal), after a backup of each file cut
    (``samples.csv.bak-<UTC stamp>``). Anything else is refused as a resume refuses it, nothing touched.
    The caller holds the session's lock."""
    d = Path(session_dir)
    info, _ = SessionManifest.load(d)
    state = check_samples(d, info)
    _, journal_torn = journal.read(d)
    stamp = (now or datetime.now(timezone.utc)).strftime("%Y%m%dT%H%M%SZ")
    backups = []
    for path, keep, torn in ((state.path, state.committed, state.cut_bytes),
                             (journal.journal_path(d), None, journal_torn)):
        if torn:
            size = path.stat().st_size
            backups.append(_backup(path, stamp))
            cut_to(path, keep if keep is not None else size - torn)
    if backups:
        note_in_events(d, f"rig repair: {Repair(d, state, tuple(backups), journal_torn).summary()}")
    return Repair(d, state, tuple(backups), journal_torn)


def _backup(path: Path, stamp: str) -> Path:
    """A durable copy of ``path`` beside it, ``NAME.bak-STAMP`` (``-2``, ``-3``, ... when taken)."""
    target, k = path.with_name(f"{path.name}.bak-{stamp}"), 1
    while target.exists():
        k += 1
        target = path.with_name(f"{path.name}.bak-{stamp}-{k}")
    with open(path, "rb") as src, open(target, "xb") as dst:
        shutil.copyfileobj(src, dst, 1 << 20)
        dst.flush()
        os.fsync(dst.fileno())
    _fsync_dir(path.parent)
    return target


def cut_to(path: Path, size: int) -> None:
    """Truncate ``path`` to ``size`` bytes, durably."""
    with open(path, "r+b") as fh:
        fh.truncate(size)
        fh.flush()
        os.fsync(fh.fileno())


def note_in_events(session_dir: Path, message: str) -> None:
    """A warning event (a torn last event line, a crash's, is ended first so the new line stays whole)."""
    path = Path(session_dir) / "events.jsonl"
    end_torn_line(path)
    record = {"utc": datetime.now(timezone.utc).isoformat(timespec="milliseconds"), "kind": "warning",
              "message": message}
    with open(path, "a") as fh:
        fh.write(json.dumps(record) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def end_torn_line(path: Path) -> None:
    """End a torn last line of a line file (a crash while it was written) so that what is appended next is a
    line of its own; readers skip the damaged line."""
    try:
        with open(path, "rb+") as fh:
            if fh.seek(0, os.SEEK_END) and (fh.seek(-1, os.SEEK_END), fh.read(1))[1] != b"\n":
                fh.write(b"\n")
                fh.flush()
                os.fsync(fh.fileno())
    except FileNotFoundError:
        return


def _fsync_dir(d: Path) -> None:
    fd = os.open(d, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
