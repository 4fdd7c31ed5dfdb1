"""``rig characterize SESSION [--step N] [--terms N,B,K] [--json] [--plot FILE]``: the Allan deviation of every
axis of a static recording and its noise terms (docs/noise.md)."""

from __future__ import annotations

import json

from calib.noise.characterize import UNITS
from calib.noise.terms import DEFAULT_TERMS, parse_terms
from rig.analysis import characterize as chz
from rig.analysis import plots
from rig.cli import outputs
from rig.cli.common import EXIT_OK, json_default, report_warnings
from rig.lab import noise_profiles
from rig.session.reader import load_session

#: the resolution the plot is drawn at
PLOT_DPI = 100
#: term -> (printed heading, unit suffix after the sensor's unit)
HEADINGS = {t: (t, suffix) for t, suffix in chz.UNIT_SUFFIX.items()}


def add_parser(sub) -> None:
    c = sub.add_parser("characterize", help="Allan deviation of a static recording: each axis's noise terms "
                                            "(white noise, bias instability, random walk) with uncertainties")
    c.add_argument("session")
    c.add_argument("--step", type=int, default=None, help="the static step to characterise (default: the longest)")
    c.add_argument("--terms", default=",".join(DEFAULT_TERMS),
                   help="the terms to fit, of N, B, K, R (default N,B,K; a rate ramp R is added where seen)")
    c.add_argument("--json", action="store_true", help="print the characterisation as JSON (docs/noise.md)")
    c.add_argument("--plot", metavar="FILE.png", default=None,
                   help="the Allan deviations with the fitted lines (a directory: written inside it)")
    c.add_argument("-o", "--output", metavar="PROFILE.json", default=None,
                   help="write the unit's noise profile (rig-noise/1, docs/noise.md)")
    c.add_argument("--record", action="store_true",
                   help="store the profile under the unit's identity beside the calibration history: later "
                        "solves of this unit use its figures instead of the family's")
    c.add_argument("--history", default=None, metavar="PATH|URL",
                   help="the history database (file or URL) the profile is stored beside (default: "
                                                   "$RIG_HISTORY, else the user's)")
    c.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)


def run(args) -> int:
    terms = parse_terms(args.terms)
    policy = outputs.OutputPolicy(inputs=[args.session], session=args.session, follow=args.follow)
    plot = profile_out = None
    if args.output is not None:
        profile_out = policy.file(args.output, what="the profile", own=("noise-profile*.json",), stdout=True)
    if args.plot is not None:  # checked before the session is read
        plot = policy.file(args.plot, option="--plot", what="the plot", directory=True)
        if not plot.directory:
            plots.resolve_plot_path(args.plot, "unused.png")
    session = load_session(args.session)
    report_warnings("characterize", session)
    result, step, notes = chz.characterize_session(session, args.step, terms)
    extra = {}
    if plot is not None:
        name = plots.safe_name(f"{session.id or 'session'}-allan") + ".png"
        if plot.directory:
            plots.resolve_plot_path(args.plot, name)
            plot = plot.inside(name)
        fig = chz.adev_figure(result, f"Allan deviation: session {session.id}, step {step}")
        extra["plot"] = str(outputs.write_figure(plot, fig, PLOT_DPI))
    if profile_out is not None or args.record:
        profile = noise_profiles.profile_from(session, result, step)
        if args.record:
            extra["recorded"] = str(noise_profiles.record_profile(profile, args.history))
        if profile_out is not None:
            written = outputs.write(profile_out, profile.model_dump_json(indent=2) + "\n")
            if written is not None:
                extra["profile"] = str(written)
    if args.json:
        print(json.dumps({**to_json(session, result, step, notes), **extra}, indent=2, default=json_default))
        return EXIT_OK
    print(format_report(session, result, step, notes))
    for k, v in extra.items():
        print(f"{k}: {v}")
    return EXIT_OK


def to_json(session, result, step: int, notes: list[str]) -> dict:
    return {"format": "rig-characterize/1", "session": session.id, "step": step,
            "sensor": session.info.rig.sensor.model, "duration_s": result.duration_s, "rate_hz": result.rate_hz,
            "terms_asked": list(result.terms), "units": {s: UNITS[s] for s in result.fits},
            "axes": {s: {a: f.to_dict() for a, f in fits.items()} for s, fits in result.fits.items()},
            "notes": notes}


def format_report(session, result, step: int, notes: list[str]) -> str:
    lines = [f"session {session.id}, step {step}: {result.duration_s:.0f} s at {result.rate_hz:g} Hz, "
             f"{session.info.rig.sensor.model}; 95 % intervals"]
    for sensor, fits in result.fits.items():
        unit = UNITS[sensor]
        lines.append(f"{sensor} ({unit}):")
        for axis, fit in fits.items():
            cells = [f"{HEADINGS[t][0]} {f.value:.3g} [{f.lo:.3g}, {f.hi:.3g}] {unit}{HEADINGS[t][1]}"
                     for t, f in fit.terms.items()]
            floor = f", floor at {fit.tau_floor_s:.0f} s" if fit.tau_floor_s else ""
            lines.append(f"  {axis}: " + "; ".join(cells) + f"{floor}; chi2/dof {fit.chi2_dof:.2f}, "
                         f"worst point {100 * fit.max_rel_dev:.0f} % off the fit")
    lines += [f"note: {n}" for n in notes]
    return "\n".join(lines)
