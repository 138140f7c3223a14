"""Strict JSON for everything wrt writes (benchmark rows, render and frame logs, BVH reports): a NaN or infinite
number is written as ``null``. Python's ``json`` writes them as bare ``NaN`` and ``Infinity``, which are no JSON:
``jq``, ``JSON.parse`` and other strict readers reject the whole file for one of them. Numpy values (a float32
timing, an int64 count, a bool_ flag, an array of them) are written as the Python values they hold, which
``json.dumps`` refuses."""

from __future__ import annotations

import json
import math

import numpy as np


def finite_or_none(value):
    """``value`` with every NaN or infinite float in it (in dicts, lists and tuples too) replaced by None, and every
    numpy scalar or array in it replaced by the Python value or nested list it holds."""
    if isinstance(value, float):  # numpy's float64 too: it is a float
        return value if math.isfinite(value) else None
    if isinstance(value, (np.generic, np.ndarray)):  # np.float32(nan) -> nan -> None; arrays -> nested lists
        return finite_or_none(value.tolist())
    if isinstance(value, dict):
        return {k.item() if isinstance(k, np.generic) else k: finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_none(v) for v in value]
    return value


def strict_json(value, **kwargs) -> str:
    """``json.dumps(value, **kwargs)`` with null for each NaN or infinite number (:func:`finite_or_none`)."""
    return json.dumps(finite_or_none(value), allow_nan=False, **kwargs)
