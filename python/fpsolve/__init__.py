"""fpsolve: stationary PDFs of randomly excited 2-D oscillators from model files.

A model file (or text) says the equations of motion, the noise and the impact law; fpsolve
derives the Fokker-Planck operator symbolically and solves it by the exponential-polynomial
closure (``"epc"``, the impact as a delta term; ``"epc-impact"``, the exact impact
condition) or by a finite-volume solver (``"grid"``), and checks it against Monte Carlo.

>>> import fpsolve, numpy as np
>>> model = fpsolve.Model.load("models/vibro_duffing.sde")        # doctest: +SKIP
>>> sol = model.solve("epc", degree=4, mu=0.5)                    # doctest: +SKIP
>>> p = sol.pdf("y", np.linspace(0, 3, 50))                       # doctest: +SKIP

The heavy lifting is the Rust library (``fpsolve._fpsolve``); this layer gives it Python's
conventions: keyword arguments for parameter overrides, NumPy arrays in and out, reports as
dicts, and typed exceptions (:class:`FpsolveError` and its subclasses).
"""

from ._fpsolve import (
    FpsolveError,
    GridSolveError,
    JobError,
    ModelError,
    ModelFileNotFoundError,
    MonteCarloError,
    NoConvergenceError,
    NotApplicableError,
    NotNormalisableError,
    ParameterError,
    SolveError,
    SweepError,
    UnknownQuantityError,
    __version__,
)
from ._model import Model
from ._montecarlo import CrossingRates, Histogram, MonteCarlo, MonteCarloShard, WallImpacts
from ._passage import Passage, PassageMonteCarlo
from ._solution import Moments, PointMassWarning, Solution
from ._transient import Transient, TransientHistory
from ._warnings import FpsolveWarning, MonteCarloWarning
from ._sweep import SweepResult, SweepShard, sweep
from ._merge import merge
from ._job import run_job

METHODS = ("epc", "epc-impact", "grid")
"""The methods :meth:`Model.solve` and :func:`sweep` take."""

__all__ = [
    "METHODS",
    "CrossingRates",
    "FpsolveError",
    "GridSolveError",
    "Histogram",
    "JobError",
    "Model",
    "ModelError",
    "ModelFileNotFoundError",
    "Moments",
    "MonteCarlo",
    "MonteCarloError",
    "MonteCarloShard",
    "MonteCarloWarning",
    "FpsolveWarning",
    "NoConvergenceError",
    "NotApplicableError",
    "NotNormalisableError",
    "ParameterError",
    "Passage",
    "PassageMonteCarlo",
    "Transient",
    "TransientHistory",
    "PointMassWarning",
    "Solution",
    "SolveError",
    "SweepError",
    "SweepResult",
    "SweepShard",
    "UnknownQuantityError",
    "WallImpacts",
    "__version__",
    "merge",
    "run_job",
    "sweep",
]
