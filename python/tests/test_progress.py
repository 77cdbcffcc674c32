"""progress= on long calls (a sweep's points, a Monte Carlo run's batches) and the provenance
a result carries."""

import pytest

import fpsolve


def test_sweep_reports_its_points_to_the_end(vibro):
    seen = []
    r = fpsolve.sweep(vibro, eps=[-0.2, -0.1, 0.0, 0.1, 0.2], progress=lambda d, t: seen.append((d, t)))
    assert len(r) == 5
    assert seen, "the callback was never called"
    assert seen[-1] == (5, 5)
    assert all(t == 5 for _, t in seen)
    done = [d for d, _ in seen]
    assert done == sorted(done) and len(set(done)) == len(done)


def test_simulate_reports_its_batches(linear):
    seen = []
    mc = linear.simulate(samples=200_000, progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1][0] == seen[-1][1] > 0
    assert mc.ok


def test_a_callback_that_raises_stops_the_run(vibro):
    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop(f"{done}/{total}")

    with pytest.raises(Stop):
        fpsolve.sweep(vibro, eps=[-0.2, -0.1, 0.0, 0.1, 0.2], progress=stop)


def test_progress_true_prints_to_stderr_without_tqdm(vibro, capfd, monkeypatch):
    from fpsolve import _progress

    monkeypatch.setattr(_progress, "_tqdm", lambda: None)
    fpsolve.sweep(vibro, eps=[-0.1, 0.0, 0.1], progress=True)
    err = capfd.readouterr().err
    assert "sweep: 3/3 (100%)" in err


def test_progress_true_is_a_tqdm_bar_when_tqdm_is_installed(vibro, capfd, monkeypatch):
    from fpsolve import _progress

    bars = []

    class FakeTqdm:
        def __init__(self, total, desc):
            self.total, self.desc, self.n, self.closed = total, desc, 0, False
            bars.append(self)

        def update(self, k):
            self.n += k

        def close(self):
            self.closed = True

    monkeypatch.setattr(_progress, "_tqdm", lambda: FakeTqdm)
    fpsolve.sweep(vibro, eps=[-0.1, 0.0, 0.1], progress=True)
    assert len(bars) == 1
    assert (bars[0].desc, bars[0].total, bars[0].n, bars[0].closed) == ("sweep", 3, 3, True)


def test_bad_progress_arguments_are_refused_before_work(vibro):
    with pytest.raises(TypeError, match="progress"):
        fpsolve.sweep(vibro, eps=[0.0, 0.1], progress="yes")
    with pytest.raises(TypeError, match="progress"):
        vibro.simulate(samples=1000, shard=(0, 2), progress=True)


def test_results_carry_their_provenance(vibro, linear):
    r = fpsolve.sweep(vibro, eps=[0.0, 0.1])
    p = r.provenance
    assert p["fpsolve_version"] == fpsolve.__version__
    assert p["schema_version"] >= 2 and p["created"].endswith("Z")
    assert p["model"]["name"] == "vibro_duffing" and "model vibro_duffing" in p["model"]["text"]
    merged = fpsolve.merge([fpsolve.sweep(vibro, eps=[0.0, 0.1], shard=(k, 2)) for k in range(2)])
    assert merged.provenance["model"]["name"] == "vibro_duffing"
    mc = linear.simulate(samples=100_000)
    assert mc.provenance["model"]["name"] == "linear"
    assert mc.provenance["created"].endswith("Z")
