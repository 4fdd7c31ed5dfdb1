"""``rig archive``: session directories into a partitioned Parquet dataset, and back.

Layout of ``ARCHIVE/`` (hive partitions by the month the session was created, ``month=2026-11``):

- ``sessions/``: one row per session: ``session_id``, ``content_hash`` (sha256 over the session's recording files,
  name and bytes, in name order: :data:`RECORDING_FILES`), identity columns from the manifest (``sensor_key``, ``model``, ``serial``, ``rig_kind``,
  ``rig_file``, ``procedure``, ``created``, ``status``, ``n_steps``, ``lot``), ``columns`` (samples.csv's header);
- ``steps/``: one row per step: ``session_id``, ``index``, ``name``, ``kind``, ``status``, ``n_samples``,
  ``temp_c``;
- ``samples/``: every sample: ``session_id`` and samples.csv's columns as numbers (float64; empty cells NaN);
- ``files/``: every other file of the session (``session.yaml``, ``events.jsonl``, ``sim_truth.yaml``,
  ``calibration*.yaml``, ...): ``session_id``, ``name``, ``data`` (bytes).

Each ``rig archive`` call appends one Parquet file per table and partition; a session already in the archive
with the same content hash is skipped (appending is idempotent), one with the same id and other content is
refused. :func:`extract_session` writes a session back as a directory: its files as they were and samples.csv
formatted as the session writer formats it, so the seal verifies.
"""

from __future__ import annotations

import hashlib
import os
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.dataset as ds
import pyarrow.parquet as pq

from rig.analysis.sensor_key import sensor_identity
from rig.errors import RigInputError
from rig.session import load_session
from rig.session.writer import format_rows

#: rows per Parquet row group: about 50 six-face sessions of samples, so that reading a chunk of sessions (filtered by
#: id, which Parquet prunes by each row group's id range) decodes about the chunk's own rows (before, one
#: row group of pyarrow's default, about 10^6 rows: a 50-session chunk decoded 1.2 million rows, 350 MB a worker)
ROW_GROUP_ROWS = 64 * 1024
TABLES = ("sessions", "steps", "samples", "files")
#: files a session directory holds that are not part of its record (a lock of a run in progress)
SKIPPED_FILES = ("session.lock",)


@dataclass
class ArchiveReport:
    """What an archive call did: sessions added, skipped (already there, same content) and refused (one line each)."""

    added: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    refused: list[str] = field(default_factory=list)


#: the files that are the recording (rig-session/1); the others (calibrations, reports, plots, discover's output)
#: are made from it, kept in the archive as they were when the session was first added, and not in its hash
RECORDING_FILES = ("session.yaml", "samples.csv", "events.jsonl", "steps.jsonl", "sim_truth.yaml")


def content_hash(session_dir: Path) -> str:
    """sha256 over the session's recording (:data:`RECORDING_FILES` present: each name, its length and its bytes,
    in name order): a re-solve that adds a calibration file leaves it unchanged."""
    h = hashlib.sha256()
    for p in sorted(session_dir.iterdir()):
        if p.is_file() and p.name in RECORDING_FILES:
            data = p.read_bytes()
            h.update(p.name.encode() + b"\0" + str(len(data)).encode() + b"\0" + data)
    return h.hexdigest()


def _month(created: str | None) -> str:
    return (created or "unknown")[:7] or "unknown"


def _session_tables(session_dir: Path, lot: str | None) -> dict[str, pa.Table]:
    """The four tables' rows of one session (loaded and checked as ``rig solve`` loads it)."""
    s = load_session(session_dir)
    info = s.info
    sid = info.id
    with open(session_dir / "samples.csv", encoding="utf-8") as fh:
        header = fh.readline().strip().split(",")
    sensor = info.rig.sensor
    key = sensor_identity(info.to_dict(), SimpleNamespace(sensor=None))["key"]  # as the history keys the unit
    sessions = pa.table({
        "session_id": [sid], "content_hash": [content_hash(session_dir)],
        "sensor_key": [key],
        "model": [str(sensor.model or "")], "serial": [str(sensor.serial or "")],
        "rig_kind": [str(info.rig.kind or "")], "rig_file": [str(info.rig.rig_file or "")],
        "procedure": [str(info.procedure.name if info.procedure is not None else "")],
        "created": [str(info.created or "")], "status": [str(info.status)], "n_steps": [len(info.steps)],
        "lot": [lot or ""], "columns": [",".join(header)], "month": [_month(info.created)]})
    steps = pa.table({
        "session_id": [sid] * len(info.steps), "index": [st.index for st in info.steps],
        "name": [st.name for st in info.steps], "kind": [st.kind for st in info.steps],
        "status": [st.status for st in info.steps],
        "n_samples": [int(st.stats.n_samples) if st.stats is not None and st.stats.n_samples is not None else 0
                      for st in info.steps],
        "temp_c": [float(st.stats.temp_c) if st.stats is not None and st.stats.temp_c is not None else np.nan
                   for st in info.steps],
        "month": [_month(info.created)] * len(info.steps)})
    parsed = pacsv.read_csv(session_dir / "samples.csv", convert_options=pacsv.ConvertOptions(
        column_types={c: pa.float64() for c in header}, strings_can_be_null=True))
    n = parsed.num_rows
    samples = pa.table({"session_id": pa.array([sid] * n, pa.string()),
                        **{c: pa.array(parsed.column(c).to_numpy(zero_copy_only=False), pa.float64())
                           for c in header},  # an empty cell (no reading) is NaN, as the session reader has it
                        "month": pa.array([_month(info.created)] * n, pa.string())})
    names = sorted(p.name for p in session_dir.iterdir()
                   if p.is_file() and p.name not in SKIPPED_FILES and p.name != "samples.csv")
    files = pa.table({"session_id": [sid] * len(names), "name": names,
                      "data": pa.array([(session_dir / n).read_bytes() for n in names], pa.binary()),
                      "month": [_month(info.created)] * len(names)})
    return {"sessions": sessions, "steps": steps, "samples": samples, "files": files}


def _dataset(archive: Path, table: str) -> ds.Dataset | None:
    where = archive / table
    if not where.is_dir():
        return None
    try:
        return ds.dataset(where, format="parquet", partitioning="hive")
    except (pa.ArrowInvalid, OSError) as exc:
        raise RigInputError(str(where), None, None, f"not a readable archive table: {exc}") from None


def read_table(archive, table: str, columns=None, session_ids=None) -> pa.Table:
    """One table of the archive (``session_ids``: only those sessions' rows); one-line RigInputError for a damaged
    file (which file, and why)."""
    d = _dataset(Path(archive), table)
    if d is None:
        return pa.table({})
    flt = ds.field("session_id").isin(list(session_ids)) if session_ids is not None else None
    try:
        return d.to_table(columns=columns, filter=flt)
    except (pa.ArrowInvalid, OSError) as exc:
        raise RigInputError(str(Path(archive) / table), None, None, f"a damaged archive file: {exc}") from None


def archived(archive) -> dict[str, str]:
    """session_id -> content hash of every session in the archive."""
    t = read_table(archive, "sessions", columns=["session_id", "content_hash"])
    if t.num_rows == 0:
        return {}
    return dict(zip(t.column("session_id").to_pylist(), t.column("content_hash").to_pylist()))


def archive_sessions(session_dirs, archive, lot: str | None = None) -> ArchiveReport:
    """Append ``session_dirs`` to ``archive`` (created when missing): new sessions added, those already there
    with the same content skipped, one with an archived id and other content refused (one line each); the files
    of one call are written under temporary names and renamed into place, so a killed call leaves no part file."""
    archive = Path(archive)
    have = archived(archive)
    report = ArchiveReport()
    parts: dict[str, list[pa.Table]] = {t: [] for t in TABLES}
    for d in map(Path, session_dirs):
        try:
            tables = _session_tables(d, lot)
        except (RigInputError, OSError, ValueError, pa.ArrowInvalid) as exc:  # one session's refusal: the rest go on
            report.refused.append(f"{d}: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}")
            continue
        sid, digest = tables["sessions"].column("session_id")[0].as_py(), tables["sessions"].column("content_hash")[0].as_py()
        if sid in have:
            if have[sid] == digest:
                report.skipped.append(sid)
            else:
                report.refused.append(f"{d}: session {sid} is archived already with other content (hash "
                                      f"{have[sid][:12]}.., this one {digest[:12]}..): not added")
            continue
        have[sid] = digest
        for t in TABLES:
            parts[t].append(tables[t])
        report.added.append(sid)
    if report.added:
        batch = uuid.uuid4().hex[:12]
        written = []
        for t in TABLES:
            table = pa.concat_tables(parts[t], promote_options="default")
            for month in sorted(set(table.column("month").to_pylist())):
                rows = table.filter(pc.equal(table.column("month"), month)).drop(["month"])
                # sorted by session (stable: a session's rows keep their order) in row groups of ROW_GROUP_ROWS: a
                # resolve's chunk (sessions in id order) reads the few row groups its sessions are in, not the file
                rows = rows.sort_by("session_id")
                folder = archive / t / f"month={month}"
                folder.mkdir(parents=True, exist_ok=True)
                tmp = folder / f".{batch}.parquet.partial"
                pq.write_table(rows, tmp, compression="zstd", row_group_size=ROW_GROUP_ROWS)
                written.append((tmp, folder / f"part-{batch}.parquet"))
        for tmp, final in written:  # the sessions table last: a session is archived once its rows are all in place
            if final.parent.parent.name != "sessions":
                os.replace(tmp, final)
        for tmp, final in written:
            if final.parent.parent.name == "sessions":
                os.replace(tmp, final)
    return report


def extract_session(archive, session_id: str, out_dir) -> Path:
    """Write archived session ``session_id`` back as a session directory ``out_dir/session_id`` (its files as they
    were, samples.csv as the session writer formats it); RigInputError (one line) when it is not in the archive."""
    return extract_sessions(archive, [session_id], out_dir)[0]


def extract_sessions(archive, session_ids: list[str], out_dir) -> list[Path]:
    """:func:`extract_session` of several sessions, each table read once for all of them (a chunk of a resolve)."""
    archive, ids = Path(archive), list(session_ids)
    meta = read_table(archive, "sessions", session_ids=ids)
    found = dict(zip(meta.column("session_id").to_pylist(), meta.column("columns").to_pylist())) if meta.num_rows else {}
    missing = [sid for sid in ids if sid not in found]
    if missing:
        raise RigInputError(str(archive), None, None, f"session {missing[0]!r} is not in the archive")
    samples = read_table(archive, "samples", session_ids=ids)
    files = read_table(archive, "files", columns=["session_id", "name", "data"], session_ids=ids)
    out = []
    for sid in ids:
        target = Path(out_dir) / sid
        if target.exists():
            raise RigInputError(str(target), None, None, "exists already: choose another -o directory")
        columns = found[sid].split(",")
        rows = samples.filter(pc.equal(samples.column("session_id"), sid)) if samples.num_rows else samples
        mine = files.filter(pc.equal(files.column("session_id"), sid))
        target.mkdir(parents=True)
        for name, data in zip(mine.column("name").to_pylist(), mine.column("data").to_pylist()):
            (target / Path(name).name).write_bytes(data)
        cols = {c: rows.column(c).to_numpy(zero_copy_only=False) for c in columns} if rows.num_rows else {}
        (target / "samples.csv").write_text(",".join(columns) + "\n" + format_rows(columns, cols), encoding="utf-8")
        out.append(target)
    return out
