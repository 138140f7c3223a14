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
