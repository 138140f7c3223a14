"""Strict JSON for everything wrt writes (benchmark rows, render and frame logs, BVH reports): a NaN or infinite
number is written as ``null``. Python's ``json`` writes them as bare ``NaN`` and ``Infinity``, which are no JSON:
``jq``, ``JSON.parse`` and other strict readers reject the whole file for one of them."""

from __future__ import annotations

import json
import math


def finite_or_none(value):
    """``value`` with every NaN or infinite float in it (in dicts, lists and tuples too) replaced by None."""
    if isinstance(value, float):  # numpy's float64 too: it is a float
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_none(v) for v in value]
    return value


def strict_json(value, **kwargs) -> str:
    """``json.dumps(value, **kwargs)`` with null for each NaN or infinite number (:func:`finite_or_none`)."""
    return json.dumps(finite_or_none(value), allow_nan=False, **kwargs)
