"""Sealed sessions: a session is the recording as it was made, or it says where it is not (docs/session-format.md, "Seal").

A lab record must show that it is the recording as made (ISO/IEC 17025 7.5, 7.11). Three pieces:

- **each step** (:meth:`Chains.link`, called by :meth:`rig.session.SessionWriter.complete_step` once the step's rows
  are fsynced): the bytes appended to ``samples.csv`` since the previous step, and the lines appended to
  ``events.jsonl``, are hashed (SHA-256) and chained over the steps, ``h_i = sha256(h_{i-1} || rows_i)``; the
  link goes into the step's ``stats`` (``sha256``, ``samples_bytes`` [start, end], ``events_sha256``,
  ``events_bytes`` [start, end]), written with the step. The writer hashes the bytes as it writes them
  (:class:`Chains`): nothing is read back (:func:`link_step` reads them for a step recorded again).
- **at completion** (:func:`seal_session`, called by :meth:`~rig.session.SessionWriter.set_status` ``("complete")``,
  so an import that ends complete is sealed too): the whole raw record (``samples.csv``, ``events.jsonl`` as it
  is at completion, the manifest's content; the writer's hashes and text) is sealed into a top-level ``seal:``
  mapping appended to ``session.yaml`` (a key the manifest model keeps as it is).
- **on every read** (:func:`verify_on_load`, called by :func:`rig.session.load_session`, which checks samples.csv on
  the read that parses it: :class:`SamplesCheck`): a sealed session whose
  files differ from its seal is refused with one line naming the file and the first step that differs; under
  ``RIG_UNSEALED=1`` (research: analysing edited data on purpose) it loads with a warning, and its id becomes
  ``ID.SEAL-BROKEN`` so that everything written from it (calibration file, history row, report, replay)
  says so. A session without a seal (recorded before sealing existed; still running or aborted) loads as before.

``rig verify SESSION`` (:func:`verify_session`) checks a session without loading it.

The seal detects a change; it does not authenticate: whoever can edit the files can compute new hashes.
The history database keeps a copy of each solved session's seal (``calibrations.seal``): a session sealed
again after an edit no longer matches the seal recorded when it was solved.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from calib.file.calibration import atomic_write_text
from rig.config.yamlload import read_source
from rig.errors import SessionFormatError
from rig.session.manifest import MAX_BYTES, SessionManifest, load_yaml, utc_now

ALGORITHM = "sha256"
#: the version of the seal's construction (the first line of what its ``sha256`` hashes)
SEAL_FORMAT = "rig-seal/1"
#: the analysis mode: a session whose seal does not match loads anyway, with a warning, marked
UNSEALED_ENV = "RIG_UNSEALED"
#: appended to the id of a session analysed under RIG_UNSEALED=1 whose seal does not match (id characters only)
BROKEN_MARK = ".SEAL-BROKEN"
NOT_SEALED = "not sealed (recorded before sealing existed, or unfinished)"
#: hex digits of each manifest part's digest in ``seal.parts`` (they locate an edit; manifest_sha256 detects it)
PART_HEX = 16
_CHUNK = 1 << 20
_FILES = ("samples.csv", "events.jsonl")
#: per file: its name, the key of a step's link and of the link's byte range (in the step's stats)
_LINK_KEYS = ((_FILES[0], "sha256", "samples_bytes"), (_FILES[1], "events_sha256", "events_bytes"))
_HEX = frozenset("0123456789abcdef")


class SealBroken(SessionFormatError):
    """A session differs from its seal (or from a step's recorded hash): one line naming the file, the line
    and the step or manifest key. ``file`` is the file's name."""

    def __init__(self, path: Path, line, key, message: str) -> None:
        self.file = Path(path).name
        super().__init__(str(path), line, key, message)


def unsealed_mode() -> bool:
    """``RIG_UNSEALED=1``: analyse a session whose seal does not match (with a warning, marked)."""
    return os.environ.get(UNSEALED_ENV, "").strip() not in ("", "0")


# ------------------------------------------------------------------------------------------------ writing

def link_step(session_dir, info: SessionManifest, index: int, stats: dict) -> dict:
    """The step's ``stats`` with its link in the chain added (for :meth:`SessionWriter.complete_step`, once the
    step's rows are fsynced): ``samples_bytes`` [start, end] and ``sha256`` = sha256(previous link || the bytes
    of samples.csv since the previous link), the same for events.jsonl (``events_bytes``, ``events_sha256``).
    The previous link is the latest recorded by another step (a step recorded again is chained once, after the
    others); the first link chains from the header line (samples) and from the empty file (events)."""
    d = Path(session_dir)
    prev = _last_link([(s.index, s.stats.model_extra if s.stats is not None else None) for s in info.steps],
                      exclude=index)
    out = dict(stats or {})
    for name, key, start_key in ((_FILES[0], "sha256", "samples_bytes"), (_FILES[1], "events_sha256", "events_bytes")):
        path = d / name
        with open(path, "rb") as fh:
            if prev is not None:
                start, head = int(prev[start_key][1]), bytes.fromhex(prev[key])
            else:
                start = len(fh.readline()) if name == _FILES[0] else 0  # the header line: the chain's origin
                fh.seek(0)
                head = hashlib.sha256(fh.read(start)).digest()
            end = os.fstat(fh.fileno()).st_size
            fh.seek(start)
            h = hashlib.sha256(head)
            _copy(fh, end - start, h)
        out[start_key], out[key] = [start, end], h.hexdigest()
    return out


class Chains:
    """The hashes of ``samples.csv`` and ``events.jsonl`` kept as their writer appends to them, so that neither
    recording a step (:meth:`link`) nor sealing (:meth:`digests`) reads a file back.

    Per file: the whole file's SHA-256 so far and its size, and the chain's running hash since the last link
    (``sha256(last link || bytes since)``). :meth:`fresh` starts them at a new file's first bytes,
    :meth:`from_files` (a resumed session) from the files as they are, read once."""

    def __init__(self, state: dict, last_index: int | None = None) -> None:
        self._s = state  # name -> {"size", "whole", "start", "head" (hex), "origin", "run"}
        self._last_index = last_index  # the step whose link the chain runs from (None: from the origin)

    @classmethod
    def fresh(cls, samples_origin: bytes, events_origin: bytes = b"") -> "Chains":
        """A new session's files holding ``samples_origin`` (the header line) and ``events_origin``."""
        state = {}
        for name, origin in zip(_FILES, (samples_origin, events_origin)):
            head = hashlib.sha256(origin).hexdigest()
            state[name] = {"size": len(origin), "whole": hashlib.sha256(origin), "start": len(origin), "head": head,
                           "origin": len(origin), "run": hashlib.sha256(bytes.fromhex(head))}
        return cls(state)

    @classmethod
    def from_files(cls, session_dir, info: SessionManifest) -> "Chains":
        """The files of a session reopened (resumed), each read once; the chain continues from the last link."""
        d = Path(session_dir)
        steps = [(s.index, s.stats.model_extra if s.stats is not None else None) for s in info.steps]
        last = _last_link(steps)
        last_index = next((i for i, st in steps if st is last), None) if last is not None else None
        state = {}
        for name, key, range_key in _LINK_KEYS:
            whole = hashlib.sha256()
            with open(d / name, "rb") as fh:
                origin = len(fh.readline()) if name == _FILES[0] else 0  # the header line; the empty file
                fh.seek(0)
                origin_head = hashlib.sha256(fh.read(origin)).hexdigest()
                fh.seek(0)
                start, head = (int(last[range_key][1]), last[key]) if last is not None else (origin, origin_head)
                n = _copy(fh, start, whole)
                run = hashlib.sha256(bytes.fromhex(head))
                n += _copy(fh, None, whole, run)
            state[name] = {"size": n, "whole": whole, "start": start, "head": head, "origin": origin, "run": run}
        return cls(state, last_index)

    def wrote(self, name: str, data: bytes) -> None:
        """``data`` was appended to ``name`` (samples.csv or events.jsonl)."""
        st = self._s[name]
        st["whole"].update(data)
        st["run"].update(data)
        st["size"] += len(data)

    def link(self, session_dir, info: SessionManifest, index: int, stats: dict) -> dict:
        """The step's ``stats`` with its link added, as :func:`link_step` computes it; from the running hashes
        when the previous link is where the chain runs from (always, but for a step recorded again: then the
        files are read from the previous link on, :func:`link_step`). The chain then continues from this link."""
        if index != self._last_index:  # the previous link is the last one made: the chain runs from it
            prev, known = None, True
        else:  # the last step recorded again: chained from the link before it (found among the steps)
            prev, known = _last_link([(s.index, s.stats.model_extra if s.stats is not None else None)
                                      for s in info.steps], exclude=index), False
        if known or all(self._runs_from(prev, *keys) for keys in _LINK_KEYS):
            out = dict(stats or {})
            for name, key, range_key in _LINK_KEYS:
                st = self._s[name]
                out[range_key], out[key] = [st["start"], st["size"]], st["run"].hexdigest()
        else:
            out = link_step(session_dir, info, index, stats)
        for name, key, range_key in _LINK_KEYS:
            st = self._s[name]
            st["start"], st["head"] = int(out[range_key][1]), out[key]
            st["run"] = hashlib.sha256(bytes.fromhex(out[key]))
        self._last_index = index
        return out

    def _runs_from(self, prev: dict | None, name: str, key: str, range_key: str) -> bool:
        st = self._s[name]
        if prev is None:
            return st["start"] == st["origin"]
        return (int(prev[range_key][1]), prev[key]) == (st["start"], st["head"])

    def digests(self) -> dict:
        """``{"samples.csv": (sha256 hex, bytes), "events.jsonl": (...)}`` of the files as written so far."""
        return {name: (st["whole"].hexdigest(), st["size"]) for name, st in self._s.items()}


def seal_session(session_dir, *, source_sha256: str | None = None, text: str | None = None,
                 digests: dict | None = None, doc: dict | None = None) -> dict:
    """Seal a completed session: append ``seal:`` to ``session.yaml`` (atomically) and return it.

    ``seal``: ``algorithm`` (sha256), ``sha256`` (of the whole record: the lines below, see
    :func:`seal_digest`), ``sealed_at``, ``samples_sha256`` and ``samples_bytes`` (samples.csv), ``chain`` (the last
    step's link), ``events_sha256`` and ``events_bytes`` (events.jsonl at completion), ``manifest_sha256`` (the
    manifest's content without the seal, :func:`manifest_digest`), ``source_sha256`` (an import: the source file's
    SHA-256, from ``source_sha256``, else the manifest's ``import.source_sha256``, else an import's
    ``procedure.sha256``) and ``parts`` (short digests of each top-level key and step, to name what changed).
    A session sealed already keeps its seal (a seal is never replaced).

    ``text``: ``session.yaml`` as its writer has just written it, and ``digests``: the files' hashes as their writer
    kept them (:meth:`Chains.digests`); given, nothing is read back from disk. ``doc``: with ``text``, the plain
    mapping ``text`` is the YAML of (the writer dumped it: the same mapping :func:`load_yaml` gives back, so the
    text is not parsed again; a 10,000-step manifest takes about a second to parse)."""
    d = Path(session_dir)
    path = d / "session.yaml"
    # the text kept, the seal appended. The writer has compacted the manifest (a steps journal folded in and
    # removed) before it seals: this is the content every reader folds and checks (SessionManifest.load)
    if text is None:
        text = read_source(path, "session manifest", "missing", MAX_BYTES)
    if doc is None or text is None:
        doc = load_yaml(text, str(path))
    if not isinstance(doc, dict):
        raise SessionFormatError(str(path), None, None, "expected a mapping")
    if isinstance(doc.get("seal"), dict):
        return doc["seal"]
    seal: dict = {"algorithm": ALGORITHM, "sha256": None, "sealed_at": utc_now()}
    for name, prefix in zip(_FILES, ("samples", "events")):
        if digests is not None:
            seal[f"{prefix}_sha256"], seal[f"{prefix}_bytes"] = digests[name]
        else:
            h = hashlib.sha256()
            with open(d / name, "rb") as fh:
                n = _copy(fh, None, h)
            seal[f"{prefix}_sha256"], seal[f"{prefix}_bytes"] = h.hexdigest(), n
        if prefix == "samples":
            last = _last_link(_doc_steps(doc))
            seal["chain"] = last["sha256"] if last is not None else None
    seal["manifest_sha256"] = manifest_digest(doc)
    source = source_sha256 or _source_sha256(doc)
    if source:
        seal["source_sha256"] = str(source)
    seal["parts"] = manifest_parts(doc)
    seal["sha256"] = seal_digest(seal)
    sep = "" if text.endswith("\n") else "\n"
    atomic_write_text(path, text + sep + yaml.safe_dump({"seal": seal}, sort_keys=False, width=1000))
    return seal


def _source_sha256(doc: dict) -> str | None:
    imp = doc.get("import")
    if not isinstance(imp, dict):
        return None
    proc = doc.get("procedure") if isinstance(doc.get("procedure"), dict) else {}
    return imp.get("source_sha256") or proc.get("sha256")


# ------------------------------------------------------------------------------------------------ digests

def canonical(value) -> bytes:
    """The canonical bytes of a manifest value: JSON, keys sorted, no spaces, ASCII (``\\uXXXX`` escapes: a lone
    surrogate a hand-edited manifest may hold is bytes too)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True, default=str).encode("ascii")


def manifest_digest(doc: dict) -> str:
    """SHA-256 of the manifest's content (the mapping ``session.yaml`` holds, without ``seal``), canonical JSON."""
    return hashlib.sha256(canonical({k: v for k, v in doc.items() if k != "seal"})).hexdigest()


def manifest_parts(doc: dict) -> dict:
    """Short digests (:data:`PART_HEX` hex digits) of each top-level key of the manifest but the seal, and of each
    step (``steps``: a list): what :func:`verify_session` names when the manifest differs."""
    parts = {}
    for key, value in doc.items():
        if key == "seal":
            continue
        if key == "steps" and isinstance(value, list):
            parts[key] = [_short(v) for v in value]
        else:
            parts[key] = _short(value)
    return parts


def _short(value) -> str:
    return hashlib.sha256(canonical(value)).hexdigest()[:PART_HEX]


def seal_digest(seal: dict) -> str:
    """The seal's ``sha256``: SHA-256 of these lines (UTF-8, each ending in a newline), ``-`` for a value absent::

        rig-seal/1
        samples.csv SAMPLES_BYTES SAMPLES_SHA256
        chain CHAIN
        events.jsonl EVENTS_BYTES EVENTS_SHA256
        session.yaml MANIFEST_SHA256
        parts SHA256_OF_CANONICAL_PARTS
        source SOURCE_SHA256
        sealed_at SEALED_AT
    """
    def v(key):
        x = seal.get(key)
        return "-" if x is None else str(x)
    lines = [SEAL_FORMAT, f"samples.csv {v('samples_bytes')} {v('samples_sha256')}", f"chain {v('chain')}",
             f"events.jsonl {v('events_bytes')} {v('events_sha256')}", f"session.yaml {v('manifest_sha256')}",
             f"parts {hashlib.sha256(canonical(seal.get('parts'))).hexdigest()}", f"source {v('source_sha256')}",
             f"sealed_at {v('sealed_at')}"]
    return hashlib.sha256(("\n".join(lines) + "\n").encode("utf-8")).hexdigest()


# ------------------------------------------------------------------------------------------------ checking

@dataclass
class Verified:
    """What :func:`verify_session` found intact: ``sealed`` (False: no seal; the chained steps were checked),
    ``seal`` (the mapping, or None), ``steps`` (how many steps' links were checked)."""

    sealed: bool
    seal: dict | None
    steps: int


def verify_session(session_dir, doc: dict | None = None, samples: SamplesCheck | None = None) -> Verified:
    """Check a session against its seal, or (no seal) its recorded steps against their links.

    In this order, the first difference is one :class:`SealBroken` line naming the file and the step or key:
    the seal's own fields (their ``sha256``), the manifest (``session.yaml: steps[3]: ...``), samples.csv step
    by step (``samples.csv:2: step 1: ...``; rows added or removed after the seal), events.jsonl step by step.
    ``doc``: the manifest as read (:meth:`SessionManifest.load`), when the caller has it; ``samples``: samples.csv
    checked as the caller read it (:class:`SamplesCheck`), not read again."""
    d = Path(session_dir)
    if doc is None:
        _, doc = SessionManifest.load(d)
    seal = doc.get("seal")
    if seal is not None:
        _check_seal_fields(d / "session.yaml", seal)
        _check_manifest(d / "session.yaml", doc, seal)
    steps = _doc_steps(doc)
    links = _links(d / "samples.csv", steps)
    _check_file(d, _FILES[0], links, "sha256", "samples_bytes", seal, doc, samples)
    _check_file(d, _FILES[1], links, "events_sha256", "events_bytes", seal, doc)
    return Verified(seal is not None, seal, len(links))


def verify_on_load(session_dir, info: SessionManifest, doc: dict, samples: SamplesCheck | None = None) -> list[str]:
    """For :func:`rig.session.load_session`: nothing for a session without a seal; a sealed session that differs
    from its seal is refused (:class:`SealBroken`), or, under ``RIG_UNSEALED=1``, loads marked: its id becomes
    ``ID.SEAL-BROKEN`` (what is written from it says so) and its seal gets ``broken`` (the history row keeps it);
    the returned warning says so. ``samples``: samples.csv checked as it was read (:class:`SamplesCheck`)."""
    if "seal" not in doc:
        return []
    try:
        verify_session(session_dir, doc, samples)
    except SealBroken as exc:
        if not unsealed_mode():
            raise
        seal = doc["seal"] if isinstance(doc["seal"], dict) else {"value": doc["seal"]}
        info.seal = {**seal, "broken": str(exc)}
        info.id = f"{info.id}{BROKEN_MARK}"
        return [f"{exc} -- analysed anyway ({UNSEALED_ENV}=1): not the recording as made; everything written from "
                f"it is marked as session {info.id}"]
    return []


def _check_seal_fields(path: Path, seal) -> None:
    if not isinstance(seal, dict):
        raise SealBroken(path, None, "seal", "expected the seal mapping written at completion; the seal was changed")
    if seal.get("algorithm") != ALGORITHM:
        raise SealBroken(path, None, "seal.algorithm", f"expected {ALGORITHM!r}, got {seal.get('algorithm')!r}")
    for key in ("sha256", "samples_sha256", "events_sha256", "manifest_sha256"):
        if not _is_hex(seal.get(key)):
            raise SealBroken(path, None, f"seal.{key}", "expected a SHA-256 (64 hex digits); the seal was changed")
    for key in ("samples_bytes", "events_bytes"):
        if isinstance(seal.get(key), bool) or not isinstance(seal.get(key), int) or seal[key] < 0:
            raise SealBroken(path, None, f"seal.{key}", "expected a byte count; the seal was changed")
    if seal_digest(seal) != seal["sha256"]:
        raise SealBroken(path, None, "seal", "the seal's fields do not match its sha256: the seal was changed "
                         "after the recording was sealed")


def _check_manifest(path: Path, doc: dict, seal: dict) -> None:
    if manifest_digest(doc) == seal["manifest_sha256"]:
        return
    sealed = seal.get("parts") if isinstance(seal.get("parts"), dict) else None
    if sealed is None:
        raise SealBroken(path, None, None, "the manifest differs from the seal (edited after the recording was sealed)")
    now = manifest_parts(doc)
    for key in list(sealed) + [k for k in now if k not in sealed]:
        if key not in now:
            raise SealBroken(path, None, key, "removed after the recording was sealed (the seal has it)")
        if key not in sealed:
            raise SealBroken(path, None, key, "added after the recording was sealed (the seal does not have it)")
        a, b = sealed[key], now[key]
        if a == b:
            continue
        if key == "steps" and isinstance(a, list) and isinstance(b, list):
            for i in range(min(len(a), len(b))):
                if a[i] != b[i]:
                    raise SealBroken(path, None, f"steps[{i}]", f"the record of {_label(doc, i)} differs from the seal "
                                     "(the manifest was edited after the recording was sealed)")
            raise SealBroken(path, None, "steps", f"{len(b)} steps, the seal recorded {len(a)}")
        raise SealBroken(path, None, key, "differs from the seal (the manifest was edited after the recording was "
                         "sealed)")
    raise SealBroken(path, None, None, "the manifest differs from the seal (edited after the recording was sealed)")


def _check_file(d: Path, name: str, links: list, key: str, range_key: str, seal, doc: dict,
                fed: "SamplesCheck | None" = None) -> None:
    """One file, link by link (then, sealed, its whole bytes): the first difference as a SealBroken. ``fed``: the
    file's bytes were checked as a reader read them (:class:`SamplesCheck`): its outcome, nothing read again."""
    path = d / name
    if fed is not None:
        fed.result()
        return
    if not path.is_file():
        if not isinstance(seal, dict) and not links:
            return
        raise SealBroken(path, None, None, "missing: the sealed recording had it")
    with open(path, "rb") as fh:
        check = _Check(_checker(path, name, links, key, range_key, seal, doc, os.fstat(fh.fileno()).st_size))
        while not check.done and (chunk := fh.read(_CHUNK)):
            check.update(chunk)
    check.result()


class _Check:
    """Drives a checker generator (:func:`_checker`): bytes in with :meth:`update`, the outcome from :meth:`result`."""

    def __init__(self, gen) -> None:
        self._gen, self.done, self._error = gen, False, None
        self._step(lambda: next(gen))

    def update(self, chunk: bytes) -> None:
        if not self.done and chunk:
            self._step(lambda: self._gen.send(bytes(chunk)))

    def result(self) -> None:
        """The end of the file: nothing, or the first difference raised."""
        if not self.done:
            self._step(lambda: self._gen.send(None))
        if not self.done:
            raise RuntimeError("the seal check wanted more bytes after the end of the file")
        if self._error is not None:
            raise self._error

    def _step(self, go) -> None:
        try:
            go()
        except StopIteration:
            self.done = True
        except Exception as exc:  # noqa: BLE001 -- kept, raised by result(): a SealBroken, or a seal's malformed field
            self.done, self._error = True, exc                 # that verify_session refuses before it asks


class SamplesCheck(_Check):
    """``samples.csv`` of a sealed session checked while a reader reads it (:func:`rig.session.read_samples`
    feeds every byte once, in order, through :meth:`update`; ``size``: the file's size when it was opened): the
    file is read once to load and to verify. :func:`verify_session` given it (``samples=``) raises what it found,
    as it would have reading the file itself."""

    def __init__(self, session_dir, doc: dict, size: int) -> None:
        d = Path(session_dir)
        super().__init__(_checker(d / _FILES[0], _FILES[0], _links(d / _FILES[0], _doc_steps(doc)), "sha256",
                                  "samples_bytes", doc.get("seal"), doc, size))


class _Fed:
    """What a checker written as a generator reads: bytes sent to it in order (None: the end), taken as the
    checker asks for them (``yield from fed.read(n)``), never more than one sent chunk held."""

    def __init__(self) -> None:
        self.chunk, self.at, self.end = b"", 0, False

    def take(self, n: int | None, sinks=(), keep: bool = False):
        """Up to ``n`` bytes (None: to the end) passed to ``sinks``; returns (count, the bytes if ``keep``)."""
        got, kept = 0, []
        while n is None or got < n:
            if self.at >= len(self.chunk):
                if self.end:
                    break
                chunk = yield
                if chunk is None:
                    self.end = True
                    continue
                self.chunk, self.at = chunk, 0
            stop = len(self.chunk) if n is None else min(len(self.chunk), self.at + n - got)
            piece = self.chunk[self.at:stop]
            self.at = stop
            for sink in sinks:
                sink.update(piece)
            if keep:
                kept.append(piece)
            got += len(piece)
        return got, b"".join(kept)


def _checker(path: Path, name: str, links: list, key: str, range_key: str, seal, doc: dict, size: int):
    """The check of one file (module docstring), as a generator sent the file's bytes in order, then None; it
    returns when the file agrees and raises the first difference as a SealBroken."""
    sealed = isinstance(seal, dict)
    what = "rows" if name == _FILES[0] else "events"
    prefix = "samples" if name == _FILES[0] else "events"
    fed = _Fed()
    # the chained links cover the file from its origin to the sealed end: they check every byte (the manifest that
    # holds them is checked against the seal), so the whole file's hash would check the same bytes a second time
    covered = sealed and bool(links) and seal.get(f"{prefix}_bytes") == links[-1][1][range_key][1]
    whole = _Unused() if covered else hashlib.sha256()
    pos, head = 0, None
    for index, stats in links:
        start, end = (int(x) for x in stats[range_key])
        step = _key(name, index)
        if head is None:
            _, origin = yield from fed.take(start, (whole,), keep=True)
            if len(origin) != start:
                raise SealBroken(path, 1, step, f"the file is shorter ({size} bytes) than the sealed recording")
            if name == _FILES[0] and not _header_ok(origin, doc):
                raise SealBroken(path, 1, "header", "the header line differs from the recorded columns")
            head, pos = hashlib.sha256(origin).digest(), start
        if start != pos:
            raise SealBroken(path, None, step, f"the chain of {what} is broken before {_this(doc, index)}: its "
                             f"{what} start at byte {start}, the previous step's end at {pos}")
        h = hashlib.sha256(head)
        got, _ = yield from fed.take(end - start, (h, whole))
        if got != end - start:
            raise SealBroken(path, _line_at(path, start), step, f"the {what} of {_this(doc, index)} are cut short (the "
                             f"file ends at byte {size}, the step's {what} end at {end}): {_changed(sealed)}")
        if h.hexdigest() != stats[key]:
            raise SealBroken(path, _line_at(path, start), step, f"the {what} of {_this(doc, index)} differ from "
                             f"{_what(sealed)}: {_changed(sealed)}")
        head, pos = h.digest(), end
    if not sealed:
        return
    total = int(seal[f"{prefix}_bytes"])
    last = _key(name, links[-1][0]) if links else None
    after = "after the last step" if links else "of the file"
    rest, _ = yield from fed.take(max(total - pos, 0), (whole,))
    if pos + rest < total:
        raise SealBroken(path, None, last, f"{total - pos - rest} bytes of the sealed {what} are missing at the "
                         f"end ({after}): removed after the recording was sealed")
    if not covered and whole.hexdigest() != seal[f"{prefix}_sha256"]:
        raise SealBroken(path, _line_at(path, pos) if links else None, last,
                         f"the {what} {after} differ from the seal: {_changed(True)}")
    if size > total:
        _, extra = yield from fed.take(min(size - total, 64 * 1024), keep=True)
        step = _step_of(extra, doc) if name == _FILES[0] else _event_step(extra)
        raise SealBroken(path, _line_at(path, total), _key(name, step) if step is not None else last,
                         f"{size - total} bytes of {what} added after the recording was sealed (the sealed file "
                         f"ended at byte {total})")


def _line_at(path: Path, offset: int) -> int:
    """The 1-based line of ``path`` that starts at byte ``offset`` (1 + the newlines before it): read again, only for
    an error's message (a check that passes counts no lines)."""
    n, left = 1, offset
    with open(path, "rb") as fh:
        while left > 0 and (chunk := fh.read(min(_CHUNK, left))):
            n += chunk.count(b"\n")
            left -= len(chunk)
    return n


def _what(sealed: bool) -> str:
    return "the seal" if sealed else "the hash recorded when the step was recorded"


def _changed(sealed: bool) -> str:
    return ("the recording was changed after it was sealed" if sealed else
            "the recording was changed after the step was recorded")


class _Unused:
    """A sink that takes bytes and does nothing with them."""

    def update(self, chunk: bytes) -> None:
        pass


def _copy(fh, n: int | None, *sinks) -> int:
    """Read ``n`` bytes (None: to the end) from ``fh`` in chunks into each of ``sinks``; the number read."""
    got = 0
    while n is None or got < n:
        chunk = fh.read(_CHUNK if n is None else min(_CHUNK, n - got))
        if not chunk:
            break
        for s in sinks:
            s.update(chunk)
        got += len(chunk)
    return got


def _header_ok(origin: bytes, doc: dict) -> bool:
    cols = doc.get("columns")
    if not isinstance(cols, list) or b"\n" not in origin or origin.count(b"\n") != 1:
        return True  # not the writer's header alone (rows recorded before sealing existed): the first link says
    return origin == (",".join(map(str, cols)) + "\n").encode("utf-8")


def _doc_steps(doc: dict) -> list[tuple[int, dict | None]]:
    steps = doc.get("steps") if isinstance(doc.get("steps"), list) else []
    return [(i, s.get("stats") if isinstance(s, dict) and isinstance(s.get("stats"), dict) else None)
            for i, s in enumerate(steps)]


def _is_link(stats) -> bool:
    if not isinstance(stats, dict):
        return False
    for key, range_key in (("sha256", "samples_bytes"), ("events_sha256", "events_bytes")):
        r = stats.get(range_key)
        if not (_is_hex(stats.get(key)) and isinstance(r, list) and len(r) == 2
                and all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in r) and r[0] <= r[1]):
            return False
    return True


def _last_link(steps: list[tuple[int, dict | None]], exclude: int | None = None) -> dict | None:
    """The stats of the step linked last (its samples end furthest), other than ``exclude``."""
    best = None
    for i, stats in steps:
        if i != exclude and _is_link(stats) and (best is None or stats["samples_bytes"][1] >= best["samples_bytes"][1]):
            best = stats
    return best


def _links(path: Path, steps: list[tuple[int, dict | None]]) -> list[tuple[int, dict]]:
    """The linked steps in the order their rows were written."""
    linked = [(i, s) for i, s in steps if _is_link(s)]
    return sorted(linked, key=lambda x: (x[1]["samples_bytes"][0], x[1]["samples_bytes"][1]))


def _label(doc: dict, index: int) -> str:
    steps = doc.get("steps") if isinstance(doc.get("steps"), list) else []
    name = steps[index].get("name") if index < len(steps) and isinstance(steps[index], dict) else None
    return f"step {index + 1} ({name})" if name else f"step {index + 1}"


def _key(name: str, index: int) -> str:
    """How a refusal names a step: counted from 1, with the index samples.csv holds (docs/session-format.md)."""
    return f"step {index + 1} (index {index} in samples.csv)" if name == _FILES[0] else f"step {index + 1}"


def _this(doc: dict, index: int) -> str:
    steps = doc.get("steps") if isinstance(doc.get("steps"), list) else []
    name = steps[index].get("name") if index < len(steps) and isinstance(steps[index], dict) else None
    return f"this step ({name})" if name else "this step"


def _step_of(data: bytes, doc: dict) -> int | None:
    """The step index of the first whole row in ``data`` (rows added after the seal), or None."""
    cols = doc.get("columns")
    line = data.split(b"\n", 1)[0].decode("utf-8", "replace").split(",")
    if not isinstance(cols, list) or "step" not in cols or len(line) <= cols.index("step"):
        return None
    try:
        return int(float(line[cols.index("step")]))
    except ValueError:
        return None


def _event_step(data: bytes) -> int | None:
    try:
        step = json.loads(data.split(b"\n", 1)[0]).get("step")
    except (ValueError, AttributeError):
        return None
    return step if isinstance(step, int) and not isinstance(step, bool) else None


def _is_hex(v) -> bool:
    return isinstance(v, str) and len(v) == 64 and set(v) <= _HEX
