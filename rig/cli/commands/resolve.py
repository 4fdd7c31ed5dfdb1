"""``rig resolve ARCHIVE -o RESULTS``: every archived session solved again, in chunks (docs/archive.md)."""

from __future__ import annotations

import sys
import time

from rig.archive.resolve import EXECUTORS, resolve_archive
from rig.cli.common import EXIT_OK


def add_parser(sub) -> None:
    r = sub.add_parser("resolve", help="solve every session of an archive again, in chunks, on a process pool")
    r.add_argument("archive")
    r.add_argument("-o", "--out", required=True, help="the results folder (one Parquet file per chunk; resumable)")
    r.add_argument("--executor", choices=EXECUTORS, default="processes")
    r.add_argument("--workers", type=int, default=None, help="processes (default: the machine's cores)")
    r.add_argument("--chunk", type=int, default=50, help="sessions per chunk (default 50)")
    r.add_argument("--model", choices=["triangular", "full"], default=None)
    r.add_argument("--method", choices=["pinv", "flip", "combinations"], default=None)
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="--executor dask: an existing Dask scheduler (tcp://host:8786); default a local cluster")


def run(args) -> int:
    start = time.monotonic()

    def progress(done: int, total: int) -> None:
        if total > 1:
            print(f"rig resolve: {done} of {total} chunks ({time.monotonic() - start:.0f} s)", file=sys.stderr,
                  flush=True)

    report = resolve_archive(args.archive, args.out, executor=args.executor, workers=args.workers, chunk=args.chunk,
                             model=args.model, method=args.method, progress=progress, scheduler=args.scheduler)
    print(f"resolved {args.archive} into {args.out}: {report.sessions} sessions, {report.chunks_solved} chunks solved "
          f"now, {report.chunks_done_before} found done; {len(report.failed)} failed now")
    for sid, reason in report.failed:
        print(f"  {sid}: {reason}")
    return EXIT_OK
