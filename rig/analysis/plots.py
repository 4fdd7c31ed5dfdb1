"""Plots people can read: the ``--plot`` of ``rig discover`` and ``rig history`` and the figures of ``rig report``.

matplotlib is imported inside the functions only (a plot is drawn on request; docs/architecture.md)
and draws on its Agg canvas without pyplot (no display, no global figure state). Every builder
returns a :class:`matplotlib.figure.Figure` the caller can inspect; :func:`save` writes one,
:func:`png_data_uri` embeds one in a page.

The conventions every plot follows:

- the title names what is shown and the session (or the sensor of a history);
- the step axis is labelled with the steps' pose names, in recorded order;
- one unit per quantity, the same in titles and axis labels (residuals in µg);
- the legend sits right of the panels, outside every axes, so it never covers data;
- a panel without data says so (``no temperature data``) instead of staying empty;
- names are data: every text is drawn as written (no mathtext, no TeX, whatever the user's
  matplotlibrc says; :func:`new_figure`'s figure switches both off for every text when it draws),
  control characters and lone surrogates as their escapes (:func:`literal`); a name is shown whole
  in a title (wrapped, :func:`wrap`) and shortened with ``…`` on an axis (:func:`short_label`), so a
  long one never squeezes the panels away.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import io
import math
import os
import re
import textwrap
import warnings
from pathlib import Path

import numpy as np

from rig.errors import RigInputError

#: file types ``--plot`` writes (matplotlib chooses the format from the suffix)
PLOT_SUFFIXES = (".png", ".pdf", ".svg")
RESIDUAL_UNIT = "µg"
NO_TEMPERATURE = "no temperature data"
AXIS_COLOURS = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}
#: more steps than this: only every k-th pose name is written on the step axis
MAX_STEP_LABELS = 40
#: a name on an axis (a step's, a parameter's) longer than this is shortened with "…"; titles show it whole
MAX_LABEL_CHARS = 32
#: a title wraps onto at most this many lines (then "…")
MAX_TITLE_LINES = 8
#: file-name components longer than this end in a hash of the whole text instead (names are data, file
#: systems refuse names beyond 255 bytes)
MAX_FILE_NAME = 80
#: the settings every drawing runs under: user text is never math or TeX
LITERAL_RC = {"text.parse_math": False, "text.usetex": False, "axes.formatter.use_mathtext": False}
#: what is drawn as its escape: control characters but the newline, and lone surrogates (which no font
#: and no file encoding can carry)
_UNDRAWABLE = re.compile(r"[\x00-\x09\x0b-\x1f\x7f-\x9f\ud800-\udfff]")


def literal(text) -> str:
    """``text`` as a figure shows it: ``str(text)`` with control characters (but the newline) and lone
    surrogates written as their Python escapes (``\\x00``, ``\\t``, ``\\udcff``); everything else as is."""
    return _UNDRAWABLE.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), str(text))


def short_label(text, chars: int = MAX_LABEL_CHARS, lines: int = 2) -> str:
    """``text`` (:func:`literal`) for an axis: at most ``lines`` lines of at most ``chars`` characters,
    what is cut off marked with ``…``."""
    rows = literal(text).split("\n")
    out = [r if len(r) <= chars else r[:chars - 1] + "…" for r in rows[:lines]]
    if len(rows) > lines:
        out[-1] = (out[-1][:chars - 1] if len(out[-1]) >= chars else out[-1]) + "…"
    return "\n".join(out)


def wrap(text, width: int, max_lines: int = MAX_TITLE_LINES) -> str:
    """``text`` (:func:`literal`) wrapped at ``width`` characters, its own line breaks kept, long words
    (a long name) broken; beyond ``max_lines`` lines the rest is cut off and marked with ``…``."""
    rows = [w for line in literal(text).split("\n")
            for w in (textwrap.wrap(line, max(8, width), break_on_hyphens=False) or [""])]
    if len(rows) > max_lines:
        rows = rows[:max_lines]
        rows[-1] = rows[-1][:max(1, width - 1)] + "…"
    return "\n".join(rows)


def safe_name(text: str) -> str:
    """``text`` as one file-name component (letters, digits, ``.``, ``_``, ``-``); beyond
    :data:`MAX_FILE_NAME` characters, its beginning and a hash of the whole text."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", str(text)).strip("._") or "plot"
    if len(name) <= MAX_FILE_NAME:
        return name
    digest = hashlib.sha256(str(text).encode("utf-8", "backslashreplace")).hexdigest()[:12]
    return f"{name[:MAX_FILE_NAME - 13].rstrip('._')}-{digest}"


def resolve_plot_path(path, default_name: str) -> Path:
    """The file a ``--plot PATH`` writes, absolute: ``PATH`` itself, or ``PATH/default_name`` when
    ``PATH`` is a directory (an existing one, or one given with a trailing ``/``, then created).

    Raises RigInputError (exit 2) for a suffix matplotlib would not write or a missing folder.
    """
    text = os.fspath(path)
    p = Path(text).expanduser()
    if p.is_dir() or text.endswith(("/", os.sep)):
        try:
            p.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RigInputError(text, None, "--plot", f"cannot create the directory ({exc.strerror})") from None
        p = p / default_name
    if p.suffix.lower() not in PLOT_SUFFIXES:
        raise RigInputError(text, None, "--plot", f"expected a {', '.join(PLOT_SUFFIXES)} file or a directory")
    if not p.parent.is_dir():
        raise RigInputError(text, None, "--plot", f"no such directory: {p.parent}")
    return p.resolve()


@functools.cache
def _literal_figure():
    """The Figure class whose texts are drawn as written (made on first use: matplotlib loads on request)."""
    import matplotlib
    from matplotlib.figure import Figure
    from matplotlib.text import Text

    class LiteralFigure(Figure):
        """A Figure that draws every text literally: mathtext and TeX off for each text it holds and for
        those drawing creates (tick labels), whatever the rc settings; a glyph the font lacks (an emoji)
        is drawn as the font's box, without a warning on the console."""

        def draw(self, renderer):
            with matplotlib.rc_context(LITERAL_RC), warnings.catch_warnings():
                warnings.filterwarnings("ignore", message=r"Glyph \d+ .*missing from", category=UserWarning)
                for t in self.findobj(Text):
                    t.set_parse_math(False)
                    t.set_usetex(False)
                return super().draw(renderer)

    return LiteralFigure


def new_figure(width_in: float, height_in: float):
    """An empty Figure on the Agg canvas, constrained layout (titles, labels and legend never overlap),
    every text drawn as written (no mathtext, no TeX: names are data)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = _literal_figure()(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save(fig, path, dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix); returns the path."""
    p = Path(path)
    fig.savefig(p, dpi=dpi, metadata=_metadata(p.suffix))
    return p


def png_data_uri(fig, dpi: int = 96) -> str:
    """``data:image/png;base64,...`` of ``fig``: a picture a page carries inside itself."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata=_metadata(".png"))
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _metadata(suffix: str) -> dict:
    """No 'Software: matplotlib, https://...' stamp in the file (a report carries no web address)."""
    return {"Creator": None} if suffix.lower() in (".svg", ".pdf") else {"Software": None}


def step_axis(ax, names) -> None:
    """Label the x axis of ``ax`` with the pose names at 0..N-1 (every k-th one beyond 40 steps)."""
    names = [short_label(n) for n in names]
    n = len(names)
    every = max(1, math.ceil(n / MAX_STEP_LABELS))
    ticks = list(range(0, n, every))
    size = 8 if n <= 12 else 7 if n <= 26 else 6
    short = n <= 8 and max((len(s) for s in names), default=0) <= 8 and not any("\n" in s for s in names)
    ax.set_xticks(ticks, [names[i] for i in ticks], fontsize=size, rotation=0 if short else 45,
                  ha="center" if short else "right", rotation_mode="anchor")
    ax.set_xlim(-0.5, n - 0.5)
    ax.set_xlabel("step (pose, in recorded order)" + (f"; every {every}th labelled" if every > 1 else ""))


def no_data(ax, text: str = NO_TEMPERATURE) -> None:
    """A panel that says what is missing instead of an empty frame."""
    ax.text(0.5, 0.5, literal(text), transform=ax.transAxes, ha="center", va="center", fontsize=11, color="0.35")
    ax.tick_params(left=False, bottom=False, labelleft=False, labelbottom=False)
    for spine in ax.spines.values():
        spine.set_color("0.8")


def legend_outside(fig, ax) -> None:
    """One legend for the figure (the series of ``ax``), right of the panels: outside every axes."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside right upper", title="axis", fontsize=9, title_fontsize=9)


def residuals_figure(title: str, step_names, temps_c, series, *, labels=("x", "y", "z"), unit: str = RESIDUAL_UNIT):
    """Residuals by step (top row) and by temperature (bottom row), one column per entry of ``series``
    (a single series: by step and by temperature side by side).

    ``series``: ``[(panel title, residuals (N, len(labels)) in unit), ...]``; ``temps_c`` (N,) with NaN
    (or None) where unknown: without any temperature the bottom row says ``no temperature data``.
    """
    n = len(step_names)
    temps = np.full(n, np.nan) if temps_c is None else np.array([np.nan if t is None else t for t in temps_c], float)
    has_t = bool(np.isfinite(temps).any())
    cols = len(series)
    if cols == 1:  # one series: by step and by temperature side by side
        fig = new_figure(12.0, 4.8)
        grid = fig.subplots(1, 2, width_ratios=[1.7, 1.0], squeeze=False)
        panels = [(grid[0, 0], grid[0, 1])]
    else:
        fig = new_figure(5.6 * cols, 7.4)
        grid = fig.subplots(2, cols, squeeze=False)
        panels = [(grid[0, c], grid[1, c]) for c in range(cols)]
    k = np.arange(n)
    for (top, bottom), (head, r) in zip(panels, series):
        r = np.asarray(r, float).reshape(n, len(labels))
        for j, lab in enumerate(labels):
            colour = AXIS_COLOURS.get(lab, "tab:purple")
            top.plot(k, r[:, j], "o", ms=4, color=colour, label=lab)
            if has_t:
                bottom.plot(temps, r[:, j], "o", ms=4, color=colour, label=lab)
        top.set_title(wrap(head, 70 if cols == 1 else 62, 4), fontsize=10)
        step_axis(top, step_names)
        top.axhline(0, color="0.6", lw=0.8, zorder=0)
        if has_t:
            bottom.axhline(0, color="0.6", lw=0.8, zorder=0)
            bottom.set_xlabel("temperature, °C")
            if cols == 1:
                bottom.set_title("by temperature", fontsize=10)
        else:
            no_data(bottom)
        for a in (top, bottom) if has_t else (top,):
            a.set_ylabel(f"residual, {unit}")
            a.grid(True, color="0.92")
    legend_outside(fig, panels[0][0])
    fig.suptitle(wrap(title, int(fig.get_figwidth() * 11)), fontsize=11)
    return fig


def parameters_figure(title: str, x_labels, panels, *, footnote: str = "", cols: int = 3):
    """One panel per parameter over a sequence (calibrations): ``panels`` is ``[(name, unit, [(x, value,
    sigma or None), ...]), ...]``; error bars are the 1-sigma; the unit is on each y axis."""
    rows = max(1, math.ceil(len(panels) / cols))
    fig = new_figure(4.4 * cols, 2.5 * rows + 1.0)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax, (name, unit, pts) in zip(axes.ravel(), panels):
        ax.errorbar([p[0] for p in pts], [p[1] for p in pts], yerr=[p[2] or 0.0 for p in pts], fmt="o-",
                    capsize=3, ms=4)
        ax.set_title(short_label(name, 48, 1), fontsize=9)
        ax.set_ylabel(short_label(unit, 24, 1), fontsize=8)
        ax.set_xticks(range(len(x_labels)), [short_label(x, MAX_LABEL_CHARS, 3) for x in x_labels], fontsize=6)
        ax.set_xlim(-0.5, len(x_labels) - 0.5)
        ax.tick_params(axis="y", labelsize=7)
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.grid(True, color="0.92")
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    if not panels:
        axes[0, 0].set_visible(True)
        no_data(axes[0, 0], "no parameters recorded")
    fig.suptitle(wrap(title, int(fig.get_figwidth() * 13)), fontsize=10)
    if footnote:
        fig.supxlabel(wrap(footnote, int(fig.get_figwidth() * 17), 3), fontsize=7, color="0.3")
    return fig
