"""Reading the history: the sensors, every calibration of one sensor, the drift between calibrations.

Drift of a parameter between consecutive calibrations k-1 and k is ``z = (v_k - v_{k-1}) /
sqrt(s_{k-1}^2 + s_k^2)`` (units of the combined 1-sigma); ``|z| > 3`` is flagged (docs/history.md).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

from calib.file.parameters import at_common_temperature
from rig.analysis import plots
from rig.lab.history import History, HistoryCorrupt

DRIFT_LIMIT_SIGMA = 3.0


@dataclass
class CalibrationRecord:
    """One stored calibration and its parameters ``{name: (value, sigma, unit)}``."""

    id: int
    info: dict
    parameters: dict = field(default_factory=dict)


def list_sensors(h: History) -> list[dict]:
    """Every sensor with its number of calibrations and the first and last calibration time."""
    rows = h.query("SELECT s.sensor_key, s.model, s.address, s.serial, COUNT(c.id) AS n, "
                   "MIN(c.calibrated_at) AS first, MAX(c.calibrated_at) AS last FROM sensors s "
                   "LEFT JOIN calibrations c ON c.sensor_key = s.sensor_key GROUP BY s.sensor_key ORDER BY s.sensor_key")
    return [dict(r) for r in rows]


def resolve_sensor(h: History, sensor: str) -> str:
    """The stored key matching ``sensor`` exactly, else the one key containing it; HistoryCorrupt otherwise."""
    keys = [r["sensor_key"] for r in h.query("SELECT sensor_key FROM sensors")]
    if sensor in keys:
        return sensor
    hits = [k for k in keys if sensor.lower() in k.lower()]
    if len(hits) == 1:
        return hits[0]
    what = "matches several sensors: " + ", ".join(sorted(hits)) if hits else "no such sensor in the history"
    raise HistoryCorrupt(h.path, f"sensor {sensor!r}: {what} (rig history lists them)")


def sensor_history(h: History, key: str) -> list[CalibrationRecord]:
    """Every calibration of sensor ``key``, oldest first (calibration time, then record order)."""
    cals = h.query("SELECT * FROM calibrations WHERE sensor_key = ? ORDER BY calibrated_at, id", (key,))
    out = [CalibrationRecord(r["id"], {k: r[k] for k in r.keys()}) for r in cals]
    by_id = {c.id: c for c in out}
    for p in h.query("SELECT p.* FROM parameters p JOIN calibrations c ON c.id = p.calibration_id "
                     "WHERE c.sensor_key = ? ORDER BY p.rowid", (key,)):
        by_id[p["calibration_id"]].parameters[p["name"]] = (p["value"], p["sigma"], p["unit"])
    for c in out:
        c.info["rig"] = json.loads(c.info["rig"]) if c.info.get("rig") else None
    return out


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
    return {"format": "rig-history/1", "sensor": key, "drift_limit_sigma": DRIFT_LIMIT_SIGMA,
            "calibrations": cals, "flagged": flagged}


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
    return "\n".join(head + [""] + lines + ["", foot])


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
