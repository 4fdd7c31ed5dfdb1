"""Attack class: output paths. Every command that writes a file is given, as that file: a named pipe nobody reads
(a plain open would block forever), a device node (made in the campaign's temp folder, by root only: else the
attack is not tried), a symbolic link to a file elsewhere, and one of its own inputs. Each must be refused in one
line naming the path (exit 2), and the pipe, the device, the link and its target, and the input stay as they were.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
from pathlib import Path

from .runner import Case

FAMILY = "output path"
#: the simulated sensor of the workspace's history (seed 9)
SENSOR = "sim-seed-9"


def commands(ws, s: Path, cal: Path) -> dict:
    """Every command that takes an output file: name -> (option, args given the output path)."""
    return {
        "solve -o": ("-o", lambda x: ["solve", s, "-o", x]),
        "apply -o": ("-o", lambda x: ["apply", cal, s, "-o", x]),
        "export -o": ("-o", lambda x: ["export", cal, "--to", "px4", "-o", x]),
        "report -o": ("-o", lambda x: ["report", s, "-o", x, "--history", ws.history]),
        "discover -o": ("-o", lambda x: ["discover", s, "-o", x]),
        "discover --plot": ("--plot", lambda x: ["discover", s, "--plot", x]),
        "history --plot": ("--plot", lambda x: ["history", SENSOR, "--history", ws.history, "--plot", x]),
    }


def _fingerprint(p: Path):
    """What must not change about ``p``: its kind, inode and device number (no contents are read: a FIFO blocks)."""
    try:
        st = os.lstat(p)
    except OSError as exc:
        return ("gone", exc.errno)
    return (stat.S_IFMT(st.st_mode), st.st_ino, st.st_rdev)


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "missing"


def cases(ws, rng, quick: bool) -> list[Case]:
    s = ws.session_copy("outputs-session")
    shutil.copy(ws.calibration, s / "calibration.yaml")
    cal = ws.path("outputs-calibration", ".yaml")
    shutil.copy(ws.calibration, cal)
    out = []
    for name, (option, args) in commands(ws, s, cal).items():
        # a named pipe with no reader
        fifo = ws.path(f"out-fifo-{name.replace(' ', '_')}", ".png")
        os.mkfifo(fifo)
        out.append(_unchanged(Case(FAMILY, f"{name}: a FIFO nobody reads", args(fifo), hint=(fifo.name,), timeout=30),
                              [fifo]))
        # a device node (our own null device, in the temp folder): writes to it vanish
        dev = ws.path(f"out-device-{name.replace(' ', '_')}", ".png")
        case = Case(FAMILY, f"{name}: a device node (a null device made in the temp folder)", args(dev),
                    hint=(dev.name,), timeout=30)
        if os.geteuid() == 0:
            os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))
            out.append(_unchanged(case, [dev]))
        else:
            case.script = _not_root
            out.append(case)
        # a symbolic link to a file elsewhere (without --follow)
        target = ws.path(f"out-link-target-{name.replace(' ', '_')}", ".png")
        target.write_bytes(b"keep me\n")
        link = ws.path(f"out-link-{name.replace(' ', '_')}", ".png")
        os.symlink(target, link)
        out.append(_unchanged(Case(FAMILY, f"{name}: a symbolic link to a file elsewhere", args(link),
                                   hint=(link.name,)), [link], contents=[target]))
    out += own_inputs(ws)
    return out


def own_inputs(ws) -> list[Case]:
    """Each command given one of its own inputs as its output (a copy of the session and calibration each)."""
    out = []
    table = {
        "solve -o SESSION/samples.csv": lambda s, cal: (["solve", s, "-o", s / "samples.csv"], s / "samples.csv"),
        "apply -o its calibration": lambda s, cal: (["apply", cal, s, "-o", cal], cal),
        "apply -o SESSION/samples.csv": lambda s, cal: (["apply", cal, s, "-o", s / "samples.csv"], s / "samples.csv"),
        "export -o its calibration": lambda s, cal: (["export", cal, "--to", "json", "-o", cal], cal),
        "report -o SESSION/session.yaml": lambda s, cal: (["report", s, "-o", s / "session.yaml", "--history",
                                                            ws.history], s / "session.yaml"),
        "discover -o SESSION/samples.csv": lambda s, cal: (["discover", s, "-o", s / "samples.csv"],
                                                           s / "samples.csv"),
        "discover --plot SESSION/session.yaml": lambda s, cal: (["discover", s, "--plot", s / "session.yaml"],
                                                                s / "session.yaml"),
        "history --plot its database": lambda s, cal: (["history", SENSOR, "--history", ws.history, "--plot",
                                                        ws.history], ws.history),
    }
    for k, (name, make) in enumerate(table.items()):
        s = ws.session_copy(f"outputs-own-{k}")
        cal = ws.path(f"outputs-own-{k}-calibration", ".yaml")
        shutil.copy(ws.calibration, cal)
        args, given = make(s, cal)
        inputs = [s / "samples.csv", s / "session.yaml", cal]
        case = Case(FAMILY, f"its own input: {name}", args, hint=(Path(given).name,))
        out.append(_unchanged(case, [], contents=inputs))
    rec = ws.path("outputs-recording", ".csv")
    rec.write_text("# units: g\nt_s,ax,ay,az,label\n" + "".join(
        f"{0.01 * i:.2f},0,0,1,+Z up\n" for i in range(100)))
    out.append(_unchanged(Case(FAMILY, "its own input: import -o the recording", ["import", "--from", "csv", rec, "-o",
                                                                                   rec], hint=(rec.name,)),
                          [], contents=[rec]))
    return out


def _unchanged(case: Case, special: list[Path], contents=()) -> Case:
    """``case``, whose post-check says what changed: a special file's kind or inode, a file's bytes."""
    kinds = {p: _fingerprint(p) for p in special}
    digests = {p: _digest(p) for p in contents}

    def post() -> str | None:
        for p, before in kinds.items():
            if _fingerprint(p) != before:
                return f"{p.name} was replaced or removed"
        for p, before in digests.items():
            if _digest(p) != before:
                return f"{p.name} was overwritten"
        return None

    case.post = post
    return case


def _not_root(case: Case) -> None:
    case.result.update(category="not tried", why="a device node can be made by root only", code=None, first="")
