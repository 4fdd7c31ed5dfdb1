"""``rig discover SESSION [--plot FILE] [-o CALIB] [--twin RIG] [--propose OUT] [--follow]``: where the model and the data disagree,
and which effect is missing."""

from __future__ import annotations

import json
import sys

from calib.numerics.design import MISFIT_LEVEL
from rig.analysis import discover as dsc
from rig.analysis import plots
from rig.analysis import propose as prop
from rig.analysis import twin as twn
from rig.cli import outputs
from rig.lab.noise_profiles import use_unit_profile
from rig.cli.common import EXIT_OK, Stages, check_false_alarm, json_default, report_warnings


def add_parser(sub) -> None:
    dc = sub.add_parser("discover", help="find where the model and the data disagree; name the missing effect")
    dc.add_argument("session")
    dc.add_argument("--json", action="store_true", help="print the rig-discover/6 JSON (docs/discrepancy.md) instead of the report")
    dc.add_argument("--details", action="store_true",
                    help="print the statistics too: where the data disagree, the effects tested and not needed, "
                         "the smallest detectable magnitudes, the per-step table (always in --json and the report)")
    dc.add_argument("--plot", metavar="FILE.png", default=None,
                    help="residuals before/after, by pose and temperature (a directory: written inside it)")
    dc.add_argument("-o", "--output", metavar="CALIB.yaml", default=None,
                    help="write the augmented calibration (effects filled in)")
    dc.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)
    dc.add_argument("--twin", metavar="RIG.yaml", default=None,
                    help="write the digital twin: a simulated-rig file whose sensor is the fitted model plus the "
                         "named effects, and the session's procedure beside it (docs/twin.md)")
    dc.add_argument("--propose", metavar="OUT.yaml", default=None,
                    help="when aliases or weak candidates remain, write the session's procedure with the steps that tell "
                         "the aliases apart or decide the weak candidate appended (T-optimal set-points, predicted "
                         "power printed; docs/discrepancy.md)")
    dc.add_argument("--false-alarm", type=float, default=MISFIT_LEVEL,
                    help="probability of naming an effect in a session that has none (default 0.01)")


#: what rig discover -o may write in the session it examines (docs/cli.md, "Output paths"); calibration.yaml is the
#: solve's and stays
OWN = ("calibration-*.yaml",)
#: the resolution rig.analysis.discover.write_plot draws at
PLOT_DPI = 100


#: a session of more static steps than this, or more bytes of samples, is discovered with its stages said on
#: stderr as they start (a 400-step session takes about a minute: docs/discrepancy.md)
LONG_STEPS = 100
LONG_BYTES = 20 * 1024 * 1024


def run(args) -> int:
    check_false_alarm(args.false_alarm)
    policy = outputs.OutputPolicy(inputs=[args.session], session=args.session, follow=args.follow)
    plot = cal_out = twin = None  # every output checked before the session is read
    if args.plot is not None:
        plot = policy.file(args.plot, option="--plot", what="the plot", directory=True)
        if not plot.directory:
            plots.resolve_plot_path(args.plot, "unused.png")  # the suffix and the folder, now
    if args.output is not None:
        cal_out = policy.file(args.output, what="the calibration", own=OWN, make_parents=True)
    if args.twin is not None:
        twin = policy.file(args.twin, option="--twin", what="the twin", directory=True)
    proposal = None if args.propose is None else policy.file(args.propose, option="--propose", what="the proposal",
                                                             make_parents=True)
    stages = Stages("discover", args.session, long_steps=LONG_STEPS, long_bytes=LONG_BYTES)
    noise = {}
    session, d = dsc.discover_session(args.session, false_alarm=args.false_alarm, progress=stages,
                                      prepare=lambda s: noise.update(used=use_unit_profile(s)))
    stages("done")
    report_warnings("discover", session)
    extra = {}
    if noise.get("used") and not args.json:  # the unit's own wander, as its calibrations weigh it (docs/noise.md)
        print(f"rig discover: note: the bias wander is the unit's own (its noise profile of "
              f"{noise['used']['measured_at'][:10]}), not the chip family's", file=sys.stderr)
    if plot is not None:
        name = plots.safe_name(f"{session.id or 'session'}-discover") + ".png"
        if plot.directory:
            plots.resolve_plot_path(args.plot, name)  # the suffix; a folder given with a trailing / is made
            plot = plot.inside(name)
        extra["plot"] = str(outputs.write_figure(plot, dsc.write_plot(d, None, session_id=session.id), PLOT_DPI))
    if cal_out is not None:
        with outputs.writing(cal_out):
            extra["calibration"] = str(dsc.write_calibration(session, d, cal_out.path))
    if twin is not None:
        extra.update(write_twin(session, d, twin))
    if proposal is not None:
        with outputs.writing(proposal):
            extra.update(prop.write_proposal(session, d, proposal.path))
    if args.json:
        print(json.dumps({**dsc.document(session, d), **extra, **({"noise": noise["used"]} if noise.get("used") else {})},
                         indent=2, default=json_default))
    else:
        print(dsc.format_report(session, d, details=args.details))
        for k, v in extra.items():
            print(f"{k}: {v}")
    return EXIT_OK


def write_twin(session, d, out: outputs.Output) -> dict:
    """``--twin``: the rig file (inside ``out`` when a directory: ``NAME.yaml``) and the procedure beside it,
    both checked by the output policy before either is written."""
    if d.calibration is None:  # no poses, no twin: its one-line refusal, nothing written
        twn.write_for_discovery(session, d, out.path)
    twin = twn.build_twin(session, d.calibration)
    rig_file = out.inside(f"{twin.document['name']}.yaml") if out.directory else out
    if twin.procedure_text:
        p = rig_file.path
        rig_file.beside(p.name[:-len(p.suffix)] + ".procedure.yaml" if p.suffix else p.name + ".procedure.yaml")
    with outputs.writing(rig_file):
        return twn.write_twin(twin, rig_file.path)
