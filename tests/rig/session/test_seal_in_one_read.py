"""A seal costs no second read (issue 25, "reads samples.csv once"; docs/session-format.md, "Seal").

The writer hashes what it writes as it writes it (:class:`rig.session.seal.Chains`): a step's link and the
seal come from those hashes, not from reading the files back. The reader checks a sealed session's
samples.csv on the read that loads it (:class:`rig.session.seal.SamplesCheck`). Both must give what the
file-reading forms give: the same seal, the same refusals.
"""

from __future__ import annotations

import shutil

import pytest
import yaml

from rig.session import SessionWriter, load_session
from rig.session.seal import SealBroken, seal_session, verify_session

from test_large_session_memory import make_thermal_session
from test_seal import _manifest, _write_steps, record

#: the seal's fields that depend on the files' content (not on when the seal was made)
CONTENT = ("samples_sha256", "samples_bytes", "chain", "events_sha256", "events_bytes", "manifest_sha256", "parts")


def _reseal_from_files(d) -> dict:
    """The session's seal made again the old way: session.yaml without its seal, then read from disk."""
    path = d / "session.yaml"
    doc = yaml.safe_load(path.read_text())
    doc.pop("seal")
    path.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return seal_session(d)


def test_the_seal_made_from_the_writers_hashes_is_the_seal_made_from_the_files(tmp_path):
    d = record(tmp_path / "a")
    kept = yaml.safe_load((d / "session.yaml").read_text())["seal"]
    again = _reseal_from_files(d)
    assert {k: kept[k] for k in CONTENT} == {k: again[k] for k in CONTENT}


def test_a_resumed_writer_hashes_the_files_it_reopens_and_seals_as_the_files_say(tmp_path):
    w = SessionWriter.create(tmp_path, "six", _manifest())
    _write_steps(w, range(3))
    w.set_status("aborted")
    w, first = SessionWriter.resume(tmp_path / "six")
    assert first == 3
    _write_steps(w, range(3, 6))
    w.set_status("complete")
    kept = yaml.safe_load((tmp_path / "six" / "session.yaml").read_text())["seal"]
    assert verify_session(tmp_path / "six").sealed
    again = _reseal_from_files(tmp_path / "six")
    assert {k: kept[k] for k in CONTENT} == {k: again[k] for k in CONTENT}


def test_the_last_step_recorded_again_is_chained_from_the_step_before_it(tmp_path):
    w = SessionWriter.create(tmp_path, "six", _manifest())
    _write_steps(w, [0, 1, 2])
    _write_steps(w, [2])  # recorded again: its link covers both recordings, from where step 2's rows end
    _write_steps(w, [3, 4, 5])
    w.set_status("complete")
    steps = yaml.safe_load((tmp_path / "six" / "session.yaml").read_text())["steps"]
    assert steps[2]["stats"]["samples_bytes"][0] == steps[1]["stats"]["samples_bytes"][1]
    assert steps[3]["stats"]["samples_bytes"][0] == steps[2]["stats"]["samples_bytes"][1]
    assert verify_session(tmp_path / "six").steps == 6


@pytest.fixture(scope="module")
def big(tmp_path_factory):
    """A sealed 36-step session of 7.7 MB: samples.csv is read in several blocks (and counted first)."""
    return make_thermal_session(tmp_path_factory.mktemp("big"), "big", step_s=30.0)


def _flip_digit(path, at: int) -> None:
    """Change one count digit at about byte ``at`` (the row stays a valid row)."""
    data = bytearray(path.read_bytes())
    line = data.rindex(b"\n", 0, at) + 1
    comma = data.index(b",", data.index(b",", line) + 1) + 1  # the ax cell
    data[comma] = ord("1") if data[comma] != ord("1") else ord("2")
    path.write_bytes(bytes(data))


def test_a_sealed_session_read_in_blocks_loads_once_checked(big):
    assert (big / "samples.csv").stat().st_size > 3 * (2 << 20)
    s = load_session(big)
    assert len(s.samples["step"]) == 36 * 3000 and not s.warnings


@pytest.mark.parametrize("where, step", [(0.51, 18), (0.985, 35), (0.0001, 0)])
def test_a_changed_count_in_a_session_read_in_blocks_is_refused_naming_its_step(big, tmp_path, where, step):
    d = tmp_path / "big"
    shutil.copytree(big, d)
    path = d / "samples.csv"
    size = path.stat().st_size
    _flip_digit(path, max(int(size * where), 200))
    with pytest.raises(SealBroken) as err:
        load_session(d)
    assert f"step {step + 1} (index {step} in samples.csv)" in str(err.value)
    # the file-reading check (rig verify) names the same step on the same line
    with pytest.raises(SealBroken) as again:
        verify_session(d)
    assert str(again.value) == str(err.value)


def test_bytes_appended_to_a_session_read_in_blocks_are_refused(big, tmp_path):
    d = tmp_path / "big"
    shutil.copytree(big, d)
    with open(d / "samples.csv", "ab") as fh:
        fh.write(b"1080.00000,35,8192")  # what a torn last line looks like: the reader alone would drop it
    with pytest.raises(SealBroken, match="added after the recording was sealed"):
        load_session(d)
