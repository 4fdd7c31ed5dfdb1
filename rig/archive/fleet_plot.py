"""The figures of ``rig fleet --plot`` and of its HTML page (docs/archive.md).

:func:`fleet_figure`: one panel per parameter (bias x, y, z in counts; scale x, y, z in counts/g), in each the
groups side by side: every solved unit a point (a box plot for a group of more than :data:`MAX_POINTS` units), the
median, the robust band ``median +- threshold * spread`` (beyond it a unit stands out) and the units that stand
out, marked and labelled with their session id. :func:`change_figure`: after a re-solve, each parameter's change
of every session in combined sigmas, the band ``+-threshold`` and the sessions beyond it, labelled.

Drawn with :mod:`rig.analysis.plots` (matplotlib's Agg canvas, loaded on request; names drawn as written).
"""

from __future__ import annotations

import math

import numpy as np

from rig.analysis import plots
from rig.archive.fleet import GroupStats

#: a group of more units than this is drawn as a box plot (its outliers still marked), not point by point
MAX_POINTS = 400
#: at most this many outliers are labelled per panel (the largest |z|); the rest are marked only
MAX_LABELS = 8
#: a session id longer than this is labelled by its end
LABEL_CHARS = 22
BAND_COLOUR = "tab:blue"
OUTLIER_COLOUR = "tab:red"
COLS = 3


def _jitter(n: int, width: float = 0.28) -> np.ndarray:
    """Deterministic horizontal offsets for ``n`` points of one group (the same figure every time)."""
    return (np.arange(n) * 0.618034 % 1.0 - 0.5) * 2 * width if n > 1 else np.zeros(n)


def session_label(session_id: str, chars: int = LABEL_CHARS) -> str:
    """A session id as a point's label: whole, or its end (where ids differ: time, seed, hash) after ``…``."""
    text = plots.literal(session_id).replace("\n", " ")
    return text if len(text) <= chars else "…" + text[-(chars - 1):]


def _label(ax, marked: list[tuple[float, float, str, float]]) -> None:
    """Label the ``MAX_LABELS`` points of largest |z| of ``marked`` ((x, y, session id, z)) with their session (the
    others counted in the corner)."""
    chosen = sorted(sorted(marked, key=lambda m: -abs(m[3]))[:MAX_LABELS], key=lambda m: m[1])
    for k, (x, y, sid, _) in enumerate(chosen):  # neighbours in height alternate right and left of their point
        ax.annotate(session_label(sid), (x, y), xytext=(5 if k % 2 == 0 else -5, 3), textcoords="offset points",
                    fontsize=6.5, color=OUTLIER_COLOUR, ha="left" if k % 2 == 0 else "right")
    if len(marked) > MAX_LABELS:
        ax.text(0.99, 0.01, f"{len(marked) - MAX_LABELS} more not labelled", transform=ax.transAxes, ha="right",
                va="bottom", fontsize=6.5, color=OUTLIER_COLOUR)


def _panel(ax, name: str, groups: list[str], values: dict, stats: dict[str, GroupStats], threshold: float) -> None:
    """One parameter: each group's units, median, robust band and outliers."""
    unit = ""
    marked = []
    for i, g in enumerate(groups):
        ids, v = values[g][name]
        p = stats[g].parameters[name]
        unit = p["unit"]
        med, spread = p["median"], p["spread"]
        if math.isfinite(spread) and spread > 0:
            ax.fill_between([i - 0.4, i + 0.4], med - threshold * spread, med + threshold * spread,
                            color=BAND_COLOUR, alpha=0.12, lw=0)
        if math.isfinite(med):
            ax.hlines(med, i - 0.4, i + 0.4, color=BAND_COLOUR, lw=1.5)
        out = {o["session_id"]: o["z"] for o in stats[g].outliers if o["parameter"] == name}
        keep = np.array([sid not in out for sid in ids], bool)
        x = i + _jitter(len(v))
        if len(v) > MAX_POINTS:
            ax.boxplot([v], positions=[i], widths=0.5, showfliers=False, manage_ticks=False)
        else:
            ax.plot(x[keep], v[keep], "o", ms=3, color="0.35", alpha=0.7, lw=0)
        for xi, vi, sid in zip(x, v, ids):
            if sid in out:
                marked.append((float(xi), float(vi), sid, out[sid]))
    if marked:
        ax.plot([m[0] for m in marked], [m[1] for m in marked], "o", ms=5, mfc="none", mec=OUTLIER_COLOUR, mew=1.3)
        _label(ax, marked)
    ax.set_title(plots.short_label(name.replace("_", " "), 48, 1), fontsize=9)
    ax.set_ylabel(plots.short_label(unit, 24, 1), fontsize=8)
    ax.set_xticks(range(len(groups)), [plots.short_label(g, 18, 2) for g in groups], fontsize=7,
                  rotation=0 if len(groups) <= 4 else 45, ha="center" if len(groups) <= 4 else "right")
    ax.set_xlim(-0.6, len(groups) - 0.4)
    ax.tick_params(axis="y", labelsize=7)
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.grid(True, axis="y", color="0.92")


def fleet_figure(values: dict, stats: list[GroupStats], threshold: float, by: str | None, title: str = ""):
    """Per parameter each group's distribution (``values``: :func:`rig.archive.fleet.unit_values`), the robust
    band and the outliers of ``stats`` (:func:`rig.archive.fleet.fleet` at ``threshold``), labelled by session."""
    by_group = {s.group: s for s in stats}
    groups = [s.group for s in stats]
    names = list(stats[0].parameters) if stats else []
    rows = max(1, math.ceil(len(names) / COLS))
    fig = plots.new_figure(max(10.5, 1.1 * len(groups) * COLS + 3), 3.0 * rows + 1.0)
    axes = fig.subplots(rows, COLS, squeeze=False)
    for ax, name in zip(axes.ravel(), names):
        _panel(ax, name, groups, values, by_group, threshold)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    fig.suptitle(plots.wrap(title or f"fleet by {by or 'nothing (one group)'}", int(fig.get_figwidth() * 13)),
                 fontsize=10)
    boxed = any(len(v) > MAX_POINTS for g in values.values() for _, v in g.values())
    fig.supxlabel(plots.wrap(f"one point per solved unit ({'group: ' + by if by else 'all units'})"
                             + (f", a box (quartiles, whiskers at 1.5 IQR) for a group of more than {MAX_POINTS}"
                                if boxed else "") + f"; line: median; band: median +- {threshold:g} robust sigmas "
                             "(1.4826 MAD); red circles: units beyond it, labelled by session",
                             int(fig.get_figwidth() * 17), 3), fontsize=7, color="0.3")
    return fig


def change_figure(ids: list[str], values: dict, threshold: float, title: str = ""):
    """Each parameter's change of every session in combined sigmas (``values``:
    :func:`rig.archive.fleet.change_values`), the band ``+-threshold`` and the sessions beyond it, labelled."""
    names = list(values)
    fig = plots.new_figure(max(9.0, 1.3 * len(names) + 2), 4.8)
    ax = fig.subplots()
    ax.axhspan(-threshold, threshold, color=BAND_COLOUR, alpha=0.12, lw=0)
    ax.axhline(0, color="0.6", lw=0.8, zorder=0)
    marked = []
    for i, name in enumerate(names):
        _, _, z = values[name]
        x = i + _jitter(len(z))
        beyond = np.abs(z) > threshold
        if len(z) > MAX_POINTS:
            ax.boxplot([z], positions=[i], widths=0.5, showfliers=False, manage_ticks=False)
        else:
            ax.plot(x[~beyond], z[~beyond], "o", ms=3, color="0.35", alpha=0.7, lw=0)
        marked += [(float(xi), float(zi), sid, float(zi)) for xi, zi, sid, b in zip(x, z, ids, beyond) if b]
    if marked:
        ax.plot([m[0] for m in marked], [m[1] for m in marked], "o", ms=5, mfc="none", mec=OUTLIER_COLOUR, mew=1.3)
        _label(ax, marked)
    ax.set_xticks(range(len(names)), [n.replace("_", " ") for n in names], fontsize=8)
    ax.set_xlim(-0.6, len(names) - 0.4)
    ax.set_ylabel("change (new - old) / combined sigma", fontsize=8)
    ax.grid(True, axis="y", color="0.92")
    fig.suptitle(plots.wrap(title or f"change after a re-solve over {len(ids)} sessions",
                            int(fig.get_figwidth() * 13)), fontsize=10)
    fig.supxlabel(plots.wrap(f"one point per session solved in both; band: +-{threshold:g} combined sigmas; red "
                             "circles: sessions beyond it, labelled", int(fig.get_figwidth() * 17), 2),
                  fontsize=7, color="0.3")
    return fig
