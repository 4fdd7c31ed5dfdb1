"""``rig report SESSION [-o REPORT.html] [--follow]``: one self-contained HTML page of a calibrated session
(docs/report.md); ``rig report BATCH_DIR``: the batch report of a fixture run, a folder holding ``batch.json``
(docs/fixture.md, "The batch report")."""

from __future__ import annotations

from pathlib import Path

from rig.cli import outputs
from rig.cli.common import EXIT_OK, report_warnings
from rig.errors import RigInputError
from rig.lab import ENV_VAR, default_path
from rig.lab.batch_record import BATCH_FILE, is_batch
from rig.lab.report import gather, page, report_path
from rig.lab.report.batch import batch_page, batch_report_path, gather_batch
from rig.session import load_session

#: what rig report may write in the session it reports (docs/cli.md, "Output paths")
OWN = ("*.html",)


def add_parser(sub) -> None:
    s = sub.add_parser("report", help="one self-contained HTML report of a session: verdict, parameters, "
                                      "residuals, roll/pitch table, discrepancy, history")
    s.add_argument("session", help="a session directory, or a fixture run's batch directory (its batch.json): the "
                                   "batch report")
    s.add_argument("-o", "--output", default=None, metavar="REPORT.html",
                   help="file to write (default SESSION/report.html; a directory: written inside it; -: stdout)")
    s.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)
    s.add_argument("--calibration", default=None, metavar="CALIB",
                   help="the calibration to report (default SESSION/calibration.yaml)")
    s.add_argument("--history", default=None, metavar="PATH|URL",
                   help=f"history database file or URL (postgresql+psycopg://user@host/db; default ${ENV_VAR}, else "
                        "~/.local/share/rig/history.sqlite)")


def run(args) -> int:
    kind = what_is(args.session)
    if kind == "batch":
        return run_batch(args)
    if kind == "neither":
        raise RigInputError(args.session, None, None, "neither a session (no session.yaml: not a rig-session/1 "
                            f"directory) nor a fixture run's batch (no {BATCH_FILE}: not a rig-batch/1 directory)")
    session = None
    if args.output is None:  # the default is in the session folder: read the session first, so a folder that is
        session = load_session(args.session)  # not one is the session reader's one line
    out = target(args)
    content = gather(args.session, calibration=args.calibration, history_db=args.history, session=session)
    report_warnings("report", content.session)
    path = outputs.write(out, page(content))
    if path is not None:
        print(f"report: {path}")
    return EXIT_OK


def target(args) -> outputs.Output:
    """The report's output, checked by the output policy before anything is computed: ``-o`` (a file, a
    directory, ``-``; before the session is read) or ``SESSION/report.html``."""
    policy = outputs.OutputPolicy(inputs=[args.session, args.calibration, default_path(args.history)],
                                  session=args.session, follow=args.follow)
    if args.output is None:
        return policy.file(report_path(args.session), what="the report", own=OWN)
    out = policy.file(args.output, what="the report", own=OWN, stdout=True, directory=True)
    if out.directory:
        out = out.inside(report_path(args.session, args.output).name)
    return out


def what_is(path) -> str:
    """``session`` (or anything that is not a folder: the session reader says what is wrong), ``batch`` (a folder
    with ``batch.json`` and no ``session.yaml``) or ``neither`` (a folder with neither)."""
    p = Path(path)
    if not p.is_dir() or (p / "session.yaml").exists():
        return "session"
    return "batch" if is_batch(p) else "neither"


def run_batch(args) -> int:
    """The batch report: ``BATCH_DIR/batch-report.html`` (or ``-o``), the links to the slots' reports relative to
    where it is written."""
    if args.calibration is not None:
        raise RigInputError(args.session, None, "--calibration", "a batch reports each slot's own calibration; give "
                            "a slot's session directory to report another calibration of it")
    policy = outputs.OutputPolicy(inputs=[Path(args.session) / BATCH_FILE], follow=args.follow)
    if args.output is None:
        out = policy.file(batch_report_path(args.session), what="the batch report")
    else:
        out = policy.file(args.output, what="the batch report", stdout=True, directory=True)
        if out.directory:
            out = out.inside(f"{Path(args.session).resolve().name}-{batch_report_path('.').name}")
    page_dir = Path(args.session) if out.stdout else Path(out.path).expanduser().parent
    path = outputs.write(out, batch_page(gather_batch(args.session, page_dir=page_dir)))
    if path is not None:
        print(f"report: {path}")
    return EXIT_OK
