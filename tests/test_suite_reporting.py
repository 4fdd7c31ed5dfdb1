"""What the test run itself tells its reader (issue 26): tests that need the shared datasets and do not
find them are named once, at the end, with how to get the datasets."""

from __future__ import annotations

from conftest import REPO

pytest_plugins = ["pytester"]


def test_a_run_without_the_datasets_says_once_which_tests_skipped_and_how_to_get_them(pytester, monkeypatch):
    pytester.makeconftest((REPO / "tests" / "conftest.py").read_text())
    pytester.makepyfile(test_needs_data="""
        def test_one(datasets):
            assert datasets.is_dir()

        def test_two(datasets):
            assert datasets.is_dir()

        def test_other():
            pass
    """)
    monkeypatch.setenv("RIG_DATASETS", str(pytester.path / "no-datasets-here"))
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, skipped=2)
    said = [line for line in result.outlines if "tests skipped: shared datasets not found" in line]
    assert len(said) == 1, result.outlines
    assert said[0].startswith("2 tests skipped") and "test_needs_data.py" in said[0]
    assert "RIG_DATASETS" in said[0] and "../shared/datasets" in said[0]
