"""The ``rig`` command line (contract: docs/cli.md)."""

from rig.cli.main import main

__all__ = ["main"]
