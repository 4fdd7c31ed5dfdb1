"""``rig report SESSION [-o REPORT.html] [--follow]``: one self-contained HTML page of a calibrated session
(docs/report.md)."""

from __future__ import annotations

from rig.cli import outputs
from rig.cli.common import EXIT_OK, report_warnings
from rig.lab import ENV_VAR, default_path
from rig.lab.report import gather, page, report_path
from rig.session import load_session

#: what rig report may write in the session it reports (docs/cli.md, "Output paths")
OWN = ("*.html",)


def add_parser(sub) -> None:
    s = sub.add_parser("report", help="one self-contained HTML report of a session: verdict, parameters, "
                                      "residuals, roll/pitch table, discrepancy, history")
    s.add_argument("session")
    s.add_argument("-o", "--output", default=None, metavar="REPORT.html",
                   help="file to write (default SESSION/report.html; a directory: written inside it; -: stdout)")
    s.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)
    s.add_argument("--calibration", default=None, metavar="CALIB",
                   help="the calibration to report (default SESSION/calibration.yaml)")
    s.add_argument("--history", default=None, metavar="PATH",
                   help=f"history database (default ${ENV_VAR}, else ~/.local/share/rig/history.sqlite)")


def run(args) -> int:
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
