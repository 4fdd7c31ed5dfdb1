"""Shared test fixtures: paths of the repository, shipped procedures and the shared datasets."""

from __future__ import annotations

import os
import signal
import tempfile
from pathlib import Path

import pytest

# BLAS on one thread per test process, set before numpy loads (subprocesses and xdist's workers inherit it): the
# suite runs one process per core, and the calibration's small matrices gain nothing from threads; two OpenBLAS
# threads per worker on two busy cores made the discovery search's 6x6 triangular solves 16 ms each, not 0.02 ms
from rig.cli.main import one_blas_thread  # imports no numpy (tests/system/test_cli_startup.py)

one_blas_thread()  # as the rig program does

from rig.workflow import kinds  # noqa: E402,F401 - after the BLAS threads; the suite is wired as the workflows are (rig.composition): rig kinds, sim:/faults:

REPO = Path(__file__).resolve().parents[1]
PROCEDURES = REPO / "procedures"
RIGS = REPO / "rigs"
#: the real recordings of other projects (../shared/datasets beside the checkout; $RIG_DATASETS elsewhere)
DATASETS = Path(os.environ.get("RIG_DATASETS") or REPO.parent / "shared" / "datasets")
#: the reason every test skipped for want of the datasets gives (counted once at the end of the run)
NO_DATASETS = f"shared datasets not found at {DATASETS}"
#: the seed's six faces as the ``steps:`` of a procedure written in a test
SIX_FACES_STEPS = "".join(f'  - pose: "{face}"\n' for face in ("+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up"))


def unseal(session_dir) -> Path:
    """Remove a recorded session's seal (docs/session-format.md, "Seal"). A test that rewrites a session's files
    to stand for a session written by another tool, by hand, or left unfinished makes what those are: a session
    without a seal (a sealed session whose files changed is refused on load, naming what changed)."""
    path = Path(session_dir) / "session.yaml"
    text = path.read_text(encoding="utf-8")
    at = text.find("\nseal:\n")
    if at >= 0:
        path.write_text(text[:at + 1], encoding="utf-8")
    return Path(session_dir)


def scale_counts(session_dir, factor: float) -> Path:
    """Multiply a session's accelerometer counts in samples.csv by ``factor`` (rounded to whole counts): data of
    another range or scale under an unchanged manifest."""
    path = Path(session_dir) / "samples.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cols = [header.index(c) for c in ("ax", "ay", "az")]
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for j in cols:
            cells[j] = str(round(int(cells[j]) * factor))
        out.append(",".join(cells))
    path.write_text("\n".join(out) + "\n")
    return Path(session_dir)


#: the test modules whose set-up records many simulated sessions (tens of seconds each, measured with
#: ``--durations``), in falling cost. ``pytest -n auto --dist loadscope`` hands whole modules (and classes) to
#: the workers in collection order; collected alphabetically, tests/system came last and its long modules
#: made a tail in which one worker ran alone (111 s of 594 idle on 2 workers). Scheduled first, the short
#: modules fill the gaps at the end (issue 26).
#: Longest first (measured with --durations=0), so that the two workers finish together; xdist's own reordering
#: (by number of tests per module) is switched off in :func:`pytest_configure`, or it would undo this order.
HEAVY_FIRST = ("system/test_discover.py", "rig/importers/test_import_streaming.py", "system/test_adversarial_smoke.py",
               "calib/test_gyro_mag_uncertainty.py", "system/test_gyro_mag_rig.py", "system/test_discover_new_effects.py",
               "system/test_twin_compare.py", "system/test_golden.py", "system/test_twin_sensors.py",
               "system/test_hardware_path.py", "system/test_discover_propose.py")


def pytest_collection_modifyitems(config, items):
    """The heavy modules first (:data:`HEAVY_FIRST`), then the other system tests, then the rest, each in
    its collected order (a stable sort: the tests of a module keep theirs)."""
    def rank(item) -> int:
        path = Path(str(item.fspath)).as_posix()
        for i, name in enumerate(HEAVY_FIRST):
            if path.endswith("tests/" + name):
                return i
        return len(HEAVY_FIRST) + (0 if "/tests/system/" in path else 1)
    items.sort(key=rank)


def pytest_configure(config):
    """Every solve records into a calibration history (docs/history.md): the tests' go into a
    database of their own, never the user's (subprocesses inherit the variable). Simulated rigs whose
    rig file does not choose run their controllers in process (``sim.transport: memory``: the same
    protocol bytes through the same Stage driver, no pseudo-terminal threads); the tests whose point is
    the pseudo-terminal say ``transport: pty`` or start emulators themselves."""
    os.environ["RIG_HISTORY"] = str(Path(tempfile.mkdtemp(prefix="rig-test-history-")) / "history.sqlite")
    os.environ["RIG_HISTORY_OUTBOX"] = str(Path(tempfile.mkdtemp(prefix="rig-test-outbox-")))
    os.environ["RIG_SIM_TRANSPORT"] = "memory"
    # a shell without job control starts a background job (`pytest ... &`) with SIGINT ignored, and the ignored
    # signal is inherited by every program the tests start: the tests of Ctrl-C need it to reach them
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    # --dist loadscope hands out modules in the order pytest_collection_modifyitems left them (heavy first), not
    # re-sorted by their number of tests (pytest-xdist's default since 3.6; the option's own name for this)
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def datasets() -> Path:
    if not DATASETS.is_dir():
        pytest.skip(NO_DATASETS)
    return DATASETS


def pytest_terminal_summary(terminalreporter):
    """Say once, at the end, which tests skipped for want of the shared datasets and how to get them."""
    skipped = [r for r in terminalreporter.stats.get("skipped", [])
               if isinstance(r.longrepr, tuple) and NO_DATASETS in str(r.longrepr[2])]
    if skipped:
        names = sorted({r.nodeid.split("::")[0] for r in skipped})
        terminalreporter.write_line(
            f"{len(skipped)} tests skipped: {NO_DATASETS} (in {', '.join(names)}). They read other projects' "
            "recordings (../shared/datasets/README.md, with their licences): put that folder beside the checkout as "
            "../shared/datasets, or point RIG_DATASETS at it.", yellow=True)


@pytest.fixture(scope="session")
def simulated_lab(tmp_path_factory) -> dict:
    """Two calibrations of one simulated sensor (six-position, then twelve-position, seed 6) in a
    history of their own: ``six`` and ``twelve`` (session directories), ``db``, ``root``. Shared by
    the report tests; tests that change a session work on a copy."""
    from rig.cli import main  # the CLI is what the fixture exercises; imported once it is needed

    root = tmp_path_factory.mktemp("lab")
    db = root / "history.sqlite"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(db))
        for proc in ("six_position", "twelve_position"):
            assert main(["run", str(PROCEDURES / f"{proc}.yaml"), "--seed", "6", "--time-scale", "0",
                         "--out", str(root / proc), "--quiet"]) == 0
    return {"six": next((root / "six_position").iterdir()), "twelve": next((root / "twelve_position").iterdir()),
            "db": db, "root": root}
