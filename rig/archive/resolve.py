"""``rig resolve``: every session of an archive solved again, in chunks, on a process pool (or serially).

One pure function per chunk (:func:`solve_chunk`: the chunk's sessions written back as directories in a
temporary folder, each solved by :func:`rig.analysis.solve.calibrate_session`, the pipeline ``rig solve`` runs,
without recording into any history) gives one Parquet file of results per chunk, named by the chunk's sessions
and the options. A chunk whose file exists is not solved again: a run killed (or a worker lost) goes on where it
stopped. A session that cannot be solved is a row with ``ok`` false and its reason; it never stops the others.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from calib.errors import CalibError
from rig import __version__
from rig.analysis.solve import calibrate_session
from rig.archive.store import extract_sessions, read_table
from rig.errors import RigInputError

EXECUTORS = ("serial", "processes", "dask")
RESULTS_FILE = "resolve.json"
RESULTS_FORMAT = "rig-resolve/1"
#: how long rig resolve waits for a Dask scheduler that does not answer
CONNECT_TIMEOUT = "10s"


@dataclass
class ResolveReport:
    """What a resolve did: chunks solved now, chunks found done, sessions solved and failed (now and before)."""

    chunks_solved: int = 0
    chunks_done_before: int = 0
    sessions: int = 0
    failed: list[tuple[str, str]] = field(default_factory=list)


def _row(session_id: str, content_hash: str, options: dict, cal=None, reason: str | None = None) -> dict:
    a = cal.accelerometer if cal is not None else None
    nan3 = [float("nan")] * 3
    return {"session_id": session_id, "content_hash": content_hash, "ok": a is not None, "reason": reason or "",
            "software": __version__, "model": options.get("model") or "", "method": options.get("method") or "",
            "fit_model": a.model if a is not None else "", "fit_method": a.fit.method if a is not None else "",
            "bias_counts": [float(x) for x in a.bias_counts] if a is not None else nan3,
            "bias_sigma_counts": [float(x) for x in a.sigma["bias_counts"]] if a is not None else nan3,
            "scale_counts_per_g": [float(x) for x in a.scale_counts_per_g] if a is not None else nan3,
            "scale_sigma_counts_per_g": [float(x) for x in a.sigma["scale_counts_per_g"]] if a is not None else nan3,
            "chi2_per_dof": float(a.fit.chi2_per_dof) if a is not None and a.fit.chi2_per_dof is not None else np.nan,
            "residual_rms_g": float(a.fit.residual_rms_g) if a is not None else np.nan}


def solve_chunk(archive: str, sessions: list[tuple[str, str]], options: dict) -> pa.Table:
    """The results of one chunk (``sessions``: (id, content hash) pairs): each session written back from the
    archive into a temporary folder and solved as ``rig solve`` solves it; one row each."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="rig-resolve-") as tmp:
        paths = dict(zip((sid for sid, _ in sessions), extract_sessions(archive, [sid for sid, _ in sessions], tmp)))
        for sid, digest in sessions:
            try:
                cal = calibrate_session(paths[sid], model=options.get("model"), method=options.get("method"))
                rows.append(_row(sid, digest, options, cal))
            except (CalibError, RigInputError, ValueError, OSError) as exc:
                rows.append(_row(sid, digest, options, reason=str(exc).splitlines()[0] if str(exc) else
                                 type(exc).__name__))
    return pa.Table.from_pylist(rows)


def _chunk_name(sessions: list[tuple[str, str]], options: dict) -> str:
    h = hashlib.sha256(json.dumps([sessions, options], sort_keys=True).encode()).hexdigest()[:16]
    return f"chunk-{h}.parquet"


def _write_chunk(results: Path, name: str, table: pa.Table) -> None:
    tmp = results / f".{name}.partial"
    pq.write_table(table, tmp, compression="zstd")
    os.replace(tmp, results / name)


def _solve_and_write(archive: str, results: str, name: str, sessions: list, options: dict) -> tuple[str, list]:
    table = solve_chunk(archive, sessions, options)
    _write_chunk(Path(results), name, table)
    failed = [(s, r) for s, ok, r in zip(table.column("session_id").to_pylist(), table.column("ok").to_pylist(),
                                         table.column("reason").to_pylist()) if not ok]
    return name, failed


def resolve_archive(archive, results, *, executor: str = "processes", workers: int | None = None, chunk: int = 50,
                    model: str | None = None, method: str | None = None,
                    progress: Callable[[int, int], None] | None = None, scheduler: str | None = None,
                    dask_processes: bool = True) -> ResolveReport:
    """Solve every archived session again into ``results/`` (one Parquet file per chunk of ``chunk`` sessions;
    ``resolve.json`` states the archive and the options). Chunks already there are skipped; a results folder made
    with other options is refused (one line). ``progress(done, total)`` after each chunk. ``executor`` ``dask``:
    the chunks as tasks on the Dask scheduler at ``scheduler`` (an address), else on a ``LocalCluster`` of
    ``workers`` (``dask_processes``: worker processes, else threads in this process)."""
    if executor not in EXECUTORS:
        raise RigInputError(None, None, "--executor", f"expected one of {', '.join(EXECUTORS)}, got {executor!r}")
    if chunk < 1:
        raise RigInputError(None, None, "--chunk", f"expected a number of sessions >= 1, got {chunk}")
    archive, results = Path(archive), Path(results)
    if not (archive / "sessions").is_dir():
        raise RigInputError(str(archive), None, None, "not a session archive (no sessions/ table): make one with "
                            "rig archive SESSIONS... -o ARCHIVE")
    options = {"model": model, "method": method}
    _results_folder(archive, results, options)
    meta = read_table(archive, "sessions", columns=["session_id", "content_hash"])
    pairs = sorted(zip(meta.column("session_id").to_pylist(), meta.column("content_hash").to_pylist()))
    chunks = [pairs[i:i + chunk] for i in range(0, len(pairs), chunk)]
    report = ResolveReport(sessions=len(pairs))
    todo = []
    for c in chunks:
        name = _chunk_name(c, options)
        if (results / name).exists():
            report.chunks_done_before += 1
        else:
            todo.append((name, c))
    for _, failed in _outcomes(todo, str(archive), str(results), options, executor, workers, scheduler,
                               dask_processes):
        report.chunks_solved += 1
        report.failed += failed
        if progress:
            progress(report.chunks_done_before + report.chunks_solved, len(chunks))
    return report


def _results_folder(archive: Path, results: Path, options: dict) -> None:
    """Make ``results`` (with its ``resolve.json``), or check that it holds results of the same options."""
    results.mkdir(parents=True, exist_ok=True)
    manifest = results / RESULTS_FILE
    if not manifest.exists():
        manifest.write_text(json.dumps({"format": RESULTS_FORMAT, "archive": str(archive.resolve()),
                                        "options": options}, indent=2) + "\n")
        return
    try:
        before = json.loads(manifest.read_text())
    except ValueError:
        raise RigInputError(str(manifest), None, None, "not a resolve record (damaged): remove the folder or "
                            "choose another -o") from None
    if before.get("options") != options:
        raise RigInputError(str(manifest), None, "options", f"this folder holds results solved with "
                            f"{before.get('options')}, not {options}: choose another -o")


def _outcomes(todo: list, archive: str, results: str, options: dict, executor: str, workers: int | None,
              scheduler: str | None, dask_processes: bool):
    """(name, failed) of each chunk of ``todo`` as it is solved and written, by ``executor``."""
    if executor == "dask":
        yield from _on_dask(todo, archive, results, options, scheduler, workers, dask_processes)
    elif executor == "serial" or len(todo) <= 1:
        for name, c in todo:
            yield _solve_and_write(archive, results, name, c, options)
    else:
        with ProcessPoolExecutor(max_workers=workers or os.cpu_count()) as pool:
            futures = [pool.submit(_solve_and_write, archive, results, name, c, options) for name, c in todo]
            for f in futures:
                yield f.result()


def _on_dask(todo: list, archive: str, results: str, options: dict, scheduler: str | None, workers: int | None,
             processes: bool):
    """The chunks as Dask tasks (one per chunk: a task costs the scheduler about a millisecond, a chunk of 50
    sessions about a second); (name, failed) of each as it finishes."""
    try:
        import dask  # deferred: the optional dask extra
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise RigInputError(None, None, "--executor", "dask needs the dask extra: pip install "
                            "'rig-calibration[dask]' (or use --executor processes)") from None
    cluster = None if scheduler else LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1,
                                                   processes=processes, dashboard_address=None)
    try:
        # a scheduler that does not answer is said after CONNECT_TIMEOUT, not Dask's 30 s (unless configured)
        timeout = dask.config.get("distributed.comm.timeouts.connect")
        with dask.config.set({"distributed.comm.timeouts.connect": CONNECT_TIMEOUT if timeout == "30s" else timeout}), \
                Client(scheduler or cluster) as client:
            futures = [client.submit(_solve_and_write, archive, results, name, c, options, key=f"resolve-{name}",
                                     pure=False) for name, c in todo]
            for f in as_completed(futures):
                yield f.result()
    except OSError as exc:
        raise RigInputError(None, None, "--scheduler", f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
    finally:
        if cluster is not None:
            cluster.close()


def read_results(results) -> pa.Table:
    """Every row of a results folder (its chunks), sorted by session id."""
    files = sorted(Path(results).glob("chunk-*.parquet"))
    if not files:
        return pa.table({})
    try:
        table = pa.concat_tables([pq.read_table(f) for f in files])
    except (pa.ArrowInvalid, OSError) as exc:
        raise RigInputError(str(results), None, None, f"a damaged results file: {exc}") from None
    return table.sort_by("session_id")
