"""Every calibrated quantity as a flat, named scalar: ``(name, value, sigma, unit)``.

Names are ``<sensor>.<quantity>[_<axis>]``: ``accel.bias_x`` (counts), ``accel.scale_y`` (counts/g),
``accel.alpha_yz`` (rad, triangular model), ``accel.m_xy`` (counts/g, full model), ``accel.t0_c`` (C),
``accel.tempco1_z`` (counts/C), ``gyro.bias_x`` (counts), ``gyro.scale_x`` (counts/(deg/s)),
``mag.hard_iron_x`` (uT). The calibration history stores these rows and acceptance limits name them
(docs/history.md, docs/procedures.md).
"""

from __future__ import annotations

import math

import numpy as np


def finite_or_none(x) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _vector(out: list, prefix: str, values, sigmas, unit: str) -> None:
    values = np.asarray(values, float).ravel()
    sig = np.asarray(sigmas, float).ravel() if sigmas is not None else np.full(values.shape, np.nan)
    for axis, v, s in zip("xyz", values, sig):
        out.append((f"{prefix}_{axis}", float(v), finite_or_none(s), unit))


def accel_parameters(a) -> list[tuple[str, float, float | None, str]]:
    """(name, value, sigma, unit) of every accelerometer parameter of an AccelCalibration."""
    out: list = []
    sig = a.sigma
    _vector(out, "accel.bias", a.bias_counts, sig.get("bias_counts"), "counts")
    _vector(out, "accel.scale", a.scale_counts_per_g, sig.get("scale_counts_per_g"), "counts/g")
    if a.misalignment:
        sm = sig.get("misalignment") or {}
        for k in ("alpha_yz", "alpha_zy", "alpha_zx"):
            out.append((f"accel.{k}", float(a.misalignment[k]), finite_or_none(sm.get(k)), "rad"))
    elif a.model == "full":
        m, sm = np.asarray(a.matrix_counts_per_g, float), np.asarray(sig.get("matrix_counts_per_g"), float)
        for i, j in [(i, j) for i in range(3) for j in range(3) if i != j]:
            out.append((f"accel.m_{'xyz'[i]}{'xyz'[j]}", float(m[i, j]), finite_or_none(sm[i, j]), "counts/g"))
    if a.temperature is not None:
        coeffs = np.asarray(a.temperature.coefficients, float)
        st = ((sig.get("temperature") or {}).get("coefficients"))
        st = np.asarray(st, float) if st is not None and np.shape(st) == coeffs.shape else np.full(coeffs.shape, np.nan)
        out.append(("accel.t0_c", float(a.temperature.t0_c), None, "C"))  # the biases above are at t0
        for s in range(coeffs.shape[1]):
            _vector(out, f"accel.tempco{s + 1}", coeffs[:, s], st[:, s], f"counts/C^{s + 1}")
    return out


def sensor_parameters(cal) -> list[tuple[str, float, float | None, str]]:
    """Every parameter with its sigma: accelerometer, gyroscope and magnetometer biases when present."""
    out = accel_parameters(cal.accelerometer)
    g = cal.gyroscope
    if g is not None:
        _vector(out, "gyro.bias", g.bias_counts, [g.sigma.get(f"b_{x}") for x in "xyz"], "counts")
        _vector(out, "gyro.scale", g.scale_counts_per_dps, [g.sigma.get(f"k_{x}") for x in "xyz"], "counts/(deg/s)")
    m = cal.magnetometer
    if m is not None:
        _vector(out, "mag.hard_iron", m.hard_iron_ut, [m.sigma.get(f"hard_iron_{x}") for x in "xyz"], "uT")
    return out


def reference_temp_c(params: dict, temp_mean_c: float | None) -> float | None:
    """The temperature, C, at which ``params`` ({name: (value, sigma, unit)}) state the accelerometer
    bias: ``accel.t0_c`` when the calibration has temperature terms, else the session's mean
    temperature (None when unknown)."""
    t0 = params.get("accel.t0_c")
    return float(t0[0]) if t0 is not None else finite_or_none(temp_mean_c)


def biases_moved(params: dict, polynomial: dict, from_c: float, to_c: float) -> dict:
    """``params``' accelerometer biases, stated at ``from_c`` (C), moved to ``to_c`` by the temperature terms of
    another calibration of the same unit (``polynomial``: its parameters, with ``accel.t0_c`` and
    ``accel.tempco{k}_{axis}``): ``b(to) = b(from) + sum_k c_k ((to - t0)^k - (from - t0)^k)``, each sigma gaining
    ``|(to - t0)^k - (from - t0)^k| sigma(c_k)`` in quadrature. Only the biases are returned."""
    t0 = float(polynomial["accel.t0_c"][0])
    out = {}
    for axis in "xyz":
        name = f"accel.bias_{axis}"
        if name not in params:
            continue
        value, sigma, unit = params[name]
        var = None if sigma is None else sigma**2
        for k in (1, 2, 3):
            c = polynomial.get(f"accel.tempco{k}_{axis}")
            if c is None:
                continue
            step = (float(to_c) - t0) ** k - (float(from_c) - t0) ** k
            value += c[0] * step
            if var is not None:
                var = None if c[1] is None else var + (c[1] * abs(step)) ** 2
        out[name] = (value, None if var is None else math.sqrt(var), unit)
    return out


def biases_at(params: dict, temp_c: float) -> dict:
    """``params`` with the accelerometer biases moved from ``accel.t0_c`` to ``temp_c`` (C) by the
    calibration's own bias polynomial, ``b(T) = b(t0) + sum_k c_k (T - t0)^k``; each bias sigma gains
    ``|T - t0|^k sigma(c_k)`` in quadrature (the covariance of bias and coefficients is not stored,
    so this is an approximation). Unchanged without temperature terms."""
    if "accel.t0_c" not in params:
        return params
    t0 = float(params["accel.t0_c"][0])
    return {**params, **biases_moved(params, params, t0, temp_c)}  # from t0 by its own polynomial


def at_common_temperature(previous: dict, prev_temp_c: float | None, current: dict,
                          cur_temp_c: float | None) -> tuple[dict, dict, float | None]:
    """Two calibrations' parameters with their accelerometer biases stated at one temperature, so a
    change between them is the sensor's and not the temperature's.

    The common temperature is the reference of the calibration *without* temperature terms (its
    bias holds only there), else the current calibration's ``t0``. When neither has temperature
    terms, or a needed temperature is unknown, both are returned unchanged (and None).
    """
    t_prev, t_cur = reference_temp_c(previous, prev_temp_c), reference_temp_c(current, cur_temp_c)
    thermal_prev, thermal_cur = "accel.t0_c" in previous, "accel.t0_c" in current
    if not (thermal_prev or thermal_cur) or t_prev is None or t_cur is None:
        return previous, current, None
    common = t_prev if not thermal_prev else t_cur
    return biases_at(previous, common), biases_at(current, common), common
