"""A session being recorded is locked: a second writer is refused, a dead holder's lock is taken over."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from rig.session.lock import SessionLock, SessionLocked


def test_a_second_holder_is_refused_with_the_holder_named(tmp_path):
    with SessionLock(tmp_path):
        code = ("import sys; from rig.session.lock import SessionLock, SessionLocked\n"
                f"try:\n    SessionLock({str(tmp_path)!r}).acquire()\nexcept SessionLocked as e:\n"
                "    print(e); sys.exit(3)\n")
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 3
    assert f"pid {os.getpid()}" in proc.stdout and "being recorded" in proc.stdout


def test_the_lock_of_a_killed_process_is_taken_over_and_reported(tmp_path):
    code = (f"from rig.session.lock import SessionLock; import os, signal; SessionLock({str(tmp_path)!r}).acquire(); "
            "os.kill(os.getpid(), signal.SIGKILL)")
    proc = subprocess.run([sys.executable, "-c", code], timeout=60)
    assert proc.returncode == -9
    dead_pid = json.loads((tmp_path / "session.lock").read_text())["pid"]
    lock = SessionLock(tmp_path).acquire()
    try:
        assert lock.stale["pid"] == dead_pid
    finally:
        lock.release()
    assert SessionLock(tmp_path).acquire().stale is None  # released cleanly: nothing stale


def test_released_lock_can_be_taken_again_in_the_same_process(tmp_path):
    SessionLock(tmp_path).acquire().release()
    with SessionLock(tmp_path) as lock:
        with pytest.raises(SessionLocked):
            SessionLock(tmp_path).acquire()
        assert lock.stale is None


def test_a_run_refused_while_the_holder_is_still_writing_its_record_names_the_live_holder(tmp_path):
    """The holder writes its record just after taking the lock: a run refused in that moment read the
    previous (killed) holder's record, or an empty one, and said "pid ?" (seen in the concurrent-resume
    campaign under load). It waits for the live holder to name itself."""
    import fcntl
    import socket
    import threading

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    path = tmp_path / "session.lock"
    path.write_text(json.dumps({"pid": int(dead.stdout), "host": socket.gethostname(), "command": "killed",
                                "since": "earlier"}))
    with open(path, "r+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # taken; the record not yet rewritten

        def name_itself():
            fh.seek(0)
            fh.truncate()
            fh.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "command": "rig run",
                                 "since": "now"}))
            fh.flush()

        timer = threading.Timer(0.3, name_itself)
        timer.start()
        with pytest.raises(SessionLocked, match=rf"being recorded by pid {os.getpid()} "):
            SessionLock(tmp_path).acquire()
        timer.join()


def test_a_released_lock_leaves_no_lock_file_behind(tmp_path):
    with SessionLock(tmp_path):
        assert (tmp_path / "session.lock").is_file()
    assert not (tmp_path / "session.lock").exists()


def test_a_lock_file_removed_by_its_releasing_holder_is_opened_again_not_locked_unlinked(tmp_path):
    """B opened the lock file while A held it; A releases (removing the file); B's flock then succeeds on a
    removed file: B must open the path again, so that a third process C cannot lock a new file beside it."""
    import fcntl

    a = SessionLock(tmp_path).acquire()
    stale = open(tmp_path / "session.lock", "a+")  # what B opened before A let go
    a.release()
    fcntl.flock(stale.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # B's lock: on a file no longer in the folder
    try:
        with SessionLock(tmp_path) as c:  # C gets the lock (the file B locked is not the session's lock)
            assert (tmp_path / "session.lock").is_file()
            with pytest.raises(SessionLocked):
                SessionLock(tmp_path).acquire()  # and holds it against everyone after it
            assert c.stale is None
    finally:
        stale.close()


def test_a_holder_that_locked_a_removed_lock_file_opens_the_path_again(tmp_path, monkeypatch):
    """A releases (removing the file) between B's open and B's flock: B locks the removed file, sees it is not
    the session's lock any more, and opens and locks the path again."""
    import fcntl

    from rig.session import lock as lock_module

    a = SessionLock(tmp_path).acquire()
    real_flock = fcntl.flock
    calls = []

    def flock_after_a_lets_go(fd, op):
        if op & fcntl.LOCK_EX:
            if not calls:
                a.release()  # A lets go between B's open and B's lock
            calls.append(fd)
        return real_flock(fd, op)

    monkeypatch.setattr(lock_module.fcntl, "flock", flock_after_a_lets_go)
    b = SessionLock(tmp_path).acquire()
    monkeypatch.setattr(lock_module.fcntl, "flock", real_flock)
    try:
        assert len(calls) == 2  # locked twice: the removed file, then the path's new file
        assert os.fstat(b._fh.fileno()).st_ino == os.stat(tmp_path / "session.lock").st_ino
        with pytest.raises(SessionLocked):
            SessionLock(tmp_path).acquire()
    finally:
        b.release()
