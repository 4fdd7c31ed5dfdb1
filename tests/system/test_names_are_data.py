"""Names are data (issue 34 item 5).

Whatever the user writes (step names, the rig file's name, a serial, file names) is shown literally
in the plots and the report: matplotlib draws it without mathtext or TeX (``$\\frac{1$`` made
``rig report``, ``rig discover --plot`` and a run with ``report: true`` fail with an internal
ValueError), the page escapes it. Every auxiliary file a command reads (a ``rig discover`` document or
an augmented calibration in the session folder, the history's rows, the history the drift limit reads)
is checked, and a damaged one is a note in the output, never a failed command.

The sessions are recorded in process (:func:`rig.workflow.run.run_procedure`, the simulated rig at
time_scale 0); the figures are checked as SVG with text as text (``svg.fonttype: none``), so a name
drawn literally is one ``<text>`` element with exactly its characters.
"""

from __future__ import annotations

import html
import io
import json
import re
import shutil
import sqlite3
import xml.etree.ElementTree as ET
from pathlib import Path

import matplotlib
import pytest
import yaml

from rig.analysis import plots
from rig.analysis.discover import discover_session, write_plot
from rig.cli import main
from rig.cli.common import json_default
from rig.workflow.run import run_procedure

from conftest import PROCEDURES, RIGS, unseal
from html_page import Page

SEED = 5
FACES = ("+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up")
#: one hostile step name per pose: mathtext that does not parse, TeX and a backslash, markup, the
#: longest name a step may have (200 characters), a line break, right-to-left text and an emoji
STEP_NAMES = ("$\\frac{1$", "back\\slash $x^2$ 100% {}", "<script>alert('names')</script>",
              "L" * 188 + "$\\alpha$ end", "two\nlines", "שלום עולם 🎉 ✓")
#: a serial the operator wrote: 500 characters of the same
SERIAL = ("SN-$\\frac{1$ <script>alert(1)</script> & back\\slash\nשלום 🎉 "
          + "0123456789abcdef" * 40)[:500]
RIG_FILE_NAME = "rig $\\frac{1$ <i> שלום 🎉.yaml"
SVG_TEXT = "{http://www.w3.org/2000/svg}text"


def _procedure(folder: Path, extra: str = "", name: str = "hostile") -> Path:
    text = (PROCEDURES / "six_position.yaml").read_text()
    head, _, _ = text.partition("steps:")
    steps = "".join(f'  - pose: "{face}"\n    name: {json.dumps(n, ensure_ascii=False)}\n'
                    for face, n in zip(FACES, STEP_NAMES))
    text = (head.replace("name: six_position", f"name: {name}").replace("dwell: {seconds: 10}", "dwell: {seconds: 2}")
            + "steps:\n" + steps + "solve: {model: triangular, method: pinv, thermal: auto}\n" + extra)
    path = folder / f"{name}.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _rig_file(folder: Path) -> Path:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["name"] = "rig $\\frac{1$ <b>bold</b> & שלום"
    path = folder / RIG_FILE_NAME
    path.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> dict:
    """A six-position session whose steps have hostile names, recorded on a rig file with a hostile
    name into a history of its own; its rig-discover/4 document (as ``rig discover --json`` prints it)."""
    root = tmp_path_factory.mktemp("names")
    db = root / "history.sqlite"
    result = run_procedure(str(_procedure(root)), rig_spec=str(_rig_file(root)), out_dir=root / "sessions",
                           seed=SEED, time_scale=0, history=db)
    assert result.status == "complete" and result.conclusion.history_warning is None
    return {"root": root, "session": result.session_dir, "db": db}


@pytest.fixture(scope="module")
def plain(tmp_path_factory) -> dict:
    """A six-position session with the shipped names, in a history of its own, and its rig-discover/4
    document as ``rig discover --json`` prints it: the damaged-file tests damage nothing but the file."""
    root = tmp_path_factory.mktemp("plain")
    db = root / "history.sqlite"
    result = run_procedure(str(PROCEDURES / "six_position.yaml"), out_dir=root / "sessions", seed=SEED, time_scale=0,
                           history=db)
    assert result.status == "complete" and result.conclusion.history_warning is None
    _, d = discover_session(result.session_dir)
    doc = json.loads(json.dumps(d.to_json(), default=json_default))
    return {"session": result.session_dir, "db": db, "discover": doc}


def _copy(session: Path, tmp: Path) -> Path:
    out = tmp / session.name
    shutil.copytree(session, out, ignore=shutil.ignore_patterns("report.html", "*.json", "session.lock"))
    return unseal(out)  # the tests edit the copies by hand: no longer the sealed recordings


def _svg_texts(fig) -> list[str]:
    """The texts of ``fig`` as an SVG viewer finds them (one element per line of a text)."""
    buf = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        fig.savefig(buf, format="svg")
    return ["".join(t.itertext()) for t in ET.fromstring(buf.getvalue()).iter(SVG_TEXT)]


def _svg_comments(path: Path) -> list[str]:
    """The texts of an SVG file written with glyphs as paths: matplotlib names each one in a comment."""
    unescape = {"&lt;": "<", "&gt;": ">", "&amp;": "&"}
    found = re.findall(r"<!-- (.*?) -->", path.read_text(encoding="utf-8"), re.S)
    return [re.sub(r"&lt;|&gt;|&amp;", lambda m: unescape[m.group()], c).replace("- ", "-") for c in found]


def _on_axis(name: str) -> list[str]:
    """The lines a step's name is drawn as on the step axis: whole, or its first 31 characters and "…"."""
    return [line if len(line) <= plots.MAX_LABEL_CHARS else line[:plots.MAX_LABEL_CHARS - 1] + "…"
            for line in name.split("\n")]


def _squeezed(text: str) -> str:
    return re.sub(r"\s+", "", text)


@pytest.fixture
def drawn(monkeypatch) -> list:
    """Every figure the report embeds (``plots.png_data_uri`` still draws it into the page)."""
    figures, embed = [], plots.png_data_uri

    def spy(fig, *args, **kwargs):
        figures.append(fig)
        return embed(fig, *args, **kwargs)
    monkeypatch.setattr(plots, "png_data_uri", spy)
    return figures


# ---------------------------------------------------------------------------------------------- names, literally

def test_a_run_that_asks_for_its_report_exits_0_and_the_report_names_every_step(tmp_path, capsys):
    proc = _procedure(tmp_path, "report: true\n", name="hostile_report")
    # rig run has no --history: the suite's own database ($RIG_HISTORY, conftest) takes the record
    code = main(["run", str(proc), "--seed", str(SEED), "--time-scale", "0", "--out", str(tmp_path / "s"), "--quiet"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    (session,) = (tmp_path / "s").iterdir()
    text = (session / "report.html").read_text(encoding="utf-8")
    for name in STEP_NAMES:
        assert html.escape(name) in text, name
    assert "<script>alert" not in text


def test_run_procedure_with_report_true_returns_the_report(tmp_path):
    proc = _procedure(tmp_path, "report: true\n", name="hostile_api")
    result = run_procedure(str(proc), out_dir=tmp_path / "s", seed=SEED, time_scale=0, history=tmp_path / "h.sqlite")
    assert result.conclusion.report_path is not None and result.conclusion.report_path.is_file()
    assert (result.session_dir / "calibration.yaml").is_file()


def test_the_report_shows_every_name_literally_in_its_tables_and_figures(lab, tmp_path, drawn, capsys):
    assert main(["report", str(lab["session"]), "-o", str(tmp_path / "r.html"), "--history", str(lab["db"])]) == 0
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    page = Page(text)
    steps = [row[0] for row in page.rows["residual-table"][1:]]
    assert steps == [" ".join(n.split()) for n in STEP_NAMES]  # every name whole (whitespace as the parser gives it)
    for name in STEP_NAMES:
        assert html.escape(name) in text
    assert html.escape(RIG_FILE_NAME) in text  # the rig file, named by its path in the identity card
    assert "<script>alert" not in text and page.tags.count("script") == 0
    assert len(drawn) >= 1
    shown = _svg_texts(drawn[0])  # the residuals by step and by temperature
    for name in STEP_NAMES:
        for line in _on_axis(name):
            assert line in shown, (line, shown[:12])


def test_discover_plot_draws_the_names_as_written(lab, tmp_path, capsys):
    assert main(["discover", str(lab["session"]), "--plot", str(tmp_path / "d.svg")]) == 0
    assert f"plot: {(tmp_path / 'd.svg').resolve()}" in capsys.readouterr().out
    comments = _svg_comments(tmp_path / "d.svg")
    for name in STEP_NAMES:
        for line in _on_axis(name):
            assert comments.count(line) == 2, line  # on both panels' step axes
    _, d = discover_session(lab["session"])
    shown = _svg_texts(write_plot(d, None, session_id="s"))
    for name in STEP_NAMES:
        assert all(shown.count(line) == 2 for line in _on_axis(name)), name


def test_control_characters_and_lone_surrogates_in_a_name_never_fail_a_figure_or_the_page(plain, tmp_path, capsys):
    """A hand-edited manifest can carry any string YAML escapes can write: a NUL, an escape sequence, half
    of a surrogate pair. The figure and the page show their escapes (no font or UTF-8 file holds them)."""
    s = _copy(plain["session"], tmp_path)
    doc = yaml.safe_load((s / "session.yaml").read_text(encoding="utf-8"))
    doc["steps"][0]["name"] = "nul\x00 esc\x1b[31m half\udcff"
    (s / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False), encoding="ascii")
    assert main(["report", str(s), "-o", str(tmp_path / "r.html"), "--history", str(plain["db"])]) == 0
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "half\\udcff" in text
    fig = plots.residuals_figure("t", ["nul\x00 esc\x1b[31m half\udcff"], [None], [("h", [[0.0, 1.0, 2.0]])])
    assert "nul\\x00 esc\\x1b[31m half\\udcff" in _svg_texts(fig)


def test_a_500_character_serial_in_the_history_its_plot_and_the_report(plain, lab, tmp_path, drawn, capsys):
    db = tmp_path / "h.sqlite"
    copies = []
    for recorded in (lab["session"], plain["session"]):  # two calibrations of the sensor: the history has a plot
        s = _copy(recorded, tmp_path)
        doc = yaml.safe_load((s / "session.yaml").read_text(encoding="utf-8"))
        doc["rig"]["sensor"]["serial"] = SERIAL
        (s / "session.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
        assert main(["history", "--record", str(s), "--history", str(db)]) == 0
        copies.append(s)
    s = copies[-1]
    key = f"MPU-9150:{SERIAL}"
    assert key in capsys.readouterr().out
    assert main(["history", key, "--history", str(db), "--plot", str(tmp_path / "h.svg")]) == 0
    assert "2 calibration(s)" in capsys.readouterr().out
    assert _squeezed(key) in _squeezed("".join(_svg_comments(tmp_path / "h.svg")))  # the title: the whole key
    (tmp_path / "plots").mkdir()
    assert main(["history", key, "--history", str(db), "--plot", str(tmp_path / "plots")]) == 0
    (written,) = (tmp_path / "plots").iterdir()  # a file name the file system takes
    assert written.name.startswith("history-MPU-9150_SN") and len(written.name) < 100
    assert main(["report", str(s), "-o", str(tmp_path / "r.html"), "--history", str(db)]) == 0
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert html.escape(SERIAL) in text and html.escape(key) in text  # the serial in the identity card, the key
    assert "history-plot" in Page(text).text_by_id and "<script>alert" not in text
    assert _squeezed(key) in _squeezed("".join(_svg_texts(drawn[-1])))  # the history figure's title


# ---------------------------------------------------------------------------------------------- damaged files

def _damaged(doc: dict, case: str):
    d = json.loads(json.dumps(doc))
    if case == "effects a string":
        d["effects"] = "bias_tempco"
    elif case == "residuals strings":
        for st in d["steps"]:
            st["residual_before_g"] = "1e-5, 2e-5, 3e-5"
    elif case == "residual entries strings":
        for st in d["steps"]:
            st["residual_after_g"] = ["1e-5", "2e-5", "3e-5"]
    elif case == "rms a string":
        d["rms_before_g"] = "0.0001"
    elif case == "effect a string":
        d["effects"] = ["bias_tempco"]
    elif case == "effect estimate strings":
        d["effects"] = [{"name": "bias_tempco", "axes": ["x", "y", "z"], "estimate": ["big", 1e-5, 2e-5],
                         "sigma": [1e-6, 1e-6, 1e-6], "unit": "g/C", "rms_after_g": 1e-4, "p_value": 1e-9}]
    elif case == "steps a mapping":
        d["steps"] = {"+Z up": [0, 0, 0]}
    elif case == "gap_closed a string":
        d["gap_closed"] = "yes"
    elif case == "a list":
        d = [d]
    elif case == "truncated":
        return json.dumps(doc)[:200]
    elif case == "nested too deep":
        return "[" * 100_000 + "]" * 100_000
    return json.dumps(d)


DAMAGED = {
    "effects a string": "(effects: expected a list, got 'bias_tempco')",
    "residuals strings": "(steps[0].residual_before_g: expected a list of 3 numbers",
    "residual entries strings": "(steps[0].residual_after_g: expected a list of 3 numbers",
    "rms a string": "(rms_before_g: expected a number, got '0.0001')",
    "effect a string": "(effects[0]: expected a mapping, got 'bias_tempco')",
    "effect estimate strings": "(effects[0].estimate: expected a list of numbers",
    "steps a mapping": "(steps: expected a list",
    "gap_closed a string": "(gap_closed: expected true or false, got 'yes')",
    "a list": "(the document: expected a JSON object",
    "truncated": "(not JSON: ",
    "nested too deep": "(not JSON: ",
}


@pytest.mark.parametrize("case", list(DAMAGED))
def test_a_damaged_discover_document_is_a_note_not_a_failed_report(plain, tmp_path, capsys, case):
    s = _copy(plain["session"], tmp_path)
    (s / "discover.json").write_text(_damaged(plain["discover"], case), encoding="utf-8")
    assert main(["report", str(s), "-o", str(tmp_path / "r.html"), "--history", str(plain["db"])]) == 0
    section = Page((tmp_path / "r.html").read_text(encoding="utf-8")).text("discover")
    assert f"discover.json: not a {plain['discover']['format']} document {DAMAGED[case]}" in section, section
    assert section.endswith("; left out") and "has not been run" not in section


def test_a_damaged_document_beside_a_good_one_leaves_the_good_one_shown(plain, tmp_path, capsys):
    s = _copy(plain["session"], tmp_path)
    (s / "discover-good.json").write_text(json.dumps(plain["discover"]), encoding="utf-8")
    (s / "discover.json").write_text(_damaged(plain["discover"], "residuals strings"), encoding="utf-8")
    (s / "other-tool.json").write_text('{"format": "something-else/1", "effects": "x"}', encoding="utf-8")
    assert main(["report", str(s), "-o", str(tmp_path / "r.html"), "--history", str(plain["db"])]) == 0
    page = Page((tmp_path / "r.html").read_text(encoding="utf-8"))
    section = page.text("discover")
    assert "discover-plot" in page.text_by_id and str(s / "discover-good.json") in section
    assert f"discover.json: not a {plain['discover']['format']} document (steps[0].residual_before_g" in section
    assert "other-tool.json" not in section  # another program's JSON is none of the report's business


def test_a_damaged_augmented_calibration_is_a_note(plain, tmp_path, capsys):
    s = _copy(plain["session"], tmp_path)
    (s / "calibration-discover.yaml").write_text("format: rig-calibration/1\naccelerometer: 3\n", encoding="utf-8")
    assert main(["report", str(s), "-o", str(tmp_path / "r.html"), "--history", str(plain["db"])]) == 0
    section = Page((tmp_path / "r.html").read_text(encoding="utf-8")).text("discover")
    assert re.search(r"calibration-discover\.yaml: not a readable calibration file \(.+\); left out", section), section
    assert str(s) not in section  # the file is named once, by its name


def _damage_history(db: Path, *, text: bool = True) -> None:
    with sqlite3.connect(db) as c:
        c.execute("UPDATE parameters SET value = 'abc' WHERE name = 'accel.bias_x'")
        c.execute("UPDATE parameters SET sigma = 'wide' WHERE name = 'accel.bias_y'")
        c.execute("UPDATE calibrations SET rig = '{not json', temp_mean_c = 'warm'")
        if text:
            c.execute("UPDATE calibrations SET procedure_name = CAST(X'FF6869' AS TEXT)")


HISTORY_NOTES = ("temp_mean_c: expected a number, got 'warm'; shown as missing",
                 "rig: expected the rig identity as a JSON mapping, got '{not json'; shown as missing",
                 "procedure_name: not UTF-8 text; shown with replacement characters",
                 "parameter accel.bias_x: expected a number, got 'abc'; left out",
                 "parameter accel.bias_y: sigma: expected a number >= 0, got 'wide'; shown as missing")


def test_damaged_history_rows_are_notes_in_rig_history_its_json_its_plot_and_the_report(plain, tmp_path, capsys):
    db = tmp_path / "h.sqlite"
    shutil.copy(plain["db"], db)
    _damage_history(db)
    key = f"MPU-9150@0x68#0x68/sim-seed-{SEED}"
    assert main(["history", key, "--history", str(db), "--plot", str(tmp_path / "h.svg")]) == 0
    out = capsys.readouterr().out
    for line in HISTORY_NOTES:
        assert f"note: calibration #1 (history row 1): {line}" in out, out
    assert "accel.bias_x" not in out.split("note:")[0] and "accel.bias_y (counts)" in out
    assert main(["history", key, "--history", str(db), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["notes"]) == len(HISTORY_NOTES) and "accel.bias_x" not in doc["calibrations"][0]["parameters"]
    assert doc["calibrations"][0]["parameters"]["accel.bias_y"]["sigma"] is None
    assert main(["report", str(plain["session"]), "-o", str(tmp_path / "r.html"), "--history", str(db)]) == 0
    section = Page((tmp_path / "r.html").read_text(encoding="utf-8")).text("history")
    for line in HISTORY_NOTES:
        assert line in section


def test_the_drift_limit_judges_what_is_left_of_a_damaged_history(plain, tmp_path):
    db = tmp_path / "h.sqlite"
    shutil.copy(plain["db"], db)
    _damage_history(db, text=False)
    proc = tmp_path / "accepted.yaml"
    proc.write_text((PROCEDURES / "six_position.yaml").read_text() + "accept:\n  max_drift_sigma: 5\n")
    result = run_procedure(str(proc), out_dir=tmp_path / "s", seed=SEED, time_scale=0, history=db)
    (check,) = [c for c in result.conclusion.acceptance.checks if c.name == "max_drift_sigma"]
    assert check.passed and check.value is not None and abs(check.value) < 1e-6, check.line
