"""Adversarial campaign: generated bad inputs against every file-reading command and option, plus process faults.

    python benchmarks/bench_adversarial.py            # full campaign (~400 inputs, 24 signal trials, concurrency)
    python benchmarks/bench_adversarial.py --quick    # ~60 inputs, 3 signal trials, one concurrent resume
    python benchmarks/bench_adversarial.py --jobs 2 --seed 2026 --filter samples

Part 1, bad inputs. A table of mutators x targets (procedures for `rig run`, rig files for `--rig`, corrupted
copies of a real session for `rig solve/apply/evaluate/discover/replay`, mutated calibration files for
`rig apply/evaluate`, recordings for `rig import`, and command-line options), plus seeded random cell
mutations of samples.csv. Each input runs as `python -m rig.cli ...` in a subprocess with a timeout and is
classified:

- correct: the documented exit code (2 for bad input; 0 for valid-but-odd inputs such as a BOM or CRLF
  line endings, whose calibration must then equal the clean one), and for a refusal exactly one stderr line,
  naming the input, without "Traceback" or "internal error";
- traceback: "Traceback" or "internal error" on stderr;
- silent wrong result: exit 0 for an input that must be refused (or a valid input whose numbers differ from
  the clean run's, or a YAML tag that ran code);
- wrong exit code: anything else (1 for bad input, 2 for a valid input);
- bad message: the right exit code, but not one line, or a line that does not name the input;
- timeout: no answer within the timeout (a hang or a bomb).

A torn last line of samples.csv (no newline) is what a crash leaves, and a crash tears only the step in
progress: inside a *finished* step it means rows lost, and one line with exit 2 is the correct answer; in the
step in progress (an aborted session) the line is dropped with a warning and the rest solves.

Part 2, process faults. kill -9, SIGTERM and SIGINT at seeded random moments of
`rig run procedures/six_position.yaml --time-scale 4`, then `rig run --resume DIR`: every step recorded
exactly once (rows per step = the manifest's n_samples, t_s increasing within a step, each step's rows
contiguous), every step committed before the signal unchanged after the resume (else: data lost), the session
complete and its calibration within 5 sigma of an uninterrupted run of the same simulated sensor. Concurrent
resumes: two `rig run --resume DIR` at once on one interrupted session: exactly one proceeds, the other exits 1
with one line naming the holder's pid, and the session is intact. Two runs into one --out at once: distinct ids.

Prints the tally and every failure (input, command, exit code, first stderr line).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
DATASETS = REPO.parent / "shared" / "datasets"
SIX = REPO / "procedures" / "six_position.yaml"
PY = sys.executable
TIMEOUT_S = 60.0
SEED_SENSOR = 9

CATEGORIES = ("correct", "traceback", "wrong exit code", "silent wrong result", "bad message", "timeout",
              "data lost")


# ----------------------------------------------------------------------------------------------- running

def rig_env() -> dict:
    env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONWARNINGS="default")
    env.pop("RIG_DEBUG", None)
    env["RIG_HISTORY"] = str(Path(tempfile.gettempdir()) / "rig-adversarial-history.sqlite")
    return env


def rig(*args, timeout: float = TIMEOUT_S, stdin=subprocess.DEVNULL) -> tuple[int | None, str, str, float]:
    """Run ``python -m rig.cli ARGS``: (exit code or None on timeout, stdout, stderr, seconds)."""
    t0 = time.monotonic()
    try:
        p = subprocess.run([PY, "-m", "rig.cli", *map(str, args)], cwd=REPO, env=rig_env(), capture_output=True,
                           text=True, errors="replace", timeout=timeout, stdin=stdin)
        return p.returncode, p.stdout, p.stderr, time.monotonic() - t0
    except subprocess.TimeoutExpired as exc:
        def text(b):
            return b.decode("utf-8", "replace") if isinstance(b, bytes) else (b or "")
        return None, text(exc.stdout), text(exc.stderr), time.monotonic() - t0


def stderr_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


@dataclass
class Case:
    """One adversarial input: ``args`` for rig; ``expect`` 'refuse' (exit 2), 'valid' (exit 0, then ``check``),
    'refuse_or_warn' (exit 2 with one line, or exit 0 with a warning on stderr naming the problem),
    'warn' (exit 0 with a warning on stderr: valid input that lost something, e.g. a torn line of the step in
    progress)."""

    family: str
    name: str
    args: list
    expect: str = "refuse"
    hint: tuple = ()            # one of these must appear in the refusal line (the file, key or option)
    check: object = None        # valid inputs: callable(out_stdout) -> str | None (None: the numbers agree)
    post: object = None         # callable() -> str | None: a side effect that must not happen (e.g. a tag ran)
    timeout: float = TIMEOUT_S
    result: dict = field(default_factory=dict)

    def command(self) -> str:
        return "rig " + " ".join(_quote(a) for a in self.args)


def _quote(a) -> str:
    s = str(a)
    return s if s and all(c.isalnum() or c in "/._-=+:" for c in s) else "'" + s.replace("'", "'\\''") + "'"


def classify(case: Case, code, out: str, err: str) -> str:
    lines = stderr_lines(err)
    if "Traceback" in err or "internal error" in err:
        return "traceback"
    if code is None:
        return "timeout"
    if case.post is not None:
        why = case.post()
        if why:
            case.result["why"] = why
            return "silent wrong result"
    if case.expect == "valid":
        if code != 0:
            return "wrong exit code"
        if case.check is not None:
            why = case.check(out)
            if why:
                case.result["why"] = why
                return "silent wrong result"
        return "correct"
    if case.expect in ("refuse_or_warn", "warn") and code == 0:
        if any("warning" in line.lower() for line in lines):
            return "correct"
        return "silent wrong result"
    if case.expect == "warn":
        return "wrong exit code"
    if code == 0:
        return "silent wrong result"
    if code != 2:
        return "wrong exit code"
    if len(lines) != 1:
        case.result["why"] = f"{len(lines)} stderr lines"
        return "bad message"
    if case.hint and not any(h.lower() in lines[0].lower() for h in case.hint):
        case.result["why"] = f"does not name {' or '.join(case.hint)}"
        return "bad message"
    return "correct"


def run_case(case: Case) -> Case:
    code, out, err, dt = rig(*case.args, timeout=case.timeout)
    if code == 1 and ("No module named" in err or "ImportError" in err or "SyntaxError" in err):
        time.sleep(60)  # another engineer's half-saved file: the rig command is momentarily broken; retry once
        code, out, err, dt = rig(*case.args, timeout=case.timeout)
    case.result.update(code=code, first=(stderr_lines(err) or [""])[0][:300], seconds=dt,
                       lines=len(stderr_lines(err)))
    case.result["category"] = classify(case, code, out, err)
    return case


# ----------------------------------------------------------------------------------------------- fixtures

class Workspace:
    """A clean session and calibration of the simulated rig, and a place for the mutated copies."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.n = 0
        code, out, err, _ = rig("run", SIX, "--out", root / "clean", "--seed", SEED_SENSOR, "--time-scale", "0",
                                "--quiet", timeout=300)
        if code != 0:
            raise SystemExit(f"the clean run failed (exit {code}): {err.strip()[-500:]}")
        self.session = next((root / "clean").iterdir())
        self.calibration = self.session / "calibration.yaml"
        code, out, err, _ = rig("solve", self.session, "-o", root / "ref.yaml", timeout=300)
        if code != 0:
            raise SystemExit(f"the clean solve failed (exit {code}): {err.strip()[-500:]}")
        self.ref = yaml.safe_load((root / "ref.yaml").read_text())["accelerometer"]
        self.manifest_text = (self.session / "session.yaml").read_text()
        self.manifest = yaml.safe_load(self.manifest_text)
        self.samples = (self.session / "samples.csv").read_bytes()

    def path(self, stem: str, suffix: str = "") -> Path:
        self.n += 1
        p = self.root / "in" / f"{self.n:04d}-{stem}{suffix}"
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def session_copy(self, stem: str, manifest: str | bytes | None = None, samples: bytes | None = None) -> Path:
        d = self.path(stem)
        shutil.copytree(self.session, d, ignore=shutil.ignore_patterns("session.lock", "calibration.yaml"))
        if manifest is not None:
            (d / "session.yaml").write_bytes(manifest.encode() if isinstance(manifest, str) else manifest)
        if samples is not None:
            (d / "samples.csv").write_bytes(samples)
        return d

    def same_as_ref(self, cal_path: Path, sigmas: float = 0.0):
        """A check: the solved calibration equals the clean one (exactly, or within ``sigmas``)."""
        def check(_out: str) -> str | None:
            try:
                acc = yaml.safe_load(Path(cal_path).read_text())["accelerometer"]
            except Exception as exc:  # noqa: BLE001
                return f"no calibration written ({exc})"
            for key in ("bias_counts", "scale_counts_per_g"):
                for a, b, s in zip(acc[key], self.ref[key], self.ref["sigma"][key]):
                    tol = sigmas * s if sigmas else 1e-9 * max(1.0, abs(b))
                    if not abs(a - b) <= tol:
                        return f"{key} {a:.6g} != clean {b:.6g}"
            return None
        return check


# ----------------------------------------------------------------------------------------------- generic hostile files

def bomb_yaml() -> str:
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 10):
        prev = chr(ord("a") + i - 1)
        cur = chr(ord("a") + i)
        lines.append(f"{cur}: &{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    return "\n".join(lines) + "\n"


HOSTILE_YAML = {
    "billion-laughs alias bomb": lambda base: bomb_yaml() + base,
    "nesting 20000 levels": lambda base: base + "extra: " + "[" * 20000 + "]" * 20000 + "\n",
    "nesting 100 levels in a mapping": lambda base: base + "extra:" + "".join(
        "\n" + "  " * (i + 1) + f"k{i}:" for i in range(100)) + " 1\n",
    "400-digit integer": lambda base: base + "extra: " + "9" * 400 + "\n",
    "mapping used as a key": lambda base: base + "? {a: 1}\n: 2\n",
    "list used as a key": lambda base: base + "? [1, 2]\n: 2\n",
    "python object tag": lambda base: base + "extra: !!python/object/apply:os.system ['touch {marker}']\n",
    "custom tag": lambda base: base + "extra: !thing 3\n",
    "duplicate top-level key": lambda base: base + base.split("\n")[[i for i, l in enumerate(base.split("\n"))
                                                                      if l.startswith("format")][0]] + "\n",
    "truncated at 60%": lambda base: base[: int(len(base) * 0.6)],
    "top level is a list": lambda base: "- 1\n- 2\n",
    "top level is a scalar": lambda base: "just words\n",
    "empty file": lambda base: "",
    "only a document marker": lambda base: "---\n",
    "tab indentation": lambda base: base.replace("\n  ", "\n\t", 1),
    "unclosed flow mapping": lambda base: base + "extra: {a: 1\n",
    "multiple documents": lambda base: base + "---\n" + base,
}
HOSTILE_BYTES = {
    "binary garbage": lambda base: bytes(random.Random(7).randrange(256) for _ in range(4096)),
    "latin-1 bytes": lambda base: base.encode() + b"extra: caf\xe9\n",
    "NUL bytes": lambda base: base.encode() + b"\x00\x00\x00\n",
    "5 MiB file": lambda base: base.encode() + b"# " + b"x" * (5 * 1024 * 1024) + b"\n",
}


def hostile_files(ws: Workspace, stem: str, base: str, suffix: str = ".yaml") -> list[tuple[str, Path, object]]:
    """(mutation name, file, post-check) for every hostile YAML/bytes mutation of ``base``."""
    out = []
    for name, fn in HOSTILE_YAML.items():
        p = ws.path(f"{stem}-{name.replace(' ', '_')}", suffix)
        marker = ws.root / f"pwned-{p.stem}"
        p.write_text(fn(base).replace("{marker}", str(marker)))
        post = (lambda m=marker: f"the YAML tag ran code ({m} exists)" if m.exists() else None)
        out.append((name, p, post if "tag" in name else None))
    for name, fn in HOSTILE_BYTES.items():
        p = ws.path(f"{stem}-{name.replace(' ', '_')}", suffix)
        p.write_bytes(fn(base))
        out.append((name, p, None))
    loop = ws.path(f"{stem}-symlink_loop", suffix)
    os.symlink(loop, loop)
    out.append(("symlink loop", loop, None))
    d = ws.path(f"{stem}-a_directory", suffix)
    d.mkdir()
    out.append(("a directory", d, None))
    out.append(("missing file", ws.root / "in" / f"no-such-{stem}{suffix}", None))
    return out


def set_path(doc, path: str, value):
    """Set ``a.b[2].c`` in a nested mapping (creating mappings on the way)."""
    cur = doc
    parts = []
    for token in path.split("."):
        name, _, rest = token.partition("[")
        parts.append(name)
        for idx in ([int(x.rstrip("]")) for x in rest.split("[") if x] if rest else []):
            parts.append(idx)
    for p in parts[:-1]:
        cur = cur[p] if isinstance(p, int) else cur.setdefault(p, {})
    cur[parts[-1]] = value


def dump(doc) -> str:
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=1000)


#: values that no numeric field of a procedure or rig file accepts
BAD_NUMBERS = {
    "a word": "ten",
    "NaN": float("nan"),
    "infinity": float("inf"),
    "1e300": 1e300,
    "a list": [1, 2],
    "a mapping": {"a": 1},
}


# ----------------------------------------------------------------------------------------------- procedures

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


def procedure_cases(ws: Workspace) -> list[Case]:
    cases = []

    def add(name, path, expect="refuse", stdin_note=""):
        cases.append(Case("procedure", name, ["run", path, "--out", ws.root / "runs", "--time-scale", "0",
                                                "--quiet", "--seed", "3"], expect, hint=(path.name, "prompt")))

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
    dup = ws.path("proc-duplicate-dwell", ".yaml")
    dup.write_text(base.replace("dwell: {seconds: 10}", "dwell: {seconds: 10}\ndwell: {seconds: 1}"))
    add("duplicate key dwell", dup)
    dup2 = ws.path("proc-duplicate-inner", ".yaml")
    dup2.write_text(base.replace("dwell: {seconds: 10}", "dwell: {seconds: 10, seconds: 1}"))
    add("duplicate inner key dwell.seconds", dup2)
    for name, p, post in hostile_files(ws, "proc", base):
        cases.append(Case("procedure", name, ["run", p, "--out", ws.root / "runs", "--time-scale", "0", "--quiet"],
                          hint=(p.name,), post=post, timeout=30))
    return cases


# ----------------------------------------------------------------------------------------------- rig files

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


def rig_cases(ws: Workspace) -> list[Case]:
    cases = []

    def add(name, p, expect="refuse", post=None, timeout=TIMEOUT_S):
        cases.append(Case("rig file", name, ["run", SIX, "--rig", p, "--out", ws.root / "runs", "--time-scale", "0",
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
    return cases


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


# ----------------------------------------------------------------------------------------------- sessions

def csv_rows(data: bytes) -> tuple[str, list[list[str]]]:
    text = data.decode()
    lines = text.splitlines()
    return lines[0], [line.split(",") for line in lines[1:]]


def csv_bytes(header: str, rows: list[list[str]], nl: str = "\n") -> bytes:
    return (nl.join([header] + [",".join(r) for r in rows]) + nl).encode()


def samples_mutations(ws: Workspace) -> list[tuple[str, str, bytes]]:
    """(name, expect, new samples.csv)."""
    header, rows = csv_rows(ws.samples)
    cols = header.split(",")
    ci = {c: i for i, c in enumerate(cols)}
    n = len(rows)
    out = []

    def cell(name, col, value, row=1234, expect="refuse"):
        r = [list(x) for x in rows]
        r[row][ci[col]] = value
        out.append((name, expect, csv_bytes(header, r)))

    cell("NaN count in ax", "ax", "nan")
    cell("empty az cell", "az", "")
    cell("non-integer count 12.5", "ay", "12.5")
    cell("count 40000000 (beyond the +-4 g range)", "ax", "40000000")
    cell("count 1e19", "az", "1e19")
    cell("count -1e19", "ay", "-1e19")
    cell("count 32768 (beyond int16)", "ax", "32768")
    cell("count is a word", "ax", "abc")
    cell("count infinity", "ax", "inf")
    cell("gyro count NaN", "wx", "nan")
    cell("gyro count 1.5", "wy", "1.5")
    cell("gyro count 1e19", "wz", "1e19")
    cell("step index 1.5", "step", "1.5", row=1500)
    cell("step index 0.9", "step", "0.9", row=500)
    cell("step index 99", "step", "99")
    cell("step index -1", "step", "-1")
    cell("step index NaN", "step", "nan")
    cell("step index 1e19", "step", "1e19")
    cell("t_s NaN", "t_s", "nan")
    cell("t_s empty", "t_s", "")
    cell("temp_c 1e300", "temp_c", "1e300", expect="refuse_or_warn")
    cell("3 MB cell", "ax", "1" * (3 * 1024 * 1024))
    # truncations
    out.append(("truncated to the header", "refuse", (header + "\n").encode()))
    out.append(("empty samples.csv", "refuse", b""))
    out.append(("truncated at 50% on a row boundary", "refuse_or_warn", csv_bytes(header, rows[: n // 2])))
    body = csv_bytes(header, rows)
    # a crash tears only the step in progress: a torn line inside a finished step is rows lost (refused)
    out.append(("torn last line inside a finished step (rows lost)", "refuse", body[:-7]))
    out.append(("last step missing (rows of step 5 gone)", "refuse_or_warn",
                csv_bytes(header, [r for r in rows if r[ci["step"]] != "5"])))
    out.append(("step 2 duplicated (rows appended twice)", "refuse_or_warn",
                csv_bytes(header, rows + [r for r in rows if r[ci["step"]] == "2"])))
    out.append(("step 0 rows relabelled as step 1", "refuse_or_warn",
                csv_bytes(header, [[*r[:1], "1" if r[1] == "0" else r[1], *r[2:]] for r in rows])))
    # columns
    swapped = [[*r[:2], r[ci["ay"]], r[ci["ax"]], *r[4:]] for r in rows]
    out.append(("ax and ay data swapped (header unchanged)", "refuse", csv_bytes(header, swapped)))
    swapped_xz = [[r[ci["az"]] if i == ci["ax"] else r[ci["ax"]] if i == ci["az"] else x for i, x in enumerate(r)]
                  for r in rows]
    out.append(("ax and az data swapped (header unchanged)", "refuse", csv_bytes(header, swapped_xz)))
    flipped = [[str(-int(x)) if i == ci["az"] else x for i, x in enumerate(r)] for r in rows]
    out.append(("az sign flipped (another sensor frame)", "refuse", csv_bytes(header, flipped)))
    perm = [cols.index(c) for c in ("az", "t_s", "ay", "step", "ax")] + [i for i, c in enumerate(cols)
                                                                        if c not in ("az", "t_s", "ay", "step", "ax")]
    out.append(("columns reordered consistently", "valid",
                csv_bytes(",".join(cols[i] for i in perm), [[r[i] for i in perm] for r in rows])))
    out.append(("extra non-numeric column", "valid", csv_bytes(header + ",note", [r + ["hello"] for r in rows])))
    out.append(("quoted fields", "valid", csv_bytes(header, [[f'"{x}"' for x in r] for r in rows])))
    out.append(("UTF-8 BOM", "valid", b"\xef\xbb\xbf" + body))
    out.append(("CRLF line endings", "valid", csv_bytes(header, rows, "\r\n")))
    out.append(("BOM and CRLF", "valid", b"\xef\xbb\xbf" + csv_bytes(header, rows, "\r\n")))
    out.append(("blank lines between rows", "valid", body.replace(b"\n", b"\n\n", 50)))
    out.append(("duplicate column name", "refuse", csv_bytes(header.replace("wx", "ax"), rows)))
    out.append(("missing az column", "refuse", csv_bytes(",".join(c for c in cols if c != "az"),
                                                          [[x for i, x in enumerate(r) if i != ci["az"]] for r in rows])))
    out.append(("empty column name", "refuse", csv_bytes(header.replace("wz", ""), rows)))
    out.append(("ragged row (extra field)", "refuse",
                csv_bytes(header, [r + ["7"] if i == 77 else r for i, r in enumerate(rows)])))
    out.append(("ragged row (missing field)", "refuse",
                csv_bytes(header, [r[:-1] if i == 77 else r for i, r in enumerate(rows)])))
    out.append(("binary garbage in the middle", "refuse", body[:50000] + bytes(range(256)) * 8 + body[50000:]))
    out.append(("all binary garbage", "refuse", bytes(random.Random(3).randrange(256) for _ in range(20000))))
    out.append(("unterminated quote", "refuse", body[:80000] + b'"' + body[80000:]))
    return out


def manifest_mutations(ws: Workspace) -> list[tuple[str, str, str | bytes]]:
    """(name, expect, new session.yaml)."""
    out = []

    def mod(name, fn, expect="refuse"):
        doc = yaml.safe_load(ws.manifest_text)
        fn(doc)
        out.append((name, expect, dump(doc)))

    def setp(path, value):
        return lambda d: set_path(d, path, value)

    mod("format rig-session/2", setp("format", "rig-session/2"))
    mod("status bogus", setp("status", "finished-ish"))
    mod("step status bogus", setp("steps[0].status", "done"))
    mod("f_nominal a word", setp("steps[0].f_nominal", "up"))
    mod("f_nominal two numbers", setp("steps[0].f_nominal", [0, 0]))
    mod("f_nominal NaN", setp("steps[0].f_nominal", [float("nan"), 0, 1]))
    mod("f_nominal 5 g", setp("steps[0].f_nominal", [0, 0, 5]))
    mod("f_nominal of +Z and -Z swapped (contradicts the data, solve only)",
        lambda d: (set_path(d, "steps[0].f_nominal", [0, 0, -1]), set_path(d, "steps[2].f_nominal", [0, 0, 1])),
        expect="refuse_or_warn")
    mod("step index 1.5", setp("steps[1].index", 1.5))
    mod("step index 99", setp("steps[1].index", 99))
    mod("step index a word", setp("steps[1].index", "one"))
    mod("two steps with index 0", setp("steps[1].index", 0))
    mod("no steps", setp("steps", []))
    mod("last step removed", lambda d: d["steps"].pop())
    mod("steps a mapping", setp("steps", {"a": 1}))
    mod("accel_lsb_per_g 0", setp("rig.sensor.accel_lsb_per_g", 0))
    mod("accel_lsb_per_g negative", setp("rig.sensor.accel_lsb_per_g", -8192))
    mod("accel_lsb_per_g a word", setp("rig.sensor.accel_lsb_per_g", "lots"))
    mod("accel_lsb_per_g NaN", setp("rig.sensor.accel_lsb_per_g", float("nan")))
    mod("accel_lsb_per_g 1e300", setp("rig.sensor.accel_lsb_per_g", 1e300))
    mod("accel_range_g 3", setp("rig.sensor.accel_range_g", 3))
    mod("sample_rate_hz -100", setp("rig.sensor.sample_rate_hz", -100))
    mod("n_samples -5", setp("steps[0].stats.n_samples", -5))
    mod("n_samples 1.5", setp("steps[0].stats.n_samples", 1.5))
    mod("n_samples a word", setp("steps[0].stats.n_samples", "many"))
    mod("n_samples 999999 (contradicts samples.csv)", setp("steps[0].stats.n_samples", 999999),
        expect="refuse_or_warn")
    mod("id with ..", setp("id", "../../evil"))
    mod("id with a slash", setp("id", "a/b"))
    mod("samples_committed_bytes -1", setp("samples_committed_bytes", -1))
    mod("samples_committed_bytes a word", setp("samples_committed_bytes", "all"))
    mod("columns a word", setp("columns", "t_s ax"))
    mod("seed a word", setp("seed", "lucky"))
    mod("rig a list", setp("rig", [1, 2]))
    mod("rig.sensor missing", lambda d: d["rig"].pop("sensor"))
    mod("procedure.text a bomb", setp("procedure.text", bomb_yaml()), expect="refuse_or_warn")
    mod("has_temperature a word", setp("rig.sensor.has_temperature", "perhaps"))
    text = ws.manifest_text
    out.append(("duplicate key status", "refuse", text + "status: complete\n"))
    out.append(("CRLF line endings", "valid", text.replace("\n", "\r\n")))
    out.append(("UTF-8 BOM", "valid", b"\xef\xbb\xbf" + text.encode()))
    for name, fn in HOSTILE_YAML.items():
        if name in ("python object tag", "nesting 100 levels in a mapping"):
            continue
        out.append((name, "refuse", fn(text)))
    for name, fn in HOSTILE_BYTES.items():
        out.append((name, "refuse", fn(text)))
    return out


def session_cases(ws: Workspace, rng: random.Random, quick: bool) -> list[Case]:
    cases = []
    cmds = ["solve", "apply", "evaluate", "discover", "replay"]

    def session_case(family, name, d, expect, cmd):
        out_cal = d.parent / f"{d.name}-{cmd}.yaml"
        args = {"solve": ["solve", d, "-o", out_cal],
                "apply": ["apply", ws.calibration, d, "-o", d.parent / f"{d.name}-applied.csv"],
                "evaluate": ["evaluate", ws.calibration, d],
                "discover": ["discover", d],
                "replay": ["replay", d, "--out", d.parent / f"{d.name}-replayed"]}[cmd]
        check = None
        if expect in ("valid", "warn_close") and cmd == "solve":
            check = ws.same_as_ref(out_cal, sigmas=1.0 if expect == "warn_close" else 0.0)
        if expect == "warn_close":
            expect = "refuse_or_warn" if cmd != "solve" else "valid"
        cases.append(Case(family, f"{name} [{cmd}]", args, expect, hint=(d.name, "f_nominal"), check=check))

    for k, (name, expect, data) in enumerate(samples_mutations(ws)):
        d = ws.session_copy(f"samples-{k}", samples=data)
        use = (["solve", cmds[1 + k % 4]] if k % 2 else [cmds[k % len(cmds)]]) if not quick else [cmds[k % len(cmds)]]
        if expect == "valid" or expect == "warn_close":
            use = ["solve", "apply"] if not quick else ["solve"]
        for cmd in use:
            if cmd == "replay" and expect != "refuse":
                continue
            session_case("samples.csv", name, d, expect, cmd)
    for k, (name, expect, data) in enumerate(manifest_mutations(ws)):
        d = ws.session_copy(f"manifest-{k}", manifest=data)
        use = [cmds[k % len(cmds)]]
        if expect == "valid" or "solve only" in name:
            use = ["solve"]
        for cmd in use:
            session_case("session.yaml", name, d, expect, cmd)
    # hypothesis-style: seeded random cells of samples.csv replaced by tokens that must be refused
    header, rows = csv_rows(ws.samples)
    cols = header.split(",")
    tokens = {"ax": ["nan", "1.25", "4e7", "-4e7", "1e19", "x", "", "0x10", "inf"],
              "ay": ["nan", "0.5", "9e18", "", "--1"], "az": ["NaN", "2.5", "1e308", "one"],
              "step": ["0.5", "6", "-2", "nan", "", "2.000001", "1e3"], "t_s": ["nan", "", "t"],
              "wx": ["nan", "0.1", "1e19"], "wy": ["1.5"], "wz": ["-0.5", "nan"]}
    n_random = 12 if quick else 24
    for k in range(n_random):
        col = rng.choice(sorted(tokens))
        tok = rng.choice(tokens[col])
        row = rng.randrange(len(rows))
        r = [list(x) for x in rows]
        r[row][cols.index(col)] = tok
        d = ws.session_copy(f"random-{k}", samples=csv_bytes(header, r))
        session_case("samples.csv (random)", f"row {row + 2} {col}={tok!r}", d, "refuse", rng.choice(cmds[:4]))
    # not a session at all
    for name, d in (("missing directory", ws.root / "in" / "no-such-session"),
                    ("a file, not a directory", ws.path("session-file", ".txt"))):
        if name.startswith("a file"):
            d.write_text("hello\n")
        for cmd in (cmds if name.startswith("missing") else ["solve", "replay"]):
            session_case("session dir", name, d, "refuse", cmd)
    d = ws.session_copy("no-manifest")
    (d / "session.yaml").unlink()
    for cmd in ("solve", "replay"):
        session_case("session dir", "session.yaml missing", d, "refuse", cmd)
    d = ws.session_copy("no-samples")
    (d / "samples.csv").unlink()
    for cmd in ("solve", "apply"):
        session_case("session dir", "samples.csv missing", d, "refuse", cmd)
    d = ws.session_copy("samples-loop")
    (d / "samples.csv").unlink()
    os.symlink(d / "samples.csv", d / "samples.csv")
    session_case("session dir", "samples.csv a symlink loop", d, "refuse", "solve")
    loop = ws.path("session-loop")
    os.symlink(loop, loop)
    for cmd in cmds:
        session_case("session dir", "session directory a symlink loop", loop, "refuse", cmd)
    d = ws.session_copy("manifest-loop")
    (d / "session.yaml").unlink()
    os.symlink(d / "session.yaml", d / "session.yaml")
    for cmd in ("solve", "replay"):
        session_case("session dir", "session.yaml a symlink loop", d, "refuse", cmd)
    d = torn_in_progress(ws)
    for cmd in ("solve", "apply"):
        session_case("samples.csv", "torn last line in the step in progress (aborted session)", d, "warn", cmd)
    return cases


def torn_in_progress(ws: Workspace) -> Path:
    """The session as a crash in its last step leaves it: status aborted, the last step pending (no stats),
    samples_committed_bytes at the end of the step before, and the last row torn."""
    doc = yaml.safe_load(ws.manifest_text)
    last = doc["steps"][-1]
    doc["status"] = "aborted"
    last["status"] = "pending"
    last.pop("stats", None)
    offset = 0
    for line in ws.samples.splitlines(keepends=True)[1:]:
        if line.split(b",")[1].strip() == str(last["index"]).encode():
            break
        offset += len(line)
    doc["samples_committed_bytes"] = len(ws.samples.splitlines(keepends=True)[0]) + offset
    return ws.session_copy("torn-in-progress", manifest=dump(doc), samples=ws.samples[:-7])


# ----------------------------------------------------------------------------------------------- calibration files

def calibration_cases(ws: Workspace, quick: bool) -> list[Case]:
    base = yaml.safe_load(ws.calibration.read_text())
    text = ws.calibration.read_text()
    muts = []

    def mod(name, path, value, expect="refuse"):
        doc = yaml.safe_load(text)
        set_path(doc, path, value)
        muts.append((name, expect, dump(doc)))

    a = "accelerometer."
    mod("format rig-calibration/7", "format", "rig-calibration/7")
    mod("bias a word", a + "bias_counts", "abc")
    mod("bias element a word", a + "bias_counts[1]", "abc")
    mod("bias element a numeric string", a + "bias_counts[1]", "1.0")
    mod("bias two numbers", a + "bias_counts", [1.0, 2.0])
    mod("bias NaN", a + "bias_counts[0]", float("nan"))
    mod("bias infinity", a + "bias_counts[2]", float("inf"))
    mod("scale zero", a + "scale_counts_per_g", [0, 0, 0])
    mod("scale a word", a + "scale_counts_per_g[0]", "big")
    mod("scale 1e300", a + "scale_counts_per_g[0]", 1e300)
    mod("matrix 2x2", a + "matrix_counts_per_g", [[1, 0], [0, 1]])
    mod("matrix ragged", a + "matrix_counts_per_g[1]", [0, 1])
    mod("matrix a word inside", a + "matrix_counts_per_g[0][1]", "x")
    mod("matrix singular", a + "matrix_counts_per_g", [[0, 0, 0], [0, 0, 0], [0, 0, 0]])
    mod("matrix disagrees with scale", a + "matrix_counts_per_g[0][0]", 9000.0)
    mod("misalignment contradicts the matrix", a + "misalignment.alpha_yz", 0.5)
    mod("misalignment a word", a + "misalignment.alpha_zx", "tilted")
    mod("misalignment_unit furlongs", a + "misalignment_unit", "furlongs")
    mod("lsb_per_g 0", a + "lsb_per_g", 0)
    mod("lsb_per_g a word", a + "lsb_per_g", "x")
    mod("lsb_per_g 16384 (another range)", a + "lsb_per_g", 16384.0)
    mod("model a word", a + "model", "wobbly")
    mod("sigma bias shape", a + "sigma.bias_counts", [1.0])
    mod("sigma negative", a + "sigma.bias_counts", [-1.0, 0.3, 0.3])
    mod("temperature a word", a + "temperature", "hot")
    mod("accelerometer null", "accelerometer", None)
    mod("accelerometer a list", "accelerometer", [1, 2, 3])
    mod("sensor model ADXL345", "sensor.model", "ADXL345")
    mod("unknown top-level key", "flavour", "vanilla")
    muts.append(("duplicate key accelerometer", "refuse", text + "accelerometer: null\n"))
    muts.append(("truncated at 50%", "refuse", text[: len(text) // 2]))
    for name, fn in HOSTILE_YAML.items():
        if name not in ("python object tag", "nesting 100 levels in a mapping"):
            muts.append((name, "refuse", fn(text)))
    for name, fn in HOSTILE_BYTES.items():
        muts.append((name, "refuse", fn(text)))
    muts.append(("CRLF line endings", "valid", text.replace("\n", "\r\n")))
    cases = []
    for k, (name, expect, data) in enumerate(muts):
        p = ws.path(f"cal-{k}", ".yaml")
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
        use = (("apply", "evaluate")[k % 2],)
        if name == "sensor model ADXL345" or name.startswith("lsb_per_g 16384"):
            use = ("evaluate",)
        for cmd in use:
            args = (["apply", p, ws.session, "-o", ws.root / "in" / f"{p.stem}-applied.csv"] if cmd == "apply"
                    else ["evaluate", p, ws.session])
            cases.append(Case("calibration", f"{name} [{cmd}]", args, expect, hint=(p.name,)))
    loop = ws.path("cal-loop", ".yaml")
    os.symlink(loop, loop)
    for cmd in ("apply", "evaluate", "export"):
        args = {"apply": ["apply", loop, ws.session, "-o", ws.root / "in" / "loop-applied.csv"],
                "evaluate": ["evaluate", loop, ws.session], "export": ["export", loop, "--to", "px4"]}[cmd]
        cases.append(Case("calibration", f"symlink loop [{cmd}]", args, hint=(loop.name,)))
    for cmd in ("apply", "evaluate", "export"):
        missing = ws.root / "in" / "no-such-calibration.yaml"
        args = {"apply": ["apply", missing, ws.session, "-o", ws.root / "x.csv"],
                "evaluate": ["evaluate", missing, ws.session],
                "export": ["export", missing, "--to", "px4"]}[cmd]
        cases.append(Case("calibration", f"missing file [{cmd}]", args, hint=(missing.name,)))
    bad = ws.path("cal-export", ".yaml")
    bad.write_text(dump({**base, "accelerometer": {**base["accelerometer"], "bias_counts": "abc"}}))
    for to in ("px4", "json"):
        cases.append(Case("calibration", f"bias a word [export --to {to}]", ["export", bad, "--to", to],
                          hint=(bad.name,)))
    return cases


# ----------------------------------------------------------------------------------------------- imports

def _imucal_rows(n=40, part_data=None) -> str:
    parts = {"x_p": (2048, 0, 0), "x_a": (-2048, 0, 0), "y_p": (0, 2048, 0), "y_a": (0, -2048, 0),
             "z_p": (0, 0, 2048), "z_a": (0, 0, -2048)}
    parts.update(part_data or {})
    lines = ["part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"]
    k = 0
    for part, (x, y, z) in parts.items():
        for i in range(n):
            lines.append(f"{part},{k},{x + i % 3}.0,{y - i % 2}.0,{z + i % 5}.0,1.0,0.0,-1.0")
            k += 1
    return "\n".join(lines) + "\n"


def _csv_rows(labels=(("+X up", (1, 0, 0)), ("-X up", (-1, 0, 0)), ("+Y up", (0, 1, 0)), ("-Y up", (0, -1, 0)),
                      ("+Z up", (0, 0, 1)), ("-Z up", (0, 0, -1))), n=50, units="g") -> str:
    rng = random.Random(1)
    lines = [f"# units: {units}", "t_s,ax,ay,az,temp_c,label"]
    t = 0.0
    for label, f in labels:
        for _ in range(n):
            v = [c * 1.01 + 0.02 + rng.gauss(0, 1e-3) for c in f]
            lines.append(f"{t:.3f},{v[0]:.6f},{v[1]:.6f},{v[2]:.6f},25.0,{label}")
            t += 0.01
    return "\n".join(lines) + "\n"


def _imu_tk_rows(n=3000) -> str:
    rng = random.Random(2)
    return "".join(f"{0.01 * i:.5f} {33100 + rng.randint(-5, 5)} {33300 + rng.randint(-5, 5)} "
                   f"{36430 + rng.randint(-5, 5)}\n" for i in range(n))


def _tofu_rows(n=600) -> str:
    head = "timestamp\timu.gyro.x\timu.gyro.y\timu.gyro.z\timu.acc.x\timu.acc.y\timu.acc.z\timu.status\timu.temperature"
    rows = [f"{1000000 + i * 500000}\t0.01\t0.0\t0.0\t0.17\t-0.1\t-9.6\t0\t{25 + i * 0.01:.3f}" for i in range(n)]
    return "\n".join([head] + rows) + "\n"


def import_cases(ws: Workspace) -> list[Case]:
    good = {"imucal": _imucal_rows(), "csv": _csv_rows(), "imu_tk": _imu_tk_rows(), "tofupilot": _tofu_rows()}
    muts: list[tuple[str, str, str, str | bytes, list]] = []  # (source, name, expect, content, extra args)
    for src, text in good.items():
        lines = text.splitlines(keepends=True)
        first_data = 2 if src == "csv" else (0 if src == "imu_tk" else 1)
        muts += [
            (src, "control: valid recording", "valid", text, []),
            (src, "empty file", "refuse", "", []),
            (src, "header only", "refuse", "".join(lines[:first_data]) or "\n", []),
            (src, "one data row", "refuse", "".join(lines[:first_data + 1]), []),
            (src, "binary garbage", "refuse", bytes(random.Random(5).randrange(256) for _ in range(3000)), []),
            (src, "text garbage", "refuse", "lorem ipsum dolor\nsit amet\n" * 20, []),
            (src, "a value of 1e300", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "1e300") + "".join(lines[first_data + 6:]), []),
            (src, "a NaN value", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "nan") + "".join(lines[first_data + 6:]), []),
            (src, "a word as a value", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "oops") + "".join(lines[first_data + 6:]), []),
            (src, "3 MB field", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "7" * (3 * 1024 * 1024)) + "".join(lines[first_data + 6:]),
             []),
            (src, "ragged row", "refuse", "".join(lines[:first_data + 5]) + lines[first_data + 5].rstrip("\n") +
             (",9\n" if src in ("csv", "imucal") else (" 9\n" if src == "imu_tk" else "\t9\n")) +
             "".join(lines[first_data + 6:]), []),
        ]
    muts += [
        ("imucal", "x_p rows read -1 g (mislabelled part)", "refuse",
         _imucal_rows(part_data={"x_p": (-2048, 0, 0)}), []),
        ("imucal", "unknown part q_p", "refuse", _imucal_rows().replace("y_a,", "q_p,"), []),
        ("csv", "+1 g rows labelled -Z up (mislabelled pose)", "refuse",
         _csv_rows(labels=(("+X up", (1, 0, 0)), ("-X up", (-1, 0, 0)), ("+Y up", (0, 1, 0)), ("-Y up", (0, -1, 0)),
                           ("+Z up", (0, 0, 1)), ("-Z up", (0, 0, 1)))), []),
        ("csv", "decreasing time stamps", "refuse", _csv_rows().replace("\n0.020,", "\n-5.0,"), []),
        ("csv", "counts without lsb_per_g", "refuse", _csv_rows(units="counts"), []),
        ("csv", "unknown units", "refuse", _csv_rows(units="furlongs"), []),
        ("csv", "no ax column", "refuse", _csv_rows().replace("t_s,ax,ay", "t_s,bx,ay"), []),
        ("csv", "--g 5", "refuse", _csv_rows(), ["--g", "5"]),
        ("csv", "--g nan", "refuse", _csv_rows(), ["--g", "nan"]),
        ("tofupilot", "--window-s -1", "refuse", _tofu_rows(), ["--window-s", "-1"]),
        ("tofupilot", "--window-s 0", "refuse", _tofu_rows(), ["--window-s", "0"]),
        ("tofupilot", "--window-s nan", "refuse", _tofu_rows(), ["--window-s", "nan"]),
        ("imu_tk", "decreasing time stamps", "refuse", _imu_tk_rows().replace("\n0.50000 ", "\n0.10000 "), []),
        ("csv", "--id ../escape", "refuse", _csv_rows(), ["--id", "../escape"]),
        ("csv", "--id a/b", "refuse", _csv_rows(), ["--id", "a/b"]),  # hint: "--id" or "id"
    ]
    if (DATASETS / "imu_tk-xsens" / "xsens_gyro.txt").exists():
        muts.append(("imu_tk", "gyro file imported as accelerometer data (then solved)", "gyro-as-accel",
                     (DATASETS / "imu_tk-xsens" / "xsens_gyro.txt").read_bytes(), []))
    cases = []
    for k, (src, name, expect, content, extra) in enumerate(muts):
        p = ws.path(f"import-{src}-{k}", ".txt" if src in ("imu_tk",) else ".csv")
        p.write_bytes(content if isinstance(content, bytes) else content.encode())
        out_dir = ws.root / "imports" / f"{k}"
        hint = (p.name,) if not extra else (p.name, extra[0], extra[0].lstrip("-") + ":")
        if expect == "gyro-as-accel":
            # refused at import (exit 2), or the solve that follows refuses: a calibration must not come out
            cases.append(_GyroAsAccel("import", f"{src}: {name}", ["import", "--from", src, p, "-o", out_dir,
                                                                      "--id", "g"], "valid", hint=hint,
                                      out_dir=out_dir))
            continue
        cases.append(Case("import", f"{src}: {name}", ["import", "--from", src, p, "-o", out_dir, *extra], expect,
                          hint=hint))
    p = ws.path("import-any", ".csv")
    p.write_text(_csv_rows())
    cases.append(Case("import", "--from bogus", ["import", "--from", "bogus", p], hint=("bogus", "--from")))
    cases.append(Case("import", "missing file", ["import", "--from", "csv", ws.root / "in" / "nope.csv"],
                      hint=("nope.csv",)))
    cases.append(Case("import", "a directory", ["import", "--from", "csv", ws.root / "in"], hint=("in",)))
    loop = ws.path("import-loop", ".csv")
    os.symlink(loop, loop)
    for src in ("csv", "imucal"):
        cases.append(Case("import", f"{src}: a symlink loop", ["import", "--from", src, loop, "-o",
                                                                ws.root / "imports" / "loop"], hint=(loop.name,)))
    return cases


@dataclass
class _GyroAsAccel(Case):
    out_dir: Path | None = None


def _replace_value(line: str, src: str, value: str) -> str:
    if src == "imu_tk":
        f = line.split()
        f[2] = value
        return " ".join(f) + "\n"
    sep = "\t" if src == "tofupilot" else ","
    f = line.rstrip("\n").split(sep)
    f[{"imucal": 3, "csv": 2, "tofupilot": 5}[src]] = value
    return sep.join(f) + "\n"


def run_gyro_as_accel(case: _GyroAsAccel) -> Case:
    code, out, err, dt = rig(*case.args, timeout=case.timeout)
    case.result.update(code=code, first=(stderr_lines(err) or [""])[0][:300], seconds=dt)
    if code == 2 and len(stderr_lines(err)) == 1 and "Traceback" not in err:
        case.result["category"] = "correct"
        return case
    if code != 0:
        case.result["category"] = classify(Case(case.family, case.name, case.args, "refuse"), code, out, err)
        return case
    code2, out2, err2, dt2 = rig("solve", case.out_dir / "g", "--method", "magnitude", "-o", case.out_dir / "g.yaml")
    case.args = case.args + ["&&", "rig", "solve", case.out_dir / "g", "--method", "magnitude"]
    case.result.update(code=code2, first=(stderr_lines(err2) or [""])[0][:300], seconds=dt + dt2)
    case.result["category"] = classify(Case(case.family, case.name, case.args, "refuse"), code2, out2, err2)
    if case.result["category"] == "silent wrong result":
        try:
            acc = yaml.safe_load((case.out_dir / "g.yaml").read_text())["accelerometer"]
            case.result["why"] = f"solved: scale {acc['scale_counts_per_g'][0]:.3g} counts/g"
        except Exception:  # noqa: BLE001
            pass
    return case


# ----------------------------------------------------------------------------------------------- options

def option_cases(ws: Workspace) -> list[Case]:
    s, cal, out = ws.session, ws.calibration, ws.root / "opt-runs"
    run = ["run", SIX, "--out", out, "--quiet"]
    junk_db = ws.path("history-junk", ".sqlite")
    junk_db.write_bytes(b"this is not a database\n" * 10)
    junk_hash = hashlib.sha256(junk_db.read_bytes()).hexdigest()
    t = [
        ("bare rig", [], "refuse", ("rig --help",)),
        ("unknown command", ["frobnicate"], "refuse", ("frobnicate",)),
        ("--seed -1", run + ["--seed", "-1"], "refuse", ("--seed",)),
        ("--seed a word", run + ["--seed", "nine"], "refuse", ("--seed",)),
        ("--seed 2**64", run + ["--seed", str(2 ** 64)], "refuse", ("--seed",)),
        ("--seed 1.5", run + ["--seed", "1.5"], "refuse", ("--seed",)),
        ("--time-scale -1", run + ["--time-scale", "-1"], "refuse", ("--time-scale",)),
        ("--time-scale nan", run + ["--time-scale", "nan"], "refuse", ("--time-scale",)),
        ("--time-scale inf", run + ["--time-scale", "inf"], "refuse", ("--time-scale",)),
        ("--time-scale a word", run + ["--time-scale", "fast"], "refuse", ("--time-scale",)),
        ("--time-scale 1e300", run + ["--time-scale", "1e300"], "refuse", ("--time-scale",)),
        ("--rig missing file", run + ["--rig", ws.root / "nope.yaml"], "refuse", ("nope.yaml",)),
        ("--resume missing dir", ["run", "--resume", ws.root / "nope"], "refuse", ("nope",)),
        ("run without a procedure", ["run"], "refuse", ("procedure", "rig --help")),
        ("run unknown option", run + ["--turbo"], "refuse", ("--turbo",)),
        ("sim --count 0", ["sim", "--count", "0", "--once"], "refuse", ("--count",)),
        ("sim --count -3", ["sim", "--count", "-3", "--once"], "refuse", ("--count",)),
        ("sim --count 100000", ["sim", "--count", "100000", "--once"], "refuse", ("--count",)),
        ("sim --count a word", ["sim", "--count", "three", "--once"], "refuse", ("--count",)),
        ("sim --time-scale -1", ["sim", "--time-scale", "-1", "--once"], "refuse", ("--time-scale",)),
        ("sim --time-scale nan", ["sim", "--time-scale", "nan", "--once"], "refuse", ("--time-scale",)),
        ("sim --seed -1", ["sim", "--seed", "-1", "--once"], "refuse", ("--seed",)),
        ("sim --sensor BMI160", ["sim", "--sensor", "BMI160", "--once"], "refuse", ("--sensor", "BMI160")),
        ("solve --thermal 1 with --method magnitude", ["solve", s, "-o", ws.root / "o1.yaml", "--method", "magnitude",
                                                       "--thermal", "1"], "refuse", ("--thermal", "magnitude")),
        ("solve --thermal auto with --method magnitude", ["solve", s, "-o", ws.root / "o2.yaml", "--method",
                                                          "magnitude", "--thermal", "auto"], "refuse_or_warn",
         ("--thermal", "magnitude")),
        ("solve --model full --method flip", ["solve", s, "-o", ws.root / "o3.yaml", "--model", "full", "--method",
                                              "flip"], "refuse", ("full", "flip")),
        ("solve --model wobbly", ["solve", s, "--model", "wobbly"], "refuse", ("--model",)),
        ("solve --method magic", ["solve", s, "--method", "magic"], "refuse", ("--method",)),
        ("solve --thermal 9", ["solve", s, "-o", ws.root / "o4.yaml", "--thermal", "9"], "refuse", ("--thermal",)),
        ("solve --thermal -1", ["solve", s, "-o", ws.root / "o5.yaml", "--thermal", "-1"], "refuse", ("--thermal",)),
        ("solve --thermal hot", ["solve", s, "-o", ws.root / "o6.yaml", "--thermal", "hot"], "refuse", ("--thermal",)),
        ("solve --thermal 1 on a 0.0 C span", ["solve", s, "-o", ws.root / "o7.yaml", "--thermal", "1"], "refuse",
         ("thermal", "temperature")),
        ("solve unknown option", ["solve", s, "--fast"], "refuse", ("--fast",)),
        ("apply without -o", ["apply", cal, s], "refuse", ("-o", "rig --help")),
        ("apply unknown option", ["apply", cal, s, "-o", ws.root / "a.csv", "--gain", "2"], "refuse", ("--gain",)),
        ("evaluate unknown option", ["evaluate", cal, s, "--verbose"], "refuse", ("--verbose",)),
        ("discover --false-alarm 2", ["discover", s, "--false-alarm", "2"], "refuse", ("--false-alarm",)),
        ("discover --false-alarm -1", ["discover", s, "--false-alarm", "-1"], "refuse", ("--false-alarm",)),
        ("discover --false-alarm nan", ["discover", s, "--false-alarm", "nan"], "refuse", ("--false-alarm",)),
        ("discover --false-alarm a word", ["discover", s, "--false-alarm", "rare"], "refuse", ("--false-alarm",)),
        ("replay unknown option", ["replay", s, "--faster"], "refuse", ("--faster",)),
        ("export --to bogus", ["export", cal, "--to", "bogus"], "refuse", ("--to", "bogus")),
        ("export without --to", ["export", cal], "refuse", ("--to", "rig --help")),
        ("import without --from", ["import", cal], "refuse", ("--from", "rig --help")),
        ("import --g a word", ["import", "--from", "csv", cal, "--g", "heavy"], "refuse", ("--g",)),
        ("history --history on a non-database", ["history", "--history", junk_db], "refuse", (junk_db.name,)),
        ("history unknown sensor", ["history", "no-such-sensor", "--history", ws.root / "h.sqlite"], "refuse",
         ("no-such-sensor", "h.sqlite")),
        ("history --record a missing session", ["history", "--history", ws.root / "h2.sqlite", "--record",
                                                ws.root / "nope"], "refuse", ("nope",)),
        ("ports unknown option", ["ports", "--all"], "refuse", ("--all",)),
        ("--version", ["--version"], "valid", ()),
    ]
    cases = []
    for name, args, expect, hint in t:
        post = None
        if "non-database" in name:
            post = (lambda: "the non-database file was modified"
                    if hashlib.sha256(junk_db.read_bytes()).hexdigest() != junk_hash else None)
        check = None
        if name == "--version":
            check = lambda out: None if out.startswith("rig ") else f"stdout {out[:40]!r}"
        cases.append(Case("option", name, args, expect, hint=hint, post=post, check=check, timeout=40))
    return cases


# ----------------------------------------------------------------------------------------------- process faults

def read_state(d: Path) -> dict:
    """Manifest steps and the rows of samples.csv per step (as raw lines), for data-loss and duplicate checks."""
    m = yaml.safe_load((d / "session.yaml").read_text())
    data = (d / "samples.csv").read_bytes()
    committed = m.get("samples_committed_bytes") or 0
    lines = data[:committed].decode().splitlines() if committed else data.decode().splitlines()
    header = lines[0].split(",") if lines else []
    rows: dict[int, list[str]] = {}
    order: list[int] = []
    for line in lines[1:]:
        if not line.strip():
            continue
        step = int(float(line.split(",")[header.index("step")]))
        if not order or order[-1] != step:
            order.append(step)
        rows.setdefault(step, []).append(line)
    return {"manifest": m, "rows": rows, "order": order, "header": header}


def check_session(d: Path, before: dict | None, ref: dict) -> tuple[str, str]:
    """(category, why) of a resumed session: data lost, a wrong/duplicated step, or correct."""
    st = read_state(d)
    m = st["manifest"]
    if before is not None:
        for step, lines in before["rows"].items():
            prev = next(s for s in before["manifest"]["steps"] if s["index"] == step)
            if prev["status"] != "complete":
                continue
            if st["rows"].get(step) != lines:
                return "data lost", f"committed step {step} changed or lost by the resume"
    if m["status"] != "complete":
        return "data lost", f"session status {m['status']} after the resume"
    ti = st["header"].index("t_s")
    for s in m["steps"]:
        if s["status"] != "complete":
            return "data lost", f"step {s['index']} {s['status']}"
        rows = st["rows"].get(s["index"], [])
        if len(rows) != s["stats"]["n_samples"]:
            return "silent wrong result", f"step {s['index']}: {len(rows)} rows, manifest n_samples {s['stats']['n_samples']}"
        t = [float(r.split(",")[ti]) for r in rows]
        if any(b <= a for a, b in zip(t, t[1:])):
            return "silent wrong result", f"step {s['index']}: t_s not increasing"
    if len(st["order"]) != len(set(st["order"])):
        return "silent wrong result", f"steps interleaved or duplicated in samples.csv: {st['order']}"
    size = (d / "samples.csv").stat().st_size
    if m.get("samples_committed_bytes") != size:
        return "silent wrong result", f"samples.csv has {size} bytes, manifest says {m.get('samples_committed_bytes')}"
    code, out, err, _ = rig("solve", d, "-o", d.parent / f"{d.name}-check.yaml", timeout=120)
    if code != 0:
        return "wrong exit code", f"solve of the resumed session: exit {code}: {(stderr_lines(err) or [''])[0]}"
    acc = yaml.safe_load((d.parent / f"{d.name}-check.yaml").read_text())["accelerometer"]
    for key in ("bias_counts", "scale_counts_per_g"):
        for a, b, sa, sb in zip(acc[key], ref[key], acc["sigma"][key], ref["sigma"][key]):
            if abs(a - b) > 5 * math.hypot(sa, sb):
                return "silent wrong result", f"{key} {a:.2f} vs uninterrupted {b:.2f} (> 5 sigma)"
    return "correct", ""


def start_run(out: Path, time_scale: str = "4", resume: Path | None = None) -> subprocess.Popen:
    args = ["run", "--resume", resume, "--time-scale", time_scale, "--quiet"] if resume else \
        ["run", SIX, "--out", out, "--seed", SEED_SENSOR, "--time-scale", time_scale, "--quiet"]
    return subprocess.Popen([PY, "-m", "rig.cli", *map(str, args)], cwd=REPO, env=rig_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
                            errors="replace")


def signal_trial(root: Path, k: int, sig: signal.Signals, delay: float, ref: dict) -> Case:
    out = root / f"sig{k}"
    case = Case("process", f"{sig.name} after {delay:.1f} s, then --resume",
                ["run", SIX, "--out", out, "--seed", SEED_SENSOR, "--time-scale", "4"], "valid")
    t0 = time.monotonic()
    p = start_run(out)
    try:
        p.wait(timeout=delay)
    except subprocess.TimeoutExpired:
        pass
    alive = p.poll() is None
    if alive:
        p.send_signal(sig)
    try:
        _, err = p.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        p.kill()
        _, err = p.communicate()
        case.result.update(code=None, first="did not stop within 30 s of the signal", category="timeout",
                           seconds=time.monotonic() - t0)
        return case
    code = p.returncode
    case.result.update(code=code, first=(stderr_lines(err) or [""])[0][:300])
    if "Traceback" in err or "internal error" in err:
        case.result["category"] = "traceback"
        return case
    if alive and sig != signal.SIGKILL and code not in (0, 1):
        case.result.update(category="wrong exit code", why=f"{sig.name}: exit {code} (expected 1)")
        return case
    dirs = [d for d in out.iterdir() if d.is_dir()] if out.exists() else []
    if not dirs:
        case.result.update(category="correct", why="stopped before the session existed",
                           seconds=time.monotonic() - t0)
        return case
    d = dirs[0]
    if not (d / "session.yaml").exists():
        code, o, e, _ = rig("run", "--resume", d, "--time-scale", "0", "--quiet")
        case.result.update(code=code, first=(stderr_lines(e) or [""])[0][:300])
        case.result["category"] = "correct" if code == 2 and len(stderr_lines(e)) == 1 else "wrong exit code"
        return case
    before = read_state(d)
    if before["manifest"]["status"] != "complete":
        case.args = ["run", "--resume", d, "--time-scale", "0", "--quiet"]
        code, o, e, _ = rig(*case.args, timeout=180)
        case.result.update(code=code, first=(stderr_lines(e) or [""])[0][:300])
        if code is None:
            case.result["category"] = "timeout"
            return case
        if "Traceback" in e or "internal error" in e:
            case.result["category"] = "traceback"
            return case
        if code != 0:
            case.result.update(category="wrong exit code", why="the resume failed")
            return case
    cat, why = check_session(d, before, ref)
    case.result.update(category=cat, why=why or f"{len([s for s in before['manifest']['steps'] if s['status'] == 'complete'])} steps kept",
                       seconds=time.monotonic() - t0)
    return case


def concurrent_resume_trial(root: Path, k: int, delay: float, ref: dict) -> Case:
    out = root / f"conc{k}"
    case = Case("process", f"two concurrent --resume (killed after {delay:.1f} s)", [], "valid")
    p = start_run(out)
    time.sleep(delay)
    p.kill()
    p.communicate()
    dirs = [d for d in out.iterdir() if d.is_dir()] if out.exists() else []
    if not dirs or not (dirs[0] / "session.yaml").exists():
        case.result.update(category="correct", why="killed before the session existed", code=None, first="")
        return case
    d = dirs[0]
    before = read_state(d)
    case.args = ["run", "--resume", d, "--time-scale", "4", "--quiet", "&", "rig", "run", "--resume", d]
    a = start_run(out, resume=d)
    b = start_run(out, resume=d)
    ra = a.communicate(timeout=300)
    rb = b.communicate(timeout=300)
    codes = sorted([a.returncode, b.returncode])
    errs = {a.returncode: ra[1], b.returncode: rb[1]}
    case.result.update(code=codes, first=(stderr_lines(errs.get(1, "")) or [""])[0][:300])
    if any("Traceback" in e or "internal error" in e for e in (ra[1], rb[1])):
        case.result["category"] = "traceback"
        return case
    if codes != [0, 1]:
        case.result.update(category="silent wrong result" if codes == [0, 0] else "wrong exit code",
                           why=f"exit codes {codes}, expected one 0 and one 1")
        return case
    loser = a if a.returncode == 1 else b
    winner = b if loser is a else a
    lines = stderr_lines(errs[1])
    if len(lines) != 1 or str(winner.pid) not in lines[0]:
        case.result.update(category="bad message", why=f"refusal does not name holder pid {winner.pid} in one line")
        return case
    cat, why = check_session(d, before, ref)
    case.result.update(category=cat, why=why)
    return case


def same_second_runs_trial(root: Path) -> Case:
    out = root / "same-second"
    case = Case("process", "two runs into one --out in the same second", ["run", SIX, "--out", out, "&", "..."],
                "valid")
    ps = [start_run(out, time_scale="0") for _ in range(2)]
    res = [p.communicate(timeout=300) for p in ps]
    codes = [p.returncode for p in ps]
    dirs = sorted(d for d in out.iterdir() if d.is_dir()) if out.exists() else []
    case.result.update(code=codes, first=(stderr_lines(res[0][1] + res[1][1]) or [""])[0][:300])
    if codes != [0, 0]:
        case.result.update(category="wrong exit code", why=f"exit codes {codes}")
    elif len(dirs) != 2:
        case.result.update(category="data lost", why=f"{len(dirs)} session directories for two runs")
    else:
        bad = [check_session(d, None, ref=_REF["acc"]) for d in dirs]
        wrong = [c for c in bad if c[0] != "correct"]
        case.result.update(category=wrong[0][0] if wrong else "correct", why=wrong[0][1] if wrong else "")
    return case


_REF: dict = {}


# ----------------------------------------------------------------------------------------------- main

def tally(cases: list[Case]) -> dict:
    t = {c: 0 for c in CATEGORIES}
    for c in cases:
        t[c.result["category"]] += 1
    return t


def print_report(inputs: list[Case], process: list[Case], seconds: float) -> None:
    ti, tp = tally(inputs), tally(process)
    print("\n=== adversarial campaign ===")
    print(f"{'':28s} {'inputs':>7s} {'process':>8s} {'total':>7s}")
    print(f"{'tried':28s} {len(inputs):7d} {len(process):8d} {len(inputs) + len(process):7d}")
    labels = {"correct": "handled correctly", "traceback": "tracebacks", "wrong exit code": "wrong exit codes",
              "silent wrong result": "silent wrong results", "bad message": "bad messages (lines/naming)",
              "timeout": "timeouts (hangs, bombs)", "data lost": "data lost"}
    for c in CATEGORIES:
        print(f"{labels[c]:28s} {ti[c]:7d} {tp[c]:8d} {ti[c] + tp[c]:7d}")
    fams: dict[str, list[Case]] = {}
    for c in inputs + process:
        fams.setdefault(c.family, []).append(c)
    print("\nby family:")
    for fam, cs in fams.items():
        ok = sum(c.result["category"] == "correct" for c in cs)
        print(f"  {fam:24s} {ok:4d}/{len(cs):<4d} correct")
    fails = [c for c in inputs + process if c.result["category"] != "correct"]
    print(f"\nfailures ({len(fails)}):")
    for c in sorted(fails, key=lambda c: (c.result["category"], c.family, c.name)):
        why = f" ({c.result['why']})" if c.result.get("why") else ""
        print(f"- [{c.result['category']}] {c.family}: {c.name}{why}\n    $ {c.command()}\n"
              f"    exit {c.result.get('code')}: {c.result.get('first', '')}")
    print(f"\nrun time: {seconds:.0f} s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="~60 inputs and a few process trials (< 3 min)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--jobs", type=int, default=max(1, min(4, os.cpu_count() or 1)))
    ap.add_argument("--trials", type=int, default=None, help="signal trials (default 24, quick 3)")
    ap.add_argument("--filter", default=None, help="only inputs whose family or name contains this")
    ap.add_argument("--no-process", action="store_true", help="skip the process-fault trials")
    ap.add_argument("--json", default=None, help="also write every result to this JSON file")
    ap.add_argument("--keep", action="store_true", help="keep the work directory")
    args = ap.parse_args(argv)
    t0 = time.monotonic()
    rng = random.Random(args.seed)
    root = Path(tempfile.mkdtemp(prefix="rig-adversarial-"))
    try:
        ws = Workspace(root)
        _REF["acc"] = ws.ref
        print(f"clean session {ws.session.name} ({time.monotonic() - t0:.0f} s); generating inputs", file=sys.stderr)
        cases = (procedure_cases(ws) + rig_cases(ws) + session_cases(ws, rng, args.quick) + calibration_cases(ws, args.quick)
                 + import_cases(ws) + option_cases(ws))
        if args.quick:
            # a fixed-seed sample that keeps every family
            fams: dict[str, list[Case]] = {}
            for c in cases:
                fams.setdefault(c.family, []).append(c)
            picked = []
            for fam, cs in fams.items():
                controls = [c for c in cs if c.expect == "valid"][:1]
                rest = [c for c in cs if c not in controls]
                picked += controls + random.Random(args.seed).sample(rest, min(len(rest), max(4, 60 * len(cs) // len(cases))))
            cases = picked
        if args.filter:
            cases = [c for c in cases if args.filter.lower() in (c.family + " " + c.name).lower()]
        print(f"{len(cases)} inputs, {args.jobs} at a time", file=sys.stderr)
        done = 0

        def one(c: Case) -> Case:
            nonlocal done
            r = run_gyro_as_accel(c) if isinstance(c, _GyroAsAccel) else run_case(c)
            done += 1
            if done % 25 == 0:
                print(f"  {done}/{len(cases)} ({time.monotonic() - t0:.0f} s)", file=sys.stderr)
            return r

        with ThreadPoolExecutor(args.jobs) as pool:
            inputs = list(pool.map(one, cases))
        process: list[Case] = []
        if not args.no_process:
            n = args.trials if args.trials is not None else (3 if args.quick else 21)
            prng = random.Random(args.seed + 1)
            sigs = [signal.SIGKILL, signal.SIGTERM, signal.SIGINT]
            for k in range(n):
                sig = sigs[k % 3]
                delay = prng.uniform(0.5, 26.0)
                c = signal_trial(root / "proc", k, sig, delay, ws.ref)
                print(f"  trial {k + 1}/{n}: {c.name}: {c.result['category']} {c.result.get('why', '')}",
                      file=sys.stderr)
                process.append(c)
            for k in range(1 if args.quick else 3):
                c = concurrent_resume_trial(root / "proc", k, prng.uniform(4.0, 14.0), ws.ref)
                print(f"  {c.name}: {c.result['category']} {c.result.get('why', '')}", file=sys.stderr)
                process.append(c)
            process.append(same_second_runs_trial(root / "proc"))
        print_report(inputs, process, time.monotonic() - t0)
        if args.json:
            Path(args.json).write_text(json.dumps([{"family": c.family, "name": c.name, "command": c.command(),
                                                    "expect": c.expect, **c.result} for c in inputs + process],
                                                   indent=1, default=str))
        bad = sum(c.result["category"] != "correct" for c in inputs + process)
        return 1 if bad else 0
    finally:
        if args.keep:
            print(f"work directory kept: {root}", file=sys.stderr)
        else:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())
