"""``rig discover SESSION --propose OUT.yaml``: the procedure that tells aliases apart (docs/discrepancy.md).

The session's own procedure (its text, as recorded) with blocks appended: a chamber set-point
(``temperature`` step, as the session's own) and every pose of the session at it (``pose`` steps, the
session's pose names), the set-points chosen by :func:`calib.discovery.propose.separating` (T-optimal,
greedy, within the block budget). Run it as the session was run; ``rig discover`` of the new session
names one of the aliases (the predicted power is printed and written in the procedure's description).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from calib.discovery.propose import Proposal, separating
from calib.discovery.search import Discovery
from calib.errors import CalibError
from rig.analysis.discover import step_context
from rig.session import Session, step_means

#: the temperature step appended before each block (the shipped ``temperature`` step kind)
TEMPERATURE_STEP = {"tolerance_c": 0.3, "hold_s": 60, "timeout_s": 3600, "mode": "wait"}


def proposals(session: Session, d: Discovery, max_blocks: int = 4) -> list[Proposal]:
    """The proposals for every alias of the named effects (empty: nothing to separate)."""
    named = {e.name for e in d.effects}
    if not any(g[0] in named for g in d.aliases):
        return []
    if d.baseline != "seed":
        raise CalibError("--propose: the session's poses are unknown (no poses to propose)")
    if session.info.procedure is None or not session.info.procedure.text:
        raise CalibError("--propose: the session does not carry its procedure's text (nothing to extend)")
    idx = session.static_step_indices()
    return separating(step_means(session, idx), step_context(session, idx), d, d.false_alarm, max_blocks)


def _pose_names(session: Session) -> dict:
    """Nominal force (rounded) -> the session's pose name for it (the first step at it)."""
    out: dict = {}
    for s in session.info.steps:
        if s.kind == "static" and s.f_nominal is not None and s.name:
            out.setdefault(tuple(np.round(np.asarray(s.f_nominal, float), 6)), s.name)
    return out


def procedure_text(session: Session, props: list[Proposal]) -> str:
    """The session's procedure with the blocks of every proposal appended (set-points in order)."""
    doc = yaml.safe_load(session.info.procedure.text)
    poses = list(dict.fromkeys(_pose_names(session).values()))
    added = []
    for p in props:
        for sp in p.setpoints_c:
            added.append({"temperature": {"target_c": float(sp), **TEMPERATURE_STEP}})
            added += [{"pose": name} for name in poses]
    doc["steps"] = list(doc.get("steps") or []) + added
    doc["name"] = f"{doc.get('name', 'procedure')}-separate"
    said = "; ".join(f"{a} vs {b}: +{len(p.setpoints_c)} set-point(s) {p.setpoints_c} C, predicted power "
                     f"{p.power:.3f} (was {p.power_before:.3f})" for p in props for a, b in [p.pair])
    doc["description"] = f"{doc.get('description', '')} Proposed by rig discover to separate aliases: {said}".strip()
    return yaml.safe_dump(doc, sort_keys=False)


def write_proposal(session: Session, d: Discovery, path, max_blocks: int = 4) -> dict:
    """Write the proposal to ``path``; returns what the report and the JSON say (nothing written, and
    ``proposal: null``, when no aliases remain)."""
    props = proposals(session, d, max_blocks)
    if not props:
        return {"proposal": None}
    Path(path).write_text(procedure_text(session, props), encoding="utf-8")
    return {"proposal": str(Path(path).resolve()),
            "proposal_power": [{"named": p.pair[0], "alias": p.pair[1], "setpoints_c": p.setpoints_c,
                                "power": p.power, "power_before": p.power_before, "noncentrality": p.noncentrality,
                                "alpha": p.alpha, "added_steps": p.added_steps} for p in props]}
