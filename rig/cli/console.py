"""What the technician sees: a live progress bar, prompts, warnings, the result below.

On a terminal the progress is a ``rich.progress`` bar: the step, its phase, temperature and noise,
and the run's end as a wall-clock time; warnings and information print above the bar and the result
below it once the run ends; nothing is redrawn over stale characters. Elsewhere (CI, logs, pipes)
it degrades to one plain line per phase change. The console is a view: when it is gone (a closed
terminal, EIO; a closed pipe, EPIPE) it falls silent and the run goes on, or stops as it was asked
to; a write never aborts a run (:class:`QuietOnFailure`).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from datetime import datetime, timedelta
from typing import TextIO

from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn
from rich.text import Text

from rig.cli.terminal import silence
from rig.execution.operator import OperatorAbsent, StepProgress


class WallClockEta(ProgressColumn):
    """When the run will end, as a time of day (from the remaining rig time and the observed pace)."""

    def render(self, task) -> Text:
        remaining = task.time_remaining
        if remaining is None:
            return Text("ends --:--", style="progress.remaining")
        end = datetime.now() + timedelta(seconds=remaining)
        return Text(f"ends {end:%H:%M}", style="progress.remaining")


class ConsoleUI:
    """Plain-language console output for a run (an ``rig.execution.operator.Operator``).

    Parameters
    ----------
    out : TextIO
        Where progress goes (stderr by default so stdout stays for results).
    assume_yes : bool
        Answer every operator prompt with "yes" (for scripted runs).
    interactive : bool | None
        Whether prompts may read stdin; default: stdin is a terminal.
    quiet : bool
        Only warnings and prompts.
    """

    def __init__(self, out: TextIO | None = None, *, assume_yes: bool = False,
                 interactive: bool | None = None, quiet: bool = False) -> None:
        self.out = QuietOnFailure(out or sys.stderr)
        self.assume_yes = assume_yes
        self.interactive = sys.stdin.isatty() if interactive is None else interactive
        self.quiet = quiet
        self._last_phase: tuple[int, str] | None = None
        self._capture: StepProgress | None = None
        self._live = _LiveBar(self.out) if self.out.isatty() and not quiet else None

    def info(self, message: str) -> None:
        if not self.quiet:
            self._line(message)

    def warn(self, message: str) -> None:
        self._line(f"warning: {message}")

    def progress(self, p: StepProgress) -> None:
        if self.quiet:
            return
        if self._live is not None:
            self._live.update(p)
            return
        key = (p.index, p.phase)
        if key != self._last_phase:  # plain output: one line per phase change
            self._flush_capture()
            self._last_phase = key
            self._line(plain_progress_line(replace(p, noise_ug=None) if p.phase == "capture" else p))
        if p.phase == "capture":  # its noise is printed when the capture is over (a few samples say little)
            self._capture = p

    def _flush_capture(self) -> None:
        """Plain output: the finished capture's line (``done``) with the noise of all its samples."""
        if self._capture is not None:
            self._line(plain_progress_line(replace(self._capture, phase="done", eta_s=None)))
            self._capture = None

    def can_confirm(self) -> bool:
        return self.assume_yes or self.interactive

    def confirm(self, question: str) -> bool:
        """Ask the operator; True when they confirm."""
        self._line(f">>> {question}")
        if self.assume_yes:
            self._line(">>> (answered yes: --yes)")
            return True
        if not self.interactive:
            raise OperatorAbsent(f"operator prompt needs a terminal: {question!r} (rerun with --yes to confirm prompts)")
        if self._live is not None:
            self._live.pause()
        answer = input(">>> press Enter to continue, or type 'abort': ").strip().lower()
        return answer not in ("abort", "a", "no", "n", "q")

    def close(self, *, finished: bool = False) -> None:
        """End the live display: the bar stays where it is and what follows prints below it.
        ``finished``: the run ended normally, so the last capture's line is printed (an aborted
        capture's is not)."""
        if finished:
            self._flush_capture()
        self._capture = None
        if self._live is not None:
            self._live.stop()

    def _line(self, text: str) -> None:
        if self._live is not None:
            self._live.print(text)
        else:
            print(text, file=self.out, flush=True)


class QuietOnFailure:
    """A text stream (the console's) whose writes cannot fail: the first that does (OSError: EIO from a
    terminal that hung up, EPIPE from a pipe whose reader is gone) silences it for good (its descriptor
    goes to /dev/null: :func:`rig.cli.main.silence`), and the text is dropped. The progress bar's
    refresh thread writes through it too."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except OSError:
            silence(self.stream)
            return len(text)

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError:
            silence(self.stream)

    def isatty(self) -> bool:
        try:
            return self.stream.isatty()
        except (OSError, ValueError):
            return False

    def __getattr__(self, name: str):
        return getattr(self.stream, name)


class _LiveBar:
    """One ``rich`` progress bar for the whole run (completed = estimated rig seconds done)."""

    def __init__(self, out: TextIO) -> None:
        self.console = Console(file=out)
        self.bar = Progress(TextColumn("{task.description}"), BarColumn(bar_width=None), WallClockEta(),
                            console=self.console, transient=False, auto_refresh=True)
        self.task = None
        self.total_s = 0.0

    def update(self, p: StepProgress) -> None:
        remaining = max(float(p.run_eta_s or 0.0), 0.0)
        if self.task is None:
            self.total_s = remaining
            self.task = self.bar.add_task(describe(p), total=max(self.total_s, 1e-9))
            self.bar.start()
        self.total_s = max(self.total_s, remaining)
        self.bar.update(self.task, description=describe(p), total=max(self.total_s, 1e-9),
                        completed=self.total_s - remaining)

    def print(self, text: str) -> None:
        self.console.print(text, highlight=False, markup=False)

    def pause(self) -> None:
        self.bar.stop()

    def stop(self) -> None:
        if self.task is not None:
            self.bar.stop()


def describe(p: StepProgress) -> str:
    """Short description of where the run is (fits 60 columns with the bar)."""
    temp = f" {p.temp_c:.1f}C" if p.temp_c is not None and p.temp_c == p.temp_c else ""
    noise = f" {p.noise_ug:.0f}ug" if p.noise_ug is not None and p.noise_ug == p.noise_ug else ""
    return f"[{p.index + 1}/{p.total}] {p.name}: {p.phase}{temp}{noise}{target_text(p, short=True)}"


def target_text(p: StepProgress, short: bool = False) -> str:
    """The predicted figure against the target (empty without a target): `` pred 0.041>0.030 deg``."""
    if p.predicted is None or p.target is None:
        return ""
    sign = "<=" if p.predicted <= p.target else ">"
    unit = (p.target_unit or "").split(" ")[0] if short else (p.target_unit or "")
    label = " pred" if short else "  predicted"
    return f"{label} {p.predicted:.3g}{sign}{p.target:.3g} {unit}".rstrip()


def plain_progress_line(p: StepProgress) -> str:
    """One line for logs: step, phase, temperature, noise, the prediction against the target, the
    step's and the run's remaining time in wall-clock time (rig time / the time scale; none in virtual time)."""
    step_s, run_s = _wall_s(p, p.eta_s), _wall_s(p, p.run_eta_s)
    eta = f"  ETA {_fmt_s(step_s)}" if step_s is not None else ""
    noise = f"  noise {p.noise_ug:.0f} ug" if p.noise_ug is not None and p.noise_ug == p.noise_ug else ""
    temp = f"  {p.temp_c:.2f} C" if p.temp_c is not None and p.temp_c == p.temp_c else ""
    run_eta = f"  run ETA {_fmt_s(run_s)}" if run_s is not None else ""
    return f"[{p.index + 1}/{p.total}] {p.name}: {p.phase}{temp}{noise}{target_text(p)}{eta}{run_eta}"


def _wall_s(p: StepProgress, rig_s: float | None) -> float | None:
    """``rig_s`` seconds of rig time in wall seconds (None: unknown, as in virtual time)."""
    if rig_s is None or p.wall_per_rig_s is None:
        return None
    return rig_s * p.wall_per_rig_s


def _fmt_s(s: float) -> str:
    s = max(0.0, float(s))
    if s < 60:
        return f"{s:.0f}s"
    if s < 3600:
        return f"{int(s // 60)}m{int(s % 60):02d}s"
    return f"{int(s // 3600)}h{int((s % 3600) // 60):02d}m"
