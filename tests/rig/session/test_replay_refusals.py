"""`rig replay` refusals name the session the user gave (its session.yaml), not the procedure file the
session was once recorded from, and not nothing: a recorded procedure text that no longer validates, a
recorded sensitivity the chip cannot have."""

from __future__ import annotations

import shutil

import pytest
import yaml

from rig.cli.main import main
from rig.workflow.run import run_procedure

from conftest import PROCEDURES


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    return run_procedure(str(PROCEDURES / "six_position.yaml"), out_dir=tmp_path_factory.mktemp("rec"), seed=6,
                         time_scale=0).session_dir


def _replay_refusal(recorded, tmp_path, capsys, edit) -> tuple[str, str]:
    d = tmp_path / "s"
    shutil.copytree(recorded, d)
    doc = yaml.safe_load((d / "session.yaml").read_text())
    edit(doc)
    doc.pop("seal", None)  # changed by hand: no longer the sealed recording (docs/session-format.md, "Seal")
    (d / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    assert main(["replay", str(d), "--out", str(tmp_path / "out")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0], str(d / "session.yaml")


@pytest.mark.parametrize("text, expect", [
    ('a: &a ["x","x","x","x","x","x","x","x","x"]\n' + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [" + ",".join([f"*{chr(97 + i)}"] * 9) + "]\n" for i in range(9)),
     "aliases expand to more than"),
    ("format: rig-procedure/1\nname: p\nsteps: [{pose: '+W up'}]\n", "steps[0] (step 1).pose"),
])
def test_a_recorded_procedure_that_does_not_validate_names_session_yaml(recorded, tmp_path, capsys, text, expect):
    line, manifest = _replay_refusal(recorded, tmp_path, capsys, lambda doc: doc["procedure"].update(text=text))
    assert line.startswith(f"rig replay: {manifest}: procedure.text: the recorded procedure (from "), line
    assert "six_position.yaml) does not validate: line " in line and expect in line, line


def test_an_impossible_recorded_sensitivity_names_session_yaml(recorded, tmp_path, capsys):
    line, manifest = _replay_refusal(recorded, tmp_path, capsys,
                                     lambda doc: doc["rig"]["sensor"].update(accel_lsb_per_g=1e300))
    assert line.startswith(f"rig replay: {manifest}: rig.sensor.accel_lsb_per_g: "), line
