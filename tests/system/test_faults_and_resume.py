"""Nothing lost, nothing silent: turntable and sensor faults, kill -9 and Ctrl-C, on the simulated rig.

kill -9 and Ctrl-C need a run in another process (``_spawn``); everything else, the resumes after them
included, runs in this process. The signalled runs go at ``SIGNALLED_TIME_SCALE``: the elastic simulated
clock never loses a sample at any scale, so the scale only sets how long the test waits for the steps the
signal must come after (issue 26). One complete six-position session (``complete_six``, seed 21) serves as
the uninterrupted reference of the kill -9 tests, the complete session a resume must refuse (a copy) and
the complete session without a coverage section.
"""

from __future__ import annotations

import json
import re
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main
from rig.errors import RigInputError
from rig.session import SessionManifest, load_session

from conftest import PROCEDURES, REPO, RIGS

SIX = str(PROCEDURES / "six_position.yaml")
#: time scale of the runs that are killed or interrupted (a step of six_position.yaml, ~13 s of rig time,
#: takes under a second of wall time: the signal still lands in the middle of the run)
SIGNALLED_TIME_SCALE = "16"


def _rig_file(tmp_path: Path, extra: str, time_scale: float = 0) -> Path:
    text = (RIGS / "sim.yaml").read_text().replace("time_scale: 10", f"time_scale: {time_scale}")
    p = tmp_path / "rig.yaml"
    p.write_text(text + extra)
    return p


def _only_session(root: Path) -> Path:
    dirs = [d for d in root.iterdir() if d.is_dir()]
    assert len(dirs) == 1
    return dirs[0]


@pytest.fixture(scope="module")
def complete_six(tmp_path_factory) -> Path:
    """An uninterrupted six-position session of seed 21 (virtual time); read only: copy it to change it."""
    out = tmp_path_factory.mktemp("complete")
    assert main(["run", SIX, "--out", str(out), "--seed", "21", "--time-scale", "0", "--quiet"]) == 0
    return _only_session(out)


def test_a_stalled_stage_stops_everything_and_says_which_axis_port_and_command(tmp_path, capsys):
    rig = _rig_file(tmp_path, "faults:\n  ximc:\n    a2: {stall_at_deg: 30}\n")
    code = main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "s"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and re.match(r"rig run: a2 (/dev/pts/|ximcsim://)", err[0]) and "stalled" in err[0]
    d = _only_session(tmp_path / "s")
    m = yaml.safe_load((d / "session.yaml").read_text())
    assert m["status"] == "aborted"
    # the poses before +Y up (which needs a2 = 90 deg) were recorded and kept
    assert [s["status"] for s in m["steps"]][:4] == ["complete"] * 4
    events = [json.loads(x) for x in (d / "events.jsonl").read_text().splitlines()]
    assert events[-1]["kind"] == "abort"


def test_corrupted_and_dropped_answers_are_recovered_with_warnings_and_the_calibration_unchanged(tmp_path):
    rig = _rig_file(tmp_path, "faults:\n  ximc:\n    a1: {crc_corrupt_rate: 0.01, seed: 3}\n"
                              "    a2: {drop_rate: 0.01, seed: 4}\n    a3: {truncate_rate: 0.01, seed: 5}\n")
    assert main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "f"), "--seed", "11", "--quiet"]) == 0
    assert main(["run", SIX, "--rig", "sim", "--time-scale", "0", "--out", str(tmp_path / "c"), "--seed", "11",
                 "--quiet"]) == 0
    faulty, clean = _only_session(tmp_path / "f"), _only_session(tmp_path / "c")
    events = [json.loads(x) for x in (faulty / "events.jsonl").read_text().splitlines()]
    assert any(e["kind"] == "warning" and e.get("source") == "turntable" for e in events)
    a = calfile.read(faulty / "calibration.yaml").accelerometer
    b = calfile.read(clean / "calibration.yaml").accelerometer
    # same hidden sensor, independent noise: equal within the combined uncertainty
    sig = np.hypot(a.sigma["bias_counts"], b.sigma["bias_counts"])
    assert np.all(np.abs(np.asarray(a.bias_counts) - b.bias_counts) < 5 * sig)


def test_stuck_sensor_data_is_re_measured_then_flagged_never_used(tmp_path, capsys):
    rig = _rig_file(tmp_path, "faults:\n  sensor: {stuck_after_s: 40}\n")
    code = main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "s"), "--quiet"])
    err = capsys.readouterr().err
    d = _only_session(tmp_path / "s")
    m = yaml.safe_load((d / "session.yaml").read_text())
    flagged = [s for s in m["steps"] if s["status"] == "flagged"]
    assert flagged, "stuck data must not be accepted"
    assert all(any("stuck" in p for p in s["stats"]["problems"]) for s in flagged)
    assert all(s["stats"]["attempts"] == 3 for s in flagged)
    # with too few good poses left there is no calibration, and the run says why
    assert code == 1 and "flagged" in err and not (d / "calibration.yaml").exists()


def test_random_i2c_errors_are_retried_and_logged(tmp_path):
    rig = _rig_file(tmp_path, "faults:\n  sensor: {oserror_rate: 0.01, seed: 2}\n")
    assert main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "s"), "--quiet"]) == 0
    events = [json.loads(x) for x in (_only_session(tmp_path / "s") / "events.jsonl").read_text().splitlines()]
    assert any(e.get("source") == "sensor" and "retried" in e.get("message", "") for e in events)


def test_a_chip_that_stops_answering_aborts_with_one_line(tmp_path, capsys):
    rig = _rig_file(tmp_path, "faults:\n  sensor: {dead_after_s: 30}\n")
    assert main(["run", SIX, "--rig", str(rig), "--out", str(tmp_path / "s"), "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    errors = [line for line in err if line.startswith("rig run:")]
    assert len(errors) == 1 and "MPU-9150 at 0x68" in errors[0] and errors[0] == err[-1]
    # it was measured again before giving up, and said so
    assert sum("measuring again" in line for line in err) == 2
    assert yaml.safe_load((_only_session(tmp_path / "s") / "session.yaml").read_text())["status"] == "aborted"


def _spawn(args, ignore_sigint=False, **kw):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    if ignore_sigint:  # as a background job of a non-interactive shell starts
        kw["preexec_fn"] = lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)
    return subprocess.Popen([sys.executable, "-X", "faulthandler", "-m", "rig.cli", *args], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _wait_for_steps(root: Path, n: int, proc, timeout_s: float = 60) -> Path:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if root.exists():
            for d in root.iterdir():
                try:  # the manifest with the steps journal folded in (steps.jsonl: a line per finished step)
                    info, _ = SessionManifest.load(d)
                except (OSError, RigInputError):
                    continue
                if sum(s.status == "complete" for s in info.steps) >= n:
                    return d
        if proc.poll() is not None:
            raise AssertionError(f"run ended early: {proc.stderr.read()}")
        time.sleep(0.02)
    raise AssertionError("run did not get that far")


@pytest.mark.realtime
@pytest.mark.parametrize("after_steps", [1, 3])
def test_kill_9_then_resume_keeps_every_step_once_and_solves(tmp_path, after_steps, complete_six):
    out = tmp_path / "s"
    proc = _spawn(["run", SIX, "--out", str(out), "--seed", "21", "--time-scale", SIGNALLED_TIME_SCALE, "--quiet"])
    d = _wait_for_steps(out, after_steps, proc)
    proc.kill()
    proc.wait()
    assert yaml.safe_load((d / "session.yaml").read_text())["status"] == "running"  # it never got to say
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    s = load_session(d)
    assert s.info.to_dict()["status"] == "complete"
    for step in s.info.to_dict()["steps"]:
        n = len(s.step_samples(step["index"])["t_s"])
        assert n == 1000, f"step {step['index']} has {n} samples"
    t = s.samples["t_s"]
    assert np.all(np.diff(t[s.samples["step"] == 0]) > 0)
    events = [json.loads(x)["kind"] for x in (d / "events.jsonl").read_text().splitlines()]
    assert "resume" in events
    cal = calfile.read(d / "calibration.yaml").accelerometer
    ref = calfile.read(complete_six / "calibration.yaml").accelerometer  # the same sensor, never interrupted
    sig = np.hypot(cal.sigma["scale_counts_per_g"], ref.sigma["scale_counts_per_g"])
    assert np.all(np.abs(np.asarray(cal.scale_counts_per_g) - ref.scale_counts_per_g) < 5 * sig)


@pytest.mark.realtime
@pytest.mark.parametrize("how", ["ctrl-c", "ctrl-c, started with SIGINT ignored", "sigterm"])
def test_ctrl_c_stops_promptly_marks_aborted_and_the_run_resumes(tmp_path, how):
    out = tmp_path / "s"
    proc = _spawn(["run", SIX, "--out", str(out), "--seed", "5", "--time-scale", SIGNALLED_TIME_SCALE, "--quiet"],
                  ignore_sigint="ignored" in how)
    d = _wait_for_steps(out, 1, proc)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM if how == "sigterm" else signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)  # faulthandler dumps every thread's stack to stderr
        _, err = proc.communicate()
        raise AssertionError(f"rig run did not stop after Ctrl-C; its stacks:\n{err[-6000:]}") from None
    elapsed = time.monotonic() - t0
    events = (d / "events.jsonl").read_text().splitlines()[-8:]
    assert elapsed < 5.0, f"took {elapsed:.1f} s to stop; stderr: {err!r}; last events: {events}"
    assert proc.returncode == 1
    assert "aborted" in err and "--resume" in err and len(err.strip().splitlines()) == 1
    m = yaml.safe_load((d / "session.yaml").read_text())
    assert m["status"] == "aborted"
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    assert yaml.safe_load((d / "session.yaml").read_text())["status"] == "complete"


def test_resuming_a_complete_session_is_refused(tmp_path, capsys, complete_six):
    d = tmp_path / complete_six.name
    shutil.copytree(complete_six, d)
    assert main(["run", "--resume", str(d), "--time-scale", "0"]) == 2
    assert "already complete" in capsys.readouterr().err


@pytest.mark.realtime
def test_a_resume_on_another_sensor_or_rig_file_is_refused_before_anything_is_touched(tmp_path, capsys):
    out = tmp_path / "s"
    proc = _spawn(["run", SIX, "--out", str(out), "--seed", "21", "--time-scale", SIGNALLED_TIME_SCALE, "--quiet"])
    d = _wait_for_steps(out, 1, proc)
    proc.kill()
    proc.wait()
    before = {p.name: p.read_bytes() for p in d.iterdir() if p.name != "session.lock"}
    other_rig = tmp_path / "other.yaml"
    other_rig.write_text((RIGS / "sim.yaml").read_text().replace("initial_c: 27.6", "initial_c: 20.0"))
    for extra, why in ((["--seed", "22"], "seed 22 (recorded 21)"), (["--rig", str(other_rig)], "rig file")):
        assert main(["run", "--resume", str(d), "--time-scale", "0", *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        warnings = [line for line in err[:-1] if not line.startswith("warning: took over the lock of pid")]
        assert not warnings and "cannot resume on another rig or sensor" in err[-1] and why in err[-1], err
    assert {p.name: p.read_bytes() for p in d.iterdir() if p.name != "session.lock"} == before
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0  # the same rig still resumes


@pytest.mark.realtime
def test_a_second_ctrl_c_does_not_cut_the_cleanup_short(tmp_path):
    """Technicians press Ctrl-C twice. The second one, while the motors stop and the session is
    closed, only says "please wait": the session is still closed as aborted and resumable, and the
    last line is the real resume command."""
    out = tmp_path / "s"
    proc = _spawn(["run", SIX, "--out", str(out), "--seed", "5", "--time-scale", SIGNALLED_TIME_SCALE, "--quiet"])
    d = _wait_for_steps(out, 1, proc)
    proc.send_signal(signal.SIGINT)
    for _ in range(3):
        time.sleep(0.01)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    lines = err.strip().splitlines()
    assert proc.returncode == 1, err
    assert lines[-1].startswith("rig run: aborted") and lines[-1].endswith(f"Resume with: rig run --resume {d}"), lines
    assert all(line == lines[-1] or "please wait" in line for line in lines), lines
    assert yaml.safe_load((d / "session.yaml").read_text())["status"] == "aborted"
    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    assert yaml.safe_load((d / "session.yaml").read_text())["status"] == "complete"


def test_solving_an_incomplete_session_says_so_and_the_calibration_file_records_it(tmp_path, capsys, complete_six):
    rig = _rig_file(tmp_path, "faults:\n  sensor: {dead_after_s: 130}\n")
    assert main(["run", str(PROCEDURES / "twelve_position.yaml"), "--rig", str(rig), "--out", str(tmp_path / "s"),
                 "--quiet"]) == 1
    d = _only_session(tmp_path / "s")
    pending = [s for s in yaml.safe_load((d / "session.yaml").read_text())["steps"] if s["status"] == "pending"]
    assert pending
    capsys.readouterr()
    assert main(["solve", str(d)]) == 0
    err = capsys.readouterr().err
    assert "the session is incomplete (aborted)" in err and f"{pending[0]['index'] + 1} ({pending[0]['name']})" in err
    cov = calfile.read(d / "calibration.yaml").coverage
    assert cov["complete"] is False and cov["status"] == "aborted" and cov["steps_planned"] == 12
    assert cov["pending_steps"][0] == f"{pending[0]['index'] + 1} ({pending[0]['name']})"
    assert cov["steps_recorded"] == 12 - len(pending) - sum(
        s["status"] == "failed" for s in yaml.safe_load((d / "session.yaml").read_text())["steps"])
    # a complete session writes no coverage section
    assert calfile.read(complete_six / "calibration.yaml").coverage is None
