"""What every command shares: exit codes and the usage error (from :mod:`rig.cli.codes`), JSON and
calibration formatting, how the end of every solve (:func:`rig.workflow.conclude.conclude`) is shown."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from calib.accel.rig_propagation import GROUPS as RIG_GROUPS
from calib.gyro import GyroCalibration
from calib.gyro.result import NONORTHOGONALITY_NAMES
from calib.mag import MagCalibration
from rig.cli.codes import EXIT_FAILURE, EXIT_OK, EXIT_REJECTED, UsageError  # noqa: F401 - the commands use them
from rig.lab.acceptance import as_lines
from rig.lab.fit import exactly_determined, misfit_with_rig
from rig.lab.units import GYRO_G_SENSITIVITY_UNIT, GYRO_NONORTHOGONALITY_UNIT, gyro_g_sensitivity_terms


def present(command: str, conclusion, *, quiet: bool = False) -> int:
    """What the pipeline tail decided, as every solving command prints it: PASS or FAIL with one line
    per failed limit (on stderr when ``quiet``), a history warning, the report written. Returns EXIT_OK,
    or EXIT_REJECTED when a limit failed."""
    if conclusion.acceptance is not None:
        for line in as_lines(conclusion.acceptance):  # with --json the verdict is in the JSON; the lines go to stderr
            print(line, file=sys.stderr if quiet else sys.stdout)
    if conclusion.history_warning is not None:
        print(f"rig {command}: warning: {conclusion.history_warning}", file=sys.stderr)
    if conclusion.report_path is not None:
        print(f"report: {conclusion.report_path}", file=sys.stderr if quiet else sys.stdout)
    if conclusion.report_warning is not None:
        print(f"rig {command}: warning: {conclusion.report_warning}", file=sys.stderr)
    return EXIT_OK if conclusion.passed else EXIT_REJECTED


def report_warnings(command: str, session) -> None:
    """Every warning the session reader collected (a dropped torn last line, ...) reaches the user."""
    for warning in getattr(session, "warnings", ()):
        print(f"rig {command}: warning: {warning}", file=sys.stderr)


def json_default(o):
    """JSON for numpy values (arrays as lists); anything else as its string."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def check_false_alarm(p: float) -> float:
    """``--false-alarm``: a probability in (0, 0.5)."""
    if not 0 < p < 0.5:
        raise UsageError(f"--false-alarm: expected a probability in (0, 0.5), got {p:g}")
    return p


def parse_thermal(v):
    """``--thermal``: auto, off or a polynomial order 1..3."""
    if v is None or v in ("auto", "off"):
        return v
    try:
        order = int(v)
    except ValueError:
        raise UsageError(f"--thermal: expected auto, off or a polynomial order 1..3, got {v!r}") from None
    if not 1 <= order <= 3:
        raise UsageError(f"--thermal: expected auto, off or a polynomial order 1..3, got {v!r}")
    return order


def format_calibration(cal) -> str:
    """A short human summary of a calibration file (accelerometer, gyroscope, magnetometer)."""
    lines = _accelerometer_lines(cal.accelerometer)
    if cal.gyroscope:
        lines += gyroscope_lines(cal.gyroscope)
    if cal.magnetometer:
        m = cal.magnetometer if isinstance(cal.magnetometer, MagCalibration) else MagCalibration.from_dict(cal.magnetometer)
        lines.append(format_magnetometer(m, "uT"))
    return "\n".join(lines)


#: the zero-rate output is printed, not stored, when the calibration file has no gyroscope section (rate steps)
ZRO_NOT_STORED = "; printed only: the calibration file's gyroscope section comes from rate steps (gyro_rates.yaml)"


class Stages:
    """``rig COMMAND: STAGE (T s)`` on stderr as each stage starts, for a long input only (more than ``long_bytes``
    of samples, or more than ``long_steps`` steps once :meth:`steps` says how many): a progress that never
    depends on stdout (it goes where the errors go, and a closed stderr does not stop the command)."""

    def __init__(self, command: str, session_dir, *, long_steps: int, long_bytes: int) -> None:
        try:
            size = (Path(session_dir) / "samples.csv").stat().st_size
        except OSError:
            size = 0
        self.command, self.long_steps = command, long_steps
        self.size_mb = size / 1e6
        self.on = size > long_bytes
        self.start = time.monotonic()

    def __call__(self, stage: str) -> None:
        if self.on:
            try:
                print(f"rig {self.command}: {stage} ({time.monotonic() - self.start:.1f} s)", file=sys.stderr,
                      flush=True)
            except (OSError, ValueError):
                self.on = False

    def steps(self, n_steps: int) -> None:
        """The input's length is known: long by its steps as well as by its bytes."""
        self.on = self.on or n_steps > self.long_steps


def warn_if_misfit(cal, command: str) -> None:
    """Say plainly, on stderr, when the fit is worse than the noise explains, by the solvers' own rule
    (:meth:`calib.accel.result.AccelCalibration.misfit`, the one the report and discovery use): ``rig solve`` and
    ``rig run`` alike (a run at chi2/dof 119 said nothing)."""
    fit = cal.accelerometer.fit
    significant, p = cal.accelerometer.misfit()
    with_rig = misfit_with_rig(cal.accelerometer)
    if significant and with_rig is not None and not with_rig["significant"]:
        print(f"rig {command}: note: the fit is worse than the noise alone explains (chi2/dof {fit.chi2_per_dof:.2f}), "
              f"as the turntable's own errors make it: with them at their budget's figures it fits (chi2/dof "
              f"{with_rig['chi2_per_dof']:.2f}, p = {with_rig['p']:.2g}). The expanded uncertainty U holds them"
              f"{TAKE_THEM_OUT if uncharacterised_table(cal.accelerometer) else ''}.", file=sys.stderr)
        return
    if significant:
        print(f"rig {command}: warning: the model does not fit the data (chi2/dof {fit.chi2_per_dof:.2f}, p = {p:.2g}, "
              f"residual {fit.residual_rms_g * 1e6:.0f} ug rms): poses not where the session says (hand-placed?"
              f"{UNCHARACTERISED_TABLE if uncharacterised_table(cal.accelerometer) else ''}), "
              "another sensor, or an effect the model lacks; see rig discover. The sigmas carry the misfit.",
              file=sys.stderr)


#: ``--history`` of the commands that record a calibration (``rig run``, ``rig solve``)
HISTORY_HELP = ("the calibration history to record into: a database file or URL (postgresql+psycopg://user@host/db; "
                "default $RIG_HISTORY, else ~/.local/share/rig/history.sqlite)")
#: how a turntable's own errors, known only by their classes, are taken out of a calibration
TAKE_THEM_OUT = ("; characterising the rig by reversal (procedures/characterize_reversal.yaml then rig "
                 "characterize-rig) takes most of them out")
#: what a misfit on a turntable whose own errors are only known by their classes may be, and what takes them out
UNCHARACTERISED_TABLE = ("; or the turntable's own errors, which its budget holds only by their classes: characterise "
                         "the rig by reversal, procedures/characterize_reversal.yaml then rig characterize-rig")


def uncertainty_rig_terms(accel) -> float:
    """The largest standard uncertainty the turntable's own errors put into any quantity of ``accel``'s budget (0
    without a budget or without rig terms: a simulated table without its errors, an import)."""
    budget = (getattr(accel, "uncertainty", None) or {}).get("budget") or []
    largest = 0.0
    for entry in budget:
        if entry.get("name") not in RIG_GROUPS:
            continue
        stack = [v for k, v in entry.items() if k not in ("name", "type", "source", "distribution")]
        while stack:
            v = stack.pop()
            if isinstance(v, dict):
                stack.extend(v.values())
            elif isinstance(v, (list, tuple)):
                stack.extend(v)
            elif isinstance(v, (int, float)) and v == v:
                largest = max(largest, abs(float(v)))
    return largest


def uncharacterised_table(accel) -> bool:
    """Whether ``accel``'s budget holds a turntable's own errors by their classes (not by a characterisation)."""
    rig = str((getattr(accel, "uncertainty", None) or {}).get("rig") or "")
    return "characterised by reversal" not in rig and uncertainty_rig_terms(accel) > 0


def format_magnetometer(m: MagCalibration, unit: str) -> str:
    """The magnetometer's result with its sigmas (``unit``: uT, or counts for unknown units): hard iron and the
    soft-iron matrix A, each entry with its 1-sigma."""
    sig = m.sigma
    steps = f"{m.n_steps} step" + ("" if m.n_steps == 1 else "s")
    if m.method == "ellipsoid" and m.field_ut == 1.0:  # no site: the field's magnitude is the unit of the fit
        residual = (f"residual {m.residual_rms_ut:.4g} of the field's magnitude rms (unknown: A is up to that scale; "
                    "a site: section in the rig file states it)")
    else:
        residual = f"residual {m.residual_rms_ut:.4g} {unit} rms"
    lines = [f"  magnetometer ({m.method}): {steps}, {residual}, chi2/dof {m.chi2_per_dof:.2f}",
             "    hard iron " + "  ".join(f"{a} {v:+.4g} +- {sig[f'hard_iron_{a}']:.2g}"
                                         for a, v in zip("xyz", m.hard_iron_ut)) + f" {unit}"]
    scale = (f" ({unit}: the field's magnitude is unknown, so A carries it)" if m.method == "ellipsoid"
             and m.field_ut == 1.0 else " (dimensionless)")
    lines.append(f"    soft-iron matrix A, m = A h + B, rows x, y, z{scale}"
                 + (", up to a rotation (the ellipsoid fixes its shape, not its orientation)"
                    if m.method == "ellipsoid" else "") + ":")
    for i, r in enumerate("xyz"):
        lines.append(f"    a_{r}* " + "  ".join(f"{m.matrix[i][j]:+.5g} +- {sig[f'a_{r}{c}']:.2g}"
                                               for j, c in enumerate("xyz")))
    u = m.uncertainty
    if u:  # the table's frame and poses (docs/uncertainty.md, "The magnetometer")
        k = float(u["k"])
        lines.append(f"    expanded uncertainty U, k = {k:g}: hard iron " + "  ".join(
            f"{a} {float(u[f'hard_iron_{a}']):.2g}" for a in "xyz") + f" {unit}; A off-diagonal up to "
            f"{max(float(u[f'a_{r}{c}']) for r in 'xyz' for c in 'xyz' if r != c):.2g}, diagonal up to "
            f"{max(float(u[f'a_{r}{r}']) for r in 'xyz'):.2g}")
    return "\n".join(lines)


#: an effect's estimate is printed as found when it is this many sigmas from zero on some axis
EFFECT_Z = 3.0


def _accelerometer_lines(a) -> list[str]:
    # exactly determined: no degrees of freedom, or a residual at rounding level (the flip method on one pose per face)
    exact = exactly_determined(a.fit.residual_rms_g, a.degrees_of_freedom())
    fit = (f"chi2/dof {a.fit.chi2_per_dof:.2f}" if not exact else
           "exactly determined (as many estimates as measurements: the residual is zero by construction and says "
           "nothing about the noise)")
    lines = [f"  model: {a.model}   fit: {a.fit.steps} steps, residual {a.fit.residual_rms_g * 1e6:.1f} ug rms, {fit}"]
    sig = a.sigma
    at = f" (at t0 {a.temperature.t0_c:.2f} C)" if a.temperature else ""
    for j, axis in enumerate("xyz"):
        lines.append(f"  {axis}: bias {a.bias_counts[j]:10.2f} +- {sig['bias_counts'][j]:.2f} counts{at}   "
                     f"scale {a.scale_counts_per_g[j]:10.2f} +- {sig['scale_counts_per_g'][j]:.2f} counts/g")
    if a.misalignment:
        m = a.misalignment
        sm = sig.get("misalignment") or {}
        lines.append("  misalignment (mrad): " + "  ".join(
            f"{k} {m[k] * 1e3:.3f} +- {sm.get(k, float('nan')) * 1e3:.3f}" for k in ("alpha_yz", "alpha_zy", "alpha_zx")))
    elif a.model == "full":  # the six cross-axis terms M_ij, named as the history and the report name them (accel.m_xy)
        lines.append(cross_axis_line(a.matrix_counts_per_g, sig.get("matrix_counts_per_g")))
    if a.temperature:
        lines += _tempco_lines(a.temperature, (sig.get("temperature") or {}).get("coefficients"))
    if a.uncertainty:
        lines += uncertainty_lines(a.uncertainty)
    if a.effects:
        lines += _effect_lines(a.effects)
    return lines


def cross_axis_line(matrix, sigma) -> str:
    """The full model's six cross-axis terms ``M_ij`` (i != j, counts/g) with their 1-sigma, on one line."""
    m = np.asarray(matrix, float)
    s = np.asarray(sigma, float) if sigma is not None else np.full((3, 3), np.nan)
    return "  cross-axis (counts/g): " + "  ".join(f"{'xyz'[i]}{'xyz'[j]} {m[i, j]:+.2f} +- {s[i, j]:.2f}"
                                                  for i in range(3) for j in range(3) if i != j)


#: the budget's quantity groups as the printout shows them: (key in the section, label, unit, factor, axis names)
UNCERTAINTY_GROUPS = (("bias_counts", "bias", "counts", 1.0, "xyz"),
                      ("scale_counts_per_g", "scale", "counts/g", 1.0, "xyz"),
                      ("misalignment", "misalignment", "mrad", 1e3, ("alpha_yz", "alpha_zy", "alpha_zx")),
                      ("matrix_counts_per_g", "cross-axis", "counts/g", 1.0, ("xy", "xz", "yx", "yz", "zx", "zy")))
#: how many of the largest contributions each group's line names
LARGEST = 2


def _group_values(block, axes) -> list[float]:
    """A group's values in the section (a list of 3, a 3x3 list or the misalignment mapping) in ``axes``' order."""
    if isinstance(block, dict):
        return [float(block.get(a, float("nan"))) for a in axes]
    arr = np.asarray(block, float)
    if arr.ndim == 2:
        return [float(arr["xyz".index(a[0]), "xyz".index(a[1])]) for a in axes]
    return [float(v) for v in arr]


def uncertainty_lines(u: dict) -> list[str]:
    """The expanded uncertainty of every parameter group, one line each: U = k u_c per axis in the printout's
    units (counts, counts/g, mrad), and the largest contributions (their largest standard uncertainty over
    the axes); then where the rig's terms come from. ``sigma`` above stays the Type A standard uncertainty."""
    k = float(u.get("k", float("nan")))
    lines = [f"  expanded uncertainty U = k u_c, k = {k:g} (the +- above: sigma, Type A only; docs/uncertainty.md):"]
    budget = u.get("budget") or []
    for key, label, unit, factor, axes in UNCERTAINTY_GROUPS:
        if u.get(key) is None or (key == "matrix_counts_per_g" and u.get("misalignment") is not None):
            continue  # the triangular model's cross-axis terms are its angles
        values = [v * factor for v in _group_values(u[key], axes)]
        if key == "matrix_counts_per_g":
            shown_axes = [a for a, v in zip(axes, values) if v > 0]
            values = [v for v in values if v > 0]
            if not values:
                continue
        else:
            shown_axes = list(axes)
        named = sorted(((max(_group_values(c.get(key), axes), default=0.0) * factor, c.get("name", "?"))
                        for c in budget if c.get(key) is not None), key=lambda t: -np.nan_to_num(t[0]))
        largest = ", ".join(f"{name} {v:.3g}" for v, name in named[:LARGEST] if np.isfinite(v) and v > 0)
        lines.append(f"    {label} U: " + "  ".join(f"{a.replace('alpha_', '')} {v:.3g}" for a, v in
                                                  zip(shown_axes, values)) + f" {unit}"
                     + (f"   largest u: {largest}" if largest else ""))
    if u.get("rig"):
        lines.append(f"    rig terms: {u['rig']}")
    return lines


def _tempco_lines(t, sigmas) -> list[str]:
    """The bias temperature coefficients, each order on a line, with their sigmas (counts/C^s)."""
    c = np.asarray(t.coefficients, float)
    s = np.asarray(sigmas, float) if sigmas is not None else np.full_like(c, np.nan)
    lines = [f"  temperature: bias polynomial about t0 {t.t0_c:.2f} C, order {t.order}"]
    for k in range(int(t.order)):
        unit = "counts/C" if k == 0 else f"counts/C^{k + 1}"
        lines.append(f"  bias tempco ({unit}): " + "  ".join(
            f"{axis} {c[j, k]:+.4g} +- {s[j, k]:.2g}" for j, axis in enumerate("xyz")))
    return lines


def _effect_lines(effects) -> list[str]:
    """Each fitted effect with its estimate per axis; those within EFFECT_Z sigmas of zero on every axis are
    named as tested and not needed (their estimates stay in the file)."""
    found, not_needed = [], []
    for e in effects:
        est, sig = e.get("estimate") or [], e.get("sigma") or []
        z = [abs(v) / s for v, s in zip(est, sig) if v is not None and s not in (None, 0)]
        if z and max(z) >= EFFECT_Z:
            found.append(f"  effect {e['name']} ({e.get('unit', '')}): " + "  ".join(
                f"{axis} {v:+.3g} +- {s:.2g}" for axis, v, s in zip(e.get("axes") or "xyz", est, sig)
                if v is not None and s is not None))
        else:
            not_needed.append(e["name"])
    if not_needed:
        found.append(f"  tested, not needed (within {EFFECT_Z:g} sigma of zero on every axis): {', '.join(not_needed)}")
    return found


def gyroscope_lines(section) -> list[str]:
    """The gyroscope's result in the calibration file's units, as ``rig history`` and ``rig report`` show it (issue
    33 item 4: one unit per quantity, every parameter with its sigma): bias (counts), scale (counts/(deg/s)), the
    six nonorthogonalities (ratio M_ij/M_ii) and, when determined, the g-sensitivity terms (counts/g; ``xz``: gyro x
    per g along z), named and labelled as the report's parameters table names them (:mod:`rig.lab.units`)."""
    g = section if isinstance(section, GyroCalibration) else GyroCalibration.from_dict(section)
    sig = g.sigma
    out = [f"  gyroscope: {g.n_steps} rate steps, residual {g.residual_rms_dps:.4f} deg/s rms",
           "    bias " + " ".join(f"{x} {v:+.2f}+-{sig[f'b_{x}']:.2f}" for x, v in zip("xyz", g.bias_counts)) + " counts",
           "    scale " + " ".join(f"{x} {v:.3f}+-{sig[f'k_{x}']:.3f}" for x, v in zip("xyz", g.scale_counts_per_dps))
           + " counts/(deg/s)",
           f"    nonorthogonality ({GYRO_NONORTHOGONALITY_UNIT}): " + " ".join(
               f"{n[2:]} {g.nonorthogonality[n]:+.6f}+-{sig[n]:.6f}" for n in NONORTHOGONALITY_NAMES)]
    u = g.uncertainty
    if u:  # the table's own axes and frame in the nonorthogonalities (docs/uncertainty.md, "The gyroscope")
        named = sorted(((max(float(c.get(n, 0.0)) for n in NONORTHOGONALITY_NAMES), c.get("name", "?"))
                        for c in u.get("budget") or []), key=lambda t: -t[0])
        largest = ", ".join(f"{name} {v:.2g}" for v, name in named[:LARGEST] if v > 0)
        out.append(f"    nonorthogonality U, k = {float(u['k']):g}: " + " ".join(
            f"{n[2:]} {float(u[n]):.6f}" for n in NONORTHOGONALITY_NAMES) + (f"   largest u: {largest}" if largest else ""))
    if g.g_sensitivity:
        terms = gyro_g_sensitivity_terms(g.g_sensitivity)
        out.append(f"    g-sensitivity ({GYRO_G_SENSITIVITY_UNIT}; gyro axis, g axis): " + " ".join(
            f"{n} {v:+.2f}+-{e:.2f}" for n, v, e in terms) if terms else
            "    g-sensitivity: no column determined by these rate steps (not estimated)")
    return out
