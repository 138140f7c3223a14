"""Coincident partners of single-sided triangles: the triangles at the same place that a camera ray sees where it
meets a single-sided one from behind.

The "two-sided card" idiom (a front face and a reversed back face at one place, often a material each) and
flattened closed meshes put single-sided surfaces at the same place with opposite windings. Both are hit at the
same ``t``; the closest-hit tie rule reports one of them, and when that one is culled as a back face a re-trace from
just past ``t`` skips the other too (:mod:`wrt.shade` takes the partner that contains the hit point instead). A
triangle's partners are the triangles of its space (world, or the same prototype) that are coplanar with it (within
a tight tolerance: :mod:`wrt.coplanar`), overlap it in area, and show their front where it shows its back
(double-sided, or single-sided with the reversed winding): a twin with the same corners, the triangles of a reversed
polygon fanned along other diagonals, two triangulations of one outline in one mesh or several, a mesh squashed flat
by a singular transform. The surface seen from behind is the union of those; the cull kernel takes the one that
holds the hit point. Each triangle keeps at most :data:`MAX_PARTNERS`.
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


def _vertex_hashes(points: np.ndarray) -> np.ndarray:
    """``(V,)`` uint64 hash of each vertex position (equal positions, equal hashes)."""
    bits = _point_bits(points).astype(np.uint64)
    return _mix(bits[:, 0] ^ _mix(bits[:, 1] ^ _mix(bits[:, 2])))


def _repeated(keys: np.ndarray) -> np.ndarray:
    """Indices of the entries of ``keys`` (uint64 hashes) whose value occurs more than once, sorted by key (stable).

    Counting the keys in buckets of a few of their bits, three times with other bits, leaves the entries that share
    a bucket each time (a third, then a tenth, ...: every repeated key among them); only those are sorted.
    A sort of all of them cost several times as much, and most scenes repeat none."""
    found = np.arange(len(keys))
    for shift in (0, 21, 42):
        if len(found) < 1024:
            break
        bits = min(21, int(np.log2(len(found))) + 2)  # 2 to 4 buckets per key: a quarter to a third share one
        bucket = ((keys[found] >> np.uint64(shift)) & np.uint64((1 << bits) - 1)).astype(np.intp)
        found = found[np.bincount(bucket, minlength=1 << bits)[bucket] > 1]
    order = found[np.argsort(keys[found], kind="stable")]
    equal = keys[order[1:]] == keys[order[:-1]]
    return order[np.concatenate([equal, [False]]) | np.concatenate([[False], equal])]


def find_twins(points: np.ndarray, indices: np.ndarray, spaces: np.ndarray, double_sided: np.ndarray,
               corner_hashes: np.ndarray | None = None):
    """Each single-sided triangle's twin: the triangle with the same three corner positions in the same space, seen
    from its back (double-sided, or single-sided with the reversed winding); of several, the smallest geometry id
    (the one the tie rule reports first).

    A symmetric hash of the corner positions finds the triangles that may share their corners with another
    (:func:`_repeated`); only those are compared exactly, so a scene without twins costs a hash and a count of its
    triangles.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        spaces: ``(T,)`` int: the space of each triangle's points (e.g. -1 world, ``k`` prototype ``k``); only
            triangles of one space can be twins.
        double_sided: ``(T,)`` bool: the triangle's mesh is double-sided.
        corner_hashes: ``(T, 3)`` uint64 :func:`_vertex_hashes` of each corner, when the caller has them.

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
    if corner_hashes is None:
        corner_hashes = _vertex_hashes(points)[indices]
    corner_sum = corner_hashes[:, 0] + corner_hashes[:, 1] + corner_hashes[:, 2]
    tri_hash = _mix(corner_sum + spaces.astype(np.uint64) * _MIX_2)
    order = _repeated(tri_hash)
    if not len(order):  # the common case ends here
        return None
    # Group the triangles of equal hash (runs of the sorted order) and compare each exactly with its group's first:
    # same space and the same corner positions, and whether its winding is the first's or reversed.
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


# The most partners a triangle keeps (the smallest geometry ids): the cull kernel tests each at every hit on it.
MAX_PARTNERS = 64


def find_partners(points, indices, spaces, double_sided):
    """Each single-sided triangle's partners (module docstring), as ranges of geometry ids.

    Coplanar pairs come from :func:`wrt.coplanar.coplanar_pairs` (a hash of the triangles' planes: a scene where no
    plane holds both sides costs a kernel over the triangles and a count of its cells); the triangles whose normals
    are too uncertain to hash (slivers) get their exact twins (:func:`find_twins`) among themselves.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        spaces: ``(T,)`` int: the space of each triangle's points (e.g. -1 world, ``k`` prototype ``k``).
        double_sided: ``(T,)`` bool: the triangle's mesh is double-sided.

    Returns:
        ``(offsets, ranges)``: ``(T + 1,)`` int32, triangle ``t``'s partners are ``ranges[offsets[t]:offsets[t +
        1]]``, ``(K, 2)`` int32 rows ``(first geometry id, count)`` of consecutive partners, sorted; or None when no
        triangle has a partner.
    """
    from .coplanar import coplanar_pairs

    indices = np.ascontiguousarray(np.asarray(indices).reshape(-1, 3), np.int32)
    spaces = np.asarray(spaces, np.int64)
    double_sided = np.asarray(double_sided, bool)
    n = len(indices)
    if n < 2 or double_sided.all():
        return None
    pairs, uncertain = coplanar_pairs(points, indices, spaces, double_sided)
    if len(uncertain) > 1:
        twins = find_twins(points, indices[uncertain], spaces[uncertain], double_sided[uncertain])
        if twins is not None:
            has = np.flatnonzero(twins >= 0)
            pairs = np.concatenate([pairs, np.stack([uncertain[has], uncertain[twins[has]]], axis=1)])
    if not len(pairs):
        return None
    pairs = np.unique(pairs, axis=0)  # by triangle, then partner
    # Keep each triangle's first MAX_PARTNERS.
    starts = np.concatenate([[True], pairs[1:, 0] != pairs[:-1, 0]])
    rank = np.arange(len(pairs)) - np.maximum.accumulate(np.where(starts, np.arange(len(pairs)), 0))
    pairs = pairs[rank < MAX_PARTNERS]
    # Runs of consecutive partners of one triangle become one range.
    new = np.concatenate([[True], (pairs[1:, 0] != pairs[:-1, 0]) | (pairs[1:, 1] != pairs[:-1, 1] + 1)])
    firsts = np.flatnonzero(new)
    ranges = np.stack([pairs[firsts, 1], np.diff(np.append(firsts, len(pairs)))], axis=1)
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(pairs[firsts, 0], minlength=n), out=offsets[1:])
    return offsets.astype(np.int32), np.ascontiguousarray(ranges, np.int32)
