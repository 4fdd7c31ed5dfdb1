"""``CalibrationFile.apply``: the one way to apply a calibration file (calib.file.apply).

Round trip of each section (the forward model's counts give the physical quantity back), the effects
that apply at apply time (thermal bias model, a time effect, the gyroscope's g-sensitivity), the result's
units and type tag, and each refusal as one line naming the file and the recording.
"""

from __future__ import annotations

import numpy as np
import pytest

import calib
from calib.errors import CalibError
from calib.file import calibration as calfile
from calib.file.apply import G_MS2, CalibratedRecording, Recording, RecordingMismatch
from calib.gyro import GyroCalibration, param_names
from calib.mag import MagCalibration, sigma_names
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

LSB_G, LSB_DPS, LSB_UT = 8192.0, 131.0, 3.3
TRUTH = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
              np.array([3.0, -2.0, 4.0]), 27.6)
G_MATRIX = np.array([[0.0, 0.0, -13.7], [0.0, 0.0, -9.7], [0.0, 0.0, 6.3]])  # counts per g, input z determined
GYRO_M = np.array([[131.5, 0.4, -0.3], [0.2, 130.2, 0.5], [-0.6, 0.1, 132.0]])
GYRO_B = np.array([25.0, -40.0, 12.0])
MAG_A = np.array([[1.05, 0.02, -0.01], [0.0, 0.97, 0.03], [0.0, 0.0, 1.02]])
MAG_B = np.array([12.0, -30.0, 45.0])
N = 40


def _accel(thermal: bool = True, effects: list | None = None):
    f = np.repeat(six_faces(), 3, axis=0) if thermal else six_faces()
    temps = np.tile([25.0, 30.0, 35.0], 6) if thermal else None
    acc = calib.solve(make_steps(TRUTH, f, temp_c=temps, rng=np.random.default_rng(1)),
                      thermal=1 if thermal else "off")
    if effects:
        acc = calib.AccelCalibration.from_dict(acc.to_dict() | {"effects": effects})
    return acc


def _gyro(g_sensitivity: bool = True) -> GyroCalibration:
    gs = {"inputs": ["z"], "matrix_counts_per_g": G_MATRIX, "sigma_counts_per_g": np.zeros((3, 3))}
    return GyroCalibration(
        lsb_per_dps=LSB_DPS, matrix_counts_per_dps=GYRO_M, bias_counts=GYRO_B, scale_counts_per_dps=np.diag(GYRO_M),
        nonorthogonality={f"m_{a}{b}": GYRO_M[i, j] / GYRO_M[i, i] for i, a in enumerate("xyz")
                          for j, b in enumerate("xyz") if i != j},
        sigma={n: 0.1 for n in param_names()}, g_sensitivity=gs if g_sensitivity else None)


def _mag() -> MagCalibration:
    return MagCalibration(method="positions", matrix=MAG_A, hard_iron_ut=MAG_B, sigma={n: 0.1 for n in sigma_names()},
                          residual_rms_ut=0.1, chi2_per_dof=1.0, field_ut=None, n_steps=8)


def _file(accel=None, gyro=None, mag=None, model="MPU-9150") -> calib.CalibrationFile:
    return calib.CalibrationFile(created="2026-11-23T00:00:00+00:00", software={"name": "rig", "version": "0.1.0"},
                                 session="s1", sensor={"model": model, "address": 0x68, "serial": None},
                                 accelerometer=accel if accel is not None else _accel(), gyroscope=gyro,
                                 magnetometer=mag)


def _truth_data(n: int = N, seed: int = 3):
    """Specific force (unit vectors, g), rates (deg/s), fields (uT), temperatures (C) and times (s)."""
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(n, 3))
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    return f, rng.uniform(-60, 60, (n, 3)), rng.uniform(-50, 50, (n, 3)), np.linspace(22.0, 38.0, n), \
        np.linspace(0.0, 200.0, n)


def _recording(cal, *, n: int = N, **kw) -> tuple[Recording, tuple]:
    """The raw data a sensor with exactly ``cal``'s parameters gives, as a Recording (``kw`` overrides)."""
    f, w, h, temp, t = _truth_data(n)
    accel = cal.accelerometer.predict_counts(f, temp_c=temp, t_s=t)
    args = dict(sensor_model="MPU-9150", label="recording R", t_s=t, temp_c=temp, accel=accel, lsb_per_g=LSB_G,
                accel_range_g=4.0)
    if cal.gyroscope is not None:
        args.update(gyro=cal.gyroscope.predict_counts(w) + f @ cal.gyroscope.g_matrix().T, lsb_per_dps=LSB_DPS,
                    gyro_range_dps=250.0)
    if cal.magnetometer is not None:
        args.update(mag=cal.magnetometer.predict_ut(h) * LSB_UT, mag_lsb_per_ut=LSB_UT)
    args.update(kw)
    return Recording(**args), (f, w, h)


# ---------------------------------------------------------------------------------------------- round trips

def test_every_section_round_trips_through_the_file(tmp_path):
    cal = calfile.read(calfile.write(tmp_path / "c.yaml", _file(gyro=_gyro(), mag=_mag())))
    rec, (f, w, h) = _recording(cal)
    out = cal.apply(rec)
    assert isinstance(out, CalibratedRecording) and out.TYPE == "calibrated-recording" and out.FRAME == "sensor"
    assert out.applied == ("accelerometer", "gyroscope", "magnetometer")
    np.testing.assert_allclose(out.f_g, f, atol=1e-9)
    np.testing.assert_allclose(out.f_ms2, f * G_MS2, atol=1e-8)
    np.testing.assert_allclose(out.w_dps, w, atol=1e-9)  # the g-sensitivity removed with the calibrated f
    np.testing.assert_allclose(out.h_ut, h, atol=1e-9)
    assert out.units() == {"t_s": "s", "temp_c": "C", "f_g": "g", "f_ms2": "m/s^2", "w_dps": "deg/s", "h_ut": "uT"}
    np.testing.assert_array_equal(out.temp_c, rec.temp_c)


def test_the_entry_point_gives_what_each_section_gives():
    cal = _file(gyro=_gyro(), mag=_mag())
    rec, _ = _recording(cal)
    out = cal.apply(rec)
    f = cal.accelerometer.apply(rec.accel, temp_c=rec.temp_c, t_s=rec.t_s)
    np.testing.assert_array_equal(out.f_g, f)
    np.testing.assert_array_equal(out.w_dps, cal.gyroscope.apply(rec.gyro, f_g=f))
    np.testing.assert_array_equal(out.h_ut, cal.magnetometer.apply(rec.mag / LSB_UT))


def test_the_thermal_bias_model_uses_each_samples_temperature():
    cal = _file()
    rec, (f, _, _) = _recording(cal)
    np.testing.assert_allclose(cal.apply(rec).f_g, f, atol=1e-9)
    # the same counts taken as if at t0 miss the bias change (3 counts/C over up to 10 C: mg)
    at_t0 = cal.apply(Recording(**(vars(rec) | {"temp_c": np.full(N, cal.accelerometer.temperature.t0_c)})))
    assert np.max(np.abs(at_t0.f_g - f)) > 1e-3


def test_time_effects_apply_and_need_time_stamps():
    drift = {"name": "bias_drift", "unit": "g/s", "estimate": [1e-5, -2e-5, 0.0], "sigma": [0, 0, 0], "t_ref_s": 0.0}
    cal = _file(_accel(thermal=False, effects=[drift]))
    rec, (f, _, _) = _recording(cal)
    np.testing.assert_allclose(cal.apply(rec).f_g, f, atol=1e-9)
    _refused(cal, rec, "no time stamps", t_s=None)


def test_magnetometer_data_in_ut_are_taken_as_they_are():
    cal = _file(mag=_mag())
    rec, (_, _, h) = _recording(cal)
    out = cal.apply(Recording(**(vars(rec) | {"mag": rec.mag / LSB_UT, "mag_unit": "uT", "mag_lsb_per_ut": None})))
    np.testing.assert_allclose(out.h_ut, h, atol=1e-9)


def test_by_default_every_section_the_recording_has_data_for():
    cal = _file(gyro=_gyro(), mag=_mag())
    rec, _ = _recording(cal)
    only_accel = Recording(**(vars(rec) | {"gyro": None, "mag": None}))
    assert cal.apply(only_accel).applied == ("accelerometer",)
    assert cal.apply(only_accel).units() == {"t_s": "s", "temp_c": "C", "f_g": "g", "f_ms2": "m/s^2"}
    # data the file has no section for are left out (rig apply writes the columns both have)
    rec2, _ = _recording(_file(gyro=_gyro(), mag=_mag()))
    assert _file().apply(rec2).applied == ("accelerometer",)
    assert cal.apply(rec, sensors=["magnetometer", "accelerometer"]).applied == ("accelerometer", "magnetometer")
    assert cal.apply(rec, sensors="magnetometer").h_ut is not None


# ---------------------------------------------------------------------------------------------- refusals

def _refused(cal, rec, *words, sensors=None, **changes) -> str:
    if changes:
        rec = Recording(**(vars(rec) | changes))
    with pytest.raises(RecordingMismatch) as e:
        cal.apply(rec, sensors=sensors, source="cal.yaml")
    msg = str(e.value)
    assert isinstance(e.value, CalibError)
    assert "\n" not in msg and msg.startswith("cal.yaml: ") and "recording R" in msg, msg
    for w in words:
        assert w in msg, (w, msg)
    return msg


def test_another_sensor_model_is_refused():
    cal = _file()
    rec, _ = _recording(cal)
    msg = _refused(cal, rec, "MPU-9150", "ADXL345", "another sensor model", sensor_model="ADXL345")
    assert msg == ("cal.yaml: calibrates the MPU-9150; recording R is a recording of the ADXL345: another sensor "
                   "model (solve a calibration of that sensor)")
    _refused(cal, rec, "does not say which sensor", sensor_model=None)
    assert cal.apply(Recording(**(vars(rec) | {"sensor_model": "mpu9150"}))).f_g is not None  # spelling only


def test_another_accelerometer_range_is_refused():
    cal = _file()
    rec, _ = _recording(cal)
    msg = _refused(cal, rec, "8192 counts/g", "16384 counts/g", "+-2 g range", "another full-scale range",
                   lsb_per_g=16384.0, accel_range_g=2.0)
    assert msg == ("cal.yaml: calibrates the accelerometer at 8192 counts/g; recording R recorded it at 16384 "
                   "counts/g, its +-2 g range: another full-scale range (calibrate at that range)")
    _refused(cal, rec, "does not state", "lsb_per_g", lsb_per_g=None)


def test_another_gyroscope_range_is_refused():
    cal = _file(gyro=_gyro())
    rec, _ = _recording(cal)
    _refused(cal, rec, "131 counts/(deg/s)", "65.5 counts/(deg/s)", "+-500 deg/s range", "another full-scale range",
             lsb_per_dps=65.5, gyro_range_dps=500.0)
    _refused(cal, rec, "does not state", "lsb_per_dps", lsb_per_dps=None)


@pytest.mark.parametrize("changes, words", [
    ({"accel_unit": "m/s^2"}, ("accelerometer section takes raw counts", "in m/s^2", "another unit")),
    ({"accel_unit": "g"}, ("accelerometer section takes raw counts", "in g", "another unit")),
    ({"gyro_unit": "rad/s"}, ("gyroscope section takes raw counts", "in rad/s", "another unit")),
    ({"mag_unit": "gauss"}, ("magnetometer section takes raw counts or uT", "in gauss", "another unit")),
    ({"mag_lsb_per_ut": None}, ("magnetometer", "mag_lsb_per_ut")),
])
def test_another_unit_is_refused(changes, words):
    cal = _file(gyro=_gyro(), mag=_mag())
    rec, _ = _recording(cal)
    _refused(cal, rec, *words, **changes)


def test_a_file_without_a_section_for_the_data_is_refused():
    rec, _ = _recording(_file(gyro=_gyro()))
    gyro_only = Recording(**(vars(rec) | {"accel": None, "lsb_per_g": None}))
    msg = _refused(_file(), gyro_only, "holds the accelerometer section", "gyroscope data only",
                   "no section of the file for its data")
    assert msg == ("cal.yaml: holds the accelerometer section; recording R has gyroscope data only: no section of "
                   "the file for its data")
    _refused(_file(), rec, "has no gyroscope section", "no section of the file", sensors=["gyroscope"])
    _refused(_file(gyro=_gyro(), mag=_mag()), rec, "magnetometer section was asked for", "no magnetometer data",
             sensors=("magnetometer",))


def test_a_thermal_model_without_temperatures_is_refused():
    cal = _file()
    rec, _ = _recording(cal)
    msg = _refused(cal, rec, "thermal bias model", "t0 ", "no temperature", temp_c=None)
    assert "refusing to apply the bias at t0" in msg
    _refused(cal, rec, "no temperature", temp_c=np.full(N, np.nan))
    # a calibration without thermal terms applies without a temperature
    cold = _file(_accel(thermal=False))
    assert cold.apply(_recording(cold, temp_c=None)[0]).temp_c is None


def test_the_g_sensitivity_needs_the_accelerometer():
    cal = _file(gyro=_gyro())
    rec, _ = _recording(cal)
    _refused(cal, rec, "g-sensitivity", "apply the accelerometer section too", sensors=["gyroscope"])
    plain = _file(gyro=_gyro(g_sensitivity=False))
    rec2, (_, w, _) = _recording(plain)
    np.testing.assert_allclose(plain.apply(rec2, sensors=["gyroscope"]).w_dps, w, atol=1e-9)


def test_a_refusal_without_a_path_names_the_session_solved():
    cal = _file()
    rec, _ = _recording(cal, sensor_model="ADXL345")
    with pytest.raises(RecordingMismatch, match=r"^calibration \(session s1\): calibrates the MPU-9150; "):
        cal.apply(rec)


def test_a_section_refusal_says_which_file_and_recording():
    cal = _file()
    temps = np.linspace(20, 30, N)
    temps[3] = np.nan
    rec, _ = _recording(cal, temp_c=temps)
    with pytest.raises(CalibError) as e:
        cal.apply(rec, source="cal.yaml")
    assert str(e.value).startswith("cal.yaml, applied to recording R: ") and "NaN" in str(e.value)


@pytest.mark.parametrize("kw, words", [
    ({"accel": np.zeros((5, 2))}, "Recording.accel: expected an array of shape (N, 3)"),
    ({"accel": np.zeros((5, 3)), "gyro": np.zeros((4, 3))}, "Recording.gyro: expected an array of shape (5, 3)"),
    ({"accel": np.zeros((5, 3)), "temp_c": np.zeros(4)}, "Recording.temp_c: expected 5 values"),
    ({"accel": np.zeros((5, 3)), "lsb_per_g": -1.0}, "Recording.lsb_per_g: expected a finite number > 0"),
    ({}, "needs the data of at least one sensor"),
])
def test_a_malformed_recording_is_one_line(kw, words):
    with pytest.raises(CalibError) as e:
        Recording(sensor_model="MPU-9150", **kw)
    assert words in str(e.value) and "\n" not in str(e.value)
