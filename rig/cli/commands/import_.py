"""``rig import --from imucal|imu_tk|tofupilot|csv SRC``: another tool's recording as a session."""

from __future__ import annotations

from rig.cli.common import EXIT_OK, UsageError
from rig.importers.recordings import import_recording
from rig.session.store import load_session


def add_parser(sub) -> None:
    im = sub.add_parser("import", help="import another tool's recording as a session")
    im.add_argument("--from", dest="source", required=True, choices=["imucal", "imu_tk", "tofupilot", "csv"])
    im.add_argument("src", help="the recording file")
    im.add_argument("-o", "--out", default="sessions", help="sessions directory (default: sessions/)")
    im.add_argument("--id", default=None, help="session id (default: import-SOURCE-FILESTEM)")
    im.add_argument("--g", type=float, default=9.80665, help="local gravity for m/s^2 sources (default 9.80665)")
    im.add_argument("--window-s", type=float, default=120.0, help="tofupilot: seconds per step window")


def run(args) -> int:
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
