"""Headless Chromium for the tests that render a page: skipped without it, failed when CI is set (.ci/run installs
Debian's chromium)."""

from __future__ import annotations

import os
import shutil

import pytest


def headless_chromium() -> str:
    """The Chromium executable; skips the test without one, fails it under CI."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("CI is set but headless Chromium is not installed (.ci/run installs the Debian package "
                        "chromium): the browser tests must run in CI")
        pytest.skip("headless Chromium is not installed (Debian: apt-get install chromium)")
    return exe
