"""Step numbers in messages (issue 34 item 9): a step is counted from 1 in everything rig says ("step 3"), the files
hold its index from 0 (samples.csv's ``step`` column, session.yaml's ``steps[i].index``); a message that points
into samples.csv names both, ``step 3 (index 2 in samples.csv)``, never a bare number that could be either."""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest
import yaml

from rig.errors import SessionFormatError
from rig.session import load_session
from rig.workflow.run import run_procedure

from conftest import REPO

#: "step N" that is not followed by the index it has in the file
BARE = re.compile(r"\bstep (\d+)(?! \(index \d+ in samples\.csv\)| is index \d+)")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec")
    return run_procedure(str(REPO / "procedures" / "six_position.yaml"), out_dir=out, seed=5,
                         time_scale=0).session_dir


def _copy(recorded, tmp_path, rows=None, manifest=None):
    d = tmp_path / "s"
    shutil.copytree(recorded, d)
    if rows is not None:
        lines = (d / "samples.csv").read_text().splitlines(keepends=True)
        (d / "samples.csv").write_text("".join(rows(lines)))
    if manifest is not None:
        doc = yaml.safe_load((d / "session.yaml").read_text())
        manifest(doc)
        (d / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return d


def _step(line: str) -> int:
    return int(line.split(",")[1])


def _refused(d) -> str:
    with pytest.raises(SessionFormatError) as e:
        load_session(d)
    msg = str(e.value)
    assert "\n" not in msg
    for n in BARE.findall(msg):  # every step number in the line is 1-based and says its index
        pytest.fail(f"step {n} without its index in samples.csv: {msg}")
    return msg


def _shown(msg: str) -> list[tuple[int, int]]:
    return [(int(a), int(b)) for a, b in re.findall(r"step (\d+) \(index (\d+) in samples\.csv\)", msg)]


def test_rows_duplicated_name_the_step_and_its_index(recorded, tmp_path):
    msg = _refused(_copy(recorded, tmp_path, rows=lambda ls: ls + [ln for ln in ls[1:] if _step(ln) == 2]))
    assert _shown(msg) == [(3, 2)] and "2000 rows, but the manifest recorded 1000" in msg, msg


def test_a_contradicting_pose_names_the_step_and_its_index(recorded, tmp_path):
    def swap_z_up_and_x_up(doc):
        doc["steps"][0]["f_nominal"], doc["steps"][1]["f_nominal"] = doc["steps"][1]["f_nominal"], [0, 0, 1]
    msg = _refused(_copy(recorded, tmp_path, manifest=swap_z_up_and_x_up))
    assert _shown(msg) == [(1, 0)] and "the data of +Z up read gravity" in msg, msg


def test_a_row_of_no_step_names_the_index_the_file_holds(recorded, tmp_path):
    msg = _refused(_copy(recorded, tmp_path, rows=lambda ls: ls + [ls[-1].replace(",5,", ",6,", 1)]))
    assert msg.endswith("step: index 6 is no step of the manifest (its 6 steps are indices 0..5: step 1 is index 0)")


def test_a_complete_step_without_samples_names_the_step_and_its_index(recorded):
    session = load_session(recorded)
    step = session.samples["step"]
    keep = step != 3
    keep[np.flatnonzero(step == 3)[0]] = True  # one row of step 4 is left
    session.samples = {k: v[keep] for k, v in session.samples.items()}
    with pytest.raises(SessionFormatError) as e:
        session.step_means()
    msg = str(e.value)
    assert not BARE.findall(msg), msg
    assert _shown(msg) == [(4, 3)] and "marked complete in session.yaml but has 1 samples" in msg, msg
