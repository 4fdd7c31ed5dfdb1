"""Sessions (``rig-session/1``): the recording on disk. See docs/session-format.md.

A session is a directory:

- ``session.yaml``: the manifest, rewritten atomically (temp file, fsync, rename) after each step;
- ``samples.csv``: append-only raw samples, fsynced at every step end;
- ``events.jsonl``: one JSON object per line (moves, settles, warnings, errors, prompts);
- ``calibration.yaml`` when solved; ``sim_truth.yaml`` for simulated rigs (tests only).

Nothing is lost: a crash loses at most the step in progress, and
:meth:`SessionWriter.resume` cuts ``samples.csv`` back to the last fsynced
step so no step is ever duplicated.
"""

from __future__ import annotations

import io
import json
import os
import re
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import yaml

from calib.calfile import atomic_write_text
from rig.errors import SessionFormatError

FORMAT = "rig-session/1"
BASE_COLUMNS = ("t_s", "step", "ax", "ay", "az", "temp_c")
OPTIONAL_COLUMNS = ("wx", "wy", "wz", "mx", "my", "mz", "a1_deg", "a2_deg", "a3_deg")
STATUSES = ("running", "complete", "aborted")
STEP_STATUSES = ("pending", "complete", "failed", "flagged")
_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,127}$")


def validate_session_id(session_id: str) -> str:
    """A session id is one path component: letters, digits, '_', '-', '.'; never '..'."""
    if not isinstance(session_id, str) or not _ID_RE.match(session_id) or ".." in session_id:
        raise SessionFormatError(None, None, "id", f"invalid session id {session_id!r} "
                                 "(letters, digits, '_', '-', '.'; no path separators or '..')")
    return session_id


def _utc() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


class SessionWriter:
    """Writes one session directory. Create with :meth:`create` or :meth:`resume`."""

    def __init__(self, session_dir: Path, manifest: dict, columns: tuple[str, ...]) -> None:
        self.session_dir = Path(session_dir)
        self.manifest = manifest
        self.columns = columns
        self._samples = open(self.session_dir / "samples.csv", "a", newline="")
        self._events = open(self.session_dir / "events.jsonl", "a")

    # -- construction ------------------------------------------------------------------
    @classmethod
    def create(cls, sessions_root, session_id: str, manifest: dict,
               columns: tuple[str, ...] | None = None) -> "SessionWriter":
        """Create ``sessions_root/session_id`` and write the manifest and the CSV header."""
        validate_session_id(session_id)
        columns = tuple(columns) if columns else BASE_COLUMNS + ("a1_deg", "a2_deg", "a3_deg")
        root = Path(sessions_root)
        root.mkdir(parents=True, exist_ok=True)
        d = root / session_id
        if d.resolve().parent != root.resolve():
            raise SessionFormatError(str(d), None, "id", "session directory would be outside the sessions root")
        d.mkdir(exist_ok=False)
        m = {"format": FORMAT, "id": session_id}
        m.update({k: v for k, v in manifest.items() if k not in ("format", "id")})
        m.setdefault("created", _utc())
        m.setdefault("status", "running")
        m["columns"] = list(columns)
        header = ",".join(columns) + "\n"
        with open(d / "samples.csv", "w") as fh:
            fh.write(header)
            fh.flush()
            os.fsync(fh.fileno())
        m["samples_committed_bytes"] = len(header.encode())
        (d / "events.jsonl").touch()
        atomic_write_text(d / "session.yaml", _dump(m))
        w = cls(d, m, tuple(columns))
        w.event("start", session=session_id)
        return w

    @classmethod
    def resume(cls, session_dir) -> tuple["SessionWriter", int]:
        """Reopen an interrupted session; return the writer and the first incomplete step.

        ``samples.csv`` is cut back to the size recorded after the last fsynced step,
        discarding any samples of the step that was in progress.
        """
        d = Path(session_dir)
        m = _read_manifest(d)
        if m["status"] == "complete":
            raise SessionFormatError(str(d / "session.yaml"), None, "status",
                                     "session is already complete; nothing to resume")
        csv_path = d / "samples.csv"
        committed = int(m.get("samples_committed_bytes", 0))
        size = csv_path.stat().st_size
        if size < committed:
            raise SessionFormatError(str(csv_path), None, None,
                                     f"samples.csv is shorter ({size} bytes) than the {committed} bytes already committed: "
                                     "the file was damaged")
        if size > committed:
            with open(csv_path, "r+b") as fh:
                fh.truncate(committed)
                fh.flush()
                os.fsync(fh.fileno())
        first = next((s["index"] for s in m["steps"] if s.get("status") not in ("complete", "flagged")),
                     len(m["steps"]))
        m["status"] = "running"
        w = cls(d, m, tuple(m.get("columns") or BASE_COLUMNS))
        w._write_manifest()
        if size > committed:
            w.event("warning", message=f"discarded {size - committed} bytes of samples of the step in progress "
                                       f"when the session stopped (step {first + 1})")
        return w, first

    # -- writing -----------------------------------------------------------------------
    def append_samples(self, step_index: int, t_s, accel_counts, temp_c=None, gyro_counts=None,
                       mag_counts=None, angles_deg=None) -> None:
        """Append samples of one step (streamed; durable at :meth:`complete_step`)."""
        t = np.asarray(t_s, float)
        n = len(t)
        if n == 0:
            return
        cols: dict[str, np.ndarray] = {"t_s": t, "step": np.full(n, int(step_index))}
        a = np.asarray(accel_counts, np.int64)
        cols.update(ax=a[:, 0], ay=a[:, 1], az=a[:, 2])
        cols["temp_c"] = np.asarray(temp_c, float) if temp_c is not None else None
        if gyro_counts is not None:
            g = np.asarray(gyro_counts, np.int64)
            cols.update(wx=g[:, 0], wy=g[:, 1], wz=g[:, 2])
        if mag_counts is not None:  # rows without a magnetometer reading are NaN -> empty cells
            mm = np.asarray(mag_counts, float)
            cols.update(mx=mm[:, 0], my=mm[:, 1], mz=mm[:, 2])
        if angles_deg is not None:
            an = np.asarray(angles_deg, float)
            cols.update(a1_deg=an[:, 0], a2_deg=an[:, 1], a3_deg=an[:, 2])
        parts = []
        for c in self.columns:
            v = cols.get(c)
            if v is None:
                parts.append(np.full(n, "", dtype=object))
            elif c == "t_s":
                parts.append(np.char.mod("%.5f", v))
            elif c in ("temp_c",):
                s = np.char.mod("%.4f", v).astype(object)
                s[~np.isfinite(v)] = ""
                parts.append(s)
            elif c.endswith("_deg"):
                parts.append(np.char.mod("%.5f", v))
            elif c in ("mx", "my", "mz"):
                ok = np.isfinite(v)
                s = np.full(n, "", dtype=object)
                s[ok] = np.char.mod("%d", v[ok].astype(np.int64)).astype(object)
                parts.append(s)
            else:
                parts.append(np.char.mod("%d", v))
        rows = [",".join(r) for r in zip(*[p.astype(str) for p in parts])]
        self._samples.write("\n".join(rows) + "\n")

    def complete_step(self, index: int, stats: dict, status: str = "complete") -> None:
        """Make the step's samples durable (flush + fsync), then record it in the manifest."""
        if status not in STEP_STATUSES:
            raise ValueError(f"unknown step status {status!r}")
        self._samples.flush()
        os.fsync(self._samples.fileno())
        self.manifest["samples_committed_bytes"] = os.path.getsize(self.session_dir / "samples.csv")
        step = self.manifest["steps"][index]
        step["status"] = status
        step["stats"] = _plain(stats)
        self._write_manifest()

    def event(self, kind: str, **fields) -> None:
        rec = {"utc": _utc(), "kind": kind}
        rec.update(_plain(fields))
        self._events.write(json.dumps(rec, allow_nan=False, default=str) + "\n")
        self._events.flush()

    def set_status(self, status: str) -> None:
        if status not in STATUSES:
            raise ValueError(f"unknown session status {status!r}")
        self.manifest["status"] = status
        if status != "running":
            self.manifest["ended"] = _utc()
        self._write_manifest()
        if status != "running":
            self.close()

    def close(self) -> None:
        for fh in (self._samples, self._events):
            if not fh.closed:
                fh.flush()
                os.fsync(fh.fileno())
                fh.close()

    def _write_manifest(self) -> None:
        atomic_write_text(self.session_dir / "session.yaml", _dump(_plain(self.manifest)))


_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml when present: 10x faster
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _dump(doc) -> str:
    return yaml.dump(doc, Dumper=_DUMPER, sort_keys=False, allow_unicode=True)


def _plain(v):
    """Plain YAML/JSON-safe values (numpy scalars/arrays to Python; NaN to None)."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and v != v:
        return None
    return v


# -- reading --------------------------------------------------------------------------------
REQUIRED = {"format": str, "id": str, "created": str, "status": str, "procedure": dict, "rig": dict,
            "software": dict, "steps": list}


def _read_manifest(d: Path) -> dict:
    path = d / "session.yaml"
    if not d.is_dir():
        raise SessionFormatError(str(d), None, None, "no such session directory")
    if not path.is_file():
        raise SessionFormatError(str(path), None, None, "missing: not a rig-session/1 directory")
    try:
        m = yaml.load(path.read_text(), Loader=_LOADER)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise SessionFormatError(str(path), mark.line + 1 if mark else None, None, "not valid YAML") from None
    if not isinstance(m, dict):
        raise SessionFormatError(str(path), None, None, "expected a mapping")
    if m.get("format") != FORMAT:
        raise SessionFormatError(str(path), None, "format", f"expected {FORMAT!r}, got {m.get('format')!r}")
    for k, t in REQUIRED.items():
        if k not in m:
            raise SessionFormatError(str(path), None, k, "missing required field")
        if not isinstance(m[k], t):
            raise SessionFormatError(str(path), None, k, f"expected a {t.__name__}")
    if m["status"] not in STATUSES:
        raise SessionFormatError(str(path), None, "status", f"expected one of {', '.join(STATUSES)}")
    sensor = m["rig"].get("sensor")
    if not isinstance(sensor, dict):
        raise SessionFormatError(str(path), None, "rig.sensor", "missing sensor description")
    for k in ("accel_lsb_per_g", "sample_rate_hz"):
        v = sensor.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
            raise SessionFormatError(str(path), None, f"rig.sensor.{k}", f"expected a positive number, got {v!r}")
    for i, s in enumerate(m["steps"]):
        w = f"steps[{i}]"
        if not isinstance(s, dict) or s.get("index") != i:
            raise SessionFormatError(str(path), None, w, f"expected a step mapping with index {i}")
        if s.get("status") not in STEP_STATUSES:
            raise SessionFormatError(str(path), None, f"{w}.status", f"expected one of {', '.join(STEP_STATUSES)}")
        fn = s.get("f_nominal")
        if fn is not None and not (isinstance(fn, list) and len(fn) == 3
                                   and all(isinstance(x, (int, float)) and np.isfinite(x) for x in fn)):
            raise SessionFormatError(str(path), None, f"{w}.f_nominal", "expected [x, y, z] in g, or null")
    return m


@dataclass
class Session:
    """A loaded, validated session."""

    path: Path
    manifest: dict
    samples: dict  # t_s (N,), step (N,), accel_counts (N,3), temp_c (N,), optional gyro/mag/angles
    warnings: list[str] = field(default_factory=list)

    @property
    def id(self) -> str:
        return self.manifest["id"]

    @property
    def has_temperature(self) -> bool:
        return bool(self.manifest["rig"]["sensor"].get("has_temperature"))

    @property
    def lsb_per_g(self) -> float:
        return float(self.manifest["rig"]["sensor"]["accel_lsb_per_g"])

    @property
    def solve_spec(self) -> dict | None:
        text = self.manifest["procedure"].get("text")
        if not text:
            return None
        try:
            doc = yaml.safe_load(text)
        except yaml.YAMLError:
            return None
        return doc.get("solve") if isinstance(doc, dict) else None

    def step_samples(self, index: int) -> dict:
        sel = self.samples["step"] == index
        return {k: (v[sel] if isinstance(v, np.ndarray) else v) for k, v in self.samples.items()}

    def static_step_indices(self, include_flagged: bool = False, unknown_pose: bool = False) -> list[int]:
        """Indices of complete static steps with a known pose (and, with ``unknown_pose``, without one)."""
        ok = ("complete", "flagged") if include_flagged else ("complete",)
        return [s["index"] for s in self.manifest["steps"]
                if s.get("kind", "static") == "static" and s.get("status") in ok
                and (unknown_pose or s.get("f_nominal") is not None)]

    def step_means(self, include=None):
        """Per-step means for the solver (complete static steps with a known pose)."""
        from calib.data import StepMeans

        idx = self.static_step_indices() if include is None else list(include)
        step = self.samples["step"]
        order = np.argsort(step, kind="stable")
        s_sorted = step[order]
        names, f_nom, means, sems, ns, temps, ts = [], [], [], [], [], [], []
        for i in idx:
            lo, hi = np.searchsorted(s_sorted, i, "left"), np.searchsorted(s_sorted, i, "right")
            rows = order[lo:hi]
            n = len(rows)
            if n < 2:
                raise SessionFormatError(str(self.path / "samples.csv"), None, f"step {i}",
                                         f"step {i + 1} is marked complete but has {n} samples")
            a = self.samples["accel_counts"][rows].astype(float)
            st = self.manifest["steps"][i]
            names.append(st.get("name", f"step {i + 1}"))
            f_nom.append(st["f_nominal"] if st.get("f_nominal") is not None else [np.nan] * 3)
            means.append(a.mean(axis=0))
            sems.append(np.maximum(a.std(axis=0, ddof=1), 1.0 / np.sqrt(12.0)) / np.sqrt(n))
            ns.append(n)
            if self.has_temperature:
                tc = self.samples["temp_c"][rows]
                if not np.all(np.isfinite(tc)):
                    raise SessionFormatError(str(self.path / "samples.csv"), int(rows[~np.isfinite(tc)][0]) + 2,
                                             "temp_c", f"step {i + 1} has rows without a temperature")
                temps.append(float(np.mean(tc)))
            else:
                temps.append(np.nan)
            tt = self.samples["t_s"][rows]
            ts.append(0.5 * (tt.min() + tt.max()))
        if not idx:
            raise SessionFormatError(str(self.path), None, "steps", "no complete static step with a known pose to solve"
                                     " (steps with unknown poses: use --method magnitude)")
        return StepMeans(names=tuple(names), f_nominal_g=np.array(f_nom, float), mean_counts=np.array(means),
                         sem_counts=np.array(sems), n_samples=np.array(ns, int),
                         temp_c=np.array(temps) if self.has_temperature else None, t_s=np.array(ts),
                         lsb_per_g=self.lsb_per_g)


def rate_step_means(session: "Session", accel=None):
    """Per-step gyroscope means of the complete rate steps (calib.gyro.RateStepMeans), with the mean
    specific force of each step (for the g-sensitivity): from the accelerometer calibration ``accel``
    when given, else the raw accelerometer divided by its nominal sensitivity."""
    from calib.gyro import RateStepMeans
    sensor = session.manifest["rig"]["sensor"]
    lsb = sensor.get("gyro_lsb_per_dps")
    if "gyro_counts" not in session.samples or not lsb:
        raise SessionFormatError(str(session.path), None, "rig.sensor", "the session has no gyroscope data")
    steps = [s for s in session.manifest["steps"] if s.get("kind") == "rate" and s.get("status") == "complete"]
    if not steps:
        raise SessionFormatError(str(session.path), None, "steps", "no complete rate step")
    names, w, means, sems, ns, fs = [], [], [], [], [], []
    for st in steps:
        rows = session.samples["step"] == st["index"]
        g = session.samples["gyro_counts"][rows].astype(float)
        # the mean specific force during the step (raw accelerometer, g): for the gyro's g-sensitivity
        a_mean = session.samples["accel_counts"][rows].mean(axis=0)
        if accel is not None:
            tc = session.samples["temp_c"][rows]
            t_mean = float(np.mean(tc)) if np.all(np.isfinite(tc)) and len(tc) else None
            fs.append(accel.apply(a_mean[None, :], temp_c=t_mean, t_s=float(np.mean(session.samples["t_s"][rows])))[0])
        else:
            fs.append(a_mean / session.lsb_per_g)
        if len(g) < 2 or not np.all(np.isfinite(g)):
            raise SessionFormatError(str(session.path / "samples.csv"), None, f"step {st['index']}",
                                     f"rate step {st['index'] + 1} has no usable gyroscope samples")
        names.append(st.get("name"))
        w.append(st["rate_nominal_dps"])
        means.append(g.mean(axis=0))
        sems.append(np.maximum(g.std(axis=0, ddof=1), 1.0 / np.sqrt(12.0)) / np.sqrt(len(g)))
        ns.append(len(g))
    return RateStepMeans(names=tuple(names), rate_nominal_dps=np.array(w, float), mean_counts=np.array(means),
                         sem_counts=np.array(sems), n_samples=np.array(ns), lsb_per_dps=float(lsb),
                         f_mean_g=np.array(fs, float))


def mag_step_means(session: "Session", known_field: bool = True):
    """Per-step magnetometer means (calib.magnetometer.MagStepMeans) of the static steps that have
    readings; with ``known_field`` the nominal field in the sensor frame from the site field and the
    step's stage angles (None when the session records no site field)."""
    from calib.magnetometer import MagStepMeans
    from rig.planning.kinematics import sensor_to_world
    mag_info = session.manifest["rig"]["sensor"].get("magnetometer") or {}
    lsb = float(mag_info.get("mag_lsb_per_ut") or 100.0)
    if "mag_counts" not in session.samples:
        return None
    site = session.manifest["rig"].get("site")
    h_world = None
    if known_field and site:
        inc, dec = np.radians(site["inclination_deg"]), np.radians(site["declination_deg"])
        hor = site["field_ut"] * np.cos(inc)
        h_world = np.array([hor * np.cos(dec), hor * np.sin(dec), -site["field_ut"] * np.sin(inc)])
    names, h, means, sems, ns = [], [], [], [], []
    for st in session.manifest["steps"]:
        if st.get("kind", "static") != "static" or st.get("status") != "complete":
            continue
        rows = session.samples["step"] == st["index"]
        m = session.samples["mag_counts"][rows]
        m = m[np.all(np.isfinite(m), axis=1)] / lsb
        if len(m) < 2:
            continue
        names.append(st.get("name"))
        if h_world is not None and st.get("angles_deg") is not None:
            r = sensor_to_world(np.asarray([st["angles_deg"]], float))[0]
            h.append(r.T @ h_world)
        means.append(m.mean(axis=0))
        sems.append(np.maximum(m.std(axis=0, ddof=1), 0.01) / np.sqrt(len(m)))
        ns.append(len(m))
    if not names:
        return None
    field = np.array(h, float) if len(h) == len(names) else None
    return MagStepMeans(names=tuple(names), field_nominal_ut=field, mean_ut=np.array(means), sem_ut=np.array(sems),
                        n_samples=np.array(ns))


def load_session(path) -> Session:
    """Load and validate a session directory (manifest, samples; events are not needed to solve)."""
    d = Path(path)
    m = _read_manifest(d)
    samples, warnings = read_samples(d / "samples.csv", n_steps=len(m["steps"]))
    if m["rig"]["sensor"].get("has_temperature"):
        t = samples["temp_c"]
        if len(t) and not np.any(np.isfinite(t)):
            raise SessionFormatError(str(d / "samples.csv"), 1, "temp_c",
                                     "the manifest says the sensor has a thermometer, but there are no temperatures")
    return Session(d, m, samples, warnings)


def read_samples(path: Path, n_steps: int | None = None) -> tuple[dict, list[str]]:
    """Read samples.csv fast; accept extra columns in any order; drop a torn last line (saying so)."""
    warnings: list[str] = []
    if not path.is_file():
        raise SessionFormatError(str(path), None, None, "missing samples.csv")
    raw = path.read_bytes()
    if not raw:
        raise SessionFormatError(str(path), 1, None, "empty file: expected a header line")
    nl = raw.find(b"\n")
    if nl < 0:
        raise SessionFormatError(str(path), 1, None, "no header line")
    header = raw[:nl].decode("ascii", "replace").strip().split(",")
    if any(not c.strip() for c in header) or len(set(header)) != len(header):
        raise SessionFormatError(str(path), 1, None, f"header has empty or repeated column names: {','.join(header)}")
    for c in ("t_s", "step", "ax", "ay", "az"):
        if c not in header:
            raise SessionFormatError(str(path), 1, c, f"missing column (header: {','.join(header)})")
    body = raw[nl + 1:]
    if body and not body.endswith(b"\n"):
        cut = body.rfind(b"\n")
        torn_line = body[:cut + 1].count(b"\n") + 2
        body = body[:cut + 1] if cut >= 0 else b""
        warnings.append(f"{path}:{torn_line}: dropped a torn last line (the run stopped while writing it)")
    ncol = len(header)
    known = [c for c in header if c in BASE_COLUMNS + OPTIONAL_COLUMNS]
    use = [header.index(c) for c in known]  # extra columns (any type) are ignored
    if not body.strip():
        arr = np.empty((0, len(use)))
    else:
        # empty fields (no thermometer, absent optional columns) become NaN
        text = body.replace(b",,", b",nan,").replace(b",,", b",nan,")
        text = text.replace(b",\n", b",nan\n")
        if text.startswith(b","):
            text = b"nan" + text
        text = text.replace(b"\n,", b"\nnan,")
        try:
            arr = np.loadtxt(io.BytesIO(text), delimiter=",", dtype=float, ndmin=2, usecols=use,
                             converters=None)
        except ValueError as exc:
            line = _bad_line(body, ncol)
            raise SessionFormatError(str(path), line, None,
                                     f"expected {ncol} comma-separated numbers per row ({str(exc).splitlines()[0]})") from None
    ragged = _ragged_line(body, ncol)
    if ragged is not None:
        raise SessionFormatError(str(path), ragged, None, f"expected {ncol} comma-separated fields as in the header")
    col = {c: arr[:, i] for i, c in enumerate(known)}
    for c in ("t_s", "step", "ax", "ay", "az"):
        bad = ~np.isfinite(col[c])
        if bad.any():
            raise SessionFormatError(str(path), int(np.argmax(bad)) + 2, c, "expected a number, got an empty field or NaN")
    accel = np.stack([col["ax"], col["ay"], col["az"]], axis=1)
    if np.any(accel != np.round(accel)):
        raise SessionFormatError(str(path), int(np.argmax(np.any(accel != np.round(accel), axis=1))) + 2, "ax",
                                 "raw counts must be integers")
    step = col["step"].astype(np.int64)
    if n_steps is not None and len(step) and (step.min() < 0 or step.max() >= n_steps):
        bad = int(np.argmax((step < 0) | (step >= n_steps)))
        raise SessionFormatError(str(path), bad + 2, "step", f"step {step[bad]} is not in the manifest (0..{n_steps - 1})")
    out = {"t_s": col["t_s"], "step": step, "accel_counts": accel.astype(np.int64),
           "temp_c": col["temp_c"] if "temp_c" in col else np.full(len(step), np.nan)}
    if all(c in col for c in ("wx", "wy", "wz")):
        out["gyro_counts"] = np.stack([col["wx"], col["wy"], col["wz"]], axis=1)
    if all(c in col for c in ("mx", "my", "mz")):
        out["mag_counts"] = np.stack([col["mx"], col["my"], col["mz"]], axis=1)
    if all(c in col for c in ("a1_deg", "a2_deg", "a3_deg")):
        out["angles_deg"] = np.stack([col["a1_deg"], col["a2_deg"], col["a3_deg"]], axis=1)
    return out, warnings


def _ragged_line(body: bytes, ncol: int) -> int | None:
    counts = np.array([line.count(b",") + 1 for line in body.split(b"\n") if line])
    bad = np.flatnonzero(counts != ncol)
    return int(bad[0]) + 2 if len(bad) else None


def _bad_line(body: bytes, ncol: int) -> int | None:
    for i, line in enumerate(body.split(b"\n")):
        if not line:
            continue
        fields = line.split(b",")
        if len(fields) != ncol:
            return i + 2
        for f in fields:
            if f and f.strip().lower() != b"nan":
                try:
                    float(f)
                except ValueError:
                    return i + 2
    return None
