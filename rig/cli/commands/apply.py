"""``rig apply CALIB SESSION -o OUT.csv``: calibrated specific force (and rates, field) per sample."""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from calib.file import calibration as calfile
from rig.analysis.apply import recording_from_session
from rig.cli import outputs
from rig.cli.commands.evaluate import note_other_unit
from rig.cli.common import EXIT_OK, report_warnings
from rig.session import load_session


def add_parser(sub) -> None:
    a = sub.add_parser("apply", help="apply a calibration to a session's samples")
    a.add_argument("calibration")
    a.add_argument("session")
    a.add_argument("-o", "--output", required=True, help="output CSV: t_s,step,fx,fy,fz,temp_c (-: stdout)")
    a.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)


def run(args) -> int:
    dest = outputs.OutputPolicy(inputs=[args.calibration, args.session], follow=args.follow).file(
        args.output, what="the calibrated samples", stdout=True)
    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    report_warnings("apply", session)
    note_other_unit("apply", cal, args.calibration, session)
    # the one entry point: every section the session has data for, after the sensor/range/unit checks
    out = cal.apply(recording_from_session(session), source=str(args.calibration))
    f, temp = out.f_g, out.temp_c
    table = {"t_s": _fmt(out.t_s, "%.4f"), "step": session.samples["step"].astype(np.int64).astype(str),
             "fx": _fmt(f[:, 0], "%.7f"), "fy": _fmt(f[:, 1], "%.7f"), "fz": _fmt(f[:, 2], "%.7f"),
             "temp_c": _fmt(temp, "%.3f") if temp is not None else np.full(len(f), "")}
    if out.w_dps is not None:
        table.update({f"w{a}_dps": _fmt(out.w_dps[:, j], "%.5f") for j, a in enumerate("xyz")})
    if out.h_ut is not None:
        table.update({f"m{a}_ut": _fmt(out.h_ut[:, j], "%.5f") for j, a in enumerate("xyz")})
    outputs.write(dest, pd.DataFrame(table).to_csv(None, index=False, lineterminator="\r\n"))
    if dest.stdout and outputs.reader_left_unread(sys.stdout):  # `-o - | head -1`: taken by the pipe, not read
        print(f"rig apply: wrote {len(f)} rows to stdout; its reader closed it before reading them all",
              file=sys.stderr)
        return EXIT_OK
    print(f"wrote {len(f)} rows to {'stdout' if dest.stdout else args.output}",
          file=sys.stderr if dest.stdout else sys.stdout)
    return EXIT_OK


def _fmt(values, spec: str) -> np.ndarray:
    """Numbers as text with ``spec`` (vectorised); NaN becomes an empty field."""
    v = np.asarray(values, float)
    text = np.char.mod(spec, np.where(np.isfinite(v), v, 0.0))
    return np.where(np.isfinite(v), text, "")
