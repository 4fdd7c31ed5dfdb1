"""The simulated sensor turned in its fixture during a run (a prompt step's ``mount:``, docs/procedures.md).

The chip reads the world through :class:`MountedPhysics`: every vector of the world (the fixture frame: specific
force g, body rate deg/s, field uT) taken to the sensor's frame by the turn in force at each sample's time. The
simulated operator who confirms a ``mount:`` prompt turns the sensor (:meth:`MountedPhysics.turn_at`, through
``Rig.remount``) at that instant of the rig's clock; the chip samples lazily, so a sample is always seen through
the turn of its own time. The table's own errors (``sim.geometry``: the fixture's misalignment, the
non-orthogonalities) stay with the table, the sensor's errors turn with it: what characterisation by reversal
separates (``calib.accel.reversal``).
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from drivers.sensors.sim.physics import PhysicsBatch, SeenThrough


@dataclass
class MountedPhysics(SeenThrough):
    """``physics`` (the fixture frame) seen by a sensor turned in its fixture by the turn in force at each time.

    Parameters
    ----------
    physics : PhysicsSource
        The world model (fixture frame).
    """

    physics: object
    times_s: list = field(default_factory=list)  # clock times of the turns, ascending
    turns: list = field(default_factory=list)  # (3, 3) each: sensor frame -> fixture frame

    def turn_at(self, t_s: float, turn) -> None:
        """From clock time ``t_s`` on, the sensor sits turned by ``turn`` (3x3, sensor -> fixture frame, relative
        to the reference mounting) in its fixture."""
        t = float(t_s)
        keep = bisect.bisect_left(self.times_s, t)
        del self.times_s[keep:], self.turns[keep:]
        self.times_s.append(t)
        self.turns.append(np.asarray(turn, float))

    def turn_now(self, t_s: float) -> np.ndarray:
        """The turn in force at clock time ``t_s`` (the identity before any)."""
        i = bisect.bisect_right(self.times_s, float(t_s))
        return self.turns[i - 1] if i else np.eye(3)

    def __call__(self, t_s: np.ndarray) -> PhysicsBatch:
        p = self.physics(t_s)
        if not self.turns:
            return p
        t = np.atleast_1d(np.asarray(t_s, float))
        which = np.searchsorted(np.asarray(self.times_s), t, side="right")  # 0: before the first turn
        out = [np.array(v, float, copy=True) for v in (p.specific_force_g, p.angular_rate_dps, p.magnetic_field_ut)]
        for k in np.unique(which):
            if k == 0:
                continue
            rows, q = which == k, self.turns[k - 1]
            for v in out:
                v[rows] = v[rows] @ q  # Q^T v as rows
        return PhysicsBatch(specific_force_g=out[0], angular_rate_dps=out[1], magnetic_field_ut=out[2],
                            temp_c=p.temp_c)
