"""``rig compare SESSION_A SESSION_B``: two sessions of the same procedure, step by step and axis by
axis, each difference judged against the two step means' own standard errors and the two sensors' bias
wander between steps (docs/twin.md).

Measured against re-simulated (the twin of ``rig discover --twin``), before against after, sensor A
against sensor B. For every static step complete in both sessions and every axis::

    d = mean_A - mean_B,   cov(d) = diag(se_A^2 + se_B^2) + W_A + W_B,   z = L^-1 d   (L L^T = cov(d))

per axis, with the step means and their correlation-aware standard errors of the session adapter
(:func:`rig.session.step_means`, :mod:`calib.numerics.uncertainty`) and the covariance W of each session's bias
wander between its step means that the chip's stated bias stability implies (:mod:`calib.numerics.wander`; the
two sessions' wanders are independent). ``z`` is the whitened difference (each step's innovation given
the steps before it), ~N(0, 1) per cell when the sessions agree; without a stated stability it is
``(mean_A - mean_B) / sqrt(se_A^2 + se_B^2)``. The sessions agree at the noise level
unless some |z| is beyond the Bonferroni threshold or the chi-square sum of z^2 is beyond its upper
quantile; the false-alarm rate P of that verdict is split evenly between the two tests (P/2 each).
Where they disagree, the normalised differences are summarised by axis, temperature, leg, time and
pose with :func:`calib.discovery.search.unexplained`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import linalg, stats

from calib.file import calibration as calfile
from calib.accel.inputs import StepMeans
from calib.numerics.design import misfit
from calib.discovery.report import unexplained, unexplained_lines
from calib.frames import SENSOR_AXES
from calib.numerics.wander import wander_cov_g2
from rig.analysis.discover import step_context
from rig.analysis.same_unit import Units, units_of
from rig.errors import RigInputError
from rig.session import Session, load_session, step_means

FORMAT = "rig-compare/2"  # /2: z whitened with the bias wander (the keys are those of /1)
TEMP_NOTE_C = 0.2  # step temperatures further apart than this are pointed out
TIME_NOTE_S = 30.0  # and step times (a thermometer-timed wait varies by a few seconds)
LOADED_G = 0.5  # an axis carrying at least this much of gravity in a step is "loaded"


@dataclass
class Side:
    """One session's values at the compared steps (g) and their standard errors (g)."""

    session: Session
    value_g: np.ndarray  # (K, 3)
    se_g: np.ndarray  # (K, 3)
    temp_c: np.ndarray | None  # (K,)
    t_s: np.ndarray  # (K,)
    f_nominal_g: np.ndarray  # (K, 3), NaN rows where the pose is unknown


@dataclass
class Comparison:
    """The outcome of :func:`compare_sessions`; ``to_json`` is the ``rig-compare/2`` contract."""

    a: Side
    b: Side
    indices: list  # session step indices compared
    names: list
    quantity: str  # raw | calibrated
    quantity_note: str
    false_alarm: float
    z: np.ndarray  # (K, 3)
    z_threshold: float
    chi2: float
    p_chi2: float
    structure: dict | None = None
    skipped: list = field(default_factory=list)  # (index, name, why)
    units: Units | None = None  # the two sessions' sensor keys; different units are said first

    @property
    def flagged(self) -> np.ndarray:
        return np.abs(self.z) > self.z_threshold

    @property
    def dof(self) -> int:
        return int(self.z.size)

    @property
    def chi2_beyond(self) -> bool:
        return self.p_chi2 < self.false_alarm / 2

    @property
    def agree(self) -> bool:
        return not self.flagged.any() and not self.chi2_beyond

    def largest(self) -> dict:
        k, j = np.unravel_index(int(np.argmax(np.abs(self.z))), self.z.shape)
        return {"index": int(self.indices[k]), "step": str(self.names[k]), "axis": SENSOR_AXES[j], "z": float(self.z[k, j])}

    def where(self) -> dict:
        """The disagreeing cells: steps (index and name), axes, temperature range and time span."""
        f = self.flagged
        rows = np.flatnonzero(f.any(axis=1))
        out = {"cells": int(f.sum()), "steps": [str(self.names[k]) for k in rows],
               "indices": [int(self.indices[k]) for k in rows],
               "axes": [a for j, a in enumerate(SENSOR_AXES) if f[:, j].any()]}
        if len(rows):
            out["time_span_s"] = [float(self.a.t_s[rows].min()), float(self.a.t_s[rows].max())]
            if self.a.temp_c is not None:
                out["temp_range_c"] = [float(self.a.temp_c[rows].min()), float(self.a.temp_c[rows].max())]
        return out

    def by_axis(self) -> dict:
        return {a: {"rms_z": float(np.sqrt(np.mean(self.z[:, j] ** 2))), "disagreeing": int(self.flagged[:, j].sum())}
                for j, a in enumerate(SENSOR_AXES)}

    def by_load(self) -> dict | None:
        """RMS z on the axes carrying gravity in a step (|f_j| >= 0.5 g) and on the others: a difference on
        the loaded axes only is scale-like, one on every axis alike bias-like. None when poses are unknown."""
        f = np.abs(self.a.f_nominal_g)
        if not np.all(np.isfinite(f)):
            return None
        loaded = f >= LOADED_G
        rms = {k: float(np.sqrt(np.mean(self.z[m] ** 2))) for k, m in (("loaded", loaded), ("unloaded", ~loaded))
               if m.any()}
        return rms or None

    def differences(self) -> dict:
        """Largest |temperature| and |time| difference between the sessions' steps (None without)."""
        dt_c = None
        if self.a.temp_c is not None and self.b.temp_c is not None:
            dt_c = float(np.max(np.abs(self.a.temp_c - self.b.temp_c)))
        return {"max_temp_diff_c": dt_c, "max_time_diff_s": float(np.max(np.abs(self.a.t_s - self.b.t_s)))}

    def to_json(self) -> dict:
        steps = []
        for k, i in enumerate(self.indices):
            temps = [None if s.temp_c is None else float(s.temp_c[k]) for s in (self.a, self.b)]
            f_nom = self.a.f_nominal_g[k]
            steps.append({"index": int(i), "name": str(self.names[k]), "temp_c": temps,
                          "f_nominal_g": f_nom.tolist() if np.all(np.isfinite(f_nom)) else None,
                          "t_s": [float(self.a.t_s[k]), float(self.b.t_s[k])],
                          "difference_g": (self.a.value_g[k] - self.b.value_g[k]).tolist(),
                          "se_g": np.hypot(self.a.se_g[k], self.b.se_g[k]).tolist(), "z": self.z[k].tolist(),
                          "disagree": self.flagged[k].tolist()})
        return {"format": FORMAT, "headline": headline(self), "units": self.units.to_json() if self.units else None,
                "a": _side_json(self.a), "b": _side_json(self.b), "quantity": self.quantity,
                "quantity_note": self.quantity_note, "unit": "g", "false_alarm": self.false_alarm,
                "agree": bool(self.agree), "z_threshold": self.z_threshold, "cells": self.dof,
                "cells_disagreeing": int(self.flagged.sum()), "chi2": self.chi2, "dof": self.dof,
                "chi2_per_dof": self.chi2 / self.dof, "p_chi2": self.p_chi2, "chi2_beyond": bool(self.chi2_beyond),
                "largest": self.largest(), "where": self.where(), "by_axis": self.by_axis(),
                "by_load": self.by_load(), **self.differences(),
                "structure": self.structure,
                "skipped": [{"index": i, "name": n, "why": w} for i, n, w in self.skipped], "steps": steps}


def _side_json(s: Side) -> dict:
    return {"session": s.session.id, "path": str(s.session.path)}


# -- which steps, which quantity ---------------------------------------------------------------------------
def _step_words(step) -> str:
    """``static '+X up' at (0, 90, 0) deg``; a step without a pose says none."""
    at = "" if step.angles_deg is None else " at (" + ", ".join(f"{float(v):g}" for v in step.angles_deg) + ") deg"
    return f"{step.kind} {step.name!r}{at}"


def _describe(step) -> tuple:
    angles = None if step.angles_deg is None else tuple(round(float(x), 6) for x in step.angles_deg)
    return step.kind, step.name, angles


def check_same_procedure(a: Session, b: Session) -> None:
    """Refuse two sessions whose steps (kind, name, pose) differ: not the same procedure."""
    sa, sb = a.info.steps, b.info.steps
    if len(sa) != len(sb):
        raise RigInputError(str(b.path), None, None, f"not a session of the same procedure as {a.path}: "
                            f"{len(sb)} steps, expected {len(sa)}")
    for x, y in zip(sa, sb):
        if _describe(x) != _describe(y):
            raise RigInputError(str(b.path), None, None, f"not a session of the same procedure as {a.path}: step "
                                f"{x.index + 1} is {_step_words(y)}, expected {_step_words(x)}")


def common_steps(a: Session, b: Session) -> tuple[list, list]:
    """Static steps complete in both sessions, and the static steps left out (index, name, why)."""
    done_a = set(a.static_step_indices(unknown_pose=True))
    done_b = set(b.static_step_indices(unknown_pose=True))
    keep, skipped = [], []
    for st in a.info.steps:
        if not st.is_static:
            continue
        if st.index in done_a and st.index in done_b:
            keep.append(st.index)
        else:
            skipped.append((st.index, st.name, "not complete in " + " and ".join(
                n for n, done in (("A", done_a), ("B", done_b)) if st.index not in done)))
    if not keep:
        raise RigInputError(str(b.path), None, "steps", f"no static step is complete in both {a.path} and {b.path}")
    return keep, skipped


def _raw_unit(a: Session, b: Session) -> str:
    sa, sb = a.info.rig.sensor, b.info.rig.sensor
    if sa.model != sb.model or a.lsb_per_g != b.lsb_per_g:
        raise RigInputError(str(b.path), None, "rig.sensor", f"{sb.model} at {b.lsb_per_g:g} counts/g, but A "
                            f"({a.path}) is {sa.model} at {a.lsb_per_g:g} counts/g: raw counts do not compare; "
                            "use --calibrated (each session's own calibration.yaml)")
    return (f"raw accelerometer counts / nominal {a.lsb_per_g:g} counts/g (both sessions: {sa.model}, same range); "
            "the same sensor model and range, uncalibrated")


def side(session: Session, idx: list, calibrated: bool) -> tuple[Side, StepMeans]:
    """One session's step means at ``idx``: raw counts / nominal sensitivity, or calibrated by the session's
    own ``calibration.yaml`` (standard errors through M^-1); and the adapter's step means."""
    m = step_means(session, idx)
    temps = None if m.temp_c is None else np.asarray(m.temp_c, float)
    t, f_nom = np.asarray(m.t_s, float), np.asarray(m.f_nominal_g, float)
    if not calibrated:
        return Side(session, m.mean_counts / m.lsb_per_g, m.sem_counts / m.lsb_per_g, temps, t, f_nom), m
    cal = calfile.read(session.path / "calibration.yaml").accelerometer
    f = cal.apply(m.mean_counts, temp_c=temps, t_s=m.t_s)
    minv = np.linalg.inv(np.asarray(cal.matrix_counts_per_g, float))
    se = np.sqrt(np.asarray(m.sem_counts, float) ** 2 @ (minv ** 2).T)
    return Side(session, f, se, temps, t, f_nom), m


# -- the comparison -----------------------------------------------------------------------------------------
def judge(z: np.ndarray, false_alarm: float) -> tuple[float, float, float]:
    """The |z| threshold (two-sided, Bonferroni over the cells at ``false_alarm`` / 2), the chi-square sum of
    z^2 and its upper-tail probability on one degree of freedom per cell (judged at ``false_alarm`` / 2)."""
    zc = float(stats.norm.isf(false_alarm / 2 / (2 * z.size)))
    chi2 = float(np.sum(np.asarray(z, float) ** 2))
    return zc, chi2, misfit(chi2, z.size, false_alarm / 2)[1]


def whitened_difference(sa: Side, sb: Side, wanders) -> np.ndarray:
    """(K, 3) the difference A - B whitened per axis by its covariance: both standard errors and both
    sessions' bias wander (``wanders``: their (K, K) covariances, g^2)."""
    d = sa.value_g - sb.value_g
    w = sum(wanders)
    if not np.any(w):
        return d / np.hypot(sa.se_g, sb.se_g)
    out = np.empty_like(d)
    for j in range(3):
        chol = np.linalg.cholesky(np.diag(sa.se_g[:, j] ** 2 + sb.se_g[:, j] ** 2) + w)
        out[:, j] = linalg.solve_triangular(chol, d[:, j], lower=True)
    return out


def compare_sessions(path_a, path_b, *, false_alarm: float = 0.01, calibrated: bool = False) -> Comparison:
    """Compare two sessions of the same procedure (see the module docstring)."""
    a, b = load_session(path_a), load_session(path_b)
    check_same_procedure(a, b)
    idx, skipped = common_steps(a, b)
    note = ("specific force calibrated by each session's own calibration.yaml, g" if calibrated
            else _raw_unit(a, b))
    (sa, means_a), (sb, means_b) = side(a, idx, calibrated), side(b, idx, calibrated)
    wanders = [wander_cov_g2(s.t_s, m.duration_s, m.bias_stability)
               for s, m in ((sa, means_a), (sb, means_b))]
    z = whitened_difference(sa, sb, wanders)
    zc, chi2, p = judge(z, false_alarm)
    c = Comparison(a=sa, b=sb, indices=idx, names=[a.info.steps[i].name for i in idx],
                   quantity="calibrated" if calibrated else "raw", quantity_note=note, false_alarm=false_alarm,
                   z=z, z_threshold=zc, chi2=chi2, p_chi2=p, skipped=skipped,
                   units=units_of(a.info.to_dict(), b.info.to_dict()))
    if not c.agree and len(idx) >= 2:
        # where: each difference in its own marginal standard deviations (a jump stays a step in time)
        marginal = (sa.value_g - sb.value_g) / np.sqrt(sa.se_g ** 2 + sb.se_g ** 2 + np.diag(sum(wanders))[:, None])
        c.structure = unexplained(means_a, step_context(a, idx), marginal, false_alarm)
    return c


# -- what a technician reads first ---------------------------------------------------------------------------
def details_hint(c: Comparison) -> str:
    """Where the statistics are, with the command as the user would type it again."""
    return (f"A is {c.a.session.path}, B is {c.b.session.path}; the statistics behind this: rig compare "
            f"{c.a.session.path} {c.b.session.path} --details (every step, its z, where); --json has all")


#: the differences are called scale-like when their rms z on the axes carrying gravity exceeds this many times
#: that on the other axes (taken as at least 1: the noise level)
SCALE_LIKE_RATIO = 3.0


#: what a scale-like difference says to look for (the headline's and the --details verdict's words)
SCALE_LIKE_WORDS = ("the difference is on the axes carrying gravity only (scale-like): look for a changed range or "
                    "sensitivity setting, a different temperature, or a sensor that was damaged or replaced")


def scale_like(c: Comparison) -> bool:
    """The differences sit on the axes carrying gravity, not on the others: a scale factor (or the range) changed,
    which no step in time or single event describes as well (a six-position run's loaded axes change with the pose,
    so a time factor can fit them too; the load pattern is the more specific evidence)."""
    load = c.by_load()
    return bool(load and len(load) == 2 and load["loaded"] > SCALE_LIKE_RATIO * max(load["unloaded"], 1.0))


def _structure_sentences(c: Comparison) -> list[str]:
    """The structure of the differences as things to look for (``step in time near 48 s (axes x): look for ...``)."""
    if c.structure is None:
        return []
    return [s for s in unexplained_lines(c.structure) if ": look for " in s]


def same_session(c: Comparison) -> str | None:
    """None unless A and B are one recording (the same session id); then ``""`` for the same directory given
    twice, or the words for a copy of it elsewhere (``"; B is a copy of A at another path"``)."""
    a, b = c.a.session, c.b.session
    if a.id != b.id:
        return None
    return "" if Path(a.path).resolve() == Path(b.path).resolve() else "; B is a copy of A at another path"


def headline(c: Comparison) -> list[str]:
    """One or two sentences a technician can act on: two different units; agree; or where they differ and
    what to look for."""
    same = same_session(c)
    if same is not None:
        return [f"A and B are the same session ({c.a.session.id}{same}): nothing to compare.",
                "Compare it with another session of the procedure: this unit's earlier one (rig history) or the "
                "session recorded on its digital twin (docs/twin.md)."]
    u = c.units
    if u is not None and u.different:
        return [f"These are two different units ({u.a} vs {u.b}; {u.why}): their differences are the units' own "
                "errors, not a change in either, so there is nothing to compare.",
                "Compare a unit with its own earlier sessions, or follow it with rig history."]
    twin = [f"{u.twin}."] if u is not None and u.twin else []
    if c.agree:
        return [f"A and B agree at the noise level ({len(c.indices)} steps x 3 axes): nothing to act on."] + twin
    w = c.where()
    where = (f"at {len(w['steps'])} of {len(c.indices)} steps (axes {', '.join(w['axes'])})" if w["cells"]
             else "overall, though no single step stands out")
    look = _structure_sentences(c)
    if scale_like(c):
        look = [SCALE_LIKE_WORDS]
    first = f"A and B differ beyond the noise {where}" + (f": {look[0]}." if look else ".")
    return [first, "Re-run the procedure to see whether it repeats before acting on it."] + twin


def format_report(c: Comparison, details: bool = False) -> str:
    """The headline (:func:`headline`); with ``details`` then what was compared, the per-step table, the verdict
    and where."""
    if not details:
        hint = [] if same_session(c) is not None else [details_hint(c)]  # one recording: no statistics to look at
        return "\n".join(headline(c) + hint)
    return "\n".join(headline(c) + ["", _statistics(c)])


def _statistics(c: Comparison) -> str:
    """What was compared, the per-step table, the verdict and where."""
    lines = [f"A: {c.a.session.id} ({c.a.session.path})", f"B: {c.b.session.id} ({c.b.session.path})",
             f"compared: {c.quantity_note}",
             f"{len(c.indices)} static steps x 3 axes; z = (A - B) whitened by each step's own standard errors "
             f"and both sensors' bias wander between steps; |z| threshold {c.z_threshold:.2f} (Bonferroni over {c.dof} cells)",
             f"chi2 {c.chi2:.1f} on {c.dof} dof (chi2/dof {c.chi2 / c.dof:.2f}, p = {c.p_chi2:.2g})",
             "by axis: " + ", ".join(f"{a} rms z {v['rms_z']:.2f} ({v['disagreeing']} beyond)"
                                     for a, v in c.by_axis().items())]
    load = c.by_load()
    if load and len(load) == 2:
        lines.append(f"rms z on the axes carrying gravity (|f| >= {LOADED_G:g} g) {load['loaded']:.2f}, on the others "
                     f"{load['unloaded']:.2f} (a difference on the loaded axes only is scale-like)")
    lines += _difference_notes(c)
    for i, n, why in c.skipped:
        lines.append(f"left out: step {i + 1} {n} ({why})")
    lines.append("per step (A - B in ug, z; * beyond the threshold):")
    lines.append(f"  {'#':>3} {'step':<16} {'T_A C':>7} {'T_B C':>7}   {'x':>16} {'y':>16} {'z':>16}")
    for k, i in enumerate(c.indices):
        d = (c.a.value_g[k] - c.b.value_g[k]) * 1e6
        cells = " ".join(f"{d[j]:7.0f} {c.z[k, j]:6.1f}{'*' if c.flagged[k, j] else ' '}" for j in range(3))
        ta = "      -" if c.a.temp_c is None else f"{c.a.temp_c[k]:7.2f}"
        tb = "      -" if c.b.temp_c is None else f"{c.b.temp_c[k]:7.2f}"
        lines.append(f"  {i + 1:>3} {str(c.names[k])[:16]:<16} {ta} {tb}   {cells}")
    return "\n".join(lines + verdict_lines(c))


def _difference_notes(c: Comparison) -> list[str]:
    d = c.differences()
    out = []
    if d["max_temp_diff_c"] is not None and d["max_temp_diff_c"] > TEMP_NOTE_C:
        out.append(f"note: the steps' temperatures differ by up to {d['max_temp_diff_c']:.2f} C between A and B "
                   "(temperature effects then show as differences)")
    if d["max_time_diff_s"] > TIME_NOTE_S:
        out.append(f"note: the steps' times differ by up to {d['max_time_diff_s']:.1f} s between A and B "
                   "(time effects then show as differences)")
    return out


def verdict_lines(c: Comparison) -> list[str]:
    """The verdict: agree at the noise level, or where they disagree and what structure the difference has."""
    tail = f"false-alarm rate {c.false_alarm:g}: {c.false_alarm / 2:g} to the cells, {c.false_alarm / 2:g} to chi2"
    if c.agree:
        return [f"verdict: A and B agree at the noise level (largest |z| {abs(c.largest()['z']):.2f} <= "
                f"{c.z_threshold:.2f}, chi2/dof {c.chi2 / c.dof:.2f}, p = {c.p_chi2:.2g}; {tail})"]
    w, big = c.where(), c.largest()
    if w["cells"]:
        steps = ", ".join(f"{i + 1} {n}" for i, n in zip(w["indices"], w["steps"]))
        head = (f"verdict: A and B disagree at steps {steps} ({len(w['steps'])} of {len(c.indices)}), axes "
                f"{', '.join(w['axes'])}; largest z {big['z']:.1f} at step {big['index'] + 1} {big['step']} axis "
                f"{big['axis']} ({tail})")
    else:
        head = (f"verdict: A and B disagree overall (chi2/dof {c.chi2 / c.dof:.2f}, p = {c.p_chi2:.2g}) though no "
                f"single step stands out (largest z {big['z']:.1f} at step {big['index'] + 1} {big['step']} axis "
                f"{big['axis']}; {tail})")
    lines = [head]
    if "temp_range_c" in w:
        lines.append(f"  the disagreeing steps: {w['temp_range_c'][0]:.1f} .. {w['temp_range_c'][1]:.1f} C, "
                     f"{w['time_span_s'][0]:.0f} .. {w['time_span_s'][1]:.0f} s")
    if c.structure is not None:
        different = c.units is not None and c.units.different  # no shock or re-mount explains two units apart
        scaled = scale_like(c)  # the load pattern is the more specific evidence: the headline's words, not a time step
        lines += ["  " + s.replace("residual rms z", "difference rms z") for s in unexplained_lines(c.structure)
                  if not ((different or scaled) and ": look for " in s)]
        if scaled and not different:
            lines.append(f"  {SCALE_LIKE_WORDS}")
    return lines
