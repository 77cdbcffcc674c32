"""Model.simulate: histograms as arrays, determinism, errors, and Ctrl-C."""

import _thread
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import fpsolve
from conftest import MODELS, REPO


def test_histograms_are_arrays(linear):
    mc = linear.simulate(samples=100_000, seed=3, grids={"z": (-8.0, 8.0, 64)})
    assert isinstance(mc, fpsolve.MonteCarlo)
    assert list(mc) == list(linear.quantities)
    h = mc["z"]
    assert isinstance(h, fpsolve.Histogram)
    for a in (h.x, h.density, h.stderr):
        assert a.dtype == np.float64 and a.shape == (64,)
    assert h.edges.shape == (65,)
    np.testing.assert_allclose(h.x, 0.5 * (h.edges[1:] + h.edges[:-1]), rtol=0, atol=1e-12)
    assert np.all(h.stderr >= 0)
    assert mc.samples == h.samples >= 100_000
    # The histogram is a density: its mass is the fraction of samples inside the grid.
    inside = 1 - h.outside / h.samples
    assert np.sum(h.density) * (h.edges[1] - h.edges[0]) == pytest.approx(inside, rel=1e-9)
    assert mc.report["trajectories"] >= 1


def test_linear_moments_agree_with_the_exact_variance(linear):
    # Var z = Var v = 5 exactly; Monte Carlo within five standard errors (plus the
    # time-step bias allowance of 1%).
    mc = linear.simulate(samples=400_000, seed=11)
    for name in ("z", "v"):
        value, stderr = mc[name].moments["variance"]
        assert abs(value - 5.0) < 5 * stderr + 0.05


def test_same_seed_same_histograms_whatever_the_threads(linear):
    a = linear.simulate(samples=50_000, seed=7, threads=1)
    b = linear.simulate(samples=50_000, seed=7, threads=2)
    np.testing.assert_array_equal(a["z"].density, b["z"].density)
    c = linear.simulate(samples=50_000, seed=8, threads=2)
    assert not np.array_equal(a["z"].density, c["z"].density)


def test_overrides_apply(linear):
    a = linear.simulate(samples=50_000, seed=1, k=4.0)
    # Var z = pi K / (c k) = 1.25 at k = 4.
    value, stderr = a["z"].moments["variance"]
    assert abs(value - 1.25) < 5 * stderr + 0.02


def test_bad_settings_are_monte_carlo_errors(linear):
    with pytest.raises(fpsolve.MonteCarloError) as info:
        linear.simulate(samples=1000, dt=-0.1)
    assert info.value.kind == "bad_setting"
    with pytest.raises(fpsolve.MonteCarloError) as info:
        linear.simulate(samples=1000, grids={"z": (1.0, 1.0, 10)})
    assert info.value.kind == "bad_setting"


def _threads():
    return len(os.listdir("/proc/self/task"))


@pytest.fixture
def python_sigint():
    """Python's own SIGINT handler, as in an interactive session. A process started in the
    background by a non-interactive shell (`cmd &`, nohup) inherits SIGINT ignored; Python then
    installs no handler and Ctrl-C (or `interrupt_main`) raises nothing, whatever fpsolve does."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_stops_a_long_simulation(vibro, python_sigint):
    vibro.simulate(samples=20_000, seed=0, threads=2)  # warm-up: any lazily started threads
    before_py = threading.active_count()
    before_os = _threads()
    fired = []

    def interrupt():
        fired.append(time.monotonic())
        _thread.interrupt_main()  # as Ctrl-C: SIGINT's default handler raises KeyboardInterrupt

    timer = threading.Timer(0.5, interrupt)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        # About a minute of work on two cores if it were not interrupted.
        vibro.simulate(samples=2_000_000_000, seed=0, threads=2)
    latency = time.monotonic() - fired[0]
    timer.join()
    assert latency < 1.0, f"KeyboardInterrupt {latency:.2f} s after Ctrl-C"
    assert threading.active_count() == before_py
    # The worker is joined before the exception is raised; the pool's threads exit with it.
    deadline = time.monotonic() + 2.0
    while _threads() > before_os and time.monotonic() < deadline:
        time.sleep(0.02)
    assert _threads() <= before_os


def test_ctrl_c_stops_a_sweep(vibro, python_sigint):
    fired = []

    def interrupt():
        fired.append(time.monotonic())
        _thread.interrupt_main()

    timer = threading.Timer(0.3, interrupt)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        # 120 grid solves of ~0.1 s each: several seconds if it were not interrupted.
        fpsolve.sweep(vibro, method="grid", cells=(60, 60), eps=np.linspace(-0.3, 0.3, 40), mu=[0.1, 0.5, 1.0])
    latency = time.monotonic() - fired[0]
    timer.join()
    # A sweep stops between points: only the points in progress finish.
    assert latency < 1.0, f"KeyboardInterrupt {latency:.2f} s after Ctrl-C"


def _interrupt_after(seconds, fired):
    def interrupt():
        fired.append(time.monotonic())
        _thread.interrupt_main()

    timer = threading.Timer(seconds, interrupt)
    timer.start()
    return timer


def test_ctrl_c_returns_from_a_long_grid_solve(vibro, python_sigint):
    # One factorisation of half a million cells, seconds of work with no point to stop at: the
    # call returns at the next poll and the solve finishes unseen.
    fired = []
    timer = _interrupt_after(0.3, fired)
    with pytest.raises(KeyboardInterrupt):
        vibro.solve("grid", cells=(500, 1000))
    latency = time.monotonic() - fired[0]
    timer.join()
    assert latency < 0.5, f"KeyboardInterrupt {latency:.2f} s after Ctrl-C"
    # The abandoned solve keeps the shared pool's threads until it ends: the next call waits
    # for them (here, so that the next test starts on an idle pool).
    assert vibro.solve("epc", degree=2).method == "epc"


def test_ctrl_c_returns_from_run_job_and_writes_nothing(vibro, python_sigint, tmp_path):
    out = tmp_path / "job"
    fired = []
    timer = _interrupt_after(0.3, fired)
    with pytest.raises(KeyboardInterrupt):
        fpsolve.run_job(vibro, out, methods=["grid"], cells=(500, 1000), figures=False)
    latency = time.monotonic() - fired[0]
    timer.join()
    assert latency < 0.5, f"KeyboardInterrupt {latency:.2f} s after Ctrl-C"
    # The abandoned job ends by itself and removes its staging directory: nothing of it is
    # ever put in place.
    deadline = time.monotonic() + 120
    def staged():
        return [p.name for p in tmp_path.iterdir() if "partial" in p.name]

    while staged() and time.monotonic() < deadline:
        assert not out.exists()
        time.sleep(0.1)
    assert not out.exists()
    assert staged() == []


def test_sigint_to_a_python_process(tmp_path):
    script = tmp_path / "long.py"
    script.write_text(
        "import signal, sys, fpsolve\n"
        # As in an interactive session, even when these tests run in the background (see
        # `python_sigint`).
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        f"m = fpsolve.Model.load({str(MODELS / 'vibro_duffing.sde')!r})\n"
        "print('started', flush=True)\n"
        "try:\n"
        "    m.simulate(samples=2_000_000_000, threads=1)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True)\n"
        "    sys.exit(130)\n"
    )
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "started"
    time.sleep(0.5)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=30)
    assert time.monotonic() - sent < 1.5
    assert proc.returncode == 130
    assert out.strip() == "interrupted"


def test_a_flagged_run_warns_and_strict_raises():
    # dt = 0.5 on the parametric oscillator: hundreds of 4096 trajectories blow up, which
    # `fpsolve simulate` exits 1 for. Python warns and lists why; strict=True raises.
    model = fpsolve.Model.load(os.path.join(MODELS, "parametric.sde"))
    with pytest.warns(fpsolve.MonteCarloWarning, match="blew up"):
        mc = model.simulate(samples=100_000, dt=0.5, spacing=0.5)
    assert not mc.ok
    assert any("blew up" in f for f in mc.flags)
    with pytest.raises(fpsolve.MonteCarloError, match="blew up"):
        model.simulate(samples=100_000, dt=0.5, spacing=0.5, strict=True)


def test_numbers_without_a_finite_value_are_flagged():
    # dt = 0.25: no blow-up, but some time-step-bias numbers are infinite (null in the
    # JSON, NaN here): flagged as the CLI flags them, with the field named.
    model = fpsolve.Model.load(os.path.join(MODELS, "parametric.sde"))
    with pytest.warns(fpsolve.MonteCarloWarning, match="no finite value"):
        mc = model.simulate(samples=100_000, dt=0.25, spacing=0.25)
    assert any("mc_summary.json" in f for f in mc.flags)


def test_a_sound_run_is_silent(linear):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mc = linear.simulate(samples=100_000, seed=3)
    assert mc.ok and mc.flags == []
    assert issubclass(fpsolve.MonteCarloWarning, fpsolve.FpsolveWarning)
    assert issubclass(fpsolve.PointMassWarning, fpsolve.FpsolveWarning)
