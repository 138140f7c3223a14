"""Coincident twins of single-sided triangles: the other triangle at the same place that a camera ray sees where
it meets the single-sided one from behind.

The "two-sided leaf" idiom (a card made of a front face and a reversed back face, often with a material per side)
and flattened closed meshes put two single-sided triangles at the same place with opposite windings. Both are hit
at the same ``t``; the closest-hit tie rule reports one of them, and when that one is culled as a back face a
re-trace from just past ``t`` skips its twin too (:mod:`wrt.shade` takes the twin instead). A triangle's twin is a
triangle with the same three corner positions, in the same space (world, or the same prototype), that is seen from
the first one's back: double-sided, or single-sided with the reversed winding; of several, the smallest geometry id
(the one the tie rule reports first).
"""

import numpy as np

_MIX_1 = np.uint64(0xFF51AFD7ED558CCD)  # MurmurHash3 fmix64 constants
_MIX_2 = np.uint64(0xC4CEB9FE1A85EC53)
_SHIFT = np.uint64(33)


def _mix(x: np.ndarray) -> np.ndarray:
    """MurmurHash3's 64-bit finaliser (Appleby), element-wise on a uint64 array (wrapping)."""
    x = x ^ (x >> _SHIFT)
    x = x * _MIX_1
    x = x ^ (x >> _SHIFT)
    x = x * _MIX_2
    return x ^ (x >> _SHIFT)


def _point_bits(points: np.ndarray) -> np.ndarray:
    """``(V, 3)`` uint32 bit patterns of ``points`` with -0 made +0, so equal coordinates have equal bits."""
    return (np.asarray(points, np.float32) + np.float32(0.0)).view(np.uint32)


def find_twins(points: np.ndarray, indices: np.ndarray, spaces: np.ndarray, double_sided: np.ndarray):
    """Each triangle's twin (module docstring).

    A symmetric hash of the corner positions finds the triangles that may share their corners with another (one
    sort); only those are compared exactly, so a scene without twins costs one hash and one sort of its triangles.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        spaces: ``(T,)`` int: the space of each triangle's points (e.g. -1 world, ``k`` prototype ``k``); only
            triangles of one space can be twins.
        double_sided: ``(T,)`` bool: the triangle's mesh is double-sided.

    Returns:
        ``(T,)`` int32 twin geometry id of every single-sided triangle (-1: none, and for double-sided triangles),
        or None when no triangle has a twin.
    """
    indices = np.asarray(indices, np.int64).reshape(-1, 3)
    spaces = np.asarray(spaces, np.int64)
    double_sided = np.asarray(double_sided, bool)
    n = len(indices)
    if n < 2 or double_sided.all():
        return None
    # Hash the corners in any order (a sum of per-corner hashes) with the space; equal hashes are candidates.
    bits = _point_bits(points).astype(np.uint64)
    vertex_hash = _mix(bits[:, 0] ^ _mix(bits[:, 1] ^ _mix(bits[:, 2])))
    corner_sum = vertex_hash[indices[:, 0]] + vertex_hash[indices[:, 1]] + vertex_hash[indices[:, 2]]
    tri_hash = _mix(corner_sum + spaces.astype(np.uint64) * _MIX_2)
    hashes = np.sort(tri_hash)  # a plain sort is several times faster than argsort: the common case ends here
    if not (hashes[1:] == hashes[:-1]).any():
        return None
    # Group the triangles of equal hash (runs of the sorted order) and compare each exactly with its group's first:
    # same space and the same corner positions, and whether its winding is the first's or reversed.
    order = np.argsort(tri_hash)
    starts = np.concatenate([[True], tri_hash[order[1:]] != tri_hash[order[:-1]]])
    run = np.cumsum(starts) - 1
    shared = np.bincount(run)[run] > 1
    candidates, group = order[shared], run[shared]
    first = order[np.flatnonzero(starts)][group]
    bits = _point_bits(points)
    mine, theirs = bits[indices[candidates]], bits[indices[first]]  # (C, 3, 3) corner bits
    match = np.all(mine[:, :, None, :] == theirs[:, None, :, :], axis=3)  # (C, 3 corners, 3 corners of the first)
    exact = (np.all(match.sum(axis=1) == 1, axis=1) & np.all(match.sum(axis=2) == 1, axis=1)
             & (spaces[candidates] == spaces[first]))  # distinct corners too: a degenerate triangle has no winding
    slot = match.argmax(axis=2)  # the first's corner at each of mine
    winding = (slot[:, 1] - slot[:, 0]) % 3 == 2  # reversed relative to the group's first
    candidates, group, winding = candidates[exact], group[exact], winding[exact]
    # For each group and winding, the smallest id a single-sided triangle of the other winding sees.
    twins = np.full(n, -1, np.int32)
    sided = ~double_sided[candidates]
    for w in (False, True):
        seen_by = ~sided | (winding != w)  # what a single-sided triangle of winding w sees from behind
        smallest = np.full(run[-1] + 1, n, np.int64)
        np.minimum.at(smallest, group[seen_by], candidates[seen_by])
        found = smallest[group[sided & (winding == w)]]
        twins[candidates[sided & (winding == w)][found < n]] = found[found < n]
    return twins if (twins >= 0).any() else None
