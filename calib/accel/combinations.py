"""The C(m, N) averaging of ``method="combinations"``: the exactly-determined solutions of pose subsets.

For every subset S of N of the m steps whose design rows determine every output axis, the per-axis
solution is ``p_S = G_S^+ a_S`` (the inverse of the N x N design where the axis has N parameters, the
least-squares solution where it has fewer). The method averages them over the subsets; the average is
a fixed linear map of the step means, ``p = A a`` with ``A = mean over S of E_S G_S^+`` (``E_S`` puts the
subset's columns at its steps' places), so its covariance is exact.

:func:`subset_average_maps` evaluates the subsets a block at a time with batched numpy linear algebra
(no Python loop over the subsets). :func:`choose_subsets` gives every subset when there are at most
``limit`` of them, else ``limit`` of them drawn uniformly at random without replacement (a fixed seed:
the same session always gives the same numbers). A sample's average differs from the average over all
subsets by its sampling error, which :func:`subset_average_maps` estimates from the spread of the
sampled solutions (docs/methods.md, "Peers").
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from calib.errors import CalibError

#: a subset whose design has a singular-value ratio below this on some axis does not determine the model
SINGULAR_RATIO = 1e-9
#: subsets are evaluated this many at a time (bounded memory)
BLOCK = 8192
#: below this bound on the condition number of the design (square) or of its normal matrix (tall) the
#: batched inverse is used as it is (relative error below 1e-10); above it the subset goes through the
#: singular value decomposition (the exact singular-value test and pseudo-inverse)
FAST_COND = 1e6


@dataclass
class SubsetAverage:
    """The average maps (one (P_a, m) array per axis), how many subsets determined the model
    (``count``) and, for a random sample (``sampled``), the standard error of each axis' averaged
    parameters (P_a,) as an estimate of the average over every subset (``sampling_se``, else zeros)."""

    maps: list
    count: int
    total: int
    sampled: bool
    sampling_se: list


def choose_subsets(k: int, n: int, limit: int, seed: int = 0) -> tuple[np.ndarray, int, bool]:
    """The subsets of ``n`` of ``k`` steps to average: (subsets (M, n), sorted indices, how many subsets
    there are in all, whether the M are a random sample of them). Every subset in lexicographic order
    when there are at most ``limit``; else ``limit`` distinct ones drawn uniformly (seed ``seed``)."""
    total = math.comb(k, n)
    if total <= limit:
        return np.array(list(itertools.combinations(range(k), n)), dtype=np.int64).reshape(-1, n), total, False
    if total >= 2**63:
        raise CalibError(f"C({k}, {n}) subsets: too many to draw from")
    ranks = np.sort(np.random.default_rng(seed).choice(total, size=limit, replace=False))
    return _unrank(ranks, k, n), total, True


def _unrank(ranks: np.ndarray, k: int, n: int) -> np.ndarray:
    """The subsets (sorted indices) of the combinatorial number system's ``ranks``:
    ``rank = sum_i C(c_i, i)`` with ``c_n > ... > c_1`` (greedy from the largest)."""
    r = np.asarray(ranks, np.int64).copy()
    out = np.empty((len(r), n), np.int64)
    for i in range(n, 0, -1):
        table = np.array([math.comb(c, i) for c in range(k)], np.int64)
        c = np.searchsorted(table, r, side="right") - 1
        out[:, i - 1] = c
        r -= table[c]
    return out


def subset_average_maps(designs: list, subsets: np.ndarray, total: int, sampled: bool,
                        data: list | None = None) -> SubsetAverage:
    """The average of ``E_S G_S^+`` per axis over the ``subsets`` (M, n) that determine every axis
    (``designs``: one (m, P_a) array per axis). With ``sampled`` (the M drawn from ``total``) and the
    axes' step means ``data`` (one (m,) array per axis), the sampling error of the averaged parameters:
    the standard deviation of the sampled subsets' solutions over the square root of their count, with
    the finite-population correction ``sqrt(1 - M / total)``."""
    k = designs[0].shape[0]
    sums = [np.zeros((d.shape[1], k)) for d in designs]
    solutions: list[list] = [[] for _ in designs]
    count = 0
    for s, blocks in determined_blocks(designs, subsets):
        for j, (acc, local) in enumerate(zip(sums, blocks)):
            _scatter_add(acc, s, local)
            if sampled and data is not None:
                solutions[j].append(np.einsum("cpn,cn->cp", local, np.asarray(data[j], float)[s]))
        count += len(s)
    maps = [acc / count if count else acc for acc in sums]
    se = [np.zeros(d.shape[1]) for d in designs]
    if sampled and data is not None and count > 1:
        fpc = math.sqrt(max(1.0 - len(subsets) / total, 0.0))
        se = [np.concatenate(sol).std(axis=0, ddof=1) / math.sqrt(count) * fpc for sol in solutions]
    return SubsetAverage(maps, count, total, sampled, se)


def determined_blocks(designs: list, subsets: np.ndarray):
    """The subsets (M, n) that determine every axis, a block of at most :data:`BLOCK` at a time: yields ``(s, locals)``,
    ``s`` the block's determined subsets and ``locals`` per axis their pseudo-inverses (c, P_a, n)."""
    for start in range(0, len(subsets), BLOCK):
        s = subsets[start:start + BLOCK]
        blocks, ok = [], np.ones(len(s), bool)
        for d in designs:
            local, good = pinv_batch(d[s])
            blocks.append(local)
            ok &= good
        if ok.any():
            yield s[ok], [local[ok] for local in blocks]


def _scatter_add(acc: np.ndarray, subsets: np.ndarray, local: np.ndarray) -> None:
    """``acc[:, subset] += local`` for every subset (c, n) and its local map (c, P, n), in subset order."""
    idx = subsets.ravel()
    for r in range(local.shape[1]):
        acc[r] += np.bincount(idx, weights=local[:, r, :].ravel(), minlength=acc.shape[1])


def pinv_batch(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pseudo-inverses (c, P, n) of the designs ``g`` (c, n, P) and whether each determines its P
    parameters (singular-value ratio at least :data:`SINGULAR_RATIO`; the others' maps are left zero).

    Square designs by their batched inverse, tall ones by the normal equations, wherever
    ``|X|_F |X^-1|_F`` (at least the 2-norm condition number of X, at most P times it; X the design or
    its normal matrix) is at most :data:`FAST_COND`; the rest (near-singular or singular) by the singular
    value decomposition, as :func:`numpy.linalg.pinv` and the singular-value test."""
    c, n, p = g.shape
    if n < p:
        return np.zeros((c, p, n)), np.zeros(c, bool)
    square = n == p
    gt = np.swapaxes(g, 1, 2)
    x = g if square else gt @ g  # the design, or its normal matrix
    det = np.linalg.det(x)
    invertible = np.isfinite(det) & (det != 0)
    x_safe = np.where(invertible[:, None, None], x, np.eye(p))  # exactly singular ones: identity, dropped below
    inv = np.linalg.inv(x_safe)
    bound = np.sqrt(np.einsum("cij,cij->c", x, x) * np.einsum("cij,cij->c", inv, inv))
    good = invertible & (bound <= FAST_COND)
    out = inv if square else inv @ gt
    out[~good] = 0.0
    slow = np.flatnonzero(~good)
    if len(slow):
        sv = np.linalg.svd(g[slow], compute_uv=False)
        slow = slow[sv[:, -1] >= SINGULAR_RATIO * sv[:, 0]]
        if len(slow):
            out[slow] = np.linalg.pinv(g[slow])
            good[slow] = True
    return out, good
