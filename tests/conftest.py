"""Shared test fixtures: paths of the repository, shipped procedures and the shared datasets."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PROCEDURES = REPO / "procedures"
RIGS = REPO / "rigs"
DATASETS = REPO.parent / "shared" / "datasets"


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def datasets() -> Path:
    if not DATASETS.is_dir():
        pytest.skip(f"shared datasets not found at {DATASETS} (CI has ../shared beside the checkout)")
    return DATASETS
