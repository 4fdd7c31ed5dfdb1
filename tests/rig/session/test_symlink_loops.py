"""A symbolic link loop given as any input file (procedure, rig file, session directory, session.yaml,
samples.csv, calibration file, import source) is bad input: exit 2 and one line naming the path and saying
it is a loop, never exit 1 with a bare "Too many levels of symbolic links" or a misleading "missing"."""

from __future__ import annotations

import os
import shutil

import pytest

from rig.cli.main import main
from rig.workflow.run import run_procedure

from conftest import PROCEDURES

SIX = PROCEDURES / "six_position.yaml"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    return run_procedure(str(SIX), out_dir=tmp_path_factory.mktemp("rec"), seed=4, time_scale=0).session_dir


def _loop(path):
    os.symlink(path, path)
    return path


def _session_with_loop(recorded, tmp_path, name):
    d = tmp_path / "s"
    shutil.copytree(recorded, d)
    (d / name).unlink()
    _loop(d / name)
    return d, d / name


CASES = {
    "procedure": lambda L, s, t: (["run", L, "--out", t / "runs", "--time-scale", "0"], L),
    "rig file": lambda L, s, t: (["run", SIX, "--rig", L, "--out", t / "runs", "--time-scale", "0"], L),
    "session directory [solve]": lambda L, s, t: (["solve", L], L),
    "session directory [discover]": lambda L, s, t: (["discover", L], L),
    "session directory [replay]": lambda L, s, t: (["replay", L], L),
    "session directory [evaluate]": lambda L, s, t: (["evaluate", s / "calibration.yaml", L], L),
    "calibration file [apply]": lambda L, s, t: (["apply", L, s, "-o", t / "x.csv"], L),
    "calibration file [evaluate]": lambda L, s, t: (["evaluate", L, s], L),
    "calibration file [export]": lambda L, s, t: (["export", L, "--to", "px4"], L),
    "import source": lambda L, s, t: (["import", "--from", "csv", L, "-o", t / "imports"], L),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_symlink_loop_as_an_input_file_is_one_line_exit_2(recorded, tmp_path, capsys, case):
    args, named = CASES[case](_loop(tmp_path / "loop.yaml"), recorded, tmp_path)
    assert main([str(a) for a in args]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{named}: a symbolic link loop" in lines[0], lines


@pytest.mark.parametrize("name", ["session.yaml", "samples.csv"])
def test_a_symlink_loop_inside_a_session_is_named(recorded, tmp_path, capsys, name):
    d, loop = _session_with_loop(recorded, tmp_path, name)
    assert main(["solve", str(d), "-o", str(tmp_path / "c.yaml")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{loop}: a symbolic link loop" in lines[0], lines
