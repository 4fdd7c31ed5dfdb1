"""``rig report`` in a real browser: headless Chromium (the Debian package ``chromium``) renders the page,
the rendered DOM carries the verdict and the parameter table, and the screenshot shows the page drawn
(the verdict badge's colour, the embedded plots' markers).

Without Chromium the tests skip, unless the environment variable ``CI`` is set: then they fail
(``.ci/run`` installs Chromium).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from calib.file import calibration as calfile
from calib.file.parameters import sensor_parameters
from rig.lab.units import shown
from rig.lab.report import write_report

from browser import headless_chromium
from html_page import Page


WINDOW = (1280, 2400)
#: colours drawn only when the page's style and pictures render (style.py, matplotlib's tab: colours)
BADGE_NO_LIMITS, BADGE_FAIL = (9, 105, 218), (207, 34, 46)
MARKER_RED, MARKER_BLUE = (214, 39, 40), (31, 119, 180)


@pytest.fixture(scope="module")
def chromium() -> str:
    return headless_chromium()


def browse(exe: str, page: Path, tmp: Path, *, screenshot: Path | None = None) -> str:
    """Run headless Chromium on ``page``: the rendered DOM (``--dump-dom``), or a screenshot."""
    args = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            f"--user-data-dir={tmp / 'chromium-profile'}", "--hide-scrollbars"]
    args += [f"--screenshot={screenshot}", f"--window-size={WINDOW[0]},{WINDOW[1]}"] if screenshot else ["--dump-dom"]
    proc = subprocess.run(args + [page.resolve().as_uri()], capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def pixels(png: Path) -> dict:
    from PIL import Image  # matplotlib's own dependency

    with Image.open(png) as im:
        assert im.size == WINDOW
        counts = im.convert("RGB").getcolors(maxcolors=WINDOW[0] * WINDOW[1])
    return {rgb: n for n, rgb in counts}


@pytest.fixture(scope="module")
def session(simulated_lab):
    return simulated_lab["six"], simulated_lab["db"]


def test_chromium_renders_the_verdict_and_the_parameter_table(chromium, session, tmp_path):
    s, db = session
    page = write_report(s, tmp_path / "report.html", history_db=db)
    dom = Page(browse(chromium, page, tmp_path))
    assert "NO LIMITS" in dom.text("verdict") and "no acceptance limits" in dom.text("verdict")
    assert "6 steps used" in dom.text("verdict") and "INCOMPLETE SESSION" not in dom.all_text
    rows = {r[0]: r for r in dom.rows["parameter-table"] if len(r) >= 4}
    cal = calfile.read(s / "calibration.yaml")
    for name, value, sigma, unit in sensor_parameters(cal):
        value, sigma, unit = shown(value, sigma, unit)  # as a person reads it (angles in mrad, rig.lab.units)
        assert rows[name][3] == unit and abs(float(rows[name][1]) - value) <= 0.05 * sigma, name
    assert dom.images >= 1 and dom.rows["roll-pitch-table"][0][0] == "step"
    shot = tmp_path / "report.png"
    browse(chromium, page, tmp_path, screenshot=shot)
    colours = pixels(shot)
    assert colours.get(BADGE_NO_LIMITS, 0) > 2000  # the verdict badge, drawn with the page's own style
    assert colours.get(MARKER_RED, 0) > 20 and colours.get(MARKER_BLUE, 0) > 20  # the embedded residual plot
    assert len(colours) > 200  # text, tables and plots, not a blank or error page


def test_chromium_renders_a_failed_verdict_and_an_incomplete_session(chromium, session, tmp_path):
    s, db = session
    copy = tmp_path / s.name
    shutil.copytree(s, copy, ignore=shutil.ignore_patterns("report.html"))
    doc = yaml.safe_load((copy / "session.yaml").read_text())
    doc["status"], doc["steps"][4]["status"] = "aborted", "failed"
    doc.pop("seal")  # an unfinished session has no seal
    (copy / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    line = "accel.scale_x = 8146 counts/g: outside [8180, 8200] counts/g"
    acceptance = {"passed": False, "limits": [{"name": "range accel.scale_x", "limit": "[8180, 8200]", "value": 8146.0,
                                               "passed": False, "line": line}]}
    cal = calfile.read(copy / "calibration.yaml")  # the verdict a failed limit writes into the file
    calfile.write(copy / "calibration.yaml", cal.model_copy(update={"acceptance": acceptance}))
    page = write_report(copy, tmp_path / "report.html", history_db=db)
    dom = Page(browse(chromium, page, tmp_path))
    verdict = dom.text("verdict")
    assert "FAIL" in verdict and line in verdict and "INCOMPLETE SESSION" in verdict and "+Y up (failed)" in verdict
    shot = tmp_path / "report.png"
    browse(chromium, page, tmp_path, screenshot=shot)
    assert pixels(shot).get(BADGE_FAIL, 0) > 2000
