"""Rests in a hand-tumbled recording (the generic CSV without labels): quasi-static intervals found with an
adaptive threshold and a minimum duration (the Tedaldi et al. 2014 detector), checked for motion inside.

1. The noise floor: the 10th percentile of the summed variances of consecutive 1 s blocks over the whole
   recording (:class:`calib.numerics.static_detect.VarianceFloor`): a hand-tumbled recording has no
   initial rest to take the noise from, its rests are where the variance is lowest.
2. A sample is quasi-static when the summed variance of a 1 s window around it is below ``factor`` times
   that floor (:class:`calib.numerics.static_detect.StaticDetector` with the floor as its reference);
   runs of at least ``min_s`` seconds (after 0.25 s trimmed from each end) are intervals, shorter ones
   are counted as rejected.
3. The motion left inside each interval is measured (:func:`calib.numerics.static_detect.interval_motion`:
   the scatter of its 0.25 s block means over what its own noise gives them): an interval whose block
   means scatter more than :data:`MAX_MOTION` times the noise is rejected (the hand still moved); below it
   the remaining slow motion is in the step's standard error, which the session reader takes from the
   step's own scatter with the correlation of its samples pooled over the steps (the variance inflation
   factor), so it is propagated into the sigmas.

The settings and their documented range (``rig import --static-factor F --static-min-s S``): ``factor``
4 to 10 (default 6), ``min_s`` 0.5 to 1 s (default 1). Within it the solved parameters move by less than
1 sigma on the synthetic hand-tumbled recordings of ``benchmarks/bench_hand_tumble.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from calib.numerics.static_detect import StaticDetector, VarianceFloor, interval_motion
from rig.errors import RigInputError
from rig.importers.common import ImportedStep, Spool

DEFAULT_FACTOR = 6.0
FACTOR_RANGE = (4.0, 10.0)
DEFAULT_MIN_S = 1.0
MIN_S_RANGE = (0.5, 1.0)
WINDOW_S = 1.0
TRIM_S = 0.25
MOTION_BLOCK_S = 0.25
#: an interval whose block means scatter more than this many times its noise moved inside: rejected
MAX_MOTION = 3.0


@dataclass
class Detection:
    """What the detector did: its settings, the floor, the intervals kept and those rejected and why."""

    factor: float
    min_s: float
    floor: float
    found: int = 0
    short: int = 0
    moving: list[tuple[float, float]] = field(default_factory=list)  # (start time s, motion ratio)

    def note(self, key: str) -> str:
        moving = f"{len(self.moving)} moving inside"
        if self.moving:
            moving += (" (block means scatter " + ", ".join(f"{r:.1f}x at {t:.1f} s" for t, r in self.moving[:5])
                       + (" ..." if len(self.moving) > 5 else "") + f" the noise; limit {MAX_MOTION:g}x)")
        return (f"quasi-static detection on the {key} (adaptive threshold {self.factor:g} x the noise floor "
                f"{self.floor:.4g} counts^2, windows of {WINDOW_S:g} s, at least {self.min_s:g} s): {self.found} "
                f"intervals kept; rejected: {self.short} shorter than {self.min_s:g} s, {moving}")


def check_settings(factor: float, min_s: float) -> None:
    """The detector's settings within their documented range."""
    for option, value, (lo, hi) in (("--static-factor", factor, FACTOR_RANGE), ("--static-min-s", min_s, MIN_S_RANGE)):
        if not lo <= value <= hi:
            raise RigInputError(None, None, option, f"expected {lo:g} to {hi:g} (the range in which the results "
                                f"do not depend on it, docs/import.md), got {value:g}")


def detect_rests(spool: Spool, dt: float, key: str, factor: float = DEFAULT_FACTOR,
                 min_s: float = DEFAULT_MIN_S) -> tuple[list[ImportedStep], Detection]:
    """The rests of spool column ``key`` (n, 3) as static steps (each its own unknown pose), and the report."""
    window = max(3, int(round(WINDOW_S / dt)))
    floor = VarianceFloor(window)
    for x in spool.chunks(key):
        floor.feed(np.rint(x))
    n = spool.n_rows
    t0 = float(spool.read("t", 0, 1)[0])
    detector = StaticDetector(dt, t0, window_s=WINDOW_S, threshold_factor=factor, min_s=min_s, trim_s=TRIM_S,
                              reference=max(floor.value(), 1e-12))
    for t, x in zip(spool.chunks("t"), spool.chunks(key)):
        detector.feed(t, np.rint(x).astype(np.int64))
    report = Detection(factor, min_s, floor.value())
    block = max(2, int(round(MOTION_BLOCK_S / dt)))
    steps = []
    for a, b in detector.finish() if n > 1 else []:
        motion = interval_motion(np.rint(spool.read(key, a, b)), block)
        if motion > MAX_MOTION:
            report.moving.append((float(spool.read("t", a, a + 1)[0]) - t0, motion))
            continue
        steps.append(ImportedStep(f"static {len(steps) + 1}", "static", [(a, b)], pose_group=1000 + len(steps)))
    report.found, report.short = len(steps), detector.rejected_short
    return steps, report
