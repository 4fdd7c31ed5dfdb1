"""Shared test fixtures: paths of the repository, shipped procedures and the shared datasets."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PROCEDURES = REPO / "procedures"
RIGS = REPO / "rigs"
DATASETS = REPO.parent / "shared" / "datasets"


def pytest_configure(config):
    """Every solve records into a calibration history (docs/history.md): the tests' go into a
    database of their own, never the user's (subprocesses inherit the variable)."""
    os.environ["RIG_HISTORY"] = str(Path(tempfile.mkdtemp(prefix="rig-test-history-")) / "history.sqlite")


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def datasets() -> Path:
    if not DATASETS.is_dir():
        pytest.skip(f"shared datasets not found at {DATASETS} (CI has ../shared beside the checkout)")
    return DATASETS
