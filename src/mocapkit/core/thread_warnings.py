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

import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["collected_warnings"]

_local = threading.local()  # .stack: this thread's open collections, innermost last
_lock = threading.Lock()
_previous: Any = None  # the showwarning that _show replaced


def _show(
    message: Any, category: Any, filename: str, lineno: int, file: Any = None, line: Any = None
) -> None:
    stack = getattr(_local, "stack", None) or []
    for caught, forward in reversed(stack):
        caught.append(warnings.WarningMessage(message, category, filename, lineno, file, line))
        if not forward:
            return
    previous = _previous
    if previous is not None and previous is not _show:
        previous(message, category, filename, lineno, file, line)


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
