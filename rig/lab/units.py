"""One unit per quantity wherever a person reads it (issue 33 item 4).

The history stores every parameter in the calibration file's unit (``accel.alpha_*`` in rad); ``rig run`` and
``rig solve`` print misalignment angles in mrad (and a first-order tempco in counts/C), so ``rig history``'s table and figure and ``rig report``'s
tables show them in mrad too (the ``--json`` documents keep the stored unit, named beside each value).
"""

from __future__ import annotations

#: stored unit -> (unit shown to a person, factor from stored to shown)
SHOWN_UNITS: dict[str, tuple[str, float]] = {"rad": ("mrad", 1e3), "counts/C^1": ("counts/C", 1.0)}
#: the unit label of the gyroscope's nonorthogonalities ``m_ij = M_ij / M_ii`` (dimensionless), as ``rig run``,
#: ``rig solve`` and ``rig report`` show them
GYRO_NONORTHOGONALITY_UNIT = "ratio M_ij/M_ii"
#: the unit of the gyroscope's g-sensitivity terms ``G_ij`` (gyro axis i per g of specific force along j)
GYRO_G_SENSITIVITY_UNIT = "counts/g"


def gyro_g_sensitivity_terms(g_sensitivity) -> list[tuple[str, float, float | None]]:
    """``(name, value, sigma)`` of every g-sensitivity term the rate steps determined, counts/g: ``ij`` is the
    gyro axis i's output per g of specific force along sensor axis j, for the determined input columns j only
    (the file's other columns are zeros that were not estimated). Empty for None or no determined column."""
    if not isinstance(g_sensitivity, dict):
        return []
    m, s = g_sensitivity.get("matrix_counts_per_g"), g_sensitivity.get("sigma_counts_per_g")
    out = []
    for i, a in enumerate("xyz"):
        for c in g_sensitivity.get("inputs") or []:
            j = "xyz".index(c)
            sigma = None if s is None else float(s[i][j])
            out.append((f"{a}{c}", float(m[i][j]), sigma))
    return out


def shown(value: float, sigma: float | None, unit: str | None) -> tuple[float, float | None, str | None]:
    """``(value, sigma, unit)`` in the unit shown to a person."""
    to, k = SHOWN_UNITS.get(unit or "", (unit, 1.0))
    return value * k, None if sigma is None else sigma * k, to


def shown_scale(unit: str | None) -> tuple[str | None, float]:
    """``(unit shown, factor from stored to shown)`` of a quantity stored in ``unit``."""
    return SHOWN_UNITS.get(unit or "", (unit, 1.0))


def shown_unit(unit: str | None) -> str | None:
    """The unit a quantity stored in ``unit`` is shown in."""
    return SHOWN_UNITS.get(unit or "", (unit, 1.0))[0]


def shown_change(change: dict | None, unit: str | None) -> dict | None:
    """A drift change (``delta``, ``combined_sigma`` in the stored unit) in the shown unit (z is unitless)."""
    k = SHOWN_UNITS.get(unit or "", (unit, 1.0))[1]
    if change is None or k == 1.0:
        return change
    return {**change, "delta": change["delta"] * k, "combined_sigma": change["combined_sigma"] * k}
