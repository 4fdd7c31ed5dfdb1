"""Where the history is: ``--history PATH|URL``, else ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``;
and where a rig keeps what it could not send to a history server (the outbox, beside the default history)."""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

ENV_VAR = "RIG_HISTORY"
DEFAULT_PATH = Path("~/.local/share/rig/history.sqlite")
#: the folder of the outboxes (default: beside the default history, ``~/.local/share/rig/outbox``)
OUTBOX_ENV_VAR = "RIG_HISTORY_OUTBOX"
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")
_PASSWORD = re.compile(r"^([^:/]+://[^:/@]*):[^@]*@")


def is_url(value) -> bool:
    """Whether a ``--history`` value is a database URL (``postgresql+psycopg://...``, ``sqlite:///...``)."""
    return isinstance(value, (str, HistoryURL)) and bool(_URL.match(str(getattr(value, "url", value))))


def masked(url: str) -> str:
    """``url`` with its password (if it has one) shown as ``***``: what messages print."""
    return _PASSWORD.sub(r"\1:***@", url)


class HistoryURL:
    """A history on a server, where a caller expects the history's path: ``str()`` is the URL with its password
    masked, ``exists()`` is True (the server is asked when it is opened), ``with_name``/``stem`` name files in the
    local folder beside the outbox (noise profiles: ``history.noise``)."""

    def __init__(self, url: str) -> None:
        self.url = url

    def __str__(self) -> str:
        return masked(self.url)

    __fspath__ = __str__

    def __repr__(self) -> str:
        return f"HistoryURL({masked(self.url)!r})"

    def __eq__(self, other) -> bool:
        return isinstance(other, HistoryURL) and other.url == self.url

    def __hash__(self) -> int:
        return hash(self.url)

    def exists(self) -> bool:
        return True

    stem = "history"
    name = "history"

    def with_name(self, name: str) -> Path:
        return outbox_dir() / name


def default_path(path=None) -> Path | HistoryURL:
    """``path``, else ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``: a path, or a
    :class:`HistoryURL` for a database URL."""
    chosen = path or os.environ.get(ENV_VAR) or DEFAULT_PATH
    if isinstance(chosen, HistoryURL):
        return chosen
    if is_url(chosen):
        return HistoryURL(str(chosen))
    return Path(chosen).expanduser()


def outbox_dir() -> Path:
    """The folder of the outboxes: ``$RIG_HISTORY_OUTBOX``, else ``outbox`` beside the default history."""
    return Path(os.environ.get(OUTBOX_ENV_VAR) or DEFAULT_PATH.expanduser().with_name("outbox")).expanduser()


def outbox_path(url: str) -> Path:
    """The outbox of the history server ``url``: one SQLite history per server and database (the password
    is no part of its name), e.g. ``outbox/127.0.0.1-5432-rig-3f2a9c1b.sqlite``."""
    plain = masked(url)
    where = re.sub(r"^[^:]+://([^@/]*@)?", "", plain)
    stem = re.sub(r"[^A-Za-z0-9._-]+", "-", where.split("?")[0]).strip("-")[:60] or "server"
    return outbox_dir() / f"{stem}-{hashlib.sha256(plain.encode()).hexdigest()[:8]}.sqlite"
