"""fpsolve.Model: a validated model and the calls that solve and simulate it."""

from __future__ import annotations

import concurrent.futures
import os
import warnings
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _fpsolve
from ._montecarlo import MonteCarlo, MonteCarloShard
from ._passage import Passage
from ._passage import run as _passage_run
from ._progress import ProgressArg, callback
from ._solution import Solution
from ._transient import Transient
from ._transient import run as _transient_run
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

        Parameters
        ----------
        path : str or os.PathLike
            The model file (``.sde``).

        Returns
        -------
        Model
            The model, validated (every expression parsed, every name declared).

        Raises
        ------
        ModelFileNotFoundError
            The file does not exist (also a ``FileNotFoundError``).
        ModelError
            The file cannot be read or is not a valid model: ``.path``, ``.line``,
            ``.column``, ``.message``, and the command line's file:line:col message.

        Examples
        --------
        >>> model = fpsolve.Model.load("models/duffing.sde")  # doctest: +SKIP
        >>> model.states                                      # doctest: +SKIP
        ('z', 'v')
        """
        return cls(_fpsolve._Model.load(os.fspath(path)))

    @classmethod
    def from_text(cls, text: str, path: Optional[str] = None) -> "Model":
        """Parses and validates model text.

        Parameters
        ----------
        text : str
            The model, as a model file holds it.
        path : str, optional
            Only names the text in error messages (and ``Model.path``).

        Returns
        -------
        Model
            The model, validated.

        Raises
        ------
        ModelError
            The text is not a valid model (``.line``, ``.column``, ``.message``).
        """
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
        """The parameters' values with overrides applied.

        Parameters
        ----------
        params : mapping of str to number or str, optional
            Overrides as a dict (for names that are not identifiers or clash with a keyword).
        **set : number or str
            Overrides by keyword: a number (NumPy scalars too) or an expression string.

        Returns
        -------
        dict of str to float
            Every parameter's value, in declaration order.

        Raises
        ------
        ParameterError
            An unknown parameter, a value that is not a real number, or a name given twice.
        """
        return dict(self._inner.parameters(_params(params, set)))

    def check(self, params: Optional[Mapping[str, Value]] = None, **set: Value) -> str:
        """What ``fpsolve check`` prints.

        Parameters
        ----------
        params : mapping of str to number or str, optional
            Overrides as a dict.
        **set : number or str
            Overrides by keyword.

        Returns
        -------
        str
            The model, its parameter values and its derived Fokker-Planck operator (and, for
            a reflecting barrier, the Zhuravlev transform EPC solves).

        Raises
        ------
        ParameterError
            A bad override.
        ModelError
            The operator cannot be derived for these values.
        """
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
        """Solves the stationary Fokker-Planck equation.

        Parameters
        ----------
        method : {"epc", "epc-impact", "grid"}
            ``"epc"``: the paper's exponential-polynomial closure (the impact as a delta
            term); ``"epc-impact"``: EPC with the exact impact condition; ``"grid"``: finite
            volumes with an estimate of their own error.
        degree : int
            The EPC degree (even, 2 to 12; every even degree up to it is solved in turn).
            Not used by the grid.
        cells : (int, int), optional
            The grid's cells ``(nx, nv)``. Without ``cells`` or ``tol`` the grid chooses its
            cells for an estimated L1 error of at most 1e-3, as the command line does.
        params : mapping of str to number or str, optional
            Overrides as a dict (for names that are not identifiers or clash with a keyword
            of this call); it and ``**set`` together may not name a parameter twice.
        domain : str or mapping of str to (float, float), optional
            Fixes the grid's box instead of sizing it from the density:
            ``{"x": (-8, 8), "v": (-10, 10)}`` or the command line's text
            ``"x=-8:8,v=-10:10"`` (the model's state names; the velocity's range is made
            symmetric about 0; a reflecting wall's side must end on the wall). A box that cuts
            the density is flagged in the report (``grid.report.edges``) and its estimate
            grows.
        tol : float, optional
            Asks the grid for an accuracy instead of cells (the command line's ``--tol``): it
            chooses and refines its cells until its estimated L1 error of both marginals is at
            most ``tol`` (0 < tol <= 0.5). ``report["tolerance"]`` holds ``asked``,
            ``achieved``, ``reached``, ``shortfall`` and the ``solves`` made (cells,
            estimate); not reached, the best solve is returned and a :class:`FpsolveWarning`
            says so.
        **set : number or str
            Parameter overrides by keyword.

        Returns
        -------
        Solution
            The density, asked by state or observable name.

        Raises
        ------
        NoConvergenceError, NotNormalisableError, GridSolveError, NotApplicableError
            The method failed or does not apply (all :class:`SolveError`, with the failure's
            data).
        ParameterError
            A bad override.
        ValueError
            A malformed box, or a box given to another method than the grid; a bad ``tol``,
            one with ``cells`` or with another method.
        KeyboardInterrupt
            Ctrl-C: the call returns within 0.1 s; a solve in progress finishes unseen in the
            background and is dropped (it keeps fpsolve's worker threads until then: the
            next call waits for them).

        Notes
        -----
        Releases the GIL.

        Examples
        --------
        >>> sol = model.solve("grid", cells=(100, 200))  # doctest: +SKIP
        >>> sol.moments("z").variance                    # doctest: +SKIP
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
        levels: Optional[Mapping[str, Sequence[float]]] = None,
        impact_speeds: Optional[Tuple[float, float, int]] = None,
        strict: bool = False,
        params: Optional[Mapping[str, Value]] = None,
        shard: Optional[Tuple[int, int]] = None,
        executor: Optional["concurrent.futures.Executor"] = None,
        shards: Optional[int] = None,
        progress: ProgressArg = None,
        **set: Value,
    ) -> Union[MonteCarlo, MonteCarloShard]:
        """Monte Carlo simulation of the model: histograms of every state and observable with
        standard errors, judged for stationarity, blow-ups and time-step bias.

        Parameters
        ----------
        samples : int
            Recorded samples in all, rounded up to whole trajectories (as ``fpsolve simulate
            --samples``).
        seed : int, None, numpy.random.Generator or numpy.random.SeedSequence
            The command line's ``--seed`` (default 1, as there: the same seed gives the same
            bits as ``fpsolve simulate``); ``None`` draws a fresh one from the operating
            system; a ``Generator`` or ``SeedSequence`` gives one of its draws (SPEC 7). The
            seed used is ``mc.report["settings"]["seed"]``.
        threads : int, optional
            Worker threads (default: the cores available). The result does not depend on it.
        dt : float, optional
            The time step (default 0.01, as ``--dt``); the time-step bias is estimated from
            batches rerun at 2·dt.
        spacing : float, optional
            Time between recorded samples of a trajectory (default 0.1).
        trajectories : int, optional
            Independent trajectories (default 4096, rounded up to whole SIMD lanes).
        bins : int, optional
            Bins of each histogram whose grid is not in ``grids`` (default 100).
        grids : mapping of str to (float, float, int), optional
            A quantity's histogram grid ``(lo, hi, bins)``; the others are chosen from a
            pilot run.
        levels : mapping of str to sequence of float, optional
            Levels of a state or observable (finite, ascending) whose mean up-crossing
            rates the run counts: ``mc.crossings[name]``.
        impact_speeds : (float, float, int), optional
            The grid ``(lo, hi, bins)`` of the impact-speed histogram at each wall
            (``mc.walls[k].speed_density``); the impact rate, mean speed and dissipated power
            are recorded whenever the model has a wall.
        strict : bool
            Raise :class:`MonteCarloError` for a flagged run instead of warning.
        params : mapping of str to number or str, optional
            Overrides as a dict.
        shard : (int, int), optional
            ``(k, n)``: run only the ``k``-th (from 0) of ``n`` parts of the run's statistics
            batches and return a :class:`MonteCarloShard` (plain data: it pickles;
            :func:`fpsolve.merge` joins the ``n`` parts into the unsplit run, bit for bit).
        executor : concurrent.futures.Executor, optional
            Runs ``shards`` parts on it (a ``ProcessPoolExecutor``,
            ``distributed.Client.get_executor()``, Ray's) and merges them: the same bits as
            the local run.
        shards : int, optional
            The parts of an ``executor`` run (default 8, at most the run's batches).
        progress : bool or callable, optional
            ``True`` prints the batches done to stderr as the run goes (a tqdm bar when tqdm
            is installed); a callable ``f(done, total)`` is called instead, from the calling
            thread (an exception it raises stops the run). Local runs only.
        **set : number or str
            Parameter overrides by keyword.

        Returns
        -------
        MonteCarlo or MonteCarloShard
            The run (a :class:`MonteCarloShard` with ``shard``).

        Raises
        ------
        MonteCarloError
            The run was refused or failed; or, with ``strict=True``, it is flagged.
        KeyboardInterrupt
            Ctrl-C: the run stops at its next batch.

        Warns
        -----
        MonteCarloWarning
            The run finished but is flagged (too many blow-ups, not stationary, numbers
            without a finite value: what ``fpsolve simulate`` exits 1 for); the reasons are
            in the result's ``flags``.
        FpsolveWarning
            The run's other warnings (a resolved time-step bias above the statistical
            error, a few blow-ups), also kept in ``warnings``.

        Notes
        -----
        Releases the GIL.
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
            levels=[(name, [float(u) for u in us]) for name, us in (levels or {}).items()],
            impact_speeds=None
            if impact_speeds is None
            else (float(impact_speeds[0]), float(impact_speeds[1]), int(impact_speeds[2])),
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

    def reliability(
        self,
        safe: Optional[str] = None,
        start: Union[None, str, Sequence[float]] = None,
        times: Union[None, str, Sequence[float], "np.ndarray"] = None,
        cells: Union[None, str, Sequence[int]] = None,
        method: Union[str, Sequence[str]] = "grid",
        paths: int = 10_000,
        dt: float = 0.01,
        horizon: Optional[float] = None,
        seed: Union[int, None, "np.random.Generator", "np.random.SeedSequence"] = 1,
        threads: Optional[int] = None,
        params: Optional[Mapping[str, Value]] = None,
        domain: Union[None, str, Mapping[str, Sequence[float]]] = None,
        mean_only: bool = False,
        **set: Value,
    ) -> Passage:
        """Reliability: first passage out of the safe set, as ``fpsolve reliability``: the
        mean first-passage time and its second moment (from the start and from the stationary
        density in the set), the reliability R(t) = P(T > t) and the first-passage-time
        density, the slowest decay and the quasi-stationary density on the grid; and by Monte
        Carlo with ``"mc"`` in ``method`` (R(t) with its 95 % band, the first-passage-time
        density as a histogram on the output times), the distances between the two; with the
        grid, for a model with a stationary density, the stationary mean up-crossing rates
        and the impact statistics at each wall (Monte Carlo's counts beside them with
        ``"mc"``). The same checks, defaults and numbers (to the bit) as the command line
        with the same arguments. ``Model.passage`` is the same method under its former name.

        Parameters
        ----------
        safe : str, optional
            The safe set, as ``--safe`` (``"abs(z) < 2.5"``, ``"-2 < z < 3"``): any expression
            of states, observables and parameters bounded by ``<``; default the model's
            ``safe`` line.
        start : (float, float) or str, optional
            The start ``(x, v)`` (or the text ``"X,V"``); default rest, (0, 0). It must lie
            inside the safe set.
        times : str or sequence of float, optional
            The output times of R(t): ``"FIRST:LAST:COUNT"`` as ``--times`` (0 <= FIRST <
            LAST, 2 <= COUNT <= 100000, evenly spaced), or the times themselves (finite,
            non-negative, non-decreasing). Default 101 evenly spaced times from 0 to
            ``horizon`` when given, else to 5 of the grid's mean times from the start.
        cells : (int, int) or str, optional
            The grid's cells ``(nx, nv)`` (even, at least 8 per axis); default (200, 400).
        method : str or sequence of str
            ``"grid"`` (default), ``"mc"`` or ``"grid,mc"`` (or a list of them).
        paths : int
            Monte Carlo paths (default 10000).
        dt : float
            Monte Carlo time step (default 0.01; the bias estimate runs again at 2·dt).
        horizon : float, optional
            Monte Carlo horizon (paths still inside then are censored); default the last of
            ``times``, else 20 times the grid's mean time. Only with ``"mc"``; with ``"mc"``
            alone, ``horizon`` or ``times`` is needed.
        seed : int, None, numpy.random.Generator or numpy.random.SeedSequence
            Monte Carlo seed, as ``--seed`` (default 1); ``None`` draws a fresh one, a
            ``Generator`` or ``SeedSequence`` gives one of its draws.
        threads : int, optional
            Worker threads (default: the cores available). The result does not depend on it.
        params : mapping of str to number or str, optional
            Overrides as a dict.
        domain : str or mapping of str to (float, float), optional
            The grid's box as ``--domain`` (``"x=-1.05:1.05,v=-8:8"``, the model's state
            names or ``x``/``v``; or ``{"x": (-1.05, 1.05), "v": (-8, 8)}``) instead of one
            sized from the stationary density: a model without one (no damping, as the
            randomly accelerated particle) needs it, with the safe set ending inside it
            along the position. Only with the grid; checked before any work.
        mean_only : bool
            Only the mean first-passage times, as ``--mean-only``: E[T] and E[T²] from the
            start and from the stationary density in the set with their estimated errors
            (Monte Carlo's mean and variance with ``"mc"``); no R(t), decay or stationary
            crossing and impact statistics (``scope`` is ``"mean_times"``, ``not_computed``
            lists what was left out and why). Not with ``times``.
        **set : number or str
            Parameter overrides by keyword (``--set``).

        Returns
        -------
        Passage
            The grid's and Monte Carlo's numbers as NumPy arrays and floats (the columns of
            the command line's ``reliability.csv`` and ``first_passage_pdf.csv``), ``report``
            (its ``summary.json`` as a dict) and ``warnings``.

        Raises
        ------
        ValueError
            Bad arguments, checked before any work in the command line's order: a method
            other than grid and mc, no safe set, a start outside it, bad times or cells,
            ``horizon`` without Monte Carlo, Monte Carlo alone without a horizon or times,
            ``mean_only`` with ``times``, a
            negative number of paths, a ``domain`` that does not parse, does not fit the
            model's walls, leaves the start outside or is given without the grid, a model
            without a stationary density without ``domain``; and a safe set holding no
            stationary probability.
        ModelError
            A ``safe`` text that does not parse or does not depend on a state (located in
            the text, shown as ``--safe``), or a safe set whose bounds are not finite or
            empty at these parameters; :class:`ParameterError` for a bad override.
        MonteCarloError
            Monte Carlo settings out of range (too few paths, a bad ``dt`` or ``horizon``:
            ``kind`` ``"bad_setting"``), or a failed run.
        GridSolveError, NotApplicableError
            The grid's solves failed, or the grid does not apply to the model.
        KeyboardInterrupt
            Ctrl-C: the call returns at once; the solve finishes unseen in the background.

        Warns
        -----
        FpsolveWarning
            A number (the mean time, R(t) at a time) by the grid and by Monte Carlo more
            than 3 standard errors plus the grid's estimated error apart;
            Monte Carlo paths blew up; the stationary Monte Carlo gave no usable result (also
            in ``warnings``).

        Notes
        -----
        Releases the GIL.

        Examples
        --------
        >>> p = model.reliability(safe="abs(z) < 2", times="0:50:11", c=1)  # doctest: +SKIP
        >>> p.mean_at_start, p.reliability                                   # doctest: +SKIP
        """
        return _passage_run(
            self,
            safe,
            start,
            times,
            cells,
            method,
            paths,
            dt,
            horizon,
            _seed(seed),
            threads,
            _params(params, set),
            _domain(domain),
            mean_only,
        )

    passage = reliability

    def transient(
        self,
        times: Union[str, Sequence[float], "np.ndarray"],
        cells: Union[None, str, Sequence[int]] = None,
        domain: Union[None, str, Mapping[str, Sequence[float]]] = None,
        tol: Optional[float] = None,
        initial: Optional[str] = None,
        method: Union[str, Sequence[str]] = "grid",
        trajectories: int = 10_000,
        dt: float = 0.01,
        seed: Union[int, None, "np.random.Generator", "np.random.SeedSequence"] = 1,
        threads: Optional[int] = None,
        params: Optional[Mapping[str, Value]] = None,
        period: Optional[float] = None,
        **set: Value,
    ) -> Transient:
        """The density as it evolves from the start, as ``fpsolve transient``: on the grid
        (ESDIRK4 steps on the stationary solver's operator, with error control) and, with
        ``"mc"`` in ``method``, by a Monte Carlo ensemble on the grid's cells as bins; the
        mean, variance and kurtosis of every state (and observable, on the grid) and each
        state's marginal PDF at every output time. The same checks, defaults and numbers (to
        the bit) as the command line with the same arguments.

        Parameters
        ----------
        times : str or sequence of float
            The output times: ``"FIRST:LAST:COUNT"`` as ``--times`` (0 <= FIRST < LAST,
            2 <= COUNT <= 100000, evenly spaced), or the times themselves (finite,
            non-negative, non-decreasing).
        cells : (int, int) or str, optional
            The grid's cells ``(nx, nv)`` (even, at least 8 per axis); Monte Carlo's bins
            without the grid. Default (200, 400).
        domain : str or mapping of str to (float, float), optional
            The box, ``"z=-5:5,v=-5:5"`` as ``--domain`` or ``{"z": (-5, 5), "v": (-5, 5)}``;
            default the stationary solver's. Required for a model whose coefficients depend
            on the time ``t``, and for Monte Carlo alone (the histograms' range).
        tol : float, optional
            The L1 error each grid step may make per unit time, in (0, 1); default 1e-4.
        initial : str, optional
            Where the run starts, overriding the model's ``initial`` line, as ``--initial``:
            ``"rest"``, ``"point z = 1, v = 0"``, ``"gaussian mean z = 0, v = 0 cov 1, 0, 0,
            1"``. Default the model's line, else rest.
        method : str or sequence of str
            ``"grid"`` (default), ``"mc"`` or ``"grid,mc"`` (or a list of them).
        trajectories : int
            Monte Carlo trajectories (default 10000; rounded up to whole batches of 64).
        dt : float
            Monte Carlo's largest time step (default 0.01).
        seed : int, None, numpy.random.Generator or numpy.random.SeedSequence
            Monte Carlo seed, as ``--seed`` (default 1); ``None`` draws a fresh one, a
            ``Generator`` or ``SeedSequence`` gives one of its draws.
        threads : int, optional
            Worker threads (default: the cores available). The result does not depend on it.
        params : mapping of str to number or str, optional
            Overrides as a dict.
        period : float, optional
            As ``--period``: the coefficients' period P, for the periodic steady state
            instead of a history from the start (the grid's by the period map; Monte
            Carlo's, with ``method="grid,mc"`` or ``"mc"``, over the periods after those its
            pilot discards); ``times`` are then phases in [0, P] and ``domain`` is required;
            ``report["periodic"]`` holds the grid's fixed point's outcome (residual, period
            maps), ``report["mc_periodic"]`` Monte Carlo's discarded and recorded periods.
        **set : number or str
            Parameter overrides by keyword (``--set``).

        Returns
        -------
        Transient
            ``t``; ``grid`` and ``mc`` (:class:`TransientHistory`: moment histories, Monte
            Carlo's standard errors, the marginal PDFs as ``(x, p[t_index, x_index])``);
            ``report`` (``summary.json`` as a dict), ``warnings``; ``write(directory)``
            writes the command line's files.

        Raises
        ------
        ValueError
            Bad arguments, checked before any work in the command line's order: the cells, a
            method other than grid and mc, the times, the box (its text, none for a model
            that depends on the time or for Monte Carlo alone), fewer than 1 trajectory, a
            tolerance outside (0, 1), a grid setting, or a start the box does not hold.
        ModelError
            An ``initial`` text that does not parse or names no state (located in the text,
            shown as ``--initial``), or a start not finite at these parameters;
            :class:`ParameterError` for a bad override.
        MonteCarloError
            Monte Carlo refused: a setting out of range (``kind`` ``"bad_setting"``), a start
            beyond a wall (``"start_beyond_wall"``); or a failed run.
        GridSolveError, NotApplicableError
            The grid's time stepping failed, or the grid does not apply to the model.
        KeyboardInterrupt
            Ctrl-C: the call returns at once; the run finishes unseen in the background.

        Warns
        -----
        FpsolveWarning
            Grid variances or marginals the cells do not resolve; a Monte Carlo ensemble
            still at its point start (also in ``warnings``, the last in ``flags``).

        Notes
        -----
        Releases the GIL.

        Examples
        --------
        >>> tr = model.transient("0:20:41", cells=(64, 64), domain="z=-8:8,v=-8:8", c=1)  # doctest: +SKIP
        >>> tr.t, tr.grid.variance["z"]                                                 # doctest: +SKIP
        >>> x, p = tr.grid.pdf["z"]                                                     # doctest: +SKIP
        """
        return _transient_run(
            self,
            times,
            cells,
            _domain(domain),
            tol,
            initial,
            method,
            trajectories,
            dt,
            _seed(seed),
            threads,
            _params(params, set),
            None if period is None else float(period),
        )

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
