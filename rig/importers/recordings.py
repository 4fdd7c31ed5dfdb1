"""``rig import``: other tools' recordings as ``rig-session/1`` sessions (docs/import.md).

One module per source reads the file into a :class:`~rig.importers.common.Recording`:
:mod:`~rig.importers.imucal`, :mod:`~rig.importers.imu_tk`, :mod:`~rig.importers.tofupilot` and
:mod:`~rig.importers.generic_csv` (``--from csv``); this module checks the arguments and writes the
recording as a complete session through :class:`rig.session.SessionWriter`.

Every problem with a source file raises :class:`rig.errors.RigInputError` naming the file and,
where there is one, the line.
"""

from __future__ import annotations

import hashlib
import re
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rig.config.yamlload import SymlinkLoop
from rig.errors import RigInputError
from rig.importers.common import COUNTS_PER_G_EQUIVALENT, G_MS2, ImportedStep, Recording, check_recording
from rig.importers.generic_csv import read_csv
from rig.importers.imu_tk import read_imu_tk
from rig.importers.imucal import IMUCAL_POSES, IMUCAL_ROTATIONS, read_imucal
from rig.importers.tofupilot import read_tofupilot
from rig.session import (ImportInfo, ProcedureInfo, RigInfo, SensorInfo, SessionManifest, SessionWriter, StepRecord,
                         validate_session_id)

READERS = {"imucal": read_imucal, "imu_tk": read_imu_tk, "tofupilot": read_tofupilot, "csv": read_csv}
SOURCES = tuple(READERS)

__all__ = ["SOURCES", "READERS", "G_MS2", "COUNTS_PER_G_EQUIVALENT", "ImportedStep", "Recording", "IMUCAL_POSES",
           "IMUCAL_ROTATIONS", "import_recording", "import_manifest", "read_imucal", "read_imu_tk", "read_tofupilot",
           "read_csv"]


def import_recording(source: str, src, sessions_root, session_id: str | None = None, *, g_ms2: float = G_MS2,
                     window_s: float = 120.0) -> Path:
    """Import ``src`` (a file of kind ``source``) as a complete session under ``sessions_root``.

    Returns the session directory.
    """
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
    rec = READERS[source](path, g_ms2=g_ms2, window_s=window_s)
    if not rec.steps:
        raise RigInputError(str(path), None, None, "no steps found in the recording")
    check_recording(path, rec)
    sid = session_id or f"import-{source}-{re.sub(r'[^A-Za-z0-9_-]+', '-', path.stem)}"
    validate_session_id(sid)
    return write_session(rec, import_manifest(rec, path, sid, g_ms2), Path(sessions_root))


def import_manifest(rec: Recording, path: Path, sid: str, g_ms2: float) -> SessionManifest:
    """The manifest of an imported session: no turntable (``rig.kind: import``), the ``import:`` section,
    the source file's hash as ``procedure.sha256``."""
    procedure = ProcedureInfo(name=f"import-{rec.source}", file=str(path),
                              sha256=hashlib.sha256(path.read_bytes()).hexdigest(), text=None)
    sensor = SensorInfo(model=rec.sensor_model, address=None, accel_lsb_per_g=float(rec.lsb_per_g),
                        sample_rate_hz=float(rec.sample_rate_hz), has_temperature=rec.has_temperature)
    if rec.has_gyro and rec.gyro_lsb_per_dps:
        sensor.gyro_lsb_per_dps = float(rec.gyro_lsb_per_dps)
    steps = [StepRecord(index=i, name=st.name, kind=st.kind, angles_deg=None, f_nominal=st.f_nominal,
                        **({"pose_group": int(st.pose_group)} if st.pose_group is not None else {}))
             for i, st in enumerate(rec.steps)]
    return SessionManifest(
        id=sid, created=datetime.now(timezone.utc).isoformat(timespec="seconds"), procedure=procedure,
        rig=RigInfo(kind="import", turntable=None, sensor=sensor, rig_file=None),
        import_=ImportInfo(source=rec.source, file=str(path), units=rec.units, g_ms2=float(g_ms2),
                           lsb_per_g=float(rec.lsb_per_g), steps_from=rec.steps_from, notes=list(rec.notes)),
        steps=steps)


def write_session(rec: Recording, manifest: SessionManifest, root: Path) -> Path:
    """Write the recording's samples step by step under ``root``; the session ends complete."""
    cols = ("t_s", "step", "ax", "ay", "az", "temp_c") + (("wx", "wy", "wz") if rec.has_gyro else ())
    w = SessionWriter.create(root, manifest.id, manifest, columns=cols)
    try:
        for i, st in enumerate(rec.steps):
            w.append_samples(i, st.t_s, st.accel_counts, temp_c=st.temp_c, gyro_counts=st.gyro_counts)
            stats = {"n_samples": int(len(st.t_s)), "t_start_s": float(st.t_s[0]), "t_end_s": float(st.t_s[-1]),
                     "temp_c": float(np.mean(st.temp_c)) if st.temp_c is not None else None}
            w.complete_step(i, stats)
        w.set_status("complete")
    except BaseException:
        w.set_status("aborted")
        raise
    return w.session_dir
