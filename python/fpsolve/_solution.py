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
        # (model, method, degree, cells, overrides, domain, tol): what solved it, for pickling.
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
        """The PDF of a state or observable.

        Parameters
        ----------
        name : str
            A state or observable of the model.
        x : array_like
            Where to evaluate it, any shape.

        Returns
        -------
        float or numpy.ndarray
            An array of ``x``'s shape (float64), or a float for a scalar ``x``.

        Raises
        ------
        UnknownQuantityError
            ``name`` is not a state or observable (a ``KeyError``).

        Warns
        -----
        PointMassWarning
            Once per quantity that takes some values with positive probability.

        Notes
        -----
        Releases the GIL.
        """
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
        """The joint density of the states named by :attr:`joint_states`.

        Parameters
        ----------
        x1, x2 : array_like
            The two coordinates, broadcast together (e.g. a meshgrid).

        Returns
        -------
        float or numpy.ndarray
            The density, of the broadcast shape; a float for scalars.

        Notes
        -----
        For the δ-term EPC of a model in its own coordinates these are the Zhuravlev states,
        not the model's: use :meth:`pdf` for the model's states.
        """
        a, b = np.broadcast_arrays(np.asarray(x1, dtype=np.float64), np.asarray(x2, dtype=np.float64))
        shape = a.shape
        p = self._inner.joint(np.ascontiguousarray(a.reshape(-1)), np.ascontiguousarray(b.reshape(-1)))
        return float(p[0]) if len(shape) == 0 else p.reshape(shape)

    def marginal(self, name: str) -> Tuple[np.ndarray, np.ndarray]:
        """The PDF of ``name`` on the grid the command line's reports use.

        Parameters
        ----------
        name : str
            A state or observable of the model.

        Returns
        -------
        x, p : numpy.ndarray
            The grid and the PDF on it.
        """
        out = self._inner.marginal(name)
        self._warn_point_masses(name)
        return out

    def moments(self, name: str) -> Moments:
        """The moments of a state or observable, from the joint density directly.

        Parameters
        ----------
        name : str
            A state or observable of the model.

        Returns
        -------
        Moments
            Mean, variance, kurtosis and raw moments E[g^k], k <= 4; a moment that does not
            exist is NaN.
        """
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

    def _curve(self, name: str) -> "_Curve":
        """``name``'s marginal curve prepared once for :meth:`logpdf`, :meth:`cdf`, :meth:`sf`."""
        curve = self._curves.get(name)
        if curve is None:
            x, p = self.marginal(name)
            if name in self.joint_states:
                masses: Tuple[Tuple[float, float], ...] = ()
                undefined = 0.0
            else:
                m = self.moments(name)
                masses, undefined = m.point_masses, m.undefined_mass
            curve = _Curve(np.asarray(x, dtype=np.float64), np.asarray(p, dtype=np.float64), masses, undefined)
            self._curves[name] = curve
        return curve

    def logpdf(self, name: str, x: ArrayLike) -> Union[float, np.ndarray]:
        """The log of the PDF of ``name`` at ``x``.

        Parameters
        ----------
        name : str
            A state or observable of the model.
        x : array_like
            Where to evaluate it, any shape.

        Returns
        -------
        float or numpy.ndarray
            Of ``x``'s shape, or a float for a scalar ``x``; ``-inf`` outside the support.

        Notes
        -----
        From the marginal curve (:meth:`marginal`, computed once per quantity): log p
        interpolated through the three nearest grid points (log-linearly next to a zero of
        the curve).

        Beyond the curve's grid: where the curve ends in a decaying tail (below 1e-6 of its
        peak) the last cell's exponential decay is continued (the rule :meth:`tail_probability`
        and the command line use); where it ends at the edge of the support (a barrier,
        ``|z| >= 0``) it is ``-inf``. At a point mass (see :attr:`Moments.point_masses`) it is
        the log-density of the continuous part: the atom has no density.
        """
        arr = np.asarray(x, dtype=np.float64)
        out = self._curve(name).logpdf(arr.reshape(-1))
        return float(out[0]) if arr.ndim == 0 else out.reshape(arr.shape)

    def cdf(self, name: str, x: ArrayLike) -> Union[float, np.ndarray]:
        """The cumulative distribution P(name <= x).

        Parameters
        ----------
        name : str
            A state or observable of the model.
        x : array_like
            Where to evaluate it, any shape.

        Returns
        -------
        float or numpy.ndarray
            Of ``x``'s shape, or a float for a scalar ``x``.

        Notes
        -----
        The continuous part from the marginal curve, integrated
        cell by cell with the log-linear rule of :meth:`tail_probability` and normalised by
        the curve's own mass, plus every point mass at or below ``x`` (the CDF jumps there).
        Its accuracy is the curve's quadrature: about 1e-4 relative in a far tail of the
        401-point curve (5e-5 at 5 standard deviations of a Gaussian), better in the bulk.

        ``cdf + sf = 1 - undefined_mass`` (the probability that the quantity has no finite
        value, :attr:`Moments.undefined_mass`). Beyond the curve's grid the value is exact
        where the curve ends at the edge of the support (0 below it, the whole mass above
        it); where it ends in a decaying tail, the tail beyond (below about 1e-8 of the
        mass) is the exponential continuation of the last cell, which the solution does not
        resolve: read it as "negligible", not as a tail estimate.
        """
        arr = np.asarray(x, dtype=np.float64)
        out = self._curve(name).cdf(arr.reshape(-1))
        return float(out[0]) if arr.ndim == 0 else out.reshape(arr.shape)

    def sf(self, name: str, x: ArrayLike) -> Union[float, np.ndarray]:
        """The survival function P(name > x).

        Parameters
        ----------
        name : str
            A state or observable of the model.
        x : array_like
            Where to evaluate it, any shape.

        Returns
        -------
        float or numpy.ndarray
            Of ``x``'s shape, or a float for a scalar ``x``.

        Notes
        -----
        Computed as :meth:`cdf` is (not as ``1 - cdf``, so that small upper tails keep their
        digits); the same caveats beyond the curve's grid.
        """
        arr = np.asarray(x, dtype=np.float64)
        out = self._curve(name).sf(arr.reshape(-1))
        return float(out[0]) if arr.ndim == 0 else out.reshape(arr.shape)

    def tail_probability(self, name: str, a: float) -> Optional[float]:
        """The tail probability P(name > a), as the command line reports it.

        Parameters
        ----------
        name : str
            A state or observable of the model.
        a : float
            The level.

        Returns
        -------
        float or None
            None where the density's support does not reliably reach ``a``.
        """
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

        It opens with ``provenance``, where the solution came from, as in ``summary.json``
        and :attr:`SweepResult.provenance`: ``fpsolve_version``, ``schema_version``,
        ``created`` (when it was solved, UTC, ISO 8601), ``threads`` (the worker threads it
        was solved with) and ``model`` (``name``, ``file`` when it was loaded from one, and
        its whole ``text``); no ``command`` (none from Python), no seed (a solve has none).
        A pickled solution keeps its original report, provenance included.

        EPC: ``solve`` (iterations, residual, residual_threshold, timings in ms),
        ``normalisation`` (plane or inside a ridge, with its depth), ``fpk_residual``,
        ``exponents``, ``coefficients``, ``sigma``, ``moments`` of the states. EPC-impact: its
        ``report`` and ``log_c``. Grid: cells, domain, clipped mass, the discretisation-error
        estimate, timings."""
        if self._report is None:
            self._report = json.loads(self._inner.report_json())
        return self._report

    @property
    def provenance(self) -> Dict[str, Any]:
        """Where the solution came from: ``report["provenance"]`` (see :attr:`report`)."""
        return self.report["provenance"]

    def __repr__(self) -> str:
        return repr(self._inner)


def _fill_atoms(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The curve with its gaps filled: the library leaves the PDF undefined (NaN) at a point
    mass, where the continuous part's density is its limit from beside; that limit is taken
    log-linearly from the two neighbours on the side that has them (at an end of the grid)
    or as the geometric mean of both."""
    p = p.copy()
    bad = ~np.isfinite(p)
    if not bad.any():
        return p
    good = np.flatnonzero(~bad)
    if good.size < 2:
        raise ValueError("the marginal curve has fewer than two finite values")
    with np.errstate(divide="ignore"):
        logp = np.log(np.where(bad, 1.0, p))
    for i in np.flatnonzero(bad):
        left, right = good[good < i], good[good > i]
        if left.size and right.size:
            a, b = left[-1], right[0]
            t = (x[i] - x[a]) / (x[b] - x[a])
            p[i] = np.exp(logp[a] + (logp[b] - logp[a]) * t) if p[a] > 0 and p[b] > 0 else 0.0
        else:
            a, b = (right[0], right[1]) if right.size >= 2 else (left[-2], left[-1])
            if p[a] > 0 and p[b] > 0:
                p[i] = np.exp(logp[a] + (logp[b] - logp[a]) * (x[i] - x[a]) / (x[b] - x[a]))
            else:
                p[i] = p[a] if right.size >= 2 else p[b]
    return p


class _Curve:
    """A marginal curve ``(x, p)`` with its cell integrals, the exponential continuations
    beyond its ends (the library's rule in ``solve::tail``), its point masses and the weight
    of its continuous part."""

    def __init__(self, x: np.ndarray, p: np.ndarray, masses, undefined: float):
        if x.size < 2 or p.shape != x.shape:
            raise ValueError("a marginal curve needs at least two points")
        p = _fill_atoms(x, p)
        self.x, self.p = x, p
        self.h = np.diff(x)
        p0, p1 = p[:-1], p[1:]
        positive = (p0 > 0) & (p1 > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.slope = np.where(positive, np.log(p1 / p0) / self.h, np.nan)
        self.positive = positive
        cells = self._partial(np.arange(x.size - 1), self.h)
        self.cum = np.concatenate(([0.0], np.cumsum(cells)))
        peak = float(p.max())

        def beyond(p_in: float, p_end: float, h: float) -> float:
            # The last cell's decay p_end·exp(-λ|x - x_end|) continued; 0 at a support edge.
            if p_in > p_end > 0 and p_end < 1e-6 * peak:
                return h / math.log(p_in / p_end)  # 1/λ
            return 0.0

        self.left_scale = beyond(p[1], p[0], self.h[0])
        self.right_scale = beyond(p[-2], p[-1], self.h[-1])
        self.mass = self.cum[-1] + p[0] * self.left_scale + p[-1] * self.right_scale
        self.masses = tuple((float(v), float(q)) for v, q in masses)
        self.weight = 1.0 - sum(q for _, q in self.masses) - float(undefined)

    def _partial(self, i: np.ndarray, d: np.ndarray) -> np.ndarray:
        """∫ p over [x_i, x_i + d] within cell i (log-linear; linear where an end is 0)."""
        p0, p1, h, s = self.p[i], self.p[i + 1], self.h[i], self.slope[i]
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            small = np.abs(s * d) < 1e-12
            loglin = np.where(small, p0 * d, p0 * np.expm1(s * d) / np.where(small, 1.0, s))
            linear = (p0 + 0.5 * (p1 - p0) * d / h) * d
        return np.where(self.positive[i], loglin, linear)

    def _below(self, x: np.ndarray) -> np.ndarray:
        """∫ p over (-inf, x]: the continuous part's unnormalised mass below x."""
        xs, n = self.x, self.x.size
        out = np.empty_like(x)
        inside = (x >= xs[0]) & (x <= xs[-1])
        i = np.clip(np.searchsorted(xs, x[inside], side="right") - 1, 0, n - 2)
        left = self.p[0] * self.left_scale
        out[inside] = left + self.cum[i] + self._partial(i, x[inside] - xs[i])
        low = x < xs[0]
        out[low] = 0.0 if self.left_scale == 0 else left * np.exp((x[low] - xs[0]) / self.left_scale)
        high = x > xs[-1]
        tail = 0.0 if self.right_scale == 0 else self.p[-1] * self.right_scale * np.exp(-(x[high] - xs[-1]) / self.right_scale)
        out[high] = self.mass - tail
        out[np.isnan(x)] = np.nan
        return out

    def _atoms(self, x: np.ndarray, upper: bool) -> np.ndarray:
        out = np.zeros_like(x)
        for v, q in self.masses:
            out += q * ((x < v) if upper else (x >= v))
        return out

    def cdf(self, x: np.ndarray) -> np.ndarray:
        below = self._below(x)
        return np.minimum(self.weight * below / self.mass, self.weight) + self._atoms(x, False)

    def sf(self, x: np.ndarray) -> np.ndarray:
        # The mass above x summed directly, so that a small upper tail keeps its digits.
        above = np.maximum(self.mass - self._below(x), 0.0)
        xs = self.x
        high = x > xs[-1]
        if self.right_scale > 0:
            above[high] = self.p[-1] * self.right_scale * np.exp(-(x[high] - xs[-1]) / self.right_scale)
        else:
            above[high] = 0.0
        above[np.isnan(x)] = np.nan
        return self.weight * above / self.mass + self._atoms(x, True)

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        xs, p, n = self.x, self.p, self.x.size
        out = np.full(x.shape, -np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            inside = (x >= xs[0]) & (x <= xs[-1])
            i = np.clip(np.searchsorted(xs, x[inside], side="right") - 1, 0, n - 2)
            u = x[inside]
            t = (u - xs[i]) / self.h[i]
            linear = np.log(p[i] + (p[i + 1] - p[i]) * t)
            # log p through the three grid points nearest x (exact for a Gaussian, whose log
            # is quadratic; a straight line in log p would be off by about h²/8σ², 1e-4 here).
            j = np.clip(np.where(t < 0.5, i - 1, i), 0, n - 3)
            x0, x1, x2 = xs[j], xs[j + 1], xs[j + 2]
            l0, l1, l2 = np.log(p[j]), np.log(p[j + 1]), np.log(p[j + 2])
            quad = (
                l0 * (u - x1) * (u - x2) / ((x0 - x1) * (x0 - x2))
                + l1 * (u - x0) * (u - x2) / ((x1 - x0) * (x1 - x2))
                + l2 * (u - x0) * (u - x1) / ((x2 - x0) * (x2 - x1))
            )
            usable = (p[j] > 0) & (p[j + 1] > 0) & (p[j + 2] > 0)
            lp0, lp1 = np.log(p[i]), np.log(p[i + 1])
            loglin = lp0 + (lp1 - lp0) * t
            out[inside] = np.where(usable, quad, np.where(self.positive[i], loglin, linear))
            low, high = x < xs[0], x > xs[-1]
            if self.left_scale > 0:
                out[low] = np.log(p[0]) + (x[low] - xs[0]) / self.left_scale
            if self.right_scale > 0:
                out[high] = np.log(p[-1]) - (x[high] - xs[-1]) / self.right_scale
        out[np.isnan(x)] = np.nan
        return out


def _unpickle_solution(recipe: Tuple[Any, ...], report: Dict[str, Any]) -> Solution:
    """A pickled :class:`Solution` back: solved again from its recipe (bit-identical), with
    the original's report."""
    model, method, degree, cells, overrides, domain, *tol = recipe
    solution = model.solve(
        method, degree=degree, cells=cells, params=overrides, domain=domain, tol=(tol or [None])[0]
    )
    solution._report = report
    return solution
