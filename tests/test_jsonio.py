"""Strict JSON: non-finite floats become null with a warning naming where they were."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocapkit.jsonio import NonFiniteWarning, to_json_text, to_jsonable


def test_nan_and_inf_become_null_with_a_warning_naming_the_key_path() -> None:
    obj = {"a": 1.0, "b": {"c": float("nan")}, "d": [0.5, float("inf")], "e": -np.inf}
    with pytest.warns(NonFiniteWarning) as rec:
        text = to_json_text(obj)
    assert json.loads(text) == {"a": 1.0, "b": {"c": None}, "d": [0.5, None], "e": None}
    msg = str(rec[0].message)
    for path in ("b.c", "d[1]", "e"):
        assert path in msg
    assert "NaN" not in text and "Infinity" not in text


def test_numpy_scalars_arrays_tuples_and_paths() -> None:
    obj = {
        "i": np.int64(3),
        "f": np.float32(0.5),
        "b": np.bool_(True),
        "arr": np.arange(4).reshape(2, 2),
        "f32": np.array([1.5, 2.5], dtype=np.float32),
        "t": (1, 2),
        "p": Path("x") / "y.bvh",
        "scalar0d": np.array(2.0),
    }
    out = to_jsonable(obj)
    assert out == {
        "i": 3,
        "f": 0.5,
        "b": True,
        "arr": [[0, 1], [2, 3]],
        "f32": [1.5, 2.5],
        "t": [1, 2],
        "p": str(Path("x") / "y.bvh"),
        "scalar0d": 2.0,
    }
    assert type(out["i"]) is int and type(out["f"]) is float and type(out["b"]) is bool
    json.dumps(out, allow_nan=False)  # plain Python values only


def test_non_finite_inside_numpy_arrays() -> None:
    a = np.array([[0.0, np.nan], [np.inf, 1.0]], dtype=np.float32)
    with pytest.warns(NonFiniteWarning, match=r"m\.mdm\[0\]\[1\].*m\.mdm\[1\]\[0\]"):
        out = to_jsonable({"m": {"mdm": a}})
    assert out == {"m": {"mdm": [[0.0, None], [None, 1.0]]}}
    with pytest.warns(NonFiniteWarning, match="more"):
        to_jsonable(np.full(20, np.nan))


def test_finite_input_gives_no_warning_and_objects_with_to_json() -> None:
    class R:
        def to_json(self) -> dict:
            return {"x": np.float64(1.25)}

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert json.loads(to_json_text([R(), {"k": 2}])) == [{"x": 1.25}, {"k": 2}]
    with pytest.raises(TypeError, match="set"):
        to_json_text({"s": {1, 2}})
