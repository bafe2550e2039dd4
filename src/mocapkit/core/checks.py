"""Checks of values a user passes in (API arguments, settings dataclasses), shared so that every
entry point refuses the same things with the same words: NaN, a string where a switch is meant
(``"no"`` is truthy), a fraction where a frame number is meant (it used to be truncated)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["check_field_types", "whole_number"]


def whole_number(x: object, what: str) -> int:
    """``x`` as an int, or a ValueError ``"<what> must be a whole number, got <x>"``: ints and
    integral floats pass (60.0 is frame 60), booleans, fractions and other types do not."""
    if not isinstance(x, bool | np.bool_):
        if isinstance(x, int | np.integer):
            return int(x)
        if isinstance(x, float | np.floating) and float(x).is_integer():
            return int(x)
    raise ValueError(f"{what} must be a whole number, got {x!r}")


def check_field_types(obj: object) -> None:
    """ValueError naming the first field of the dataclass ``obj`` whose value does not fit its
    annotation (as a string, under ``from __future__ import annotations``): ``bool`` must be a
    boolean, ``int`` a whole number (not a boolean), ``float`` a finite number (or None where
    the annotation allows it)."""
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        v = getattr(obj, f.name)
        kind = str(f.type)
        if kind == "bool" and not isinstance(v, bool | np.bool_):
            raise ValueError(f"{f.name} must be True or False, got {v!r}")
        if kind == "int":
            whole_number(v, f.name)
        if kind.startswith("float") and not (v is None and "None" in kind):
            number = isinstance(v, int | float | np.integer | np.floating)
            if isinstance(v, bool | np.bool_) or not (number and math.isfinite(v)):
                raise ValueError(f"{f.name} must be a finite number, got {v!r}")
