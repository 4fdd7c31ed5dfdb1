"""How a fit's residual is judged, in the same words by ``rig solve``, ``rig run``, ``rig history`` and ``rig report``:
an exactly determined solve (as many estimates as measurements, the flip method on one pose per face) has a residual
of zero by construction and no chi2/dof to judge (said so instead of ``residual 0.0 ug, chi2/dof 0.00``); a turntable
session's misfit is judged against the noise and against the rig's own errors too (:func:`misfit_words`)."""

from __future__ import annotations

import math

#: a residual below this is rounding: the fit was exactly determined, g (1 ng)
EXACT_RESIDUAL_G = 1e-9
#: what ``rig history`` and ``rig report`` say of such a fit in place of its chi2/dof
EXACTLY_DETERMINED = "exactly determined (no residual to judge the fit)"


def exactly_determined(residual_rms_g, degrees_of_freedom: int | None = None) -> bool:
    """Whether a fit is exactly determined: no degrees of freedom left (when known) or a residual RMS (g) at
    rounding level (:data:`EXACT_RESIDUAL_G`); False when neither is known."""
    if degrees_of_freedom is not None and degrees_of_freedom <= 0:
        return True
    try:
        return math.isfinite(float(residual_rms_g)) and abs(float(residual_rms_g)) < EXACT_RESIDUAL_G
    except (TypeError, ValueError):
        return False


def misfit_with_rig(accel) -> dict | None:
    """``accelerometer.uncertainty.misfit_with_rig`` (the residuals judged against the noise and the rig's own
    errors, :mod:`calib.accel.rig_misfit`), or None where the calibration has no budget or no poses to judge."""
    found = (getattr(accel, "uncertainty", None) or {}).get("misfit_with_rig")
    return found if isinstance(found, dict) and "significant" in found else None


def misfit_words(accel) -> str:
    """What follows a fit's chi2/dof in a report: nothing when the noise explains it; that the turntable's own
    errors explain it (with them, chi2/dof and p); or that the model misses something."""
    if not accel.misfit()[0]:
        return ""
    with_rig = misfit_with_rig(accel)
    if with_rig is not None and not with_rig["significant"]:
        return (f" (beyond the noise alone, within the turntable's own errors: chi2/dof {with_rig['chi2_per_dof']:.2f} "
                f"with them, p = {with_rig['p']:.2g})")
    return " (beyond what the noise explains: the model misses something; see rig discover)"
