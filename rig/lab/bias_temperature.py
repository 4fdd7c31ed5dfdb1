"""A sensor's accelerometer biases at one reference temperature, so its calibrations compare like with like.

A calibration with temperature terms states its bias at its own ``t0`` (``accel.t0_c``), one without them at
its session's mean temperature: side by side, a thermal calibration at t0 = 40 C and the others at 27.6 C
look like a sensor that drifted and came back (issue 33 item 1). Every history view (the table, the figure,
the drift verdict, the report) therefore shows the biases at **one reference temperature**, the sensor's
usual one: the median of its calibrations' temperatures (each calibration's session mean temperature, else
its ``t0``), taken over the calibrations without a temperature model when there are any (no model moves
their biases; the others are carried to them). A calibration with a bias polynomial is carried there by its own polynomial,
``b(T) = b(t0) + sum_k c_k (T - t0)^k``, its sigma gaining ``|T - t0|^k sigma(c_k)`` in quadrature
(:func:`calib.file.parameters.biases_at`; the stored rows have no covariance, so this is approximate). One
without a model is carried by the temperature terms of the unit's own thermal calibration nearest to it in the
history (its tempcos are the sensor's, whichever session measured them: :func:`calib.file.parameters.biases_moved`);
when the history has none it stays at its own temperature and is marked with it when that is more than
:data:`TEMP_MATCH_C` from the reference (no model allows the move). docs/history.md, "Reference temperature".
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass, field

from calib.file.parameters import biases_at, biases_moved, finite_or_none, reference_temp_c

#: a bias stated within this of the reference temperature is taken as stated there (C); the same figure as
#: rig compare's note on step temperatures (rig.analysis.compare.TEMP_NOTE_C)
TEMP_MATCH_C = 0.2
BIAS_NAMES = ("accel.bias_x", "accel.bias_y", "accel.bias_z")


@dataclass(frozen=True)
class BiasesAt:
    """One calibration's accelerometer biases as compared: ``values`` ``{name: (value, sigma, unit)}`` stated at
    ``temp_c`` (None: unknown); ``carried_from_c``: the ``t0`` they were carried from (None: as stated)."""

    values: dict
    temp_c: float | None
    carried_from_c: float | None = None
    carried_by: int | None = None  # the record (index) whose temperature terms carried them; None: their own


@dataclass
class ReferenceView:
    """Every calibration's biases at the reference temperature ``temp_c`` (None: no calibration has one)."""

    temp_c: float | None
    n_temps: int = 0
    fixed: bool = False  # the median is over the calibrations without a temperature model
    biases: list[BiasesAt] = field(default_factory=list)

    def at_reference(self, i: int) -> bool:
        """Calibration ``i``'s biases hold at the reference temperature (or it has none, or no temperature is
        known anywhere)."""
        b = self.biases[i]
        if not b.values or self.temp_c is None:
            return True
        return b.temp_c is not None and abs(b.temp_c - self.temp_c) <= TEMP_MATCH_C

    def own_temperature(self, i: int) -> bool:
        """Calibration ``i``'s biases are marked with their own temperature: no model moves them to the reference."""
        return not self.at_reference(i)

    def describe(self) -> str:
        """One line: the reference temperature and where it comes from."""
        if self.temp_c is None:
            return "accelerometer biases as stated (no calibration of this sensor has a temperature)"
        which = " without a temperature model" if self.fixed else ""
        return (f"accelerometer biases at {self.temp_c:.1f} C, this sensor's usual temperature (the median over its "
                f"{self.n_temps} calibration{'s' if self.n_temps != 1 else ''}{which}; a bias polynomial carries a "
                "thermal calibration there)")

    def to_json(self) -> dict:
        return {"temp_c": self.temp_c, "calibrations": self.n_temps, "rule": (
            "median of the calibrations' temperatures (session mean, else t0), over those without a temperature "
            "model when there are any"), "match_c": TEMP_MATCH_C}


def calibration_temp_c(params: dict, temp_mean_c) -> float | None:
    """Where the unit was calibrated, C: the session's mean temperature, else the calibration's ``t0``."""
    t = finite_or_none(temp_mean_c)
    return t if t is not None else reference_temp_c(params, None)


def reference_view(records) -> ReferenceView:
    """The biases of every record (``.parameters``, ``.info['temp_mean_c']``) at the sensor's reference temperature."""
    with_bias = [r for r in records if any(n in r.parameters for n in BIAS_NAMES)]
    fixed = [r for r in with_bias if "accel.t0_c" not in r.parameters]  # no model moves these
    temps = [t for t in (calibration_temp_c(r.parameters, r.info.get("temp_mean_c")) for r in (fixed or with_bias))
             if t is not None]
    if fixed and not temps:  # the fixed ones' temperatures are unknown: the thermal ones' say where the unit sits
        temps = [t for t in (calibration_temp_c(r.parameters, r.info.get("temp_mean_c")) for r in with_bias)
                 if t is not None]
    ref = float(statistics.median(temps)) if temps else None
    thermal = [i for i, r in enumerate(records) if "accel.t0_c" in r.parameters and any(
        k.startswith("accel.tempco") for k in r.parameters)]
    return ReferenceView(ref, len(temps), bool(fixed) and len(fixed) < len(with_bias),
                         [_biases(records, i, ref, thermal) for i in range(len(records))])


def _biases(records, i: int, ref_c: float | None, thermal: list[int]) -> BiasesAt:
    params = records[i].parameters
    stated = reference_temp_c(params, records[i].info.get("temp_mean_c"))
    if ref_c is not None and "accel.t0_c" in params:
        moved = biases_at(params, ref_c)
        return BiasesAt({n: moved[n] for n in BIAS_NAMES if n in moved}, ref_c, carried_from_c=stated)
    own = {n: params[n] for n in BIAS_NAMES if n in params}
    if ref_c is not None and stated is not None and abs(stated - ref_c) > TEMP_MATCH_C and own and thermal:
        donor = min(thermal, key=lambda j: (abs(j - i), -j))  # the nearest thermal calibration, the later on a tie
        return BiasesAt(biases_moved(own, records[donor].parameters, stated, ref_c), ref_c, carried_from_c=stated,
                        carried_by=donor)
    return BiasesAt(own, stated)


def compared_parameters(record, view: ReferenceView, i: int) -> dict:
    """Record ``i``'s parameters with the biases as the view compares them."""
    return {**record.parameters, **view.biases[i].values}
