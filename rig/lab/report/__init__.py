"""``rig report``: one self-contained HTML page per session (docs/report.md).

:func:`write_report` reads the session, its calibration file, what ``rig discover`` left in the session
and the sensor's calibration history (:mod:`rig.lab.report.content`), and writes the page
(:mod:`rig.lab.report.render`): the verdict, the identity of sensor and rig, the parameters with
sigmas and units, the residuals by step and temperature, the seed paper's roll/pitch table, the
discrepancy summary and the history. No network: style and figures are inside the file.
"""

from __future__ import annotations

import os
from pathlib import Path

from calib.file.calibration import atomic_write_text
from rig.errors import RigInputError
from rig.lab.report.content import ReportContent, gather
from rig.lab.report.render import page

REPORT_NAME = "report.html"


def report_path(session_dir, out=None) -> Path:
    """Where the report goes: ``SESSION/report.html``, ``out``, or ``out/SESSION-report.html`` when ``out``
    is a directory (an existing one, or one given with a trailing ``/``). RigInputError for a missing folder."""
    if out is None:
        return Path(session_dir) / REPORT_NAME
    text = os.fspath(out)
    p = Path(text).expanduser()
    if p.is_dir() or text.endswith(("/", os.sep)):
        p = p / f"{Path(session_dir).resolve().name}-{REPORT_NAME.replace('.html', '')}.html"
    if not p.parent.is_dir():
        raise RigInputError(text, None, "-o", f"cannot write the report: no such directory {p.parent}")
    return p


def write_report(session_dir, out=None, *, history_db=None, calibration=None, session=None,
                 calibration_file=None) -> Path:
    """Write the report of ``session_dir`` (default ``SESSION/report.html``); returns its absolute path.

    ``history_db``: the history database (default ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``);
    ``calibration``: the calibration file to report (default ``SESSION/calibration.yaml``);
    ``session``, ``calibration_file``: the loaded session and the calibration's content, when the caller
    holds them (neither is read again).
    Raises SessionFormatError / RigInputError / CalibrationFileError for bad input (no calibration yet,
    a report that cannot be written).
    """
    target = report_path(session_dir, out)
    return write_page(target, page(gather(session_dir, calibration=calibration, history_db=history_db, session=session,
                                          calibration_file=calibration_file)),
                      explicit=out is not None)


def write_page(target: Path, text: str, *, explicit: bool = True) -> Path:
    """Write the page atomically; a place that cannot be written is one RigInputError line (exit 2)."""
    try:
        atomic_write_text(target, text)
    except OSError as exc:
        raise RigInputError(str(target), None, "-o" if explicit else None,
                            f"cannot write the report ({exc.strerror or exc})"
                            + ("" if explicit else "; give another place with -o")) from None
    return target.resolve()


__all__ = ["REPORT_NAME", "ReportContent", "gather", "page", "report_path", "write_page", "write_report"]
