"""fpsolve.sweep: arrays over the points, failures kept, agreement with `fpsolve sweep`."""

import csv
import math
import subprocess

import numpy as np
import pytest

import fpsolve
from conftest import MODELS


def test_two_parameters_by_two_methods(linear):
    r = fpsolve.sweep(linear, method=["epc", "grid"], degree=2, cells=(100, 100), c=[0.1, 0.2], k=[1.0, 2.0, 4.0])
    assert len(r) == 6 and r.methods == ("epc", "grid")
    assert set(r.values) == {"c", "k"}
    assert r.values["c"].dtype == np.float64 and r.values["c"].shape == (6,)
    # The first parameter varies fastest.
    np.testing.assert_array_equal(r.values["c"], [0.1, 0.2] * 3)
    np.testing.assert_array_equal(r.values["k"], [1.0, 1.0, 2.0, 2.0, 4.0, 4.0])
    assert r.converged("epc").dtype == bool and r.converged("epc").all()
    # Var z = pi K / (c k) with K = 1/(2 pi): exact for EPC at degree 2.
    exact = 0.5 / (r.values["c"] * r.values["k"])
    np.testing.assert_allclose(r.stat("epc", "z", "variance"), exact, rtol=1e-9)
    np.testing.assert_allclose(r.stat("epc", "z", "std"), np.sqrt(exact), rtol=1e-9)
    # The grid on 100x100 cells: within 2% (its discretisation error).
    np.testing.assert_allclose(r.stat("grid", "z", "variance"), exact, rtol=0.02)
    assert r.report["degree"] == 2


def test_a_point_equals_a_solve(vibro):
    r = fpsolve.sweep(vibro, eps=[-0.3, 0.0], mu=0.5)
    for k, eps in enumerate(r.values["eps"]):
        m = vibro.solve("epc", degree=4, eps=eps, mu=0.5).moments("y")
        assert r.stat("epc", "y", "mean")[k] == m.mean
        assert r.stat("epc", "y", "kurtosis")[k] == m.kurtosis


def test_failed_points_are_nan_with_their_reason(vibro):
    r = fpsolve.sweep(vibro, eps=[-0.3, 0.15])
    ok = r.converged("epc")
    np.testing.assert_array_equal(ok, [True, False])
    mean = r.stat("epc", "y", "mean")
    assert not math.isnan(mean[0]) and math.isnan(mean[1])
    (failure,) = r.failures("epc")
    assert failure["values"] == {"eps": 0.15}
    assert failure["stage"] == "epc"


def test_sweep_errors(vibro):
    with pytest.raises(fpsolve.SweepError) as info:
        fpsolve.sweep(vibro, mu=0.5)
    assert info.value.kind == "nothing_swept"
    with pytest.raises(fpsolve.SweepError) as info:
        fpsolve.sweep(vibro, muu=[0.1, 0.2])
    assert (info.value.kind, info.value.name) == ("unknown_parameter", "muu")
    with pytest.raises(fpsolve.SweepError) as info:
        fpsolve.sweep(vibro, method="epc-impact", eps=[0.1, 0.2])
    assert info.value.kind == "method"
    # Values further apart than the largest float (the figures' axis search looped on them).
    with pytest.raises(fpsolve.SweepError) as info:
        fpsolve.sweep(vibro, eps=[-1e308, 1e308])
    assert info.value.kind == "span_overflow"
    with pytest.raises(KeyError):
        fpsolve.sweep(vibro, eps=[0.1, 0.2]).stat("grid", "y")


def test_agrees_with_the_cli_sweep_csv(cli, vibro, tmp_path):
    out = tmp_path / "sweep"
    run = subprocess.run(
        [cli, "sweep", MODELS / "vibro_duffing.sde", "--set", "eps=-0.3,-0.1,0.1,0.3",
         "--set", "mu=0.5", "--out", out, "--quiet"],
        capture_output=True, text=True,
    )
    assert run.returncode in (0, 1), run.stderr  # 1: some points failed, all written
    rows = list(csv.DictReader(open(out / "sweep.csv")))
    r = fpsolve.sweep(vibro, eps=[-0.3, -0.1, 0.1, 0.3], mu=0.5)
    assert [float(row["eps"]) for row in rows] == list(r.values["eps"])
    assert [row["epc_status"] == "converged" for row in rows] == list(r.converged("epc"))
    for q in vibro.quantities:
        for col, stat in (("mean", "mean"), ("std_dev", "std"), ("kurtosis", "kurtosis")):
            c = f"epc_{q}_{col}"
            cli_values = [float(row[c]) if row[c] else math.nan for row in rows]
            np.testing.assert_array_equal(r.stat("epc", q, stat), cli_values)


def test_threads_is_the_pool_size_not_a_parameter(vibro):
    # threads=1 used to be read as a model parameter (an unknown-parameter error).
    eps = [-0.1, 0.0, 0.1]
    one = fpsolve.sweep(vibro, eps=eps, threads=1)
    two = fpsolve.sweep(vibro, eps=eps, threads=2)
    for q in ("y", "ydot"):
        np.testing.assert_array_equal(one.stat("epc", q, "variance"), two.stat("epc", q, "variance"))
    with pytest.raises(ValueError):
        fpsolve.sweep(vibro, eps=eps, threads=0)
