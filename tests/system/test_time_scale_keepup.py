"""``rig run --time-scale K`` on a machine that cannot keep up (issue #13 item 3; issue #26: the strict clock
keeps this behaviour, the elastic default never loses a sample).

A time scale clearly beyond what this machine keeps up with is refused before a session exists (one
line, exit 2, the figure it does keep up with and what to use); a run whose simulated clock outruns
the machine during the run has the step measured again and, when every attempt loses samples, stops
there (exit 1, one line naming the clock, not the sensor), keeps what it recorded, and resumes slower
to a complete session with no hole.

Deterministic, not machine-speed dependent: a 1 kHz MPU-9150 at time scale 1000 (a million samples a
wall second into a 73-sample FIFO) is beyond any machine; for the stop during the run, the keep-up
probe is told the machine keeps up with anything (a machine that got busy after the run started).
"""

from __future__ import annotations

import json
import re

import pytest
import yaml

from conftest import RIGS, SIX_FACES_STEPS
from rig.cli import main
from rig.session import load_session
from rig.simulation import simulated

pytestmark = pytest.mark.realtime  # time-scaled clocks, strict and elastic, against this machine's pace

FAST = """format: rig-procedure/1
name: fast
sensor: {model: MPU-9150, accel_range_g: 4, sample_rate_hz: 1000}
dwell: {seconds: 1}
settle: {window_s: 0.3, threshold_g: 0.01, timeout_s: 20}
steps:
""" + SIX_FACES_STEPS + """solve: {model: triangular, method: pinv, thermal: "off"}
"""
KEEPS_UP = r"this machine keeps up with about [0-9.]+x for a 1 kHz MPU-9150; use --time-scale (?:[0-9.]+ or 0|0) " \
           r"\(virtual time\)$"


def _fast(tmp_path):
    p = tmp_path / "fast.yaml"
    p.write_text(FAST)
    return p


def test_a_time_scale_the_machine_cannot_keep_up_with_is_refused_before_a_session_exists(tmp_path, capsys):
    out = tmp_path / "sessions"
    assert main(["run", str(_fast(tmp_path)), "--time-scale", "1000", "--strict", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.match(r"^rig run: --time-scale 1000: " + KEEPS_UP, err[0]), err
    assert not out.exists() or not any(out.iterdir())


def test_a_rig_files_time_scale_is_refused_naming_the_file(tmp_path, capsys):
    rig = tmp_path / "rig.yaml"
    rig.write_text((RIGS / "sim.yaml").read_text().replace("time_scale: 10", "time_scale: 1000\n  clock: strict"))
    out = tmp_path / "sessions"
    assert main(["run", str(_fast(tmp_path)), "--rig", str(rig), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.match(rf"^rig run: {re.escape(str(rig))}: sim.time_scale 1000: " + KEEPS_UP, err[0]), err
    assert not out.exists() or not any(out.iterdir())


def test_a_run_that_loses_samples_to_the_clock_stops_then_resumes_slower_without_a_hole(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(simulated, "keeps_up_with", lambda *args: 1e9)  # measured fast; busy once running
    out = tmp_path / "sessions"
    assert main(["run", str(_fast(tmp_path)), "--time-scale", "1000", "--strict", "--out", str(out), "--seed", "2",
                 "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    (d,) = list(out.iterdir())
    *again, line = err  # measured twice more (a moment's load would pass), then stopped
    assert len(again) == 2 and all(w.startswith("warning: step 1 (+Z up): sensor FIFO overflowed ") and
                                   "outran this machine" in w and w.endswith("; measuring again") for w in again), err
    assert line.startswith("rig run: step 1 (+Z up): sensor FIFO overflowed "), line
    assert "the simulated clock (--time-scale 1000) outran this machine" in line
    assert "the simulated sensor itself lost nothing" in line and "run stopped (motors stopped, session kept)" in line
    resume = re.search(r"resume with: (rig run --resume (\S+) --time-scale ([0-9.]+))$", line)
    assert resume and resume.group(2) == str(d), line
    m = yaml.safe_load((d / "session.yaml").read_text())
    assert m["status"] == "aborted" and {s["status"] for s in m["steps"]} == {"pending"}
    abort = [json.loads(x) for x in (d / "events.jsonl").read_text().splitlines() if '"abort"' in x]
    assert abort and "SamplesLost" in abort[-1]["reason"] and "outran this machine" in abort[-1]["reason"]

    assert main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"]) == 0
    s = load_session(d)
    assert s.info.to_dict()["status"] == "complete"
    assert [st["status"] for st in s.info.to_dict()["steps"]] == ["complete"] * 6
    assert [len(s.step_samples(i)["t_s"]) for i in range(6)] == [1000] * 6
    assert (d / "calibration.yaml").is_file()


def test_on_the_default_elastic_clock_the_same_time_scale_completes_with_every_sample(tmp_path, capsys):
    # the scale refused above, and the machine far too slow for it: simulated time waits for the reader
    out = tmp_path / "sessions"
    assert main(["run", str(_fast(tmp_path)), "--time-scale", "1000", "--out", str(out), "--seed", "2",
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "overflow" not in err and "outran" not in err, err
    (d,) = list(out.iterdir())
    s = load_session(d)
    assert [st["status"] for st in s.info.to_dict()["steps"]] == ["complete"] * 6
    for i in range(6):
        t = s.step_samples(i)["t_s"]
        assert len(t) == 1000 and abs(max(t[1:] - t[:-1]) - 1e-3) < 1e-6  # contiguous: no sample lost
    assert (d / "calibration.yaml").is_file()
