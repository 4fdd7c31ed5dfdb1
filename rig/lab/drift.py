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

import re

import json
import math
from dataclasses import dataclass, field

from calib.file.parameters import at_common_temperature
from rig.lab.bias_temperature import TEMP_MATCH_C, ReferenceView, compared_parameters, reference_view
from rig.lab.fit import EXACTLY_DETERMINED, exactly_determined
from rig.lab.history import History, HistoryCorrupt
from rig.lab.history_plot import history_figure, save_history_figure
from rig.lab.units import shown, shown_unit

DRIFT_LIMIT_SIGMA = 3.0
#: the columns of ``calibrations`` that hold numbers (anything else in them is damage)
NUMBER_COLUMNS = ("temp_mean_c", "temp_min_c", "temp_max_c", "residual_rms_g", "chi2_per_dof")
INTEGER_COLUMNS = ("id", "steps", "simulated")


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


def _query(h: History, sql: str, params=None) -> list:
    """``h.query`` with text read as bytes where a file may hold text that is not UTF-8 (SQLite; decoded by the
    caller, so such text is a note instead of an error of the whole query). Rows read by column name."""
    return h.query(sql, params, raw_text=True)


def list_sensors(h: History, include_simulated: bool = True) -> list[dict]:
    """Every sensor with its number of calibrations (``n``; ``simulated`` of them recorded on the simulated or
    replay rig) and the first and last calibration time. ``include_simulated`` False: the hardware
    calibrations only, and only the sensors that have one (the default view of ``rig history``)."""
    rows = _query(h, "SELECT s.sensor_key, s.model, s.address, s.serial, COUNT(c.id) AS n, "
                     "COALESCE(SUM(c.simulated), 0) AS n_sim, "
                     "MIN(c.calibrated_at) AS first, MAX(c.calibrated_at) AS last FROM sensors s "
                     "LEFT JOIN calibrations c ON c.sensor_key = s.sensor_key AND (:everything = 1 OR c.simulated = 0) "
                     "GROUP BY s.sensor_key ORDER BY s.sensor_key", {"everything": int(include_simulated)})
    out = [{"sensor_key": _text(r["sensor_key"]) or "", "model": _text(r["model"]), "address": _number(r["address"]),
            "serial": _text(r["serial"]), "n": r["n"], "simulated": r["n_sim"], "first": _text(r["first"]),
            "last": _text(r["last"])}
           for r in rows if include_simulated or r["n"]]
    return sorted(out, key=lambda row: natural_key(row["sensor_key"]))


def natural_key(text: str) -> list:
    """Sort key that orders the numbers in ``text`` by value (``sim-seed-2`` before ``sim-seed-10``)."""
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", text)]


def resolve_sensor(h: History, sensor: str) -> str:
    """The stored key matching ``sensor`` exactly, else the one key containing it; HistoryCorrupt otherwise."""
    keys = [_text(r["sensor_key"]) or "" for r in _query(h, "SELECT sensor_key FROM sensors")]
    if sensor in keys:
        return sensor
    hits = [k for k in keys if sensor.lower() in k.lower()]
    if len(hits) == 1:
        return hits[0]
    what = "matches several sensors: " + ", ".join(sorted(hits)) if hits else "no such sensor in the history"
    raise HistoryCorrupt(h.path, f"sensor {sensor!r}: {what} (rig history --all lists them, simulated ones too)")


def _calibration_info(row, where: str, notes: list[str]) -> dict:
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


def sensor_history(h: History, key: str, include_simulated: bool | None = None) -> list[CalibrationRecord]:
    """Every calibration of sensor ``key``, oldest first (calibration time, then record order); a
    damaged value is missing, a damaged parameter left out, each with a note in the record's ``notes``.

    ``include_simulated``: True every calibration, False those of hardware rigs only, None (the default view)
    those of hardware rigs when the sensor has any, else its simulated ones (a simulated sensor's history)."""
    cals = _query(h, "SELECT * FROM calibrations WHERE sensor_key = :key ORDER BY calibrated_at, id", {"key": key})
    if not include_simulated:
        hardware = [r for r in cals if not r["simulated"]]
        cals = hardware if hardware or include_simulated is False else cals
    out, where = [], {}
    for i, r in enumerate(cals):
        notes: list[str] = []
        here = f"calibration #{i + 1} (history row {_text(r['id'])})"
        info = _calibration_info(r, here, notes)
        info["simulated"] = bool(info.get("simulated"))
        out.append(CalibrationRecord(info["id"], info, notes=notes))
        where[info["id"]] = here
    by_id = {c.id: c for c in out if c.id is not None}
    for p in _query(h, "SELECT p.* FROM parameters p JOIN calibrations c ON c.id = p.calibration_id "
                       f"WHERE c.sensor_key = :key ORDER BY p.{h.db.row_order}", {"key": key}):
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


def resolve_of(records: list[CalibrationRecord], i: int) -> int | None:
    """The first calibration (index) of the session calibration ``i`` was solved from, when that is an earlier one:
    ``i`` is then a re-solve of the same data (another method or model, ``rig solve S --method flip``), not a new
    measurement of the sensor; None otherwise (and for a calibration whose session is unknown)."""
    sid = records[i].info.get("session_id")
    if sid is None:
        return None
    return next((j for j in range(i) if records[j].info.get("session_id") == sid), None)


def fit_label(info: dict) -> str:
    """How a calibration was fitted: ``triangular by pinv``, ``diagonal by flip`` (the history's model, method)."""
    model, method = info.get("model"), info.get("method")
    return f"{model or '?'} by {method}" if method else str(model or "-")


def previous_index(records: list[CalibrationRecord], i: int) -> int | None:
    """The calibration (index) calibration ``i`` is compared with for drift, like with like: a calibration of the
    newest earlier session other than ``i``'s (re-solves of one session share its data: their differences are the
    methods', not the sensor's), the one fitted as ``i`` was (same model and method) when that session has one, else
    its newest. None: nothing to compare with (the sensor's first session, or ``i`` is a re-solve)."""
    if resolve_of(records, i) is not None:
        return None
    return like_previous(records[:i], records[i].info.get("session_id"), fit_label(records[i].info))


def like_previous(records: list[CalibrationRecord], session_id: str | None, fit: str) -> int | None:
    """Among ``records`` (oldest first), the one a calibration of session ``session_id`` fitted as ``fit``
    (:func:`fit_label`) is compared with: of the newest session other than ``session_id``, its calibration fitted
    the same way when it has one, else its newest. None when every record is of ``session_id``."""
    newest = next((j for j in range(len(records) - 1, -1, -1)
                   if session_id is None or records[j].info.get("session_id") != session_id), None)
    if newest is None:
        return None
    other = records[newest].info.get("session_id")
    same = [j for j in range(newest + 1) if records[j].info.get("session_id") == other
            and fit_label(records[j].info) == fit] if other is not None else []
    return same[-1] if same else newest


def _pair(records: list[CalibrationRecord], view: ReferenceView, j: int,
          i: int) -> tuple[dict, dict, float | None, list | None]:
    """Calibrations ``j`` (the previous one, :func:`previous_index`) and ``i`` as the drift compares them:
    ``(previous, current, at_temp_c, across_c)``. Both at the reference temperature: the view's values there.
    Otherwise the pair at its own common temperature (:func:`calib.file.parameters.at_common_temperature`), and
    ``across_c`` the two temperatures when no model brings the biases to one (both without temperature terms, more
    than ``TEMP_MATCH_C`` apart)."""
    prev, cur = records[j], records[i]
    if view.at_reference(j) and view.at_reference(i):
        return compared_parameters(prev, view, j), compared_parameters(cur, view, i), view.temp_c, None
    p0, p1, common = at_common_temperature(prev.parameters, prev.info.get("temp_mean_c"), cur.parameters,
                                           cur.info.get("temp_mean_c"))
    t0, t1 = view.biases[j].temp_c, view.biases[i].temp_c
    across = None
    if common is None and (t0 is None or t1 is None or abs(t1 - t0) > TEMP_MATCH_C):
        across = [t0, t1]
    return p0, p1, common, across


def drift(records: list[CalibrationRecord], limit: float = DRIFT_LIMIT_SIGMA,
          view: ReferenceView | None = None) -> dict[str, list[dict | None]]:
    """Per parameter, per calibration: None for the first (or when the parameter is new, or the calibration is a
    re-solve of an earlier one's session: :func:`resolve_of`), else ``{delta, combined_sigma, z, flagged,
    compared_with}`` against the calibration :func:`previous_index` picks (``compared_with``: its number, 1 for
    the first). Accelerometer biases are compared at the sensor's reference temperature
    (:mod:`rig.lab.bias_temperature`, ``at_temp_c``) where both calibrations' biases hold there, else at the
    pair's common temperature (``at_temp_c``), or, when no model brings them to one, as stated (``across_temp_c``:
    the two temperatures)."""
    view = view if view is not None else reference_view(records)
    names = list(dict.fromkeys(n for r in records for n in r.parameters))
    previous = [previous_index(records, i) for i in range(len(records))]
    pairs = [None if j is None else (j, *_pair(records, view, j, i)) for i, j in enumerate(previous)]
    out: dict[str, list[dict | None]] = {}
    for name in names:
        col: list[dict | None] = []
        bias = name.startswith("accel.bias")
        for pair in pairs:
            if pair is None or name not in pair[1] or name not in pair[2]:
                col.append(None)
                continue
            j, p0, p1, common_c, across = pair
            (v0, s0, _), (v1, s1, _) = p0[name], p1[name]
            comb = math.hypot(s0, s1) if s0 is not None and s1 is not None else float("nan")
            z = (v1 - v0) / comb if comb > 0 else float("nan")
            col.append({"delta": v1 - v0, "combined_sigma": comb, "z": z,
                        "flagged": bool(math.isfinite(z) and abs(z) > limit), "compared_with": j + 1,
                        **({"at_temp_c": common_c} if common_c is not None and bias else {}),
                        **({"across_temp_c": across} if across is not None and bias else {})})
        out[name] = col
    return out


def flagged_names(d: dict[str, list[dict | None]]) -> list[str]:
    """The parameters whose change between two consecutive calibrations is beyond the limit."""
    return sorted({n for n, col in d.items() for c in col if c and c["flagged"]})


def history_document(key: str, records: list[CalibrationRecord]) -> dict:
    """``rig history SENSOR --json``: the calibrations, their parameters (as stored: value, sigma, unit; an
    accelerometer bias also ``at_reference``, as compared) and the drift; ``reference_temperature``."""
    view = reference_view(records)
    d = drift(records, view=view)
    cals = []
    for i, r in enumerate(records):
        b = view.biases[i]
        params = {}
        for n, (v, s, u) in r.parameters.items():
            params[n] = {"value": v, "sigma": s, "unit": u,
                         **({"at_reference": {"value": b.values[n][0], "sigma": b.values[n][1], "temp_c": b.temp_c,
                                              "own_temperature": view.own_temperature(i),
                                              **({"carried_by_calibration": b.carried_by + 1}
                                                 if b.carried_by is not None else {})}} if n in b.values else {}),
                         **({"change": d[n][i]} if d.get(n) and d[n][i] is not None else {})}
        cals.append({**r.info, "parameters": params})
    notes = history_notes(records)
    return {"format": "rig-history/1", "sensor": key, "drift_limit_sigma": DRIFT_LIMIT_SIGMA,
            "reference_temperature": view.to_json(), "calibrations": cals, "flagged": flagged_names(d),
            **({"notes": notes} if notes else {})}


def _cell(value: float, sigma, unit, change, mark: str = "") -> str:
    value, sigma, _ = shown(value, sigma, unit)
    main = f"{value:.6g}" + (f"+-{sigma:.2g}" if sigma is not None else "") + mark
    if change is None:
        return main
    z = change["z"]
    flag = " !" if change["flagged"] else ""
    return f"{main} ({z:+.1f}s{flag})" if math.isfinite(z) else main


def _own_mark(view: ReferenceView, i: int) -> str:
    t = view.biases[i].temp_c
    return (" @?C" if t is None else f" @{t:.1f}C") if view.own_temperature(i) else ""


def fit_text(info: dict, unit: str = "ug") -> str:
    """The fit of a history row in words: ``residual 91.9 ug  chi2/dof 1.19``, or, for an exactly determined fit
    (a residual at rounding level: the flip method on six faces), ``residual 0.0 ug, exactly determined (no
    residual to judge the fit)`` as ``rig solve`` says it (``unit``: ``ug`` on the console, ``µg`` in the report)."""
    res = info.get("residual_rms_g")
    residual = f"residual {1e6 * (res if res is not None else float('nan')):.1f} {unit}"
    if exactly_determined(res):
        return f"{residual}, {EXACTLY_DETERMINED}"
    chi2 = info.get("chi2_per_dof")
    return f"{residual}  chi2/dof {chi2 if chi2 is not None else float('nan'):.2f}"


def _heading(i: int, r: CalibrationRecord, records: list[CalibrationRecord]) -> str:
    t = r.info.get("temp_mean_c")
    again = resolve_of(records, i - 1)
    return (f"  #{i} {r.info['calibrated_at']}  {r.info.get('procedure_name') or '-'}  session "
            f"{r.info.get('session_id')}  {'' if t is None else f'{t:.1f} C  '}{fit_label(r.info)}  "
            f"{fit_text(r.info)}"
            + (f"  {r.info['verdict']}" if r.info.get("verdict") else "")
            + ("  simulated" if r.info.get("simulated") else "")
            + (f"  (a re-solve of #{again + 1}'s session: not compared for drift)" if again is not None else ""))


#: the width ``rig history``'s table keeps to unless asked for every column (``--wide``), characters
TABLE_WIDTH = 120


def shown_columns(name_w: int, width: list[int], max_width: int | None) -> list[int]:
    """The calibrations (indices) whose columns fit in ``max_width`` characters: the first (the baseline) and as many
    of the newest as fit, never fewer than those two; every one when ``max_width`` is None."""
    n = len(width)
    if max_width is None or name_w + sum(w + 2 for w in width) <= max_width:
        return list(range(n))
    room = max_width - name_w - (width[0] + 2) - 5  # the first column and the gap marker
    newest: list[int] = []
    for i in range(n - 1, 0, -1):
        if newest and room < width[i] + 2:
            break
        newest.insert(0, i)
        room -= width[i] + 2
    return [0] + newest


def format_history(key: str, records: list[CalibrationRecord], max_width: int | None = TABLE_WIDTH) -> str:
    """The table: one column per calibration, one row per parameter (angles in mrad, as ``rig run`` prints
    them); accelerometer biases at the sensor's reference temperature (``@25.1C``: at its own temperature, no
    model moves it); ``(+1.2s)`` is the change since the previous calibration in combined sigmas, ``!`` beyond 3.
    The columns keep to ``max_width`` characters (the first and the newest calibrations; a note says which were left
    out and how to see them); None: every column."""
    view = reference_view(records)
    d = drift(records, view=view)
    head = [f"sensor {key}: {len(records)} calibration(s)"] + [_heading(i, r, records)
                                                               for i, r in enumerate(records, 1)]
    cells = {}
    for n in d:
        row = []
        for i, r in enumerate(records):
            b = view.biases[i]
            v, s, u = b.values[n] if n in b.values else r.parameters.get(n, (None, None, None))
            row.append("-" if v is None else _cell(v, s, u, d[n][i], _own_mark(view, i) if n in b.values else ""))
        cells[n] = row
    width = [max(len(f"#{i + 1}"), *(len(c[i]) for c in cells.values())) for i in range(len(records))]
    name_w = max([len("parameter (unit)")] + [len(f"{n} ({_unit(records, n)})") for n in cells])
    shown = shown_columns(name_w, width, max_width)
    gap = len(shown) > 1 and shown[1] > 1  # calibrations left out between the first and the newest

    def row_text(first: str, items: list[str]) -> str:
        parts = [f"{items[i]:>{width[i]}}" for i in shown]
        if gap:
            parts.insert(1, "...")
        return f"{first:<{name_w}}  " + "  ".join(parts)

    lines = [row_text("parameter (unit)", [f"#{i + 1}" for i in range(len(records))])]
    for n, row in cells.items():
        lines.append(row_text(f"{n} ({_unit(records, n)})", row))
    if gap:
        lines.append(f"(#2..#{shown[1]} left out to keep to {max_width} characters: rig history {key} --wide shows "
                     "every calibration; --json and --plot have them all)")
    flagged = flagged_names(d)
    foot = (f"drift beyond {DRIFT_LIMIT_SIGMA:g} combined sigma: " + ", ".join(flagged)) if flagged else \
        f"no drift beyond {DRIFT_LIMIT_SIGMA:g} combined sigma"
    foot += "".join(f"\n{x}" for x in like_with_like_lines(records))
    foot += "\n" + _reference_lines(view, d.get("accel.bias_x", []))
    notes = [f"note: {n}" for n in history_notes(records)]
    return "\n".join(head + [""] + lines + ["", foot] + notes)


def like_with_like_lines(records: list[CalibrationRecord]) -> list[str]:
    """Under the table: the re-solves (compared with nothing: the same data) and the calibrations compared with
    another than the one before them (:func:`previous_index`)."""
    out = []
    again: dict[int, list[int]] = {}
    for i in range(len(records)):
        j = resolve_of(records, i)
        if j is not None:
            again.setdefault(j, []).append(i)
    for j, later in again.items():
        out.append(f"re-solves of session {records[j].info.get('session_id')} (#{j + 1}): "
                   + ", ".join(f"#{i + 1} {fit_label(records[i].info)}" for i in later)
                   + " (the same data: their differences are the methods', not drift; not compared)")
    other = [f"#{i + 1} with #{j + 1}" for i in range(1, len(records))
             if (j := previous_index(records, i)) is not None and j != i - 1]
    if other:
        out.append("compared like with like (the previous session's calibration fitted the same way): "
                   + ", ".join(other))
    return out


def _reference_lines(view: ReferenceView, col: list[dict | None]) -> str:
    """Under the table: the reference temperature, what was carried there, what stays at its own temperature."""
    out = [view.describe()]
    carried = [f"#{i + 1} from its t0 {b.carried_from_c:.1f} C" for i, b in enumerate(view.biases)
               if b.carried_by is None and b.carried_from_c is not None
               and abs(b.carried_from_c - (view.temp_c or 0.0)) > TEMP_MATCH_C]
    if carried:
        out.append("carried by their own bias polynomial (sigma propagated): " + "; ".join(carried))
    borrowed = [f"#{i + 1} from {b.carried_from_c:.1f} C by the tempcos of #{b.carried_by + 1}"
                for i, b in enumerate(view.biases) if b.carried_by is not None]
    if borrowed:
        out.append("carried by this sensor's tempcos from its thermal calibration (no temperature model of their own; "
                   "sigma propagated): " + "; ".join(borrowed))
    own = [f"#{i + 1}" for i in range(len(view.biases)) if view.own_temperature(i)]
    if own:
        out.append("marked @T: stated at their own temperature, no temperature model moves them: " + ", ".join(own))
    moved = [f"#{i + 1} compared with #{c['compared_with']} at {c['at_temp_c']:.1f} C" for i, c in enumerate(col)
             if c and "at_temp_c" in c and (view.own_temperature(i) or view.own_temperature(c["compared_with"] - 1))]
    if moved:
        out.append("accelerometer biases with temperature terms are carried to the other calibration's "
                   "temperature before comparing: " + "; ".join(moved))
    across = [f"#{i + 1} with #{c['compared_with']}" for i, c in enumerate(col) if c and "across_temp_c" in c]
    if across:
        out.append("compared as stated across temperatures (no temperature model; the change includes the "
                   "temperature's): " + ", ".join(across))
    return "\n".join(out)


def _unit(records, name) -> str:
    return shown_unit(next(r.parameters[name][2] for r in records if name in r.parameters)) or "-"


def plot_history(key: str, records: list[CalibrationRecord], path=None):
    """Each parameter over the calibrations with 1-sigma error bars (:mod:`rig.lab.history_plot`), biases at
    the reference temperature, angles in mrad.

    ``path`` a file or a directory (then ``history-SENSOR.png`` inside it): writes the plot and returns
    the absolute path written; ``path`` None: returns the matplotlib Figure (nothing written).
    """
    view = reference_view(records)
    panels = []
    for name in drift(records, view=view):
        pts = []
        for i, r in enumerate(records):
            b = view.biases[i]
            if name in b.values:
                own_c = (math.nan if b.temp_c is None else b.temp_c) if view.own_temperature(i) else None
                pts.append((i, *shown(*b.values[name])[:2], own_c))
            elif name in r.parameters:
                pts.append((i, *shown(*r.parameters[name])[:2], None))
        panels.append((name, _unit(records, name), pts))
    fig = history_figure(key, records, panels, view.describe())
    return fig if path is None else save_history_figure(fig, key, path)
