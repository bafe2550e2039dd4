"""Helpers shared by test files (importable because pytest puts tests/ on sys.path)."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path
from types import ModuleType

REPO_ROOT = Path(__file__).resolve().parent.parent


def load_file(path: str | Path, name: str | None = None) -> ModuleType:
    """Import a Python file by path: a test folder's reference twin (``naive.py``) or a
    ``bench/`` script. Test folders are not packages (pytest runs in importlib mode)."""
    path = Path(path)
    spec = importlib.util.spec_from_file_location(name or f"loaded_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load_sibling(test_file: str, stem: str) -> ModuleType:
    """``load_sibling(__file__, "naive")``: the module ``naive.py`` beside a test file."""
    folder = Path(test_file).resolve().parent
    return load_file(folder / f"{stem}.py", f"{folder.name}_{stem}")


def load_bench(stem: str) -> ModuleType:
    """A script of the repository's ``bench/`` folder."""
    return load_file(REPO_ROOT / "bench" / f"{stem}.py", f"bench_{stem}")


def shared_dir() -> Path:
    """The shared folder: ``$MOCAPKIT_SHARED`` if set, else ``../shared`` beside the repo."""
    env = os.environ.get("MOCAPKIT_SHARED")
    return Path(env).expanduser() if env else REPO_ROOT.parent / "shared"


def shared_subpath(subpath: str = "") -> Path:
    """``subpath`` in the shared ``data/`` folder (``"bandai1/data"``), else in the shared folder
    itself; it may not exist (tests ask the ``shared_path`` fixture, which skips or fails)."""
    root = shared_dir()
    inside = root / "data" / subpath
    return inside if inside.exists() else root / subpath


def require_tool(found: bool, flag: str, missing: str) -> None:
    """Skip with ``missing`` (the reason) where a consumer program is absent, unless the
    environment sets ``flag`` to 1 (CI), where the test fails instead."""
    if found:
        return
    import pytest

    if os.environ.get(flag) == "1":
        pytest.fail(f"{flag}=1 but {missing}", pytrace=False)
    pytest.skip(missing)


def require_chromium() -> None:
    """Skip (or, under MOCAPKIT_REQUIRE_BROWSER=1, fail) where no Chromium is found."""
    from mocapkit.viz.browser import find_chromium

    require_tool(
        find_chromium() is not None,
        "MOCAPKIT_REQUIRE_BROWSER",
        "no Chromium found: install the Debian packages chromium and chromium-driver, or set "
        "MOCAPKIT_CHROMIUM to the binary",
    )
