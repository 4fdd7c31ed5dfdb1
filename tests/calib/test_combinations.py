"""``method="combinations"``: the batched evaluation equals the subset-by-subset definition, and a random
sample of the subsets (beyond ``max_subsets``) stays within its stated sampling error of the average over
every subset, on sessions where that full enumeration is still feasible."""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest

import calib
from calib.accel.combinations import choose_subsets, subset_average_maps
from calib.accel.solve import COMBINATIONS_MAX_SUBSETS, _model_with_thermal, solve_combinations
from calib.numerics.design import SENSOR_AXES
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

TRUTH = Truth(triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002), np.array([300.0, -200.0, 500.0]),
              np.array([3.0, -2.0, 4.0]), 27.6)


def reference_maps(steps, model: str, thermal) -> tuple[list, int]:
    """The definition, one subset at a time (the solver's loop before it was batched): every subset of N
    steps whose design on every axis has a singular-value ratio of at least 1e-9, ``pinv`` per axis."""
    lm, x, _ = _model_with_thermal(steps, model, thermal, None)
    k, n = len(steps), max(len(lm.terms[a]) for a in SENSOR_AXES)
    designs = [lm.design(a, x) for a in SENSOR_AXES]
    sums = [np.zeros((d.shape[1], k)) for d in designs]
    count = 0
    for subset in itertools.combinations(range(k), n):
        idx = list(subset)
        local = []
        for d in designs:
            sv = np.linalg.svd(d[idx], compute_uv=False)
            if sv[-1] < 1e-9 * sv[0] or len(sv) < d.shape[1]:
                break
            local.append(np.linalg.pinv(d[idx]))
        else:
            for acc, m in zip(sums, local):
                acc[:, idx] += m
            count += 1
    return [acc / count for acc in sums], count


def twelve_poses() -> np.ndarray:
    f = np.vstack([six_faces(), [[1, 1, 0], [-1, -1, 0], [0, 1, 1], [0, -1, -1], [1, 0, 1], [-1, 0, -1]]])
    return f / np.linalg.norm(f, axis=1, keepdims=True)


@pytest.mark.parametrize("poses,model,thermal", [
    (six_faces(), "triangular", "off"), (twelve_poses(), "triangular", "off"), (twelve_poses(), "full", "off"),
    (twelve_poses(), "triangular", 1), (np.repeat(six_faces(), 2, axis=0), "triangular", 1)])
def test_every_subset_batched_equals_the_subset_by_subset_definition(poses, model, thermal):
    temps = 25.0 + 3.0 * np.arange(len(poses)) % 7.0
    steps = make_steps(TRUTH, poses, temp_c=temps, rng=np.random.default_rng(4))
    expected, count = reference_maps(steps, model, thermal)
    cal = solve_combinations(steps, model=model, thermal=thermal)
    lm, x, _ = _model_with_thermal(steps, model, thermal, None)
    n = max(len(lm.terms[a]) for a in SENSOR_AXES)
    assert cal.fit.method == f"combinations({count} subsets of {n})"
    subsets, total, sampled = choose_subsets(len(steps), n, COMBINATIONS_MAX_SUBSETS)
    assert not sampled and total == math.comb(len(steps), n)
    got = subset_average_maps([lm.design(a, x) for a in SENSOR_AXES], subsets, total, sampled)
    assert got.count == count
    for g, e in zip(got.maps, expected):
        np.testing.assert_allclose(g, e, rtol=1e-9, atol=1e-12 * np.max(np.abs(e)))


def test_subsets_drawn_are_distinct_uniform_and_in_range():
    every = set(itertools.combinations(range(12), 4))
    drawn, total, sampled = choose_subsets(12, 4, 200, seed=3)
    assert sampled and total == 495 and len(drawn) == 200
    assert len({tuple(s) for s in drawn}) == 200 and {tuple(s) for s in drawn} <= every
    assert np.all(np.diff(drawn, axis=1) > 0)
    # the combinatorial number system's unranking covers every subset exactly once
    all_drawn, _, _ = choose_subsets(12, 4, 494, seed=0)
    assert len({tuple(s) for s in all_drawn}) == 494
    # seeded: the same steps give the same numbers
    again, _, _ = choose_subsets(12, 4, 200, seed=3)
    assert np.array_equal(drawn, again)


def sampled_and_full(steps, thermal, max_subsets: int, seed: int):
    lm, x, _ = _model_with_thermal(steps, "triangular", thermal, None)
    designs = [lm.design(a, x) for a in SENSOR_AXES]
    n = max(d.shape[1] for d in designs)
    data = [steps.mean_counts[:, j] for j in range(3)]
    full_subsets, total, _ = choose_subsets(len(steps), n, math.comb(len(steps), n))
    full = subset_average_maps(designs, full_subsets, total, False, data)
    subsets, total, sampled = choose_subsets(len(steps), n, max_subsets, seed)
    assert sampled
    return subset_average_maps(designs, subsets, total, True, data), full


def cube_directions() -> np.ndarray:
    """The 26 directions of procedures/tumble26.yaml: the cube's faces, edges and corners."""
    f = np.array([[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)],
                 float)
    return f / np.linalg.norm(f, axis=1, keepdims=True)


@pytest.mark.parametrize("thermal,draws", [("off", 2000), (1, 4000)])
def test_a_random_sample_of_subsets_is_within_four_sampling_errors_of_every_subset(thermal, draws):
    """The stated tolerance (docs/methods.md, "Peers"): on the shipped procedures' pose sets (the cube's
    directions: every subset of them is either exactly singular or well conditioned) every parameter of the
    sampled average is within 4 of its estimated sampling errors of the average over every subset
    (C(26, 4) = 14950 and, with a temperature term over four temperature levels, C(26, 5) = 65780 subsets
    enumerated here; five seeds each)."""
    temps = 20.0 + 5.0 * (np.arange(26) // 7) + 0.2 * np.random.default_rng(3).random(26) if thermal else None
    steps = make_steps(TRUTH, cube_directions(), temp_c=temps, rng=np.random.default_rng(8))
    ratios = []
    for seed in range(5):
        sample, full = sampled_and_full(steps, thermal, draws, seed)
        for j in range(3):
            y = steps.mean_counts[:, j]
            assert np.all(sample.sampling_se[j] > 0)
            ratios.append(np.abs(sample.maps[j] @ y - full.maps[j] @ y) / sample.sampling_se[j])
    ratios = np.concatenate(ratios)
    assert np.max(ratios) < 4.0, np.max(ratios)
    assert 0.3 < np.sqrt(np.mean(ratios**2)) < 1.7  # the standard error is the scatter's, not a loose bound


def test_the_solve_names_the_sample_and_its_sampling_error_in_sigmas():
    steps = make_steps(TRUTH, cube_directions(), rng=np.random.default_rng(9))
    full = calib.solve(steps, method="combinations", thermal="off")
    assert re.fullmatch(r"combinations\(\d+ subsets of 4\)", full.fit.method), full.fit.method
    sampled = solve_combinations(steps, thermal="off", max_subsets=2000, seed=1)
    found = re.fullmatch(r"combinations\((\d+) subsets of 4, a random sample of the 14950; "
                         r"sampling error up to ([0-9.e+-]+) sigma\)", sampled.fit.method)
    assert found, sampled.fit.method
    ratio = float(found.group(2))
    sigma = np.asarray(full.sigma["bias_counts"])
    assert np.all(np.abs(sampled.bias_counts - full.bias_counts) <= 4 * ratio * sigma)
