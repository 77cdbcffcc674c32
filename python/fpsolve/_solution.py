"""fpsolve.Solution: a solved stationary density, asked by state or observable name."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from ._warnings import FpsolveWarning

from . import _fpsolve

ArrayLike = Union[float, "np.typing.ArrayLike"]


def _nan(v: Optional[float]) -> float:
    """JSON's null (a moment that does not exist) as NaN."""
    return math.nan if v is None else float(v)


@dataclass(frozen=True)
class Moments:
    """The moments of one state or observable, from the joint density directly.

    A moment that does not exist, and every statistic built on it, is NaN;
    ``existing_moments`` says how many of E[g] ... E[g^4] exist, ``undefined_mass`` is
    P(g has no finite value) (the moments are then conditional on g being defined).
    ``point_masses`` lists ``(value, probability)`` for the values g takes with positive
    probability (g constant on a region: ``max(z, 0)`` is 0 with probability 1/2); there g has
    no density, its PDF is that of the rest and integrates to 1 minus their sum; the moments
    include them.
    """

    name: str
    mean: float
    variance: float
    kurtosis: float
    raw: Tuple[float, float, float, float]
    undefined_mass: float
    existing_moments: int
    point_masses: Tuple[Tuple[float, float], ...] = ()

    @property
    def std(self) -> float:
        """The standard deviation, sqrt(variance)."""
        return math.sqrt(self.variance)


class PointMassWarning(FpsolveWarning):
    """A quantity takes some values with positive probability: its PDF integrates to less
    than 1 (see :attr:`Moments.point_masses`)."""


class Solution:
    """A solved stationary density (from :meth:`Model.solve`).

    Every method takes any state or observable by name; an unknown name raises
    :class:`UnknownQuantityError` (``.name``, ``.known``).
    """

    __slots__ = ("_inner", "_report", "_checked", "_recipe", "_curves")

    def __init__(self, inner: "_fpsolve._Solution", recipe: Optional[Tuple[Any, ...]] = None):
        self._inner = inner
        self._report: Optional[Dict[str, Any]] = None
        self._checked: set = set()
        # (model, method, degree, cells, overrides): what solved it, for pickling.
        self._recipe = recipe
        self._curves: Dict[str, Tuple[np.ndarray, np.ndarray, np.ndarray, float, Tuple]] = {}

    def __reduce__(self):
        # The solvers are deterministic: the model (pickled by its text), the method and the
        # overrides give the same density to the bit in any process. The report (with this
        # solve's timings) travels as data.
        if self._recipe is None:
            raise TypeError("this Solution was not made by Model.solve and cannot be pickled")
        return (_unpickle_solution, (self._recipe, self.report))

    @property
    def method(self) -> str:
        """``"epc"``, ``"epc-impact"`` or ``"grid"``."""
        return self._inner.method

    @property
    def degree(self) -> Optional[int]:
        """The EPC degree, None for the grid."""
        return self._inner.degree

    @property
    def quantities(self) -> Tuple[str, ...]:
        """The states, then the observables."""
        return tuple(self._inner.quantities)

    def pdf(self, name: str, x: ArrayLike) -> Union[float, np.ndarray]:
        """The PDF of ``name`` at ``x``: an array of ``x``'s shape (float64), or a float for a
        scalar ``x``. Releases the GIL."""
        arr = np.asarray(x, dtype=np.float64)
        p = self._inner.pdf(name, np.ascontiguousarray(arr.reshape(-1)))
        self._warn_point_masses(name)
        return float(p[0]) if arr.ndim == 0 else p.reshape(arr.shape)

    def _warn_point_masses(self, name: str) -> None:
        """A ``PointMassWarning`` (once per quantity) when ``name`` takes some values with
        positive probability: its PDF then integrates to less than 1 (the command line flags
        the same run, exit 1). States never do; an observable is checked once (its moments)."""
        if name in self.joint_states or name in self._checked:
            return
        self._checked.add(name)
        masses = self.moments(name).point_masses
        if masses:
            listed = ", ".join(f"{v:.6g} with probability about {q:.2g}" for v, q in masses)
            rest = 1.0 - sum(q for _, q in masses)
            warnings.warn(
                f"`{name}` is constant on part of the plane: it equals {listed} (point masses, "
                f"which have no density), so its PDF is that of the rest and integrates to about "
                f"{rest:.2g}; Solution.moments({name!r}).point_masses lists them",
                PointMassWarning,
                stacklevel=3,
            )

    @property
    def joint_states(self) -> Tuple[str, str]:
        """The names of :meth:`joint`'s two coordinates: the model's states, except for a
        model with an impact law in its own coordinates solved by the δ-term EPC
        (``method="epc"``), whose density is that of the Zhuravlev transform's states
        (``("z", "v")``), the model's states being observables of it."""
        return tuple(self._inner.joint_states)

    def joint(self, x1: ArrayLike, x2: ArrayLike) -> Union[float, np.ndarray]:
        """The joint density at (x1, x2) of the states named by :attr:`joint_states`,
        broadcast together (e.g. a meshgrid); a float for scalars. For the δ-term EPC of a
        model in its own coordinates these are the Zhuravlev states, not the model's: use
        :meth:`pdf` for the model's states."""
        a, b = np.broadcast_arrays(np.asarray(x1, dtype=np.float64), np.asarray(x2, dtype=np.float64))
        shape = a.shape
        p = self._inner.joint(np.ascontiguousarray(a.reshape(-1)), np.ascontiguousarray(b.reshape(-1)))
        return float(p[0]) if len(shape) == 0 else p.reshape(shape)

    def marginal(self, name: str) -> Tuple[np.ndarray, np.ndarray]:
        """``(x, p)``: the PDF of ``name`` on the grid the command line's reports use."""
        out = self._inner.marginal(name)
        self._warn_point_masses(name)
        return out

    def moments(self, name: str) -> Moments:
        """Mean, variance, kurtosis and raw moments E[g^k], k <= 4, of ``name``."""
        d = json.loads(self._inner.moments_json(name))
        return Moments(
            name=d["name"],
            mean=_nan(d["mean"]),
            variance=_nan(d["variance"]),
            kurtosis=_nan(d["kurtosis"]),
            raw=tuple(_nan(v) for v in d["raw"]),  # type: ignore[arg-type]
            undefined_mass=_nan(d["undefined_mass"]),
            existing_moments=int(d["existing_moments"]),
            point_masses=tuple((float(m["value"]), float(m["probability"])) for m in d.get("point_masses", [])),
        )

    def tail_probability(self, name: str, a: float) -> Optional[float]:
        """P(name > a), or None where the density's support does not reliably reach ``a``."""
        return self._inner.tail_probability(name, float(a))

    @property
    def coefficients(self) -> Dict[Tuple[int, int], float]:
        """EPC: Q(x1, x2) = sum of a_ij x1^i x2^j as ``{(i, j): a_ij}`` (p = C exp(Q)).

        The grid solution has none: :class:`NotApplicableError`."""
        exponents, values = self._inner.coefficients()
        return {(int(i), int(j)): float(a) for (i, j), a in zip(exponents, values)}

    @property
    def report(self) -> Dict[str, Any]:
        """The typed outcome as a dict (the library's serde form; a non-finite number is None).

        EPC: ``solve`` (iterations, residual, residual_threshold, timings in ms),
        ``normalisation`` (plane or inside a ridge, with its depth), ``fpk_residual``,
        ``exponents``, ``coefficients``, ``sigma``, ``moments`` of the states. EPC-impact: its
        ``report`` and ``log_c``. Grid: cells, domain, clipped mass, the discretisation-error
        estimate, timings."""
        if self._report is None:
            self._report = json.loads(self._inner.report_json())
        return self._report

    def __repr__(self) -> str:
        return repr(self._inner)


def _unpickle_solution(recipe: Tuple[Any, ...], report: Dict[str, Any]) -> Solution:
    """A pickled :class:`Solution` back: solved again from its recipe (bit-identical), with
    the original's report."""
    model, method, degree, cells, overrides = recipe
    solution = model.solve(method, degree=degree, cells=cells, params=overrides)
    solution._report = report
    return solution
