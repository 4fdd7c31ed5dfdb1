"""A resume verifies, then acts (issue 34 item 1): ``samples.csv`` is checked against the finished steps before
any file is touched, and any disagreement is refused with one line naming the file, the step and the numbers
(exit 2), every file byte-identical. ``rig repair`` cuts back only what is provably past the last finished step
(the rows of the step in progress, a torn last line), after a backup, and refuses anything else.

One aborted six-position session (three steps finished, seed 4, virtual time) is recorded once; each test
edits a copy of it.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from rig.cli import main
from rig.errors import SessionFormatError
from rig.execution.context import RunAborted
from rig.execution.operator import SilentOperator
from rig.session import SessionManifest, SessionWriter, load_session
from rig.session.lock import SessionLock
from rig.workflow.run import run_procedure

from conftest import PROCEDURES

ROWS = 1000  # six_position.yaml: 10 s at 100 Hz


class CtrlCAtStep:
    """An operator who presses Ctrl-C as step ``index`` (0-based) starts."""

    def __init__(self, index: int) -> None:
        self.index = index
        self.inner = SilentOperator()

    def progress(self, progress) -> None:
        if progress.index == self.index:
            raise KeyboardInterrupt

    def __getattr__(self, name):
        return getattr(self.inner, name)


@pytest.fixture(scope="module")
def aborted(tmp_path_factory) -> Path:
    """Three of six steps finished, then Ctrl-C (read only: copy it to change it)."""
    out = tmp_path_factory.mktemp("aborted")
    with pytest.raises(RunAborted) as exc:
        run_procedure(str(PROCEDURES / "six_position.yaml"), out_dir=out, seed=4, time_scale=0, ui=CtrlCAtStep(3))
    return exc.value.session_dir


@pytest.fixture
def session(aborted, tmp_path) -> Path:
    d = tmp_path / aborted.name
    shutil.copytree(aborted, d)
    return d


def files(d: Path) -> dict[str, bytes]:
    """Every file of the session but the lock (taken by whoever tries), by name."""
    return {p.name: p.read_bytes() for p in sorted(d.iterdir()) if p.name != "session.lock"}


def lines(d: Path) -> list[bytes]:
    return (d / "samples.csv").read_bytes().splitlines(keepends=True)


def rows_of(d: Path, index: int) -> list[bytes]:
    return [x for x in lines(d)[1:] if x.split(b",")[1] == str(index).encode()]


def append_rows(d: Path, index: int, n: int, torn: bytes = b"") -> None:
    """``n`` rows of step ``index`` (copies of step 1's, renumbered) and a torn last line, as a crash leaves them."""
    rows = [re.sub(rb"^([^,]*),0,", rb"\g<1>," + str(index).encode() + b",", x) for x in rows_of(d, 0)[:n]]
    with open(d / "samples.csv", "ab") as fh:
        fh.write(b"".join(rows) + torn)


def set_committed(d: Path, value: int) -> None:
    text = (d / "session.yaml").read_text()
    new = re.sub(r"(?m)^samples_committed_bytes: \d+$", f"samples_committed_bytes: {value}", text)
    assert new != text
    (d / "session.yaml").write_text(new)


def committed(d: Path) -> int:
    return SessionManifest.load(d)[0].samples_committed_bytes


def resume(d: Path) -> int:
    return main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"])


def refused(capsys, code: int) -> str:
    """The one stderr line of a refusal (exit 2)."""
    err = [x for x in capsys.readouterr().err.strip().splitlines() if not x.startswith("warning: took over the lock")]
    assert code == 2 and len(err) == 1, err
    return err[0]


# -- resume ---------------------------------------------------------------------------------------------------
def test_committed_bytes_of_zero_are_refused_and_every_file_is_left_byte_identical(session, capsys):
    append_rows(session, 3, 40)  # the step in progress had written rows: today's resume cut the file to 0 bytes
    set_committed(session, 0)
    before = files(session)
    line = refused(capsys, resume(session))
    assert "session.yaml: samples_committed_bytes: 0, but the 3 finished steps' 3000 rows end at byte" in line, line
    assert files(session) == before


def test_ten_rows_of_a_finished_step_missing_are_refused_naming_the_step(session, capsys):
    gone = rows_of(session, 1)[500:510]
    kept = [x for x in lines(session) if x not in gone]
    (session / "samples.csv").write_bytes(b"".join(kept))
    append_rows(session, 3, 60)  # the step in progress: the file is longer than committed, as a crash leaves it
    before = files(session)
    line = refused(capsys, resume(session))
    assert "samples.csv: step 2 (index 1 in samples.csv): 990 rows, but the manifest recorded 1000 samples" in line, line
    assert files(session) == before


def test_rows_of_the_step_in_progress_and_a_torn_line_are_cut_and_the_resume_goes_on(session, capsys):
    end = committed(session)
    append_rows(session, 3, 25, torn=b"42.01,3,1")
    assert resume(session) == 0
    s = load_session(session)
    assert s.info.status == "complete" and [s.step_samples(i)["t_s"].size for i in range(6)] == [ROWS] * 6
    events = [json.loads(x) for x in (session / "events.jsonl").read_text().splitlines()]
    cut = [e for e in events if e["kind"] == "warning" and "discarded" in e.get("message", "")]
    assert len(cut) == 1 and "25 rows of step 4" in cut[0]["message"] and "torn last line of 9 bytes" in cut[0]["message"]
    assert (session / "samples.csv").read_bytes()[end:end + 4] != b"42.0"  # cut at the committed point, then on
    assert not (session / "steps.jsonl").exists()


@pytest.mark.parametrize("edit,expect", [
    (lambda d: append_rows(d, 4, 10), "samples.csv:3032: step 5 (index 4 in samples.csv): a row of step 5, which the manifest records as pending"),
    (lambda d: set_committed(d, committed(d) + 70), "samples_committed_bytes: "),
    (lambda d: (d / "samples.csv").write_bytes(lines(d)[0].replace(b"ax,ay", b"ay,ax") + b"".join(lines(d)[1:])),
     "samples.csv:1: the header is 't_s,step,ay,ax,az"),
    (lambda d: (d / "samples.csv").write_bytes(b"".join(lines(d) + rows_of(d, 2)[:3])),
     "samples.csv: step 3 (index 2 in samples.csv): 1003 rows, but the manifest recorded 1000 samples"),
    (lambda d: (d / "samples.csv").write_bytes(b"".join(lines(d)[:1500])), "samples.csv: step 2 (index 1 in samples.csv): 499 rows"),
])
def test_any_other_disagreement_is_refused_with_one_line_and_nothing_touched(session, capsys, edit, expect):
    append_rows(session, 3, 30)
    edit(session)
    before = files(session)
    line = refused(capsys, resume(session))
    assert expect in line and "nothing was changed" in line, line
    assert files(session) == before


def test_the_writer_itself_refuses_before_touching_anything(session):
    set_committed(session, 0)
    before = files(session)
    with pytest.raises(SessionFormatError, match="samples_committed_bytes: 0, but the 3 finished steps"):
        SessionWriter.resume(session)
    assert files(session) == before


# -- rig repair -----------------------------------------------------------------------------------------------
def repair(d: Path) -> int:
    return main(["repair", str(d)])


def test_repair_refuses_committed_bytes_of_zero_and_writes_no_backup(session, capsys):
    append_rows(session, 3, 40)
    set_committed(session, 0)
    before = files(session)
    line = refused(capsys, repair(session))
    assert "samples_committed_bytes: 0, but the 3 finished steps' 3000 rows end at byte" in line, line
    assert files(session) == before


def test_repair_refuses_a_finished_step_with_rows_missing(session, capsys):
    gone = set(rows_of(session, 1)[:10])
    (session / "samples.csv").write_bytes(b"".join(x for x in lines(session) if x not in gone))
    before = files(session)
    line = refused(capsys, repair(session))
    assert "samples.csv: step 2 (index 1 in samples.csv): 990 rows, but the manifest recorded 1000 samples" in line, line
    assert files(session) == before


def test_repair_cuts_the_step_in_progress_after_a_backup_and_says_what_it_cut(session, capsys):
    end = committed(session)
    append_rows(session, 3, 25, torn=b"42.01,3,1")
    original = (session / "samples.csv").read_bytes()
    assert repair(session) == 0
    out = capsys.readouterr().out
    backups = list(session.glob("samples.csv.bak-*"))
    assert len(backups) == 1 and re.fullmatch(r"samples\.csv\.bak-\d{8}T\d{6}Z", backups[0].name)
    assert backups[0].read_bytes() == original
    assert (session / "samples.csv").read_bytes() == original[:end]
    assert f"cut {len(original) - end} bytes of samples.csv past its 3 finished steps: 25 rows of step 4 (in progress" in out, out
    assert "a torn last line of 9 bytes" in out and str(backups[0]) in out and "rig run --resume" in out
    assert load_session(session).info.status == "aborted"
    assert resume(session) == 0 and load_session(session).info.status == "complete"


def test_repair_of_a_clean_session_cuts_nothing(session, capsys):
    before = files(session)
    assert repair(session) == 0
    assert "nothing to cut" in capsys.readouterr().out
    assert files(session) == before


def test_repair_cuts_a_torn_journal_line_too(session, capsys):
    (session / "steps.jsonl").write_bytes(b'{"index":3,"status":"comp')  # a crash while step 4 was recorded
    append_rows(session, 3, 5)
    assert repair(session) == 0
    out = capsys.readouterr().out
    assert "and a torn last line of steps.jsonl (25 bytes" in out, out
    assert (session / "steps.jsonl").read_bytes() == b""
    assert len(list(session.glob("steps.jsonl.bak-*"))) == 1


def test_repair_waits_for_nobody_a_session_being_recorded_is_refused(session, capsys):
    before = files(session)
    with SessionLock(session):
        assert repair(session) == 1
    assert "being recorded by pid" in capsys.readouterr().err
    assert files(session) == before
