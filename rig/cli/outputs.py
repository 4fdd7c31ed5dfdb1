"""Where ``rig`` writes: the one policy for every output path a command is given (docs/cli.md, "Output paths").

A command builds an :class:`OutputPolicy` from what it reads (its inputs, the session it works on, ``--follow``)
before it computes anything and asks it for each output path: :meth:`OutputPolicy.file` (``-o FILE``,
``--plot``, ``--twin``) or :meth:`OutputPolicy.directory` (``rig import -o DIR``). A path it refuses is one
:class:`~rig.errors.RigInputError` line naming the path as given (exit 2), and nothing has been computed or
written yet. Refused:

- an empty path;
- ``-`` where the output is not text (where it is, ``-`` is standard output);
- a device, a named pipe (FIFO) or a socket: never replaced, never written;
- a symbolic link, unless ``--follow`` (then the file it points to is written, under the same rules, and the
  link stays); a link to a directory is a directory;
- a directory where a file is expected (where a directory is accepted, the file is written inside it and checked
  again: :meth:`Output.inside`), a file where a directory is expected;
- a path whose folder does not exist (unless the command creates it) or is not a folder;
- an input of the command, by any name (a link, a hard link), and the same file given for two outputs;
- any file inside a session directory (a folder holding ``session.yaml`` and ``samples.csv``): a session's
  recording and results are never replaced, except the command's own documented output in the session it works
  on (``rig solve``: ``calibration*.yaml``; ``rig discover -o``: ``calibration-*.yaml``; ``rig report``:
  ``*.html``).

:func:`write` and :func:`write_figure` write atomically (:func:`calib.file.calibration.atomic_write_text`: a
temp file beside the target, fsync, rename); the file gets mode ``0o666 & ~umask`` (or keeps the mode of the
file it replaces); an error while writing is one line naming the path given, never the temp file.
"""

from __future__ import annotations

import array
import fcntl
import fnmatch
import os
import select
import stat
import sys
import tempfile
import termios
from dataclasses import dataclass, field, replace
from pathlib import Path

from calib.file.calibration import atomic_write_text
from rig.analysis import plots
from rig.errors import RigInputError

#: the output path that means standard output
STDOUT = "-"
#: the files that make a folder a session directory (docs/session-format.md)
SESSION_MARKERS = ("session.yaml", "samples.csv")
#: ``--follow``'s help, the same for every command
FOLLOW_HELP = ("an output path that is a symbolic link is written through: the file it points to is replaced "
               "and the link stays (without it a link is refused)")


@dataclass(frozen=True)
class Output:
    """An output path the policy accepted.

    ``given``: the path as the user typed it (every message names it); ``path``: where to write (the file a link
    points to with ``--follow``; the folder itself when ``directory``), None for standard output;
    ``directory``: ``path`` is a folder the file goes into, its name chosen once known (:meth:`inside`).
    """

    given: str
    option: str
    what: str
    path: Path | None
    directory: bool = False
    own: tuple[str, ...] = ()
    policy: OutputPolicy | None = field(default=None, repr=False, compare=False)

    @property
    def stdout(self) -> bool:
        return self.path is None

    def inside(self, name: str) -> Output:
        """The file ``name`` inside this directory, checked by the same rules (a link or a FIFO there is refused
        as any other); ``given`` becomes ``GIVEN/name``."""
        assert self.directory and self.policy is not None
        return self.policy._check_file(str(Path(self.given) / name), self.option, self.what, self.own,
                                       stdout=False, directory=False, make_parents=False, at=self.path / name)

    def beside(self, name: str) -> Output:
        """Another file in this file's folder (``rig discover --twin``: the procedure beside the rig file)."""
        assert not self.directory and self.path is not None and self.policy is not None
        return self.policy._check_file(str(Path(self.given).with_name(name)), self.option, self.what, self.own,
                                       stdout=False, directory=False, make_parents=False,
                                       at=self.path.with_name(name))

    def refuse(self, message: str) -> RigInputError:
        """The one line refusing this output (exit 2), naming the path as given (``''`` when empty)."""
        return RigInputError(self.given or "''", None, self.option, f"cannot write {self.what}: {message}")


class OutputPolicy:
    """The output paths of one command run: what it reads (``inputs``, files or folders), the session it works on
    (``session``: its own documented outputs may go there) and ``follow`` (``--follow``).

    Every accepted output is remembered: a second output to the same file is refused.
    """

    def __init__(self, *, inputs=(), session=None, follow: bool = False) -> None:
        self.inputs = [Path(p) for p in inputs if p is not None and os.fspath(p) != ""]
        self.session = _real(session) if session is not None else None
        self.follow = follow
        self._claimed: dict[str, str] = {}

    # ------------------------------------------------------------------------------------------ the checks
    def file(self, given, *, option: str = "-o", what: str = "the output", own: tuple[str, ...] = (),
             stdout: bool = False, directory: bool = False, make_parents: bool = False) -> Output:
        """Check the output file ``given`` (as typed). ``own``: file-name patterns this command may write in its
        own session; ``stdout``: ``-`` is standard output; ``directory``: a folder is accepted (the file goes
        inside it, :meth:`Output.inside`); ``make_parents``: the command creates a missing folder."""
        text = os.fspath(given)
        return self._check_file(text, option, what, tuple(own), stdout=stdout, directory=directory,
                                make_parents=make_parents, at=Path(text).expanduser() if text else None)

    def directory(self, given, *, option: str = "-o", what: str = "the output") -> Path:
        """Check the output folder ``given``: missing (then created by the command) or a folder (a link to one
        is one), not a session's folder nor inside one, not an input."""
        text = os.fspath(given)
        out = Output(text, option, what, None, directory=True, policy=self)
        if text == "":
            raise out.refuse("the path is empty; give a folder")
        if text == STDOUT:
            raise out.refuse("- (standard output) is not a folder; give a folder (./- for one named -)")
        p = Path(text).expanduser()
        st = _stat(p, out, follow=True)
        if st is not None and not stat.S_ISDIR(st.st_mode):
            raise out.refuse(f"{_kind(st)}, expected a folder")
        if st is None:
            lst = _stat(p, out, follow=False)
            if lst is not None:  # a link to nothing
                raise out.refuse(f"is a symbolic link to {os.readlink(p)}, which does not exist; give a folder")
            self._existing_folder(p.parent, out, make_parents=True)
        real = _real(p)
        session = _session_of(real, include_self=True)
        if session is not None:
            raise out.refuse(f"{'is' if session == real else 'is inside'} the session directory {session}: a "
                             "session's recording and results are never written over; give another folder")
        for item in self.inputs:
            if _real(item) == real:
                raise out.refuse(f"is an input of this command ({item}); give another folder")
        return p

    def _check_file(self, text: str, option: str, what: str, own: tuple[str, ...], *, stdout: bool,
                    directory: bool, make_parents: bool, at: Path | None) -> Output:
        out = Output(text, option, what, None, own=own, policy=self)
        if text == "":
            raise out.refuse("the path is empty; give a file" + (" (or - for standard output)" if stdout else ""))
        if text == STDOUT:
            if not stdout:
                raise out.refuse("- (standard output) is not possible here; give a file (./- for one named -)")
            return out
        assert at is not None
        p = at
        st = _stat(p, out, follow=False)
        if st is not None and stat.S_ISLNK(st.st_mode):
            followed = _stat(p, out, follow=True)
            if followed is not None and stat.S_ISDIR(followed.st_mode) and directory:
                st = followed  # a link to a folder where a folder is accepted: a folder
            elif not self.follow:
                raise out.refuse(f"is a symbolic link (to {os.readlink(p)}); it would be replaced: give --follow to "
                                 "write to the file it points to")
            else:
                st = followed
                if st is None or stat.S_ISREG(st.st_mode):
                    p = Path(os.path.realpath(p))  # the file the link points to (a link to nothing: created there)
        if st is not None and not stat.S_ISREG(st.st_mode):
            if stat.S_ISDIR(st.st_mode) and directory:  # the file goes inside, checked then (Output.inside)
                return replace(out, path=p, directory=True)
            raise out.refuse(f"{_kind(st)}" + (", expected a file" if stat.S_ISDIR(st.st_mode) else
                                               ", not a file: never replaced nor written"))
        if st is None:
            if directory and text.endswith(("/", os.sep)):  # a folder the command creates
                self._not_in_a_session(_real(p), None, out, ())
                return replace(out, path=p, directory=True)
            self._existing_folder(p.parent, out, make_parents=make_parents)
        real = _real(p)
        self._not_an_input(real, st, out)
        self._not_in_a_session(real.parent, real.name, out, own)
        self._claim(real, out)
        return replace(out, path=p)

    def _existing_folder(self, folder: Path, out: Output, *, make_parents: bool) -> None:
        """The folder an output goes into exists and is a folder (or, when the command creates folders, its first
        existing ancestor is one)."""
        probe = folder
        while True:
            st = _stat(probe, out, follow=True)
            if st is not None:
                if not stat.S_ISDIR(st.st_mode):
                    raise out.refuse(f"{probe} is not a folder")
                return
            if not make_parents:
                raise out.refuse(f"no such directory {folder}")
            if probe.parent == probe:
                return
            probe = probe.parent

    def _not_an_input(self, real: Path, st, out: Output) -> None:
        for item in self.inputs:
            try:
                same = st is not None and os.path.samefile(real, item)
            except OSError:
                same = False
            if same or _real(item) == real:
                raise out.refuse(f"is an input of this command ({item}); it would be overwritten: write elsewhere")

    def _not_in_a_session(self, folder: Path, name: str | None, out: Output, own: tuple[str, ...]) -> None:
        """``folder/name`` (``name`` None: the folder itself) is in no session directory, unless ``own`` lets this
        command write ``name`` directly in the session it works on."""
        session = _session_of(folder, include_self=True)
        if session is None:
            return
        if (session == self.session and folder == session and name is not None
                and any(fnmatch.fnmatch(name, pat) for pat in own)):
            return
        allowed = (f"; only {' or '.join(own)} may be written there" if own and session == self.session else "")
        raise out.refuse(f"is inside the session directory {session}: a session's recording and results are never "
                         f"written over{allowed}; write elsewhere")

    def _claim(self, real: Path, out: Output) -> None:
        key = str(real)
        if key in self._claimed and self._claimed[key] != out.option:
            raise out.refuse(f"is also the {self._claimed[key]} output; give two files")
        self._claimed[key] = out.option


# ---------------------------------------------------------------------------------------------- writing
def write(out: Output, data: str | bytes) -> Path | None:
    """Write ``data`` to ``out`` (standard output for ``-``), atomically; returns the absolute path written (None
    for standard output). An error while writing is one line naming the path given (exit 2)."""
    if out.stdout:
        if isinstance(data, bytes):
            sys.stdout.flush()
            sys.stdout.buffer.write(data)
        else:
            sys.stdout.write(data)
        sys.stdout.flush()
        return None
    try:
        atomic_write_text(out.path, data)
    except OSError as exc:
        raise out.refuse(exc.strerror or str(exc)) from None
    return out.path.resolve()


def reader_left_unread(stream=None) -> bool:
    """True when ``stream`` (standard output) is a pipe whose reader has closed it with bytes of ours still unread
    (``rig apply ... -o - | head -1``: what was written fitted in the pipe, so no write failed). False while the
    reader is there, when it read everything, or when ``stream`` is not a pipe. Linux: the pipe's POLLERR says
    the reader is gone, FIONREAD what it left (unknown counts as left)."""
    stream = sys.stdout if stream is None else stream
    try:
        fd = stream.fileno()
        if not stat.S_ISFIFO(os.fstat(fd).st_mode):
            return False
        poller = select.poll()
        poller.register(fd, 0)  # POLLERR and POLLHUP are always reported
        gone = any(events & select.POLLERR for _, events in poller.poll(0))
    except (OSError, ValueError, AttributeError):  # no descriptor (a test's capture), no poll: cannot tell
        return False
    if not gone:
        return False
    unread = array.array("i", [0])
    try:
        fcntl.ioctl(fd, termios.FIONREAD, unread)
    except OSError:
        return True
    return unread[0] > 0


def write_figure(out: Output, fig, dpi: int) -> Path:
    """Write a matplotlib figure to ``out`` (format from the file's suffix, as :func:`rig.analysis.plots.save`
    draws it), atomically."""
    with tempfile.TemporaryDirectory(prefix="rig-plot-") as tmp:  # drawn privately, then written as any output
        drawn = plots.save(fig, Path(tmp) / f"plot{out.path.suffix.lower()}", dpi=dpi)
        return write(out, drawn.read_bytes())


class writing:
    """``with writing(out): lower_layer_writes(out.path)``: an OSError while writing ``out`` becomes one line
    naming the path given (exit 2)."""

    def __init__(self, out: Output) -> None:
        self.out = out

    def __enter__(self) -> Output:
        return self.out

    def __exit__(self, kind, exc, tb) -> None:
        if isinstance(exc, OSError):
            raise self.out.refuse(exc.strerror or str(exc)) from None


# ---------------------------------------------------------------------------------------------- helpers
def _stat(p: Path, out: Output, *, follow: bool):
    """``stat`` (or ``lstat``) of ``p``; None when nothing is there. Anything else is a refusal naming the path."""
    try:
        return os.stat(p) if follow else os.lstat(p)
    except (FileNotFoundError, NotADirectoryError):
        if isinstance(p, Path) and p.parent != p:
            parent = _stat_or_none(p.parent)
            if parent is not None and not stat.S_ISDIR(parent.st_mode):
                raise out.refuse(f"{p.parent} is not a folder") from None
        return None
    except OSError as exc:  # a link loop, a folder we may not look into
        raise out.refuse(exc.strerror or str(exc)) from None


def _stat_or_none(p: Path):
    try:
        return os.stat(p)
    except OSError:
        return None


def _kind(st) -> str:
    mode = st.st_mode
    if stat.S_ISDIR(mode):
        return "is a directory"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device"
    if stat.S_ISFIFO(mode):
        return "is a named pipe (FIFO)"
    if stat.S_ISSOCK(mode):
        return "is a socket"
    if stat.S_ISREG(mode):
        return "is a file"
    return "is not a regular file"


def _real(p) -> Path:
    return Path(os.path.realpath(os.path.expanduser(os.fspath(p))))


def _session_of(folder: Path, *, include_self: bool) -> Path | None:
    """The session directory ``folder`` is (``include_self``) or is inside, else None."""
    for d in ([folder] if include_self else []) + list(folder.parents):
        if all((d / name).is_file() for name in SESSION_MARKERS):
            return d
    return None
