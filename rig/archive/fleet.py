"""``rig fleet RESULTS``: statistics across the units of a re-solved archive (docs/archive.md).

Per parameter (each axis's bias, counts, and scale factor, counts/g) and group (``--by`` lot, rig file, sensor
model or month, from the archive's sessions table), the robust location (median) and spread (the median absolute
deviation scaled to a normal sigma, ``1.4826 MAD``), and the units that stand out: a robust z,
``(value - median) / spread``, beyond ``threshold`` (default 5) on any parameter. Failed rows are counted, not
used. :func:`changes`: each parameter's change between two result sets of the same archive, in combined sigmas.
:func:`unit_values`, :func:`change_values` and :func:`provenance` give the figure and the page
(:mod:`rig.archive.fleet_plot`, :mod:`rig.archive.fleet_page`) the values per unit and where the results come from.
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


def _grouped(results, by: str | None) -> dict[str, list[dict]]:
    """Every row of the results folder (solved and failed) per group, the groups sorted."""
    if by is not None and by not in GROUPS:
        raise RigInputError(None, None, "--by", f"expected one of {', '.join(GROUPS)}, got {by!r}")
    results = Path(results)
    table = read_results(results)
    if table.num_rows == 0:
        raise RigInputError(str(results), None, None, "no results: run rig resolve ARCHIVE -o RESULTS first")
    rows = table.to_pylist()
    groups = _groups_of(results, [r["session_id"] for r in rows], by)
    return {g: [r for r, gg in zip(rows, groups) if gg == g] for g in sorted(set(groups))}


def _values(ok: list[dict]):
    """(parameter name, unit, values (N,)) of the solved rows ``ok``, for each parameter and axis."""
    for column, (name, unit) in PARAMETERS.items():
        values = np.array([r[column] for r in ok], float).reshape(-1, 3)
        for j, axis in enumerate("xyz"):
            yield f"{name}_{axis}", unit, values[:, j]


def fleet(results, by: str | None = None, threshold: float = 5.0) -> list[GroupStats]:
    """The fleet statistics of a ``rig resolve`` results folder, per group (``by``: one of :data:`GROUPS`)."""
    out = []
    for g, mine in _grouped(results, by).items():
        ok = [r for r in mine if r["ok"]]
        stats = GroupStats(g, len(ok), len(mine) - len(ok))
        for name, unit, v in _values(ok):
            med = float(np.median(v)) if len(v) else float("nan")
            spread = float(MAD_TO_SIGMA * np.median(np.abs(v - med))) if len(v) else float("nan")
            stats.parameters[name] = {"median": med, "spread": spread, "unit": unit}
            if len(v) >= 3 and spread > 0:
                for r, x in zip(ok, v):
                    z = (x - med) / spread
                    if abs(z) > threshold:
                        stats.outliers.append({"session_id": r["session_id"], "parameter": name,
                                               "value": float(x), "z": float(z)})
        out.append(stats)
    return out


def unit_values(results, by: str | None = None) -> dict[str, dict[str, tuple[list[str], np.ndarray]]]:
    """Per group and parameter the solved units' session ids and values (in the parameter's unit): what the
    fleet's figure draws (:mod:`rig.archive.fleet_plot`)."""
    out = {}
    for g, mine in _grouped(results, by).items():
        ok = [r for r in mine if r["ok"]]
        out[g] = {name: ([r["session_id"] for r in ok], v) for name, _, v in _values(ok)}
    return out


def provenance(results) -> dict:
    """Where a results folder comes from: its archive and solve options (``resolve.json``), the software versions
    that solved its rows, how many sessions it holds and solved, and its failed rows counted per reason (with up to
    five session ids each)."""
    results = Path(results)
    try:
        record = json.loads((results / RESULTS_FILE).read_text())
    except (OSError, ValueError):
        record = {}
    rows = read_results(results).to_pylist()
    reasons: dict[str, list[str]] = {}
    for r in rows:
        if not r["ok"]:
            reasons.setdefault(r["reason"] or "(no reason recorded)", []).append(r["session_id"])
    return {"results": str(results), "archive": record.get("archive"), "options": record.get("options"),
            "software": sorted({r["software"] for r in rows if r.get("software")}), "sessions": len(rows),
            "solved": sum(1 for r in rows if r["ok"]),
            "failed": [{"reason": k, "sessions": len(v), "examples": v[:5]} for k, v in
                       sorted(reasons.items(), key=lambda kv: (-len(kv[1]), kv[0]))]}


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


def _pairs(new, old) -> list[tuple[dict, dict]]:
    """(new row, old row) of every session solved in both result sets."""
    a, b = read_results(new).to_pylist(), read_results(old).to_pylist()
    if not a or not b:
        raise RigInputError(str(new if not a else old), None, None, "no results: run rig resolve first")
    before = {r["session_id"]: r for r in b if r["ok"]}
    pairs = [(r, before[r["session_id"]]) for r in a if r["ok"] and r["session_id"] in before]
    if not pairs:
        raise RigInputError(str(new), None, None, f"no session is solved in both {new} and {old}")
    return pairs


def change_values(new, old) -> tuple[list[str], dict[str, tuple[str, np.ndarray, np.ndarray]]]:
    """The session ids solved in both result sets and, per parameter, (unit, change in that unit, change in
    combined sigmas) for each of them: what :func:`changes` summarises and the figure draws."""
    pairs = _pairs(new, old)
    sigma_of = {"bias_counts": "bias_sigma_counts", "scale_counts_per_g": "scale_sigma_counts_per_g"}
    out = {}
    for column, (name, unit) in PARAMETERS.items():
        for j, axis in enumerate("xyz"):
            d = np.array([n[column][j] - o[column][j] for n, o in pairs])
            s = np.array([np.hypot(n[sigma_of[column]][j], o[sigma_of[column]][j]) for n, o in pairs])
            out[f"{name}_{axis}"] = (unit, d, np.where(s > 0, d / np.where(s > 0, s, 1.0), 0.0))
    return [n["session_id"] for n, _ in pairs], out


def changes(new, old, threshold: float = 3.0) -> list[Change]:
    """Per parameter the change from results ``old`` to ``new`` (``rig resolve`` folders of the same archive, say
    before and after a model change) over the sessions solved in both: ``z = (new - old) / sqrt(s_new^2 + s_old^2)``
    (the two solves' sigmas, as if independent: an upper bound of the change's own sigma when they share data, so a
    conservative z)."""
    ids, values = change_values(new, old)
    out = []
    for name, (unit, d, z) in values.items():
        change = Change(name, unit, len(ids), float(d.mean()), float(z.mean()), float(z[np.argmax(np.abs(z))]))
        change.beyond = [{"session_id": sid, "change": float(dd), "z": float(zz)}
                         for sid, dd, zz in zip(ids, d, z) if abs(zz) > threshold]
        out.append(change)
    return out
