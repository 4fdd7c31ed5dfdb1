"""The exit codes of the ``rig`` command (contract: docs/cli.md) and the usage error.

Imported by the parser (:mod:`rig.cli.main`) before any command is chosen, so it imports nothing:
``rig --help`` and ``rig --version`` stay fast (docs/architecture.md, "Deferred imports").
"""

#: exit codes (contract: docs/cli.md); 3: the calibration was written but failed the procedure's accept: limits
EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT, EXIT_REJECTED = 0, 1, 2, 3


class UsageError(Exception):
    """Bad command-line input (exit 2)."""
