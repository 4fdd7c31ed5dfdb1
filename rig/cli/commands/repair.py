"""``rig repair SESSION``: cut back what a crash left past the last finished step, after a backup.

Only what is provably not part of a finished step is cut (:func:`rig.session.recovery.repair`): the rows of
the step that was in progress and a torn last line of ``samples.csv`` (a copy is kept as
``samples.csv.bak-<UTC stamp>``), and a torn last line of the steps journal. Anything else that disagrees
with the manifest is refused as ``rig run --resume`` refuses it (exit 2), every file untouched.
"""

from __future__ import annotations

import shlex
import sys

from rig.cli.codes import EXIT_OK
from rig.session import SessionManifest
from rig.session.lock import SessionLock
from rig.session.recovery import repair


def add_parser(sub) -> None:
    r = sub.add_parser("repair", help="cut back what a crash left past a session's last finished step (after a "
                                      "backup); refuse anything else")
    r.add_argument("session", metavar="SESSION", help="the session directory")


def run(args) -> int:
    info, _ = SessionManifest.load(args.session)  # a directory that is not a session is refused before it is locked
    with SessionLock(args.session) as lock:
        if lock.stale:
            print(f"rig repair: warning: took over the lock of pid {lock.stale.get('pid', '?')} on "
                  f"{lock.stale.get('host', '?')}, which is no longer running", file=sys.stderr)
        done = repair(args.session)
    print(f"rig repair: {done.summary()}")
    if done.changed and info.status != "complete":
        print(f"resume with: rig run --resume {shlex.quote(str(args.session))}")
    return EXIT_OK
