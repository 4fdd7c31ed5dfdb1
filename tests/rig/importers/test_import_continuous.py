"""A magnetometer turned by hand without rests has a route from the command line (issue 32 item 3):
``rig import --from csv REC --continuous`` makes one turning step, ``rig solve`` fits the field ellipsoid on
its samples, within 3 sigma of the truth; without the option the import names it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from rig.analysis.solve import solve_present_sensors
from rig.session import load_session

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "calib"))
from mag_turning import turning_recording
from cli_run import rig_in_process as _rig


def _write(path: Path, rec: dict, label: bool = False) -> Path:
    rows = [f"{t:.3f},{m[0]:.3f},{m[1]:.3f},{m[2]:.3f}" + (",turn" if label else "")
            for t, m in zip(rec["t_s"], rec["m_ut"])]
    path.write_text("# mag_units: uT\nt_s,mx,my,mz" + (",label" if label else "") + "\n" + "\n".join(rows) + "\n")
    return path


def test_a_turning_magnetometer_imports_as_one_turning_step_and_solves_within_3_sigma(tmp_path):
    rec = turning_recording(6, seconds=30.0)
    code, out, err = _rig("import", "--from", "csv", _write(tmp_path / "turn.csv", rec), "-o", tmp_path / "s",
                          "--continuous", "--id", "turn")
    assert code == 0, err
    assert "1 steps (0 static, 0 with known poses) from one turning step (--continuous)" in out
    assert f"next: rig solve {tmp_path / 's' / 'turn'}" in out
    mag = solve_present_sensors(load_session(tmp_path / "s" / "turn")).magnetometer
    assert mag["method"] == "ellipsoid" and mag["n_steps"] == 1
    sigma = np.array([mag["sigma"][f"hard_iron_{c}"] for c in "xyz"])
    assert np.all(np.abs(np.array(mag["hard_iron_ut"]) - rec["b"]) < 3 * sigma)
    assert 0.7 < mag["chi2_per_dof"] < 1.3  # weighed by the noise measured from the samples
    code, out, err = _rig("solve", tmp_path / "s" / "turn")
    assert code == 0 and "magnetometer (ellipsoid): 1 step, residual" in out, err
    # no site stated: the residual is a fraction of the field's magnitude, said so (not "uT")
    assert "of the field's magnitude rms (unknown" in out


def test_without_the_option_the_import_says_no_rests_were_found_and_names_it(tmp_path):
    code, out, err = _rig("import", "--from", "csv", _write(tmp_path / "turn.csv", turning_recording(6, seconds=20.0)),
                          "-o", tmp_path / "s")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert "no steps found in the recording (quasi-static detection on the magnetometer" in err
    assert "imported with --continuous" in err


def test_the_option_with_labels_or_another_format_is_refused_in_one_line(tmp_path):
    rec = turning_recording(6, seconds=5.0)
    code, _, err = _rig("import", "--from", "csv", _write(tmp_path / "l.csv", rec, label=True), "-o", tmp_path / "s",
                        "--continuous")
    assert code == 2 and "label: --continuous takes the whole recording as one turning step" in err
    assert len(err.strip().splitlines()) == 1
    code, _, err = _rig("import", "--from", "imucal", tmp_path / "l.csv", "-o", tmp_path / "s", "--continuous")
    assert code == 2 and "--continuous applies to --from csv only" in err


def test_a_session_without_an_accelerometer_refuses_what_it_cannot_give_in_one_line(tmp_path):
    rec = turning_recording(7, seconds=10.0)
    assert _rig("import", "--from", "csv", _write(tmp_path / "t.csv", rec), "-o", tmp_path / "s", "--continuous",
                "--id", "t")[0] == 0
    session = tmp_path / "s" / "t"
    # a file asked for that cannot be written (rig-calibration/1 holds an accelerometer): exit 2, never exit 0 without it
    code, out, err = _rig("solve", session, "-o", tmp_path / "mag.yaml")
    assert code == 2 and not (tmp_path / "mag.yaml").exists() and len(err.strip().splitlines()) == 1
    assert "has no accelerometer data" in err and "--json > FILE" in err
    code, _, err = _rig("report", session)  # no loop back to 'run rig solve first'
    assert code == 2 and "no calibration file to report" in err and "run `rig solve" not in err
    code, _, err = _rig("discover", session)
    assert code == 2 and "searches the accelerometer's model" in err and len(err.strip().splitlines()) == 1
