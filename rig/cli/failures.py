"""How an exception becomes the ``rig`` command's exit code and its one line on stderr (docs/cli.md).

The table names the error types of every layer (calib, the drivers, the session, the engine), so
importing this module imports those packages (numpy, scipy, pandas): :mod:`rig.cli.main` imports it
once a command runs, never for ``rig --help`` or ``rig --version`` (docs/architecture.md, "Deferred
imports").
"""

from __future__ import annotations

import yaml

from calib.errors import CalibError
from drivers.sensors.base import SensorError
from drivers.ximc.errors import TurntableError
from rig.cli.codes import EXIT_BAD_INPUT, EXIT_FAILURE, UsageError
from rig.config.yamlload import SymlinkLoop
from rig.errors import RigInputError, RunAborted, RunError, SessionFormatError
from rig.execution.operator import OperatorAbsent
from rig.session.lock import SessionLocked

#: exception types -> exit code, and how the one line reads (first line of the message by default)
EXIT_CODES: list[tuple[tuple[type, ...], int, object]] = [
    ((KeyboardInterrupt,), EXIT_FAILURE, lambda exc, first: "interrupted"),
    ((RigInputError, SessionFormatError, CalibError, UsageError, OperatorAbsent), EXIT_BAD_INPUT, None),
    ((FileNotFoundError,), EXIT_BAD_INPUT, lambda exc, first: f"{exc.filename}: no such file or directory"),
    ((IsADirectoryError,), EXIT_BAD_INPUT, lambda exc, first: f"{exc.filename}: is a directory, expected a file"),
    ((SymlinkLoop,), EXIT_BAD_INPUT, lambda exc, first: f"{exc.filename}: {SymlinkLoop.message}, expected a file"),
    ((yaml.YAMLError,), EXIT_BAD_INPUT, lambda exc, first: f"not valid YAML: {first}"),
    ((RunAborted,), EXIT_FAILURE, lambda exc, first: f"aborted: {first}"),
    ((TurntableError,), EXIT_FAILURE, lambda exc, first: _turntable_line(exc, first)),
    ((TurntableError, SensorError, RunError, SessionLocked), EXIT_FAILURE, None),
    ((OSError,), EXIT_FAILURE,
     lambda exc, first: f"{exc.strerror or first}" + (f": {exc.filename}" if exc.filename else "")),
]


def _turntable_line(exc: TurntableError, first: str) -> str:
    """A port that does not open says what to do, as ``rig check`` does (rig.devices.bringup.OPEN_HINTS): a
    missing link, a permission, a busy port."""
    if exc.command != "open":
        return first
    from rig.devices.bringup import hint_for  # deferred: rig check's hints (17 ms), only when a port did not open
    name = f"{exc.name} " if exc.name else ""
    return f"{name}{exc.port}: {hint_for(exc, 'serial')}"


def classify(exc: BaseException) -> tuple[int, str]:
    """Map an exception to (exit code, one line)."""
    first = (str(exc).strip().splitlines() or [""])[0]
    for types, code, line in EXIT_CODES:
        if isinstance(exc, types):
            return code, line(exc, first) if line else first
    return EXIT_FAILURE, f"internal error ({type(exc).__name__}: {first}); rerun with RIG_DEBUG=1 and report it"
