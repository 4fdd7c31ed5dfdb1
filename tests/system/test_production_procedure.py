"""The shipped production procedure (procedures/six_position_production.yaml): datasheet-class limits, so a
technician sees PASS or FAIL out of the box (issue 33, item 5)."""

from __future__ import annotations

import yaml

from calib.file import calibration as calfile
from rig.cli import main

from conftest import PROCEDURES

PRODUCTION = PROCEDURES / "six_position_production.yaml"
SIM_RIG = PROCEDURES.parent / "rigs" / "sim.yaml"


def _run(tmp_path, monkeypatch, *extra):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "history.sqlite"))
    out = tmp_path / "sessions"
    code = main(["run", str(PRODUCTION), "--time-scale", "0", "--out", str(out), "--quiet", *extra])
    (session,) = out.iterdir()
    return code, session


def test_the_production_procedure_passes_on_the_simulated_rig_and_says_so_everywhere(tmp_path, capsys, monkeypatch):
    code, session = _run(tmp_path, monkeypatch)
    out = capsys.readouterr().out
    assert code == 0, out
    assert "acceptance: PASS (15 limits met)" in out
    cal = calfile.read(session / "calibration.yaml")
    assert cal.acceptance["passed"] is True and len(cal.acceptance["limits"]) == 15
    assert "PASS" in (session / "report.html").read_text()  # report: true, the verdict box says it


def test_a_unit_outside_its_datasheet_fails_with_exit_3_naming_the_parameter(tmp_path, capsys, monkeypatch):
    rig = yaml.safe_load(SIM_RIG.read_text())
    rig["sim"]["errors"] = {"bias_g": [0.07, 0.0, 0.0]}  # 70 mg on x: beyond the datasheet's +-50 mg
    rig_path = tmp_path / "outside.yaml"
    rig_path.write_text(yaml.safe_dump(rig, sort_keys=False))
    code, _ = _run(tmp_path, monkeypatch, "--rig", str(rig_path))
    said = capsys.readouterr()
    out = said.out + said.err
    assert code == 3, out
    assert "acceptance: FAIL (1 of 15 limits)" in out
    assert "FAIL accel.bias_x = 5" in out and "outside [-410, 410] counts" in out


def test_every_limit_of_the_production_procedure_carries_its_unit_and_source():
    lines = PRODUCTION.read_text().splitlines()
    start = lines.index("accept:")
    limits = [ln for ln in lines[start + 1:] if ln.startswith("    ")]
    assert limits and all("#" in ln for ln in limits if ":" in ln.split("#")[0] and "[" in ln), limits
    header = "\n".join(ln for ln in lines if ln.startswith("#"))
    for source in ("PS-MPU-6000A-00", "+-50 mg", "+-80 mg", "+-3 %", "+-2 %"):
        assert source in header
