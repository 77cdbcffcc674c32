"""fpsolve.Model: a validated model and the calls that solve and simulate it."""

from __future__ import annotations

import concurrent.futures
import os
import warnings
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _fpsolve
from ._montecarlo import MonteCarlo, MonteCarloShard
from ._progress import ProgressArg, callback
from ._solution import Solution
from ._warnings import FpsolveWarning

Value = Union[float, int, str]
"""A parameter override: a number, or an expression of numbers, ``pi``, ``e`` and other
parameters (as ``--set name=expr`` takes it)."""


def _seed(seed: Any) -> int:
    """The run's 64-bit seed from what SPEC 7 lets a caller pass: an int (as ``--seed``),
    ``None`` (fresh entropy), a ``numpy.random.Generator`` or a ``SeedSequence``."""
    if seed is None:
        return int(np.random.SeedSequence().generate_state(1, np.uint64)[0])
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**64, dtype=np.uint64))
    if isinstance(seed, np.random.SeedSequence):
        return int(seed.generate_state(1, np.uint64)[0])
    if isinstance(seed, bool) or not hasattr(seed, "__index__"):
        raise TypeError(
            "seed: expected an int, None, a numpy Generator or SeedSequence, "
            f"got {type(seed).__name__}"
        )
    value = int(seed.__index__())
    if not 0 <= value < 2**64:
        raise ValueError(f"seed: {value} is not a 64-bit unsigned integer")
    return value


def _params(params: Optional[Mapping[str, Any]], set: Dict[str, Any]) -> Dict[str, Any]:
    """The overrides of a call: the explicit ``params`` dict and the keyword arguments,
    neither naming a parameter the other does."""
    if params is None:
        return set
    if not isinstance(params, Mapping):
        raise TypeError(f"params: expected a dict of overrides, got {type(params).__name__}")
    both = sorted(set.keys() & params.keys())
    if both:
        raise TypeError(f"parameter {both[0]!r} given both in params and as a keyword")
    return {**params, **set}


def _domain(
    domain: Union[None, str, Mapping[str, Sequence[float]]],
) -> Optional[str]:
    """The grid's box as the CLI's ``--domain`` text: a string as it is, a mapping
    ``{state: (lo, hi)}`` as ``state=lo:hi,...`` (numbers in their shortest exact form)."""
    if domain is None or isinstance(domain, str):
        return domain
    parts = []
    for name, bounds in domain.items():
        lo, hi = bounds
        parts.append(f"{name}={float(lo)!r}:{float(hi)!r}")
    return ",".join(parts)


def _cells(cells: Optional[Sequence[int]]) -> Optional[Tuple[int, int]]:
    if cells is None:
        return None
    nx, nv = cells
    return (int(nx), int(nv))


class Model:
    """A model file read and validated (``Model.load``) or model text (``Model.from_text``).

    Parameter overrides are keyword arguments of every call (``model.solve("epc", mu=0.5)``);
    the model itself never changes.
    """

    __slots__ = ("_inner",)

    def __init__(self, inner: "_fpsolve._Model"):
        self._inner = inner

    def __reduce__(self):
        # By its text and the name it was read under: the unpickled model is the same model
        # (it solves to the same bits) in any process, with no file needed there.
        return (_from_state, (self._inner.text, self.path))

    @property
    def text(self) -> str:
        """The model text it was parsed from (a file's content as read)."""
        return self._inner.text

    @classmethod
    def load(cls, path: Union[str, os.PathLike]) -> "Model":
        """Reads and validates the model file at ``path``.

        Raises :class:`ModelError` (``.path``, ``.line``, ``.column``, ``.message``) with the
        command line's file:line:col message when the file cannot be read or is not a valid
        model.
        """
        return cls(_fpsolve._Model.load(os.fspath(path)))

    @classmethod
    def from_text(cls, text: str, path: Optional[str] = None) -> "Model":
        """Parses and validates model text; ``path`` only names it in error messages."""
        return cls(_fpsolve._Model.from_text(text, path))

    @property
    def name(self) -> str:
        """The model's name (its ``model NAME`` line)."""
        return self._inner.name

    @property
    def description(self) -> str:
        """The model's description (its ``model NAME "..."`` text), or ``""``."""
        return self._inner.description

    @property
    def path(self) -> Optional[str]:
        """The file it was read from, or None for text."""
        p = self._inner.path
        return None if p is None else os.fspath(p)

    @property
    def states(self) -> Tuple[str, str]:
        """The two state names."""
        a, b = self._inner.states
        return (a, b)

    @property
    def observables(self) -> Tuple[str, ...]:
        """The observables' names (``observe`` lines)."""
        return tuple(self._inner.observables)

    @property
    def quantities(self) -> Tuple[str, ...]:
        """Every name ``Solution.pdf`` takes: the states, then the observables."""
        return self.states + self.observables

    def parameters(self, params: Optional[Mapping[str, Value]] = None, **set: Value) -> Dict[str, float]:
        """The parameters' values with the overrides ``params`` and ``set`` applied, in
        declaration order."""
        return dict(self._inner.parameters(_params(params, set)))

    def check(self, params: Optional[Mapping[str, Value]] = None, **set: Value) -> str:
        """What ``fpsolve check`` prints: the model, its parameter values and its derived
        Fokker-Planck operator (and, for a reflecting barrier, the Zhuravlev transform EPC
        solves)."""
        return self._inner.check(_params(params, set))

    def solve(
        self,
        method: str = "epc",
        degree: int = 4,
        cells: Optional[Sequence[int]] = None,
        params: Optional[Mapping[str, Value]] = None,
        domain: Union[None, str, Mapping[str, Sequence[float]]] = None,
        tol: Optional[float] = None,
        **set: Value,
    ) -> Solution:
        """Solves the stationary FPK equation with the overrides ``set``.

        ``method`` is ``"epc"`` (the paper's closure, the impact as a delta term),
        ``"epc-impact"`` (EPC with the exact impact condition) or ``"grid"`` (finite volumes
        on ``cells = (nx, nv)``, default (200, 400)); ``degree`` is the EPC degree (even,
        2 to 12; every even degree up to it is solved in turn). ``domain`` fixes the grid's
        box instead of sizing it from the density: ``{"x": (-8, 8), "v": (-10, 10)}`` or the
        CLI's text ``"x=-8:8,v=-10:10"`` (the model's state names; the velocity's range is
        made symmetric about 0; a reflecting wall's side must end on the wall); a box that
        cuts the density is flagged in the report (``grid.report.edges``) and its estimate
        grows. ``ValueError`` for a malformed box or one given to another method. ``tol`` asks
        the grid for an accuracy instead of cells (``--tol``): it chooses and refines its cells
        until its estimated L1 error of both marginals is at most ``tol`` (0 < tol <= 0.5);
        ``report["tolerance"]`` holds ``asked``, ``achieved``, ``reached``, ``shortfall`` and
        the ``solves`` made (cells, estimate); not reached, the best solve is returned and a
        :class:`FpsolveWarning` says so. ``ValueError`` for a bad ``tol``, one with ``cells``
        or with another method. ``params`` is the
        overrides as a dict (for names that are not identifiers or clash with a keyword of
        this call); it and ``**set`` together may not name a parameter twice. Releases the
        GIL.

        Raises :class:`NoConvergenceError`, :class:`NotNormalisableError`,
        :class:`GridSolveError`, :class:`NotApplicableError` (all :class:`SolveError`) with
        the failure's data, or :class:`ParameterError` for a bad override.
        """
        set = _params(params, set)
        box = _domain(domain)
        tol = None if tol is None else float(tol)
        inner = self._inner.solve(method, int(degree), _cells(cells), set, box, tol)
        solution = Solution(inner, (self, method, int(degree), _cells(cells), set, box, tol))
        _warn_shortfall(solution, tol)
        return solution

    def simulate(
        self,
        samples: int = 1_000_000,
        seed: Union[int, None, "np.random.Generator", "np.random.SeedSequence"] = 1,
        threads: Optional[int] = None,
        dt: Optional[float] = None,
        spacing: Optional[float] = None,
        trajectories: Optional[int] = None,
        bins: Optional[int] = None,
        grids: Optional[Mapping[str, Tuple[float, float, int]]] = None,
        strict: bool = False,
        params: Optional[Mapping[str, Value]] = None,
        shard: Optional[Tuple[int, int]] = None,
        executor: Optional["concurrent.futures.Executor"] = None,
        shards: Optional[int] = None,
        progress: ProgressArg = None,
        **set: Value,
    ) -> Union[MonteCarlo, MonteCarloShard]:
        """Monte Carlo simulation: ``samples`` recorded samples in all (rounded up to whole
        trajectories, as ``fpsolve simulate --samples``), histograms of every state and
        observable with standard errors.

        ``seed`` is the command line's ``--seed`` (default 1, as there: the same seed gives the
        same bits as ``fpsolve simulate``); ``None`` draws a fresh one from the operating
        system, and a ``numpy.random.Generator`` or ``SeedSequence`` gives one of its draws
        (SPEC 7); the seed used is ``mc.report["settings"]["seed"]``. ``grids`` maps a quantity to its histogram grid ``(lo, hi, bins)`` (the others are
        chosen from a pilot run); ``threads`` defaults to the cores available. The result
        does not depend on ``threads``. Releases the GIL; Ctrl-C stops the run and raises
        KeyboardInterrupt. Raises :class:`MonteCarloError` for a run refused or failed.

        A run that finished but is flagged (too many blow-ups, not stationary, numbers
        without a finite value: what ``fpsolve simulate`` exits 1 for) warns
        :class:`MonteCarloWarning` and lists why in the result's ``flags``; with
        ``strict=True`` it raises :class:`MonteCarloError` instead. The run's other warnings
        (a resolved time-step bias above the statistical error, a few blow-ups) are warned as
        :class:`FpsolveWarning` and kept in ``warnings``.

        Split runs (the command line's ``simulate --shard`` and ``merge``): ``shard=(k, n)``
        runs only the ``k``-th (from 0) of ``n`` parts of the run's statistics batches and
        returns a :class:`MonteCarloShard` (plain data: it pickles, and
        :func:`fpsolve.merge` joins the ``n`` parts into the :class:`MonteCarlo` of the
        unsplit run, bit for bit). ``executor`` (any ``concurrent.futures.Executor``: a
        ``ProcessPoolExecutor``, ``distributed.Client.get_executor()``, Ray's) runs the
        ``shards`` parts (default 8, at most the run's statistics batches) on it and merges
        them: the same bits as the local run. ``params`` is the overrides as a dict.

        ``progress=True`` prints the statistics batches done to stderr as the run goes (in
        place on a terminal, every tenth in a log); a callable ``f(done, total)`` is called
        instead (from the calling thread; an exception it raises stops the run). Local runs
        only (not with ``shard`` or ``executor``).
        """
        set = _params(params, set)
        run = dict(
            samples=int(samples),
            seed=_seed(seed),
            threads=None if threads is None else int(threads),
            dt=None if dt is None else float(dt),
            spacing=None if spacing is None else float(spacing),
            trajectories=None if trajectories is None else int(trajectories),
            bins=None if bins is None else int(bins),
            grids=[(name, float(lo), float(hi), int(n)) for name, (lo, hi, n) in (grids or {}).items()],
            set=set,
        )
        if shard is not None and executor is not None:
            raise TypeError("simulate: give shard= (one part) or executor= (all parts), not both")
        report = callback(progress, "Monte Carlo")
        if report is not None and (shard is not None or executor is not None):
            raise TypeError("simulate: progress= reports a local, unsplit run")
        if shard is not None:
            index, count = (int(k) for k in shard)
            return MonteCarloShard(self._inner.simulate_shard(index, count, **run))
        if executor is not None:
            count = 8 if shards is None else int(shards)
            if count < 1:
                raise ValueError("shards must be at least 1")
            futures = [executor.submit(_simulate_shard, self, run, k, count) for k in range(count)]
            from ._merge import merge

            return merge([f.result() for f in futures], strict=strict)
        if shards is not None:
            raise TypeError("simulate: shards= is the split of executor= runs; give executor=")
        text, flags, notes = self._inner.simulate(**run, progress=report)
        mc = MonteCarlo._from_json(text, flags, notes)
        mc._judge(bool(strict))
        return mc

    def __repr__(self) -> str:
        return repr(self._inner)


def _simulate_shard(model: Model, run: Dict[str, Any], index: int, count: int) -> "MonteCarloShard":
    """One part of a split run, for an executor's worker (a module-level function pickles)."""
    return MonteCarloShard(model._inner.simulate_shard(index, count, **run))


def _from_state(text: str, path: Optional[str]) -> Model:
    """A pickled :class:`Model` back: parsed from its text, named by its path."""
    return Model(_fpsolve._Model.from_text(text, path))


def _warn_shortfall(solution: Solution, tol: Optional[float]) -> None:
    """A grid tolerance not reached is said, not silent: the solution is the best solve."""
    if tol is None:
        return
    outcome = solution.report.get("tolerance") or {}
    if not outcome.get("reached", True):
        why = (outcome.get("shortfall") or {}).get("kind", "not reached")
        warnings.warn(
            f"the grid did not reach the L1 tolerance {tol:.1e}: achieved "
            f"{outcome.get('achieved'):.1e} ({why})",
            FpsolveWarning,
            stacklevel=3,
        )
