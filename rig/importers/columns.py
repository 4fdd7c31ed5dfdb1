"""What each column of a generic CSV becomes (``rig import --from csv``, docs/import.md "Columns and units").

A generic CSV may carry any subset of the three sensors, each as three columns, in counts or in
physical units stated by a ``# key: value`` line at the top:

| sensor | columns | units line (default) | counts need | physical units -> stored counts |
|---|---|---|---|---|
| accelerometer | ``ax, ay, az`` | ``# units:`` (counts) | ``# lsb_per_g: N`` | g, m/s^2 -> 100000 counts per g (10 ug) |
| gyroscope | ``gx, gy, gz`` | ``# gyro_units:`` (counts) | ``# gyro_lsb_per_dps: N`` | deg/s, rad/s -> 1000 counts per deg/s |
| magnetometer | ``mx, my, mz`` | ``# mag_units:`` (counts) | ``# mag_lsb_per_ut: N`` | uT, gauss -> 100 counts per uT; ``unknown``: counts kept, 1 count per "uT" |

plus ``temp_c`` (C), ``label`` (the steps) and the time: a ``t_s`` column (s), or a rate (``--rate HZ``,
``# rate_hz: N`` or a preamble line such as ``Fs,100`` before the header). Other names are mapped with
``--columns ours=theirs,...`` (or ``# columns: ours=theirs,...``). Every input column is named in the
import's summary with what became of it (:meth:`ColumnPlan.summary`); nothing is dropped silently.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from rig.errors import RigInputError
from rig.importers.common import COUNTS_PER_G_EQUIVALENT

COUNTS_PER_DPS_EQUIVALENT = 1000.0  # 1 mdeg/s per count
COUNTS_PER_UT_EQUIVALENT = 100.0  # 0.01 uT per count, as the session stores a magnetometer


@dataclass(frozen=True)
class SensorColumns:
    """One sensor's three columns, where its units are stated, and what each unit is worth.

    ``per_unit``: unit -> (input units per physical quantity, counts stored per physical quantity) with
    the physical quantity g, deg/s or uT; None for ``counts`` (the file's counts are kept and its
    ``lsb_key`` line gives their scale); ``unknown`` keeps counts at 1 count per quantity."""

    sensor: str
    columns: tuple[str, str, str]
    units_key: str
    lsb_key: str
    quantity: str
    per_unit: dict


def _accel_units(g_ms2: float) -> dict:
    return {"counts": None, "g": (1.0, COUNTS_PER_G_EQUIVALENT), "m/s^2": (g_ms2, COUNTS_PER_G_EQUIVALENT)}


GYRO_UNITS = {"counts": None, "deg/s": (1.0, COUNTS_PER_DPS_EQUIVALENT),
              "rad/s": (math.pi / 180.0, COUNTS_PER_DPS_EQUIVALENT)}
MAG_UNITS = {"counts": None, "uT": (1.0, COUNTS_PER_UT_EQUIVALENT), "gauss": (0.01, COUNTS_PER_UT_EQUIVALENT),
             "unknown": (1.0, 1.0)}


def sensor_table(g_ms2: float) -> dict[str, SensorColumns]:
    """The three sensors: spool name -> :class:`SensorColumns`."""
    return {
        "acc": SensorColumns("accelerometer", ("ax", "ay", "az"), "units", "lsb_per_g", "g", _accel_units(g_ms2)),
        "gyro": SensorColumns("gyroscope", ("gx", "gy", "gz"), "gyro_units", "gyro_lsb_per_dps", "deg/s", GYRO_UNITS),
        "mag": SensorColumns("magnetometer", ("mx", "my", "mz"), "mag_units", "mag_lsb_per_ut", "uT", MAG_UNITS),
    }


#: a line before the header that states the sample rate: ``Fs,100``, ``sample_rate: 200 Hz``, ``rate=50``
PREAMBLE_RATE = re.compile(r"^\s*(fs|rate|rate_hz|sample_rate|sample_rate_hz|sampling_rate|sampling_frequency|odr)"
                           r"\s*[,;:=\t ]\s*([0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?)\s*(hz)?\s*[,;\t ]*$", re.I)


@dataclass
class SensorPlan:
    """One sensor found in the file: its units, input units per quantity (None: counts kept), counts per quantity."""

    key: str
    spec: SensorColumns
    units: str
    divisor: float | None  # input units per g, deg/s or uT; None: the file's counts are stored
    lsb: float  # stored counts per g, deg/s or uT

    def convert(self, v):
        """Input values -> stored counts (``v / divisor * lsb``; counts as they are)."""
        return v if self.divisor is None else v / self.divisor * self.lsb


@dataclass
class ColumnPlan:
    """What the importer does with each column of the header."""

    header: list[str]
    time_column: str | None
    rate_hz: float | None
    rate_from: str | None
    sensors: dict[str, SensorPlan] = field(default_factory=dict)
    renamed: dict[str, str] = field(default_factory=dict)  # ours -> theirs
    has_temp: bool = False
    has_label: bool = False

    def numeric(self) -> list[str]:
        """The numeric columns read, in spool order: time, the sensors' columns, temperature."""
        cols = [self.time_column] if self.time_column else []
        for p in self.sensors.values():
            cols += list(p.spec.columns)
        return cols + (["temp_c"] if self.has_temp else [])

    def used(self) -> set[str]:
        return set(self.numeric()) | ({"label"} if self.has_label else set())

    def summary(self) -> list[str]:
        """One line per input column (or column group): what became of it."""
        def theirs(name: str) -> str:
            return self.renamed.get(name, name)
        out = []
        if self.time_column:
            out.append(f"column {theirs(self.time_column)}: time, s")
        else:
            out.append(f"no time column: times from the rate {self.rate_hz:g} Hz ({self.rate_from})")
        for p in self.sensors.values():
            cols = ",".join(theirs(c) for c in p.spec.columns)
            if p.spec.per_unit.get(p.units) is None:
                what = f"counts kept, {p.lsb:g} counts per {p.spec.quantity} ('# {p.spec.lsb_key}')"
            elif p.units == "unknown":
                what = "units unknown: counts kept and reported as counts"
            else:
                what = f"{p.units} stored as {p.lsb:g} counts per {p.spec.quantity}"
            out.append(f"columns {cols}: {p.spec.sensor}, {what}")
        if self.has_temp:
            out.append(f"column {theirs('temp_c')}: temperature, C")
        if self.has_label:
            out.append(f"column {theirs('label')}: step labels")
        for h in self.header:
            if h not in self.used():
                out.append(f"column {h}: ignored (not a known column; map it with --columns NAME={h})")
        return out


def parse_column_map(path, text: str | None, where: str) -> dict[str, str]:
    """``ours=theirs,...`` -> {ours: theirs}; ours must be a known column name."""
    if not text:
        return {}
    known = {"t_s", "temp_c", "label", "ax", "ay", "az", "gx", "gy", "gz", "mx", "my", "mz"}
    out = {}
    for part in text.split(","):
        if not part.strip():
            continue
        ours, sep, theirs = part.partition("=")
        ours, theirs = ours.strip(), theirs.strip()
        if not sep or not theirs or ours not in known:
            raise RigInputError(str(path), None, where, f"expected OURS=THEIRS pairs with OURS one of "
                                f"{', '.join(sorted(known))}, got {part.strip()!r}")
        out[ours] = theirs
    return out


def apply_column_map(path, header: list[str], mapping: dict[str, str], header_line: int) -> list[str]:
    """The header with the mapped names replaced by ours."""
    renamed = list(header)
    for ours, theirs in mapping.items():
        if theirs not in header:
            raise RigInputError(str(path), header_line, None, f"the column map names {theirs!r} for {ours}, but "
                                f"the header has no such column (got {', '.join(header)})")
        renamed[header.index(theirs)] = ours
    return renamed


def plan_columns(path, header: list[str], meta: dict[str, str], header_line: int, *, g_ms2: float,
                 rate_hz: float | None, rate_from: str | None, renamed: dict[str, str]) -> ColumnPlan:
    """The :class:`ColumnPlan` of a header (names already mapped), or one line saying what is missing."""
    got = ", ".join(header) or "nothing"
    table = sensor_table(g_ms2)
    plan = ColumnPlan(header, "t_s" if "t_s" in header else None, rate_hz, rate_from, renamed=renamed,
                      has_temp="temp_c" in header, has_label="label" in header)
    for key, spec in table.items():
        present = [c for c in spec.columns if c in header]
        if present and len(present) < 3:
            raise RigInputError(str(path), header_line, None, f"the {spec.sensor} needs all of "
                                f"{', '.join(spec.columns)}; missing {', '.join(c for c in spec.columns if c not in header)}"
                                f" (got {got})")
        if present:
            plan.sensors[key] = sensor_plan(path, key, spec, meta)
    if not plan.sensors:
        raise RigInputError(str(path), header_line, None, "expected the columns of at least one sensor (ax,ay,az; "
                            f"gx,gy,gz; mx,my,mz), got {got}; other names: --columns ax=NAME,... (docs/import.md)")
    if plan.time_column is None and rate_hz is None:
        raise RigInputError(str(path), header_line, None, f"no time: expected a t_s column (got {got}), or the rate: "
                            "--rate HZ, a '# rate_hz: N' line or a preamble line such as 'Fs,100'")
    return plan


def sensor_plan(path, key: str, spec: SensorColumns, meta: dict[str, str]) -> SensorPlan:
    """The units of one sensor from the file's ``# key: value`` lines."""
    units = meta.get(spec.units_key, "counts")
    if units not in spec.per_unit:
        raise RigInputError(str(path), None, spec.units_key, f"expected {', '.join(spec.per_unit)} for the "
                            f"{spec.sensor}, got {units!r}")
    conv = spec.per_unit[units]
    if conv is not None:
        return SensorPlan(key, spec, units, conv[0], conv[1])
    try:
        lsb = float(meta[spec.lsb_key])
    except (KeyError, ValueError):
        lsb = 0.0
    if not (lsb > 0 and math.isfinite(lsb)):
        physical = ", ".join(f"'# {spec.units_key}: {u}'" for u, c in spec.per_unit.items() if c is not None)
        raise RigInputError(str(path), None, spec.lsb_key, f"{spec.sensor} counts need a '# {spec.lsb_key}: N' line "
                            f"(N > 0); a file in physical units says which: {physical}")
    return SensorPlan(key, spec, units, None, lsb)


def rate_option(path, value: float | None, meta: dict[str, str], preamble: float | None) -> tuple[float | None, str | None]:
    """The sample rate (Hz) and where it came from: ``--rate``, ``# rate_hz:``, a preamble line; or None."""
    candidates = [(value, "--rate"), (meta.get("rate_hz"), "'# rate_hz' line"), (preamble, "the preamble")]
    for v, where in candidates:
        if v is None:
            continue
        try:
            hz = float(v)
        except ValueError:
            hz = float("nan")
        if not (math.isfinite(hz) and 0 < hz <= 1e6):
            raise RigInputError(str(path), None, "rate_hz" if where != "--rate" else "--rate",
                                f"expected a sample rate in Hz (0 < rate <= 1e6), got {v!r}")
        return hz, where
    return None, None
