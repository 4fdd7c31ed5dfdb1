"""``rig fleet --html``: one self-contained HTML page of the fleet statistics (docs/archive.md).

The session report's scaffold and style (:mod:`rig.lab.report.render`, :mod:`rig.lab.report.style`): the summary
table (per group and parameter: units, median, spread), the units that stand out, the figure
(:mod:`rig.archive.fleet_plot`, embedded as a ``data:image/png`` picture) and the provenance of the results (the
archive, the solve options, the software versions, how many sessions, the failed rows with their reasons). With
``--against``: the change of every parameter instead, and the provenance of both result sets. No script, no web
address; every name from the results is escaped.
"""

from __future__ import annotations

from datetime import datetime, timezone
from html import escape

from rig import __version__
from rig.archive.fleet import Change, GroupStats, change_values, provenance, unit_values
from rig.archive.fleet_plot import change_figure, fleet_figure
from rig.lab.report.render import _num, definitions, figure, note, section, table, when, writable
from rig.lab.report.style import CSS

FLEET_PAGE_NAME = "fleet.html"
FLEET_CSS = """
table.data td.sid { overflow-wrap: anywhere; max-width: 360px; }
"""


def _summary_html(stats: list[GroupStats], by: str | None) -> str:
    rows = []
    for g in stats:
        for name, p in g.parameters.items():
            rows.append([escape(g.group), str(g.n), str(g.failed), escape(name.replace("_", " ")),
                         _num(p["median"], "+.3f"), _num(p["spread"], ".3f"), escape(p["unit"])])
    head = [escape(by or "group"), "units solved", "failed", "parameter", "median", "spread (1.4826 MAD)", "unit"]
    return section("summary", "Summary", note("Per group and parameter the median and the robust spread of the "
                                              "solved units; failed rows are counted and left out.")
                   + table(head, rows, id_="summary-table", numeric=(1, 2, 4, 5)))


def _outliers_html(stats: list[GroupStats], threshold: float) -> str:
    rows = [[escape(g.group), f'<code>{escape(o["session_id"])}</code>', escape(o["parameter"].replace("_", " ")),
             _num(o["value"], "+.3f"), escape(g.parameters[o["parameter"]]["unit"]), _num(o["z"], "+.1f")]
            for g in stats for o in g.outliers]
    if not rows:
        return section("outliers", "Units that stand out", note(f"No unit beyond {threshold:g} robust sigmas."))
    return section("outliers", "Units that stand out",
                   note(f"{len(rows)} value(s) beyond {threshold:g} robust sigmas: z = (value - median) / spread.")
                   + table(["group", "session", "parameter", "value", "unit", "robust z"], rows, id_="outliers-table",
                           numeric=(3, 5)))


def _provenance_html(prov: dict, title: str = "") -> str:
    options = prov.get("options") or {}
    shown = ", ".join(f"{k} {v}" for k, v in options.items() if v) or "the procedures' own (no --model, --method)"
    facts = definitions([("results", prov["results"]), ("archive", prov.get("archive") or "not recorded"),
                         ("solve options", shown), ("software", ", ".join(prov["software"]) or "not recorded"),
                         ("sessions", str(prov["sessions"])), ("solved", str(prov["solved"])),
                         ("failed", str(prov["sessions"] - prov["solved"]))])
    failed = ""
    if prov["failed"]:
        failed = table(["reason", "sessions", "for example"],
                       [[escape(f["reason"]), str(f["sessions"]),
                         ", ".join(f"<code>{escape(s)}</code>" for s in f["examples"])] for f in prov["failed"]],
                       id_=f"failed-table{'-' + title if title else ''}", numeric=(1,))
    return (f"<h3>{escape(title)}</h3>" if title else "") + facts + failed


def _page(title: str, kicker: str, heading: str, sub: str, contents, body: str) -> str:
    now = when(datetime.now(timezone.utc).isoformat(timespec="seconds"))
    nav = "".join(f'<a href="#{i}">{escape(t)}</a>' for i, t in contents)
    return writable(
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{escape(title)}</title><style>{CSS}{FLEET_CSS}</style></head><body>"
        f'<header class="top"><div class="kicker">{escape(kicker)}</div><h1>{escape(heading)}</h1>'
        f'<p class="sub">{sub} · page written {escape(now)}</p><nav>{nav}</nav></header>'
        f"<main>{body}</main>"
        f"<footer>Written by rig {escape(__version__)} (rig fleet). Self-contained: the figure is inside this file; "
        f"it loads nothing from the network.</footer></body></html>\n")


def fleet_page(stats: list[GroupStats], threshold: float, by: str | None, prov: dict, fig) -> str:
    """The whole HTML document of ``rig fleet RESULTS --html``: ``stats`` (:func:`rig.archive.fleet.fleet` at
    ``threshold``, grouped ``by``), ``prov`` (:func:`rig.archive.fleet.provenance`), ``fig`` (the fleet figure)."""
    units = sum(g.n for g in stats)
    contents = [("summary", "Summary"), ("outliers", "Units that stand out"), ("figure", "Figure"),
                ("provenance", "Provenance")]
    body = "".join([_summary_html(stats, by), _outliers_html(stats, threshold),
                    section("figure", "Figure", figure(fig, "each group's units per parameter, the robust band and "
                                                            "the units beyond it", "fleet-figure")),
                    section("provenance", "Provenance", _provenance_html(prov))])
    sub = (f"results <code>{escape(prov['results'])}</code> · {units} units solved in {len(stats)} "
           f"group(s){' by ' + escape(by) if by else ''}")
    return _page(f"Fleet: {prov['results']}", "rig fleet statistics", f"{units} units", sub, contents, body)


def change_page(found: list[Change], threshold: float, provs: tuple[dict, dict], fig) -> str:
    """The whole HTML document of ``rig fleet NEW --against OLD --html``: ``found``
    (:func:`rig.archive.fleet.changes`), ``provs`` the provenance of NEW and OLD, ``fig`` the change figure."""
    new, old = provs
    rows = [[escape(c.parameter.replace("_", " ")), _num(c.mean, "+.4g"), escape(c.unit), _num(c.mean_z, "+.2f"),
             _num(c.largest_z, "+.2f"), str(len(c.beyond))] for c in found]
    beyond = [[escape(c.parameter.replace("_", " ")), f'<code>{escape(b["session_id"])}</code>',
               _num(b["change"], "+.4g"), escape(c.unit), _num(b["z"], "+.2f")] for c in found for b in c.beyond]
    summary = (note(f"The change from OLD to NEW over the {found[0].n} sessions solved in both; z: the change over "
                    "the two solves' combined sigma.")
               + table(["parameter", "mean change", "unit", "mean z", "largest z", f"beyond {threshold:g}"], rows,
                       id_="summary-table", numeric=(1, 3, 4, 5)))
    outliers = (table(["parameter", "session", "change", "unit", "z"], beyond, id_="outliers-table", numeric=(2, 4))
                if beyond else note(f"No session changed by more than {threshold:g} combined sigmas."))
    contents = [("summary", "Change"), ("outliers", "Sessions beyond"), ("figure", "Figure"),
                ("provenance", "Provenance")]
    body = "".join([section("summary", "Change", summary), section("outliers", "Sessions beyond", outliers),
                    section("figure", "Figure", figure(fig, "each session's change in combined sigmas",
                                                       "fleet-figure")),
                    section("provenance", "Provenance", _provenance_html(new, "new") + _provenance_html(old, "old"))])
    sub = (f"new <code>{escape(new['results'])}</code> · old <code>{escape(old['results'])}</code> · "
           f"{found[0].n} sessions solved in both")
    return _page(f"Fleet change: {new['results']}", "rig fleet: change after a re-solve",
                 f"{found[0].n} sessions re-solved", sub, contents, body)


def fleet_outputs(results, stats: list[GroupStats], by: str | None, threshold: float, page: bool):
    """(the fleet figure, the page's text or None unless ``page``) of ``rig fleet RESULTS --plot/-o``."""
    fig = fleet_figure(unit_values(results, by), stats, threshold, by,
                       f"fleet of {results}: {sum(g.n for g in stats)} units" + (f" by {by}" if by else ""))
    return fig, (fleet_page(stats, threshold, by, provenance(results), fig) if page else None)


def change_outputs(new, old, found: list[Change], threshold: float, page: bool):
    """(the change figure, the page's text or None unless ``page``) of ``rig fleet NEW --against OLD --plot/-o``."""
    ids, values = change_values(new, old)
    fig = change_figure(ids, values, threshold, f"change from {old} to {new} over {len(ids)} sessions solved in both")
    return fig, (change_page(found, threshold, (provenance(new), provenance(old)), fig) if page else None)
