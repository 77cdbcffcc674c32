"""fpsolve.sweep: a parameter study, every point solved in parallel, results as arrays."""

from __future__ import annotations

import json
import math
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from . import _fpsolve
from ._model import Model

_STATS = ("mean", "variance", "kurtosis")


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

    def _outcome(self, point: Dict[str, Any], method: str) -> Dict[str, Any]:
        for o in point["outcomes"]:
            if o["method"] == method:
                return o
        raise KeyError(f"method {method!r} was not in the sweep (it ran {', '.join(self.methods)})")

    def converged(self, method: str) -> np.ndarray:
        """True at the points ``method`` solved."""
        return np.array(
            [self._outcome(p, method)["status"] == "converged" for p in self._points], dtype=bool
        )

    def stat(self, method: str, quantity: str, stat: str = "mean") -> np.ndarray:
        """``stat`` of ``quantity`` under ``method`` at every point (NaN where it failed)."""
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
        """The points ``method`` did not solve: ``{"values": {...}, "status": ..., "stage": ...,
        "message": ...}``, status ``"failed"``, or ``"refused"`` (stage ``"admissibility"``) for
        a point without a stationary density, which no method was asked to solve."""
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

    def __repr__(self) -> str:
        return f"<fpsolve.SweepResult {len(self)} points of {', '.join(self.values)} by {', '.join(self.methods)}>"


def sweep(
    model: Model,
    method: Union[str, Sequence[str]] = "epc",
    degree: int = 4,
    cells: Union[Sequence[int], None] = None,
    threads: Optional[int] = None,
    **parameters: Any,
) -> SweepResult:
    """Solves ``model`` at every point of a parameter study, points in parallel.

    A keyword whose value is a sequence or array (``eps=np.linspace(-0.3, 0.3, 13)``,
    ``mu=[0.1, 1]``) is swept (at most two, the points are their Cartesian product); a number
    or expression string is a fixed override. ``method`` is one method or a list of them.
    A point that fails for a method is kept, with its reason (``failures``). Releases the
    GIL; Ctrl-C stops the sweep and raises KeyboardInterrupt. Raises :class:`SweepError` for
    a sweep that cannot run. ``threads`` (default: all cores) is the number of worker threads;
    the result does not depend on it (a model parameter named ``threads`` cannot be set
    through this keyword).
    """
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
    text = _fpsolve.sweep_json(
        model._inner,
        swept,
        fixed,
        methods,
        int(degree),
        cells_t,
        None if threads is None else int(threads),
    )
    return SweepResult(json.loads(text))
