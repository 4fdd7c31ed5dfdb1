"""An uncertainty budget (GUM, JCGM 100:2008): contributions, their combination, the expanded uncertainty.

Each :class:`Contribution` is one source's *standard* uncertainty on every quantity (a flat name -> value
map: ``bias_counts[0]``, ``misalignment.alpha_yz``, ...), Type A (evaluated from the session's own scatter)
or Type B (from other knowledge: the rig's classes or characterisation, the gravity statement, the
thermometer). The sources are taken as uncorrelated, so the combined standard uncertainty is the root sum
of squares (GUM 5.1.2 with unit sensitivities: every contribution is already in the quantity's unit), and
the expanded uncertainty is ``U = k u_c`` (GUM 6.2.1; k = 2 by default, about 95 % coverage for a
near-normal distribution). The rig's error classes (:class:`TableClass`) are stated once, here, and turned
into standard uncertainties of the pose (docs/uncertainty.md).

Pure numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from calib.numerics.gravity import Gravity, standard_gravity

#: coverage factor of the expanded uncertainty unless asked otherwise
DEFAULT_K = 2.0
TYPES = ("A", "B")
#: a contribution's distribution -> unit-variance draws of it (rng, n) (JCGM 101 6.4.2, 6.4.7)
DISTRIBUTIONS = {"normal": lambda rng, n: rng.standard_normal(n),
                 "rectangular": lambda rng, n: rng.uniform(-math.sqrt(3.0), math.sqrt(3.0), n)}


@dataclass(frozen=True)
class Contribution:
    """One source of uncertainty: ``name``, ``type`` (A or B), ``source`` (where its figure comes from) and
    ``u`` (quantity name -> standard uncertainty in the quantity's unit)."""

    name: str
    type: str
    source: str
    u: dict[str, float]
    distribution: str = "normal"  # DISTRIBUTIONS: the shape of the error this contribution stands for

    def __post_init__(self) -> None:
        if self.type not in TYPES:
            raise ValueError(f"contribution type must be A or B, got {self.type!r}")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {', '.join(DISTRIBUTIONS)}, got {self.distribution!r}")


def combined(contributions: list[Contribution]) -> dict[str, float]:
    """The combined standard uncertainty of every quantity: the root sum of squares of the contributions
    (a quantity a contribution does not name gets nothing from it; NaN where no contribution is finite)."""
    names = list(dict.fromkeys(n for c in contributions for n in c.u))
    out = {}
    for n in names:
        vals = np.array([c.u.get(n, 0.0) for c in contributions], float)
        finite = vals[np.isfinite(vals)]
        out[n] = float(math.sqrt(float(np.sum(finite ** 2)))) if len(finite) else float("nan")
    return out


def expanded(contributions: list[Contribution], k: float = DEFAULT_K) -> dict[str, float]:
    """``U = k u_c`` of every quantity."""
    if not k > 0:
        raise ValueError(f"coverage factor k must be > 0, got {k!r}")
    return {n: k * u for n, u in combined(contributions).items()}


def budget_section(parts: list[Contribution], keys, k: float, rig: str) -> dict:
    """A sensor's ``uncertainty`` section in flat keys ``keys`` (its ``sigma``'s names): ``k``, where the rig's
    figures come from (``rig``), ``U = k u_c`` per key, ``combined_standard`` and the ``budget``: each contribution's
    standard uncertainty per key (0 where it names none)."""
    return {"k": float(k), "rig": rig, **expanded(parts, k), "combined_standard": combined(parts),
            "budget": [{"name": c.name, "type": c.type, "source": c.source, "distribution": c.distribution,
                        **{n: c.u.get(n, 0.0) for n in keys}} for c in parts]}


def coverage_interval(contributions: list[Contribution], p: float = 0.95, n: int = 20000,
                      seed: int = 0) -> dict[str, float]:
    """Half-width of the shortest symmetric interval holding probability ``p`` of every quantity's error, by
    Monte Carlo over the contributions' distributions (JCGM 101: the sum of ``u_c X_c`` with X_c of unit
    variance and the contribution's shape). Where a rectangular contribution dominates, this is below
    ``2 u_c`` (one rectangular alone: 1.65 u), where normal ones do, about ``1.96 u_c``."""
    rng = np.random.default_rng(seed)
    draws = np.stack([DISTRIBUTIONS[c.distribution](rng, n) for c in contributions])  # (C, n)
    out = {}
    for name in combined(contributions):
        u = np.nan_to_num(np.array([c.u.get(name, 0.0) for c in contributions], float))
        out[name] = float(np.quantile(np.abs(u @ draws), p))
    return out


def rectangular(half_width: float) -> float:
    """Standard uncertainty of a rectangular distribution of half-width ``half_width`` (GUM 4.3.7)."""
    return float(half_width) / math.sqrt(3.0)


@dataclass(frozen=True)
class TableClass:
    """The datasheet-class errors of a turntable of three worm-gear stages (deg; half-widths of rectangular
    distributions, except lost motion and wobble: their largest values). The 8MR191 catalogue states none
    of them: docs/simulated-rig.md ("The turntable's own errors") gives each value and its source; the
    simulator draws its hidden tables from these classes (``rig.simulation.geometry``)."""

    zero_offset_deg: float = 0.01
    periodic_deg: float = 0.005
    period_deg: float = 2.0
    accumulated_deg: float = 0.02
    lost_motion_deg: float = 0.02
    wobble_deg: float = 0.003
    non_orthogonality_deg: float = 0.02
    mounting_deg: float = 0.1

    def pose_u_rad(self) -> float:
        """Standard uncertainty (rad, per axis) of one pose's direction from the errors that differ from pose
        to pose: periodic and accumulated errors (a sinusoid of random phase and rectangular amplitude a:
        a / sqrt(6)), wobble (its largest w, uniform in [0, w], a tilt of random direction: w / sqrt(6)) and
        the non-orthogonalities (rectangular, they enter the poses that turn about the tilted axes)."""
        per_pose = [self.periodic_deg / math.sqrt(6), self.accumulated_deg / math.sqrt(6),
                    self.wobble_deg / math.sqrt(6), rectangular(self.non_orthogonality_deg)]
        return math.radians(math.sqrt(sum(x * x for x in per_pose)))

    def frame_u_rad(self) -> float:
        """Standard uncertainty (rad, per axis) of the rotation common to every pose: the sensor's mounting in
        its fixture and the stages' zero offsets (rectangular)."""
        return math.radians(math.hypot(rectangular(self.mounting_deg), rectangular(self.zero_offset_deg)))

    def lost_motion_u_rad(self, one_direction: bool = False) -> float:
        """Standard uncertainty (rad) of a pose from lost motion: +-L/2 with L uniform in [0, L_max] when poses
        are reached from either side (sqrt(E[L^2] / 4) = L_max / sqrt(12)); none when every pose is approached
        from the same side (the constant offset is a zero offset)."""
        return 0.0 if one_direction else math.radians(self.lost_motion_deg / math.sqrt(12))


#: the thermometer's step-to-step non-repeatability, C (class value: an on-die sensor read at 1/340 C per LSB
#: and averaged over a step; its absolute offset cancels, the same thermometer is read in use)
THERMOMETER_U_C = 0.1


@dataclass(frozen=True)
class RigErrors:
    """The rig's Type B inputs to a budget: its turntable's error classes (``table``), whether every pose is
    approached from one side (``one_direction``), the stated gravity, the thermometer's non-repeatability (C),
    characterised parameters' standard uncertainties replacing their classes (``known``: parameter name ->
    deg, e.g. ``non_orthogonality.a1_a2``; ``calib.accel.rig_propagation``) and where the figures come from."""

    table: TableClass
    gravity: Gravity
    one_direction: bool = False
    #: some stages (not all) approach every pose from one side: a session's recorded arrival directions do not say
    #: how those arrived (the overshoot turns them back), so lost motion is then of unknown sign at every pose
    mixed_approach: bool = False
    thermometer_u_c: float = THERMOMETER_U_C
    known: dict = field(default_factory=dict)
    source: str = "turntable classes (docs/simulated-rig.md), no characterisation"

    @classmethod
    def from_classes(cls, table: TableClass | None = None, gravity: Gravity | None = None,
                     one_direction: bool = False) -> "RigErrors":
        """The rig's errors from its classes alone (no characterisation); ``one_direction``: every pose is
        approached from the same side (the lost motion is then a constant offset of each stage)."""
        return cls(table=table or TableClass(), gravity=gravity or standard_gravity(), one_direction=one_direction)
