"""``imu_tk``: Kyle-ak/imu_tk's text file ``t x y z`` (raw counts, poses unknown): static intervals by
:class:`calib.numerics.static_detect.StaticDetector` (chunk by chunk), each a static step with
``f_nominal: null``; the samples between intervals (hand motion) are not imported."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from calib.numerics.static_detect import StaticDetector
from rig.errors import RigInputError
from rig.importers.common import (G_MS2, ImportedStep, Increasing, Recording, Spools, diffs, exact_median, open_text,
                                  text_blocks)

XSENS_COUNTS_PER_MS2 = 415.0  # the Xsens datasheet figure
MIN_ROWS = 100
#: characters that send a block to the exact reading: comments, line breaks of str.splitlines other than \n,
#: the separators str.split() takes for whitespace
_NOT_FAST = re.compile("[#\x0b\x0c\x1c-\x1f\r]")
#: the fast path reads fields at most this far apart (bytes); a longer one is read line by line
_MAX_FAST_FIELD = 256
_SPACE = np.zeros(256, bool)
_SPACE[[9, 10, 32]] = True


def _fast(block: str, line: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The block's rows (lines, (n, 4) values) when it is plain ASCII without comments and every non-blank
    line has four fields that numpy reads as numbers; None to read it exactly."""
    if not block.isascii() or _NOT_FAST.search(block):
        return None
    raw = block.encode() if block.endswith("\n") else (block + "\n").encode()
    a = np.frombuffer(raw, np.uint8)
    ends = np.flatnonzero(a == 10)
    space = _SPACE[a]
    token_starts = np.flatnonzero(~space & np.concatenate([[True], space[:-1]]))
    starts = np.concatenate([[0], ends[:-1] + 1])
    fields = np.searchsorted(token_starts, ends) - np.searchsorted(token_starts, starts)
    if np.any((fields != 0) & (fields != 4)):
        return None
    if len(token_starts) and np.diff(token_starts, append=len(a)).max() > _MAX_FAST_FIELD:
        return None  # a field (or a gap) of kilobytes: numpy would hold every field at that width (gigabytes)
    try:
        values = np.array(raw.split()).astype(np.float64).reshape(-1, 4)  # numpy's float() of each field
    except ValueError:
        return None
    return line + np.flatnonzero(fields == 4), values


def _exact(path: Path, block: str, line: int) -> tuple[np.ndarray, np.ndarray]:
    """The block line by line (comments and blank lines skipped): the first bad line is refused."""
    lines, rows = [], []
    for n, text in enumerate(block.splitlines(), start=line):
        if not text.strip() or text.lstrip().startswith("#"):
            continue
        parts = text.split()
        if len(parts) != 4:
            raise RigInputError(str(path), n, None, f"expected 4 numbers (t x y z), got {len(parts)} fields")
        try:
            rows.append([float(x) for x in parts])
        except ValueError:
            raise RigInputError(str(path), n, None, f"expected numbers (t x y z), got {text.strip()[:40]!r}") from None
        lines.append(n)
    return np.array(lines, np.int64), np.array(rows, np.float64).reshape(-1, 4)


def read_imu_tk(path: Path, spools: Spools, g_ms2: float = G_MS2, **_) -> Recording:
    spool = spools.new({"t": 1, "acc": 3})
    increasing = Increasing()
    with open_text(path) as fh:
        for line, block in text_blocks(path, fh, 1):
            found = _fast(block, line)
            lines, d = found if found is not None else _exact(path, block, line)
            if not np.all(np.isfinite(d)):
                raise RigInputError(str(path), int(lines[np.flatnonzero(~np.isfinite(d).all(axis=1))[0]]), None,
                                    "expected finite numbers (t x y z)")
            increasing.feed(d[:, 0], lines)
            spool.append(t=d[:, 0], acc=d[:, 1:4])
    spool.finish()
    n = spool.n_rows
    if n < MIN_ROWS:
        raise RigInputError(str(path), None, None, f"expected a recording of t x y z rows, got {n} rows")
    increasing.check(path, "t")
    dt = exact_median(diffs(spool), n - 1)
    rec = Recording("imu_tk", "Xsens MTi (imu_tk test data, raw counts)", XSENS_COUNTS_PER_MS2 * g_ms2,
                    round(float(1.0 / dt), 3), "counts", "static detection",
                    notes=["lsb_per_g from the Xsens datasheet figure of about 415 counts per m/s^2; offset near "
                           "32768 counts", "samples between static intervals (hand motion) are not imported"],
                    spool=spool)
    detector = StaticDetector(dt, float(spool.read("t", 0, 1)[0]))
    for t, acc in zip(spool.chunks("t"), spool.chunks("acc")):
        detector.feed(t, acc)
    for k, (a, b) in enumerate(detector.finish()):
        rec.steps.append(ImportedStep(f"static {k + 1}", "static", [(a, b)], pose_group=1000 + k))
    return rec
