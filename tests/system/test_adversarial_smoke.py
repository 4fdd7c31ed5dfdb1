"""A fast subset of the adversarial campaign (`benchmarks/bench_adversarial.py`) as a regression test.

Thirty-five representative bad (and valid-but-odd) inputs across procedures, rig files, sessions, calibration
files, imports and options, each run as `python -m rig.cli ...` and classified exactly as the campaign does
(exit 2 with one stderr line naming the input, no traceback, no silent wrong number; exit 0 and the clean
calibration for BOM/CRLF; exit 0 with a warning for a torn line of the step in progress), one of each class
fixed since, plus one kill -9 then --resume trial and one concurrent-resume trial.
Only inputs the campaign handles correctly today are listed; the rest are in the campaign's report.
"""

from __future__ import annotations

import importlib.util
import random
import signal
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest

from conftest import REPO

_spec = importlib.util.spec_from_file_location("bench_adversarial", REPO / "benchmarks" / "bench_adversarial.py")
bench = importlib.util.module_from_spec(_spec)
sys.modules["bench_adversarial"] = bench
_spec.loader.exec_module(bench)

#: (family, case name) of the campaign's inputs
SMOKE = [
    ("procedure", "billion-laughs alias bomb"),
    ("procedure", "python object tag"),
    ("procedure", "duplicate key dwell"),
    ("procedure", "binary garbage"),
    ("procedure", "settle.window_s = 60"),
    ("procedure", "sensor.model = \"ADXL345\""),
    ("rig file", "faults.ximc.a1.crc_corrupt_rate = 1.5"),
    ("rig file", "turntable.axes.a1.speed_deg_s = 100"),
    ("samples.csv", "step index 1.5 [evaluate]"),
    ("samples.csv", "NaN count in ax [solve]"),
    ("samples.csv", "BOM and CRLF [solve]"),
    ("session.yaml", "format rig-session/2 [solve]"),
    ("calibration", "CRLF line endings [apply]"),
    ("calibration", "bias a word [evaluate]"),
    ("import", "imucal: x_p rows read -1 g (mislabelled part)"),
    ("import", "csv: decreasing time stamps"),
    ("option", "--seed -1"),
    ("option", "--time-scale nan"),
    ("option", "sim --count 0"),
    ("option", "bare rig"),
    ("option", "solve --model full --method flip"),
    # one per class fixed after the campaign's 534/553 run
    ("rig file", 'name = ""'),
    ("rig file", "faults.sensor.oserror_rate = a list of words"),
    ("rig file", "sim.errors.bias_g = [0.1, 0.2]"),
    ("option", "solve --thermal 1 on a 0.0 C span"),
    ("samples.csv", "ax and ay data swapped (header unchanged) [evaluate]"),
    ("session.yaml", "accel_range_g 3 [solve]"),
    ("session.yaml", "f_nominal 5 g [apply]"),
    ("session.yaml", "accel_lsb_per_g 1e300 [replay]"),
    ("session.yaml", "procedure.text a bomb [replay]"),
    ("session dir", "session directory a symlink loop [solve]"),
    ("calibration", "symlink loop [apply]"),
    ("import", "csv: a symlink loop"),
    ("samples.csv", "torn last line inside a finished step (rows lost) [solve]"),
    ("samples.csv", "torn last line in the step in progress (aborted session) [solve]"),
]


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    return bench.Workspace(tmp_path_factory.mktemp("adversarial"))


def _all_cases(ws):
    return (bench.procedure_cases(ws) + bench.rig_cases(ws) + bench.session_cases(ws, random.Random(0), False)
            + bench.calibration_cases(ws, False) + bench.import_cases(ws) + bench.option_cases(ws))


def test_representative_bad_inputs_are_refused_with_one_line(ws):
    by_key = {}
    for c in _all_cases(ws):
        by_key.setdefault((c.family, c.name), c)
    missing = [k for k in SMOKE if k not in by_key]
    assert not missing, f"campaign cases renamed or gone: {missing}"
    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(bench.run_case, [by_key[k] for k in SMOKE]))
    bad = [f"{c.family}: {c.name}: {c.result['category']} {c.result.get('why', '')} (exit {c.result['code']}: "
           f"{c.result['first']}) $ {c.command()}" for c in results if c.result["category"] != "correct"]
    assert not bad, "\n".join(bad)


def test_kill_9_then_resume_keeps_every_step_exactly_once(ws, tmp_path):
    c = bench.signal_trial(tmp_path, 0, signal.SIGKILL, 9.0, ws.ref)
    assert c.result["category"] == "correct", (c.result, c.command())


def test_concurrent_resumes_one_proceeds_the_other_names_the_holder(ws, tmp_path):
    c = bench.concurrent_resume_trial(tmp_path, 0, 8.0, ws.ref)
    assert c.result["category"] == "correct", (c.result, c.command())
