"""Each thread's warnings, apart from other threads'.

``warnings.catch_warnings`` swaps the process's ``showwarning`` and filters and puts back what
it found on leaving. Two tasks on one Dask worker's threads therefore restore each other's: a
take's warnings went into another take's list, or to the worker's standard error and never to
the client (a worker with 4 threads running 40 tasks of 3 warnings each: 14 of the 120 were
lost). :func:`collected_warnings` instead installs, once, a ``showwarning`` that hands a
warning to the collections open in the thread that raised it, and any other warning on to the
``showwarning`` it replaced.

Python before 3.14 has no per-thread warning filters: code that itself enters
``catch_warnings`` (to silence one category) still swaps them for every thread while inside.
"""

from __future__ import annotations

import contextlib
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["collected_warnings", "every_warning_shown"]

_local = threading.local()  # .stack: this thread's open collections, innermost last
_lock = threading.Lock()
_previous: Any = None  # the showwarning that _show replaced
_shown_by = 0  # how many every_warning_shown() are open


def _show(
    message: Any, category: Any, filename: str, lineno: int, file: Any = None, line: Any = None
) -> None:
    stack = getattr(_local, "stack", None) or []
    msg = warnings.WarningMessage(message, category, filename, lineno, file, line)
    for caught, forward in reversed(stack):
        caught.append(msg)  # the same object in each: a collection can tell an inner one's
        if not forward:
            return
    previous = _previous
    if getattr(_local, "passing_on", False) or previous is None or previous is _show:
        # a showwarning installed over this one that calls it back: write it plainly
        warnings._showwarning_orig(message, category, filename, lineno, file, line)  # type: ignore[attr-defined]
        return
    _local.passing_on = True
    try:
        previous(message, category, filename, lineno, file, line)
    finally:
        _local.passing_on = False


def _install() -> None:
    global _previous
    with _lock:
        if warnings.showwarning is not _show:  # first use, or a catch_warnings put its own back
            _previous = warnings.showwarning
            warnings.showwarning = _show


@contextmanager
def collected_warnings(forward: bool = True) -> Iterator[list[warnings.WarningMessage]]:
    """The warnings this thread shows while inside (``warnings.WarningMessage`` items, in
    order); with ``forward`` they also go on where they would have gone (an enclosing
    collection in this thread, else the process's ``showwarning``: a command's own collection,
    or standard error), without it only here. Other threads' warnings are untouched. Whether a
    warning is shown at all is still the process's filters' decision (a worker that must see
    every warning of every task sets ``"always"``)."""
    _install()
    stack = getattr(_local, "stack", None)
    if stack is None:
        stack = _local.stack = []
    caught: list[warnings.WarningMessage] = []
    stack.append((caught, forward))
    try:
        yield caught
    finally:
        stack.pop()


@contextmanager
def every_warning_shown() -> Iterator[None]:
    """Show every warning every time while inside (an ``"always"`` filter first in the list,
    which a collection needs: under the default filters a warning already shown from the same
    line is not shown again, so a later task's report would lack it). Process-wide, as filters
    are; counted, so that tasks running side by side on threads share one entry, which the last
    to leave takes out again: only that entry, so filters added meanwhile (a library's own at
    import) stay (reviewer: restoring a copy of the list threw them away)."""
    global _shown_by
    entry = ("always", None, Warning, None, 0)
    with _lock:
        if _shown_by == 0:
            warnings.filters.insert(0, entry)
            warnings._filters_mutated()  # type: ignore[attr-defined]  # as simplefilter does
        _shown_by += 1
    try:
        yield
    finally:
        with _lock:
            _shown_by -= 1
            if _shown_by == 0:
                with contextlib.suppress(ValueError):  # a catch_warnings put the list back
                    warnings.filters.remove(entry)  # the first: ours, put first
                warnings._filters_mutated()  # type: ignore[attr-defined]
