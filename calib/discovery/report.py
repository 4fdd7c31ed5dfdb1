"""Where a model's residual sits: the localisation of the baseline's disagreement and, when the gap
stays open, what remains (plain data for the report and the JSON of ``rig discover`` and ``rig compare``).

The residuals given are each in its own marginal standard deviation (``r / sqrt(sem^2 + wander_ii)``,
:meth:`calib.discovery.problem.Problem.marginal`), so a jump stays a step in time and a drift a trend.
With a bias wander they are correlated between steps, so the p-values of the structure tests here
(which assume independent residuals) are descriptive; the tests that decide (the nested tests, the
verdict, the lack-of-fit factor) use the whitened residuals.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from calib.accel.inputs import StepMeans
from calib.discovery.problem import jump_times
from calib.numerics.design import MISFIT_LEVEL
from calib.frames import SENSOR_AXES


# -- localisation ---------------------------------------------------------------------------
def localise(steps: StepMeans, ctx, z: np.ndarray, false_alarm: float = MISFIT_LEVEL) -> dict:
    """Where the baseline disagrees: significant step-axis cells and their poses, axes,
    temperature range, legs and time span; RMS of z by group."""
    k = len(steps)
    zc = float(stats.norm.isf(false_alarm / (2 * 3 * k)))
    sig = np.abs(z) > zc
    temps = None if steps.temp_c is None else np.asarray(steps.temp_c, float)
    t = np.asarray(steps.t_s, float)
    out: dict = {"z_threshold": zc, "cells": int(sig.sum()), "cells_total": int(3 * k)}
    out["by_axis"] = {a: {"significant": int(sig[:, j].sum()), "rms_z": float(np.sqrt(np.mean(z[:, j] ** 2)))}
                      for j, a in enumerate(SENSOR_AXES)}
    rows = np.flatnonzero(sig.any(axis=1))
    out["steps"] = [str(steps.names[i]) for i in rows]
    if len(rows):
        out["time_span_s"] = [float(t[rows].min()), float(t[rows].max())]
        if temps is not None:
            out["temp_range_c"] = [float(temps[rows].min()), float(temps[rows].max())]
    zr = np.sqrt(np.mean(z ** 2, axis=1))
    if temps is not None:
        levels = np.round(temps).astype(int)
        out["by_temperature"] = {f"{lv}": float(np.sqrt(np.mean(zr[levels == lv] ** 2)))
                                 for lv in sorted(set(levels.tolist()))}
    if ctx.heating is not None:
        out["by_leg"] = {lab: float(np.sqrt(np.mean(zr[ctx.heating == v] ** 2)))
                         for lab, v in (("heating", 1), ("cooling", -1), ("unknown", 0)) if np.any(ctx.heating == v)}
    halves = t <= np.median(t)
    out["by_time"] = {"first_half": float(np.sqrt(np.mean(zr[halves] ** 2))),
                      "second_half": float(np.sqrt(np.mean(zr[~halves] ** 2))) if np.any(~halves) else None}
    names = np.asarray(steps.names, dtype=object)
    by_pose = {}
    for n in dict.fromkeys(names.tolist()):
        by_pose[str(n)] = float(np.sqrt(np.mean(zr[names == n] ** 2)))
    out["worst_poses"] = sorted(by_pose, key=by_pose.get, reverse=True)[:5]
    return out


def summary_lines(d: dict) -> list[str]:
    """Plain sentences from :func:`localise`'s dict."""
    lines = [f"{d['cells']} of {d['cells_total']} step-axis means disagree beyond |z| > {d['z_threshold']:.1f} "
             f"(about {0.01:g} expected by chance)"]
    ax = ", ".join(f"{a}: {v['significant']} (rms z {v['rms_z']:.1f})" for a, v in d["by_axis"].items())
    lines.append(f"by axis: {ax}")
    if "temp_range_c" in d:
        lines.append(f"temperatures of the disagreeing steps: {d['temp_range_c'][0]:.1f} .. {d['temp_range_c'][1]:.1f} C")
    if "by_temperature" in d and len(d["by_temperature"]) > 1:
        lines.append("rms z by temperature: " + ", ".join(f"{k} C {v:.1f}" for k, v in d["by_temperature"].items()))
    if "by_leg" in d:
        lines.append("rms z by leg: " + ", ".join(f"{k} {v:.1f}" for k, v in d["by_leg"].items()))
    if "time_span_s" in d:
        lines.append(f"time span of the disagreeing steps: {d['time_span_s'][0]:.0f} .. {d['time_span_s'][1]:.0f} s"
                     f" (rms z first half {d['by_time']['first_half']:.1f}, second half "
                     f"{(d['by_time']['second_half'] or 0):.1f})")
    lines.append("worst poses: " + ", ".join(d["worst_poses"]))
    return lines


# -- what remains ---------------------------------------------------------------------------
def unexplained(steps: StepMeans, ctx, z: np.ndarray, false_alarm: float = MISFIT_LEVEL) -> dict:
    """Where the final model's normalised residual ``z`` (K, 3) sits and what structure it has.

    Plain data: RMS of z by axis, pose, temperature, leg, time block and outer-axis angle; then
    ``structure``: per axis, the residual against time, temperature and temperature rate (Pearson r),
    a step in time (best split, Bonferroni over the splits) and an offset per pose or per outer-axis
    angle (one-way F); each with its p-value, significant below ``false_alarm`` / (number of tests).
    """
    k = len(steps)
    zr = np.sqrt(np.mean(z ** 2, axis=1))
    t = np.asarray(steps.t_s, float)
    out: dict = {"rms_z": float(np.sqrt(np.mean(z ** 2))),
                 "by_axis": {a: float(np.sqrt(np.mean(z[:, j] ** 2))) for j, a in enumerate(SENSOR_AXES)}}
    order = np.argsort(-zr)[:5]
    out["worst_steps"] = [{"name": str(steps.names[i]), "t_s": float(t[i]), "z": z[i].tolist()} for i in order]
    groups = _groups(steps, ctx)
    for label, g in groups.items():
        out[f"by_{label}"] = {str(v): float(np.sqrt(np.mean(zr[g == v] ** 2))) for v in dict.fromkeys(g.tolist())}
    blocks = np.minimum((4 * np.argsort(np.argsort(t))) // max(k, 1), 3)
    out["by_time_block"] = {f"{t[blocks == b].min():.0f}-{t[blocks == b].max():.0f} s":
                            float(np.sqrt(np.mean(zr[blocks == b] ** 2))) for b in range(4) if np.any(blocks == b)}
    tests = _structure_tests(steps, ctx, z, groups)
    thr = false_alarm / max(len(tests), 1)
    for s_ in tests:
        s_["significant"] = bool(s_["p_value"] < thr)
    out["structure"] = tests
    out["threshold"] = thr
    return out


def _groups(steps: StepMeans, ctx) -> dict:
    """Step labels to group the residual by: pose, temperature, leg, outer-axis angle."""
    g = {"pose": np.asarray([str(n) for n in steps.names], dtype=object)}
    if steps.temp_c is not None:
        g["temperature"] = np.round(np.asarray(steps.temp_c, float)).astype(int)
    if ctx.heating is not None:
        g["leg"] = np.asarray([{1: "heating", -1: "cooling"}.get(int(h), "unknown") for h in ctx.heating], dtype=object)
    if ctx.angles_deg is not None and np.all(np.isfinite(ctx.angles_deg)):
        g["outer_axis_deg"] = np.round(np.asarray(ctx.angles_deg, float)[:, 0] % 360).astype(int)
    return g


def _structure_tests(steps: StepMeans, ctx, z: np.ndarray, groups: dict) -> list:
    t = np.asarray(steps.t_s, float)
    regressors = {"time": t}
    if steps.temp_c is not None:
        regressors["temperature"] = np.asarray(steps.temp_c, float)
    if ctx.temp_rate is not None and np.all(np.isfinite(ctx.temp_rate)):
        regressors["temperature_rate"] = np.asarray(ctx.temp_rate, float)
    out = []
    for j, a in enumerate(SENSOR_AXES):
        for kind, x in regressors.items():
            if np.ptp(x) > 0:
                r, p = stats.pearsonr(x, z[:, j])
                out.append({"kind": f"correlated_with_{kind}", "axis": a, "r": float(r), "p_value": float(p)})
        out.append({"kind": "step_in_time", "axis": a, **_best_split(t, z[:, j])})
        for label in ("pose", "outer_axis_deg"):
            if label in groups and 1 < len(set(groups[label].tolist())) < len(z):
                f, p = stats.f_oneway(*[z[groups[label] == v, j] for v in dict.fromkeys(groups[label].tolist())])
                out.append({"kind": f"offset_per_{label}", "axis": a, "f": float(f), "p_value": float(p)})
    return out


def _best_split(t: np.ndarray, zj: np.ndarray) -> dict:
    """The time split with the largest two-sample t statistic of ``zj``; p Bonferroni over the splits."""
    grid = jump_times(t)
    best = {"t_s": None, "shift_z": 0.0, "p_value": 1.0}
    tmax = -1.0
    for tj in grid:
        a, b = zj[t < tj], zj[t >= tj]
        se = np.sqrt(1.0 / len(a) + 1.0 / len(b))
        stat = abs(a.mean() - b.mean()) / se  # z is unit-variance under the model
        if stat > tmax:
            tmax = stat
            p = min(1.0, 2 * stats.norm.sf(stat) * len(grid))
            best = {"t_s": float(tj), "shift_z": float(b.mean() - a.mean()), "p_value": float(p)}
    return best


#: plain-language hints for the structures of :func:`unexplained`
HINTS = {"correlated_with_time": "something changing with time (drift that is not linear, warm-up, aging)",
         "correlated_with_temperature": "a temperature dependence the library does not describe",
         "correlated_with_temperature_rate": "a thermal lag or gradient (the temperature rate matters)",
         "step_in_time": "a sudden change (a shock, a mode change, a re-mount)",
         "offset_per_pose": "something that depends on the pose (mounting, nonlinearity, the fixture)",
         "offset_per_outer_axis_deg": "something that depends on the outer-axis angle (the turntable: "
                                      "wobble, tilt, a magnetic or electrical disturbance)"}


def unexplained_lines(u: dict) -> list[str]:
    """Plain sentences from :func:`unexplained`'s dict: where the residual sits and what to look for."""
    lines = ["residual rms z " + f"{u['rms_z']:.2f} (1 expected); by axis: "
             + ", ".join(f"{a} {v:.2f}" for a, v in u["by_axis"].items())]
    for label in ("temperature", "leg", "time_block", "outer_axis_deg"):
        if f"by_{label}" in u and len(u[f"by_{label}"]) > 1:
            lines.append(f"rms z by {label.replace('_', ' ')}: "
                         + ", ".join(f"{k} {v:.2f}" for k, v in u[f"by_{label}"].items()))
    lines.append("worst steps: " + ", ".join(f"{s['name']} ({s['t_s']:.0f} s)" for s in u["worst_steps"]))
    sig = [s for s in u["structure"] if s["significant"]]
    for kind in dict.fromkeys(s["kind"] for s in sig):
        axes = ", ".join(s["axis"] for s in sig if s["kind"] == kind)
        at = next(s for s in sig if s["kind"] == kind)
        when = f" near {at['t_s']:.0f} s" if kind == "step_in_time" and at.get("t_s") is not None else ""
        lines.append(f"{kind.replace('_', ' ')}{when} (axes {axes}): look for {HINTS[kind]}")
    if not sig:
        lines.append("no simple structure (time, temperature, rate, step, pose, angle) is significant: look for "
                     "noise larger than each step's scatter says (vibration, correlated noise)")
    return lines
