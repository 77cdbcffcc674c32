"""progress= on long calls (a sweep's points, a Monte Carlo run's batches) and the provenance
a result carries."""

import json
import pickle

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


def test_a_solutions_report_opens_with_its_provenance(vibro, linear):
    sol = vibro.solve("epc", degree=4)
    r = sol.report
    assert list(r)[0] == "provenance"
    p = sol.provenance
    assert p is r["provenance"]
    sweep = fpsolve.sweep(vibro, eps=[0.0, 0.1])
    # The keys of SweepResult.provenance: no command from Python, no seed (a solve has none).
    assert set(p) == set(sweep.provenance) == {
        "fpsolve_version", "schema_version", "created", "threads", "model"
    }
    assert p["fpsolve_version"] == fpsolve.__version__
    assert p["schema_version"] == sweep.provenance["schema_version"] and p["created"].endswith("Z")
    assert isinstance(p["threads"], int) and p["threads"] >= 1
    assert p["model"] == sweep.provenance["model"]
    assert p["model"]["text"] == vibro.text and p["model"]["file"].endswith("vibro_duffing.sde")
    # The rest of the report is the solution's as before.
    assert r["degree"] == 4 and r["solve"]["iterations"] >= 1
    grid = linear.solve("grid", cells=(24, 48), c=0.5)
    assert list(grid.report)[0] == "provenance" and grid.provenance["model"]["name"] == "linear"
    assert "cells" in json.dumps(grid.report)
    # A model made from text has no file; a pickled solution keeps its provenance.
    text_model = fpsolve.Model.from_text(linear.text)
    q = text_model.solve("epc", degree=2).provenance["model"]
    assert "file" not in q and q["text"] == linear.text and q["name"] == "linear"
    back = pickle.loads(pickle.dumps(sol))
    assert back.report == sol.report and back.provenance == p
