"""fpsolve.Transient: the density as it evolves (``Model.transient``), as ``fpsolve transient``
computes it, with NumPy arrays."""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _fpsolve
from ._passage import _passage_cells, _times
from ._warnings import FpsolveWarning

_MOMENTS = ("mean", "variance", "kurtosis")


@dataclass(frozen=True)
class TransientHistory:
    """One method's history in a :class:`Transient` (``Transient.grid`` or
    ``Transient.mc``): the moments of each quantity and the marginal PDFs of each state at
    every output time ``Transient.t``, the numbers of ``fpsolve transient``'s
    ``moments_vs_t.csv`` and ``pdf_<state>_t.csv``.

    Attributes
    ----------
    method : str
        ``"grid"`` or ``"mc"``.
    quantities : tuple of str
        The quantities with moments: the states and the observables on the grid, the states
        by Monte Carlo.
    mean, variance, kurtosis : dict of str to numpy.ndarray
        Each quantity's moment at every output time (shape ``(len(t),)``). A moment that does
        not exist (Monte Carlo's kurtosis at a point start, whose variance is 0) is NaN.
    mean_se, variance_se, kurtosis_se : dict of str to numpy.ndarray or None
        Monte Carlo's standard errors of the moments (None on the grid).
    mean_err, variance_err, kurtosis_err : dict of str to numpy.ndarray or None
        The grid's estimated errors of the moments, from the run on half the cells (None by
        Monte Carlo, or when the grid made no estimate).
    pdf : dict of str to (numpy.ndarray, numpy.ndarray)
        Each state's marginal as ``(x, p)``: ``x`` the cell centres (the grid's cells; Monte
        Carlo's bins are the same cells), ``p[k, i]`` the density at time ``t[k]`` in cell
        ``i`` (the grid's cell average, Monte Carlo's histogram).
    pdf_se : dict of str to numpy.ndarray or None
        Monte Carlo's standard error of each ``p[k, i]`` (None on the grid).
    """

    method: str
    quantities: Tuple[str, ...]
    mean: Dict[str, np.ndarray]
    variance: Dict[str, np.ndarray]
    kurtosis: Dict[str, np.ndarray]
    mean_se: Optional[Dict[str, np.ndarray]]
    variance_se: Optional[Dict[str, np.ndarray]]
    kurtosis_se: Optional[Dict[str, np.ndarray]]
    mean_err: Optional[Dict[str, np.ndarray]]
    variance_err: Optional[Dict[str, np.ndarray]]
    kurtosis_err: Optional[Dict[str, np.ndarray]]
    pdf: Dict[str, Tuple[np.ndarray, np.ndarray]]
    pdf_se: Optional[Dict[str, np.ndarray]]

    @classmethod
    def _of(
        cls,
        method: str,
        quantities: Sequence[str],
        times: int,
        moments: Mapping[str, np.ndarray],
        pdfs: Mapping[str, Mapping[str, np.ndarray]],
    ) -> "TransientHistory":
        mc = method == "mc"
        suffix = "_mc" if mc else ""

        def column(q: str, m: str, tail: str) -> Optional[np.ndarray]:
            return moments.get(f"{q}_{m}{suffix}{tail}")

        def table(m: str, tail: str) -> Optional[Dict[str, np.ndarray]]:
            found = {q: column(q, m, tail) for q in quantities}
            if any(v is None for v in found.values()):
                return None
            return found  # type: ignore[return-value]

        def required(m: str) -> Dict[str, np.ndarray]:
            found = table(m, "")
            assert found is not None, f"{method}: no {m} columns"
            return found

        pdf = {}
        for state, cols in pdfs.items():
            x_all, p_all = cols["x"], cols[method]
            n = x_all.size // times if times else 0
            pdf[state] = (x_all[:n].copy(), p_all.reshape(times, n))
        pdf_se = None
        if mc:
            pdf_se = {}
            for state, cols in pdfs.items():
                pdf_se[state] = cols["mc_se"].reshape(pdf[state][1].shape)
        return cls(
            method=method,
            quantities=tuple(quantities),
            mean=required("mean"),
            variance=required("variance"),
            kurtosis=required("kurtosis"),
            mean_se=table("mean", "_se") if mc else None,
            variance_se=table("variance", "_se") if mc else None,
            kurtosis_se=table("kurtosis", "_se") if mc else None,
            mean_err=None if mc else table("mean", "_err"),
            variance_err=None if mc else table("variance", "_err"),
            kurtosis_err=None if mc else table("kurtosis", "_err"),
            pdf=pdf,
            pdf_se=pdf_se,
        )

    def __repr__(self) -> str:
        return f"<fpsolve.TransientHistory {self.method}: {', '.join(self.quantities)}>"


class Transient:
    """The result of :meth:`Model.transient`: the density as it evolves from the start, on
    the grid and, with ``method="grid,mc"`` or ``"mc"``, by Monte Carlo. The numbers are the
    ones ``fpsolve transient`` writes with the same arguments, to the bit.

    Attributes
    ----------
    t : numpy.ndarray
        The output times.
    states : tuple of str
        The two states (each has a marginal PDF).
    method : str
        ``"grid"``, ``"mc"`` or ``"grid,mc"``.
    initial : dict
        The start as ``summary.json`` writes it: ``{"kind": "rest"}``, ``{"kind": "point",
        "at": [x, v]}`` or ``{"kind": "gaussian", "mean": [...], "covariance": [[...], [...]]}``.
    grid, mc : TransientHistory or None
        Each method's moments and PDFs (None when it did not run).
    report : dict
        ``summary.json`` as a dict, opening with ``provenance`` (the command line's keys but
        ``command``); a number without a finite value is None there and listed under
        ``undefined``.
    warnings : list of str
        The warnings the command line prints (each also raised as a :class:`FpsolveWarning`):
        grid variances or marginals the cells do not resolve, a Monte Carlo ensemble stuck
        at its start.
    flags : list of str
        Those of ``warnings`` for which the command line exits with status 1: the numbers are
        not the law's.
    """

    __slots__ = ("t", "states", "method", "initial", "grid", "mc", "report", "warnings", "flags", "_native")

    def __init__(self, native: Any) -> None:
        self._native = native
        self.report: Dict[str, Any] = json.loads(native.summary_json())
        moments = {name: values for name, values in native.moments()}
        self.t: np.ndarray = moments["t"]
        quantities = list(native.quantities())
        self.states: Tuple[str, str] = (quantities[0], quantities[1])
        pdfs = {state: {name: values for name, values in native.pdf(axis)} for axis, state in enumerate(self.states)}
        self.method: str = self.report["method"]
        self.initial: Dict[str, Any] = self.report["initial"]
        methods = self.method.split(",")
        self.grid: Optional[TransientHistory] = (
            TransientHistory._of("grid", quantities, len(self.t), moments, pdfs) if "grid" in methods else None
        )
        self.mc: Optional[TransientHistory] = (
            TransientHistory._of("mc", self.states, len(self.t), moments, pdfs) if "mc" in methods else None
        )
        notes = native.warnings()
        self.warnings: List[str] = [text for text, _ in notes]
        self.flags: List[str] = [text for text, flags in notes if flags]

    def write(self, directory: Union[str, "os.PathLike[str]"], figures: bool = True) -> str:
        """Writes the files ``fpsolve transient --out DIRECTORY`` writes, the same way
        (staged, then moved into place whole): ``moments_vs_t.csv``, ``pdf_<state>_t.csv``,
        the figures ``sigma_vs_t`` and ``pdf_<state>_at_t<T>`` (png and svg) and
        ``summary.json`` (the text of ``report``).

        Parameters
        ----------
        directory : str or os.PathLike
            The output directory (replaced as a whole; one holding foreign files is refused).
        figures : bool
            Draw the figures beside the CSV files.

        Returns
        -------
        str
            The directory written.

        Raises
        ------
        JobError
            The directory cannot be used or a file cannot be written.
        """
        return str(self._native.write(os.fspath(directory), bool(figures)))

    def __repr__(self) -> str:
        return f"<fpsolve.Transient {self.method}: {len(self.t)} times from {self.t[0]:g} to {self.t[-1]:g}>"


def _method(method: Union[str, Sequence[str]]) -> str:
    if isinstance(method, str):
        return method
    return ",".join(str(m) for m in method)


def run(
    model: Any,
    times: Any,
    cells: Any,
    domain: Optional[str],
    tol: Optional[float],
    initial: Optional[str],
    method: Union[str, Sequence[str]],
    trajectories: int,
    dt: float,
    seed: int,
    threads: Optional[int],
    set: Dict[str, Any],
    period: Optional[float] = None,
) -> Transient:
    """Runs ``Model.transient`` (arguments converted, then checked by the native module in
    the command line's order) and warns the command line's warnings."""

    if isinstance(trajectories, bool) or not hasattr(trajectories, "__index__"):
        raise TypeError(f"trajectories: expected an int, got {type(trajectories).__name__}")
    native = _fpsolve.transient(
        model._inner,
        _times(times),
        _passage_cells(cells),
        domain,
        None if tol is None else float(tol),
        initial,
        _method(method),
        int(trajectories.__index__()),
        float(dt),
        seed,
        None if threads is None else int(threads),
        set,
        period,
    )
    result = Transient(native)
    for note in result.warnings:
        warnings.warn(note, FpsolveWarning, stacklevel=3)
    return result
