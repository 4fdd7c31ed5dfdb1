"""``csv``: the documented generic CSV (docs/import.md)::

    # units: counts
    # lsb_per_g: 16384
    t_s,ax,ay,az,temp_c,label
    0.000,16390,12,-40,25.1,+Z up

``t_s`` (s, increasing), ``ax, ay, az`` required; ``temp_c``, ``label`` optional; other columns ignored.
Steps from the ``label`` column (a new step at each change; a pose name gives ``f_nominal``; a label
containing ``rot`` a rotation step), else by static detection.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from calib.numerics.static_detect import detect_static
from rig.errors import RigInputError
from rig.importers.common import COUNTS_PER_G_EQUIVALENT, G_MS2, ImportedStep, Recording, first_decrease, numbers, \
    table
from rig.planning.kinematics import f_nominal
from rig.planning.poses import POSE_NAMES, pose_angles_deg

UNITS = ("counts", "g", "m/s^2")


def read_meta(path: Path, lines: list[str]) -> tuple[dict[str, str], int]:
    """The ``# key: value`` lines at the top, and how many comment lines there are."""
    meta, skip = {}, 0
    for line in lines:
        if not line.startswith("#"):
            break
        m = re.match(r"#\s*([A-Za-z_]+)\s*:\s*(.+)$", line)
        if m:
            meta[m.group(1).lower()] = m.group(2).strip()
        skip += 1
    units = meta.get("units", "counts")
    if units not in UNITS:
        raise RigInputError(str(path), None, "units", f"expected counts, g or m/s^2, got {units!r}")
    return meta, skip


def counts_per_g(path: Path, meta: dict[str, str]) -> float:
    """``# lsb_per_g`` for counts; the counts-equivalent (10 ug per count) for physical units."""
    if meta.get("units", "counts") != "counts":
        return COUNTS_PER_G_EQUIVALENT
    try:
        lsb = float(meta["lsb_per_g"])
    except (KeyError, ValueError):
        lsb = 0.0
    if not lsb > 0:
        raise RigInputError(str(path), None, "lsb_per_g", "counts need a '# lsb_per_g: N' line (N > 0)")
    return lsb


def read_csv(path: Path, g_ms2: float = G_MS2, **_) -> Recording:
    """Generic CSV: comment lines, then a header with ``t_s, ax, ay, az`` and optional ``temp_c``, ``label``."""
    raw_lines = path.read_text(errors="replace").splitlines()
    meta, skip = read_meta(path, raw_lines)
    units, lsb = meta.get("units", "counts"), counts_per_g(path, meta)
    header, body = table(path, "\n".join(raw_lines[skip:]), ["t_s", "ax", "ay", "az"], ",")
    first = skip + 2
    data = numbers(path, body, first, [header.index(c) for c in ("t_s", "ax", "ay", "az")], header)
    temp = numbers(path, body, first, [header.index("temp_c")], header)[:, 0] if "temp_c" in header else None
    labels = None
    if "label" in header:
        j = header.index("label")
        labels = [r[j].strip() if j < len(r) else "" for r in body]
    t = data[:, 0]
    bad = first_decrease(t)
    if bad is not None:
        raise RigInputError(str(path), first + bad + 1, "t_s", "time stamps must increase")
    acc = data[:, 1:4]
    if units == "g":
        acc = acc * lsb
    elif units == "m/s^2":
        acc = acc / g_ms2 * lsb
    counts = np.rint(acc).astype(np.int64)
    rec = Recording("csv", meta.get("sensor", "generic CSV"), lsb, round(float(1.0 / np.median(np.diff(t))), 4),
                    units, "labels" if labels else "static detection")
    if labels:
        rec.steps += labelled_steps(labels, t, counts, temp)
    else:
        for k, (a, b) in enumerate(detect_static(t, counts, init_s=min(30.0, 0.2 * (t[-1] - t[0])))):
            rec.steps.append(ImportedStep(f"static {k + 1}", "static", t[a:b], counts[a:b],
                                          temp_c=None if temp is None else temp[a:b], pose_group=1000 + k))
    return rec


def labelled_steps(labels: list[str], t: np.ndarray, counts: np.ndarray, temp: np.ndarray | None) -> list[ImportedStep]:
    """One step per run of equal labels; a pose name gives the step's nominal specific force."""
    steps: list[ImportedStep] = []
    starts = [0] + [i for i in range(1, len(labels)) if labels[i] != labels[i - 1]]
    for a, b in zip(starts, starts[1:] + [len(labels)]):
        name = labels[a] or f"segment {len(steps) + 1}"
        f = [float(x) for x in f_nominal(np.array(pose_angles_deg(name)))] if name in POSE_NAMES else None
        kind = "rotation" if "rot" in name.lower() else "static"
        steps.append(ImportedStep(name, kind, t[a:b], counts[a:b], temp_c=None if temp is None else temp[a:b],
                                  f_nominal=f))
    return steps
