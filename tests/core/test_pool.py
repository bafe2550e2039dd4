"""The thread-pool map under in-process library jobs and graph tiles: input order, progress
per finished task, a task's error at its turn."""

from __future__ import annotations

import threading
import time

import pytest

from mocapkit.core.pool import ordered_imap, usable_threads


def _slow_first(x: int) -> tuple[int, str]:
    time.sleep(0.05 if x == 0 else 0.0)  # the first item finishes last
    return x * x, threading.current_thread().name


@pytest.mark.parametrize("threads", [1, 2, 4])
def test_results_in_input_order_progress_per_task(threads):
    seen: list[tuple[int, int]] = []
    out = list(ordered_imap(_slow_first, range(7), threads, lambda d, t: seen.append((d, t))))
    assert [o[0] for o in out] == [x * x for x in range(7)]
    assert seen == [(n, 7) for n in range(1, 8)]
    names = {o[1] for o in out}
    assert (len(names) > 1) == (usable_threads(threads) > 1 and threads > 1)


def test_error_raised_at_its_turn_and_rest_cancelled():
    started: list[int] = []

    def fn(x: int) -> int:
        started.append(x)
        if x == 2:
            raise ValueError("item 2 is bad")
        time.sleep(0.01)
        return x

    it = ordered_imap(fn, range(50), 2)
    assert [next(it), next(it)] == [0, 1]
    with pytest.raises(ValueError, match="item 2 is bad"):
        next(it)
    it.close()
    assert len(started) < 50


def test_empty_and_single():
    assert list(ordered_imap(abs, [], 4)) == []
    assert list(ordered_imap(abs, [-3], 4)) == [3]
