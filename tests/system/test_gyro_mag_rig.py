"""Gyroscope rate-table and magnetometer calibration on the simulated rig, end to end.

The shipped procedures run in virtual time; the recovered parameters are compared with the
simulator's hidden truth (``sim_truth.yaml``) within the reported sigmas. The ``rig`` commands run in
this process (``rig.cli.main``, the command line's own entry point).
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from calib.numerics.stability import FLICKER_FLOOR, flicker_mean_factor
from calib.gyro import GyroCalibration
from calib.mag import MagCalibration
from drivers.sensors.sim.noise import NoiseConfig
from rig.cli import main

from conftest import PROCEDURES, RIGS

SHORT_GYRO = """format: rig-procedure/1
name: gyro_short
sensor: {model: MPU-9150, sample_rate_hz: 100}
dwell: {seconds: 5}
steps:
  - {pose: "+Z up"}
  - {pose: "-Z up"}
  - {pose: "+X up"}
  - {pose: "-X up"}
  - {pose: "+Y up"}
  - {pose: "-Y up"}
""" + "".join(f"  - {{rate: {{axis: {a}, rate_deg_s: {r}, seconds: 10}}}}\n"
              for a in ("a1", "a2", "a3") for r in (30, -30)) + "solve: {model: triangular, method: pinv}\n"


def _rig(tmp: Path, name: str, sim_extra: dict | None = None, axes_extra: dict | None = None) -> Path:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"].update(sim_extra or {})
    for ax, extra in (axes_extra or {}).items():
        doc["turntable"]["axes"][ax].update(extra)
    p = tmp / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


class Result(NamedTuple):
    """What a ``rig`` command gave: its exit code and what it printed."""
    returncode: int
    stdout: str
    stderr: str


def _cli(*args) -> Result:
    """``rig ARGS`` in this process (the command line's main())."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return Result(code, out.getvalue(), err.getvalue())


def _run(tmp: Path, name: str, procedure: Path, rig: Path, seed: int = 4) -> Result:
    return _cli("run", procedure, "--rig", rig, "--out", tmp / name, "--seed", seed, "--quiet")


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("gyromag")
    short = tmp / "gyro_short.yaml"
    short.write_text(SHORT_GYRO)
    no_gsens = _rig(tmp, "no_gsens", {"gyro_errors": {"g_sensitivity_dps_per_g": 0.0}})
    default = _rig(tmp, "default")
    jobs = {"gyro": (PROCEDURES / "gyro_rates.yaml", no_gsens), "mag8": (PROCEDURES / "mag_eight_position.yaml", default),
            "magtumble": (PROCEDURES / "mag_tumble.yaml", default), "short": (short, default)}
    out = {}
    for k, (p, r) in jobs.items():  # one after the other (the test workers run modules side by side)
        proc = _run(tmp, k, p, r)
        assert proc.returncode == 0, (k, proc.stderr)
        out[k] = next((tmp / k).iterdir())
        out[f"{k}_printed"] = proc.stdout
    out["tmp"] = tmp
    return out


def _truth(session: Path) -> dict:
    return yaml.safe_load((session / "sim_truth.yaml").read_text())


def test_the_rate_test_recovers_all_12_gyro_parameters_within_their_sigmas_and_uncertainty(runs):
    """Biases and scales within 4 sigma; the nonorthogonalities within their expanded uncertainty U (k = 2): they
    are the sensor's axes against the table's, so the sensor's mounting in its fixture and the brackets'
    non-orthogonality (the simulated table's own errors, on by default) are in them, beyond the Type A sigma."""
    s = runs["gyro"]
    cal = calfile.read(s / "calibration.yaml")
    g = GyroCalibration.from_dict(cal.gyroscope)
    truth = _truth(s)["gyroscope"]
    lsb = g.lsb_per_dps
    beyond_sigma = []
    m_true = np.asarray(truth["matrix"]) * lsb
    b_true = np.asarray(truth["bias_dps"]) * lsb
    for j, a in enumerate("xyz"):
        assert abs(g.bias_counts[j] - b_true[j]) < 4 * g.sigma[f"b_{a}"], a
        assert abs(g.matrix_counts_per_dps[j][j] - m_true[j, j]) < 4 * g.sigma[f"k_{a}"], a
        for k, c in enumerate("xyz"):
            if j != k:
                est, name = g.nonorthogonality[f"m_{a}{c}"], f"m_{a}{c}"
                error = abs(est - m_true[j, k] / g.matrix_counts_per_dps[j][j])
                assert error < g.uncertainty[name], (a, c, error, g.uncertainty[name])
                beyond_sigma.append(error > 4 * g.sigma[name])
    assert any(beyond_sigma)  # the table's errors: the Type A sigma alone would not hold them
    # the zero-rate bias of every +/- pair agrees with the least-squares bias
    for pair in g.bias_pairs:
        assert np.all(np.abs(np.asarray(pair.bias_counts) - g.bias_counts) < 4 * np.hypot(pair.sigma_counts, 0.5))
    assert len(g.bias_pairs) == 9
    # calibrated rates of the rate steps match the commanded ones
    from rig.session import load_session, rate_step_means
    rs = rate_step_means(load_session(s))
    w = g.apply(rs.mean_counts)
    assert np.max(np.abs(w - rs.rate_nominal_dps)) < 0.02


def test_with_the_gyros_g_sensitivity_the_bias_and_the_determined_g_column_are_recovered(runs):
    """The default simulated MPU-9150 has g-sensitivity: z spins with z up see 1 g along z; the
    solver adds the g-sensitivity columns the steps determine (here the z column)."""
    s = runs["short"]
    g = GyroCalibration.from_dict(calfile.read(s / "calibration.yaml").gyroscope)
    truth = _truth(s)["gyroscope"]
    lsb = g.lsb_per_dps
    assert "z" in g.g_sensitivity["inputs"]
    gm, gs = g.g_matrix() / lsb, np.asarray(g.g_sensitivity["sigma_counts_per_g"]) / lsb
    g_true = np.asarray(truth["g_sensitivity_dps_per_g"])
    assert np.all(np.abs(gm[:, 2] - g_true[:, 2]) < 4 * gs[:, 2])
    for j, a in enumerate("xyz"):
        assert abs(g.bias_counts[j] / lsb - truth["bias_dps"][j]) < 4 * g.sigma[f"b_{a}"] / lsb, a
    assert g.chi2_per_dof < 3


def test_the_rate_steps_capture_only_the_constant_rate_part(runs):
    from rig.session import load_session
    sess = load_session(runs["gyro"])
    for st in sess.info.to_dict()["steps"]:
        if st["kind"] == "rate":
            s0, s1 = st["stats"]["stage_rate_deg_s"]
            assert s0 == pytest.approx(st["rate_deg_s"], abs=1e-3) and s1 == pytest.approx(st["rate_deg_s"], abs=1e-3)
            assert st["stats"]["n_samples"] == 10000  # 100 s at 100 Hz, nothing from the spin-up


def _mag_between_steps_ut(session_dir: Path) -> float:
    """RMS (uT) of the magnetometer's bias wander of one step's mean about the session's mean in the
    dlpf noise model: the flicker between a step's length d and the session's T,
    ``c^2 (F(d / T_c) - F(T / T_c)) / (2 pi)`` (:func:`calib.accel.inputs.flicker_mean_factor`), plus a
    random walk's spread about its session mean, ``K^2 T / 6``. The positions fit and the field
    magnitude of the calibrated steps see it as step-to-step scatter (the white model had none)."""
    from rig.session import load_session
    cfg = NoiseConfig.for_chip("MPU-9150")
    session = load_session(session_dir)
    t, step = session.samples["t_s"], session.samples["step"]
    dwell_s = float(np.median([np.ptp(t[step == i]) for i in np.unique(step)]))
    span_s, corner_s = float(np.ptp(t)), cfg.flicker_band_s[1]
    coeff = cfg.mag_bias_instability_ut[0] / FLICKER_FLOOR
    flicker = coeff**2 * (flicker_mean_factor(dwell_s / corner_s) - flicker_mean_factor(span_s / corner_s)) / (2 * np.pi)
    return float(np.sqrt(flicker + cfg.mag_random_walk_ut_per_rts[0] ** 2 * span_s / 6))


def test_eight_positions_recover_soft_and_hard_iron_within_their_sigmas(runs):
    s = runs["mag8"]
    m = MagCalibration.from_dict(calfile.read(s / "calibration.yaml").magnetometer)
    truth = _truth(s)["magnetometer"]
    assert m.method == "positions"
    b = np.asarray(m.hard_iron_ut)
    for j, a in enumerate("xyz"):  # the sigma holds the AK8975's bias wander (the solve is GLS with it)
        assert abs(b[j] - truth["hard_iron_ut"][j]) < 4 * m.sigma[f"hard_iron_{a}"], a
        for k, c in enumerate("xyz"):
            assert abs(np.asarray(m.matrix)[j, k] - truth["soft_iron"][j][k]) < 4 * m.sigma[f"a_{a}{c}"], (a, c)
    # 0.1 uT: white measurement noise averaged over a step; the wander adds its step-to-step scatter
    assert m.residual_rms_ut < np.hypot(0.1, 2 * _mag_between_steps_ut(s))


def test_the_ellipsoid_from_a_tumble_recovers_the_hard_iron_and_the_field_magnitude(runs):
    s = runs["magtumble"]
    m = MagCalibration.from_dict(calfile.read(s / "calibration.yaml").magnetometer)
    truth = _truth(s)["magnetometer"]
    assert m.method == "ellipsoid" and m.field_ut == pytest.approx(50.0)
    for j, a in enumerate("xyz"):
        assert abs(m.hard_iron_ut[j] - truth["hard_iron_ut"][j]) < 4 * m.sigma[f"hard_iron_{a}"], a
    from rig.session import load_session, mag_step_means
    ms = mag_step_means(load_session(s))
    h = m.apply(ms.mean_ut)
    between = _mag_between_steps_ut(s)  # each step's wander about the session's, 1-sigma
    assert np.allclose(np.linalg.norm(h, axis=1), 50.0, atol=np.hypot(0.1, 4 * between))
    assert m.fit_quality < np.hypot(0.1, 2 * between)


def test_rate_and_magnetometer_sessions_replay_to_identical_sections(runs, tmp_path):
    for key in ("short", "mag8"):
        s = runs[key]
        proc = _cli("replay", s, "--out", tmp_path / key)
        assert proc.returncode == 0, proc.stderr
        r = next((tmp_path / key).iterdir())
        a, b = calfile.read(s / "calibration.yaml"), calfile.read(r / "calibration.yaml")
        for first, again in ((a.gyroscope, b.gyroscope), (a.magnetometer, b.magnetometer)):
            if first is None:
                assert again is None
                continue
            x, y = first.to_dict(), again.to_dict()  # the same numbers; the replay's budget names its rig a replay's
            if "uncertainty" in x:
                assert "a replay of a recorded session" in y["uncertainty"].pop("rig") and x["uncertainty"].pop("rig")
            assert type(first).from_dict(x) == type(again).from_dict(y)
        assert np.array_equal(a.accelerometer.bias_counts, b.accelerometer.bias_counts)


def test_apply_writes_calibrated_rates_and_fields(runs, tmp_path):
    s = runs["short"]
    out = tmp_path / "applied.csv"
    proc = _cli("apply", s / "calibration.yaml", s, "-o", out)
    assert proc.returncode == 0, proc.stderr
    header = out.read_text().splitlines()[0].split(",")
    assert header[-3:] == ["wx_dps", "wy_dps", "wz_dps"]


def _bad(tmp: Path, text: str, rig: Path | None = None) -> Result:
    p = tmp / "bad.yaml"
    p.write_text(text)
    rig = rig or _rig(tmp, "plain")
    return _run(tmp, "bad", p, rig)


@pytest.mark.parametrize("text, expected", [
    (SHORT_GYRO.replace("rate_deg_s: 30,", "rate_deg_s: 63,", 1), "limit of +-48 deg/s"),
    (SHORT_GYRO.replace("axis: a1", "axis: a4", 1), "expected a1, a2 or a3"),
    ("format: rig-procedure/1\nname: m\nsensor: {model: ADXL345, sample_rate_hz: 100, magnetometer: true}\n"
     "steps:\n  - {pose: \"+Z up\"}\n", "has no magnetometer"),
])
def test_bad_rate_and_magnetometer_procedures_get_one_line(tmp_path, text, expected):
    proc = _bad(tmp_path, text)
    assert proc.returncode == 2 and expected in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_spinning_an_axis_without_a_slip_ring_is_refused_before_anything_moves(tmp_path):
    rig = _rig(tmp_path, "noslip", axes_extra={"a1": {"slip_ring": False, "cable_wrap_deg": 200}})
    proc = _bad(tmp_path, SHORT_GYRO, rig)
    assert proc.returncode == 2 and "cable wrap" in proc.stderr and "slip_ring" in proc.stderr, proc.stderr
    session = next((tmp_path / "bad").iterdir(), None) if (tmp_path / "bad").exists() else None
    if session is not None:
        assert '"move"' not in (session / "events.jsonl").read_text()


def test_rate_steps_that_never_spin_about_z_cannot_determine_the_gyro_model(tmp_path):
    text = SHORT_GYRO.replace("  - {rate: {axis: a1, rate_deg_s: 30, seconds: 10}}\n", "").replace(
        "  - {rate: {axis: a1, rate_deg_s: -30, seconds: 10}}\n", "")
    proc = _bad(tmp_path, text)
    assert proc.returncode == 2 and "never spin about z" in proc.stderr, proc.stderr


def test_the_gyro_bias_is_printed_in_the_unit_the_history_and_the_report_show(runs):
    """Issue 33 item 4: rig run printed the gyro bias in deg/s, the history and the report in counts."""
    from calib.file.parameters import sensor_parameters

    cal = calfile.read(runs["gyro"] / "calibration.yaml")
    g = GyroCalibration.from_dict(cal.gyroscope)
    lines = runs["gyro_printed"].splitlines()
    (head,) = [i for i, x in enumerate(lines) if x.startswith("  gyroscope: ")]
    line = lines[head + 1]  # the gyroscope's bias line
    printed = dict(re.findall(r"([xyz]) ([+-]\d+\.\d+)\+-", line))
    assert line.endswith(" counts")
    assert [float(printed[a]) for a in "xyz"] == pytest.approx(g.bias_counts, abs=0.006)
    # every gyro parameter with its sigma (the walkthrough: the scale without, the nonorthogonalities not at all)
    text = runs["gyro_printed"]
    for a in "xyz":
        assert re.search(rf"    scale .*{a} {g.scale_counts_per_dps[' xyz'.index(a) - 1]:.3f}\+-\d", text), text
    for n in ("xy", "xz", "yx", "yz", "zx", "zy"):
        assert re.search(rf"    nonorthogonality .*{n} [+-]\d\.\d{{6}}\+-\d", text), text
    stored = {name: (value, unit) for name, value, _, unit in sensor_parameters(cal)}  # what the history keeps
    assert [stored[f"gyro.bias_{a}"] for a in "xyz"] == [(pytest.approx(b), "counts") for b in g.bias_counts]
