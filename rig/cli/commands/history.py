"""``rig history [SENSOR]``: the sensors in the calibration history, or every calibration of one (docs/history.md)."""

from __future__ import annotations

import json
import sys

from rig.analysis import plots
from rig.cli import outputs
from rig.cli.common import EXIT_OK, UsageError, json_default
from rig.lab import (ENV_VAR, TABLE_WIDTH, HistoryError, default_path, format_history, history_document, list_sensors, open_history,
                     plot_history, resolve_sensor, sensor_history, store_calibration)


def add_parser(sub) -> None:
    s = sub.add_parser("history", help="calibration history: the sensors, or every calibration of one and its drift")
    s.add_argument("sensor", nargs="?", default=None, help="sensor key (or a unique part of it); none: list sensors")
    s.add_argument("--json", action="store_true", help="print the rig-history/1 document")
    s.add_argument("--wide", action="store_true",
                   help="one column for every calibration (by default the table keeps to 120 characters: the first "
                        "and the newest calibrations)")
    s.add_argument("--all", action="store_true",
                   help="include the calibrations recorded on the simulated and replay rigs (left out by default)")
    s.add_argument("--plot", default=None, metavar="FILE.png",
                   help="parameters over time with 1-sigma error bars (a directory: written inside it)")
    s.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)
    s.add_argument("--history", default=None, metavar="PATH|URL",
                   help=f"database file or URL (postgresql+psycopg://user@host/db; default ${ENV_VAR}, else "
                        "~/.local/share/rig/history.sqlite)")
    s.add_argument("--record", default=None, metavar="SESSION", help="record SESSION's calibration first")
    s.add_argument("--calibration", default=None, metavar="CALIB",
                   help="with --record: the calibration file (default SESSION/calibration.yaml)")
    s.add_argument("--sensor-id", default=None, help="with --record: serial or fixture id of the sensor")


def run(args) -> int:
    try:
        return _run(args)
    except HistoryError as exc:
        print(f"rig history: {exc}", file=sys.stderr)
        return exc.exit_code


def _run(args) -> int:
    if (args.calibration or args.sensor_id) and not args.record:
        raise UsageError("--calibration and --sensor-id need --record SESSION")
    if args.plot is not None and args.sensor is None:
        raise UsageError("--plot needs a SENSOR")
    plot = None
    if args.plot is not None:  # checked before anything is recorded or read
        policy = outputs.OutputPolicy(inputs=[default_path(args.history), args.record, args.calibration],
                                      follow=args.follow)
        plot = policy.file(args.plot, option="--plot", what="the plot", directory=True)
        if not plot.directory:
            plots.resolve_plot_path(args.plot, "unused.png")  # the suffix and the folder, now
    if args.record:
        calib_path = args.calibration or f"{args.record.rstrip('/')}/calibration.yaml"
        stored = store_calibration(args.record, calib_path, history=args.history, sensor_id=args.sensor_id)
        cid, key = stored
        number = table_number(args.history, key, cid)
        if stored.already:  # the same calibration of the same session: recorded once (docs/history.md)
            print(f"already recorded: calibration {number} of sensor {key} in {default_path(args.history)} "
                  "(nothing added)")
        else:
            print(f"recorded: calibration {number} of sensor {key} in {default_path(args.history)}")
        if args.sensor is None and not args.json and args.plot is None:
            return EXIT_OK
    with open_history(args.history, create=False) as h:
        if args.sensor is None:
            hidden = 0 if args.all else len(list_sensors(h)) - len(list_sensors(h, include_simulated=False))
            return _print_sensors(list_sensors(h, include_simulated=args.all), args, hidden)
        key = resolve_sensor(h, args.sensor)
        records = sensor_history(h, key, include_simulated=True if args.all else None)
    if plot is not None:
        if plot.directory:
            name = plots.safe_name(f"history-{key}") + ".png"
            plots.resolve_plot_path(args.plot, name)  # the suffix; a folder given with a trailing / is made
            plot = plot.inside(name)
        plot = outputs.write_figure(plot, plot_history(key, records), PLOT_DPI)
    if args.json:
        print(json.dumps(history_document(key, records), indent=2, default=json_default))
        if plot is not None:  # stdout is the JSON document
            print(f"plot: {plot}", file=sys.stderr)
    else:
        print(format_history(key, records, None if args.wide else TABLE_WIDTH))
        if plot is not None:
            print(f"plot: {plot}")
    return EXIT_OK


def table_number(history, key: str, cid: int) -> str:
    """The number the sensor's table (``rig history KEY``) gives calibration ``cid`` (its history row): ``#2``, its
    column (oldest first), not the database's row id; ``#2 (rig history KEY --all)`` when the default view leaves
    it out (a simulated record of a sensor with hardware calibrations)."""
    with open_history(history, create=False) as h:
        for view, where in ((None, ""), (True, f" (rig history {key} --all)")):
            ids = [r.id for r in sensor_history(h, key, include_simulated=view)]
            if cid in ids:
                return f"#{ids.index(cid) + 1}{where}"
    return f"(history row {cid})"  # not in the sensor's history as read back: say which row it is


#: the resolution rig.lab.drift.plot_history draws at
PLOT_DPI = 110


#: said under the sensor list when simulated sensors are left out of it (docs/history.md, "Simulated records")
HIDDEN_NOTE = ("{n} sensor(s) calibrated only on the simulated or replay rig are not listed: rig history --all "
               "lists them; rig history SENSOR shows one")


def _print_sensors(sensors: list[dict], args, hidden: int = 0) -> int:
    if args.json:
        print(json.dumps({"format": "rig-history/1", "sensors": sensors, "simulated_included": bool(args.all),
                          "sensors_not_listed": hidden}, indent=2, default=json_default))
        return EXIT_OK
    if not sensors:
        print("no calibrations recorded yet" if not hidden else "no calibrations recorded on a hardware rig yet")
    else:
        w = max(len("sensor"), *(len(s["sensor_key"]) for s in sensors))
        print(f"{'sensor':<{w}}  {'calibrations':>12}  {'first':<25}  last")
        for s in sensors:
            sim = f"  ({s['simulated']} simulated)" if s.get("simulated") else ""
            print(f"{s['sensor_key']:<{w}}  {s['n']:>12}  {s['first'] or '-':<25}  {s['last'] or '-'}{sim}")
    if hidden:
        print(HIDDEN_NOTE.format(n=hidden))
    return EXIT_OK
