"""The uncertainty budget in the product (issue 29 item 5): ``rig run`` and ``rig solve`` write
``accelerometer.uncertainty`` for the pose methods and print U with k; ``rig report`` shows U and the budget; a
session whose rig file is not known gets the turntable's datasheet classes and says so; bad inputs keep their
one-line errors."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yaml

from conftest import DATASETS, NO_DATASETS, PROCEDURES, RIGS
from cli_run import rig_in_process as rig

QUANTITIES = ("bias_counts", "scale_counts_per_g")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A six-position run on a copy of the simulated rig file (virtual time): its session, printout and file."""
    tmp = tmp_path_factory.mktemp("budget_wiring")
    rig_file = tmp / "sim.yaml"
    shutil.copy(RIGS / "sim.yaml", rig_file)
    code, out, err = rig("run", PROCEDURES / "six_position.yaml", "--rig", rig_file, "--time-scale", "0",
                         "--seed", "5", "--out", tmp / "s")
    assert code == 0, err
    (session,) = (tmp / "s").iterdir()
    return {"session": session, "out": out, "rig_file": rig_file, "tmp": tmp}


def _section(path):
    return yaml.safe_load(path.read_text())["accelerometer"]


def test_a_simulated_run_writes_the_budget_in_its_calibration_file(run):
    acc = _section(run["session"] / "calibration.yaml")
    u = acc["uncertainty"]
    assert u["k"] == 2.0
    assert [c["name"] for c in u["budget"]][0] == "noise and wander"
    assert "datasheet classes, no characterisation" in u["rig"]  # the simulated table has its own errors (default)
    assert {"rig axes (non-orthogonality)", "rig frame (mounting, stage zeros)"} <= {c["name"] for c in u["budget"]}
    (type_a,) = [c for c in u["budget"] if c["type"] == "A"]
    for key in QUANTITIES:  # U covers at least the Type A term it contains, k times; that is sigma at most
        assert np.all(np.asarray(u[key]) >= 2 * np.asarray(type_a[key]) * (1 - 1e-9))
        assert np.all(np.asarray(type_a[key]) <= np.asarray(acc["sigma"][key]) * (1 + 1e-9))


def test_the_contributions_add_up_to_the_combined_uncertainty(run):
    u = _section(run["session"] / "calibration.yaml")["uncertainty"]
    for key in QUANTITIES:
        rss = np.sqrt(sum(np.asarray(c[key], float) ** 2 for c in u["budget"]))
        assert np.allclose(rss, u["combined_standard"][key], rtol=1e-9)
        assert np.allclose(np.asarray(u[key]), u["k"] * np.asarray(u["combined_standard"][key]), rtol=1e-9)
    for n, v in u["misalignment"].items():
        rss = np.sqrt(sum(c["misalignment"][n] ** 2 for c in u["budget"]))
        assert v == pytest.approx(u["k"] * rss, rel=1e-9)


def test_run_prints_the_expanded_uncertainty_with_k(run):
    out = run["out"]
    assert "expanded uncertainty U = k u_c, k = 2" in out
    assert "bias U: x " in out and "scale U: x " in out and "misalignment U: yz " in out and " mrad" in out
    assert "largest u: rig " in out and "rig terms: rig file sim.yaml" in out  # the table's own errors lead


def test_solve_writes_and_prints_the_budget_and_keeps_sigma(run):
    target = run["tmp"] / "resolved.yaml"
    code, out, err = rig("solve", run["session"], "-o", target)
    assert code == 0, err
    assert "expanded uncertainty U = k u_c, k = 2" in out and "misalignment U:" in out
    first, again = _section(run["session"] / "calibration.yaml"), _section(target)
    assert again["uncertainty"]["k"] == 2.0 and again["sigma"] == first["sigma"]
    assert again["uncertainty"]["bias_counts"] == pytest.approx(first["uncertainty"]["bias_counts"], rel=1e-9)


def test_a_method_other_than_pinv_or_combinations_has_no_budget(run):
    target = run["tmp"] / "flip.yaml"
    code, out, err = rig("solve", run["session"], "--method", "flip", "-o", target)
    assert code == 0, err
    assert "uncertainty" not in _section(target) and "expanded uncertainty" not in out


def test_the_report_shows_u_with_k_and_the_budget_table(run):
    page = run["tmp"] / "report.html"
    code, _, err = rig("report", run["session"], "-o", page)
    assert code == 0, err
    html = page.read_text()
    assert 'id="uncertainty-table"' in html and "U (k = 2)" in html
    for name in ("noise and wander", "rig frame (mounting, stage zeros)", "gravity", "accel.alpha_yz"):
        assert name in html
    assert "mrad" in html


def test_a_session_whose_rig_file_changed_gets_the_datasheet_classes_and_says_so(run):
    session = run["tmp"] / "changed"
    shutil.copytree(run["session"], session)
    run["rig_file"].write_text(run["rig_file"].read_text() + "\n# edited after the run\n")
    try:
        target = run["tmp"] / "changed.yaml"
        code, out, err = rig("solve", session, "-o", target)
    finally:
        shutil.copy(RIGS / "sim.yaml", run["rig_file"])
    assert code == 0, err
    u = _section(target)["uncertainty"]
    assert "datasheet classes" in u["rig"] and "not there unchanged" in u["rig"]
    frame = next(c for c in u["budget"] if c["name"] == "rig frame (mounting, stage zeros)")
    assert min(frame["misalignment"].values()) > 1e-3  # the fixture's 0.1 deg class: about 1 mrad
    assert "rig terms: turntable datasheet classes" in out


@pytest.mark.skipif(not DATASETS.is_dir(), reason=NO_DATASETS)
def test_an_imported_session_gets_the_datasheet_classes_and_says_so(tmp_path):
    code, _, err = rig("import", "--from", "imucal", DATASETS / "imucal" / "annotated_session.csv", "-o", tmp_path,
                       "--id", "imp")
    assert code == 0, err
    code, out, err = rig("solve", tmp_path / "imp", "--trust-poses", "-o", tmp_path / "cal.yaml")
    assert code in (0, 1), err
    u = _section(tmp_path / "cal.yaml")["uncertainty"]
    assert "datasheet classes" in u["rig"] and "imported session" in u["rig"]
    assert "imported session" in out


def test_bad_inputs_keep_their_one_line_errors(run, tmp_path):
    code, _, err = rig("solve", run["session"], "--thermal", "2", "-o", tmp_path / "t.yaml")
    assert code == 2 and "temperature span" in err and len(err.strip().splitlines()) == 1
    bad = yaml.safe_load((run["session"] / "calibration.yaml").read_text())
    bad["accelerometer"]["uncertainty"]["k"] = 0
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(bad))
    code, _, err = rig("report", run["session"], "--calibration", path, "-o", tmp_path / "r.html")
    assert code == 2 and "uncertainty.k" in err and len(err.strip().splitlines()) == 1


def test_a_session_that_misfits_on_a_rig_without_geometry_errors_keeps_its_whole_sigma_in_u(run):
    """The walkthrough's session with a hidden scale nonlinearity (chi2/dof ~120) printed 'bias +- 7.71 counts' and
    then 'bias U: x 1.41': the budget dropped the solve's misfit scaling as 'the rig's geometry', though the rig's
    terms were all zero (sim.geometry off). Only what the rig's geometry explains may be dropped."""
    doc = yaml.safe_load(run["rig_file"].read_text())
    doc["sim"]["effects"] = {"scale_nonlinearity": 2e-3}
    doc["sim"]["geometry"] = {"enabled": False}  # a table that lands where commanded
    bad = run["tmp"] / "nonlinear.yaml"
    bad.write_text(yaml.safe_dump(doc))
    code, _, err = rig("run", PROCEDURES / "six_position.yaml", "--rig", bad, "--time-scale", "0", "--seed", "5",
                       "--out", run["tmp"] / "nl")
    assert code == 0, err
    assert "rig run: warning: the model does not fit the data" in err  # as rig solve says it (the run said nothing)
    (session,) = (run["tmp"] / "nl").iterdir()
    acc = _section(session / "calibration.yaml")
    assert acc["fit"]["chi2_per_dof"] > 20  # the misfit is real and the solve scaled its sigmas for it
    u = acc["uncertainty"]
    for key in QUANTITIES:
        assert np.all(np.asarray(u[key]) >= 2 * np.asarray(acc["sigma"][key]) * (1 - 1e-9)), key
    for n, v in u["misalignment"].items():
        assert v >= 2 * acc["sigma"]["misalignment"][n] * (1 - 1e-9), n
