"""The package rules hold: import contracts, no import cycles, small classes and functions.

The rules are in docs/architecture.md; ``pyproject.toml`` holds the import-linter contracts and
``benchmarks/structure.py`` the size limits. These tests fail when a change breaks one.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import grimp
import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
import structure  # noqa: E402


def test_import_contracts_hold():
    lint = Path(sys.executable).parent / "lint-imports"
    proc = subprocess.run([str(lint)], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:]


def test_no_import_cycles_between_modules():
    graph = grimp.build_graph("rig", "drivers", "calib")
    cycles = []
    for module in sorted(graph.modules):
        for imported in graph.find_modules_directly_imported_by(module):
            if graph.chain_exists(importer=imported, imported=module):
                cycles.append(f"{module} <-> {imported}")
    assert not cycles, cycles


@pytest.mark.parametrize("package", ["rig", "drivers", "calib"])
def test_no_class_over_250_lines_no_function_over_60_no_stray_function_level_imports(package, capsys):
    assert structure.report([package]) == 0, capsys.readouterr().out
