"""Writing a session: :class:`SessionWriter` (docs/session-format.md).

- ``session.yaml``: the manifest, written atomically (temp file, fsync, rename) at the start, and compacted
  (the steps journal folded in) when the session ends or is resumed;
- ``steps.jsonl``: the steps journal (:mod:`rig.session.journal`): one fsynced line per finished step, so a
  step costs the same whatever the number of steps;
- ``samples.csv``: append-only raw samples, fsynced at every step end;
- ``events.jsonl``: one JSON object per line (moves, settles, warnings, errors, prompts).

Nothing is lost: a crash loses at most the step in progress, and :meth:`SessionWriter.resume` cuts
``samples.csv`` back to the last fsynced step so no step is ever duplicated, after checking that the file
agrees with the manifest (:func:`rig.session.recovery.check_resumable`: a disagreement is refused, nothing
touched).

A writer made with ``durable_steps=False`` (an import: :mod:`rig.importers.recordings`, which writes into a
partial directory renamed into place at the end, so a killed import leaves no session whatever was
written) skips all of the per-step durability: no fsync and no journal line per step, no manifest before
the end. Each file is fsynced once when the session ends (:meth:`SessionWriter.set_status`: ``samples.csv``
and ``events.jsonl`` at close, ``session.yaml`` by its atomic write, with the directory), before the
caller's rename. A recorded run (``durable_steps=True``, the default) is unchanged.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import yaml

from calib.file.calibration import atomic_write_text
from rig.errors import SessionFormatError
from rig.session import journal
from rig.session.manifest import (BASE_COLUMNS, FORMAT, STATUSES, STEP_STATUSES, SessionManifest, as_manifest,
                                  validate_session_id,
                                  utc_now)
from rig.session.recovery import check_resumable, cut_to, end_torn_line
from rig.session.seal import Chains, seal_session

_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml when present: 10x faster
DEFAULT_COLUMNS = BASE_COLUMNS + ("a1_deg", "a2_deg", "a3_deg")


def dump_yaml(doc) -> str:
    return yaml.dump(doc, Dumper=_DUMPER, sort_keys=False, allow_unicode=True)


def plain(v):
    """Plain YAML/JSON-safe values (numpy scalars/arrays to Python; NaN to None)."""
    if isinstance(v, dict):
        return {str(k): plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return plain(v.tolist())
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and v != v:
        return None
    return v


def new_manifest_dict(session_id: str, manifest, columns: tuple[str, ...]) -> dict:
    """The manifest of a new session as written: ``format`` and ``id`` first, then the caller's keys
    (a :class:`SessionManifest` or a mapping, validated), then ``columns``."""
    given = manifest.to_dict() if isinstance(manifest, SessionManifest) else dict(manifest)
    m = {"format": FORMAT, "id": session_id}
    m.update({k: v for k, v in given.items() if k not in ("format", "id")})
    m.setdefault("created", utc_now())
    m.setdefault("status", "running")
    m["columns"] = list(columns)
    m = plain(m)
    as_manifest(m)  # what is written can be read back
    return m


class SessionWriter:
    """Writes one session directory. Create with :meth:`create` or :meth:`resume`.

    :attr:`info` is the typed manifest (:class:`SessionManifest`) as recorded so far (``session.yaml`` with
    ``steps.jsonl`` folded in); the writer changes it (validated on assignment): a finished step is one
    journal line, every other change rewrites ``session.yaml`` (compacted: the journal folded in and removed).
    """

    def __init__(self, session_dir: Path, info: SessionManifest, columns: tuple[str, ...],
                 chains: Chains | None = None, *, durable_steps: bool = True) -> None:
        self.session_dir = Path(session_dir)
        self.info = info
        self.columns = columns
        #: False: an import's writer (module docstring): the files fsynced once at the end, no steps journal
        self.durable_steps = durable_steps
        # the files' hashes kept as they are written (rig.session.seal): a step's link and the seal read nothing back
        self._chains = chains if chains is not None else Chains.from_files(self.session_dir, info)
        self._samples = open(self.session_dir / "samples.csv", "ab")
        self._events = open(self.session_dir / "events.jsonl", "ab")
        self._journal = None  # steps.jsonl, opened at the first finished step after the manifest was written

    # -- construction ------------------------------------------------------------------
    @classmethod
    def create(cls, sessions_root, session_id: str, manifest: SessionManifest | dict,
               columns: tuple[str, ...] | None = None, *, durable_steps: bool = True) -> "SessionWriter":
        """Create ``sessions_root/session_id`` and write the manifest and the CSV header.

        ``manifest``: a :class:`SessionManifest` or a mapping of the same keys (``format``, ``id``,
        ``columns`` and ``samples_committed_bytes`` are set here; ``created`` and ``status`` default).
        ``durable_steps=False``: only for a directory that is renamed into place once complete (an import):
        nothing is fsynced and no manifest is written until :meth:`set_status` (module docstring).
        """
        validate_session_id(session_id)
        columns = tuple(columns) if columns else DEFAULT_COLUMNS
        root = Path(sessions_root)
        root.mkdir(parents=True, exist_ok=True)
        d = root / session_id
        if d.resolve().parent != root.resolve():
            raise SessionFormatError(str(d), None, "id", "session directory would be outside the sessions root")
        m = new_manifest_dict(session_id, manifest, columns)
        d.mkdir(exist_ok=False)
        header = ",".join(columns) + "\n"
        with open(d / "samples.csv", "wb") as fh:
            fh.write(header.encode())
            if durable_steps:
                fh.flush()
                os.fsync(fh.fileno())
        m["samples_committed_bytes"] = len(header.encode())
        (d / "events.jsonl").touch()
        if durable_steps:
            atomic_write_text(d / "session.yaml", dump_yaml(m))
        w = cls(d, as_manifest(m), columns, Chains.fresh(header.encode()), durable_steps=durable_steps)
        w.event("start", session=session_id)
        return w

    @classmethod
    def resume(cls, session_dir) -> tuple["SessionWriter", int]:
        """Reopen an interrupted session; return the writer and the first incomplete step.

        First ``samples.csv`` is checked against the manifest, touching nothing
        (:func:`rig.session.recovery.check_resumable`: any disagreement is one SessionFormatError); then
        what lies past the last finished step (the samples of the step that was in progress, a torn last
        line) is cut away and the manifest compacted (the steps journal folded in).
        """
        d = Path(session_dir)
        info, _ = SessionManifest.load(d)
        state = check_resumable(d, info)
        if state.cut_bytes:
            cut_to(state.path, state.committed)
        end_torn_line(d / "events.jsonl")
        info.status = "running"
        w = cls(d, info, tuple(info.columns or BASE_COLUMNS))
        w._write_manifest()
        if state.cut_bytes:
            w.event("warning", message=f"discarded {state.cut_bytes} bytes of samples past the finished steps when "
                                       f"the session stopped: {state.describe_cut()}")
        return w, state.first_step

    # -- writing -----------------------------------------------------------------------
    def append_samples(self, step_index: int, t_s, accel_counts, temp_c=None, gyro_counts=None,
                       mag_counts=None, angles_deg=None) -> None:
        """Append samples of one step (streamed; durable at :meth:`complete_step`)."""
        t = np.asarray(t_s, float)
        n = len(t)
        if n == 0:
            return
        cols: dict[str, np.ndarray | None] = {"t_s": t, "step": np.full(n, int(step_index))}
        for names, values, dtype in ((("ax", "ay", "az"), accel_counts, np.int64),
                                     (("wx", "wy", "wz"), gyro_counts, np.int64),
                                     (("mx", "my", "mz"), mag_counts, float),  # NaN rows -> empty cells
                                     (("a1_deg", "a2_deg", "a3_deg"), angles_deg, float)):
            if values is not None:
                v = np.asarray(values, dtype)
                cols.update({c: v[:, j] for j, c in enumerate(names)})
        cols["temp_c"] = np.asarray(temp_c, float) if temp_c is not None else None
        self._append(self._samples, "samples.csv", format_rows(self.columns, cols, n).encode())

    def complete_step(self, index: int, stats: dict, status: str = "complete") -> None:
        """Make the step's samples durable (flush + fsync), then record it: one fsynced line of the steps
        journal (the step is finished when this returns). Without ``durable_steps`` (an import) the step is
        recorded in memory only, made durable with the whole session at :meth:`set_status`."""
        if status not in STEP_STATUSES:
            raise ValueError(f"unknown step status {status!r}")
        if self.durable_steps:
            self._samples.flush()
            os.fsync(self._samples.fileno())
        stats = self._chains.link(self.session_dir, self.info, index, stats)  # the step's link (rig.session.seal)
        self.info.samples_committed_bytes = int(stats["samples_bytes"][1])
        step = self.info.steps[index]
        step.status = status
        step.stats = plain(stats)
        self._record_step(index)

    def event(self, kind: str, **fields) -> None:
        rec = {"utc": utc_now(), "kind": kind}
        rec.update(plain(fields))
        self._append(self._events, "events.jsonl", (json.dumps(rec, allow_nan=False, default=str) + "\n").encode())
        self._events.flush()

    def set_status(self, status: str) -> None:
        if status not in STATUSES:
            raise ValueError(f"unknown session status {status!r}")
        self.info.status = status
        if status != "running":
            self.info.ended = utc_now()
        text, doc = self._write_manifest()
        if status != "running":
            self.close()
        if status == "complete":  # the whole record sealed (rig.session.seal), from what was written: nothing re-read
            self.info.seal = seal_session(self.session_dir, text=text, digests=self._chains.digests(), doc=doc)

    def close(self) -> None:
        self._close_journal()
        for fh in (self._samples, self._events):
            if not fh.closed:
                fh.flush()
                os.fsync(fh.fileno())
                fh.close()

    def _record_step(self, index: int) -> None:
        """A finished step's line in the journal (a status the journal does not hold: the whole manifest)."""
        step = self.info.steps[index]
        if not self.durable_steps:
            return  # written with the manifest at the end
        if step.status not in journal.FINISHED:
            self._write_manifest()
            return
        if self._journal is None:
            self._journal = open(journal.journal_path(self.session_dir), "ab")
        stats = step.model_dump(mode="python", by_alias=True, exclude_unset=True).get("stats")
        journal.append(self._journal, journal.record_line(index, step.status, plain(stats),
                                                          self.info.samples_committed_bytes or 0))

    def _write_manifest(self) -> tuple[str, dict]:
        """Compact: the whole manifest, atomically (the journal's lines are in it), then the journal removed; the
        text written and the plain mapping it is the YAML of (what a reader of the text gets)."""
        doc = plain(self.info.to_dict())
        text = dump_yaml(doc)
        atomic_write_text(self.session_dir / "session.yaml", text)
        self._close_journal()
        journal.remove(self.session_dir)
        return text, doc

    def _append(self, fh, name: str, data: bytes) -> None:
        fh.write(data)
        self._chains.wrote(name, data)

    def _close_journal(self) -> None:
        if self._journal is not None and not self._journal.closed:
            self._journal.close()
        self._journal = None


def format_rows(columns, cols: dict, n: int | None = None) -> str:
    """Rows of samples.csv (no header; each line ended) of the values ``cols`` (column -> (N,) array; a missing
    column's cells empty), as the writer formats them: what an archive writes back (:mod:`rig.archive.store`).

    One ``%`` format per row over the columns' Python values (``tolist``), the cells' text that of ``%`` on each
    value (what ``np.char.mod`` applies cell by cell, at a sixth of its cost: 4 against 24 ms for 2,000 rows; this
    formatting was 7 % of the test suite's time); a column with empty cells (not finite) is formatted cell by cell."""
    if n is None:
        n = len(next(v for v in cols.values() if v is not None)) if cols else 0
    if n == 0:
        return ""
    formats, values = [], []
    for c in columns:
        fmt, v = _cell_format(c), cols.get(c)
        if v is None:
            formats.append("")
            continue
        if c in ("temp_c", "mx", "my", "mz"):
            ok = np.isfinite(v)
            cast = v if c == "temp_c" else np.where(ok, v, 0).astype(np.int64)
            if not ok.all():
                formats.append("%s")
                values.append([fmt % x if good else "" for x, good in zip(cast.tolist(), ok.tolist())])
                continue
            v = cast
        formats.append(fmt)
        values.append(np.asarray(v).tolist())
    line = ",".join(formats) + "\n"
    if not values:
        return line * n
    return "".join([line % row for row in zip(*values)])


def _cell_format(c: str) -> str:
    """The ``%`` format of one column's cells in samples.csv."""
    if c == "t_s" or c.endswith("_deg"):
        return "%.5f"
    return "%.4f" if c == "temp_c" else "%d"
