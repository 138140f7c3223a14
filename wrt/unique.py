"""Sorted distinct values of an integer array by one sort, for arrays whose values are mostly distinct; distinct rows
of a float array by one lexsort.

numpy 2.3 and later find the distinct values of an integer array (``np.unique`` without ``return_*``) through a hash
table, then sort them. That is quick when few values repeat many times, but where most values are distinct (pair
keys, the vertex indices of a mesh) it took 10 to 20 times as long as a sort: 4 s for 1M int64 keys, 22 s for 4M
(numpy 2.4.6, this project's CPU runner), where a sort and a neighbour comparison take 0.2 s and 1 s.
``np.unique(axis=0)`` sorts the rows as a structured array, field by field in Python-level comparisons: 1.4 s for 1M
rows of 2 floats, where a lexsort of the columns takes 0.15 s.
"""

import numpy as np


def sorted_unique(values: np.ndarray) -> np.ndarray:
    """``np.unique(values)`` (flattened, ascending, without repeats) through ``np.sort``, whatever numpy's version.

    Args:
        values: an integer array of any shape (floats would keep every NaN, where ``np.unique`` keeps one).

    Returns:
        ``(U,)`` the distinct values, ascending, of ``values``' dtype.
    """
    ordered = np.sort(np.asarray(values).reshape(-1))
    if len(ordered) < 2:
        return ordered
    keep = np.empty(len(ordered), bool)
    keep[0] = True
    np.not_equal(ordered[1:], ordered[:-1], out=keep[1:])
    return ordered[keep]


def unique_rows(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(values, axis=0, return_inverse=True)`` (the inverse flattened) from one stable lexsort.

    Rows are ordered as ``np.unique`` orders them: by the first column, then the second, ..., as floats compare
    (``-0.0 == 0.0``; of equal rows the first in ``values`` is kept, where ``np.unique``'s sort kept any of them).

    Args:
        values: ``(N, K)`` numbers, ``K >= 1``, holding no NaN (``np.unique`` keeps every NaN row apart).

    Returns:
        ``(distinct, inverse)``: ``(U, K)`` the distinct rows, ascending, and ``(N,)`` intp, the row of ``distinct``
        each row of ``values`` is.
    """
    values = np.asarray(values)
    order = np.lexsort(values.T[::-1])  # the last key is the primary one: the first column
    ordered = values[order]
    starts = np.ones(len(values), bool)  # each row that differs from the one before it in that order
    np.any(ordered[1:] != ordered[:-1], axis=1, out=starts[1:])
    inverse = np.empty(len(values), np.intp)
    inverse[order] = np.cumsum(starts) - 1
    return ordered[starts], inverse
