"""``rig characterize-rig SESSION [-o FILE]``: the turntable's own errors by reversal from a session of one sensor
in several mountings in its fixture (``procedures/characterize_reversal.yaml``), printed with their standard
uncertainties and stored as the rig's characterisation (``rig-characterisation/1``, next to the rig file unless
``-o``), which every later calibration on that rig file uses (docs/uncertainty.md)."""

from __future__ import annotations

import math

from calib.accel.reversal import ALIASES
from rig.analysis.characterisation_record import CharacterisationRecord, default_path
from rig.analysis.rig_characterisation import characterise_session, kept_as_classes
from rig.analysis.uncertainty import rig_errors, session_rig_facts
from rig.cli import outputs
from rig.cli.common import EXIT_OK, report_warnings
from rig.session.reader import load_session


def add_parser(sub) -> None:
    c = sub.add_parser("characterize-rig", help="the turntable's own errors by reversal (one sensor in several "
                                                "mountings); stored as the rig's characterisation")
    c.add_argument("session", help="a session of procedures/characterize_reversal.yaml (or any procedure whose "
                                   "prompts turn the sensor in its fixture: mount:)")
    c.add_argument("-o", "--output", metavar="FILE.yaml", default=None,
                   help="where to write the characterisation (default: next to the session's rig file, "
                        "<rig file stem>.characterisation.yaml, where later calibrations find it)")
    c.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)


def run(args) -> int:
    policy = outputs.OutputPolicy(inputs=[args.session], session=args.session, follow=args.follow)
    out = policy.file(args.output, what="the characterisation", stdout=True) if args.output is not None else None
    session = load_session(args.session)
    report_warnings("characterize-rig", session)
    record = characterise_session(session)
    if out is None:
        out = policy.file(str(default_path(record.rig_file)), what="the characterisation")
    if not out.stdout:  # -o -: the record alone on standard output
        print(format_report(record, session))
    written = outputs.write(out, record.to_yaml())
    if written is not None:
        print(f"characterisation: {written} (used by every calibration on rig file sha256 "
              f"{record.rig_file_sha256[:12]}..)")
    return EXIT_OK


def format_report(record: CharacterisationRecord, session) -> str:
    """The table's errors with their standard uncertainties, the aliases they hold, what stays a class."""
    c = record.characterisation
    lines = [f"rig characterisation by reversal: session {record.session}",
             f"  rig file: {record.rig_file} (sha256 {record.rig_file_sha256[:12]}..)",
             "  mountings: " + "; ".join(f"{m['turn']} ({m['steps']} poses)" for m in record.mountings),
             "  table errors (deg, and mrad as misalignments are printed; u: standard uncertainty as the table's "
             "own error, then as a correction of later poses):"]
    fix = c.u_correction_deg or c.u_deg
    for name, value in c.estimate_deg.items():
        mrad = math.radians(value) * 1e3
        lines.append(f"    {name:<26} {value:+.5f} deg ({mrad:+.3f} mrad)  u {c.u_deg[name]:.5f} deg, "
                     f"as a correction {fix[name]:.5f} deg")
    lines.append(f"  chi2/dof {c.chi2_per_dof:.2f} ({c.dof} dof)")
    lines.append(f"  held by the above (no term of their own in later budgets): {', '.join(ALIASES)}")
    n_poses = record.mountings[0]["steps"] if record.mountings else 6
    kept = kept_as_classes(rig_errors(session_rig_facts(session)), n_poses)
    kinds = sorted({n.split(".")[0] for n, _ in kept})
    largest = max((u for _, u in kept), default=0.0)
    lines.append(f"  kept as classes (they change from pose to pose): {', '.join(kinds)} of each stage "
                 f"(u up to {largest:.4f} deg)")
    return "\n".join(lines)
