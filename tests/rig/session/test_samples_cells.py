"""samples.csv's cells (docs/session-format.md): every value written as ``%`` formats it, column by column, and a
temperature or magnetometer value that is not finite written as an empty cell."""

from __future__ import annotations

import numpy as np
import pytest

from rig.session.writer import format_rows

COLUMNS = ["t_s", "ax", "ay", "az", "temp_c", "gx", "gy", "gz", "mx", "my", "mz", "stage1_deg"]


def _cell(column: str, x) -> str:
    """One cell as the format promises it, written out value by value."""
    if column in ("temp_c", "mx", "my", "mz") and not np.isfinite(x):
        return ""
    if column == "t_s" or column.endswith("_deg"):
        return "%.5f" % x
    if column == "temp_c":
        return "%.4f" % x
    return "%d" % int(x)


def _columns(rng, n: int) -> dict:
    cols = {"t_s": np.cumsum(rng.uniform(0.004, 0.02, n)) + rng.choice([0.0, 1e5]),
            "temp_c": 25 + rng.normal(0, 3, n), "stage1_deg": rng.uniform(-720, 720, n)}
    for c in ("ax", "ay", "az", "gx", "gy", "gz"):
        cols[c] = rng.integers(-32768, 32768, n)
    for c in ("mx", "my", "mz"):
        cols[c] = np.round(rng.normal(0, 300, n))
    return cols


@pytest.mark.parametrize("seed", range(20))
def test_every_cell_is_the_value_formatted_and_a_missing_reading_an_empty_cell(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    cols = _columns(rng, n)
    if seed % 2:  # readings the chip did not give: NaN (and an infinity for good measure)
        for c in ("temp_c", "mx", "my", "mz"):
            cols[c][rng.random(n) < 0.4] = np.nan
        cols["mz"][0] = np.inf
    if seed % 5 == 0:
        cols["my"][:] = np.nan
    columns = [c for c in COLUMNS if seed % 3 or c not in ("gx", "gy", "gz")]
    expected = "".join(",".join(_cell(c, cols[c][k]) for c in columns) + "\n" for k in range(n))
    assert format_rows(columns, cols) == expected


def test_a_column_not_given_is_empty_and_no_rows_is_no_text():
    cols = {"t_s": np.array([0.0, 0.01]), "ax": np.array([1, -2])}
    assert format_rows(["t_s", "ax", "temp_c"], cols) == "0.00000,1,\n0.01000,-2,\n"
    assert format_rows(["temp_c"], {"temp_c": None}, n=2) == "\n\n"
    assert format_rows(["t_s", "ax"], {"t_s": np.array([]), "ax": np.array([])}) == ""
