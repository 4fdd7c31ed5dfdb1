"""The capture's noise line is the scatter of everything captured so far, updated block by block (issue 28: a
2-hour Allan dwell must not re-read its whole capture at every poll)."""

from __future__ import annotations

import numpy as np

from rig.execution.capture import Scatter


def test_block_by_block_equals_the_scatter_of_the_whole_capture():
    rng = np.random.default_rng(4)
    blocks = [np.round(rng.normal([300, -200, 8192], [20, 25, 30], (k, 3))).astype(np.int64) for k in (0, 1, 2, 73, 18, 500)]
    s = Scatter()
    for i, b in enumerate(blocks):
        s.add(b)
        whole = np.concatenate(blocks[: i + 1])
        want = None if len(whole) < 3 else float(np.max(whole.std(axis=0, ddof=1)) / 8192 * 1e6)
        got = s.noise_ug(8192)
        assert (got is None) == (want is None) and (want is None or abs(got - want) < 1e-9 * want)

