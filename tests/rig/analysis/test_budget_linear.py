"""The budget by the solve's linear sensitivity (docs/uncertainty.md, "Cost"): the same contributions as one
re-solve per perturbation (to first order), no re-solve at all, and a cost that grows linearly with the steps."""

from __future__ import annotations

import time

import numpy as np
import pytest

import calib
from calib.accel.budget import contributions, linear_solve, uncertainty_section
from calib.numerics.budget import Contribution, RigErrors, combined
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

TRUTH = Truth(matrix_counts_per_g=triangular_matrix([8200.0, 8150.0, 8230.0], 1e-3, -2e-3, 5e-4),
              bias_counts=np.array([40.0, -25.0, 60.0]), tempco_counts_per_c=np.array([2.0, -0.4, 3.0]))
#: a pose direction off the faces, so every stage's errors reach the data
TILTED = np.array([[0.6, 0.0, 0.8], [0.0, -0.8, 0.6], [-0.48, 0.6, 0.64]])


def _steps(repeats: int, seed: int = 2):
    f = np.vstack([np.tile(np.vstack([six_faces(), TILTED]), (repeats, 1))])
    temps = np.linspace(15.0, 35.0, len(f))
    return make_steps(TRUTH, f, temp_c=temps, rng=np.random.default_rng(seed))


def _resolve(method, order=1, t0=25.0):
    return lambda st: calib.solve(st, model="triangular", method=method, thermal=order, t0_c=t0)


def _never(_):
    raise AssertionError("the linear budget re-solved")


def _by_name(parts):
    out = {}
    for c in parts:  # the re-solve lists lost motion per pose; the linear budget one RSS per stage
        key = c.name.split("@")[0]
        prev = out.get(key)
        out[key] = c.u if prev is None else {n: float(np.hypot(prev[n], v)) for n, v in c.u.items()}
    return out


@pytest.mark.parametrize("method", ["pinv", "combinations"])
def test_the_linear_sensitivity_gives_the_re_solves_contributions(method):
    """pinv with a thermal model on tilted poses; combinations on poses of general direction (where some subsets of
    the poses are singular at the nominal poses and not once moved, the re-solve jumps; the linear map does not)."""
    order = 1 if method == "pinv" else "off"
    general = np.random.default_rng(5).normal(size=(8, 3))
    general /= np.linalg.norm(general, axis=1, keepdims=True)
    steps = _steps(1) if method == "pinv" else make_steps(TRUTH, general, rng=np.random.default_rng(3),
                                                           with_temperature=False)
    cal = _resolve(method, order)(steps)
    rig = RigErrors.from_classes()
    slow = contributions(cal, steps, _resolve(method, order), rig)
    fast = contributions(cal, steps, _never, rig, linear_solve(cal, steps))
    u_c = combined(slow)
    a, b = _by_name(slow), _by_name(fast)
    assert set(a) == set(b)
    tol = 1e-3 if method == "pinv" else 2e-3  # combinations: second order on its ill-conditioned subsets
    for name in a:
        for q, v in a[name].items():
            if np.isfinite(v) and u_c[q] > 0:
                assert abs(b[name][q] - v) <= tol * u_c[q], (name, q, b[name][q], v)


def test_the_linear_budget_adds_up_and_needs_no_re_solve():
    steps = _steps(2)
    cal = _resolve("pinv")(steps)
    section = uncertainty_section(cal, steps, _never, RigErrors.from_classes(), linear=linear_solve(cal, steps))
    assert "datasheet" in section["rig"] or "classes" in section["rig"]
    parts = [Contribution(c["name"], c["type"], c["source"], {f"b{i}": c["bias_counts"][i] for i in range(3)})
             for c in section["budget"]]
    rss = combined(parts)
    assert [rss[f"b{i}"] for i in range(3)] == pytest.approx(section["combined_standard"]["bias_counts"], rel=1e-12)
    assert section["bias_counts"] == pytest.approx([2 * rss[f"b{i}"] for i in range(3)], rel=1e-12)


def test_the_cost_grows_linearly_with_the_steps():
    """A 2,250-step session costs about 25 times a 90-step one, not 625 times (one re-solve per step did)."""
    rig = RigErrors.from_classes()
    times = {}
    for repeats in (10, 250):
        steps = _steps(repeats)
        cal = _resolve("pinv")(steps)
        t = time.perf_counter()
        uncertainty_section(cal, steps, _never, rig, linear=linear_solve(cal, steps))
        times[len(steps)] = time.perf_counter() - t
    (k1, t1), (k2, t2) = sorted(times.items())
    assert t2 < 2.0 and t2 / t1 < 0.3 * (k2 / k1) ** 2
