"""fpsolve.sweep: a parameter study, every point solved in parallel, results as arrays."""

from __future__ import annotations

import concurrent.futures
import json
import math
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _fpsolve
from ._model import Model
from ._progress import ProgressArg, callback
from ._shard import ShardText

_STATS = ("mean", "variance", "kurtosis")


def _optional(module: str) -> Any:
    """An optional dependency, imported when first needed, with how to get it when missing."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(f"this needs {module}, which is not installed: pip install {module}") from e


class SweepResult:
    """Per point (the Cartesian product of the swept values, the first parameter fastest)
    and per method: the statistics of every quantity, NaN where the point failed.

    ``values[name]`` is the array of a swept parameter over the points; ``converged(method)``
    a bool array; ``stat(method, quantity, "mean")`` (also ``"variance"``, ``"std"``,
    ``"kurtosis"``) a float array; ``failures(method)`` the failed points with their stage
    and message; ``report`` the library's ``SweepResult`` as a dict (``sweep.json``'s
    content).
    """

    __slots__ = ("report", "values", "methods", "quantities", "_points")

    def __init__(self, report: Dict[str, Any]):
        self.report = report
        self._points: List[Dict[str, Any]] = report["points"]
        names: List[str] = report["parameters"]
        coords = np.array([p["values"] for p in self._points], dtype=np.float64)
        self.values = {n: coords[:, k].copy() for k, n in enumerate(names)}
        self.methods = tuple(report["methods"])
        self.quantities = tuple(report["quantities"])

    def __len__(self) -> int:
        return len(self._points)

    @property
    def provenance(self) -> Optional[Dict[str, Any]]:
        """Where the result came from (``sweep.json``'s ``provenance``): fpsolve's version, the
        schema, the command (none from Python), the time (UTC), the worker threads, the
        model's name, file and text. A merged sweep (``fpsolve.merge``, or
        ``sweep(executor=...)``, which merges its parts) states the merge's time, the parts'
        model, and as ``threads`` the threads each part ran with (the most, when they
        differ)."""
        return self.report.get("provenance")

    def _outcome(self, point: Dict[str, Any], method: str) -> Dict[str, Any]:
        for o in point["outcomes"]:
            if o["method"] == method:
                return o
        raise KeyError(f"method {method!r} was not in the sweep (it ran {', '.join(self.methods)})")

    def converged(self, method: str) -> np.ndarray:
        """Where ``method`` solved the point.

        Parameters
        ----------
        method : str
            One of the sweep's ``methods``.

        Returns
        -------
        numpy.ndarray of bool
            One entry per point, in the sweep's order (the first parameter fastest).

        Raises
        ------
        KeyError
            ``method`` was not in the sweep.
        """
        return np.array(
            [self._outcome(p, method)["status"] == "converged" for p in self._points], dtype=bool
        )

    def stat(self, method: str, quantity: str, stat: str = "mean") -> np.ndarray:
        """One statistic of one quantity under one method at every point.

        Parameters
        ----------
        method : str
            One of the sweep's ``methods``.
        quantity : str
            A state or observable of the model.
        stat : {"mean", "variance", "std", "kurtosis"}
            The statistic.

        Returns
        -------
        numpy.ndarray of float
            One entry per point, NaN where the point failed or the moment does not exist.

        Raises
        ------
        KeyError
            An unknown method or quantity.
        ValueError
            An unknown statistic.
        """
        if quantity not in self.quantities:
            raise KeyError(f"{quantity!r} is not a quantity of the sweep ({', '.join(self.quantities)})")
        key = "variance" if stat == "std" else stat
        if key not in _STATS:
            raise ValueError(f"stat must be one of mean, variance, std, kurtosis (got {stat!r})")
        out = np.full(len(self._points), math.nan)
        for k, p in enumerate(self._points):
            o = self._outcome(p, method)
            if o["status"] != "converged":
                continue
            for s in o["stats"]:
                if s["name"] == quantity and s[key] is not None:
                    out[k] = s[key]
        return np.sqrt(out) if stat == "std" else out

    def failures(self, method: str) -> List[Dict[str, Any]]:
        """The points ``method`` did not solve, with why.

        Parameters
        ----------
        method : str
            One of the sweep's ``methods``.

        Returns
        -------
        list of dict
            ``{"values": {...}, "status": ..., "stage": ..., "message": ...}`` per failed
            point: status ``"failed"``, or ``"refused"`` (stage ``"admissibility"``) for a
            point without a stationary density, which no method was asked to solve.

        Raises
        ------
        KeyError
            ``method`` was not in the sweep.
        """
        names = list(self.values)
        out = []
        for p in self._points:
            o = self._outcome(p, method)
            if o["status"] in ("failed", "refused"):
                out.append(
                    {
                        "values": dict(zip(names, p["values"])),
                        "status": o["status"],
                        "stage": o["stage"],
                        "message": o["message"],
                    }
                )
        return out

    def to_pandas(self) -> "pandas.DataFrame":
        """The sweep in long form.

        Returns
        -------
        pandas.DataFrame
            One row per point, method and quantity: a column per swept parameter, ``method``,
            ``quantity``, ``converged`` and ``mean``, ``variance``, ``std``, ``kurtosis`` (NaN
            where the point failed).

        Raises
        ------
        ImportError
            pandas is not installed (it is imported here only).
        """
        pd = _optional("pandas")
        columns: Dict[str, List[Any]] = {n: [] for n in self.values}
        for key in ("method", "quantity", "converged", "mean", "variance", "std", "kurtosis"):
            columns[key] = []
        n = len(self)
        for m in self.methods:
            conv = self.converged(m)
            for q in self.quantities:
                stats = {s: self.stat(m, q, s) for s in ("mean", "variance", "std", "kurtosis")}
                for k in range(n):
                    for name, vals in self.values.items():
                        columns[name].append(vals[k])
                    columns["method"].append(m)
                    columns["quantity"].append(q)
                    columns["converged"].append(bool(conv[k]))
                    for s, arr in stats.items():
                        columns[s].append(arr[k])
        return pd.DataFrame(columns)

    def to_xarray(self) -> "xarray.Dataset":
        """The sweep on its grid of swept values.

        Returns
        -------
        xarray.Dataset
            Variables ``mean``, ``variance``, ``std``, ``kurtosis`` with dims ``("method",
            "quantity", *swept parameters)`` and ``converged`` with dims ``("method", *swept
            parameters)``; coordinates are the swept values; ``attrs`` hold ``model``,
            ``method`` (the methods, comma-separated), ``degree`` and ``fpsolve_version``.

        Raises
        ------
        ImportError
            xarray is not installed (it is imported here only).
        ValueError
            The points are not the Cartesian product of the swept values.
        """
        xr = _optional("xarray")
        names = list(self.values)
        axes = [list(dict.fromkeys(self.values[n].tolist())) for n in names]
        shape = tuple(len(a) for a in axes)
        if int(np.prod(shape)) != len(self):
            raise ValueError("the sweep's points are not the Cartesian product of its values")

        def grid(a: np.ndarray) -> np.ndarray:
            # Points run with the first parameter fastest.
            return a.reshape(shape[::-1]).transpose(tuple(range(len(shape)))[::-1])

        data = {}
        for s in ("mean", "variance", "std", "kurtosis"):
            data[s] = (
                ["method", "quantity", *names],
                np.array([[grid(self.stat(m, q, s)) for q in self.quantities] for m in self.methods]),
            )
        data["converged"] = (["method", *names], np.array([grid(self.converged(m)) for m in self.methods]))
        coords = {"method": list(self.methods), "quantity": list(self.quantities)}
        coords.update({n: np.array(a, dtype=np.float64) for n, a in zip(names, axes)})
        attrs = {
            "model": str(self.report.get("model", "")),
            "method": ",".join(self.methods),
            "degree": self.report.get("degree", ""),
            "fpsolve_version": _fpsolve.__version__,
        }
        return xr.Dataset(data, coords=coords, attrs={k: v for k, v in attrs.items() if v is not None})

    def __repr__(self) -> str:
        return f"<fpsolve.SweepResult {len(self)} points of {', '.join(self.values)} by {', '.join(self.methods)}>"


class SweepShard(ShardText):
    """One part of a split sweep (``sweep(..., shard=(k, n))``): its points' results as plain
    data (the command line's ``sweep_shard_K_of_N.json`` text), which pickles and which
    :func:`fpsolve.merge` joins with the other parts into the unsplit sweep's
    :class:`SweepResult`."""

    __slots__ = ()

    @property
    def file_name(self) -> str:
        """``sweep_shard_K_of_N.json`` (K from 1), the name ``fpsolve sweep --shard`` writes."""
        return f"sweep_shard_{self.index + 1}_of_{self.count}.json"

    def __repr__(self) -> str:
        return f"<fpsolve.SweepShard {self.index + 1} of {self.count}>"


def _sweep_shard(model: Model, args: Tuple[Any, ...], index: int, count: int) -> SweepShard:
    """One part of a split sweep, for an executor's worker."""
    return SweepShard(_fpsolve.sweep_json(model._inner, *args, shard=(index, count)))


def sweep(
    model: Model,
    method: Union[str, Sequence[str]] = "epc",
    degree: int = 4,
    cells: Union[Sequence[int], None] = None,
    threads: Optional[int] = None,
    params: Optional[Mapping[str, Any]] = None,
    shard: Optional[Tuple[int, int]] = None,
    executor: Optional["concurrent.futures.Executor"] = None,
    shards: Optional[int] = None,
    progress: ProgressArg = None,
    **parameters: Any,
) -> Union[SweepResult, SweepShard]:
    """Solves ``model`` at every point of a parameter study, points in parallel.

    Parameters
    ----------
    model : Model
        The model.
    method : str or sequence of str
        One method (``"epc"``, ``"epc-impact"``, ``"grid"``) or a list of them.
    degree : int
        The EPC degree.
    cells : (int, int), optional
        The grid's cells at every point (default (200, 400)).
    threads : int, optional
        Worker threads (default: all cores); the result does not depend on it. A model
        parameter named ``threads`` is set through ``params``.
    params : mapping of str to value, optional
        The same as ``**parameters``, as a dict.
    shard : (int, int), optional
        ``(k, n)``: solve only the ``k``-th (from 0) of ``n`` runs of consecutive points and
        return a :class:`SweepShard` (the command line's ``sweep --shard``), which
        :func:`fpsolve.merge` joins.
    executor : concurrent.futures.Executor, optional
        Solves ``shards`` parts on it and merges them: the same numbers as the local run.
    shards : int, optional
        The parts of an ``executor`` run (default: one per 4 points, at most 64).
    progress : bool or callable, optional
        ``True`` prints the points solved to stderr as the sweep goes (a tqdm bar when tqdm
        is installed); a callable ``f(done, total)`` is called instead, from the calling
        thread (an exception it raises stops the sweep). Not with ``executor``.
    **parameters : sequence, number or str
        A sequence or array (``eps=np.linspace(-0.3, 0.3, 13)``, ``mu=[0.1, 1]``) is swept (at
        most two; the points are their Cartesian product, the first fastest); a number or
        expression string is a fixed override.

    Returns
    -------
    SweepResult or SweepShard
        Every point's statistics per method (a :class:`SweepShard` with ``shard``). A point
        that fails for a method is kept, with its reason (``failures``).

    Raises
    ------
    SweepError
        The sweep cannot run (no swept parameter, an unknown one, more than two, ...).
    KeyboardInterrupt
        Ctrl-C: the sweep stops between points.

    Notes
    -----
    Releases the GIL.

    Examples
    --------
    >>> res = fpsolve.sweep(model, method=["epc", "grid"], mu=np.linspace(0.1, 1, 10))  # doctest: +SKIP
    >>> res.to_pandas()                                                                  # doctest: +SKIP
    """
    from ._model import _params

    parameters = _params(params, parameters)
    swept = []
    fixed = []
    for name, value in parameters.items():
        if isinstance(value, str):
            fixed.append((name, value))
        elif np.ndim(value) == 0:
            fixed.append((name, repr(float(value))))
        else:
            swept.append((name, [float(v) for v in np.asarray(value, dtype=np.float64).ravel()]))
    methods = [method] if isinstance(method, str) else list(method)
    cells_t = None if cells is None else (int(cells[0]), int(cells[1]))
    args = (swept, fixed, methods, int(degree), cells_t, None if threads is None else int(threads))
    if shard is not None and executor is not None:
        raise TypeError("sweep: give shard= (one part) or executor= (all parts), not both")
    report = callback(progress, "sweep")
    if report is not None and executor is not None:
        raise TypeError("sweep: progress= reports a local run; an executor's parts run elsewhere")
    if shard is not None:
        index, count = (int(k) for k in shard)
        return SweepShard(
            _fpsolve.sweep_json(model._inner, *args, shard=(index, count), progress=report)
        )
    if executor is not None:
        points = 1
        for _, values in swept:
            points *= len(values)
        count = min(64, max(1, points // 4)) if shards is None else int(shards)
        if count < 1:
            raise ValueError("shards must be at least 1")
        futures = [executor.submit(_sweep_shard, model, args, k, count) for k in range(count)]
        from ._merge import merge

        return merge([f.result() for f in futures])
    if shards is not None:
        raise TypeError("sweep: shards= is the split of executor= runs; give executor=")
    return SweepResult(json.loads(_fpsolve.sweep_json(model._inner, *args, progress=report)))
