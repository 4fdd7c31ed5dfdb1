"""Attack class: rig files given to ``rig run --rig`` (wrong types, impossible axes, simulator error models of the
wrong shape, wrong-typed fault fields from the published schema, hostile YAML)."""

from __future__ import annotations

import json
import random

import yaml

from .hostile import BAD_NUMBERS, dump, hostile_files, set_path
from .runner import REPO, SIX, TIMEOUT_S, Case

FAMILY = "rig file"


def base_rig() -> dict:
    return yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())


RIG_NUMERIC = ["turntable.axes.a1.speed_deg_s", "turntable.axes.a2.accel_deg_s2", "turntable.axes.a3.home_offset_deg",
               "turntable.axes.a1.cable_wrap_deg", "turntable.axes.a2.sign", "sim.time_scale", "sim.chamber.tau_s",
               "sim.chamber.initial_c"]
RIG_SPECIFIC = [
    ("turntable.axes.a1.speed_deg_s", 100), ("turntable.axes.a1.speed_deg_s", 0), ("turntable.axes.a1.speed_deg_s", -5),
    ("turntable.axes.a2.accel_deg_s2", 1e300), ("turntable.axes.a2.accel_deg_s2", 0), ("turntable.axes.a2.accel_deg_s2", 700),
    ("turntable.axes.a3.home_offset_deg", 1e300), ("turntable.axes.a3.home_offset_deg", 4000),
    ("turntable.axes.a1.soft_limits_deg", [400, -400]), ("turntable.axes.a1.soft_limits_deg", [0]),
    ("turntable.axes.a3.soft_limits_deg", [-10, 10]), ("turntable.axes.a3.cable_wrap_deg", 10),
    ("turntable.axes.a1.soft_limits_deg", "wide"), ("turntable.axes.a2.sign", 2), ("turntable.axes.a2.sign", 0),
    ("turntable.axes.a1.serial", -1), ("turntable.axes.a1.serial", 2 ** 40), ("turntable.axes.a1.slip_ring", "maybe"),
    ("turntable.axes.a1.unknown", 1), ("turntable.axes.a4", {"sign": 1}), ("turntable.axes.a3", None),
    ("turntable", None), ("sensor.model", "BMI160"), ("sensor.address", 0x99), ("sensor.address", "near"),
    ("home", "sideways"), ("kind", "quantum"), ("kind", "hardware"), ("format", "rig-file/9"), ("name", ""),
    ("sim.time_scale", -1), ("sim.chamber.tau_s", -1), ("sim.table_tilt_deg", [90, 0]),
    ("sim.table_tilt_deg", [0]), ("sim.ringing", {"amplitude_g": -1, "freq_hz": 5, "tau_s": 1}),
    ("sim.field", {"magnitude_ut": -50, "inclination_deg": 65, "declination_deg": 0}),
    ("sim.errors", {"no_such_parameter": 1}), ("sim.errors", "big"), ("sim.effects", {"no_such_effect": 1}),
    ("sim.serial_base", "x"), ("sim.unknown", 1), ("name", "   "),
    # error-model overrides and effects of the wrong shape (they reached the simulator: internal errors)
    ("sim.errors.bias_g", [0.1, 0.2]), ("sim.errors.matrix", [1, 2, 3]), ("sim.errors.matrix", [[1, 0], [0, 1]]),
    ("sim.errors.t_ref_c", [1, 2, 3]), ("sim.errors.noise_density_g_per_rthz", [-1, 0, 0]),
    ("sim.effects.table_tilt", [1, 2, 3]), ("sim.effects.full_misalignment", [[1]]),
    ("sim.effects.bias_tempco", [[1, 2], [3]]), ("sim.mag_errors.hard_iron_ut", [[1]]),
    ("sim.gyro_errors.matrix", [1, 2]),
    ("faults.ximc.a1.crc_corrupt_rate", 1.5), ("faults.ximc.a1.drop_rate", -0.1), ("faults.ximc.a1.latency_s", -1),
    ("faults.ximc.a1.error_answer", "errz"), ("faults.ximc.a1.seed", "lucky"), ("faults.ximc.a1.bogus", 1),
    ("faults.ximc.a9.drop_rate", 0.1), ("faults.sensor.oserror_rate", 2), ("faults.sensor.oserror_window_s", [5, 1]),
    ("faults.sensor.oserror_window_s", "soon"), ("faults.sensor.dead_after_s", -3),
    ("faults.sensor.stuck_after_s", "later"), ("faults.sensor.bogus", 1), ("faults.printer", {"on_fire": True}),
]

#: values of the wrong type for a fault field (a rate, a time, a seed, a name, a flag or a [start, end] window)
FAULT_WRONG_TYPES = {"a word": "often", "a numeric string": "0.5", "a list": [0.1], "a mapping": {"rate": 0.1},
                     "a list of words": ["1", "2"], "a nested list": [[0.1, 0.2]]}


def fault_type_values() -> list[tuple[str, str, object]]:
    """(path, value name, value): two wrong-typed values (fixed seed) for every fault field a rig file may set,
    ``faults.ximc.a1.*`` and ``faults.sensor.*`` (from the published JSON Schema, whose fields are the
    simulators' fault dataclasses'): each must be refused when the rig file is loaded, never reach the
    emulator's thread."""
    defs = json.loads((REPO / "docs" / "schemas" / "rig-file.schema.json").read_text())["$defs"]
    pick = random.Random(13)
    out = []
    for prefix, name in (("faults.ximc.a1", "XimcFaultsSection"), ("faults.sensor", "SensorFaultsSection")):
        for field_name in defs[name]["properties"]:
            for vname in pick.sample(sorted(FAULT_WRONG_TYPES), 2):
                out.append((f"{prefix}.{field_name}", vname, FAULT_WRONG_TYPES[vname]))
    return out


def cases(ws, rng, quick: bool) -> list[Case]:
    out = []

    def add(name, p, expect="refuse", post=None, timeout=TIMEOUT_S):
        out.append(Case(FAMILY, name, ["run", SIX, "--rig", p, "--out", ws.root / "runs", "--time-scale", "0",
                                       "--quiet", "--seed", "3"], expect, hint=(p.name, "soft limits"), post=post,
                        timeout=timeout))

    p = ws.path("rig-valid", ".yaml")
    p.write_text(dump(base_rig()))
    add("control: valid rig file", p, expect="valid")
    pick = random.Random(12)
    for path in RIG_NUMERIC:
        for vname, value in [(k, BAD_NUMBERS[k]) for k in pick.sample(sorted(BAD_NUMBERS), 2)]:
            doc = base_rig()
            set_path(doc, path, value)
            p = ws.path(f"rig-{path}-{vname.replace(' ', '_')}", ".yaml")
            p.write_text(dump(doc))
            add(f"{path} = {vname}", p)
    for path, value in RIG_SPECIFIC:
        doc = base_rig()
        set_path(doc, path, value)
        p = ws.path(f"rig-{path}", ".yaml")
        p.write_text(dump(doc))
        add(f"{path} = {json.dumps(value)[:40]}", p)
    for path, vname, value in fault_type_values():
        doc = base_rig()
        set_path(doc, path, value)
        p = ws.path(f"rig-{path}-{vname.replace(' ', '_')}", ".yaml")
        p.write_text(dump(doc))
        add(f"{path} = {vname}", p)
    base = (REPO / "rigs" / "sim.yaml").read_text()
    dup = ws.path("rig-duplicate", ".yaml")
    dup.write_text(base.replace("home: zero", "home: zero\nhome: none"))
    add("duplicate key home", dup)
    for name, p, post in hostile_files(ws, "rig", base):
        add(name, p, post=post, timeout=30)
    return out
