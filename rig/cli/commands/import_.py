"""``rig import --from imucal|imu_tk|tofupilot|csv SRC``: another tool's recording as a session."""

from __future__ import annotations

import sys
import time

import calib
from calib.errors import CalibError
from rig.analysis.discover import MAX_DISCOVER_STEPS, discover_session
from rig.analysis.solve import accelerometer_absent, check_plausible, placement, solve_present_sensors
from rig.cli import outputs
from rig.cli.common import EXIT_OK, UsageError
from rig.errors import RigInputError, SessionFormatError
from rig.importers.recordings import import_recording
from rig.session import SessionManifest, load_session, step_means

#: the follow-up commands are tried on the imported session up to this many samples (loading it whole);
#: a larger import names them untried (each says why, if it cannot)
TRY_MAX_SAMPLES = 500_000
#: ... and up to this many steps (rig discover refits at every step boundary: minutes on thousands of steps)
TRY_MAX_STEPS = 100


def add_parser(sub) -> None:
    im = sub.add_parser("import", help="import another tool's recording as a session")
    im.add_argument("--from", dest="source", required=True, choices=["imucal", "imu_tk", "tofupilot", "csv"])
    im.add_argument("src", help="the recording file")
    im.add_argument("-o", "--out", default="sessions",
                    help="sessions directory (default: sessions/; created when missing; a link to a folder is one)")
    im.add_argument("--id", default=None, help="session id (default: import-SOURCE-FILESTEM)")
    im.add_argument("--g", type=float, default=9.80665, help="local gravity for m/s^2 sources (default 9.80665)")
    im.add_argument("--window-s", type=float, default=120.0, help="tofupilot: seconds per step window")
    im.add_argument("--rate", type=float, default=None,
                    help="csv without a t_s column: the sample rate, Hz (or a '# rate_hz: N' or 'Fs,N' line in the file)")
    im.add_argument("--columns", default=None, metavar="OURS=THEIRS,...",
                    help="csv: other column names, e.g. ax=AccX,ay=AccY,az=AccZ,t_s=time (docs/import.md)")
    im.add_argument("--static-factor", type=float, default=6.0,
                    help="csv without labels: quasi-static threshold, times the noise floor (4..10, default 6)")
    im.add_argument("--static-min-s", type=float, default=1.0,
                    help="csv without labels: shortest rest kept, s (0.5..1, default 1)")
    im.add_argument("--continuous", action="store_true",
                    help="csv: the sensor turns all the time (a magnetometer turned by hand without rests): one "
                         "turning step, the ellipsoid fitted on its samples (docs/import.md)")


def run(args) -> int:
    if not args.window_s > 0:
        raise UsageError(f"--window-s: expected a positive number of seconds, got {args.window_s:g}")
    for option, value in (("--rate", args.rate), ("--columns", args.columns), ("--continuous", args.continuous or None)):
        if value is not None and args.source != "csv":
            raise UsageError(f"{option} applies to --from csv only (the {args.source} format states its own)")
    outputs.OutputPolicy(inputs=[args.src]).directory(args.out, what="the session")
    try:
        path = import_recording(args.source, args.src, args.out, args.id, g_ms2=args.g, window_s=args.window_s,
                                notify=lambda message: print(f"note: {message}"), rate_hz=args.rate,
                                column_map=args.columns, static_factor=args.static_factor,
                                static_min_s=args.static_min_s, progress=Progress(), continuous=args.continuous)
    except FileExistsError as exc:
        raise UsageError(f"{exc.filename}: a session with this id exists already; give another with --id ID "
                         "(or another sessions directory with -o)") from None
    info, _ = SessionManifest.load(path)  # the manifest only: the samples may be more than memory
    steps = info.steps
    n_samples = sum(int(st.stats.n_samples) for st in steps)
    known = sum(1 for st in steps if st.kind == "static" and st.f_nominal is not None)
    static = sum(1 for st in steps if st.kind == "static")
    imp = info.import_
    print(f"session: {path}")
    print(f"  {n_samples} samples at {info.rig.sensor.sample_rate_hz:g} Hz, "
          f"{len(steps)} steps ({static} static, {known} with known poses) from {imp.steps_from}; "
          f"units {imp.units}" + ("" if (imp.units or "").startswith("accelerometer none") else
                                  f", {imp.lsb_per_g:g} counts/g"))
    for note in imp.notes:
        print(f"  note: {note}")
    if n_samples > TRY_MAX_SAMPLES or len(steps) > TRY_MAX_STEPS:
        hints = [h for h, _ in next_steps(None, path, known, static)]
        print(f"  next (not tried on {n_samples} samples in {len(steps)} steps): {'; '.join(hints)}")
        return EXIT_OK
    s = load_session(path)
    hints = [h for h, works in next_steps(s, path, known, static) if works]
    print(f"  next: {'; '.join(hints)}" if hints else
          "  next: nothing can be solved from this recording alone (too few distinct poses)")
    return EXIT_OK


class Progress:
    """``rig import: N of M steps written (T s)`` on stderr, at most every :data:`PROGRESS_S` seconds, for an
    import of more than :data:`PROGRESS_STEPS` steps (the last step always)."""

    def __init__(self) -> None:
        self.start = self.last = time.monotonic()

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if total > PROGRESS_STEPS and (now - self.last >= PROGRESS_S or done == total):
            self.last = now
            print(f"rig import: {done} of {total} steps written ({now - self.start:.0f} s)", file=sys.stderr, flush=True)


#: progress is shown for imports of more than this many steps, every this many seconds
PROGRESS_STEPS = 1000
PROGRESS_S = 5.0


def next_steps(session, path, known: int, static: int = 0) -> list[tuple[str, bool]]:
    """The follow-up commands, each tried here first on ``session`` (None: not tried): only those that work
    on this import are shown (``rig discover`` never beyond its limit of static steps, ``static``)."""
    if session is not None and accelerometer_absent(session):
        res = solve_present_sensors(session)
        return [(f"rig solve {path}", res.magnetometer is not None or res.gyro_static is not None)]
    if known >= 6 and (session is None or not _misplaced(session)):
        solve = (f"rig solve {path}", True)
    else:
        steps = lambda: step_means(session, session.static_step_indices(unknown_pose=True))
        solve = (f"rig solve {path} --method magnitude", session is None or
                 _works(lambda: check_plausible(calib.solve(steps(), method="magnitude"), session.lsb_per_g)))
    if static > MAX_DISCOVER_STEPS:  # rig discover would refuse it: not suggested
        return [solve]
    return [solve, (f"rig discover {path}", session is None or _works(lambda: discover_session(path)))]


def _misplaced(session) -> bool:
    """Whether the known poses disagree with the data beyond the noise (rig solve would refuse them)."""
    try:
        found = placement(session)
    except (CalibError, SessionFormatError, RigInputError):
        return False  # rig solve says why
    return found is not None and found.misplaced


def _works(attempt) -> bool:
    try:
        attempt()
    except (CalibError, SessionFormatError, RigInputError):
        return False
    return True
