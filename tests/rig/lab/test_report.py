"""``rig report`` (issue #17 item 4): the content of the HTML page, without a browser.

The page is parsed with the standard library's ``html.parser``; the browser test
(tests/system/test_report_browser.py) renders it in headless Chromium.
"""

from __future__ import annotations

import json
import re
import shutil
from functools import cache
from pathlib import Path

import pytest
import yaml

from calib.file import calibration as calfile
from calib.file.parameters import sensor_parameters
from rig.cli import main
from rig.lab.report import content, render, write_report
from rig.lab.units import shown

from conftest import PROCEDURES
from html_page import Page

SECTIONS = ("verdict", "identity", "parameters", "residuals", "seed-table", "discover", "history")



@pytest.fixture(scope="module")
def lab(simulated_lab):
    """Two calibrations of one simulated sensor (six-position, then twelve-position) in a history of their own."""
    return simulated_lab


def _copy(session: Path, tmp: Path) -> Path:
    out = tmp / session.name
    shutil.copytree(session, out, ignore=shutil.ignore_patterns("report.html", "*.json"))
    return out


def _report(session: Path, tmp: Path, db, **kw) -> tuple[Path, str, Page]:
    path = write_report(session, tmp / "r.html", history_db=db, **kw)
    text = path.read_text()
    return path, text, Page(text)


@pytest.fixture(scope="module")
def lab_report(lab, tmp_path_factory):
    """``lab_report(key)``: (folder, path, text, page) of the report of the lab's ``six`` or ``twelve`` session
    with the lab's history, written once for the tests that only read it (into ``folder / "r.html"``)."""
    root = tmp_path_factory.mktemp("lab-reports")

    @cache
    def report(key: str) -> tuple[Path, Path, str, Page]:
        folder = root / key
        folder.mkdir()
        return (folder, *_report(lab[key], folder, lab["db"]))
    return report


# ---------------------------------------------------------------------------------------------- the page

def test_every_section_is_present_and_the_page_is_self_contained(lab_report):
    folder, path, text, page = lab_report("twelve")
    assert path == (folder / "r.html").resolve()
    for ident in SECTIONS:
        assert ident in page.text_by_id, ident
    assert not re.search(r"(?i)https?:", text)  # no web address at all
    assert "<script" not in text and "<link" not in text and "@import" not in text and "url(" not in text
    sources = [v for tag, k, v in page.attrs_seen if k in ("src", "href", "srcset", "action", "data")]
    assert sources and all(v.startswith(("data:image/png;base64,", "#")) for v in sources), sources
    assert sum(v.startswith("data:image/png") for v in sources) >= 2  # residuals and history plots, inside the file


def test_the_parameter_table_has_every_parameter_with_sigma_and_unit(lab, lab_report):
    *_, page = lab_report("six")
    cal = calfile.read(lab["six"] / "calibration.yaml")
    rows = {r[0]: r for r in page.rows["parameter-table"] if len(r) >= 4 and r[0].startswith("accel.")}
    expected = sensor_parameters(cal)
    assert set(rows) == {n for n, *_ in expected}
    for name, *stored in expected:
        value, sigma, unit = shown(*stored)  # angles in mrad, as rig run prints them
        shown_value, shown_sigma, shown_unit = rows[name][1:4]
        assert shown_unit == unit
        if sigma is not None:
            assert abs(float(shown_value) - value) <= 0.05 * sigma + 1e-12, (name, shown_value, value)
            assert float(shown_sigma) == pytest.approx(sigma, rel=0.06)
    assert page.rows["parameter-table"][0][:4] == ["parameter", "value", "1σ", "unit"]
    assert rows["accel.alpha_yz"][3] == "mrad"


def test_the_verdict_without_acceptance_limits_is_the_fit_quality(lab, lab_report):
    *_, page = lab_report("six")
    verdict = page.text("verdict")
    cal = calfile.read(lab["six"] / "calibration.yaml")
    assert "no acceptance limits" in verdict and "NO LIMITS" in verdict
    assert f"chi2/dof {cal.accelerometer.fit.chi2_per_dof:.2f}" in verdict and "6 steps used" in verdict
    assert "incomplete" not in page.text_by_id


def test_acceptance_limits_give_pass_or_fail_with_the_failed_lines(lab, tmp_path):
    failed = {"name": "range accel.bias_x", "limit": "[-100, 100]", "value": 396.5, "passed": False,
              "line": "accel.bias_x = 396.5 counts: outside [-100, 100] counts"}
    ok = {"name": "max_chi2_per_dof", "limit": "<= 3", "value": 1.2, "passed": True, "line": "chi2/dof 1.2 <= 3"}
    for passed, limits in ((False, [failed, ok]), (True, [ok])):
        s = _copy(lab["six"], tmp_path / str(passed))
        cal = calfile.read(s / "calibration.yaml")
        calfile.write(s / "calibration.yaml", cal.model_copy(update={"acceptance": {"passed": passed, "limits": limits}}))
        _, _, page = _report(s, tmp_path / str(passed), lab["db"])
        verdict = page.text("verdict")
        if passed:
            assert "PASS" in verdict and "FAIL" not in verdict and "all 1 acceptance limits met" in verdict
        else:
            assert "FAIL" in verdict and "1 of 2 acceptance limits not met" in verdict
            assert failed["line"] in verdict
        assert [r[3] for r in page.rows["acceptance-table"][1:]] == ["pass" if e["passed"] else "fail" for e in limits]


def test_the_acceptance_section_a_procedure_writes_is_the_verdict(tmp_path, capsys):
    proc = tmp_path / "accept.yaml"
    proc.write_text((PROCEDURES / "six_position.yaml").read_text()
                    + "accept:\n  ranges:\n    accel.bias_*: [-100, 100]\n  max_chi2_per_dof: 5\n")
    assert main(["run", str(proc), "--seed", "6", "--time-scale", "0", "--out", str(tmp_path / "s"), "--quiet"]) == 3
    capsys.readouterr()
    s = next((tmp_path / "s").iterdir())
    acceptance = calfile.read(s / "calibration.yaml").acceptance
    failed = [e["line"] for e in acceptance["limits"] if not e["passed"]]
    assert failed and not acceptance["passed"]
    _, _, page = _report(s, tmp_path, tmp_path / "h.sqlite")
    verdict = page.text("verdict")
    assert verdict.startswith("FAIL") and f"{len(failed)} of {len(acceptance['limits'])} acceptance limits" in verdict
    assert all(line in verdict for line in failed)
    assert len(page.rows["acceptance-table"]) == len(acceptance["limits"]) + 1


def test_an_incomplete_session_is_flagged_in_the_verdict(lab, tmp_path):
    s = _copy(lab["six"], tmp_path)
    doc = yaml.safe_load((s / "session.yaml").read_text())
    doc["status"] = "aborted"
    doc["steps"][5]["status"] = "pending"
    doc["steps"][5].pop("stats", None)
    doc.pop("seal")  # an unfinished session has no seal
    (s / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    _, text, page = _report(s, tmp_path, lab["db"])
    flag = page.text("incomplete")
    assert "INCOMPLETE SESSION" in flag and "'aborted'" in flag and "1 of 6 steps not recorded: -Y up (pending)" in flag
    assert text.index('id="incomplete"') < text.index('id="identity"')  # right under the verdict, at the top


def test_a_session_without_a_discover_run_says_so_and_one_with_it_shows_the_summary(lab, tmp_path, capsys):
    s = _copy(lab["six"], tmp_path)
    _, _, page = _report(s, tmp_path, lab["db"])
    assert "rig discover has not been run on this session" in page.text("discover")
    assert "discover-effects" not in page.rows and "discover-plot" not in page.text_by_id
    assert main(["discover", str(s), "--json"]) == 0
    (s / "discover.json").write_text(capsys.readouterr().out)
    doc = json.loads((s / "discover.json").read_text())
    _, _, page = _report(s, tmp_path, lab["db"])
    text = page.text("discover")
    assert "has not been run" not in text and f"{doc['rms_before_g'] * 1e6:.1f} → " in text
    assert "discover-plot" in page.text_by_id and str(s / "discover.json") in text


def test_the_roll_pitch_table_is_the_seed_layout_of_rig_evaluate(lab, lab_report, tmp_path, capsys):
    *_, page = lab_report("six")
    rows = page.rows["roll-pitch-table"]
    assert rows[0][0] == "step" and [r[0] for r in rows[1:]] == ["+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up"]
    assert main(["evaluate", str(lab["six"] / "calibration.yaml"), str(lab["six"]), "--json"]) == 0
    ev = json.loads(capsys.readouterr().out)
    for row, step in zip(rows[1:], ev["steps"]):
        assert float(row[3]) == pytest.approx(step["pitch_error_deg"], abs=6e-4)
    assert "In-sample" in page.text("seed-table")
    # the same calibration on another session of the sensor is an independent check
    _, _, other = _report(lab["twelve"], tmp_path, lab["db"], calibration=lab["six"] / "calibration.yaml")
    assert "Independent check" in other.text("seed-table") and len(other.rows["roll-pitch-table"]) == 13
    assert "solved from session" in other.text("verdict")


def test_the_history_of_the_sensor_marks_this_calibration_and_its_changes(lab, lab_report, tmp_path):
    *_, page = lab_report("twelve")
    rows = page.rows["history-table"]
    assert len(rows) == 3 and "this report" in rows[2][0] and "six_position" in rows[1][2]
    assert "history-plot" in page.text_by_id
    params = page.rows["parameter-table"]
    assert params[0][-1] == "change since previous calibration"
    assert any(re.fullmatch(r"[+-]\d+\.\dσ( !)?", r[-1]) for r in params if len(r) == 5)
    _, _, none = _report(lab["six"], tmp_path, tmp_path / "absent.sqlite")
    assert "no history database at" in none.text("history") and "history-table" not in none.rows


def test_residuals_by_step_carry_the_pose_names(lab_report):
    *_, page = lab_report("six")
    rows = page.rows["residual-table"]
    assert rows[0] == ["step", "temperature, °C", "x, µg", "y, µg", "z, µg"]
    assert [r[0] for r in rows[1:]] == ["+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up"]
    assert all(re.fullmatch(r"\d+\.\d\d", r[1]) for r in rows[1:])  # the simulated MPU-9150 has a thermometer
    assert "residual-plot" in page.text_by_id


def test_an_imported_real_recording(datasets, tmp_path, capsys):
    from rig.importers.recordings import import_recording

    s = import_recording("imucal", datasets / "imucal" / "annotated_session.csv", tmp_path)
    db = tmp_path / "h.sqlite"
    # imucal's faces are placed by hand, 0.5-1.4 deg off: refused unless the poses are trusted on purpose
    assert main(["solve", str(s), "--trust-poses"]) == 0
    capsys.readouterr()
    _, text, page = _report(s, tmp_path, db)
    ident = page.text("identity")
    assert "imucal" in ident and "annotated_session.csv" in ident and "thermometer no" in ident
    assert sorted(r[0] for r in page.rows["roll-pitch-table"][1:]) == ["x_a", "x_p", "y_a", "y_p", "z_a", "z_p"]
    assert all(r[1] == "–" for r in page.rows["residual-table"][1:])  # no temperatures: a dash, and the plot says so
    assert not re.search(r"(?i)https?:", text)
    assert "accel.alpha_yz" in [r[0] for r in page.rows["parameter-table"]]


def test_render_never_writes_a_negative_zero_and_rounds_to_the_sigma():
    assert render.fmt_value(396.5205588, 0.3534866) == ("396.52", "0.35")
    assert render.fmt_value(0.0166037958, 7.43e-05) == ("0.016604", "0.000074")
    assert render.fmt_value(12345.6, 150.0) == ("12346", "150")
    assert render.fmt_value(40.0085, None) == ("40.0085", "–")
    assert render._num(-0.00004, "+.3f") == "+0.000" and render._num(-0.04, ".1f") == "0.0"


# ---------------------------------------------------------------------------------------------- the command

def test_the_command_writes_the_default_file_and_prints_its_path(lab, tmp_path, capsys):
    s = _copy(lab["six"], tmp_path)
    assert main(["report", str(s), "--history", str(lab["db"])]) == 0
    assert capsys.readouterr().out.strip() == f"report: {(s / 'report.html').resolve()}"
    out_dir = tmp_path / "reports"
    out_dir.mkdir()
    assert main(["report", str(s), "-o", str(out_dir), "--history", str(lab["db"])]) == 0
    assert capsys.readouterr().out.strip() == f"report: {(out_dir / (s.name + '-report.html')).resolve()}"


@pytest.mark.parametrize("case", ["not a session", "no calibration", "unwritable -o", "missing folder", "bad calib"])
def test_bad_input_is_one_line_exit_2(lab, tmp_path, capsys, case):
    s = _copy(lab["six"], tmp_path)
    args = ["report", str(s)]
    if case == "not a session":
        args = ["report", str(tmp_path)]
        want = "session.yaml"
    elif case == "no calibration":
        (s / "calibration.yaml").unlink()
        want = "run `rig solve"
    elif case == "unwritable -o":
        (tmp_path / "file").write_text("x")
        args += ["-o", str(tmp_path / "file" / "r.html")]  # a folder that is a file: no one can write there
        want = "cannot write the report"
    elif case == "missing folder":
        args += ["-o", str(tmp_path / "no" / "such" / "r.html")]
        want = "no such directory"
    else:
        (s / "calibration.yaml").write_text("format: rig-calibration/1\n")
        want = "calibration.yaml"
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig report: ") and err.count("\n") == 1 and want in err, err


def test_the_content_never_fails_on_a_missing_part(lab, tmp_path):
    """Each part that is absent is a note, never an exception (content.gather on a magnitude-only case)."""
    c = content.gather(lab["six"], history_db=tmp_path / "none.sqlite")
    assert c.history.note and c.discover.note and c.seed.evaluation is not None and c.residuals.values_ug.shape == (6, 3)
    assert c.sensor_key.startswith("MPU-9150@0x68") and c.sensor_key.endswith("/sim-seed-6")


def test_a_procedure_that_asks_for_the_report_gets_it_at_the_end_of_the_run(lab, tmp_path, capsys):
    proc = tmp_path / "reported.yaml"
    proc.write_text((PROCEDURES / "six_position.yaml").read_text().replace("dwell: {seconds: 10}", "dwell: {seconds: 2}")
                    + "report: true\n")
    assert main(["run", str(proc), "--seed", "6", "--time-scale", "0", "--out", str(tmp_path / "s"), "--quiet"]) == 0
    s = next((tmp_path / "s").iterdir())
    assert f"report: {(s / 'report.html').resolve()}" in capsys.readouterr().out.splitlines()
    assert "verdict" in Page((s / "report.html").read_text()).text_by_id
    # one that does not ask gets none: the lab's six-position session, recorded by `rig run six_position.yaml`
    assert not (lab["six"] / "report.html").exists()
