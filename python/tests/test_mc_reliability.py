"""Model.simulate's reliability statistics as arrays: up-crossing rates and impact
statistics against the elastic wall's exact values (the barrier-free Gaussian restricted to
the domain), their checks before any work, and shards merged to the unsplit run's bits."""

import math

import numpy as np
import pytest

import fpsolve
from conftest import REPO

WALL = REPO / "tests" / "models" / "grid_impact_linear.sde"
# The model's f = c/(pi K) = 0.2: sigma_v^2 = 5; the wall at y = -0.5.
F, YB = 0.2, -0.5
SV = math.sqrt(1 / F)


def _flux(u):
    """Rice's up-crossing rate p_y(u) sigma_v / sqrt(2 pi) of the restricted Gaussian."""
    # p_y(u) = exp(-F u^2/2) / Z, Z the integral over y > YB.
    z = math.sqrt(math.pi / (2 * F)) * math.erfc(YB * math.sqrt(F / 2))
    return math.exp(-F * u * u / 2) / z * SV / math.sqrt(2 * math.pi)


@pytest.fixture(scope="module")
def wall():
    return fpsolve.Model.load(WALL)


@pytest.fixture(scope="module")
def run(wall):
    return wall.simulate(
        samples=400_000,
        seed=5,
        levels={"y": [YB, -0.3, 1.0, 2.5]},
        impact_speeds=(0.0, 10.0, 10),
    )


def _within(value, stderr, bias, exact):
    return abs(value - exact) <= 5 * stderr + abs(bias)


def test_crossing_rates_are_rices(run):
    c = run.crossings["y"]
    assert isinstance(c, fpsolve.CrossingRates)
    np.testing.assert_array_equal(c.levels, [YB, -0.3, 1.0, 2.5])
    for a in (c.rate, c.stderr, c.spacing_bias):
        assert a.dtype == np.float64 and a.shape == (4,)
    assert np.all(c.stderr > 0)
    tsb = np.zeros(4) if c.time_step_bias is None else c.time_step_bias
    for k, u in enumerate(c.levels):
        bias = c.spacing_bias[k] + tsb[k]
        assert _within(c.rate[k], c.stderr[k], bias, _flux(u)), (u, c.rate[k], _flux(u))


def test_wall_statistics_are_the_restricted_gaussians(run):
    [w] = run.walls
    assert isinstance(w, fpsolve.WallImpacts)
    assert (w.state, w.at, w.above) == ("y", YB, True)
    assert w.count > 0
    bias = w.time_step_bias or (0.0, 0.0, 0.0)
    assert _within(*w.rate, bias[0], _flux(YB))
    assert _within(*w.mean_speed, bias[1], SV * math.sqrt(math.pi / 2))
    # r = 1: no energy taken.
    assert w.mean_power[0] == 0.0
    # The speed density: bins of width 1 on [0, 10), centred at k + 1/2, mass ~ 1.
    np.testing.assert_allclose(w.speeds, np.arange(10) + 0.5, rtol=0, atol=1e-12)
    assert w.speed_density.shape == w.speed_stderr.shape == (10,)
    assert abs(np.sum(w.speed_density) - 1) < 0.01
    # Against the Rayleigh bin averages.
    cdf = 1 - np.exp(-np.arange(11) ** 2 / (2 * SV**2))
    exact = np.diff(cdf)
    assert np.all(np.abs(w.speed_density - exact) <= 5 * w.speed_stderr + 1e-3)


def test_without_levels_or_a_wall_there_is_nothing(linear):
    mc = linear.simulate(samples=20_000, seed=2)
    assert mc.crossings == {} and mc.walls == []


def test_bad_levels_are_refused_before_work(wall):
    for levels in ({"w": [0.0]}, {"y": [1.0, 0.0]}, {"y": []}, {"y": [0.0, float("nan")]}):
        with pytest.raises(fpsolve.MonteCarloError) as info:
            wall.simulate(samples=1000, levels=levels)
        assert info.value.kind == "bad_setting", levels
    with pytest.raises(fpsolve.MonteCarloError) as info:
        wall.simulate(samples=1000, impact_speeds=(1.0, 1.0, 4))
    assert info.value.kind == "bad_setting"


def test_shards_merge_to_the_unsplit_run(wall):
    kw = dict(samples=40_000, seed=9, levels={"y": [YB, 0.0]}, impact_speeds=(0.0, 8.0, 4))
    whole = wall.simulate(**kw)
    parts = [wall.simulate(shard=(k, 3), **kw) for k in range(3)]
    merged = fpsolve.merge(parts)
    a, b = whole.crossings["y"], merged.crossings["y"]
    np.testing.assert_array_equal(a.rate, b.rate)
    np.testing.assert_array_equal(a.stderr, b.stderr)
    [wa], [wb] = whole.walls, merged.walls
    assert (wa.count, wa.rate, wa.mean_speed) == (wb.count, wb.rate, wb.mean_speed)
    np.testing.assert_array_equal(wa.speed_density, wb.speed_density)
