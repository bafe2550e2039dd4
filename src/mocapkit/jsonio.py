"""Strict JSON: the one writer every mocapkit JSON output goes through.

``json.dumps`` writes ``NaN`` and ``Infinity`` by default, which are not JSON (browsers, ``jq``
and most parsers reject them), and it cannot write NumPy scalars or arrays. :func:`to_jsonable`
turns a result into plain JSON values: NumPy scalars and arrays become Python numbers and lists,
tuples become lists, paths become strings, and every non-finite float becomes ``null`` with a
:class:`NonFiniteWarning` naming where it was (``segments[3].peak``). :func:`to_json_text`
then writes it with ``allow_nan=False``, so a non-finite value can never slip through.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["NonFiniteWarning", "to_json_text", "to_jsonable"]

_MAX_NAMED = 8  # key paths named in one warning


class NonFiniteWarning(UserWarning):
    """A NaN or infinite value was written as JSON ``null``."""


def _key(path: str, key: object) -> str:
    k = str(key)
    if k.isidentifier():
        return f"{path}.{k}" if path else k
    return f"{path}[{json.dumps(k)}]"


def _convert(obj: Any, path: str, bad: list[str]) -> Any:
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        if math.isfinite(v):
            return v
        bad.append(path or "(top level)")
        return None
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind == "f" and obj.size and not np.isfinite(obj).all():
            bad_cells = ~np.isfinite(obj)
            where = np.argwhere(bad_cells)
            bad += [path + "".join(f"[{int(n)}]" for n in idx) for idx in where]
            cells = obj.astype(object)  # Python floats
            cells[bad_cells] = None
            return cells.tolist()
        return _convert(obj.tolist(), path, bad)
    if isinstance(obj, Mapping):
        return {str(k): _convert(v, _key(path, k), bad) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_convert(v, f"{path}[{i}]", bad) for i, v in enumerate(obj)]
    if isinstance(obj, PurePath):
        return str(obj)
    to_json = getattr(obj, "to_json", None)
    if callable(to_json):
        return _convert(to_json(), path, bad)
    raise TypeError(f"{path or 'value'}: {type(obj).__name__} is not JSON-serialisable")


def to_jsonable(obj: Any) -> Any:
    """``obj`` as plain JSON values (dict, list, str, int, float, bool, None).

    NumPy scalars and arrays, tuples, paths and objects with a ``to_json()`` method are
    converted; NaN and infinities become None, with one :class:`NonFiniteWarning` that names
    their key paths. Anything else raises TypeError.
    """
    bad: list[str] = []
    out = _convert(obj, "", bad)
    if bad:
        shown = ", ".join(bad[:_MAX_NAMED])
        if len(bad) > _MAX_NAMED:
            shown += f" and {len(bad) - _MAX_NAMED} more"
        warnings.warn(
            f"{len(bad)} non-finite value{'s' if len(bad) > 1 else ''} written as null in JSON: "
            f"{shown}",
            NonFiniteWarning,
            stacklevel=3,
        )
    return out


def to_json_text(obj: Any, indent: int | None = 2, **kwargs: Any) -> str:
    """Strict JSON text of ``obj`` (see :func:`to_jsonable`): never NaN or Infinity.

    ``indent`` and other keyword arguments (``separators``, ``sort_keys``) go to
    :func:`json.dumps`.
    """
    return json.dumps(to_jsonable(obj), indent=indent, allow_nan=False, **kwargs)
