"""Attack class: concurrent writers. Two ``rig run --resume DIR`` at once on one interrupted session (killed
mid-step first): exactly one proceeds, the other exits 1 with one line naming the holder's pid, and the session
is intact. Two runs into one ``--out`` in the same second: two sessions with distinct ids, both correct."""

from __future__ import annotations

import time
from pathlib import Path

from .runner import Case, first_line, stderr_lines, start_run
from .signals import wait_mid_step
from .workspace import check_session, read_state

FAMILY = "process"


def concurrent_resume_trial(root: Path, k: int, ref: dict, *, step: int | None = None, into_s: float = 0.0,
                            resume_time_scale: str = "4") -> Case:
    """Kill -9 a run mid-step, then start two ``rig run --resume`` of its session at once (at
    ``resume_time_scale``): one proceeds and completes the session, the other is refused in one line naming the
    holder's pid."""
    out = root / f"conc{k}"
    where = "the first step" if step is None else f"step {step + 1}"
    case = Case(FAMILY, f"two concurrent --resume (killed {into_s:.1f} s into {where})", [], "valid")
    p = start_run(out)
    d, why = wait_mid_step(p, out, step, into_s)
    p.kill()  # kill -9, mid-step (or the run that never got there)
    p.communicate()
    if d is None:
        case.result.update(category="not tried", why=why, code=None, first="")
        return case
    before = read_state(d)
    case.args = ["run", "--resume", d, "--time-scale", resume_time_scale, "--quiet", "&", "rig", "run", "--resume", d]
    a = start_run(out, resume=d, time_scale=resume_time_scale)
    b = start_run(out, resume=d, time_scale=resume_time_scale)
    ra = a.communicate(timeout=300)
    rb = b.communicate(timeout=300)
    codes = sorted([a.returncode, b.returncode])
    errs = {a.returncode: ra[1], b.returncode: rb[1]}
    case.result.update(code=codes, first=first_line(errs.get(1, "")))
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


def same_second_runs_trial(root: Path, ref: dict) -> Case:
    out = root / "same-second"
    case = Case(FAMILY, "two runs into one --out in the same second", ["run", "SIX", "--out", out, "&", "..."],
                "valid")
    t0 = time.monotonic()
    ps = [start_run(out, time_scale="0") for _ in range(2)]
    res = [p.communicate(timeout=300) for p in ps]
    codes = [p.returncode for p in ps]
    dirs = sorted(d for d in out.iterdir() if d.is_dir()) if out.exists() else []
    case.result.update(code=codes, first=first_line(res[0][1] + res[1][1]))
    if codes != [0, 0]:
        case.result.update(category="wrong exit code", why=f"exit codes {codes}")
    elif len(dirs) != 2:
        case.result.update(category="data lost", why=f"{len(dirs)} session directories for two runs")
    else:
        bad = [check_session(d, None, ref) for d in dirs]
        wrong = [c for c in bad if c[0] != "correct"]
        case.result.update(category=wrong[0][0] if wrong else "correct", why=wrong[0][1] if wrong else "")
    case.result["seconds"] = time.monotonic() - t0
    return case


def trials(root: Path, ref: dict, rng, quick: bool) -> list[tuple[str, object]]:
    out = []
    for k in range(1 if quick else 3):
        step, into = rng.randrange(1, 5), rng.uniform(0.0, 2.0)
        out.append(("concurrent resume", lambda k=k, step=step, into=into:
                    concurrent_resume_trial(root, k, ref, step=step, into_s=into)))
    out.append(("same second", lambda: same_second_runs_trial(root, ref)))
    return out
