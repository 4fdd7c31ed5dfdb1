"""``rig apply CALIB SESSION -o OUT.csv``: calibrated specific force (and rates, field) per sample."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from calib.file import calibration as calfile
from calib.gyro import GyroCalibration
from calib.mag import MagCalibration
from rig.cli.common import EXIT_OK, report_warnings
from rig.session import MAG_COUNTS_PER_UT, load_session


def add_parser(sub) -> None:
    a = sub.add_parser("apply", help="apply a calibration to a session's samples")
    a.add_argument("calibration")
    a.add_argument("session")
    a.add_argument("-o", "--output", required=True, help="output CSV: t_s,step,fx,fy,fz,temp_c")


def run(args) -> int:
    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    report_warnings("apply", session)
    d = session.samples
    temp = d["temp_c"] if session.has_temperature else None
    f = cal.accelerometer.apply(d["accel_counts"], temp_c=temp, t_s=d["t_s"])
    table = {"t_s": _fmt(d["t_s"], "%.4f"), "step": d["step"].astype(np.int64).astype(str),
             "fx": _fmt(f[:, 0], "%.7f"), "fy": _fmt(f[:, 1], "%.7f"), "fz": _fmt(f[:, 2], "%.7f"),
             "temp_c": _fmt(temp, "%.3f") if temp is not None else np.full(len(f), "")}
    if cal.gyroscope and "gyro_counts" in d:
        gyro = cal.gyroscope if isinstance(cal.gyroscope, GyroCalibration) else \
            GyroCalibration.from_dict(cal.gyroscope, args.calibration)
        w = gyro.apply(d["gyro_counts"])
        table.update({f"w{a}_dps": _fmt(w[:, j], "%.5f") for j, a in enumerate("xyz")})
    if cal.magnetometer and "mag_counts" in d:
        mag = cal.magnetometer if isinstance(cal.magnetometer, MagCalibration) else \
            MagCalibration.from_dict(cal.magnetometer, args.calibration)
        info = session.info.rig.sensor.magnetometer
        h = mag.apply(d["mag_counts"] / float((info.mag_lsb_per_ut if info else None) or MAG_COUNTS_PER_UT))
        table.update({f"m{a}_ut": _fmt(h[:, j], "%.5f") for j, a in enumerate("xyz")})
    out = Path(args.output)
    write_atomically(out, lambda tmp: pd.DataFrame(table).to_csv(tmp, index=False, lineterminator="\r\n"))
    print(f"wrote {len(f)} rows to {out}")
    return EXIT_OK


def write_atomically(path: Path, write) -> None:
    """``write(tmp)`` to a temporary file beside ``path``, then rename: a failure (a full disk) leaves
    no partial or empty file behind."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _fmt(values, spec: str) -> np.ndarray:
    """Numbers as text with ``spec`` (vectorised); NaN becomes an empty field."""
    v = np.asarray(values, float)
    text = np.char.mod(spec, np.where(np.isfinite(v), v, 0.0))
    return np.where(np.isfinite(v), text, "")
