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

from .unique import sorted_unique

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


# The most partners a triangle keeps (the smallest geometry ids): the cull kernel tests each at every hit on it.
MAX_PARTNERS = 64
_EDGES = np.array([[0, 1], [1, 2], [2, 0]])  # edge k of a triangle runs from its corner k to k + 1; k + 2 is far


def _edge_ends(points, indices, triangles, edges, far_only=False):
    """``(start, end, far)``: ``(E, 3)`` float64 corners of edge ``edges[i]`` of triangle ``triangles[i]`` and the
    corner off it (``far`` alone with ``far_only``)."""
    rows = np.arange(len(triangles))
    corners = indices[triangles]
    ends = tuple(points[corners[rows, (edges + k) % 3]].astype(np.float64) for k in ((2,) if far_only else range(3)))
    return ends[0] if far_only else ends


def edge_partners(points, indices, spaces, double_sided, uncertain) -> np.ndarray:
    """Partner pairs ``(t, p)`` across the edges of the ``uncertain`` triangles (those :mod:`wrt.coplanar` cannot
    hash: slivers), one of the two uncertain: ``t`` single-sided, ``p`` double-sided or facing the other way, the two
    sharing an edge (its two corner positions) in one space, their far corners on the same side of it (so they share
    area along it), and coplanar within :mod:`wrt.coplanar`'s tolerances in float64: normals within the sum of their
    margins, and the far corner nearer the edge within its triangle's offset tolerance of the other's plane (the
    part they share lies that near both; the other far corner, measured from a sliver's plane, would measure the
    sliver's rounding). Exact twins among the uncertain are such pairs too.

    Only the uncertain triangles' corner positions are hashed, and the edges of the triangles with two corners at
    such positions; of a pile of coincident edges, each is paired with the :data:`MAX_PARTNERS` nearest it in
    sorted order.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int32 rows into ``points``.
        spaces: ``(T,)`` int64 space of each triangle.
        double_sided: ``(T,)`` bool.
        uncertain: ``(U,)`` int geometry ids.

    Returns:
        ``(P, 2)`` int64 pairs ``(t, p)``; a pair may repeat.
    """
    from .coplanar import triangle_margins

    none = np.zeros((0, 2), np.int64)
    points = np.asarray(points, np.float32)
    uncertain = np.asarray(uncertain, np.int64)
    # Positions at the uncertain triangles' corners; the edges of any triangle with both ends at such positions.
    # (A table of the positions' hashes' low bits, some 16 slots a position: a few other vertices pass it too, and
    # fail the exact edge test below; a search of every vertex among the positions took several times as long.)
    vertex_hash = _vertex_hashes(points)
    slots = np.uint64((1 << int(np.ceil(np.log2(48 * len(uncertain) + 1)))) - 1)
    table = np.zeros(int(slots) + 1, bool)
    table[(vertex_hash[indices[uncertain]] & slots).astype(np.intp)] = True
    corner_known = table[(vertex_hash & slots).astype(np.intp)][indices]  # (T, 3)
    tris, edges = [], []
    for k, (i, j) in enumerate(_EDGES):
        found = np.flatnonzero(corner_known[:, i] & corner_known[:, j])
        tris.append(found)
        edges.append(np.full(len(found), k))
    tris, edges = np.concatenate(tris), np.concatenate(edges)
    # Hash each edge (its two ends in any order) with its space; equal keys within a few places of each other in
    # sorted order (one of them an uncertain triangle's) are candidate pairs.
    ends = indices[tris[:, None], _EDGES[edges]]  # (E, 2)
    keys = _mix(vertex_hash[ends[:, 0]] + vertex_hash[ends[:, 1]] + _mix(spaces[tris].astype(np.uint64) + _MIX_1))
    order = np.argsort(keys)
    sorted_keys = keys[order]
    is_uncertain = np.zeros(len(indices), bool)
    is_uncertain[uncertain] = True
    sorted_uncertain = is_uncertain[tris[order]]
    mine, theirs = [], []
    for step in range(1, MAX_PARTNERS + 1):
        near = np.flatnonzero(sorted_keys[step:] == sorted_keys[:-step])
        if not len(near):
            break
        # Each pair once, ``mine`` an uncertain one (the first where both are).
        first = sorted_uncertain[near]
        mine.append(order[np.where(first, near, near + step)[first | sorted_uncertain[near + step]]])
        theirs.append(order[np.where(first, near + step, near)[first | sorted_uncertain[near + step]]])
    if not mine:
        return none
    mine, theirs = np.concatenate(mine), np.concatenate(theirs)
    keep = (tris[theirs] != tris[mine]) & (spaces[tris[theirs]] == spaces[tris[mine]])
    theirs, mine = theirs[keep], mine[keep]
    # The same two corner positions, in the same order or reversed.
    bits = _point_bits(points)
    a, b = bits[ends[mine, 0]], bits[ends[mine, 1]]
    c, d = bits[ends[theirs, 0]], bits[ends[theirs, 1]]
    same = (a == c).all(axis=1) & (b == d).all(axis=1)
    reversed_ = (a == d).all(axis=1) & (b == c).all(axis=1)
    keep = same ^ reversed_  # (both: an edge of one point)
    theirs, mine, reversed_ = theirs[keep], mine[keep], reversed_[keep]
    # Each triangle's normal from its edge, so that the two differ only by the far corners: the same side of the edge
    # when they point alike, facing each other's backs when the edge runs the other way in one of them.
    start, end, far_mine = _edge_ends(points, indices, tris[mine], edges[mine])
    far_theirs = _edge_ends(points, indices, tris[theirs], edges[theirs], far_only=True)
    along = end - start
    n_mine = np.cross(along, far_mine - start)
    n_theirs = np.cross(along, far_theirs - start)  # their normal, negated where their edge runs the other way
    same_side = np.einsum("ij,ij->i", n_mine, n_theirs) > 0.0  # (false for a degenerate one)
    area_mine, area_theirs = np.linalg.norm(n_mine, axis=1), np.linalg.norm(n_theirs, axis=1)
    keep = np.flatnonzero(same_side)
    # Both sides' margins in one launch (one upload of the points): mine first, then theirs.
    margins, deltas = triangle_margins(points, indices, np.concatenate([tris[mine[keep]], tris[theirs[keep]]]),
                                       np.concatenate([area_mine[keep], area_theirs[keep]]))
    (m_mine, m_theirs), (delta_mine, delta_theirs) = np.split(margins, 2), np.split(deltas, 2)
    n_mine, n_theirs = n_mine[keep], n_theirs[keep]
    area_mine, area_theirs = area_mine[keep], area_theirs[keep]
    angle = np.linalg.norm(np.cross(n_mine, n_theirs), axis=1) / (area_mine * area_theirs)
    mine_lower = area_mine <= area_theirs  # the one whose far corner is nearer the shared edge
    offset = np.where(mine_lower,
                      np.abs(np.einsum("ij,ij->i", n_theirs, far_mine[keep] - start[keep])) / area_theirs,
                      np.abs(np.einsum("ij,ij->i", n_mine, far_theirs[keep] - start[keep])) / area_mine)
    coplanar = (angle <= m_mine + m_theirs) & (offset <= np.where(mine_lower, delta_mine, delta_theirs))
    keep = keep[coplanar]
    t, p, opposite = tris[mine[keep]], tris[theirs[keep]], reversed_[keep]
    # Both ways: each single-sided one of the two takes the other where that one shows its front to its back.
    forward = ~double_sided[t] & (double_sided[p] | opposite)
    backward = ~double_sided[p] & (double_sided[t] | opposite)
    return np.concatenate([np.stack([t[forward], p[forward]], 1), np.stack([p[backward], t[backward]], 1)])


def find_partners(points, indices, spaces, double_sided, face_starts=None, on_capped=None):
    """Each single-sided triangle's partners (module docstring), as ranges of geometry ids.

    Coplanar pairs come from :func:`wrt.coplanar.coplanar_pairs` (a hash of the triangles' planes: a scene where no
    plane holds both sides costs a kernel over the triangles and a count of its cells); the triangles whose normals
    are too uncertain to hash (slivers) are paired across their edges (:func:`edge_partners`); given the polygons, the
    triangles of a polygon and of its reversal (a bent one's fans are not coplanar) are paired too
    (:func:`wrt.reversed_polygons.reversed_pairs`).

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        spaces: ``(T,)`` int: the space of each triangle's points (e.g. -1 world, ``k`` prototype ``k``).
        double_sided: ``(T,)`` bool: the triangle's mesh is double-sided.
        face_starts: ``(F,)`` int, ascending: the first row of each polygon (its triangles are the rows up to the
            next one's first), a callable returning them (called only when some triangle may face another's
            back), or None.
        on_capped: called with the ``(N,)`` int64 geometry ids of the triangles that have more than
            :data:`MAX_PARTNERS` partners (they keep the first), if any.

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
    # Each triangle keeps its MAX_PARTNERS lowest partners, and one more tells that it had more.
    pairs, uncertain, opposed = coplanar_pairs(points, indices, spaces, double_sided, limit=MAX_PARTNERS + 1)
    if len(uncertain):
        pairs = np.concatenate([pairs, edge_partners(points, indices, spaces, double_sided, uncertain)])
    # A polygon and its reversal have opposite vector areas, so some triangle of the two faces each way (or one is
    # double-sided, or uncertain): a floor whose triangles all face one way has none.
    if face_starts is not None and (opposed or len(uncertain)):
        from .reversed_polygons import reversed_pairs

        starts = face_starts() if callable(face_starts) else face_starts
        pairs = np.concatenate([pairs, reversed_pairs(points, indices, spaces, double_sided, starts)])
    if not len(pairs):
        return None
    # Sorted by triangle, then partner, without repeats (as one int64 key: np.unique along axis 0 took 4 times as long;
    # by a sort: numpy's hash table took 31 s for the 8M pairs of 2,000 stacked quads facing both ways).
    keys = sorted_unique(pairs[:, 0].astype(np.int64) * n + pairs[:, 1])
    pairs = np.stack([keys // n, keys % n], axis=1)
    # Keep each triangle's first MAX_PARTNERS; name those that had more.
    starts = np.concatenate([[True], pairs[1:, 0] != pairs[:-1, 0]])
    rank = np.arange(len(pairs)) - np.maximum.accumulate(np.where(starts, np.arange(len(pairs)), 0))
    capped = pairs[rank == MAX_PARTNERS, 0]
    if len(capped) and on_capped is not None:
        on_capped(capped)
    pairs = pairs[rank < MAX_PARTNERS]
    # Runs of consecutive partners of one triangle become one range.
    new = np.concatenate([[True], (pairs[1:, 0] != pairs[:-1, 0]) | (pairs[1:, 1] != pairs[:-1, 1] + 1)])
    firsts = np.flatnonzero(new)
    ranges = np.stack([pairs[firsts, 1], np.diff(np.append(firsts, len(pairs)))], axis=1)
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(pairs[firsts, 0], minlength=n), out=offsets[1:])
    return offsets.astype(np.int32), np.ascontiguousarray(ranges, np.int32)
