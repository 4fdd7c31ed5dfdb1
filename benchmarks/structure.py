"""Structure figures of the code base: largest classes and functions, function-level imports.

    python benchmarks/structure.py [PACKAGE ...]      # default: rig drivers calib

Prints the five largest classes and functions, the number of function-level imports and the
modules per folder; exits 1 when a limit of the architecture rules (docs/architecture.md) is broken:
no class over 250 lines, no function over 60 lines (declarative tables excepted: a function or class
whose body is a single literal), function-level (deferred) imports only those of ``DEFERRED``.
``tests/test_architecture.py`` runs the same check.
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAX_CLASS_LINES = 250
MAX_FUNCTION_LINES = 60
#: the deferred (function-level) imports allowed, each on purpose (docs/architecture.md, "Deferred imports"):
#: (module or package imported, the module that may defer it or "" for any, why). Every other import is at
#: the top of its module; a deferred import is still an import statement, which import-linter sees.
DEFERRED: tuple[tuple[str, str, str], ...] = (
    ("matplotlib", "", "a plot one command draws on request"),
    ("scipy.signal", "drivers.sensors.sim.noise", "the noise filter, only when a simulated sensor draws noise"),
    ("pandas", "rig.session.reader", "the CSV reader for files with empty or quoted cells; a file of numbers is read by numpy"),
    ("rig.config.procedure", "rig.session.reader", "the recorded procedure's validation, only when a solve needs its target or limits"),
    ("rig.lab.report", "rig.workflow.conclude", "the HTML report, only when the procedure asks for one"),
    ("rig.lab.report", "rig.workflow.batch", "the batch's HTML report, only at the end of a fixture run"),
    ("rig.simulation", "rig.workflow.kinds", "the sim and replay rig kinds, only when such a rig is opened"),
    ("rig.simulation", "rig.composition", "the sim: and faults: schemas, only when a rig file has such a section"),
    ("rig.composition", "rig.cli.main", "the composition root, called once a command runs (not for --help)"),
    ("rig.cli.commands", "rig.cli.commands", "a command's module, only when that command is given"),
    ("rig.cli.failures", "rig.cli.main", "every layer's error types (calib, pandas), once a command runs"),
    ("rig.devices.bringup", "rig.cli.failures", "rig check's hints for a port that does not open, only then"),
    ("scipy.optimize", "calib.numerics.magnitude", "the magnitude method's nonlinear fit, only when that method is asked for"),
    ("scipy.optimize", "calib.mag.ellipsoid", "the ellipsoid's nonlinear fit, only when a magnetometer is solved"),
    ("allantools", "calib.noise.allan", "the Allan deviation and its intervals, only when rig characterize computes one"),
    ("distributed", "rig.archive.resolve", "the Dask executor (an optional extra), only when rig resolve --executor dask"),
    ("dask", "rig.archive.resolve", "the Dask executor's configuration, only when rig resolve --executor dask"),
    ("rig.archive.fleet_page", "rig.cli.commands.fleet",
     "the fleet's figure and HTML page (matplotlib, the report's renderer), only when --plot or -o is given"),
    ("rig.lab.history_db.server", "rig.lab.history_db.database", "SQLAlchemy, only when the history is a URL (a server)"),
    ("rig.lab.history_db.migrate", "rig.lab.history_db.database", "Alembic, only when a history's schema is older"),
)


def deferred_allowed(module: str, imported: str) -> bool:
    """Whether ``module`` may import ``imported`` inside a function (an entry of :data:`DEFERRED`)."""
    return any((imported == name or imported.startswith(name + ".")) and importer in ("", module)
               for name, importer, _ in DEFERRED)


@dataclass(frozen=True)
class Block:
    kind: str  # class | function
    name: str  # module:qualified.name
    lines: int


def _is_table(node: ast.AST) -> bool:
    """A body that is one literal (a declarative table), after an optional docstring."""
    body = [n for n in node.body if not (isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant))]
    return len(body) == 1 and isinstance(body[0], (ast.Return, ast.Assign)) and isinstance(
        body[0].value, (ast.Dict, ast.List, ast.Tuple, ast.Set))


def _imported(node: ast.Import | ast.ImportFrom) -> list[str]:
    """The modules (or module attributes) an import statement names: ``from a.b import c`` -> ``a.b.c``."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    return [f"{node.module or ''}.{a.name}" for a in node.names]


def scan(path: Path, root: Path) -> tuple[list[Block], list[str]]:
    """Classes, functions (with their line counts) and function-level imports of one module."""
    tree = ast.parse(path.read_text(), str(path))
    module = path.relative_to(root).with_suffix("").as_posix().replace("/", ".").removesuffix(".__init__")
    blocks: list[Block] = []
    inner_imports: list[str] = []

    def visit(node: ast.AST, prefix: str, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                kind = "class" if isinstance(child, ast.ClassDef) else "function"
                name = f"{prefix}{child.name}"
                if not _is_table(child):
                    blocks.append(Block(kind, f"{module}:{name}", child.end_lineno - child.lineno + 1))
                visit(child, name + ".", in_function or kind == "function")
            elif isinstance(child, (ast.Import, ast.ImportFrom)):
                if in_function:
                    for n in _imported(child):
                        if not deferred_allowed(module, n):
                            inner_imports.append(f"{module}:{child.lineno}: {n}")
            else:
                visit(child, prefix, in_function)

    visit(tree, "", False)
    return blocks, inner_imports


def report(packages: list[str]) -> int:
    blocks: list[Block] = []
    inner: list[str] = []
    folders: Counter[str] = Counter()
    for package in packages:
        for path in sorted((REPO / package).rglob("*.py")):
            b, i = scan(path, REPO)
            blocks += b
            inner += i
            folders[path.parent.relative_to(REPO).as_posix()] += 1
    classes = sorted((b for b in blocks if b.kind == "class"), key=lambda b: -b.lines)
    functions = sorted((b for b in blocks if b.kind == "function"), key=lambda b: -b.lines)
    print("largest classes:   " + ", ".join(f"{b.name} ({b.lines})" for b in classes[:5]))
    print("largest functions: " + ", ".join(f"{b.name} ({b.lines})" for b in functions[:5]))
    print(f"function-level imports (not allowed deferred imports): {len(inner)}")
    for line in inner:
        print(f"  {line}")
    print("modules per folder: " + ", ".join(f"{k} {v}" for k, v in sorted(folders.items())))
    over = [b for b in classes if b.lines > MAX_CLASS_LINES] + [b for b in functions if b.lines > MAX_FUNCTION_LINES]
    for b in over:
        print(f"OVER LIMIT: {b.kind} {b.name}: {b.lines} lines")
    return 1 if over or inner else 0


if __name__ == "__main__":
    sys.exit(report(sys.argv[1:] or ["rig", "drivers", "calib"]))
