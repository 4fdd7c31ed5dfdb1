"""The report as one self-contained HTML page: standard library only (``html.escape``), the style in
the page, every plot a ``data:image/png;base64`` picture, no script and no web address (docs/report.md).

Names are data: every text from the session, the files and the history is escaped, drawn literally in
the figures (:mod:`rig.analysis.plots`), and a lone surrogate (which UTF-8 cannot carry) is written as
its escape (``\\udcff``), so no name fails the page.
"""

from __future__ import annotations

import math
import re
from datetime import datetime, timezone
from html import escape
from pathlib import Path

import numpy as np

from rig import __version__
from rig.analysis import plots
from rig.analysis.effect_units import shown_effect_unit
from rig.lab.bias_temperature import TEMP_MATCH_C
from rig.lab.drift import fit_label, plot_history, resolve_of
from rig.lab.fit import EXACTLY_DETERMINED, exactly_determined
from rig.lab.report.content import (DiscoverSummary, HistoryView, ReportContent, Residuals, SeedTable,
                                    UncertaintyView, Verdict)
from rig.lab.report.style import CSS

PLOT_DPI = 90
#: longer tables are folded (a <details> element) under their summary line
LONG_TABLE_ROWS = 14


# ---------------------------------------------------------------------------------------------- small pieces

def sigma_digits(sigma) -> int | None:
    """Decimals that show ``sigma`` to two significant digits (None without a usable sigma)."""
    if sigma is None or not math.isfinite(sigma) or sigma <= 0:
        return None
    return 1 - math.floor(math.log10(sigma))


def fmt_value(value, sigma, digits: int | None = None) -> tuple[str, str]:
    """(value, sigma) as text, both to the sigma's second significant digit (or ``digits`` decimals)."""
    if value is None or not math.isfinite(value):
        return "n/a", "–"
    d = sigma_digits(sigma) if digits is None else digits
    if d is None:
        return f"{value:.6g}", "–"
    if d < 0:
        return f"{value:.0f}", f"{sigma:.0f}"
    if d > 9:
        return f"{value:.4e}", f"{sigma:.1e}"
    return f"{value:.{d}f}", f"{sigma:.{d}f}"


def _num(v, spec: str, missing: str = "–") -> str:
    """``v`` formatted, ``missing`` for None or NaN; a value that rounds to zero is written as zero (no "-0.0")."""
    if v is None or not math.isfinite(float(v)):
        return missing
    text = format(float(v), spec)
    return format(0.0, spec) if not text.lstrip("+-").strip("0.") else text


def _value(v) -> str:
    """A limit's value: 6 significant digits; 'not evaluated' when there is none."""
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return _num(v, ".6g")
    return "not evaluated" if v is None else escape(str(v))


def when(text) -> str:
    """An ISO time stamp as ``2026-11-23 09:21:59 UTC`` (other zones keep their offset); other text unchanged."""
    try:
        t = datetime.fromisoformat(str(text))
    except ValueError:
        return str(text)
    if t.tzinfo is not None and t.utcoffset().total_seconds() == 0:
        return t.strftime("%Y-%m-%d %H:%M:%S UTC")
    return t.isoformat(sep=" ", timespec="seconds")


def table(headers, rows, *, id_=None, cls="data", numeric=()) -> str:
    """A table; ``rows`` hold already escaped cell HTML; ``numeric`` column indices are right-aligned."""
    head = "".join(f'<th{" class=num" if i in numeric else ""}>{h}</th>' for i, h in enumerate(headers))
    body = "".join("<tr>" + "".join(f'<td{" class=num" if i in numeric else ""}>{c}</td>' for i, c in enumerate(r))
                   + "</tr>" for r in rows)
    ident = f' id="{id_}"' if id_ else ""
    return f'<table{ident} class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def section(id_: str, title: str, body: str) -> str:
    return f'<section id="{id_}"><h2>{escape(title)}</h2>{body}</section>'


def note(text: str, cls: str = "note") -> str:
    return f'<p class="{cls}">{escape(text)}</p>' if text else ""


def figure(fig, caption: str, id_: str) -> str:
    uri = plots.png_data_uri(fig, dpi=PLOT_DPI)
    return (f'<figure id="{id_}"><img src="{uri}" alt="{escape(caption)}">'
            f"<figcaption>{escape(caption)}</figcaption></figure>")


def definitions(pairs) -> str:
    """A definition list of (label, text) pairs; None values are left out."""
    items = "".join(f"<dt>{escape(k)}</dt><dd>{escape(str(v))}</dd>" for k, v in pairs if v not in (None, ""))
    return f'<dl class="facts">{items}</dl>'


# ---------------------------------------------------------------------------------------------- sections

def verdict_html(v: Verdict) -> str:
    """The verdict card, then (inside the same section) the incomplete-session flag, warnings, the limits."""
    badge = {"pass": "PASS", "fail": "FAIL", "none": "NO LIMITS"}[v.state]
    parts = [f'<div class="verdict verdict-{v.state}"><div class="badge">{badge}</div><div class="verdict-body">'
             f'<p class="headline">{escape(v.headline)}</p>']
    if v.state == "none":
        parts.append('<p class="muted">The calibration file carries no acceptance limits; the fit quality is the '
                     "verdict:</p>")
    if v.failed:
        parts.append('<ul class="failed">' + "".join(f"<li>{escape(x)}</li>" for x in v.failed) + "</ul>")
    parts.append(definitions(v.fit) + "</div></div>")
    if v.incomplete:
        parts.append('<div id="incomplete" class="alert alert-incomplete"><strong>INCOMPLETE SESSION</strong><ul>'
                     + "".join(f"<li>{escape(x)}</li>" for x in v.incomplete) + "</ul>"
                     "<p>The calibration was solved from what was recorded.</p></div>")
    if v.warnings:
        parts.append('<div class="alert alert-warning"><ul>' + "".join(f"<li>{escape(x)}</li>" for x in v.warnings)
                     + "</ul></div>")
    if v.limits:
        rows = [[escape(e["name"]), _value(e["value"]) + (f" {escape(e['unit'])}" if e.get("unit") and
                                                           _value(e["value"]) != "not evaluated" else ""),
                 f'<span class="nowrap">{escape(str(e["limit"]))}</span>',
                 '<span class="ok">pass</span>' if e["passed"] else '<span class="bad">fail</span>', escape(e["line"])]
                for e in v.limits]
        parts.append(table(["check", "value", "limit", "result", "explanation"], rows, id_="acceptance-table",
                           numeric=(1,)))
    return f'<section id="verdict" class="verdict-section">{"".join(parts)}</section>'


def identity_html(c: ReportContent) -> str:
    info, s = c.session.info, c.session.info.rig.sensor
    ident = s.identity if isinstance(s.identity, dict) else {}
    self_test = s.self_test.get("passed") if isinstance(s.self_test, dict) else None
    sensor = [("model", s.model), ("I2C address", f"0x{s.address:02x}" if isinstance(s.address, int) else None),
              ("serial", s.serial), ("identity register", ident.get("identity_value") if ident else None),
              ("history key", c.sensor_key),
              ("accelerometer", f"±{s.accel_range_g:g} g, {s.accel_lsb_per_g:g} counts/g" if s.accel_range_g
               else f"{s.accel_lsb_per_g:g} counts/g"),
              ("gyroscope", f"±{s.gyro_range_dps:g} deg/s" if s.gyro_range_dps else None),
              ("magnetometer", s.magnetometer.model if s.magnetometer else None),
              ("sample rate", f"{s.sample_rate_hz:g} Hz"), ("thermometer", "yes" if s.has_temperature else "no"),
              ("self-test", None if self_test is None else ("passed" if self_test else "FAILED"))]
    table_ = info.rig.turntable
    axes = [(f"axis {n}", f"controller serial {a.serial}, firmware {a.firmware}" + (f", {a.port}" if a.port else ""))
            for n, a in sorted((table_.axes or {}).items())] if table_ is not None else []
    imp = info.import_
    rig = [("kind", (table_.kind if table_ else None) or info.rig.kind), ("rig file", info.rig.rig_file),
           ("simulated sensor seed", info.seed), ("replay of", info.replay_of), *axes,
           ("imported from", f"{imp.source}: {imp.file}" if imp else None)]
    counts = {k: sum(st.status == k for st in info.steps) for k in ("complete", "flagged", "pending", "failed")}
    sess = [("id", info.id), ("folder", str(c.session.path.resolve())), ("procedure", info.procedure.name),
            ("procedure sha256", (info.procedure.sha256 or "")[:16]), ("started", when(info.created)),
            ("ended", when(info.ended) if info.ended else None),
            ("status", info.status), ("steps", ", ".join(f"{n} {k}" for k, n in counts.items() if n)),
            ("samples", len(c.session.samples["t_s"]))]
    cal = c.calibration
    calib_ = [("file", str(c.calibration_path.resolve())), ("created", when(cal.created)),
              ("software", " ".join(str(v) for v in (cal.software or {}).values() if v)),
              ("solved from session", cal.session)]
    blocks = [("Sensor", sensor), ("Rig", rig), ("Session", sess), ("Calibration file", calib_)]
    body = "".join(f'<div class="card"><h3>{escape(t)}</h3>{definitions(p)}</div>' for t, p in blocks)
    return section("identity", "Sensor, rig and session", f'<div class="cards">{body}</div>')


def _change(ch, temp_c: float | None = None) -> str:
    """The change in combined sigmas; ``at T C`` when it was compared at another temperature than ``temp_c``, the
    one the value shown holds at (a thermal calibration's bias at its t0, compared at the sensor's usual one)."""
    if not ch or not math.isfinite(ch.get("z", float("nan"))):
        return "–"
    text = f"{ch['z']:+.1f}σ"
    at = ch.get("at_temp_c")
    if temp_c is not None and at is not None and abs(at - temp_c) > TEMP_MATCH_C:
        text += f" at {at:.1f} C"
    return f'<span class="bad">{text} !</span>' if ch["flagged"] else text


def _unit_at(p) -> str:
    """The unit cell: the unit, and ``at 40.0 C`` for a value that holds at one temperature (a thermal bias)."""
    return escape(p.unit) + (f" at {p.temp_c:.1f} C" if p.temp_c is not None else "")


def _stem(name: str) -> str:
    return re.sub(r"_[xyz]$", "", name)


def parameters_html(c: ReportContent) -> str:
    with_change = any(p.change for p in c.parameters)
    headers = ["parameter", "value", "1σ", "unit"] + (["change since previous calibration"] if with_change else [])
    head = "".join(f'<th{" class=num" if i in (1, 2, 4) else ""}>{h}</th>' for i, h in enumerate(headers))
    groups: dict[str, list[str]] = {}
    decimals: dict[str, int] = {}  # one number of decimals for the x, y, z of a quantity
    for p in c.parameters:
        d = sigma_digits(p.sigma)
        if d is not None:
            decimals[_stem(p.name)] = max(d, decimals.get(_stem(p.name), d))
    for p in c.parameters:
        v, s = fmt_value(p.value, p.sigma, decimals.get(_stem(p.name)) if sigma_digits(p.sigma) is not None else None)
        cells = [f"<code>{escape(p.name)}</code>", v, s, _unit_at(p)] + ([_change(p.change, p.temp_c)]
                                                                         if with_change else [])
        groups.setdefault(p.section, []).append(
            '<tr class="param">' + "".join(f'<td{" class=num" if i in (1, 2, 4) else ""}>{x}</td>'
                                           for i, x in enumerate(cells)) + "</tr>")
    bodies = "".join(f'<tbody><tr class="group"><th colspan="{len(headers)}" scope="rowgroup">{escape(g)}</th></tr>'
                     + "".join(rows) + "</tbody>" for g, rows in groups.items())
    text = ("Every parameter of the calibration file with its 1-sigma uncertainty and unit (names as in the "
            "calibration history).")
    if with_change:
        text += (" The change is in combined sigmas of this and the previous calibration of the sensor; ! marks more "
                 "than 3. Accelerometer biases are compared at the sensor's usual temperature, a thermal "
                 "calibration's carried there by its own bias polynomial (docs/history.md); the values shown are "
                 "this calibration's own, at the temperature the unit column names (a thermal model's t0), and a "
                 "change compared at another temperature names that one.")
    if c.history.resolve_of is not None:
        first = c.history.records[c.history.resolve_of].info
        text += (f" This calibration re-solves session {first.get('session_id')} (history #{c.history.resolve_of + 1}, "
                 f"{fit_label(first)}): the same data, so no change is shown (the methods differ, not the sensor).")
    return section("parameters", "Parameters", note(text, "muted") + f'<table id="parameter-table" class="data">'
                   f"<thead><tr>{head}</tr></thead>{bodies}</table>")


def uncertainty_html(u: UncertaintyView) -> str:
    """The expanded uncertainty U = k u_c of the accelerometer's parameters and their budget (docs/uncertainty.md)."""
    title = "Uncertainty budget"
    if not u.rows:
        return section("uncertainty", title, note(u.note or "No uncertainty budget."))
    k = f"{u.k:g}" if u.k is not None else "?"
    headers = ["parameter", "value", f"U (k = {k})", "u<sub>c</sub>"] + [
        f"{escape(n)} ({escape(t)})" for n, t, _ in u.contributions] + ["unit"]
    rows = []
    for r in u.rows:
        d = sigma_digits(r.expanded)
        v, big_u = fmt_value(r.value, r.expanded)
        rows.append([f"<code>{escape(r.name)}</code>", v, big_u, _num(r.combined, f".{d + 1}f" if d is not None and d >= 0
                                                                       else ".3g")]
                    + [_num(x, ".2g") for x in r.parts] + [escape(r.unit)])
    grid = table(headers, rows, id_="uncertainty-table", numeric=tuple(range(1, 4 + len(u.contributions))))
    sources = table(["contribution", "type", "source"], [[escape(n), escape(t), escape(s)] for n, t, s in u.contributions],
                    id_="uncertainty-sources")
    text = (f"Expanded uncertainty U = k u_c with coverage factor k = {k} (GUM): u_c is the root sum of squares of the "
            "contributions' standard uncertainties (columns, in the parameter's unit). The 1σ of the parameters "
            "table is the Type A contribution alone (noise and wander).")
    return section("uncertainty", title, note(text, "muted") + grid
                   + note(f"rig terms: {u.rig}" if u.rig else "", "muted")
                   + f"<details><summary>where each contribution comes from</summary>{sources}</details>")


def residuals_html(c: ReportContent) -> str:
    r: Residuals = c.residuals
    if r.values_ug is None:
        return section("residuals", "Residuals", note(r.note))
    model = c.calibration.accelerometer.model
    title = f"session {c.session.id}: residuals of the {model} calibration"
    fig = plots.residuals_figure(title, r.names, r.temps_c, [(f"calibration: {r.rms_ug:.1f} µg rms", r.values_ug)],
                                 labels=r.labels)
    cols = [f"{lab}, µg" for lab in r.labels]
    rows = [[escape(n), _num(t, ".2f")] + [f"{v:+.1f}" for v in row]
            for n, t, row in zip(r.names, r.temps_c, r.values_ug)]
    details = ("<details><summary>residuals by step (table)</summary>"
               + table(["step", "temperature, °C"] + cols, rows, id_="residual-table",
                       numeric=tuple(range(1, 2 + len(cols)))) + "</details>")
    text = ("Calibrated minus nominal specific force at every complete static step, sensor frame, in µg; "
            "left: by step in recorded order, right: by temperature.")
    return section("residuals", "Residuals by step and by temperature",
                   note(r.note or text, "muted") + figure(fig, title, "residual-plot") + details)


def seed_html(seed: SeedTable) -> str:
    ev = seed.evaluation
    if ev is None:
        return section("seed-table", "Roll and pitch (the seed paper's table)", note(seed.note))
    rows = [[escape(r.name), f"{_num(r.roll_deg, '.1f')} / {_num(r.pitch_deg, '.1f')}",
             _num(r.roll_error_deg, "+.3f", "n/a"), _num(r.pitch_error_deg, "+.3f"), _num(r.angle_error_deg, ".4f"),
             _num(r.norm_error_g * 1e6, "+.0f")] for r in ev.rows]
    summary = (f"max |error|: roll {ev.max_abs('roll_error_deg'):.3f} deg, pitch {ev.max_abs('pitch_error_deg'):.3f}"
               f" deg, angle {ev.max_abs('angle_error_deg'):.4f} deg, ||f| - 1| {ev.max_abs('norm_error_g') * 1e6:.0f} µg")
    grid = table(["step", "nominal roll / pitch, deg", "roll error, deg", "pitch error, deg", "angle error, deg",
                  "|f| - 1, µg"], rows, id_="roll-pitch-table", numeric=(1, 2, 3, 4, 5))
    if len(rows) > LONG_TABLE_ROWS:
        grid = f"<details><summary>all {len(rows)} poses (table)</summary>{grid}</details>"
    body = (note("Roll and pitch computed from the calibrated specific force at each pose against the nominal pose "
                 "(as rig evaluate prints them). Roll is not scored at gimbal lock (pitch ±90).", "muted")
            + f'<p class="summary">{escape(summary)}</p>' + grid + note(seed.note))
    return section("seed-table", "Roll and pitch (the seed paper's table)", body)


def _ug(doc: dict, key: str) -> float:
    """``doc[key]`` (g) in µg; NaN when absent or null."""
    v = doc.get(key)
    return float("nan") if v is None else float(v) * 1e6


def _effects_rows(doc: dict, lsb_per_g: float | None = None) -> list[list[str]]:
    """The named effects, the bias tempcos in counts/C^s as the parameters table states them, angles in mrad
    (:mod:`rig.analysis.effect_units`)."""
    rows = []
    for e in doc.get("effects") or []:
        unit, k = shown_effect_unit(str(e.get("unit", "")), lsb_per_g)
        est = ", ".join(f"{a} {fmt_value(v * k, _times(s, k))[0]} ± {fmt_value(v * k, _times(s, k))[1]}"
                        if v is not None else f"{a} n/a"
                        for a, v, s in zip(e.get("axes") or [], e.get("estimate") or [], e.get("sigma") or []))
        rows.append([f"<code>{escape(str(e.get('name')))}</code>", escape(est), escape(unit),
                     _num(e.get("p_value"), ".2g"), _num(_ug(e, "rms_after_g"), ".1f")])
    return rows


def _times(v, k: float):
    return None if v is None else v * k


def _discover_figure(doc: dict, session_id: str):
    steps = [s for s in doc.get("steps") or [] if isinstance(s, dict)]
    if not steps:
        return None
    r0 = np.array([[np.nan if x is None else x for x in s.get("residual_before_g") or [None] * 3] for s in steps]) * 1e6
    r1 = np.array([[np.nan if x is None else x for x in s.get("residual_after_g") or [None] * 3] for s in steps]) * 1e6
    names = ", ".join(str(e.get("name")) for e in doc.get("effects") or []) or "nothing added"
    series = [(f"baseline model: {_ug(doc, 'rms_before_g'):.1f} µg rms", r0),
              (f"+ {names}: {_ug(doc, 'rms_after_g'):.1f} µg rms", r1)]
    return plots.residuals_figure(f"rig discover, session {session_id}: residuals before and after",
                                  [str(s.get("name")) for s in steps], [s.get("temp_c") for s in steps], series)


def _discover_document_html(path: Path, doc: dict, session_id: str, lsb_per_g: float | None = None,
                            headline: str = "", modelled=()) -> str:
    """One rig discover document: its headline (the verdict in words, as the console prints it first), the gap,
    the effects named, the plot."""
    gap = (f"gap: {_num(_ug(doc, 'rms_before_g'), '.1f')} → {_num(_ug(doc, 'rms_after_g'), '.1f')} µg rms (noise "
           f"{_num(_ug(doc, 'noise_rms_g'), '.1f')} µg), chi2/dof "
           f"{_num(doc.get('chi2_per_dof_before'), '.2f')} → {_num(doc.get('chi2_per_dof_after'), '.2f')}")
    parts = [f'<p id="discover-headline" class="summary">{escape(headline)}</p>' if headline else "",
             f'<p class="summary">{escape(gap)}</p>']
    rows = _effects_rows(doc, lsb_per_g)
    parts.append(table(["effect named", "estimate ± 1σ", "unit", "p-value", "residual after, µg"], rows,
                       id_="discover-effects", numeric=(3, 4)) if rows else note("effects named: none"))
    had = [str(e.get("name")) for e in doc.get("effects") or [] if isinstance(e, dict) and e.get("name") in modelled]
    if had:
        parts.append(f'<p id="discover-modelled" class="muted">{escape(", ".join(had))}: already in this session\'s '
                     "calibration (its thermal model), not missing from it</p>")
    if doc.get("unobservable"):
        parts.append(note("not observable in this session: " + ", ".join(map(str, doc["unobservable"])), "muted"))
    fig = _discover_figure(doc, session_id)
    if fig is not None:
        parts.append(figure(fig, f"rig discover residuals before and after ({path.name})", "discover-plot"))
    parts.append(note(f"from {path}", "source"))
    return "".join(parts)


def discover_html(d: DiscoverSummary, session_id: str) -> str:
    if d.note:
        return section("discover", "Discrepancy (rig discover)", note(d.note))
    parts = [_discover_document_html(p, doc, session_id, d.lsb_per_g, h, d.modelled)
             for (p, doc), h in list(zip(d.documents, d.headlines or [""] * len(d.documents)))[-1:]]
    for p, effects in d.calibrations:
        parts.append(note(f"augmented calibration {p} (rig discover -o): effects "
                          + ", ".join(str(e.get("name")) for e in effects), "muted"))
    parts += [note(x, "note damaged") for x in d.problems]
    return section("discover", "Discrepancy (rig discover)", "".join(parts))


def history_html(h: HistoryView) -> str:
    if h.note:
        return section("history", "History of this sensor", note(h.note))
    rows = []
    for i, r in enumerate(h.records):
        info = r.info
        mark = ' <span class="tag">this report</span>' if i == h.current else ""
        rows.append([f"#{i + 1}{mark}", escape(when(info.get("calibrated_at") or "–")),
                     escape(str(info.get("procedure_name") or "–")), f"<code>{escape(str(info.get('session_id')))}</code>",
                     escape(fit_label(info)) + (f" (re-solve of #{again + 1}'s session)"
                                                if (again := resolve_of(h.records, i)) is not None else ""),
                     _num(info.get("temp_mean_c"), ".1f"), _num((info.get("residual_rms_g") or float("nan")) * 1e6, ".1f"),
                     escape(EXACTLY_DETERMINED) if exactly_determined(info.get("residual_rms_g"))
                     else _num(info.get("chi2_per_dof"), ".2f"), escape(str(info.get("verdict") or "–"))])
    between = "between each calibration and the previous session's (re-solves of one session are not compared)"
    flagged = (f"drift beyond 3 combined sigma {between}: {', '.join(h.flagged)}" if h.flagged
               else f"no drift beyond 3 combined sigma {between}")
    body = (note(f"sensor {h.key}: {len(h.records)} calibration(s) in {h.path}, oldest first", "muted")
            + table(["#", "calibrated", "procedure", "session", "fit", "temperature, °C", "residual, µg", "chi2/dof",
                     "verdict"], rows, id_="history-table", numeric=(5, 6, 7))
            + f'<p class="summary">{escape(flagged)}</p>' + "".join(note(x, "muted") for x in h.like_with_like)
            + (note(h.reference, "muted") if h.reference else ""))
    if len(h.records) >= 2:
        body += figure(plot_history(h.key, h.records), f"parameters of sensor {h.key} over its calibrations",
                       "history-plot")
    body += "".join(note(x, "note damaged") for x in h.notes)
    return section("history", "History of this sensor", body)


# ---------------------------------------------------------------------------------------------- the page

CONTENTS = [("verdict", "Verdict"), ("identity", "Sensor, rig and session"), ("parameters", "Parameters"),
            ("uncertainty", "Uncertainty"), ("residuals", "Residuals"), ("seed-table", "Roll and pitch"), ("discover", "Discrepancy"),
            ("history", "History")]


def writable(text: str) -> str:
    """``text`` with every lone surrogate (a name no UTF-8 file can hold) written as its escape (``\\udcff``)."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


def page(c: ReportContent) -> str:
    """The whole HTML document (every lone surrogate in a name written as its escape: :func:`writable`)."""
    info = c.session.info
    now = when(datetime.now(timezone.utc).isoformat(timespec="seconds"))
    subject = " · ".join(x for x in (info.rig.sensor.model, info.procedure.name) if x)
    nav = "".join(f'<a href="#{i}">{escape(t)}</a>' for i, t in CONTENTS)
    body = "".join([verdict_html(c.verdict), identity_html(c), parameters_html(c), uncertainty_html(c.uncertainty),
                    residuals_html(c),
                    seed_html(c.seed), discover_html(c.discover, info.id), history_html(c.history)])
    return writable(
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>Calibration report: {escape(info.id)}</title><style>{CSS}</style></head><body>"
        f'<header class="top"><div class="kicker">rig calibration report</div>'
        f"<h1>{escape(subject or 'calibration')}</h1>"
        f'<p class="sub">session <code>{escape(info.id)}</code> · calibrated {escape(when(c.calibration.created))}'
        f" · report written {escape(now)}</p><nav>{nav}</nav></header>"
        f"<main>{body}</main>"
        f'<footer>Written by rig {escape(__version__)} (rig report). Self-contained: every figure is inside '
        f"this file; it loads nothing from the network.</footer></body></html>\n")
