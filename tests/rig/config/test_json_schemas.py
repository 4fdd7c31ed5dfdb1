"""The published JSON Schemas (docs/schemas/) are what the code generates and accept every shipped file."""

from __future__ import annotations

import json

import pytest
import yaml

from rig.config.json_schema import SCHEMAS, render

from conftest import PROCEDURES, REPO, RIGS

jsonschema = pytest.importorskip("jsonschema")
SCHEMA_DIR = REPO / "docs" / "schemas"


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_the_committed_schema_is_what_the_code_generates(name):
    committed = (SCHEMA_DIR / name).read_text()
    assert committed == render(name), f"regenerate: python -m rig.cli.schemas docs/schemas ({name})"


def _validator(name):
    schema = json.loads((SCHEMA_DIR / name).read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


@pytest.mark.parametrize("name,files", [("procedure.schema.json", sorted(PROCEDURES.glob("*.yaml"))),
                                        ("rig-file.schema.json", sorted(RIGS.glob("*.yaml")))])
def test_every_shipped_file_validates_against_its_schema(name, files):
    validator = _validator(name)
    assert files
    for path in files:
        errors = [f"{list(e.path)}: {e.message}" for e in validator.iter_errors(yaml.safe_load(path.read_text()))]
        assert not errors, (path.name, errors[:3])


def test_the_schemas_refuse_what_the_loaders_refuse():
    proc = yaml.safe_load((PROCEDURES / "six_position.yaml").read_text())
    v = _validator("procedure.schema.json")
    assert not v.is_valid({**proc, "colour": "red"})
    assert not v.is_valid({**proc, "steps": [{"pose": "+W up"}]})
    assert not v.is_valid({**proc, "steps": [{"pose": "+Z up", "angles_deg": [0, 0, 0]}]})
    assert not v.is_valid({**proc, "dwell": {"samples": 10**12}})
    rig = yaml.safe_load((RIGS / "sim.yaml").read_text())
    v = _validator("rig-file.schema.json")
    assert v.is_valid({**rig, "faults": {"ximc": {"a1": {"drop_rate": 0.5}}}})
    assert not v.is_valid({**rig, "faults": {"ximc": {"a1": {"drop_rate": 1.5}}}})
    assert not v.is_valid({**rig, "sim": {"effects": {"telekinesis": 1}}})
    rig["turntable"]["axes"]["a1"]["speed_deg_s"] = 60
    assert not v.is_valid(rig)


def test_the_one_schema_writer_finds_every_published_schema_up_to_date(tmp_path, capsys):
    from rig.cli.schemas import main
    from conftest import REPO

    assert main(["--check", str(REPO / "docs" / "schemas")]) == 0
    assert main([str(tmp_path)]) == 0 and sorted(p.name for p in tmp_path.iterdir()) == [
        "noise.schema.json", "procedure.schema.json", "rig-file.schema.json", "session.schema.json"]
    (tmp_path / "session.schema.json").write_text("{}")
    assert main(["--check", str(tmp_path)]) == 1
    assert "out of date (run python -m rig.cli.schemas" in capsys.readouterr().err
