"""The unit a person reads an effect's estimate in (issue 33 item 4: one unit per quantity).

``rig discover`` fits its effects in the library's units (``calib.discovery.effects``; its ``--json`` keeps
them); ``rig run``, ``rig solve``, ``rig history`` and ``rig report`` state the bias temperature coefficients in
counts/C^s, the calibration file's unit (``accelerometer.temperature.coefficients``), and every angle in mrad.
The bias tempcos of a discover report are shown in counts/C^s too, converted with the sensor's nominal
sensitivity (counts per g), the same factor the discovery's own thermal model uses when it writes the
calibration file; its angles (``full_misalignment`` in rad, ``table_tilt`` and ``pose_error`` in deg) in mrad.
"""

from __future__ import annotations

import math

#: library unit -> unit shown to a person, for the estimates converted with the nominal sensitivity (counts/g)
COUNTS_UNITS: dict[str, str] = {"g/C": "counts/C", "g/C^2": "counts/C^2", "g/C^3": "counts/C^3"}
#: library unit of an angle -> (unit shown, factor): every angle in mrad, as the calibration's misalignment
ANGLE_UNITS: dict[str, tuple[str, float]] = {"rad": ("mrad", 1e3), "deg": ("mrad", math.pi / 180.0 * 1e3)}


def shown_effect_unit(unit: str | None, lsb_per_g: float | None) -> tuple[str, float]:
    """``(unit shown, factor from the library's unit to it)`` of an effect estimated in ``unit``; the bias
    tempcos (g/C^s) in counts/C^s when the sensitivity ``lsb_per_g`` (counts per g) is known, angles (rad,
    deg) in mrad, others unchanged."""
    if unit in ANGLE_UNITS:
        return ANGLE_UNITS[unit]
    to = COUNTS_UNITS.get(unit or "")
    if to is None or not lsb_per_g:
        return unit or "", 1.0
    return to, float(lsb_per_g)
