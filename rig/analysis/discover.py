"""``rig discover``: the discrepancy workflow on a recorded session (docs/discrepancy.md).

The session side of :mod:`calib.discovery.search`: step means, the rotation of every
pose (for ``table_tilt``), the heating or cooling leg of every step (from the
temperature record, for ``thermal_hysteresis``), then the report, the JSON, the
plot and the augmented calibration file.
"""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import dataclasses

import numpy as np

from calib.accel.inputs import StepMeans
from calib.accel.rig_misfit import MAX_STEPS, has_pose_errors, rig_step_covariance
from calib.accel.rig_propagation import needs_arrival
from calib.file import calibration as calfile
from calib.discovery.report import summary_lines, unexplained_lines
from calib.discovery.search import Discovery, StepContext, discover
from calib.discovery.effects import LIBRARY, heating_state
from calib.errors import CalibError
from rig.analysis import plots
from rig.analysis.effect_units import shown_effect_unit
from rig.analysis.solve import SOFTWARE, accelerometer_absent, sensor_section
from rig.analysis.uncertainty import session_rig_errors, session_rig_facts
from rig.errors import RigInputError
from rig.planning.kinematics import sensor_to_world
from rig.session import Session, load_session, step_means
from rig.session.adapter import with_arrival

BAND_C = 0.5


def step_context(session: Session, step_indices: list[int]) -> StepContext:
    """Pose rotations and heating legs of the given steps."""
    steps = session.info.steps
    angles = [steps[i].angles_deg for i in step_indices]
    b2s = None
    if all(a is not None for a in angles):
        b2s = np.transpose(sensor_to_world(np.asarray(angles, float)), (0, 2, 1))
    heating = None
    if session.has_temperature:
        series: list[tuple[float, float, int | None]] = []  # (t_s, temp_c, step position or None)
        for e in session.events:
            if e.get("kind") == "temperature" and isinstance(e.get("t_s"), (int, float)):
                t_end = float(e["t_s"])
                if isinstance(e.get("start_c"), (int, float)):
                    series.append((t_end - float(e.get("waited_s", 0.0)), float(e["start_c"]), None))
                if isinstance(e.get("temp_c"), (int, float)):
                    series.append((t_end, float(e["temp_c"]), None))
        for pos, i in enumerate(step_indices):
            rows = session.samples["step"] == i
            tc = session.samples["temp_c"][rows]
            tt = session.samples["t_s"][rows]
            if len(tt):
                series.append((float(tt.mean()), float(np.mean(tc)), pos))
        series.sort(key=lambda r: r[0])
        state = heating_state([r[1] for r in series], BAND_C)
        heating = np.zeros(len(step_indices))
        for (t, c, pos), h in zip(series, state):
            if pos is not None:
                heating[pos] = h
    groups = None
    if any(steps[i].f_nominal is None for i in step_indices):
        # steps sharing one unknown pose carry the same pose_group; otherwise each is its own
        groups = np.array([steps[i].pose_group if steps[i].pose_group is not None else 1_000_000 + i
                           for i in step_indices])
    rates, window = step_rates(session, step_indices)
    return StepContext(heating=heating, base_to_sensor=b2s, pose_group=groups, band_c=BAND_C, temp_rate=rates,
                       rate_window_s=window,
                       angles_deg=np.asarray(angles, float) if all(a is not None for a in angles) else None)


def step_rates(session: Session, step_indices: list[int]) -> tuple[np.ndarray | None, float]:
    """Rate of temperature change during each step (C/s): the least-squares slope of the step's own
    temperature samples against time; and the median step duration (s). None without temperatures."""
    if not session.has_temperature:
        return None, 5.0
    rates, spans = np.full(len(step_indices), np.nan), []
    for pos, i in enumerate(step_indices):
        s = session.step_samples(i)
        t, tc = np.asarray(s["t_s"], float), np.asarray(s["temp_c"], float)
        ok = np.isfinite(t) & np.isfinite(tc)
        if ok.sum() >= 2 and np.ptp(t[ok]) > 0:
            rates[pos] = np.polyfit(t[ok] - t[ok].mean(), tc[ok], 1)[0]
            spans.append(float(np.ptp(t[ok])))
    return (rates if np.all(np.isfinite(rates)) else None), (float(np.median(spans)) if spans else 5.0)


#: ``rig discover`` fits at most this many static steps. Its model of the data holds the bias wander as a dense
#: K x K covariance per axis (whitened by its inverse Cholesky factor) and it refits at every step boundary and
#: per-step candidate: its time grows with the square to the cube of the steps, and depends on what the data hold
#: (measured on 2 cores, 2026-11-26: 400 steps 3-6 s, 450 steps 4-31 s, 600 steps 69 s, 1000 steps 60-74 s of
#: CPU over 60 s; 10,000 steps would need about 2.4 GB for the factors alone, and hours). At 400 the slowest
#: path seen, scaled, is about 22 s. Beyond the limit it refuses at once (issue 32: under 60 s, or a refusal).
MAX_DISCOVER_STEPS = 400


def check_discover_size(session: Session, n_steps: int) -> None:
    """Refuse, in one line naming the limit and the reason, a discovery over more than :data:`MAX_DISCOVER_STEPS`."""
    if n_steps > MAX_DISCOVER_STEPS:
        raise RigInputError(str(session.path), None, None,
                            f"{n_steps} static steps: rig discover fits at most {MAX_DISCOVER_STEPS} (its time grows "
                            "with the square to the cube of the steps: up to 31 s at 450 and 69 s at 600 on 2 cores, "
                            "hours at 10,000); rig solve works on any number of steps, and rig discover on a part of "
                            "the recording imported alone")


def discover_session(session_dir, *, false_alarm: float = 0.01, progress=None, prepare=None) -> tuple[Session, Discovery]:
    """Load the session and run the discovery on its static steps (refused beyond :data:`MAX_DISCOVER_STEPS`).
    ``progress``: called with each stage's name as it starts (``progress.steps(n)`` first, when it has one: the
    static steps the session holds). ``prepare``: called with the loaded session before its step means are taken
    (``rig discover`` attaches the unit's noise profile there, as a solve does)."""
    say = progress or (lambda stage: None)
    say("reading the session")
    session = load_session(session_dir)
    if prepare is not None:
        prepare(session)
    idx = session.static_step_indices()
    if not idx:  # an imported recording without known poses: the pose-free baseline
        idx = session.static_step_indices(unknown_pose=True)
    check_discover_size(session, len(idx))
    if accelerometer_absent(session):
        raise CalibError(f"{session.path}: the session has no accelerometer data (an import of other sensors only): "
                         "rig discover searches the accelerometer's model; rig solve solves the sensors it has")
    if hasattr(progress, "steps"):
        progress.steps(len(idx))
    say("the step means")
    steps, rig_cov = judged_with_rig(session, step_means(session, idx), idx)
    ctx = dataclasses.replace(step_context(session, idx), rig_cov_counts2=rig_cov)
    return session, discover(steps, ctx, false_alarm=false_alarm, progress=progress)


def rig_covariance(session: Session, steps: StepMeans, idx: list[int]) -> np.ndarray | None:
    """The step means' covariance (3K, 3K), counts^2, from the turntable's own errors: :func:`judged_with_rig`'s
    covariance alone (None where the session is judged against the noise alone)."""
    return judged_with_rig(session, steps, idx)[1]


def judged_with_rig(session: Session, steps: StepMeans, idx: list[int]) -> tuple[StepMeans, np.ndarray | None]:
    """The step means as the search fits them and their covariance (3K, 3K), counts^2, from the turntable's own
    errors (:func:`calib.accel.rig_misfit.rig_step_covariance`, with the recorded arrival directions): what the
    search judges residuals against besides the noise, so that the table's pose errors are not named as effects of
    the sensor (docs/discrepancy.md, "The rig's own errors").

    The rig's errors are the budget's (:func:`rig.analysis.uncertainty.session_rig_errors`): its rig file's classes,
    or, when a characterisation of the rig applies to the session (made on its rig file's digest or the same
    table), the characterised errors' standard uncertainties in place of their classes; the step means then come
    back with their nominal specific force where the characterised table puts it (``Characterisation.corrected``,
    as :func:`rig.analysis.uncertainty.with_budget` solves), since the smaller uncertainties hold only about the
    corrected poses. Unchanged steps and None where the session's rig file is not there unchanged (an import, a
    replay), the table has no errors (a simulated one with ``sim.geometry`` off), a pose is unknown, or the
    session has more than :data:`~calib.accel.rig_misfit.MAX_STEPS` steps."""
    if session_rig_facts(session) is None or len(steps) > MAX_STEPS or not bool(np.all(steps.pose_known)):
        return steps, None
    rig = session_rig_errors(session)
    if not has_pose_errors(rig):
        return steps, None
    record = getattr(rig, "record", None)  # a CharacterisedRig's characterisation record
    if record is not None:
        steps = record.characterisation.corrected(steps, rig)
    judged = with_arrival(session, steps, idx) if needs_arrival(rig) else steps
    return steps, rig_step_covariance(judged, rig, steps.lsb_per_g * np.eye(3))


#: how the report names each baseline model (calib.discovery.search.Discovery.baseline)
BASELINE_LABELS = {"seed": "baseline (bias, scale, triangular misalignment)",
                   "pose_groups": "pose-free baseline (one constant per axis and unknown pose)",
                   "magnitude": "magnitude baseline (|M^-1 (a - b)| = 1 g, poses unknown and never repeated; "
                                "only each step's residual along its gravity direction counts)"}


#: the effects a calibration's thermal model of order 1, 2, 3 holds already
THERMAL_EFFECTS = ("bias_tempco", "bias_tempco_quadratic", "bias_tempco_cubic")


def already_modelled(session: Session) -> set[str]:
    """The library effects the session's own calibration (``SESSION/calibration.yaml``, as the procedure solved it)
    models already: its thermal model's orders. Empty without a calibration (or one that does not load)."""
    try:
        temperature = calfile.read(session.path / "calibration.yaml").accelerometer.temperature
    except (OSError, RigInputError, CalibError):
        return set()
    return set(THERMAL_EFFECTS[:int(temperature.order)]) if temperature is not None else set()


def headline_lines(session: Session, d: Discovery) -> list[str]:
    """The verdict first, in words a technician can act on (issue 33 item 3); the statistics follow."""
    return verdict_words(session, [(e.name, e.extra.get("t_jump_s")) for e in d.effects], d.gap_closed, d.aliases,
                         [w["name"] for w in d.weak])


def headline(session: Session, d: Discovery) -> str:
    """:func:`headline_lines` as one text: the ``headline`` of the ``--json`` document (docs/discrepancy.md)."""
    return " ".join(headline_lines(session, d))


def document_headline(session: Session, doc: dict) -> str:
    """The headline of a ``rig discover --json`` document of ``session``: its own ``headline`` when it has one,
    else the same words made from its ``effects``, ``gap_closed`` and ``aliases`` (a document written before the
    key existed)."""
    if isinstance(doc.get("headline"), str) and doc["headline"].strip():
        return doc["headline"]
    effects = [(str(e.get("name")), e.get("t_jump_s") if isinstance(e.get("t_jump_s"), (int, float)) else None)
               for e in doc.get("effects") or [] if isinstance(e, dict)]
    aliases = [[str(n) for n in a] for a in doc.get("aliases") or [] if isinstance(a, list)]
    weak = [str(w.get("name")) for w in doc.get("weak_candidates") or [] if isinstance(w, dict)]
    return " ".join(verdict_words(session, effects, doc.get("gap_closed") is not False, aliases, weak))


def document(session: Session, d: Discovery) -> dict:
    """The ``--json`` document: ``rig-discover/6`` (:meth:`Discovery.to_json`) and its ``headline``, the verdict in
    words the console prints first (an additive key: readers ignore keys they do not know)."""
    return {**d.to_json(), "headline": headline(session, d)}


def verdict_words(session: Session, effects: list[tuple[str, float | None]], gap_closed: bool,
                  aliases: list[list[str]], weak: list[str] = ()) -> list[str]:
    """The headline's sentences from the effects named (``(name, jump time s or None)``), whether the gap closed,
    the aliases left and the weak candidates (not named, some support), the effects this session's calibration
    models already said as such."""
    known = already_modelled(session)
    new = [(n, t) for n, t in effects if n not in known]
    have = [n for n, _ in effects if n in known]
    lines = []
    if not new and gap_closed:
        beyond = (f" beyond {', '.join(have)}, which this session's calibration already models (its thermal model)"
                  if have else "")
        lines.append(f"Nothing is missing{beyond}: the model explains this session to its noise level. Nothing to "
                     "act on.")
    elif new:
        names = ", ".join(n + (f" at {t:.0f} s" if t is not None else "") for n, t in new)
        rest = ("with it the model explains the data to the noise level" if gap_closed else
                "something else remains beyond it (the verdict below)")
        lines.append(f"Missing from the model: {names}; {rest}.")
        if any(n == "pose_error" for n, _ in new):
            lines.append(f"The poses are not where the session says: solve without them: rig solve {session.path} "
                         "--method magnitude")
        else:
            lines.append(f"Add it: rig discover {session.path} -o CALIB.yaml writes the calibration with it "
                         "(docs/discrepancy.md).")
    else:
        lines.append("Something remains that no effect in the library describes: the per-step table below shows "
                     "where; look for what changed in the rig or the session.")
    if aliases:
        lines.append(f"Cannot tell apart: {'; '.join(' / '.join(g) for g in aliases)}: rig discover {session.path} "
                     "--propose OUT.yaml writes the experiment that does.")
    if weak:
        lines.append(f"Weakly supported, not named: {', '.join(weak)} (some evidence, not enough to name it at the "
                     f"false-alarm rate): rig discover {session.path} --propose OUT.yaml writes the experiment that "
                     "would decide.")
    return lines


def format_report(session: Session, d: Discovery, *, details: bool = True) -> str:
    """The plain-text report: the verdict in words first, then localisation, effects named, gap before and
    after, per-step table. ``details`` False (the console's default, issue 33 item 3): the verdict, the effects
    named with their estimates, what the selection warns of, the gap and the final verdict; the statistics
    (localisation, the effects tested and not needed, smallest detectable magnitudes, the per-step table) only
    with ``details`` (``rig discover --details``; always in ``--json`` and the report)."""
    if not details:
        return "\n".join(_short_report(session, d))
    lines = headline_lines(session, d) + [""]
    lines += [f"session {session.id}: {len(d.steps)} static steps, noise level {d.noise_rms_g * 1e6:.1f} ug rms "
             f"(from each step's own scatter)" + (f", bias wander {d.wander_rms_g * 1e6:.1f} ug rms between steps "
                                                  "(the sensor's stated bias stability)" if d.wander_rms_g else "")]
    label = BASELINE_LABELS[d.baseline]
    lines.append(f"{label}: residual {d.rms_before_g * 1e6:.1f} ug rms, chi2/dof {d.chi2_per_dof_before:.2f}")
    lines.append("where the model and the data disagree:")
    lines += ["  " + s for s in summary_lines(d.where)]
    if d.effects:
        lines.append(f"effects named (false-alarm rate {d.false_alarm:g} per session):")
        for e in d.effects:
            lines.append(effect_line(e, session.lsb_per_g))
            lines.append(f"    residual after: {e.rms_after_g * 1e6:.1f} ug rms (p = {e.p_value:.2g})")
    else:
        lines.append("effects named: none (nothing significant beyond the baseline)")
    if d.not_named:
        near = sorted(d.not_named.items(), key=lambda kv: kv[1][0])
        lines.append("tested, not significant (p-value vs threshold): "
                     + ", ".join(f"{n} {p:.2g} vs {t:.2g}" for n, (p, t) in near))
    for group in d.aliases:
        lines.append(f"aliases (the data cannot tell these apart; the first was used): {', '.join(group)}")
    lines += selection_lines(session, d)
    if d.dropped:
        lines.append(f"named on the way, then dropped: {', '.join(d.dropped)} (what remains is better described by a "
                     f"generic factor, {d.unexplained['factor']['name'].replace('_', ' ')}, that makes them unnecessary)")
    if d.observability:
        lines.append(f"smallest detectable magnitude per candidate (false-alarm rate {d.false_alarm:g}, power "
                     f"{next(iter(d.observability.values()))['power']:.0%}, given the final model):")
        lines += ["  " + mdm_line(n, o, session.lsb_per_g) for n, o in d.observability.items()]
    if d.unobservable:
        lines.append("unobservable in this session (never named):")
        for n in d.unobservable:
            lines.append(f"  - {n}: {d.unobservable_why[n]}; needs {LIBRARY[n].coverage}")
    lines.append(f"gap: {d.rms_before_g * 1e6:.1f} -> {d.rms_after_g * 1e6:.1f} ug rms "
                 f"(noise {d.noise_rms_g * 1e6:.1f} ug), chi2/dof {d.chi2_per_dof_before:.2f} -> "
                 f"{d.chi2_per_dof_after:.2f}")
    lines += verdict_lines(d)
    lines.append("per step (residual, ug; before -> after):")
    lines.append(f"  {'step':<14} {'temp C':>7} {'leg':>7}   {'x':>17} {'y':>17} {'z':>17}")
    for s in d.steps:
        temp = f"{s.temp_c:7.2f}" if s.temp_c is not None else "      -"
        cells = " ".join(f"{b * 1e6:7.0f} -> {a * 1e6:5.0f}" for b, a in zip(s.residual_before_g, s.residual_after_g))
        lines.append(f"  {s.name[:14]:<14} {temp} {leg_word(s.heating):>7}   {cells}")
    return "\n".join(lines)


#: the words for a step's temperature leg (``StepRow.heating``: +1, -1, 0), as the localisation names them
#: (``rms z by leg: heating ..., cooling ..., unknown ...``, :func:`calib.discovery.report.localise`)
LEG_WORDS = {1: "heating", -1: "cooling", 0: "unknown"}


def leg_word(heating) -> str:
    """The per-step table's word for a step's leg: ``heating``, ``cooling``, ``unknown`` (before the temperature
    first moved more than the band), ``-`` without a temperature record."""
    return "-" if heating is None else LEG_WORDS.get(int(heating), "unknown")


def _short_report(session: Session, d: Discovery) -> list[str]:
    """The console's report without ``--details``: what to act on, and where the statistics are."""
    lines = headline_lines(session, d) + [""]
    lines += [effect_line(e, session.lsb_per_g) for e in d.effects]
    lines += selection_lines(session, d)
    lines.append(f"gap: {d.rms_before_g * 1e6:.1f} -> {d.rms_after_g * 1e6:.1f} ug rms "
                 f"(noise {d.noise_rms_g * 1e6:.1f} ug), chi2/dof {d.chi2_per_dof_before:.2f} -> "
                 f"{d.chi2_per_dof_after:.2f}")
    lines += verdict_lines(d)
    lines.append(f"the statistics (where the data disagree, effects tested and not needed, detectable magnitudes, "
                 f"the per-step table): rig discover {session.path} --details (or --json)")
    return lines


def selection_lines(session: Session, d: Discovery) -> list[str]:
    """What the selection says beyond the names: a jump on a design boundary, a pose error and its
    remedy, the effects selected and then not supported by the final model."""
    lines: list[str] = []
    for e in d.effects:
        if e.extra.get("t_jump_boundary"):
            lines.append(f"the jump's time ({e.extra['t_jump_s']:.0f} s) is a design boundary "
                         f"({', '.join(e.extra['t_jump_boundary'])}): an offset per "
                         f"{' / '.join(f.replace('_', ' ') for f in e.extra['aliased_with_factor'])} describes it as "
                         "well (aliased with the design, not a sudden change the data alone reveal)")
    saturated = "absorb every residual" in d.unobservable_why.get("pose_error", "")
    if saturated and not d.gap_closed:
        lines.append("the poses may not be where they should be (hand placement): with one step per placement the "
                     "placements' tilts would explain every residual, so the design cannot test it (record several "
                     f"windows per face); a pose-free solve does not need them: rig solve {session.path} --method "
                     "magnitude (with rests in enough orientations)")
    if any(e.name == "pose_error" for e in d.effects):
        lines.append(f"the poses are not where they should be (hand placement): solve with the pose-free method, "
                     f"rig solve {session.path} --method magnitude")
    if d.unsupported:
        lines.append("selected, then not significant in the final model (not named): "
                     + ", ".join(f"{u['name']} p = {u['p_value']:.2g}" for u in d.unsupported))
    for w in d.weak:
        lines.append(weak_line(w, session.lsb_per_g))
    return lines


def weak_line(w: dict, lsb_per_g: float | None) -> str:
    """A weak candidate (``Discovery.weak``): its fitted magnitude, p-value against the weak threshold and the
    design's smallest detectable magnitude, in the units :func:`effect_line` uses."""
    unit, k = shown_effect_unit(w["unit"], lsb_per_g)
    est = ", ".join(f"{a} {_fmt(_times(v, k))} +- {_fmt(_times(s, k))}" for a, v, s in zip(w["axes"], w["estimate"],
                                                                                         w["sigma"]))
    mdm = ", ".join(_fmt(_times(x, k)) for x in w["mdm"])
    return (f"  ? {w['name']:<24} [{unit}] {est}: weak candidate, not named (p = {w['p_value']:.2g}, weak below "
            f"{w['threshold']:.2g}; this design detects {mdm})")


def effect_line(e, lsb_per_g: float | None) -> str:
    """One named effect with its estimates and sigmas, the bias tempcos in counts/C^s as ``rig run`` prints them
    (:mod:`rig.analysis.effect_units`; the ``--json`` keeps the library's g/C^s)."""
    unit, k = shown_effect_unit(e.unit, lsb_per_g)
    est = ", ".join(f"{a} {_fmt(_times(v, k))} +- {_fmt(_times(s, k))}" for a, v, s in zip(e.axes, e.estimate, e.sigma))
    return f"  + {e.name:<24} [{unit}] {est}"


def mdm_line(name: str, o: dict, lsb_per_g: float | None = None) -> str:
    """One candidate's minimum detectable magnitude per parameter and its worst variance inflation (the bias
    tempcos' in counts/C^s, as :func:`effect_line`)."""
    unit, k = shown_effect_unit(o["unit"], lsb_per_g)
    mdm = ", ".join(_fmt(_times(x, k)) for x in o["mdm"])
    vif = f", variance inflation {o['max_vif']:.3g}" if o.get("max_vif") else ""
    return f"{name:<24} [{unit}] {mdm}{vif}"


def _times(v, k: float):
    return v if v is None else v * k


def verdict_lines(d: Discovery) -> list[str]:
    """The verdict in plain words: is the gap closed to the noise level, and if not, what remains."""
    head = f"chi2/dof {d.chi2_per_dof_after:.2f} on {d.dof_after} dof, p = {d.p_fit:.2g}"
    if d.gap_closed:
        return [f"verdict: the model now explains the data to the noise level ({head})"]
    lines = [f"verdict: something remains ({head}, beyond the false-alarm level {d.false_alarm:g}); "
             "no effect in the library describes it:"]
    if d.unexplained:
        lines += ["  " + s for s in unexplained_lines(d.unexplained)]
        f = d.unexplained.get("factor")
        if f:
            at = f" at {f['t_s']:.0f} s" if f.get("t_s") is not None else ""
            lines.append(f"  best generic description of what remains: an offset per {f['name'].replace('_', ' ')}{at} "
                         f"(p = {f['p_value']:.2g}; with it the residual would be {f['rms_with_factor_g'] * 1e6:.0f} ug rms)")
    return lines


def _fmt(v) -> str:
    if v is None or not np.isfinite(v):
        return "n/a"
    return f"{v:.4g}"


def write_plot(d: Discovery, path=None, *, session_id: str | None = None):
    """Residuals before and after against step (pose names) and temperature, in µg.

    ``path`` a file or a directory (then ``SESSION-discover.png`` inside it): writes the plot and
    returns the absolute path written; ``path`` None: returns the matplotlib Figure (nothing written).
    """
    r0 = np.array([s.residual_before_g for s in d.steps]) * 1e6
    r1 = np.array([s.residual_after_g for s in d.steps]) * 1e6
    added = ", ".join(e.name for e in d.effects) or "nothing added"
    series = [(f"baseline model: {d.rms_before_g * 1e6:.1f} {plots.RESIDUAL_UNIT} rms", r0),
              (f"+ {added}: {d.rms_after_g * 1e6:.1f} {plots.RESIDUAL_UNIT} rms", r1)]
    title = (f"rig discover, session {session_id or '(unnamed)'}: residuals before and after "
             f"(noise {d.noise_rms_g * 1e6:.1f} {plots.RESIDUAL_UNIT} rms)")
    fig = plots.residuals_figure(title, [s.name for s in d.steps], [s.temp_c for s in d.steps], series)
    if path is None:
        return fig
    target = plots.resolve_plot_path(path, plots.safe_name(f"{session_id or 'session'}-discover") + ".png")
    return plots.save(fig, target, dpi=100)


def write_calibration(session: Session, d: Discovery, path) -> Path:
    if d.calibration is None:
        raise CalibError("cannot write a calibration: the session's poses are unknown")
    cal = calfile.CalibrationFile(created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                                  software=dict(SOFTWARE), session=session.id, sensor=sensor_section(session),
                                  accelerometer=d.calibration)
    return calfile.write(path, cal)
