"""Model.transient against `fpsolve transient`: the same numbers to the bit (moments_vs_t.csv,
pdf_<state>_t.csv, summary.json, the warnings), the arrays' shapes, the exact variance of the
linear oscillator from rest, the files `write` puts down, and the same refusals before any
work."""

import json
import subprocess
import warnings

import numpy as np
import pytest

import fpsolve
from conftest import MODELS, REPO, read_csv

# The runs are small: the grid warns that its cells do not resolve the start; the tests that
# are about the warnings record them themselves.
pytestmark = pytest.mark.filterwarnings("ignore::fpsolve.FpsolveWarning")

LINEAR = MODELS / "linear.sde"
# The CLI's and Python's arguments of one run: c = 1, 40x40 cells, grid and Monte Carlo.
ARGS = ["--set", "c=1", "--times", "0:4:5", "--cells", "40,40", "--method", "grid,mc", "--trajectories", "2000"]
KWARGS = dict(c=1, times="0:4:5", cells=(40, 40), method="grid,mc", trajectories=2000)
# A model whose noise intensity rises and decays in time (tests/transient_cli.rs).
MODULATED = (
    "model m\nstate z, v\ndrift z: v\ndrift v: -0.5*v - z\nnoise xi: intensity 1\n"
    "diffusion v: 4*(exp(-0.5*t) - exp(-t))*xi\n"
)


def run_cli(cli, model, out, *args, check=True):
    return subprocess.run(
        [cli, "transient", model, *args, "--out", out], check=check, capture_output=True, text=True
    )


def without_timing(summary):
    summary = json.loads(json.dumps(summary))
    summary.pop("provenance")
    summary.get("grid", {}).pop("total_ms", None)
    summary.get("mc", {}).get("settings", {}).pop("total_ms", None)
    return summary


def console_warnings(text):
    return [line[len("warning: ") :] for line in text.splitlines() if line.startswith("warning: ")]


@pytest.fixture(scope="module")
def both(cli, tmp_path_factory):
    """The CLI's and Python's grid and Monte Carlo run with the same arguments."""
    out = tmp_path_factory.mktemp("transient") / "both"
    console = run_cli(cli, LINEAR, out, *ARGS)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        py = fpsolve.Model.load(LINEAR).transient(**KWARGS)
    return out, console.stdout, py, [str(w.message) for w in caught if w.category is fpsolve.FpsolveWarning]


def test_summary_is_the_cli_summary(both):
    out, _, py, _ = both
    cli = json.loads((out / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(cli)
    # Both open with the provenance; Python's has no command line, and its time is its own.
    assert list(py.report) == list(cli) and next(iter(py.report)) == "provenance"
    for key in ("fpsolve_version", "schema_version", "threads"):
        assert py.report["provenance"][key] == cli["provenance"][key], key
    for key in ("name", "file", "text"):
        assert py.report["provenance"]["model"][key] == cli["provenance"]["model"][key], key
    assert "command" not in py.report["provenance"]
    assert py.method == "grid,mc" and py.initial == {"kind": "rest"} == cli["initial"]
    # Monte Carlo's kurtosis at the point start has no value: null, listed under `undefined`.
    assert cli["undefined"] and py.report["undefined"] == cli["undefined"]


def test_moments_are_the_cli_moments_vs_t(both):
    out, _, py, _ = both
    header, cols = read_csv(out / "moments_vs_t.csv")
    np.testing.assert_array_equal(py.t, cols["t"])
    seen = {"t"}
    for q in py.grid.quantities:
        for m in ("mean", "variance", "kurtosis"):
            np.testing.assert_array_equal(getattr(py.grid, m)[q], cols[f"{q}_{m}"])
            np.testing.assert_array_equal(getattr(py.grid, f"{m}_err")[q], cols[f"{q}_{m}_err"])
            seen |= {f"{q}_{m}", f"{q}_{m}_err"}
    for q in py.mc.quantities:
        for m in ("mean", "variance", "kurtosis"):
            np.testing.assert_array_equal(getattr(py.mc, m)[q], cols[f"{q}_{m}_mc"])
            np.testing.assert_array_equal(getattr(py.mc, f"{m}_se")[q], cols[f"{q}_{m}_mc_se"])
            seen |= {f"{q}_{m}_mc", f"{q}_{m}_mc_se"}
    assert seen == set(header)
    assert np.isnan(py.mc.kurtosis["z"][0]) and py.mc.variance["z"][0] == 0.0


def test_pdfs_are_the_cli_pdf_files(both):
    out, _, py, _ = both
    for state in py.states:
        header, cols = read_csv(out / f"pdf_{state}_t.csv")
        assert header == ["t", "x", "grid", "mc", "mc_se"]
        x, p = py.grid.pdf[state]
        x_mc, p_mc = py.mc.pdf[state]
        np.testing.assert_array_equal(x, x_mc)
        np.testing.assert_array_equal(np.tile(x, len(py.t)), cols["x"])
        np.testing.assert_array_equal(np.repeat(py.t, len(x)), cols["t"])
        np.testing.assert_array_equal(p.ravel(), cols["grid"])
        np.testing.assert_array_equal(p_mc.ravel(), cols["mc"])
        np.testing.assert_array_equal(py.mc.pdf_se[state].ravel(), cols["mc_se"])


def test_shapes(both):
    _, _, py, _ = both
    assert py.t.shape == (5,) and py.states == ("z", "v")
    assert py.grid.quantities == ("z", "v", "y", "ydot") and py.mc.quantities == ("z", "v")
    for history in (py.grid, py.mc):
        for m in (history.mean, history.variance, history.kurtosis):
            assert set(m) == set(history.quantities) and all(a.shape == (5,) for a in m.values())
        for state in py.states:
            x, p = history.pdf[state]
            assert x.shape == (40,) and p.shape == (5, 40)
    assert py.grid.mean_se is None and py.grid.pdf_se is None and py.mc.mean_err is None
    assert py.mc.pdf_se["v"].shape == (5, 40)
    # Each output's density integrates to one on the grid.
    x, p = py.grid.pdf["z"]
    np.testing.assert_allclose(p.sum(axis=1) * (x[1] - x[0]), 1.0, atol=1e-9)


def test_warnings_are_the_cli_warnings(both):
    _, console, py, caught = both
    assert py.warnings == console_warnings(console)
    # The grid's three resolution warnings (40x40 cells), then where the two methods are
    # apart: here Monte Carlo's variance of z at t = 3 with 2048 paths, 0.4424 ± 0.0102,
    # against the grid's 0.4903 ± 0.0076 (the Lyapunov equation's 0.4834).
    assert len(py.warnings) >= 3
    assert all("Monte Carlo's" in w and "further apart than 3" in w for w in py.warnings[3:])
    assert not any("Monte Carlo's" in w for w in py.warnings[:3])
    assert caught == py.warnings and py.flags == []


def test_write_puts_down_the_cli_files(both, tmp_path):
    out, _, py, _ = both
    written = py.write(tmp_path / "py")
    names = sorted(p.name for p in (tmp_path / "py").iterdir())
    assert names == sorted(p.name for p in out.iterdir()) and written == str(tmp_path / "py")
    for name in names:
        if name.endswith((".csv", ".svg", ".png")):
            assert (tmp_path / "py" / name).read_bytes() == (out / name).read_bytes(), name
    assert json.loads((tmp_path / "py" / "summary.json").read_text()) == py.report
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "notes.txt").write_text("mine")
    with pytest.raises(fpsolve.JobError):
        py.write(tmp_path / "foreign")
    py.write(tmp_path / "bare", figures=False)
    assert sorted(p.name for p in (tmp_path / "bare").iterdir() if not p.name.startswith(".")) == [
        "moments_vs_t.csv",
        "pdf_v_t.csv",
        "pdf_z_t.csv",
        "summary.json",
    ]


def lyapunov(c, k, intensity, s0, times, step=1e-3):
    """The covariance of x' = v, v' = -c v - k x + xi from N(0, s0) at each time: the Lyapunov
    equation S' = A S + S A^T + diag(0, intensity) by RK4 (its error far below the test's)."""
    a = np.array([[0.0, 1.0], [-k, -c]])
    b = np.diag([0.0, intensity])

    def rhs(s):
        return a @ s + s @ a.T + b

    s, t, out = np.array(s0, dtype=float), 0.0, []
    for target in times:
        while t < target - 1e-12:
            h = min(step, target - t)
            k1 = rhs(s)
            k2 = rhs(s + h / 2 * k1)
            k3 = rhs(s + h / 2 * k2)
            k4 = rhs(s + h * k3)
            s, t = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), t + h
        out.append(s.copy())
    return out


def test_linear_from_rest_has_the_lyapunov_variance(linear):
    # From rest the grid starts from a Gaussian POINT_CELLS = 2 cells wide on each axis (the
    # narrowest start the cells resolve): its law stays Gaussian, with the covariance of the
    # Lyapunov equation from that start. Monte Carlo starts from the point itself.
    times = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0]
    h = 10.0 / 64
    tr = linear.transient(
        times, cells=(64, 64), domain={"z": (-5, 5), "v": (-5, 5)}, method="grid,mc", trajectories=4096, c=1
    )
    np.testing.assert_array_equal(tr.t, times)
    grid = lyapunov(1.0, 1.0, 1.0, np.diag([(2 * h) ** 2] * 2), times)
    point = lyapunov(1.0, 1.0, 1.0, np.zeros((2, 2)), times)
    for k, t in enumerate(times):
        for a, q in enumerate(("z", "v")):
            exact = grid[k][a, a]
            assert abs(tr.grid.variance[q][k] / exact - 1) < 5e-3, (t, q, tr.grid.variance[q][k], exact)
            assert abs(tr.grid.mean[q][k]) < 1e-6
            if t > 0:
                se = tr.mc.variance_se[q][k]
                assert abs(tr.mc.variance[q][k] - point[k][a, a]) < 5 * se, (t, q)
    # The stationary law's variances, pi K / (c k) = 0.5 for both states, approached by t = 8.
    assert abs(tr.grid.variance["z"][-1] - 0.5) < 0.02 and abs(tr.grid.variance["v"][-1] - 0.5) < 0.02


def test_a_time_dependent_model_as_the_cli(cli, tmp_path):
    path = tmp_path / "modulated.sde"
    path.write_text(MODULATED)
    model = fpsolve.Model.load(path)
    box = ["--times", "0:2:5", "--cells", "32,32", "--domain", "z=-5:5,v=-5:5"]
    run_cli(cli, path, tmp_path / "grid", *box)
    py = model.transient("0:2:5", cells=(32, 32), domain="z=-5:5,v=-5:5")
    summary = json.loads((tmp_path / "grid" / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    assert py.report["grid"]["time_dependent"] is True and py.mc is None
    header, cols = read_csv(tmp_path / "grid" / "moments_vs_t.csv")
    np.testing.assert_array_equal(py.grid.variance["v"], cols["v_variance"])
    # Monte Carlo on it: the CLI's numbers, file for file.
    done = run_cli(cli, path, tmp_path / "mc", *box, "--method", "grid,mc", "--trajectories", "512")
    py = model.transient("0:2:5", cells=(32, 32), domain="z=-5:5,v=-5:5", method="grid,mc", trajectories=512)
    summary = json.loads((tmp_path / "mc" / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    header, cols = read_csv(tmp_path / "mc" / "moments_vs_t.csv")
    np.testing.assert_array_equal(py.mc.variance["v"], cols["v_variance_mc"])


def test_a_start_held_still_is_refused_as_the_cli(cli, vibro, tmp_path):
    # The Zhuravlev form at rest: drift and noise vanish (sgn(0) = 0), every Monte Carlo
    # trajectory would stay; refused before any work by both.
    args = ["--times", "0:1:2", "--method", "grid,mc"]
    done = run_cli(cli, MODELS / "vibro_duffing.sde", tmp_path / "held", *args, check=False)
    assert done.returncode == 2 and "every path would stay at its start" in done.stderr
    assert not (tmp_path / "held").exists()
    with pytest.raises(fpsolve.MonteCarloError, match="every path would stay at its start") as e:
        vibro.transient("0:1:2", method="grid,mc")
    assert e.value.kind == "start_held_still"


def test_a_stuck_ensemble_is_flagged_as_the_cli(cli, tmp_path):
    # Noise sgn(z)*xi fading in time: the check before work cannot decide (the coefficients
    # depend on t), every Monte Carlo trajectory stays at rest; the CLI writes its files and
    # exits 1 with the flag, Python warns it and lists it in `flags`.
    path = REPO / "tests" / "models" / "zhuravlev_timed.sde"
    box = "z=-8:8,v=-8:8"
    args = ["--times", "0:1:2", "--cells", "30,60", "--domain", box, "--method", "grid,mc", "--trajectories", "640"]
    done = run_cli(cli, path, tmp_path / "stuck", *args, check=False)
    assert done.returncode == 1
    model = fpsolve.Model.load(path)
    with pytest.warns(fpsolve.FpsolveWarning, match="still at its start at t = 1"):
        py = model.transient("0:1:2", cells=(30, 60), domain=box, method="grid,mc", trajectories=640)
    assert len(py.flags) == 1 and py.flags[0] in done.stderr and py.warnings[-1] == py.flags[0]
    assert py.warnings[:-1] == console_warnings(done.stdout)
    summary = json.loads((tmp_path / "stuck" / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)


def test_times_as_numbers_and_a_gaussian_start(cli, linear, tmp_path):
    start = "gaussian mean z = 1, v = 0 cov 0.25, 0, 0, 0.25"
    args = ["--times", "0:2:5", "--cells", "32,32", "--domain", "z=-8:8,v=-8:8", "--tol", "1e-3", "--initial", start]
    run_cli(cli, LINEAR, tmp_path / "g", *args)
    py = linear.transient(
        np.linspace(0, 2, 5), cells="32,32", domain="z=-8:8,v=-8:8", tol=1e-3, initial=start
    )
    summary = json.loads((tmp_path / "g" / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    assert py.initial == {"kind": "gaussian", "mean": [1.0, 0.0], "covariance": [[0.25, 0.0], [0.0, 0.25]]}
    header, cols = read_csv(tmp_path / "g" / "moments_vs_t.csv")
    np.testing.assert_array_equal(py.grid.mean["z"], cols["z_mean"])
    assert py.mc is None and py.method == "grid"


def test_threads_do_not_change_the_numbers(both):
    _, _, py, _ = both
    one = fpsolve.Model.load(LINEAR).transient(**KWARGS, threads=1)
    assert without_timing(one.report) == without_timing(py.report)
    assert one.report["provenance"]["threads"] == 1
    np.testing.assert_array_equal(one.mc.pdf["z"][1], py.mc.pdf["z"][1])
    with pytest.raises(ValueError, match="threads"):
        fpsolve.Model.load(LINEAR).transient("0:1:2", threads=0)


# Refused before any work, as the CLI refuses them with exit status 2: (CLI arguments after
# the model, Python keyword arguments, the class raised).
T = ["--times", "0:1:3"]
REFUSED = {
    "bad method": (T + ["--method", "epc"], dict(method="epc"), ValueError),
    "bad times": (["--times", "1:0:3"], dict(times="1:0:3"), ValueError),
    "bad tol": (T + ["--tol", "0"], dict(tol=0), ValueError),
    "odd cells": (T + ["--cells", "41,40"], dict(cells=(41, 40)), ValueError),
    "bad domain": (T + ["--domain", "z=3:1,v=-1:1"], dict(domain="z=3:1,v=-1:1"), ValueError),
    "mc without a box": (T + ["--method", "mc"], dict(method="mc"), ValueError),
    "start outside the box": (
        T + ["--domain", "z=-1:1,v=-1:1", "--initial", "point z = 5, v = 0"],
        dict(domain={"z": (-1, 1), "v": (-1, 1)}, initial="point z = 5, v = 0"),
        ValueError,
    ),
    "no trajectories": (
        T + ["--method", "grid,mc", "--trajectories", "0"],
        dict(method="grid,mc", trajectories=0),
        ValueError,
    ),
    "too few trajectories": (
        T + ["--method", "grid,mc", "--trajectories", "100"],
        dict(method=["grid", "mc"], trajectories=100),
        fpsolve.MonteCarloError,
    ),
    "bad dt": (T + ["--method", "grid,mc", "--dt=-1"], dict(method="grid,mc", dt=-1), fpsolve.MonteCarloError),
    "unknown state in the start": (
        T + ["--initial", "point q = 1, v = 0"],
        dict(initial="point q = 1, v = 0"),
        fpsolve.ModelError,
    ),
    "start text": (T + ["--initial", "nonsense"], dict(initial="nonsense"), fpsolve.ModelError),
    "start not finite": (T + ["--initial", "point z = 1/0, v = 0"], dict(initial="point z = 1/0, v = 0"), fpsolve.ModelError),
    "bad override": (T + ["--set", "nope=1"], dict(nope=1), fpsolve.ParameterError),
}


@pytest.mark.parametrize("case", REFUSED, ids=list(REFUSED))
def test_refused_before_any_work_as_the_cli(cli, linear, tmp_path, case):
    args, kwargs, error = REFUSED[case]
    out = tmp_path / "refused"
    done = run_cli(cli, LINEAR, out, *args, check=False)
    assert done.returncode == 2, done.stderr
    assert not out.exists()
    kwargs = {"times": "0:1:3", **kwargs}
    with pytest.raises(error):
        linear.transient(**kwargs)


def test_a_time_dependent_model_needs_a_box(cli, tmp_path):
    path = tmp_path / "modulated.sde"
    path.write_text(MODULATED)
    done = run_cli(cli, path, tmp_path / "r", "--times", "0:1:3", check=False)
    assert done.returncode == 2 and "--domain: required" in done.stderr
    with pytest.raises(ValueError, match="^domain: required for a model whose coefficients depend on the time"):
        fpsolve.Model.load(path).transient("0:1:3")


def test_error_details(linear):
    with pytest.raises(ValueError, match=r"^method: `epc`: expected `grid`, `mc` or `grid,mc`$"):
        linear.transient("0:1:3", method="grid,epc")
    with pytest.raises(ValueError, match=r"^tol: 2: expected a number in \(0, 1\)$"):
        linear.transient("0:1:3", tol=2)
    with pytest.raises(ValueError, match="^domain: required for Monte Carlo alone"):
        linear.transient("0:1:3", method="mc")
    with pytest.raises(fpsolve.ModelError) as info:
        linear.transient("0:1:3", initial="point q = 1, v = 0")
    assert info.value.line == 1 and "--initial" in str(info.value)
    with pytest.raises(fpsolve.ModelError) as info:
        linear.transient("0:1:3", initial="point z = 1/0, v = 0")
    assert info.value.kind == "initial" and info.value.path.endswith("linear.sde")
    with pytest.raises(fpsolve.MonteCarloError) as mc:
        linear.transient("0:1:3", method="grid,mc", trajectories=100)
    assert mc.value.kind == "bad_setting"
    with pytest.raises(TypeError):
        linear.transient("0:1:3", trajectories=1.5)
    with pytest.raises(TypeError):
        linear.transient("0:1:3", params={"c": 1}, c=2)


FORCED = """model forced "forced linear oscillator"
param c = 0.2, k = 1, a = 1, w = 0.8
state z, v
drift z: v
drift v: -c*v - k*z + a*cos(w*t)
noise xi: intensity 0.2
diffusion v: xi
"""


def test_the_periodic_state_as_the_cli(cli, tmp_path):
    # The period map from Python: the CLI's report and numbers, the mean the harmonic
    # response within its stated error, and the refusals of the CLI.
    path = tmp_path / "forced.sde"
    path.write_text(FORCED)
    period = 2 * np.pi / 0.8
    box = "z=-8:8,v=-8:8"
    times = f"0:{period!r}:5"
    run_cli(cli, path, tmp_path / "cli", "--period", repr(period), "--times", times, "--cells", "32,32", "--domain", box)
    model = fpsolve.Model.load(path)
    py = model.transient(times, cells=(32, 32), domain=box, period=period)
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    periodic = py.report["periodic"]
    assert periodic["outcome"]["stop"] == "converged", periodic
    assert periodic["outcome"]["residual"] <= 1e-8
    c, k, w = 0.2, 1.0, 0.8
    den = (k - w * w) ** 2 + (c * w) ** 2
    exact = ((k - w * w) * np.cos(w * py.t) + c * w * np.sin(w * py.t)) / den
    header, cols = read_csv(tmp_path / "cli" / "moments_vs_t.csv")
    np.testing.assert_array_equal(py.grid.mean["z"], cols["z_mean"])
    assert np.all(np.abs(cols["z_mean"] - exact) <= cols["z_mean_err"]), (cols["z_mean"], exact, cols["z_mean_err"])
    with pytest.raises(ValueError, match="period"):
        model.transient(times, cells=(32, 32), domain=box, period=-1.0)
    with pytest.raises(ValueError, match="not periodic with period 7"):
        model.transient(times, domain=box, period=7.0, method="mc")


def test_the_periodic_state_on_both_methods_as_the_cli(cli, tmp_path):
    # Monte Carlo's periodic state beside the grid's: the CLI's numbers to the bit, the
    # discarded and recorded periods in the report, the MC means the harmonic response
    # within 4 standard errors, and the grid's distance from MC within 4 of them.
    path = tmp_path / "forced.sde"
    path.write_text(FORCED)
    period = 2 * np.pi / 0.8
    box = "z=-8:8,v=-8:8"
    times = f"0:{0.75 * period!r}:4"
    args = ["--period", repr(period), "--times", times, "--cells", "48,48", "--domain", box]
    mc = ["--method", "grid,mc", "--trajectories", "2048", "--dt", "0.02", "--seed", "4"]
    run_cli(cli, path, tmp_path / "cli", *args, *mc)
    model = fpsolve.Model.load(path)
    py = model.transient(
        times, cells=(48, 48), domain=box, period=period, method="grid,mc", trajectories=2048, dt=0.02, seed=4
    )
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    sampled = py.report["mc_periodic"]
    assert sampled["discarded_periods"] >= 1 and sampled["recorded_periods"] == 8, sampled
    header, cols = read_csv(tmp_path / "cli" / "moments_vs_t.csv")
    np.testing.assert_array_equal(py.mc.mean["z"], cols["z_mean_mc"])
    c, k, w = 0.2, 1.0, 0.8
    den = (k - w * w) ** 2 + (c * w) ** 2
    exact = ((k - w * w) * np.cos(w * py.t) + c * w * np.sin(w * py.t)) / den
    assert np.all(np.abs(py.mc.mean["z"] - exact) <= 4 * py.mc.mean_se["z"]), (py.mc.mean["z"], exact)
    for out in py.report["outputs"]:
        for d in out["grid_vs_mc_in_se"]:
            assert abs(d["mean"]) <= 4 and abs(d["variance"]) <= 4, (out["t"], d)
