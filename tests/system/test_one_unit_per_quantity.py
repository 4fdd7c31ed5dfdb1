"""One unit per quantity across run, solve, discover, evaluate, history and report (issue 33 item 4): a quantity a
person reads in two places is printed in the same unit, under the same name, with its sigma. The ``rig`` commands
run in this process (``rig.cli.main``) on sessions recorded by the simulated rig in virtual time."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

from rig.cli import main

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
