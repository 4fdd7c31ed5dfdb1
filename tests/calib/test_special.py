"""The chi-square tail and the exponential integral the solvers use instead of importing
scipy.special on every solve (issue 26): they give scipy's values over the ranges the solvers use."""

import numpy as np
import pytest
from scipy import special as scipy_special

from calib.numerics.special import chi2_sf, expn

DOFS = [1, 2, 3, 5, 7, 10, 29, 100, 1000, 6000, 2.5]


@pytest.mark.parametrize("dof", DOFS)
def test_chi2_tail_matches_scipy_from_the_mode_to_the_far_tail(dof):
    chi2 = np.concatenate([np.linspace(0.0, 3 * dof + 60, 120), [1e-9, dof, dof + 0.5]])
    expected = scipy_special.chdtrc(dof, chi2)
    got = chi2_sf(chi2, dof)
    shown = expected > 1e-300
    np.testing.assert_allclose(got[shown], expected[shown], rtol=1e-11, atol=0)


def test_chi2_tail_keeps_relative_accuracy_at_a_hundred_thousand_degrees_of_freedom():
    chi2 = np.linspace(0.97e5, 1.1e5, 30)
    np.testing.assert_allclose(chi2_sf(chi2, 1e5), scipy_special.chdtrc(1e5, chi2), rtol=1e-9)


def test_chi2_tail_shapes_follow_the_inputs():
    assert isinstance(chi2_sf(3.0, 2), float)
    assert chi2_sf(np.array([1.0, 2.0, 3.0]), 2).shape == (3,)
    assert chi2_sf(0.0, 4) == 1.0
    assert chi2_sf(np.inf, 4) == 0.0
    assert np.isnan(chi2_sf(5.0, 0)) and np.isnan(chi2_sf(np.nan, 3))


@pytest.mark.parametrize("n", [0, 1, 2, 3, 5])
def test_exponential_integral_matches_scipy(n):
    x = np.geomspace(1e-6, 700, 300)
    expected = scipy_special.expn(n, x)
    got = np.array([expn(n, v) for v in x])
    shown = expected > 0
    np.testing.assert_allclose(got[shown], expected[shown], rtol=1e-13)


def test_exponential_integral_edges():
    assert expn(3, 0.0) == pytest.approx(0.5)
    assert np.isnan(expn(1, 0.0)) and np.isnan(expn(2, -1.0))
