"""Procedures (``rig-procedure/1``): what a technician runs, declared in YAML.

See docs/procedures.md. Loading validates everything up front: unknown keys,
wrong types, unknown poses, impossible dwell or sensor settings each give one
line ``file:line: key: what is allowed``, before anything moves.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import math
import re

import numpy as np

from drivers.sensors.base import SensorSettings
from drivers.sensors.chips import CHIPS
from calib.accel.predict import Predictor
from calib.accel.solve import check_poses
from calib.errors import CalibError
from rig.config.procedure_model import (ACCEL_RANGES_G, ADXL345_RATES_HZ, FORMAT, GYRO_RANGES_DPS, METHODS, AcceptSpec,
                                         MAX_STEPS, MIN_DWELL_SAMPLES, MODELS, RATE_MAX_DEG_S, STEPS_LIMIT,
                                         AnglesStep, Dwell, Mount,
                                         ProcedureDoc, PoseStep, RampStep, RateStep, RepeatStep, SensorSpec, Settle,
                                         SolveSpec, TargetSpec, TemperatureStep, TemperatureTarget, PromptStep)
from rig.config.validate import validate_document
from rig.config.yamlload import read_source
from rig.errors import RigInputError
from rig.planning.kinematics import f_nominal, rot_x, rot_y
from rig.planning.poses import pose_angles_deg
from rig.planning.targets import reorder_fastest, reorder_for_travel

MAX_REPEAT_DEPTH = 4
__all__ = ["ACCEL_RANGES_G", "ADXL345_RATES_HZ", "FORMAT", "GYRO_RANGES_DPS", "METHODS", "MODELS", "RATE_MAX_DEG_S",
           "Dwell", "PlannedStep", "Procedure", "SensorSpec", "Settle", "SolveSpec", "TargetSpec", "TemperatureTarget",
           "body_rate_dps", "load_procedure", "load_procedure_text"]


@dataclass(frozen=True)
class RampPlan:
    """A step's place in a thermal ramp: leg ``leg`` (1-based) ramps the chamber from ``from_c`` to
    ``to_c`` (C) at ``rate_c_per_min``; ``capture`` is 0 for the step that starts the ramp and 1 ..
    ``captures`` for the poses captured while it runs. ``from_given``: the procedure states ``from_c``
    (the set-point starts there); otherwise the ramp starts wherever the previous step left the set-point."""

    leg: int
    from_c: float
    to_c: float
    rate_c_per_min: float
    capture: int
    captures: int
    from_given: bool = False

    @property
    def duration_s(self) -> float:
        """How long the chamber's set-point takes from ``from_c`` to ``to_c``, s."""
        return abs(self.to_c - self.from_c) / self.rate_c_per_min * 60.0

    def to_manifest(self) -> dict:
        return {"leg": self.leg, "from_c": self.from_c, "to_c": self.to_c, "rate_c_per_min": self.rate_c_per_min,
                "capture": self.capture, "captures": self.captures}


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
    #: static steps: "fixed" (the dwell: it states), or in a procedure with target: "target" (the target
    #: decides the dwell) or "given" (the step states its own dwell)
    dwell_rule: str = "fixed"
    #: steps of a thermal ramp (the step starting it, kind thermal, and its poses): where in the ramp
    ramp: RampPlan | None = None
    #: in a procedure whose prompts turn the sensor in its fixture (``mount:``): a prompt's turn, and every other
    #: step's mounting in force (the reference, ``x+z+``, before the first such prompt); None in other procedures
    mount: Mount | None = None

    @property
    def executor(self) -> str:
        """The key of the executor that runs this step (``rig.execution.executors.EXECUTORS``): its
        kind, ``targeted`` for every pose of a procedure with an accuracy target, ``ramp`` for the steps
        of a thermal ramp."""
        if self.ramp is not None:
            return "ramp"
        return "targeted" if self.dwell_rule in ("target", "given") else self.kind

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
        if self.ramp is not None:
            d["ramp"] = self.ramp.to_manifest()
        if self.mount is not None:
            d["mount"] = self.mount.to_manifest()
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
    target: TargetSpec | None = None
    accept: AcceptSpec | None = None  # acceptance limits (docs/procedures.md, ``accept:``)
    report: bool = False  # write SESSION/report.html at the end of the run

    def expanded_steps(self) -> list[PlannedStep]:
        return list(self.steps)

    def sensor_settings(self):
        return SensorSettings(accel_range_g=self.sensor.accel_range_g, sample_rate_hz=self.sensor.sample_rate_hz,
                              gyro_range_dps=self.sensor.gyro_range_dps)


def load_procedure(path) -> Procedure:
    """Load and validate a procedure file."""
    text = read_source(path, "procedure", "no such procedure file")
    return load_procedure_text(text, str(Path(path)))


def load_procedure_text(text: str, path: str = "<procedure>") -> Procedure:
    """Validate procedure YAML text (``path`` only names it in errors)."""
    try:
        doc, loc, spec = validate_document(ProcedureDoc, text, path,
                                           "expected a mapping with format, name, steps, ...")
        return _Expander(path, loc, spec).procedure(doc, text)
    except RigInputError as exc:
        if exc.key is None or not _STEP_INDEX.search(exc.key):
            raise
        raise type(exc)(exc.path, exc.line, counted_steps(exc.key), exc.message) from None


#: the key path of a top-level step: ``steps[4]`` at its start
_STEP_INDEX = re.compile(r"^steps\[(\d+)\]")


def counted_steps(key: str) -> str:
    """A key path with its step also named as people count it: ``steps[4].pose`` -> ``steps[4] (step 5).pose``
    (the progress line, the report and ``rig compare`` number steps from 1; the key path keeps the file's
    0-based list index). Only the procedure's own list is counted: a repeat's or a ramp's steps keep their
    index (``steps[2] (step 3).steps[0]``: the first of step 3's steps)."""
    return _STEP_INDEX.sub(lambda m: f"{m.group(0)} (step {int(m.group(1)) + 1})", key, count=1)


class _Expander:
    """Validated document -> ``PlannedStep`` list (repeats expanded), with the checks that need the
    whole procedure: dwell long enough for two samples, settle window within its timeout, the
    sensor able to do what the steps ask. ``doc`` is walked beside the models for line numbers."""

    def __init__(self, path: str, loc, spec: ProcedureDoc) -> None:
        self.path, self.loc, self.spec = path, loc, spec
        self.sensor = spec.sensor or SensorSpec()
        self.out: list[PlannedStep] = []
        self.last_temp_c: float | None = None  # where the last temperature or ramp step left the chamber
        self.ramps = 0

    def fail(self, container, key, where, message):
        raise RigInputError(self.path, self.loc.line_of(container, key), where, message)

    def procedure(self, doc: dict, text: str) -> Procedure:
        spec = self.spec
        self.check_dwell(spec.dwell, doc, "dwell", "dwell")
        self.check_settle(spec.settle, doc, "settle", "settle")
        self.steps(spec.steps, doc["steps"], "steps", prefix="", depth=0)
        steps = with_mountings(self.out)
        if spec.order != "as_written" and self.ramps:
            self.fail(doc, "order", "order", f"order: {spec.order} would regroup the poses a ramp cycles (temperature "
                      "would follow the pose); list a ramp's poses in the order to cycle them and use as_written")
        if spec.order in ("shortest", "fastest"):
            reorder = reorder_for_travel if spec.order == "shortest" else reorder_fastest
            steps = [replace(s, index=i) for i, s in enumerate(reorder(steps))]
        if any(s.kind == "thermal" for s in steps) and self.sensor.model is not None and \
                not CHIPS[self.sensor.model].has_temperature:
            self.fail(doc, "sensor", "sensor",
                      f"temperature steps need the sensor's thermometer; the {self.sensor.model} has none")
        if not any(s.kind == "static" for s in steps):
            self.fail(doc, "steps", "steps", "no pose step: nothing to capture")
        if spec.target is not None:
            self.check_target(spec, doc, steps)
        self.check_solve_poses(spec, doc, steps)
        return Procedure(name=spec.name, description=spec.description or "", path=self.path, sensor=self.sensor,
                         dwell=spec.dwell, settle=spec.settle, order=spec.order, steps=tuple(steps),
                         solve=spec.solve, text=text, target=spec.target, accept=spec.accept,
                         report=bool(spec.report))

    def check_target(self, spec: ProcedureDoc, doc: dict, steps: list) -> None:
        """A target needs pose steps only, a pinv solve of the static model, parameters that model
        has, and poses that determine it (all refused here, before anything moves)."""
        if "dwell" in doc:
            self.fail(doc, "dwell", "dwell", "dwell: and target: exclude each other: the target decides how long to "
                      "dwell at each pose (a step may still give its own dwell)")
        other = [s for s in steps if s.kind != "static"]
        if other:
            raise RigInputError(self.path, other[0].source_line, f"steps: {other[0].name}",
                                f"a procedure with target: has pose steps only (the dwell is planned across "
                                f"them); this is a {other[0].kind} step")
        solve = spec.solve
        if solve is None or solve.method != "pinv" or solve.thermal not in ("auto", "off"):
            got = "solve: null" if solve is None else f"method {solve.method}, thermal {solve.thermal}"
            self.fail(doc, "target", "target", "the target is predicted for the pinv solve of the static model: "
                      f"needs solve: {{method: pinv, thermal: auto or off}}, got {got}")
        try:
            goal = spec.target.goal(solve.model)
        except CalibError as exc:
            self.fail(doc["target"], "sigma", "target.sigma", str(exc))
        f = np.array([s.f_nominal for s in steps], float)
        try:
            Predictor(goal, 1.0).covariances(f, np.ones_like(f))
        except CalibError as exc:
            self.fail(doc, "steps", "steps", f"{exc}: a target needs poses that determine every parameter")

    def check_solve_poses(self, spec: ProcedureDoc, doc: dict, steps: list) -> None:
        """A procedure whose ``solve:`` trusts the poses (pinv, combinations, flip) and whose poses cannot determine
        the static model is refused here, before anything moves (it used to run to its end and fail in the
        solve, after every pose and every chamber wait)."""
        solve = spec.solve
        poses = [s.f_nominal for s in steps if s.kind == "static" and s.f_nominal is not None]
        if solve is None or solve.method not in ("pinv", "combinations", "flip") or not poses:
            return
        try:
            check_poses(np.array(poses, float), solve.model, solve.method)
        except CalibError as exc:
            self.fail(doc, "solve", "solve", f"{exc}: these poses cannot calibrate the {solve.model} model; add "
                      "poses (the six faces determine it) or drop solve:")

    def check_dwell(self, dwell: Dwell, container, key, where) -> None:
        rate = self.sensor.sample_rate_hz
        longest = dwell.max_duration_s(rate)
        if longest is not None and longest * rate < MIN_DWELL_SAMPLES:
            self.fail(container, key, where, f"a dwell of {longest:g} s at {rate:g} Hz gives fewer than "
                      f"{MIN_DWELL_SAMPLES} samples")

    def check_settle(self, settle: Settle, container, key, where) -> None:
        if settle.window_s > settle.timeout_s:
            self.fail(container, key, where, f"window_s {settle.window_s:g} s is longer than timeout_s "
                      f"{settle.timeout_s:g} s: the table could never be judged still")

    def steps(self, models, items: list, where: str, prefix: str, depth: int) -> None:
        if depth > MAX_REPEAT_DEPTH:
            self.fail(items, None, where, f"repeats nested too deeply (at most {MAX_REPEAT_DEPTH})")
        for i, (model, item) in enumerate(zip(models, items)):
            w, line = f"{where}[{i}]", self.loc.line_of(items, i)
            if isinstance(model, RepeatStep):
                for r in range(model.repeat):
                    self.steps(model.steps, item["steps"], f"{w}.steps", f"{prefix}r{r + 1}/", depth + 1)
                continue
            if len(self.out) >= MAX_STEPS:
                self.fail(items, i, w, f"more than {MAX_STEPS} steps: {STEPS_LIMIT}")
            if isinstance(model, TemperatureStep):
                t = model.temperature
                self.add(model.name or f"{prefix}temperature {t.target_c:g} C", "thermal", line, temperature=t)
                self.last_temp_c = float(t.target_c)
            elif isinstance(model, RampStep):
                self.ramp_step(model, item, w, line, prefix)
            elif isinstance(model, PromptStep):
                self.add(model.name or f"{prefix}prompt", "prompt", line, prompt=model.prompt, mount=model.mount)
            elif isinstance(model, RateStep):
                self.rate_step(model, item, w, line, prefix)
            else:
                self.static_step(model, item, w, line, prefix)

    def add(self, name: str, kind: str, line, **fields) -> None:
        self.out.append(PlannedStep(len(self.out), str(name), kind, source_line=line, **fields))

    def ramp_step(self, model: RampStep, item: dict, w: str, line, prefix: str) -> None:
        """``{ramp: {to_c, rate_c_per_min, from_c, cycles, move_settle_s}, steps: [poses], name}``: a step that
        starts the chamber's ramp, then the poses cycled ``cycles`` times (default: as many cycles as the
        ramp's duration fills, each pose taking its dwell plus ``move_settle_s``)."""
        r, items = model.ramp, item["steps"]
        from_c = r.from_c if r.from_c is not None else self.last_temp_c
        if from_c is None:
            self.fail(item, "ramp", f"{w}.ramp", "a ramp needs a temperature to start from: put a temperature step "
                      "before it or give from_c")
        if from_c == r.to_c:
            self.fail(item["ramp"], "to_c", f"{w}.ramp.to_c", f"the ramp starts at {from_c:g} C (from_c or the "
                      f"previous temperature step): to_c {r.to_c:g} C leaves nothing to ramp")
        for i, sub in enumerate(model.steps):
            if not isinstance(sub, (PoseStep, AnglesStep)):
                self.fail(items, i, f"{w}.steps[{i}]", "a ramp cycles pose steps (pose or angles_deg) only")
        rate = self.sensor.sample_rate_hz
        cycle_s = sum((sub.dwell or self.spec.dwell).max_duration_s(rate) + r.move_settle_s for sub in model.steps)
        duration_s = abs(r.to_c - from_c) / r.rate_c_per_min * 60.0
        cycles = r.cycles if r.cycles is not None else max(1, math.ceil(duration_s / cycle_s))
        if len(self.out) + 1 + cycles * len(model.steps) > MAX_STEPS:
            self.fail(item, "ramp", f"{w}.ramp", f"more than {MAX_STEPS} steps with the ramp's {cycles} cycles: "
                      + STEPS_LIMIT)
        self.ramps += 1
        plan = RampPlan(self.ramps, float(from_c), float(r.to_c), float(r.rate_c_per_min), 0, cycles * len(model.steps),
                        from_given=r.from_c is not None)
        self.add(model.name or f"{prefix}ramp {from_c:g} -> {r.to_c:g} C at {r.rate_c_per_min:g} C/min", "thermal",
                 line, temperature=TemperatureTarget(target_c=r.to_c), ramp=plan)
        for c in range(cycles):
            for i, (sub, sub_item) in enumerate(zip(model.steps, items)):
                self.static_step(sub, sub_item, f"{w}.steps[{i}]", self.loc.line_of(items, i),
                                 f"{prefix}ramp{self.ramps} c{c + 1}/",
                                 ramp=replace(plan, capture=c * len(model.steps) + i + 1))
        self.last_temp_c = float(r.to_c)

    def static_step(self, model, item: dict, w: str, line, prefix: str, ramp: RampPlan | None = None) -> None:
        if isinstance(model, AnglesStep):
            angles = tuple(float(x) for x in model.angles_deg)
            nm = model.name or f"angles {angles[0]:g}/{angles[1]:g}/{angles[2]:g}"
        else:
            angles = tuple(float(x) for x in pose_angles_deg(model.pose, model.a1_deg))
            nm = model.name or (model.pose if model.a1_deg == 0 else f"{model.pose} a1={model.a1_deg:g}")
        dwell = self.spec.dwell
        if model.dwell is not None:
            dwell = model.dwell
            self.check_dwell(dwell, item, "dwell", f"{w}.dwell")
        settle = self.spec.settle
        if model.settle is not None:
            settle = settle.model_copy(update={k: getattr(model.settle, k) for k in item["settle"]})
            self.check_settle(settle, item, "settle", f"{w}.settle")
        f = tuple(float(x) for x in f_nominal(np.array(angles)))
        rule = "fixed" if self.spec.target is None else "given"
        if self.spec.target is not None and model.dwell is None:  # the target decides, within its time cap
            rule, dwell = "target", Dwell(seconds=self.spec.target.max_seconds)
        self.add(f"{prefix}{nm}", "static", line, angles_deg=angles, f_nominal=f, dwell=dwell, settle=settle,
                 dwell_rule=rule, ramp=ramp)

    def rate_step(self, model: RateStep, item: dict, w: str, line, prefix: str) -> None:
        """``{rate: {axis, rate_deg_s, seconds, spin_up_s}, pose | angles_deg (optional), name}``."""
        r = model.rate
        seconds = r.seconds if r.seconds is not None else (self.spec.dwell.seconds or 10.0)
        if r.seconds is not None:
            self.check_dwell(Dwell(seconds=seconds), item["rate"], "seconds", f"{w}.rate.seconds")
        if model.pose is not None:
            angles = tuple(float(x) for x in pose_angles_deg(model.pose, model.a1_deg))
        elif model.angles_deg is not None:
            angles = tuple(float(x) for x in model.angles_deg)
        else:
            angles = (0.0, 0.0, 0.0)
        w_body = body_rate_dps(angles, r.axis, r.rate_deg_s)
        nm = model.name or f"{r.axis} {r.rate_deg_s:+g} deg/s"
        self.add(f"{prefix}{nm}", "rate", line, angles_deg=angles, f_nominal=None, dwell=Dwell(seconds=seconds),
                 settle=Settle(min_s=r.spin_up_s), rate_axis=r.axis, rate_deg_s=float(r.rate_deg_s),
                 rate_nominal_dps=tuple(float(x) for x in w_body))


def with_mountings(steps: list[PlannedStep]) -> list[PlannedStep]:
    """``steps`` with each one's mounting in force, when a prompt turns the sensor in its fixture (``mount:``):
    the reference (``x+z+``, as placed) until the first such prompt, then the last prompt's turn. A step's
    ``f_nominal`` (and a rate step's ``rate_nominal_dps``) is then what the turned sensor feels, in its own frame
    (``Q^T f`` of the table's pose ``f``; its name and angles stay the table's). A procedure without ``mount:`` is
    returned as it is (its steps say nothing of the mounting)."""
    if not any(s.kind == "prompt" and s.mount is not None for s in steps):
        return list(steps)
    current, out = Mount.of(np.eye(3)), []
    for s in steps:
        if s.kind == "prompt":
            current = s.mount if s.mount is not None else current
            out.append(s)
            continue
        q = np.array(current.turn, float)
        turned = {k: tuple(float(x) for x in np.asarray(getattr(s, k), float) @ q)
                  for k in ("f_nominal", "rate_nominal_dps") if getattr(s, k) is not None}
        out.append(replace(s, mount=current, **turned))
    return out


def body_rate_dps(angles_deg, axis: str, rate_deg_s: float) -> np.ndarray:
    """Angular rate in the sensor frame (deg/s) when stage ``axis`` turns at ``rate_deg_s`` from ``angles_deg``.

    ``R = Rz(a1) Rx(a2) Ry(a3)``: a1 turns about Ry^T Rx^T e_z, a2 about Ry^T e_x, a3 about e_y
    (docs/kinematics.md); the other two axes hold still, so the body rate is constant.
    """
    a = np.radians(np.asarray(angles_deg, float))
    rx, ry = rot_x(a[1:2])[0], rot_y(a[2:3])[0]
    e = {"a1": ry.T @ rx.T @ np.array([0.0, 0.0, 1.0]), "a2": ry.T @ np.array([1.0, 0.0, 0.0]),
         "a3": np.array([0.0, 1.0, 0.0])}[axis]
    return e * rate_deg_s
