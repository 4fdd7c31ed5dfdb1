"""The operator as the engine sees it: someone who is told things and may be asked to confirm.

The engine never prints. It reports progress, information and warnings to an :class:`Operator`
and asks it to confirm prompts. The console (``rig.cli.console.ConsoleUI``) is the operator of a
technician's run; :class:`SilentOperator` is the operator of tests and replays.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol


class OperatorAbsent(Exception):
    """An operator prompt needs an answer but nobody can give one."""


@dataclass(frozen=True)
class StepProgress:
    """Where a run is, for a progress display.

    ``index`` is 0-based; ``phase`` is one of move, settle, capture, spin-up, temperature, prompt.
    Times are seconds of rig time; ``noise_ug`` is the largest per-axis sample standard deviation
    so far (micro-g); ``run_eta_s`` the remaining time of the whole run; ``wall_per_rig_s`` the wall seconds a
    second of rig time takes (1 on hardware, 1/K at ``--time-scale K``, then the pace observed in the run;
    None while unknown: virtual time before a pace is observed), so a display shows ETAs in wall-clock time. With an accuracy target,
    ``predicted`` is the calibration's predicted figure (this pose stopping now, the poses to come
    getting their planned dwell) against ``target``, both in ``target_unit`` (deg for the largest
    roll/pitch error).
    """

    index: int
    total: int
    name: str
    phase: str
    eta_s: float | None = None
    noise_ug: float | None = None
    temp_c: float | None = None
    run_eta_s: float | None = None
    wall_per_rig_s: float | None = 1.0
    predicted: float | None = None
    target: float | None = None
    target_unit: str | None = None


class Operator(Protocol):
    """What the engine needs from whoever watches the run."""

    def info(self, message: str) -> None: ...

    def warn(self, message: str) -> None: ...

    def progress(self, progress: StepProgress) -> None: ...

    def confirm(self, question: str) -> bool: ...

    def can_confirm(self) -> bool:
        """Whether someone (or --yes) can answer a prompt: checked before a run that has prompts."""
        ...


class SilentOperator:
    """Reports nothing; answers prompts with ``answer`` (None: nobody is there to answer).

    Parameters
    ----------
    answer : bool | None
        True confirms every prompt (a replay re-enacts a run whose prompts were confirmed);
        None raises :class:`OperatorAbsent` at the first prompt.
    """

    def __init__(self, answer: bool | None = None) -> None:
        self.answer = answer
        self.warnings: list[str] = []

    def info(self, message: str) -> None:
        """Nothing is shown."""

    def warn(self, message: str) -> None:
        self.warnings.append(message)

    def progress(self, progress: StepProgress) -> None:
        """Nothing is shown."""

    def can_confirm(self) -> bool:
        return self.answer is not None

    def confirm(self, question: str) -> bool:
        if self.answer is None:
            raise OperatorAbsent(f"operator prompt needs a terminal: {question!r} "
                                 "(rerun with --yes to confirm prompts)")
        return self.answer
