"""``rig characterize``'s analysis: a session's static record in physical units, the chip family's expected
figures, the characterisation (:mod:`calib.noise`) and its Allan-deviation plot (docs/noise.md).
"""

from __future__ import annotations

import numpy as np

from calib.errors import CalibError
from calib.noise.characterize import UNITS, Characterisation, characterize
from calib.noise.terms import DEFAULT_TERMS, REGISTRY_B_FLOOR, TERMS, NoiseFigures
from drivers.sensors.chips import CHIPS
from rig.analysis import plots
from rig.session.reader import Session

#: sensor -> (the session's column of counts, how counts become the unit)
COLUMNS = {
    "accel": ("accel_counts", lambda s: s.info.rig.sensor.accel_lsb_per_g),
    "gyro": ("gyro_counts", lambda s: s.info.rig.sensor.gyro_lsb_per_dps),
    "mag": ("mag_counts", lambda s: (s.info.rig.sensor.magnetometer.mag_lsb_per_ut
                                     if s.info.rig.sensor.magnetometer else None)),
}
#: sensor -> the chip registry's (bias instability, random walk) fields
REGISTRY = {
    "accel": ("accel_bias_instability_g", "accel_random_walk_g_per_rts"),
    "gyro": ("gyro_bias_instability_dps", "gyro_random_walk_dps_per_rts"),
    "mag": ("mag_bias_instability_ut", "mag_random_walk_ut_per_rts"),
}


def family_figures(model: str | None) -> dict:
    """The chip family's figures per sensor in the Allan convention (B the deviation's floor:
    :data:`calib.noise.terms.REGISTRY_B_FLOOR` times the registry's B); {} for an unknown chip."""
    spec = CHIPS.get(model or "")
    if spec is None:
        return {}
    out = {}
    for sensor, (b_key, k_key) in REGISTRY.items():
        b, k = getattr(spec, b_key), getattr(spec, k_key)
        if b is None:
            continue
        n = float(np.mean(spec.accel_noise_density_g_rthz)) if sensor == "accel" else 0.0
        out[sensor] = NoiseFigures(N=n, B=float(b) * REGISTRY_B_FLOOR, K=float(k or 0.0))
    return out


def record_step(session: Session, step: int | None) -> int:
    """The step to characterise: ``step`` when given (a complete static step), else the longest complete
    static step. CalibError (one line) when there is none."""
    static = [s for s in session.steps if s.is_static and s.status in ("complete", "flagged")]
    if step is not None:
        chosen = [s for s in static if s.index == step]
        if not chosen:
            raise CalibError(f"{session.path}: step {step} is not a finished static step (static steps: "
                             f"{', '.join(str(s.index) for s in static) or 'none'})")
        return step
    if not static:
        raise CalibError(f"{session.path}: no finished static step to characterise")
    counts = np.bincount(session.samples["step"][session.samples["step"] >= 0], minlength=len(session.steps))
    return max(static, key=lambda s: counts[s.index] if s.index < len(counts) else 0).index


def step_series(session: Session, index: int) -> tuple[np.ndarray, dict, list[str]]:
    """The step's sample times (s), each recorded sensor's samples in its unit, and notes on sensors left out."""
    rows = session.samples["step"] == index
    series, notes = {}, []
    for sensor, (column, lsb) in COLUMNS.items():
        counts = session.samples.get(column)
        scale = lsb(session)
        if counts is None or scale is None:
            continue
        x = np.asarray(counts[rows], float)
        if not np.all(np.isfinite(x)):
            notes.append(f"{sensor}: not read with every sample ({int(np.isfinite(x[:, 0]).sum())} of {len(x)}), "
                         "not characterised")
            continue
        series[sensor] = x / float(scale)
    return np.asarray(session.samples["t_s"][rows], float), series, notes


def characterize_session(session: Session, step: int | None = None, terms=DEFAULT_TERMS) -> tuple:
    """(the characterisation, the step characterised, notes) of ``session``'s static record."""
    index = record_step(session, step)
    t, series, notes = step_series(session, index)
    where = f"{session.path} step {index}"
    result = characterize(t, series, session.info.rig.sensor.sample_rate_hz, terms,
                          family_figures(session.info.rig.sensor.model), where=where)
    return result, index, notes + unresolved_notes(result)


#: each term's unit after the sensor's (g, deg/s, uT)
UNIT_SUFFIX = {"N": "/rtHz", "B": "", "K": "/rts", "R": "/s"}


def unresolved_notes(result: Characterisation) -> list[str]:
    """One note per axis and term whose 95 % interval reaches 0 (:meth:`calib.noise.fit.NoiseFit.unresolved`):
    what a calibration weighed with the profile then rests on (the point value, or 0 for a term fitted at 0)."""
    out = []
    for sensor, fits in result.fits.items():
        for axis, fit in fits.items():
            for term in fit.unresolved():
                f, unit = fit.terms[term], UNITS[sensor] + UNIT_SUFFIX[term]
                takes = (f"its point value {f.value:.3g} {unit}, so its sigmas may be off by as much" if f.value > 0 else
                         "0 for it, so its sigmas may be too small by as much")
                out.append(f"{sensor} {axis}: {TERMS[term][0]} not resolved by this record (95 % interval from 0 to "
                           f"{f.hi:.3g} {unit}): a calibration weighed with this profile takes {takes}; a longer record "
                           "narrows the interval")
    return out


def adev_figure(result: Characterisation, title: str):
    """One panel per sensor: each axis's Allan deviation with its 68 % intervals and the fitted model."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    plain = FuncFormatter(lambda v, _: f"{v:g}")  # the figures draw no mathtext (rig.analysis.plots)
    fig = plots.new_figure(5.0 * len(result.fits), 4.2)
    axes = fig.subplots(1, len(result.fits), squeeze=False)[0]
    for ax, (sensor, fits) in zip(axes, result.fits.items()):
        for axis, fit in fits.items():
            c = fit.curve
            colour = plots.AXIS_COLOURS[axis]
            ax.errorbar(c.tau_s, c.adev, yerr=[c.adev - c.lo, c.hi - c.adev], fmt="o", ms=3, color=colour,
                        label=f"{axis}", alpha=0.8)
            grid = np.geomspace(c.tau_s[0], c.tau_s[-1], 200)
            ax.plot(grid, fit.figures.adev(grid), "-", color=colour, lw=1)
            for term, style in (("N", ":"), ("B", "--"), ("K", "-."), ("R", (0, (1, 3)))):
                if term in fit.terms and fit.terms[term].value > 0:
                    only = NoiseFigures(**{term: fit.terms[term].value})
                    ax.plot(grid, only.adev(grid), linestyle=style, color=colour, lw=0.6, alpha=0.6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        for a in (ax.xaxis, ax.yaxis):
            a.set_major_formatter(plain)
            a.set_minor_formatter(NullFormatter())
        ax.set_xlabel("averaging time tau, s")
        ax.set_ylabel(f"Allan deviation, {UNITS[sensor]}")
        ax.set_title(f"{sensor}: fit (solid), N ..., B --, K -.", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    plots.legend_outside(fig, axes[0])
    fig.suptitle(plots.wrap(title, 90), fontsize=10)
    return fig
