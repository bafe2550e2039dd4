"""Fixtures shared by the whole test suite.

Shared data (read-only, never copied into the repository) lives in ``$MOCAPKIT_SHARED`` if that is
set, else in ``../shared`` beside the repository root; the data sets themselves sit in its
``data/`` folder (``data/bandai1/data``, ``data/bvh-corpus``). A test that needs a data set asks
for it with the ``shared_path`` fixture::

    def test_something(shared_path):
        corpus = shared_path("bvh-corpus")  # skips if the data set is absent

A missing data set skips the test, unless ``MOCAPKIT_REQUIRE_SHARED=1`` is set (CI), where it
fails instead, so that a misplaced data folder cannot turn the data-driven tests into silent skips.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest
from testsupport import shared_dir, shared_subpath


def require_shared(subpath: str = "") -> Path:
    """Path of ``subpath`` inside the shared folder, or skip (fail under MOCAPKIT_REQUIRE_SHARED=1).

    ``subpath`` is looked up in the shared ``data/`` folder first (``"bandai1/data"``,
    ``"bvh-corpus"``), then in the shared folder itself (``"data/bandai1/data"`` works too).
    """
    path = shared_subpath(subpath)
    if path.exists():
        return path
    msg = (
        f"shared data not found at {shared_dir() / 'data' / subpath}: "
        "set MOCAPKIT_SHARED or place ../shared beside the repo"
    )
    if os.environ.get("MOCAPKIT_REQUIRE_SHARED") == "1":
        pytest.fail(msg + " (MOCAPKIT_REQUIRE_SHARED=1 makes this a failure)", pytrace=False)
    pytest.skip(msg)


@pytest.fixture(name="shared_dir")
def _shared_dir_fixture() -> Path:
    """The shared folder (which may not exist; use ``shared`` or ``shared_path`` to require it)."""
    return shared_dir()


@pytest.fixture
def shared() -> Path:
    """The shared ``data/`` folder; skips (or fails, see above) when it is absent."""
    return require_shared()


@pytest.fixture
def shared_path() -> Callable[[str], Path]:
    """``shared_path("bandai1/data")``: a data set's path, skipping (or failing) when absent."""
    return require_shared
