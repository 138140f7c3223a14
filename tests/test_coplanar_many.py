"""The plane hash's grid and probes (``wrt.coplanar``) on many triangles at once: scattered coplanar triangles of
both windings, big and small, in several planes and spaces, paired exactly as float64 polygon clipping says; and
its host helpers (the bucket filter, the row sort) against plain numpy oracles."""

import numpy as np
import pytest
from test_coplanar import clipped_area, cross2

from wrt.coplanar import _row_order, coplanar_pairs, two_sided_cells


def scattered_planes(seed: int, per_plane: int):
    """Triangles scattered over 3 generic planes (``per_plane`` each; every 40th some 20 times the others' size, so
    past the grid's BIG_CELLS), random windings, spaces -1 and 0, a tenth double-sided: ``(points (V, 3) float32,
    tris (T, 3), spaces (T,), double_sided (T,), flat (T, 3, 2) float64 corners in their plane's own
    coordinates, plane (T,) int)``."""
    rng = np.random.default_rng(seed)
    points, flats, planes = [], [], []
    for plane in range(3):
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        u = np.cross(normal, [0.3, 0.5, 0.8])
        u /= np.linalg.norm(u)
        v = np.cross(normal, u)
        size = np.where(np.arange(per_plane) % 40 == 0, 12.0, rng.uniform(0.1, 0.8, per_plane))
        # Jittered equilateral triangles, turned at random (no slivers: those are paired across edges instead).
        turn = rng.uniform(0, 2 * np.pi, (per_plane, 1)) + np.array([0, 2, 4]) * np.pi / 3
        shape = np.stack([np.cos(turn), np.sin(turn)], axis=2) + rng.uniform(-0.2, 0.2, (per_plane, 3, 2))
        flat = rng.uniform(-6, 6, (per_plane, 1, 2)) + shape * size[:, None, None]
        flip = rng.random(per_plane) < 0.5
        flat[flip] = flat[flip, ::-1]
        points.append((rng.normal(size=3) * 4 + flat[..., :1] * u + flat[..., 1:] * v).reshape(-1, 3))
        flats.append(flat)
        planes.append(np.full(per_plane, plane))
    n = 3 * per_plane
    points = np.concatenate(points).astype(np.float32)
    # The oracle works on the float32 corners, in float64, projected on their plane's basis.
    return (points, np.arange(3 * n).reshape(n, 3), rng.integers(-1, 1, n), rng.random(n) < 0.1,
            np.concatenate(flats), np.concatenate(planes))


def clipping_pairs(flat, plane, spaces, double_sided) -> set:
    """``(t, p)``: ``t`` single-sided, ``p`` in its plane and space, of the other winding or double-sided, sharing
    area with it (float64 clipping, above 1e-6 of the smaller: no pair here comes near that)."""
    winding = np.sign(cross2(flat[:, 1] - flat[:, 0], flat[:, 2] - flat[:, 0]))
    area = 0.5 * np.abs(cross2(flat[:, 1] - flat[:, 0], flat[:, 2] - flat[:, 0]))
    lower, upper = flat.min(axis=1), flat.max(axis=1)
    pairs = set()
    for t in np.flatnonzero(~double_sided):
        near = ((plane == plane[t]) & (spaces == spaces[t]) & (double_sided | (winding != winding[t]))
                & (lower < upper[t]).all(axis=1) & (upper > lower[t]).all(axis=1))
        near[t] = False
        pairs |= {(t, p) for p in np.flatnonzero(near)
                  if clipped_area(flat[t], flat[p]) > 1e-6 * min(area[t], area[p])}
    return pairs


@pytest.mark.parametrize("seed", [1, 2])
def test_scattered_coplanar_triangles_pair_as_clipping_says(seed):
    """Hundreds of triangles scattered over three planes (some big enough to be paired plane-cell-wide, some
    double-sided, two spaces): the pairs found are exactly those float64 polygon clipping finds, and a limit keeps at
    least each triangle's lowest ``limit`` partners of the full set."""
    points, tris, spaces, double_sided, flat, plane = scattered_planes(seed, 200)
    want = clipping_pairs(flat, plane, spaces, double_sided)
    assert len(want) > 500 and any(double_sided[p] for _, p in want)
    pairs, uncertain, opposed = coplanar_pairs(points, tris, spaces, double_sided)
    assert opposed and not len(uncertain)
    assert set(map(tuple, pairs.tolist())) == want
    limited = set(map(tuple, coplanar_pairs(points, tris, spaces, double_sided, limit=2)[0].tolist()))
    assert limited <= want
    for t in {t for t, _ in want}:
        lowest = sorted(p for s, p in want if s == t)[:2]
        assert {(t, p) for p in lowest} <= limited


def test_row_order_is_numpy_lexsort():
    """The row sort packs its five keys into one when they fit: the same order as ``np.lexsort`` (ties in row
    order), and lexsort itself when they do not (cells far apart in one group, tris past 2**40, groups unsorted)."""
    rng = np.random.default_rng(5)
    n = 5000
    groups = np.sort(rng.integers(0, 300, n))
    cells = rng.integers(-40, 40, (n, 2)) + rng.integers(-10 ** 6, 10 ** 6, 300)[groups, None]
    ranks, tris = rng.integers(0, 3, n), rng.integers(0, 400, n)  # repeats: ties kept in row order
    for g, c, t in ((groups, cells, tris), (groups, cells * 10 ** 6, tris), (groups, cells, tris + 2 ** 40),
                    (groups[::-1], cells, tris)):
        np.testing.assert_array_equal(_row_order(g, c, ranks, t), np.lexsort((t, ranks, c[:, 1], c[:, 0], g)))
    assert len(_row_order(groups[:0], cells[:0], ranks[:0], tris[:0])) == 0


def test_two_sided_cells_are_those_a_count_per_key_gives():
    """The entries whose key holds a side that may face theirs (0 and 1 face each other, 2 faces both), sorted by
    key then entry, as a dictionary of each key's sides gives; with keys that share their low bits (the buckets)."""
    rng = np.random.default_rng(9)
    n = 60000
    distinct = rng.integers(0, 2 ** 63, 30000, dtype=np.uint64)
    low = np.uint64(2 ** 42 - 1)
    distinct[1::2] = (distinct[1::2] & ~low) | (distinct[::2] & low)  # pairs of keys in one bucket every pass
    keys = distinct[rng.integers(0, len(distinct), n)]
    sides = rng.choice(3, n, p=[0.49, 0.49, 0.02])
    seen = {}
    for k, s in zip(keys.tolist(), sides.tolist()):
        seen.setdefault(k, set()).add(s)
    faces = {0: {1, 2}, 1: {0, 2}, 2: {0, 1}}
    want = sorted((k, i) for i, (k, s) in enumerate(zip(keys.tolist(), sides.tolist())) if seen[k] & faces[s])
    assert 100 < len(want) < n
    np.testing.assert_array_equal(two_sided_cells(keys, sides), [i for _, i in want])


def test_small_triangles_over_a_big_one_pair_with_it_once():
    """Small triangles of one winding over a big reversed one (past BIG_CELLS: paired plane-cell-wide), all on
    z = 0, each in one plane cell: every small triangle pairs with the big one and the big one with each small one,
    each pair once (each small entry probed the big entries twice, a third of shaderball_scene's pairs repeats)."""
    n = 300  # (the big one's box over some 100 x 100 of the cells their mean size makes)
    corners = np.array([[0, 0], [0.9, 0.1], [0.2, 0.8]])
    small = (np.arange(n)[:, None, None] % 20) * [1.5, 0] + (np.arange(n)[:, None, None] // 20) * [0, 1.5] + corners
    flat = np.concatenate([small.reshape(-1, 2), [[-1, -1], [-1, 400], [400, -1]]])
    points = np.concatenate([flat, np.zeros((len(flat), 1))], axis=1).astype(np.float32)
    tris = np.concatenate([np.arange(3 * n).reshape(n, 3), [[3 * n, 3 * n + 1, 3 * n + 2]]])
    pairs, _, _ = coplanar_pairs(points, tris, np.full(n + 1, -1), np.zeros(n + 1, bool))
    want = {(t, n) for t in range(n)} | {(n, t) for t in range(n)}
    assert set(map(tuple, pairs.tolist())) == want
    assert len(pairs) == len(want)
