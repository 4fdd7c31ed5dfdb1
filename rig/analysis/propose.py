"""``rig discover SESSION --propose OUT.yaml``: the procedure that tells aliases apart, or decides a weak
candidate (docs/discrepancy.md).

The session's own procedure (its text, as recorded) with blocks appended: a chamber set-point
(``temperature`` step, as the session's own) and every pose of the session at it (``pose`` steps, the
session's pose names), the set-points chosen by :func:`calib.discovery.propose.separating` (T-optimal,
greedy, within a time budget). Run it as the
session was run; ``rig discover`` of the new session names one of the aliases, or names the weak candidate
when it is real at its fitted size (the predicted power is printed and written in the procedure's
description). A weak candidate whose experiment does not reach the power within the budget adds no block:
the document says so (``proposal_note``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from calib.discovery.propose import POWER_TARGET, Proposal, deciding, separating
from calib.discovery.search import Discovery
from calib.errors import CalibError
from rig.analysis.discover import step_context
from rig.session import Session, step_means

#: the temperature step appended before each block (the shipped ``temperature`` step kind)
TEMPERATURE_STEP = {"tolerance_c": 0.3, "hold_s": 60, "timeout_s": 3600, "mode": "wait"}


def proposals(session: Session, d: Discovery, max_blocks: int | None = None) -> list[Proposal]:
    """The proposals for every alias of the named effects; when none remains, for every weak candidate (empty:
    nothing to separate or decide)."""
    named = {e.name for e in d.effects}
    aliased = any(g[0] in named for g in d.aliases)
    if not aliased and not d.weak:
        return []
    if d.baseline != "seed":
        raise CalibError("--propose: the session's poses are unknown (no poses to propose)")
    if session.info.procedure is None or not session.info.procedure.text:
        raise CalibError("--propose: the session does not carry its procedure's text (nothing to extend)")
    idx = session.static_step_indices()
    steps, ctx = step_means(session, idx), step_context(session, idx)
    if aliased:
        return separating(steps, ctx, d, d.false_alarm, max_blocks)
    return deciding(steps, ctx, d, d.false_alarm)


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
    said = "; ".join(_said(p) for p in props)
    what = " and ".join(w for w, kind in (("separate aliases", "alias"), ("decide weak candidates", "weak"))
                        if any(p.kind == kind for p in props))
    doc["description"] = f"{doc.get('description', '')} Proposed by rig discover to {what}: {said}".strip()
    return yaml.safe_dump(doc, sort_keys=False)


def _said(p: Proposal) -> str:
    """One proposal in words: what it decides, the set-points added and the predicted power."""
    head = f"{p.pair[0]} vs {p.pair[1]}" if p.kind == "alias" else f"weak candidate {p.pair[0]} at its fitted magnitude"
    return (f"{head}: +{len(p.setpoints_c)} set-point(s) {p.setpoints_c} C, predicted power {p.power:.3f} "
            f"(was {p.power_before:.3f})")


def unreached_note(props: list[Proposal]) -> str | None:
    """The plain sentence for weak candidates no experiment within the budget decides (None: none such)."""
    left = [p for p in props if p.kind == "weak" and not p.reached]
    if not left:
        return None
    return ("no experiment within the budget reaches power " + f"{POWER_TARGET:g} for the weak candidate(s) "
            + ", ".join(f"{p.pair[0]} (best {p.power:.3f} with {len(p.setpoints_c)} set-point(s) in "
                        f"{(p.budget_s or 0) / 3600:g} h)" for p in left)
            + ": nothing added for them")


def write_proposal(session: Session, d: Discovery, path, max_blocks: int | None = None) -> dict:
    """Write the proposal to ``path``; returns what the report and the JSON say (nothing written, and
    ``proposal: null``, when no aliases remain and no weak candidate's experiment reaches the power within its
    budget; ``proposal_note`` then says so for the weak candidates)."""
    props = proposals(session, d, max_blocks)
    used = [p for p in props if p.kind == "alias" or p.reached]
    note = unreached_note(props)
    out: dict = {"proposal": None}
    if used:
        Path(path).write_text(procedure_text(session, used), encoding="utf-8")
        out["proposal"] = str(Path(path).resolve())
    if any(p.kind == "alias" for p in props):
        out["proposal_power"] = [_power_entry(p) for p in props]
    if any(p.kind == "weak" for p in props):
        out["weak_proposal_power"] = [_power_entry(p) for p in props]
    if note:
        out["proposal_note"] = note
    return out


def _power_entry(p: Proposal) -> dict:
    """One proposal in the document: an alias pair's (``named``, ``alias``) or a weak candidate's (``name``,
    ``reached``: whether its blocks are in the procedure written)."""
    head = ({"named": p.pair[0], "alias": p.pair[1]} if p.kind == "alias"
            else {"name": p.pair[0], "reached": p.reached})
    return {**head, "setpoints_c": p.setpoints_c, "power": p.power, "power_before": p.power_before,
            "noncentrality": p.noncentrality, "alpha": p.alpha, "added_steps": p.added_steps, "added_s": p.added_s,
            "budget_s": p.budget_s}
