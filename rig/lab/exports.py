"""Exports of a ``rig-calibration/1`` file to the tools people fly and analyse with (docs/exports.md).

``px4`` (QGroundControl parameter file: ``CAL_ACC0_*``, ``TC_A0_*``), ``ardupilot`` (Mission Planner
parameter file: ``INS_ACCOFFS_*``, ``INS_ACCSCAL_*``, ``INS_TCAL1_*``), ``imucal`` (its
``FerrarisCalibrationInfo`` JSON) and ``json`` (the calibration file itself as JSON, lossless).

Each target's correction is re-implemented here from the *exported numbers* (:data:`APPLY`), so
the error an export causes is measured on what the target would compute: the full model predicts
raw counts at the seed's seven verification poses, both the full calibration and the exported one
turn them back into specific force, and the roll/pitch difference is the price of the export.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from calib.file import calibration as calfile
from calib.evaluation import GIMBAL_LOCK_COS, roll_pitch_deg
from rig.planning.kinematics import f_nominal

G_MS2 = 9.80665  # PX4 CONSTANTS_ONE_G, ArduPilot GRAVITY_MSS, imucal's m/s^2

#: the seed's seven verification poses (procedures/verify_seed_table.yaml): name, (a1, a2, a3) deg
VERIFY_POSES: list[tuple[str, tuple[float, float, float]]] = [
    ("roll 0 pitch 90", (0, 90, 0)), ("roll -60 pitch 60", (0, 60, -60)), ("roll -30 pitch 30", (0, 30, -30)),
    ("roll 0 pitch 0", (0, 0, 0)), ("roll 30 pitch -30", (0, -30, 30)), ("roll 60 pitch -60", (0, -60, 60)),
    ("roll 90 pitch 0", (0, 0, 90)),
]
#: thermal-compensation validity range written to PX4 and ArduPilot (the file does not record the
#: chamber's range); ArduPilot's midpoint 35 C equals its TEMP_REFERENCE, so old and new firmware agree
TC_RANGE_C = (-10.0, 80.0)
AP_TEMP_REFERENCE_C = 35.0
AP_SCALE_FACTOR = 1.0e6
TARGETS = ("px4", "ardupilot", "imucal", "json")


@dataclass
class Export:
    """An exported calibration: the file's text, its parameters, what it cannot hold and what that costs."""

    target: str
    text: str
    params: dict = field(default_factory=dict)
    dropped: list = field(default_factory=list)
    error: dict = field(default_factory=dict)

    def summary(self) -> str:
        """One line: what the format cannot hold and the roll/pitch error dropping it causes."""
        if not self.dropped:
            return f"{self.target}: holds the whole calibration (nothing dropped)"
        e = self.error
        return (f"{self.target}: cannot hold {', '.join(self.dropped)}; dropping them changes roll/pitch at the seed's "
                f"{e['poses']} verification poses by up to {e['max_roll_deg']:.4f} deg roll / "
                f"{e['max_pitch_deg']:.4f} deg pitch ({e['max_angle_deg']:.4f} deg angle)")


# ---------------------------------------------------------------------------------------------- what is lost

def _off_diagonal(a) -> bool:
    m = np.asarray(a.matrix_counts_per_g, float)
    return bool(np.any(np.abs(m - np.diag(np.diag(m))) > 0))


def dropped_terms(cal, target: str) -> list[str]:
    """What ``target`` cannot hold of ``cal`` (only what the calibration actually has)."""
    a = cal.accelerometer
    if target == "json":
        return []
    out = []
    if target in ("px4", "ardupilot") and _off_diagonal(a):
        out.append("misalignment / cross-axis terms" + (" (3 angles)" if a.misalignment else " (6 terms)"))
    if target == "imucal" and a.temperature is not None:
        out.append(f"temperature terms (order {a.temperature.order})")
    if a.effects:
        out.append("effect terms (" + ", ".join(e["name"] for e in a.effects) + ")")
    out.append("sigmas")
    if target in ("px4", "ardupilot"):
        out += [name for name, sec in (("gyroscope section", cal.gyroscope), ("magnetometer section", cal.magnetometer))
                if sec is not None]
    elif cal.magnetometer is not None:
        out.append("magnetometer section")
    return out


# ---------------------------------------------------------------------------------------------- targets

def _bias_poly_ms2(a) -> tuple[float, np.ndarray]:
    """(t0, (3, S) coefficients in m/s^2 per C^s) of the bias polynomial, sensor frame pre-scale."""
    t = a.temperature
    return float(t.t0_c), np.asarray(t.coefficients, float) * G_MS2 / a.lsb_per_g


def _offsets_and_scales(a, offset_name: str, scale_name: str) -> dict:
    """The diagonal model both autopilots hold: per axis X, Y, Z the offset in m/s^2 at the nominal scale
    (``offset_name.format(axis)``) and the dimensionless scale that corrects it (``scale_name``)."""
    k = np.diag(np.asarray(a.matrix_counts_per_g, float))
    b = np.asarray(a.bias_counts, float) * G_MS2 / a.lsb_per_g
    p = {offset_name.format(axis): float(b[j]) for j, axis in enumerate("XYZ")}
    p.update({scale_name.format(axis): float(a.lsb_per_g / k[j]) for j, axis in enumerate("XYZ")})
    return p


def px4_params(cal) -> dict:
    """PX4: ``corrected = R (raw - TC_offset(T) - CAL_ACC0_OFF) * CAL_ACC0_SCALE``, raw in m/s^2 at the
    nominal scale; TC_offset(T) = X0 + X1 dT + X2 dT^2 + X3 dT^3, dT = clip(T) - TREF."""
    a = cal.accelerometer
    p = _offsets_and_scales(a, "CAL_ACC0_{}OFF", "CAL_ACC0_{}SCALE")
    if a.temperature is not None:
        t0, c = _bias_poly_ms2(a)
        p.update({"TC_A_ENABLE": 1, "TC_A0_TREF": t0, "TC_A0_TMIN": TC_RANGE_C[0], "TC_A0_TMAX": TC_RANGE_C[1]})
        for s in range(4):
            for j in range(3):
                p[f"TC_A0_X{s}_{j}"] = float(c[j, s - 1]) if 1 <= s <= c.shape[1] else 0.0
    return p


def _shift_polynomial(coeffs: np.ndarray, shift: float) -> np.ndarray:
    """Coefficients (3, 3) of powers 1..3 of d = T - Tref for sum_s c_s (d + shift)^s, constant dropped."""
    out = np.zeros((3, 3))
    for s in range(1, coeffs.shape[1] + 1):
        for k in range(1, s + 1):
            out[:, k - 1] += coeffs[:, s - 1] * math.comb(s, k) * shift ** (s - k)
    return out


def ardupilot_params(cal) -> dict:
    """ArduPilot: ``corrected = ((raw - tcal(T)) - INS_ACCOFFS) * INS_ACCSCAL`` in the sensor frame, with
    tcal(T) = P(T - 35) - P(INS_ACC1_CALTEMP - 35), P(d) = (ACC1 d + ACC2 d^2 + ACC3 d^3) * 1e-6."""
    a = cal.accelerometer
    p = _offsets_and_scales(a, "INS_ACCOFFS_{}", "INS_ACCSCAL_{}")
    if a.temperature is not None:
        t0, c = _bias_poly_ms2(a)
        shifted = _shift_polynomial(c, AP_TEMP_REFERENCE_C - t0) * AP_SCALE_FACTOR
        p.update({"INS_ACC1_CALTEMP": t0, "INS_TCAL1_ENABLE": 1, "INS_TCAL1_TMIN": TC_RANGE_C[0],
                  "INS_TCAL1_TMAX": TC_RANGE_C[1]})
        for s in range(3):
            for j, axis in enumerate("XYZ"):
                p[f"INS_TCAL1_ACC{s + 1}_{axis}"] = float(shifted[j, s])
    return p


def _split_k_r(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M = K R with K diagonal (row norms) and R's rows unit vectors (imucal's scale and 'rotation')."""
    norms = np.linalg.norm(m, axis=1)
    return np.diag(norms), m / norms[:, None]


def imucal_info(cal) -> dict:
    """imucal FerrarisCalibrationInfo: ``acc = R_a^-1 K_a^-1 (raw - b_a)`` in m/s^2 from raw counts ("a.u."),
    ``gyr = R_g^-1 K_g^-1 (raw - K_ga acc - b_g)`` in deg/s."""
    a = cal.accelerometer
    k_a, r_a = _split_k_r(np.asarray(a.matrix_counts_per_g, float) / G_MS2)
    g = cal.gyroscope
    if g is not None:
        k_g, r_g = _split_k_r(np.asarray(g.matrix_counts_per_dps, float))
        sens = (g.g_sensitivity or {}).get("matrix_counts_per_g") if isinstance(g.g_sensitivity, dict) else None
        k_ga = np.asarray(sens, float) / G_MS2 if sens is not None else np.zeros((3, 3))
        b_g, comment = np.asarray(g.bias_counts, float), "exported by rig export"
    else:
        k_g, r_g, k_ga, b_g = np.eye(3), np.eye(3), np.zeros((3, 3)), np.zeros(3)
        comment = "exported by rig export; no gyroscope calibration: the gyro terms pass raw counts through"
    return {"acc_unit": "m/s^2", "gyr_unit": "deg/s", "from_acc_unit": "a.u.", "from_gyr_unit": "a.u.",
            "comment": comment, "K_a": k_a.tolist(), "R_a": r_a.tolist(), "b_a": np.asarray(a.bias_counts, float).tolist(),
            "K_g": k_g.tolist(), "R_g": r_g.tolist(), "K_ga": k_ga.tolist(), "b_g": b_g.tolist(),
            "cal_type": "Ferraris", "_format_version": "2.0.0"}


# ---------------------------------------------------------------------------------------------- applying

def _tc_px4(p: dict, temp_c: float) -> np.ndarray:
    if not p.get("TC_A_ENABLE"):
        return np.zeros(3)
    t = min(max(temp_c, p["TC_A0_TMIN"]), p["TC_A0_TMAX"]) - p["TC_A0_TREF"]
    return np.array([sum(p[f"TC_A0_X{s}_{j}"] * t ** s for s in range(4)) for j in range(3)])


def apply_px4(p: dict, counts, lsb_per_g: float, temp_c: float) -> np.ndarray:
    """What PX4 computes (sensor frame, rotation identity), in g, from raw counts."""
    raw = np.atleast_2d(counts) * G_MS2 / lsb_per_g
    off = np.array([p[f"CAL_ACC0_{x}OFF"] for x in "XYZ"]) + _tc_px4(p, temp_c)
    return (raw - off) * np.array([p[f"CAL_ACC0_{x}SCALE"] for x in "XYZ"]) / G_MS2


def _tc_ardupilot(p: dict, temp_c: float) -> np.ndarray:
    if not p.get("INS_TCAL1_ENABLE"):
        return np.zeros(3)

    def poly(d):
        return np.array([sum(p[f"INS_TCAL1_ACC{s}_{x}"] * d ** s for s in (1, 2, 3)) for x in "XYZ"]) / AP_SCALE_FACTOR

    lo, hi = p["INS_TCAL1_TMIN"], p["INS_TCAL1_TMAX"]
    t, cal_t = min(max(temp_c, lo), hi), min(max(p["INS_ACC1_CALTEMP"], lo), hi)
    return poly(t - AP_TEMP_REFERENCE_C) - poly(cal_t - AP_TEMP_REFERENCE_C)


def apply_ardupilot(p: dict, counts, lsb_per_g: float, temp_c: float) -> np.ndarray:
    """What ArduPilot computes (sensor frame, orientation identity), in g, from raw counts."""
    raw = np.atleast_2d(counts) * G_MS2 / lsb_per_g
    corrected = raw - _tc_ardupilot(p, temp_c) - np.array([p[f"INS_ACCOFFS_{x}"] for x in "XYZ"])
    return corrected * np.array([p[f"INS_ACCSCAL_{x}"] for x in "XYZ"]) / G_MS2


def apply_imucal(info: dict, counts, lsb_per_g: float, temp_c: float) -> np.ndarray:
    """imucal's ``_calibrate_acc`` (inv(R_a) inv(K_a) (acc - b_a)), in g."""
    mat = np.linalg.inv(np.asarray(info["R_a"])) @ np.linalg.inv(np.asarray(info["K_a"]))
    return (mat @ (np.atleast_2d(counts) - np.asarray(info["b_a"])).T).T / G_MS2


def apply_json(doc: dict, counts, lsb_per_g: float, temp_c: float) -> np.ndarray:
    a = calfile.from_dict(doc, "<json export>").accelerometer
    n = len(np.atleast_2d(counts))
    return a.apply(counts, temp_c=np.full(n, temp_c) if a.temperature is not None else None, t_s=np.zeros(n))


APPLY = {"px4": apply_px4, "ardupilot": apply_ardupilot, "imucal": apply_imucal, "json": apply_json}


def export_error(cal, target: str, params: dict) -> dict:
    """Max roll/pitch/angle difference (deg) between the full calibration and the export at the seven poses.

    The full model predicts the counts (at t0 and t0 + 20 C when it has temperature terms, else 25 C);
    both turn them back into specific force. Roll is not scored where the nominal pose is gimbal-locked.
    """
    a = cal.accelerometer
    f0 = f_nominal(np.array([p for _, p in VERIFY_POSES], float))
    temps = [a.temperature.t0_c, a.temperature.t0_c + 20.0] if a.temperature is not None else [25.0]
    n = len(f0)
    worst = {"poses": n, "max_roll_deg": 0.0, "max_pitch_deg": 0.0, "max_angle_deg": 0.0}
    scored = np.abs(np.cos(np.radians(roll_pitch_deg(f0)[1]))) >= GIMBAL_LOCK_COS
    for temp in temps:
        tc = np.full(n, temp) if a.temperature is not None else None
        counts = a.predict_counts(f0, temp_c=tc, t_s=np.zeros(n))
        f_full = a.apply(counts, temp_c=tc, t_s=np.zeros(n))
        f_exp = APPLY[target](params, counts, a.lsb_per_g, temp)
        (r1, p1), (r2, p2) = roll_pitch_deg(f_full), roll_pitch_deg(f_exp)
        cos = np.sum(f_full * f_exp, axis=1) / (np.linalg.norm(f_full, axis=1) * np.linalg.norm(f_exp, axis=1))
        worst["max_roll_deg"] = max(worst["max_roll_deg"], float(np.max(np.abs(_wrap(r2 - r1)[scored]), initial=0.0)))
        worst["max_pitch_deg"] = max(worst["max_pitch_deg"], float(np.max(np.abs(_wrap(p2 - p1)))))
        worst["max_angle_deg"] = max(worst["max_angle_deg"], float(np.max(np.degrees(np.arccos(np.clip(cos, -1, 1))))))
    return worst


def _wrap(d):
    return (np.asarray(d) + 180.0) % 360.0 - 180.0


# ---------------------------------------------------------------------------------------------- files

PX4_INT_PARAMS = {"TC_A_ENABLE"}
AP_INT_PARAMS = {"INS_TCAL1_ENABLE"}


def _hex(address) -> str:
    """An I2C address as every other output writes it (0x68); anything else as it is."""
    return f"0x{address:02X}" if isinstance(address, int) and not isinstance(address, bool) else str(address)


def _header(cal, target: str, dropped: list[str]) -> list[str]:
    s = cal.sensor or {}
    return [f"# rig export --to {target}: {cal.format} of session {cal.session}, created {cal.created}",
            f"# sensor {s.get('model')} address {_hex(s.get('address'))}; accelerometer only, sensor frame "
            "(set the board/sensor rotation on the autopilot)",
            "# not held: " + (", ".join(dropped) if dropped else "nothing"),
            "# conventions: docs/exports.md"]


def px4_text(cal, params: dict, dropped: list[str]) -> str:
    """QGroundControl parameter file: ``vehicle-id component-id name value type`` (9 REAL32, 6 INT32)."""
    lines = _header(cal, "px4", dropped) + [
        "# CAL_ACC0_ID / TC_A0_ID (the autopilot's device id of this accelerometer) are not written: keep yours",
        "#", "# Vehicle-Id\tComponent-Id\tName\tValue\tType"]
    for name, v in params.items():
        if name in PX4_INT_PARAMS:
            lines.append(f"1\t1\t{name}\t{int(v)}\t6")
        else:
            lines.append(f"1\t1\t{name}\t{v:.9g}\t9")
    return "\n".join(lines) + "\n"


def ardupilot_text(cal, params: dict, dropped: list[str]) -> str:
    """Mission Planner parameter file: ``NAME,VALUE`` (also loaded by MAVProxy ``param load``)."""
    lines = _header(cal, "ardupilot", dropped) + ["# IMU 1 (INS_ACC*, INS_TCAL1_*); rename for another IMU"]
    for name, v in params.items():
        lines.append(f"{name},{int(v)}" if name in AP_INT_PARAMS else f"{name},{v:.9g}")
    return "\n".join(lines) + "\n"


def parse_param_file(text: str) -> dict:
    """Read back a PX4 (QGC, tab-separated) or ArduPilot (``NAME,VALUE``) parameter file: {name: float}."""
    out = {}
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split("\t") if "\t" in line else line.replace(",", " ").split()
        name, value = (parts[2], parts[3]) if len(parts) == 5 else (parts[0], parts[1])
        out[name] = float(value)
    return out


def export_calibration(cal, target: str) -> Export:
    """Export ``cal`` (a CalibrationFile) to ``target`` (px4, ardupilot, imucal, json)."""
    if target not in TARGETS:
        raise ValueError(f"unknown export target {target!r}; expected one of {', '.join(TARGETS)}")
    dropped = dropped_terms(cal, target)
    if target == "px4":
        params = px4_params(cal)
        text = px4_text(cal, params, dropped)
        params = parse_param_file(text)  # the error is measured on the numbers as written
    elif target == "ardupilot":
        params = ardupilot_params(cal)
        text = ardupilot_text(cal, params, dropped)
        params = parse_param_file(text)
    elif target == "imucal":
        params = imucal_info(cal)
        text = json.dumps(params, indent=4) + "\n"
    else:
        params = cal.to_dict()
        text = json.dumps(params, indent=2, allow_nan=False) + "\n"
    return Export(target, text, params, dropped, export_error(cal, target, params))
