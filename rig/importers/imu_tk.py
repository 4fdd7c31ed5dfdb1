"""``imu_tk``: Kyle-ak/imu_tk's text file ``t x y z`` (raw counts, poses unknown): static intervals by
:func:`calib.numerics.static_detect.detect_static`, each a static step with ``f_nominal: null``; the samples
between intervals (hand motion) are not imported."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calib.numerics.static_detect import detect_static
from rig.errors import RigInputError
from rig.importers.common import G_MS2, ImportedStep, Recording, first_decrease

XSENS_COUNTS_PER_MS2 = 415.0  # the Xsens datasheet figure


def read_rows(path: Path) -> np.ndarray:
    """The ``t x y z`` rows (comments and blank lines skipped)."""
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
    return np.array(rows)


def read_imu_tk(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    d = read_rows(path)
    t, acc = d[:, 0], d[:, 1:4]
    bad = first_decrease(t)
    if bad is not None:
        raise RigInputError(str(path), bad + 2, "t", "time stamps must increase")
    rate = float(1.0 / np.median(np.diff(t)))
    rec = Recording("imu_tk", "Xsens MTi (imu_tk test data, raw counts)", XSENS_COUNTS_PER_MS2 * g_ms2,
                    round(rate, 3), "counts", "static detection",
                    notes=["lsb_per_g from the Xsens datasheet figure of about 415 counts per m/s^2; offset near "
                           "32768 counts", "samples between static intervals (hand motion) are not imported"])
    for k, (a, b) in enumerate(detect_static(t, acc)):
        rec.steps.append(ImportedStep(f"static {k + 1}", "static", t[a:b], np.rint(acc[a:b]).astype(np.int64),
                                      pose_group=1000 + k))
    return rec
