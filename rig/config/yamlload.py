"""The rig's YAML input files as :class:`~rig.errors.RigInputError`: reading them, and the loader's refusals.

The parsing is :mod:`calib.file.yamlsafe`'s (the one guarded loader: sizes, depth, aliases, tags,
duplicate keys, digits). Here: :func:`read_source` reads a procedure, rig file or session manifest
(missing, a directory, a symbolic link loop, too large, not text: one line naming the file), and
:func:`input_error` gives a :class:`~calib.file.yamlsafe.HostileYaml` the file's name.
"""

from __future__ import annotations

import errno
from pathlib import Path

from calib.file import yamlsafe
from calib.file.yamlsafe import HostileYaml
from rig.errors import RigInputError


class _ErrnoMatch(type):
    """``isinstance(exc, cls)`` is true for any OSError whose errno is in ``cls.errnos``."""

    def __instancecheck__(cls, exc) -> bool:
        return isinstance(exc, OSError) and exc.errno in cls.errnos


class SymlinkLoop(OSError, metaclass=_ErrnoMatch):
    """Matches (``isinstance``, not ``except``) any OSError with errno ELOOP: a path that is a loop of
    symbolic links. Whoever opened the file, this is bad input (the CLI's exit-code table says 2)."""

    errnos = (errno.ELOOP,)
    message = "a symbolic link loop (too many levels of symbolic links)"


def read_source(path, what: str, missing: str, max_bytes: int = yamlsafe.MAX_BYTES) -> str:
    """The text of ``path``; a one-line RigInputError if it is missing, a directory, too large or not text."""
    p = Path(path)
    try:
        return yamlsafe.read_text(p, what, max_bytes)
    except HostileYaml as exc:
        raise RigInputError(str(p), None, None, exc.message) from None
    except FileNotFoundError:
        raise RigInputError(str(p), None, None, missing) from None
    except IsADirectoryError:
        raise RigInputError(str(p), None, None, f"is a directory, expected a {what} YAML file") from None
    except OSError as exc:  # (``except SymlinkLoop`` would not match: except clauses ignore __instancecheck__)
        if isinstance(exc, SymlinkLoop):
            raise RigInputError(str(p), None, None, f"{SymlinkLoop.message}, expected a {what} YAML file") from None
        raise RigInputError(str(p), None, None, f"cannot read: {exc.strerror or exc}") from None


def input_error(exc: HostileYaml, path: str | None) -> RigInputError:
    """The loader's refusal as one line ``path:line: key: message``."""
    return RigInputError(path, exc.line, exc.key, exc.message)
