"""Solves the vibro-impact model (the paper's Eqs. 1-2, models/vibro_impact_duffing.sde) with
each method from Python and times each call against the command line doing the same solve
(`fpsolve solve MODEL --method M --degree 4 --out DIR --quiet`: process start, parsing,
solving and writing summary.json and the marginals).

    python examples/python/timings.py                 # medians of 5 runs
    python examples/python/timings.py --repeat 9 --cli target/release/fpsolve

Prints a Markdown table: method, Python call (median, min), CLI run (median, min), and the
mean displacement each gives.
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import tempfile
import time

import fpsolve

REPO = pathlib.Path(__file__).resolve().parents[2]
MODEL = REPO / "models" / "vibro_impact_duffing.sde"


def timed(f, repeat):
    times, value = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        value = f()
        times.append(time.perf_counter() - t)
    return times, value


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--degree", type=int, default=4)
    default_cli = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target")) / "release" / "fpsolve"
    ap.add_argument("--cli", type=pathlib.Path, default=default_cli)
    args = ap.parse_args()
    if not args.cli.exists():
        raise SystemExit(f"no fpsolve binary at {args.cli}: run `cargo build --release` first")

    model = fpsolve.Model.load(MODEL)
    print(f"model {MODEL.relative_to(REPO)}, EPC degree {args.degree}, grid on its default cells; "
          f"{args.repeat} runs each, interleaved; load average {os.getloadavg()[0]:.2f}\n")
    print("| method | Python `model.solve` median (min) | CLI `fpsolve solve` median (min) | mean y |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for method in fpsolve.METHODS:
            py_times, cli_times, sol = [], [], None
            for k in range(args.repeat):
                t, sol = timed(lambda: model.solve(method, degree=args.degree), 1)
                py_times += t
                out = pathlib.Path(tmp) / f"{method}-{k}"
                cmd = [args.cli, "solve", MODEL, "--method", method, "--out", out, "--quiet"]
                if method != "grid":
                    cmd += ["--degree", str(args.degree)]
                t, _ = timed(lambda: subprocess.run(cmd, check=True, capture_output=True), 1)
                cli_times += t
            print(f"| {method} | {statistics.median(py_times):.3f} s ({min(py_times):.3f}) "
                  f"| {statistics.median(cli_times):.3f} s ({min(cli_times):.3f}) "
                  f"| {sol.moments('y').mean:.6f} |")


if __name__ == "__main__":
    main()
