"""fpsolve.run_job: the command line's main job from Python."""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Sequence, Union

from . import _fpsolve
from ._model import Model


def run_job(
    model: Union[Model, str, os.PathLike],
    out: Union[str, os.PathLike],
    methods: Optional[Sequence[str]] = None,
    degrees: Sequence[int] = (2, 4),
    cells: Optional[Sequence[int]] = None,
    figures: bool = True,
    **set: Any,
) -> Dict[str, Any]:
    """Runs what ``fpsolve MODEL --out OUT`` runs (without Monte Carlo) and writes the same
    files (``pdf_<state>.csv`` and ``pdf_<observable>.csv``, ``summary.json``, figures) the
    same way: staged, then moved into place whole.

    ``methods`` defaults to EPC and the grid, with EPC-impact where EPC cannot use the impact
    law, each only where it applies; named methods must all apply (else
    :class:`NotApplicableError`, naming every one that does not). Returns ``{"table": the table the
    command line prints, "files": paths written, "flags": what is flagged (the reasons the
    command line would exit 1)}``. Ctrl-C is honoured once the job finishes (nothing is
    written then).
    """
    if not isinstance(model, Model):
        model = Model.load(model)
    cells_t = None if cells is None else (int(cells[0]), int(cells[1]))
    result = _fpsolve.run_job(
        model._inner,
        os.fspath(out),
        None if methods is None else list(methods),
        [int(d) for d in degrees],
        cells_t,
        set,
        bool(figures),
    )
    result["files"] = [str(f) for f in result["files"]]
    return result
