"""``imucal``: mad-lab-fau/imucal's annotated session CSV (``part,samples,acc_x..z,gyr_x..z``, raw
counts, 204.8 Hz). Its parts ``x_p, x_a, y_p, y_a, z_p, z_a`` are the six static poses (``_p``: the
axis points up, +1 g; ``_a``: down, -1 g; checked against the data) and ``x_rot, y_rot, z_rot`` the
three 360 deg rotations (kind ``rotation``, gyro kept)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import RigInputError
from rig.importers.common import G_MS2, ImportedStep, Recording, numbers, table

IMUCAL_POSES = {"x_p": [1, 0, 0], "x_a": [-1, 0, 0], "y_p": [0, 1, 0], "y_a": [0, -1, 0], "z_p": [0, 0, 1],
                "z_a": [0, 0, -1]}
IMUCAL_ROTATIONS = ("x_rot", "y_rot", "z_rot")
RATE_HZ = 204.8
COLUMNS = ["part", "samples", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]


def read_imucal(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    header, body = table(path, path.read_text(errors="replace"), COLUMNS, ",")
    data = numbers(path, body, 2, [header.index(c) for c in COLUMNS[1:]], header)
    parts = [r[header.index("part")].strip() for r in body]
    rec = Recording("imucal", "imucal recording (raw counts, ~2048 counts/g)", 2048.0, RATE_HZ, "counts", "labels",
                    notes=["lsb_per_g is the nominal 2048 counts/g of the +-16 g range; imucal's own scale is "
                           "fitted per axis", "gyro in raw counts, nominal 16.4 counts/(deg/s)"],
                    gyro_lsb_per_dps=16.4)
    order = list(dict.fromkeys(parts))
    unknown = [p for p in order if p not in IMUCAL_POSES and p not in IMUCAL_ROTATIONS]
    if unknown:
        line = parts.index(unknown[0]) + 2
        raise RigInputError(str(path), line, "part", f"unknown part {unknown[0]!r} (expected "
                            f"{', '.join(list(IMUCAL_POSES) + list(IMUCAL_ROTATIONS))})")
    parts_arr = np.array(parts)
    for p in order:
        sel = parts_arr == p
        d = data[sel]
        t = d[:, 0] / RATE_HZ
        acc = np.rint(d[:, 1:4]).astype(np.int64)
        gyr = np.rint(d[:, 4:7]).astype(np.int64)
        if p in IMUCAL_POSES:
            _check_pose(path, p, acc, int(np.flatnonzero(sel)[0]) + 2)
            rec.steps.append(ImportedStep(p, "static", t, acc, gyro_counts=gyr,
                                          f_nominal=[float(x) for x in IMUCAL_POSES[p]]))
        else:
            rec.steps.append(ImportedStep(p, "rotation", t, acc, gyro_counts=gyr))
    return rec


def _check_pose(path: Path, part: str, acc: np.ndarray, line: int) -> None:
    """A static part must read +-1 g along its labelled axis, with its labelled sign."""
    f = IMUCAL_POSES[part]
    axis = int(np.argmax(np.abs(f)))
    mean = acc.mean(axis=0)
    dom = int(np.argmax(np.abs(mean)))
    if dom != axis or np.sign(mean[dom]) != np.sign(f[dom]):
        raise RigInputError(str(path), line, "part", f"part {part!r} should read +-1 g along {'xyz'[axis]} with sign "
                            f"{f[axis]:+d}, but its mean is {mean.round(0).tolist()} counts")
