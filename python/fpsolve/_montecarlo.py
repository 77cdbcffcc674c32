"""fpsolve.MonteCarlo: histograms of a Monte Carlo run as NumPy arrays."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from typing import Any, Dict, Iterator, List, Optional, Tuple

import numpy as np

from ._shard import ShardText
from ._warnings import FpsolveWarning, MonteCarloWarning


def _num(v: Any) -> float:
    """A number of the library's JSON: null (no finite value) is NaN, and exact numbers are
    written as their shortest round-trip decimal string ("0.1", "inf")."""
    return math.nan if v is None else float(v)


def _arr(values) -> np.ndarray:
    """A float64 array of the library's JSON numbers."""
    return np.array([_num(v) for v in values], dtype=np.float64)


@dataclass(frozen=True)
class Histogram:
    """The histogram of one state or observable: ``density`` and its standard error
    ``stderr`` (from the spread over statistics batches) on the bins ``edges``, with bin
    centres ``x``; ``moments`` maps ``mean``, ``variance``, ``kurtosis`` to
    ``(value, stderr)``; ``bias`` is the time-step bias estimate of the density (a paired run
    at 2*dt), or None."""

    name: str
    is_state: bool
    x: np.ndarray
    edges: np.ndarray
    density: np.ndarray
    stderr: np.ndarray
    samples: int
    outside: int
    moments: Dict[str, Tuple[float, float]]
    bias: Optional[np.ndarray]
    bias_stderr: Optional[np.ndarray]

    @classmethod
    def _from_dict(cls, d: Dict[str, Any]) -> "Histogram":
        g = d["grid"]
        lo, hi, bins = _num(g["lo"]), _num(g["hi"]), int(g["bins"])
        width = (hi - lo) / bins
        # The library's bin centres, lo + (j + 1/2)·width, to the bit.
        x = lo + (np.arange(bins) + 0.5) * width
        edges = lo + np.arange(bins + 1) * width
        m = d["moments"]
        moments = {
            k: (_num(m[k]["value"]), _num(m[k]["stderr"])) for k in ("mean", "variance", "kurtosis")
        }
        b = d.get("time_step_bias")
        return cls(
            name=d["name"],
            is_state=bool(d["is_state"]),
            x=x,
            edges=edges,
            density=_arr(d["density"]),
            stderr=_arr(d["stderr"]),
            samples=int(d["samples"]),
            outside=int(d["underflow"]) + int(d["overflow"]) + int(d["invalid"]),
            moments=moments,
            bias=None if b is None else _arr(b["density"]),
            bias_stderr=None if b is None else _arr(b["density_stderr"]),
        )


def _est(d: Any) -> Tuple[float, float]:
    """An ``Estimate`` of the library's JSON as ``(value, stderr)``."""
    return (_num(d["value"]), _num(d["stderr"]))


@dataclass(frozen=True)
class CrossingRates:
    """Monte Carlo's mean up-crossing rates of one quantity's ``levels`` (asked with
    ``Model.simulate(levels=...)``): ``rate`` and its standard error ``stderr`` (up-crossings
    per unit time per trajectory, counted between sample points and through the impacts in
    between; at the level of a wall the state stands on, one per impact, Rice's flux there),
    ``spacing_bias`` (the count on every other sample point minus the count: the sample
    spacing's bias, first order) and ``time_step_bias`` (from the 2·dt run, or None)."""

    quantity: str
    levels: np.ndarray
    rate: np.ndarray
    stderr: np.ndarray
    spacing_bias: np.ndarray
    time_step_bias: Optional[np.ndarray]

    @classmethod
    def _from_dict(cls, d: Dict[str, Any]) -> "CrossingRates":
        b = d.get("time_step_bias")
        return cls(
            quantity=d["quantity"],
            levels=_arr(d["levels"]),
            rate=_arr(e["value"] for e in d["rate"]),
            stderr=_arr(e["stderr"] for e in d["rate"]),
            spacing_bias=_arr(e["value"] for e in d["spacing_bias"]),
            time_step_bias=None if b is None else _arr(e["value"] for e in b),
        )


@dataclass(frozen=True)
class WallImpacts:
    """Monte Carlo's impact statistics at one wall, per unit mass: ``rate`` (impacts per unit
    time per trajectory), ``mean_speed`` (|v| before the impact) and ``mean_power`` (the
    kinetic energy (v² − v′²)/2 the impacts take per unit time), each ``(value, stderr)``;
    ``time_step_bias`` their biases from the 2·dt run (or None); with
    ``Model.simulate(impact_speeds=...)`` the flux-weighted impact-speed density
    ``speed_density`` with ``speed_stderr`` on the bin centres ``speeds``, else None."""

    state: str
    at: float
    above: bool
    count: int
    rate: Tuple[float, float]
    mean_speed: Tuple[float, float]
    mean_power: Tuple[float, float]
    time_step_bias: Optional[Tuple[float, float, float]]
    speeds: Optional[np.ndarray]
    speed_density: Optional[np.ndarray]
    speed_stderr: Optional[np.ndarray]

    @classmethod
    def _from_dict(cls, d: Dict[str, Any]) -> "WallImpacts":
        b = d.get("time_step_bias")
        sp = d.get("speeds")
        x = None
        if sp is not None:
            g = sp["grid"]
            lo, hi, bins = _num(g["lo"]), _num(g["hi"]), int(g["bins"])
            x = lo + (np.arange(bins) + 0.5) * ((hi - lo) / bins)
        return cls(
            state=d["state"],
            at=_num(d["at"]),
            above=bool(d["above"]),
            count=int(d["count"]),
            rate=_est(d["rate"]),
            mean_speed=_est(d["mean_speed"]),
            mean_power=_est(d["mean_power"]),
            time_step_bias=None if b is None else tuple(_num(e["value"]) for e in b),
            speeds=x,
            speed_density=None if sp is None else _arr(sp["density"]),
            speed_stderr=None if sp is None else _arr(sp["stderr"]),
        )


class MonteCarlo:
    """The result of :meth:`Model.simulate`: a :class:`Histogram` per state and observable
    (``mc["y"]``, ``mc.histograms``), and ``report``, the run as a dict (settings, scheme,
    stationarity test, blow-ups, impacts: the library's serde form).

    ``flags`` lists what makes the result unusable as it stands, one sentence each (what
    ``fpsolve simulate`` exits 1 for; empty for a sound run); ``warnings`` lists the run's
    warnings (a few blow-ups, a time-step bias above the statistical error, ...), as the
    command line prints them. ``ok`` is ``not flags``."""

    __slots__ = ("histograms", "report", "flags", "warnings")

    @property
    def provenance(self) -> Optional[Dict[str, Any]]:
        """Where the run came from (as ``mc_summary.json``'s ``provenance``): fpsolve's
        version, the schema, the time (UTC), the worker ``threads``, the ``model``'s name,
        file and text; no ``command`` (none from Python). The seed is
        ``report["settings"]["seed"]``.

        A merged run (``fpsolve.merge``, or ``simulate(executor=...)``, which merges its
        parts) states the merge's time, the parts' model, and as ``threads`` the threads each
        part ran with (the most, when they differ; the merging process's for parts that do
        not say, such as shard files of an older fpsolve)."""
        return self.report.get("provenance")

    def __init__(
        self,
        histograms: Dict[str, Histogram],
        report: Dict[str, Any],
        flags: Optional[List[str]] = None,
        warnings: Optional[List[str]] = None,
    ):
        self.histograms = histograms
        self.report = report
        self.flags = list(flags or [])
        self.warnings = list(warnings or [])

    @classmethod
    def _from_json(
        cls, text: str, flags: Optional[List[str]] = None, warnings: Optional[List[str]] = None
    ) -> "MonteCarlo":
        report = json.loads(text)
        hists = {q["name"]: Histogram._from_dict(q) for q in report["quantities"]}
        return cls(hists, report, flags, warnings)

    @property
    def ok(self) -> bool:
        """Whether the run's verdict passed and every number is defined (``flags`` empty)."""
        return not self.flags

    def _judge(self, strict: bool) -> None:
        """Raises :class:`MonteCarloError` (``strict``) or warns :class:`MonteCarloWarning`
        when the result is flagged; the warnings of a sound run are warned as
        :class:`FpsolveWarning`."""
        from ._fpsolve import MonteCarloError

        if self.flags:
            text = "the Monte Carlo run finished, but: " + "; ".join(self.flags)
            if strict:
                raise MonteCarloError(text)
            warnings.warn(text, MonteCarloWarning, stacklevel=3)
        for w in self.warnings:
            warnings.warn(f"Monte Carlo: {w}", FpsolveWarning, stacklevel=3)

    def __getitem__(self, name: str) -> Histogram:
        return self.histograms[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.histograms)

    @property
    def crossings(self) -> Dict[str, CrossingRates]:
        """The up-crossing rates of the quantities given levels, by name (empty without
        ``levels=``)."""
        return {
            c["quantity"]: CrossingRates._from_dict(c) for c in self.report.get("crossings") or []
        }

    @property
    def walls(self) -> List[WallImpacts]:
        """The impact statistics of each wall (the model's walls in order; empty without
        one)."""
        impacts = self.report.get("impacts") or {}
        return [WallImpacts._from_dict(w) for w in impacts.get("walls") or []]

    @property
    def samples(self) -> int:
        """Recorded samples of each quantity."""
        return next(iter(self.histograms.values())).samples

    def to_xarray(self) -> "xarray.Dataset":
        """The histograms as an xarray Dataset.

        Returns
        -------
        xarray.Dataset
            For each quantity ``q``: the variables ``q`` (density) and ``q_stderr`` on the
            dim ``x_q`` (its bin centres), and ``q_edges`` (the bin edges, on the dim
            ``edge_q``); ``attrs`` hold ``seed``, ``samples``, ``flags`` and
            ``fpsolve_version``.

        Raises
        ------
        ImportError
            xarray is not installed (it is imported here only).
        """
        from ._fpsolve import __version__
        from ._sweep import _optional

        xr = _optional("xarray")
        data, coords = {}, {}
        for name, h in self.histograms.items():
            coords[f"x_{name}"] = h.x
            data[name] = ([f"x_{name}"], h.density)
            data[f"{name}_stderr"] = ([f"x_{name}"], h.stderr)
            data[f"{name}_edges"] = ([f"edge_{name}"], h.edges)
        settings = self.report.get("settings", {})
        attrs = {
            "seed": int(settings.get("seed", 0)),
            "samples": self.samples,
            "flags": "; ".join(self.flags),
            "fpsolve_version": __version__,
        }
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def __repr__(self) -> str:
        return f"<fpsolve.MonteCarlo {self.samples} samples of {', '.join(self.histograms)}>"


class MonteCarloShard(ShardText):
    """One part of a split Monte Carlo run (``Model.simulate(shard=(k, n))``): the statistics
    of its batches as plain data (the command line's ``shard_K_of_N.json`` text), which
    pickles and which :func:`fpsolve.merge` joins with the other parts into the unsplit run's
    :class:`MonteCarlo`, bit for bit.

    ``index`` (from 0) and ``count`` say which part it is; ``json`` is the file's text
    (``write`` puts it where ``fpsolve merge`` reads it), which opens with the part's
    ``provenance`` (the model, the threads it ran with; absent in files of an older
    fpsolve)."""

    __slots__ = ()

    @property
    def provenance(self) -> Optional[Dict[str, Any]]:
        """Where the part came from: fpsolve's version, the schema, the time (UTC), the worker
        ``threads`` it ran with, the ``model``'s name, file and text (None for a shard file of
        an older fpsolve)."""
        return json.loads(self.json).get("provenance")

    @property
    def file_name(self) -> str:
        """``shard_K_of_N.json`` (K from 1), the name ``fpsolve simulate --shard`` writes."""
        return f"shard_{self.index + 1}_of_{self.count}.json"

    def write(self, directory) -> str:
        """Writes the part where ``fpsolve merge DIR`` reads it.

        Parameters
        ----------
        directory : str or os.PathLike
            An existing directory.

        Returns
        -------
        str
            The path written, ``directory/shard_K_of_N.json``.
        """
        import os

        path = os.path.join(os.fspath(directory), self.file_name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.json)
        return path

    def __eq__(self, other: object) -> bool:
        return isinstance(other, MonteCarloShard) and other.json == self.json

    def __repr__(self) -> str:
        return f"<fpsolve.MonteCarloShard {self.index + 1} of {self.count}>"

