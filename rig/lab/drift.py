"""Reading the history: the sensors, every calibration of one sensor, the drift between calibrations.

Drift of a parameter between consecutive calibrations k-1 and k is ``z = (v_k - v_{k-1}) /
sqrt(s_{k-1}^2 + s_k^2)`` (units of the combined 1-sigma); ``|z| > 3`` is flagged (docs/history.md).

The rows are data: every value read is checked (a number where a number belongs, text that is UTF-8,
the rig identity as JSON). A damaged value is shown as missing, a damaged parameter is left out, and
each says so in the record's ``notes`` (printed by ``rig history``, in its JSON, in ``rig report``):
a damaged row never fails a command, and the acceptance limits that read the history (drift since the
previous calibration) judge what is left.
"""

from __future__ import annotations

import json
import math
import sqlite3
from dataclasses import dataclass, field

from calib.file.parameters import at_common_temperature
from rig.analysis import plots
from rig.lab.history import History, HistoryCorrupt

DRIFT_LIMIT_SIGMA = 3.0
#: the columns of ``calibrations`` that hold numbers (anything else in them is damage)
NUMBER_COLUMNS = ("temp_mean_c", "temp_min_c", "temp_max_c", "residual_rms_g", "chi2_per_dof")
INTEGER_COLUMNS = ("id", "steps")


@dataclass
class CalibrationRecord:
    """One stored calibration and its parameters ``{name: (value, sigma, unit)}``; ``notes``: what was
    damaged in its rows and how it is shown (missing, left out)."""

    id: int
    info: dict
    parameters: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _got(v) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _text(v, notes: list[str] | None = None, where: str = ""):
    """A text column's value: str or None (bytes decoded; not UTF-8: with replacement characters and a note)."""
    if isinstance(v, (bytes, bytearray, memoryview)):
        raw = bytes(v)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            if notes is not None:
                notes.append(f"{where}: not UTF-8 text; shown with replacement characters")
            return raw.decode("utf-8", "replace")
    return v if v is None or isinstance(v, str) else str(v)


def _number(v) -> int | float | None:
    """``v`` when it is a finite number (an int or a float), None when it is none (text, a blob, infinity)."""
    if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
        return float(v) if isinstance(v, float) else v
    return None


def _query(h: History, sql: str, params=()) -> list[sqlite3.Row]:
    """``h.query`` with text read as bytes (decoded by the caller, so text that is not UTF-8 is a note
    instead of an error of the whole query)."""
    before = h.conn.text_factory
    h.conn.text_factory = bytes
    try:
        return h.query(sql, params)
    finally:
        h.conn.text_factory = before


def list_sensors(h: History) -> list[dict]:
    """Every sensor with its number of calibrations and the first and last calibration time."""
    rows = _query(h, "SELECT s.sensor_key, s.model, s.address, s.serial, COUNT(c.id) AS n, "
                     "MIN(c.calibrated_at) AS first, MAX(c.calibrated_at) AS last FROM sensors s "
                     "LEFT JOIN calibrations c ON c.sensor_key = s.sensor_key GROUP BY s.sensor_key "
                     "ORDER BY s.sensor_key")
    return [{"sensor_key": _text(r["sensor_key"]) or "", "model": _text(r["model"]), "address": _number(r["address"]),
             "serial": _text(r["serial"]), "n": r["n"], "first": _text(r["first"]), "last": _text(r["last"])}
            for r in rows]


def resolve_sensor(h: History, sensor: str) -> str:
    """The stored key matching ``sensor`` exactly, else the one key containing it; HistoryCorrupt otherwise."""
    keys = [_text(r["sensor_key"]) or "" for r in _query(h, "SELECT sensor_key FROM sensors")]
    if sensor in keys:
        return sensor
    hits = [k for k in keys if sensor.lower() in k.lower()]
    if len(hits) == 1:
        return hits[0]
    what = "matches several sensors: " + ", ".join(sorted(hits)) if hits else "no such sensor in the history"
    raise HistoryCorrupt(h.path, f"sensor {sensor!r}: {what} (rig history lists them)")


def _calibration_info(row: sqlite3.Row, where: str, notes: list[str]) -> dict:
    """The ``calibrations`` row as plain values: numbers where numbers belong, text, the rig as a mapping."""
    info = {}
    for k in row.keys():
        v = row[k]
        if k in NUMBER_COLUMNS or k in INTEGER_COLUMNS:
            n = _number(v)
            if v is not None and (n is None or (k in INTEGER_COLUMNS and not isinstance(n, int))):
                notes.append(f"{where}: {k}: expected a number, got {_got(_text(v))}; shown as missing")
                n = None
            info[k] = n
        elif k == "rig":
            text = _text(v, notes, f"{where}: rig")
            try:
                rig = json.loads(text) if text else None
            except (ValueError, RecursionError):
                rig = text
            if rig is not None and not isinstance(rig, dict):
                notes.append(f"{where}: rig: expected the rig identity as a JSON mapping, got {_got(text)}; "
                             "shown as missing")
                rig = None
            info[k] = rig
        else:
            info[k] = _text(v, notes, f"{where}: {k}")
    return info


def sensor_history(h: History, key: str) -> list[CalibrationRecord]:
    """Every calibration of sensor ``key``, oldest first (calibration time, then record order); a
    damaged value is missing, a damaged parameter left out, each with a note in the record's ``notes``."""
    cals = _query(h, "SELECT * FROM calibrations WHERE sensor_key = ? ORDER BY calibrated_at, id", (key,))
    out, where = [], {}
    for i, r in enumerate(cals):
        notes: list[str] = []
        here = f"calibration #{i + 1} (history row {_text(r['id'])})"
        info = _calibration_info(r, here, notes)
        out.append(CalibrationRecord(info["id"], info, notes=notes))
        where[info["id"]] = here
    by_id = {c.id: c for c in out if c.id is not None}
    for p in _query(h, "SELECT p.* FROM parameters p JOIN calibrations c ON c.id = p.calibration_id "
                       "WHERE c.sensor_key = ? ORDER BY p.rowid", (key,)):
        rec = by_id.get(p["calibration_id"])
        if rec is None:
            continue
        here = where[rec.id]
        name = _text(p["name"], rec.notes, f"{here}: a parameter name")
        if not name:
            rec.notes.append(f"{here}: a parameter without a name; left out")
            continue
        value, sigma = _number(p["value"]), _number(p["sigma"])
        if value is None:
            rec.notes.append(f"{here}: parameter {name}: expected a number, got {_got(_text(p['value']))}; left out")
            continue
        if p["sigma"] is not None and (sigma is None or sigma < 0):
            rec.notes.append(f"{here}: parameter {name}: sigma: expected a number >= 0, got "
                             f"{_got(_text(p['sigma']))}; shown as missing")
            sigma = None
        rec.parameters[name] = (value, sigma, _text(p["unit"], rec.notes, f"{here}: parameter {name}: unit"))
    return out


def history_notes(records: list[CalibrationRecord]) -> list[str]:
    """Every record's notes (what was damaged in the history and how it is shown), oldest first."""
    return [n for r in records for n in r.notes]


def drift(records: list[CalibrationRecord], limit: float = DRIFT_LIMIT_SIGMA) -> dict[str, list[dict | None]]:
    """Per parameter, per calibration: None for the first (or when the parameter is new), else
    ``{delta, combined_sigma, z, flagged}``; accelerometer biases of two calibrations of which one
    or both have temperature terms are compared at one temperature (``at_temp_c``, see
    :func:`calib.file.parameters.at_common_temperature`)."""
    names = list(dict.fromkeys(n for r in records for n in r.parameters))
    pairs = [at_common_temperature(prev.parameters, prev.info.get("temp_mean_c"), cur.parameters,
                                   cur.info.get("temp_mean_c")) for prev, cur in zip(records, records[1:])]
    out: dict[str, list[dict | None]] = {}
    for name in names:
        col: list[dict | None] = [None]
        for p0, p1, common_c in pairs:
            if name not in p0 or name not in p1:
                col.append(None)
                continue
            (v0, s0, _), (v1, s1, _) = p0[name], p1[name]
            comb = math.hypot(s0, s1) if s0 is not None and s1 is not None else float("nan")
            z = (v1 - v0) / comb if comb > 0 else float("nan")
            col.append({"delta": v1 - v0, "combined_sigma": comb, "z": z,
                        "flagged": bool(math.isfinite(z) and abs(z) > limit),
                        **({"at_temp_c": common_c} if common_c is not None and name.startswith("accel.bias") else {})})
        out[name] = col
    return out


def history_document(key: str, records: list[CalibrationRecord]) -> dict:
    """``rig history SENSOR --json``: the calibrations, their parameters and the drift."""
    d = drift(records)
    cals = []
    for i, r in enumerate(records):
        params = {n: {"value": v, "sigma": s, "unit": u,
                      **({"change": d[n][i]} if d.get(n) and d[n][i] is not None else {})}
                  for n, (v, s, u) in r.parameters.items()}
        cals.append({**r.info, "parameters": params})
    flagged = sorted({n for n, col in d.items() for c in col if c and c["flagged"]})
    notes = history_notes(records)
    return {"format": "rig-history/1", "sensor": key, "drift_limit_sigma": DRIFT_LIMIT_SIGMA,
            "calibrations": cals, "flagged": flagged,
            **({"notes": notes} if notes else {})}


def _cell(value: float, sigma, change) -> str:
    main = f"{value:.6g}" + (f"+-{sigma:.2g}" if sigma is not None else "")
    if change is None:
        return main
    z = change["z"]
    mark = " !" if change["flagged"] else ""
    return f"{main} ({z:+.1f}s{mark})" if math.isfinite(z) else main


def format_history(key: str, records: list[CalibrationRecord]) -> str:
    """The table: one column per calibration, one row per parameter; ``(+1.2s)`` is the change since
    the previous calibration in combined sigmas, ``!`` beyond 3."""
    d = drift(records)
    head = [f"sensor {key}: {len(records)} calibration(s)"]
    for i, r in enumerate(records, 1):
        t = r.info.get("temp_mean_c")
        head.append(f"  #{i} {r.info['calibrated_at']}  {r.info.get('procedure_name') or '-'}  session "
                    f"{r.info.get('session_id')}  {'' if t is None else f'{t:.1f} C  '}"
                    f"residual {1e6 * (r.info.get('residual_rms_g') or float('nan')):.1f} ug  "
                    f"chi2/dof {r.info.get('chi2_per_dof') or float('nan'):.2f}"
                    + (f"  {r.info['verdict']}" if r.info.get("verdict") else ""))
    cells = {n: [_cell(*r.parameters[n][:2], d[n][i]) if n in r.parameters else "-" for i, r in enumerate(records)]
             for n in d}
    width = [max(len(f"#{i + 1}"), *(len(c[i]) for c in cells.values())) for i in range(len(records))]
    name_w = max([len("parameter (unit)")] + [len(f"{n} ({_unit(records, n)})") for n in cells])
    lines = [f"{'parameter (unit)':<{name_w}}  " + "  ".join(f"{f'#{i + 1}':>{w}}" for i, w in enumerate(width))]
    for n, row in cells.items():
        lines.append(f"{n + ' (' + _unit(records, n) + ')':<{name_w}}  " + "  ".join(
            f"{c:>{w}}" for c, w in zip(row, width)))
    flagged = sorted({n for n, col in d.items() for c in col if c and c["flagged"]})
    foot = (f"drift beyond {DRIFT_LIMIT_SIGMA:g} combined sigma: " + ", ".join(flagged)) if flagged else \
        f"no drift beyond {DRIFT_LIMIT_SIGMA:g} combined sigma"
    moved = [f"#{i + 1} compared with #{i} at {c['at_temp_c']:.1f} C"
             for i, c in enumerate(d.get("accel.bias_x", [])) if c and "at_temp_c" in c]
    if moved:
        foot += ("\naccelerometer biases with temperature terms are carried to the other calibration's "
                 "temperature before comparing: " + "; ".join(moved))
    notes = [f"note: {n}" for n in history_notes(records)]
    return "\n".join(head + [""] + lines + ["", foot] + notes)


def _unit(records, name) -> str:
    return next(r.parameters[name][2] for r in records if name in r.parameters) or "-"


def plot_history(key: str, records: list[CalibrationRecord], path=None):
    """Each parameter over the calibrations with 1-sigma error bars, one panel per parameter, its unit
    on the y axis; the x axis names each calibration (number, date, procedure), the footnote its session.

    ``path`` a file or a directory (then ``history-SENSOR.png`` inside it): writes the plot and returns
    the absolute path written; ``path`` None: returns the matplotlib Figure (nothing written).
    """
    ticks = [f"#{i + 1}\n{(r.info.get('calibrated_at') or '')[:16].replace('T', ' ')}\n"
             f"{r.info.get('procedure_name') or ''}" for i, r in enumerate(records)]
    panels = [(name, _unit(records, name), [(i, *r.parameters[name][:2]) for i, r in enumerate(records)
                                           if name in r.parameters]) for name in drift(records)]
    sessions = [f"#{i + 1} {r.info.get('session_id') or '-'}" for i, r in enumerate(records)]
    footnote = "sessions: " + ";  ".join(sessions) if len(records) <= 8 else \
        f"sessions: {sessions[0]} ... {sessions[-1]} (rig history {key} lists them all)"
    fig = plots.parameters_figure(f"calibration history of sensor {key}: {len(records)} calibration(s), "
                                  "oldest first, 1-sigma error bars", ticks, panels, footnote=footnote)
    if path is None:
        return fig
    target = plots.resolve_plot_path(path, plots.safe_name(f"history-{key}") + ".png")
    return plots.save(fig, target, dpi=110)
