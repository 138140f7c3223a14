"""Reversed polygons: the pairs of faces with the same outline wound the other way (a bent polygon and its
reversal, the back of a two-sided card), found on the host whatever their triangulations (:func:`reversed_pairs`).

A bent polygon's two fans are not coplanar (:mod:`wrt.coplanar` would not pair them), and where they cross or meet
at its outline the re-trace past a culled hit misses the other side: the camera saw what lay behind. Every triangle
of one such face is a partner of every triangle of the other; the cull kernel takes the one that holds the hit
point, within its own tolerance (``wrt.shade.PARTNER_TOLERANCE``), so the pairing needs no tolerance of its own.

A face's outline is keyed by the shoelace sum over its triangles' edges in a pseudo-random plane: each corner
position hashed to a point ``(A, B)`` of 64-bit integers, each directed edge ``p -> q`` adding ``A(p) B(q) - A(q)
B(p)`` (wrapping). An edge inside the face is walked both ways and cancels, so the sum is the outline's, whatever the
triangulation (a fan from any corner, ear clipping); walked the other way it is negated. Faces whose keys are each
other's negations (or equal, one of them double-sided) in the same space are pairs: the same corner positions in
reversed order, but for a 64-bit collision, which would only hand the cull kernel triangles it then finds not to
hold the point.

Only bent faces are keyed: a face whose corners lie within :data:`FLAT_ROUNDINGS` float32 roundings of its first
triangle's plane is as flat as its corners can be written (a tilted floor's quads are), and the coplanar hash,
whose margins allow for that rounding, pairs its triangles with its reversal's. (The measure depends on the first
triangle, so a polygon and its reversal fanned from other corners measure a bend of a few roundings a little
differently.) A face whose first triangle is degenerate measures nothing and is keyed.
"""

import numpy as np
import warp as wp

from .coplanar import MIX_1, corner, corner_rounding, mix64, two_sided_cells
from .twins import MAX_PARTNERS

wp.set_module_options({"enable_backward": False})

MAX_FACE_TRIANGLES = 16  # faces of more triangles are left to the coplanar hash (each pair costs their product)
FLAT_ROUNDINGS = 4.0  # a face's corners this many float32 roundings off its first triangle's plane: flat
_MINUS_ZERO = wp.constant(wp.uint32(0x80000000))  # float32 -0: hashed as +0, the same position


@wp.func
def flat_limit(a: wp.vec3d, b: wp.vec3d, c: wp.vec3d):
    """How far the corners of a face whose first triangle is ``a, b, c`` may lie off that triangle's plane and the
    face still count as flat: :data:`FLAT_ROUNDINGS` roundings of their coordinates (:func:`corner_rounding`)."""
    return wp.float64(FLAT_ROUNDINGS) * corner_rounding(a, b, c)


@wp.func
def position_point(bits: wp.array2d[wp.uint32], v: int):
    """Vertex ``v``'s position hashed to a point ``(A, B)`` of the pseudo-random plane (equal positions, equal
    points): ``A`` the mixed coordinate bits, ``B`` its halves swapped (a multiple of ``A`` would cancel)."""
    h = wp.uint64(0)
    for k in range(3):
        b = bits[v, k]
        if b == _MINUS_ZERO:
            b = wp.uint32(0)
        h = h * MIX_1 + wp.uint64(b)
    a = mix64(h)
    return a, (a << wp.uint64(32)) | (a >> wp.uint64(32))


@wp.kernel
def outline_keys_kernel(
    points: wp.array[wp.vec3],
    bits: wp.array2d[wp.uint32],
    indices: wp.array2d[wp.int32],
    starts: wp.array[wp.int32],
    sizes: wp.array[wp.int32],
    # outputs
    keys: wp.array[wp.uint64],
    bent: wp.array[wp.int32],
):
    """Face ``f`` (``sizes[f]`` triangles from row ``starts[f]``): 1 in ``bent`` when a corner lies off the plane of
    its first triangle by more than :func:`flat_limit`, and then its outline key (module docstring) in ``keys``."""
    f = wp.tid()
    first = starts[f]
    bent[f] = 0
    keys[f] = wp.uint64(0)
    # The largest distance of a corner from the first triangle's plane (times its area vector's length).
    a0 = corner(points, indices, first, 0)
    b0 = corner(points, indices, first, 1)
    c0 = corner(points, indices, first, 2)
    n0 = wp.cross(b0 - a0, c0 - a0)
    off = wp.float64(0.0)
    for t in range(first + 1, first + sizes[f]):
        a = corner(points, indices, t, 0)
        b = corner(points, indices, t, 1)
        c = corner(points, indices, t, 2)
        off = wp.max(off, wp.max(wp.abs(wp.dot(n0, a - a0)), wp.max(wp.abs(wp.dot(n0, b - a0)),
                                                                    wp.abs(wp.dot(n0, c - a0)))))
    limit = flat_limit(a0, b0, c0) * wp.length(n0)
    if off <= limit and limit > wp.float64(0.0):
        return  # (a degenerate first triangle measures nothing: keyed)
    key = wp.uint64(0)
    for t in range(first, first + sizes[f]):
        pa, qa = position_point(bits, indices[t, 0])
        pb, qb = position_point(bits, indices[t, 1])
        pc, qc = position_point(bits, indices[t, 2])
        key += (pa * qb - pb * qa) + (pb * qc - pc * qb) + (pc * qa - pa * qc)
    keys[f] = key
    bent[f] = 1


def reversed_pairs(points, indices, spaces, double_sided, face_starts) -> np.ndarray:
    """Partner pairs ``(t, p)`` between reversed polygons (module docstring): ``t`` single-sided, ``p`` of a face
    with the same outline in the same space, wound the other way or double-sided.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int32 rows into ``points``.
        spaces: ``(T,)`` int64 space of each triangle.
        double_sided: ``(T,)`` bool.
        face_starts: ``(F,)`` int, ascending: the first row of each polygon (its triangles are the rows up to the
            next one's first).

    Returns:
        ``(P, 2)`` int64 pairs ``(t, p)``; a pair may repeat.
    """
    none = np.zeros((0, 2), np.int64)
    n = len(indices)
    if n < 4:
        return none
    # Faces of 2 to MAX_FACE_TRIANGLES triangles (one triangle and its reversal are twins: coplanar).
    starts = np.asarray(face_starts, np.int64)
    sizes = np.diff(np.append(starts, n))
    polygons = (sizes >= 2) & (sizes <= MAX_FACE_TRIANGLES)
    if not polygons.any():
        return none
    starts, sizes = starts[polygons], sizes[polygons]
    pts = np.ascontiguousarray(points, np.float32)
    keys = wp.empty(len(starts), dtype=wp.uint64, device="cpu")
    bent = wp.empty(len(starts), dtype=wp.int32, device="cpu")
    wp.launch(outline_keys_kernel, dim=len(starts), device="cpu", outputs=[keys, bent],
              inputs=[wp.array(pts, dtype=wp.vec3, device="cpu", copy=False),
                      wp.array(pts.view(np.uint32), dtype=wp.uint32, device="cpu", copy=False),
                      wp.array(np.ascontiguousarray(indices, np.int32), dtype=wp.int32, device="cpu", copy=False),
                      wp.array(starts.astype(np.int32), dtype=wp.int32, device="cpu"),
                      wp.array(sizes.astype(np.int32), dtype=wp.int32, device="cpu")])
    bent = np.flatnonzero(bent.numpy())
    if not len(bent):
        return none
    keys, starts, sizes = keys.numpy()[bent], starts[bent], sizes[bent]
    # The key and its negation are one outline, each way round: the smaller names it; side 0 or 1 says which way
    # (2: double-sided, faces both).
    negated = np.uint64(0) - keys
    outline = np.minimum(keys, negated)
    sides = np.where(double_sided[starts], 2, (keys != outline).astype(np.int64))
    chosen = two_sided_cells(outline, sides)
    if not len(chosen):
        return none
    # Faces of one outline, same space, that face each other: every triangle of one with every one of the other.
    chosen = chosen[np.lexsort((spaces[starts[chosen]], outline[chosen]))]
    mine, theirs = [], []
    for step in range(1, min(len(chosen), MAX_PARTNERS + 1)):  # (a pile of copies: the nearest in sorted order)
        f, g = chosen[:-step], chosen[step:]
        same = (outline[f] == outline[g]) & (spaces[starts[f]] == spaces[starts[g]])
        if not same.any():
            break
        f, g = f[same], g[same]
        facing = sides[f] != sides[g]  # (0 and 1 face each other, 2 faces both)
        mine.append(f[facing])
        theirs.append(g[facing])
    if not mine:
        return none
    f, g = np.concatenate(mine), np.concatenate(theirs)
    pairs = []
    for a, b in ((f, g), (g, f)):  # each single-sided face takes the other's triangles
        a, b = a[sides[a] != 2], b[sides[a] != 2]
        count = sizes[a] * sizes[b]
        rank = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        pairs.append(np.stack([np.repeat(starts[a], count) + rank // np.repeat(sizes[b], count),
                               np.repeat(starts[b], count) + rank % np.repeat(sizes[b], count)], 1))
    return np.concatenate(pairs).astype(np.int64)
