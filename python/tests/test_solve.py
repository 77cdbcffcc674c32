"""Model.solve and Solution: exact solutions, NumPy dtypes and shapes, reports and the typed
exceptions of failed solves."""

import math
import warnings

import numpy as np
import pytest

import fpsolve
from conftest import MODELS


def gaussian(x, var):
    return np.exp(-x * x / (2 * var)) / np.sqrt(2 * np.pi * var)


@pytest.mark.parametrize("method, tol", [("epc", 1e-9), ("grid", 1e-2)])
def test_linear_oscillator_is_the_exact_gaussian(linear, method, tol):
    # Var z = pi K / (c k) = 5, Var v = pi K / c = 5 with c = 0.1, k = 1, K = 1/(2 pi).
    # EPC at degree 2 is exact; the grid on 100x100 cells is within 0.5% of the peak.
    sol = linear.solve(method, degree=2, cells=(100, 100))
    x = np.linspace(-6, 6, 25)
    peak = gaussian(0.0, 5.0)
    for name in ("z", "v"):
        err = np.max(np.abs(sol.pdf(name, x) - gaussian(x, 5.0))) / peak
        assert err < tol
        m = sol.moments(name)
        assert m.variance == pytest.approx(5.0, rel=tol)
        assert m.mean == pytest.approx(0.0, abs=tol)
    joint = sol.joint(1.0, -2.0)
    assert joint == pytest.approx(gaussian(1.0, 5.0) * gaussian(-2.0, 5.0), rel=2 * tol)


def test_overrides_change_the_solution(linear):
    # Var z = pi K / (c k): doubling k halves it.
    sol = linear.solve("epc", degree=2, k=2)
    assert sol.moments("z").variance == pytest.approx(2.5, rel=1e-9)


def test_pdf_dtypes_and_shapes(vibro):
    sol = vibro.solve("epc", degree=4)
    p = sol.pdf("y", [0.5, 1.0, 1.5])
    assert isinstance(p, np.ndarray) and p.dtype == np.float64 and p.shape == (3,)
    grid = np.linspace(0, 2, 12).reshape(3, 4)
    q = sol.pdf("y", grid)
    assert q.shape == (3, 4)
    np.testing.assert_array_equal(q.ravel(), sol.pdf("y", grid.ravel()))
    s = sol.pdf("y", 1.0)
    assert isinstance(s, float) and s == p[1]
    assert sol.pdf("y", np.array([], dtype=np.float64)).shape == (0,)
    # Non-contiguous and integer input are accepted.
    np.testing.assert_array_equal(sol.pdf("y", grid[:, ::2]), sol.pdf("y", np.ascontiguousarray(grid[:, ::2])))
    assert sol.pdf("y", np.array([1])).dtype == np.float64


def test_joint_broadcasts(vibro):
    sol = vibro.solve("epc", degree=4)
    z, v = np.meshgrid(np.linspace(-2, 2, 5), np.linspace(-3, 3, 7))
    p = sol.joint(z, v)
    assert p.shape == (7, 5) and p.dtype == np.float64
    row = sol.joint(np.linspace(-2, 2, 5), 0.5)
    assert row.shape == (5,)
    assert row[1] == sol.joint(-1.0, 0.5)


def test_marginal_is_a_normalised_density(vibro):
    sol = vibro.solve("epc", degree=4)
    x, p = sol.marginal("y")
    assert x.dtype == p.dtype == np.float64 and x.shape == p.shape and x.ndim == 1
    assert np.all(np.diff(x) > 0)
    assert np.trapezoid(p, x) == pytest.approx(1.0, abs=2e-3)
    np.testing.assert_array_equal(sol.pdf("y", x), p)


def test_moments_tail_coefficients_report(vibro):
    sol = vibro.solve("epc", degree=4)
    assert (sol.method, sol.degree) == ("epc", 4)
    assert sol.quantities == ("z", "v", "y", "ydot")
    m = sol.moments("y")
    assert isinstance(m, fpsolve.Moments)
    assert m.raw[0] == m.mean and m.std == math.sqrt(m.variance)
    assert m.existing_moments == 4 and m.undefined_mass == 0.0
    t = sol.tail_probability("y", 1.0)
    assert 0.0 < t < 1.0
    c = sol.coefficients
    assert set(c) == {(i, d - i) for d in range(1, 5) for i in range(d + 1)}
    r = sol.report
    assert r["degree"] == 4
    assert r["solve"]["iterations"] >= 1
    assert r["solve"]["residual"] <= r["solve"]["residual_threshold"]
    assert r["coefficients"] == [c[tuple(e)] for e in r["exponents"]]
    assert "normalisation" in r and r["solve"]["solve_ms"] >= 0


def test_each_method_on_the_vibro_impact_model(vibro_impact):
    means = {}
    for method in fpsolve.METHODS:
        sol = vibro_impact.solve(method, degree=4)
        assert sol.method == method
        means[method] = sol.moments("y").mean
        x, p = sol.marginal("y")
        assert np.trapezoid(p, x) == pytest.approx(1.0, abs=5e-3)
    # The three methods agree on the mean displacement to a few per cent (docs/method.md).
    assert means["epc"] == pytest.approx(means["grid"], rel=0.03)
    assert means["epc-impact"] == pytest.approx(means["grid"], rel=0.03)


def test_grid_report_and_no_coefficients(linear):
    sol = linear.solve("grid", cells=(40, 40))
    assert sol.degree is None
    assert sol.report["cells"] == [40, 40]
    with pytest.raises(fpsolve.NotApplicableError) as info:
        sol.coefficients
    assert info.value.kind == "no_coefficients"


def test_unknown_quantity(vibro):
    sol = vibro.solve("epc", degree=2)
    with pytest.raises(fpsolve.UnknownQuantityError) as info:
        sol.pdf("w", [1.0])
    e = info.value
    assert (e.name, e.known, e.method, e.degree) == ("w", ["z", "v", "y", "ydot"], "epc", 2)
    with pytest.raises(fpsolve.SolveError):
        sol.moments("w")


def test_odd_degree_is_refused_with_its_data(vibro):
    with pytest.raises(fpsolve.SolveError) as info:
        vibro.solve("epc", degree=3)
    assert (info.value.kind, info.value.degree) == ("odd_degree", 3)


def test_not_normalisable_carries_degree(vibro):
    # Table 1's neighbourhood: at eps = 0.15, mu = 0.1 the degree-4 ridge is too shallow.
    with pytest.raises(fpsolve.NotNormalisableError) as info:
        vibro.solve("epc", degree=4, eps=0.15)
    assert (info.value.kind, info.value.degree, info.value.method) == ("not_normalisable", 4, "epc")
    assert isinstance(info.value, fpsolve.SolveError)


def test_no_convergence_carries_residuals(vibro):
    # Degree 6 has no solution for the paper's cases (docs/method.md, section 3).
    with pytest.raises(fpsolve.NoConvergenceError) as info:
        vibro.solve("epc", degree=6)
    e = info.value
    assert (e.kind, e.degree) == ("no_convergence", 6)
    assert e.residual > e.threshold > 0
    assert e.gradient >= 0


def test_method_that_does_not_apply(vibro):
    # epc-impact takes the original-coordinates model, not the Zhuravlev form.
    with pytest.raises(fpsolve.NotApplicableError) as info:
        vibro.solve("epc-impact", degree=4)
    assert (info.value.kind, info.value.method) == ("unsupported", "epc-impact")


def test_unknown_method_is_a_value_error(vibro):
    with pytest.raises(ValueError):
        vibro.solve("galerkin")


def test_too_many_cells_are_refused_before_any_work(linear):
    with pytest.raises(ValueError):
        linear.solve("grid", cells=(100_000, 100_000))


def test_joint_states_name_the_joint_densitys_coordinates(vibro_impact):
    # The δ-term EPC of a model in its own coordinates solves the Zhuravlev transform: its
    # joint density is over (z, v), the model's y, ydot being observables of it; the methods
    # with the exact impact condition keep the model's states.
    epc = vibro_impact.solve("epc", degree=4)
    assert epc.joint_states == ("z", "v")
    # joint(-0.5, 0) is a density value of z below the wall (the model's y is never below it).
    assert epc.joint(-0.5, 0.0) > 0.0
    assert epc.pdf("y", -0.5) == 0.0
    for method in ("epc-impact", "grid"):
        assert vibro_impact.solve(method, degree=4).joint_states == ("y", "ydot")


def test_point_masses_are_data_and_a_warning():
    # max(z, 0) is 0 with probability 1/2 (p(z) even): no density there; its PDF integrates
    # to 1/2. The CLI flags it (exit 1); Python gives the masses and warns once.
    text = (MODELS / "duffing.sde").read_text().replace("observe y = z, ydot = v", "observe m = max(z, 0)")
    sol = fpsolve.Model.from_text(text).solve("epc", degree=2)
    masses = sol.moments("m").point_masses
    assert len(masses) == 1 and masses[0][0] == 0.0
    assert masses[0][1] == pytest.approx(0.5, abs=2e-3)
    assert sol.moments("z").point_masses == ()
    with pytest.warns(fpsolve.PointMassWarning, match="integrates to about 0.5"):
        sol.pdf("m", [0.5, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol.pdf("m", 0.5)  # once per quantity
        sol.pdf("z", 0.5)  # states never


def test_grid_domain_fixes_the_box_and_is_checked(linear):
    # The linear model's states are z and v; the same box as a mapping and as the CLI's text.
    a = linear.solve("grid", cells=(40, 80), domain={"z": (-12, 13), "v": (-12, 12)})
    b = linear.solve("grid", cells=(40, 80), domain="z=-12:13,v=-12:12")
    assert a.report["domain"] == {"x": [-12.0, 13.0], "v": [-12.0, 12.0]}
    x = np.linspace(-3, 3, 7)
    assert np.array_equal(a.pdf("z", x), b.pdf("z", x))
    # A box that cuts the density is flagged in the report, not refused.
    cut = linear.solve("grid", cells=(40, 80), domain={"z": (-2, 2), "v": (-12, 12)})
    assert cut.report["edges"]["cuts_density"]
    # Malformed boxes and a box for another method are refused before any work.
    with pytest.raises(ValueError, match="domain"):
        linear.solve("grid", domain="z=3:1,v=-1:1")
    with pytest.raises(ValueError, match="domain"):
        linear.solve("grid", domain="q=0:1,v=-1:1")
    with pytest.raises(ValueError, match="only the grid"):
        linear.solve("epc", domain="z=-5:5,v=-5:5")


def test_a_solution_with_a_box_pickles(linear):
    import pickle

    sol = linear.solve("grid", cells=(40, 80), domain={"z": (-12, 13), "v": (-12, 12)})
    back = pickle.loads(pickle.dumps(sol))
    assert back.report["domain"] == sol.report["domain"]
    x = np.linspace(-3, 3, 7)
    assert np.array_equal(back.pdf("z", x), sol.pdf("z", x))
