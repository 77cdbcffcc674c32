"""The main job from Python and from the command line: the same files, and the Python API's
densities equal to the CLI's pdf_*.csv to the last printed digit."""

import csv
import subprocess

import numpy as np
import pytest

import fpsolve
from conftest import MODELS

MODEL = MODELS / "vibro_duffing.sde"
COLUMNS = {"epc_n2": ("epc", 2), "epc_n4": ("epc", 4), "grid": ("grid", 4)}


@pytest.fixture(scope="module")
def cli_out(cli, tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "vibro_duffing"
    subprocess.run([cli, MODEL, "--out", out, "--quiet"], check=True, capture_output=True)
    return out


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    # float() of the printed text: the printed numbers are shortest round-trip decimals.
    return header, {h: np.array([float(r[k]) for r in body]) for k, h in enumerate(header)}


@pytest.mark.parametrize("quantity", ["y", "ydot"])
def test_python_densities_equal_the_cli_csv(cli_out, vibro, quantity):
    header, cols = read_csv(cli_out / f"pdf_{quantity}.csv")
    assert header == [quantity, *COLUMNS]
    x = cols[quantity]
    for col, (method, degree) in COLUMNS.items():
        p = vibro.solve(method, degree=degree).pdf(quantity, x)
        np.testing.assert_array_equal(p, cols[col], err_msg=col)


def test_run_job_writes_the_cli_files(cli_out, tmp_path):
    out = tmp_path / "py"
    result = fpsolve.run_job(MODEL, out=out)
    assert result["flags"] == []
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in cli_out.iterdir())
    written = {str(p) for p in out.iterdir()}
    assert {str(out / "pdf_y.csv"), str(out / "pdf_ydot.csv")} <= set(result["files"]) <= written
    for name in ("pdf_y.csv", "pdf_ydot.csv"):
        assert (out / name).read_bytes() == (cli_out / name).read_bytes()
    assert "EPC n = 4" in result["table"]


def test_run_job_refuses_a_directory_it_did_not_write(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    with pytest.raises(fpsolve.JobError) as info:
        fpsolve.run_job(MODEL, out=out, figures=False)
    assert info.value.kind == "output"
    assert (out / "notes.txt").read_text() == "keep me"


def test_run_job_named_method_must_apply(tmp_path):
    with pytest.raises(fpsolve.NotApplicableError):
        fpsolve.run_job(MODEL, out=tmp_path / "x", methods=["epc-impact"])
    assert not (tmp_path / "x").exists()


def test_simulate_by_default_is_the_cli_simulate_by_default(cli, linear, tmp_path):
    # The same default seed (the CLI's --seed 1), so the same histogram to the printed digit.
    out = tmp_path / "mc"
    subprocess.run(
        [cli, "simulate", MODELS / "linear.sde", "--samples", "50000", "--out", out, "--quiet"],
        check=True,
        capture_output=True,
    )
    header, cols = read_csv(out / "mc_z.csv")
    mc = linear.simulate(samples=50_000)
    assert mc.report["settings"]["seed"] == 1
    np.testing.assert_array_equal(mc["z"].density, cols["mc"])


def test_seed_takes_none_an_int_a_generator_and_a_seed_sequence(linear):
    a = linear.simulate(samples=20_000, seed=np.random.default_rng(5))
    b = linear.simulate(samples=20_000, seed=np.random.default_rng(5))
    assert a.report["settings"]["seed"] == b.report["settings"]["seed"]
    np.testing.assert_array_equal(a["z"].density, b["z"].density)
    c = linear.simulate(samples=20_000, seed=np.random.SeedSequence(5))
    d = linear.simulate(samples=20_000, seed=c.report["settings"]["seed"])
    np.testing.assert_array_equal(c["z"].density, d["z"].density)
    fresh = [linear.simulate(samples=20_000, seed=None).report["settings"]["seed"] for _ in range(2)]
    assert fresh[0] != fresh[1]
    with pytest.raises(TypeError):
        linear.simulate(samples=20_000, seed="1")
    with pytest.raises(ValueError):
        linear.simulate(samples=20_000, seed=-1)
