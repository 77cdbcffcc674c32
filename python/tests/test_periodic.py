"""A periodic state from Python: the grid solves it (its angle on one period, as the command
line does), Monte Carlo records the angle in the same window, and the methods that do not
represent it refuse with their reason."""

import math

import numpy as np
import pytest

import fpsolve

PENDULUM = """model pendulum
param c = 0.5, k = 2, S = 0.5
state theta, w
drift theta: w
drift w: -c*w - k*sin(theta)
noise xi: intensity S
diffusion w: xi
domain theta periodic 2*pi
"""


def test_the_grid_gives_the_von_mises_angle():
    model = fpsolve.Model.from_text(PENDULUM)
    sol = model.solve("grid", tol=1e-3)
    x, p = sol.marginal("theta")
    # The curve spans the window, its ends one point of the circle.
    assert x[0] == pytest.approx(-math.pi) and x[-1] == pytest.approx(math.pi)
    assert p[0] == pytest.approx(p[-1], rel=1e-9)
    # kappa = 2 c k / S = 4: p(theta) = exp(4 cos theta) / (2 pi I0(4)).
    t = np.linspace(-math.pi, math.pi, 20001)
    norm = np.sum(np.exp(4 * np.cos(t[:-1]))) * (t[1] - t[0])
    exact = np.exp(4 * np.cos(x)) / norm
    err = np.abs(p - exact)
    assert np.sum(0.5 * (err[1:] + err[:-1]) * np.diff(x)) < 1e-3
    assert sol.moments("w").variance == pytest.approx(0.5, rel=2e-3)


@pytest.mark.parametrize("method", ["epc", "epc-impact"])
def test_epc_refuses_with_its_reason(method):
    model = fpsolve.Model.from_text(PENDULUM)
    with pytest.raises(fpsolve.NotApplicableError) as info:
        model.solve(method, degree=4)
    assert info.value.kind == "periodic_state" and "periodic" in str(info.value)


def test_monte_carlo_records_the_angle_in_its_window():
    model = fpsolve.Model.from_text(PENDULUM)
    mc = model.simulate(samples=2_000_000, seed=3)
    h = mc["theta"]
    assert h.edges[0] == pytest.approx(-math.pi) and h.edges[-1] == pytest.approx(math.pi)
    assert h.outside == 0
    # von Mises, kappa = 4: Var theta = 0.298228 (midpoint rule on 2e5 points).
    value, stderr = h.moments["variance"]
    assert abs(value - 0.298228) < 5 * stderr + 1e-3
    # Its crossings are not counted (the recorded angle jumps at the seam).
    with pytest.raises(fpsolve.MonteCarloError) as info:
        model.simulate(samples=10_000, levels={"theta": [0.0]})
    assert info.value.kind == "bad_setting"


def test_monte_carlo_transient_and_passage_refuse():
    # They ran before, with the angle unwrapped (a variance of 23.5 on a circle of 2 pi).
    model = fpsolve.Model.from_text(PENDULUM)
    with pytest.raises(fpsolve.MonteCarloError) as info:
        model.transient("0:20:5", method="mc", domain={"theta": (-math.pi, math.pi), "w": (-5, 5)})
    assert info.value.kind == "periodic_state"
    with pytest.raises(fpsolve.MonteCarloError) as info:
        model.passage(safe="abs(w) < 2", method="mc", horizon=50)
    assert info.value.kind == "periodic_state"
