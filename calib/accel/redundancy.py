"""The six-pose redundancy check: the bias from each +/- pose pair, separately.

With the six orthogonal poses, each pair of opposite poses (+k up, -k up) gives its own estimate
of the whole bias vector, ``b = (a(+k) + a(-k)) / 2``, because the specific force cancels (if the
poses are truly opposite). Three pairs give three independent estimates; a model that fits says
they agree within their standard errors. A plain least-squares fit averages them and hides the
disagreement; here it shows, per output axis, as a spread and a chi-square.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.numerics.special import chi2_sf

from calib.accel.inputs import StepMeans
from calib.errors import ObservabilityError
from calib.frames import SENSOR_AXES



@dataclass(frozen=True)
class PairBias:
    axis_up: str  # which input axis the pair flips
    bias_counts: np.ndarray  # (3,) estimate of every output's bias
    sigma_counts: np.ndarray  # (3,)


@dataclass(frozen=True)
class Redundancy:
    pairs: list[PairBias]
    spread_counts: np.ndarray  # (3,) max - min over the pairs, per output axis
    chi2: np.ndarray  # (3,) of the pair estimates about their weighted mean, per output axis
    dof: int
    p_value: np.ndarray  # (3,)

    def format_table(self, lsb_per_g: float | None = None) -> str:
        """The pairs' biases in counts, the unit every other printout of the bias uses (``lsb_per_g`` unused: kept
        for callers that pass it)."""
        lines = ["bias from each +/- pose pair (counts):", "  pair     x                 y                 z"]
        for p in self.pairs:
            cells = "  ".join(f"{b:8.2f}+-{s:5.2f}" for b, s in zip(p.bias_counts, p.sigma_counts))
            lines.append(f"  +/-{p.axis_up}   {cells}")
        lines.append("  spread   " + "  ".join(f"{s:14.2f}" for s in self.spread_counts)
                     + "   chi2/dof " + " ".join(f"{c / max(self.dof, 1):.1f}" for c in self.chi2))
        return "\n".join(lines)


def pair_biases(steps: StepMeans, tol: float = 0.05) -> Redundancy:
    """Bias estimates from every pair of opposite single-axis poses (known f_nominal)."""
    f = np.asarray(steps.f_nominal_g, float)
    a = np.asarray(steps.mean_counts, float)
    s = np.asarray(steps.sem_counts, float)
    pairs = []
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        plus = np.flatnonzero(np.all(np.abs(f - e) < tol, axis=1))
        minus = np.flatnonzero(np.all(np.abs(f + e) < tol, axis=1))
        if len(plus) and len(minus):
            ap, am = a[plus].mean(axis=0), a[minus].mean(axis=0)
            sp = np.sqrt(np.sum(s[plus] ** 2, axis=0)) / len(plus)
            sm = np.sqrt(np.sum(s[minus] ** 2, axis=0)) / len(minus)
            pairs.append(PairBias(SENSOR_AXES[k], 0.5 * (ap + am), 0.5 * np.hypot(sp, sm)))
    if len(pairs) < 2:
        raise ObservabilityError("the redundancy check needs at least two pairs of opposite poses")
    b = np.array([p.bias_counts for p in pairs])
    sg = np.array([p.sigma_counts for p in pairs])
    w = 1.0 / sg ** 2
    mean = np.sum(w * b, axis=0) / np.sum(w, axis=0)
    chi2 = np.sum(((b - mean) / sg) ** 2, axis=0)
    dof = len(pairs) - 1
    return Redundancy(pairs, b.max(axis=0) - b.min(axis=0), chi2, dof, chi2_sf(chi2, dof))
