"""Rays a robot's sensors cast, against a float64 brute-force oracle, with every builder and layout.

A depth camera sits in a millimetre-unit room far from the world origin: its rays start on walls and furniture or
inside the room and keep to a ``[t_min, t_max)`` band. Rays from the centre of a closed octahedron pass exactly
through its vertices (directions with zero components, some nudged by subnormal ones), edge midpoints and face
centres, with lengths 1e-30 ... 1e30. The oracle intersects every ray with every triangle in float64; a ray within
the float32 rounding of the scene's coordinates of an edge or of a ``t`` limit is a tie that either answer may take.
"""

import numpy as np
import pytest

import wrt

BUILDERS = ["sah", "sweep_sah", "median", "middle", "lbvh", "ploc"]
LAYOUTS = ["binary", "compact", "wide", "wide8"]
TIE_ULPS = 16  # float32 ulps of the scene's largest coordinate within which a hit is a tie


def box(lo, hi):
    """``(8, 3)`` corners and ``(12, 3)`` triangles of an axis-aligned box."""
    unit = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
    tris = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5],
                     [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    return np.asarray(lo) + unit * (np.asarray(hi) - np.asarray(lo)), tris


def oracle(points, tris, origins, directions, t_min, t_max, scale):
    """Per ray, in float64: the nearest ``t`` of a triangle certainly hit (inf: none), and ``(R, T)`` masks of the
    triangles possibly hit and the ``t`` of each, ties included."""
    p = points.astype(np.float64)[tris]  # (T, 3, 3)
    o, d = origins.astype(np.float64)[:, None], directions.astype(np.float64)[:, None]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("tk,rtk->rt", n, p[None, :, 0] - o) / np.einsum("tk,rk->rt", n, d[:, 0])
        hit_points = o + t[..., None] * d
        # Signed distance of the hit point to each edge line, in the triangle's plane.
        dist = np.full(t.shape, np.inf)
        for a, b in ((0, 1), (1, 2), (2, 0)):
            edge = p[:, b] - p[:, a]
            side = np.einsum("rtk,tk->rt", np.cross(edge[None], hit_points - p[None, :, a]), n) / area2
            dist = np.minimum(dist, side / np.linalg.norm(edge, axis=1))
        cos = np.abs(np.einsum("tk,rk->rt", n, d[:, 0])) / (area2 * np.linalg.norm(d[:, 0], axis=1)[:, None])
    ulp = float(np.spacing(np.float32(scale)))
    slack = TIE_ULPS * ulp / np.maximum(cos, 1e-9)  # along the surface
    t_slack = (1e-5 * np.abs(t) + 64 * ulp / np.linalg.norm(d, axis=2)) / np.maximum(cos, 1e-3)  # along the ray
    t_min, t_max = t_min[:, None], t_max[:, None]
    valid = np.isfinite(t)
    with np.errstate(invalid="ignore"):  # inf - inf where t_max is inf and the ray runs in the plane
        possible = valid & (dist >= -slack) & (t >= t_min - t_slack) & (t < t_max + t_slack)
        certain = valid & (dist > slack) & (t >= t_min + t_slack) & (t < t_max - t_slack)
    return np.where(certain, t, np.inf).min(axis=1), possible, t, t_slack


def assert_agrees(scene, origins, directions, t_min, t_max, what):
    """Every builder (binary layout), every layout (``sah``) and every thread agree with :func:`oracle`, and
    ``occluded`` with it (an offline fuzz ran every builder with every layout: the same hits)."""
    points, tris = scene.triangles()
    scale = max(float(np.abs(points).max()), float(np.abs(origins).max()))
    certain_t, possible, t_all, t_slack = oracle(points, tris, origins, directions, t_min, t_max, scale)
    rows = np.arange(len(origins))
    configs = [(b, "binary", 1) for b in BUILDERS] + [("sah", lay, 1) for lay in LAYOUTS[1:]]
    configs.append(("sah", "wide8", "all"))
    for builder, layout, threads in configs:
        where = f"{what}, builder={builder}, layout={layout}, threads={threads}"
        kw = dict(t_min=t_min, t_max=t_max, builder=builder, layout=layout, threads=threads)
        hits = wrt.trace(scene, origins, directions, **kw)
        missed = ~hits.hit & np.isfinite(certain_t)
        assert not missed.any(), f"{where}: {missed.sum()} rays missed a certain hit, e.g. ray {np.argmax(missed)}"
        h = rows[hits.hit]
        prim = hits.prim[h]
        assert possible[h, prim].all(), f"{where}: hits on triangles the rays cannot meet: rays {h[~possible[h, prim]]}"
        t_err = np.abs(hits.t[h] - t_all[h, prim])
        assert (t_err <= t_slack[h, prim]).all(), f"{where}: t off its triangle's by {t_err.max():.3g}"
        nearer = hits.t[h] <= certain_t[h] + t_slack[h, prim]
        assert nearer.all(), f"{where}: a farther triangle than the nearest certain hit: rays {h[~nearer]}"
        blocked = wrt.occluded(scene, origins, directions, **kw)
        assert not (~blocked & np.isfinite(certain_t)).any(), f"{where}: occluded missed a certain hit"
        assert not (blocked & ~possible.any(axis=1)).any(), f"{where}: occluded by nothing"


@pytest.mark.parametrize("offset", [0.0, 9e4])
def test_depth_camera_in_a_millimetre_room_far_from_the_origin(offset):
    """A room 4 x 3 x 5 m in millimetres with six boxes in it, ``offset`` mm from the origin (ulps of 1/128 mm at
    9e4): rays from inside the room and from points on its walls and boxes, ``t_min`` 0.1 to 10 mm and ``t_max``
    50 mm to 2 m, and the rays from inside without limits, none of which may leave the closed room."""
    rng = np.random.default_rng(64)
    parts = [box([0, 0, 0], [4, 3, 5])] + [box(lo, lo + rng.uniform(0.1, 1.0, 3))
                                           for lo in rng.uniform([0.2, 0, 0.2], [3, 1.5, 4], (6, 3))]
    points = np.concatenate([p for p, _ in parts]) * 1000.0 + offset
    tris = np.concatenate([t + 8 * k for k, (_, t) in enumerate(parts)]).astype(np.int32)
    scene = wrt.Scene.from_triangles(points.astype(np.float32), tris)
    scene.meters_per_unit = 0.001
    n = 160
    inside = rng.uniform([40, 30, 50], [3960, 2970, 4950], (n, 3)) + offset
    on_surface = np.einsum("ij,ijk->ik", rng.dirichlet([1, 1, 1], n), points[tris[rng.integers(0, len(tris), n)]])
    origins = np.concatenate([inside, on_surface]).astype(np.float32)
    directions = rng.normal(size=(2 * n, 3)).astype(np.float32)
    t_min = rng.choice([0.1, 1.0, 10.0], 2 * n).astype(np.float32)
    t_max = rng.uniform(50.0, 2000.0, 2 * n).astype(np.float32)
    assert_agrees(scene, origins, directions, t_min, t_max, f"room at {offset:g} mm, t band")
    none, inf = np.zeros(n, np.float32), np.full(n, np.inf, np.float32)
    assert_agrees(scene, origins[:n], directions[:n], none, inf, f"room at {offset:g} mm, from inside")
    assert wrt.trace(scene, origins[:n], directions[:n], layout="wide8").hit.all()


@pytest.mark.parametrize("size, offset", [(1.0, 0.0), (1000.0, 1e6)])
def test_rays_through_an_octahedrons_vertices_edges_and_faces(size, offset):
    """From the centre of a closed octahedron exactly through its 6 vertices (two zero direction components), 12 edge
    midpoints (one) and 8 face centres, each also nudged by components of 1e-45, 1e-40 and 1e-38 and scaled to
    lengths 1e-30 and 1e30: every ray hits (a vertex is shared by four triangles, an edge by two), at the float64
    ``t``, also from ``t_min`` a hundredth of the way out."""
    axes = np.concatenate([np.eye(3), -np.eye(3)])
    faces = [[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 0, 2], [1, 0, 5], [3, 1, 5], [4, 3, 5], [0, 4, 5]]
    points = (axes * size + offset).astype(np.float32)
    scene = wrt.Scene.from_triangles(points, np.array(faces, np.int32))
    edges = (axes[:, None] + axes[None]).reshape(-1, 3)
    edges = np.unique(edges[np.abs(edges).sum(axis=1) == 2], axis=0)
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    base = np.concatenate([axes, edges, corners]).astype(np.float64)
    signs = np.random.default_rng(5).choice([-1.0, 0.0, 1.0], (3, *base.shape))
    nudged = [base] + [base + tiny * s for tiny, s in zip((1e-45, 1e-40, 1e-38), signs)]
    directions = np.concatenate([np.concatenate(nudged) * length for length in (1.0, 1e-30, 1e30)])
    directions = directions.astype(np.float32)
    origins = np.full((len(directions), 3), offset, np.float32)
    lengths = np.linalg.norm(directions.astype(np.float64), axis=1)
    t_min = (0.01 * size / lengths).astype(np.float32)
    assert_agrees(scene, origins, directions, t_min, np.full(len(origins), np.inf, np.float32),
                  f"octahedron of size {size:g} at {offset:g}")
    assert wrt.trace(scene, origins, directions, t_min=t_min).hit.all()
