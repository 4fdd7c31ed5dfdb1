"""Safe outputs (issue 34 item 2): every output path of every command goes through one policy (rig.cli.outputs).

An output that is a device, a named pipe, a socket, a symbolic link (unless ``--follow``), a directory where a
file is expected, an empty path, an input of the command or a file of a session is refused with one line naming
the path given (exit 2) before anything is computed or written; ``-o -`` is standard output where the output is
text; a file written gets mode 0o666 & ~umask; an error while writing names the path given, never a temp file.
Every command runs in process (``rig.cli.main``); nothing outside ``tmp_path`` is touched.
"""

from __future__ import annotations

import errno
import fcntl
import os
import shutil
import socket
import stat
from pathlib import Path

import pytest

from rig.cli import main

from conftest import PROCEDURES

#: the sensor key part of the simulated sensor the module's run calibrated
SENSOR = "sim-seed-4"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A six-position session of the simulated rig (seed 4, virtual time), solved, and the history its run
    recorded into. Read only: tests copy it (:func:`lab`)."""
    out = tmp_path_factory.mktemp("safe-outputs")
    db = out / "history.sqlite"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(db))
        assert main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "4", "--time-scale", "0",
                     "--out", str(out / "s"), "--quiet"]) == 0
    (session,) = (out / "s").iterdir()
    return session, db


@pytest.fixture
def lab(recorded, tmp_path, monkeypatch):
    """A copy of the session (``S``), its calibration (``CAL``), a copy of the history (``DB``) and the history
    of this test's solves in ``tmp_path``."""
    session, db = recorded
    s = tmp_path / "sessions" / session.name
    shutil.copytree(session, s)
    shutil.copy(db, tmp_path / "history.sqlite")
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "solves.sqlite"))
    monkeypatch.chdir(tmp_path)  # a relative output lands here, never in the work tree
    return {"S": s, "CAL": s / "calibration.yaml", "DB": tmp_path / "history.sqlite"}


def rig(capsys, *args) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def refused(capsys, command: str, args, given) -> str:
    """``rig ARGS`` exits 2 with one line naming ``given`` (never a temp file); returns the line."""
    code, out, err = rig(capsys, *args)
    assert code == 2, (code, out, err)
    assert err.startswith(f"rig {command}: ") and err.count("\n") == 1, err
    assert str(given) in err and ".tmp" not in err, err
    return err


def snapshot(folder: Path) -> dict:
    """Every file under ``folder`` (links not followed) -> (kind, bytes of a regular file)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = os.lstat(p)
        out[str(p)] = (stat.S_IFMT(st.st_mode), p.read_bytes() if stat.S_ISREG(st.st_mode) else None)
    return out


#: every command that takes an output file: (name, option, args given the lab and the output path)
FILE_OUTPUTS = {
    "export": ("export", "-o", lambda L, x: ["export", L["CAL"], "--to", "px4", "-o", x]),
    "report": ("report", "-o", lambda L, x: ["report", L["S"], "-o", x, "--history", L["DB"]]),
    "solve": ("solve", "-o", lambda L, x: ["solve", L["S"], "-o", x]),
    "apply": ("apply", "-o", lambda L, x: ["apply", L["CAL"], L["S"], "-o", x]),
    "discover -o": ("discover", "-o", lambda L, x: ["discover", L["S"], "-o", x]),
    "discover --plot": ("discover", "--plot", lambda L, x: ["discover", L["S"], "--plot", x]),
    "discover --twin": ("discover", "--twin", lambda L, x: ["discover", L["S"], "--twin", x]),
    "history --plot": ("history", "--plot", lambda L, x: ["history", SENSOR, "--history", L["DB"], "--plot", x]),
}


def _special(kind: str, path: Path, request):
    """Make ``path`` a device node (root only), a FIFO (with a reader open, so no writer can block) or a socket."""
    if kind == "device":
        if os.geteuid() != 0:
            pytest.skip("a device node can be made by root only")
        os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 7))  # our own /dev/full, in tmp_path
    elif kind == "fifo":
        os.mkfifo(path)
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        fcntl.fcntl(fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), 1 << 20)  # room for a whole plot
        request.addfinalizer(lambda: os.close(fd))
    else:
        cwd = os.getcwd()
        os.chdir(path.parent)  # a socket's path is limited to 107 bytes: bind the short relative name
        try:
            sock = socket.socket(socket.AF_UNIX)
            sock.bind(path.name)
        finally:
            os.chdir(cwd)
        request.addfinalizer(sock.close)


@pytest.mark.parametrize("case", FILE_OUTPUTS)
@pytest.mark.parametrize("kind", ["device", "fifo", "socket"])
def test_a_device_fifo_or_socket_is_never_replaced_nor_written(lab, tmp_path, capsys, request, case, kind):
    command, option, args = FILE_OUTPUTS[case]
    target = tmp_path / "o.png"
    _special(kind, target, request)
    before = os.lstat(target)
    err = refused(capsys, command, args(lab, target), target)
    assert option in err
    after = os.lstat(target)
    assert (stat.S_IFMT(after.st_mode), after.st_ino) == (stat.S_IFMT(before.st_mode), before.st_ino)


@pytest.mark.parametrize("case", FILE_OUTPUTS)
def test_a_symlink_is_refused_without_follow_and_written_through_with_it(lab, tmp_path, capsys, case):
    command, option, args = FILE_OUTPUTS[case]
    outside = tmp_path / "elsewhere" / "real.png"
    outside.parent.mkdir()
    outside.write_text("keep me\n")
    link = tmp_path / "link.png"
    link.symlink_to(outside)
    err = refused(capsys, command, args(lab, link), link)
    assert "--follow" in err
    assert link.is_symlink() and outside.read_text() == "keep me\n"
    code, out, err = rig(capsys, *args(lab, link), "--follow")
    assert code == 0, err
    assert link.is_symlink() and os.readlink(link) == str(outside)  # the link stays, its file is written
    assert outside.read_bytes() != b"keep me\n" and outside.stat().st_size > 100


@pytest.mark.parametrize("name", ["stdout", "fd1"])
def test_a_link_to_standard_output_is_refused_and_stays_a_link(lab, tmp_path, capsys, name):
    link = tmp_path / name
    link.symlink_to("/dev/stdout" if name == "stdout" else "/proc/self/fd/1")
    refused(capsys, "export", ["export", lab["CAL"], "--to", "px4", "-o", link], link)
    assert link.is_symlink()


@pytest.mark.parametrize("case", FILE_OUTPUTS)
def test_a_directory_where_a_file_is_expected_or_an_empty_path_is_refused(lab, tmp_path, capsys, case):
    command, option, args = FILE_OUTPUTS[case]
    before = snapshot(tmp_path)
    err = refused(capsys, command, args(lab, ""), option)
    assert "empty" in err
    if case not in ("report", "discover --plot", "discover --twin", "history --plot"):  # these write inside one
        folder = tmp_path / "folder"
        folder.mkdir()
        refused(capsys, command, args(lab, folder), folder)
        folder.rmdir()
    assert snapshot(tmp_path) == before


#: an output that is an input of the command or a file of a session: (command, option, args given the lab)
CLOBBERS = {
    "export over its calibration": ("export", lambda L: ["export", L["CAL"], "--to", "px4", "-o", L["CAL"]]),
    "export over the samples": ("export", lambda L: ["export", L["CAL"], "--to", "px4", "-o", L["S"] / "samples.csv"]),
    "export through a hard link": ("export", lambda L: ["export", L["CAL"], "--to", "json", "-o", L["hard"]]),
    "report over the calibration": ("report", lambda L: ["report", L["S"], "-o", L["CAL"], "--history", L["DB"]]),
    "report over the history": ("report", lambda L: ["report", L["S"], "-o", L["DB"], "--history", L["DB"]]),
    "report into another session": ("report", lambda L: ["report", L["S"], "-o", L["S2"], "--history", L["DB"]]),
    "solve over the manifest": ("solve", lambda L: ["solve", L["S"], "-o", L["S"] / "session.yaml"]),
    "solve into another session": ("solve", lambda L: ["solve", L["S"], "-o", L["S2"] / "calibration.yaml"]),
    "apply over the samples": ("apply", lambda L: ["apply", L["CAL"], L["S"], "-o", L["S"] / "samples.csv"]),
    "apply over its calibration": ("apply", lambda L: ["apply", L["CAL2"], L["S"], "-o", L["CAL2"]]),
    "discover over the events": ("discover", lambda L: ["discover", L["S"], "-o", L["S"] / "events.jsonl"]),
    "discover over the run's calibration": ("discover", lambda L: ["discover", L["S"], "-o", L["CAL"]]),
    "discover's twin into the session": ("discover", lambda L: ["discover", L["S"], "--twin", L["S"]]),
    "history's plot into a session": ("history", lambda L: ["history", SENSOR, "--history", L["DB"],
                                                            "--plot", L["S"] / "p.png"]),
    "import into a session": ("import", lambda L: ["import", "--from", "csv", L["CSV"], "-o", L["S"]]),
    "import over its recording": ("import", lambda L: ["import", "--from", "csv", L["CSV"], "-o", L["CSV"]]),
}


@pytest.mark.parametrize("case", CLOBBERS)
def test_an_input_or_a_sessions_file_is_never_an_output(lab, tmp_path, capsys, case):
    command, args = CLOBBERS[case]
    lab["S2"] = tmp_path / "sessions" / "other"
    shutil.copytree(lab["S"], lab["S2"])
    lab["hard"] = tmp_path / "hard.json"
    os.link(lab["CAL"], lab["hard"])
    lab["CAL2"] = tmp_path / "cal2.yaml"
    shutil.copy(lab["CAL"], lab["CAL2"])
    lab["CSV"] = tmp_path / "recording.csv"
    lab["CSV"].write_text("ax,ay,az\n0,0,1\n")
    argv = args(lab)
    before = snapshot(tmp_path)
    refused(capsys, command, argv, argv[argv.index("-o" if "-o" in argv else argv[-2]) + 1])
    assert snapshot(tmp_path) == before


def test_each_command_writes_its_own_documented_output_in_its_session(lab, capsys):
    s = lab["S"]
    code, out, err = rig(capsys, "solve", s)  # calibration.yaml exists: the re-solve goes beside it
    assert code == 0, err and (s / "calibration-resolved.yaml").is_file()
    assert rig(capsys, "solve", s, "-o", s / "calibration-mine.yaml")[0] == 0
    assert rig(capsys, "discover", s, "-o", s / "calibration-discover.yaml")[0] == 0
    assert rig(capsys, "report", s, "--history", lab["DB"])[0] == 0 and (s / "report.html").is_file()
    assert rig(capsys, "report", s, "-o", s, "--history", lab["DB"])[0] == 0
    assert (s / f"{s.name}-report.html").is_file()


@pytest.mark.parametrize("command", ["export", "report", "apply"])
def test_dash_is_standard_output(lab, tmp_path, capsys, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    args = {"export": ["export", lab["CAL"], "--to", "px4", "-o", "-"],
            "report": ["report", lab["S"], "-o", "-", "--history", lab["DB"]],
            "apply": ["apply", lab["CAL"], lab["S"], "-o", "-"]}[command]
    code, out, err = rig(capsys, *args)
    assert code == 0, err
    assert not (tmp_path / "-").exists()
    start = {"export": "# ", "report": "<!DOCTYPE html>", "apply": "t_s,step,fx,fy,fz,temp_c"}[command]
    assert out.startswith(start), out[:200]


@pytest.mark.parametrize("case", ["solve", "discover -o", "discover --plot", "discover --twin", "history --plot"])
def test_dash_is_refused_where_the_output_is_not_text(lab, tmp_path, capsys, monkeypatch, case):
    command, option, args = FILE_OUTPUTS[case]
    monkeypatch.chdir(tmp_path)
    refused(capsys, command, args(lab, "-"), "-")
    assert not (tmp_path / "-").exists()


def test_an_import_directory_must_be_a_directory(lab, tmp_path, capsys):
    src = tmp_path / "recording.csv"
    src.write_text("ax,ay,az\n0,0,1\n")
    plain = tmp_path / "plain"
    plain.write_text("x")
    for given in ("", plain, "-"):
        refused(capsys, "import", ["import", "--from", "csv", src, "-o", given], given or "-o")
    assert plain.read_text() == "x"


@pytest.mark.parametrize("case", ["export", "report", "solve", "apply", "discover -o", "history --plot"])
def test_files_are_created_under_the_umask(lab, tmp_path, capsys, case):
    command, option, args = FILE_OUTPUTS[case]
    target = tmp_path / "new.png"
    previous = os.umask(0o022)
    try:
        code, _, err = rig(capsys, *args(lab, target))
        assert code == 0, err
        assert stat.S_IMODE(target.stat().st_mode) == 0o644
        os.umask(0o027)
        target.unlink()
        assert rig(capsys, *args(lab, target))[0] == 0
        assert stat.S_IMODE(target.stat().st_mode) == 0o640
    finally:
        os.umask(previous)


def test_a_file_replaced_keeps_its_mode(lab, tmp_path, capsys):
    target = tmp_path / "px4.params"
    target.write_text("old\n")
    target.chmod(0o604)
    assert rig(capsys, "export", lab["CAL"], "--to", "px4", "-o", target)[0] == 0
    assert stat.S_IMODE(target.stat().st_mode) == 0o604 and target.read_text() != "old\n"


@pytest.mark.parametrize("case", ["export", "solve", "apply", "report"])
def test_an_error_while_writing_names_the_path_given_and_leaves_nothing(lab, tmp_path, capsys, monkeypatch, case):
    command, option, args = FILE_OUTPUTS[case]
    folder = tmp_path / "out"
    folder.mkdir()
    target = folder / "cal.out"

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    code, _, err = rig(capsys, *args(lab, target))
    assert code in (1, 2) and err.count("\n") == 1 and str(target) in err and ".tmp" not in err, err
    assert "No space left on device" in err
    assert list(folder.iterdir()) == []


def test_a_folder_that_is_a_file_is_named_as_given(lab, tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    given = tmp_path / "file" / "px4.params"
    refused(capsys, "export", ["export", lab["CAL"], "--to", "px4", "-o", given], given)


def test_a_refusal_comes_before_anything_is_computed_or_written(lab, tmp_path, capsys, request):
    fifo = tmp_path / "p.png"
    _special("fifo", fifo, request)
    (lab["S"] / "calibration.yaml").unlink()  # report would say "no calibration yet"; the output is refused first
    refused(capsys, "report", ["report", lab["S"], "-o", fifo, "--history", lab["DB"]], fifo)
    before = lab["DB"].read_bytes()
    refused(capsys, "history", ["history", SENSOR, "--history", lab["DB"], "--record", lab["S"],
                                "--calibration", lab["S"] / "calibration-none.yaml", "--plot", fifo], fifo)
    assert lab["DB"].read_bytes() == before  # --record recorded nothing


def test_two_outputs_of_one_command_are_two_files(lab, tmp_path, capsys):
    same = tmp_path / "same.png"
    refused(capsys, "discover", ["discover", lab["S"], "--plot", same, "--twin", same], same)
    assert not same.exists()


def test_a_directory_given_writes_inside_it_and_a_link_inside_is_refused(lab, tmp_path, capsys):
    real = tmp_path / "real-reports"
    real.mkdir()
    (tmp_path / "reports").symlink_to(real)  # a link to a directory is a directory: written inside
    code, out, err = rig(capsys, "report", lab["S"], "-o", tmp_path / "reports", "--history", lab["DB"])
    assert code == 0, err and (real / f"{lab['S'].name}-report.html").is_file()
    plots = tmp_path / "plots"
    plots.mkdir()
    outside = tmp_path / "outside.png"
    outside.write_text("keep me\n")
    (plots / f"{lab['S'].name}-discover.png").symlink_to(outside)
    refused(capsys, "discover", ["discover", lab["S"], "--plot", plots], plots)
    assert outside.read_text() == "keep me\n"
