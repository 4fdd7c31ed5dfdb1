"""A session of one sensor in several mountings in its fixture -> the rig's characterisation by reversal
(``rig characterize-rig``, docs/uncertainty.md, "Characterisation by reversal").

The session's complete static steps are grouped by the mounting in force (``steps[].mount``, recorded when a
procedure's prompts say ``mount:``: ``procedures/characterize_reversal.yaml``); each group's step means, in the
first group's pose order, is one :class:`calib.accel.reversal.Mounting`; the fit (:func:`calib.accel.reversal.
characterise`) gives the table's errors with their standard uncertainties. The result is a
:class:`~rig.analysis.characterisation_record.CharacterisationRecord` tied to the session's rig file (its path and
the sha256 the run recorded), which must still be there unchanged.
"""

from __future__ import annotations

from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from calib.accel.reversal import ALIASES, CHARACTERISED, Mounting, characterise
from calib.accel.rig_propagation import rig_parameters
from calib.errors import CalibError
from calib.numerics.budget import RigErrors
from rig.analysis.characterisation_record import CharacterisationRecord
from rig.analysis.uncertainty import rig_errors, session_rig_facts
from rig.config.rotations import describe, name_of
from rig.session import Session, step_means

#: two poses are the same when their nominal specific forces agree to this (g)
SAME_POSE_G = 1e-9


def mounting_groups(session: Session) -> list[tuple[np.ndarray, list[int]]]:
    """The complete static steps with a known pose grouped by the sensor's turn in its fixture: (turn 3x3, sensor
    -> fixture frame; step indices), in the order the mountings were first recorded. CalibError (one line) when the
    session records no mounting (not recorded with a procedure whose prompts say ``mount:``)."""
    steps = {s.index: s for s in session.info.steps}
    idx = session.static_step_indices()
    if not any(steps[i].mount is not None for i in idx):
        raise CalibError(f"{session.path}: the session records no mounting (steps[].mount): record it with a "
                         "procedure whose prompts turn the sensor in its fixture (mount:, e.g. "
                         "procedures/characterize_reversal.yaml)")
    groups: list[tuple[np.ndarray, list[int]]] = []
    for i in idx:
        turn = np.array(steps[i].mount.turn if steps[i].mount is not None else np.eye(3), float)
        for q, members in groups:
            if np.allclose(q, turn, atol=1e-9):
                members.append(i)
                break
        else:
            groups.append((turn, [i]))
    return groups


def table_poses(session: Session, turn: np.ndarray, members: list[int]) -> np.ndarray:
    """The table's nominal poses (K, 3), g, fixture frame, of steps recorded with the sensor turned by ``turn``:
    ``Q f`` of each step's ``f_nominal`` (which the session records in the turned sensor's frame)."""
    f = np.array([session.info.steps[i].f_nominal for i in members], float)
    return f @ np.asarray(turn, float).T


def _in_order_of(first_f: np.ndarray, f: np.ndarray, members: list[int]) -> list[int]:
    """``members`` (their table poses ``f``) ordered as the poses ``first_f`` (unchanged when they are other poses:
    the fit refuses them)."""
    ordered: list[int] = []
    for target in first_f:
        match = next((k for k in range(len(members)) if k not in ordered
                      and np.allclose(f[k], target, atol=SAME_POSE_G)), None)
        if match is None:
            return members
        ordered.append(match)
    return [members[k] for k in ordered] if len(ordered) == len(members) else members


def characterise_session(session: Session) -> CharacterisationRecord:
    """The rig's characterisation from ``session`` (CalibError, one line: no mounting recorded, one mounting only,
    mountings that do not separate the table from the sensor, mountings at other poses, a rig file not there
    unchanged)."""
    facts = session_rig_facts(session)
    if facts is None:
        rig = session.info.rig
        why = ("it records no rig file" if not rig.rig_file or not rig.rig_file_sha256 else
               f"its rig file {rig.rig_file} is not there unchanged (sha256)")
        raise CalibError(f"{session.path}: a characterisation belongs to the rig file the session ran on, and {why}")
    groups = mounting_groups(session)
    first = table_poses(session, groups[0][0], groups[0][1])
    mountings = []
    for turn, members in groups:
        members = members if not mountings else _in_order_of(first, table_poses(session, turn, members), members)
        means = step_means(session, members)
        means = replace(means, f_nominal_g=table_poses(session, turn, members))
        mountings.append(Mounting(means, turn))
    classes = rig_errors(facts)
    fit = characterise(mountings, classes)
    info = session.info.rig
    return CharacterisationRecord(
        fit, date=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        rig_file=str(Path(facts.path).resolve()), rig_file_sha256=info.rig_file_sha256, session=session.id,
        mountings=tuple({"name": name_of(q), "turn": describe(q), "steps": len(m)} for q, m in groups),
        table_sha256=facts.table_sha256)


def kept_as_classes(rig: RigErrors, n_poses: int) -> list[tuple[str, float]]:
    """The table errors a reversal does not estimate (they change from pose to pose) with the standard
    uncertainty their class gives them, deg: what stays in later budgets as it was."""
    skip = set(CHARACTERISED) | set(ALIASES)
    return [(p.name, p.u_deg) for p in rig_parameters(rig, n_poses) if p.name not in skip]


__all__ = ["characterise_session", "kept_as_classes", "mounting_groups"]
