"""Solution.logpdf / cdf / sf (issue 37 item 5): exact for the linear oscillator's Gaussian,
a jump at a point mass, exact 0/1 beyond a support edge, vectorised over any shape."""

import math
import warnings

import numpy as np
import pytest

import fpsolve

from conftest import MODELS


@pytest.fixture(scope="module")
def gaussian(linear):
    sol = linear.solve("epc", degree=2, c=0.5)
    p = linear.parameters(c=0.5)
    return sol, math.sqrt(math.pi * p["K"] / (p["c"] * p["k"]))


def test_the_linear_oscillator_is_its_exact_gaussian(gaussian):
    sol, sd = gaussian
    x = np.linspace(-5, 5, 41) * sd
    cdf = np.array([0.5 * math.erfc(-v / (sd * math.sqrt(2))) for v in x])
    sf = np.array([0.5 * math.erfc(v / (sd * math.sqrt(2))) for v in x])
    logpdf = -0.5 * (x / sd) ** 2 - math.log(sd * math.sqrt(2 * math.pi))
    np.testing.assert_allclose(sol.cdf("z", x), cdf, rtol=1e-4, atol=0)
    # The upper tail keeps its digits out to 5 sd (2.9e-7).
    np.testing.assert_allclose(sol.sf("z", x), sf, rtol=2e-4, atol=0)
    np.testing.assert_allclose(sol.logpdf("z", x), logpdf, atol=2e-5)
    np.testing.assert_allclose(sol.cdf("z", x) + sol.sf("z", x), 1.0, atol=1e-12)


def test_vectorised_over_any_shape_and_scalars(gaussian):
    sol, sd = gaussian
    grid = np.linspace(-2, 2, 12).reshape(3, 4) * sd
    assert sol.cdf("z", grid).shape == (3, 4)
    assert isinstance(sol.sf("z", 0.0), float) and sol.sf("z", 0.0) == pytest.approx(0.5, abs=1e-9)
    assert np.isnan(sol.cdf("z", np.nan))
    with pytest.raises(fpsolve.UnknownQuantityError):
        sol.cdf("nope", 0.0)


def test_beyond_the_grid_is_monotone_and_negligible(gaussian):
    sol, sd = gaussian
    x, _ = sol.marginal("z")
    far = np.array([x[0] - sd, x[0] - 10 * sd, x[-1] + sd, x[-1] + 10 * sd])
    c = sol.cdf("z", far)
    assert 0 <= c[1] <= c[0] < 1e-8 and 1 - 1e-8 < c[2] <= c[3] <= 1
    assert sol.sf("z", far[3]) < 1e-8


def test_a_point_mass_is_a_jump(tmp_path):
    # max(z, 0) is 0 with probability 1/2: the CDF jumps by 1/2 at 0, is 0 below (the edge of
    # the support: exact), and P(m > a) = P(z > a) above.
    text = (MODELS / "duffing.sde").read_text().replace("observe y = z, ydot = v", "observe m = max(z, 0)")
    sol = fpsolve.Model.from_text(text).solve("epc", degree=2)
    (value, q), = sol.moments("m").point_masses
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fpsolve.PointMassWarning)
        assert sol.cdf("m", -1e-9) == 0.0 and sol.cdf("m", -5.0) == 0.0
        assert sol.cdf("m", 0.0) == pytest.approx(q, abs=1e-6)
        assert sol.sf("m", -1e-9) == pytest.approx(1.0, abs=1e-12)
        for a in (0.3, 1.0, 2.0):
            assert sol.sf("m", a) == pytest.approx(sol.sf("z", a), rel=1e-3)
        assert sol.logpdf("m", -1.0) == -math.inf
        x = np.linspace(0.05, 2, 9)
        np.testing.assert_allclose(np.exp(sol.logpdf("m", x)), sol.pdf("z", x), rtol=1e-3)
