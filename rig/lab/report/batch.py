"""The batch report: one self-contained HTML page of a fixture run (docs/fixture.md, "The batch report").

:func:`gather_batch` reads ``BATCH_DIR/batch.json`` (:mod:`rig.lab.batch_record`) and, per slot, the sigmas and
failed limits of its calibration file and whether its own session report exists; :func:`batch_page` draws the
page with the one-unit report's scaffold (:mod:`rig.lab.report.render`, :mod:`rig.lab.report.style`): the batch's
identity, the verdict counts by outcome and by failure bin, one row per slot, and a figure of every unit's bias
and scale. No network: the style and the figure are inside the file; the only links are relative ones to the
slots' own reports.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from datetime import datetime, timezone
from html import escape
from pathlib import Path
from urllib.parse import quote

from calib.errors import CalibError
from calib.file import calibration as calfile
from rig import __version__
from rig.analysis import plots
from rig.lab.batch_record import BATCH_FORMAT, read_batch
from rig.lab.bins import GOOD, bin_counts, failure_bin
from rig.lab.report import REPORT_NAME, write_page
from rig.lab.report.render import _num, definitions, figure, note, section, when, writable
from rig.lab.report.style import CSS

BATCH_REPORT_NAME = "batch-report.html"
#: the outcomes in the order the page counts them, and the class their cell is drawn with
OUTCOME_CLASS = {"PASS": "ok", "NO LIMITS": "tag", "FAIL": "bad", "FAULT": "bad", "ABSENT": "bad"}
#: the page's own few rules on top of the one-unit report's style sheet
BATCH_CSS = """
table.units td { font-size: 12.5px; } table.units td.reason { max-width: 320px; overflow-wrap: anywhere; }
table.units tr.not-good td:first-child { border-left: 4px solid var(--fail); }
.counts { display: flex; flex-wrap: wrap; gap: 10px; margin: 4px 0 10px; }
.counts > span { background: var(--soft); border: 1px solid var(--line); border-radius: 6px; padding: 4px 12px; }
"""
CONTENTS = [("verdict", "Verdict"), ("batch", "Batch"), ("units", "Units"), ("figure", "Bias and scale")]
AXES = "xyz"


@dataclass
class SlotRow:
    """One slot as the page shows it: its record entry, its calibration's sigmas (counts, counts/g; None when it
    has none), its bin and the link to its own report (relative to the page's folder; None without one)."""

    entry: dict
    bias_sigma: list | None = None
    scale_sigma: list | None = None
    bin: str = GOOD
    link: str | None = None


@dataclass
class BatchView:
    """What the batch page shows: the record, its directory, and one row per slot."""

    record: dict
    batch_dir: Path
    rows: list[SlotRow] = field(default_factory=list)


def batch_report_path(batch_dir) -> Path:
    """Where the batch report goes by default: ``BATCH_DIR/batch-report.html``."""
    return Path(batch_dir) / BATCH_REPORT_NAME


def gather_batch(batch_dir, *, page_dir=None) -> BatchView:
    """Read the batch's record and every slot's calibration; ``page_dir``: the folder the page is written to (the
    links to the slots' reports are relative to it; default the batch directory).

    Raises RigInputError (one line) for a record that is not ``rig-batch/1``; a slot's calibration that cannot be
    read leaves its sigmas out (never a failure).
    """
    root = Path(batch_dir)
    record = read_batch(root)
    page_dir = Path(page_dir) if page_dir is not None else root
    return BatchView(record, root, [_row(root, page_dir, entry) for entry in record["slots"]])


def _row(root: Path, page_dir: Path, entry: dict) -> SlotRow:
    row = SlotRow(entry)
    failed: list[str] = []
    if entry.get("calibration"):
        try:
            cal = calfile.read(root / entry["calibration"])
        except (CalibError, OSError, ValueError):
            cal = None
        if cal is not None and cal.accelerometer is not None:
            sigma = cal.accelerometer.sigma or {}
            row.bias_sigma, row.scale_sigma = sigma.get("bias_counts"), sigma.get("scale_counts_per_g")
        acceptance = getattr(cal, "acceptance", None) or {}
        failed = [lim["name"] for lim in acceptance.get("limits", []) if not lim.get("passed")]
    row.bin = entry.get("bin") or failure_bin(entry["outcome"], entry.get("reason"), failed)  # older records: none
    if entry.get("session"):
        report = root / entry["session"] / REPORT_NAME
        if report.is_file():
            row.link = quote(Path(os.path.relpath(report, page_dir)).as_posix())
    return row


# ---------------------------------------------------------------------------------------------- drawing

def _outcome(outcome: str) -> str:
    return f'<span class="{OUTCOME_CLASS.get(outcome, "bad")}">{escape(outcome)}</span>'


def _rotation(rotation) -> str:
    if isinstance(rotation, str):
        return escape(rotation)
    rows = rotation if isinstance(rotation, list) else []
    return "matrix " + escape("; ".join(" ".join(_num(v, "g", "?") for v in r) for r in rows)) if rows else "–"


def _with_sigma(values, sigmas, spec: str) -> str:
    """Three per-axis values with their 1-sigma, one per line (``x +286.73 ± 0.55``)."""
    if not values:
        return "–"
    sig = sigmas if sigmas and len(sigmas) == len(values) else [None] * len(values)
    return "<br>".join(f'<span class="nowrap">{a} {_num(v, spec)}'
                       + (f" ± {_num(s, '.2f')}" if s is not None else "") + "</span>"
                       for a, v, s in zip(AXES, values, sig))


def verdict_html(view: BatchView) -> str:
    """All units good (green), or how many are not (red), with the counts by outcome and by bin."""
    rows = view.rows
    good = sum(1 for r in rows if r.bin == GOOD)
    state, badge = ("pass", "ALL GOOD") if good == len(rows) and rows else ("fail", f"{len(rows) - good} NOT GOOD")
    counts = view.record.get("counts") or {}
    outcomes = "".join(f"<span>{_outcome(k)} {int(n)}</span>" for k, n in counts.items() if n or k in ("PASS", "FAIL"))
    bins = "".join(f"<span>{escape(b)} {n}</span>" for b, n in bin_counts(r.bin for r in rows).items() if n)
    return (f'<section id="verdict" class="verdict-section"><div class="verdict verdict-{state}">'
            f'<div class="badge">{escape(badge)}</div><div class="verdict-body">'
            f'<p class="headline">{good} of {len(rows)} units good (PASS or NO LIMITS)</p>'
            f'<h3>by outcome</h3><div class="counts" id="outcome-counts">{outcomes}</div>'
            f'<h3>by failure bin</h3><div class="counts" id="bin-counts">{bins}</div></div></div></section>')


def identity_html(view: BatchView) -> str:
    r = view.record
    proc = r.get("procedure") or {}
    pairs = [("batch", r.get("id")), ("created", when(r.get("created")) if r.get("created") else None),
             ("procedure", proc.get("name")), ("procedure file", proc.get("file")), ("rig file", r.get("rig_file")),
             ("turntable", r.get("turntable")), ("seed", r.get("seed")), ("units", len(view.rows)),
             ("batch folder", str(view.batch_dir.resolve())), ("record", f"batch.json ({BATCH_FORMAT})")]
    return section("batch", "Batch", definitions(pairs))


def units_html(view: BatchView) -> str:
    """One row per slot: slot, serial, mounting, outcome, bin, bias and scale per axis with sigmas, residual,
    reason, and the link to its own report."""
    head = ["slot", "serial", "mounting", "outcome", "bin", "bias x, y, z (counts)", "scale x, y, z (counts/g)",
            "residual (µg rms)", "reason", "report"]
    body = []
    for r in view.rows:
        e, p = r.entry, r.entry.get("parameters") or {}
        link = f'<a href="{escape(r.link)}">report</a>' if r.link else "–"
        cells = [escape(str(e["slot"])), escape(str(e["serial"])), _rotation(e.get("rotation")), _outcome(e["outcome"]),
                 escape(r.bin), _with_sigma(p.get("bias_counts"), r.bias_sigma, "+.2f"),
                 _with_sigma(p.get("scale_counts_per_g"), r.scale_sigma, ".1f"), _num(p.get("residual_ug"), ".1f"),
                 escape(e.get("reason") or ""), link]
        cls = "" if r.bin == GOOD else ' class="not-good"'
        body.append(f"<tr{cls}>" + "".join(f'<td{_cell_class(i)}>{c}</td>' for i, c in enumerate(cells)) + "</tr>")
    header = "".join(f"<th>{escape(h)}</th>" for h in head)
    return section("units", "Units", f'<table id="units-table" class="data units"><thead><tr>{header}</tr></thead>'
                   f"<tbody>{''.join(body)}</tbody></table>"
                   + note("Bias and scale factor per axis of each unit's own frame, with their 1-sigma; a unit "
                          "without a calibration (FAULT, ABSENT, no solve) has none. Bins: docs/fixture.md."))


def _cell_class(i: int) -> str:
    return {5: " class=num", 6: " class=num", 7: " class=num", 8: " class=reason"}.get(i, "")


def figure_html(view: BatchView) -> str:
    """Every unit's bias (counts) and scale factor (counts/g) per axis, with 1-sigma error bars."""
    labels = [f"{r.entry['slot']} {r.entry['serial']}" for r in view.rows]
    panels = []
    for key, sig, name, unit in (("bias_counts", "bias_sigma", "bias", "counts"),
                                 ("scale_counts_per_g", "scale_sigma", "scale", "counts/g")):
        for k, axis in enumerate(AXES):
            pts = [(i, (r.entry.get("parameters") or {})[key][k], _at(getattr(r, sig), k))
                   for i, r in enumerate(view.rows) if (r.entry.get("parameters") or {}).get(key)]
            panels.append((f"{name} {axis}", unit, pts))
    if not any(pts for _, _, pts in panels):
        return section("figure", "Bias and scale", note("No unit of this batch was calibrated: nothing to plot."))
    fig = plots.parameters_figure(f"bias and scale per unit: batch {view.record.get('id', '')}", labels, panels,
                                  footnote="one point per calibrated unit (slot serial), 1-sigma error bars; "
                                           "each unit in its own frame")
    for ax in fig.axes:  # units, not a sequence: points without a line between them
        for line in ax.get_lines():
            line.set_linestyle("")
    return section("figure", "Bias and scale", figure(fig, "bias and scale factor of every calibrated unit",
                                                      "units-figure"))


def _at(values, k: int):
    v = values[k] if values and len(values) > k else None
    return float(v) if v is not None and math.isfinite(float(v)) else None


def batch_page(view: BatchView) -> str:
    """The whole HTML document of the batch."""
    r = view.record
    proc = (r.get("procedure") or {}).get("name") or "procedure"
    now = when(datetime.now(timezone.utc).isoformat(timespec="seconds"))
    nav = "".join(f'<a href="#{i}">{escape(t)}</a>' for i, t in CONTENTS)
    body = "".join([verdict_html(view), identity_html(view), units_html(view), figure_html(view)])
    return writable(
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>Batch report: {escape(str(r.get('id', '')))}</title><style>{CSS}{BATCH_CSS}</style></head><body>"
        f'<header class="top"><div class="kicker">rig batch report</div>'
        f"<h1>{escape(proc)} · {len(view.rows)} units</h1>"
        f'<p class="sub">batch <code>{escape(str(r.get("id", "")))}</code> · run {escape(when(r.get("created", "")))}'
        f" · report written {escape(now)}</p><nav>{nav}</nav></header>"
        f"<main>{body}</main>"
        f"<footer>Written by rig {escape(__version__)} (rig report). Self-contained: the figure is inside this file; "
        f"it loads nothing from the network. The links open each unit's own report beside it.</footer></body></html>\n")


def write_batch_report(batch_dir) -> Path:
    """Write ``BATCH_DIR/batch-report.html``; returns its absolute path (RigInputError: one line, for a record that
    is not ``rig-batch/1`` or a page that cannot be written)."""
    target = batch_report_path(batch_dir)
    return write_page(target, batch_page(gather_batch(batch_dir)), explicit=False)


__all__ = ["BATCH_REPORT_NAME", "BatchView", "SlotRow", "batch_page", "batch_report_path", "gather_batch",
           "write_batch_report"]
