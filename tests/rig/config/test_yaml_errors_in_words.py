"""YAML mistakes said in words (issue 33, item 7): the common causes of a syntax error are named with the line
of the cause and the fix, never the parser's jargon; a misspelt key, pose or step kind gets a "did you mean"."""

from __future__ import annotations

import pytest

from calib.file.yamlhints import explain
from rig.cli import main
from rig.config.procedure import load_procedure_text
from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError

from conftest import RIGS

GOOD = """format: rig-procedure/1
name: p
description: two faces
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 2}
steps:
  - pose: "+Z up"
  - pose: "-Z up"
solve: {model: triangular}
"""
JARGON = ("<block end>", "'?'", "<scalar>", "mapping values are not allowed", "cannot start any token",
          "while scanning", "could not find expected")


def _line(text: str) -> str:
    with pytest.raises(RigInputError) as exc:
        load_procedure_text(text, "p.yaml")
    return str(exc.value)


#: bad input -> (the line the message names, what it must say)
SYNTAX = {
    "no space after a list item's dash": (
        GOOD.replace('  - pose: "-Z up"', '  -pose: "-Z up"'),
        "p.yaml:8: not valid YAML: a list item needs a space after its dash: write '- pose: \"-Z up\"'"),
    "a tab in the indentation": (
        GOOD.replace('  - pose: "-Z up"', '\t- pose: "-Z up"'),
        "p.yaml:8: not valid YAML: a tab in the indentation: YAML indents with spaces only; replace the tab"),
    "a quote not closed (the error is found a line later)": (
        GOOD.replace('  - pose: "+Z up"', '  - pose: "+Z up'),
        "p.yaml:7: not valid YAML: the quote \" opened on this line is not closed: end the value with it: "
        "- pose: \"+Z up\""),
    "a quote not closed on the last line": (
        GOOD.replace("solve: {model: triangular}", "solve: {model: 'triangular}"),
        "p.yaml:9: not valid YAML: the quote ' opened on this line is not closed"),
    "a colon in an unquoted name": (
        GOOD.replace("name: p", "name: six: production"),
        "p.yaml:2: not valid YAML: the value of 'name' contains ': ', which YAML reads as another key: put the "
        "value in quotes: name: \"six: production\""),
    "a colon in an unquoted description": (
        GOOD.replace("description: two faces", "description: two faces: +Z and -Z"),
        "p.yaml:3: not valid YAML: the value of 'description' contains ': '"),
}


@pytest.mark.parametrize("case", SYNTAX)
def test_a_common_syntax_mistake_is_named_with_its_line_and_fix(case):
    text, says = SYNTAX[case]
    line = _line(text)
    assert line.startswith(says), line
    assert "\n" not in line and not any(j in line for j in JARGON), line


def test_an_apostrophe_inside_a_plain_value_is_not_taken_for_an_unclosed_quote():
    assert explain("description: rock 'n roll\nname: *a\n", "found undefined alias 'a'", 2) == (
        2, "found undefined alias 'a'")
    assert explain("a: it's\nb: 'x''y' # it's\n", "whatever", 2) == (2, "whatever")


@pytest.mark.parametrize("bad, says", [
    (GOOD.replace("dwell: {seconds: 2}", "dwell: {seconds: 2}\n  extra: 1"),
     "p.yaml:6: not valid YAML: this line does not line up with the lines above it"),
    (GOOD.replace("dwell: {seconds: 2}", "dwell\norder: as_written"),  # the key without its colon, not the next line
     "p.yaml:5: not valid YAML: a line that is neither 'key: value' nor a list item '- ...' (a missing ':' after a "
     "key?)"),
    (GOOD.replace("solve: {model: triangular}", "solve: {model: triangular"),
     "p.yaml:10: not valid YAML: a {...} is not closed, or two of its entries lack the comma between them"),
])
def test_a_mistake_without_a_known_cause_is_said_plainly_at_its_line(bad, says):
    line = _line(bad)
    assert line.startswith(says) and not any(j in line for j in JARGON), line


def test_every_step_without_its_space_is_a_duplicate_key_that_says_why():
    line = _line(GOOD.replace('  - pose: "+Z up"\n  - pose: "-Z up"', '  -pose: "+Z up"\n  -pose: "-Z up"'))
    assert line == ("p.yaml:8: -pose: duplicate key; a list item needs a space after its dash: write '- pose: ...' "
                    "instead of '-pose: ...'"), line


def test_the_text_of_a_block_scalar_is_never_taken_for_the_cause():
    text = GOOD.replace("description: two faces", "description: |\n  Note: dwell: 2 s\n  -see \"docs")
    text = text.replace("dwell: {seconds: 2}", "dwell: {seconds: 2}\n  extra: 1")
    line = _line(text)
    assert line.startswith("p.yaml:8: not valid YAML: this line does not line up with the lines above it"), line


def test_the_cli_says_it_in_one_line_exit_2(tmp_path, capsys):
    proc = tmp_path / "p.yaml"
    proc.write_text(GOOD.replace('  - pose: "-Z up"', '  -pose: "-Z up"'))
    assert main(["run", str(proc), "--time-scale", "0", "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rig run: {proc}:8: not valid YAML: a list item needs a space after its dash: write "
                   "'- pose: \"-Z up\"' instead of '-pose: \"-Z up\"'"]


@pytest.mark.parametrize("bad, says, meant", [
    (GOOD.replace("dwell:", "dwel:"), "p.yaml:5: dwel: unknown key (allowed: accept, description, dwell, ", "dwell"),
    (GOOD.replace("dwell: {seconds: 2}", "dwell: {secnds: 2}"), "p.yaml:5: dwell.secnds: unknown key", "seconds"),
    (GOOD.replace('"-Z up"', '"-Z upp"'), "p.yaml:8: steps[1] (step 2).pose: unknown pose '-Z upp'", "-Z up"),
    (GOOD.replace('"-Z up"', '"+x+y up"'), "p.yaml:8: steps[1] (step 2).pose: unknown pose '+x+y up'", "+X+Y up"),
    (GOOD.replace('  - pose: "-Z up"', '  - pos: "-Z up"'), "p.yaml:8: steps[1] (step 2): each step needs exactly one of",
     "pose"),
])
def test_a_misspelt_key_pose_or_step_kind_gets_a_did_you_mean(bad, says, meant):
    line = _line(bad)
    assert line.startswith(says), line
    assert line.endswith(f": did you mean '{meant}'?"), line
    far = _line(GOOD.replace("dwell:", "zzzzzz:"))  # nothing close: no guess
    assert "did you mean" not in far and far.endswith("target)"), far


def test_a_rig_file_key_gets_a_did_you_mean_too():
    text = (RIGS / "sim.yaml").read_text().replace("speed_deg_s: 20", "sped_deg_s: 20", 1)
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(text, "r.yaml")
    assert "turntable.axes.a1.sped_deg_s: unknown key" in str(exc.value)
    assert str(exc.value).endswith(": did you mean 'speed_deg_s'?")
