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
    tol: Optional[float] = None,
    **set: Any,
) -> Dict[str, Any]:
    """Runs what ``fpsolve MODEL --out OUT`` runs (without Monte Carlo) and writes the same
    files the same way: staged, then moved into place whole.

    Parameters
    ----------
    model : Model, str or os.PathLike
        The model, or its file.
    out : str or os.PathLike
        The output directory (replaced as a whole; one holding foreign files is refused).
    methods : sequence of str, optional
        Default: EPC and the grid, with EPC-impact where EPC cannot use the impact law, each
        only where it applies. Named methods must all apply.
    degrees : sequence of int
        The EPC degrees.
    cells : (int, int), optional
        The grid's cells. Without ``cells`` or ``tol`` the grid chooses its cells for an
        estimated L1 error of at most 1e-3, as the command line does.
    figures : bool
        Draw the figures (png and svg) beside the CSV files.
    tol : float, optional
        The grid's L1 tolerance (``--tol``): it chooses its box and cells until its estimate
        is below it; not with ``cells``, and only when the grid runs.
    **set : number or str
        Parameter overrides by keyword.

    Returns
    -------
    dict
        ``{"table": the table the command line prints, "files": paths written, "flags": what
        is flagged (the reasons the command line would exit 1)}``. The files are
        ``pdf_<state>.csv``, ``pdf_<observable>.csv``, ``summary.json``, crossing rates and
        figures.

    Raises
    ------
    NotApplicableError
        A named method does not apply (every one that does not is named).
    JobError
        The output directory cannot be used, or the job cannot run.
    KeyboardInterrupt
        Ctrl-C: the call returns within 0.1 s; the job in progress finishes unseen in the
        background, and nothing of it is written (the output directory stays locked, and
        fpsolve's worker threads busy, until it ends).
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
        None if tol is None else float(tol),
    )
    result["files"] = [str(f) for f in result["files"]]
    return result
