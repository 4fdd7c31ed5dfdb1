"""The history figure: every parameter of a sensor over its calibrations, readable at 50 calibrations.

The x axis is the calibration's number (``#1`` oldest), labelled at most :data:`MAX_X_LABELS` times; a legend
table under the panels says, per number, when, which procedure and at what temperature (a date under every
tick overprints into a smear beyond a handful of calibrations, issue 33 item 1). Every text is inside the
figure: the panels, the table and the caption are laid out by matplotlib's constrained layout, the table's
entries are cut to the width of their column, point labels are clipped to their panel.
"""

from __future__ import annotations

import math

from rig.analysis import plots

MAX_X_LABELS = 12  # tick labels per panel at most (every k-th number beyond)
COLS = 3  # panels per row
LEGEND_FONT_PT = 6.5
LEGEND_LINE_IN = LEGEND_FONT_PT * 1.45 / 72
CHAR_IN = LEGEND_FONT_PT * 0.62 / 72  # the width of one monospace character
OWN_TEMP_COLOUR = "tab:orange"
FOOT_SESSIONS = 8  # the caption names every session up to this many calibrations (else the first and the last)


def legend_entries(records) -> list[str]:
    """``#k  YYYY-MM-DD HH:MM  procedure  T C`` per calibration (``sim``: recorded on a simulated rig)."""
    out = []
    for i, r in enumerate(records, 1):
        when = (r.info.get("calibrated_at") or "")[:16].replace("T", " ")
        t = r.info.get("temp_mean_c")
        out.append(f"#{i:<3d} {when}  {r.info.get('procedure_name') or '-'}"
                   f"{'' if t is None else f'  {t:.1f} C'}{'  sim' if r.info.get('simulated') else ''}")
    return out


def _legend_layout(n: int, width_in: float) -> tuple[int, int, int]:
    """(columns, rows per column, characters per entry) of the legend table for ``n`` calibrations."""
    cols = 1 if n <= 6 else 2 if n <= 16 else 3 if n <= 36 else 4
    rows = math.ceil(n / cols)
    return cols, rows, max(12, int(width_in / cols / CHAR_IN) - 2)


def _x_axis(ax, n: int) -> None:
    every = max(1, math.ceil(n / MAX_X_LABELS))
    ticks = list(range(0, n, every))
    ax.set_xticks(ticks, [f"#{i + 1}" for i in ticks], fontsize=7)
    ax.set_xlim(-0.6, n - 0.4)


def _panel(ax, name: str, unit: str, pts, n: int) -> None:
    """One parameter: ``pts`` ``[(index, value, sigma or None, own temperature C or None), ...]``."""
    ordinary = [p for p in pts if p[3] is None]
    own = [p for p in pts if p[3] is not None]
    ax.errorbar([p[0] for p in pts], [p[1] for p in pts], yerr=[p[2] or 0.0 for p in pts], fmt="-", color="0.55",
                lw=0.8, capsize=2, elinewidth=0.8)
    ax.plot([p[0] for p in ordinary], [p[1] for p in ordinary], "o", ms=3.5, color="tab:blue")
    if own:
        ax.plot([p[0] for p in own], [p[1] for p in own], "D", ms=4.5, mfc="white", color=OWN_TEMP_COLOUR)
        for i, v, _, t in own:
            ax.annotate("?C" if math.isnan(t) else f"{t:.1f}C", (i, v), xytext=(0, 5), textcoords="offset points",
                        fontsize=5.5, ha="center", color=OWN_TEMP_COLOUR, annotation_clip=True, clip_on=True)
    ax.set_title(plots.short_label(name, 48, 1), fontsize=9)
    ax.set_ylabel(plots.short_label(unit, 24, 1), fontsize=8)
    _x_axis(ax, n)
    ax.tick_params(axis="y", labelsize=7)
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.grid(True, color="0.92")


def _legend_table(ax, records, width_in: float) -> None:
    entries = legend_entries(records)
    cols, rows, chars = _legend_layout(len(entries), width_in)
    ax.axis("off")
    for k, text in enumerate(entries):
        c, r = divmod(k, rows)
        ax.text(c / cols, 1 - (r + 1.5) / (rows + 1), plots.short_label(text, chars, 1), transform=ax.transAxes,
                fontsize=LEGEND_FONT_PT, family="monospace", va="center", ha="left")
    key = ("calibrations (number, time, procedure, mean temperature);  o: bias at the reference temperature;  "
           "hollow diamond: at its own temperature (no temperature model), labelled with it")
    ax.text(0, 1 - 0.5 / (rows + 1), plots.short_label(key, int(width_in / CHAR_IN) - 2, 1),
            transform=ax.transAxes, fontsize=LEGEND_FONT_PT, va="center", ha="left", color="0.3")


def history_figure(key: str, records, panels, reference_line: str):
    """The figure: ``panels`` ``[(name, unit, [(index, value, sigma, own temperature or None), ...]), ...]``."""
    n = len(records)
    rows = max(1, math.ceil(len(panels) / COLS))
    width_in = 4.4 * COLS
    _, legend_rows, _ = _legend_layout(n, width_in)
    legend_in = (legend_rows + 1) * LEGEND_LINE_IN + 0.15
    fig = plots.new_figure(width_in, 2.5 * rows + legend_in + 1.4)
    grid = fig.add_gridspec(rows + 1, COLS, height_ratios=[2.5] * rows + [legend_in])
    axes = [fig.add_subplot(grid[i // COLS, i % COLS]) for i in range(max(1, len(panels)))]
    for ax, (name, unit, pts) in zip(axes, panels):
        _panel(ax, name, unit, pts, n)
    if not panels:
        plots.no_data(axes[0], "no parameters recorded")
    _legend_table(fig.add_subplot(grid[rows, :]), records, width_in)
    title = (f"calibration history of sensor {key}: {n} calibration(s), oldest first, 1-sigma error bars; "
             f"{reference_line}")
    fig.suptitle(plots.wrap(title, int(width_in * 13), 4), fontsize=9)
    sessions = [f"#{i + 1} {r.info.get('session_id') or '-'}" for i, r in enumerate(records)]
    foot = ("sessions: " + ";  ".join(sessions) if n <= FOOT_SESSIONS else
            f"sessions: {sessions[0]} ... {sessions[-1]} (rig history {key} lists them all)")
    fig.supxlabel(plots.wrap(foot, int(width_in * 17), 3), fontsize=7, color="0.3")
    return fig


def save_history_figure(fig, key: str, path):
    """Write ``fig`` to ``path`` (a directory: ``history-SENSOR.png`` inside it); the path written."""
    target = plots.resolve_plot_path(path, plots.safe_name(f"history-{key}") + ".png")
    return plots.save(fig, target, dpi=110)
