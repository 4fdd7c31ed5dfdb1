"""``csv``: the documented generic CSV (docs/import.md)::

    # units: counts
    # lsb_per_g: 16384
    t_s,ax,ay,az,temp_c,label
    0.000,16390,12,-40,25.1,+Z up

Any of the sensors' columns (``ax,ay,az``, ``gx,gy,gz``, ``mx,my,mz``) in counts or physical units, time
from ``t_s`` or a rate (``--rate``, ``# rate_hz:``, a preamble line ``Fs,100``), ``temp_c`` and ``label``
optional, other names mapped by ``--columns`` (:mod:`rig.importers.columns`); every other column is named
in the summary as ignored. Steps from the ``label`` column (a new step at each change; a pose name gives ``f_nominal``; a label
containing ``rot`` a rotation step), else by static detection. Read block by block into the spool
(:mod:`rig.importers.common`); static detection runs chunk by chunk on the spooled counts.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from rig.importers.columns import (COUNTS_PER_G_EQUIVALENT, PREAMBLE_RATE, ColumnPlan, apply_column_map,
                                   parse_column_map, plan_columns, rate_option)
from rig.importers.quasi_static import DEFAULT_FACTOR, DEFAULT_MIN_S, detect_rests
from rig.importers.common import (G_MS2, ImportedStep, Increasing, Recording, Runs, Spool, Spools, Table, diffs,
                                  exact_median, open_text, read_line)
from rig.errors import RigInputError
from rig.planning.kinematics import f_nominal
from rig.planning.poses import POSE_NAMES, pose_angles_deg



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
    return meta, skip


def _head(path: Path, fh) -> tuple[dict[str, str], float | None, str, int]:
    """Comment lines, then preamble lines stating the rate (``Fs,100``), then the header: the meta, the
    preamble's rate, the header line and its line number."""
    comments, preamble, n = [], None, 1
    line = read_line(path, fh, n)
    while line.startswith("#") or (line.strip() and PREAMBLE_RATE.match(line.rstrip("\n"))):
        if line.startswith("#"):
            comments.append(line.rstrip("\n"))
        else:
            preamble = PREAMBLE_RATE.match(line.rstrip("\n")).group(2)
        n += 1
        line = read_line(path, fh, n)
    meta, _ = read_meta(path, comments)
    return meta, preamble, line, n


def read_csv(path: Path, spools: Spools, g_ms2: float = G_MS2, rate_hz: float | None = None,
             column_map: str | None = None, static_factor: float = DEFAULT_FACTOR, static_min_s: float = DEFAULT_MIN_S,
             continuous: bool = False, **_) -> Recording:
    """Generic CSV: comment lines (and a rate preamble), then a header with any of the sensors' columns, a
    time column or a rate, optional ``temp_c`` and ``label`` (:mod:`rig.importers.columns`). ``continuous``: the
    whole recording is one step in which the sensor turns (a magnetometer turned by hand without rests), no
    static detection."""
    with open_text(path) as fh:
        meta, preamble, line, header_at = _head(path, fh)
        table = Table(path, fh, line, header_at, [], ",", splitlines=True)
        mapping = {**parse_column_map(path, meta.get("columns"), "columns"),
                   **parse_column_map(path, column_map, "--columns")}
        table.header = apply_column_map(path, table.header, mapping, header_at)
        rate, rate_from = rate_option(path, rate_hz, meta, preamble)
        plan = plan_columns(path, table.header, meta, header_at, g_ms2=g_ms2, rate_hz=rate, rate_from=rate_from,
                            renamed=mapping)
        spool, runs = _read_rows(path, table, plan, spools)
    n = spool.n_rows
    dt = exact_median(diffs(spool), n - 1) if n > 1 else float("nan")
    if continuous and plan.has_label:
        raise RigInputError(str(path), header_at, "label", "--continuous takes the whole recording as one turning "
                            "step; this file's label column gives its steps: import it without --continuous")
    steps_from = "labels" if plan.has_label else "one turning step (--continuous)" if continuous else "static detection"
    rec = Recording("csv", meta.get("sensor", "generic CSV"), _lsb(plan), round(float(1.0 / dt), 4), _units(plan),
                    steps_from, spool=spool, columns=plan.summary())
    if "gyro" in plan.sensors:
        rec.gyro_lsb_per_dps = plan.sensors["gyro"].lsb
    if "mag" in plan.sensors:
        rec.mag_lsb_per_ut, rec.mag_units = plan.sensors["mag"].lsb, plan.sensors["mag"].units
    if plan.has_label:  # a label column gives the steps, even empty labels ("segment N")
        rec.steps += labelled_steps(runs, poses="acc" in plan.sensors)
    elif continuous:
        rec.steps.append(ImportedStep("turning", "rotation", [(0, n)], first_line=header_at + 1))
    elif n > 1:
        key = next(k for k in ("acc", "mag", "gyro") if k in plan.sensors)
        steps, report = detect_rests(spool, dt, key, static_factor, static_min_s)
        rec.steps += steps
        rec.notes.append(report.note(plan.sensors[key].spec.sensor))
    return rec


def _read_rows(path: Path, table: Table, plan: ColumnPlan, spools: Spools) -> tuple[Spool, list[list]]:
    """Every row into the spool (time, each sensor in stored counts, temperature; the labels' runs kept)."""
    widths = {"t": 1, **{k: 3 for k in plan.sensors}, **({"temp": 1} if plan.has_temp else {})}
    spool = spools.new(widths)
    increasing, runs = Increasing(), Runs(path, "label")
    for b in table.blocks(plan.numeric(), ["label"] if plan.has_label else []):
        col, arrays = 0, {}
        if plan.time_column:
            arrays["t"] = b.numbers[:, 0]
            col = 1
        else:
            arrays["t"] = np.arange(table.n_rows - len(b), table.n_rows, dtype=np.float64) / plan.rate_hz
        increasing.feed(arrays["t"], b.lines)
        for key, p in plan.sensors.items():
            v = b.numbers[:, col:col + 3]
            arrays[key] = p.convert(v)
            col += 3
        if plan.has_temp:
            arrays["temp"] = b.numbers[:, col]
        spool.append(**arrays)
        if plan.has_label:
            runs.feed([x.strip() for x in b.texts[0]], b.lines)
    spool.finish()
    increasing.check(path, plan.renamed.get("t_s", "t_s"))
    return spool, runs.runs


def _lsb(plan: ColumnPlan) -> float:
    """Counts per g of the stored accelerometer (the counts-equivalent when there is none: nothing reads it)."""
    return plan.sensors["acc"].lsb if "acc" in plan.sensors else COUNTS_PER_G_EQUIVALENT


def _units(plan: ColumnPlan) -> str:
    """``import.units``: the accelerometer's units as before for an accelerometer-only file; else each
    sensor's, ``accelerometer none`` when it has none (docs/import.md)."""
    if list(plan.sensors) == ["acc"]:
        return plan.sensors["acc"].units
    names = {"acc": "accelerometer", "gyro": "gyroscope", "mag": "magnetometer"}
    return "; ".join(f"{names[k]} {plan.sensors[k].units if k in plan.sensors else 'none'}" for k in names)


def labelled_steps(runs: list[list], poses: bool = True) -> list[ImportedStep]:
    """One step per run of equal labels; a pose name gives the step's nominal specific force (``poses``:
    only with an accelerometer, whose data check it)."""
    steps: list[ImportedStep] = []
    for a, b, label, line in runs:
        name = label or f"segment {len(steps) + 1}"
        f = [float(x) for x in f_nominal(np.array(pose_angles_deg(name)))] if poses and name in POSE_NAMES else None
        kind = "rotation" if "rot" in name.lower() else "static"
        steps.append(ImportedStep(name, kind, [(a, b)], f_nominal=f, first_line=line))
    return steps
