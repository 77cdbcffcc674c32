"""Model.reliability against `fpsolve reliability`: the same numbers to the bit (summary.json,
reliability.csv and first_passage_pdf.csv), the same refusals before any work, and the Monte
Carlo's fields. `passage`, the former name, is the same command and the same method."""

import json
import subprocess
import warnings

import numpy as np
import pytest

import fpsolve
from conftest import MODELS, read_csv

MODEL = MODELS / "linear.sde"
SAFE = "abs(z) < 1.2"
COMMON = ["--safe", SAFE, "--set", "c=1", "--cells", "60,80"]


def run_cli(cli, out, *args, command="reliability"):
    return subprocess.run(
        [cli, command, MODEL, *COMMON, *args, "--out", out],
        check=True,
        capture_output=True,
        text=True,
    )


def without_timing(summary):
    summary = json.loads(json.dumps(summary))
    for key in ("command", "model_file", "provenance"):
        summary.pop(key)
    if "grid" in summary:
        summary["grid"]["report"].pop("total_ms")
    stationary = summary.get("stationary", {})
    stationary.pop("grid_ms", None)
    stationary.get("mc", {}).pop("wall_ms", None)
    return summary


def read_table(path):
    """A table the CLI wrote whose empty fields (no value) read as NaN."""
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    rows = [[float(f) if f else np.nan for f in line.split(",")] for line in lines[1:]]
    return header, {h: np.array([r[k] for r in rows]) for k, h in enumerate(header)}


@pytest.fixture(scope="module")
def both(cli, linear, tmp_path_factory):
    """The CLI's and Python's grid and Monte Carlo run with the same arguments."""
    out = tmp_path_factory.mktemp("reliability") / "both"
    console = run_cli(cli, out, "--times", "0:20:11", "--method", "grid,mc", "--paths", "2000")
    py = linear.reliability(
        safe=SAFE, c=1, cells=(60, 80), times="0:20:11", method="grid,mc", paths=2000
    )
    return out, console.stdout, py


def test_summary_is_the_cli_summary(both):
    out, _, py = both
    cli = json.loads((out / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(cli)
    # Both open with the provenance; Python's has no command line, and its time is its own.
    assert next(iter(py.report)) == "provenance" == next(iter(cli))
    for key in ("fpsolve_version", "schema_version", "threads"):
        assert py.report["provenance"][key] == cli["provenance"][key], key
    for key in ("name", "text"):
        assert py.report["provenance"]["model"][key] == cli["provenance"]["model"][key], key
    assert "command" not in py.report["provenance"]
    g = cli["grid"]
    for key in (
        "mean_at_start",
        "second_at_start",
        "mean_from_start_cell",
        "mean_stationary",
        "second_stationary",
        "safe_mass",
        "integral_of_reliability",
    ):
        assert getattr(py, key) == g[key], key
    assert py.errors["mean_at_start"] == g["errors"]["mean_at_start"]
    assert py.errors["rate"] == g["errors"]["rate"]
    assert py.decay == g["decay"] and py.decay["status"] == "found"
    assert py.start == (0.0, 0.0) and py.safe == SAFE
    assert np.isnan(py.grid_vs_mc_se) and cli["grid_vs_mc_se"] is None  # censored: no distance


def test_columns_are_the_cli_reliability_csv(both):
    out, _, py = both
    header, cols = read_csv(out / "reliability.csv")
    assert header == ["t", "R_grid", "pdf_grid", "R_grid_err", "R_mc", "R_mc_lo95", "R_mc_hi95"]
    np.testing.assert_array_equal(py.times, cols["t"])
    np.testing.assert_array_equal(py.reliability, cols["R_grid"])
    np.testing.assert_array_equal(py.pdf, cols["pdf_grid"])
    np.testing.assert_array_equal(py.errors["reliability"], cols["R_grid_err"])
    np.testing.assert_array_equal(py.mc.reliability, cols["R_mc"])
    np.testing.assert_array_equal(py.mc.reliability_lo, cols["R_mc_lo95"])
    np.testing.assert_array_equal(py.mc.reliability_hi, cols["R_mc_hi95"])
    for state in ("z", "v"):
        header, cols = read_csv(out / f"quasi_stationary_{state}.csv")
        x, p = py.quasi_stationary[state]
        np.testing.assert_array_equal(x, cols[state])
        np.testing.assert_array_equal(p, cols["quasi_stationary"])


def test_monte_carlo_density_is_the_cli_first_passage_pdf_csv(both):
    out, _, py = both
    mc = py.mc
    header, cols = read_csv(out / "first_passage_pdf.csv")
    assert header == ["t_lo", "t_hi", "t_mid", "pdf_mc", "pdf_mc_se"]
    np.testing.assert_array_equal(py.times[:-1], cols["t_lo"])
    np.testing.assert_array_equal(py.times[1:], cols["t_hi"])
    np.testing.assert_array_equal(mc.pdf_t_mid, cols["t_mid"])
    np.testing.assert_array_equal(mc.pdf_binned, cols["pdf_mc"])
    np.testing.assert_array_equal(mc.pdf_binned_stderr, cols["pdf_mc_se"])
    # Each bin holds what R loses over it; censored paths are no exits, so the bins hold
    # 1 - R(last time) in all.
    width = np.diff(py.times)
    np.testing.assert_allclose(mc.pdf_binned * width, -np.diff(mc.reliability), rtol=0, atol=1e-15)
    assert np.all(mc.pdf_binned_stderr >= 0) and mc.censored > 0
    assert np.isclose(np.sum(mc.pdf_binned * width), 1 - mc.reliability[-1], rtol=0, atol=1e-12)


def test_monte_carlo_fields(both):
    out, console, py = both
    mc = py.mc
    cli = json.loads((out / "summary.json").read_text())["mc"]
    assert (mc.paths, mc.dt, mc.horizon, mc.seed) == (2000, 0.01, 20.0, 1)
    # The horizon 20 censors paths: no mean, a lower bound.
    assert mc.censored > 0 and mc.censored_fraction == cli["censored_fraction"]
    assert mc.mean is None and mc.variance is None
    assert mc.mean_lower_bound == (cli["mean_lower_bound"]["value"], cli["mean_lower_bound"]["stderr"])
    assert f"{mc.mean_lower_bound[0]:.6f}" in console
    assert mc.bias == (cli["bias"]["value"], cli["bias"]["stderr"]) and mc.bias_paths > 0
    np.testing.assert_array_equal(mc.times, py.times)
    assert np.all(mc.reliability_lo <= mc.reliability) and np.all(mc.reliability <= mc.reliability_hi)
    assert py.warnings == []


def test_monte_carlo_alone_and_uncensored(cli, linear, tmp_path):
    # Monte Carlo alone, with a horizon long enough that no path is censored: the mean with
    # its standard error, R on the times asked, the same bits as the CLI.
    out = tmp_path / "mc"
    run_cli(cli, out, "--method", "mc", "--paths", "1024", "--horizon", "400", "--times", "0:40:5")
    py = linear.reliability(
        safe=SAFE, params={"c": 1}, cells="60,80", method="mc", paths=1024, horizon=400, times=[0, 10, 20, 30, 40]
    )
    summary = json.loads((out / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    assert "grid" not in py.report and py.mean_at_start is None and py.reliability is None
    assert py.grid_vs_mc_se is None and py.quasi_stationary == {}
    # No crossing or impact statistics without the grid, and the report says why.
    assert summary["stationary"]["status"] == "not_computed"
    assert "--method grid,mc" in summary["stationary"]["why"] and py.crossings == {}
    mc = py.mc
    assert mc.censored == 0 and mc.censored_fraction == 0.0
    assert mc.mean == (summary["mc"]["mean"]["value"], summary["mc"]["mean"]["stderr"])
    assert mc.mean[1] > 0 and mc.variance[0] > 0
    assert mc.mean_lower_bound == mc.mean
    np.testing.assert_array_equal(py.times, [0, 10, 20, 30, 40])
    header, cols = read_csv(out / "reliability.csv")
    assert header == ["t", "R_mc", "R_mc_lo95", "R_mc_hi95"]
    np.testing.assert_array_equal(mc.reliability, cols["R_mc"])
    header, cols = read_csv(out / "first_passage_pdf.csv")
    np.testing.assert_array_equal(mc.pdf_t_mid, [5, 15, 25, 35])
    np.testing.assert_array_equal(mc.pdf_binned, cols["pdf_mc"])
    np.testing.assert_array_equal(mc.pdf_binned_stderr, cols["pdf_mc_se"])


def test_horizon_defaults_to_twenty_grid_means(cli, linear, tmp_path):
    out = tmp_path / "h"
    run_cli(cli, out, "--method", "grid,mc", "--paths", "512")
    py = linear.reliability(safe=SAFE, c=1, cells=(60, 80), method=["grid", "mc"], paths=512)
    summary = json.loads((out / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    assert py.mc.horizon == 20.0 * py.mean_at_start
    assert py.grid_vs_mc_se == summary["grid_vs_mc_se"]
    # No times asked: 101 times to 5 of the grid's mean times (not to the horizon).
    assert len(py.times) == 101 and py.times[0] == 0
    assert py.times[-1] == pytest.approx(5.0 * py.mean_at_start, rel=1e-12)


def test_disagreement_warns_as_the_cli(cli, linear, tmp_path):
    # A coarse Monte Carlo step biases its mean beyond 3 standard errors plus the grid's error.
    out = tmp_path / "w"
    args = ["--method", "grid,mc", "--paths", "4000", "--dt", "0.4", "--horizon", "400"]
    console = run_cli(cli, out, *args).stdout
    assert "warning: the grid's mean first-passage time" in console
    with pytest.warns(fpsolve.FpsolveWarning, match="more than 3 standard errors"):
        py = linear.reliability(safe=SAFE, c=1, cells=(60, 80), method="grid,mc", paths=4000, dt=0.4, horizon=400)
    # The mean's warning first, then R(t)'s at the default output times (as biased).
    assert len(py.warnings) >= 1
    assert all("more than 3 standard errors" in w for w in py.warnings)
    assert py.warnings[0].startswith("the grid's mean first-passage time")
    gap = py.warnings[0].split(" is ")[1].split(" ")[0]
    assert f"is {gap} from Monte Carlo's" in console
    assert py.grid_vs_mc_se == json.loads((out / "summary.json").read_text())["grid_vs_mc_se"]


def test_the_model_safe_line_and_a_start(cli, tmp_path):
    text = MODEL.read_text() + "safe -1 < z < 1.5\n"
    path = tmp_path / "linear_safe.sde"
    path.write_text(text)
    out = tmp_path / "s"
    # The former names, `fpsolve passage` and Model.passage: the same command and method.
    subprocess.run(
        [cli, "passage", path, "--start", "0.5,-0.25", "--cells", "40,40", "--method", "grid", "--out", out],
        check=True,
        capture_output=True,
    )
    py = fpsolve.Model.load(path).passage(start=(0.5, -0.25), cells=(40, 40))
    assert fpsolve.Model.passage is fpsolve.Model.reliability
    assert py.report["command"] == "fpsolve.Model.reliability"
    summary = json.loads((out / "summary.json").read_text())
    # Without output times both get R(t) at 101 times to 5 grid mean times; the command
    # line draws it (nothing left unwritten).
    assert "unwritten" not in summary and "unwritten" not in py.report
    assert len(py.times) == 101
    assert without_timing(py.report) == without_timing(summary)
    assert py.safe == "-1 < z < 1.5" and py.start == (0.5, -0.25)
    assert py.mc is None and "mc" not in py.report


# Refused before any work, as the CLI refuses them with exit status 2: (CLI arguments after
# the model, Python keyword arguments, the class raised).
REFUSED = {
    "start outside": (["--safe", SAFE, "--start", "2,0"], dict(safe=SAFE, start=(2, 0)), ValueError),
    "start text": (["--safe", SAFE, "--start", "1"], dict(safe=SAFE, start="1"), ValueError),
    "odd cells": (["--safe", SAFE, "--cells", "61,80"], dict(safe=SAFE, cells=(61, 80)), ValueError),
    "few cells": (["--safe", SAFE, "--cells", "4,80"], dict(safe=SAFE, cells=(4, 80)), ValueError),
    "negative paths": (
        ["--safe", SAFE, "--method", "mc", "--paths", "-5", "--horizon", "10"],
        dict(safe=SAFE, method="mc", paths=-5, horizon=10),
        ValueError,
    ),
    "too few paths": (
        ["--safe", SAFE, "--method", "mc", "--paths", "1", "--horizon", "10"],
        dict(safe=SAFE, method="mc", paths=1, horizon=10),
        fpsolve.MonteCarloError,
    ),
    "bad dt": (
        ["--safe", SAFE, "--method", "grid,mc", "--dt", "-0.1"],
        dict(safe=SAFE, method="grid,mc", dt=-0.1),
        fpsolve.MonteCarloError,
    ),
    "no state": (["--safe", "c < 2"], dict(safe="c < 2"), fpsolve.ModelError),
    "unknown name": (["--safe", "abs(w) < 2"], dict(safe="abs(w) < 2"), fpsolve.ModelError),
    "empty set": (["--safe", "2 < z < 1"], dict(safe="2 < z < 1"), fpsolve.ModelError),
    "no safe set": ([], dict(), ValueError),
    "bad method": (["--safe", SAFE, "--method", "epc"], dict(safe=SAFE, method="epc"), ValueError),
    "bad times": (["--safe", SAFE, "--times", "5:1:3"], dict(safe=SAFE, times="5:1:3"), ValueError),
    "horizon without mc": (
        ["--safe", SAFE, "--method", "grid", "--horizon", "10"],
        dict(safe=SAFE, method="grid", horizon=10),
        ValueError,
    ),
    "mc without horizon": (["--safe", SAFE, "--method", "mc"], dict(safe=SAFE, method="mc"), ValueError),
    "bad override": (["--safe", SAFE, "--set", "nope=1"], dict(safe=SAFE, nope=1), fpsolve.ParameterError),
    "mean only with times": (
        ["--safe", SAFE, "--mean-only", "--times", "0:10:11"],
        dict(safe=SAFE, mean_only=True, times="0:10:11"),
        ValueError,
    ),
    "mean only, mc without horizon": (
        ["--safe", SAFE, "--mean-only", "--method", "mc"],
        dict(safe=SAFE, mean_only=True, method="mc"),
        ValueError,
    ),
}


@pytest.mark.parametrize("case", REFUSED, ids=list(REFUSED))
def test_refused_before_any_work_as_the_cli(cli, linear, tmp_path, case):
    args, kwargs, error = REFUSED[case]
    out = tmp_path / "refused"
    for command in ("reliability", "passage"):
        done = subprocess.run(
            [cli, command, MODEL, *args, "--out", out], capture_output=True, text=True
        )
        assert done.returncode == 2, done.stderr
        assert not out.exists()
    with pytest.raises(error):
        linear.reliability(**kwargs)


def test_error_details(linear):
    with pytest.raises(ValueError, match="not inside the safe set `abs"):
        linear.reliability(safe=SAFE, start=(1.3, 0))
    with pytest.raises(fpsolve.ModelError) as info:
        linear.reliability(safe="c < 2")
    assert "depends on no state" in str(info.value) and "--safe" in str(info.value)
    assert info.value.line == 1
    with pytest.raises(fpsolve.MonteCarloError) as mc:
        linear.reliability(safe=SAFE, method="mc", paths=1, horizon=10)
    assert mc.value.kind == "bad_setting"
    with pytest.raises(ValueError, match="paths"):
        linear.reliability(safe=SAFE, method="mc", paths=-1, horizon=10)
    with pytest.raises(TypeError):
        linear.reliability(safe=SAFE, params={"c": 1}, c=2)


def test_no_probability_in_the_set_is_a_value_error(cli, linear, tmp_path):
    # Found by the grid's stationary solve, not before (as the CLI, which exits 2 for it).
    args = ["--set", "c=1", "--safe", "z > 5", "--start", "5.1,0", "--cells", "40,40", "--method", "grid"]
    done = subprocess.run([cli, "reliability", MODEL, *args, "--out", tmp_path / "n"], capture_output=True, text=True)
    assert done.returncode == 2 and "of the stationary probability" in done.stderr
    with pytest.raises(ValueError, match="of the stationary probability"):
        linear.reliability(safe="z > 5", start=(5.1, 0), cells=(40, 40), c=1)


def test_threads_do_not_change_the_numbers(both, linear):
    _, _, py = both
    one = linear.reliability(
        safe=SAFE, c=1, cells=(60, 80), times="0:20:11", method="grid,mc", paths=2000, threads=1
    )
    assert without_timing(one.report) == without_timing(py.report)
    with pytest.raises(ValueError, match="threads"):
        linear.reliability(safe=SAFE, threads=0)


def test_crossings_and_distances_are_the_cli_files(both):
    # The stationary crossing table of the state beside the first passage: the CLI's
    # crossings_z.csv, column by column, with Monte Carlo's counts; the method distances of
    # summary.json.
    out, console, py = both
    assert sorted(py.crossings) == ["y", "z"]  # y = z, an observable
    header, cols = read_table(out / "crossings_z.csv")
    assert header == ["u", "grid", "grid_error", "mc", "mc_se", "mc_bias"]
    assert list(py.crossings["z"]) == header
    for h in header:
        np.testing.assert_array_equal(py.crossings["z"][h], cols[h])
    assert py.impacts == []  # no wall
    cli = json.loads((out / "summary.json").read_text())
    assert py.method_distances == cli["method_distances"]
    assert py.method_distances["mean_at_start"] is None  # censored
    assert len(py.method_distances["reliability"]) == len(py.times)
    worst = py.method_distances["worst"]["distance"]
    assert f"worst {worst:.2f}" in console


FREE = MODELS.parent / "tests" / "models" / "random_acceleration.sde"
FREE_BOX = "x=-1.05:1.05,v=-8:8"


def test_domain_is_the_cli_domain(cli, tmp_path):
    # The randomly accelerated particle (no stationary density) needs the grid's box: the
    # same numbers as `--domain`, the box as text or as a mapping, the mean exit time within
    # the grid's stated error plus 3 standard errors of the independent reference
    # (tests/passage.rs, RA_MEAN).
    out = tmp_path / "free"
    subprocess.run(
        [cli, "reliability", FREE, "--method", "grid", "--cells", "100,200", "--domain", FREE_BOX, "--out", out],
        check=True,
        capture_output=True,
    )
    free = fpsolve.Model.load(FREE)
    py = free.reliability(cells=(100, 200), domain=FREE_BOX)
    summary = json.loads((out / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(summary)
    as_mapping = free.reliability(cells=(100, 200), domain={"x": (-1.05, 1.05), "v": (-8, 8)})
    assert as_mapping.mean_at_start == py.mean_at_start
    assert abs(py.mean_at_start - 2.312577) <= py.errors["mean_at_start"] + 3 * 0.002819
    assert np.isnan(py.mean_stationary) and py.crossings == {} and py.impacts == []
    assert py.report["stationary"]["status"] == "not_computed"
    box = py.report["grid"]["report"]["domain"]
    assert abs(box["x"][1] - 1.05) < 2.1 / 100 and box["v"] == [-8.0, 8.0]  # moved < a cell


@pytest.mark.parametrize(
    "domain, says",
    [
        ("z=9:-9,v=-9:9", "lower end must be below"),
        ("q=-9:9,v=-9:9", "`q`"),
        ("z=-9..9", "is not x=LO:HI"),
        ("z=1:9,v=-9:9", "outside the grid's box"),
        ("z=-9:9,v=1:9", "v_lo < 0 < v_hi"),
    ],
)
def test_a_bad_domain_is_refused_before_any_work(linear, domain, says):
    with pytest.raises(ValueError, match="domain") as e:
        linear.reliability(safe=SAFE, c=1, cells=(40, 40), domain=domain)
    assert says in str(e.value)


def test_a_domain_needs_the_grid_and_a_free_particle_needs_a_domain():
    free = fpsolve.Model.load(FREE)
    with pytest.raises(ValueError, match="only the grid uses a box"):
        free.reliability(method="mc", horizon=5, domain=FREE_BOX)
    with pytest.raises(ValueError, match="domain="):
        free.reliability(cells=(40, 40))
    with pytest.raises(ValueError, match="reaches the grid's box"):
        free.reliability(cells=(40, 40), start=(-0.2, 0), domain="x=-0.5:1.05,v=-8:8")


def test_mean_only_is_the_cli_mean_only(cli, linear, tmp_path):
    """``mean_only=True`` as ``--mean-only``: the same summary.json (the mean times alone,
    what was not computed and why), nothing else written by the CLI, and the grid's and
    Monte Carlo's means those of the full run."""
    out = tmp_path / "means"
    run_cli(cli, out, "--mean-only", "--method", "grid,mc", "--paths", "500", "--horizon", "40")
    py = linear.reliability(
        safe=SAFE, c=1, cells=(60, 80), method="grid,mc", paths=500, horizon=40, mean_only=True
    )
    cli_summary = json.loads((out / "summary.json").read_text())
    assert without_timing(py.report) == without_timing(cli_summary)
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["summary.json"]
    assert py.scope == "mean_times"
    assert py.not_computed == [
        {"what": "reliability", "why": "mean_times_only"},
        {"what": "decay", "why": "mean_times_only"},
        {"what": "stationary_statistics", "why": "mean_times_only"},
    ]
    assert py.integral_of_reliability is None
    assert py.times.size == 0 and py.reliability.size == 0 and py.mc.times.size == 0
    assert py.decay == {"status": "not_computed"}
    assert py.crossings == {} and py.impacts == []
    with warnings.catch_warnings():
        # R(t) at 60x80 against 500 paths may be flagged; the means are what is compared.
        warnings.simplefilter("ignore", fpsolve.FpsolveWarning)
        full = linear.reliability(safe=SAFE, c=1, cells=(60, 80), method="grid,mc", paths=500, horizon=40)
    assert full.scope == "full" and full.not_computed == []
    for key in ("mean_at_start", "second_at_start", "mean_stationary", "second_stationary", "safe_mass"):
        assert getattr(py, key) == getattr(full, key), key
    assert py.errors["mean_at_start"] == full.errors["mean_at_start"]
    assert py.mc.mean == full.mc.mean and py.mc.variance == full.mc.variance
    with pytest.raises(TypeError, match="mean_only"):
        linear.reliability(safe=SAFE, mean_only="yes")
