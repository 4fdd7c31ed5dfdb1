"""Failure bins: where a production line sorts each unit of a batch, and what put it there (docs/fixture.md).

A unit's bin follows from its outcome (``PASS``, ``FAIL``, ``NO LIMITS``, ``FAULT``, ``ABSENT``), the names of
the acceptance limits it failed (:class:`calib.acceptance.LimitCheck` ``name``: ``range accel.bias_y``,
``sigma accel.bias_x``, ``max_chi2_per_dof``, ...) and, for a FAIL without a failed limit, its reason. Three
tables decide it, read in order; :func:`failure_bin` only looks them up:

- :data:`OUTCOME_BINS`: the outcomes that say it all (a good unit, a failed chip, an empty slot);
- :data:`LIMIT_BINS`: a failed limit's name (shell-style patterns) -> the parameter family that failed; a unit
  that failed several limits goes to the bin of the first row that matches one of them (bias before scale
  before misalignment ...: the table's order is the line's priority);
- :data:`REASON_BINS`: a FAIL without acceptance limits (its steps flagged, its fit poor, no solve) by its reason.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable

#: a unit to ship (PASS: its limits met; NO LIMITS: a good fit, no limits to judge it by)
GOOD = "good"
#: what an outcome alone decides
OUTCOME_BINS: dict[str, str] = {"PASS": GOOD, "NO LIMITS": GOOD, "FAULT": "sensor fault", "ABSENT": "absent"}
#: a failed acceptance limit's name -> its bin; the first row matching a failed limit wins
LIMIT_BINS: dict[str, str] = {
    "range accel.bias_*": "bias", "range gyro.bias_*": "bias", "range mag.hard_iron_*": "bias",
    "range accel.scale_*": "scale", "range gyro.scale_*": "scale",
    "range accel.alpha_*": "misalignment", "range accel.m_*": "misalignment",
    "range accel.tempco*": "tempco", "range accel.t0_c": "tempco",
    "max_drift_sigma": "drift",
    "sigma *": "sigma",
    "max_chi2_per_dof": "fit", "max_residual_g": "fit",
    "max_attitude_error_deg": "attitude",
}
#: a FAIL's reason (when no acceptance limit failed) -> its bin (rig.workflow.batch's reasons)
REASON_BINS: dict[str, str] = {"steps flagged:*": "flagged steps", "fit residual *": "fit",
                               "cannot solve:*": "no solve", "acceptance:*": "limits"}
#: a FAIL none of the tables places
OTHER = "other"
#: every bin, in the order counts and tables list them
BINS: tuple[str, ...] = tuple(dict.fromkeys(
    [GOOD, *LIMIT_BINS.values(), *REASON_BINS.values(), OTHER, *OUTCOME_BINS.values()]))


def failure_bin(outcome: str, reason: str | None = None, failed_limits: Iterable[str] = ()) -> str:
    """The bin of a unit of a batch.

    Parameters
    ----------
    outcome : PASS, FAIL, NO LIMITS, FAULT or ABSENT.
    reason : the one-line reason of a FAIL (``steps flagged: 2, 4``, ``fit residual ...``), or None.
    failed_limits : the names of the acceptance limits it failed (``range accel.bias_y``, ...).

    Returns
    -------
    One of :data:`BINS`.
    """
    if outcome in OUTCOME_BINS:
        return OUTCOME_BINS[outcome]
    names = list(failed_limits)
    found = next((b for pattern, b in LIMIT_BINS.items() if any(fnmatch.fnmatchcase(n, pattern) for n in names)),
                 None)
    if found is None:
        found = next((b for pattern, b in REASON_BINS.items() if fnmatch.fnmatchcase(reason or "", pattern)), OTHER)
    return found


def bin_counts(bins: Iterable[str]) -> dict[str, int]:
    """How many units are in each bin: every bin of :data:`BINS` (zero included), in that order."""
    found = list(bins)
    return {b: found.count(b) for b in BINS}


__all__ = ["BINS", "GOOD", "LIMIT_BINS", "OTHER", "OUTCOME_BINS", "REASON_BINS", "bin_counts", "failure_bin"]
