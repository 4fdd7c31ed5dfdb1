"""`rig discover` says the same thing wherever a person reads it (issue 33, the walkthrough on a fresh clone):
the leg of a step in the same words in the localisation and the per-step table, the console's first sentence
as the ``headline`` of the ``--json`` document and as the report's discrepancy verdict, every angle in mrad.
The ``rig`` commands run in this process (``rig.cli.main``) on sessions the simulated rig records in virtual time."""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
from pathlib import Path

import pytest
import yaml

from rig.cli import main

from conftest import PROCEDURES, RIGS
from html_page import Page

SCHEMA = json.loads((Path(__file__).resolve().parents[2] / "docs" / "schemas" / "discover.schema.json").read_text())
#: what the console's headline says first on a thermal session whose calibration models the bias tempco
NOTHING_MISSING = "Nothing is missing beyond bias_tempco, which this session's calibration already models"


def rig(*args) -> tuple[int, str]:
    """``rig ARGS`` in this process: (exit code, what it printed on stdout)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main([str(a) for a in args])
    return code, out.getvalue()


def _run(procedure: Path, out: Path, *extra) -> Path:
    code, _ = rig("run", procedure, "--seed", 3, "--time-scale", 0, "--out", out, "--quiet", *extra)
    assert code == 0
    return next(out.iterdir())


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    """A thermal session, a thermal-ramp session and a tumble26 session on a rig whose base is out of level and
    whose sensor is mounted rotated (``table_tilt``, ``full_misalignment``), each in a history of its own."""
    root = tmp_path_factory.mktemp("discover_words")
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["effects"] = {"table_tilt": [0.1, -0.05], "full_misalignment": 0.3}
    tilted = root / "tilted.yaml"
    tilted.write_text(yaml.safe_dump(doc))
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(root / "h.sqlite"))
        return {"thermal": _run(PROCEDURES / "thermal.yaml", root / "thermal"),
                "ramp": _run(PROCEDURES / "thermal_ramp.yaml", root / "ramp"),
                "tilted": _run(PROCEDURES / "tumble26.yaml", root / "tilted", "--rig", tilted)}


@pytest.fixture(autouse=True)
def history(tmp_path, monkeypatch) -> Path:
    path = tmp_path / "h.sqlite"
    monkeypatch.setenv("RIG_HISTORY", str(path))
    return path


def test_the_per_step_table_names_each_leg_in_the_words_of_the_localisation(sessions):
    """`rms z by leg: heating .., cooling .., unknown ..` above a table whose leg column said `up`, `down`, `-`:
    both now say heating, cooling, unknown."""
    code, out = rig("discover", sessions["ramp"], "--details")
    assert code == 0
    (by_leg,) = [x for x in out.splitlines() if "rms z by leg:" in x]
    words = set(re.findall(r"(\w+) [\d.]+", by_leg.split(":", 1)[1]))
    assert words == {"heating", "cooling", "unknown"}
    lines = out.splitlines()
    start = next(i for i, x in enumerate(lines) if x.startswith("per step (residual")) + 2
    legs = {re.match(r"  .{14} .{7} (.{7})   ", x).group(1).strip() for x in lines[start:] if x.startswith("  ")}
    assert legs == words, legs


def test_the_json_document_carries_the_headline_the_console_prints_first(sessions):
    code, console = rig("discover", sessions["thermal"])
    assert code == 0
    first = console.split("\n\n", 1)[0].replace("\n", " ")
    assert first.startswith(NOTHING_MISSING)
    code, text = rig("discover", sessions["thermal"], "--json")
    doc = json.loads(text)
    assert doc["headline"] == first and doc["format"] == "rig-discover/6"  # the headline: additive
    jsonschema = pytest.importorskip("jsonschema")
    assert not list(jsonschema.Draft202012Validator(SCHEMA).iter_errors(doc))


def test_the_reports_discrepancy_verdict_is_the_consoles_headline(sessions, tmp_path):
    """The report said "verdict: the model with the named effects explains the data" and listed bias_tempco as
    an effect named; it now opens the section with the console's headline and marks the effect as modelled."""
    session = sessions["thermal"]
    code, text = rig("discover", session, "--json")
    (session / "discover.json").write_text(text)
    try:
        assert rig("report", session, "-o", tmp_path / "r.html")[0] == 0
    finally:
        (session / "discover.json").unlink()
    page = Page((tmp_path / "r.html").read_text())
    assert page.text("discover-headline") == json.loads(text)["headline"]
    assert "named effects explains" not in page.text("discover")
    assert [r[0] for r in page.rows["discover-effects"][1:]] == ["bias_tempco"]
    assert page.text("discover-modelled").startswith("bias_tempco: already in this session's calibration")


def test_a_document_without_a_headline_gets_the_same_words_in_the_report(sessions, tmp_path):
    """A discover document written before the key existed: the report makes the headline from its effects."""
    session = sessions["thermal"]
    code, text = rig("discover", session, "--json")
    doc = json.loads(text)
    headline = doc.pop("headline")
    (session / "discover.json").write_text(json.dumps(doc))
    try:
        assert rig("report", session, "-o", tmp_path / "r.html")[0] == 0
    finally:
        (session / "discover.json").unlink()
    assert Page((tmp_path / "r.html").read_text()).text("discover-headline") == headline


def test_discover_prints_the_tilt_and_the_mounting_rotation_in_mrad_and_the_json_keeps_the_librarys_units(
        sessions):
    code, out = rig("discover", sessions["tilted"])
    assert code == 0
    doc = json.loads(rig("discover", sessions["tilted"], "--json")[1])
    effects = {e["name"]: e for e in doc["effects"]}
    assert {"table_tilt", "full_misalignment"} <= set(effects)
    to_mrad = {"rad": 1e3, "deg": math.pi / 180 * 1e3}
    for name in ("table_tilt", "full_misalignment"):
        (line,) = [x for x in out.splitlines() if x.strip().startswith(f"+ {name} ")]
        assert "[mrad]" in line, line
        printed = [float(v) for v in re.findall(r"\w ([+-]?[\d.]+(?:e[+-]?\d+)?) \+-", line)]
        e = effects[name]
        assert e["unit"] in to_mrad  # the JSON keeps the library's unit
        shown = [v * to_mrad[e["unit"]] for v in e["estimate"] if v is not None]
        assert printed == pytest.approx(shown, rel=1e-3), (line, shown)
