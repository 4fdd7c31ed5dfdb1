"""``rig verify SESSION``: is the session the recording as made? (its seal: docs/session-format.md, "Seal")."""

from __future__ import annotations

from pathlib import Path

from rig.cli.common import EXIT_OK
from rig.errors import SessionFormatError
from rig.lab.history import HistoryError, recorded_seals
from rig.session.manifest import SessionManifest
from rig.session.seal import NOT_SEALED, verify_session


def add_parser(sub) -> None:
    v = sub.add_parser("verify", help="check a session against its seal: the recording as made, or where it differs")
    v.add_argument("session")
    v.add_argument("--allow-unsealed", action="store_true",
                   help="a session without a seal (recorded before sealing existed, or unfinished) exits 0")
    v.add_argument("--history", default=None, metavar="PATH|URL",
                   help="also compare with the seal the calibration history recorded (default: $RIG_HISTORY, else "
                        "the user's; skipped when there is none)")


def run(args) -> int:
    d = Path(args.session)
    _, doc = SessionManifest.load(d)
    found = verify_session(d, doc)  # the first difference: one line naming the file and step (exit 2)
    if not found.sealed:
        checked = (f"; the {found.steps} steps recorded match the hashes taken when each was recorded"
                   if found.steps else "")
        compare_with_history(d, doc, None, args.history)  # a seal the history knows and the session lost
        if not args.allow_unsealed:
            raise SessionFormatError(str(d / "session.yaml"), None, None, NOT_SEALED + checked)
        print(f"{d}: {NOT_SEALED}{checked}")
        return EXIT_OK
    seal = found.seal
    note = compare_with_history(d, doc, seal, args.history)
    print(f"{d}: sealed, intact (sha256 {seal['sha256']}, {found.steps} steps chained, sealed {seal.get('sealed_at')}"
          f"{note})")
    return EXIT_OK


def compare_with_history(d: Path, doc: dict, seal: dict | None, history) -> str:
    """The history's copy of the seal (``calibrations.seal``), when it has one for this session: the same seal,
    else one line (exit 2: the session was sealed again, or its seal removed, after it was recorded). An
    unreadable history is a note."""
    try:
        rows = recorded_seals(str(doc.get("id")), history=history)
    except (HistoryError, OSError) as exc:
        return f"; history not compared: {(str(exc).splitlines() or [''])[0]}"
    rows = [r for r in rows if r["seal"] and "broken" not in r["seal"]]  # what a sealed session's solve recorded
    if not rows:
        return ""
    first = rows[0]
    theirs = first["seal"].get("sha256")
    if seal is None:
        raise SessionFormatError(str(d / "session.yaml"), None, "seal",
                                 f"the calibration history recorded session {doc.get('id')} on {first['recorded_at']} "
                                 f"sealed (seal {theirs}); the session has no seal now: it was removed after the "
                                 "recording was sealed, or it is another session with this id")
    if any(r["seal"].get("sha256") == seal["sha256"] for r in rows):
        return "; the calibration history recorded the same seal"
    raise SessionFormatError(str(d / "session.yaml"), None, "seal",
                             f"the calibration history recorded session {doc.get('id')} on {first['recorded_at']} "
                             f"with seal {theirs}, the session now carries {seal['sha256']}: it was sealed again after "
                             "it was recorded (changed and re-hashed), or it is another session with this id")
