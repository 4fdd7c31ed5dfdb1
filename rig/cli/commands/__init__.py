"""One module per ``rig`` command: ``add_parser(subparsers)`` and ``run(args) -> exit code``."""

from types import ModuleType

from rig.cli.commands import apply, discover, evaluate, import_, ports, replay, run, sim, solve
from rig.cli.commands import compare, export, history, report

#: command name -> module, in the order ``rig --help`` lists them
COMMANDS: dict[str, ModuleType] = {"run": run, "solve": solve, "apply": apply, "evaluate": evaluate,
                                   "discover": discover, "compare": compare, "import": import_, "replay": replay,
                                   "sim": sim, "ports": ports, "history": history, "export": export, "report": report}
