"""The stopping rule of a procedure with an accuracy target (``target:``; docs/procedures.md,
"Accuracy targets"; the mathematics in :mod:`calib.accel.predict`).

One :class:`TargetPolicy` per run, kept in ``RunContext.target``. After every capture block of a
targeted pose it re-estimates the noise from every sample captured so far (the pooled,
correlation-aware standard errors of :mod:`calib.numerics.uncertainty`, the same the solver will use) and
predicts the calibration for the display; at the pose's first block, whenever its dwell has grown by
half since, and when its share is captured, it plans the least dwell of this pose and the poses
still to come that meets the target within the time cap (travel and settling of the poses to come
reserved). The pose stops when its share of the plan is captured: another second here would pay
less than a second at the poses to come (or, at the last pose, as soon as the target is met). A target the first block already shows out of reach is
refused; one that drifts out of reach later is warned about with the numbers and pursued as far as
the cap allows. Decisions are taken at fixed sample counts from the samples alone (and their
session times), so a replay of the recording stops where the run stopped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.accel.predict import Predictor, describe, plan_dwell, planned_sems, unit_of
from calib.numerics.uncertainty import pooled_vif, step_standard_errors
from rig.config.procedure import Procedure
from rig.devices.rig import Rig
from rig.execution.capture import nominal_dwell_s
from rig.execution.context import RunContext, RunError
from rig.planning.kinematics import STAGE_AXES
from rig.planning.targets import move_time_s
from rig.session import load_session
from rig.session.adapter import accel_stability, chip_of

#: decisions every BLOCK_S of samples; never less than MIN_DWELL_S at a pose
BLOCK_S = 0.25
MIN_DWELL_S = 0.5
#: the first decision refuses a target predicted out of reach by more than this factor: the noise is then known from
#: 0.5 s of samples, whose standard error and VIF estimates may be 10-20 % off
REFUSE_FACTOR = 1.25
#: the plan is also redone whenever the pose's dwell has grown by this factor since it was last made: the
#: noise known from the first blocks may be 10-50 % off, and a pose must not be held to an early plan
REPLAN_GROWTH = 1.5
#: at the last pose of an unreachable target: stop once the rest of the cap would improve the prediction by less
NO_LONGER_PAYS = 0.01
#: what a capture takes after its last sample (the last poll, stopping the sensor), s: kept clear of the cap
CAP_MARGIN_S = 0.1
#: per pose beyond the move and the settle rule's two windows: sensor start, polls (s)
STEP_MARGIN_S = 0.2
#: the standard error of a mean never goes below the quantisation of one count (as rig.session.adapter)
QUANTUM_SIGMA = 1.0 / np.sqrt(12.0)


@dataclass(frozen=True)
class Decision:
    """After one capture block: stop or go on, why, the prediction and the target for the display
    (deg for an attitude target, else the worst parameter's unit) and the pose's remaining dwell."""

    stop: bool
    reason: str
    predicted: float
    target: float
    unit: str
    eta_s: float


class TargetSetup:
    """What a target's planning needs and a run does not change: the goal, its predictor, the static
    steps and the time each costs beyond its dwell on this rig (the preflight uses it alone)."""

    def __init__(self, procedure: Procedure, rig: Rig) -> None:
        sensor = rig.sensor
        self.rig = rig
        self.spec = procedure.target
        self.goal = self.spec.goal(procedure.solve.model)
        self.rate = float(procedure.sensor.sample_rate_hz)  # what the sensor is configured to (also before it is)
        # as the solver's: the unit's own figures when its noise profile is known, else the chip family's
        stability = rig.unit_accel_stability or accel_stability(chip_of(sensor.model))
        self.stability_name = ("this unit's bias stability (its noise profile)" if rig.unit_accel_stability is not None
                               else "the chip's bias stability")
        self.predictor = Predictor(self.goal, sensor.accel_lsb_per_g, stability=stability)
        self.statics = [s for s in procedure.expanded_steps() if s.kind == "static"]

    def timeline(self, start_s: float, steps: list, dwell_s: list) -> tuple[np.ndarray, np.ndarray]:
        """Capture windows ``(t_mid_s, duration_s)`` of ``steps`` taken one after another from session time
        ``start_s`` with dwells ``dwell_s`` (s), each after its move and settling (:meth:`overhead_of`)."""
        mids, t = [], float(start_s)
        for s, d in zip(steps, dwell_s):
            t += self.overhead_of(s.index)
            mids.append(t + d / 2)
            t += d
        return np.array(mids), np.asarray(dwell_s, float)

    def overhead_of(self, index: int) -> float:
        """Move into static step ``index`` from the one before it, settle and margin (s)."""
        before = [s for s in self.statics if s.index < index]
        step = next(s for s in self.statics if s.index == index)
        a = np.asarray(before[-1].angles_deg if before else (0.0, 0.0, 0.0), float)
        turn = np.abs((np.asarray(step.angles_deg, float) - a + 180.0) % 360.0 - 180.0)
        axes = self.rig.axes
        move = max(move_time_s(d, axes[n].config.speed_deg_s, axes[n].config.accel_deg_s2) for n, d in zip(STAGE_AXES, turn))
        settle = 2 * step.settle.window_s + step.settle.min_s if self.rig.settle == "accelerometer" else 0.0
        return move + settle + STEP_MARGIN_S


class TargetPolicy:
    """The run's target state: the captured steps, the plan, and the decisions (see the module)."""

    def __init__(self, ctx: RunContext, recorded: dict[int, tuple[np.ndarray, np.ndarray]] | None = None) -> None:
        self.ctx = ctx
        self.setup = setup = TargetSetup(ctx.procedure, ctx.rig)
        self.spec, self.goal, self.rate = setup.spec, setup.goal, setup.rate
        self.predictor, self.statics = setup.predictor, setup.statics
        self.blocks: dict[int, np.ndarray] = {i: np.asarray(a, float) for i, (_, a) in (recorded or {}).items()}
        self.mids: dict[int, float] = {i: _mid(t) for i, (t, _) in (recorded or {}).items()}
        self.spans: dict[int, float] = {i: _span(t) for i, (t, _) in (recorded or {}).items()}
        self.block_n = max(2, int(round(BLOCK_S * self.rate)))
        self.min_n = self.block_n * max(1, int(np.ceil(MIN_DWELL_S * self.rate / self.block_n)))
        self.planned_s: dict[int, float] = {}
        self.plan = None
        self.replanned_at = 0.0
        self.stats: dict[int, dict] = {}
        self.warned = False

    @classmethod
    def for_run(cls, ctx: RunContext) -> "TargetPolicy":
        """The policy of this run; a resumed run starts from the static steps already recorded."""
        done = [s.index for s in ctx.recorder.info.steps if s.status == "complete" and s.kind == "static"]
        recorded = {}
        if done:
            session = load_session(ctx.recorder.session_dir)
            for i in done:
                rows = session.step_samples(i)
                recorded[i] = (np.asarray(rows["t_s"], float), np.asarray(rows["accel_counts"], float))
        return cls(ctx, recorded)

    # -- the rule -------------------------------------------------------------------------------
    def decide(self, step, accel_counts: np.ndarray, t_s: np.ndarray) -> Decision:
        """Stop or go on after the samples ``accel_counts`` (n, 3) of ``step`` taken at session times ``t_s``."""
        tau = len(accel_counts) / self.rate
        layout = _Layout.build(self, step, np.asarray(accel_counts, float), tau)
        budget_s = self.spec.max_seconds - float(t_s[-1]) - self._reserved_after(step)
        last = self._last_free(step)
        self.predictor.timeline = self._timeline(layout, step, np.asarray(t_s, float), tau)
        first_look = step.index not in self.planned_s
        if first_look or tau >= self.planned_s[step.index] - 1e-9 or tau >= REPLAN_GROWTH * self.replanned_at:
            self._replan(step, layout, tau, budget_s, first_look)
            self.replanned_at = tau
        planned = self.planned_s[step.index]
        now = self.predictor.predict(layout.f, planned_sems(layout.sem, layout.unit, layout.dwell_now(tau, self),
                                                            layout.free))
        stop, reason = self._stop(tau, planned, budget_s, now, last)
        value, target, unit = self._shown(now)
        self.stats[step.index] = {"dwell_s": tau, "planned_s": planned, "stop": reason if stop else None,
                                  "predicted": value, "unit": unit}
        return Decision(stop, reason, value, target, unit, max(planned - tau, 0.0))

    def _stop(self, tau: float, planned: float, budget_s: float, now, last: bool) -> tuple[bool, str]:
        """Why this pose stops now (or "" to go on): see the module."""
        if budget_s < BLOCK_S + CAP_MARGIN_S:  # another block would end past the cap
            return True, "time cap reached"
        if last and now.met:
            return True, "target met"
        if last and not self.plan.feasible and now.ratio <= self.plan.ratio * (1.0 + NO_LONGER_PAYS):
            return True, "target out of reach: more samples here no longer pay"
        if tau < planned - 1e-9:
            return False, ""
        if not self.plan.feasible:
            return True, "target out of reach: as far as the time cap allows"
        return True, "its share of the plan: a second more pays less at the poses still to come"

    def _replan(self, step, layout, tau: float, budget_s: float, first_look: bool) -> None:
        min_s = np.where(layout.free, MIN_DWELL_S, 0.0)
        min_s[layout.current] = tau
        reserved_min = MIN_DWELL_S * (int(layout.free.sum()) - 1)  # the least dwell of the poses to come
        # a pose that stops at its share is final, but the noise it was planned with is re-estimated as
        # later poses join (the pooled VIF of correlated samples moves by a few per cent): plan with the
        # noise one standard error of its estimate higher, so a parameter only earlier poses determine
        # still meets its target with the final estimate (the last pose stops on the target itself)
        worse = 1.0 if self._last_free(step) else 1.0 + 1.0 / np.sqrt(2.0 * layout.n_eff)
        self.plan = plan_dwell(self.predictor, layout.f, layout.sem * worse, layout.unit * worse, layout.free, min_s,
                               max(budget_s + tau + reserved_min, tau + reserved_min))
        for row, index in enumerate(layout.indices):
            if layout.free[row]:
                self.planned_s[index] = float(self.plan.dwell_s[row])
                self.ctx.estimates_s[index] = self.planned_s[index] + self.setup.overhead_of(index)
        if not self.plan.feasible:
            self._out_of_reach(step, layout, tau, budget_s, first_look)

    def _out_of_reach(self, step, layout, tau: float, budget_s: float, first_look: bool) -> None:
        """Refuse at the run's first look (nothing invested yet), else warn once with the numbers."""
        need = plan_dwell(self.predictor, layout.f, layout.sem, layout.unit, layout.free,
                          np.where(layout.free, MIN_DWELL_S, 0.0), 1e7)
        best = self.predictor.predict(layout.f, planned_sems(layout.sem, layout.unit, self.plan.dwell_s, layout.free))
        pooled = layout.unit[-1] if len(layout.unit) > layout.current + 1 else layout.unit[layout.current]
        line = (f"target cannot be met within max_seconds {self.spec.max_seconds:g}: with the noise measured so far "
                f"(standard error of a 1 s mean {_fmt3(pooled)} counts) the best reachable is {describe(self.goal, best)},"
                f" spending all {max(budget_s + tau, 0.0):.1f} s of dwell left"
                + (f"; it needs about {need.total_s:.0f} s of dwell" if need.feasible else
                   f"; no dwell reaches it ({self.setup.stability_name} alone exceeds it)"))
        if first_look and not self.blocks and self.plan.ratio > REFUSE_FACTOR:
            raise RunError(f"{line}. Stopped at the first pose: relax the target or raise max_seconds")
        if not self.warned:
            self.warned = True
            self.ctx.warn(step, line + "; going on as far as the cap allows")

    # -- bookkeeping ----------------------------------------------------------------------------
    def commit(self, step, samples, status: str) -> None:
        """A pose is recorded: a complete one joins the data (a flagged one is left out, as by the solve)."""
        if status == "complete" and len(samples):
            self.blocks[step.index] = np.asarray(samples.accel_counts, float)
            self.mids[step.index] = _mid(np.asarray(samples.t_s, float) - self.ctx.t0_s)
            self.spans[step.index] = _span(np.asarray(samples.t_s, float))

    def step_stats(self, step) -> dict:
        """What the session records about this pose's decision (``steps[i].stats.target``)."""
        return dict(self.stats.get(step.index, {}))

    def is_last(self, step) -> bool:
        """No pose is still to come after ``step`` (the run's prediction can be concluded)."""
        return not any(s.index > step.index for s in self.statics)

    def conclude(self) -> None:
        """After the last targeted pose: the prediction from the recorded steps (their standard errors
        and bias stability as the solver will compute them), as an event and a line."""
        rows = [s for s in self.statics if s.index in self.blocks]
        if not rows:
            return
        sems, _ = step_standard_errors([self.blocks[s.index] for s in rows], QUANTUM_SIGMA)
        self.predictor.timeline = (np.array([self.mids[s.index] for s in rows]),
                                   np.array([self.spans[s.index] for s in rows]))
        p = self.predictor.predict(np.array([s.f_nominal for s in rows], float), sems)
        summary = ("target met: " if p.met else "target not met: ") + describe(self.goal, p)
        rig_time = self.ctx.session_time()
        self.ctx.event("target", met=p.met, predicted_attitude_error_deg=p.attitude_error_deg,
                       sigmas=p.sigmas, ratio=p.ratio, rig_time_s=rig_time, summary=summary)
        self.ctx.operator.info(f"{summary} (rig time {rig_time:.1f} s of max_seconds {self.spec.max_seconds:g}; "
                               "predicted from the noise and wander: the turntable's own errors are in the "
                               "calibration's expanded uncertainty U)")

    # -- helpers --------------------------------------------------------------------------------
    def _last_free(self, step) -> bool:
        return not any(s.dwell_rule == "target" and s.index not in self.blocks for s in self.statics
                       if s.index > step.index)

    def _overhead_after(self, step) -> float:
        return sum(self.setup.overhead_of(s.index) for s in self.statics if s.index > step.index)

    def _reserved_after(self, step) -> float:
        """Session time the poses after ``step`` need whatever the plan: moves, settling, their given
        dwell or the least dwell of a targeted pose."""
        later = [s for s in self.statics if s.index > step.index and s.index not in self.blocks]
        dwell = sum(MIN_DWELL_S if s.dwell_rule == "target" else nominal_dwell_s(s, self.rate) for s in later)
        return self._overhead_after(step) + dwell

    def _timeline(self, layout, step, t_s: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
        """The capture windows the solver will see for ``layout``'s rows (:class:`calib.accel.predict.Predictor`
        weighs the chip's wander between them): the recorded poses' own, this pose's from its first sample
        to its planned end, the poses to come after it at their planned (or given, or least) dwell."""
        done = layout.indices[:layout.current]
        this_s = max(tau, self.planned_s.get(step.index, tau))
        start = float(t_s[0]) if len(t_s) else 0.0
        by_index = {s.index: s for s in self.statics}
        rest = [by_index[i] for i in layout.indices[layout.current + 1:]]
        dwell = [self.planned_s.get(s.index, MIN_DWELL_S) if s.dwell_rule == "target"
                 else nominal_dwell_s(s, self.rate) for s in rest]
        mids, spans = self.setup.timeline(start + this_s, rest, dwell)
        return (np.concatenate([[self.mids[i] for i in done], [start + this_s / 2], mids]),
                np.concatenate([[self.spans[i] for i in done], [this_s], spans]))

    def _shown(self, p) -> tuple[float, float, str]:
        if p.attitude_error_deg is not None:
            return p.attitude_error_deg, self.goal.attitude_error_deg, "deg"
        name = max(p.sigmas, key=lambda n: p.sigmas[n] / self.predictor.targets[n])
        return p.sigmas[name], self.predictor.targets[name], f"{unit_of(name)} ({name})"


@dataclass
class _Layout:
    """The static steps in a decision, in the order recorded-then-this-then-to-come: poses, standard
    errors (final for the recorded), the standard error of a 1 s mean of each free step (this pose's
    own, the pooled one for the poses to come) and which are free (this pose, the targeted to come)."""

    indices: list
    f: np.ndarray
    sem: np.ndarray
    unit: np.ndarray
    free: np.ndarray
    current: int
    n_eff: float  # independent samples' worth behind the noise estimate: samples / VIF (the largest axis')

    @classmethod
    def build(cls, policy: TargetPolicy, step, accel: np.ndarray, tau: float) -> "_Layout":
        done = [s for s in policy.statics if s.index in policy.blocks]
        blocks = [policy.blocks[s.index] for s in done] + [accel]
        # the solver truncates the autocorrelation at half its shortest step: at the last pose that is known,
        # before it the shortest step may yet be a least dwell (a single long first block would otherwise
        # count slow wander the final solve does not, and over-plan the first pose)
        last = not any(s.index > step.index and s.index not in policy.blocks for s in policy.statics)
        sems, vif = standard_errors(blocks, None if last else policy.min_n // 2)
        pooled = _pooled_sd(blocks) * np.sqrt(vif / policy.rate)
        rest = [s for s in policy.statics if s.index not in policy.blocks and s.index != step.index]
        rows = done + [step] + rest
        sem = np.vstack([sems] + [pooled[None, :] / np.sqrt(max(nominal_dwell_s(s, policy.rate), MIN_DWELL_S))
                                  for s in rest])
        unit = np.tile(pooled, (len(rows), 1))
        unit[len(done)] = sems[-1] * np.sqrt(tau)  # this pose goes on with its own scatter
        free = np.array([False] * len(done) + [True] + [s.dwell_rule == "target" for s in rest])
        n_eff = sum(len(b) for b in blocks) / float(np.max(vif))
        return cls([s.index for s in rows], np.array([s.f_nominal for s in rows], float), sem, unit, free, len(done),
                   n_eff)

    def dwell_now(self, tau: float, policy: TargetPolicy) -> np.ndarray:
        """Dwell of the free steps if this pose stopped now and the others got their planned share."""
        out = np.array([policy.planned_s.get(i, MIN_DWELL_S) if free else 0.0
                        for i, free in zip(self.indices, self.free)])
        out[self.current] = tau
        return out


def standard_errors(blocks: list, max_lag: int | None) -> tuple[np.ndarray, np.ndarray]:
    """``calib.numerics.uncertainty.step_standard_errors`` (what the solver computes) with the autocorrelation
    summed to at most ``max_lag`` (None: half the shortest block, as the solver)."""
    if max_lag is None:
        return step_standard_errors(blocks, QUANTUM_SIGMA)
    vif = pooled_vif(blocks, max_lag=min(max_lag, min(len(b) for b in blocks) - 1))
    sems = np.array([np.maximum(b.std(axis=0, ddof=1), QUANTUM_SIGMA) / np.sqrt(len(b)) for b in blocks])
    return sems * np.sqrt(vif)[None, :], vif


def _mid(t_s) -> float:
    t = np.asarray(t_s, float)
    return float(0.5 * (t.min() + t.max())) if len(t) else 0.0


def _span(t_s) -> float:
    """A capture's duration (s) as the solver takes it (rig.session.adapter): n samples span n periods."""
    t = np.asarray(t_s, float)
    return float(np.ptp(t) * len(t) / (len(t) - 1)) if len(t) >= 2 else 0.0


def _pooled_sd(blocks: list) -> np.ndarray:
    """Per-axis sample standard deviation pooled over blocks (each block's own mean removed)."""
    ss = sum(((b - b.mean(axis=0)) ** 2).sum(axis=0) for b in blocks)
    dof = sum(len(b) - 1 for b in blocks)
    return np.maximum(np.sqrt(ss / max(dof, 1)), QUANTUM_SIGMA)


def _fmt3(v) -> str:
    return "/".join(f"{x:.2f}" for x in np.asarray(v, float))
