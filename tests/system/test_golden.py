"""The ``rig`` command gives the results recorded before the architecture change.

``golden/record.py`` ran every shipped procedure on the simulated rig (seed 3, virtual time), the
re-solves, replay, discover, evaluate and the three real-data imports on the code before the
refactor and stored the outputs in ``golden/``. These tests run the same commands on today's code
and require the same numbers (to 1e-9 relative: only floating-point summation order may differ).
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

GOLDEN = Path(__file__).resolve().parent / "golden"
_spec = importlib.util.spec_from_file_location("golden_record", GOLDEN / "record.py")
record = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(record)


def assert_same(actual, expected, where: str = "") -> None:
    """Equal structure; numbers equal to 1e-9 relative (or 1e-12 absolute)."""
    if isinstance(expected, dict):
        assert isinstance(actual, dict), where
        assert sorted(actual) == sorted(expected), f"{where}: keys {sorted(actual)} != {sorted(expected)}"
        for key in expected:
            assert_same(actual[key], expected[key], f"{where}.{key}")
    elif isinstance(expected, list):
        assert isinstance(actual, list) and len(actual) == len(expected), where
        for i, (a, e) in enumerate(zip(actual, expected)):
            assert_same(a, e, f"{where}[{i}]")
    elif isinstance(expected, float) and not isinstance(expected, bool):
        assert isinstance(actual, (int, float)), where
        assert math.isclose(actual, expected, rel_tol=1e-9, abs_tol=1e-12) or (
            math.isnan(actual) and math.isnan(expected)), f"{where}: {actual!r} != {expected!r}"
    else:
        assert actual == expected, f"{where}: {actual!r} != {expected!r}"


@pytest.fixture(scope="module")
def produced(tmp_path_factory, datasets):
    out = tmp_path_factory.mktemp("golden")
    results = record.record_runs(out / "runs")
    results.update(record.record_imports(out / "imports"))
    return {name: json.loads(json.dumps(record.normalise(value))) for name, value in results.items()}


GOLDEN_NAMES = sorted(p.stem for p in GOLDEN.glob("*.json"))


def test_every_golden_output_is_still_produced(produced):
    assert sorted(produced) == GOLDEN_NAMES


@pytest.mark.parametrize("name", GOLDEN_NAMES)
def test_output_matches_the_recording_made_before_the_refactor(produced, name):
    expected = json.loads((GOLDEN / f"{name}.json").read_text())
    assert_same(produced[name], expected, name)
