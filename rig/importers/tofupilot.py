"""``tofupilot``: TofuPilot's tab-separated thermal recording (timestamp, ``imu.acc.x..z`` in m/s^2,
``imu.temperature`` C; one static pose): converted to counts-equivalent at 100000 counts per g
(10 ug) with the stated g, cut into consecutive windows (default 120 s), each a static step with
``f_nominal: null`` and ``pose_group: 0`` (one unknown pose). Read block by block into the spool; the
windows are counted chunk by chunk."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import RigInputError
from rig.importers.common import (COUNTS_PER_G_EQUIVALENT, G_MS2, ImportedStep, Increasing, Recording, Spools, Table,
                                  diffs, exact_median, open_text, read_line)

COLUMNS = ["timestamp", "imu.acc.x", "imu.acc.y", "imu.acc.z", "imu.temperature"]
#: time stamp units, tried in turn: the one that makes the sample interval between 1 ms and 60 s
UNITS = {1.0: "s", 1e-3: "ms", 1e-6: "us", 1e-9: "ns"}


def read_tofupilot(path: Path, spools: Spools, g_ms2: float = G_MS2, window_s: float = 120.0, **_) -> Recording:
    with open_text(path) as fh:
        table = Table(path, fh, read_line(path, fh, 1), 1, COLUMNS, "\t")
        spool = spools.new({"t": 1, "acc": 3, "temp": 1})
        increasing = Increasing()
        for b in table.blocks(COLUMNS):
            d = b.numbers
            increasing.feed(d[:, 0], b.lines)
            spool.append(t=d[:, 0], acc=d[:, 1:4] / g_ms2 * COUNTS_PER_G_EQUIVALENT, temp=d[:, 4])
        spool.finish()
    increasing.check(path, "timestamp")
    n = spool.n_rows
    dt = exact_median(diffs(spool), n - 1) if n > 1 else float("nan")
    scale = next((s for s in UNITS if 1e-3 <= dt * s <= 60.0), None)
    if scale is None:
        raise RigInputError(str(path), 2, "timestamp", f"cannot tell the time unit (median step {dt:g})")
    rec = Recording("tofupilot", "TofuPilot IMU thermal recording (m/s^2)", COUNTS_PER_G_EQUIVALENT,
                    round(1.0 / (dt * scale), 4), "m/s^2", f"windows of {window_s:g} s",
                    notes=[f"acceleration converted to counts-equivalent: counts = a / {g_ms2:g} m/s^2 * "
                           f"{COUNTS_PER_G_EQUIVALENT:g}", f"timestamp unit {UNITS[scale]}", "one static pose (z "
                           "down), unknown to the tool: every window shares pose_group 0", "gyro columns not imported"],
                    spool=spool, time_origin=float(spool.read("t", 0, 1)[0]), time_scale=scale)
    edges = np.arange(0.0, rec.times(spool.read("t", n - 1, n))[0] + window_s, window_s)
    counts = np.zeros(len(edges) + 1, np.int64)  # rows per window (the last: at or past the last edge)
    for raw in spool.chunks("t"):
        counts += np.bincount(np.searchsorted(edges, rec.times(raw), side="right"), minlength=len(edges) + 1)
    start = int(counts[0])  # (no time is before the first)
    for k in range(len(edges) - 1):
        m = int(counts[k + 1])
        if m >= 10:
            rec.steps.append(ImportedStep(f"window {k + 1}", "static", [(start, start + m)], pose_group=0))
        start += m
    return rec
