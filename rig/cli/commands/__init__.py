"""One module per ``rig`` command: ``add_parser(subparsers)`` and ``run(args) -> exit code``.

:data:`COMMANDS` lists the commands with the line ``rig --help`` shows for each; :func:`load` imports
a command's module when that command is given. ``rig --help`` and ``rig --version`` import no command
module and ``rig solve`` imports only solve's (docs/architecture.md, "Deferred imports"): each
command pays only for what it uses.
"""

from __future__ import annotations

from types import ModuleType

#: command name -> its line in ``rig --help`` (the help its module's ``add_parser`` gives), in the order listed
COMMANDS: dict[str, str] = {
    "run": "run a procedure and record a session",
    "solve": "solve a recorded session into a calibration file",
    "apply": "apply a calibration to a session's samples",
    "evaluate": "evaluate a calibration against a session's poses",
    "discover": "find where the model and the data disagree; name the missing effect",
    "compare": "compare two sessions of the same procedure step by step; say where they disagree beyond the noise",
    "import": "import another tool's recording as a session",
    "replay": "re-run a recorded session through the replay rig",
    "sim": "start emulated controllers; show the simulated sensor",
    "ports": "list serial ports and I2C buses and what answers on them",
    "check": "open every controller and the sensor bus, read who answers; move nothing",
    "jog": "turn one axis by a few degrees (confirmed; Ctrl-C stops it)",
    "history": "calibration history: the sensors, or every calibration of one and its drift",
    "export": "export a calibration file to PX4, ArduPilot, imucal or plain JSON",
    "repair": "cut back what a crash left past a session's last finished step (after a backup); refuse anything else",
    "report": "one self-contained HTML report of a session: verdict, parameters, residuals, roll/pitch table, "
              "discrepancy, history",
    "verify": "check a session against its seal: the recording as made, or where it differs",
    "characterize": "Allan deviation of a static recording: each axis's noise terms (white noise, bias instability, "
                    "random walk) with uncertainties",
    "characterize-rig": "the turntable's own errors by reversal (one sensor in several mountings); stored as the "
                        "rig's characterisation",
    "archive": "session directories into a partitioned Parquet archive (or one back out)",
    "resolve": "solve every session of an archive again, in chunks, on a process pool",
    "fleet": "statistics across the units of a re-solved archive: spread, units that stand out",
}


def load(name: str) -> ModuleType:
    """The module of command ``name``, imported now (deferred imports: only the command given runs)."""
    if name == "run":
        from rig.cli.commands import run as module
    elif name == "solve":
        from rig.cli.commands import solve as module
    elif name == "apply":
        from rig.cli.commands import apply as module
    elif name == "evaluate":
        from rig.cli.commands import evaluate as module
    elif name == "discover":
        from rig.cli.commands import discover as module
    elif name == "compare":
        from rig.cli.commands import compare as module
    elif name == "import":
        from rig.cli.commands import import_ as module
    elif name == "replay":
        from rig.cli.commands import replay as module
    elif name == "sim":
        from rig.cli.commands import sim as module
    elif name == "ports":
        from rig.cli.commands import ports as module
    elif name == "check":
        from rig.cli.commands import check as module
    elif name == "jog":
        from rig.cli.commands import jog as module
    elif name == "history":
        from rig.cli.commands import history as module
    elif name == "export":
        from rig.cli.commands import export as module
    elif name == "repair":
        from rig.cli.commands import repair as module
    elif name == "report":
        from rig.cli.commands import report as module
    elif name == "verify":
        from rig.cli.commands import verify as module
    elif name == "characterize":
        from rig.cli.commands import characterize as module
    elif name == "characterize-rig":
        from rig.cli.commands import characterize_rig as module
    elif name == "archive":
        from rig.cli.commands import archive as module
    elif name == "resolve":
        from rig.cli.commands import resolve as module
    elif name == "fleet":
        from rig.cli.commands import fleet as module
    else:
        raise KeyError(f"no rig command {name!r}")
    return module
