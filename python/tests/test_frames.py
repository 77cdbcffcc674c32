"""SweepResult.to_pandas / to_xarray and MonteCarlo.to_xarray (issue 37 item 5): the same
numbers as the arrays they are built from, on the sweep's grid."""

import numpy as np
import pytest

import fpsolve


@pytest.fixture(scope="module")
def study(linear):
    return fpsolve.sweep(linear, ["epc", "grid"], degree=2, cells=(30, 60), c=[0.5, 1.0, 2.0], K=[0.5, 1.0])


def test_to_pandas_is_the_long_form(study):
    pd = pytest.importorskip("pandas", reason="pandas is not installed")
    df = study.to_pandas()
    assert list(df.columns) == ["c", "K", "method", "quantity", "converged", "mean", "variance", "std", "kurtosis"]
    assert len(df) == len(study) * len(study.methods) * len(study.quantities)
    for m in study.methods:
        for q in study.quantities:
            rows = df[(df.method == m) & (df.quantity == q)]
            assert np.array_equal(rows["variance"].to_numpy(), study.stat(m, q, "variance"), equal_nan=True)
            assert np.array_equal(rows["c"].to_numpy(), study.values["c"])
            assert np.array_equal(rows["converged"].to_numpy(), study.converged(m))
    assert isinstance(df, pd.DataFrame)


def test_to_xarray_has_the_swept_parameters_as_dims(study, linear):
    pytest.importorskip("xarray", reason="xarray is not installed")
    ds = study.to_xarray()
    assert ds["variance"].dims == ("method", "quantity", "c", "K")
    assert list(ds["c"].values) == [0.5, 1.0, 2.0] and list(ds["K"].values) == [0.5, 1.0]
    # Each cell is the point with those values.
    for k in range(len(study)):
        c, K = study.values["c"][k], study.values["K"][k]
        got = ds["variance"].sel({"method": "grid", "quantity": "z", "c": c, "K": K}).item()
        assert got == study.stat("grid", "z", "variance")[k]
        # The linear oscillator's exact Var z = pi K / (c k), k = 1 in linear.sde.
        exact = np.pi * K / (c * linear.parameters(c=c, K=K)["k"])
        assert study.stat("epc", "z", "variance")[k] == pytest.approx(exact, rel=1e-9)
    assert ds.attrs["method"] == "epc,grid"
    assert ds.attrs["fpsolve_version"] == fpsolve.__version__
    assert ds.attrs["model"]


def test_monte_carlo_to_xarray(linear):
    pytest.importorskip("xarray", reason="xarray is not installed")
    mc = linear.simulate(samples=20000, trajectories=1024, seed=2, c=0.5)
    ds = mc.to_xarray()
    for q in mc:
        assert np.array_equal(ds[q].values, mc[q].density, equal_nan=True)
        assert np.array_equal(ds[q][f"x_{q}"].values, mc[q].x)
        assert np.array_equal(ds[f"{q}_stderr"].values, mc[q].stderr, equal_nan=True)
    assert ds.attrs["seed"] == 2
