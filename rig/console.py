"""What the technician sees: progress lines, prompts, warnings.

On a terminal the progress is a live ``rich`` line (step, pose, ETA, noise);
elsewhere (CI, logs, pipes) it degrades to one plain line per event.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import TextIO


class OperatorAbsent(Exception):
    """An operator prompt needs an answer but nobody can give one."""


@dataclass
class StepProgress:
    index: int  # 0-based
    total: int
    name: str
    phase: str  # "move" | "settle" | "capture" | "temperature" | "prompt"
    eta_s: float | None = None
    noise_ug: float | None = None
    temp_c: float | None = None
    run_eta_s: float | None = None  # whole run, remaining


class ConsoleUI:
    """Plain-language console output for a run.

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
        self.out = out or sys.stderr
        self.assume_yes = assume_yes
        self.interactive = sys.stdin.isatty() if interactive is None else interactive
        self.quiet = quiet
        self._live = None
        self._last_phase: tuple[int, str] | None = None
        if self.out.isatty() and not quiet:
            try:
                from rich.console import Console
                self._console = Console(file=self.out)
            except ImportError:  # pragma: no cover - rich is a dependency
                self._console = None
        else:
            self._console = None

    def info(self, message: str) -> None:
        if not self.quiet:
            self._line(message)

    def warn(self, message: str) -> None:
        self._line(f"warning: {message}")

    def progress(self, p: StepProgress) -> None:
        if self.quiet:
            return
        eta = f"  ETA {_fmt_s(p.eta_s)}" if p.eta_s is not None else ""
        noise = f"  noise {p.noise_ug:.0f} ug" if p.noise_ug is not None and p.noise_ug == p.noise_ug else ""
        temp = f"  {p.temp_c:.2f} C" if p.temp_c is not None and p.temp_c == p.temp_c else ""
        run_eta = f"  run ETA {_fmt_s(p.run_eta_s)}" if p.run_eta_s is not None else ""
        text = f"[{p.index + 1}/{p.total}] {p.name}: {p.phase}{temp}{noise}{eta}{run_eta}"
        if self._console is not None:
            self._console.print(text, end="\r", highlight=False)
            return
        key = (p.index, p.phase)
        if key != self._last_phase:  # plain output: one line per phase change
            self._last_phase = key
            self._line(text)

    def confirm(self, question: str) -> bool:
        """Ask the operator; True when they confirm."""
        self._line(f">>> {question}")
        if self.assume_yes:
            self._line(">>> (answered yes: --yes)")
            return True
        if not self.interactive:
            raise OperatorAbsent(f"operator prompt needs a terminal: {question!r} (rerun with --yes to confirm prompts)")
        answer = input(">>> press Enter to continue, or type 'abort': ").strip().lower()
        return answer not in ("abort", "a", "no", "n", "q")

    def _line(self, text: str) -> None:
        if self._console is not None:
            self._console.print(" " * 100, end="\r")
        print(text, file=self.out, flush=True)


def _fmt_s(s: float) -> str:
    s = max(0.0, float(s))
    if s < 60:
        return f"{s:.0f}s"
    if s < 3600:
        return f"{int(s // 60)}m{int(s % 60):02d}s"
    return f"{int(s // 3600)}h{int((s % 3600) // 60):02d}m"
