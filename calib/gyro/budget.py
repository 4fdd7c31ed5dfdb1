"""The gyroscope's uncertainty budget on a turntable (docs/uncertainty.md, "The gyroscope").

The rate test turns the sensor about the stages' axes, so its six nonorthogonalities ``m_ij = M_ij / M_ii`` are
the sensor's axes against the *table's* rotation axes: the sensor's mounting in its fixture and the stages' zero
offsets (a rotation of the sensor's frame by small angles ``theta``) add ``-theta_k`` or ``+theta_k`` to each
``m_ij`` (``M R^T`` with ``R = I + [theta]x``), and each bracket's non-orthogonality tilts the axis a stage turns
about, which adds its angle to the terms that stage's rate steps determine. To first order every ``m_ij`` gets one
frame angle and at most one bracket angle; the budget gives each of the six the standard uncertainty of both
(``TableClass.frame_u_rad``, the brackets' rectangular class), the same for all six (conservative where a term
sees no bracket). Biases and scale factors move only at second order (1 - cos of hundredths of a degree: below
1e-7 of the scale), and get the Type A term alone.

The rate steps are not re-placed by a characterisation by reversal (that corrects the accelerometer's static
poses), so the classes apply on a characterised rig too: the table's actual errors are fixed, and unknown to this
solve. Pure.
"""

from __future__ import annotations

import math

from calib.gyro.result import GyroCalibration
from calib.numerics.budget import DEFAULT_K, Contribution, RigErrors, budget_section, rectangular

#: the budget's entries, in the file's order
FRAME = "rig frame (mounting, stage zeros)"
AXES = "rig axes (non-orthogonality)"


def contributions(gyro: GyroCalibration, rig: RigErrors) -> list[Contribution]:
    """Type A (the solve's sigma) and the table's two Type B terms on the nonorthogonalities, rad (= the ratio's
    unit to first order)."""
    sigma = {n: float(v) for n, v in gyro.sigma.items()}
    frame_u = rig.table.frame_u_rad()
    axes_u = math.radians(rectangular(rig.table.non_orthogonality_deg))
    off = [n for n in sigma if n.startswith("m_")]
    return [Contribution("noise and wander", "A", "the solve's sigma (rate steps' scatter, bias wander)", sigma),
            Contribution(FRAME, "B", f"the sensor's mounting and the stages' zeros at their classes: {frame_u:.3g} rad "
                         "per frame angle, in each nonorthogonality", {n: frame_u for n in off}, "rectangular"),
            Contribution(AXES, "B", f"the brackets' non-orthogonality at its class: {axes_u:.3g} rad, in each "
                         "nonorthogonality", {n: axes_u for n in off}, "rectangular")]


def uncertainty_section(gyro: GyroCalibration, rig: RigErrors, k: float = DEFAULT_K) -> dict:
    """``gyroscope.uncertainty``: ``U = k u_c`` in ``sigma``'s keys (``b_x`` counts, ``k_x`` counts/(deg/s),
    ``m_xy`` -), ``k``, where the rig's figures come from, the combined standard uncertainty and the ``budget``."""
    return budget_section(contributions(gyro, rig), gyro.sigma, k,
                          f"{rig.source} (the table's classes: the rate steps are not re-placed)")
