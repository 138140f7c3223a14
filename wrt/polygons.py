"""Polygons triangulated inside their outline: a face that is not convex in its best-fit plane is ear-clipped, every
other face keeps the fan around its first vertex that :func:`wrt.usd_meshes.triangulate` makes.

A fan covers a convex polygon exactly, but for a concave one (a dart, an L) some of its triangles lie outside the
outline and others overlap, so rays hit where the face has no surface. The check for convexity is vectorised over all
faces, so a mesh of millions of convex quads pays a few numpy passes; only the concave faces are clipped, one at a
time. Each face's best-fit plane is the one normal to its Newell normal (its area vector; Newell's method, see
Sutherland, Sproull and Schumacker, "A Characterization of Ten Hidden-Surface Algorithms", 1974). Ear clipping after
Meisters, "Polygons have ears", 1975: a convex corner whose triangle holds no reflex corner is cut off, until three
corners are left.

Every face keeps ``n - 2`` triangles in its rows of the fan, each listing corners in the face's own order, so the face
ids, the corner positions into ``faceVertexIndices`` (which primvars are looked up by) and the winding all stay as the
fan had them. What cannot be clipped (a face that crosses itself, with reflex corners or as a star whose corners all
turn one way, see :func:`convexity`; a face of more than ``MAX_CLIPPED_CORNERS`` corners, whose clipping would take
quadratic time) keeps its fan, reported through ``on_problem``.

Corners that add no outline are left out of the clipping, each with a triangle of no area in the face's rows
(:func:`_left_out`): copies (a point listed twice, or a few float32 ulps away) and the tips of zero-width spikes (the
outline out to a point and back: no area by the even-odd rule, which USD renderers draw), whose tip counts as a
reflex corner, since the fan over it draws outside the outline or turns a triangle over.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

MAX_CLIPPED_CORNERS = 10_000  # faces with more corners keep their fan (ear clipping is quadratic in the corners)
REFLEX_SINE = 1e-6  # a corner turning the wrong way by less than this sine of its angle counts as straight
BLOCK_CORNERS = 1 << 16  # corners checked for convexity per numpy pass (small enough to stay in cache)
_FLAT = 1e-12  # corner triangles under this fraction of the squared face size are flat (neither convex nor reflex)
# Corners closer than this fraction of their face's size (its farthest corner from the first) count as one (copies):
# 8-16 float32 ulps of coordinates the face's size, a weld that missed. Not a fraction of the perimeter, which grows
# with the corners: a comb of 500 teeth 1 long had its gaps 0.01 wide (2^-16 of its perimeter is 0.016) taken as
# spikes of no area and covered by triangles turned over, and a 1e6 square lost a notch 3 wide.
COPY_DISTANCE = 2.0 ** -20
_COPY_PERIMETER = COPY_DISTANCE / 2  # the size is at most half the perimeter: the faces that may have copies


def reflex_counts(points, counts, face_indices) -> np.ndarray:
    """``(F,)`` int64: how many corners of each face turn against the face's Newell normal (reflex corners in its
    best-fit plane). Faces of fewer than four corners, and faces with no area (all corners in a line), count 0.
    The first result of :func:`convexity`, which takes the same arguments."""
    return convexity(points, counts, face_indices)[0]


def convexity(points, counts, face_indices) -> tuple[np.ndarray, np.ndarray]:
    """Why faces are not convex: ``(F,)`` int64 reflex corners per face (see :func:`reflex_counts`), and ``(F,)``
    bool stars, faces whose corners all turn one way round their Newell normal but that wind round it more than once
    (a pentagram turns through 4 pi): they cross themselves with no reflex corner to show it.

    Only faces of five corners or more can be stars (each corner turns by less than pi, and 4 pi takes five), so only
    they pay for the check (two numpy passes over their corners): triangle and quad meshes pay nothing.

    Args:
        points: ``(V, 3)`` float, the mesh's points.
        counts: ``(F,)`` int, corners per face (``faceVertexCounts``), none negative.
        face_indices: ``(N,)`` int, rows into ``points`` (``faceVertexIndices``), ``N = counts.sum()``.
    """
    counts = np.asarray(counts, np.int64)
    face_indices = np.asarray(face_indices, np.int64).reshape(-1)
    points = np.asarray(points)
    k = int(counts[0]) if len(counts) else 0
    if 4 <= k and len(face_indices) <= BLOCK_CORNERS and len(face_indices) == k * len(counts) and (counts == k).all():
        # Faces all of one size, in one block (a small quad mesh): the corners are the indices in rows, no
        # bookkeeping of sizes and blocks (most of the check's cost for a mesh of a few quads).
        corners = np.ascontiguousarray(points.T)[:, face_indices.reshape(-1, k)]
        corner_reflex, stars = _corner_turns(corners.astype(np.float64, copy=False), k >= 5)
        return corner_reflex.sum(axis=1), stars
    starts = np.cumsum(counts) - counts
    reflex = np.zeros(len(counts), np.int64)
    stars = np.zeros(len(counts), bool)
    # Faces of one corner count at a time, as (faces, corners) arrays: no per-corner walk to build. Triangles are
    # always convex.
    sizes = np.unique(counts[counts >= 4])
    planes = np.ascontiguousarray(points.T)  # (3, V): one plane per axis, so the math below runs on contiguous rows
    for k in sizes.tolist():
        faces = np.flatnonzero(counts == k)
        step = max(BLOCK_CORNERS // k, 1)
        for b in range(0, len(faces), step):
            block = faces[b:b + step]
            corners = planes[:, face_indices[starts[block][:, None] + np.arange(k)]]
            corner_reflex, stars[block] = _corner_turns(corners.astype(np.float64, copy=False), k >= 5)
            reflex[block] = corner_reflex.sum(axis=1)
    return reflex, stars


def _cross(a, b):
    """Cross product of ``(3, ...)`` arrays (axis first)."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _turned(a: np.ndarray, shift: int) -> np.ndarray:
    """``a`` with its last axis (a face's corners) turned so that entry ``i`` holds entry ``i + shift`` (1: the
    following corner, -1: the preceding one), as ``np.roll(a, -shift, axis=-1)``."""
    return np.concatenate((a[..., shift:], a[..., :shift]), axis=-1)


def _corner_turns(corners: np.ndarray, find_stars: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(F, k)`` bool: the reflex corners of faces ``corners`` ``(3, F, k)`` float64 (axis first; none for a face of
    no area), and ``(F,)`` bool: with ``find_stars``, the faces without one that turn round their normal more than
    once (see :func:`convexity`)."""
    # Newell normal (twice the area vector) of each face, relative to its first corner for precision far out.
    # (Each face's corners shifted by one with _turned, not np.roll: the same copies at a fraction of the overhead,
    # which small meshes pay per mesh.)
    k = corners.shape[2]
    relative = corners - corners[:, :, :1]
    following = _turned(relative, 1)
    normals = _cross(relative, following).sum(axis=2)  # (3, F)
    # A corner is reflex when it turns against the normal by more than REFLEX_SINE.
    outgoing = following - relative
    lengths = np.sqrt((outgoing * outgoing).sum(axis=0))
    incoming, in_lengths = _turned(outgoing, -1), _turned(lengths, -1)
    perimeters = lengths.sum(axis=1)
    # Corners left out of the outline (copies of the next corner, spike tips and the copy before each: _left_out).
    left_out, tips = _left_out(relative, outgoing, lengths, perimeters, k >= 5, with_triangles=False)[:2]
    if left_out.any():
        outgoing, lengths, incoming, in_lengths = _edges_between_kept(relative, ~left_out)
    turn = (_cross(incoming, outgoing) * normals[:, :, None]).sum(axis=0)
    turn[left_out] = 0.0  # the last corner of a run of repeats turns for all of them
    normal_lengths = np.sqrt((normals * normals).sum(axis=0))
    # A spike tip counts as reflex: the fan over it draws outside the outline or turns a triangle over.
    reflex = (turn < -REFLEX_SINE * lengths * in_lengths * normal_lengths[:, None]) | tips
    # A face with no area has no plane to be convex in: the fan is as good as anything.
    flat = normal_lengths <= _FLAT * perimeters ** 2
    reflex[flat] = False
    if not find_stars:
        return reflex, np.zeros(len(flat), bool)
    # The total turning, the sum of the angles between each edge and the next, is 2 pi for a convex face and 2 pi m
    # for one that winds round m times; halfway between the two is safe from rounding. A run of repeated points
    # turns once, at its last corner (the others add atan2(0, 1) = 0). All rows at once: picking the faces without a
    # reflex corner first copied more than the sum costs.
    dots = np.einsum("ifk,ifk->fk", incoming, outgoing)
    dots[left_out] = 1.0
    turns = np.arctan2(turn, dots * normal_lengths[:, None]).sum(axis=1)  # atan2(sin, cos), both times |N|
    return reflex, (turns > 3.0 * np.pi) & ~flat & ~reflex.any(axis=1)


def _kept_neighbours(kept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(following, preceding)`` ``(F, k)``: the nearest corner ``kept`` after and before each corner, cyclically
    (a face with none kept: the corner's own neighbours)."""
    k = kept.shape[1]
    order = np.arange(2 * k)
    twice = np.concatenate([kept, kept], axis=1)  # twice round, so that the search wraps
    last = np.maximum.accumulate(np.where(twice, order, -1), axis=1)
    first = np.minimum.accumulate(np.where(twice, order, 2 * k)[:, ::-1], axis=1)[:, ::-1]
    own = np.arange(k)
    following = np.where(first[:, 1:k + 1] < 2 * k, first[:, 1:k + 1], own + 1) % k
    preceding = np.where(last[:, k - 1:2 * k - 1] >= 0, last[:, k - 1:2 * k - 1], own - 1) % k
    return following, preceding


def _edges_between_kept(relative: np.ndarray, kept: np.ndarray) -> tuple:
    """``(outgoing, lengths, incoming, in_lengths)``: each corner's edges ``(3, F, k)`` to the next corner ``kept``
    and from the last one before it, and their lengths ``(F, k)``, for faces ``relative`` ``(3, F, k)`` whose other
    corners are left out (:func:`_left_out`). A reflex corner listed twice (one point named twice in
    ``faceVertexIndices``, or two points at the same place) has no length on one side of each copy, so neither turned:
    the face was taken for convex and fanned over its notch."""
    following, preceding = _kept_neighbours(kept)
    rows = np.arange(kept.shape[0])[:, None]
    outgoing = relative[:, rows, following] - relative
    incoming = relative - relative[:, rows, preceding]
    return (outgoing, np.sqrt((outgoing * outgoing).sum(axis=0)), incoming,
            np.sqrt((incoming * incoming).sum(axis=0)))


def _left_out(corners: np.ndarray, outgoing: np.ndarray, lengths: np.ndarray, perimeters: np.ndarray,
              find_tips: bool = True, with_triangles: bool = True) -> tuple:
    """``(left_out, tips, triangles)`` of faces ``corners`` ``(d, F, k)`` float64 (axis first) whose ``outgoing``
    edges ``(d, F, k)`` have ``lengths`` ``(F, k)`` round ``perimeters`` ``(F,)``: the corners ``(F, k)`` that are
    not part of the outline, the spike tips among them, and ``(F, k, 3)`` a triangle of no area for each corner left
    out, in the face's order (None when no face has a corner to leave out, or without ``with_triangles``).

    Left out, round by round until none is, of the corners still in (at least three are kept):

    - copies, corners at the place of the next one (within :data:`COPY_DISTANCE` of the face's size: a point listed
      twice, or a few float32 ulps away, a weld that missed): triangle (copy, next, the one after);
    - the tips of zero-width spikes, corners whose two neighbours lie at one place: the outline goes out and back,
      an area of nothing by the even-odd rule (what USD renderers draw), but the tip turns back by 180 degrees, so a
      spike outward was clipped into a triangle outside the outline and one inward made the face look like a star:
      triangle (previous, tip, next);
    - the corner before each tip, at the place of the one after it: triangle (it, the one after the tip, the next).

    A spike on a spike goes in the next round, with its base. Faces of fewer than five corners (``find_tips``
    False) have no spike beside an area to look for: their copies are left out in one round (leaving copies out
    makes no new ones), and without ``with_triangles`` (the convexity check) in one numpy pass, as before there
    were rounds: 500k quads with a corner listed twice took twice as long in rounds."""
    # The perimeter, a sum the caller has, picks the faces that may have copies; their size (a pass over their
    # corners, which would cost the convexity check of every face a third more) decides.
    tolerance = _COPY_PERIMETER * perimeters[:, None]
    candidates = lengths <= tolerance
    if find_tips:
        span = _turned(outgoing, -1) + outgoing  # from each corner's previous corner to its next
        spans = (span * span).sum(axis=0)
        candidates |= spans <= tolerance * tolerance
    n_faces, k = lengths.shape
    left_out = np.zeros((n_faces, k), bool)
    tips = np.zeros((n_faces, k), bool)
    faces = np.flatnonzero(candidates.any(axis=1))
    if len(faces) == 0:
        return left_out, tips, None
    corners = corners if len(faces) == n_faces else corners[:, faces]  # (every face a candidate: no copy made)
    # The size: the farthest corner from the first, which turning the face into its plane keeps (clip_ears has it
    # in plane coordinates, the convexity check in the scene's axes: one measure, so a pair one takes as a copy the
    # other does too).
    reach = corners - corners[:, :, :1]
    tolerance = COPY_DISTANCE * np.sqrt((reach * reach).sum(axis=0).max(axis=1))[:, None]
    if not (find_tips or with_triangles):
        left_out[faces] = lengths[faces] <= tolerance
        return left_out, tips, None
    candidates = lengths[faces] <= tolerance
    if find_tips:
        candidates |= spans[faces] <= tolerance * tolerance
    near = candidates.any(axis=1)
    faces, corners, tolerance = faces[near], corners[:, near], tolerance[near]
    if len(faces) == 0:
        return left_out, tips, None
    triangles = np.zeros((n_faces, k, 3), np.int64) if with_triangles else None
    rows = np.arange(len(faces))[:, None]
    alive = np.ones((len(faces), k), bool)
    corner = np.broadcast_to(np.arange(k), alive.shape)

    def distances(a, b):
        gap = a - b
        return np.sqrt((gap * gap).sum(axis=0))

    for _ in range(k):
        following, preceding = _kept_neighbours(alive)
        ahead = corners[:, rows, following]
        copy = alive & (distances(ahead, corners) <= tolerance)
        tip = (alive & ~copy & (distances(ahead, corners[:, rows, preceding]) <= tolerance) if find_tips
               else np.zeros_like(copy))
        tip &= ~tip[rows, following] & ~tip[rows, preceding]  # (two tips side by side: a zigzag of no area)
        base = np.zeros_like(tip)
        base[np.nonzero(tip)[0], preceding[tip]] = True
        drop = copy | tip | base
        drop &= (alive.sum(axis=1) - drop.sum(axis=1) >= 3)[:, None]
        if not drop.any():
            break
        tips[faces] |= tip & drop
        alive &= ~drop
        if triangles is None:
            continue
        after = following[rows, following]
        found = np.stack([corner, following, after], axis=2)  # a copy's
        found[tip] = np.stack([preceding, corner, following], axis=2)[tip]
        found[base] = np.stack([corner, after, following[rows, after]], axis=2)[base]
        triangles[faces[np.nonzero(drop)[0]], np.nonzero(drop)[1]] = found[drop]
        if not find_tips:
            break  # copies alone: all gone in one round
    left_out[faces] = ~alive
    return left_out, tips, triangles


def clip_ears(xy) -> tuple[np.ndarray, bool]:
    """Ear-clips the polygon ``xy`` ``(n, 2)`` float (n >= 3, counter-clockwise: positive area).

    A corner at the same place as the next (a point listed twice) is left out of the clipping, and given a triangle
    of no area in its place: each copy has an edge of no length, so it turns neither way and is no ear, and where
    the copies were the polygon's convex corners no ear was found (a dart whose tips are listed twice kept its fan).
    So is the tip of a zero-width spike, with the corner before it (:func:`_left_out`): no area by the even-odd rule.

    Returns:
        ``(n - 2, 3)`` int64 corner numbers ``0 .. n-1`` of the triangles, each in the polygon's order (so they wind
        as it does), and whether the clipping finished. When it finds no ear (the polygon crosses itself), the corners
        left are fanned around the first of them; ``False`` is returned only if those have area (a rest in a line
        triangulates to nothing visible).
    """
    xy = np.asarray(xy, np.float64)
    n = len(xy)
    left_out, _, no_area = _left_out_of_faces(xy.T[:, None, :])
    kept = np.flatnonzero(~left_out[0])
    if len(kept) == n or len(kept) < 3:
        return _clip_distinct_ears(xy)
    triangles, clipped = _clip_distinct_ears(xy[kept])
    return np.concatenate([kept[triangles], no_area[0][left_out[0]]]), clipped


def _left_out_of_faces(corners: np.ndarray) -> tuple:
    """:func:`_left_out` of faces ``corners`` ``(d, F, k)`` float64 (axis first)."""
    outgoing = _turned(corners, 1) - corners
    lengths = np.sqrt((outgoing * outgoing).sum(axis=0))
    return _left_out(corners, outgoing, lengths, lengths.sum(axis=1), corners.shape[2] >= 5)


def _clip_distinct_ears(xy: np.ndarray) -> tuple[np.ndarray, bool]:
    """:func:`clip_ears` of a polygon ``xy`` ``(n, 2)`` float64 without a corner at the place of the next."""
    n = len(xy)
    xs, ys = xy[:, 0].tolist(), xy[:, 1].tolist()
    size = float(np.ptp(xy, axis=0).max()) if n else 0.0
    flat = _FLAT * size * size
    nxt = [*range(1, n), 0]
    prev = [n - 1, *range(n - 1)]

    def turn(a, b, c):  # twice the signed area of triangle a, b, c
        return (xs[b] - xs[a]) * (ys[c] - ys[b]) - (ys[b] - ys[a]) * (xs[c] - xs[b])

    convex = [turn(prev[i], i, nxt[i]) > flat for i in range(n)]
    blockers = {i for i in range(n) if not convex[i]}  # corners that may lie inside an ear: reflex and flat ones

    def blocked(a, b, c) -> bool:
        """Whether a blocker lies inside or on triangle a, b, c (counter-clockwise); corners at the same place as
        one of a, b, c (repeated points, keyholes) do not block."""
        corners = ((xs[a], ys[a]), (xs[b], ys[b]), (xs[c], ys[c]))
        if len(blockers) > 32:  # many: one numpy pass
            ids = np.fromiter(blockers, np.int64, len(blockers))
            px, py = xy[ids, 0], xy[ids, 1]
            inside = np.ones(len(ids), bool)
            for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1], strict=True):
                inside &= (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0) >= 0.0
            for x0, y0 in corners:
                inside &= (px != x0) | (py != y0)
            return bool(inside.any())
        for j in blockers:
            px, py = xs[j], ys[j]
            if (px, py) in corners:
                continue
            if all((x1 - x0) * (py - y0) - (y1 - y0) * (px - x0) >= 0.0
                   for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1], strict=True)):
                return True
        return False

    # Cut off ears until three corners are left, or a whole turn round the polygon finds none.
    triangles = []
    remaining, i = n, 0
    stop = i
    while remaining > 3:
        a, c = prev[i], nxt[i]
        if convex[i] and not blocked(a, i, c):
            triangles.append((a, i, c))
            nxt[a], prev[c] = c, a
            blockers.discard(i)
            remaining -= 1
            for j in (a, c):
                convex[j] = turn(prev[j], j, nxt[j]) > flat
                (blockers.discard if convex[j] else blockers.add)(j)
            i = stop = c
            continue
        i = nxt[i]
        if i == stop:
            break

    # Fan the rest: the last triangle, or the corners no ear could be cut from.
    rest = [i]
    while nxt[rest[-1]] != i:
        rest.append(nxt[rest[-1]])
    triangles += [(rest[0], rest[k], rest[k + 1]) for k in range(1, len(rest) - 1)]
    area = sum(turn(rest[0], rest[k], rest[k + 1]) for k in range(1, len(rest) - 1))
    clipped = len(rest) == 3 or abs(area) <= flat * len(rest)
    return np.array(triangles, np.int64).reshape(-1, 3), clipped


def plane_coordinates(corners) -> np.ndarray:
    """``(n, 2)`` coordinates of ``corners`` ``(n, 3)`` in the plane normal to their Newell normal, with axes chosen so
    that the polygon winds counter-clockwise (positive area) in them: :func:`plane_coordinates_batch` of one face."""
    return plane_coordinates_batch(np.asarray(corners, np.float64).T[:, None, :])[0]


BATCH_CORNERS = 64  # concave faces of up to this many corners are clipped together, in numpy; larger ones one by one


def plane_coordinates_batch(corners) -> np.ndarray:
    """``(F, k, 2)`` coordinates of faces ``corners`` ``(3, F, k)`` (axis first) in the planes normal to their Newell
    normals, with axes chosen so that each face winds counter-clockwise (positive area) in them."""
    relative = corners - corners[:, :, :1]
    normals = _cross(relative, np.roll(relative, -1, axis=2)).sum(axis=2)  # (3, F)
    normals = normals / np.sqrt((normals * normals).sum(axis=0))
    helpers = np.eye(3)[np.argmin(np.abs(normals), axis=0)].T
    u = _cross(helpers, normals)
    u = u / np.sqrt((u * u).sum(axis=0))
    v = _cross(normals, u)
    return np.stack([(relative * u[:, :, None]).sum(axis=0), (relative * v[:, :, None]).sum(axis=0)], axis=-1)


def _neighbours(alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(next, previous)`` ``(F, k)``: the nearest corner still ``alive`` after and before each corner, cyclically."""
    k = alive.shape[1]
    ahead = (np.arange(k)[:, None] + np.arange(1, k)) % k  # (k, k-1): corners after each, nearest first
    behind = (np.arange(k)[:, None] - np.arange(1, k)) % k
    following = ahead[np.arange(k), np.argmax(alive[:, ahead], axis=2)]
    preceding = behind[np.arange(k), np.argmax(alive[:, behind], axis=2)]
    return following, preceding


def clip_ears_batch(xy) -> tuple[np.ndarray, np.ndarray]:
    """Ear-clips faces ``xy`` ``(F, k, 2)`` float (k >= 4, each counter-clockwise) together, one ear per face a step,
    as :func:`clip_ears` does for one.

    Returns:
        ``(F, k - 2, 3)`` int64 corner numbers of the triangles, each in the face's order, and ``(F,)`` bool whether a
        face was clipped through (False: some step found no ear; its triangles are then not to be used).
    """
    xy = np.asarray(xy, np.float64)
    n_faces, k, _ = xy.shape
    x, y = xy[..., 0], xy[..., 1]
    size = np.maximum(np.ptp(x, axis=1), np.ptp(y, axis=1))
    flat = (_FLAT * size * size)[:, None]
    rows = np.arange(n_faces)[:, None]
    alive = np.ones((n_faces, k), bool)
    clipped = np.ones(n_faces, bool)
    triangles = np.zeros((n_faces, k - 2, 3), np.int64)
    for step in range(k - 3):
        following, preceding = _neighbours(alive)
        ax, ay, cx, cy = x[rows, preceding], y[rows, preceding], x[rows, following], y[rows, following]
        convex = alive & ((x - ax) * (cy - y) - (y - ay) * (cx - x) > flat)
        blockers = alive & ~convex
        # Blocker b (last axis) inside or on the triangle of corner j (middle axis), not at one of its corners.
        px, py = x[:, None, :], y[:, None, :]
        inside = np.repeat(blockers[:, None, :], k, axis=1)
        for (x0, y0), (x1, y1) in (((ax, ay), (x, y)), ((x, y), (cx, cy)), ((cx, cy), (ax, ay))):
            x0, y0, x1, y1 = x0[..., None], y0[..., None], x1[..., None], y1[..., None]
            inside &= (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0) >= 0.0
        for x0, y0 in ((ax, ay), (x, y), (cx, cy)):
            inside &= (px != x0[..., None]) | (py != y0[..., None])
        ears = convex & ~inside.any(axis=2)
        clipped &= ears.any(axis=1)
        ear = np.argmax(ears | ~clipped[:, None] & alive, axis=1)  # a face with no ear drops any corner: discarded
        triangles[:, step] = np.stack([preceding[rows[:, 0], ear], ear, following[rows[:, 0], ear]], axis=1)
        alive[rows[:, 0], ear] = False
    # The last three corners, in the face's order.
    triangles[:, k - 3] = np.sort(np.argsort(~alive, axis=1, kind="stable")[:, :3], axis=1)
    return triangles, clipped


def _clip_ears_past_left_out_batch(corners: np.ndarray, left_out: tuple) -> tuple[np.ndarray, np.ndarray]:
    """:func:`clip_ears_batch` of faces ``corners`` ``(3, F, k)`` float64 (axis first) with corners ``left_out``
    (:func:`_left_out_of_faces`: copies, spike tips), as :func:`clip_ears` clips one: each face without them, those of
    one count of kept corners together, and a triangle of no area for each corner left out (20,000 darts whose reflex
    corner is listed twice took 10 s clipped one at a time, as many without copies 0.1 s). Returns what
    :func:`clip_ears_batch` returns, corner numbers of the faces as given."""
    dropped, _, no_area = left_out
    n_faces, k = dropped.shape
    triangles = np.zeros((n_faces, k - 2, 3), np.int64)
    clipped = np.zeros(n_faces, bool)
    distinct = k - dropped.sum(axis=1)
    order = np.argsort(dropped, axis=1, kind="stable")  # each face's kept corners first, in the face's order
    for m in np.unique(distinct[distinct >= 3]).tolist():
        group = np.flatnonzero(distinct == m)
        kept, gone = order[group, :m], order[group, m:]  # (G, m), (G, k - m)
        rows = np.arange(len(group))[:, None]
        if m == 3:
            ears, done = np.zeros((len(group), 1, 3), np.int64) + np.arange(3), np.ones(len(group), bool)
        else:
            ears, done = clip_ears_batch(plane_coordinates_batch(corners[:, group[:, None], kept]))
        triangles[group, :m - 2] = kept[rows[:, :, None], ears]
        triangles[group, m - 2:] = no_area[group[:, None], gone]
        clipped[group] = done
    return triangles, clipped


def clip_concave_faces(points, counts, face_indices, tri_corners,
                       on_problem: Callable[[str, str], None] | None = None, holes=None) -> np.ndarray:
    """The fan ``tri_corners`` of :func:`wrt.usd_meshes.triangulate` with the rows of every concave face replaced by
    ear-clipped triangles that lie inside the face.

    Args:
        points: ``(V, 3)`` float, the mesh's points (its own space).
        counts: ``(F,)`` int, corners per face (``faceVertexCounts``).
        face_indices: ``(N,)`` int, rows into ``points`` (``faceVertexIndices``), already checked in range.
        tri_corners: ``(T, 3)`` int64 positions into ``face_indices``: the fan, ``n - 2`` rows per face in face order.
        on_problem: called ``(reason, detail)`` for faces left fanned although not convex, once per reason.
        holes: ``(H,)`` int, faces that are not drawn (``holeIndices``; numbers out of range are ignored): they keep
            their fan, neither clipped nor reported.

    Returns:
        ``(T, 3)`` int64, a copy where anything changed; the rows of convex faces are the fan's.
    """
    counts = np.asarray(counts, np.int64)
    face_indices = np.asarray(face_indices, np.int64)
    reflex, stars = convexity(points, counts, face_indices)
    if holes is not None and len(holes):
        hidden = np.asarray(holes, np.int64).reshape(-1)
        hidden = hidden[(hidden >= 0) & (hidden < len(counts))]
        reflex[hidden], stars[hidden] = 0, False  # never drawn: what their fan looks like does not matter
    concave = np.flatnonzero(reflex > 0)
    # A star keeps its fan: it crosses itself, so it has no inside to clip to.
    crossing = np.flatnonzero(stars).tolist()
    if len(concave) == 0:
        _report(on_problem, crossing, [])
        return tri_corners
    tri_corners = tri_corners.copy()
    starts = np.cumsum(counts) - counts
    first_tri = np.cumsum(np.maximum(counts - 2, 0)) - np.maximum(counts - 2, 0)

    # Faces of up to BATCH_CORNERS corners: clipped together, those of one corner count at a time.
    points = np.asarray(points)
    planes = points.T
    one_by_one, too_large = [], []
    for k in np.unique(counts[concave]).tolist():
        faces = concave[counts[concave] == k]
        if k > BATCH_CORNERS:
            one_by_one += faces.tolist()
            continue
        step = max(BLOCK_CORNERS // (k * k), 1)
        for b in range(0, len(faces), step):
            block = faces[b:b + step]
            corners = planes[:, face_indices[starts[block][:, None] + np.arange(k)]].astype(np.float64)
            left_out = _left_out_of_faces(corners)
            if left_out[0].any():  # clipped past copies and spikes (no ear is found where copies are convex corners)
                triangles, clipped = _clip_ears_past_left_out_batch(corners, left_out)
            else:
                triangles, clipped = clip_ears_batch(plane_coordinates_batch(corners))
            rows = first_tri[block[clipped]][:, None] + np.arange(k - 2)
            tri_corners[rows] = starts[block[clipped]][:, None, None] + triangles[clipped]
            # No ear at some step: clipped alone, which finishes where the corners left lie in a line.
            one_by_one += block[~clipped].tolist()

    # The rest one at a time in their best-fit plane.
    for f in one_by_one:
        n, s = int(counts[f]), int(starts[f])
        if n > MAX_CLIPPED_CORNERS:
            too_large.append(f"face {f} ({n:,} corners)")
            continue
        triangles, clipped = clip_ears(plane_coordinates(points[face_indices[s:s + n]].astype(np.float64)))
        if not clipped:  # no inside to keep to: the face keeps its fan rows, as the warning says
            crossing.append(f)
            continue
        tri_corners[first_tri[f]:first_tri[f] + n - 2] = s + triangles

    _report(on_problem, sorted(crossing), too_large)
    return tri_corners


def _report(on_problem, crossing: list, too_large: list) -> None:
    """Tells ``on_problem`` of the faces left fanned: ``crossing`` face numbers, ``too_large`` descriptions."""
    if on_problem is None:
        return
    if crossing:
        shown = ", ".join(str(f) for f in crossing[:5]) + (", ..." if len(crossing) > 5 else "")
        on_problem("non-convex faces that cross themselves were fan-triangulated (not clipped)",
                   f"{len(crossing)} face(s): {shown}")
    if too_large:
        on_problem(f"non-convex faces of more than {MAX_CLIPPED_CORNERS:,} corners were fan-triangulated "
                   "(some triangles lie outside them)", ", ".join(too_large))


__all__ = ["MAX_CLIPPED_CORNERS", "clip_concave_faces", "clip_ears", "clip_ears_batch", "convexity",
           "plane_coordinates", "plane_coordinates_batch", "reflex_counts"]
