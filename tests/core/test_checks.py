"""The shared checks of user-given values (mocapkit.core.checks)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from mocapkit.core.checks import check_field_types, whole_number


def test_whole_number_passes_whole_values_and_names_what_it_refuses() -> None:
    assert whole_number(60, "frame") == 60
    assert whole_number(np.int64(60), "frame") == 60
    assert whole_number(60.0, "frame") == 60
    for bad in (60.5, True, np.bool_(True), "60", None, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="frame must be a whole number"):
            whole_number(bad, "frame")


@dataclass(frozen=True)
class _Settings:
    switch: bool = True
    count: int = 2
    size: float = 1.0
    limit: float | None = None

    def __post_init__(self) -> None:
        check_field_types(self)


def test_check_field_types_refuses_what_the_annotation_does_not_allow() -> None:
    _Settings()
    _Settings(switch=np.bool_(False), count=np.int64(3), size=2, limit=0.5)
    for field, bad in (("switch", "no"), ("switch", 1), ("count", 2.5), ("count", True),
                       ("size", float("nan")), ("size", float("inf")), ("size", True),
                       ("size", "1"), ("limit", float("nan"))):  # fmt: skip
        with pytest.raises(ValueError, match=field):
            _Settings(**{field: bad})
