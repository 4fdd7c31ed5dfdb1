"""``rig fleet RESULTS``: statistics across the units of a re-solved archive (docs/archive.md).

Per parameter (each axis's bias, counts, and scale factor, counts/g) and group (``--by`` lot, rig file, sensor
model or month, from the archive's sessions table), the robust location (median) and spread (the median absolute
deviation scaled to a normal sigma, ``1.4826 MAD``), and the units that stand out: a robust z,
``(value - median) / spread``, beyond ``threshold`` (default 5) on any parameter. Failed rows are counted, not
used.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rig.archive.resolve import RESULTS_FILE, read_results
from rig.archive.store import read_table
from rig.errors import RigInputError

GROUPS = {"lot": "lot", "rig": "rig_file", "model": "model", "month": "month"}
#: the parameters summarised: result column -> (name per axis, unit)
PARAMETERS = {"bias_counts": ("bias", "counts"), "scale_counts_per_g": ("scale", "counts/g")}
MAD_TO_SIGMA = 1.4826


@dataclass
class GroupStats:
    """One group's units: how many solved and failed, per parameter the median, spread and unit, the outliers."""

    group: str
    n: int
    failed: int
    parameters: dict = field(default_factory=dict)  # name -> {median, spread, unit}
    outliers: list = field(default_factory=list)  # {session_id, parameter, value, z}


def _groups_of(results_dir: Path, ids: list[str], by: str | None) -> list[str]:
    if by is None:
        return ["all"] * len(ids)
    try:
        archive = json.loads((results_dir / RESULTS_FILE).read_text())["archive"]
    except (OSError, ValueError, KeyError):
        raise RigInputError(str(results_dir / RESULTS_FILE), None, None, "not a rig resolve results folder "
                            "(its resolve.json names the archive the groups come from)") from None
    column = GROUPS[by]
    if column == "month":  # the partition column: from the created date
        t = read_table(archive, "sessions", columns=["session_id", "created"])
        values = {s: (c or "")[:7] for s, c in zip(t.column("session_id").to_pylist(), t.column("created").to_pylist())}
    else:
        t = read_table(archive, "sessions", columns=["session_id", column])
        values = dict(zip(t.column("session_id").to_pylist(), t.column(column).to_pylist()))
    return [str(values.get(s) or "(none)") for s in ids]


def fleet(results, by: str | None = None, threshold: float = 5.0) -> list[GroupStats]:
    """The fleet statistics of a ``rig resolve`` results folder, per group (``by``: one of :data:`GROUPS`)."""
    if by is not None and by not in GROUPS:
        raise RigInputError(None, None, "--by", f"expected one of {', '.join(GROUPS)}, got {by!r}")
    results = Path(results)
    table = read_results(results)
    if table.num_rows == 0:
        raise RigInputError(str(results), None, None, "no results: run rig resolve ARCHIVE -o RESULTS first")
    rows = table.to_pylist()
    groups = _groups_of(results, [r["session_id"] for r in rows], by)
    out = []
    for g in sorted(set(groups)):
        mine = [r for r, gg in zip(rows, groups) if gg == g]
        ok = [r for r in mine if r["ok"]]
        stats = GroupStats(g, len(ok), len(mine) - len(ok))
        for column, (name, unit) in PARAMETERS.items():
            values = np.array([r[column] for r in ok], float).reshape(-1, 3)
            for j, axis in enumerate("xyz"):
                v = values[:, j]
                med = float(np.median(v)) if len(v) else float("nan")
                spread = float(MAD_TO_SIGMA * np.median(np.abs(v - med))) if len(v) else float("nan")
                stats.parameters[f"{name}_{axis}"] = {"median": med, "spread": spread, "unit": unit}
                if len(v) >= 3 and spread > 0:
                    for r, x in zip(ok, v):
                        z = (x - med) / spread
                        if abs(z) > threshold:
                            stats.outliers.append({"session_id": r["session_id"], "parameter": f"{name}_{axis}",
                                                   "value": float(x), "z": float(z)})
        out.append(stats)
    return out


@dataclass
class Change:
    """A parameter's change across the sessions both result sets solved: the mean and the largest change, in its
    unit and in combined sigmas, and the sessions whose change is beyond the threshold."""

    parameter: str
    unit: str
    n: int
    mean: float
    mean_z: float
    largest_z: float
    beyond: list = field(default_factory=list)  # {session_id, change, z}


def changes(new, old, threshold: float = 3.0) -> list[Change]:
    """Per parameter the change from results ``old`` to ``new`` (``rig resolve`` folders of the same archive, say
    before and after a model change) over the sessions solved in both: ``z = (new - old) / sqrt(s_new^2 + s_old^2)``
    (the two solves' sigmas, as if independent: an upper bound of the change's own sigma when they share data, so a
    conservative z)."""
    a, b = read_results(new).to_pylist(), read_results(old).to_pylist()
    if not a or not b:
        raise RigInputError(str(new if not a else old), None, None, "no results: run rig resolve first")
    before = {r["session_id"]: r for r in b if r["ok"]}
    pairs = [(r, before[r["session_id"]]) for r in a if r["ok"] and r["session_id"] in before]
    if not pairs:
        raise RigInputError(str(new), None, None, f"no session is solved in both {new} and {old}")
    out = []
    sigma_of = {"bias_counts": "bias_sigma_counts", "scale_counts_per_g": "scale_sigma_counts_per_g"}
    for column, (name, unit) in PARAMETERS.items():
        for j, axis in enumerate("xyz"):
            d = np.array([n[column][j] - o[column][j] for n, o in pairs])
            s = np.array([np.hypot(n[sigma_of[column]][j], o[sigma_of[column]][j]) for n, o in pairs])
            z = np.where(s > 0, d / np.where(s > 0, s, 1.0), 0.0)
            change = Change(f"{name}_{axis}", unit, len(pairs), float(d.mean()), float(z.mean()),
                            float(z[np.argmax(np.abs(z))]))
            change.beyond = [{"session_id": n["session_id"], "change": float(dd), "z": float(zz)}
                             for (n, _), dd, zz in zip(pairs, d, z) if abs(zz) > threshold]
            out.append(change)
    return out
