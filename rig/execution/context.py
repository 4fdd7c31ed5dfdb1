"""What every step executor works with: the rig, the session being recorded, the operator, the
options and the session clock."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from rig.config.procedure import PlannedStep, Procedure
from rig.devices.rig import Rig
from rig.errors import RunAborted, RunError
from rig.execution.checks import CheckLimits
from rig.execution.operator import Operator, StepProgress
from rig.session.writer import SessionWriter

if TYPE_CHECKING:  # the policy's module imports this one (and the capture, which imports this one)
    from rig.execution.executors.target_policy import TargetPolicy

__all__ = ["EngineOptions", "RunAborted", "RunContext", "RunError", "StepOutcome"]


@dataclass(frozen=True)
class EngineOptions:
    """How hard the engine tries and how long it waits.

    ``max_attempts`` captures of one step before it is flagged; ``keep_settle_windows`` counts the
    settle detector's still windows as captured data (off: their ringing tail biases step means);
    tolerances in deg, times in s.
    """

    max_attempts: int = 3
    keep_settle_windows: bool = False
    position_tolerance_deg: float = 0.02
    move_timeout_s: float = 120.0
    limits: CheckLimits = field(default_factory=CheckLimits)
    temp_window_s: float = 1.0


@dataclass(frozen=True)
class StepOutcome:
    """How one step ended: ``status`` is complete or flagged; ``problems`` say why it was flagged."""

    index: int
    status: str
    n_samples: int
    problems: list[str] = field(default_factory=list)


@dataclass
class RunContext:
    """The state a run shares between its steps.

    ``recorder`` is the session being written (events, samples, finished steps; its typed manifest
    ``info`` as written so far and its ``session_dir``); ``t0_s`` is the rig-clock time of session time 0 (earlier
    than now on a resume, so session time continues); ``estimates_s`` the expected duration of every
    step (for the run's ETA).
    """

    procedure: Procedure
    rig: Rig
    recorder: SessionWriter
    operator: Operator
    options: EngineOptions
    t0_s: float
    total_steps: int
    estimates_s: list[float]
    magnetometer_samples: int = 0
    io_retries_seen: int = 0
    outcomes: list[StepOutcome] = field(default_factory=list)
    #: the run's accuracy-target policy, made by the first targeted pose
    target: TargetPolicy | None = None
    wall0_s: float = field(default_factory=time.monotonic)
    #: (wall, rig) time of the first progress report: the run's observed pace (ETAs in wall-clock time)
    pace0: tuple[float, float] | None = None

    def session_time(self) -> float:
        """Seconds since the session started (continues across resumes)."""
        return self.rig.clock.now() - self.t0_s

    def event(self, kind: str, **fields) -> None:
        """Record an event stamped with the session time."""
        self.recorder.event(kind, t_s=self.session_time(), **fields)

    def warn(self, step: PlannedStep, message: str, **fields) -> None:
        """A warning in the session's events and on the operator's screen."""
        self.recorder.event("warning", t_s=self.session_time(), step=step.index, message=message, **fields)
        self.operator.warn(message)

    def progress(self, step: PlannedStep, phase: str, **fields) -> None:
        eta_s = fields.get("eta_s")
        current = self.estimates_s[step.index] if eta_s is None else eta_s
        run_eta = sum(self.estimates_s[step.index + 1:]) + current
        self.operator.progress(StepProgress(index=step.index, total=self.total_steps, name=step.name, phase=phase,
                                            run_eta_s=run_eta, wall_per_rig_s=self.wall_per_rig_s(),
                                            **fields))

    def wall_per_rig_s(self) -> float | None:
        """Wall seconds a second of rig time takes in this run: the pace observed since the first progress report
        once :data:`PACE_MIN_RIG_S` of rig time have passed (a time-scaled simulated clock that this machine
        holds back runs slower than its scale), before that the clock's nominal pace (:func:`wall_per_rig_s`)."""
        wall, rig = time.monotonic(), self.rig.clock.now()
        if self.pace0 is None:
            self.pace0 = (wall, rig)
        wall0, rig0 = self.pace0
        if rig - rig0 >= PACE_MIN_RIG_S:
            return (wall - wall0) / (rig - rig0)
        return wall_per_rig_s(self.rig.clock)

    def finish(self, step: PlannedStep, stats: dict, status: str, n_samples: int, problems: list[str]) -> None:
        """Commit a captured step (durable on return) and note its outcome."""
        self.recorder.complete_step(step.index, stats, status=status)
        self.event("capture", step=step.index, n_samples=n_samples, status=status)
        self.outcomes.append(StepOutcome(step.index, status, n_samples, problems))


#: rig seconds after which a run's ETAs use its observed pace instead of the clock's nominal one
PACE_MIN_RIG_S = 5.0


def wall_per_rig_s(clock) -> float | None:
    """Wall seconds per second of ``clock``'s time: ``1 / time_scale`` of a paced clock (1 on hardware, 1/K at
    ``--time-scale K``); None for a virtual clock (its time costs only the machine's speed)."""
    scale = getattr(clock, "time_scale", None)
    return 1.0 / float(scale) if scale else None
