"""The paper's Figs. 1-4 from Python: the four cases of Table 1, EPC at degrees 2 and 4
against Monte Carlo, PDFs of the displacement y and the velocity ydot on linear and log
scales (panels a-d of each figure).

The model is the paper's Eqs. 1-2 as written (models/vibro_impact_duffing.sde): EPC solves
its Zhuravlev transform (Eqs. 5-10), derived by fpsolve; Monte Carlo simulates Eqs. 1-2 with
the impacts located exactly, as the paper's simulation does.

    pip install ./python matplotlib
    python examples/python/paper_cases.py                  # 1e7 samples per case (the paper's)
    python examples/python/paper_cases.py --samples 2e8 --out out/paper_figs

Writes fig1_case1.png ... fig4_case4.png into --out (default out/python_paper_cases).
"""

import argparse
import pathlib
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import fpsolve  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
# Table 1: (mu, eps); c = 0.1, k = 1, 2 pi K = 1, r = 0.95 are the model's defaults.
CASES = [(0.1, 0.1), (0.1, -0.1), (1.0, 0.1), (1.0, -0.1)]
LABELS = {"y": "displacement y", "ydot": "velocity ẏ"}


def case_figure(model, k, mu, eps, samples, bins, out):
    t = time.perf_counter()
    epc = {n: model.solve("epc", degree=n, mu=mu, eps=eps) for n in (2, 4)}
    t_epc = time.perf_counter() - t
    # Monte Carlo on the range of the degree-4 density (its marginal reaches 1e-8 of the peak).
    grids = {}
    for q in ("y", "ydot"):
        x, _ = epc[4].marginal(q)
        grids[q] = (0.0 if q == "y" else float(x[0]), float(x[-1]), bins)
    t = time.perf_counter()
    mc = model.simulate(samples=samples, seed=2024 + k, grids=grids, mu=mu, eps=eps)
    t_mc = time.perf_counter() - t

    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    for row, q in enumerate(("y", "ydot")):
        h = mc[q]
        x = np.linspace(h.edges[0], h.edges[-1], 400)
        for col, log in enumerate((False, True)):
            ax = axes[row, col]
            for n, style in ((2, "--"), (4, "-")):
                ax.plot(x, epc[n].pdf(q, x), style, label=f"EPC (n = {n})")
            shown = h.density > 0
            ax.errorbar(
                h.x[shown], h.density[shown], yerr=2 * h.stderr[shown], fmt="o", ms=2.5,
                lw=0.8, label=f"MCS ({h.samples:.1e} samples, ±2σ)",
            )
            if log:
                ax.set_yscale("log")
                ax.set_ylim(max(h.density[shown].min() / 3, 1e-7), None)
            ax.set_xlabel(LABELS[q])
            ax.set_ylabel("PDF")
            ax.set_title(f"({'abcd'[2 * row + col]}) {LABELS[q]}{', log scale' if log else ''}")
            ax.legend(fontsize=8)
    fig.suptitle(f"Figure {k}: case {k} of Table 1 (μ = {mu}, ε = {eps})")
    fig.tight_layout()
    path = out / f"fig{k}_case{k}.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"case {k} (mu = {mu}, eps = {eps}): EPC n = 2, 4 in {t_epc:.2f} s, "
          f"Monte Carlo {h.samples:.2e} samples in {t_mc:.1f} s -> {path}")
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=float, default=1e7, help="Monte Carlo samples per case")
    ap.add_argument("--bins", type=int, default=60, help="histogram bins per quantity")
    ap.add_argument("--out", type=pathlib.Path, default=REPO / "out" / "python_paper_cases")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    model = fpsolve.Model.load(REPO / "models" / "vibro_impact_duffing.sde")
    for k, (mu, eps) in enumerate(CASES, start=1):
        case_figure(model, k, mu, eps, int(args.samples), args.bins, args.out)


if __name__ == "__main__":
    main()
