"""``rig characterize`` on the simulated rig: a static recording's Allan deviation and noise terms, and a
recording too short for the terms asked refused in one line saying how long it must be (docs/noise.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rig.cli import main

PROCEDURES = Path(__file__).resolve().parents[2] / "procedures"


@pytest.fixture(scope="module")
def static_session(tmp_path_factory) -> Path:
    """procedures/allan.yaml cut to a 200 s dwell, recorded in virtual time."""
    root = tmp_path_factory.mktemp("allan")
    text = (PROCEDURES / "allan.yaml").read_text().replace("seconds: 7800", "seconds: 200")
    assert "seconds: 200" in text
    (root / "allan_short.yaml").write_text(text)
    assert main(["run", str(root / "allan_short.yaml"), "--seed", "4", "--time-scale", "0", "--out",
                 str(root / "sessions"), "--quiet"]) == 0
    return next((root / "sessions").iterdir())


def test_white_noise_of_every_axis_with_intervals_json_and_plot(static_session, tmp_path, capsys):
    capsys.readouterr()
    plot = tmp_path / "adev.png"
    assert main(["characterize", str(static_session), "--terms", "N", "--json", "--plot", str(plot)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["format"] == "rig-characterize/1" and doc["units"] == {"accel": "g", "gyro": "deg/s"}
    assert doc["step"] == 1 and 199 < doc["duration_s"] <= 200
    for sensor, (lo, hi) in {"accel": (250e-6, 450e-6), "gyro": (3e-3, 7e-3)}.items():
        for axis in "xyz":
            n = doc["axes"][sensor][axis]["terms"]["N"]
            assert lo < n["value"] < hi and n["ci95"][0] < n["value"] < n["ci95"][1]
    assert plot.stat().st_size > 10_000 and doc["plot"] == str(plot.resolve())


def test_the_report_names_each_term_with_its_interval(static_session, capsys):
    capsys.readouterr()
    assert main(["characterize", str(static_session), "--terms", "N"]) == 0
    out = capsys.readouterr().out
    assert "95 % intervals" in out and "  z: N " in out and "g/rtHz" in out and "chi2/dof" in out


def test_too_short_for_the_bias_terms_is_one_line_with_the_length_needed(static_session, capsys):
    capsys.readouterr()
    assert main(["characterize", str(static_session)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "lasts 200 s; fitting N, B, K needs at least 3600 s (1.0 h" in err


def test_bad_terms_and_a_step_that_is_not_static_are_refused(static_session, capsys):
    capsys.readouterr()
    assert main(["characterize", str(static_session), "--terms", "N,X"]) == 2
    assert main(["characterize", str(static_session), "--terms", "N", "--step", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "got 'N,X'" in err[0] and "step 0 is not a finished static step" in err[1]
