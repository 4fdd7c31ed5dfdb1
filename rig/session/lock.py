"""A session being recorded is locked: one writer at a time, across processes.

The lock is an OS file lock (``flock``) on ``SESSION/session.lock``, held for the whole run, so the
kernel releases it when the holder dies however it dies (kill -9 included). A holder that releases it
removes the file (no empty lock file is left in a finished session); one that dies leaves it, naming itself. The file also names
the holder (pid, host, command, since when): a second run is refused with those details, and a
lock left by a dead process is taken over, saying so.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

LOCK_NAME = "session.lock"


class SessionLocked(Exception):
    """Another process is recording this session (the message names it; exit 1)."""


class SessionLock:
    """Hold the lock of ``session_dir`` (a context manager); :attr:`stale` describes a dead holder
    whose lock was taken over (None when the lock was free)."""

    def __init__(self, session_dir) -> None:
        self.path = Path(session_dir) / LOCK_NAME if session_dir is not None else None
        self._fh = None
        self.stale: dict | None = None

    def acquire(self) -> "SessionLock":
        fh = self._lock_file()
        self.stale = _holder(fh) or None
        fh.seek(0)
        fh.truncate()
        fh.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "command": " ".join(sys.argv[:4]),
                             "since": datetime.now(timezone.utc).isoformat(timespec="seconds")}))
        fh.flush()
        os.fsync(fh.fileno())
        self._fh = fh
        return self

    def _lock_file(self):
        """The lock file, opened and locked: the file the path names when the lock is held (a holder that
        released it removed the file after another process opened it: that one locks a removed file and
        opens the path again)."""
        for _ in range(_OPEN_ATTEMPTS):
            fh = open(self.path, "a+")
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = _current_holder(fh)
                fh.close()
                raise SessionLocked(f"{self.path.parent}: being recorded by pid {holder.get('pid', '?')} on "
                                    f"{holder.get('host', '?')} since {holder.get('since', '?')} "
                                    f"({holder.get('command', '?')}); wait for it or stop it first") from None
            if _same_file(fh, self.path):
                return fh
            fh.close()
        raise SessionLocked(f"{self.path.parent}: its lock file keeps being replaced by another process; try again")

    def release(self) -> None:
        """Unlock, leaving no lock file behind: it is removed while still locked (:meth:`acquire` of another
        process that opened it meanwhile sees it gone and opens the path again)."""
        if self._fh is None:
            return
        try:
            self._fh.seek(0)
            self._fh.truncate()
            self._fh.flush()
        except OSError:
            pass  # a full disk must not keep the lock: closing releases it
        try:
            if _same_file(self._fh, self.path):
                self.path.unlink()
        except OSError:
            pass  # a lock file that cannot be removed is empty and unlocked: harmless
        fcntl.flock(self._fh.fileno(), fcntl.LOCK_UN)
        self._fh.close()
        self._fh = None

    def __enter__(self) -> "SessionLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


#: how long a refused run waits for the holder to name itself, s
HOLDER_WAIT_S = 2.0
#: how many times a lock file removed under the opener (released meanwhile) is opened again
_OPEN_ATTEMPTS = 20


def _same_file(fh, path: Path) -> bool:
    """Whether the open file ``fh`` is still the file ``path`` names."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return False
    own = os.fstat(fh.fileno())
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _current_holder(fh) -> dict:
    """The lock holder's record. The holder writes it just after taking the lock, so for a moment the
    file is empty or still names the previous holder (a killed run): such a record, naming no live
    process on this host, is read again for up to :data:`HOLDER_WAIT_S` (then returned as it is)."""
    deadline = time.monotonic() + HOLDER_WAIT_S
    while True:
        holder = _holder(fh)
        if _names_live_process(holder) or time.monotonic() > deadline:
            return holder
        time.sleep(0.01)


def _names_live_process(holder: dict) -> bool:
    """Whether ``holder`` names a process that is alive (one on another host is taken as alive)."""
    pid = holder.get("pid")
    if not isinstance(pid, int):
        return False
    if holder.get("host") != socket.gethostname():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _holder(fh) -> dict:
    fh.seek(0)
    try:
        return json.loads(fh.read() or "{}")
    except ValueError:
        return {}
