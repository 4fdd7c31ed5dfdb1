"""``rig import``: other tools' recordings as ``rig-session/1`` sessions (docs/import.md).

One module per source reads the file, block by block, into a :class:`~rig.importers.common.Recording`
whose samples wait in a spool: :mod:`~rig.importers.imucal`, :mod:`~rig.importers.imu_tk`,
:mod:`~rig.importers.tofupilot` and :mod:`~rig.importers.generic_csv` (``--from csv``); this module checks
the arguments and the steps and writes the recording as a complete session through
:class:`rig.session.SessionWriter`, chunk by chunk.

Nothing half-written is ever a session: the import works in ``SESSIONS/ID.PID.partial/`` (the spool, the
session being written, and ``import.lock``, an OS lock held while the import runs that names the source),
renames the complete session to ``SESSIONS/ID`` at the end and removes the partial directory, also when
it fails. A partial directory left by a killed import (its lock free) is removed by the next import of
the same source file or id into the same directory. So the session's files need no per-step durability
(the writer's ``durable_steps=False``: no fsync per step, no steps journal): each is fsynced once before the
rename (``samples.csv``, ``events.jsonl``, ``session.yaml`` and the session directory), the sessions directory
once after it.

Every problem with a source file raises :class:`rig.errors.RigInputError` naming the file and,
where there is one, the line.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import json
import os
import re
import shutil
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from rig.config.yamlload import SymlinkLoop
from rig.errors import RigInputError
from rig.importers.common import (COUNTS_PER_G_EQUIVALENT, G_MS2, MAX_STEPS, ImportedStep, Recording, Spools,
                                  StepSummary, check_recording, summarize)
from rig.importers.generic_csv import read_csv
from rig.importers.imu_tk import read_imu_tk
from rig.importers.quasi_static import DEFAULT_FACTOR, DEFAULT_MIN_S, check_settings
from rig.importers.imucal import IMUCAL_POSES, IMUCAL_ROTATIONS, read_imucal
from rig.importers.tofupilot import read_tofupilot
from rig.session import (ImportInfo, MagnetometerInfo, ProcedureInfo, RigInfo, SensorInfo, SessionManifest, SessionWriter, StepRecord,
                         validate_session_id)

READERS = {"imucal": read_imucal, "imu_tk": read_imu_tk, "tofupilot": read_tofupilot, "csv": read_csv}
SOURCES = tuple(READERS)
PARTIAL = ".partial"
LOCK = "import.lock"

__all__ = ["SOURCES", "READERS", "G_MS2", "COUNTS_PER_G_EQUIVALENT", "ImportedStep", "Recording", "IMUCAL_POSES",
           "IMUCAL_ROTATIONS", "import_recording", "import_manifest", "read_imucal", "read_imu_tk", "read_tofupilot",
           "read_csv"]


def _no_steps_hint(source: str, rec: Recording) -> str:
    """What a recording without steps can do: the detector's finding, and ``--continuous`` for a generic CSV whose
    sensor turned without rests."""
    if source != "csv" or rec.steps_from != "static detection":
        return ""
    found = f" ({rec.notes[-1]})" if rec.notes else ""
    return (f"{found}: a sensor turned without rests (a magnetometer turned by hand) is imported with --continuous "
            "(one turning step, the ellipsoid fitted on its samples)")


def import_recording(source: str, src, sessions_root, session_id: str | None = None, *, g_ms2: float = G_MS2,
                     window_s: float = 120.0, notify: Callable[[str], None] | None = None,
                     rate_hz: float | None = None, column_map: str | None = None,
                     static_factor: float = DEFAULT_FACTOR, static_min_s: float = DEFAULT_MIN_S,
                     progress: Callable[[int, int], None] | None = None, continuous: bool = False) -> Path:
    """Import ``src`` (a file of kind ``source``) as a complete session under ``sessions_root``.

    Returns the session directory. ``notify`` is told (one line each) of the partial directories of
    killed imports that were removed. ``rate_hz`` (Hz) and ``column_map`` (``ours=theirs,...``): the
    generic CSV's sample rate when it has no time column, and its other column names; ``static_factor`` and
    ``static_min_s`` (s): its quasi-static detector's settings (:mod:`rig.importers.quasi_static`).
    ``progress`` is told (steps written, steps) after each step. ``continuous`` (generic CSV): the recording is
    one step in which the sensor turns (no static detection; its magnetometer is fitted on the samples).
    """
    check_settings(static_factor, static_min_s)
    path = _checked_source(source, src, g_ms2)
    sid = session_id or f"import-{source}-{re.sub(r'[^A-Za-z0-9_-]+', '-', path.stem)}"
    validate_session_id(sid)
    root = Path(sessions_root)
    made_root = not root.exists()
    for left, file in remove_leftovers(root, path, sid):
        if notify:
            notify(f"removed {left}: the partial session left by a killed import of {file}")
    final = root / sid
    _refuse_existing(final)
    root.mkdir(parents=True, exist_ok=True)
    work = Work(root, sid, source, path)
    done = False
    try:
        rec = READERS[source](path, work.spools, g_ms2=g_ms2, window_s=window_s, rate_hz=rate_hz,
                              column_map=column_map, static_factor=static_factor, static_min_s=static_min_s,
                              continuous=continuous)
        if not rec.steps:
            raise RigInputError(str(path), None, None, "no steps found in the recording" + _no_steps_hint(source, rec))
        if len(rec.steps) > MAX_STEPS:
            raise RigInputError(str(path), None, None, f"{len(rec.steps)} steps found; a session holds at most "
                                                       f"{MAX_STEPS}")
        summaries = summarize(rec)
        check_recording(path, rec, summaries)
        session = write_session(rec, summaries, import_manifest(rec, path, sid, g_ms2), work.dir, progress)
        work.spools.close()
        _move_into_place(session, final)
        done = True
    finally:
        work.remove()
        if made_root and not done:
            try:
                root.rmdir()  # the directory this import made, empty again
            except OSError:
                pass
    return final


def _checked_source(source: str, src, g_ms2: float) -> Path:
    """The source file ``src`` of kind ``source``, with a plausible gravity ``g_ms2``."""
    if source not in SOURCES:
        raise RigInputError(None, None, "--from", f"unknown source {source!r} (allowed: {', '.join(SOURCES)})")
    path = Path(src)
    if not path.is_file():
        try:
            path.stat()
        except OSError as exc:
            if isinstance(exc, SymlinkLoop):
                raise RigInputError(str(path), None, None, f"{SymlinkLoop.message}, expected a recording") from None
        raise RigInputError(str(path), None, None, "no such file" if not path.exists() else "not a file")
    if not 9.7 < g_ms2 < 9.9:
        raise RigInputError(None, None, "--g", f"expected the local gravity in m/s^2 (9.7..9.9), got {g_ms2:g}")
    return path


def _refuse_existing(final: Path) -> None:
    if final.exists() or final.is_symlink():
        raise FileExistsError(errno.EEXIST, "a session with this id exists already", str(final))


def _move_into_place(session: Path, final: Path) -> None:
    """Rename the complete session to its place (never over another session) and make the rename durable."""
    _refuse_existing(final)
    try:
        os.rename(session, final)
    except OSError as exc:
        if exc.errno in (errno.EEXIST, errno.ENOTEMPTY):
            raise FileExistsError(errno.EEXIST, "a session with this id exists already", str(final)) from None
        raise
    fd = os.open(final.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class Work:
    """``ROOT/ID.PID.partial``: where one import works, locked (``import.lock``) while it runs."""

    def __init__(self, root: Path, sid: str, source: str, path: Path) -> None:
        self.dir = root / f"{sid}.{os.getpid()}{PARTIAL}"
        if self.dir.exists():  # a killed import of the same pid (pids are reused): its lock is free
            shutil.rmtree(self.dir, ignore_errors=True)
        self.dir.mkdir()
        self._lock = open(self.dir / LOCK, "w")
        fcntl.flock(self._lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        self._lock.write(json.dumps({"id": sid, "source": source, "file": str(path.resolve()), "pid": os.getpid(),
                                     "since": datetime.now(timezone.utc).isoformat(timespec="seconds")}))
        self._lock.flush()
        self.spools = Spools(self.dir / "spool")

    def remove(self) -> None:
        self.spools.close()
        shutil.rmtree(self.dir, ignore_errors=True)
        self._lock.close()


def remove_leftovers(root: Path, path: Path, sid: str) -> list[tuple[Path, str]]:
    """Remove the partial directories under ``root`` of imports that were killed (their lock is free)
    while importing ``path`` or writing the id ``sid``; return them with the file each was importing. A
    running import's is left alone."""
    if not root.is_dir():
        return []
    removed = []
    me = str(path.resolve())
    for d in sorted(root.glob(f"*{PARTIAL}")):
        try:
            fh = open(d / LOCK, "r")
        except OSError:
            continue  # not an import's partial directory (or one not yet locked)
        with fh:
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                continue  # an import running now
            try:
                owner = json.loads(fh.read() or "{}")
            except ValueError:
                owner = {}
            if owner.get("file") == me or owner.get("id") == sid:
                shutil.rmtree(d, ignore_errors=True)
                removed.append((d, str(owner.get("file"))))
    return removed


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def import_manifest(rec: Recording, path: Path, sid: str, g_ms2: float) -> SessionManifest:
    """The manifest of an imported session: no turntable (``rig.kind: import``), the ``import:`` section,
    the source file's hash as ``procedure.sha256``."""
    procedure = ProcedureInfo(name=f"import-{rec.source}", file=str(path), sha256=file_sha256(path), text=None)
    sensor = SensorInfo(model=rec.sensor_model, address=None, accel_lsb_per_g=float(rec.lsb_per_g),
                        sample_rate_hz=float(rec.sample_rate_hz), has_temperature=rec.has_temperature)
    if rec.has_gyro and rec.gyro_lsb_per_dps:
        sensor.gyro_lsb_per_dps = float(rec.gyro_lsb_per_dps)
    if rec.has_mag and rec.mag_lsb_per_ut:
        sensor.magnetometer = MagnetometerInfo(model=f"imported ({rec.mag_units})",
                                               mag_lsb_per_ut=float(rec.mag_lsb_per_ut))
    steps = [StepRecord(index=i, name=st.name, kind=st.kind, angles_deg=None, f_nominal=st.f_nominal,
                        **({"pose_group": int(st.pose_group)} if st.pose_group is not None else {}))
             for i, st in enumerate(rec.steps)]
    return SessionManifest(
        id=sid, created=datetime.now(timezone.utc).isoformat(timespec="seconds"), procedure=procedure,
        rig=RigInfo(kind="import", turntable=None, sensor=sensor, rig_file=None),
        import_=ImportInfo(source=rec.source, file=str(path), units=rec.units, g_ms2=float(g_ms2),
                           lsb_per_g=float(rec.lsb_per_g), steps_from=rec.steps_from,
                           notes=list(rec.notes) + list(rec.columns)),
        steps=steps)


def write_session(rec: Recording, summaries: list[StepSummary], manifest: SessionManifest, root: Path,
                  progress: Callable[[int, int], None] | None = None) -> Path:
    """Write the recording's samples step by step, chunk by chunk, under ``root``; the session ends complete
    (``progress``: told (steps written, steps) after each step)."""
    cols = ("t_s", "step", "ax", "ay", "az", "temp_c") + (("wx", "wy", "wz") if rec.has_gyro else ()) \
        + (("mx", "my", "mz") if rec.has_mag else ())
    # no per-step durability: the session is renamed into place complete (import_recording), so a killed import
    # leaves no session whatever was written; each file is fsynced once when it ends (SessionWriter, durable_steps)
    w = SessionWriter.create(root, manifest.id, manifest, columns=cols, durable_steps=False)
    try:
        for i, (st, s) in enumerate(zip(rec.steps, summaries)):
            for c in rec.step_chunks(st):
                w.append_samples(i, c["t"], c["counts"], temp_c=c["temp"], gyro_counts=c["gyro"], mag_counts=c["mag"])
            w.complete_step(i, {"n_samples": s.n, "t_start_s": s.t_start, "t_end_s": s.t_end, "temp_c": s.temp_mean})
            if progress is not None:
                progress(i + 1, len(rec.steps))
        w.set_status("complete")
    except BaseException:
        w.set_status("aborted")
        raise
    return w.session_dir
