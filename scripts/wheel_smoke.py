"""Solve models/duffing.sde with an installed fpsolve and compare with the exact PDF.

Used by scripts/wheel-check (a fresh venv without Rust) and by the release workflow on every
platform's runner. EPC at degree 4 holds the Duffing oscillator's exact stationary PDF
(p ~ exp(-(c/(pi K)) (v^2/2 + k z^2/2 + mu z^4/4)), see the model file), so the density and the
variance of z must match the closed form to the solver's tolerance, not to a loose band.
Usage: python scripts/wheel_smoke.py models/duffing.sde
"""

import sys
import time

import numpy as np

import fpsolve


def main(path):
    model = fpsolve.Model.load(path)
    start = time.perf_counter()
    solution = model.solve("epc", degree=4)
    elapsed = time.perf_counter() - start
    # The model file's defaults: c = 0.1, k = 1, mu = 0.1, 2 pi K = 1.
    c, k, mu, K = 0.1, 1.0, 0.1, 1 / (2 * np.pi)
    integrate = np.trapezoid if hasattr(np, "trapezoid") else np.trapz
    z = np.linspace(-15.0, 15.0, 30001)
    exact = np.exp(-(c / (np.pi * K)) * (k * z**2 / 2 + mu * z**4 / 4))
    exact /= integrate(exact, z)
    variance = integrate(z**2 * exact, z)
    error = np.max(np.abs(solution.pdf("z", z) - exact)) / np.max(exact)
    got = solution.moments("z").variance
    print(f"fpsolve {fpsolve.__version__} from {fpsolve.__file__}")
    print(f"solve {elapsed * 1e3:.1f} ms; max |p - p_exact| / max p_exact = {error:.2e}")
    print(f"Var z = {got:.10f}, exact {variance:.10f} (relative {abs(got / variance - 1):.1e})")
    if not (error < 1e-6 and abs(got / variance - 1) < 1e-6):
        sys.exit("the installed fpsolve's solution differs from the exact stationary PDF")


if __name__ == "__main__":
    main(sys.argv[1])
