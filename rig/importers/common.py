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


def first_decrease(t: np.ndarray) -> int | None:
    """The index of the first time stamp that does not increase, or None."""
    bad = np.diff(t) <= 0
    return int(np.argmax(bad)) if np.any(bad) else None
