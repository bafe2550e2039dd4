"""collected_warnings: each thread's warnings apart from the others', nested collections, and
what it passes on."""

from __future__ import annotations

import threading
import warnings

from mocapkit.core.thread_warnings import collected_warnings


def test_threads_collect_their_own_and_pass_them_on() -> None:
    barrier = threading.Barrier(4)
    got: dict[int, list[str]] = {}

    def work(i: int) -> None:
        with collected_warnings() as caught:
            barrier.wait()  # all four inside at once
            for k in range(5):
                warnings.warn(f"thread {i} warning {k}", UserWarning, stacklevel=1)
                barrier.wait()
        got[i] = [str(w.message) for w in caught]

    with warnings.catch_warnings(record=True) as outer:
        warnings.simplefilter("always")
        threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    for i in range(4):
        assert got[i] == [f"thread {i} warning {k}" for k in range(5)]
    assert sorted(str(w.message) for w in outer) == sorted(m for ms in got.values() for m in ms)


def test_nested_collections_and_one_that_keeps_them() -> None:
    with warnings.catch_warnings(record=True) as outer:
        warnings.simplefilter("always")
        with collected_warnings(forward=False) as kept:
            with collected_warnings() as inner:
                warnings.warn("a", UserWarning, stacklevel=1)
            warnings.warn("b", UserWarning, stacklevel=1)
        warnings.warn("c", UserWarning, stacklevel=1)
    assert [str(w.message) for w in inner] == ["a"]
    assert [str(w.message) for w in kept] == ["a", "b"]
    assert [str(w.message) for w in outer] == ["c"]  # the others were kept, not passed on


def test_every_warning_shown_takes_out_only_its_own_filter() -> None:
    """Reviewer: leaving put back a copy of the filters taken on entry, so a filter added
    meanwhile (a library's own, at import) was lost for good."""
    from mocapkit.core.thread_warnings import every_warning_shown

    with warnings.catch_warnings():
        warnings.resetwarnings()
        before = list(warnings.filters)
        with every_warning_shown():
            assert warnings.filters[0][0] == "always"
            with every_warning_shown():  # nested (or another thread's task): one entry
                assert sum(f[0] == "always" for f in warnings.filters) == 1
            warnings.filterwarnings("ignore", message="added meanwhile")
        assert warnings.filters[0][:1] == ("ignore",) and "always" not in [
            f[0] for f in warnings.filters
        ]
        assert warnings.filters[1:] == before
