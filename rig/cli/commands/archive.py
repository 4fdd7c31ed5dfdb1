"""``rig archive SESSION... -o ARCHIVE``: sessions into a Parquet archive; ``--extract ID``: one back (docs/archive.md)."""

from __future__ import annotations

import sys
from pathlib import Path

from rig.archive.store import archive_sessions, extract_session
from rig.cli.common import EXIT_OK, UsageError
from rig.errors import RigInputError


def add_parser(sub) -> None:
    a = sub.add_parser("archive", help="session directories into a partitioned Parquet archive (or one back out)")
    a.add_argument("paths", nargs="+", metavar="SESSION",
                   help="session directories to add (with --extract: the archive)")
    a.add_argument("-o", "--out", required=True, help="the archive directory (with --extract: where the session goes)")
    a.add_argument("--lot", default=None, help="a lot name recorded with every session added")
    a.add_argument("--extract", default=None, metavar="SESSION_ID",
                   help="write this archived session back as a session directory under -o")


def run(args) -> int:
    if args.extract is not None:
        if len(args.paths) != 1:
            raise UsageError("--extract takes one archive: rig archive --extract SESSION_ID ARCHIVE -o DIR")
        target = extract_session(args.paths[0], args.extract, args.out)
        print(f"session: {target}")
        return EXIT_OK
    for p in args.paths:
        if not Path(p, "session.yaml").is_file():
            raise RigInputError(str(p), None, None, "not a session directory (no session.yaml)")
    report = archive_sessions(args.paths, args.out, lot=args.lot)
    print(f"archive {args.out}: {len(report.added)} added, {len(report.skipped)} already there (the same content)"
          + (f", {len(report.refused)} refused" if report.refused else ""))
    for line in report.refused:
        print(f"rig archive: {line}", file=sys.stderr)
    return EXIT_OK if not report.refused else 2
