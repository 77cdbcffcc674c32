#!/usr/bin/env python3
"""Numba peer of `fpsolve simulate models/vibro_duffing.sde` (issue 12, item 1), run on demand.

Zhuravlev-form vibro-impact Duffing oscillator: dz = v dt, dv = (-c v - k z - mu z^3) dt
+ (sgn z + eps z) sqrt(2 pi K) dW (Stratonovich = Ito here: the noise of v depends on z only),
impact at z = 0: v -> r v, located exactly within the free flight. The drift's delta term (the
paper's approximation of that impact) is not simulated, as in fpsolve's Monte Carlo.
Scheme as fpsolve's mechanical one: Strang splitting A(h/2) B(h) A(h/2), A the exact free
flight with the impact, B the Heun velocity update at frozen z (f affine in v), three-point
increments (three per 64-bit xoshiro256++ draw, 21-bit fields, seeded per trajectory like
src/mc/kernel/rng.rs).
Each thread steps `--lanes` trajectories side by side (independent dependency chains the
compiler can interleave and vectorise); a trajectory's numbers depend only on (seed, index),
so the results do not depend on --lanes or --threads.
Usage: /work/peer-venv/bin/python benches/peers/vibro_mc_numba.py [--samples 4e7 ...]
"""
import argparse, math, time
import numpy as np
import numba
from numba import njit, prange

U = np.uint64
M1, M2 = U(0xBF58476D1CE4E5B9), U(0x94D049BB133111EB)
GG, K0 = U(0x9E3779B97F4A7C15), U(0xD1B54A32D192ED03)
T3 = U(349525)  # P(-a) = P(+a) = T3 / 2^21, as fpsolve
A3 = math.sqrt(2097152.0 / (2 * 349525))  # the variance exactly 1
GRIDS = np.array([[-10.0, 10.0], [-15.0, 15.0], [0.0, 7.5], [-15.0, 15.0]])  # z, v, y, ydot


@njit(inline="always")
def mix64(z):
    z = (z ^ (z >> U(30))) * M1
    z = (z ^ (z >> U(27))) * M2
    return z ^ (z >> U(31))


@njit(inline="always")
def rotl(x, k):
    return (x << U(k)) | (x >> U(64 - k))


@njit(inline="always")
def xoshiro(a, b, c, d):  # xoshiro256++: (output, new state)
    out = rotl(a + d, 23) + a
    t = b << U(17)
    c ^= a
    d ^= b
    b ^= c
    a ^= d
    c ^= t
    return out, a, b, c, rotl(d, 45)


@njit(inline="always")
def three_point(h):
    return (A3 if T3 <= h < U(2) * T3 else 0.0) - (A3 if h < T3 else 0.0)


@njit(inline="always")
def flight(z, v, side, tau, r):  # x <- x + v tau, the crossing of z = 0 located exactly
    zn = z + v * tau
    d0, d1 = z * side, zn * side
    if d1 < 0.0 or (d1 == 0.0 and d0 > 0.0):
        th = min(max(-z / v, 0.0), tau)
        v = r * v
        if v * side < 0.0:
            side = -side
        return v * (tau - th), v, side, 1
    return zn, v, side, 0


@njit(inline="always")
def normal(a, b):
    u1 = (np.float64(a >> U(11)) + 0.5) / 9007199254740992.0
    u2 = (np.float64(b >> U(11)) + 0.5) / 9007199254740992.0
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


@njit(inline="always")
def bstep(z, v, side, xi, h, hn, sq, c, k, mu, eps, r):  # B(h) then the flight A(hn)
    sg = (1.0 if z > 0.0 else 0.0) - (1.0 if z < 0.0 else 0.0)
    dw = xi * ((sg + eps * z) * sq)
    f0 = -c * v - k * z - mu * z * z * z
    f1 = f0 - c * (f0 * h + dw)  # f(z, v_bar), f affine in v
    v += 0.5 * (f0 + f1) * h + dw
    return flight(z, v, side, hn, r)


@njit(parallel=True)
def run(ntraj, nchunks, lanes, seed, burn, nsamp, sps, h, c, k, mu, eps, r, s_noise, grids, bins):
    hist = np.zeros((nchunks, 4, bins), np.int64)
    sums = np.zeros((ntraj, 4, 2))  # per trajectory: sum q, sum q^2
    impacts = np.zeros(ntraj, np.int64)
    sq = math.sqrt(s_noise) * math.sqrt(h)
    sd_v = math.sqrt(s_noise / (2.0 * c))  # linearised stationary spread (fpsolve's start)
    sd_z = sd_v / math.sqrt(k)
    for ch in prange(nchunks):
        Z, V, S = np.empty(lanes), np.empty(lanes), np.empty(lanes)
        W = np.zeros(lanes, np.uint64)  # each lane's last draw
        R = np.empty((4, lanes), np.uint64)
        N = np.zeros(lanes, np.int64)
        j1 = (ch + 1) * ntraj // nchunks
        for g in range(ch * ntraj // nchunks, j1, lanes):  # lanes trajectories side by side
            nl = min(lanes, j1 - g)
            for i in range(nl):
                key = mix64(U(seed) ^ mix64(U(g + i) ^ K0))  # fpsolve's stream_state(seed, j)
                key += GG; a = mix64(key)
                key += GG; b = mix64(key)
                key += GG; cc = mix64(key)
                key += GG; d = mix64(key)
                o1, a, b, cc, d = xoshiro(a, b, cc, d)
                o2, a, b, cc, d = xoshiro(a, b, cc, d)
                o3, a, b, cc, d = xoshiro(a, b, cc, d)
                o4, a, b, cc, d = xoshiro(a, b, cc, d)
                Z[i], V[i], S[i] = abs(sd_z * normal(o1, o2)), sd_v * normal(o3, o4), 1.0
                R[0, i], R[1, i], R[2, i], R[3, i] = a, b, cc, d
                N[i] = 0
            field = 0  # the field of the last draws the next step takes (0: a new draw)
            for s in range(nsamp + 1):  # s = 0: the burn-in; then one advance per sample
                nsteps = burn if s == 0 else sps
                for i in range(nl):
                    Z[i], V[i], S[i], e = flight(Z[i], V[i], S[i], 0.5 * h, r)
                    N[i] += e
                for n in range(nsteps):
                    hn = h if n + 1 < nsteps else 0.5 * h
                    if field == 0:
                        for i in range(nl):
                            bits, R[0, i], R[1, i], R[2, i], R[3, i] = xoshiro(
                                R[0, i], R[1, i], R[2, i], R[3, i])
                            W[i] = bits
                            Z[i], V[i], S[i], e = bstep(Z[i], V[i], S[i],
                                                        three_point(bits >> U(43)), h, hn, sq,
                                                        c, k, mu, eps, r)
                            N[i] += e
                    else:
                        sh = U(21 * field)
                        for i in range(nl):
                            Z[i], V[i], S[i], e = bstep(Z[i], V[i], S[i],
                                                        three_point((W[i] << sh) >> U(43)), h,
                                                        hn, sq, c, k, mu, eps, r)
                            N[i] += e
                    field = (field + 1) % 3
                if s == 0:
                    N[:] = 0
                    continue
                for i in range(nl):
                    z, v = Z[i], V[i]
                    sg = (1.0 if z > 0.0 else 0.0) - (1.0 if z < 0.0 else 0.0)
                    for q, x in enumerate((z, v, abs(z), v * sg)):
                        sums[g + i, q, 0] += x
                        sums[g + i, q, 1] += x * x
                        lo, hi = grids[q, 0], grids[q, 1]
                        if lo <= x < hi:
                            hist[ch, q, int((x - lo) * (bins / (hi - lo)))] += 1
            for i in range(nl):
                impacts[g + i] = N[i]
    return hist, sums, impacts


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=float, default=4e7, help="recorded samples in all")
    p.add_argument("--spacing", type=float, default=0.05)
    p.add_argument("--dt", type=float, default=0.01)
    p.add_argument("--trajectories", type=int, default=800)
    p.add_argument("--burn-in", type=float, default=300.0)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--bins", type=int, default=100)
    p.add_argument("--lanes", type=int, default=64,
                   help="trajectories stepped side by side per thread (1: one at a time)")
    p.add_argument("--fpsolve-work", action="store_true",
                   help="also do what `fpsolve simulate` does besides the stated work: round "
                   "trajectories up to batches of 128, a pilot run (2 x 128 trajectories, <= 500 "
                   "samples) and the time-step bias run of the first max(8, batches/4) batches "
                   "at 2 dt (src/mc/config.rs, settings.rs); the wall time covers all three")
    a = p.parse_args()
    if a.fpsolve_work:
        a.trajectories = -(-a.trajectories // 128) * 128
    c, k, mu, eps, r, s_noise = 0.1, 1.0, 0.1, 0.1, 0.95, 1.0  # case 1, 2 pi K = 1
    numba.set_num_threads(a.threads)
    sps = round(a.spacing / a.dt)
    burn = math.ceil(a.burn_in / a.dt)
    nsamp = math.ceil(a.samples / a.trajectories)
    t0 = time.perf_counter()
    run(4, a.threads, a.lanes, 0, 10, 3, sps, a.dt, c, k, mu, eps, r, s_noise, GRIDS, a.bins)  # JIT
    t1 = time.perf_counter()
    hist, sums, imp = run(a.trajectories, a.threads, a.lanes, a.seed, burn, nsamp, sps, a.dt,
                          c, k, mu, eps, r, s_noise, GRIDS, a.bins)
    steps = a.trajectories * (burn + nsamp * sps)
    if a.fpsolve_work:
        nb = a.trajectories // 128
        cb = min(max(-(-nb // 4), 8), nb) * 128  # trajectories of the 2 dt run
        csps = sps // 2 if sps % 2 == 0 else sps
        run(256, a.threads, a.lanes, a.seed ^ 0x50494C4F545F5255, burn, min(nsamp, 500), sps,
            a.dt, c, k, mu, eps, r, s_noise, GRIDS, a.bins)
        run(cb, a.threads, a.lanes, a.seed, -(-burn // 2), nsamp, csps, 2 * a.dt,
            c, k, mu, eps, r, s_noise, GRIDS, a.bins)
        extra = 256 * (burn + min(nsamp, 500) * sps) + cb * (-(-burn // 2) + nsamp * csps)
        print(f"fpsolve's extra work: pilot + {cb} trajectories at 2 dt = {extra:.4e} steps")
        steps += extra
    t2 = time.perf_counter()
    wall = t2 - t1
    print(f"numba {numba.__version__}, {a.threads} threads, {a.lanes} lanes: "
          f"{a.trajectories} trajectories x "
          f"({burn} burn-in + {nsamp} samples x {sps}) steps = {steps:.4e} steps "
          f"({a.trajectories * nsamp:.4e} samples)")
    print(f"JIT warm-up {t1 - t0:.2f} s; wall {wall:.3f} s; {steps / wall:.3e} steps/s total, "
          f"{steps / wall / a.threads:.3e} per thread")
    m = sums / nsamp  # per-trajectory means of q and q^2
    n = a.trajectories
    print(f"impacts {imp.sum()} after burn-in, rate {imp.sum() / (n * nsamp * a.spacing):.5f} "
          "per unit time")
    print("quantity      mean       se    variance       se   (se over trajectories)")
    for q, name in enumerate(("z", "v", "y", "ydot")):
        m1, m2 = m[:, q, 0], m[:, q, 1]
        mean = m1.mean()
        var = m2.mean() - mean * mean
        infl = m2 - 2.0 * mean * m1  # linearisation of var in the trajectory means
        h = hist[:, q, :].sum(axis=0)
        print(f"{name:>8} {mean:10.6f} {m1.std(ddof=1) / math.sqrt(n):8.2e} {var:11.6f} "
              f"{infl.std(ddof=1) / math.sqrt(n):8.2e}   (histogram: {h.sum()} in grid "
              f"[{GRIDS[q, 0]}, {GRIDS[q, 1]}), {a.bins} bins)")


if __name__ == "__main__":
    main()
