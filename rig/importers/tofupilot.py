"""``tofupilot``: TofuPilot's tab-separated thermal recording (timestamp, ``imu.acc.x..z`` in m/s^2,
``imu.temperature`` C; one static pose): converted to counts-equivalent at 100000 counts per g
(10 ug) with the stated g, cut into consecutive windows (default 120 s), each a static step with
``f_nominal: null`` and ``pose_group: 0`` (one unknown pose)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import RigInputError
from rig.importers.common import COUNTS_PER_G_EQUIVALENT, G_MS2, ImportedStep, Recording, first_decrease, numbers, \
    table

COLUMNS = ["timestamp", "imu.acc.x", "imu.acc.y", "imu.acc.z", "imu.temperature"]
#: time stamp units, tried in turn: the one that makes the sample interval between 1 ms and 60 s
UNITS = {1.0: "s", 1e-3: "ms", 1e-6: "us", 1e-9: "ns"}


def read_tofupilot(path: Path, g_ms2: float = G_MS2, window_s: float = 120.0, **_) -> Recording:
    header, body = table(path, path.read_text(errors="replace"), COLUMNS, "\t")
    data = numbers(path, body, 2, [header.index(c) for c in COLUMNS], header)
    ts = data[:, 0]
    bad = first_decrease(ts)
    if bad is not None:
        raise RigInputError(str(path), bad + 3, "timestamp", "time stamps must increase")
    dt = float(np.median(np.diff(ts)))
    scale = next((s for s in UNITS if 1e-3 <= dt * s <= 60.0), None)
    if scale is None:
        raise RigInputError(str(path), 2, "timestamp", f"cannot tell the time unit (median step {dt:g})")
    t = (ts - ts[0]) * scale
    counts = np.rint(data[:, 1:4] / g_ms2 * COUNTS_PER_G_EQUIVALENT).astype(np.int64)
    temp = data[:, 4]
    rec = Recording("tofupilot", "TofuPilot IMU thermal recording (m/s^2)", COUNTS_PER_G_EQUIVALENT,
                    round(1.0 / (dt * scale), 4), "m/s^2", f"windows of {window_s:g} s",
                    notes=[f"acceleration converted to counts-equivalent: counts = a / {g_ms2:g} m/s^2 * "
                           f"{COUNTS_PER_G_EQUIVALENT:g}", f"timestamp unit {UNITS[scale]}", "one static pose (z "
                           "down), unknown to the tool: every window shares pose_group 0", "gyro columns not imported"])
    edges = np.arange(0.0, t[-1] + window_s, window_s)
    for k in range(len(edges) - 1):
        sel = (t >= edges[k]) & (t < edges[k + 1])
        if sel.sum() < 10:
            continue
        rec.steps.append(ImportedStep(f"window {k + 1}", "static", t[sel], counts[sel], temp_c=temp[sel],
                                      pose_group=0))
    return rec
