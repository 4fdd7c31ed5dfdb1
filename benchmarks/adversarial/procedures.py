"""Attack class: procedures given to ``rig run`` (wrong types, out-of-range and contradictory values, hostile
YAML, and size: a procedure of 10,000 steps, the most a procedure may have, and one of 10,001)."""

from __future__ import annotations

import json
import random

from .hostile import BAD_NUMBERS, dump, hostile_files, set_path
from .runner import SIX, Case

FAMILY = "procedure"


def base_procedure(extra_steps=()) -> dict:
    rate = any("rate" in s for s in extra_steps)  # one spin axis cannot determine the gyroscope: no solve
    return {
        "format": "rig-procedure/1", "name": "adv", "description": "adversarial base",
        "sensor": {"accel_range_g": 4, "sample_rate_hz": 100},
        "dwell": {"seconds": 1},
        "settle": {"window_s": 0.5, "threshold_g": 0.01, "mean_tol_sigma": 4, "timeout_s": 30, "min_s": 0},
        "steps": [{"pose": p} for p in ("+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up")] + list(extra_steps),
        "solve": None if rate else {"model": "triangular", "method": "pinv", "thermal": "auto"},
    }


TEMP_STEP = {"temperature": {"target_c": 28.0, "tolerance_c": 0.5, "hold_s": 1, "timeout_s": 600, "mode": "wait"}}
RATE_STEP = {"rate": {"axis": "a1", "rate_deg_s": 20, "seconds": 1, "spin_up_s": 0.5}, "pose": "+Z up", "name": "r"}

#: numeric fields of a procedure (path, base with the field present)
PROC_NUMERIC = [
    ("dwell.seconds", ()), ("settle.window_s", ()), ("settle.threshold_g", ()), ("settle.mean_tol_sigma", ()),
    ("settle.timeout_s", ()), ("settle.min_s", ()), ("sensor.accel_range_g", ()), ("sensor.sample_rate_hz", ()),
    ("steps[6].angles_deg[0]", ({"angles_deg": [0, 0, 0]},)),
    ("steps[6].temperature.target_c", (TEMP_STEP,)), ("steps[6].temperature.tolerance_c", (TEMP_STEP,)),
    ("steps[6].temperature.hold_s", (TEMP_STEP,)), ("steps[6].temperature.timeout_s", (TEMP_STEP,)),
    ("steps[6].rate.rate_deg_s", (RATE_STEP,)), ("steps[6].rate.seconds", (RATE_STEP,)),
    ("steps[6].rate.spin_up_s", (RATE_STEP,)), ("steps[6].repeat", ({"repeat": 2, "steps": [{"pose": "+Z up"}]},)),
    ("steps[6].dwell.seconds", ({"pose": "+Z up", "dwell": {"seconds": 1}},)),
]

#: specific out-of-range or contradictory procedure values (path, value, extra steps, drop keys)
PROC_SPECIFIC = [
    ("dwell.seconds", -1, ()), ("dwell.seconds", 0, ()), ("dwell.seconds", 1e-4, ()), ("dwell.seconds", 1e7, ()),
    ("dwell", {"samples": 10 ** 12}, ()), ("dwell", {"samples": 1}, ()), ("dwell", {"samples": 2.5}, ()),
    ("dwell", {"seconds": 1, "samples": 100}, ()), ("dwell", {"sem_g": 1e-5}, ()),
    ("dwell", {"sem_g": 5, "max_seconds": 10}, ()), ("dwell", {}, ()),
    ("settle.timeout_s", 1e300, ()), ("settle.min_s", 1e300, ()), ("settle.window_s", 60, ()),
    ("settle.threshold_g", 1e300, ()), ("settle.threshold_g", -0.01, ()), ("settle.window_s", 0, ()),
    ("sensor.accel_range_g", 3, ()), ("sensor.accel_range_g", 32, ()), ("sensor.sample_rate_hz", 0, ()),
    ("sensor.sample_rate_hz", 7, ()), ("sensor.sample_rate_hz", 1e9, ()), ("sensor.model", "BMI160", ()),
    ("sensor.model", "ADXL345", ()), ("sensor.magnetometer", "yes please", ()), ("sensor.unknown", 1, ()),
    ("steps[0].pose", "+W up", ()), ("steps[0].pose", "+X+X up", ()), ("steps[0].pose", 3, ()),
    ("steps[6].angles_deg", [0, 0], ({"angles_deg": [0, 0, 0]},)),
    ("steps[6].angles_deg", [0, 0, 0, 0], ({"angles_deg": [0, 0, 0]},)),
    ("steps[6].repeat", -1, ({"repeat": 2, "steps": [{"pose": "+Z up"}]},)),
    ("steps[6].repeat", 10 ** 9, ({"repeat": 2, "steps": [{"pose": "+Z up"}]},)),
    ("steps[6].steps", [], ({"repeat": 2, "steps": [{"pose": "+Z up"}]},)),
    ("steps[6].temperature.target_c", 200, (TEMP_STEP,)), ("steps[6].temperature.hold_s", 5000, (TEMP_STEP,)),
    ("steps[6].temperature.tolerance_c", 0, (TEMP_STEP,)), ("steps[6].temperature.mode", "pray", (TEMP_STEP,)),
    ("steps[6].rate.rate_deg_s", 100, (RATE_STEP,)), ("steps[6].rate.rate_deg_s", 0, (RATE_STEP,)),
    ("steps[6].rate.axis", "a4", (RATE_STEP,)), ("steps[6].pose", "-W up", ({"pose": "+Z up"},)),
    ("steps[6].settle", {"window_s": 50, "timeout_s": 10}, ({"pose": "+Z up"},)),
    ("steps[6].prompt", "Mount the sensor and confirm.", ({"prompt": "x"},)),  # no operator (stdin not a tty)
    ("steps[6]", {"pose": "+Z up", "angles_deg": [0, 0, 0]}, ({"pose": "+Z up"},)),
    ("steps[6]", {"wobble": 1}, ({"pose": "+Z up"},)),
    ("steps", [], ()), ("steps", "all of them", ()), ("format", "rig-procedure/2", ()), ("format", None, ()),
    ("name", "../../etc", ()), ("name", "a b", ()), ("order", "random", ()), ("solve.model", "quadratic", ()),
    ("solve.method", "magic", ()), ("solve.thermal", 9, ()), ("solve.thermal", "on", ()),
    ("solve.magnetometer", "compass", ()), ("unknown_key", 1, ()),
]

#: the most steps a procedure may have after expanding repeats (rig.config.procedure.MAX_STEPS)
MAX_STEPS = 10_000
FACES = ("+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up")


def many_steps(n: int) -> str:
    """A procedure of ``n`` listed steps (no repeat:), the six faces in turn, 0.2 s dwell (20 samples)."""
    steps = "".join(f'  - pose: "{FACES[i % 6]}"\n' for i in range(n))
    return ("format: rig-procedure/1\nname: many_steps\nsensor: {accel_range_g: 4, sample_rate_hz: 100}\n"
            "dwell: {seconds: 0.2}\nsettle: {window_s: 0.1, threshold_g: 0.01, timeout_s: 30}\n"
            f"steps:\n{steps}solve: {{model: triangular, method: pinv, thermal: auto}}\n")


def cases(ws, rng, quick: bool) -> list[Case]:
    out = []

    def add(name, path, expect="refuse", timeout=None, heavy=False):
        out.append(Case(FAMILY, name, ["run", path, "--out", ws.root / "runs", "--time-scale", "0", "--quiet",
                                       "--seed", "3"], expect, hint=(path.name, "prompt"), heavy=heavy,
                        **({"timeout": timeout} if timeout else {})))

    for extra, label in (((), "six poses"), ((TEMP_STEP,), "with a temperature step"),
                         ((RATE_STEP,), "with a rate step")):
        p = ws.path(f"proc-valid-{label.replace(' ', '_')}", ".yaml")
        p.write_text(dump(base_procedure(extra)))
        add(f"control: valid procedure {label}", p, expect="valid")
    pick = random.Random(11)  # two of the bad values per field, drawn with a fixed seed
    for path, extra in PROC_NUMERIC:
        for vname, value in [(k, BAD_NUMBERS[k]) for k in pick.sample(sorted(BAD_NUMBERS), 2)]:
            doc = base_procedure(extra)
            set_path(doc, path, value)
            p = ws.path(f"proc-{path}-{vname.replace(' ', '_')}", ".yaml")
            p.write_text(dump(doc))
            add(f"{path} = {vname}", p)
    for path, value, extra in PROC_SPECIFIC:
        doc = base_procedure(extra)
        set_path(doc, path, value)
        p = ws.path(f"proc-{path}-specific", ".yaml")
        p.write_text(dump(doc))
        add(f"{path} = {json.dumps(value)[:40]}", p)
    base = SIX.read_text()
    for written in ("1.0e9", "1e9"):  # YAML 1.1 reads these as strings: a number field takes them, then its range
        p = ws.path(f"proc-dwell-exponent-{written}", ".yaml")
        p.write_text(base.replace("dwell: {seconds: 10}", f"dwell: {{seconds: {written}}}"))
        add(f"dwell.seconds = {written} (exponent form)", p)
    dup = ws.path("proc-duplicate-dwell", ".yaml")
    dup.write_text(base.replace("dwell: {seconds: 10}", "dwell: {seconds: 10}\ndwell: {seconds: 1}"))
    add("duplicate key dwell", dup)
    dup2 = ws.path("proc-duplicate-inner", ".yaml")
    dup2.write_text(base.replace("dwell: {seconds: 10}", "dwell: {seconds: 10, seconds: 1}"))
    add("duplicate inner key dwell.seconds", dup2)
    for name, p, post in hostile_files(ws, "proc", base):
        out.append(Case(FAMILY, name, ["run", p, "--out", ws.root / "runs", "--time-scale", "0", "--quiet"],
                        hint=(p.name,), post=post, timeout=30))
    # size: the most steps a procedure may have runs (and solves) in bounded time; one more is refused at once
    p = ws.path("proc-10000-steps", ".yaml")
    p.write_text(many_steps(MAX_STEPS))
    # 217 s on the 2-core machine beside other work (benchmarks/bench_many_steps.py); over 600 s at load 11
    add(f"{MAX_STEPS} steps (the most allowed), virtual time", p, expect="valid", timeout=1800, heavy=True)
    p = ws.path("proc-10001-steps", ".yaml")
    p.write_text(many_steps(MAX_STEPS + 1))
    add(f"{MAX_STEPS + 1} steps (one too many)", p, timeout=60)
    return out
