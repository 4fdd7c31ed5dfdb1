"""``rig import``: other tools' recordings as ``rig-session/1`` sessions (docs/import.md).

Sources:

- ``imucal``: mad-lab-fau/imucal's annotated session CSV (``part,samples,acc_x..z,gyr_x..z``, raw
  counts, 204.8 Hz). Its parts ``x_p, x_a, y_p, y_a, z_p, z_a`` are the six static poses (``_p``: the
  axis points up, +1 g; ``_a``: down, -1 g; checked against the data) and ``x_rot, y_rot, z_rot``
  the three 360 deg rotations (kind ``rotation``, gyro kept).
- ``imu_tk``: Kyle-ak/imu_tk's text file ``t x y z`` (raw counts, poses unknown): static intervals
  by :func:`calib.static_detect.detect_static`, each a static step with ``f_nominal: null``;
  the samples between intervals (hand motion) are not imported.
- ``tofupilot``: TofuPilot's tab-separated thermal recording (timestamp in microseconds,
  ``imu.acc.x..z`` in m/s^2, ``imu.temperature`` C; one static pose): converted to counts-equivalent
  at 100000 counts per g (10 ug) with the stated g, cut into consecutive windows (default 120 s),
  each a static step with ``f_nominal: null`` and ``pose_group: 0`` (one unknown pose).
- ``csv``: a documented generic CSV (see docs/import.md).

Every problem with a source file raises :class:`rig.errors.RigInputError` naming the file and,
where there is one, the line.
"""

from __future__ import annotations

import csv
import hashlib
import io
import re
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rig import __version__
from rig.errors import RigInputError
from rig.session.store import SessionWriter, validate_session_id

SOURCES = ("imucal", "imu_tk", "tofupilot", "csv")
G_MS2 = 9.80665
COUNTS_PER_G_EQUIVALENT = 100000.0  # counts-equivalent of physical units: 10 ug per count


@dataclass
class ImportedStep:
    name: str
    kind: str  # static | rotation
    t_s: np.ndarray
    accel_counts: np.ndarray  # (N, 3) int
    temp_c: np.ndarray | None = None
    gyro_counts: np.ndarray | None = None
    f_nominal: list | None = None
    pose_group: int | None = None


@dataclass
class Recording:
    """What an importer found: steps, units and provenance."""

    source: str
    sensor_model: str
    lsb_per_g: float
    sample_rate_hz: float
    units: str
    steps_from: str  # labels | static detection | windows
    steps: list[ImportedStep] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    gyro_lsb_per_dps: float | None = None


def import_recording(source: str, src, sessions_root, session_id: str | None = None, *, g_ms2: float = G_MS2,
                     window_s: float = 120.0) -> Path:
    """Import ``src`` (a file of kind ``source``) as a complete session under ``sessions_root``.

    Returns the session directory.
    """
    if source not in SOURCES:
        raise RigInputError(None, None, "--from", f"unknown source {source!r} (allowed: {', '.join(SOURCES)})")
    path = Path(src)
    if not path.is_file():
        raise RigInputError(str(path), None, None, "no such file" if not path.exists() else "not a file")
    if not 9.7 < g_ms2 < 9.9:
        raise RigInputError(None, None, "--g", f"expected the local gravity in m/s^2 (9.7..9.9), got {g_ms2:g}")
    rec = {"imucal": read_imucal, "imu_tk": read_imu_tk, "tofupilot": read_tofupilot, "csv": read_csv}[source](
        path, g_ms2=g_ms2, window_s=window_s)
    if not rec.steps:
        raise RigInputError(str(path), None, None, "no steps found in the recording")
    sid = session_id or f"import-{source}-{re.sub(r'[^A-Za-z0-9_-]+', '-', path.stem)}"
    validate_session_id(sid)
    return _write(rec, path, Path(sessions_root), sid, g_ms2)


def _write(rec: Recording, path: Path, root: Path, sid: str, g_ms2: float) -> Path:
    raw = path.read_bytes()
    steps = []
    for i, st in enumerate(rec.steps):
        d = {"index": i, "name": st.name, "kind": st.kind, "angles_deg": None, "f_nominal": st.f_nominal,
             "status": "pending"}
        if st.pose_group is not None:
            d["pose_group"] = int(st.pose_group)
        steps.append(d)
    has_temp = any(st.temp_c is not None for st in rec.steps)
    has_gyro = any(st.gyro_counts is not None for st in rec.steps)
    sensor = {"model": rec.sensor_model, "address": None, "accel_lsb_per_g": float(rec.lsb_per_g),
              "sample_rate_hz": float(rec.sample_rate_hz), "has_temperature": has_temp}
    if has_gyro and rec.gyro_lsb_per_dps:
        sensor["gyro_lsb_per_dps"] = float(rec.gyro_lsb_per_dps)
    manifest = {
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "procedure": {"name": f"import-{rec.source}", "file": str(path), "sha256": hashlib.sha256(raw).hexdigest(),
                      "text": None},
        "software": {"name": "rig-calibration", "version": __version__},
        "rig": {"kind": "import", "turntable": None, "sensor": sensor, "rig_file": None},
        "import": {"source": rec.source, "file": str(path), "units": rec.units, "g_ms2": float(g_ms2),
                   "lsb_per_g": float(rec.lsb_per_g), "steps_from": rec.steps_from, "notes": list(rec.notes)},
        "steps": steps,
    }
    cols = ("t_s", "step", "ax", "ay", "az", "temp_c") + (("wx", "wy", "wz") if has_gyro else ())
    w = SessionWriter.create(root, sid, manifest, columns=cols)
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


# -- sources --------------------------------------------------------------------------------------
IMUCAL_POSES = {"x_p": [1, 0, 0], "x_a": [-1, 0, 0], "y_p": [0, 1, 0], "y_a": [0, -1, 0], "z_p": [0, 0, 1],
                "z_a": [0, 0, -1]}
IMUCAL_ROTATIONS = ("x_rot", "y_rot", "z_rot")


def _numbers(path: Path, rows: list[list[str]], first_line: int, cols: list[int], header: list[str]) -> np.ndarray:
    out = np.empty((len(rows), len(cols)))
    for r, row in enumerate(rows):
        for c, j in enumerate(cols):
            try:
                out[r, c] = float(row[j])
            except (ValueError, IndexError):
                got = row[j] if j < len(row) else "nothing"
                raise RigInputError(str(path), first_line + r, header[j] if j < len(header) else None,
                                    f"expected a number, got {got!r}") from None
        if not np.all(np.isfinite(out[r])):
            raise RigInputError(str(path), first_line + r, None, "expected finite numbers")
    return out


def _header(path: Path, text: str, required: list[str], delimiter: str) -> tuple[list[str], list[list[str]]]:
    lines = [ln for ln in text.splitlines()]
    if not lines or not lines[0].strip():
        raise RigInputError(str(path), 1, None, "empty file: expected a header line")
    reader = list(csv.reader(io.StringIO(text), delimiter=delimiter))
    header = [h.strip() for h in reader[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise RigInputError(str(path), 1, None, f"expected columns {', '.join(required)}; missing {', '.join(missing)}"
                                                f" (got {', '.join(header) or 'nothing'})")
    body = [r for r in reader[1:] if r]
    if not body:
        raise RigInputError(str(path), 2, None, "no data rows after the header")
    return header, body


def read_imucal(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    text = path.read_text(errors="replace")
    cols = ["part", "samples", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
    header, body = _header(path, text, cols, ",")
    idx = [header.index(c) for c in cols[1:]]
    data = _numbers(path, body, 2, idx, header)
    parts = [r[header.index("part")].strip() for r in body]
    rate = 204.8
    rec = Recording("imucal", "imucal recording (raw counts, ~2048 counts/g)", 2048.0, rate, "counts", "labels",
                    notes=["lsb_per_g is the nominal 2048 counts/g of the +-16 g range; imucal's own scale is "
                           "fitted per axis", "gyro in raw counts, nominal 16.4 counts/(deg/s)"],
                    gyro_lsb_per_dps=16.4)
    order = list(dict.fromkeys(parts))
    unknown = [p for p in order if p not in IMUCAL_POSES and p not in IMUCAL_ROTATIONS]
    if unknown:
        line = parts.index(unknown[0]) + 2
        raise RigInputError(str(path), line, "part", f"unknown part {unknown[0]!r} (expected "
                            f"{', '.join(list(IMUCAL_POSES) + list(IMUCAL_ROTATIONS))})")
    parts_arr = np.array(parts)
    for p in order:
        sel = parts_arr == p
        d = data[sel]
        t = d[:, 0] / rate
        acc = np.rint(d[:, 1:4]).astype(np.int64)
        gyr = np.rint(d[:, 4:7]).astype(np.int64)
        if p in IMUCAL_POSES:
            f = IMUCAL_POSES[p]
            mean = acc.mean(axis=0)
            dom = int(np.argmax(np.abs(mean)))
            if dom != int(np.argmax(np.abs(f))) or np.sign(mean[dom]) != np.sign(f[dom]):
                line = int(np.flatnonzero(sel)[0]) + 2
                raise RigInputError(str(path), line, "part", f"part {p!r} should read +-1 g along "
                                    f"{'xyz'[int(np.argmax(np.abs(f)))]} with sign {f[int(np.argmax(np.abs(f)))]:+d}"
                                    f", but its mean is {mean.round(0).tolist()} counts")
            rec.steps.append(ImportedStep(p, "static", t, acc, gyro_counts=gyr, f_nominal=[float(x) for x in f]))
        else:
            rec.steps.append(ImportedStep(p, "rotation", t, acc, gyro_counts=gyr))
    return rec


def read_imu_tk(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    from calib.static_detect import detect_static
    rows = []
    for n, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        parts = line.split()
        if len(parts) != 4:
            raise RigInputError(str(path), n, None, f"expected 4 numbers (t x y z), got {len(parts)} fields")
        try:
            rows.append([float(x) for x in parts])
        except ValueError:
            raise RigInputError(str(path), n, None, f"expected numbers (t x y z), got {line.strip()[:40]!r}") from None
    if len(rows) < 100:
        raise RigInputError(str(path), None, None, f"expected a recording of t x y z rows, got {len(rows)} rows")
    d = np.array(rows)
    t, acc = d[:, 0], d[:, 1:4]
    if np.any(np.diff(t) <= 0):
        raise RigInputError(str(path), int(np.argmax(np.diff(t) <= 0)) + 2, "t", "time stamps must increase")
    rate = float(1.0 / np.median(np.diff(t)))
    lsb = 415.0 * g_ms2
    rec = Recording("imu_tk", "Xsens MTi (imu_tk test data, raw counts)", lsb, round(rate, 3), "counts",
                    "static detection", notes=["lsb_per_g from the Xsens datasheet figure of about 415 counts per "
                                               "m/s^2; offset near 32768 counts", "samples between static "
                                               "intervals (hand motion) are not imported"])
    intervals = detect_static(t, acc)
    for k, (a, b) in enumerate(intervals):
        rec.steps.append(ImportedStep(f"static {k + 1}", "static", t[a:b], np.rint(acc[a:b]).astype(np.int64),
                                      pose_group=1000 + k))
    return rec


def read_tofupilot(path: Path, g_ms2: float = G_MS2, window_s: float = 120.0, **_) -> Recording:
    text = path.read_text(errors="replace")
    cols = ["timestamp", "imu.acc.x", "imu.acc.y", "imu.acc.z", "imu.temperature"]
    header, body = _header(path, text, cols, "\t")
    data = _numbers(path, body, 2, [header.index(c) for c in cols], header)
    ts = data[:, 0]
    if np.any(np.diff(ts) <= 0):
        raise RigInputError(str(path), int(np.argmax(np.diff(ts) <= 0)) + 3, "timestamp", "time stamps must increase")
    dt = float(np.median(np.diff(ts)))
    # the unit of the timestamp: the one that makes the sample interval between 1 ms and 60 s
    scale = next((s for s in (1.0, 1e-3, 1e-6, 1e-9) if 1e-3 <= dt * s <= 60.0), None)
    if scale is None:
        raise RigInputError(str(path), 2, "timestamp", f"cannot tell the time unit (median step {dt:g})")
    t = (ts - ts[0]) * scale
    counts = np.rint(data[:, 1:4] / g_ms2 * COUNTS_PER_G_EQUIVALENT).astype(np.int64)
    temp = data[:, 4]
    unit = {1.0: "s", 1e-3: "ms", 1e-6: "us", 1e-9: "ns"}[scale]
    rec = Recording("tofupilot", "TofuPilot IMU thermal recording (m/s^2)", COUNTS_PER_G_EQUIVALENT,
                    round(1.0 / (dt * scale), 4), "m/s^2", f"windows of {window_s:g} s",
                    notes=[f"acceleration converted to counts-equivalent: counts = a / {g_ms2:g} m/s^2 * "
                           f"{COUNTS_PER_G_EQUIVALENT:g}", f"timestamp unit {unit}", "one static pose (z down), "
                           "unknown to the tool: every window shares pose_group 0", "gyro columns not imported"])
    edges = np.arange(0.0, t[-1] + window_s, window_s)
    for k in range(len(edges) - 1):
        sel = (t >= edges[k]) & (t < edges[k + 1])
        if sel.sum() < 10:
            continue
        rec.steps.append(ImportedStep(f"window {k + 1}", "static", t[sel], counts[sel], temp_c=temp[sel],
                                      pose_group=0))
    return rec


def read_csv(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    """Generic CSV: ``# units: counts|g|m/s^2`` and ``# lsb_per_g: N`` comment lines, then a header with
    ``t_s, ax, ay, az`` and optional ``temp_c``, ``label``."""
    from rig.planning.kinematics import f_nominal
    from rig.planning.poses import POSE_NAMES, pose_angles_deg
    raw_lines = path.read_text(errors="replace").splitlines()
    meta, skip = {}, 0
    for line in raw_lines:
        if line.startswith("#"):
            m = re.match(r"#\s*([A-Za-z_]+)\s*:\s*(.+)$", line)
            if m:
                meta[m.group(1).lower()] = m.group(2).strip()
            skip += 1
        else:
            break
    units = meta.get("units", "counts")
    if units not in ("counts", "g", "m/s^2"):
        raise RigInputError(str(path), None, "units", f"expected counts, g or m/s^2, got {units!r}")
    if units == "counts":
        try:
            lsb = float(meta["lsb_per_g"])
            assert lsb > 0
        except (KeyError, ValueError, AssertionError):
            raise RigInputError(str(path), None, "lsb_per_g", "counts need a '# lsb_per_g: N' line (N > 0)") from None
    else:
        lsb = COUNTS_PER_G_EQUIVALENT
    text = "\n".join(raw_lines[skip:])
    header, body = _header(path, text, ["t_s", "ax", "ay", "az"], ",")
    first = skip + 2
    cols = [header.index(c) for c in ("t_s", "ax", "ay", "az")]
    data = _numbers(path, body, first, cols, header)
    temp = _numbers(path, body, first, [header.index("temp_c")], header)[:, 0] if "temp_c" in header else None
    labels = [r[header.index("label")].strip() if header.index("label") < len(r) else "" for r in body] \
        if "label" in header else None
    t = data[:, 0]
    if np.any(np.diff(t) <= 0):
        raise RigInputError(str(path), first + int(np.argmax(np.diff(t) <= 0)) + 1, "t_s", "time stamps must increase")
    acc = data[:, 1:4]
    if units == "g":
        acc = acc * lsb
    elif units == "m/s^2":
        acc = acc / g_ms2 * lsb
    counts = np.rint(acc).astype(np.int64)
    rate = round(float(1.0 / np.median(np.diff(t))), 4)
    rec = Recording("csv", meta.get("sensor", "generic CSV"), lsb, rate, units,
                    "labels" if labels else "static detection")
    if labels:
        lab = np.array(labels)
        starts = [0] + [i for i in range(1, len(lab)) if lab[i] != lab[i - 1]]
        ends = starts[1:] + [len(lab)]
        for a, b in zip(starts, ends):
            name = str(lab[a]) or f"segment {len(rec.steps) + 1}"
            f = [float(x) for x in f_nominal(np.array(pose_angles_deg(name)))] if name in POSE_NAMES else None
            kind = "rotation" if "rot" in name.lower() else "static"
            rec.steps.append(ImportedStep(name, kind, t[a:b], counts[a:b],
                                          temp_c=None if temp is None else temp[a:b], f_nominal=f))
    else:
        from calib.static_detect import detect_static
        for k, (a, b) in enumerate(detect_static(t, counts, init_s=min(30.0, 0.2 * (t[-1] - t[0])))):
            rec.steps.append(ImportedStep(f"static {k + 1}", "static", t[a:b], counts[a:b],
                                          temp_c=None if temp is None else temp[a:b], pose_group=1000 + k))
    return rec
