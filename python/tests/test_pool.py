"""fpsolve in process pools and on executors (issue 37 item 2): no hang after fork, models,
solutions and results that pickle, and split runs that merge to the local run's bits."""

import concurrent.futures
import multiprocessing
import os
import pickle
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import fpsolve

from conftest import MODELS

# A pool that hangs fails the test after this long instead of hanging CI.
TIMEOUT_S = int(os.environ.get("FPSOLVE_POOL_TIMEOUT", "120"))

POOL_SCRIPT = textwrap.dedent(
    """
    import multiprocessing, sys
    import fpsolve

    PATH = sys.argv[2]

    def work(k):
        model = fpsolve.Model.load(PATH)
        sol = model.solve("epc", degree=2, c=0.5 + 0.1 * k)
        mc = model.simulate(samples=4000, trajectories=512, seed=k + 1, c=0.5)
        return sol.moments("z").variance, float(mc["z"].density.sum())

    if __name__ == "__main__":
        model = fpsolve.Model.load(PATH)
        # The parent uses every parallel path first: the solve, its moments, Monte Carlo.
        model.solve("epc", degree=2).moments("z")
        model.simulate(samples=4000, trajectories=512)
        ctx = multiprocessing.get_context(sys.argv[1])
        with ctx.Pool(2) as pool:
            out = pool.map(work, range(4))
        print("ok", out)
    """
)


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_a_pool_after_the_parent_used_fpsolve_finishes(tmp_path, method):
    if method not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {method} start method on this platform")
    script = tmp_path / "pool.py"
    script.write_text(POOL_SCRIPT)
    # In its own session, so that a hang is killed with its pool workers (killing only the
    # script would leave them blocked forever).
    proc = subprocess.Popen(
        [sys.executable, str(script), method, str(MODELS / "linear.sde")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = proc.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"a {method} pool calling fpsolve hung (killed after {TIMEOUT_S} s)")
    assert proc.returncode == 0, err
    assert out.startswith("ok"), out


def test_model_pickles_by_its_text_and_solves_to_the_same_bits(vibro):
    back = pickle.loads(pickle.dumps(vibro))
    assert back.text == vibro.text
    assert back.path == vibro.path
    assert back.quantities == vibro.quantities
    x = np.linspace(-2, 2, 41)
    a = vibro.solve("epc", degree=4, r=0.9).pdf("z", x)
    b = back.solve("epc", degree=4, r=0.9).pdf("z", x)
    assert np.array_equal(a, b)


def test_model_from_text_pickles():
    text = (MODELS / "linear.sde").read_text()
    model = fpsolve.Model.from_text(text)
    back = pickle.loads(pickle.dumps(model))
    assert back.path is None and back.text == text


def test_solution_pickles_with_every_array_and_its_report(linear):
    sol = linear.solve("epc", degree=2, c=0.5)
    back = pickle.loads(pickle.dumps(sol))
    assert (back.method, back.degree, back.quantities) == (sol.method, sol.degree, sol.quantities)
    for q in sol.quantities:
        xa, pa = sol.marginal(q)
        xb, pb = back.marginal(q)
        assert np.array_equal(xa, xb) and np.array_equal(pa, pb)
        assert back.moments(q) == sol.moments(q)
    assert back.coefficients == sol.coefficients
    assert back.report == sol.report


def test_grid_solution_pickles(linear):
    sol = linear.solve("grid", cells=(40, 80), c=0.5)
    back = pickle.loads(pickle.dumps(sol))
    x = np.linspace(-3, 3, 31)
    assert np.array_equal(back.pdf("v", x), sol.pdf("v", x))


def _same_mc(a, b):
    assert list(a) == list(b)
    for q in a:
        ha, hb = a[q], b[q]
        for field in ("x", "edges", "density", "stderr"):
            assert np.array_equal(getattr(ha, field), getattr(hb, field), equal_nan=True), (q, field)
        assert ha.samples == hb.samples and ha.outside == hb.outside
        assert ha.moments == hb.moments or all(
            np.allclose(ha.moments[k], hb.moments[k], rtol=0, atol=0, equal_nan=True) for k in ha.moments
        )
    assert a.flags == b.flags and a.warnings == b.warnings


def test_monte_carlo_and_sweep_results_pickle(linear):
    mc = linear.simulate(samples=4000, trajectories=512, c=0.5)
    back = pickle.loads(pickle.dumps(mc))
    _same_mc(mc, back)
    assert back.report == mc.report
    sw = fpsolve.sweep(linear, "epc", degree=2, c=[0.5, 1.0])
    back = pickle.loads(pickle.dumps(sw))
    assert back.report == sw.report
    assert np.array_equal(back.stat("epc", "z", "variance"), sw.stat("epc", "z", "variance"))


def _mc_report_without_time(mc):
    r = dict(mc.report)
    for key in ("wall_ms", "timings", "elapsed_ms"):
        r.pop(key, None)
    return r


def test_simulate_shards_merge_to_the_local_run(linear):
    kw = dict(samples=8000, trajectories=1024, seed=7, c=0.5)
    local = linear.simulate(**kw)
    parts = [linear.simulate(shard=(k, 3), **kw) for k in range(3)]
    parts = [pickle.loads(pickle.dumps(p)) for p in parts]
    merged = fpsolve.merge(parts[::-1])
    _same_mc(local, merged)


def test_merge_refuses_a_missing_part(linear):
    parts = [linear.simulate(samples=4000, trajectories=1024, shard=(k, 3)) for k in range(2)]
    with pytest.raises(fpsolve.MonteCarloError):
        fpsolve.merge(parts)


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_executor_runs_are_the_local_runs(linear, method):
    if method not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {method} start method on this platform")
    kw = dict(samples=8000, trajectories=1024, seed=3, c=0.5)
    local = linear.simulate(**kw)
    values = dict(c=[0.4, 0.6, 0.8, 1.0, 1.2])
    local_sweep = fpsolve.sweep(linear, ["epc", "grid"], degree=2, cells=(30, 60), **values)
    ctx = multiprocessing.get_context(method)
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=ctx) as ex:
        remote = linear.simulate(executor=ex, shards=4, **kw)
        remote_sweep = fpsolve.sweep(
            linear, ["epc", "grid"], degree=2, cells=(30, 60), executor=ex, shards=3, **values
        )
        # A solution and a model travel both ways.
        sol = ex.submit(_solve_remote, linear).result(timeout=TIMEOUT_S)
    _same_mc(local, remote)
    for m in ("epc", "grid"):
        assert np.array_equal(remote_sweep.converged(m), local_sweep.converged(m))
        for stat in ("mean", "variance", "kurtosis"):
            assert np.array_equal(
                remote_sweep.stat(m, "z", stat), local_sweep.stat(m, "z", stat), equal_nan=True
            )
    x = np.linspace(-3, 3, 13)
    assert np.array_equal(sol.pdf("z", x), linear.solve("epc", degree=2, c=0.7).pdf("z", x))


def _solve_remote(model):
    return model.solve("epc", degree=2, c=0.7)


def test_shard_and_executor_are_refused_together(linear):
    with concurrent.futures.ThreadPoolExecutor(1) as ex:
        with pytest.raises(TypeError):
            linear.simulate(samples=1000, shard=(0, 2), executor=ex)


def test_dask_local_cluster_gives_the_local_bits(linear):
    distributed = pytest.importorskip("distributed", reason="dask[distributed] is not installed")
    kw = dict(samples=8000, trajectories=1024, seed=5, c=0.5)
    local = linear.simulate(**kw)
    values = dict(c=[0.5, 0.7, 0.9, 1.1])
    local_sweep = fpsolve.sweep(linear, "epc", degree=2, **values)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None, processes=True
    ) as cluster, distributed.Client(cluster) as client:
        ex = client.get_executor()
        remote = linear.simulate(executor=ex, shards=4, **kw)
        remote_sweep = fpsolve.sweep(linear, "epc", degree=2, executor=ex, shards=2, **values)
    _same_mc(local, remote)
    assert np.array_equal(remote_sweep.stat("epc", "z", "variance"), local_sweep.stat("epc", "z", "variance"))


def test_params_dict_is_the_keywords(linear):
    a = linear.solve("epc", degree=2, params={"c": 0.5})
    b = linear.solve("epc", degree=2, c=0.5)
    assert a.moments("z") == b.moments("z")
    assert linear.parameters(params={"c": 0.5}) == linear.parameters(c=0.5)
    with pytest.raises(TypeError):
        linear.solve("epc", degree=2, params={"c": 0.5}, c=0.6)


def test_the_command_lines_shard_files_merge_in_python(cli, linear, tmp_path):
    for k in (1, 2):
        subprocess.run(
            [str(cli), "simulate", str(MODELS / "linear.sde"), "--samples", "8000",
             "--trajectories", "1024", "--seed", "7", "--set", "c=0.5", "--shard", f"{k}/2",
             "--out", str(tmp_path)],
            check=True, capture_output=True, timeout=TIMEOUT_S,
        )
    parts = [fpsolve.MonteCarloShard(p.read_text()) for p in sorted(tmp_path.glob("shard_*.json"))]
    assert [p.file_name for p in parts] == ["shard_1_of_2.json", "shard_2_of_2.json"]
    _same_mc(fpsolve.merge(parts), linear.simulate(samples=8000, trajectories=1024, seed=7, c=0.5))


def _bad_override(model):
    return model.solve("epc", degree=2, nope=1.0)


def test_errors_come_back_from_a_worker_with_their_class_and_data(linear):
    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=ctx) as ex:
        with pytest.raises(fpsolve.ParameterError) as info:
            ex.submit(_bad_override, linear).result(timeout=TIMEOUT_S)
    assert info.value.kind == "bind" and isinstance(info.value, ValueError)
    assert "nope" in str(info.value)


def _without_provenance(report):
    return {k: v for k, v in report.items() if k != "provenance"}


def test_a_merged_run_states_the_parts_model_and_threads(linear):
    kw = dict(samples=8000, trajectories=1024, seed=7, c=0.5)
    local = linear.simulate(threads=1, **kw)
    parts = [linear.simulate(shard=(k, 3), threads=1, **kw) for k in range(3)]
    for p in parts:
        assert p.json.startswith('{"provenance":')
        assert p.provenance["threads"] == 1
        assert p.provenance["model"] == local.provenance["model"]
    merged = fpsolve.merge([pickle.loads(pickle.dumps(p)) for p in parts])
    # Only the provenance differs from the local run: its time, and nothing else here.
    assert _without_provenance(merged.report) == _without_provenance(local.report)
    assert list(merged.report)[0] == "provenance"
    p, q = merged.provenance, local.provenance
    assert p["model"]["name"] == "linear" and p["model"]["text"] == linear.text
    assert p["model"] == q["model"] and p["model"]["file"] == str(MODELS / "linear.sde")
    assert p["threads"] == q["threads"] == 1
    assert set(p) == set(q) == {"fpsolve_version", "schema_version", "created", "threads", "model"}


def test_executor_runs_state_the_model_and_the_threads_their_parts_ran_with(linear):
    kw = dict(samples=8000, trajectories=1024, seed=3, c=0.5)
    values = dict(c=[0.4, 0.6, 0.8, 1.0])
    local = linear.simulate(**kw)
    local_sweep = fpsolve.sweep(linear, "epc", degree=2, **values)
    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=ctx) as ex:
        remote = linear.simulate(executor=ex, shards=4, threads=1, **kw)
        remote_sweep = fpsolve.sweep(linear, "epc", degree=2, executor=ex, shards=2, threads=1, **values)
    # The numbers are the local run's bits; the provenance names the model and one thread.
    assert _without_provenance(remote.report) == _without_provenance(local.report)
    for result, alone in ((remote, local), (remote_sweep, local_sweep)):
        p = result.provenance
        assert p["model"] == alone.provenance["model"], p
        assert p["model"]["text"] == linear.text
        assert p["threads"] == 1, p
        assert set(p) == set(alone.provenance)
    assert np.array_equal(remote_sweep.stat("epc", "z", "variance"), local_sweep.stat("epc", "z", "variance"))
