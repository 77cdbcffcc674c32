"""Type stubs of the native module fpsolve._fpsolve (the Rust library's thin wrappers; the
public API is the pure-Python layer in fpsolve/)."""

import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Value = Union[float, int, str]
_Float64 = npt.NDArray[np.float64]

class FpsolveError(Exception):
    """Base class of every error fpsolve raises; ``kind`` names the library's variant."""

    kind: str

class ModelError(FpsolveError, ValueError):
    """A model that cannot be read, parsed or validated; ``str(e)`` is the CLI's
    file:line:col message. Also a ``ValueError``."""

    path: Optional[str]
    line: Optional[int]
    column: Optional[int]
    message: Optional[str]
    help: Optional[str]

class ParameterError(ModelError):
    """A parameter override that is malformed or cannot be bound."""

class ModelFileNotFoundError(ModelError, FileNotFoundError):
    """A model file that does not exist (``filename``)."""

class SolveError(FpsolveError):
    """A method that gave no density."""

    method: str
    degree: Optional[int]

class NoConvergenceError(SolveError):
    """EPC found no root: ``residual`` (best ‖R‖), ``threshold``, ``gradient``."""

    residual: float
    threshold: float
    gradient: float

class NotNormalisableError(SolveError):
    """exp(Q) has no finite mass: ``reason`` in words."""

    reason: str

class GridSolveError(SolveError):
    """The grid solver failed (``kind``: singular, degenerate, domain_not_found, …)."""

class NotApplicableError(SolveError):
    """The method does not apply to the model: ``reason``."""

    reason: str

class UnknownQuantityError(SolveError, KeyError):
    """Neither a state nor an observable: ``name``, ``known``."""

    name: str
    known: List[str]

class MonteCarloError(FpsolveError):
    """A Monte Carlo run refused or failed."""

class SweepError(FpsolveError):
    """A sweep that cannot run: ``argument`` or ``name`` when it is about one."""

    argument: Optional[str]
    name: Optional[str]

class JobError(FpsolveError):
    """The main job failed as a whole (its output directory, …)."""

class _Model:
    @staticmethod
    def load(path: Union[str, os.PathLike]) -> "_Model": ...
    @staticmethod
    def from_text(text: str, path: Optional[str] = None) -> "_Model": ...
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def path(self) -> Optional[os.PathLike]: ...
    @property
    def states(self) -> List[str]: ...
    @property
    def observables(self) -> List[str]: ...
    def parameters(self, set: Optional[Mapping[str, _Value]] = None) -> List[Tuple[str, float]]: ...
    def check(self, set: Optional[Mapping[str, _Value]] = None) -> str: ...
    def solve(
        self,
        method: str,
        degree: int,
        cells: Optional[Tuple[int, int]] = None,
        set: Optional[Mapping[str, _Value]] = None,
        domain: Optional[str] = None,
        tol: Optional[float] = None,
    ) -> "_Solution": ...
    def simulate(
        self,
        samples: int,
        seed: int,
        threads: Optional[int],
        dt: Optional[float],
        spacing: Optional[float],
        trajectories: Optional[int],
        bins: Optional[int],
        grids: Sequence[Tuple[str, float, float, int]],
        levels: Sequence[Tuple[str, Sequence[float]]] = ...,
        impact_speeds: Optional[Tuple[float, float, int]] = None,
        set: Optional[Mapping[str, _Value]] = None,
        progress: Optional[Callable[[int, int], Any]] = None,
    ) -> Tuple[str, List[str], List[str]]: ...
    def simulate_shard(
        self,
        index: int,
        count: int,
        samples: int,
        seed: int,
        threads: Optional[int],
        dt: Optional[float],
        spacing: Optional[float],
        trajectories: Optional[int],
        bins: Optional[int],
        grids: Sequence[Tuple[str, float, float, int]],
        levels: Sequence[Tuple[str, Sequence[float]]] = ...,
        impact_speeds: Optional[Tuple[float, float, int]] = None,
        set: Optional[Mapping[str, _Value]] = None,
    ) -> str: ...
    @property
    def text(self) -> str: ...

class _Solution:
    @property
    def method(self) -> str: ...
    @property
    def degree(self) -> Optional[int]: ...
    @property
    def joint_states(self) -> List[str]: ...
    @property
    def quantities(self) -> List[str]: ...
    def pdf(self, name: str, x: _Float64) -> _Float64: ...
    def joint(self, x1: _Float64, x2: _Float64) -> _Float64: ...
    def marginal(self, name: str) -> Tuple[_Float64, _Float64]: ...
    def moments_json(self, name: str) -> str: ...
    def tail_probability(self, name: str, a: float) -> Optional[float]: ...
    def coefficients(self) -> Tuple[List[Tuple[int, int]], List[float]]: ...
    def report_json(self) -> str: ...

class _JobOutcome(TypedDict):
    table: str
    files: List[os.PathLike]
    flags: List[str]

def sweep_json(
    model: _Model,
    swept: Sequence[Tuple[str, Sequence[float]]],
    fixed: Sequence[Tuple[str, str]],
    methods: Sequence[str],
    degree: int,
    cells: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    shard: Optional[Tuple[int, int]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> str: ...
def merge_sweep_json(shards: Sequence[str]) -> str: ...
def passage(
    model: _Model,
    safe: Optional[str],
    start: Union[None, str, Tuple[float, float]],
    times: Union[None, str, Sequence[float]],
    cells: Optional[Tuple[int, int]],
    method: Union[str, Sequence[str]],
    paths: int,
    dt: float,
    horizon: Optional[float],
    seed: int,
    threads: Optional[int],
    set: Optional[Mapping[str, _Value]] = None,
    domain: Optional[str] = None,
    mean_only: bool = False,
) -> Tuple[str, List[Tuple[str, List[float], List[float]]], List[Tuple[str, str]], List[str]]: ...
class _Transient:
    def summary_json(self) -> str: ...
    def quantities(self) -> List[str]: ...
    def moments(self) -> List[Tuple[str, _Float64]]: ...
    def pdf(self, axis: int) -> List[Tuple[str, _Float64]]: ...
    def warnings(self) -> List[Tuple[str, bool]]: ...
    def write(self, out: Union[str, os.PathLike], figures: bool = True) -> os.PathLike: ...

def transient(
    model: _Model,
    times: Union[str, Sequence[float]],
    cells: Optional[Tuple[int, int]],
    domain: Optional[str],
    tol: Optional[float],
    initial: Optional[str],
    method: str,
    trajectories: int,
    dt: float,
    seed: int,
    threads: Optional[int],
    set: Optional[Mapping[str, _Value]] = None,
    period: Optional[float] = None,
) -> _Transient: ...
def merge_mc_json(shards: Sequence[str]) -> Tuple[str, List[str], List[str]]: ...
def run_job(
    model: _Model,
    out: Union[str, os.PathLike],
    methods: Optional[Sequence[str]] = None,
    degrees: Sequence[int] = ...,
    cells: Optional[Tuple[int, int]] = None,
    set: Optional[Mapping[str, _Value]] = None,
    figures: bool = True,
    tol: Optional[float] = None,
) -> _JobOutcome: ...
