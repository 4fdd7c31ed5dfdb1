"""When a fit's residual says nothing: an exactly determined solve (as many estimates as measurements, the flip
method on one pose per face) has a residual of zero by construction and no chi2/dof to judge. ``rig solve``,
``rig history`` and ``rig report`` say so in the same words instead of ``residual 0.0 ug, chi2/dof 0.00``."""

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
