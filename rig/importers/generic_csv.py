"""``csv``: the documented generic CSV (docs/import.md)::

    # units: counts
    # lsb_per_g: 16384
    t_s,ax,ay,az,temp_c,label
    0.000,16390,12,-40,25.1,+Z up

``t_s`` (s, increasing), ``ax, ay, az`` required; ``temp_c``, ``label`` optional; other columns ignored.
Steps from the ``label`` column (a new step at each change; a pose name gives ``f_nominal``; a label
containing ``rot`` a rotation step), else by static detection. Read block by block into the spool
(:mod:`rig.importers.common`); static detection runs chunk by chunk on the spooled counts.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from calib.numerics.static_detect import StaticDetector
from rig.errors import RigInputError
from rig.importers.common import (COUNTS_PER_G_EQUIVALENT, G_MS2, ImportedStep, Increasing, Recording, Runs, Spools,
                                  Table, diffs, exact_median, open_text, read_line)
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


def read_csv(path: Path, spools: Spools, g_ms2: float = G_MS2, **_) -> Recording:
    """Generic CSV: comment lines, then a header with ``t_s, ax, ay, az`` and optional ``temp_c``, ``label``."""
    with open_text(path) as fh:
        comments, line = [], read_line(path, fh, 1)
        while line.startswith("#"):
            comments.append(line.rstrip("\n"))
            line = read_line(path, fh, len(comments) + 1)
        meta, skip = read_meta(path, comments)
        units, lsb = meta.get("units", "counts"), counts_per_g(path, meta)
        table = Table(path, fh, line, skip + 1, ["t_s", "ax", "ay", "az"], ",", splitlines=True)
        has_temp, has_label = "temp_c" in table.header, "label" in table.header
        spool = spools.new({"t": 1, "acc": 3, **({"temp": 1} if has_temp else {})})
        increasing, runs = Increasing(), Runs(path, "label")
        numeric = ["t_s", "ax", "ay", "az"] + (["temp_c"] if has_temp else [])
        for b in table.blocks(numeric, ["label"] if has_label else []):
            t, acc = b.numbers[:, 0], b.numbers[:, 1:4]
            increasing.feed(t, b.lines)
            if units == "g":
                acc = acc * lsb
            elif units == "m/s^2":
                acc = acc / g_ms2 * lsb
            spool.append(t=t, acc=acc, **({"temp": b.numbers[:, 4]} if has_temp else {}))
            if has_label:
                runs.feed([x.strip() for x in b.texts[0]], b.lines)
        spool.finish()
    increasing.check(path, "t_s")
    n = spool.n_rows
    dt = exact_median(diffs(spool), n - 1) if n > 1 else float("nan")
    rate = round(float(1.0 / dt), 4)
    labelled = has_label  # a label column gives the steps, even empty labels ("segment N")
    rec = Recording("csv", meta.get("sensor", "generic CSV"), lsb, rate, units,
                    "labels" if labelled else "static detection", spool=spool)
    if labelled:
        rec.steps += labelled_steps(runs.runs)
    elif n > 1:
        t0, t_end = float(spool.read("t", 0, 1)[0]), float(spool.read("t", n - 1, n)[0])
        detector = StaticDetector(dt, t0, init_s=min(30.0, 0.2 * (t_end - t0)))
        for t, acc in zip(spool.chunks("t"), spool.chunks("acc")):
            detector.feed(t, np.rint(acc).astype(np.int64))
        for k, (a, b) in enumerate(detector.finish()):
            rec.steps.append(ImportedStep(f"static {k + 1}", "static", [(a, b)], pose_group=1000 + k))
    return rec


def labelled_steps(runs: list[list]) -> list[ImportedStep]:
    """One step per run of equal labels; a pose name gives the step's nominal specific force."""
    steps: list[ImportedStep] = []
    for a, b, label, line in runs:
        name = label or f"segment {len(steps) + 1}"
        f = [float(x) for x in f_nominal(np.array(pose_angles_deg(name)))] if name in POSE_NAMES else None
        kind = "rotation" if "rot" in name.lower() else "static"
        steps.append(ImportedStep(name, kind, [(a, b)], f_nominal=f, first_line=line))
    return steps
