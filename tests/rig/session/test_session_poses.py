"""A session whose data contradict its own manifest is refused on load, naming the file and the first
contradicting step, never solved or evaluated into a wrong number: ax/ay swapped under an unchanged header,
a sign-flipped axis, poses swapped in session.yaml, an f_nominal that is not 1 g, a range or sensitivity the
recorded chip does not have. A torn last line is dropped only when it belongs to the step in progress."""

from __future__ import annotations

import re
import shutil

import pytest
import yaml

from rig.cli.main import main
from rig.errors import SessionFormatError
from rig.session import load_session
from rig.workflow.run import run_procedure

from conftest import REPO


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec")
    return run_procedure(str(REPO / "procedures" / "six_position.yaml"), out_dir=out, seed=5,
                         time_scale=0).session_dir


def _copy(recorded, tmp_path, samples=None, manifest=None):
    d = tmp_path / "s"
    shutil.copytree(recorded, d)
    if samples is not None:
        lines = (d / "samples.csv").read_text().splitlines(keepends=True)
        (d / "samples.csv").write_text("".join(samples(lines)))
    if manifest is not None:
        doc = yaml.safe_load((d / "session.yaml").read_text())
        manifest(doc)
        (d / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return d


def _swap(lines, a="ax", b="ay"):
    header = lines[0].strip().split(",")
    i, j = header.index(a), header.index(b)
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.rstrip("\n").split(",")
        cells[i], cells[j] = cells[j], cells[i]
        out.append(",".join(cells) + "\n")
    return out


def _negate(lines, column="az"):
    header = lines[0].strip().split(",")
    k = header.index(column)
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.rstrip("\n").split(",")
        cells[k] = str(-int(cells[k]))
        out.append(",".join(cells) + "\n")
    return out


def _refused(d) -> str:
    with pytest.raises(SessionFormatError) as e:
        load_session(d)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def test_ax_and_ay_swapped_under_an_unchanged_header_is_refused_naming_the_first_contradicting_step(recorded,
                                                                                                    tmp_path):
    msg = _refused(_copy(recorded, tmp_path, samples=_swap))
    # six_position: +Z up, +X up, ...: step 2 is the first whose gravity is not along z
    assert msg.startswith(f"{tmp_path / 's' / 'samples.csv'}: step 2 (index 1 in samples.csv): the data of +X up "
                          "read gravity along ["), msg
    assert re.search(r"along \[-?0\.0\d, 1\.0, -?0\.0\d\], (8\d|9\d) deg from its pose's f_nominal \[1\.0, 0\.0, 0\.0\]", msg)


def test_a_sign_flipped_axis_is_refused(recorded, tmp_path):
    msg = _refused(_copy(recorded, tmp_path, samples=_negate))
    assert "step 1 (index 0 in samples.csv): the data of +Z up" in msg and re.search(r"1[78]\d deg", msg), msg


def test_poses_swapped_in_the_manifest_are_refused(recorded, tmp_path):
    def swap(doc):
        doc["steps"][0]["f_nominal"], doc["steps"][2]["f_nominal"] = [0, 0, -1], [0, 0, 1]
    msg = _refused(_copy(recorded, tmp_path, manifest=swap))
    assert "samples.csv: step 1 (index 0 in samples.csv):" in msg and "f_nominal [0.0, 0.0, -1.0]" in msg, msg


def test_an_f_nominal_that_is_not_one_g_is_refused(recorded, tmp_path):
    msg = _refused(_copy(recorded, tmp_path, manifest=lambda doc: doc["steps"][0].update(f_nominal=[0, 0, 5])))
    assert msg.startswith(f"{tmp_path / 's' / 'session.yaml'}: steps[0].f_nominal: expected the specific force at "
                          "rest, a unit vector in g"), msg


@pytest.mark.parametrize("key,value,expect", [
    ("accel_range_g", 3, "rig.sensor.accel_range_g: expected one of 2, 4, 8, 16 (the MPU-9150's ranges, g), got 3"),
    ("accel_lsb_per_g", 1e300, "rig.sensor.accel_lsb_per_g: 1e+300 counts/g at 4 g"),
    ("accel_lsb_per_g", 16384.0, "rig.sensor.accel_lsb_per_g: 16384 counts/g at 4 g is a full scale of 6.55e+04"),
])
def test_a_range_or_sensitivity_the_chip_does_not_have_is_refused(recorded, tmp_path, key, value, expect):
    msg = _refused(_copy(recorded, tmp_path, manifest=lambda doc: doc["rig"]["sensor"].update({key: value})))
    assert msg.startswith(f"{tmp_path / 's' / 'session.yaml'}: {expect}"), msg


def test_evaluate_and_solve_refuse_swapped_columns_with_one_line(recorded, tmp_path, capsys):
    d = _copy(recorded, tmp_path, samples=_swap)
    assert main(["evaluate", str(recorded / "calibration.yaml"), str(d)]) == 2
    assert main(["solve", str(d), "-o", str(tmp_path / "c.yaml")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2 and all("samples.csv: step 2 (index 1 in samples.csv):" in line for line in lines), lines


def test_the_untouched_session_loads_and_every_step_agrees_with_its_pose(recorded):
    assert len(load_session(recorded).step_means()) == 6


def test_a_torn_last_line_in_a_finished_step_is_rows_lost(recorded, tmp_path):
    d = _copy(recorded, tmp_path)
    (d / "samples.csv").write_bytes((d / "samples.csv").read_bytes()[:-7])
    assert "step 6 (index 5 in samples.csv): 999 rows, but the manifest recorded 1000 samples (rows duplicated or lost)" in _refused(d)


def test_a_torn_last_line_in_the_step_in_progress_is_dropped_with_a_warning(recorded, tmp_path):
    def in_progress(doc):
        doc["status"] = "aborted"
        doc["steps"][5].update(status="pending")
        doc["steps"][5].pop("stats", None)
        doc.pop("seal")  # an unfinished session has no seal
    d = _copy(recorded, tmp_path, manifest=in_progress)
    (d / "samples.csv").write_bytes((d / "samples.csv").read_bytes()[:-7])
    s = load_session(d)
    assert len(s.warnings) == 1 and "dropped a torn last line" in s.warnings[0]
    assert len(s.step_means()) == 5
