"""One unit per quantity across run, solve, discover, evaluate, history and report (issue 33 item 4): a quantity a
person reads in two places is printed in the same unit, under the same name, with its sigma. The ``rig`` commands
run in this process (``rig.cli.main``) on sessions recorded by the simulated rig in virtual time."""

from __future__ import annotations

import contextlib
import json
import io
import re
import time
from pathlib import Path

import pytest

from rig.cli import main
from rig.session import load_session

from conftest import PROCEDURES
from html_page import Page

#: a short gyroscope rate test: six static poses, then +-30 deg/s about each table axis (10 s each)
SHORT_GYRO = """format: rig-procedure/1
name: gyro_short
sensor: {model: MPU-9150, sample_rate_hz: 100}
dwell: {seconds: 5}
steps:
""" + "".join(f'  - {{pose: "{p}"}}\n' for p in ("+Z up", "-Z up", "+X up", "-X up", "+Y up", "-Y up")) + "".join(
    f"  - {{rate: {{axis: {a}, rate_deg_s: {r}, seconds: 10}}}}\n" for a in ("a1", "a2", "a3") for r in (30, -30)) + (
    "solve: {model: triangular, method: pinv}\n")


def rig(*args) -> tuple[int, str]:
    """``rig ARGS`` in this process: (exit code, what it printed on stdout)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main([str(a) for a in args])
    return code, out.getvalue()


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> dict:
    """A gyroscope session (the short rate test) and a six-position session, seed 3, in a history of their own:
    {"gyro": session, "gyro_printed": what rig run printed, "six": session, "root": folder}."""
    root = tmp_path_factory.mktemp("units")
    procedure = root / "gyro_short.yaml"
    procedure.write_text(SHORT_GYRO)
    out = {"root": root}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(root / "h.sqlite"))
        for name, proc in (("gyro", procedure), ("six", PROCEDURES / "six_position.yaml")):
            if name == "six":  # calibrations are stamped to the second: the six-position one is the newer
                time.sleep(1.0 - time.time() % 1.0 + 0.01)
            code, printed = rig("run", proc, "--seed", 3, "--time-scale", 0, "--out", root / name, "--quiet")
            assert code == 0
            out[name], out[f"{name}_printed"] = next((root / name).iterdir()), printed
    return out


@pytest.fixture
def history(tmp_path, monkeypatch) -> Path:
    path = tmp_path / "h.sqlite"
    monkeypatch.setenv("RIG_HISTORY", str(path))
    return path


def _printed_gyro_terms(printed: str, label: str) -> tuple[str, dict[str, tuple[float, float]]]:
    """The unit and the ``name value+-sigma`` terms of the gyroscope line that starts with ``label``."""
    (line,) = [x for x in printed.splitlines() if x.startswith(f"    {label} (")]
    unit, terms = re.fullmatch(rf"    {label} \(([^)]*)\): (.*)", line).groups()
    found = re.findall(r"(\w\w) ([+-][\d.]+)\+-([\d.]+)", terms)
    return unit, {n: (float(v), float(s)) for n, v, s in found}


def test_the_report_shows_the_gyro_nonorthogonalities_and_g_sensitivity_as_run_and_solve_print_them(lab, history):
    """The report's gyroscope rows had the nonorthogonalities with no unit ("-") and no g-sensitivity at all,
    though rig run and rig solve print it: every one is now a row with its sigma, in the unit run and solve state."""
    code, solved = rig("solve", lab["gyro"], "-o", lab["root"] / "solved.yaml")
    assert code == 0
    assert rig("report", lab["gyro"], "-o", lab["root"] / "report.html")[0] == 0
    rows = {r[0]: r for r in Page((lab["root"] / "report.html").read_text()).rows["parameter-table"] if len(r) >= 4}
    for printed in (lab["gyro_printed"], solved):
        for label, prefix in (("nonorthogonality", "gyro.m_"), ("g-sensitivity", "gyro.g_sensitivity_")):
            unit, terms = _printed_gyro_terms(printed, label)
            unit = unit.split(";")[0]  # the g-sensitivity's unit, then how its terms are named
            assert terms, label
            if label == "nonorthogonality":
                assert unit == "ratio M_ij/M_ii" and sorted(terms) == ["xy", "xz", "yx", "yz", "zx", "zy"]
            else:
                assert unit == "counts/g" and sorted(terms) == ["xz", "yz", "zz"]  # the column the spins about z determine
            for n, (value, sigma) in terms.items():
                _, shown, shown_sigma, shown_unit = rows[f"{prefix}{n}"][:4]
                assert shown_unit == unit, n
                assert float(shown) == pytest.approx(value, abs=0.1 * sigma), n  # both rounded to the sigma
                assert float(shown_sigma) == pytest.approx(sigma, rel=0.05), n


@pytest.fixture(scope="module")
def ramp(tmp_path_factory) -> dict:
    """``rig run procedures/thermal_ramp.yaml`` (seed 2, virtual time): {"session", "printed"}."""
    root = tmp_path_factory.mktemp("ramp")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(root / "h.sqlite"))
        code, printed = rig("run", PROCEDURES / "thermal_ramp.yaml", "--seed", 2, "--time-scale", 0, "--out",
                            root / "s", "--quiet")
    assert code == 0
    return {"session": next((root / "s").iterdir()), "printed": printed}


def test_discover_states_the_bias_tempco_in_counts_per_c_as_run_does_and_its_json_keeps_g_per_c(ramp, history):
    """rig discover printed the bias tempco in g/C (x -9.481e-05 +- 4.57e-06) where rig run, solve, history and
    the report state counts/C (x -0.7783 +- 0.038): the same quantity in two units, 8192 apart."""
    session = ramp["session"]
    (run_line,) = [x for x in ramp["printed"].splitlines() if x.startswith("  bias tempco (counts/C): ")]
    by_run = {a: (float(v), float(s)) for a, v, s in re.findall(r"([xyz]) ([+-][\d.]+) \+- ([\d.]+)", run_line)}
    code, details = rig("discover", session, "--details")
    assert code == 0
    (line,) = [x for x in details.splitlines() if x.startswith("  + bias_tempco ")]
    assert "[counts/C]" in line and "g/C" not in line
    found = {a: (float(v), float(s)) for a, v, s in re.findall(r"([xyz]) ([+-]?[\d.]+) \+- ([\d.]+)", line)}
    for a in "xyz":  # two fits of one session (run's thermal model, discover's search): the same tempco, same unit
        assert found[a][0] == pytest.approx(by_run[a][0], abs=by_run[a][1])
        # the sigmas differ by how each judges the simulated table's own errors (run: the solve's misfit scaling;
        # discover: the rig's covariance): a factor of a few, nothing like the 8192 of a unit mixed up
        assert 0.2 < found[a][1] / by_run[a][1] < 5
    for name, unit in (("bias_tempco", "counts/C"), ("bias_tempco_quadratic", "counts/C^2")):  # detectable sizes
        (mdm,) = [x for x in details.splitlines() if x.startswith(f"  {name} ") and "variance inflation" in x]
        assert f"[{unit}]" in mdm
    code, text = rig("discover", session, "--json")  # the documented contract keeps the library's unit
    doc = json.loads(text)
    (effect,) = [e for e in doc["effects"] if e["name"] == "bias_tempco"]
    assert effect["unit"] == "g/C"
    lsb_per_g = load_session(session).lsb_per_g  # the sensor's nominal counts per g
    assert [v * lsb_per_g for v in effect["estimate"]] == pytest.approx([found[a][0] for a in "xyz"], rel=1e-3)
    (session / "discover.json").write_text(text)  # the report's discrepancy table, beside its parameters table
    assert rig("report", session, "-o", session.parent / "report.html")[0] == 0
    rows = Page((session.parent / "report.html").read_text()).rows["discover-effects"]
    (row,) = [r for r in rows if r[0] == "bias_tempco"]
    assert row[2] == "counts/C"


def test_evaluate_prints_the_magnitude_residual_in_ug_as_every_residual_and_its_json_keeps_g(lab, history):
    """rig evaluate printed |f| - 1 in g (+2.02e-05) with the poses and in mg without them, where rig run, solve,
    discover and the report print residuals in ug: both tables now state ug, the JSON keeps its g."""
    six = lab["six"]
    code, text = rig("evaluate", six / "calibration.yaml", six, "--json")
    assert code == 0
    by_step = {s["name"]: s["norm_error_g"] * 1e6 for s in json.loads(text)["steps"]}
    code, table = rig("evaluate", six / "calibration.yaml", six)
    assert code == 0
    head, _, *rows, last = table.splitlines()
    assert head.rstrip().endswith("|f|-1, ug") and " g" not in head.split("deg")[-1]
    for row in rows:
        name, value = re.match(r"(\S+ up) .* ([+-]\d+\.\d)$", row).groups()
        assert float(value) == pytest.approx(by_step[name], abs=0.06), row
    assert last.endswith(f"||f| - 1| {max(map(abs, by_step.values())):.1f} ug")
    code, text = rig("evaluate", six / "calibration.yaml", six, "--method", "magnitude")
    assert code == 0
    head, *rows, last = text.splitlines()
    assert head.split()[1:] == ["|f|", "-", "1", "(ug)", "sigma", "(ug)"]
    for row in rows:
        name, value, sigma = re.fullmatch(r"(\S+ up) +([+-]\d+\.\d) +(\d+\.\d)", row).groups()
        assert float(value) == pytest.approx(by_step[name], abs=0.06) and 10 < float(sigma) < 1000  # ug, not mg
    assert re.fullmatch(r"6 static steps, \|f\| - 1 rms \d+\.\d ug .*", last)


def test_solve_with_the_full_model_prints_every_cross_axis_term_with_its_sigma(lab, history):
    """rig solve --model full printed only the cross-axis terms' expanded uncertainty U, not the terms: every
    estimated parameter is now printed with its sigma, in counts/g as the file, the history and the report."""
    from calib.file import calibration as calfile

    out = lab["root"] / "full.yaml"
    code, printed = rig("solve", lab["six"], "--model", "full", "-o", out)
    assert code == 0
    a = calfile.read(out).accelerometer
    (line,) = [x for x in printed.splitlines() if x.startswith("  cross-axis (counts/g): ")]
    terms = {n: (float(v), float(s)) for n, v, s in re.findall(r"(\w\w) ([+-][\d.]+) \+- ([\d.]+)", line)}
    assert sorted(terms) == ["xy", "xz", "yx", "yz", "zx", "zy"]
    for n, (value, sigma) in terms.items():
        i, j = "xyz".index(n[0]), "xyz".index(n[1])
        assert value == pytest.approx(a.matrix_counts_per_g[i][j], abs=0.006)
        assert sigma == pytest.approx(a.sigma["matrix_counts_per_g"][i][j], abs=0.006)
    (u_line,) = [x for x in printed.splitlines() if x.startswith("    cross-axis U: ")]
    assert u_line.split(" counts/g")[0].split()[2::2] == list(terms)  # the same terms, the same order, as U


def test_history_record_names_a_calibration_by_the_number_the_table_gives_it(lab, history):
    """rig history --record printed the database's row id (`recorded: calibration 3 of sensor K`) while the
    sensor's table numbers its calibrations #1, #2 oldest first: a user looked for a #3 that is not there."""
    assert rig("history", "--record", lab["six"], "--sensor-id", "SN-OTHER")[0] == 0  # another sensor's row first
    said = {}
    for name in ("six", "gyro"):  # the newer calibration recorded first: the older one comes before it in the table
        code, out = rig("history", "--record", lab[name])
        assert code == 0
        (said[lab[name].name], key), = re.findall(r"^recorded: calibration (#\d+) of sensor (\S+) in ", out, re.M)
    code, table = rig("history", key)
    assert code == 0
    numbered = dict((sid, n) for n, sid in re.findall(r"^  (#\d+) .* session (\S+)", table, re.M))
    assert numbered == {lab["gyro"].name: "#1", lab["six"].name: "#2"}
    assert said[lab["gyro"].name] == numbered[lab["gyro"].name]  # as the table says when it was recorded
    code, out = rig("history", "--record", lab["six"])  # recorded again: named by its number in today's table
    assert out.startswith(f"already recorded: calibration {numbered[lab['six'].name]} of sensor {key} ")
