"""``rig report SESSION [-o REPORT.html]``: one self-contained HTML page of a calibrated session (docs/report.md)."""

from __future__ import annotations

from rig.cli.common import EXIT_OK, report_warnings
from rig.lab import ENV_VAR
from rig.lab.report import gather, page, report_path, write_page


def add_parser(sub) -> None:
    s = sub.add_parser("report", help="one self-contained HTML report of a session: verdict, parameters, "
                                      "residuals, roll/pitch table, discrepancy, history")
    s.add_argument("session")
    s.add_argument("-o", "--output", default=None, metavar="REPORT.html",
                   help="file to write (default SESSION/report.html; a directory: written inside it)")
    s.add_argument("--calibration", default=None, metavar="CALIB",
                   help="the calibration to report (default SESSION/calibration.yaml)")
    s.add_argument("--history", default=None, metavar="PATH",
                   help=f"history database (default ${ENV_VAR}, else ~/.local/share/rig/history.sqlite)")


def run(args) -> int:
    target = report_path(args.session, args.output)
    content = gather(args.session, calibration=args.calibration, history_db=args.history)
    report_warnings("report", content.session)
    path = write_page(target, page(content), explicit=args.output is not None)
    print(f"report: {path}")
    return EXIT_OK
