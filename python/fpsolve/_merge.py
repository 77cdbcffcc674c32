"""fpsolve.merge: the parts of a split run joined into the unsplit run's result."""

from __future__ import annotations

import json
from typing import Sequence, Union

from . import _fpsolve
from ._montecarlo import MonteCarlo, MonteCarloShard


def merge(
    shards: Sequence[Union[MonteCarloShard, "SweepShard"]], strict: bool = False
) -> Union[MonteCarlo, "SweepResult"]:
    """Joins the parts of one split run, in any order, as ``fpsolve merge`` does.

    Parameters
    ----------
    shards : sequence of MonteCarloShard, or of SweepShard
        Every part of one run (``Model.simulate(shard=(k, n))`` for ``k`` in ``range(n)``,
        or ``sweep(..., shard=(k, n))``), each once.
    strict : bool
        For Monte Carlo parts: raise :class:`MonteCarloError` instead of warning
        :class:`MonteCarloWarning` when the merged run is flagged (as ``Model.simulate``).

    Returns
    -------
    MonteCarlo or SweepResult
        The unsplit run's result, bit for bit.

    Raises
    ------
    MonteCarloError, SweepError
        Parts of different runs, a part missing or given twice, a damaged part: checked
        (by the parts' digests) before anything is merged, and named.

    Examples
    --------
    >>> parts = [model.simulate(samples=10**5, shard=(k, 4)) for k in range(4)]  # doctest: +SKIP
    >>> mc = fpsolve.merge(parts)                                                  # doctest: +SKIP
    """
    from ._sweep import SweepResult, SweepShard

    shards = list(shards)
    if not shards:
        raise ValueError("merge: no shards given")
    if all(isinstance(s, MonteCarloShard) for s in shards):
        text, flags, notes = _fpsolve.merge_mc_json([s.json for s in shards])
        mc = MonteCarlo._from_json(text, flags, notes)
        mc._judge(bool(strict))
        return mc
    if all(isinstance(s, SweepShard) for s in shards):
        return SweepResult(json.loads(_fpsolve.merge_sweep_json([s.json for s in shards])))
    kinds = sorted({type(s).__name__ for s in shards})
    raise TypeError(f"merge: expected the MonteCarloShard or SweepShard parts of one run, got {', '.join(kinds)}")
