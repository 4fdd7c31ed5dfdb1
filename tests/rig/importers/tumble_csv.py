"""A generic CSV (``rig import --from csv``) of any size: a hand-made tumble with static intervals.

:func:`write_tumble_csv` writes ``# units: counts``, ``# lsb_per_g: 16384`` and ``t_s,ax,ay,az,temp_c``
rows at 200 Hz: the 26 orientations of a tumble (faces, edges and corners of a cube), each held still
(white noise of 8 counts, a bias of a few hundred counts) and then turned to the next in 4 s of motion.
No label column, so the importer finds the steps by static detection; the held part of each pose grows
with the file. ``benchmarks/bench_import.py`` and ``tests/rig/importers/test_import_streaming.py`` use it.
Rows are formatted by numpy's string functions (about 1 s per 10 MB).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

RATE_HZ = 200.0
LSB_PER_G = 16384.0
MOVE_S = 4.0
BIAS = np.array([310.0, -120.0, 205.0])
HEADER = "# units: counts\n# lsb_per_g: 16384\nt_s,ax,ay,az,temp_c\n"
BYTES_PER_ROW = 31.0  # about, for sizing the file


def tumble_poses() -> np.ndarray:
    """The 26 unit vectors of a cube's faces, edges and corners."""
    v = np.array([p for p in itertools.product((-1, 0, 1), repeat=3) if any(p)], float)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _fixed(x: np.ndarray, decimals: int) -> np.ndarray:
    """``x`` (>= 0) as text with ``decimals`` decimals, from integers (numpy's C string functions)."""
    ticks = np.rint(x * 10**decimals).astype(np.int64).astype(str)
    ticks = np.strings.zfill(ticks, decimals + 1)
    return np.strings.add(np.strings.add(np.strings.slice(ticks, 0, -decimals), "."),
                          np.strings.slice(ticks, -decimals, None))


def _rows(t: np.ndarray, acc: np.ndarray, temp: np.ndarray) -> str:
    cols = [_fixed(t, 4)] + [np.rint(acc[:, j]).astype(np.int64).astype(str) for j in range(3)] + [_fixed(temp, 2)]
    line = cols[0]
    for c in cols[1:]:
        line = np.strings.add(np.strings.add(line, ","), c)
    return "\n".join(line.tolist()) + "\n"


def write_tumble_csv(path, size_bytes: float, *, seed: int = 0, chunk_rows: int = 200_000) -> dict:
    """Write about ``size_bytes`` of tumble CSV to ``path``; return its rows, poses and size."""
    rng = np.random.default_rng(seed)
    poses = tumble_poses()
    total_rows = max(int(size_bytes / BYTES_PER_ROW), 26 * int(20 * RATE_HZ))
    move = int(MOVE_S * RATE_HZ)
    hold = total_rows // len(poses) - move
    plan = []  # (kind, from, to, rows)
    for k, f in enumerate(poses):
        plan.append(("hold", f, f, hold))
        if k + 1 < len(poses):
            plan.append(("move", f, poses[k + 1], move))
    path = Path(path)
    row = 0
    with open(path, "w") as fh:
        fh.write(HEADER)
        for kind, f0, f1, n in plan:
            for a in range(0, n, chunk_rows):
                m = min(chunk_rows, n - a)
                i = row + np.arange(m)
                t = i / RATE_HZ
                if kind == "hold":
                    f = np.broadcast_to(f0, (m, 3))
                    noise = rng.normal(0.0, 8.0, (m, 3))
                else:
                    u = ((a + np.arange(m)) / n)[:, None]
                    f = (1 - u) * f0 + u * f1
                    f /= np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-9)
                    noise = rng.normal(0.0, 800.0, (m, 3))  # a hand turning the board
                acc = f * LSB_PER_G + BIAS + noise
                temp = 24.0 + 3.0 * i / total_rows + rng.normal(0.0, 0.02, m)
                fh.write(_rows(t, acc, temp))
                row += m
    return {"rows": row, "poses": len(poses), "bytes": path.stat().st_size}
