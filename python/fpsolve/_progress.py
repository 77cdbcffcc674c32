"""Progress of a long call (a sweep's points, a Monte Carlo run's statistics batches): what
``progress=`` accepts, and the printer ``progress=True`` uses."""

from __future__ import annotations

import sys
from typing import Any, Callable, Optional, Union

ProgressArg = Union[None, bool, Callable[[int, int], Any]]


class _Printer:
    """Writes ``what: done/total (p%)`` to stderr: in place on a terminal, else one line per
    tenth (a log or a notebook keeps ten lines, not thousands)."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.tty = sys.stderr.isatty()
        self.last = -1

    def __call__(self, done: int, total: int) -> None:
        percent = 100 * done // total if total else 100
        step = percent if self.tty else 10 * (percent // 10)
        if step == self.last:
            return
        self.last = step
        text = f"{self.what}: {done}/{total} ({percent}%)"
        if self.tty:
            sys.stderr.write("\r" + text + ("\n" if done >= total else ""))
        else:
            sys.stderr.write(text + "\n")
        sys.stderr.flush()


class _Bar:
    """A tqdm bar (``tqdm.auto``: a widget in a notebook), opened at the first report."""

    def __init__(self, what: str, tqdm: Any) -> None:
        self.what = what
        self.tqdm = tqdm
        self.bar: Any = None

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = self.tqdm(total=total, desc=self.what)
        self.bar.update(done - self.bar.n)
        if done >= total:
            self.bar.close()


def _tqdm() -> Any:
    """``tqdm.auto.tqdm`` when tqdm is installed, else ``None``."""
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm


def callback(progress: ProgressArg, what: str) -> Optional[Callable[[int, int], Any]]:
    """The callable for ``progress=``: ``None``/``False`` none, ``True`` a tqdm bar when tqdm
    is installed, else a printer to stderr, a callable ``f(done, total)`` itself (called from
    the calling thread, at most every 50 ms and once at the end; an exception it raises stops
    the run and is raised)."""
    if progress is None or progress is False:
        return None
    if progress is True:
        tqdm = _tqdm()
        return _Printer(what) if tqdm is None else _Bar(what, tqdm)
    if callable(progress):
        return progress
    raise TypeError(f"progress must be None, True or a callable f(done, total), not {progress!r}")
