"""The `rig-discover/6` JSON contract: every document validates against docs/schemas/discover.schema.json,
and the keys added in v3 say which baseline, wander, observability and lack-of-fit factor were used."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from test_discovery_matrix import _sin_a1, run, tumble

jsonschema = pytest.importorskip("jsonschema")
SCHEMA = json.loads((Path(__file__).resolve().parents[2] / "docs" / "schemas" / "discover.schema.json").read_text())


def _valid(doc: dict) -> None:
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    errors = [f"{list(e.path)}: {e.message}" for e in jsonschema.Draft202012Validator(SCHEMA).iter_errors(doc)]
    assert not errors, errors[:3]


def test_a_closed_gap_document_carries_the_v3_keys_and_validates():
    d, _ = run(tumble(), 41)
    doc = json.loads(json.dumps(d.to_json()))
    _valid(doc)
    assert doc["format"] == "rig-discover/6" and doc["baseline"] == "seed" and doc["unsupported"] == []
    assert doc["wander_rms_g"] > 0 and "unexplained" not in doc
    assert doc["observability"]["bias_drift"]["power"] == 0.8


def test_an_open_gap_document_names_its_nuisance_factor_and_validates():
    d, _ = run(tumble(), 42, outside=_sin_a1)
    doc = json.loads(json.dumps(d.to_json()))
    _valid(doc)
    assert doc["gap_closed"] is False and doc["unexplained"]["factor"]["p_value"] < doc["false_alarm"]


def test_without_a_stated_bias_stability_there_is_no_wander():
    d, _ = run(tumble(), 43, stability=None)
    assert d.to_json()["wander_rms_g"] == 0.0 and np.isfinite(d.chi2_per_dof_after)
