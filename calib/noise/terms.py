"""The IEEE Std 952 / 1431 noise terms of one sensor axis and the Allan variance they add up to.

The Allan variance of a sum of independent noises is the sum of their Allan variances:

=======  ==========================  ===================  =======================  ======
term     figure (unit u of the axis)  Allan variance        slope of log ADEV       alpha
=======  ==========================  ===================  =======================  ======
N        white noise, u/sqrt(Hz)      N^2 / tau            -1/2                    0
B        bias instability, u          B^2                  0 (the flicker floor)   -1
K        random walk, u/sqrt(s)       K^2 tau / 3          +1/2                    -2
R        rate ramp, u/s               R^2 tau^2 / 2        +1                      -2
=======  ==========================  ===================  =======================  ======

B is the floor of the Allan deviation (the project's convention everywhere, ``ChipSpec`` and
:class:`calib.numerics.stability.BiasStability`: ``0.664`` times the flicker coefficient). The model
is linear in the squared figures, so the fit (:mod:`calib.noise.fit`) is a linear least squares.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calib.errors import CalibError

#: term -> (its figure's name, the Allan variance per squared figure as a function of tau, FM alpha)
TERMS: dict[str, tuple[str, object, int]] = {
    "N": ("white noise", lambda tau: 1.0 / tau, 0),
    "B": ("bias instability", lambda tau: np.ones_like(tau), -1),
    "K": ("random walk", lambda tau: tau / 3.0, -2),
    "R": ("rate ramp", lambda tau: tau**2 / 2.0, -2),
}
#: sensor -> the unit its figures are in
UNITS = {"accel": "g", "gyro": "deg/s", "mag": "uT"}
#: the terms a characterisation fits unless told otherwise (R is fitted only where seen)
DEFAULT_TERMS = ("N", "B", "K")
#: the shortest record that can state a term: this many times the longest averaging time it needs
MIN_CLUSTERS = 8
#: averaging time (s) a term needs without a prior: N shows at 1 s; B and K need the family's crossings
FALLBACK_TAU_S = {"N": 1.0, "B": 100.0, "K": 1000.0, "R": 1000.0}


def parse_terms(text: str) -> tuple[str, ...]:
    """``"N,B,K"`` -> ("N", "B", "K"); CalibError (one line) for an unknown term."""
    terms = tuple(t.strip().upper() for t in str(text).split(",") if t.strip())
    bad = [t for t in terms if t not in TERMS]
    if bad or not terms:
        raise CalibError(f"terms: expected a comma-separated list of {', '.join(TERMS)}, got {text!r}")
    return tuple(t for t in TERMS if t in terms)


@dataclass(frozen=True)
class NoiseFigures:
    """Noise figures of one axis in its unit ``u``: N (u/sqrt(Hz)), B (u), K (u/sqrt(s)), R (u/s); 0 if absent."""

    N: float = 0.0
    B: float = 0.0
    K: float = 0.0
    R: float = 0.0

    def avar(self, tau_s) -> np.ndarray:
        """The Allan variance these figures give at ``tau_s`` (s), u^2."""
        tau = np.asarray(tau_s, float)
        return sum(getattr(self, t) ** 2 * f(tau) for t, (_, f, _) in TERMS.items())

    def adev(self, tau_s) -> np.ndarray:
        return np.sqrt(self.avar(tau_s))

    def tau_needed_s(self, term: str) -> float:
        """The longest averaging time (s) at which ``term`` must be seen to be fitted: N at 1 s; B at twice
        the crossing of the white noise and the floor, ``(N/B)^2`` (at least 10 s); K at three times the
        crossing of the floor and the walk, ``3 (B/K)^2``; R at twice the crossing of the walk and the ramp."""
        if term == "N":
            return 1.0
        if term == "B":
            return max(10.0, 2.0 * (self.N / self.B) ** 2) if self.B > 0 else FALLBACK_TAU_S["B"]
        if term == "K":
            return max(30.0, 3.0 * 3.0 * (self.B / self.K) ** 2) if self.K > 0 and self.B > 0 else FALLBACK_TAU_S["K"]
        return max(30.0, 2.0 * (2.0 * self.K**2 / (3.0 * self.R**2))) if self.R > 0 else FALLBACK_TAU_S["R"]


def required_duration_s(terms, expected: NoiseFigures | None) -> float:
    """How long (s) a record must be to fit ``terms``: :data:`MIN_CLUSTERS` times the longest averaging time
    they need (:meth:`NoiseFigures.tau_needed_s`, from the ``expected`` figures, e.g. the chip family's;
    :data:`FALLBACK_TAU_S` without them)."""
    need = [expected.tau_needed_s(t) if expected is not None else FALLBACK_TAU_S[t] for t in terms]
    return MIN_CLUSTERS * max(need)


def check_duration(duration_s: float, terms, expected: NoiseFigures | None, what: str = "the recording") -> None:
    """CalibError (one line: how long it must be) when ``duration_s`` is too short for ``terms``."""
    need = required_duration_s(terms, expected)
    if duration_s < need:
        raise CalibError(f"{what} lasts {duration_s:.0f} s; fitting {', '.join(terms)} needs at least {need:.0f} s "
                         f"({_hours(need)}: {MIN_CLUSTERS} x the {need / MIN_CLUSTERS:.0f} s averaging time the "
                         f"slowest term shows at)")


def _hours(seconds: float) -> str:
    return f"{seconds / 3600:.1f} h" if seconds >= 3600 else f"{math.ceil(seconds / 60)} min"


#: the Allan floor of the flicker a chip registry's (and :class:`calib.numerics.stability.BiasStability`'s)
#: bias instability B describes, per unit of B: they spread ``(B / 0.664)^2 / (2 pi)`` over ln(tau) as a
#: one-sided spectrum (:mod:`calib.numerics.wander`), whose Allan floor is ``B / sqrt(2)`` (measured on
#: the simulator's flicker: 0.70-0.71 B between 1 s and 1300 s); IEEE Std 952's B is the floor itself
REGISTRY_B_FLOOR = 1.0 / math.sqrt(2.0)
