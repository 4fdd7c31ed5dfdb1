"""The rig file's ``fixture:`` section: N sensor slots on one turntable (docs/fixture.md).

Each slot names its bus, optionally the TCA9548A and channel it sits behind, its chip and address, its
mounting rotation (slot frame to turntable frame, :mod:`rig.config.rotations`) and optionally the
unit's serial. :class:`FixtureConfig` checks the slots against each other, in this order, each
refusal one line at the slot's key: two chips answering at one address on one segment of a bus (the
MPU-9150's AK8975 at 0x0C counts: the driver opens its bypass), duplicate serials, a rate some chip
cannot run at, and a bus whose slots need more than half its wire time at ``rate_hz``
(:mod:`rig.config.bus_budget`). A run checks the budget again at the rate its procedure asks for, on the slots
it reads (:meth:`FixtureConfig.over_budget`; :func:`rig.execution.fixture.check_fixture_bus`, before anything
moves): the simulated bus has no wire time, so nothing else would refuse it.

The multiplexer policy the checks assume (and the engine keeps): one channel of one multiplexer is
connected at a time, so chips on different channels, or behind different multiplexers, never answer
together; a chip on the bus itself answers whatever is selected.
"""

from __future__ import annotations

import dataclasses
import re
from typing import Annotated, Any, ClassVar, Optional

import numpy as np
from pydantic import BeforeValidator, ConfigDict, Field, PlainSerializer, WithJsonSchema, model_validator
from pydantic.dataclasses import dataclass as schema_dataclass

from calib.file.fields import Index, Strict, check_mapping, choice, fail, fmt, label, number
from drivers.sensors.chips import CHIPS, SENSOR_MODELS
from drivers.sensors.regs.mpu9150 import AK8975_ADDRESS
from drivers.sensors.tca9548a import ADDRESSES as MUX_ADDRESSES
from drivers.sensors.tca9548a import CHANNELS as MUX_CHANNELS
from drivers.sensors.tca9548a import MODEL as MUX_MODEL
from rig.config import bus_budget
from rig.config.rotations import CUBE_ROTATIONS, name_of, rotation_problem

MAX_SLOTS = 64
#: addresses a chip occupies besides its own, with the reason (the driver's configure opens them)
EXTRA_ADDRESSES: dict[str, dict[int, str]] = {
    "MPU-9150": {AK8975_ADDRESS: "its AK8975 magnetometer (the driver opens the MPU-9150's I2C bypass)"},
    "ADXL345": {},
}
#: the bus clocks a fixture may run at, Hz (the TCA9548A: at most 400 kHz)
BUS_CLOCKS_HZ = (100_000, 400_000)
_DEV_I2C = re.compile(r"/dev/i2c-(\d+)\Z")
_DATACLASS_CONFIG = ConfigDict(extra="forbid")


# -- field types -----------------------------------------------------------------------------------
def _whole(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _mux_address(v):
    if v is None or (_whole(v) and v in MUX_ADDRESSES):
        return v
    shown = f"0x{v:02x}" if _whole(v) else repr(v)
    raise fail(f"expected a {MUX_MODEL} address, 0x{MUX_ADDRESSES[0]:02x}..0x{MUX_ADDRESSES[-1]:02x}, got {shown}")


def _mux_channel(v):
    if v is None or (_whole(v) and 0 <= v < MUX_CHANNELS):
        return v
    raise fail(f"expected a channel of the {MUX_MODEL}, 0..{MUX_CHANNELS - 1}, got {v!r}")


MuxAddress = Annotated[Optional[int], BeforeValidator(_mux_address), WithJsonSchema({
    "anyOf": [{"type": "integer", "minimum": MUX_ADDRESSES[0], "maximum": MUX_ADDRESSES[-1]}, {"type": "null"}],
    "description": f"address of the {MUX_MODEL} the slot is behind (0x70..0x77)"})]
MuxChannel = Annotated[Optional[int], BeforeValidator(_mux_channel), WithJsonSchema({
    "anyOf": [{"type": "integer", "minimum": 0, "maximum": MUX_CHANNELS - 1}, {"type": "null"}],
    "description": f"the {MUX_MODEL} channel the slot is on (0..{MUX_CHANNELS - 1})"})]


def _slot_bus(v):
    if isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 1_000_000:
        return f"/dev/i2c-{v}"
    if isinstance(v, str) and v.strip():
        if v.startswith("/dev/") and not _DEV_I2C.match(v):
            raise fail(f"expected /dev/i2c-N (an I2C bus device), got {v!r}")
        return v.strip()
    raise fail(f"expected an I2C bus (/dev/i2c-N, or its number N) or a simulated bus name, got {v!r}")


SlotBus = Annotated[str, BeforeValidator(_slot_bus), WithJsonSchema({
    "anyOf": [{"type": "integer", "minimum": 0}, {"type": "string", "minLength": 1}],
    "description": "the slot's I2C bus: /dev/i2c-N (or N) or a simulated bus name"})]


@dataclasses.dataclass(frozen=True)
class Rotation:
    """A slot's mounting rotation: ``matrix`` takes slot-frame vectors to the turntable frame
    (``v_turntable = matrix @ v_slot``); ``name`` is its cube-rotation name, or None for another one."""

    name: Optional[str]
    matrix: tuple[tuple[float, float, float], ...]

    def as_array(self) -> np.ndarray:
        return np.array(self.matrix, dtype=float)


def _rotation(v):
    if isinstance(v, Rotation):
        return v
    if isinstance(v, str):
        if v in CUBE_ROTATIONS:
            return Rotation(v, tuple(map(tuple, CUBE_ROTATIONS[v].tolist())))
        raise fail(f"expected a rotation name such as x+z+ (where the slot's +x and +z point: one of "
                   f"{', '.join(CUBE_ROTATIONS)}) or a 3x3 matrix, got {v!r}")
    if not isinstance(v, (list, tuple)) or any(isinstance(x, bool) for row in v if isinstance(row, (list, tuple))
                                                for x in row):
        raise fail(f"expected a rotation name such as x+z+ or a 3x3 matrix, got {v!r}")
    problem = rotation_problem(v)
    if problem is not None:
        raise fail(problem)
    m = np.asarray(v, dtype=float)
    return Rotation(name_of(m), tuple(map(tuple, m.tolist())))


RotationField = Annotated[Any, BeforeValidator(_rotation),
                          PlainSerializer(lambda r: r.name if r.name is not None else [list(row) for row in r.matrix]),
                          WithJsonSchema({"anyOf": [
                              {"enum": list(CUBE_ROTATIONS), "type": "string"},
                              {"type": "array", "minItems": 3, "maxItems": 3,
                               "items": {"type": "array", "minItems": 3, "maxItems": 3, "items": {"type": "number"}}}],
                              "description": "slot frame to turntable frame: where the slot's +x and +z point "
                                             "(x+z+ is the identity), or the 3x3 matrix (rows)"})]


# -- one slot ---------------------------------------------------------------------------------------
@schema_dataclass(frozen=True, config=_DATACLASS_CONFIG)
class SlotConfig:
    """One slot of the fixture: where its chip is on which bus, how it is mounted, which unit it holds."""

    mapping_hint: ClassVar[str] = "expected a mapping {bus, mux, channel, model, address, rotation, serial}"
    bus: SlotBus
    rotation: RotationField
    mux: MuxAddress = None
    channel: MuxChannel = None
    model: choice(SENSOR_MODELS, f"expected {' or '.join(SENSOR_MODELS)}, got {{got}}") = SENSOR_MODELS[0]
    address: Optional[number(ge=0, le=0x7F, integer=True)] = None
    serial: Optional[label(64, "the unit's serial number", blank=False)] = None

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        data = check_mapping(cls, data, info)
        if isinstance(data, dict):
            for key in ("bus", "rotation"):
                if key not in data:
                    raise fail(f"missing {key}" + (" (where the slot's +x and +z point, e.g. x+z+)"
                                                   if key == "rotation" else " (/dev/i2c-N or a simulated bus)"))
        return data

    @model_validator(mode="after")
    def _mux_and_address(self):
        if self.channel is not None and self.mux is None:
            raise fail(f"a channel needs the {MUX_MODEL} it belongs to (mux: 0x70..0x77)", at=("channel",))
        if self.mux is not None and self.channel is None:
            raise fail(f"expected the {MUX_MODEL} channel of this slot (0..{MUX_CHANNELS - 1})", at=("mux",))
        allowed = CHIPS[self.model].addresses
        if self.address is None:
            object.__setattr__(self, "address", CHIPS[self.model].default_address)
        elif self.address not in allowed:
            raise fail(f"expected one of {', '.join(hex(a) for a in allowed)} for the {self.model}, "
                       f"got {self.address!r}", at=("address",))
        return self

    @property
    def segment(self) -> tuple:
        """(bus, mux, channel): the part of the wiring the slot's chip sits on (mux and channel None: the bus)."""
        return (self.bus, self.mux, self.channel)

    def occupied(self) -> dict[int, str]:
        """Every address the slot's chip answers at, with what answers there."""
        return {self.address: f"its {self.model}", **EXTRA_ADDRESSES.get(self.model, {})}

    def where(self) -> str:
        """The segment in words: ``/dev/i2c-1, TCA9548A 0x70 channel 3``."""
        if self.mux is None:
            return f"{self.bus}, on the bus itself"
        return f"{self.bus}, {MUX_MODEL} 0x{self.mux:02x} channel {self.channel}"


def _answer_together(a: SlotConfig, b: SlotConfig) -> bool:
    """Whether the chips of two slots can be connected at the same moment (one channel of one multiplexer
    connected at a time; a chip on the bus itself is always connected)."""
    return a.bus == b.bus and (a.segment == b.segment or a.mux is None or b.mux is None)


# -- the section -------------------------------------------------------------------------------------
class FixtureConfig(Strict):
    """The ``fixture:`` section: the slots, the rate the bus budget is checked at, the bus clock."""

    mapping_hint: ClassVar[str] = "expected a mapping {slots, rate_hz, bus_clock_hz}"
    slots: Annotated[tuple[SlotConfig, ...], Field(min_length=1, max_length=MAX_SLOTS)]
    rate_hz: number(gt=0, le=8000, description="the output rate the buses must carry every slot at, Hz") = 100.0
    bus_clock_hz: choice(BUS_CLOCKS_HZ, "expected 100000 or 400000 (Hz; the TCA9548A runs at most at 400 kHz), "
                         "got {got}", "the I2C bus clock, Hz") = 400_000

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        data = check_mapping(cls, data, info)
        if isinstance(data, dict):
            slots = data.get("slots")
            if "slots" not in data:
                raise fail("missing slots (a list: one mapping per slot)")
            if not isinstance(slots, list) or not slots:
                raise fail(f"expected a list of at least one slot, got {slots!r}", at=("slots",))
            if len(slots) > MAX_SLOTS:
                raise fail(f"expected at most {MAX_SLOTS} slots, got {len(slots)}", at=("slots",))
        return data

    @model_validator(mode="after")
    def _slots_together(self):
        for check in (_clashes, _serials, _rates, _budget):
            problem = check(self)
            if problem is not None:
                raise problem
        return self

    def buses(self) -> dict[str, list[int]]:
        """Bus -> the indexes of its slots, in file order."""
        out: dict[str, list[int]] = {}
        for i, s in enumerate(self.slots):
            out.setdefault(s.bus, []).append(i)
        return out

    def over_budget(self, rate_hz: float, slots=None, what: str = "its {n} slots") -> "BudgetProblem | None":
        """The first bus that cannot carry its slots (``slots``: these indexes only) at ``rate_hz``, Hz
        (:func:`over_budget`); None when every bus carries them."""
        return over_budget(self, rate_hz, slots, what)

    def loads(self, rate_hz: float | None = None) -> dict[str, bus_budget.BusLoad]:
        """Bus -> its wire-time load at ``rate_hz`` (default the section's ``rate_hz``)."""
        rate = self.rate_hz if rate_hz is None else rate_hz
        return {bus: bus_budget.bus_load([(self.slots[i].model, self.slots[i].mux) for i in idx], rate,
                                         self.bus_clock_hz)
                for bus, idx in self.buses().items()}


def _clashes(fx: FixtureConfig):
    for j, b in enumerate(fx.slots):
        for i, a in enumerate(fx.slots[:j]):
            if not _answer_together(a, b):
                continue
            common = set(a.occupied()) & set(b.occupied())
            if common:
                addr = b.address if b.address in common else min(common)
                what_a, what_b = a.occupied()[addr], b.occupied()[addr]
                what = f"each with {what_a}" if what_a == what_b else f"slot {i} with {what_a}, this one with {what_b}"
                place = (f"on {b.where()}" if a.segment == b.segment
                         else f"(slot {i} on {a.where()}, this one on {b.where()})")
                return fail(f"slot {i} and this slot both answer at 0x{addr:02x} {place}, {what}; put them on "
                            "different channels or buses", at=("slots", Index(j), "address"))
    return None


def _serials(fx: FixtureConfig):
    seen: dict[str, int] = {}
    for j, s in enumerate(fx.slots):
        if s.serial is None:
            continue
        if s.serial in seen:
            return fail(f"serial {s.serial!r} is also slot {seen[s.serial]}'s: each unit has its own",
                        at=("slots", Index(j), "serial"))
        seen[s.serial] = j
    return None


def _rates(fx: FixtureConfig):
    for j, s in enumerate(fx.slots):
        if not CHIPS[s.model].accepts_rate(fx.rate_hz):
            return fail(f"expected a rate every slot's chip runs at: the {s.model} of slot {j} cannot run at "
                        f"{fmt(fx.rate_hz)} Hz", at=("rate_hz",))
    return None


def _budget(fx: FixtureConfig):
    problem = fx.over_budget(fx.rate_hz)
    return None if problem is None else fail(problem.message, at=("slots", Index(problem.slot), "bus"))


@dataclasses.dataclass(frozen=True)
class BudgetProblem:
    """A bus that cannot carry its slots at a rate: the first slot beyond the limit (its index in the fixture)
    and the one-line refusal with the numbers (docs/fixture.md, "Bus budget")."""

    slot: int
    message: str


def over_budget(fx: FixtureConfig, rate_hz: float, indexes=None, what: str = "its {n} slots") -> BudgetProblem | None:
    """The first bus whose slots (``indexes``: these slots only; default all) need more than
    :data:`~rig.config.bus_budget.MAX_BUS_SHARE` of its wire time at ``rate_hz`` (Hz); None when every bus carries
    them. ``what`` names the slots in the message (``{n}``: how many)."""
    chosen = set(range(len(fx.slots)) if indexes is None else indexes)
    for bus, all_idx in fx.buses().items():
        idx = [i for i in all_idx if i in chosen]
        if not idx:
            continue
        load = bus_budget.bus_load([(fx.slots[i].model, fx.slots[i].mux) for i in idx], rate_hz, fx.bus_clock_hz)
        over = load.first_over()
        if over is None:
            continue
        n = len(idx)
        best = _highest_rate(fx, idx)
        lower = f"or at most {fmt(best)} Hz for these {n}" if best is not None else "no rate of these chips fits"
        return BudgetProblem(idx[over], (
            f"bus {bus} cannot carry {what.format(n=n)} at {fmt(rate_hz)} Hz: "
            f"{load.total_bits_per_s / 1000:.0f} kbit/s of wire time of its {fx.bus_clock_hz // 1000} "
            f"kbit/s ({100 * load.share:.0f} %; a fixture may plan {100 * bus_budget.MAX_BUS_SHARE:.0f} %): "
            f"it carries the first {over} at this rate, {lower} (docs/fixture.md, \"Bus budget\")"))
    return None


def _highest_rate(fx: FixtureConfig, idx: list[int]) -> float | None:
    """The highest rate every chip of these slots runs at and their bus carries (None: none)."""
    slots = [fx.slots[i] for i in idx]
    rates = set(CHIPS[slots[0].model].sample_rates_hz)
    for s in slots[1:]:
        rates = {r for r in rates if CHIPS[s.model].accepts_rate(r)}
    for rate in sorted(rates, reverse=True):
        load = bus_budget.bus_load([(s.model, s.mux) for s in slots], rate, fx.bus_clock_hz)
        if load.first_over() is None:
            return rate
    return None
