"""fpsolve.Passage: first passage out of a safe set (``Model.reliability``, alias
``Model.passage``), as ``fpsolve reliability`` computes it, with NumPy arrays."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _fpsolve
from ._warnings import FpsolveWarning


def _num(v: Any) -> float:
    """A number of the library's JSON (null, a number without a finite value, is NaN)."""
    return math.nan if v is None else float(v)


def _arr(values: Sequence[Any]) -> np.ndarray:
    return np.array([_num(v) for v in values], dtype=np.float64)


def _pair(d: Optional[Mapping[str, Any]]) -> Optional[Tuple[float, float]]:
    return None if d is None else (_num(d["value"]), _num(d["stderr"]))


@dataclass(frozen=True)
class PassageMonteCarlo:
    """The Monte Carlo half of :meth:`Model.reliability` (``method`` with ``"mc"``): the
    numbers ``fpsolve reliability`` writes to ``summary.json``'s ``mc``, ``reliability.csv``'s
    ``R_mc`` columns and ``first_passage_pdf.csv``.

    Attributes
    ----------
    paths, dt, horizon, seed : int, float, float, int
        The run's settings (``horizon``: paths still inside then are censored).
    censored : int
        Paths still inside at the horizon; ``censored_fraction`` is ``censored / paths``.
    censored_fraction : float
        The censored paths' share.
    blowups : int
        Paths whose state stopped being finite (left out of every statistic).
    mean : (float, float) or None
        The mean first-passage time and its standard error; None when some path was censored
        (then see ``mean_lower_bound``).
    variance : (float, float) or None
        The variance of T and its standard error; None when some path was censored.
    mean_lower_bound : (float, float)
        The mean of min(T, horizon) and its standard error: the mean itself when nothing was
        censored, else a lower bound on it.
    bias : (float, float)
        The time-step bias of the mean (the dt run minus the 2·dt run) and its standard error.
    bias_paths : int
        Paths run again at 2·dt for ``bias``.
    times : numpy.ndarray
        The times of R(t) (the grid's output times when the grid ran, else ``times=`` or 101
        from 0 to the horizon).
    reliability : numpy.ndarray
        R(t) = P(T > t), the fraction of paths still inside at each time.
    reliability_lo, reliability_hi : numpy.ndarray
        The 95 % band of R (Wilson's interval).
    pdf_t_mid : numpy.ndarray
        The centres of the bins of the first-passage-time histogram: bin k is
        (``times[k]``, ``times[k + 1]``] (``first_passage_pdf.csv``'s ``t_mid``; one fewer
        than ``times``, empty for fewer than two times).
    pdf_binned : numpy.ndarray
        The first-passage-time density in each bin: the fraction of paths leaving in it over
        its width (censored paths never count as exits; NaN for a bin of no width).
    pdf_binned_stderr : numpy.ndarray
        Its binomial standard errors.
    """

    paths: int
    dt: float
    horizon: float
    seed: int
    censored: int
    censored_fraction: float
    blowups: int
    mean: Optional[Tuple[float, float]]
    variance: Optional[Tuple[float, float]]
    mean_lower_bound: Tuple[float, float]
    bias: Tuple[float, float]
    bias_paths: int
    times: np.ndarray
    reliability: np.ndarray
    reliability_lo: np.ndarray
    reliability_hi: np.ndarray
    pdf_t_mid: np.ndarray
    pdf_binned: np.ndarray
    pdf_binned_stderr: np.ndarray

    @classmethod
    def _from_dict(cls, d: Mapping[str, Any]) -> "PassageMonteCarlo":
        lower = _pair(d["mean_lower_bound"])
        assert lower is not None
        times = _arr(d["times"])
        return cls(
            paths=int(d["paths"]),
            dt=_num(d["dt"]),
            horizon=_num(d["horizon"]),
            seed=int(d["seed"]),
            censored=int(d["censored"]),
            censored_fraction=_num(d["censored_fraction"]),
            blowups=int(d["blowups"]),
            mean=_pair(d.get("mean")),
            variance=_pair(d.get("variance")),
            mean_lower_bound=lower,
            bias=(_num(d["bias"]["value"]), _num(d["bias"]["stderr"])),
            bias_paths=int(d["bias"]["paths"]),
            times=times,
            reliability=_arr(d["reliability"]),
            reliability_lo=_arr(d["reliability_lo"]),
            reliability_hi=_arr(d["reliability_hi"]),
            # As the library computes the centres, (t_lo + t_hi) / 2: the same bits.
            pdf_t_mid=(times[:-1] + times[1:]) / 2.0,
            pdf_binned=_arr(d["pdf_binned"]),
            pdf_binned_stderr=_arr(d["pdf_binned_stderr"]),
        )


class Passage:
    """The result of :meth:`Model.reliability` (alias :meth:`Model.passage`): first passage
    out of the safe set on the grid and, with ``method="grid,mc"`` or ``"mc"``, by Monte
    Carlo. The numbers are the ones ``fpsolve reliability`` writes with the same arguments,
    to the bit.

    Grid numbers (None, arrays None, when the grid did not run):

    * ``mean_at_start``, ``second_at_start``: E[T] and E[T²] from the start;
      ``mean_from_start_cell``: E[T] from the start cell (the forward run's start, so that
      ∫R dt equals it up to the horizon's tail, ``integral_of_reliability``);
    * ``mean_stationary``, ``second_stationary``: from the stationary density restricted to
      the safe set; ``safe_mass``: that set's stationary probability;
    * ``integral_of_reliability``: ∫R dt over the output times (None without them);
    * ``reliability`` (R(t) = P(T > t)) and ``pdf`` (the first-passage-time density) at
      ``times``;
    * ``errors``: their estimated discretisation errors from a solve on half the cells (a
      dict: ``mean_at_start``, ``second_at_start``, ``mean_stationary``,
      ``second_stationary``, ``reliability`` (an array over ``times``), ``rate``), or None;
    * ``decay``: the slowest decay, R(t) ≈ A e^{−λt}, as a dict: ``status`` (``"found"``,
      then ``rate`` λ, ``amplitude`` A, ``rate_backward``, ``mean_from_quasi_stationary``,
      ``iterations``, ``residuals``; or ``"not_found"`` with ``reason``; or
      ``"not_computed"`` with ``mean_only``);
    * ``quasi_stationary``: ``{state: (x, p)}``, the quasi-stationary density's marginals on
      the cell centres (empty when the decay was not found).

    ``mc`` is the :class:`PassageMonteCarlo` (None without it); ``grid_vs_mc_se`` is (Monte
    Carlo's mean − the grid's) / Monte Carlo's standard error, NaN when paths were censored,
    None without both methods; ``method_distances`` is ``summary.json``'s dict of the same
    name (None without both): for the mean from the start (``mean_at_start``, None when paths
    were censored) and R(t) at each time (``reliability``, a list), |grid − MC| / (MC's
    standard error + the grid's stated error), each ``flagged`` when more than
    ``flag_above_se`` (3) standard errors plus the grid's stated error apart, with the
    ``worst``.

    Stationary statistics beside the first passage (with the grid, for a model with a
    stationary density; ``report["stationary"]`` says how they were computed or why not):

    * ``crossings``: ``{quantity: {column: array}}``, the columns of ``crossings_<q>.csv``
      (``u``, the levels; ``grid`` and ``grid_error``, the mean up-crossing rate ν⁺(u) by
      Rice's formula and its error bound, NaN where none is stated; with Monte Carlo ``mc``,
      ``mc_se``, ``mc_bias``, the counted rate, its standard error and bias);
    * ``impacts``: the impact statistics at each wall, a list of dicts (``method``
      ``"grid"`` or ``"mc"``, ``state``, ``at``, ``rate``, ``mean_speed``, ``mean_power``,
      the grid's ``*_error``, Monte Carlo's ``stderr``), ``summary.json``'s ``impacts``.

    ``scope`` is ``"full"``, or ``"mean_times"`` with ``mean_only=True``: then only the mean
    times were computed (and Monte Carlo's mean and variance): ``times``, ``reliability`` and
    ``pdf`` are empty, ``decay`` is ``{"status": "not_computed"}``, ``crossings`` and
    ``impacts`` are empty, and ``not_computed`` lists each part left out with why, as
    ``summary.json`` does (``[{"what": "reliability", "why": "mean_times_only"}, ...]``;
    empty for a full run).

    ``report`` is ``summary.json`` as a dict (the library's serde form; ``command`` is
    ``"fpsolve.Model.reliability"``), and ``warnings`` the warnings the command line prints
    (each also raised as a :class:`FpsolveWarning`): a number (the mean time, R(t) at a time)
    flagged in ``method_distances``, paths that blew up, a stationary Monte Carlo without a
    usable result.
    """

    __slots__ = (
        "safe",
        "start",
        "times",
        "mean_at_start",
        "second_at_start",
        "mean_from_start_cell",
        "mean_stationary",
        "second_stationary",
        "safe_mass",
        "integral_of_reliability",
        "scope",
        "not_computed",
        "reliability",
        "pdf",
        "errors",
        "decay",
        "quasi_stationary",
        "mc",
        "grid_vs_mc_se",
        "method_distances",
        "crossings",
        "impacts",
        "report",
        "warnings",
    )

    def __init__(
        self,
        text: str,
        marginals: List[Tuple[str, List[float], List[float]]],
        crossings: List[Tuple[str, str]],
        notes: List[str],
    ):
        report = json.loads(text)
        self.report: Dict[str, Any] = report
        self.safe: str = report["safe"]
        self.start: Tuple[float, float] = (_num(report["start"][0]), _num(report["start"][1]))
        g = report.get("grid")
        m = report.get("mc")
        self.mc: Optional[PassageMonteCarlo] = None if m is None else PassageMonteCarlo._from_dict(m)
        scalar = lambda k: None if g is None else _num(g[k])  # noqa: E731
        self.mean_at_start: Optional[float] = scalar("mean_at_start")
        self.second_at_start: Optional[float] = scalar("second_at_start")
        self.mean_from_start_cell: Optional[float] = scalar("mean_from_start_cell")
        self.mean_stationary: Optional[float] = scalar("mean_stationary")
        self.second_stationary: Optional[float] = scalar("second_stationary")
        self.safe_mass: Optional[float] = scalar("safe_mass")
        # None without output times (``mean_only``), as the library's null.
        self.integral_of_reliability: Optional[float] = (
            None if g is None or g["integral_of_reliability"] is None else _num(g["integral_of_reliability"])
        )
        self.scope: str = report["scope"]
        self.not_computed: List[Dict[str, str]] = list(report.get("not_computed", []))
        if g is not None:
            self.times: np.ndarray = _arr(g["times"])
        elif self.mc is not None:
            self.times = self.mc.times
        else:
            self.times = np.zeros(0)
        self.reliability: Optional[np.ndarray] = None if g is None else _arr(g["reliability"])
        self.pdf: Optional[np.ndarray] = None if g is None else _arr(g["pdf"])
        errors = None if g is None else g.get("errors")
        if errors is not None:
            errors = {
                k: (_arr(v) if k == "reliability" else (None if v is None else _num(v)))
                for k, v in errors.items()
            }
        self.errors: Optional[Dict[str, Any]] = errors
        self.decay: Optional[Dict[str, Any]] = None if g is None else g["decay"]
        self.quasi_stationary: Dict[str, Tuple[np.ndarray, np.ndarray]] = {
            name: (np.array(x, dtype=np.float64), np.array(p, dtype=np.float64))
            for name, x, p in marginals
        }
        d = report.get("grid_vs_mc_se", ...)
        self.grid_vs_mc_se: Optional[float] = None if d is ... else _num(d)
        self.method_distances: Optional[Dict[str, Any]] = report.get("method_distances")
        self.crossings: Dict[str, Dict[str, np.ndarray]] = {q: _table(t) for q, t in crossings}
        self.impacts: List[Dict[str, Any]] = list(report.get("impacts", []))
        self.warnings: List[str] = list(notes)

    def __repr__(self) -> str:
        parts = [f"safe={self.safe!r}", f"start={self.start}"]
        if self.mean_at_start is not None:
            parts.append(f"mean_at_start={self.mean_at_start:.6g}")
        if self.mc is not None:
            if self.mc.mean is not None:
                parts.append(f"mc_mean={self.mc.mean[0]:.6g}±{self.mc.mean[1]:.2g}")
            else:
                parts.append(f"mc_mean>={self.mc.mean_lower_bound[0]:.6g} (censored)")
        return f"<fpsolve.Passage {' '.join(parts)}>"


def _table(text: str) -> Dict[str, np.ndarray]:
    """A CSV table of the library (a header, numbers, empty fields for no value) as columns."""
    lines = text.splitlines()
    header = lines[0].split(",")
    rows = [[math.nan if f == "" else float(f) for f in line.split(",")] for line in lines[1:]]
    values = np.array(rows, dtype=np.float64).reshape(len(rows), len(header))
    return {name: values[:, k].copy() for k, name in enumerate(header)}


def _times(times: Union[None, str, Sequence[float], np.ndarray]) -> Union[None, str, List[float]]:
    if times is None or isinstance(times, str):
        return times
    return [float(t) for t in np.asarray(times, dtype=np.float64).ravel()]


def _start(start: Union[None, str, Sequence[float]]) -> Union[None, str, Tuple[float, float]]:
    if start is None or isinstance(start, str):
        return start
    values = list(start)
    if len(values) != 2:
        raise ValueError(f"start: expected (x, v), two numbers, got {len(values)} values")
    return (float(values[0]), float(values[1]))


def _passage_cells(cells: Union[None, str, Sequence[int]]) -> Optional[Tuple[int, int]]:
    if cells is None:
        return None
    if isinstance(cells, str):
        parts = cells.split(",")
        try:
            nx, nv = (int(p.strip()) for p in parts)
        except ValueError:
            raise ValueError(f"cells: `{cells}` is not NX,NV (two whole numbers, e.g. 140,280)") from None
        return (nx, nv)
    values = list(cells)
    if len(values) != 2:
        raise ValueError(f"cells: expected (nx, nv), got {len(values)} values")
    return (int(values[0]), int(values[1]))


def run(
    model: Any,
    safe: Optional[str],
    start: Any,
    times: Any,
    cells: Any,
    method: Union[str, Sequence[str]],
    paths: int,
    dt: float,
    horizon: Optional[float],
    seed: int,
    threads: Optional[int],
    set: Dict[str, Any],
    domain: Optional[str] = None,
    mean_only: bool = False,
) -> Passage:
    """Runs ``Model.reliability`` (arguments converted, then checked by the native module in the
    command line's order) and warns the command line's warnings."""
    if isinstance(method, str):
        methods: Union[str, List[str]] = method
    else:
        methods = [str(m) for m in method]
    if isinstance(paths, bool) or not hasattr(paths, "__index__"):
        raise TypeError(f"paths: expected an int, got {type(paths).__name__}")
    if not isinstance(mean_only, (bool, np.bool_)):
        raise TypeError(f"mean_only: expected a bool, got {type(mean_only).__name__}")
    text, marginals, crossings, notes = _fpsolve.passage(
        model._inner,
        safe,
        _start(start),
        _times(times),
        _passage_cells(cells),
        methods,
        int(paths.__index__()),
        float(dt),
        None if horizon is None else float(horizon),
        seed,
        None if threads is None else int(threads),
        set,
        domain,
        bool(mean_only),
    )
    result = Passage(text, marginals, crossings, notes)
    for note in notes:
        warnings.warn(note, FpsolveWarning, stacklevel=3)
    return result
