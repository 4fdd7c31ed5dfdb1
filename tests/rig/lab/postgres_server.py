"""The PostgreSQL server the history tests run against: ``$RIG_TEST_POSTGRES_URL`` (``.ci/run`` starts one with
``.ci/postgres.sh`` and exports it), else the one ``.ci/postgres.sh`` starts here; a fresh database per test.
No server: the PostgreSQL half of the tests is skipped, saying why; with ``CI`` set it fails instead."""

from __future__ import annotations

import fcntl
import os
import subprocess
import uuid
from contextlib import contextmanager
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
_found: dict = {}


def server_url() -> tuple[str | None, str]:
    """``(url, "")`` of a server that answers, else ``(None, why not)``; asked once per test process."""
    if "url" not in _found:
        _found["url"], _found["why"] = _find()
    return _found["url"], _found["why"]


def _find() -> tuple[str | None, str]:
    url = os.environ.get("RIG_TEST_POSTGRES_URL")
    if not url:
        with open("/tmp/rig-postgres-start.lock", "w") as lock:  # two test workers: one starts it
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                out = subprocess.run(["bash", str(REPO / ".ci/postgres.sh")], capture_output=True, text=True,
                                     timeout=120)
            except (OSError, subprocess.SubprocessError) as exc:
                return None, f".ci/postgres.sh did not run ({exc})"
        if out.returncode != 0 or "RIG_TEST_POSTGRES_URL=" not in out.stdout:
            return None, f".ci/postgres.sh failed: {(out.stderr.strip().splitlines() or ['?'])[-1]}"
        url = out.stdout.strip().split("RIG_TEST_POSTGRES_URL=", 1)[1]
    try:
        import sqlalchemy as sa

        with sa.create_engine(url).connect() as c:
            c.exec_driver_sql("SELECT 1")
    except Exception as exc:  # noqa: BLE001 - any failure to connect is a reason to skip, stated
        return None, f"{url}: {(str(exc).strip().splitlines() or [type(exc).__name__])[0]}"
    return url, ""


def require_server() -> str:
    """The server's URL; skips the test (fails it when ``CI`` is set) when there is none."""
    url, why = server_url()
    if url is None:
        if os.environ.get("CI"):
            pytest.fail(f"no PostgreSQL server for the history tests ({why}); CI is set, so this fails instead of "
                        "skipping (bash .ci/postgres.sh starts one)")
        pytest.skip(f"PostgreSQL half skipped: no server could be started ({why})")
    return url


@contextmanager
def fresh_database(url: str):
    """A new, empty database on the server at ``url`` (dropped afterwards); yields its URL."""
    import sqlalchemy as sa

    name = "rig_test_" + uuid.uuid4().hex[:12]
    admin = sa.create_engine(url, isolation_level="AUTOCOMMIT")
    with admin.connect() as c:
        c.exec_driver_sql(f"CREATE DATABASE {name}")
    try:
        yield url.rsplit("/", 1)[0] + "/" + name
    finally:
        with admin.connect() as c:
            c.exec_driver_sql(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)")
        admin.dispose()


@pytest.fixture(params=["sqlite", "postgresql"])
def history(request, tmp_path, monkeypatch):
    """A history's location, once a SQLite file and once a fresh PostgreSQL database; the outbox in ``tmp_path``.
    A test module imports it (``from postgres_server import history``) to run on both backends."""
    monkeypatch.setenv("RIG_HISTORY_OUTBOX", str(tmp_path / "outbox"))
    if request.param == "sqlite":
        yield str(tmp_path / "h.sqlite")
        return
    with fresh_database(require_server()) as url:
        yield url
