"""Fast command start (issue 26): ``rig --help``, ``rig --version`` and ``rig solve`` import only what they use.

Each case runs the command in a fresh interpreter (a subprocess: only a fresh interpreter shows what a
command imports) and lists the packages it loaded that it must not: the simulator and scipy.signal (its
noise filters), matplotlib, and for ``--help`` / ``--version`` anything numeric at all. The command
table that ``rig --help`` is built from agrees with the command modules. The timings are measured by
``benchmarks/bench_startup.py``, not here.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from rig.cli.commands import COMMANDS, load
from rig.session import SessionWriter

from conftest import PROCEDURES, REPO
from written_sessions import faces_manifest

#: what no command that opens no rig and draws no plot may import
NEVER = ("rig.simulation", "drivers.ximc.sim", "drivers.sensors.sim", "scipy.signal", "matplotlib")
#: what ``rig --help`` and ``rig --version`` must not import either: the parser needs none of it
NOT_FOR_HELP = NEVER + ("numpy", "scipy", "pandas", "pydantic", "calib", "drivers", "rig.session", "rig.workflow")

#: runs ``rig ARGS`` in this interpreter, then prints the loaded modules among the packages given
PROBE = """
import json, sys
from rig.cli.main import main
code = main(sys.argv[2:])
names = json.loads(sys.argv[1])
print(json.dumps({"code": code, "loaded": sorted({n for n in names for m in list(sys.modules)
                                                  if m == n or m.startswith(n + ".")})}))
"""


def imported_by(args: list[str], names: tuple[str, ...]) -> tuple[int, list[str]]:
    """(exit code, which of ``names`` were imported) of ``rig ARGS`` in a fresh interpreter."""
    proc = subprocess.run([sys.executable, "-c", PROBE, json.dumps(names), *args], cwd=REPO, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    return result["code"], result["loaded"]


@pytest.mark.parametrize("option", ["--help", "--version"])
def test_help_and_version_import_no_command_and_nothing_numeric(option):
    assert imported_by([option], NOT_FOR_HELP) == (0, [])


def test_a_commands_help_imports_that_command_only():
    code, loaded = imported_by(["export", "--help"], NEVER + ("rig.cli.commands.solve", "rig.cli.commands.run"))
    assert (code, loaded) == (0, [])


@pytest.fixture
def six_position_session(tmp_path):
    """A six-position session as ``rig run`` writes it (the shipped procedure), written directly: no simulator."""
    faces = [[0, 0, 1], [1, 0, 0], [0, 0, -1], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
    text = (PROCEDURES / "six_position.yaml").read_text()
    manifest = faces_manifest(faces, {"name": "six_position", "file": "procedures/six_position.yaml", "text": text})
    writer = SessionWriter.create(tmp_path, "six", manifest)
    rng = np.random.default_rng(3)
    for i, f in enumerate(faces):
        counts = np.round(np.array(f) * 8200 + [60, -40, 110] + rng.normal(0, 25, (300, 3))).astype(int)
        writer.append_samples(i, i * 10 + np.arange(300) * 0.01, counts, temp_c=np.full(300, 25.0),
                              angles_deg=np.zeros((300, 3)))  # every cell a number, as rig run writes it
        writer.complete_step(i, {"n_samples": 300})
    writer.set_status("complete")
    return tmp_path / "six"


def test_rig_solve_imports_neither_the_simulator_nor_scipy_signal_nor_matplotlib_nor_pandas(six_position_session, tmp_path):
    code, loaded = imported_by(["solve", str(six_position_session), "-o", str(tmp_path / "cal.yaml")],
                               NEVER + ("rig.workflow.run", "rig.workflow.kinds", "rig.workflow.lifecycle",
                                        "rig.cli.commands.run", "rig.cli.commands.discover",
                                        "pandas", "rig.lab.report", "rig.config.procedure", "sqlalchemy", "alembic"))
    assert (code, loaded) == (0, [])
    assert (tmp_path / "cal.yaml").is_file()


def test_the_command_table_lists_every_command_module_with_the_help_line_its_parser_gives():
    for name, line in COMMANDS.items():
        sub = argparse.ArgumentParser().add_subparsers()
        load(name).add_parser(sub)
        assert [(a.dest, a.help) for a in sub._choices_actions] == [(name, line)]
    modules = {p.stem for p in (REPO / "rig" / "cli" / "commands").glob("*.py")} - {"__init__"}
    assert {load(name).__name__.rsplit(".", 1)[1] for name in COMMANDS} == modules


def test_the_workflows_register_the_sim_and_replay_kinds_without_importing_the_simulator():
    code = ("import sys, rig.workflow.run, rig.workflow.replay; from rig.devices.registry import RIG_KINDS; "
            "print(sorted(RIG_KINDS), RIG_KINDS['sim'].__module__, any(m.startswith('rig.simulation') for m in "
            "sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["['hardware',", "'replay',", "'sim']", "rig.workflow.kinds", "False"]


#: runs the program as ``rig ARGS`` (its name as argv[0], as the console script has it), then prints the BLAS
#: thread variables it ran with
AS_PROGRAM = """
import json, os, runpy, sys
sys.argv = ["rig", *sys.argv[1:]]
try:
    runpy.run_module("rig.cli", run_name="__main__")
except SystemExit:
    pass
print(json.dumps({n: os.environ.get(n) for n in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}))
"""


@pytest.mark.parametrize("given, expected", [({}, "1"), ({"OPENBLAS_NUM_THREADS": "2"}, "2")],
                         ids=["unset: one thread", "the user's kept"])
def test_the_program_runs_numpy_on_one_blas_thread_unless_told_otherwise(given, expected):
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    proc = subprocess.run([sys.executable, "-c", AS_PROGRAM, "--version"], cwd=REPO, capture_output=True, text=True,
                          env={**env, **given}, timeout=60)
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    assert seen["OPENBLAS_NUM_THREADS"] == expected and seen["OMP_NUM_THREADS"] == "1", (seen, proc.stderr[-500:])
