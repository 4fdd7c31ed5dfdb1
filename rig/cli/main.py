"""The ``rig`` command. Stable contract (docs/cli.md): exit 0 ok, 2 bad input, 1 failure.

Every error is one line on stderr: what went wrong, where (file, line or
field), what was expected. No tracebacks (set ``RIG_DEBUG=1`` to see them).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
from pathlib import Path

import numpy as np
import yaml

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


class UsageError(Exception):
    """Bad command-line input (exit 2)."""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rig", description="Calibration rig controller: run procedures on a "
                                "Standa turntable with a MEMS sensor, record sessions, solve calibrations.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    r = sub.add_parser("run", help="run a procedure and record a session")
    r.add_argument("procedure", nargs="?", help="procedure YAML (omit with --resume)")
    r.add_argument("--rig", default=None, help="'sim' (default) or a rig file")
    r.add_argument("--out", default="sessions", help="sessions directory (default: sessions/)")
    r.add_argument("--seed", type=int, default=None, help="simulated rig: seed of the hidden sensor parameters")
    r.add_argument("--resume", metavar="DIR", default=None, help="continue an interrupted session")
    r.add_argument("--time-scale", type=float, default=None,
                   help="simulated rig: clock speed-up (0 = virtual time, as fast as possible)")
    r.add_argument("--yes", action="store_true", help="confirm every operator prompt")
    r.add_argument("--quiet", action="store_true", help="print only warnings and the result")

    s = sub.add_parser("solve", help="solve a recorded session into a calibration file")
    s.add_argument("session")
    s.add_argument("-o", "--output", default=None, help="calibration file (default SESSION/calibration.yaml)")
    s.add_argument("--model", choices=["triangular", "full"], default=None)
    s.add_argument("--method", choices=["pinv", "flip", "combinations", "magnitude"], default=None,
                   help="magnitude: |f| = 1 g in every static step, poses not needed (imported recordings)")
    s.add_argument("--thermal", default=None, help="auto | off | ORDER")
    s.add_argument("--json", action="store_true")

    a = sub.add_parser("apply", help="apply a calibration to a session's samples")
    a.add_argument("calibration")
    a.add_argument("session")
    a.add_argument("-o", "--output", required=True, help="output CSV: t_s,step,fx,fy,fz,temp_c")

    e = sub.add_parser("evaluate", help="evaluate a calibration against a session's poses")
    e.add_argument("calibration")
    e.add_argument("session")
    e.add_argument("--json", action="store_true")

    dc = sub.add_parser("discover", help="find where the model and the data disagree; name the missing effect")
    dc.add_argument("session")
    dc.add_argument("--json", action="store_true", help="print the rig-discover/1 JSON instead of the report")
    dc.add_argument("--plot", metavar="FILE.png", default=None, help="residuals before/after, by pose and temperature")
    dc.add_argument("-o", "--output", metavar="CALIB.yaml", default=None,
                    help="write the augmented calibration (effects filled in)")
    dc.add_argument("--false-alarm", type=float, default=0.01,
                    help="probability of naming an effect in a session that has none (default 0.01)")

    im = sub.add_parser("import", help="import another tool's recording as a session")
    im.add_argument("--from", dest="source", required=True, choices=["imucal", "imu_tk", "tofupilot", "csv"])
    im.add_argument("src", help="the recording file")
    im.add_argument("-o", "--out", default="sessions", help="sessions directory (default: sessions/)")
    im.add_argument("--id", default=None, help="session id (default: import-SOURCE-FILESTEM)")
    im.add_argument("--g", type=float, default=9.80665, help="local gravity for m/s^2 sources (default 9.80665)")
    im.add_argument("--window-s", type=float, default=120.0, help="tofupilot: seconds per step window")

    rp = sub.add_parser("replay", help="re-run a recorded session through the replay rig")
    rp.add_argument("session")
    rp.add_argument("--out", default=None, help="where the replayed session goes (default: beside the original)")

    sm = sub.add_parser("sim", help="start emulated controllers; show the simulated sensor")
    sm.add_argument("--count", type=int, default=3)
    sm.add_argument("--time-scale", type=float, default=1.0)
    sm.add_argument("--seed", type=int, default=0)
    sm.add_argument("--sensor", choices=["MPU-9150", "ADXL345"], default="MPU-9150")
    sm.add_argument("--once", action="store_true", help="print and exit instead of serving until Ctrl-C")

    sub.add_parser("ports", help="list serial ports and I2C buses and what answers on them")
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse already printed its one-line usage error
        return EXIT_BAD_INPUT if exc.code else EXIT_OK
    if not args.command:
        parser.print_help()
        return EXIT_BAD_INPUT
    handler = {"run": cmd_run, "solve": cmd_solve, "apply": cmd_apply, "evaluate": cmd_evaluate,
               "replay": cmd_replay, "discover": cmd_discover, "import": cmd_import, "sim": cmd_sim, "ports": cmd_ports}[args.command]
    try:
        return handler(args)
    except BaseException as exc:  # noqa: BLE001 - the one place errors become exit codes
        code, line = classify(exc)
        if os.environ.get("RIG_DEBUG"):
            raise
        print(f"rig {args.command}: {line}", file=sys.stderr)
        return code


def classify(exc: BaseException) -> tuple[int, str]:
    """Map an exception to (exit code, one line)."""
    from calib.errors import CalibError
    from drivers.sensors.base import SensorError
    from drivers.ximc.stage import TurntableError
    from rig.errors import RigInputError, SessionFormatError
    from rig.execution.engine import RunAborted, RunError
    from rig.console import OperatorAbsent

    first = (str(exc).strip().splitlines() or [""])[0]
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_FAILURE, "interrupted"
    if isinstance(exc, (RigInputError, SessionFormatError, CalibError, UsageError, OperatorAbsent)):
        return EXIT_BAD_INPUT, first
    if isinstance(exc, FileNotFoundError):
        return EXIT_BAD_INPUT, f"{exc.filename}: no such file or directory"
    if isinstance(exc, IsADirectoryError):
        return EXIT_BAD_INPUT, f"{exc.filename}: is a directory, expected a file"
    if isinstance(exc, yaml.YAMLError):
        return EXIT_BAD_INPUT, f"not valid YAML: {first}"
    if isinstance(exc, RunAborted):
        return EXIT_FAILURE, f"aborted: {first}"
    if isinstance(exc, (TurntableError, SensorError, RunError)):
        return EXIT_FAILURE, first
    if isinstance(exc, OSError):
        return EXIT_FAILURE, f"{exc.strerror or first}" + (f": {exc.filename}" if exc.filename else "")
    return EXIT_FAILURE, f"internal error ({type(exc).__name__}: {first}); rerun with RIG_DEBUG=1 and report it"


# -- commands ----------------------------------------------------------------------------
def cmd_run(args) -> int:
    from rig.execution.lifecycle import run_procedure
    from rig.execution.engine import RunAborted
    from rig.console import ConsoleUI

    if args.procedure is None and args.resume is None:
        raise UsageError("give a procedure file, or --resume DIR")
    _stop_on_signals()
    ui = ConsoleUI(assume_yes=args.yes, quiet=args.quiet)
    try:
        result = run_procedure(args.procedure, rig_spec=args.rig, out_dir=args.out, seed=args.seed,
                               resume_dir=args.resume, ui=ui, time_scale=args.time_scale)
    except RunAborted as exc:
        print(f"rig run: aborted: {exc}; motors stopped. Resume with: rig run --resume <session dir>",
              file=sys.stderr)
        return EXIT_FAILURE
    flagged = [o for o in result.outcomes if o.status == "flagged"]
    print(f"session: {result.session_dir}")
    if flagged:
        print(f"flagged steps (left out of the solve): {', '.join(str(o.index + 1) for o in flagged)}")
    if result.calibration is not None:
        print(f"calibration: {result.calibration_path}")
        print(format_calibration(result.calibration))
    return EXIT_OK


def _stop_on_signals() -> None:
    """Ctrl-C (SIGINT) and SIGTERM stop the motors and abort the run, even when the shell that started
    us ignores SIGINT (a background job does): the turntable must stop whoever asks."""
    import signal

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)


def cmd_solve(args) -> int:
    from rig.analysis.solve import solve_session

    thermal = _parse_thermal(args.thermal)
    cal, path = solve_session(args.session, model=args.model, method=args.method, thermal=thermal,
                              out=args.output)
    if args.json:
        print(json.dumps({"calibration": str(path), **cal.to_dict()}, indent=2, default=_json_default))
    else:
        print(f"calibration: {path}")
        print(format_calibration(cal))
        if args.method != "magnitude":
            _print_redundancy(args.session)
    return EXIT_OK


def _print_redundancy(session_dir) -> None:
    """The six-pose redundancy check, when the session has two or more +/- pose pairs."""
    from calib.errors import CalibError
    from calib.redundancy import pair_biases
    from rig.session.store import load_session
    try:
        steps = load_session(session_dir).step_means()
        r = pair_biases(steps)
    except (CalibError, Exception):  # noqa: BLE001 - an optional extra; the calibration is already written
        return
    print("  " + r.format_table(steps.lsb_per_g).replace("\n", "\n  "))


def cmd_apply(args) -> int:
    from calib import calfile
    from rig.session.store import load_session

    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    d = session.samples
    temp = d["temp_c"] if session.has_temperature else None
    f = cal.accelerometer.apply(d["accel_counts"], temp_c=temp, t_s=d["t_s"])
    extra_cols, extra = [], []
    if cal.gyroscope and "gyro_counts" in d:
        from calib.gyro import GyroCalibration
        extra_cols += ["wx_dps", "wy_dps", "wz_dps"]
        extra.append(GyroCalibration.from_dict(cal.gyroscope, args.calibration).apply(d["gyro_counts"]))
    if cal.magnetometer and "mag_counts" in d:
        from calib.magnetometer import MagCalibration
        from rig.execution.lifecycle import MAG_LSB_PER_UT
        info = session.manifest["rig"]["sensor"].get("magnetometer") or {}
        lsb = float(info.get("mag_lsb_per_ut", MAG_LSB_PER_UT))
        extra_cols += ["mx_ut", "my_ut", "mz_ut"]
        extra.append(MagCalibration.from_dict(cal.magnetometer, args.calibration).apply(d["mag_counts"] / lsb))
    out = Path(args.output)
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "step", "fx", "fy", "fz", "temp_c"] + extra_cols)
        for i in range(len(f)):
            tc = "" if temp is None or not np.isfinite(temp[i]) else f"{temp[i]:.3f}"
            row = [f"{d['t_s'][i]:.4f}", int(d["step"][i]), f"{f[i, 0]:.7f}", f"{f[i, 1]:.7f}", f"{f[i, 2]:.7f}", tc]
            for blk in extra:
                row += ["" if not np.isfinite(v) else f"{v:.5f}" for v in blk[i]]
            w.writerow(row)
    print(f"wrote {len(f)} rows to {out}")
    return EXIT_OK


def cmd_discover(args) -> int:
    from rig.analysis import discover as dsc

    if not 0 < args.false_alarm < 0.5:
        raise UsageError(f"--false-alarm: expected a probability in (0, 0.5), got {args.false_alarm:g}")
    session, d = dsc.discover_session(args.session, false_alarm=args.false_alarm)
    extra = {}
    if args.plot:
        extra["plot"] = str(dsc.write_plot(d, args.plot))
    if args.output:
        extra["calibration"] = str(dsc.write_calibration(session, d, args.output))
    if args.json:
        print(json.dumps({**d.to_json(), **extra}, indent=2, default=_json_default))
    else:
        print(dsc.format_report(session, d))
        for k, v in extra.items():
            print(f"{k}: {v}")
    return EXIT_OK


def cmd_import(args) -> int:
    from rig.importers.recordings import import_recording
    from rig.session.store import load_session

    if not args.window_s > 0:
        raise UsageError(f"--window-s: expected a positive number of seconds, got {args.window_s:g}")
    path = import_recording(args.source, args.src, args.out, args.id, g_ms2=args.g, window_s=args.window_s)
    s = load_session(path)
    steps = s.manifest["steps"]
    known = sum(1 for st in steps if st.get("kind") == "static" and st.get("f_nominal") is not None)
    static = sum(1 for st in steps if st.get("kind") == "static")
    imp = s.manifest["import"]
    print(f"session: {path}")
    print(f"  {len(s.samples['t_s'])} samples at {s.manifest['rig']['sensor']['sample_rate_hz']:g} Hz, "
          f"{len(steps)} steps ({static} static, {known} with known poses) from {imp['steps_from']}; "
          f"units {imp['units']}, {imp['lsb_per_g']:g} counts/g")
    for note in imp["notes"]:
        print(f"  note: {note}")
    hint = "rig solve SESSION" if known >= 6 else "rig solve SESSION --method magnitude"
    print(f"  next: {hint}; rig discover SESSION")
    return EXIT_OK


def cmd_evaluate(args) -> int:
    import calib
    from calib import calfile
    from rig.session.store import load_session

    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    ev = calib.evaluate(cal.accelerometer, session.step_means())
    if args.json:
        print(json.dumps(ev.to_dict(), indent=2, default=_json_default))
    else:
        print(ev.format_table())
    return EXIT_OK


def cmd_replay(args) -> int:
    from rig.simulation.replay import replay_session

    result = replay_session(args.session, out_dir=args.out)
    print(f"replayed session: {result.session_dir}")
    if result.calibration is not None:
        print(f"calibration: {result.calibration_path}")
        print(format_calibration(result.calibration))
    return EXIT_OK


def cmd_sim(args) -> int:
    from rig.simulation.tools import serve_sim

    return serve_sim(count=args.count, time_scale=args.time_scale, seed=args.seed, sensor_model=args.sensor,
                     once=args.once)


def cmd_ports(args) -> int:
    from rig.devices.ports import list_ports

    for line in list_ports():
        print(line)
    return EXIT_OK


# -- helpers -----------------------------------------------------------------------------
def _parse_thermal(v):
    if v is None:
        return None
    if v in ("auto", "off"):
        return v
    try:
        order = int(v)
    except ValueError:
        raise UsageError(f"--thermal: expected auto, off or a polynomial order 1..3, got {v!r}") from None
    if not 1 <= order <= 3:
        raise UsageError(f"--thermal: expected auto, off or a polynomial order 1..3, got {v!r}")
    return order


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def format_calibration(cal) -> str:
    """A short human summary of a calibration file's accelerometer section."""
    a = cal.accelerometer
    lines = [f"  model: {a.model}   fit: {a.fit.steps} steps, residual {a.fit.residual_rms_g * 1e6:.1f} ug rms, "
             f"chi2/dof {a.fit.chi2_per_dof:.2f}"]
    sig = a.sigma
    for j, axis in enumerate("xyz"):
        lines.append(f"  {axis}: bias {a.bias_counts[j]:10.2f} +- {sig['bias_counts'][j]:.2f} counts   "
                     f"scale {a.scale_counts_per_g[j]:10.2f} +- {sig['scale_counts_per_g'][j]:.2f} counts/g")
    if a.misalignment:
        m = a.misalignment
        sm = sig.get("misalignment") or {}
        lines.append("  misalignment (mrad): " + "  ".join(
            f"{k} {m[k] * 1e3:.3f} +- {sm.get(k, float('nan')) * 1e3:.3f}" for k in ("alpha_yz", "alpha_zy", "alpha_zx")))
    if a.temperature:
        t = a.temperature
        lines.append(f"  temperature: t0 {t.t0_c:.2f} C, order {t.order}")
    if a.effects:
        lines.append("  effects: " + ", ".join(e["name"] for e in a.effects))
    if cal.gyroscope:
        from calib.gyro import GyroCalibration
        g = GyroCalibration.from_dict(cal.gyroscope)
        b = np.asarray(g.bias_counts) / g.lsb_per_dps
        sb = np.array([g.sigma[f"b_{x}"] for x in "xyz"]) / g.lsb_per_dps
        lines.append(f"  gyroscope: {g.n_steps} rate steps, residual {g.residual_rms_dps:.4f} deg/s rms; bias "
                     + " ".join(f"{x} {v:+.4f}+-{e:.4f}" for x, v, e in zip("xyz", b, sb)) + " deg/s; scale "
                     + " ".join(f"{v:.3f}" for v in np.asarray(g.scale_counts_per_dps)) + " counts/(deg/s)")
    if cal.magnetometer:
        from calib.magnetometer import MagCalibration
        m = MagCalibration.from_dict(cal.magnetometer)
        lines.append(f"  magnetometer ({m.method}): {m.n_steps} steps, residual {m.residual_rms_ut:.3f} uT rms; "
                     "hard iron " + " ".join(f"{v:+.2f}" for v in np.asarray(m.hard_iron_ut)) + " uT")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
