import sys

import pytest

from mocapkit._optional import require


def test_require_imports_present_module() -> None:
    assert require("json").dumps([1]) == "[1]"


def test_missing_optional_dependency_names_the_extra(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes "import matplotlib" fail
    with pytest.raises(ImportError, match=r"pip install 'mocapkit\[plot\]'"):
        require("matplotlib")
