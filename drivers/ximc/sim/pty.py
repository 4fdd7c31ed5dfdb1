"""A pseudo-terminal that stands in for a controller's USB serial port.

:class:`PtyServer` owns the pty pair and one thread: bytes the host writes are handed to a
callback (``on_bytes(data, arrival_s) -> answer``) and its answer is written back. It knows
nothing about the protocol. It also plays the "unplugged cable" fault: the port vanishes at a
clock time and a new one appears later under the same ``stable_path`` symlink.
"""

from __future__ import annotations

import os
import select
import shutil
import tempfile
import threading
import time
import tty
from typing import Callable


class PtyServer:
    """Serve one pseudo-terminal in a background thread.

    Parameters
    ----------
    on_bytes : callable
        ``on_bytes(data: bytes, arrival_s: float) -> bytes``; ``arrival_s`` is wall time
        (``time.monotonic()``); the returned bytes are written to the host.
    name : str
        Thread name and ``stable_path`` file name.
    clock : Clock
        Decides when the port vanishes (``vanish_at_s`` is a clock time).
    vanish : callable or None
        ``vanish() -> (vanish_at_s or None, vanish_for_s)``, read on every loop (faults may change).
    on_reopen : callable or None
        Called after the port came back (e.g. to forget a partial request).
    """

    def __init__(self, on_bytes: Callable[[bytes, float], bytes], *, name: str, clock,
                 vanish: Callable[[], tuple[float | None, float]] | None = None,
                 on_reopen: Callable[[], None] | None = None) -> None:
        self.on_bytes = on_bytes
        self.name = name
        self.clock = clock
        self.vanish = vanish or (lambda: (None, 0.0))
        self.on_reopen = on_reopen or (lambda: None)
        self._master: int | None = None
        self._slave: int | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._vanished_until: float | None = None
        self._vanish_done = False
        self._dir: str | None = None  # made on first use of stable_path: an emulator never served makes nothing
        self.path: str | None = None

    @property
    def stable_path(self) -> str:
        """A path that always names the current pseudo-terminal (a symlink in a directory of its own)."""
        if self._dir is None:
            self._dir = tempfile.mkdtemp(prefix="ximc-emu-")
        return os.path.join(self._dir, self.name)

    @property
    def replugged(self) -> bool:
        """Whether the port vanished and a new one was made (the vanish fault played out)."""
        return self._vanish_done

    def start(self) -> str:
        """Open the pseudo-terminal and serve; returns the device path (/dev/pts/N)."""
        self._open()
        self._thread = threading.Thread(target=self._serve, name=f"ximc-emu-{self.name}", daemon=True)
        self._thread.start()
        return self.path

    def stop(self) -> None:
        """Stop serving, close the pty and remove the stable path."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._close()
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)

    def _open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        self._master, self._slave = master, slave
        self.path = os.ttyname(slave)
        tmp = self.stable_path + ".tmp"
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(self.path, tmp)
        os.replace(tmp, self.stable_path)

    def _close(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None

    def _serve(self) -> None:
        while not self._stop.is_set():
            self._maybe_vanish()
            if self._master is None:
                time.sleep(0.01)
                continue
            try:
                ready, _, _ = select.select([self._master], [], [], 0.02)
            except (OSError, ValueError):
                continue
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                continue
            answer = self.on_bytes(data, time.monotonic())
            if answer:
                self._write(answer)

    def _maybe_vanish(self) -> None:
        at_s, for_s = self.vanish()
        if at_s is None or self._vanish_done:
            return
        if self._vanished_until is None and self.clock.now() >= at_s:
            self._close()
            self._vanished_until = time.monotonic() + for_s  # a replug takes wall time
            try:
                os.unlink(self.stable_path)
            except OSError:
                pass
        elif self._vanished_until is not None and time.monotonic() >= self._vanished_until:
            self._open()
            self.on_reopen()
            self._vanish_done = True

    def _write(self, data: bytes) -> None:
        if self._master is None:
            return
        try:
            os.write(self._master, data)
        except OSError:
            pass
