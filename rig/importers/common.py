"""What every importer shares: the recording it returns and the checked reading of a text table.

Every problem with a source file raises :class:`rig.errors.RigInputError` naming the file and,
where there is one, the line and the column.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rig.errors import RigInputError
from rig.session.reader import MAX_POSE_ANGLE_DEG

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

    @property
    def has_temperature(self) -> bool:
        return any(st.temp_c is not None for st in self.steps)

    @property
    def has_gyro(self) -> bool:
        return any(st.gyro_counts is not None for st in self.steps)


def numbers(path: Path, rows: list[list[str]], first_line: int, cols: list[int], header: list[str]) -> np.ndarray:
    """The cells ``cols`` of ``rows`` as finite floats (the first bad cell is refused with its line)."""
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


def table(path: Path, text: str, required: list[str], delimiter: str) -> tuple[list[str], list[list[str]]]:
    """The header (with the ``required`` columns) and the non-empty rows of a delimited text table."""
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise RigInputError(str(path), 1, None, "empty file: expected a header line")
    rows = csv.reader(io.StringIO(text), delimiter=delimiter)
    try:
        reader = list(rows)
    except csv.Error as exc:
        raise RigInputError(str(path), rows.line_num, None, f"cannot read this line ({exc})") from None
    header = [h.strip() for h in reader[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise RigInputError(str(path), 1, None, f"expected columns {', '.join(required)}; missing {', '.join(missing)}"
                                                f" (got {', '.join(header) or 'nothing'})")
    body = [r for r in reader[1:] if r]
    if not body:
        raise RigInputError(str(path), 2, None, "no data rows after the header")
    for line, row in enumerate(reader[1:], start=2):
        if row and len(row) != len(header):
            raise RigInputError(str(path), line, None, f"expected {len(header)} fields as in the header, "
                                                       f"got {len(row)}")
    return header, body


#: no accelerometer reads more than this many g: a larger imported value is not acceleration
MAX_IMPORT_G = 64.0
#: a labelled pose whose data point elsewhere (cosine of the angle below this) is mislabelled: the rule a
#: session's reader applies to every static step (the import would otherwise write a session it refuses)
MIN_POSE_COSINE = float(np.cos(np.radians(MAX_POSE_ANGLE_DEG)))


def check_recording(path: Path, rec: Recording) -> None:
    """Refuse a recording whose steps cannot be what they claim: fewer than 2 samples in a step,
    values beyond any accelerometer's range, data that contradict their pose label."""
    limit = MAX_IMPORT_G * rec.lsb_per_g
    for st in rec.steps:
        if len(st.t_s) < 2:
            raise RigInputError(str(path), None, st.name, f"step {st.name!r} has {len(st.t_s)} sample(s); "
                                                          "a step needs at least 2")
        big = np.abs(np.asarray(st.accel_counts, float)) > limit  # (a cast 1e300 is INT64_MIN)
        if big.any():
            raise RigInputError(str(path), None, st.name, f"a value of {st.accel_counts[big][0]:g} counts is beyond "
                                f"{MAX_IMPORT_G:g} g ({rec.lsb_per_g:g} counts/g): not acceleration in {rec.units}")
        if st.kind == "static" and st.f_nominal is not None:
            mean = st.accel_counts.mean(axis=0)
            f = np.asarray(st.f_nominal, float)
            cosine = float(mean @ f / (np.linalg.norm(mean) * np.linalg.norm(f) or 1.0))
            if cosine < MIN_POSE_COSINE:
                raise RigInputError(str(path), None, st.name, f"the data of step {st.name!r} point along "
                                    f"{np.round(mean / (np.linalg.norm(mean) or 1.0), 2).tolist()}, not its label's "
                                    f"{np.round(f, 2).tolist()}: mislabelled")


def first_decrease(t: np.ndarray) -> int | None:
    """The index of the first time stamp that does not increase, or None."""
    bad = np.diff(t) <= 0
    return int(np.argmax(bad)) if np.any(bad) else None
