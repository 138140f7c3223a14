"""Coincident partners of single-sided triangles: the triangles at the same place that a camera ray sees where it
meets a single-sided one from behind.

The "two-sided card" idiom (a front face and a reversed back face at one place, often a material each) and
flattened closed meshes put single-sided surfaces at the same place with opposite windings. Both are hit at the
same ``t``; the closest-hit tie rule reports one of them, and when that one is culled as a back face a re-trace from
just past ``t`` skips the other too (:mod:`wrt.shade` takes the partner that contains the hit point instead). A
partner is seen from the first triangle's back (double-sided, or single-sided with the reversed winding), in the
same space (world, or the same prototype), and is one of:

- a twin: the same three corner positions (:func:`find_twins`);
- a triangle of a face with the same boundary (a polygon and its reversal, each fanned from its own first corner,
  so along other diagonals: a quad ``[0, 1, 2, 3]`` and ``[3, 2, 1, 0]``, any n-gon);
- a coplanar triangle on the same side of a shared edge (the same corner positions), where the two meshes have the
  same boundary: a card authored as triangles split along different diagonals.

Coplanar overlaps that share no edge (two fans of a hexagon as separate triangle faces, where their triangles meet
at a corner only; a cube squashed flat) and both sides as triangles in one mesh (whose boundary cancels) find no
partner and stay culled to the surface behind.
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


# Coplanarity of an edge partner: the distance of its far corner from the triangle's plane, relative to the longer of
# the two triangles' longest edges (float32 corners of one plane sit within a few ulps of it).
COPLANAR_TOLERANCE = 1e-5
# Equal keys within this many places of a sorted run are paired: a group has 2 members but in piles of copies.
MAX_GROUP = 16


def _rotate(x: np.ndarray) -> np.ndarray:
    """``x`` rotated left by 29 bits (uint64): makes the edge term below lopsided in its two ends."""
    return (x << np.uint64(29)) | (x >> np.uint64(35))


def _cycle_terms(h: np.ndarray) -> np.ndarray:
    """``(T,)`` uint64 from the ``(T, 3)`` corner hashes ``h``: each triangle's sum over its directed edges
    ``a -> b`` of ``g(a, b) - g(b, a)`` (wrapping), ``g(a, b) = h(a) * rot(h(b))``. An edge walked both ways
    cancels exactly, so summed over a consistently wound triangulation (a face's fan or ear clipping, a whole mesh)
    the interior edges drop out and the sum depends on the boundary cycle only: any triangulation of a polygon gives
    the same sum, the reversed polygon its negation, a closed surface (or a degenerate triangle) 0."""
    r = _rotate(h)
    total = np.zeros(len(h), np.uint64)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        total += h[:, i] * r[:, j] - h[:, j] * r[:, i]
    return total


def _equal_key_pairs(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ordered pairs ``(i, j)``, ``i != j``, of the entries of ``keys`` that are equal (within :data:`MAX_GROUP`
    places of one another in sorted order)."""
    order = _repeated(keys)
    sorted_keys = keys[order]
    firsts, seconds = [], []
    for step in range(1, MAX_GROUP):
        near = np.flatnonzero(sorted_keys[step:] == sorted_keys[:-step])
        if not len(near):
            break
        firsts += [order[near], order[near + step]]
        seconds += [order[near + step], order[near]]
    if not firsts:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(firsts), np.concatenate(seconds)


def _facing_pairs(sums: np.ndarray, spaces: np.ndarray, sided: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)`` of groups (faces or meshes) with the same boundary cycle (:func:`_cycle_terms`) in one space
    where ``j`` shows its front to a camera ray that culls ``i`` from behind: ``i`` single-sided and ``j`` the
    reversed cycle (the negated sum), or double-sided. A group whose cycle sums to 0 (closed, or degenerate) has no
    boundary to match. A 64-bit key collision pairs unrelated groups: the cull kernel's containment test rejects
    them."""
    usable = np.flatnonzero(sums != 0)
    if len(usable) < 2:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    s = sums[usable]
    keys = _mix(np.minimum(s, np.uint64(0) - s) ^ _mix(spaces[usable].astype(np.uint64) + _MIX_1))
    i, j = _equal_key_pairs(keys)
    i, j = usable[i], usable[j]
    keep = ~sided[i] & (sided[j] | (sums[j] == np.uint64(0) - sums[i])) & (spaces[i] == spaces[j])
    return i[keep], j[keep]


def _edge_partners(points, indices, spaces, double_sided, candidates, vertex_hash) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(t, p)`` of the ``candidates`` triangles: ``t`` single-sided, ``p`` sharing an edge's two corner
    positions (same space), coplanar with it (:data:`COPLANAR_TOLERANCE`), its far corner on the same side of the
    edge as ``t``'s (the two overlap along it), and seen from ``t``'s back (double-sided, or facing the other way).
    ``vertex_hash``: :func:`_vertex_hashes` of ``points``."""
    tris = indices[candidates]
    bits = _point_bits(points)
    # Hash each undirected edge (its two ends in any order) with the space; equal keys share an edge.
    ends = np.array([[0, 1], [1, 2], [2, 0]])
    a, b = tris[:, ends[:, 0]].reshape(-1), tris[:, ends[:, 1]].reshape(-1)  # (3C,) edge k of triangle c at 3c + k
    space = np.repeat(spaces[candidates], 3).astype(np.uint64)
    i, j = _equal_key_pairs(_mix(vertex_hash[a] + vertex_hash[b] + _mix(space + _MIX_2)))
    t, p = candidates[i // 3], candidates[j // 3]
    same_ends = (((bits[a[i]] == bits[a[j]]).all(1) & (bits[b[i]] == bits[b[j]]).all(1))
                 | ((bits[a[i]] == bits[b[j]]).all(1) & (bits[b[i]] == bits[a[j]]).all(1)))
    keep = same_ends & (t != p) & ~double_sided[t] & (spaces[t] == spaces[p])
    i, j, t, p = i[keep], j[keep], t[keep], p[keep]
    # Geometry in float64: the far corners, the edge, the two normals.
    pts = np.asarray(points, np.float64)
    start, edge = pts[a[i]], pts[b[i]] - pts[a[i]]
    far_t = pts[indices[t, (i % 3 + 2) % 3]] - start
    far_p = pts[indices[p, (j % 3 + 2) % 3]] - start
    normal_t = np.cross(edge, far_t)
    corners = pts[np.concatenate([indices[t], indices[p]], axis=1)]  # (P, 6, 3)
    size = np.linalg.norm(corners.max(axis=1) - corners.min(axis=1), axis=1)
    length = np.linalg.norm(normal_t, axis=1)
    coplanar = np.abs(np.einsum("ij,ij->i", normal_t, far_p)) <= COPLANAR_TOLERANCE * size * length
    same_side = np.einsum("ij,ij->i", normal_t, np.cross(edge, far_p)) > 0.0
    own = np.cross(pts[indices[t, 1]] - pts[indices[t, 0]], pts[indices[t, 2]] - pts[indices[t, 0]])
    theirs = np.cross(pts[indices[p, 1]] - pts[indices[p, 0]], pts[indices[p, 2]] - pts[indices[p, 0]])
    facing = double_sided[p] | (np.einsum("ij,ij->i", own, theirs) < 0.0)
    keep = coplanar & same_side & facing & (length > 0.0)
    return t[keep], p[keep]


def find_partners(points, indices, spaces, double_sided, face_starts, mesh_starts):
    """Each single-sided triangle's partners (module docstring), as ranges of geometry ids.

    Faces and meshes are hashed by their boundary cycles (:func:`_cycle_terms`: one pass over the triangles, then
    :func:`_repeated` on the faces of more than one triangle and on the meshes); edges are hashed only in meshes
    whose boundary matches another's, so a scene without coincident faces costs little more than
    :func:`find_twins`.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        spaces: ``(T,)`` int: the space of each triangle's points (e.g. -1 world, ``k`` prototype ``k``).
        double_sided: ``(T,)`` bool: the triangle's mesh is double-sided.
        face_starts: ``(T,)`` bool: the triangle starts a face (a source polygon's triangles are consecutive).
        mesh_starts: ``(T,)`` bool: the triangle starts a mesh.

    Returns:
        ``(offsets, ranges)``: ``(T + 1,)`` int32, triangle ``t``'s partners are ``ranges[offsets[t]:offsets[t +
        1]]``, ``(K, 2)`` int32 rows ``(first geometry id, count)`` sorted by first id; or None when no triangle has
        a partner.
    """
    indices = np.asarray(indices, np.int64).reshape(-1, 3)
    spaces = np.asarray(spaces, np.int64)
    double_sided = np.asarray(double_sided, bool)
    n = len(indices)
    if n < 2 or double_sided.all():
        return None
    rows = []  # (triangle, first, count) arrays
    vertex_hash = _vertex_hashes(points)
    corner_hashes = vertex_hash[indices]  # (T, 3)
    twins = find_twins(points, indices, spaces, double_sided, corner_hashes)
    if twins is not None:
        has = np.flatnonzero(twins >= 0)
        rows.append((has, twins[has].astype(np.int64), np.ones(len(has), np.int64)))
    terms = _cycle_terms(corner_hashes)
    # Faces of two or more triangles (a one-triangle face's partners are its twins) with a partner face: each of
    # its triangles takes the partner face's triangles.
    face_first = np.flatnonzero(face_starts)
    face_sums = np.add.reduceat(terms, face_first)
    face_count = np.diff(np.append(face_first, n))
    polygons = np.flatnonzero(face_count > 1)
    f, g = _facing_pairs(face_sums[polygons], spaces[face_first[polygons]], double_sided[face_first[polygons]])
    f, g = polygons[f], polygons[g]
    if len(f):
        own = np.repeat(face_first[f], face_count[f]) + _ranks(face_count[f])
        rows.append((own, np.repeat(face_first[g], face_count[f]), np.repeat(face_count[g], face_count[f])))
    # Meshes with a partner mesh (the same boundary): edge partners among their triangles.
    mesh_first = np.flatnonzero(mesh_starts)
    mesh_count = np.diff(np.append(mesh_first, n))
    m, k = _facing_pairs(np.add.reduceat(terms, mesh_first), spaces[mesh_first], double_sided[mesh_first])
    if len(m):
        matched = np.unique(np.concatenate([m, k]))
        candidates = np.repeat(mesh_first[matched], mesh_count[matched]) + _ranks(mesh_count[matched])
        t, p = _edge_partners(points, indices, spaces, double_sided, candidates, vertex_hash)
        rows.append((t, p, np.ones(len(t), np.int64)))
    if not rows or not sum(len(r[0]) for r in rows):
        return None
    table = np.unique(np.stack([np.concatenate(c) for c in zip(*rows)], axis=1), axis=0)  # by triangle, then first
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(table[:, 0], minlength=n), out=offsets[1:])
    return offsets.astype(np.int32), np.ascontiguousarray(table[:, 1:], np.int32)


def _ranks(counts: np.ndarray) -> np.ndarray:
    """``0, 1, ..., c - 1`` for each ``c`` in ``counts``, concatenated."""
    counts = np.asarray(counts, np.int64)
    return np.arange(int(counts.sum()), dtype=np.int64) - np.repeat(np.cumsum(counts) - counts, counts)
