"""Procedures (``rig-procedure/1``): what a technician runs, declared in YAML.

See docs/procedures.md. Loading validates everything up front: unknown keys,
wrong types, unknown poses, impossible dwell or sensor settings each give one
line ``file:line: key: what is allowed``, before anything moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rig.errors import RigInputError
from rig.planning.kinematics import f_nominal
from rig.planning.poses import POSE_NAMES, pose_angles_deg
from rig.config.yamlload import load_located

FORMAT = "rig-procedure/1"
ACCEL_RANGES_G = (2, 4, 8, 16)
GYRO_RANGES_DPS = (250, 500, 1000, 2000)
ADXL345_RATES_HZ = (6.25, 12.5, 25, 50, 100, 200, 400, 800, 1600, 3200)
MODELS = ("triangular", "full")
METHODS = ("pinv", "flip", "combinations")
MAX_STEPS = 10000


@dataclass(frozen=True)
class Dwell:
    """How long to capture at a pose: exactly one of seconds, samples, sem_g."""

    seconds: float | None = None
    samples: int | None = None
    sem_g: float | None = None  # until the standard error of the mean reaches this, g
    max_seconds: float | None = None  # cap for sem_g


@dataclass(frozen=True)
class Settle:
    """Settle rule (see rig.execution.settle.SettleRule)."""

    window_s: float = 0.5
    threshold_g: float = 0.01
    mean_tol_sigma: float = 4.0
    timeout_s: float = 30.0
    min_s: float = 0.0


@dataclass(frozen=True)
class TemperatureTarget:
    target_c: float
    tolerance_c: float = 0.3
    hold_s: float = 60.0
    timeout_s: float = 3600.0
    mode: str = "wait"  # wait | operator


@dataclass(frozen=True)
class SensorSpec:
    model: str | None = None  # None = any
    accel_range_g: int = 4
    sample_rate_hz: float = 100.0
    gyro_range_dps: int = 250
    magnetometer: bool = False  # read the AK8975 at every static step
    mag_samples: int = 20  # magnetometer readings per static step


@dataclass(frozen=True)
class SolveSpec:
    model: str = "triangular"
    method: str = "pinv"
    thermal: object = "auto"  # auto | off | int
    magnetometer: str | None = None  # positions | ellipsoid (default: positions when the site field is known)

    def get(self, key, default=None):
        return getattr(self, key, default)


@dataclass(frozen=True)
class PlannedStep:
    """One executable step after expansion of repeats."""

    index: int
    name: str
    kind: str  # static | thermal | prompt
    angles_deg: tuple[float, float, float] | None = None
    f_nominal: tuple[float, float, float] | None = None
    dwell: Dwell | None = None
    settle: Settle | None = None
    temperature: TemperatureTarget | None = None
    prompt: str | None = None
    source_line: int | None = None
    rate_axis: str | None = None  # rate steps: the stage axis that spins
    rate_deg_s: float | None = None  # its kinematic rate, deg/s
    rate_nominal_dps: tuple[float, float, float] | None = None  # body rate in the sensor frame, deg/s

    def to_manifest(self) -> dict:
        d = {"index": self.index, "name": self.name, "kind": self.kind,
             "angles_deg": list(self.angles_deg) if self.angles_deg is not None else None,
             "f_nominal": [round(float(x), 12) for x in self.f_nominal] if self.f_nominal is not None else None,
             "status": "pending"}
        if self.temperature is not None:
            d["target_c"] = self.temperature.target_c
        if self.prompt is not None:
            d["prompt"] = self.prompt
        if self.rate_axis is not None:
            d.update(axis=self.rate_axis, rate_deg_s=self.rate_deg_s,
                     rate_nominal_dps=[round(float(x), 12) for x in self.rate_nominal_dps])
        return d


@dataclass(frozen=True)
class Procedure:
    name: str
    description: str
    path: str
    sensor: SensorSpec
    dwell: Dwell
    settle: Settle
    order: str
    steps: tuple[PlannedStep, ...]
    solve: SolveSpec | None
    text: str = field(repr=False, default="")

    def expanded_steps(self) -> list[PlannedStep]:
        return list(self.steps)

    def sensor_settings(self):
        from drivers.sensors.base import SensorSettings
        return SensorSettings(accel_range_g=self.sensor.accel_range_g, sample_rate_hz=self.sensor.sample_rate_hz,
                              gyro_range_dps=self.sensor.gyro_range_dps)


def load_procedure(path) -> Procedure:
    """Load and validate a procedure file."""
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise RigInputError(str(p), None, None, "no such procedure file") from None
    except IsADirectoryError:
        raise RigInputError(str(p), None, None, "is a directory, expected a procedure YAML file") from None
    except UnicodeDecodeError:
        raise RigInputError(str(p), None, None, "not a text file") from None
    return load_procedure_text(text, str(p))


def load_procedure_text(text: str, path: str = "<procedure>") -> Procedure:
    """Validate procedure YAML text (``path`` only names it in errors)."""
    doc, loc = load_located(text, path)
    v = _Validator(path, loc)
    if not isinstance(doc, dict):
        raise RigInputError(path, 1, None, "expected a mapping with format, name, steps, ...")
    v.keys(doc, "", {"format", "name", "description", "sensor", "dwell", "settle", "order", "steps", "solve"},
           required={"format", "name", "steps"})
    if doc["format"] != FORMAT:
        v.fail(doc, "format", f"expected {FORMAT!r}, got {doc['format']!r}")
    name = v.string(doc, "name")
    if not name.replace("_", "").replace("-", "").isalnum():
        v.fail(doc, "name", "use letters, digits, '_' and '-' only")
    description = v.string(doc, "description") if "description" in doc else ""
    sensor = v.sensor(doc.get("sensor"), doc)
    dwell = v.dwell(doc["dwell"], "dwell", doc) if "dwell" in doc else Dwell(seconds=10.0)
    settle = v.settle(doc["settle"], "settle", doc, Settle()) if "settle" in doc else Settle()
    order = doc.get("order", "as_written")
    if order not in ("as_written", "shortest"):
        v.fail(doc, "order", f"expected as_written or shortest, got {order!r}")
    solve = v.solve(doc.get("solve", None), doc) if "solve" in doc else None
    if not isinstance(doc["steps"], list) or not doc["steps"]:
        v.fail(doc, "steps", "expected a non-empty list of steps")
    raw: list[PlannedStep] = []
    v.steps(doc["steps"], "steps", dwell, settle, raw, prefix="", depth=0)
    steps = [s if s.index == i else _reindex(s, i) for i, s in enumerate(raw)]
    if order == "shortest":
        from rig.planning.targets import reorder_for_travel
        steps = [_reindex(s, i) for i, s in enumerate(reorder_for_travel(steps))]
    if sensor.model == "ADXL345" and any(s.kind == "thermal" for s in steps):
        v.fail(doc, "sensor", "temperature steps need the sensor's thermometer; the ADXL345 has none")
    if not any(s.kind == "static" for s in steps):
        v.fail(doc, "steps", "no pose step: nothing to capture")
    return Procedure(name=name, description=description, path=path, sensor=sensor, dwell=dwell, settle=settle,
                     order=order, steps=tuple(steps), solve=solve, text=text)


def _reindex(s: PlannedStep, i: int) -> PlannedStep:
    from dataclasses import replace
    return replace(s, index=i)


class _Validator:
    def __init__(self, path: str, loc) -> None:
        self.path = path
        self.loc = loc

    def fail(self, container, key, message, where=None):
        line = self.loc.line_of(container, key) if isinstance(container, (dict, list)) else None
        raise RigInputError(self.path, line, where if where is not None else key, message)

    def keys(self, m, where, allowed, required=()):
        for k in m:
            if k not in allowed:
                self.fail(m, k, f"unknown key (allowed: {', '.join(sorted(allowed))})", _join(where, k))
        for k in required:
            if k not in m:
                self.fail(m, None, f"missing required key {k!r}", where or k)

    def string(self, m, key, where=None):
        val = m[key]
        if not isinstance(val, str) or not val.strip():
            self.fail(m, key, f"expected a non-empty string, got {val!r}", where or key)
        return val.strip()

    def number(self, m, key, where, *, positive=False, minimum=None, maximum=None, integer=False):
        val = m[key]
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
            self.fail(m, key, f"expected a {'whole ' if integer else ''}number, got {val!r}", where)
        if integer and float(val) != int(val):
            self.fail(m, key, f"expected a whole number, got {val!r}", where)
        if positive and val <= 0:
            self.fail(m, key, f"expected a number > 0, got {val!r}", where)
        if minimum is not None and val < minimum:
            self.fail(m, key, f"expected >= {minimum:g}, got {val!r}", where)
        if maximum is not None and val > maximum:
            self.fail(m, key, f"expected <= {maximum:g}, got {val!r}", where)
        return int(val) if integer else float(val)

    def sensor(self, m, parent) -> SensorSpec:
        if m is None:
            return SensorSpec()
        if not isinstance(m, dict):
            self.fail(parent, "sensor", "expected a mapping (model, accel_range_g, sample_rate_hz, gyro_range_dps)")
        self.keys(m, "sensor", {"model", "accel_range_g", "sample_rate_hz", "gyro_range_dps", "magnetometer",
                                "mag_samples"})
        model = m.get("model")
        if model is not None and model not in ("MPU-9150", "ADXL345"):
            self.fail(m, "model", f"expected MPU-9150 or ADXL345, got {model!r}", "sensor.model")
        rng = m.get("accel_range_g", 4)
        if rng not in ACCEL_RANGES_G or isinstance(rng, bool):
            self.fail(m, "accel_range_g", f"expected one of {', '.join(map(str, ACCEL_RANGES_G))}, got {rng!r}",
                      "sensor.accel_range_g")
        rate = self.number(m, "sample_rate_hz", "sensor.sample_rate_hz", positive=True) \
            if "sample_rate_hz" in m else 100.0
        if model == "ADXL345" and rate not in ADXL345_RATES_HZ:
            self.fail(m, "sample_rate_hz", f"the ADXL345 runs at {', '.join(f'{r:g}' for r in ADXL345_RATES_HZ)} Hz; "
                      f"got {rate:g}", "sensor.sample_rate_hz")
        if model != "ADXL345" and not (4 <= rate <= 1000 and abs(1000 / rate - round(1000 / rate)) < 1e-9):
            self.fail(m, "sample_rate_hz", f"the MPU-9150 runs at 1000/(1+n) Hz, 4..1000; got {rate:g}",
                      "sensor.sample_rate_hz")
        gyro = m.get("gyro_range_dps", 250)
        if gyro not in GYRO_RANGES_DPS or isinstance(gyro, bool):
            self.fail(m, "gyro_range_dps", f"expected one of {', '.join(map(str, GYRO_RANGES_DPS))}, got {gyro!r}",
                      "sensor.gyro_range_dps")
        mag = m.get("magnetometer", False)
        if not isinstance(mag, bool):
            self.fail(m, "magnetometer", f"expected true or false, got {mag!r}", "sensor.magnetometer")
        if mag and model == "ADXL345":
            self.fail(m, "magnetometer", "the ADXL345 has no magnetometer (the AK8975 sits behind the MPU-9150)",
                      "sensor.magnetometer")
        n_mag = int(self.number(m, "mag_samples", "sensor.mag_samples", positive=True, integer=True, maximum=1000)) \
            if "mag_samples" in m else 20
        return SensorSpec(model=model, accel_range_g=int(rng), sample_rate_hz=rate, gyro_range_dps=int(gyro),
                          magnetometer=mag, mag_samples=n_mag)

    def dwell(self, m, where, parent) -> Dwell:
        if not isinstance(m, dict):
            self.fail(parent, where.rsplit(".", 1)[-1], "expected a mapping with one of seconds, samples, sem_g", where)
        self.keys(m, where, {"seconds", "samples", "sem_g", "max_seconds"})
        given = [k for k in ("seconds", "samples", "sem_g") if k in m]
        if len(given) != 1:
            self.fail(parent, where.rsplit(".", 1)[-1],
                      f"give exactly one of seconds, samples, sem_g (got {', '.join(given) or 'none'})", where)
        if "seconds" in m:
            return Dwell(seconds=self.number(m, "seconds", f"{where}.seconds", positive=True, maximum=86400))
        if "samples" in m:
            return Dwell(samples=self.number(m, "samples", f"{where}.samples", positive=True, integer=True,
                                             minimum=2))
        if "max_seconds" not in m:
            self.fail(m, "sem_g", "a sem_g dwell needs max_seconds too (the cap)", f"{where}.max_seconds")
        return Dwell(sem_g=self.number(m, "sem_g", f"{where}.sem_g", positive=True),
                     max_seconds=self.number(m, "max_seconds", f"{where}.max_seconds", positive=True,
                                             maximum=86400))

    def settle(self, m, where, parent, base: Settle) -> Settle:
        if not isinstance(m, dict):
            self.fail(parent, where.rsplit(".", 1)[-1], "expected a mapping", where)
        allowed = {"window_s", "threshold_g", "mean_tol_sigma", "timeout_s", "min_s"}
        self.keys(m, where, allowed)
        vals = {k: self.number(m, k, f"{where}.{k}", positive=(k != "min_s"), minimum=0) for k in m}
        from dataclasses import replace
        return replace(base, **vals)

    def solve(self, m, parent) -> SolveSpec | None:
        if m is None:
            return None
        if not isinstance(m, dict):
            self.fail(parent, "solve", "expected a mapping (model, method, thermal) or null")
        self.keys(m, "solve", {"model", "method", "thermal", "magnetometer"})
        model = m.get("model", "triangular")
        if model not in MODELS:
            self.fail(m, "model", f"expected one of {', '.join(MODELS)}, got {model!r}", "solve.model")
        method = m.get("method", "pinv")
        if method not in METHODS:
            self.fail(m, "method", f"expected one of {', '.join(METHODS)}, got {method!r}", "solve.method")
        thermal = m.get("thermal", "auto")
        if thermal is False:
            thermal = "off"
        if not (thermal in ("auto", "off") or (isinstance(thermal, int) and not isinstance(thermal, bool)
                                               and 1 <= thermal <= 3)):
            self.fail(m, "thermal", f"expected auto, off or an order 1..3, got {thermal!r}", "solve.thermal")
        mag = m.get("magnetometer")
        if mag is not None and mag not in ("positions", "ellipsoid"):
            self.fail(m, "magnetometer", f"expected positions or ellipsoid, got {mag!r}", "solve.magnetometer")
        return SolveSpec(model=model, method=method, thermal=thermal, magnetometer=mag)

    def steps(self, items, where, dwell, settle, out, prefix, depth):
        if depth > 4:
            self.fail(items, None, "repeats nested too deeply (at most 4)", where)
        for i, item in enumerate(items):
            w = f"{where}[{i}]"
            if not isinstance(item, dict):
                self.fail(items, i, "expected a mapping: a pose, angles_deg, repeat, temperature or prompt step", w)
            kinds = [k for k in ("pose", "angles_deg", "repeat", "temperature", "prompt", "rate") if k in item]
            if "rate" in kinds and len(kinds) == 2 and ("pose" in kinds or "angles_deg" in kinds):
                kinds = ["rate"]  # a rate step may give the pose it spins from
            if len(kinds) != 1:
                self.fail(items, i, "each step needs exactly one of pose, angles_deg, repeat, temperature, prompt, rate"
                          + (f" (got {', '.join(kinds)})" if kinds else ""), w)
            kind = kinds[0]
            line = self.loc.line_of(items, i)
            if kind == "repeat":
                self.keys(item, w, {"repeat", "steps"}, required={"steps"})
                n = self.number(item, "repeat", f"{w}.repeat", positive=True, integer=True, maximum=1000)
                if not isinstance(item["steps"], list) or not item["steps"]:
                    self.fail(item, "steps", "expected a non-empty list of steps", f"{w}.steps")
                for r in range(n):
                    self.steps(item["steps"], f"{w}.steps", dwell, settle, out, f"{prefix}r{r + 1}/", depth + 1)
                continue
            if len(out) >= MAX_STEPS:
                self.fail(items, i, f"more than {MAX_STEPS} steps after expanding repeats", w)
            if kind == "temperature":
                self.keys(item, w, {"temperature", "name"})
                t = item["temperature"]
                tw = f"{w}.temperature"
                if not isinstance(t, dict):
                    self.fail(item, "temperature", "expected a mapping with target_c (tolerance_c, hold_s, timeout_s, mode)", tw)
                self.keys(t, tw, {"target_c", "tolerance_c", "hold_s", "timeout_s", "mode"}, required={"target_c"})
                target = TemperatureTarget(
                    target_c=self.number(t, "target_c", f"{tw}.target_c", minimum=-40, maximum=85),
                    tolerance_c=self.number(t, "tolerance_c", f"{tw}.tolerance_c", positive=True) if "tolerance_c" in t else 0.3,
                    hold_s=self.number(t, "hold_s", f"{tw}.hold_s", minimum=0) if "hold_s" in t else 60.0,
                    timeout_s=self.number(t, "timeout_s", f"{tw}.timeout_s", positive=True) if "timeout_s" in t else 3600.0,
                    mode=t.get("mode", "wait"))
                if target.mode not in ("wait", "operator"):
                    self.fail(t, "mode", f"expected wait or operator, got {target.mode!r}", f"{tw}.mode")
                nm = item.get("name") or f"{prefix}temperature {target.target_c:g} C"
                out.append(PlannedStep(len(out), str(nm), "thermal", temperature=target, source_line=line))
                continue
            if kind == "rate":
                self.rate_step(item, w, line, dwell, out, prefix)
                continue
            if kind == "prompt":
                self.keys(item, w, {"prompt", "name"})
                text = self.string(item, "prompt", f"{w}.prompt")
                out.append(PlannedStep(len(out), str(item.get("name") or f"{prefix}prompt"), "prompt", prompt=text,
                                       source_line=line))
                continue
            self.keys(item, w, {"pose", "angles_deg", "a1_deg", "name", "dwell", "settle"})
            if kind == "pose":
                pose = item["pose"]
                if pose not in POSE_NAMES:
                    self.fail(item, "pose", f"unknown pose {pose!r} (allowed: {', '.join(POSE_NAMES[:6])}, "
                              "or any cube direction such as '+X+Y up', '-X+Y+Z up')", f"{w}.pose")
                a1 = self.number(item, "a1_deg", f"{w}.a1_deg", minimum=-3600, maximum=3600) if "a1_deg" in item else 0.0
                angles = tuple(float(x) for x in pose_angles_deg(pose, a1))
                nm = item.get("name") or (pose if a1 == 0 else f"{pose} a1={a1:g}")
            else:
                if "a1_deg" in item:
                    self.fail(item, "a1_deg", "a1_deg goes with pose; angles_deg already gives a1", f"{w}.a1_deg")
                ang = item["angles_deg"]
                if not (isinstance(ang, list) and len(ang) == 3):
                    self.fail(item, "angles_deg", "expected [a1, a2, a3] in degrees", f"{w}.angles_deg")
                for j in range(3):
                    self.number(ang, j, f"{w}.angles_deg[{j}]", minimum=-3600, maximum=3600)
                angles = tuple(float(x) for x in ang)
                nm = item.get("name") or f"angles {angles[0]:g}/{angles[1]:g}/{angles[2]:g}"
            d = self.dwell(item["dwell"], f"{w}.dwell", item) if "dwell" in item else dwell
            s = self.settle(item["settle"], f"{w}.settle", item, settle) if "settle" in item else settle
            f = tuple(float(x) for x in f_nominal(np.array(angles)))
            out.append(PlannedStep(len(out), f"{prefix}{nm}", "static", angles_deg=angles, f_nominal=f, dwell=d,
                                   settle=s, source_line=line))


    def rate_step(self, item, w, line, dwell, out, prefix) -> None:
        """``{rate: {axis: a1|a2|a3, rate_deg_s: R, seconds: S}, pose | angles_deg (optional), name}``."""
        self.keys(item, w, {"rate", "pose", "angles_deg", "a1_deg", "name"})
        r = item["rate"]
        rw = f"{w}.rate"
        if not isinstance(r, dict):
            self.fail(item, "rate", "expected a mapping {axis, rate_deg_s, seconds}", rw)
        self.keys(r, rw, {"axis", "rate_deg_s", "seconds", "spin_up_s"}, required={"axis", "rate_deg_s"})
        axis = r["axis"]
        if axis not in ("a1", "a2", "a3"):
            self.fail(r, "axis", f"expected a1, a2 or a3, got {axis!r}", f"{rw}.axis")
        rate = self.number(r, "rate_deg_s", f"{rw}.rate_deg_s")
        if rate == 0 or abs(rate) > RATE_MAX_DEG_S:
            self.fail(r, "rate_deg_s", f"expected a non-zero rate within the 8MR191's limit of +-{RATE_MAX_DEG_S:g} "
                      f"deg/s, got {rate:g}", f"{rw}.rate_deg_s")
        seconds = self.number(r, "seconds", f"{rw}.seconds", positive=True, maximum=3600) if "seconds" in r \
            else (dwell.seconds or 10.0)
        spin_up = self.number(r, "spin_up_s", f"{rw}.spin_up_s", minimum=0, maximum=60) if "spin_up_s" in r else 0.5
        if "pose" in item:
            pose = item["pose"]
            if pose not in POSE_NAMES:
                self.fail(item, "pose", f"unknown pose {pose!r}", f"{w}.pose")
            a1 = self.number(item, "a1_deg", f"{w}.a1_deg", minimum=-3600, maximum=3600) if "a1_deg" in item else 0.0
            angles = tuple(float(x) for x in pose_angles_deg(pose, a1))
        elif "angles_deg" in item:
            ang = item["angles_deg"]
            if not (isinstance(ang, list) and len(ang) == 3):
                self.fail(item, "angles_deg", "expected [a1, a2, a3] in degrees", f"{w}.angles_deg")
            angles = tuple(float(self.number(ang, j, f"{w}.angles_deg[{j}]", minimum=-3600, maximum=3600))
                           for j in range(3))
        else:
            angles = (0.0, 0.0, 0.0)
        w_body = body_rate_dps(angles, axis, rate)
        nm = item.get("name") or f"{axis} {rate:+g} deg/s"
        out.append(PlannedStep(len(out), f"{prefix}{nm}", "rate", angles_deg=angles, f_nominal=None,
                               dwell=Dwell(seconds=seconds), settle=Settle(min_s=spin_up),
                               source_line=line, rate_axis=axis, rate_deg_s=float(rate),
                               rate_nominal_dps=tuple(float(x) for x in w_body)))


RATE_MAX_DEG_S = 48.0  # 8MR191: 4800 full steps/s at 0.01 deg/step (docs/turntable.md)


def body_rate_dps(angles_deg, axis: str, rate_deg_s: float) -> np.ndarray:
    """Angular rate in the sensor frame (deg/s) when stage ``axis`` turns at ``rate_deg_s`` from ``angles_deg``.

    ``R = Rz(a1) Rx(a2) Ry(a3)``: a1 turns about Ry^T Rx^T e_z, a2 about Ry^T e_x, a3 about e_y
    (docs/kinematics.md); the other two axes hold still, so the body rate is constant.
    """
    from rig.planning.kinematics import rot_x, rot_y
    a = np.radians(np.asarray(angles_deg, float))
    rx, ry = rot_x(a[1:2])[0], rot_y(a[2:3])[0]
    e = {"a1": ry.T @ rx.T @ np.array([0.0, 0.0, 1.0]), "a2": ry.T @ np.array([1.0, 0.0, 0.0]),
         "a3": np.array([0.0, 1.0, 0.0])}[axis]
    return e * rate_deg_s


def _join(where: str, key) -> str:
    return f"{where}.{key}" if where else str(key)
