"""The discrepancy workflow (`rig discover`), tested on simulated sessions in which an effect is hidden.

Each hidden effect is switched on in a rig file's ``sim.effects`` (the workflow is never told
which); the shipped ``tumble26.yaml`` procedure runs on the simulated rig in virtual time, with the
realistic ``dlpf`` noise (DLPF-filtered white noise, flicker and random walk of the bias). The ``rig``
commands run in this process (``rig.cli.main``, the command line's own entry point, without an
interpreter's start-up per command).
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from calib.discovery.effects import LIBRARY
from rig.analysis.discover import discover_session

from conftest import PROCEDURES, RIGS
from cli_run import rig_in_process as _rig

SEED = 5
#: effect -> (value in the rig file, truth of the estimate in the effect's reported unit)
HIDDEN = {
    "bias_tempco_quadratic": (3e-5, [3e-5] * 3),
    "scale_tempco": (2e-4, [2e-4] * 3),
    "scale_nonlinearity": (3e-3, [3e-3] * 3),
    "cross_axis_nonlinearity": ([[0, 3e-3, 0], [0, 0, -2e-3], [2e-3, 0, 0]],
                                [0, 3e-3, 0, 0, 0, -2e-3, 2e-3, 0, 0]),
    "full_misalignment": (0.3, [0.0, 0.0, float(np.tan(np.radians(0.3)))]),
    "table_tilt": ([0.1, -0.05], [0.1, -0.05]),
    "bias_drift": (5e-7, [5e-7] * 3),
    "thermal_hysteresis": (1.5e-3, [1.5e-3] * 3),
}


def _rig_file(tmp: Path, name: str, effects: dict | None) -> Path:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["noise"] = "dlpf"
    if effects:
        doc["sim"]["effects"] = effects
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _run(tmp: Path, name: str, procedure: str, effects: dict | None) -> Path:
    rig = _rig_file(tmp, name, effects)
    out = tmp / name
    code, _, err = _rig("run", PROCEDURES / procedure, "--rig", rig, "--out", out, "--seed", SEED, "--quiet")
    assert code == 0, err
    return next(out.iterdir())


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    """One tumble26 session per hidden effect, a clean one, and a clean six-position one (one after the
    other in this process: the test workers run modules side by side)."""
    tmp = tmp_path_factory.mktemp("discover")
    jobs = {name: ("tumble26.yaml", {name: value}) for name, (value, _) in HIDDEN.items()}
    jobs["clean"] = ("tumble26.yaml", None)
    jobs["six_clean"] = ("six_position.yaml", None)
    return {name: _run(tmp, name, proc, eff) for name, (proc, eff) in jobs.items()}


@pytest.fixture(scope="module")
def discovered():
    """``discover_session`` of a session, computed once per session for the module's tests (they only
    read it)."""
    return cache(discover_session)


def _truth(session: Path) -> dict:
    return yaml.safe_load((session / "sim_truth.yaml").read_text())


@pytest.mark.parametrize("effect", list(HIDDEN))
def test_a_hidden_effect_is_named_estimated_within_3_sigma_and_the_gap_closes(sessions, discovered, effect):
    _, d = discovered(sessions[effect])
    named = [e.name for e in d.effects]
    assert effect in named, f"{effect} hidden, named {named}"
    assert set(named) <= {effect, "bias_tempco"}, f"{effect} hidden, named {named}"
    found = next(e for e in d.effects if e.name == effect)
    est, sig = np.array(found.estimate, float), np.array(found.sigma, float)
    truth = np.array(HIDDEN[effect][1], float)
    assert np.all(np.abs(est - truth) < 3 * sig), (est, truth, sig)
    # the gap closes: the final chi-square is that of the noise (each step's scatter and the bias wander)
    floor = float(np.hypot(d.noise_rms_g, d.wander_rms_g))
    assert d.rms_before_g > 3 * floor
    assert d.gap_closed and d.chi2_per_dof_after < 1.3
    # and the residual RMS falls with each effect added
    rms = [h[1] for h in d.history]
    assert all(b < a for a, b in zip(rms, rms[1:]))


def test_a_clean_session_names_only_the_bias_tempco_the_sensor_really_has(sessions, discovered):
    _, d = discovered(sessions["clean"])
    assert [e.name for e in d.effects] == ["bias_tempco"]
    truth = np.array(_truth(sessions["clean"])["accelerometer"]["bias_tempco_g_per_c"])
    e = d.effects[0]
    assert np.all(np.abs(np.array(e.estimate) - truth) < 3 * np.array(e.sigma))
    # observability decided by the data: every candidate gets its minimum detectable magnitude
    assert set(d.observability) | set(d.unobservable) == set(LIBRARY)
    mdm = d.to_json()["observability"]["bias_drift"]["mdm"]
    assert all(0 < x < 5e-7 for x in mdm), mdm  # the drift hidden above (5e-7 g/s) is detectable
    assert d.gap_closed and d.to_json()["gap_closed"] is True


def test_bias_tempco_estimates_match_the_simulator_in_every_session(sessions, discovered):
    for name in HIDDEN:
        if name in ("scale_tempco", "bias_tempco_quadratic"):
            continue  # these shift the linear term at t0 != the simulator's t_ref
        _, d = discovered(sessions[name])
        e = next(e for e in d.effects if e.name == "bias_tempco")
        truth = np.array(_truth(sessions[name])["accelerometer"]["bias_tempco_g_per_c"])
        assert np.all(np.abs(np.array(e.estimate) - truth) < 4 * np.array(e.sigma)), name


def test_a_six_position_session_reports_what_it_cannot_observe_and_names_nothing(sessions, discovered):
    _, d = discovered(sessions["six_clean"])
    _, tumble = discovered(sessions["clean"])
    assert d.effects == []
    for name in ("thermal_hysteresis", "cross_axis_nonlinearity"):  # no rank beyond the model
        assert name in d.unobservable, (name, d.unobservable)
    assert "zero" in d.unobservable_why["cross_axis_nonlinearity"]
    # at one chamber temperature the temperature terms have columns, but tiny ones: their minimum
    # detectable magnitudes are hundreds of times those of tumble26
    for name in ("bias_tempco", "scale_tempco"):
        six, t26 = (np.array([np.inf if m is None else m for m in x.to_json()["observability"][name]["mdm"]])
                    for x in (d, tumble))
        assert np.all(six > 100 * t26), (name, six, t26)


def test_the_localisation_reports_heating_and_cooling_legs_separately(sessions, discovered):
    _, d = discovered(sessions["thermal_hysteresis"])
    assert set(d.where["by_leg"]) >= {"heating", "cooling"}
    assert d.where["cells"] > 0


def test_the_cli_report_json_plot_and_augmented_calibration(sessions, tmp_path):
    s = sessions["scale_tempco"]
    png, cal_path = tmp_path / "res.png", tmp_path / "cal.yaml"
    code, stdout, stderr = _rig("discover", s, "--json", "--plot", png, "-o", cal_path)
    assert code == 0, stderr
    doc = json.loads(stdout)
    for key in ("rms_before_g", "rms_after_g", "effects", "aliases", "unobservable", "steps"):
        assert key in doc
    assert {"name", "axes", "estimate", "sigma", "unit", "rms_after_g"} <= set(doc["effects"][0])
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    # the augmented calibration carries the effect, validates on load and apply honours it
    cal = calfile.read(cal_path)
    names = [e["name"] for e in cal.accelerometer.effects]
    assert names == ["scale_tempco"] and cal.accelerometer.temperature is not None
    from rig.session import load_session
    sess = load_session(s)
    means = sess.step_means()
    plain = calfile.read(s / "calibration.yaml").accelerometer
    err = {}
    for label, c in (("plain", plain), ("augmented", cal.accelerometer)):
        f = c.apply(means.mean_counts, temp_c=means.temp_c, t_s=means.t_s)
        err[label] = float(np.sqrt(np.mean((f - means.f_nominal_g) ** 2)))
    # the table's own errors move every pose off its nominal direction: the same table and sensor without the hidden
    # effect leave that floor; the augmented calibration takes away most of what the effect adds above it
    clean = load_session(sessions["clean"]).step_means()
    c = calfile.read(sessions["clean"] / "calibration.yaml").accelerometer
    f = c.apply(clean.mean_counts, temp_c=clean.temp_c, t_s=clean.t_s)
    err["clean"] = float(np.sqrt(np.mean((f - clean.f_nominal_g) ** 2)))
    assert err["augmented"] ** 2 - err["clean"] ** 2 < 0.5 * (err["plain"] ** 2 - err["clean"] ** 2), err
    # the text report states the gap
    code, text, _ = _rig("discover", s)
    assert code == 0 and "scale_tempco" in text and "gap:" in text


def test_apply_of_an_augmented_calibration_inverts_its_own_forward_model(sessions, discovered):
    _, d = discovered(sessions["thermal_hysteresis"])
    cal = d.calibration
    rng = np.random.default_rng(1)
    f = rng.normal(size=(50, 3))
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    temp = np.linspace(20, 35, 50)
    t = np.linspace(0, 3000, 50)
    counts = cal.predict_counts(f, temp_c=temp, t_s=t)
    assert np.allclose(cal.apply(counts, temp_c=temp, t_s=t), f, atol=1e-9)


@pytest.mark.parametrize("args, expected", [
    (["discover", "/no/such/session"], "no such session directory"),
    (["discover", "SESSION", "--false-alarm", "2"], "--false-alarm"),
])
def test_bad_inputs_get_one_line_and_exit_2(sessions, args, expected):
    args = [str(sessions["clean"]) if a == "SESSION" else a for a in args]
    code, _, stderr = _rig(*args)
    assert code == 2
    assert expected in stderr and len(stderr.strip().splitlines()) == 1
    assert "Traceback" not in stderr


def test_an_effect_entry_that_does_not_fit_the_library_is_refused_on_load(sessions, tmp_path):
    s = sessions["scale_tempco"]
    out = tmp_path / "cal.yaml"
    code, _, stderr = _rig("discover", s, "-o", out)
    assert code == 0, stderr
    doc = yaml.safe_load(out.read_text())
    doc["accelerometer"]["effects"][0]["estimate"] = [1.0, 2.0]
    out.write_text(yaml.safe_dump(doc))
    with pytest.raises(calfile.CalibrationFileError, match=r"effects\[0\].*estimate"):
        calfile.read(out)
    doc["accelerometer"]["effects"][0]["name"] = "gremlins"
    out.write_text(yaml.safe_dump(doc))
    with pytest.raises(calfile.CalibrationFileError, match="unknown effect"):
        calfile.read(out)
