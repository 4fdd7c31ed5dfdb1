"""Trapezoidal motion profiles as piecewise-constant-acceleration phases (pure, vectorised).

Positions in microsteps (float), speeds in microsteps/s, accelerations in
microsteps/s^2, times in clock seconds. A profile is a list of phases
``(t_start, p_start, v_start, a)``; the last phase runs forever (rest, or
constant speed for continuous rotation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Phase:
    """From clock time ``t`` (s): position ``p`` (usteps), speed ``v`` (usteps/s), acceleration ``a`` (usteps/s^2)."""

    t: float
    p: float
    v: float
    a: float


class Profile:
    """A motion as phases in time order; ``position(t)`` and ``velocity(t)`` take scalars or arrays."""

    def __init__(self, phases: list[Phase]) -> None:
        self.phases = phases
        # (t, p, v, a) per phase, built once: a simulated read evaluates the profile of every axis
        self._table = np.array([(ph.t, ph.p, ph.v, ph.a) for ph in phases], float).reshape(-1, 4)
        self._t = self._table[:, 0]

    @classmethod
    def rest(cls, t: float, p: float) -> "Profile":
        return cls([Phase(t, p, 0.0, 0.0)])

    def _idx(self, t):
        i = np.searchsorted(self._t, t, side="right") - 1
        return np.maximum(i, 0)  # searchsorted - 1 never exceeds the last phase

    def position(self, t):
        """Position at clock time(s) ``t``, usteps."""
        t = np.asarray(t, float)
        i = self._idx(t)
        ph = self._table[i]
        dt = np.maximum(t - ph[..., 0], 0.0)
        return ph[..., 1] + ph[..., 2] * dt + 0.5 * ph[..., 3] * dt * dt

    def velocity(self, t):
        """Speed at clock time(s) ``t``, usteps/s."""
        t = np.asarray(t, float)
        i = self._idx(t)
        ph = self._table[i]
        dt = np.maximum(t - ph[..., 0], 0.0)
        return ph[..., 2] + ph[..., 3] * dt

    def position_velocity(self, t):
        """:meth:`position` and :meth:`velocity` at clock time(s) ``t`` from one look-up of the phases (the same
        numbers as the two calls)."""
        t = np.asarray(t, float)
        ph = self._table[self._idx(t)]
        dt = np.maximum(t - ph[..., 0], 0.0)
        return ph[..., 1] + ph[..., 2] * dt + 0.5 * ph[..., 3] * dt * dt, ph[..., 2] + ph[..., 3] * dt

    @property
    def end_time(self) -> float:
        """Time motion ends (inf for continuous rotation)."""
        last = self.phases[-1]
        return last.t if last.v == 0 and last.a == 0 else math.inf

    def truncate_at(self, limit: float) -> tuple["Profile", float | None]:
        """Stop dead where the path first crosses ``limit``; returns (profile, crossing time or None)."""
        for k, ph in enumerate(self.phases):
            t_end = self.phases[k + 1].t if k + 1 < len(self.phases) else math.inf
            # solve p + v dt + a/2 dt^2 = limit for the first dt in [0, t_end - t)
            roots = []
            if ph.a == 0:
                if ph.v != 0:
                    roots = [(limit - ph.p) / ph.v]
            else:
                disc = ph.v**2 - 2 * ph.a * (ph.p - limit)
                if disc >= 0:
                    sq = math.sqrt(disc)
                    roots = [(-ph.v - sq) / ph.a, (-ph.v + sq) / ph.a]
            roots = sorted(r for r in roots if 1e-12 < r < t_end - ph.t + 1e-12)
            if roots:
                tc = ph.t + roots[0]
                return Profile(self.phases[:k + 1] + [Phase(tc, limit, 0.0, 0.0)]), tc
        return self, None


def plan_move(t0: float, p0: float, v0: float, target: float, vmax: float, accel: float, decel: float) -> Profile:
    """Profile from state (p0, v0) at t0 to rest at ``target``."""
    phases: list[Phase] = []
    t, p, v = t0, p0, v0
    for _ in range(3):
        d = target - p
        s = 1.0 if d > 0 else -1.0 if d < 0 else (1.0 if v >= 0 else -1.0)
        stop_dist = v * v / (2 * decel)
        if v * s < 0 or (v * s > 0 and stop_dist > abs(d) + 1e-9) or abs(v) > vmax + 1e-9:
            # moving the wrong way, overshooting, or too fast: brake to rest first
            tb = abs(v) / decel
            a = -math.copysign(decel, v)
            phases.append(Phase(t, p, v, a))
            p = p + v * tb + 0.5 * a * tb * tb
            t, v = t + tb, 0.0
            continue
        d = abs(d)
        if d < 1e-9 and abs(v) < 1e-9:
            break
        u = abs(v)
        vp = min(vmax, math.sqrt((2 * accel * decel * d + decel * u * u) / (accel + decel)))
        vp = max(vp, u)
        t_acc = (vp - u) / accel
        d_acc = (vp * vp - u * u) / (2 * accel)
        d_dec = vp * vp / (2 * decel)
        t_cruise = max(d - d_acc - d_dec, 0.0) / vp if vp > 0 else 0.0
        t_dec = vp / decel
        if t_acc > 0:
            phases.append(Phase(t, p, s * u, s * accel))
        p1 = p + s * d_acc
        if t_cruise > 0:
            phases.append(Phase(t + t_acc, p1, s * vp, 0.0))
        phases.append(Phase(t + t_acc + t_cruise, p1 + s * vp * t_cruise, s * vp, -s * decel))
        t = t + t_acc + t_cruise + t_dec
        p = target
        break
    phases.append(Phase(t, target, 0.0, 0.0))
    return Profile(phases)


def plan_continuous(t0: float, p0: float, v0: float, direction: float, vmax: float, accel: float,
                    decel: float) -> Profile:
    """Accelerate (or brake) to ``direction * vmax`` and keep turning."""
    target_v = direction * vmax
    phases = []
    t, p, v = t0, p0, v0
    if v != target_v:
        a = accel if abs(target_v) > abs(v) and v * target_v >= 0 else decel
        a = math.copysign(a, target_v - v)
        dt = abs(target_v - v) / abs(a)
        phases.append(Phase(t, p, v, a))
        p = p + v * dt + 0.5 * a * dt * dt
        t += dt
    phases.append(Phase(t, p, target_v, 0.0))
    return Profile(phases)


def plan_stop(t0: float, p0: float, v0: float, decel: float) -> Profile:
    """Soft stop: brake at ``decel`` to rest."""
    if v0 == 0:
        return Profile.rest(t0, p0)
    tb = abs(v0) / decel
    a = -math.copysign(decel, v0)
    return Profile([Phase(t0, p0, v0, a), Phase(t0 + tb, p0 + v0 * tb + 0.5 * a * tb * tb, 0.0, 0.0)])
