"""What every importer shares: the recording it returns, the streamed reading of a text table, the spool.

An importer reads its source once, block by block (:func:`text_blocks`: about 4 MiB of whole lines at a
time), checks every row and appends the parsed numbers to a :class:`Spool` (binary columns in files of
the import's ``.partial`` directory). What needs the whole series is computed from the spool or from a
bounded summary: the median sample interval by :func:`exact_median` (a few passes over the times),
static intervals by :class:`calib.numerics.static_detect.StaticDetector` (fed chunk by chunk), each
step's checks and statistics by :func:`summarize` (one pass). The session is then written from the spool
chunk by chunk. Memory is bounded by the block and chunk sizes, not by the file; the values, steps and
statistics are those the whole-file reading gave (the same parsing of each cell, the same arithmetic).

Every problem with a source file raises :class:`rig.errors.RigInputError` naming the file and,
where there is one, the line and the column.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import pandas as pd

from rig.errors import RigInputError
from rig.session.reader import MAX_POSE_ANGLE_DEG

G_MS2 = 9.80665
COUNTS_PER_G_EQUIVALENT = 100000.0  # counts-equivalent of physical units: 10 ug per count

#: characters of text read per block (whole lines are added to reach the end of a line)
BLOCK_CHARS = 4 << 20
#: no line of a recording is longer than this (a file without line ends is refused, not read whole)
MAX_LINE_CHARS = 16 << 20
#: rows per chunk when the spool is read back (detection, statistics, writing the session)
CHUNK_ROWS = 65536
#: at most this many steps: the cap of a session (rig.config: 10,000 steps, listed or expanded)
MAX_STEPS = 10000


@dataclass
class ImportedStep:
    """One step of a recording: the spool rows it takes (``rows``: (start, end) ranges, in order)."""

    name: str
    kind: str  # static | rotation
    rows: list[tuple[int, int]]
    f_nominal: list | None = None
    pose_group: int | None = None
    first_line: int | None = None  # the source line of its first row (named by a pose check)

    @property
    def n_samples(self) -> int:
        return sum(b - a for a, b in self.rows)


@dataclass
class Recording:
    """What an importer found: steps, units and provenance; the samples are in ``spool``."""

    source: str
    sensor_model: str
    lsb_per_g: float
    sample_rate_hz: float
    units: str
    steps_from: str  # labels | static detection | windows
    steps: list[ImportedStep] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    gyro_lsb_per_dps: float | None = None
    spool: "Spool | None" = None
    #: times as written: (spooled time - time_origin) * time_scale (tofupilot), else the spooled time
    time_origin: float | None = None
    time_scale: float = 1.0
    #: a static step with a pose must read +-1 g along its pose's axis (imucal's parts)
    check_axis_sign: bool = False
    #: magnetometer counts per uT (the spool's ``mag`` column) and the units they came in
    mag_lsb_per_ut: float | None = None
    mag_units: str | None = None
    #: what became of each input column (the import's summary; docs/import.md)
    columns: list[str] = field(default_factory=list)

    @property
    def has_temperature(self) -> bool:
        return bool(self.steps) and self.spool is not None and "temp" in self.spool.columns

    @property
    def has_gyro(self) -> bool:
        return bool(self.steps) and self.spool is not None and "gyro" in self.spool.columns

    @property
    def has_mag(self) -> bool:
        return bool(self.steps) and self.spool is not None and "mag" in self.spool.columns

    @property
    def has_accel(self) -> bool:
        """False for a recording without accelerometer columns (its session stores 0 counts: docs/import.md)."""
        return self.spool is None or "acc" in self.spool.columns

    def times(self, raw: np.ndarray) -> np.ndarray:
        return raw if self.time_origin is None else (raw - self.time_origin) * self.time_scale

    def step_chunks(self, step: ImportedStep, rows: int | None = None) -> Iterator[dict]:
        """The step's samples, ``rows`` at a time: ``t`` (s), ``counts`` (n, 3) int (zeros without an
        accelerometer), ``temp`` or None, ``gyro`` and ``mag`` (n, 3) int or None."""
        rows = rows or CHUNK_ROWS
        cols = self.spool.columns
        for a, b in step.rows:
            for lo in range(a, b, rows):
                hi = min(b, lo + rows)
                t = self.times(self.spool.read("t", lo, hi))
                counts = np.rint(self.spool.read("acc", lo, hi)).astype(np.int64) if "acc" in cols \
                    else np.zeros((hi - lo, 3), np.int64)
                temp = self.spool.read("temp", lo, hi) if "temp" in cols else None
                gyro = np.rint(self.spool.read("gyro", lo, hi)).astype(np.int64) if "gyro" in cols else None
                mag = np.rint(self.spool.read("mag", lo, hi)).astype(np.int64) if "mag" in cols else None
                yield {"t": t, "counts": counts, "temp": temp, "gyro": gyro, "mag": mag}


# -- the spool -------------------------------------------------------------------------------------

class Spool:
    """Parsed rows in binary files (one float64 file per column group) under ``directory``: appended
    block by block while the source is read, then read back by row range."""

    def __init__(self, directory: Path, columns: dict[str, int]) -> None:
        """``columns``: name -> width (1 for a column, 3 for x, y, z)."""
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.columns = dict(columns)
        self.n_rows = 0
        self._files = {name: open(self.directory / f"{name}.f8", "w+b") for name in columns}

    def append(self, **arrays: np.ndarray) -> None:
        n = None
        for name, width in self.columns.items():
            a = np.ascontiguousarray(arrays[name], dtype=np.float64)
            if a.shape != ((len(a),) if width == 1 else (len(a), width)) or (n is not None and len(a) != n):
                raise ValueError(f"spool column {name}: shape {a.shape}")
            n = len(a)
            self._files[name].write(a.tobytes())
        self.n_rows += n or 0

    def drop_column(self, name: str) -> None:
        self.columns.pop(name)
        self._files.pop(name).close()
        (self.directory / f"{name}.f8").unlink()

    def finish(self) -> None:
        for fh in self._files.values():
            fh.flush()

    def read(self, name: str, start: int, stop: int) -> np.ndarray:
        width = self.columns[name]
        fh = self._files[name]
        fh.seek(start * width * 8)
        a = np.fromfile(fh, np.float64, count=max(0, stop - start) * width)
        return a if width == 1 else a.reshape(-1, width)

    def chunks(self, name: str, rows: int | None = None, start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
        rows, stop = rows or CHUNK_ROWS, self.n_rows if stop is None else stop
        for lo in range(start, stop, rows):
            yield self.read(name, lo, min(stop, lo + rows))

    def close(self) -> None:
        for fh in self._files.values():
            fh.close()


class Spools:
    """Where an import's spools go (``directory``): each made by :meth:`new`, all closed by :meth:`close`
    (also when the import fails half-way)."""

    def __init__(self, directory: Path) -> None:
        self.directory = Path(directory)
        self._made: list[Spool] = []

    def new(self, columns: dict[str, int]) -> Spool:
        spool = Spool(self.directory, columns)
        self._made.append(spool)
        return spool

    def close(self) -> None:
        for spool in self._made:
            spool.close()


def diffs(spool: Spool, name: str = "t") -> Callable[[], Iterator[np.ndarray]]:
    """The differences of consecutive values of column ``name`` (as ``np.diff`` of the whole column),
    chunk by chunk, each time the returned function is called."""
    def chunks():
        prev = None
        for c in spool.chunks(name):
            yield np.diff(c) if prev is None else np.diff(np.concatenate([[prev], c]))
            prev = c[-1]
    return chunks


#: at most this many values are sorted in memory by :func:`exact_median`
MEDIAN_IN_MEMORY = 2_000_000


def exact_median(chunks: Callable[[], Iterator[np.ndarray]], n: int, in_memory: int | None = None) -> float:
    """``np.median`` of the ``n`` values that ``chunks()`` yields (finite, >= 0), in bounded memory.

    Up to ``in_memory`` values are sorted in memory; more are selected by their bit patterns (for
    non-negative floats the order of the patterns is the order of the values), 16 bits per pass over
    the chunks: the same one or two middle values, averaged as ``np.median`` does.
    """
    if n <= (MEDIAN_IN_MEMORY if in_memory is None else in_memory):
        values = [c for c in chunks()]
        return float(np.median(np.concatenate(values) if values else np.empty(0)))
    middle = sorted({(n - 1) // 2, n // 2})
    found = {k: _kth_smallest(chunks, k) for k in middle}
    return float(np.mean(np.array([found[(n - 1) // 2], found[n // 2]])))


def _kth_smallest(chunks: Callable[[], Iterator[np.ndarray]], k: int) -> float:
    prefix, rank = 0, k
    for shift in (48, 32, 16, 0):
        hist = np.zeros(1 << 16, np.int64)
        for c in chunks():
            u = np.ascontiguousarray(c, np.float64).view(np.uint64)
            if shift < 48:
                u = u[(u >> np.uint64(shift + 16)) == np.uint64(prefix)]
            hist += np.bincount(((u >> np.uint64(shift)) & np.uint64(0xFFFF)).astype(np.intp), minlength=1 << 16)
        cum = np.cumsum(hist)
        b = int(np.searchsorted(cum, rank, side="right"))
        rank -= int(cum[b - 1]) if b else 0
        prefix = (prefix << 16) | b
    return float(np.array([prefix], np.uint64).view(np.float64)[0])


def pairwise_sum(read: Callable[[int, int], np.ndarray], n: int, leaf: int = 1 << 20) -> float:
    """``np.sum`` of ``n`` float64 values read by ``read(start, count)``, to the bit: numpy's pairwise
    summation, its halves recursed here down to pieces of at most ``leaf`` values that numpy sums."""
    if n <= max(leaf, 128):  # numpy sums up to 128 values in one unrolled block
        return float(np.add.reduce(read(0, n), initial=0.0))
    half = n // 2
    half -= half % 8
    return pairwise_sum(read, half, leaf) + pairwise_sum(lambda a, m: read(half + a, m), n - half, leaf)


# -- reading text in blocks ------------------------------------------------------------------------

def open_text(path: Path):
    """The source as text: UTF-8 (undecodable bytes replaced), every line end read as ``\\n``."""
    return open(path, encoding="utf-8", errors="replace", newline=None)


def read_line(path: Path, fh, line: int) -> str:
    """One line of ``fh`` (at most :data:`MAX_LINE_CHARS`)."""
    text = fh.readline(MAX_LINE_CHARS)
    if len(text) >= MAX_LINE_CHARS and not text.endswith("\n"):
        raise RigInputError(str(path), line, None, f"cannot read this line (longer than {MAX_LINE_CHARS >> 20} MiB)")
    return text


def text_blocks(path: Path, fh, first_line: int, delimiter: str | None = None) -> Iterator[tuple[int, str]]:
    """Blocks of whole lines of ``fh`` (about :data:`BLOCK_CHARS`), each with the number of its first
    line. With a ``delimiter`` (a csv table) a block never ends inside a quoted field."""
    line = first_line
    while True:
        block = fh.read(BLOCK_CHARS)
        if not block:
            return
        if not block.endswith("\n"):
            block += read_line(path, fh, line + block.count("\n"))
        if delimiter and '"' in block and inside_quotes(block, delimiter):
            parts, size, inside = [block], len(block), True
            while inside:
                more = read_line(path, fh, line + sum(p.count("\n") for p in parts))
                if not more:
                    break
                parts.append(more)
                size += len(more)
                inside = inside_quotes(more, delimiter, inside)
                if size > MAX_LINE_CHARS + BLOCK_CHARS:
                    raise RigInputError(str(path), line + block.count("\n"), None, "cannot read this line (a quoted"
                                        f" field does not end within {MAX_LINE_CHARS >> 20} MiB)")
            block = "".join(parts)
        yield line, block
        line += block.count("\n")


def inside_quotes(text: str, delimiter: str, inside: bool = False) -> bool:
    """Whether the csv module, reading ``text`` (whole lines) from within a quoted field (``inside``) or
    not, ends within one: a quote at the start of a field opens one, ``""`` in one is a quote, a single
    quote in one closes it, any other quote is a character of its field."""
    escaped = False
    for m in re.finditer('"', text):
        q = m.start()
        if escaped:
            escaped = False
        elif inside:
            escaped = text[q + 1:q + 2] == '"'
            inside = escaped
        elif q == 0 or text[q - 1] in (delimiter, "\n"):
            inside = True
    return inside


# -- a delimited table, block by block ---------------------------------------------------------------

#: characters that send a block to the exact (row by row) reading: line breaks of str.splitlines other
#: than \n, NUL, quotes
_NOT_FAST = re.compile('[\x00\x0b\x0c\x1c-\x1e\r"]')


@dataclass
class TableBlock:
    """Rows of one block: their source lines, the numeric columns asked for (n, k) and the text ones."""

    lines: np.ndarray
    numbers: np.ndarray
    texts: list[list[str]]

    def __len__(self) -> int:
        return len(self.lines)


class Table:
    """A delimited text table read block by block: the header (with the ``required`` columns), then
    :meth:`blocks` of checked rows. ``splitlines``: lines are ``str.splitlines``' lines (as the generic
    CSV was always read), else the csv module's."""

    def __init__(self, path: Path, fh, header_line: str, line: int, required: list[str], delimiter: str,
                 splitlines: bool = False) -> None:
        self.path, self.fh, self.delimiter, self.splitlines = path, fh, delimiter, splitlines
        if not header_line.strip():
            raise RigInputError(str(path), 1, None, "empty file: expected a header line")
        try:
            first = next(csv.reader([header_line.rstrip("\n")], delimiter=delimiter), [])
        except csv.Error as exc:
            raise RigInputError(str(path), line, None, f"cannot read this line ({exc})") from None
        self.header = [h.strip() for h in first]
        missing = [c for c in required if c not in self.header]
        if missing:
            raise RigInputError(str(path), 1, None, f"expected columns {', '.join(required)}; missing "
                                f"{', '.join(missing)} (got {', '.join(self.header) or 'nothing'})")
        self.first_line = line + 1
        self.n_rows = 0

    def blocks(self, numeric: list[str], text: list[str] = ()) -> Iterator[TableBlock]:
        """The rows, block by block: ``numeric`` columns as finite floats, ``text`` columns as strings."""
        num = [self.header.index(c) for c in numeric]
        txt = [self.header.index(c) for c in text]
        for line, block in text_blocks(self.path, self.fh, self.first_line, self.delimiter):
            rows = self._fast(block, line, num, txt)
            if rows is None:
                rows = self._exact(block, line, num, txt)
            self.n_rows += len(rows)
            if len(rows):
                yield rows
        if self.n_rows == 0:
            raise RigInputError(str(self.path), self.first_line, None, "no data rows after the header")

    def _fast(self, block: str, line: int, num: list[int], txt: list[int]) -> TableBlock | None:
        """The block by pandas' C parser, when it is plain ASCII without quotes and every non-blank line has
        the header's number of fields; None (read it exactly) otherwise or when a cell is not a finite number."""
        if not block.isascii() or _NOT_FAST.search(block):
            return None
        raw = block.encode() if block.endswith("\n") else (block + "\n").encode()
        a = np.frombuffer(raw, np.uint8)
        ends = np.flatnonzero(a == 10)
        starts = np.concatenate([[0], ends[:-1] + 1])
        blank = ends == starts
        delims = np.flatnonzero(a == ord(self.delimiter))
        fields = np.searchsorted(delims, ends) - np.searchsorted(delims, starts) + 1
        if np.any(~blank & (fields != len(self.header))) or np.max(ends - starts) > csv.field_size_limit():
            return None
        cols = sorted(set(num + txt))
        try:
            df = pd.read_csv(io.BytesIO(raw), sep=self.delimiter, header=None, names=list(range(len(self.header))),
                             usecols=cols, dtype={j: (str if j in txt else np.float64) for j in cols}, na_filter=False,
                             engine="c", quoting=csv.QUOTE_NONE, index_col=False, skip_blank_lines=True)
        except (ValueError, TypeError, pd.errors.ParserError):
            return None
        lines = line + np.flatnonzero(~blank)
        numbers = np.column_stack([df[j].to_numpy(np.float64) for j in num]) if num else np.empty((len(df), 0))
        if len(df) != len(lines) or not np.all(np.isfinite(numbers)):
            return None
        return TableBlock(lines, numbers, [df[j].tolist() for j in txt])

    def _exact(self, block: str, line: int, num: list[int], txt: list[int]) -> TableBlock:
        """The block row by row as the csv module and ``float`` read it: the first problem is refused with its line."""
        text = "\n".join(block.splitlines()) if self.splitlines else block
        reader = csv.reader(io.StringIO(text), delimiter=self.delimiter)
        lines, numbers, texts = [], [], [[] for _ in txt]
        before = 0
        while True:
            try:
                row = next(reader)
            except StopIteration:
                break
            except csv.Error as exc:
                raise RigInputError(str(self.path), line + reader.line_num - 1, None,
                                    f"cannot read this line ({exc})") from None
            at, before = line + before, reader.line_num
            if not row:
                continue
            if len(row) != len(self.header):
                raise RigInputError(str(self.path), at, None, f"expected {len(self.header)} fields as in the header, "
                                                              f"got {len(row)}")
            values = []
            for j in num:
                try:
                    values.append(float(row[j]))
                except ValueError:
                    raise RigInputError(str(self.path), at, self.header[j],
                                        f"expected a number, got {row[j]!r}") from None
            if not all(np.isfinite(values)):
                raise RigInputError(str(self.path), at, None, "expected finite numbers")
            lines.append(at)
            numbers.append(values)
            for k, j in enumerate(txt):
                texts[k].append(row[j])
        return TableBlock(np.array(lines, np.int64), np.array(numbers, np.float64).reshape(len(lines), len(num)),
                          texts)


class Increasing:
    """The first time stamp, fed block by block, that does not increase (kept to be refused after the
    whole file is read, as before: a cell that is no number comes first)."""

    def __init__(self) -> None:
        self.last: float | None = None
        self.bad_line: int | None = None

    def feed(self, t: np.ndarray, lines: np.ndarray) -> None:
        if not len(t):
            return
        if self.bad_line is None:
            full = t if self.last is None else np.concatenate([[self.last], t])
            bad = np.flatnonzero(np.diff(full) <= 0)
            if len(bad):  # difference i is row i + 1 of ``full``
                self.bad_line = int(lines[bad[0] + (1 if self.last is None else 0)])
        self.last = float(t[-1])

    def check(self, path: Path, column: str) -> None:
        if self.bad_line is not None:
            raise RigInputError(str(path), self.bad_line, column, "time stamps must increase")


class Runs:
    """Runs of equal values of a text column fed block by block: (start row, end row, value, first line);
    at most :data:`MAX_STEPS` of them."""

    def __init__(self, path: Path, what: str) -> None:
        self.path, self.what = path, what
        self.runs: list[list] = []
        self.n = 0

    def feed(self, values: list[str], lines: np.ndarray) -> None:
        if not values:
            return
        v = np.array(values, dtype=object)
        change = np.flatnonzero(v[1:] != v[:-1]) + 1
        starts = ([0] if not self.runs or self.runs[-1][2] != values[0] else []) + change.tolist()
        if self.runs:
            self.runs[-1][1] = self.n + (starts[0] if starts else len(v))
        for k, s in enumerate(starts):
            end = starts[k + 1] if k + 1 < len(starts) else len(v)
            self.runs.append([self.n + s, self.n + end, values[s], int(lines[s])])
        if len(self.runs) > MAX_STEPS:
            raise RigInputError(str(self.path), int(lines[starts[-1]]), None, f"the {self.what} changes more than "
                                f"{MAX_STEPS} times: more steps than a session holds")
        self.n += len(v)


# -- checks and statistics of the steps -----------------------------------------------------------

#: no accelerometer reads more than this many g: a larger imported value is not acceleration
MAX_IMPORT_G = 64.0
#: a labelled pose whose data point elsewhere (cosine of the angle below this) is mislabelled: the rule a
#: session's reader applies to every static step (the import would otherwise write a session it refuses)
MIN_POSE_COSINE = float(np.cos(np.radians(MAX_POSE_ANGLE_DEG)))


@dataclass
class StepSummary:
    """What one pass over a step's samples gives: its count, first and last time, the exact sum of its
    counts, the first value beyond any accelerometer's range, and its mean temperature."""

    n: int
    t_start: float
    t_end: float
    count_sum: np.ndarray
    first_big: float | None
    temp_mean: float | None

    @property
    def mean_counts(self) -> np.ndarray:
        # the sums are exact integers below 2**53: the mean numpy takes of the whole step's counts
        return self.count_sum.astype(float) / self.n


def summarize(rec: Recording) -> list[StepSummary]:
    """Each step's :class:`StepSummary`, from the spool."""
    limit = MAX_IMPORT_G * rec.lsb_per_g
    out = []
    for st in rec.steps:
        n, first, last, total, big = st.n_samples, None, None, np.zeros(3, np.int64), None
        for c in rec.step_chunks(st):
            first = float(c["t"][0]) if first is None else first
            last = float(c["t"][-1])
            over = np.abs(np.asarray(c["counts"], float)) > limit  # (a cast 1e300 is INT64_MIN)
            if big is None and over.any():
                big = float(c["counts"][over][0])
            total += c["counts"].sum(axis=0)
        temp = None
        if rec.has_temperature and n:
            temp = pairwise_sum(lambda a, m, st=st: _step_column(rec, st, "temp", a, m), n) / n
        out.append(StepSummary(n, first, last, total, big, temp))
    return out


def _step_column(rec: Recording, st: ImportedStep, name: str, start: int, count: int) -> np.ndarray:
    """Rows ``start .. start+count`` of the step (counted within the step) of spool column ``name``."""
    parts, pos = [], 0
    for a, b in st.rows:
        lo, hi = max(a, a + start - pos), min(b, a + start + count - pos)
        if hi > lo:
            parts.append(rec.spool.read(name, lo, hi))
        pos += b - a
    return np.concatenate(parts) if len(parts) != 1 else parts[0]


#: a static step's standard error comes from its own scatter: fewer samples than this cannot give one
MIN_STATIC_SAMPLES = 10


def check_recording(path: Path, rec: Recording, summaries: list[StepSummary]) -> None:
    """Refuse a recording whose steps cannot be what they claim: a rotation step of fewer than 2 samples,
    a static step of fewer than :data:`MIN_STATIC_SAMPLES`, values beyond any accelerometer's range, data
    that contradict their pose label."""
    if rec.check_axis_sign:
        for st, s in zip(rec.steps, summaries):
            if st.kind == "static" and st.f_nominal is not None:
                check_axis_sign(path, st, s.mean_counts)
    for st, s in zip(rec.steps, summaries):
        if s.first_big is not None:
            raise RigInputError(str(path), None, st.name, f"a value of {s.first_big:g} counts is beyond "
                                f"{MAX_IMPORT_G:g} g ({rec.lsb_per_g:g} counts/g): not acceleration in {rec.units}")
        if st.kind == "static" and st.f_nominal is not None and rec.has_accel:
            mean = s.mean_counts
            f = np.asarray(st.f_nominal, float)
            cosine = float(mean @ f / (np.linalg.norm(mean) * np.linalg.norm(f) or 1.0))
            if cosine < MIN_POSE_COSINE:
                raise RigInputError(str(path), None, st.name, f"the data of step {st.name!r} point along "
                                    f"{np.round(mean / (np.linalg.norm(mean) or 1.0), 2).tolist()}, not its label's "
                                    f"{np.round(f, 2).tolist()}: mislabelled")
        need = MIN_STATIC_SAMPLES if st.kind == "static" else 2
        if s.n < need:
            raise RigInputError(str(path), st.first_line, st.name, f"{st.kind} step {st.name!r} has {s.n} sample(s); "
                                f"a {st.kind} step needs at least {need}"
                                + (" (its standard error comes from its own scatter: label longer rests, or leave "
                                   "out the label column and let static detection find them)" if need > 2 else ""))


def check_axis_sign(path: Path, st: ImportedStep, mean: np.ndarray) -> None:
    """A static part must read +-1 g along its labelled axis, with its labelled sign (imucal)."""
    f = [int(x) for x in st.f_nominal]
    axis = int(np.argmax(np.abs(f)))
    dom = int(np.argmax(np.abs(mean)))
    if dom != axis or np.sign(mean[dom]) != np.sign(f[dom]):
        raise RigInputError(str(path), st.first_line, "part", f"part {st.name!r} should read +-1 g along "
                            f"{'xyz'[axis]} with sign {f[axis]:+d}, but its mean is {mean.round(0).tolist()} counts")
