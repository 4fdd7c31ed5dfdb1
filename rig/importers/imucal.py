"""``imucal``: mad-lab-fau/imucal's annotated session CSV (``part,samples,acc_x..z,gyr_x..z``, raw
counts, 204.8 Hz). Its parts ``x_p, x_a, y_p, y_a, z_p, z_a`` are the six static poses (``_p``: the
axis points up, +1 g; ``_a``: down, -1 g; checked against the data) and ``x_rot, y_rot, z_rot`` the
three 360 deg rotations (kind ``rotation``, gyro kept). Read block by block into the spool; a part's
rows are its runs of rows, in file order."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import RigInputError
from rig.importers.common import G_MS2, ImportedStep, Recording, Runs, Spools, Table, open_text, read_line

IMUCAL_POSES = {"x_p": [1, 0, 0], "x_a": [-1, 0, 0], "y_p": [0, 1, 0], "y_a": [0, -1, 0], "z_p": [0, 0, 1],
                "z_a": [0, 0, -1]}
IMUCAL_ROTATIONS = ("x_rot", "y_rot", "z_rot")
RATE_HZ = 204.8
COLUMNS = ["part", "samples", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]


def read_imucal(path: Path, spools: Spools, g_ms2: float = G_MS2, **_) -> Recording:
    with open_text(path) as fh:
        table = Table(path, fh, read_line(path, fh, 1), 1, COLUMNS, ",")
        spool = spools.new({"t": 1, "acc": 3, "gyro": 3})
        runs = Runs(path, "part")
        for b in table.blocks(COLUMNS[1:], ["part"]):
            d = b.numbers
            spool.append(t=d[:, 0] / RATE_HZ, acc=np.rint(d[:, 1:4]), gyro=np.rint(d[:, 4:7]))
            runs.feed([p.strip() for p in b.texts[0]], b.lines)
        spool.finish()
    rec = Recording("imucal", "imucal recording (raw counts, ~2048 counts/g)", 2048.0, RATE_HZ, "counts", "labels",
                    notes=["lsb_per_g is the nominal 2048 counts/g of the +-16 g range; imucal's own scale is "
                           "fitted per axis", "gyro in raw counts, nominal 16.4 counts/(deg/s)"],
                    gyro_lsb_per_dps=16.4, spool=spool, check_axis_sign=True)
    parts: dict[str, ImportedStep] = {}  # in order of first appearance
    for a, b, part, line in runs.runs:
        if part not in IMUCAL_POSES and part not in IMUCAL_ROTATIONS:
            raise RigInputError(str(path), line, "part", f"unknown part {part!r} (expected "
                                f"{', '.join(list(IMUCAL_POSES) + list(IMUCAL_ROTATIONS))})")
        if part in parts:
            parts[part].rows.append((a, b))
        elif part in IMUCAL_POSES:
            parts[part] = ImportedStep(part, "static", [(a, b)], f_nominal=[float(x) for x in IMUCAL_POSES[part]],
                                       first_line=line)
        else:
            parts[part] = ImportedStep(part, "rotation", [(a, b)], first_line=line)
    rec.steps += parts.values()
    return rec
