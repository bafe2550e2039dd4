"""Tasks side by side on this process's threads, results in input order: the one thread-pool
map under the in-process runs of library jobs (:class:`mocapkit.batch.Runner` with threads) and
of the graph's tile tasks."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor, as_completed
from typing import Any

__all__ = ["cores", "ordered_imap", "usable_threads"]


def cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def usable_threads(wanted: int) -> int:
    """``wanted`` threads, or 1 where numba's threading layer is its own "workqueue": that layer
    aborts the process when parallel kernels are launched from two threads at once ("tbb" and
    "omp" are thread-safe)."""
    if wanted <= 1:
        return 1
    import numba
    from numba.np.ufunc import parallel

    parallel._launch_threads()
    return 1 if numba.threading_layer() == "workqueue" else wanted


def ordered_imap(
    fn: Callable[[Any], Any],
    items: Iterable[Any],
    threads: int,
    on_done: Callable[[int, int], None] | None = None,
) -> Iterator[Any]:
    """``fn(item)`` for every item on up to ``threads`` threads (:func:`usable_threads`),
    yielding each result in input order as soon as it and those before it are done;
    ``on_done(done, total)`` after each finished task, in completion order. An exception of a
    task is raised when its turn comes; the tasks not started then are cancelled."""
    items = list(items)
    total = len(items)
    threads = usable_threads(max(1, min(int(threads), total)))
    if threads == 1:
        for n, item in enumerate(items, start=1):
            out = fn(item)
            if on_done is not None:
                on_done(n, total)
            yield out
        return
    with ThreadPoolExecutor(threads) as pool:
        futures = [pool.submit(fn, item) for item in items]
        index = {f: i for i, f in enumerate(futures)}
        done: dict[int, Any] = {}
        nxt = count = 0
        try:
            for fut in as_completed(futures):
                done[index[fut]] = fut
                count += 1
                if on_done is not None:
                    on_done(count, total)
                while nxt in done:
                    yield done.pop(nxt).result()
                    nxt += 1
        finally:
            for f in futures:
                f.cancel()
