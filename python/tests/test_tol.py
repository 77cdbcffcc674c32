"""Model.solve(tol=...): the grid chooses its cells for an L1 accuracy, its report says what it
asked, achieved and chose, the true error against the linear oscillator's exact Gaussian
marginals is below the estimate, and bad tolerances are refused before any work."""

import math
import pickle
import warnings

import numpy as np
import pytest

import fpsolve
from conftest import MODELS


def gaussian(x, var):
    return np.exp(-x * x / (2 * var)) / np.sqrt(2 * np.pi * var)


@pytest.fixture(scope="module")
def linear() -> fpsolve.Model:
    return fpsolve.Model.load(MODELS / "linear.sde")


def test_a_tolerance_is_reached_and_bounds_the_true_error(linear):
    sol = linear.solve("grid", tol=0.005)
    t = sol.report["tolerance"]
    assert t["asked"] == 0.005
    assert t["reached"] is True and t["shortfall"] is None
    assert t["achieved"] <= 0.005
    # The solves made, in order, each with its cells and estimate; the last is the one kept.
    cells, estimate = t["solves"][-1]
    assert list(sol.report["cells"]) == list(cells)
    assert estimate == t["achieved"]
    assert len(t["solves"]) >= 2
    # Var z = Var v = 5 (c = 0.1, k = 1, K = 1/(2 pi)): the L1 distance of each marginal from
    # the exact one, on the box and beyond it.
    for name in ("z", "v"):
        lo, hi = sol.report["domain"]["x" if name == "z" else "v"]
        x = np.linspace(lo, hi, 8001)
        err = np.abs(sol.pdf(name, x) - gaussian(x, 5.0))
        inside = float(np.sum(0.5 * (err[1:] + err[:-1]) * np.diff(x)))
        outside = math.erfc(min(-lo, hi) / math.sqrt(10.0))
        assert inside + outside < t["achieved"], (name, inside, outside, t)


def test_a_tolerance_survives_pickling(linear):
    sol = linear.solve("grid", tol=0.05)
    back = pickle.loads(pickle.dumps(sol))
    assert back.report["tolerance"] == sol.report["tolerance"]
    x = np.linspace(-4.0, 4.0, 9)
    assert np.array_equal(back.pdf("z", x), sol.pdf("z", x))


def test_a_tolerance_not_reached_is_a_warning_with_the_best_solve(linear):
    # A box that cuts the velocity density (sd 2.2) at +-2: no cells bring that mass back.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = linear.solve("grid", tol=1e-3, domain="z=-12:12,v=-2:2")
    t = sol.report["tolerance"]
    assert t["reached"] is False
    assert t["shortfall"]["kind"] == "box_cuts"
    assert t["achieved"] > 1e-3
    said = [w for w in caught if issubclass(w.category, fpsolve.FpsolveWarning)]
    assert said and "did not reach the L1 tolerance" in str(said[0].message)


@pytest.mark.parametrize("tol", [0.0, -1e-3, 0.6, float("nan"), float("inf")])
def test_a_tolerance_out_of_range_is_refused(linear, tol):
    with pytest.raises(ValueError, match="tol"):
        linear.solve("grid", tol=tol)


def test_a_tolerance_needs_the_grid_and_no_cells(linear):
    with pytest.raises(ValueError, match="cells"):
        linear.solve("grid", tol=1e-3, cells=(40, 80))
    with pytest.raises(ValueError, match="only the grid"):
        linear.solve("epc", tol=1e-3)
