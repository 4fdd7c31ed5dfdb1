"""The package rules hold: import contracts, no import cycles, small classes and functions.

The rules are in docs/architecture.md; ``pyproject.toml`` holds the import-linter contracts and
``benchmarks/structure.py`` the size limits. These tests fail when a change breaks one.
"""

from __future__ import annotations

import re
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
    # imports under ``if TYPE_CHECKING:`` are type hints, not dependencies (as for the contracts, pyproject.toml):
    # RunContext names the run's TargetPolicy, whose module imports the context
    graph = grimp.build_graph("rig", "drivers", "calib", exclude_type_checking_imports=True)
    cycles = []
    for module in sorted(graph.modules):
        for imported in graph.find_modules_directly_imported_by(module):
            if graph.chain_exists(importer=imported, imported=module):
                cycles.append(f"{module} <-> {imported}")
    assert not cycles, cycles


#: an import of a module by a name string (importlib, __import__): the contracts cannot see it
STRING_IMPORT = re.compile(r"\bimport_module\s*\(|\b__import__\s*\(|\bimportlib\.util\.spec_from")
#: runtime modules allowed one, and why
STRING_IMPORTS_ALLOWED = {
    "calib/__init__.py": "calib's public names loaded on first use (module __getattr__, a table of its own modules)",
}


def test_no_runtime_module_imports_one_of_ours_by_a_name_string():
    """The simulator is wired in by the composition root (rig.composition) with import statements the contracts
    see, never by a module name string (rig.config.sections once imported rig.simulation so)."""
    found = sorted(str(p.relative_to(REPO)) for package in ("rig", "drivers", "calib")
                   for p in (REPO / package).rglob("*.py") if STRING_IMPORT.search(p.read_text()))
    assert [p for p in found if p not in STRING_IMPORTS_ALLOWED] == []


@pytest.mark.parametrize("package", ["rig", "drivers", "calib"])
def test_no_class_over_250_lines_no_function_over_60_no_stray_function_level_imports(package, capsys):
    assert structure.report([package]) == 0, capsys.readouterr().out
