"""Importers: other tools' recordings written as ``rig-session/1`` sessions (docs/import.md).

Sources (:data:`SOURCES`):

- ``imucal``: mad-lab-fau/imucal annotated session CSV (``part,samples,acc_x..z,gyr_x..z``, raw
  counts, 204.8 Hz). Six static parts (``x_p .. z_a``) with ``f_nominal`` found from, and checked
  against, the data; three rotations (kind ``rotation``, gyro kept).
- ``imu_tk``: Kyle-ak/imu_tk text file ``t x y z`` (raw unsigned counts, poses unknown): static
  intervals by :func:`calib.static_detect.detect_static`; the motion between them is dropped.
- ``tofupilot``: TofuPilot's tab-separated IMU thermal recording (m/s^2, C): converted to
  counts-equivalent (100000 counts per g), cut into consecutive windows of one unknown pose.
- ``csv``: a documented generic CSV (``t_s, ax, ay, az`` [, ``temp_c``, ``label``]).

Every problem with an input raises :class:`rig.errors.RigInputError` (one line: file, line, key,
what was expected).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from calib.static_detect import detect_static
from rig import __version__
from rig.errors import RigInputError
from rig.poses import CUBE
from rig.session import SessionWriter, validate_session_id

SOURCES = ("imucal", "imu_tk", "tofupilot", "csv")
G_MS2 = 9.80665
COUNTS_PER_G_EQUIVALENT = 100000  # counts-equivalent of physical units: 10 ug per count
IMUCAL_RATE_HZ = 204.8  # imucal's example recording (sample indices only in the file)
IMUCAL_LSB_PER_G = 2048.0  # nominal +/-16 g range of the imucal example sensor
IMUCAL_GYRO_LSB_PER_DPS = 16.4  # nominal +/-2000 deg/s range
IMUCAL_STATIC = ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")
IMUCAL_ROTATIONS = ("x_rot", "y_rot", "z_rot")
XSENS_COUNTS_PER_MS2 = 415.0  # Xsens MTi datasheet accelerometer scale, counts per m/s^2
DEFAULT_WINDOW_S = 120.0
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


@dataclass
class ImportedStep:
    """One step of an imported recording.

    Attributes
    ----------
    name, kind : step name; ``static``, ``rotation``.
    t_s : (N,) sample times, s from the recording start.
    accel_counts : (N, 3) integer counts (or counts-equivalent).
    temp_c : (N,) C, or None.  gyro_counts : (N, 3) integer counts, or None.
    f_nominal : [x, y, z] specific force in g (sensor frame) or None when the pose is unknown.
    pose_group : steps sharing one unknown pose share a group number.
    """

    name: str
    kind: str
    t_s: np.ndarray
    accel_counts: np.ndarray
    temp_c: np.ndarray | None = None
    gyro_counts: np.ndarray | None = None
    f_nominal: list[float] | None = None
    pose_group: int | None = None


@dataclass
class Recording:
    """What a reader found: steps, units and provenance for the manifest."""

    source: str
    sensor_model: str
    lsb_per_g: float
    sample_rate_hz: float
    units: str
    steps_from: str  # "labels" | "static detection" | "windows"
    steps: list[ImportedStep] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    gyro_lsb_per_dps: float | None = None
    extra: dict = field(default_factory=dict)


@dataclass
class Table:
    """A delimited text table: header names and numbered data rows (1-based file line numbers)."""

    path: Path
    header: list[str]
    lines: list[int]
    rows: list[list[str]]
    comments: dict[str, tuple[int, str]] = field(default_factory=dict)


# -- entry point ----------------------------------------------------------------------------------
def import_recording(source: str, src, sessions_root, session_id: str | None = None, *,
                     g_ms2: float = G_MS2, window_s: float = DEFAULT_WINDOW_S) -> Path:
    """Import a recording of another tool as a complete ``rig-session/1`` session.

    Parameters
    ----------
    source : one of :data:`SOURCES`.
    src : path of the source file (read only).
    sessions_root : directory the session directory is created in.
    session_id : default ``import-<source>-<stem of src>``.
    g_ms2 : local gravity, m/s^2, used to convert m/s^2 to g (and the Xsens scale to counts per g).
    window_s : tofupilot window length, s.

    Returns
    -------
    pathlib.Path : the session directory (status ``complete``).

    Raises
    ------
    RigInputError : unknown source, missing or malformed file, labels contradicted by the data.
    """
    if source not in SOURCES:
        raise RigInputError(None, None, "--from", f"unknown source {source!r} (expected one of {', '.join(SOURCES)})")
    path = Path(src)
    if not path.is_file():
        raise RigInputError(str(path), None, None, "no such file" if not path.exists() else "not a regular file")
    if isinstance(g_ms2, bool) or not isinstance(g_ms2, (int, float)) or not 9.7 <= g_ms2 <= 9.9:
        raise RigInputError(None, None, "--g", f"expected the local gravity in m/s^2 (9.7..9.9), got {g_ms2!r}")
    if not window_s > 0:
        raise RigInputError(None, None, "--window-s", f"expected a positive window in s, got {window_s!r}")
    readers = {"imucal": read_imucal, "imu_tk": read_imu_tk, "tofupilot": read_tofupilot, "csv": read_csv}
    rec = readers[source](path, g_ms2=float(g_ms2), window_s=float(window_s))
    if not rec.steps:
        raise RigInputError(str(path), None, None, "no steps found in the recording")
    sid = session_id or f"import-{source}-{re.sub(r'[^A-Za-z0-9_-]+', '-', path.stem)}"
    validate_session_id(sid)
    return _write_session(rec, path, Path(sessions_root), sid, float(g_ms2))


def _manifest(rec: Recording, path: Path, g_ms2: float) -> dict:
    """The manifest of an imported session (steps pending)."""
    steps = []
    for i, st in enumerate(rec.steps):
        d = {"index": i, "name": st.name, "kind": st.kind, "angles_deg": None,
             "f_nominal": st.f_nominal, "status": "pending"}
        if st.pose_group is not None:
            d["pose_group"] = int(st.pose_group)
        steps.append(d)
    has_temp = any(st.temp_c is not None for st in rec.steps)
    sensor = {"model": rec.sensor_model, "address": None, "has_temperature": has_temp,
              "accel_lsb_per_g": float(rec.lsb_per_g), "sample_rate_hz": float(rec.sample_rate_hz)}
    if rec.gyro_lsb_per_dps and any(st.gyro_counts is not None for st in rec.steps):
        sensor["gyro_lsb_per_dps"] = float(rec.gyro_lsb_per_dps)
    imp = {"source": rec.source, "file": str(path), "units": rec.units, "g_ms2": g_ms2,
           "lsb_per_g": float(rec.lsb_per_g), "steps_from": rec.steps_from, "notes": list(rec.notes)}
    imp.update(rec.extra)
    return {
        "created": datetime.now(timezone.utc).isoformat(timespec="milliseconds"),
        "procedure": {"name": f"import-{rec.source}", "file": str(path),
                      "sha256": hashlib.sha256(path.read_bytes()).hexdigest(), "text": None},
        "software": {"name": "rig-calibration", "version": __version__},
        "rig": {"kind": "import", "turntable": None, "sensor": sensor, "rig_file": None},
        "import": imp,
        "steps": steps,
    }


def _step_stats(st: ImportedStep, lsb_per_g: float) -> dict:
    """Step statistics as recorded by the rig: n_samples, times (s), temp_c (C), noise_g [3] (g)."""
    a = st.accel_counts.astype(float)
    noise = a.std(axis=0, ddof=1) / lsb_per_g if len(a) > 1 else [None] * 3
    return {"n_samples": int(len(st.t_s)), "t_start_s": float(st.t_s[0]), "t_end_s": float(st.t_s[-1]),
            "temp_c": float(np.mean(st.temp_c)) if st.temp_c is not None else None,
            "noise_g": [float(x) if x is not None else None for x in noise]}


def _write_session(rec: Recording, path: Path, root: Path, sid: str, g_ms2: float) -> Path:
    """Write the session through :class:`SessionWriter` (fsynced per step) and mark it complete."""
    has_temp = any(st.temp_c is not None for st in rec.steps)
    has_gyro = any(st.gyro_counts is not None for st in rec.steps)
    cols = ("t_s", "step", "ax", "ay", "az", "temp_c") + (("wx", "wy", "wz") if has_gyro else ())
    w = SessionWriter.create(root, sid, _manifest(rec, path, g_ms2), columns=cols)
    try:
        w.event("import", source=rec.source, file=str(path), steps=len(rec.steps), steps_from=rec.steps_from)
        for i, st in enumerate(rec.steps):
            w.append_samples(i, st.t_s, st.accel_counts, temp_c=st.temp_c, gyro_counts=st.gyro_counts)
            w.complete_step(i, _step_stats(st, rec.lsb_per_g))
        w.set_status("complete")
    except BaseException:
        w.set_status("aborted")
        raise
    return w.session_dir


# -- text tables ----------------------------------------------------------------------------------
def _read_text(path: Path) -> str:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        line = path.read_bytes()[:exc.start].count(b"\n") + 1
        raise RigInputError(str(path), line, None, "not a UTF-8 text file") from None
    if not text.strip():
        raise RigInputError(str(path), 1, None, "empty file: expected a header line and samples")
    return text


def _split(line: str, delimiter: str | None) -> list[str]:
    return [f.strip() for f in (line.split(delimiter) if delimiter else line.split())]


def read_table(path: Path, required: tuple[str, ...], delimiter: str | None = ",",
               comment: str = "#") -> Table:
    """Read a delimited table with a header line; leading ``# key: value`` lines are comments.

    Raises RigInputError for an empty file, a missing column or a row of the wrong width.
    """
    comments: dict[str, tuple[int, str]] = {}
    header: list[str] | None = None
    lines, rows = [], []
    for no, raw in enumerate(_read_text(path).splitlines(), start=1):
        if not raw.strip():
            continue
        if header is None and raw.lstrip().startswith(comment):
            key, sep, value = raw.lstrip()[len(comment):].partition(":")
            if sep:
                comments[key.strip().lower()] = (no, value.strip())
            continue
        if header is None:
            header = _split(raw, delimiter)
            missing = [c for c in required if c not in header]
            if missing:
                raise RigInputError(str(path), no, missing[0],
                                    f"missing column(s) {', '.join(missing)}: expected a header with "
                                    f"{', '.join(required)} (found {', '.join(header)})")
            continue
        fields = _split(raw, delimiter)
        if len(fields) != len(header):
            raise RigInputError(str(path), no, None, f"expected {len(header)} fields as in the header, got {len(fields)}")
        lines.append(no)
        rows.append(fields)
    if header is None:
        raise RigInputError(str(path), 1, None, "empty file: expected a header line")
    if not rows:
        raise RigInputError(str(path), lines[-1] if lines else 2, None, "no samples after the header")
    return Table(path, header, lines, rows, comments)


def numbers(table: Table, names: tuple[str, ...]) -> np.ndarray:
    """The named columns as floats (rows, len(names)); a non-numeric or non-finite cell is an error."""
    idx = [table.header.index(n) for n in names]
    out = np.empty((len(table.rows), len(idx)))
    for r, row in enumerate(table.rows):
        for c, (i, name) in enumerate(zip(idx, names)):
            try:
                v = float(row[i])
            except ValueError:
                v = float("nan")
            if not np.isfinite(v):
                raise RigInputError(str(table.path), table.lines[r], name, f"expected a number, got {row[i]!r}")
            out[r, c] = v
    return out


def _integer_counts(path: Path, lines: list[int], a: np.ndarray, key: str) -> np.ndarray:
    """Counts must be whole numbers; return them as int64."""
    bad = np.any(a != np.round(a), axis=1)
    if bad.any():
        raise RigInputError(str(path), lines[int(np.argmax(bad))], key, "expected integer counts")
    return np.round(a).astype(np.int64)


def _increasing(path: Path, lines: list[int], t: np.ndarray, key: str) -> None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if len(bad):
        raise RigInputError(str(path), lines[int(bad[0]) + 1], key, "expected increasing time stamps")


def sample_rate_hz(t_s: np.ndarray) -> float:
    """Sample rate, Hz, from the median sample interval of ``t_s`` (s), to 4 significant digits."""
    dt = float(np.median(np.diff(t_s)))
    return float(f"{1.0 / dt:.4g}")


def to_counts_equivalent(a: np.ndarray, units: str, g_ms2: float) -> np.ndarray:
    """Physical accelerations (``g`` or ``m/s^2``) as integer counts-equivalent (10 ug per count)."""
    a_g = a / g_ms2 if units == "m/s^2" else a
    return np.round(a_g * COUNTS_PER_G_EQUIVALENT).astype(np.int64)


# -- imucal ---------------------------------------------------------------------------------------
def _imucal_pose(path: Path, line: int, part: str, acc: np.ndarray) -> np.ndarray:
    """Dominant axis and sign of a static part's mean (the accelerometer reads +1 g along the axis
    pointing up), checked against the part's label axis."""
    m = acc.astype(float).mean(axis=0)
    k = int(np.argmax(np.abs(m)))
    if abs(m[k]) < 0.8 * np.linalg.norm(m):
        raise RigInputError(str(path), line, part, f"static part has no dominant axis (mean {np.round(m, 1).tolist()} counts)")
    if "xyz"[k] != part[0]:
        raise RigInputError(str(path), line, part,
                            f"label says the {part[0]} axis is vertical, but the data's dominant axis is {'xyz'[k]} "
                            f"(mean {np.round(m, 1).tolist()} counts)")
    f = np.zeros(3)
    f[k] = np.sign(m[k])
    return f


def _imucal_convention(path: Path, first: dict[str, int], poses: dict[str, np.ndarray]) -> dict:
    """Check that one sign convention (``_p`` reads +1 g or reads -1 g) holds for all six parts."""
    signs = {p: int(poses[p].sum()) * (1 if p.endswith("_p") else -1) for p in poses}
    conv = 1 if sum(signs.values()) >= 0 else -1
    for p, s in signs.items():
        if s != conv:
            raise RigInputError(str(path), first[p], p,
                                f"the data contradict the sign convention of the other parts ('_p' reads "
                                f"{'+' if conv > 0 else '-'}1 g along its axis): mislabelled part")
    return {"p_suffix_reads_g": conv, "a_suffix_reads_g": -conv}


def read_imucal(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    """imucal annotated session: nine labelled parts, raw counts, 204.8 Hz."""
    cols = ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")
    tab = read_table(path, ("part", "samples") + cols)
    parts = [r[tab.header.index("part")] for r in tab.rows]
    known = IMUCAL_STATIC + IMUCAL_ROTATIONS
    for no, p in zip(tab.lines, parts):
        if p not in known:
            raise RigInputError(str(path), no, "part", f"expected one of {', '.join(known)}, got {p!r}")
    num = numbers(tab, ("samples",) + cols)
    acc = _integer_counts(path, tab.lines, num[:, 1:4], "acc_x")
    gyr = _integer_counts(path, tab.lines, num[:, 4:7], "gyr_x")
    t = num[:, 0] / IMUCAL_RATE_HZ
    parts_a = np.array(parts)
    first = {p: tab.lines[int(np.argmax(parts_a == p))] for p in known if (parts_a == p).any()}
    missing = [p for p in known if p not in first]
    if missing:
        raise RigInputError(str(path), None, "part", f"missing part(s) {', '.join(missing)}: expected all of {', '.join(known)}")
    poses = {p: _imucal_pose(path, first[p], p, acc[parts_a == p]) for p in IMUCAL_STATIC}
    conv = _imucal_convention(path, first, poses)
    t0 = float(t.min())
    steps = []
    for p in known:
        sel = np.flatnonzero(parts_a == p)
        sel = sel[np.argsort(t[sel], kind="stable")]
        _increasing(path, [tab.lines[i] for i in sel], t[sel], "samples")
        static = p in IMUCAL_STATIC
        steps.append(ImportedStep(name=p, kind="static" if static else "rotation", t_s=t[sel] - t0,
                                  accel_counts=acc[sel], gyro_counts=gyr[sel],
                                  f_nominal=poses[p].tolist() if static else None))
    return Recording(source="imucal", sensor_model="imucal annotated session (raw counts)",
                     lsb_per_g=IMUCAL_LSB_PER_G, sample_rate_hz=IMUCAL_RATE_HZ, units="counts",
                     steps_from="labels", steps=steps, gyro_lsb_per_dps=IMUCAL_GYRO_LSB_PER_DPS,
                     notes=["lsb_per_g 2048 is the nominal +/-16 g scale (the data show about 2040)",
                            f"sample rate {IMUCAL_RATE_HZ} Hz is the recording's (the file has sample indices only)",
                            "f_nominal from each static part's dominant axis and sign (+1 g along the axis up)"],
                     extra={"sign_convention": conv})


# -- imu_tk ---------------------------------------------------------------------------------------
def read_imu_tk(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    """imu_tk text file ``t x y z`` (no header): raw counts; static intervals by detection."""
    lines, rows = [], []
    for no, raw in enumerate(_read_text(path).splitlines(), start=1):
        if not raw.strip() or raw.lstrip().startswith(("#", "%")):
            continue
        f = raw.split()
        if len(f) != 4:
            raise RigInputError(str(path), no, None, f"expected 4 numbers (t x y z), got {len(f)} fields")
        lines.append(no)
        rows.append(f)
    if not rows:
        raise RigInputError(str(path), 1, None, "empty file: expected lines of t x y z")
    tab = Table(path, ["t", "x", "y", "z"], lines, rows)
    num = numbers(tab, ("t", "x", "y", "z"))
    t = num[:, 0]
    _increasing(path, lines, t, "t")
    acc = _integer_counts(path, lines, num[:, 1:], "x")
    intervals = detect_static(t, acc)
    lsb = XSENS_COUNTS_PER_MS2 * g_ms2
    t0 = float(t[0])
    steps = [ImportedStep(name=f"static {k + 1}", kind="static", t_s=t[s:e] - t0, accel_counts=acc[s:e],
                          pose_group=k)
             for k, (s, e) in enumerate(intervals)]
    kept = sum(e - s for s, e in intervals)
    return Recording(source="imu_tk", sensor_model="Xsens MTi (imu_tk test data, raw unsigned counts)",
                     lsb_per_g=lsb, sample_rate_hz=sample_rate_hz(t), units="counts", steps_from="static detection",
                     steps=steps,
                     notes=[f"lsb_per_g = 415 counts per m/s^2 (Xsens datasheet) x g {g_ms2} m/s^2",
                            "offsets near 32768 counts (unsigned) are kept",
                            f"motion between static intervals dropped: {len(t) - kept} of {len(t)} samples"])


# -- tofupilot ------------------------------------------------------------------------------------
def timestamp_unit(t_raw: np.ndarray, temp_c: np.ndarray) -> str:
    """The unit of raw time stamps (s, ms, us, ns), worked out from the data.

    Candidates give a sample interval between 1 ms and 60 s and a temperature range crossed no
    faster than 0.5 C/s (a thermal sweep); of those, the one whose rate is nearest 2 Hz (the
    TofuPilot template's logging rate). ValueError when none fits.
    """
    dt_raw = float(np.median(np.diff(t_raw)))
    span_raw = float(t_raw[-1] - t_raw[0])
    t_range = float(np.ptp(temp_c)) if len(temp_c) else 0.0
    fits = []
    for unit, scale in TIME_UNITS.items():
        dt, span = dt_raw * scale, span_raw * scale
        if 1e-3 <= dt <= 60.0 and t_range / span <= 0.5:
            fits.append((abs(np.log(1.0 / dt / 2.0)), unit))
    if not fits:
        raise ValueError(f"no time unit gives a plausible sample interval (median step {dt_raw:g})")
    return min(fits)[1]


def _windows(t: np.ndarray, window_s: float) -> list[tuple[int, int]]:
    """Consecutive windows of ``window_s`` (s) as (start, end) index pairs; a last window shorter
    than half a window is merged into the one before."""
    k = np.floor((t - t[0]) / window_s).astype(int)
    edges = np.flatnonzero(np.diff(k)) + 1
    bounds = list(zip(np.concatenate([[0], edges]), np.concatenate([edges, [len(t)]])))
    if len(bounds) > 1 and t[bounds[-1][1] - 1] - t[bounds[-1][0]] < 0.5 * window_s:
        bounds[-2:] = [(bounds[-2][0], bounds[-1][1])]
    return [(int(s), int(e)) for s, e in bounds]


def read_tofupilot(path: Path, g_ms2: float = G_MS2, window_s: float = DEFAULT_WINDOW_S, **_) -> Recording:
    """TofuPilot IMU thermal recording (tab-separated, m/s^2, C; one static pose, z down)."""
    cols = ("timestamp", "imu.acc.x", "imu.acc.y", "imu.acc.z", "imu.temperature")
    tab = read_table(path, cols, delimiter="\t")
    num = numbers(tab, cols)
    _increasing(path, tab.lines, num[:, 0], "timestamp")
    if len(num) < 2:
        raise RigInputError(str(path), tab.lines[-1], None, "expected at least two samples")
    temp = num[:, 4]
    try:
        unit = timestamp_unit(num[:, 0], temp)
    except ValueError as exc:
        raise RigInputError(str(path), tab.lines[0], "timestamp", str(exc)) from None
    t = (num[:, 0] - num[0, 0]) * TIME_UNITS[unit]
    acc = to_counts_equivalent(num[:, 1:4], "m/s^2", g_ms2)
    steps = [ImportedStep(name=f"window {k + 1} ({np.mean(temp[s:e]):.1f} C)", kind="static", t_s=t[s:e],
                          accel_counts=acc[s:e], temp_c=temp[s:e], pose_group=0)
             for k, (s, e) in enumerate(_windows(t, window_s))]
    return Recording(source="tofupilot", sensor_model="TofuPilot IMU thermal example (m/s^2)",
                     lsb_per_g=COUNTS_PER_G_EQUIVALENT, sample_rate_hz=sample_rate_hz(t), units="m/s^2",
                     steps_from="windows", steps=steps,
                     notes=[f"counts = a / {g_ms2} m/s^2 x {COUNTS_PER_G_EQUIVALENT} (10 ug per count)",
                            f"timestamp unit worked out from the data: {unit}",
                            f"consecutive {window_s:g} s windows of one unknown pose (pose_group 0)",
                            "gyro (imu.gyro.*) and imu.status not imported"],
                     extra={"timestamp_unit": unit, "window_s": window_s})


# -- generic csv ----------------------------------------------------------------------------------
CSV_UNITS = ("counts", "g", "m/s^2")


def _csv_units(tab: Table) -> tuple[str, float]:
    """Units and counts per g from the ``# units:`` and ``# lsb_per_g:`` comments."""
    path = str(tab.path)
    if "units" not in tab.comments:
        raise RigInputError(path, 1, "units", f"expected a first-line comment '# units: {'|'.join(CSV_UNITS)}'")
    no, units = tab.comments["units"]
    if units not in CSV_UNITS:
        raise RigInputError(path, no, "units", f"expected one of {', '.join(CSV_UNITS)}, got {units!r}")
    lsb = tab.comments.get("lsb_per_g")
    if units != "counts":
        if lsb is not None:
            raise RigInputError(path, lsb[0], "lsb_per_g", f"applies to units: counts only (units here: {units})")
        return units, float(COUNTS_PER_G_EQUIVALENT)
    if lsb is None:
        raise RigInputError(path, no, "lsb_per_g", "units: counts needs a '# lsb_per_g: N' comment (counts per g)")
    try:
        value = float(lsb[1])
    except ValueError:
        value = float("nan")
    if not (np.isfinite(value) and value > 0):
        raise RigInputError(path, lsb[0], "lsb_per_g", f"expected a positive number of counts per g, got {lsb[1]!r}")
    return units, value


def _label_runs(labels: list[str]) -> list[tuple[int, int, str]]:
    """Runs of equal non-empty labels as (start, end, label); unlabelled rows belong to no run."""
    runs, start = [], 0
    for i in range(1, len(labels) + 1):
        if i == len(labels) or labels[i] != labels[start]:
            if labels[start]:
                runs.append((start, i, labels[start]))
            start = i
    return runs


def _labelled_steps(labels: list[str], t, acc, temp) -> list[ImportedStep]:
    """One step per run of labels: a pose name ("+X up") gives f_nominal, a label containing "rot"
    a rotation step, any other label an unknown pose (one pose_group per distinct label)."""
    groups: dict[str, int] = {}
    steps = []
    for s, e, lab in _label_runs(labels):
        f = CUBE.get(lab)
        rot = f is None and "rot" in lab.lower()
        group = None if f is not None or rot else groups.setdefault(lab, len(groups))
        steps.append(ImportedStep(name=lab, kind="rotation" if rot else "static", t_s=t[s:e], accel_counts=acc[s:e],
                                  temp_c=None if temp is None else temp[s:e],
                                  f_nominal=None if f is None else [float(x) for x in f], pose_group=group))
    return steps


def read_csv(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    """Generic CSV (docs/import.md): ``t_s, ax, ay, az`` [, ``temp_c``, ``label``]."""
    tab = read_table(path, ("t_s", "ax", "ay", "az"))
    units, lsb = _csv_units(tab)
    num = numbers(tab, ("t_s", "ax", "ay", "az"))
    t = num[:, 0]
    _increasing(path, tab.lines, t, "t_s")
    if len(t) < 2:
        raise RigInputError(str(path), tab.lines[-1], None, "expected at least two samples")
    if units == "counts":
        acc = _integer_counts(path, tab.lines, num[:, 1:], "ax")
    else:
        acc = to_counts_equivalent(num[:, 1:], units, g_ms2)
    temp = numbers(tab, ("temp_c",))[:, 0] if "temp_c" in tab.header else None
    t = t - t[0]
    if "label" in tab.header:
        labels = [r[tab.header.index("label")] for r in tab.rows]
        steps, how = _labelled_steps(labels, t, acc, temp), "labels"
        if not steps:
            raise RigInputError(str(path), tab.lines[0], "label", "the label column is empty on every row")
    else:
        how = "static detection"
        steps = [ImportedStep(name=f"static {k + 1}", kind="static", t_s=t[s:e], accel_counts=acc[s:e],
                              temp_c=None if temp is None else temp[s:e], pose_group=k)
                 for k, (s, e) in enumerate(detect_static(t, acc))]
    return Recording(source="csv", sensor_model=f"generic csv ({units})", lsb_per_g=lsb,
                     sample_rate_hz=sample_rate_hz(t), units=units, steps_from=how, steps=steps,
                     notes=[] if units == "counts" else
                     [f"counts = a{'' if units == 'g' else f' / {g_ms2} m/s^2'} x {COUNTS_PER_G_EQUIVALENT} (10 ug per count)"])
