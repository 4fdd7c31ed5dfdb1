"""The published JSON Schema of the session manifest is the code's, and real manifests satisfy it."""

from __future__ import annotations

import jsonschema
import yaml

from rig.session.json_schema import FILE_NAME, render, session_schema
from rig.workflow.run import run_procedure

from conftest import REPO


def test_the_committed_schema_is_what_the_code_generates():
    assert (REPO / "docs" / "schemas" / FILE_NAME).read_text() == render()


def test_a_recorded_manifest_validates_and_a_broken_one_does_not(tmp_path):
    result = run_procedure(str(REPO / "procedures" / "six_position.yaml"), out_dir=tmp_path, seed=2, time_scale=0)
    manifest = yaml.safe_load((result.session_dir / "session.yaml").read_text())
    jsonschema.validate(manifest, session_schema())
    manifest["steps"][0]["status"] = "half-done"
    try:
        jsonschema.validate(manifest, session_schema())
    except jsonschema.ValidationError as exc:
        assert "half-done" in str(exc.message)
    else:
        raise AssertionError("a step status outside the contract validated")
