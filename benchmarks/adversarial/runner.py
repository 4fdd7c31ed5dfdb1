"""Running one attack and classifying what rig did: the campaign's shared runner.

Every command runs as ``python -m rig.cli ARGS`` in a subprocess (:func:`rig`), with the campaign's environment
(its own history database, no ``RIG_DEBUG``) and a time limit. The attack modules call it as ``runner.rig(...)``
(an attribute of this module, looked up at each call), so a test may run the commands in its own process by
replacing ``runner.rig`` (tests/system/test_adversarial_smoke.py).

An input (:class:`Case`) is classified (:func:`classify`) into one of :data:`CATEGORIES`; a process trial that
could not do what it attacks (the run ended before it could be signalled) is ``not tried``: never counted as
handled.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATASETS = REPO.parent / "shared" / "datasets"
SIX = REPO / "procedures" / "six_position.yaml"
PY = sys.executable
TIMEOUT_S = 60.0
SEED_SENSOR = 9

#: what became of one attack; "not tried": the attack could not be made (neither handled nor failed)
CATEGORIES = ("correct", "traceback", "wrong exit code", "silent wrong result", "bad message", "timeout",
              "data lost", "not tried")
#: the categories that are no failure of rig
NOT_FAILED = ("correct", "not tried")


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


def start_run(out: Path, time_scale: str = "4", resume: Path | None = None, procedure: Path = SIX,
              extra=()) -> subprocess.Popen:
    """``rig run`` (or ``rig run --resume``) as a process of its own, to be signalled or raced."""
    args = ["run", "--resume", resume, "--time-scale", time_scale, "--quiet"] if resume else \
        ["run", procedure, "--out", out, "--seed", SEED_SENSOR, "--time-scale", time_scale, "--quiet", *extra]
    return subprocess.Popen([PY, "-m", "rig.cli", *map(str, args)], cwd=REPO, env=rig_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
                            errors="replace")


def stderr_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


def first_line(err: str) -> str:
    return (stderr_lines(err) or [""])[0][:300]


@dataclass
class Case:
    """One adversarial input: ``args`` for rig; ``expect`` 'refuse' (exit 2), 'valid' (exit 0, then ``check``),
    'refuse_or_warn' (exit 2 with one line, or exit 0 with a warning on stderr naming the problem),
    'warn' (exit 0 with a warning on stderr: valid input that lost something, e.g. a torn line of the step in
    progress). ``script``: a case that runs itself (``script(case)`` fills ``case.result``), for attacks of
    more than one command."""

    family: str
    name: str
    args: list
    expect: str = "refuse"
    hint: tuple = ()            # one of these must appear in the refusal line (the file, key or option)
    check: object = None        # valid inputs: callable(out_stdout) -> str | None (None: the numbers agree)
    post: object = None         # callable() -> str | None: a side effect that must not happen (e.g. a tag ran)
    timeout: float = TIMEOUT_S
    script: object = None       # callable(case) -> None: runs the attack itself and sets result["category"]
    heavy: bool = False         # minutes of work: left out of --quick's sample
    result: dict = field(default_factory=dict)

    def command(self) -> str:
        return "rig " + " ".join(quote(a) for a in self.args)


def quote(a) -> str:
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
    if case.hint and not any(str(h).lower() in lines[0].lower() for h in case.hint):
        case.result["why"] = f"does not name {' or '.join(map(str, case.hint))}"
        return "bad message"
    return "correct"


def run_command(case: Case, *args, timeout: float | None = None) -> tuple[int | None, str, str, float]:
    """``rig ARGS`` for ``case``, retried once after a minute when rig itself cannot start (another engineer's
    half-saved file); the result's code, first stderr line and time are noted in ``case.result``."""
    code, out, err, dt = rig(*args, timeout=timeout or case.timeout)
    if code == 1 and ("No module named" in err or "ImportError" in err or "SyntaxError" in err):
        time.sleep(60)
        code, out, err, dt = rig(*args, timeout=timeout or case.timeout)
    case.result.update(code=code, first=first_line(err), seconds=dt, lines=len(stderr_lines(err)))
    return code, out, err, dt


def run_case(case: Case) -> Case:
    if case.script is not None:
        t0 = time.monotonic()
        try:
            case.script(case)
        except Unavailable as exc:  # what the attack needs could not be made: reported where it was made
            case.result.update(category="not tried", why=str(exc))
        case.result.setdefault("seconds", time.monotonic() - t0)
        case.result.setdefault("code", None)
        case.result.setdefault("first", "")
        return case
    code, out, err, _ = run_command(case, *case.args)
    case.result["category"] = classify(case, code, out, err)
    return case


class Unavailable(Exception):
    """What an attack needs (a session another case records) could not be made."""


class Once:
    """A thing made once, by whichever case needs it first (cases run on threads); ``make()`` raising makes
    every user :class:`Unavailable`."""

    def __init__(self, what: str, make) -> None:
        self.what, self.make = what, make
        self.lock = threading.Lock()
        self.done, self.value, self.error = False, None, ""

    def get(self):
        with self.lock:
            if not self.done:
                try:
                    self.value = self.make()
                except Exception as exc:  # noqa: BLE001 - any failure: the users are not tried, the maker reports it
                    self.error = f"{self.what} could not be made: {(str(exc).splitlines() or [type(exc).__name__])[0]}"
                self.done = True
        if self.error:
            raise Unavailable(self.error)
        return self.value
