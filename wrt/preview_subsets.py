"""Which of too many things a preview draws: an even subset spread over the scene, not the first ones.

A preview draws at most a budget of analytic shapes, instances and lights. Taken in order, the first of them filled
one corner of a big scene (a Points prim's spheres or a PointInstancer's instances are usually written row by row,
or cell by cell), so the view showed a corner as if it were the whole scene. The subsets here take an even stride
through the order and, where places are known, the ones reaching furthest along each axis, so that the drawn box is
the scene's.
"""

from __future__ import annotations

import numpy as np


def even_rows(total: int, budget: int) -> np.ndarray:
    """``(min(total, budget),)`` int64 rows of ``range(total)``, ascending, evenly spaced, the first and (for a budget
    of two or more) the last among them."""
    if budget >= total:
        return np.arange(total, dtype=np.int64)
    if budget <= 0:
        return np.zeros(0, np.int64)
    if budget == 1:
        return np.zeros(1, np.int64)
    # Integer arithmetic: a stride of at least 1 keeps the rows distinct (np.round's half-to-even made 1.5 and 2.5
    # the same row).
    return np.arange(budget, dtype=np.int64) * (total - 1) // (budget - 1)


def spread_rows(centres, budget: int) -> np.ndarray:
    """At most ``budget`` ascending int64 rows of ``centres`` (``(N, 3)`` float, world space): those furthest along
    -x, +x, -y, +y, -z and +z, then an even stride (:func:`even_rows`) through the others for the rest of the
    budget."""
    centres = np.asarray(centres, np.float64).reshape(-1, 3)
    if not 0 < budget < len(centres):  # all or none: no extremes to find
        return _spread(len(centres), np.zeros(0, np.int64), budget)
    return _spread(len(centres), _extremes(centres), budget)


def _extremes(centres: np.ndarray) -> np.ndarray:
    """Sorted distinct int64 rows of the centres furthest along -x, +x, -y, +y, -z and +z."""
    return np.unique(np.concatenate([centres.argmin(axis=0), centres.argmax(axis=0)]).astype(np.int64))


def _spread(total: int, extremes: np.ndarray, budget: int) -> np.ndarray:
    """:func:`spread_rows` of ``total`` things whose :func:`_extremes` are ``extremes``, in O(budget) work past them:
    the set operations over all ``total`` rows (np.setdiff1d, np.union1d) took a second each for a million
    instances, and :func:`rows_within` asks twenty budgets."""
    if budget >= total:
        return np.arange(total, dtype=np.int64)
    if budget <= 0:
        return np.zeros(0, np.int64)
    if len(extremes) >= budget:
        return np.sort(extremes[:budget])
    # Row j of the rows that are not extremes is j plus the number of extremes at or before it: extremes[i] - i
    # counts the other rows before extreme i, so that number is how many of those counts are at most j.
    j = even_rows(total - len(extremes), budget - len(extremes))
    rest = j + np.searchsorted(extremes - np.arange(len(extremes)), j, side="right")
    return np.sort(np.concatenate([extremes, rest]))


def rows_within(centres, sizes, fixed: int, budget: int) -> np.ndarray:
    """The largest :func:`spread_rows` subset of things at ``centres`` (``(N, 3)``) whose ``sizes`` (``(N,)`` int,
    triangles each), with ``fixed`` more, add up to at most ``budget``; empty where not even one fits."""
    sizes = np.asarray(sizes, np.int64)
    low, high = 0, len(sizes)  # the largest count known to fit, and one past the largest that may
    if fixed + int(sizes.sum()) <= budget:
        return np.arange(len(sizes), dtype=np.int64)
    centres = np.asarray(centres, np.float64).reshape(-1, 3)
    extremes = _extremes(centres) if len(centres) else np.zeros(0, np.int64)  # found once, not once per step
    while low < high:  # bisect the count: sums of spread subsets grow with it (up to the odd uneven size)
        middle = (low + high + 1) // 2
        if fixed + int(sizes[_spread(len(sizes), extremes, middle)].sum()) <= budget:
            low = middle
        else:
            high = middle - 1
    return _spread(len(sizes), extremes, low)
