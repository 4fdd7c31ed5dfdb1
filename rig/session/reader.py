"""Reading a session: :func:`load_session` (manifest and samples) and :func:`read_samples`.

``samples.csv`` is read by one C reader in one call when every cell is a number (the file ``rig run`` writes
for a sensor with a thermometer: numpy's, or pandas' where pandas is loaded already, :func:`_whole_reader`),
else field by field with pandas: CRLF line endings, a UTF-8 byte-order mark, quoted fields and
columns in any order, with extra (even non-numeric) columns, load like the plain file. Every refusal
is one :class:`rig.errors.SessionFormatError` line naming the file and the line: a bad header, a
ragged row, a non-numeric cell, an empty or NaN ``t_s``/``step``/``ax``/``ay``/``az``, non-integer
counts or step indices, a step not in the manifest. A torn last line (a crash while writing it) is
dropped with a warning.
"""

from __future__ import annotations

import csv
import functools
import io
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from drivers.sensors.chips import CHIPS
from rig.config.yamlload import SymlinkLoop
from rig.errors import RigInputError, SessionFormatError
from rig.session import adapter
from rig.session.manifest import BASE_COLUMNS, OPTIONAL_COLUMNS, SessionManifest, StepRecord
from rig.session.seal import SamplesCheck, verify_on_load

if TYPE_CHECKING:  # type hints only
    from rig.config.procedure import Procedure

REQUIRED_COLUMNS = ("t_s", "step", "ax", "ay", "az")
_BOM = b"\xef\xbb\xbf"
_NA = ["", "nan", "NaN", "NAN", "-nan", "+nan"]
_FLOAT64 = np.dtype(np.float64)
_BLOCK_BYTES = 2 << 20  # samples.csv is parsed in blocks of about this many bytes (whole lines)


@dataclass
class Session:
    """A loaded, validated session: ``info`` is the typed manifest, ``samples`` the columns as arrays.

    ``samples``: ``t_s`` (N,), ``step`` (N,) int, ``accel_counts`` (N, 3) int, ``temp_c`` (N,) (NaN
    when absent), and ``gyro_counts``, ``mag_counts``, ``angles_deg`` (N, 3) when recorded.
    The recorded procedure (:attr:`procedure`) and the events (:attr:`events`) are read on first use,
    once: a session is read from disk once, whatever asks what of it.
    """

    path: Path
    info: SessionManifest
    samples: dict
    warnings: list[str] = field(default_factory=list)
    #: sensor -> the unit's own BiasStability from its noise profile (rig.lab.noise_profiles), used instead of the family's
    unit_noise: dict = field(default_factory=dict)

    @property
    def id(self) -> str:
        return self.info.id

    @property
    def steps(self) -> list[StepRecord]:
        return self.info.steps

    @property
    def has_temperature(self) -> bool:
        return bool(self.info.rig.sensor.has_temperature)

    @property
    def lsb_per_g(self) -> float:
        return float(self.info.rig.sensor.accel_lsb_per_g)

    @property
    def solve_spec(self) -> dict | None:
        return self.info.procedure.solve_spec()

    @functools.cached_property
    def procedure(self) -> "Procedure | None":
        """The procedure the session recorded (``procedure.text``), validated once; None for a session
        without one (an import). A recorded text that no longer validates is one SessionFormatError
        naming session.yaml (the file it was once read from may have changed since)."""
        recorded = self.info.procedure
        if not recorded.text:
            return None
        from rig.config.procedure import load_procedure_text  # deferred: the procedure models, only when asked

        try:
            return load_procedure_text(recorded.text, recorded.file or "<session>")
        except RigInputError as exc:
            where = f"line {exc.line}: " if exc.line else ""
            key = f"{exc.key}: " if exc.key else ""
            raise SessionFormatError(str(self.path / "session.yaml"), None, "procedure.text",
                                     f"the recorded procedure (from {recorded.file or 'an unnamed file'}) does not "
                                     f"validate: {where}{key}{exc.message}") from None

    def procedure_asks(self, key: str):
        """The validated ``procedure.<key>`` when the recorded procedure's text has ``key`` (``accept``, ``target``,
        ``report``...), else None. The raw text is asked first: a text without the key (an import's, which need
        not validate as a procedure) is not validated for nothing."""
        if self.info.procedure.value(key) is None:
            return None
        return getattr(self.procedure, key)

    @functools.cached_property
    def events(self) -> list[dict]:
        """The session's events (``events.jsonl``), read once; a torn last line (a crash) is skipped."""
        return read_events(self.path)

    def step_samples(self, index: int) -> dict:
        sel = self.samples["step"] == index
        return {k: (v[sel] if isinstance(v, np.ndarray) else v) for k, v in self.samples.items()}

    def static_step_indices(self, include_flagged: bool = False, unknown_pose: bool = False) -> list[int]:
        """Indices of complete static steps with a known pose (and, with ``unknown_pose``, without one)."""
        ok = ("complete", "flagged") if include_flagged else ("complete",)
        return [s.index for s in self.info.steps
                if s.is_static and s.status in ok and (unknown_pose or s.has_pose)]

    def step_means(self, include=None):
        """Per-step means for the solver: :func:`rig.session.adapter.step_means`."""
        return adapter.step_means(self, include)


def load_session(path) -> Session:
    """Load and validate a session directory (manifest, samples; events are not needed to solve). A sealed
    session is checked against its seal after the format checks (:func:`rig.session.seal.verify_on_load`): one
    that differs is refused (``RIG_UNSEALED=1``: loaded with a warning, its id marked ``.SEAL-BROKEN``)."""
    d = Path(path)
    for p, expected in ((d, "a session directory"), (d / "session.yaml", "session.yaml"),
                        (d / "samples.csv", "samples.csv")):
        refuse_symlink_loop(p, expected)
    info, doc = SessionManifest.load(d)
    check_sensor(d / "session.yaml", info)
    # a sealed session's samples.csv is checked against its seal as it is read: read once to load and to verify
    check = SamplesCheck(d, doc, (d / "samples.csv").stat().st_size) if "seal" in doc else None
    samples, warnings = read_samples(d / "samples.csv", n_steps=len(info.steps), tap=check)
    check_against_manifest(d / "samples.csv", info, samples)
    if info.rig.sensor.has_temperature:
        t = samples["temp_c"]
        if len(t) and not np.any(np.isfinite(t)):
            raise SessionFormatError(str(d / "samples.csv"), 1, "temp_c",
                                     "the manifest says the sensor has a thermometer, but there are no temperatures")
    # sealed: the recording as made, else refused naming the file and step (RIG_UNSEALED=1: loaded, marked, warned)
    unsealed = verify_on_load(d, info, doc, samples=check)
    return Session(d, info, samples, unsealed + warnings)


def read_events(session_dir) -> list[dict]:
    """The events of a session directory (``events.jsonl``; a torn or damaged line is skipped)."""
    path = Path(session_dir) / "events.jsonl"
    out = []
    if not path.is_file():
        return out
    for line in path.read_text().splitlines():
        try:
            e = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(e, dict):
            out.append(e)
    return out


def refuse_symlink_loop(path: Path, expected: str) -> None:
    """A path that is a loop of symbolic links is refused as such (not as "missing"), naming it."""
    try:
        path.stat()
    except OSError as exc:
        if isinstance(exc, SymlinkLoop):
            raise SessionFormatError(str(path), None, None, f"{SymlinkLoop.message}, expected {expected}") from None


def check_against_manifest(path: Path, info: SessionManifest, samples: dict) -> None:
    """Samples that contradict the manifest are refused: counts beyond the recorded sensor's range,
    a finished step with more or fewer rows than recorded (rows duplicated or lost)."""
    sensor = info.rig.sensor
    if sensor.accel_range_g and sensor.accel_lsb_per_g:
        limit = float(sensor.accel_range_g) * float(sensor.accel_lsb_per_g)  # full scale: [-limit, limit - 1]
        a = samples["accel_counts"]
        over = (a > limit - 1) | (a < -limit)
        if over.any():
            row, axis = np.argwhere(over)[0]
            raise SessionFormatError(str(path), int(row) + 2, f"a{'xyz'[axis]}",
                                     f"{samples['accel_counts'][row, axis]} counts is beyond the "
                                     f"{sensor.accel_range_g:g} g range of the {sensor.model} ({limit:.0f} counts)")
    gyro = samples.get("gyro_counts")
    if gyro is not None and sensor.gyro_lsb_per_dps and info.rig.turntable is not None:
        missing = ~np.all(np.isfinite(gyro), axis=1)
        if missing.any():
            row = int(np.argmax(missing))
            raise SessionFormatError(str(path), row + 2, "wx", "the sensor recorded its gyroscope in every row; "
                                     "this row has an empty or NaN gyro count")
    counts = np.bincount(samples["step"], minlength=len(info.steps)) if len(samples["step"]) else \
        np.zeros(len(info.steps), int)
    for step in info.steps:
        n = step.stats.n_samples if step.stats is not None else None
        if step.status in ("complete", "flagged") and n is not None and int(counts[step.index]) != int(n):
            raise SessionFormatError(str(path), None, f"step {step.index + 1} (index {step.index} in samples.csv)",
                                     f"{int(counts[step.index])} rows, but the manifest recorded {int(n)} samples "
                                     "(rows duplicated or lost)")
    check_poses(path, info, samples, counts)


#: no sensor's output word is wider than 16 bits (a range's full scale in counts); nor any count than 2^31
CHIP_FULL_SCALE_COUNTS = 32768.0
MAX_FULL_SCALE_COUNTS = 2.0**31


def check_sensor(path: Path, info: SessionManifest) -> None:
    """The recorded accelerometer settings must be possible: a range the chip has, and a sensitivity
    (counts/g) whose full scale fits the chip's 16-bit output (a sensor the registry does not know: 2^31)."""
    s = info.rig.sensor
    chip = CHIPS.get(s.model) if isinstance(s.model, str) else None
    if chip is not None and s.accel_range_g is not None and s.accel_range_g not in chip.accel_ranges_g:
        raise SessionFormatError(str(path), None, "rig.sensor.accel_range_g",
                                 f"expected one of {', '.join(map(str, chip.accel_ranges_g))} (the {chip.model}'s "
                                 f"ranges, g), got {s.accel_range_g!r}")
    lsb, span = float(s.accel_lsb_per_g), float(s.accel_range_g or 1.0)
    limit = CHIP_FULL_SCALE_COUNTS if chip is not None else MAX_FULL_SCALE_COUNTS
    if not lsb * span <= limit:
        raise SessionFormatError(str(path), None, "rig.sensor.accel_lsb_per_g",
                                 f"{lsb:g} counts/g at {span:g} g is a full scale of {lsb * span:.3g} counts, beyond "
                                 f"the {limit:.0f} counts {'of the ' + chip.model if chip else 'any sensor gives'}: "
                                 "not this sensor's sensitivity")


#: a static step's mean specific force points within this angle of its pose's f_nominal: a sensor's bias,
#: scale and misalignment errors and a tilted mount stay far below it; ax/ay swapped or a sign flipped
#: (another sensor frame), or a mislabelled pose, are 90 or 180 deg off
MAX_POSE_ANGLE_DEG = 20.0
#: f_nominal is the specific force at rest: a unit vector in g, within this
F_NOMINAL_TOLERANCE_G = 0.2


def check_poses(path: Path, info: SessionManifest, samples: dict, counts: np.ndarray) -> None:
    """Refuse a session whose data contradict its poses: each complete static step with a known pose must
    read gravity (the mean of its raw counts) along its f_nominal, within :data:`MAX_POSE_ANGLE_DEG`.
    Otherwise the solver (and evaluate, discover) would fit the wrong axes and give a wrong number."""
    steps = [s for s in info.steps if s.is_static and s.status == "complete" and s.f_nominal is not None
             and counts[s.index] > 0]
    for st in steps:
        f = np.asarray(st.f_nominal, float)
        if not abs(np.linalg.norm(f) - 1.0) <= F_NOMINAL_TOLERANCE_G:
            raise SessionFormatError(str(path.parent / "session.yaml"), None, f"steps[{st.index}].f_nominal",
                                     f"expected the specific force at rest, a unit vector in g, got {f.tolist()} "
                                     f"(|f| = {np.linalg.norm(f):.3g} g)")
    if not steps:
        return
    a, step = samples["accel_counts"], samples["step"]
    sums = np.stack([np.bincount(step, weights=a[:, j].astype(float), minlength=len(counts)) for j in range(3)], 1)
    for st in steps:
        mean, f = sums[st.index] / counts[st.index], np.asarray(st.f_nominal, float)
        norm = float(np.linalg.norm(mean))
        cosine = float(mean @ f) / (norm * float(np.linalg.norm(f))) if norm > 0 else 0.0
        angle = float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))
        if angle > MAX_POSE_ANGLE_DEG:
            along = np.round(mean / norm, 2).tolist() if norm > 0 else [0, 0, 0]
            raise SessionFormatError(str(path), None, f"step {st.index + 1} (index {st.index} in samples.csv)",
                                     f"the data of {st.label} read gravity along {along}, "
                                     f"{angle:.0f} deg from its pose's f_nominal {np.round(f, 3).tolist()} "
                                     f"(session.yaml; at most {MAX_POSE_ANGLE_DEG:g} deg for a sensor at rest): "
                                     "columns swapped or sign-flipped, or a mislabelled pose")


def read_samples(path: Path, n_steps: int | None = None, tap=None) -> tuple[dict, list[str]]:
    """Read samples.csv: the columns as arrays, and the warnings (a dropped torn last line).

    The file is read in blocks of whole lines (``_BLOCK_BYTES``), each parsed, checked and copied into
    arrays allocated once for every line the file has, so memory holds the result and one block, never
    the file's text beside its parsed columns (a file with quotes is read as one block: a quoted field
    may span lines). Every refusal names the file line, as for a file read at once.

    ``tap``: given every byte of the file once, in order, as it is read (``tap.update(bytes)``; a block read
    again is not given again): :class:`rig.session.seal.SamplesCheck` verifies a seal on the same read.
    """
    path = Path(path)
    if not path.is_file():
        raise SessionFormatError(str(path), None, None, "missing samples.csv")
    warnings: list[str] = []
    with open(path, "rb") as raw:
        fh = raw if tap is None else _Tapped(raw, tap)
        header = _header(path, fh)
        known = [c for c in header if c in BASE_COLUMNS + OPTIONAL_COLUMNS]
        if os.fstat(fh.fileno()).st_size - fh.tell() <= _BLOCK_BYTES:  # one block: its arrays as they are
            blocks = [_read_block(text, header, known, n_steps) for text in _bodies(path, fh, warnings)]
            if len(blocks) == 1:
                return blocks[0], warnings
            fh.seek(0)
            _header(path, fh)
            warnings.clear()
        out = _Columns(known, _lines_after(fh))
        for text in _bodies(path, fh, warnings):
            out.add(_read_block(text, header, known, n_steps))
    return out.arrays(), warnings


class _Tapped:
    """A binary file whose bytes are also given, once each and in order, to ``tap`` as they are first read."""

    def __init__(self, fh, tap) -> None:
        self._fh, self._tap, self._seen = fh, tap, 0

    def _give(self, at: int, data: bytes) -> bytes:
        if at + len(data) > self._seen:
            self._tap.update(data[max(self._seen - at, 0):])
            self._seen = at + len(data)
        return data

    def read(self, n: int = -1) -> bytes:
        return self._give(self._fh.tell(), self._fh.read(n))

    def readline(self, n: int = -1) -> bytes:
        return self._give(self._fh.tell(), self._fh.readline(n))

    def seek(self, pos: int, whence: int = 0) -> int:
        return self._fh.seek(pos, whence)

    def tell(self) -> int:
        return self._fh.tell()

    def fileno(self) -> int:
        return self._fh.fileno()


def _read_block(text: "_Body", header: list[str], known: list[str], n_steps: int | None) -> dict:
    """One block of data lines as the arrays of :class:`Session`, after every check."""
    col = _parse_whole(text, header, known)
    if col is None:
        ragged = text.first_ragged(len(header))
        if ragged is not None:
            raise SessionFormatError(str(text.path), ragged, None, f"expected {len(header)} comma-separated fields "
                                                                    "as in the header")
        col = _parse(text, header, known)
    _check(text, col, n_steps)
    return _arrays(col)


def _parse_whole(text: "_Body", header: list[str], known: list[str]) -> dict[str, np.ndarray] | None:
    """The common file (every column known, every cell a number, every row as wide as the header) read by one
    C reader in one call (:func:`_whole_reader`); None when it refuses a cell or a row (or for anything else), and
    the block is read field by field with its refusals."""
    if text.quoted or known != header or not text.body.strip():
        return None
    reader = _whole_reader()
    try:
        values = (_pandas_whole(text.body) if reader == "pandas" else
                  np.loadtxt(io.BytesIO(text.body), delimiter=",", dtype=float, comments=None, ndmin=2,
                             encoding="utf-8"))
    except ValueError:
        return None
    if values.ndim != 2 or values.shape[1] != len(header):
        return None
    if reader == "pandas" and len(values) != text.n_records():
        return None  # pandas skipped a line of spaces (numpy's refuses it): refused, with its line, by the caller
    return {c: values[:, j] for j, c in enumerate(known)}


#: which C reader reads the common file: "auto" (:func:`_whole_reader`), "numpy" or "pandas" (the tests run both)
WHOLE_READER = "auto"


def _whole_reader() -> str:
    """pandas' C reader where pandas 3 or newer is already loaded in this process (an analysis in Python, a notebook:
    a third faster than numpy's on samples.csv, and correctly rounded, as numpy's is), numpy's otherwise (a command
    that would import pandas, 0.3 s, to save a millisecond). Both give identical arrays and refusals
    (tests/rig/session/test_whole_readers.py)."""
    if WHOLE_READER != "auto":
        return WHOLE_READER
    pd = sys.modules.get("pandas")
    version = getattr(pd, "__version__", "0")
    return "pandas" if pd is not None and version[:1].isdigit() and int(version.split(".")[0]) >= 3 else "numpy"


def _pandas_whole(body: bytes) -> np.ndarray:
    """Every cell of ``body`` (data lines, no header) as float64 by pandas' C reader; ValueError for an empty or
    non-numeric cell, a row shorter than the first (its missing cells are empty) or wider (no NA values: an empty
    cell is refused, as numpy's does). A line of spaces it skips as blank: the caller counts the rows."""
    import pandas as pd  # loaded already (_whole_reader)

    return pd.read_csv(io.BytesIO(body), header=None, dtype=_FLOAT64, na_filter=False, engine="c",
                       encoding="utf-8").to_numpy()


class _Columns:
    """The arrays of :class:`Session` for at most ``capacity`` rows, allocated at once and filled block by
    block (a few large allocations: reading does not fragment the heap with block-sized arrays)."""

    def __init__(self, known: list[str], capacity: int) -> None:
        like = _arrays({c: np.empty(0) for c in known})
        self._out = {k: np.empty((capacity,) + v.shape[1:], v.dtype) for k, v in like.items()}
        self._n = 0

    def add(self, block: dict) -> None:
        m = len(block["step"])
        for key, v in block.items():
            if self._n + m > len(self._out[key]):  # the file grew since its lines were counted (still written)
                self._out[key].resize((self._n + m,) + v.shape[1:], refcheck=False)
            self._out[key][self._n:self._n + m] = v
        self._n += m

    def arrays(self) -> dict:
        """The rows filled (the spare ones of blank lines released)."""
        for v in self._out.values():
            if len(v) != self._n:
                v.resize((self._n,) + v.shape[1:], refcheck=False)
        return self._out


def _lines_after(fh) -> int:
    """Newlines from the file position to the end (at least the data rows there); the position is kept."""
    at, n = fh.tell(), 0
    while chunk := fh.read(_BLOCK_BYTES):
        n += chunk.count(b"\n")
    fh.seek(at)
    return n


def _header(path: Path, fh) -> list[str]:
    """The header's column names (the first line; a UTF-8 byte-order mark skipped)."""
    line = fh.readline()
    if line.startswith(_BOM):
        line = line[len(_BOM):]
    if not line:
        raise SessionFormatError(str(path), 1, None, "empty file: expected a header line")
    if not line.endswith(b"\n"):
        raise SessionFormatError(str(path), 1, None, "no header line")
    text = line[:-1].decode("utf-8", "replace")
    header = [c.strip() for c in next(csv.reader([text.rstrip("\r")]), [])]
    if not header or any(not c for c in header) or len(set(header)) != len(header):
        raise SessionFormatError(str(path), 1, None, f"header has empty or repeated column names: {','.join(header)}")
    for c in REQUIRED_COLUMNS:
        if c not in header:
            raise SessionFormatError(str(path), 1, c, f"missing column (header: {','.join(header)})")
    return header


def _bodies(path: Path, fh, warnings: list[str]):
    """The data lines after the header as :class:`_Body` blocks of whole lines; a torn last line (no
    newline: the run stopped while writing it) is dropped, with a warning."""
    first_line, rest = 2, b""
    while True:
        chunk = fh.read(_BLOCK_BYTES)
        data = rest + chunk if rest else chunk
        if chunk and b'"' in data:  # quotes: one block to the end (a quoted field may hold a newline)
            data += fh.read()
            chunk = b""
        cut = data.rfind(b"\n")
        body, rest = data[:cut + 1], data[cut + 1:]
        if body:
            block = _Body(path, body, first_line)
            yield block
            first_line += block.n_lines
        if not chunk:
            break
    if rest:
        warnings.append(f"{path}:{first_line}: dropped a torn last line (the run stopped while writing it)")


class _Body:
    """Data lines of samples.csv (all, or a block of whole lines whose first is file line
    ``first_line``): field counts per line and the file line of a data row."""

    def __init__(self, path: Path, body: bytes, first_line: int = 2) -> None:
        self.path, self.body, self.first_line = path, body, first_line
        self.quoted = b'"' in body
        self._bytes = np.frombuffer(body, np.uint8)
        self._ends = np.flatnonzero(self._bytes == 10)  # every line ends with a newline
        self._line_info: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def n_lines(self) -> int:
        return len(self._ends)

    def n_records(self) -> int:
        """The lines that are not blank (no character but a carriage return): the data rows."""
        return int(np.count_nonzero(~self._lines()[1]))

    def _lines(self) -> tuple[np.ndarray, np.ndarray]:
        """Start of every line, and whether it is blank (every line ends with a newline)."""
        if self._line_info is None:
            a, ends = self._bytes, self._ends
            starts = np.concatenate([[0], ends[:-1] + 1]).astype(np.int64)
            length = ends - starts
            has_cr = np.zeros(len(ends), bool)
            has_cr[length > 0] = a[ends[length > 0] - 1] == 13
            self._line_info = starts, (length - has_cr) == 0
        return self._line_info

    def _records(self):
        """(file line, fields) of every non-blank record, quotes honoured (the slow path)."""
        reader = csv.reader(io.StringIO(self.body.decode("utf-8", "replace"), newline=""))
        try:
            for row in reader:
                if row:
                    yield reader.line_num + self.first_line - 1, row
        except csv.Error as exc:
            raise SessionFormatError(str(self.path), reader.line_num + self.first_line - 1, None,
                                     f"cannot read it ({exc})") from None

    def first_ragged(self, ncol: int) -> int | None:
        """The file line of the first row whose field count is not the header's, or None."""
        if not self.body:
            return None
        if self.quoted:
            return next((line for line, row in self._records() if len(row) != ncol), None)
        starts = np.concatenate([[0], self._ends[:-1] + 1])  # every line has its newline: none is empty
        per_line = np.add.reduceat((self._bytes == 44).view(np.uint8), starts, dtype=np.int32)  # commas
        bad = np.flatnonzero(per_line + 1 != ncol)
        if len(bad):
            bad = bad[~self._lines()[1][bad]]  # blank lines are skipped
        return int(bad[0]) + self.first_line if len(bad) else None

    def line_of(self, row: int) -> int | None:
        """The file line of data row ``row`` (0-based, blank lines skipped)."""
        if self.quoted:
            return next((line for k, (line, _) in enumerate(self._records()) if k == row), None)
        _, blank = self._lines()
        return int(np.flatnonzero(~blank)[row]) + self.first_line

    def first_non_number(self, header: list[str], known: list[str]) -> tuple[int | None, str | None, str]:
        """Where a cell of a known column is not a number (the slow path, after pandas refused)."""
        use = [header.index(c) for c in known]
        for line, row in self._records():
            for j in use:
                cell = row[j].strip() if j < len(row) else ""
                if cell in _NA:
                    continue
                try:
                    float(cell)
                except ValueError:
                    return line, header[j], cell
        return None, None, ""


def _parse(text: _Body, header: list[str], known: list[str]) -> dict[str, np.ndarray]:
    """The known columns as float arrays (empty cells are NaN)."""
    if not text.body.strip():
        return {c: np.empty(0) for c in known}
    if not text.quoted:  # the common file (every cell a number): numpy's C reader, no pandas to import
        try:
            values = np.loadtxt(io.BytesIO(text.body), delimiter=",", dtype=float, comments=None, ndmin=2,
                                usecols=[header.index(c) for c in known], encoding="utf-8")
            return {c: values[:, j] for j, c in enumerate(known)}
        except ValueError:
            pass  # an empty cell (no temperature, a row without a magnetometer reading), or a bad one: pandas
    import pandas as pd  # deferred: 0.16 s to import; only for a file with empty or quoted cells, or a bad one

    try:
        df = pd.read_csv(io.BytesIO(text.body), header=None, names=header, usecols=known,
                         dtype={c: _FLOAT64 for c in known}, na_values=_NA, keep_default_na=False,
                         skip_blank_lines=True, encoding="utf-8", encoding_errors="replace", engine="c")
    except (ValueError, pd.errors.ParserError) as exc:
        line, column, cell = text.first_non_number(header, known)
        detail = f"expected a number, got {cell[:40]!r}" if line else f"cannot read it ({str(exc).splitlines()[0]})"
        raise SessionFormatError(str(text.path), line, column, detail) from None
    values = (df if list(df.columns) == known else df[known]).to_numpy(dtype=float)  # (rows, the known columns)
    return {c: values[:, j] for j, c in enumerate(known)}


#: no raw count of any sensor or import is larger (2^31); a sensor's own range is checked on load
MAX_COUNTS = float(2**31)
MAX_ABS_TEMP_C = 1000.0


def _check(text: _Body, col: dict[str, np.ndarray], n_steps: int | None) -> None:
    """Refuse NaN or empty required cells, non-integer counts and steps, and steps not in the manifest."""
    path = str(text.path)
    for c in REQUIRED_COLUMNS:
        bad = ~np.isfinite(col[c])
        if bad.any():
            raise SessionFormatError(path, text.line_of(int(np.argmax(bad))), c,
                                     "expected a number, got an empty field or NaN")
    for c in ("ax", "ay", "az", "wx", "wy", "wz", "mx", "my", "mz"):
        if c not in col:
            continue
        v = col[c]
        bad = np.isfinite(v) & (v != np.round(v))
        if bad.any():
            raise SessionFormatError(path, text.line_of(int(np.argmax(bad))), c, "raw counts must be integers")
        bad = np.isinf(v) | (np.isfinite(v) & (np.abs(v) > MAX_COUNTS))
        if bad.any():
            k = int(np.argmax(bad))
            raise SessionFormatError(path, text.line_of(k), c, f"raw counts beyond +-{MAX_COUNTS:.0f}, got {v[k]:g}")
    if "temp_c" in col:
        t = col["temp_c"]
        bad = np.isfinite(t) & (np.abs(t) > MAX_ABS_TEMP_C) | np.isinf(t)
        if bad.any():
            k = int(np.argmax(bad))
            raise SessionFormatError(path, text.line_of(k), "temp_c", f"expected a temperature in C within "
                                     f"+-{MAX_ABS_TEMP_C:g}, got {t[k]:g}")
    step = col["step"]
    bad = step != np.round(step)
    if bad.any():
        k = int(np.argmax(bad))
        raise SessionFormatError(path, text.line_of(k), "step", f"step indices must be integers, got {step[k]:g}")
    if n_steps is not None and len(step):
        bad = (step < 0) | (step >= n_steps)
        if bad.any():
            k = int(np.argmax(bad))
            raise SessionFormatError(path, text.line_of(k), "step",
                                     f"index {step[k]:.0f} is no step of the manifest (its {n_steps} steps are "
                                     f"indices 0..{n_steps - 1}: step 1 is index 0)")


def _arrays(col: dict[str, np.ndarray]) -> dict:
    """The samples mapping of :class:`Session` from the parsed columns."""
    n = len(col["step"])
    out = {"t_s": col["t_s"].copy(), "step": col["step"].astype(np.int64),  # copies: not views of the parsed block
           "accel_counts": np.stack([col["ax"], col["ay"], col["az"]], axis=1).astype(np.int64),
           "temp_c": col["temp_c"].copy() if "temp_c" in col else np.full(n, np.nan)}
    for key, names in (("gyro_counts", ("wx", "wy", "wz")), ("mag_counts", ("mx", "my", "mz")),
                       ("angles_deg", ("a1_deg", "a2_deg", "a3_deg"))):
        if all(c in col for c in names):
            out[key] = np.stack([col[c] for c in names], axis=1)
    return out
