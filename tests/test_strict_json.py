"""Strict JSON (wrt.strict_json): every file wrt writes parses with strict readers."""

import json
import math

import numpy as np

from wrt.strict_json import strict_json


def refuse(name):
    raise ValueError(f"{name} is not JSON")


def test_non_finite_numbers_are_null_at_any_depth():
    value = {"a": math.nan, "b": [1.5, math.inf, {"c": -math.inf}], "d": (np.float64("nan"), 2), "e": "NaN", "f": 3}
    text = strict_json(value, indent=1)
    assert json.loads(text, parse_constant=refuse) == {"a": None, "b": [1.5, None, {"c": None}], "d": [None, 2],
                                                       "e": "NaN", "f": 3}


def test_numpy_scalars_and_arrays_are_their_python_values():
    value = {"ms": np.float32(1.5), "rays": np.int64(3), "ok": np.bool_(True), np.int32(7): "key",
             "image": np.array([[1.0, np.nan], [np.inf, -2.0]], dtype=np.float32), "ids": np.arange(3, dtype=np.uint8),
             "miss": np.float32(np.nan), "far": np.float16(-np.inf), "row": [np.float64(np.nan), np.array(4)]}
    assert json.loads(strict_json(value), parse_constant=refuse) == {
        "ms": 1.5, "rays": 3, "ok": True, "7": "key", "image": [[1.0, None], [None, -2.0]], "ids": [0, 1, 2],
        "miss": None, "far": None, "row": [None, 4]}


def test_python_values_are_written_as_json_writes_them():
    # bench rows, render logs and BVH reports of plain Python values keep their bytes
    value = {"a": 0.1, "b": [1, 2.5e-300, True, None, "x"], "c": {"d": (3, -0.0)}, "e": 1e22}
    for kwargs in ({}, {"indent": 1}, {"indent": 2, "sort_keys": True}):
        assert strict_json(value, **kwargs) == json.dumps(value, **kwargs)
