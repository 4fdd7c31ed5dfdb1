"""Attack class: injected names. Step names written as shell and TeX (``$(touch F)``, backticks, ``${HOME}``,
``$\\frac{1$``) and an output folder named ``$(touch F)``: a run records them, its report and ``rig discover
--plot`` and ``rig compare`` show them, and nothing runs them (the files they would touch never appear); the
names in session.yaml are the names written."""

from __future__ import annotations

import html
import json
from pathlib import Path

import yaml

from . import runner
from .runner import SIX, Case, Once, Unavailable, classify

FAMILY = "names"
FACES = ("+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up")


def step_names(marker: Path) -> tuple[str, ...]:
    return (f"$(touch {marker}-a)", f"`touch {marker}-b`", "${HOME} $PATH $$ $1 $@", "$\\frac{1$",
            f"price $5; touch {marker}-c", "$ending$")


def procedure(folder: Path, names, name: str = "dollar_names") -> Path:
    head, _, _ = SIX.read_text().partition("steps:")
    steps = "".join(f'  - pose: "{face}"\n    name: {json.dumps(n)}\n' for face, n in zip(FACES, names))
    text = (head.replace("name: six_position", f"name: {name}").replace("dwell: {seconds: 10}", "dwell: {seconds: 2}")
            + "steps:\n" + steps + "solve: {model: triangular, method: pinv, thermal: auto}\nreport: true\n")
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return path


class Recorded:
    """The run that records a session with hostile names, made once for every case that needs it."""

    def __init__(self, ws, stem: str, out: Path, names) -> None:
        self.ws, self.out, self.names = ws, out, names
        self.proc = procedure(ws.path(stem), names) if names else SIX
        self.args = ["run", self.proc, "--out", out, "--seed", "3", "--time-scale", "0", "--quiet"]
        self.result: tuple | None = None
        self.once = Once(f"the session of {stem}", self._make)

    def _make(self) -> Path:
        self.result = runner.rig(*self.args, timeout=180)
        code, _, err, _ = self.result
        dirs = [d for d in self.out.iterdir() if d.is_dir()] if self.out.is_dir() else []
        if code != 0 or len(dirs) != 1:
            raise RuntimeError(f"rig run exit {code}: {(err.strip().splitlines() or [''])[-1][:200]}")
        return dirs[0]

    def session(self) -> Path:
        return self.once.get()


def cases(ws, rng, quick: bool) -> list[Case]:
    marker = ws.root / "pwned-by-a-name"
    folder = ws.path("names")
    folder.mkdir()
    names = step_names(marker)
    hostile = Recorded(ws, "names-procedure", folder / "sessions", names)
    # a folder name holds no "/": a command in it would touch a file in the working directory (the repository)
    dollar_out = Recorded(ws, "names-out", folder / f"$(touch {marker.name}-out)", ())

    def nothing_ran() -> str | None:
        ran = sorted(ws.root.glob(f"{marker.name}*")) + sorted(runner.REPO.glob(f"{marker.name}*"))
        for p in ran:
            p.unlink(missing_ok=True)  # found once, reported once
        return f"a name ran as a command: {', '.join(p.name for p in ran)} appeared" if ran else None

    out = [
        _script(Case(FAMILY, "step names with $ and backticks: rig run (report: true)", hostile.args, "valid",
                     post=nothing_ran), lambda c: _run(c, hostile)),
        _script(Case(FAMILY, "step names with $: rig discover --plot", [], "valid", post=nothing_ran),
                lambda c: _on_session(c, hostile, lambda s: ["discover", s, "--plot", folder / "discover.png"],
                                      folder / "discover.png")),
        _script(Case(FAMILY, "step names with $: rig report", [], "valid", post=nothing_ran),
                lambda c: _on_session(c, hostile, lambda s: ["report", s, "-o", folder / "report.html", "--history",
                                                            ws.history], folder / "report.html", names=names)),
        _script(Case(FAMILY, "step names with $: rig compare", [], "valid", post=nothing_ran),
                lambda c: _on_session(c, hostile, lambda s: ["compare", s, s], None)),
        _script(Case(FAMILY, "an --out folder named $(touch ...): rig run", dollar_out.args, "valid", post=nothing_ran),
                lambda c: _run(c, dollar_out)),
        _script(Case(FAMILY, "an --out folder named $(touch ...): rig solve", [], "valid", post=nothing_ran),
                lambda c: _on_session(c, dollar_out, lambda s: ["solve", s, "-o", folder / "dollar.yaml"],
                                      folder / "dollar.yaml")),
    ]
    return out


def _script(case: Case, fn) -> Case:
    case.script = fn
    return case


def _run(case: Case, rec: Recorded) -> None:
    try:
        session = rec.session()
    except Unavailable:
        session = None
    code, out, err, dt = rec.result if rec.result is not None else (None, "", "", 0.0)
    case.result.update(code=code, first=runner.first_line(err), seconds=dt)
    category = classify(case, code, out, err)
    if category == "correct" and session is not None and rec.names:
        doc = yaml.safe_load((session / "session.yaml").read_text())
        got = tuple(s.get("name") for s in doc["steps"])
        if got != tuple(rec.names):
            category, case.result["why"] = "silent wrong result", f"session.yaml names {got!r}"
        elif not (session / "report.html").is_file():
            category, case.result["why"] = "wrong exit code", "report: true, but no report.html"
    case.result["category"] = category


def _on_session(case: Case, rec: Recorded, args, written: Path | None, names=()) -> None:
    case.args = args(rec.session())  # Unavailable: not tried (the run's own case says why)
    code, out, err, _ = runner.run_command(case, *case.args)
    category = classify(case, code, out, err)
    if category == "correct" and written is not None and not Path(written).is_file():
        category, case.result["why"] = "wrong exit code", f"exit 0, but no {Path(written).name}"
    if category == "correct" and names:
        text = Path(written).read_text(encoding="utf-8", errors="replace")
        missing = [n for n in names if html.escape(n) not in text]
        if missing:
            category, case.result["why"] = "silent wrong result", f"the report does not show {missing[0]!r}"
    case.result["category"] = category
