"""wrt's BVH against Warp's wp.Mesh, ray by ray, on real scenes; and against a brute-force oracle."""

import os
import re
import warnings

import numpy as np
import pytest
import warp as wp
from conftest import WARP_USD_ASSETS, warp_assets

import wrt
from wrt.compare import compare_hits
from wrt.geometry import intersect_ray_triangle, make_sheared_ray
from wrt.instancing import Instances, Prototype
from wrt.rays import camera_rays, random_rays
from wrt.scene import Mesh
from wrt.trace import WARP_BUILDERS, get_accelerator

SHARED_SCENES = (
    "cornell_box",
    "spot_control_ngons",
    "xform_complex",
    "xform_weird_matrix",
    "mesh_mixed_counts",
    "stage_upaxis_z",
)
MAX_TIE_FRACTION = 1e-4  # disagreements allowed on rays through edges/vertices (documented exact ties)
DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])  # the box test differs per device (geometry.py)


def agreement_rays(scene):
    """1e5 rays: 5e4 camera rays and 5e4 random rays."""
    o1, d1 = camera_rays(scene, width=250, height=200)
    o2, d2 = random_rays(scene, 50_000, seed=7)
    return np.concatenate([o1, o2]), np.concatenate([d1, d2])


def check_agreement(scene):
    origins, directions = agreement_rays(scene)
    assert len(origins) == 100_000
    ours = wrt.trace(scene, origins, directions, accel="wrt")
    theirs = wrt.trace(scene, origins, directions, accel="warp")
    points = scene.triangles()[0]
    scale = float(np.abs(points).max()) if len(points) else 0.0
    report = compare_hits(ours, theirs, directions=directions, scale=scale)
    assert report["disagreements"] == 0, report
    assert report["tie_disagreements"] <= MAX_TIE_FRACTION * report["rays"], report
    return report


@pytest.mark.parametrize("name", WARP_USD_ASSETS)
def test_agrees_with_wp_mesh_on_warp_assets(name):
    scene = wrt.load_usd(warp_assets(name))
    assert scene.stats()["rendered_triangles"] > 0
    report = check_agreement(scene)
    assert report["hits_a"] > 0


@pytest.mark.parametrize("asset_id", SHARED_SCENES)
def test_agrees_with_wp_mesh_on_shared_scenes(assets, asset_id):
    # Gprims as triangles (boxes exactly): wp.Mesh has no analytic shapes.
    scene = wrt.load_usd(assets(asset_id), tessellate_gprims=True)
    check_agreement(scene)


@wp.kernel
def brute_force_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    # outputs
    ts: wp.array[float],
    prims: wp.array[wp.int32],
):
    """O(n) oracle: test every triangle, keep the nearest (ties to the smaller id)."""
    i = wp.tid()
    ray = make_sheared_ray(origins[i], directions[i])
    best_t = float(wp.inf)
    best = int(-1)
    for k in range(indices.shape[0]):
        hit, t, u, v = intersect_ray_triangle(ray, points[indices[k, 0]], points[indices[k, 1]], points[indices[k, 2]])
        if hit and t >= 0.0 and t < best_t:
            best_t = t
            best = k
    ts[i] = best_t
    prims[i] = best


def brute_force(points, indices, origins, directions):
    n = len(origins)
    ts = wp.empty(n, dtype=float, device="cpu")
    prims = wp.empty(n, dtype=wp.int32, device="cpu")
    inputs = [
        wp.array(points, dtype=wp.vec3, device="cpu"),
        wp.array(indices, dtype=wp.int32, device="cpu"),
        wp.array(origins, dtype=wp.vec3, device="cpu"),
        wp.array(directions, dtype=wp.vec3, device="cpu"),
    ]
    wp.launch(brute_force_kernel, n, inputs=inputs, outputs=[ts, prims], device="cpu")
    return ts.numpy(), prims.numpy()


def random_soup(rng, n_tris):
    centers = rng.uniform(-1, 1, (n_tris, 1, 3))
    points = (centers + rng.normal(scale=0.15, size=(n_tris, 3, 3))).reshape(-1, 3).astype(np.float32)
    return points, np.arange(3 * n_tris, dtype=np.int32).reshape(-1, 3)


@pytest.mark.parametrize("builder", ["sah", "middle"])
@pytest.mark.parametrize("leaf_size", [1, 4, 8])
def test_brute_force_oracle_on_triangle_soup(builder, leaf_size, np_rng):
    points, indices = random_soup(np_rng, 300)
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 4000, seed=3)
    bvh = wrt.build_bvh(points, indices, builder, leaf_size=leaf_size, device="cpu")
    bvh.validate()
    # Trace through this exact tree (not the cached default one).
    scene._cache[("accel", "wrt", builder, "cpu")] = _accel_for(scene, bvh)
    hits = wrt.trace(scene, origins, directions, builder=builder)
    t_ref, prim_ref = brute_force(points, indices, origins, directions)
    # Same triangle test, same tie rule: identical answers, bit for bit.
    np.testing.assert_array_equal(hits.prim, prim_ref)
    np.testing.assert_array_equal(hits.t, t_ref)
    assert 0.2 < hits.hit.mean() < 1.0


def _accel_for(scene, bvh):
    from wrt.trace import BvhAccelerator

    acc = BvhAccelerator.__new__(BvhAccelerator)
    points, indices = scene.triangles()
    acc.bvh, acc.device = bvh, wp.get_device("cpu")
    acc.device_bvh = bvh.to_device(points, indices, "cpu")
    return acc


def test_barycentrics_reconstruct_the_hit_point(np_rng):
    points, indices = random_soup(np_rng, 200)
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 5000, seed=1)
    hits = wrt.trace(scene, origins, directions)
    h = hits.hit
    p0, p1, p2 = (points[indices[hits.prim[h], k]] for k in range(3))
    w = (1 - hits.u[h] - hits.v[h])[:, None]
    from_bary = w * p0 + hits.u[h][:, None] * p1 + hits.v[h][:, None] * p2
    from_ray = origins[h] + hits.t[h][:, None] * directions[h]
    np.testing.assert_allclose(from_bary, from_ray, atol=1e-5)
    assert np.all(hits.u[h] >= 0) and np.all(hits.v[h] >= 0) and np.all(hits.u[h] + hits.v[h] <= 1 + 1e-6)


def test_t_is_in_units_of_direction_length():
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.array([[0, 0, 5], [0, 0, 5]], np.float32)
    directions = np.array([[0, 0, -1], [0, 0, -2]], np.float32)
    for accel in ("wrt", "warp"):
        hits = wrt.trace(scene, origins, directions, accel=accel)
        np.testing.assert_allclose(hits.t, [5.0, 2.5], rtol=1e-6)
        np.testing.assert_allclose(hits.u, [0.25, 0.25], atol=1e-6)
        np.testing.assert_allclose(hits.v, [0.5, 0.5], atol=1e-6)


def test_t_max_is_exclusive_and_per_ray():
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.array([[0, 0, 5]] * 3, np.float32)
    directions = np.array([[0, 0, -1]] * 3, np.float32)
    for accel in ("wrt", "warp"):
        hits = wrt.trace(scene, origins, directions, t_max=np.array([4.0, 5.0, 6.0]), accel=accel)
        assert hits.prim.tolist() == [-1, -1, 0]
        assert np.isinf(hits.t[:2]).all()
    with pytest.raises(ValueError, match=r"t_max .* shape .* \(3,\) or \(3, 1\); got shape \(2,\)"):
        wrt.trace(scene, origins, directions, t_max=[4.0, 5.0])
    # None means no limit, as the default does (it became NaN and every ray missed); NaN itself is refused.
    assert wrt.trace(scene, origins, directions, t_max=None).prim.tolist() == [0, 0, 0]
    assert wrt.occluded(scene, origins, directions, t_max=None).tolist() == [True] * 3
    for t_max in (np.nan, [4.0, np.nan, 6.0]):
        with pytest.raises(ValueError, match="t_max must not be NaN"):
            wrt.trace(scene, origins, directions, t_max=t_max)
    # A None among per-ray values was refused as "t_max must not be NaN ...; use inf (or None) for no limit".
    for t_max, row in (([None] * 3, 0), ([4.0, None, 6.0], 1), ([None], 0), (np.array([4.0, 5.0, None]), 2)):
        with pytest.raises(ValueError, match=rf"t_max\[{row}\] is None: one value per ray takes numbers only \(None "
                                             r"stands for the whole argument, the default\); give inf for no limit"):
            wrt.trace(scene, origins, directions, t_max=t_max)
    with pytest.raises(ValueError, match=r"t_min\[1\] is None: .*; give 0 there"):
        wrt.occluded(scene, origins, directions, t_min=[0.0, None, 0.0])


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_hits_just_below_t_max_are_kept(accel):
    """wp.Mesh's traversal drops a box entered within rounding of its limit: with ``t_max`` one ulp past each ray's
    own hit, ``accel="warp"`` lost the hits on a flat floor (whose box is entered at the hit itself), 8% of them
    here. Every hit below ``t_max`` is kept, none at it."""
    rng = np.random.default_rng(5)
    corners = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], np.float64)
    faces = np.array([(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)])
    points = [np.linalg.qr(rng.normal(size=(3, 3)))[0] @ np.diag(rng.uniform(0.5, 1.5, 3)) @ corners.T
              for _ in range(8)]  # octahedra, turned and stretched,
    points = [p.T + rng.uniform(-3, 3, 3) for p in points]  # and moved,
    points.append(np.array([[-9, -7, -9], [9, -7, -9], [9, -7, 9], [-9, -7, 9]], np.float64))  # over a floor
    faces = [faces + 6 * k for k in range(8)] + [np.array([[0, 2, 1], [0, 3, 2]]) + 48]
    scene = wrt.Scene.from_triangles(np.concatenate(points), np.concatenate(faces))
    origins = rng.uniform(-4, 4, (3000, 3)).astype(np.float32)
    directions = (rng.uniform(-1, 1, (3000, 3)) - origins).astype(np.float32)  # towards the soup, not unit
    first = wrt.trace(scene, origins, directions, accel=accel)
    hit = first.prim >= 0
    assert hit.sum() > 1000
    o, d, t = origins[hit], directions[hit], first.t[hit]
    just_past = wrt.trace(scene, o, d, t_max=np.nextafter(t, np.float32(np.inf)), accel=accel)
    np.testing.assert_array_equal(just_past.prim, first.prim[hit])
    np.testing.assert_array_equal(just_past.t, t)
    assert (wrt.trace(scene, o, d, t_max=t, accel=accel).prim == -1).all()


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_occluded_keeps_hits_just_below_t_max(accel):
    """occluded agrees with trace at the limit: with ``t_max`` one ulp past each ray's own hit on a floor of 800
    triangles, ``accel="warp"``'s any-hit query (``wp.mesh_query_ray_anyhit``, whose traversal drops a box entered
    within rounding of its limit, as its closest-hit query does) said 1,883 of 20,000 rays were not blocked, while
    trace, with the same ``t_max``, hit them. A ray is blocked exactly when trace hits, and never at ``t_max``."""
    rng = np.random.default_rng(0)
    xs = np.linspace(-10, 10, 21)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    points = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1).astype(np.float32)
    corner = (np.arange(20)[:, None] * 21 + np.arange(20)[None, :]).ravel()
    tris = np.concatenate([np.stack([corner, corner + 21, corner + 22], 1), np.stack([corner, corner + 22,
                                                                                       corner + 1], 1)])
    scene = wrt.Scene.from_triangles(points, tris)
    n = 20_000
    origins = np.concatenate([rng.uniform(-9, 9, (n, 2)), rng.uniform(0.5, 5, (n, 1))], 1).astype(np.float32)
    directions = np.concatenate([rng.uniform(-0.2, 0.2, (n, 2)), -np.ones((n, 1))], 1).astype(np.float32)
    t = wrt.trace(scene, origins, directions, accel=accel).t
    # float64 oracle: the floor is z = 0, so every ray hits it at t = z / -dz
    np.testing.assert_allclose(t, origins[:, 2].astype(np.float64) / -directions[:, 2], rtol=1e-6)
    just_past = np.nextafter(t, np.float32(np.inf))
    assert wrt.trace(scene, origins, directions, t_max=just_past, accel=accel).hit.all()
    assert wrt.occluded(scene, origins, directions, t_max=just_past, accel=accel).all()
    assert not wrt.occluded(scene, origins, directions, t_max=t, accel=accel).any()


@pytest.mark.parametrize("layout", ["binary", "wide8"])
def test_hits_just_below_t_max_are_kept_for_origins_near_a_large_face(layout):
    """Rays from 1e-4 to 1 above the top face (z = 0) of a 2000-wide box, slanted (the face is not across their major
    axis): each hits the face, and must again with ``t_max`` one ulp past its own ``t``. 2,370 of 5,000 missed, in
    trace and occluded, binary and wide8 alike: their t came out up to 29% (5.7e-5 / |dz|) off the exact z / -dz
    (float64), below the face's box entry."""
    rng = np.random.default_rng(0)
    corners = np.array([[x, y, z] for x in (-1e3, 1e3) for y in (-1e3, 1e3) for z in (-1.0, 0.0)], np.float32)
    faces = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6], [0, 2, 6],
             [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    scene = wrt.Scene.from_triangles(corners, faces)
    n = 5000
    origins = np.stack([rng.uniform(-500, 500, n), rng.uniform(-500, 500, n), 10.0 ** rng.uniform(-4, 0, n)], 1)
    directions = np.stack([rng.choice([-1, 1], n) * rng.uniform(1, 2, n), rng.uniform(-0.5, 0.5, n),
                           -rng.uniform(0.01, 0.5, n)], 1)
    origins, directions = origins.astype(np.float32), directions.astype(np.float32)
    t = wrt.trace(scene, origins, directions, layout=layout).t
    exact = origins[:, 2].astype(np.float64) / -directions[:, 2].astype(np.float64)
    assert np.isfinite(t).all() and np.all(np.abs(t - exact) < 1e-3 * (1 + exact))  # the face, within 6e-5 / |dz|
    just_past = np.nextafter(t, np.float32(np.inf))
    assert wrt.trace(scene, origins, directions, t_max=just_past, layout=layout).hit.all()
    assert wrt.occluded(scene, origins, directions, t_max=just_past, layout=layout).all()


def large_flat_box() -> wrt.Scene:
    """The 2000-wide box ``[-1000, 1000]^2 x [-1, 0]`` (12 triangles): its top face is its box's top face."""
    corners = np.array([[x, y, z] for x in (-1e3, 1e3) for y in (-1e3, 1e3) for z in (-1.0, 0.0)], np.float32)
    faces = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6], [0, 2, 6],
             [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    return wrt.Scene.from_triangles(corners, faces)


@pytest.mark.parametrize("layout", ["binary", "wide8"])
def test_t_min_at_a_hits_own_t_keeps_it_for_origins_near_the_face_they_leave_by(layout):
    """Rays from 3e-4 to 0.3 below the top face (z = 0) of the 2000-wide box, inside it, slanted up: each leaves
    through the top face (its triangle's t near the exact -z / dz, float64) and must hit it again with
    ``t_min`` at its own ``t`` (nothing else lies past it). 1,038 of 2,000 missed, in trace and occluded, binary and
    wide8 alike (README's claim that wrt keeps every hit at ``t_min = t`` holds only where the triangle does not lie
    on its box's exit face)."""
    rng = np.random.default_rng(0)
    scene = large_flat_box()
    n = 2000
    origins = np.stack([rng.uniform(-500, 500, n), rng.uniform(-500, 500, n), -(10.0 ** rng.uniform(-3.5, -0.5, n))],
                       1).astype(np.float32)
    directions = np.stack([rng.choice([-1, 1], n) * rng.uniform(1, 2, n), rng.uniform(-0.5, 0.5, n),
                           rng.uniform(0.01, 0.5, n)], 1).astype(np.float32)
    hits = wrt.trace(scene, origins, directions, layout=layout)
    exact = -origins[:, 2].astype(np.float64) / directions[:, 2].astype(np.float64)
    assert hits.hit.all() and np.all(np.abs(hits.t - exact) < 1e-3 * (1 + exact))  # the top face, to 6e-5 / dz
    assert np.isin(hits.prim, [10, 11]).all()
    again = wrt.trace(scene, origins, directions, t_min=hits.t, layout=layout)
    np.testing.assert_array_equal(wrt.occluded(scene, origins, directions, t_min=hits.t, layout=layout), again.hit)
    assert again.hit.all(), f"{np.count_nonzero(~again.hit)} of {n} lost"
    np.testing.assert_array_equal(again.t, hits.t)


def fanned_cap(segments: int) -> wrt.Scene:
    """A closed cone of height 1 over the unit disc in z = 0, its base a fan of ``segments`` triangles around the
    disc's centre (as tessellated caps are): slivers of aspect about ``segments / 6``."""
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    points = np.concatenate([np.column_stack([np.cos(a), np.sin(a), np.zeros(segments)]), [[0, 0, 1], [0, 0, 0]]])
    i = np.arange(segments)
    j = (i + 1) % segments
    faces = np.concatenate([np.column_stack([i, j, np.full(segments, segments)]),
                            np.column_stack([j, i, np.full(segments, segments + 1)])])
    return wrt.Scene.from_triangles(points.astype(np.float32), faces.astype(np.int32))


@pytest.mark.parametrize("limit", ["t_max just past t", "t_min at t"])
def test_limits_at_a_hits_own_t_keep_it_on_a_finely_fanned_cap(limit):
    """Rays from inside a cone, 0.05 to 0.5 above its base, aimed at random points of the base: a disc fanned into
    1000 triangles around its centre. Each hits the base (the exact t: the height over -dz, float64) and must again
    with ``t_max`` one ulp past its own ``t``, or ``t_min`` at it. 95 and 106 of 2,000 missed, in every layout and in
    occluded (13 and 19 with 256 segments, 160 and 188 with 2000, none with 64); the origins are far from the cap,
    unlike the large-face cases above: here the slivers' aspect makes t err."""
    rng = np.random.default_rng(0)
    scene = fanned_cap(1000)
    n = 2000
    r, a = np.sqrt(rng.uniform(0, 0.9, n)), rng.uniform(0, 2 * np.pi, n)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros(n)])
    origins = np.column_stack([rng.uniform(-0.2, 0.2, (n, 2)), rng.uniform(0.05, 0.5, n)]).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    hits = wrt.trace(scene, origins, directions)
    exact = origins[:, 2].astype(np.float64) / -directions[:, 2].astype(np.float64)
    assert hits.hit.all() and (hits.prim >= 1000).all() and np.all(np.abs(hits.t - exact) < 1e-4 * exact)
    bound = ({"t_max": np.nextafter(hits.t, np.float32(np.inf))} if limit == "t_max just past t" else
             {"t_min": hits.t})
    again = wrt.trace(scene, origins, directions, **bound)
    np.testing.assert_array_equal(wrt.occluded(scene, origins, directions, **bound), again.hit)
    assert again.hit.all(), f"{np.count_nonzero(~again.hit)} of {n} lost"
    np.testing.assert_array_equal(again.t, hits.t)


def test_ties_go_to_the_smaller_triangle_id():
    # Two coincident triangles: every hit is an exact tie in t.
    tri = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32)
    points = np.concatenate([tri, tri])
    scene = wrt.Scene.from_triangles(points, [[3, 4, 5], [0, 1, 2]])
    origins = np.array([[0, 0, 1], [0, 0, -1]], np.float32)
    hits = wrt.trace(scene, origins, np.array([[0, 0, -1], [0, 0, 1]], np.float32))
    assert hits.prim.tolist() == [0, 0]


@pytest.mark.parametrize("order", [[0, 2, 1], [1, 2, 0]], ids=["reversed", "rotated"])
def test_ties_between_twins_in_other_corner_orders_go_to_the_smaller_id(order, np_rng):
    """A card made two-sided by a reversed copy of each face, or a face listed twice from another corner: the same
    corners, so every hit on one is a tie with its twin at exactly the same t, and the smaller id must win (as it
    does for a copy in the same order, above). 100 tilted triangles 4 apart, each with its twin (ids shuffled), and
    rays from within 0.5 of a point well inside one of them (every hit on that pair): the larger id of the pair
    won in 101 (reversed) and 106 (rotated) of 600 rays."""
    n, m = 100, 600
    grid = np.stack(np.meshgrid(np.arange(10), np.arange(10), indexing="ij"), -1).reshape(-1, 2) * 4.0
    centres = np.column_stack([grid, np_rng.uniform(-1, 1, n)])
    corners = (centres[:, None] + np_rng.uniform(-1, 1, (n, 3, 3))).astype(np.float32)  # tilted, at most 1.8 across
    rows = np_rng.permutation(2 * n)  # rows[k]: the row of triangle k (k < n) or of the twin of triangle k - n
    triangles = np.empty((2 * n, 3, 3), np.float32)
    triangles[rows] = np.concatenate([corners, corners[:, order]])
    scene = wrt.Scene.from_triangles(triangles.reshape(-1, 3), np.arange(6 * n).reshape(-1, 3))
    target = np_rng.integers(0, n, m)
    weights = 0.1 + 0.7 * np_rng.dirichlet([1, 1, 1], m)  # each corner's weight at least 0.1: clear of the edges
    weights /= weights.sum(axis=1, keepdims=True)
    points = np.einsum("ij,ijk->ik", weights, corners[target].astype(np.float64))
    origins = points + 0.5 * np_rng.uniform(-1, 1, (m, 3)) / np.sqrt(3)
    hits = wrt.trace(scene, origins.astype(np.float32), (points - origins).astype(np.float32))
    assert hits.hit.all()
    np.testing.assert_array_equal(hits.prim, np.minimum(rows[target], rows[target + n]))


def test_degenerate_and_invalid_rays_miss():
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.zeros((4, 3), np.float32)
    origins[:, 2] = 1
    directions = np.array([[0, 0, 0], [np.nan, 0, -1], [0, 0, np.inf], [1e-45, 0, -1]], np.float32)
    hits = wrt.trace(scene, origins, directions)
    assert hits.prim.tolist() == [-1, -1, -1, 0]


@pytest.mark.parametrize("accel,layout", [("wrt", "binary"), ("wrt", "compact"), ("wrt", "wide"), ("wrt", "wide8"),
                                          ("warp", "binary")])
def test_very_long_and_very_short_directions_hit(accel, layout):
    """Directions need not be unit length: a finite non-zero direction whose squared length overflows (|d| > ~1.8e19)
    or underflows (|d| < ~1e-23) in float32 is still a valid ray, with t = distance / |d|."""
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    lengths = np.array([1e-25, 1e-21, 1.0, 1e20, 1e25], np.float32)
    origins = np.tile(np.array([[0, 0, 1]], np.float32), (len(lengths), 1))
    directions = np.zeros((len(lengths), 3), np.float32)
    directions[:, 2] = -lengths
    hits = wrt.trace(scene, origins, directions, accel=accel, layout=layout)
    assert hits.prim.tolist() == [0] * len(lengths)
    np.testing.assert_allclose(hits.t, 1.0 / lengths.astype(np.float64), rtol=1e-6)
    assert wrt.occluded(scene, origins, directions, accel=accel, layout=layout).all()


@pytest.mark.parametrize(
    "instanced,layout", [(False, "binary"), (False, "compact"), (False, "wide"), (False, "wide8"), (True, "binary")]
)
def test_a_hit_beyond_float32_range_is_not_reported_at_t_inf(instanced, layout):
    """A hit 100 units away along a direction of length 1e-37 lies at t = 1e39, which float32 cannot hold. Hits have
    ``t_min <= t < t_max`` and ``t = inf`` only on a miss: either a miss (t unrepresentable) or a finite t would keep
    the contract, and occluded must agree with trace. The ray hit prim 0 at t = inf, and occluded said blocked
    (``accel="warp"`` reports a miss); ``unit_ray`` now caps ``t_max`` at float32's largest value, so it misses."""
    points, tris = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32)
    scene = wrt.Scene.from_triangles(points, tris)
    if instanced:
        proto = Prototype("/P", [Mesh("/P/tri", points, tris, np.zeros(1, np.int32))])
        scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0], np.eye(4)[None]))
    origins = np.array([[0, 0, 100], [0, 0, 1]], np.float32)
    directions = np.array([[0, 0, -1e-37], [0, 0, -1e-37]], np.float32)  # t = 1e39 (beyond 3.4e38) and 1e37
    with pytest.warns(UserWarning, match="1 of 2 rays .* beyond t = 3.4e38"):  # said: see the next test
        hits = wrt.trace(scene, origins, directions, layout=layout)
        blocked = wrt.occluded(scene, origins, directions, layout=layout)
    assert hits.prim[1] == 0 and np.isclose(hits.t[1], 1e37, rtol=1e-6)
    assert np.isfinite(hits.t[hits.hit]).all(), (hits.t, hits.prim)
    np.testing.assert_array_equal(blocked, hits.hit)


@pytest.mark.parametrize("accel,layout,instanced", [("wrt", "binary", False), ("wrt", "binary", True),
                                                    ("warp", "binary", False)])
def test_rays_whose_hits_lie_past_float32s_t_are_named_in_a_warning(accel, layout, instanced):
    """A direction of length 1e-38 towards a triangle 1e4 away: the float64 oracle hits it at t = 1e42, which float32
    cannot hold, so every accelerator reports a miss, and did so without a word (``wp.Mesh`` too). Now trace and
    occluded warn naming how many rays pass through the scene's box beyond t = 3.4e38, and the first; a short
    direction that meets the box within reach, a ``t_max`` that ends the ray first and one pointing away are not
    counted, and neither is any ray of a batch of unit directions from a scene's far side."""
    scene = one_triangle_scene(instanced)
    points, indices = scene.triangles()
    scene = wrt.Scene.from_triangles(points * np.float32(1e4), indices) if not instanced else scene
    if instanced:
        scene.instances.to_world = np.diag([1e4, 1e4, 1e4, 1.0])[None]
    origins = np.array([[0, 0, 1e4]] * 6, np.float32)
    directions = np.array([[0, 0, -1], [0, 0, -1e-38], [1e-39, 0, -1e-38], [0, 0, -1e-38], [0, 0, 1e-38],
                           [0, 0, -1e-30]], np.float32)
    t_max = np.array([np.inf, np.inf, np.inf, 1e30, np.inf, np.inf], np.float32)
    t, prim, clear = float64_closest_hits(scene.triangles()[0], scene.triangles()[1], origins, directions,
                                          np.zeros(6), t_max.astype(np.float64))
    assert prim.tolist() == [0, 0, 0, -1, -1, 0] and clear.all()
    np.testing.assert_allclose(t[1:3], 1e4 / -directions[1:3, 2].astype(np.float64), rtol=1e-6)  # 1e42
    for query in (wrt.trace, wrt.occluded):
        with pytest.warns(UserWarning) as said:
            result = query(scene, origins, directions, t_max=t_max, accel=accel, layout=layout)
        assert len(said) == 1 and re.match(
            r"2 of 6 rays \(the first: row 1, origin \(0, 0, 10000\), direction \(0, 0, -9.999999e-39\)\) pass "
            r"through the scene's box beyond t = 3\.4e38, float32's largest value \(or before -3\.4e38\): hits there "
            r"have no float32 t and are reported as misses \(or at t = -inf\)\. .* scale such directions up",
            str(said[0].message)), str(said[0].message)
        hit = result.hit if query is wrt.trace else result
        assert hit[:5].tolist() == [True, False, False, False, False]  # the documented miss
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # rays of unit length, from beyond the scene, and empty batches say nothing
            far = np.array([[0, 0, 1e5], [0, 0, -1e5], [3e38, 0, 0]], np.float32)
            query(scene, far, np.array([[0, 0, -1], [0, 0, 1], [-1, 0, 0]], np.float32), accel=accel, layout=layout)
            query(scene, np.zeros((0, 3)), np.zeros((0, 3)), accel=accel, layout=layout)


@pytest.mark.parametrize(
    "instanced,layout", [(False, "binary"), (False, "compact"), (False, "wide"), (False, "wide8"), (True, "binary")]
)
def test_rays_that_cannot_hit_miss_without_traversal(instanced, layout):
    """Finished paths trace empty ranges (``t_max = 0``), and a NaN origin would pass every slab test (min/max drop
    NaN) and visit the whole tree: such rays miss at once, in every layout and in the two-level (TLAS) traversal."""
    points, tris = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32)
    scene = wrt.Scene.from_triangles(points, tris)
    if instanced:
        proto = Prototype("/P", [Mesh("/P/tri", points, tris, np.zeros(1, np.int32))])
        scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0], np.eye(4)[None]))
    origins = np.array([[0, 0, 1], [np.nan, 0, 1], [0, np.inf, 1], [0, 0, 1]], np.float32)
    directions = np.tile(np.array([[0, 0, -1]], np.float32), (4, 1))
    t_max = np.array([0, np.inf, np.inf, np.inf], np.float32)
    hits = wrt.trace(scene, origins, directions, t_max=t_max, layout=layout)
    assert hits.prim.tolist() == [-1, -1, -1, 0]
    assert hits.nodes_visited.tolist()[:3] == [0, 0, 0] and hits.nodes_visited[3] > 0
    blocked = wrt.occluded(scene, origins, directions, t_max=t_max, layout=layout)
    assert blocked.tolist() == [False, False, False, True]


def test_axis_aligned_rays_through_shared_edges_never_leak():
    # A flat grid of 2x2-split quads; rays straight down through every vertex and edge midpoint hit.
    n = 8
    xs = np.linspace(-1, 1, n + 1, dtype=np.float32)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    points = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1).astype(np.float32)
    tris = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
            tris += [[a, b, c], [a, c, d]]
    scene = wrt.Scene.from_triangles(points, tris)
    probe = np.linspace(-1, 1, 2 * n + 1, dtype=np.float32)[1:-1]
    px, py = np.meshgrid(probe, probe, indexing="ij")
    origins = np.stack([px.ravel(), py.ravel(), np.full(px.size, 2.0)], 1).astype(np.float32)
    directions = np.tile(np.array([[0, 0, -1]], np.float32), (len(origins), 1))
    hits = wrt.trace(scene, origins, directions)
    assert hits.hit.all()
    np.testing.assert_allclose(hits.t, 2.0)


def closed_triangles_containing(points, indices, yz) -> np.ndarray:
    """Ids of the triangles of a wall in a plane x = const whose closed (y, z) region holds the point ``yz``:
    float64 signs of the three 2D edge functions, zero counted inside (the watertight test's rule)."""
    tri = np.asarray(points, np.float64)[np.asarray(indices)][:, :, 1:]
    signs = []
    for k in range(3):
        edge, to_point = tri[:, (k + 1) % 3] - tri[:, k], np.asarray(yz, np.float64) - tri[:, k]
        signs.append(edge[:, 0] * to_point[:, 1] - edge[:, 1] * to_point[:, 0])
    signs = np.stack(signs, 1)
    return np.flatnonzero((signs >= 0).all(1) | (signs <= 0).all(1))


@pytest.mark.parametrize("layout", ["binary", "wide8"])
@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("size", [1e10, 4e20])
def test_ties_on_an_edge_in_a_box_face_plane_go_to_the_smaller_id_at_any_scale(size, layout, device):
    """A wall at x = 2 size, tall in z, with ten strips of two triangles below z = 0 (smaller ids) and ten above;
    rays along +x in the plane z = 0 hit the shared edges, where a lower and an upper triangle tie at exactly the
    same t (the wall lies across the ray's major axis): the smaller id, the lower one, must win. Beyond t = 1e20 the
    boxes of the lower strips, whose upper face is the plane z = 0, were culled and the upper triangle won."""
    strips = np.linspace(0, 1, 11)
    points, tris = [], []
    for z0, z1 in ((-100, 0), (0, 100)):
        for a, b in zip(strips[:-1], strips[1:]):
            k = len(points)
            points += [[2, a, z0], [2, b, z0], [2, b, z1], [2, a, z1]]
            tris += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
    points = (np.array(points) * size).astype(np.float32)
    scene = wrt.Scene.from_triangles(points, tris)
    ys = np.array([0.13, 0.25, 0.5, 0.77], np.float32) * np.float32(size)
    origins = np.stack([np.zeros(4), ys, np.zeros(4)], 1).astype(np.float32)
    hits = wrt.trace(scene, origins, np.array([1, 0, 0], np.float32), layout=layout, device=device)
    expected = [closed_triangles_containing(points, tris, (y, 0.0)).min() for y in ys]
    assert all(e < 20 for e in expected)  # the lower strips' triangles: the oracle sees the tie
    assert hits.prim.tolist() == expected
    np.testing.assert_allclose(hits.t, 2 * np.float32(size), rtol=1e-6)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("placed", ["scaled", "far origin", "instance"])
def test_a_ray_along_an_outer_edge_in_a_box_face_plane_hits_at_any_distance(placed, device):
    """A wall triangle at x = 2 whose edge lies in the plane z = 0 (its box's upper face, or its lower one), and rays
    along +x in that plane, with a z component of +0 or -0: the closed triangle holds every point where they meet it
    (the watertight test's rule), so each ray hits at t = 2 s, whatever the wall's scale s, the origin's distance and
    the layout; through an instance scaled by s too. The slab of a zero direction component ended near t = 1e20
    (inverse 1e38, and the CPU's margin 1e-18, CUDA's slack 1e20 of t): beyond it the box whose face the ray runs in
    was culled and the ray missed, at a scale of 2^66 (t = 1.5e20) where it hit at 2^60. Oracle: float64 edge
    functions of the corners (:func:`closed_triangles_containing`)."""
    for below in (True, False):
        tri = np.array([[2, 0, 0], [2, 1, 0], [2, 0.5, -1 if below else 1]], np.float64)
        for exponent in (0, 66, 100):
            s = 2.0**exponent
            ys = np.array([0.13, 0.5, 0.77])
            origins = np.stack([np.zeros(3), ys, np.zeros(3)], 1)
            if placed == "instance":
                scene = wrt.Scene(prototypes=[Prototype("/P", [Mesh("/P/wall", tri.astype(np.float32),
                                                                    np.array([[0, 1, 2]]), np.zeros(1, np.int32))])],
                                  instances=Instances.from_transforms([0], np.diag([s, s, s, 1.0])[None]))
                origins, points, layouts = origins * s, tri * s, ["binary"]
            elif placed == "far origin":  # a unit wall seen from s away
                scene = wrt.Scene.from_triangles(tri.astype(np.float32), [[0, 1, 2]])
                origins[:, 0], points, layouts = -s, tri, ["binary", "compact", "wide", "wide8"]
            else:
                scene = wrt.Scene.from_triangles((tri * s).astype(np.float32), [[0, 1, 2]])
                origins, points, layouts = origins * s, tri * s, ["binary", "compact", "wide", "wide8"]
            assert all(closed_triangles_containing(points, [[0, 1, 2]], (y, 0.0)).tolist() == [0]
                       for y in origins[:, 1])
            want = points[0, 0] - origins[:, 0]
            for z in (0.0, -0.0):
                directions = np.array([1.0, 0.0, z], np.float32)
                for layout in layouts:
                    label = f"{'below' if below else 'above'} z = 0, 2^{exponent}, direction z {z}, {layout}"
                    hits = wrt.trace(scene, origins, directions, layout=layout, device=device)
                    assert hits.prim.tolist() == [0, 0, 0], label
                    np.testing.assert_allclose(hits.t, want, rtol=1e-6, err_msg=label)
                    assert wrt.occluded(scene, origins, directions, layout=layout, device=device).all(), label


def test_empty_scene_misses_everything():
    scene = wrt.Scene()
    hits = wrt.trace(scene, np.zeros((3, 3)), np.ones((3, 3)))
    assert hits.prim.tolist() == [-1, -1, -1] and np.isinf(hits.t).all()
    hits = wrt.trace(scene, np.zeros((3, 3)), np.ones((3, 3)), accel="warp")
    assert hits.prim.tolist() == [-1, -1, -1]


def test_occluded_matches_closest_hit(np_rng):
    points, indices = random_soup(np_rng, 200)
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 5000, seed=2)
    hits = wrt.trace(scene, origins, directions)
    t_max = np.where(np_rng.random(len(origins)) < 0.5, np.inf, 0.5).astype(np.float32)
    for accel in ("wrt", "warp"):
        blocked = wrt.occluded(scene, origins, directions, t_max=t_max, accel=accel)
        np.testing.assert_array_equal(blocked, hits.t < t_max)


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_non_finite_vertices_raise_for_every_accelerator(accel):
    """A NaN vertex in one triangle of a closed mesh: wp.Mesh used to build anyway and let rays through that
    triangle escape the mesh; both accelerators refuse it, on the build and on a refit, naming the triangle."""
    from wrt.primitives import Shape, tessellate

    points, tris, _ = tessellate(Shape("/s", "sphere", np.eye(4)), 16)
    points = points.astype(np.float32)
    bad = points.copy()
    bad[tris[5, 0]] = np.nan
    mesh = Mesh("/sphere", points, tris, np.arange(len(tris), dtype=np.int32))
    mesh.points = bad  # past Mesh's own check
    first = np.flatnonzero((tris == tris[5, 0]).any(axis=1))[0]  # the first triangle using the vertex
    with pytest.raises(wrt.SceneError, match=f"/sphere: triangle {first} uses vertex {tris[5, 0]} = .*not finite"):
        wrt.trace(wrt.Scene(meshes=[mesh]), np.zeros((1, 3)), np.ones((1, 3)), accel=accel)
    scene = wrt.Scene.from_triangles(points, tris)
    acc = get_accelerator(scene, accel)
    with pytest.raises(wrt.SceneError, match=f"/sphere: triangle {first} uses vertex .*not finite"):  # the mesh's check
        acc.refit(wrt.Scene(meshes=[mesh]))


def test_compare_counts_a_nan_t_on_a_hit_as_a_disagreement():
    """An accelerator that reports a hit with t = NaN disagrees with one that reports t = 1: compare_hits used to
    count it as agreement (NaN > tolerance is False), which would hide exactly the bugs it is there to find."""
    def hits(t):
        one = np.zeros(1, np.int32)
        return wrt.Hits(np.array([t], np.float32), np.full(1, 0.3, np.float32), np.full(1, 0.3, np.float32), one,
                        one, one)

    for bad in (np.nan, np.inf):
        report = compare_hits(hits(bad), hits(1.0), directions=np.ones((1, 3)), scale=1.0)
        assert report["t_mismatch"] == 1 and report["disagreements"] == 1 and report["agreement"] == 0.0
    assert compare_hits(hits(1.0), hits(1.0))["agreement"] == 1.0


def test_compare_refuses_hits_of_other_ray_counts():
    """Hit sets, directions or tie masks of another length: compare_hits raised numpy's IndexError about boolean
    indices, or broadcast a one-entry tie mask over every ray; it now names the argument."""
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.array([[0, 0, 1], [0, 0, 2]], np.float32)
    directions = np.array([[0, 0, -1], [0, 0, -1]], np.float32)
    two, one = wrt.trace(scene, origins, directions), wrt.trace(scene, origins[:1], directions[:1])
    with pytest.raises(ValueError, match=r"b must have one entry per ray of a \(2\)"):
        compare_hits(two, one)
    with pytest.raises(ValueError, match="directions must have one entry per ray"):
        compare_hits(two, two, directions=directions[:1], scale=1.0)
    with pytest.raises(ValueError, match="ties must have one entry per ray"):
        compare_hits(two, two, ties=[True])
    assert compare_hits(two, two, directions=directions, scale=1.0, ties=[False, True])["agreement"] == 1.0


def test_compare_takes_the_zero_and_nan_directions_that_trace_takes_without_a_warning():
    """wrt.trace takes zero and NaN directions (they miss); compare_hits on those same rays warned numpy's
    "divide by zero encountered in divide" (an error under ``python -W error``) while computing the absolute
    tolerance over |direction|. Two misses agree whatever the tolerance; the hit beside them is still compared."""
    import warnings

    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.array([[0, 0, 1]] * 3, np.float32)
    directions = np.array([[0, 0, 0], [np.nan, 0, 0], [0, 0, -1]], np.float32)
    hits = wrt.trace(scene, origins, directions)
    assert list(hits.prim >= 0) == [False, False, True] and hits.t[2] == 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = compare_hits(hits, hits, directions=directions, scale=1.0)
    assert report["agreement"] == 1.0 and report["hits_a"] == 1 and report["disagreements"] == 0


def test_hit_paths_refuses_hits_that_are_not_of_the_scene(tmp_path):
    """hit_paths of another scene's hits (or of this one's before an edit) named no prim, as for a miss: a ray that hit
    triangle 1 of a two-mesh stage read as a miss of a one-triangle one, without a word; hits.prim given for the
    hits raised "'numpy.ndarray' object has no attribute 'local_prim'". Both are refused, naming what is wrong (the
    scene the hits were traced in; ids out of range for hits made by hand, which name none); the scene's own hits
    are named by the prim paths the stage authors."""
    tri = '    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
    (tmp_path / "two.usda").write_text(
        '#usda 1.0\n' + "".join(f'def Mesh "{name}"\n{{\n{tri}    point3f[] points = [(-1, -1, {z}), (1, -1, {z}), '
                               f'(0, 1, {z})]\n}}\n' for name, z in (("Near", 0), ("Far", -1))))
    (tmp_path / "one.usda").write_text(f'#usda 1.0\ndef Mesh "M"\n{{\n{tri}    point3f[] points = [(-1, -1, 0), '
                                       '(1, -1, 0), (0, 1, 0)]\n}\n')
    two, one = wrt.load_usd(str(tmp_path / "two.usda")), wrt.load_usd(str(tmp_path / "one.usda"))
    origins = np.array([[0, 0, 1], [0, 0, -0.5], [5, 5, 1]], np.float32)
    hits = wrt.trace(two, origins, np.tile(np.float32([0, 0, -1]), (3, 1)))
    assert list(hits.prim) == [0, 1, -1]
    assert [list(p) for p in two.hit_paths(hits)] == [["/Near", "/Far", ""], ["", "", ""]]
    with pytest.raises(ValueError, match=r"^hit_paths: these hits were traced in scene '.*two\.usda', not in this one"):
        one.hit_paths(hits)
    by_hand = wrt.Hits(hits.t, hits.u, hits.v, hits.prim, hits.nodes_visited, hits.triangles_tested)  # no scene
    with pytest.raises(ValueError, match=r"^hit_paths: hits.local_prim\[1\] = 1 is no id of this scene \(-1 to 0\)"):
        one.hit_paths(by_hand)
    with pytest.raises(TypeError, match="^hit_paths takes the Hits of wrt.trace .*, got ndarray$"):
        two.hit_paths(hits.prim)


def test_meshes_built_in_python_refuse_malformed_arrays_naming_the_mesh():
    """wrt.Mesh reshaped what it was given: (V, 4) homogeneous points became other vertices, an index of 2**32 + 2
    wrapped round to vertex 2 and 2.7 was truncated to 2, so the mesh traced as other triangles without a word.
    It now refuses them as Scene.from_triangles does, naming the mesh."""
    tri = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32)
    for points, indices, needle in (
        (np.column_stack([tri, np.ones(3)]), [[0, 1, 2]], r"points must have shape \(N, 3\)"),
        (tri, np.array([[0, 1, 2**32 + 2]]), r"must lie in \[0, 3\); triangle 0 "),
        (tri, np.array([[0.0, 1.0, 2.7]]), "indices must be integers"),
        (tri, np.array([[0, 1, 2, 0]]), r"indices must have shape \(N, 3\)"),
    ):
        with pytest.raises(wrt.SceneError, match="^/Quad: .*" + needle):
            Mesh("/Quad", points, indices, [0])
    mesh = Mesh("/Tri", tri.astype(np.float64).ravel(), np.array([0, 1, 2], np.int64), [0])
    assert mesh.points.dtype == np.float32 and mesh.points.shape == (3, 3) and mesh.indices.tolist() == [[0, 1, 2]]


def test_a_nan_vertex_is_named_with_its_mesh_when_made_and_after_an_edit():
    """A NaN point given to from_triangles was found only at the first trace, as "triangle 0 uses one" (a row of
    all the scene's triangles, no mesh named); an edit in place likewise."""
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 0]], np.float32)  # vertex 3 unused: allowed
    with pytest.raises(wrt.SceneError, match=r"^/tri: triangle 1 uses vertex 3 = \[nan, 0.0, 0.0\], which is not "):
        wrt.Scene.from_triangles(points, [[0, 1, 2], [0, 3, 2]], name="/tri")
    scene = wrt.Scene(meshes=[Mesh("/a", points, [[0, 1, 2]], [0]), Mesh("/b", points[:3], [[0, 1, 2]], [0])])
    scene.meshes[1].points[2, 1] = np.inf
    scene.invalidate()
    with pytest.raises(wrt.SceneError, match=r"^/b: triangle 0 uses vertex 2 = \[0.0, inf, 0.0\]"):
        wrt.render(scene, width=4, height=4)


def test_meshes_refuse_per_triangle_arrays_of_another_length():
    """Three face ids, normals or material ids for two triangles were kept: scene-wide arrays concatenate meshes,
    so the extra row shifted the attributes of every later mesh without a word; per-vertex normals of a quad (4 rows)
    failed in numpy's reshape. Each is refused, naming the mesh and the attribute."""
    points = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [0, 0, 1], [0, 0, -1]], np.float32)
    quads = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    for name, value in (("normals", np.tile([0.0, 0.0, 1.0], (4, 1))), ("normals", np.zeros((3, 3, 3))),
                        ("face_ids", [0, 0, 0]), ("colors", np.zeros((2, 3))), ("uvs", np.zeros((2, 3, 3))),
                        ("material_ids", [0])):
        kwargs = {"face_ids": [0, 0], name: value}
        with pytest.raises(wrt.SceneError, match=rf"^/Quad: {name} must have shape \(2,.*one entry per triangle"):
            Mesh("/Quad", points, quads, **kwargs)
    mesh = Mesh("/Quad", points, quads, [0, 1], normals=np.zeros((6, 3)), uvs=np.zeros(12), material_ids=[[0], [1]])
    assert mesh.normals.shape == (2, 3, 3) and mesh.uvs.shape == (2, 3, 2) and mesh.material_ids.tolist() == [0, 1]


def test_mesh_arrays_assigned_after_construction_are_checked_before_the_next_trace_or_render():
    """The constructor refused per-triangle arrays of another length, but a field assigned later (a simulation step's
    ``mesh.material_ids = ...``) was not checked: one material id too many shifted the materials of every later mesh
    without a word, and a 0-d array failed with a bare IndexError. A kept Renderer and a trace now refuse it, naming
    the mesh; fixed, the mesh renders as a fresh scene of it does, and an assignment that needed a conversion
    (float64 points) builds again once, not at every render."""
    import copy

    points = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    quads = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    red = wrt.Material(path="/Red", diffuse_color=(1.0, 0.0, 0.0))
    scene = wrt.Scene(meshes=[Mesh("/A", points, quads, [0, 1], material_ids=[0, 0]),
                              Mesh("/B", points + np.float32([3, 0, 0]), quads, [0, 1])], materials=[red])
    camera = wrt.Camera.look_at((1.5, 0, 6), (1.5, 0, 0))
    renderer = wrt.Renderer(scene, camera=camera, width=24, height=12, integrator="albedo", device="cpu")
    renderer.render()
    rays = (np.float32([[0, 0, 5]]), np.float32([[0, 0, -1]]))
    for bad in ([0, 0, 0], np.array(0), [0]):
        scene.meshes[0].material_ids = bad
        with pytest.raises(wrt.SceneError, match=r"^/A: material_ids must have shape \(2,\), one entry per triangle"):
            renderer.render()
        with pytest.raises(wrt.SceneError, match="^/A: material_ids"):
            wrt.trace(scene, *rays)
    scene.meshes[0].material_ids = [0, -1]
    scene.meshes[1].points = np.zeros((4, 4))
    with pytest.raises(wrt.SceneError, match=r"^/B: points must have shape"):
        renderer.render()
    scene.meshes[1].points = (points + np.float32([3, 0, 0])).astype(np.float64)
    image = renderer.render()
    assert scene.meshes[1].points.dtype == np.float32 and scene.meshes[0].material_ids.dtype == np.int32
    fresh = wrt.render(copy.deepcopy(scene), camera=camera, width=24, height=12, integrator="albedo", device="cpu")
    np.testing.assert_array_equal(image.rgb, fresh.rgb)
    accel = renderer.accel
    renderer.render()
    assert renderer.accel is accel  # the converted arrays are the ones recorded: nothing to build again


def test_bad_trace_arguments_raise_value_error():
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="valid accelerators"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), accel="embree2")
    with pytest.raises(ValueError, match="valid builders"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), builder="octree")
    with pytest.raises(ValueError, match=r"\(N, 3\) arrays with the same N \(or one ray\), got \(2, 3\) and \(3, 3\)"):
        wrt.trace(scene, np.zeros((2, 3)), np.ones((3, 3)))  # both are (N, 3): the N differs
    with pytest.raises(ValueError, match=r"\(N, 3\) arrays, got \(2, 4\)"):
        wrt.trace(scene, np.zeros((2, 4)), np.ones((2, 4)))
    with pytest.raises(ValueError, match="available devices"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), device="tpu:7")


def test_ray_arrays_of_text_or_complex_numbers_raise_naming_the_argument():
    """Complex origins were cast with only a ComplexWarning (the imaginary part dropped, so the ray hit where the
    real part pointed), and text or ragged lists raised numpy's message without naming the argument."""
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    good_o, good_d = np.array([[0, 0, 1]], np.float32), np.array([[0, 0, -1]], np.float32)
    for name, args, kwargs in (
        ("origins", (good_o + 1j, good_d), {}),
        ("directions", (good_o, [["0", "0", "-1"]]), {}),
        ("origins", ([[0, 0, 1], [0, 0]], good_d), {}),
        ("t_max", (good_o, good_d), {"t_max": 2 + 0j}),
    ):
        for query in (wrt.trace, wrt.occluded):
            with pytest.raises(ValueError, match=f"{name} must hold real numbers"):
                query(scene, *args, **kwargs)
    assert wrt.trace(scene, good_o.astype(np.float64), good_d.tolist(), t_max=np.int64(2)).prim.tolist() == [0]


def test_finite_rays_beyond_float32_range_raise_naming_the_argument():
    """wrt traces in float32: a float64 origin beyond its range (1e39) became inf with only numpy's "overflow
    encountered in cast" warning, and a non-zero direction of 1e39 or 1e-50 became inf or (0, 0, 0): each ray then
    missed without a word, although the same ray in range hits. The limits keep their meaning as +-inf (t_max=1e39 is
    no bound), so they convert without a warning."""
    import warnings

    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    good_o, good_d = np.array([[0.0, 0.0, 1.0]] * 2), np.array([[0.0, 0.0, -1.0]] * 2)
    for name, o, d in (
        ("origins", good_o + [[0, 0, 0], [1e39, 0, 0]], good_d),
        ("directions", good_o, good_d * [[1], [1e39]]),
        ("directions", good_o, good_d * [[1], [1e-50]]),
    ):
        for query in (wrt.trace, wrt.occluded):
            with pytest.raises(ValueError, match=f"{name} row 1, .* in float32"):
                query(scene, o, d)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hits = wrt.trace(scene, good_o + [[0, 0, 0], [1e-50, 0, 0]], good_d * [[1], [1e-30]], t_min=-1e39,
                         t_max=np.array([1e39, 1e300]))  # an origin of 1e-50 is 0 to float32's precision
        # explicit inf and NaN rays still miss, as documented
        assert wrt.trace(scene, [[0, 0, np.inf]], [[0, 0, -1]]).prim.tolist() == [-1]
    assert hits.prim.tolist() == [0, 0]
    np.testing.assert_allclose(hits.t, [1.0, 1e30], rtol=1e-6)


class GpuTensor:
    """Stands for a CUDA ``torch.Tensor``: numpy refuses it (as torch does: "can't convert cuda:0 device type
    tensor to numpy"), DLPack hands it over."""

    def __init__(self, values):
        self.values = wp.array(np.asarray(values, np.float32))

    def __array__(self, dtype=None, copy=None):
        raise TypeError("can't convert cuda:0 device type tensor to numpy")

    def __dlpack__(self, stream=None):
        return self.values.__dlpack__(stream=stream)

    def __dlpack_device__(self):
        return self.values.__dlpack_device__()


def test_rays_are_taken_in_every_form_a_notebook_holds_them():
    """A (3,) ray, one origin for many directions, an empty list and a GPU tensor raised ValueError ("must both be
    (N, 3) arrays"; the tensor: "origins must hold real numbers"); a wp.array on the device was copied to the host
    and back (and one on a GPU refused, as numpy cannot read it)."""
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.array([[0.0, 0.0, 1.0]] * 3)
    directions = np.array([[0.0, 0.0, -1.0], [0.5, 0.0, -1.0], [2.0, 0.0, -1.0]])  # hit, hit, miss
    expected = wrt.trace(scene, origins.astype(np.float32), directions.astype(np.float32))
    assert expected.prim.tolist() == [0, 0, -1]
    for o, d in (
        (origins.tolist(), directions.tolist()),
        (origins[0], directions),  # one origin for every direction
        ([[0, 0, 1]], directions),
        (origins, GpuTensor(directions)),
        (wp.array(origins, dtype=wp.vec3), wp.array(directions.astype(np.float32))),  # vec3, and (N, 3) floats
        (wp.array(origins, dtype=wp.vec3d), directions[:, None, :][:, 0]),  # float64 vectors, a strided view
    ):
        for query in (wrt.trace, wrt.occluded):
            got = query(scene, o, d)
            hits = got.prim if query is wrt.trace else got
            assert hits.tolist() == (expected.prim if query is wrt.trace else expected.hit).tolist()
        np.testing.assert_array_equal(wrt.trace(scene, o, d).t, expected.t)
    one = wrt.trace(scene, [0, 0, 1], [0, 0, -1])  # a single ray: Hits of length 1
    assert one.prim.tolist() == [0] and one.t.tolist() == [1.0]
    assert len(wrt.trace(scene, [], []).t) == 0


def test_a_grid_of_rays_is_refused_with_how_to_pass_it():
    """An (H, W, 3) grid of rays (as a notebook makes camera rays) was refused with "must both be (N, 3) arrays" alone;
    the message now says to pass ``grid.reshape(-1, 3)``, which traces it."""
    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = np.broadcast_to([0.0, 0.0, 1.0], (4, 5, 3))
    directions = np.broadcast_to([0.0, 0.0, -1.0], (4, 5, 3))
    for query in (wrt.trace, wrt.occluded):
        with pytest.raises(ValueError, match=r"got \(4, 5, 3\) and \(4, 5, 3\); pass a grid of rays as "
                                             r"grid.reshape\(-1, 3\)"):
            query(scene, origins, directions)
    hits = wrt.trace(scene, origins.reshape(-1, 3), directions.reshape(-1, 3))
    assert hits.prim.reshape(4, 5).tolist() == [[0] * 5] * 4


def test_a_vec3_array_on_the_device_is_traced_in_place():
    """Rays a Warp kernel made on the tracing device are read where they are: no copy through the host."""
    from wrt.ray_batch import upload_rays

    scene = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
    origins = wp.array([[0.0, 0.0, 1.0]] * 2, dtype=wp.vec3)
    directions = wp.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]], dtype=wp.vec3)
    rays = upload_rays(origins, directions, 0.0, None, origins.device)
    assert rays[0] is origins and rays[1] is directions
    assert wrt.trace(scene, origins, directions).prim.tolist() == [0, -1]


@pytest.mark.parametrize("accel, layout", [("wrt", "binary"), ("wrt", "wide8"), ("warp", "binary")])
def test_t_min_is_an_inclusive_lower_bound(accel, layout):
    """trace and occluded had no t_min (a TypeError): lidar minimum ranges and secondary rays had to move their
    origins. Two triangles at z = 0 and z = -1 under rays pointing down -z."""
    points = [[-1, -1, 0], [1, -1, 0], [0, 1, 0], [-1, -1, -1], [1, -1, -1], [0, 1, -1]]
    scene = wrt.Scene.from_triangles(points, [[0, 1, 2], [3, 4, 5]])
    origins = [[0, 0, 5]] * 4 + [[0, 0, -0.5]]  # the last starts between the triangles
    t_min = [0.0, 5.5, 6.5, 5.0, -10.0]  # past the first; past both; exactly on the first; behind the origin
    hits = wrt.trace(scene, origins, [0, 0, -1], t_min=t_min, accel=accel, layout=layout)
    assert hits.prim.tolist() == [0, 1, -1, 0, 0]
    np.testing.assert_array_equal(hits.t, [5.0, 6.0, np.inf, 5.0, -0.5])
    blocked = wrt.occluded(scene, origins, [0, 0, -1], t_min=t_min, accel=accel, layout=layout)
    assert blocked.tolist() == [True, True, False, True, True]
    assert wrt.trace(scene, origins, [0, 0, -1], t_min=5.5, accel=accel, layout=layout).prim.tolist()[:4] == [1] * 4
    with pytest.raises(ValueError, match="t_min must not be NaN"):
        wrt.trace(scene, origins, [0, 0, -1], t_min=np.nan, accel=accel, layout=layout)


@pytest.mark.parametrize("instanced", [False, True], ids=["flat", "instanced"])
@pytest.mark.parametrize("accel, layout", [("wrt", "binary"), ("wrt", "compact"), ("wrt", "wide"), ("wrt", "wide8"),
                                           ("warp", "binary")])
def test_a_flat_quad_behind_the_origin_is_hit_at_negative_t(accel, layout, instanced, np_rng):
    """A ground quad at y = 0 under rays starting above it and pointing up, with ``t_min < 0``: every ray hits it at
    ``t = -o_y / d_y < 0`` (solved here in numpy). The box of a flat quad has a zero-thickness slab, whose exit was
    scaled by ``1 + 2 gamma`` to be safe: for a negative exit that shrank the box, so every wrt layout missed it
    (the world-space quad of an instanced scene too) while wp.Mesh hit it."""
    quad = Mesh("/Ground", [[-4, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4]], [[0, 2, 1], [0, 3, 2]], [0, 0])
    scene = wrt.Scene(meshes=[quad])
    if instanced:  # one more quad, instanced far away, makes the world-space quad an entry of the TLAS
        far = np.eye(4)
        far[:3, 3] = (100, 0, 0)
        scene = wrt.Scene(meshes=[quad], prototypes=[Prototype("/P", [quad])],
                          instances=Instances.from_transforms([0], far[None]))
    n = 200
    origins = np.column_stack([np_rng.uniform(-2, 2, n), np_rng.uniform(0.5, 3, n), np_rng.uniform(-2, 2, n)])
    tilt = np_rng.uniform(-0.3, 0.3, (n, 2))
    directions = np.column_stack([tilt[:, 0], np_rng.uniform(0.5, 1, n), tilt[:, 1]])
    expected = -origins[:, 1] / directions[:, 1]
    hits = wrt.trace(scene, origins, directions, t_min=-10.0, t_max=10.0, accel=accel, layout=layout)
    assert hits.hit.all(), f"{np.sum(~hits.hit)} of {n} rays missed"
    np.testing.assert_allclose(hits.t, expected, rtol=1e-5)
    assert wrt.occluded(scene, origins, directions, t_min=-10.0, t_max=0.0, accel=accel, layout=layout).all()


@pytest.mark.parametrize("t_min", [-1e5, -np.inf])
@pytest.mark.parametrize("accel, layout", [("wrt", "binary"), ("wrt", "wide8"), ("warp", "binary")])
def test_a_t_min_far_behind_the_scene_gives_the_hits_of_t_min_0(accel, layout, t_min, np_rng):
    """Rays from outside a unit box of triangles, aimed into it, meet nothing behind their origins, so any
    ``t_min <= 0`` gives the hits of ``t_min = 0``. ``accel="warp"`` started ``wp.mesh_query_ray`` at
    ``origin + t_min * direction``: at -1e5 the rounding of that start put all 77 hits' ``t`` off (by up to 0.13,
    8 on another triangle), and -inf made it NaN (all 77 missed)."""
    points, indices = random_soup(np_rng, 200)
    scene = wrt.Scene.from_triangles(points, indices)
    n = 100
    origins = np_rng.normal(size=(n, 3))
    origins = 3.0 * origins / np.linalg.norm(origins, axis=1, keepdims=True)  # outside the unit box
    directions = np_rng.uniform(-0.3, 0.3, (n, 3)) - origins  # aimed into it
    reference = wrt.trace(scene, origins, directions, accel=accel, layout=layout)
    assert reference.hit.sum() > n / 2
    hits = wrt.trace(scene, origins, directions, t_min=t_min, accel=accel, layout=layout)
    np.testing.assert_array_equal(hits.prim, reference.prim)
    np.testing.assert_allclose(hits.t, reference.t, rtol=1e-6)
    blocked = wrt.occluded(scene, origins, directions, t_min=t_min, accel=accel, layout=layout)
    np.testing.assert_array_equal(blocked, reference.hit)


def test_threaded_cpu_trace_gives_the_same_hits(np_rng):
    points, indices = random_soup(np_rng, 500)
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 100_000, seed=9)
    one = wrt.trace(scene, origins, directions, threads=1)
    for accel in ("wrt", "warp"):
        reference = one if accel == "wrt" else wrt.trace(scene, origins, directions, accel=accel, threads=1)
        many = wrt.trace(scene, origins, directions, accel=accel, threads=3)
        np.testing.assert_array_equal(many.prim, reference.prim)
        np.testing.assert_array_equal(many.t, reference.t)
        blocked = wrt.occluded(scene, origins, directions, accel=accel, threads=3)
        np.testing.assert_array_equal(blocked, reference.hit)
    with pytest.raises(ValueError, match="threads"):
        wrt.trace(scene, origins[:1], directions[:1], threads=0)


def test_a_bad_thread_count_raises_on_a_gpu_too(monkeypatch):
    """``threads=0`` raised on the CPU but was ignored on a GPU, so a script failed only where it ran on the CPU;
    ``WRT_THREADS`` is a CPU setting and stays unread there."""
    from types import SimpleNamespace

    from wrt.trace import resolve_threads

    gpu = SimpleNamespace(is_cpu=False)
    for bad in (0, -2, "two", True):
        with pytest.raises(ValueError, match="threads must be"):
            resolve_threads(bad, gpu)
    # The error lists every value taken: "all" is one (the docstring's), which it left out.
    for device in (gpu, wp.get_device("cpu")):
        with pytest.raises(ValueError, match=r"threads must be a positive integer, 'all' or None, got 0"):
            resolve_threads(0, device)
    assert resolve_threads(4, gpu) == 1
    monkeypatch.setenv("WRT_THREADS", "nonsense")
    assert resolve_threads(None, gpu) == 1


def test_a_thread_count_of_a_superscript_digit_is_named(monkeypatch):
    """``"²"`` passes ``str.isdigit`` but not ``int``: ``WRT_THREADS=²`` (and ``threads="²"``) raised int's own
    'invalid literal for int() with base 10', naming neither the variable nor the argument. Other decimal digits
    (``"٣"``) are numbers to ``int`` and are taken."""
    from wrt.trace import resolve_threads

    cpu = wp.get_device("cpu")
    monkeypatch.setenv("WRT_THREADS", "\u00b2")
    with pytest.raises(ValueError, match="WRT_THREADS environment variable must be .*, got '\u00b2'"):
        resolve_threads(None, cpu)
    monkeypatch.delenv("WRT_THREADS")
    with pytest.raises(ValueError, match="threads must be .*, got '\u00b2'"):
        resolve_threads("\u00b2", cpu)
    assert resolve_threads("\u0663", cpu) == int("\u0663") == 3


def test_cpu_launches_use_every_core_unless_told(monkeypatch):
    from wrt.trace import resolve_threads

    cpu = wp.get_device("cpu")
    cores = os.cpu_count()
    monkeypatch.delenv("WRT_THREADS", raising=False)
    assert resolve_threads(None, cpu) == cores
    assert resolve_threads(3, cpu) == 3
    monkeypatch.setenv("WRT_THREADS", "1")
    assert resolve_threads(None, cpu) == 1
    monkeypatch.setenv("WRT_THREADS", "all")
    assert resolve_threads(None, cpu) == cores
    for bad in ("many", "0", "-2"):  # the error named the threads argument, which the caller never passed
        monkeypatch.setenv("WRT_THREADS", bad)
        with pytest.raises(ValueError, match=f"WRT_THREADS environment variable must be .*, got '{bad}'"):
            resolve_threads(None, cpu)
    monkeypatch.setenv("WRT_THREADS", " 2 ")
    assert resolve_threads(None, cpu) == 2
    monkeypatch.delenv("WRT_THREADS")
    assert resolve_threads(np.int64(2), cpu) == 2
    for bad in (True, False, 2.0):  # True used to pass as one thread
        with pytest.raises(ValueError, match="threads must be a positive integer"):
            resolve_threads(bad, cpu)


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_edited_scene_is_traced_as_edited(accel):
    """A ray straight down onto a unit quad at z = 0. Moving the quad by replacing its points (noticed), by calling
    invalidate() and editing them in place, or adding a mesh, changes the hit; an unchanged scene keeps its tree. An
    edit in place without invalidate() (which traced the old quad, t = 3) is refused: traced arrays are read-only."""
    quad = wrt.Mesh("/quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 3)], [0, 0])
    scene = wrt.Scene(meshes=[quad])
    ray = dict(origins=[(0.25, 0.75, 5.0)], directions=[(0.0, 0.0, -1.0)], accel=accel)
    assert wrt.trace(scene, **ray).t[0] == pytest.approx(5.0)
    tree = get_accelerator(scene, accel)
    assert wrt.trace(scene, **ray).t[0] == pytest.approx(5.0) and get_accelerator(scene, accel) is tree

    quad.points = quad.points + np.float32([0, 0, 2])  # a new array: the cached tree is dropped
    assert wrt.trace(scene, **ray).t[0] == pytest.approx(3.0)
    with pytest.raises(ValueError, match="read-only"):
        quad.points[:, 2] -= 1.0
    assert wrt.trace(scene, **ray).t[0] == pytest.approx(3.0)
    scene.invalidate()  # the caller says it edits in place
    quad.points[:, 2] -= 1.0
    assert wrt.trace(scene, **ray).t[0] == pytest.approx(4.0)
    scene.meshes.append(wrt.Mesh("/lid", [(0, 0, 4.5), (1, 1, 4.5), (0, 1, 4.5)], [(0, 1, 2)], [0]))
    assert wrt.trace(scene, **ray).t[0] == pytest.approx(0.5)
    assert wrt.trace(scene, **ray).prim[0] == 2


def test_id_layout_is_cached_once_traced_and_follows_replaced_meshes():
    """``Scene.num_flat_triangles`` and the id layout (``split_ids``, ``instance_offsets``) summed over every mesh on
    each call, several per render (8 ms each for 40k meshes): once traced they are made once, and still follow a
    replaced or added mesh. Before the first trace they are made each time and the arrays stay writeable."""
    quad = wrt.Mesh("/quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 3)], [0, 0])
    scene = wrt.Scene(meshes=[quad])
    assert scene.num_flat_triangles == 2 and "2 triangles" in repr(scene)
    quad.points[:, 2] += 1.0  # repr and the counts freeze nothing
    wrt.trace(scene, origins=[(0.25, 0.75, 5.0)], directions=[(0.0, 0.0, -1.0)])
    assert scene._id_layout() is scene._id_layout()  # made once
    with pytest.raises(ValueError, match="read-only"):
        scene.instance_offsets()[0] = 5  # returned to callers: an edit would corrupt the cache
    quad.indices, quad.face_ids = np.array([(0, 1, 2)], np.int32), np.array([0], np.int32)
    assert scene.num_flat_triangles == 1 and scene.split_ids([0])[0].tolist() == [0]
    scene.meshes.append(wrt.Mesh("/lid", [(0, 0, 4.5), (1, 1, 4.5), (0, 1, 4.5)], [(0, 1, 2)], [0]))
    assert scene.num_flat_triangles == 2 and scene.instance_offsets().tolist() == [2]


def test_bounds_and_triangles_follow_a_replaced_or_added_mesh():
    """``Scene.bounds()`` and ``Scene.triangles()`` called directly (no trace or render between) returned their cached
    arrays after a mesh's points were replaced or a mesh was added: bounds (0, 0, 0)-(1, 1, 0) for a quad moved to
    z = 5, two triangles for three."""
    quad = wrt.Mesh("/quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 3)], [0, 0])
    scene = wrt.Scene(meshes=[quad])
    assert scene.bounds()[1].tolist() == [1, 1, 0] and len(scene.triangles()[1]) == 2
    quad.points = quad.points + np.float32([0, 0, 5])
    assert scene.bounds()[0].tolist() == [0, 0, 5] and scene.triangles()[0][:, 2].tolist() == [5] * 4
    scene.meshes.append(wrt.Mesh("/lid", [(0, 0, 9), (1, 1, 9), (0, 1, 9)], [(0, 1, 2)], [0]))
    assert scene.bounds()[1].tolist() == [1, 1, 9] and len(scene.triangles()[1]) == 3


def test_bounds_are_those_of_the_points_triangles_use():
    """``Scene.bounds()`` is the box of the points some triangle uses, whatever the points no triangle uses (far away
    or NaN) and however often a point is used: compared with float64 numpy over the used points of random meshes."""
    rng = np.random.default_rng(123)
    meshes, used = [], []
    for k in range(3):
        points = rng.normal(size=(50, 3)).astype(np.float32) * np.float32(10 ** k)
        points[40:] = 1e30  # no triangle uses these
        points[45] = np.nan
        indices = rng.integers(0, 40, size=(30, 3))
        meshes.append(wrt.Mesh(f"/m{k}", points, indices, np.arange(30)))
        used.append(points[np.unique(indices)].astype(np.float64))
    lower, upper = wrt.Scene(meshes=meshes).bounds()
    used = np.concatenate(used)
    assert lower.dtype == upper.dtype == np.float32
    assert lower.tolist() == used.min(axis=0).astype(np.float32).tolist()
    assert upper.tolist() == used.max(axis=0).astype(np.float32).tolist()


def test_default_camera_frames_a_scene_edited_after_a_render():
    """The default camera is framed from the scene's cached bounds: after a mesh is replaced by one far away, the next
    render must frame the new mesh, not the old box (whose cache was read before the trees were dropped)."""
    quad = wrt.Mesh("/quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2), (0, 2, 3)], [0, 0])
    scene = wrt.Scene(meshes=[quad], up_axis="Z")
    assert (wrt.render(scene, width=8, height=8).aovs["prim"] >= 0).any()
    quad.points = quad.points + np.float32([100, 0, 0])
    assert (wrt.render(scene, width=8, height=8).aovs["prim"] >= 0).any()


def test_node_visits_of_the_layouts_are_as_hits_documents(np_rng):
    """``Hits.nodes_visited``: binary counts the nodes whose box the ray enters; compact and wide layouts keep no
    root box and count their root for every ray, and a one-leaf tree gets a root over its leaf; past the root,
    compact counts what binary counts (the bunny, rays that enter its box), and wide layouts count fewer nodes."""
    one = wrt.Scene.from_triangles(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32),
                                   np.array([[0, 1, 2]], np.int32))
    origins, down = np.array([[0.25, 0.25, 1], [2, 2, 1]], np.float32), np.array([0, 0, -1], np.float32)
    counts = {layout: wrt.trace(one, origins, down, layout=layout) for layout in ("binary", "compact", "wide", "wide8")}
    assert counts["binary"].nodes_visited.tolist() == [1, 0]
    for layout in ("compact", "wide", "wide8"):
        assert counts[layout].nodes_visited.tolist() == [2, 1]
        assert counts[layout].triangles_tested.tolist() == counts["binary"].triangles_tested.tolist() == [1, 0]

    bunny = wrt.load_usd(warp_assets("bunny.usd"))
    lower, upper = bunny.bounds()
    targets = lower + (upper - lower) * np_rng.random((500, 3))
    origins = (targets + np_rng.normal(size=(500, 3)) * np.linalg.norm(upper - lower)).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    binary = wrt.trace(bunny, origins, directions)
    compact = wrt.trace(bunny, origins, directions, layout="compact")
    np.testing.assert_array_equal(compact.nodes_visited, binary.nodes_visited)
    np.testing.assert_array_equal(compact.triangles_tested, binary.triangles_tested)
    for layout in ("wide", "wide8"):
        assert wrt.trace(bunny, origins, directions, layout=layout).nodes_visited.mean() < binary.nodes_visited.mean()


# Every accelerator behind wrt.trace: wrt's layouts, its two-level (TLAS) traversal, and wp.Mesh.
TRACE_CONFIGS = [("wrt", "binary", False), ("wrt", "compact", False), ("wrt", "wide", False),
                 ("wrt", "wide8", False), ("wrt", "binary", True), ("warp", "binary", False)]
TRACE_IDS = [f"{a}-{layout}" + ("-instanced" if inst else "") for a, layout, inst in TRACE_CONFIGS]


def one_triangle_scene(instanced: bool) -> wrt.Scene:
    """The triangle ``(-1, -1, 0), (1, -1, 0), (0, 1, 0)`` in the plane z = 0, as a mesh or as one instance of it."""
    points, tris = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32)
    if not instanced:
        return wrt.Scene.from_triangles(points, tris)
    proto = Prototype("/P", [Mesh("/P/tri", points, tris, np.zeros(1, np.int32))])
    return wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0], np.eye(4)[None]))


def test_ray_arrays_of_bools_dates_or_python_objects_raise_naming_the_argument():
    """Bool arrays were traced as 0 and 1 (``t_max=True`` as 1), datetimes and timedeltas as their counts, and an
    object array holding None as NaN (the ray missed without a word); each now raises, naming the argument and
    what it held. Integer arrays are numbers: they trace as the same floats do (the hit at t = 1, found here
    analytically)."""
    scene = one_triangle_scene(False)
    good_o, good_d = np.array([[0, 0, 1]], np.float32), np.array([[0, 0, -1]], np.float32)
    for name, args, kwargs, what in (
        ("origins", (np.array([[False, False, True]]), good_d), {}, "dtype bool"),
        ("directions", (good_o, [[False, False, True]]), {}, "dtype bool"),
        ("t_max", (good_o, good_d), {"t_max": True}, "dtype bool"),
        ("t_min", (good_o, good_d), {"t_min": np.zeros(1, bool)}, "dtype bool"),
        ("origins", (good_o.astype("datetime64[s]"), good_d), {}, "dtype datetime64"),
        ("t_max", (good_o, good_d), {"t_max": np.timedelta64(2, "s")}, "dtype timedelta64"),
        ("origins", ([[0, None, 1]], good_d), {}, "None at index"),
        ("directions", (good_o, np.array([[0, 0, "-1"]], dtype=object)), {}, "str '-1' at index"),
    ):
        for query in (wrt.trace, wrt.occluded):
            with pytest.raises(ValueError, match=f"{name} must hold real numbers .*{what}"):
                query(scene, *args, **kwargs)
    for o, d, t_max in (
        (good_o.astype(np.int64), good_d.astype(np.int8), np.uint16(2)),
        (np.array([[0, 0, 1]], dtype=object), [[0, 0, -1]], np.array([2], dtype=object)),  # Python ints in objects
        ([[0, 0, 1]], np.array([[0, 0, -1]], dtype=object), 2),
    ):
        hits = wrt.trace(scene, o, d, t_max=t_max)
        assert hits.prim.tolist() == [0] and hits.t.tolist() == [1.0]
        assert wrt.occluded(scene, o, d, t_max=t_max).tolist() == [True]
    with pytest.raises(ValueError, match=r"origins row 0, \[0.0, 0.0, 1e\+40\], is beyond float32's range"):
        wrt.trace(scene, np.array([[0, 0, 10**40]], dtype=object), good_d)  # an int too large for int64


@pytest.mark.parametrize("accel, layout, instanced", TRACE_CONFIGS, ids=TRACE_IDS)
def test_float64_t_limits_keep_t_min_le_t_lt_t_max_exactly(accel, layout, instanced):
    """Limits were rounded to the nearest float32: ``t_min = 1 + 1e-12`` became 1 and kept a hit at t = 1 (analytic:
    the origin is 1 above the triangle), ``t_max = 1 + 1e-12`` became 1 and lost it, and ``t_min = 1e-50`` became 0
    and kept the hit at t = 0 of an origin on the triangle. Rounded up, a float32 ``t`` compares with the float32
    limit as it does with the given one."""
    scene = one_triangle_scene(instanced)
    query = {"accel": accel, "layout": layout}
    above, down = [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]]
    for t_min, t_max, expected in ((1 + 1e-12, np.inf, []), (0.0, 1 + 1e-12, [1.0]), (1 - 1e-12, np.inf, [1.0]),
                                   (0.0, 1 - 1e-12, [])):
        hits = wrt.trace(scene, above, down, t_min=t_min, t_max=t_max, **query)
        assert hits.t[hits.hit].tolist() == expected, (t_min, t_max)
        assert wrt.occluded(scene, above, down, t_min=t_min, t_max=t_max, **query).tolist() == [bool(expected)]
    on_surface = [[0.0, 0.0, 0.0]]
    for t_min in (1e-50, np.array([1e-50]), [-1e-300]):
        hits = wrt.trace(scene, on_surface, down, t_min=t_min, **query)
        t_min = float(np.ravel(t_min)[0])
        assert not hits.hit[0] or hits.t[0] >= t_min, hits.t  # wp.Mesh starts its query at t_min: it may hit there
        assert hits.hit[0] == (t_min <= 0) or accel == "warp"
        assert wrt.occluded(scene, on_surface, down, t_min=t_min, **query).tolist() == hits.hit.tolist()


def test_rays_past_float32s_t_behind_them_or_across_a_scene_past_half_its_range_are_named_too():
    """Two rays whose float64 hit has no float32 t went unnamed: with ``t_min = -inf`` a direction of length 1e-38
    away from a triangle 10 behind it (t = -1e39: wrt reported a hit at t = -inf, ``wp.Mesh`` a miss), and a
    direction of length 1.2 from x = 2.9e38 across a scene reaching x = -3e38 (t = 4.9e38, a miss), where
    ``|d| * 3.4e38`` and ``(|o| + reach) * 2`` both overflowed to inf and so looked within reach (the reverse of that
    ray meets the scene at t = -4.9e38). With ``t_min = -3.4e38`` only the second is named, and a ray whose ``t_max``
    of 1e30 ends it before the triangle (at t = 1e39) never is."""
    big = np.float32(3e38)
    points = np.array([[-big, 0, 0], [-big, 1, 0], [-big, 0, 1], [-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32)
    scene = wrt.Scene.from_triangles(points, np.array([[0, 1, 2], [3, 4, 5]], np.int32))
    origins = np.array([[0, 0, 10], [2.9e38, 0.2, 0.2], [0, 0, 10], [2.9e38, 0.2, 0.2], [0, 0, 10]], np.float32)
    directions = np.array([[0, 0, 1e-38], [-1.2, 0, 0], [0, 0, -1e-30], [1.2, 0, 0], [0, 0, -1e-38]], np.float32)
    t_maxs = np.array([np.inf] * 4 + [1e30], np.float32)  # the last ends before the triangle (at t = 1e39)
    lowest = np.finfo(np.float32).min
    for t_min, named in ((-np.inf, [0, 1, 3]), (lowest, [1])):
        t_mins = np.full(5, t_min, np.float32)
        t, prim, clear = float64_closest_hits(points, scene.triangles()[1], origins, directions,
                                              t_mins.astype(np.float64), t_maxs.astype(np.float64))
        assert clear.all() and np.flatnonzero(np.isfinite(t) & (np.abs(t) > -float(lowest))).tolist() == named, t
        for query in (wrt.trace, wrt.occluded):
            with warnings.catch_warnings(record=True) as said:
                warnings.simplefilter("always")
                query(scene, origins, directions, t_min=t_mins, t_max=t_maxs)
            reach = [str(w.message) for w in said if "beyond t = 3.4e38" in str(w.message)]
            assert len(reach) == 1 and reach[0].startswith(f"{len(named)} of 5 rays (the first: row {named[0]},"), \
                (t_min, [str(w.message) for w in said])


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("layout", ["binary", "compact", "wide", "wide8"])
def test_a_ray_with_zero_components_from_beyond_1e37_hits_a_unit_triangle(layout, device):
    """Straight down from ``(0.5, -0.5, z)`` onto a unit triangle at z = 0: the float64 oracle hits it at ``t = z`` for
    every ``z`` up to 3e38 (float32's t holds them all). The slab of a zero direction component ended at 1e38
    (FLAT_INVERSE) times the origin's distance from the box's faces, 0.5 here, so wrt missed from 5.1e37; its margin
    now follows the origin's distance (``geometry.flat_margin``; on CUDA such a slab holding the ray is infinite)."""
    scene = one_triangle_scene(False)
    origins = np.array([[0.5, -0.5, z] for z in (1e37, 4.9e37, 5.1e37, 1e38, 3e38)], np.float32)
    directions = np.tile(np.array([[0, 0, -1]], np.float32), (len(origins), 1))
    t, prim, clear = float64_closest_hits(*scene.triangles(), origins, directions, np.zeros(5), np.full(5, np.inf))
    assert prim.tolist() == [0] * 5 and clear.all()
    np.testing.assert_allclose(wrt.trace(scene, origins, directions, layout=layout, device=device).t, t, rtol=1e-6)
    assert wrt.occluded(scene, origins, directions, layout=layout, device=device).all()


def test_limits_at_float32s_largest_value_are_taken_without_a_numpy_warning():
    """``t_max = np.finfo(np.float32).max`` (or ``t_min = -max``) made numpy say "overflow encountered in nextafter"
    (a RuntimeWarning) at every trace and occluded: rounding the limits up to float32 stepped that value to inf, then
    kept it (it is a float32). The origin is 1 above the triangle: the hit is at t = 1, none from t_min = max."""
    scene = one_triangle_scene(False)
    big = np.finfo(np.float32).max
    above, down = [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for t_min, t_max, expected in ((-big, big, [1.0]), ([float(big)], np.inf, []),
                                       (np.float64(-big), [big], [1.0])):
            hits = wrt.trace(scene, above, down, t_min=t_min, t_max=t_max)
            assert hits.t[hits.hit].tolist() == expected, (t_min, t_max)
            assert wrt.occluded(scene, above, down, t_min=t_min, t_max=t_max).tolist() == [bool(expected)]


@pytest.mark.parametrize("accel, layout, instanced", TRACE_CONFIGS, ids=TRACE_IDS)
def test_tiny_t_limits_keep_their_meaning_along_short_directions(accel, layout, instanced):
    """wrt's kernels scale a ray's direction by a power of two near ``1 / |d|`` and its limits by ``|d|``
    (``traverse.unit_ray``): along a direction of length 1e-30 a ``t_min`` of 1e-20 became 1e-50, 0 in float32, so
    an origin on the triangle hit it at t = 0 < t_min; and a ``t_max`` of 1e-20 became 0, an empty range, so the hit
    at t = 0 < t_max was lost. The analytic answer: the only hit of a ray from the triangle's plane is at t = 0;
    from 1 above it, at t = 1 / |d|."""
    scene = one_triangle_scene(instanced)
    query = {"accel": accel, "layout": layout}
    lengths = np.array([1.0, 1e-20, 1e-30, 1e-37, 1e-40], np.float32)  # 1e-40: a subnormal float32
    for sign in (1.0, -1.0):
        directions = np.zeros((len(lengths), 3), np.float32)
        directions[:, 2] = sign * lengths
        on_surface = np.zeros_like(directions)
        for t_min in (2.0**-149, 1e-40, 1e-20, 1e-10):
            hits = wrt.trace(scene, on_surface, directions, t_min=t_min, **query)
            reported = hits.t[hits.hit].astype(np.float64)
            assert (reported >= t_min).all(), (t_min, hits.t)
            if accel == "wrt":
                assert not hits.hit.any(), (t_min, hits.t)
            assert wrt.occluded(scene, on_surface, directions, t_min=t_min, **query).tolist() == hits.hit.tolist()
        for t_min, t_max in ((0.0, 2.0**-149), (0.0, 1e-40), (0.0, 1e-20), (-1e-40, 1e-30), (-1e-20, np.inf)):
            hits = wrt.trace(scene, on_surface, directions, t_min=t_min, t_max=t_max, **query)
            assert hits.hit.all() and (hits.t == 0).all(), (t_min, t_max, hits.t)
            assert wrt.occluded(scene, on_surface, directions, t_min=t_min, t_max=t_max, **query).all()
    above, down = np.tile([[0.0, 0.0, 1.0]], (4, 1)), -np.abs(directions[:4])
    hits = wrt.trace(scene, above, down, t_min=1e-40, **query)  # the hits at t = 1 / |d| stay
    np.testing.assert_allclose(hits.t, 1.0 / lengths[:4].astype(np.float64), rtol=1e-6)


def test_a_tiny_t_min_along_a_short_direction_excludes_an_analytic_sphere_at_t_0():
    """Analytic shapes (traced under the TLAS) take the same scaled limits: from the top of a unit sphere along
    ``(0, 0, -1e-30)`` a ``t_min`` of 1e-20 scaled to 0 and the hit at the origin (t = 0) was reported; the next hit
    is the far side, 2 away: t = 2e30."""
    from wrt.primitives import Shape

    scene = wrt.Scene(shapes=[Shape("/S", "sphere", np.eye(4))])
    for t_min, expected in ((0.0, 0.0), (1e-20, 2e30), (1e-40, 2e30)):
        hits = wrt.trace(scene, [0, 0, 1], [0, 0, -1e-30], t_min=t_min)
        assert hits.prim.tolist() == [0]
        np.testing.assert_allclose(hits.t, [expected], rtol=1e-6)


@pytest.mark.parametrize("layout, instanced", [("binary", False), ("wide8", False), ("binary", True)])
def test_limits_at_a_hits_own_t_decide_it_exactly_along_directions_of_any_length(layout, instanced, np_rng):
    """Origins a subnormal height above the triangle, directions of lengths 2^-125 to 2: the scaled rays of the
    kernels meet it at t below float32's normal range. wrt's ``t`` of a triangle does not depend on the limits, so a
    limit at, just above or just below each ray's own ``t`` (float32 and float64 neighbours) must keep the hit
    exactly when ``t_min <= t < t_max`` in float64. Before the limits were rounded for the scaled rays, a limit one
    float32 (or 1e-12) above the hit's ``t`` rounded down onto it in 492 of these 500 rays once scaled: ``t_min``
    kept hits below it and ``t_max`` lost hits below it."""
    scene = one_triangle_scene(instanced)
    n = 500
    heights = np_rng.integers(1, 2**20, n) * 2.0**-149
    lengths = 2.0 ** -np_rng.integers(0, 126, n) * np_rng.uniform(1, 2, n)
    origins = np.column_stack([np_rng.uniform(-0.3, 0.3, (n, 2)), heights]).astype(np.float32)
    directions = np.column_stack([np.zeros((n, 2)), -lengths]).astype(np.float32)
    reference = wrt.trace(scene, origins, directions, layout=layout)
    assert reference.hit.all() and np.isfinite(reference.t).all()
    t = reference.t.astype(np.float64)
    t32 = reference.t
    for limits in (t, np.nextafter(t32, np.float32(np.inf)), np.nextafter(t32, np.float32(-np.inf)),
                   t * (1 + 1e-12), t * (1 - 1e-12)):
        limits = np.asarray(limits, np.float64)
        for kwargs, expected in (({"t_min": limits}, t >= limits), ({"t_max": limits}, t < limits)):
            hits = wrt.trace(scene, origins, directions, layout=layout, **kwargs)
            np.testing.assert_array_equal(hits.hit, expected)
            np.testing.assert_array_equal(hits.t[hits.hit], t32[hits.hit])
            np.testing.assert_array_equal(wrt.occluded(scene, origins, directions, layout=layout, **kwargs), expected)


@pytest.mark.parametrize("accel, layout, instanced", TRACE_CONFIGS, ids=TRACE_IDS)
def test_one_ray_against_an_empty_batch_gives_no_hits(accel, layout, instanced):
    """One origin for no directions (numpy broadcasts ``(1, 3)`` with ``(0, 3)`` to ``(0, 3)``) raised a RuntimeError
    from Warp ("Invalid indexing in slice") after launching one ray over an empty direction array."""
    scene = one_triangle_scene(instanced)
    query = {"accel": accel, "layout": layout}
    for o, d in (([0, 0, 1], np.zeros((0, 3))), ([[0, 0, 1]], np.zeros((0, 3))), (np.zeros((0, 3)), [0, 0, -1]),
                 (wp.array([[0, 0, 1]], dtype=wp.vec3), wp.zeros(0, dtype=wp.vec3))):
        hits = wrt.trace(scene, o, d, **query)
        assert hits.t.shape == hits.prim.shape == (0,)
        assert wrt.occluded(scene, o, d, **query).shape == (0,)


@pytest.mark.parametrize("accel, layout, instanced", TRACE_CONFIGS, ids=TRACE_IDS)
def test_a_hit_at_the_origin_is_t_plus_zero(accel, layout, instanced):
    """Origins on the triangle's plane: a ray leaving it (either way, any slope, any direction length) hits it at
    t = 0 exactly, analytically. It came back as -0.0 for rays leaving downwards (and from wp.Mesh with a negative
    ``t_min``): ``1 / t`` was -inf and ``np.signbit`` put the hit behind the origin."""
    scene = one_triangle_scene(instanced)
    directions = np.array([[0, 0, -1], [0, 0, 1], [0.3, 0.2, -1], [-0.1, 0.4, 1], [0, 0, -1e-30], [0, 0, 3e5]],
                          np.float32)
    origins = np.tile([[0.1, -0.2, 0.0]], (len(directions), 1))
    for t_min in (0.0, -0.0, -1.0, -np.inf):
        hits = wrt.trace(scene, origins, directions, t_min=t_min, accel=accel, layout=layout)
        assert hits.hit.all() and (hits.t == 0).all(), (t_min, hits.t)
        assert not np.signbit(hits.t).any(), (t_min, hits.t)


@pytest.mark.parametrize("layout, instanced", [("binary", False), ("wide8", False), ("binary", True)],
                         ids=["binary", "wide8", "binary-instanced"])
def test_a_ray_leaving_a_face_at_a_shallow_slope_hits_it_at_t_0(layout, instanced, np_rng):
    """As above, but the rays leave the triangle's plane (z = 0) at slopes of 0.01 to 0.9 (up or down), so z is not
    their largest component: each must hit the triangle at t = 0 exactly (its origin lies on it, well inside). t came
    out up to +-1.2e-7 (float32 epsilons of the corners' distances, 2 here): ``t_min = 0`` lost the 211 of 500 below
    0, and 207 more were hit past 0. Oracle: the origins lie on the triangle by construction."""
    scene = one_triangle_scene(instanced)
    n = 500
    corners = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float64)
    weights = 0.1 + 0.7 * np_rng.dirichlet([1, 1, 1], n)  # each corner's weight at least 0.1: clear of the edges
    origins = (weights / weights.sum(axis=1, keepdims=True)) @ corners
    heading = np_rng.uniform(0, 2 * np.pi, n)
    slope = np_rng.choice([-1, 1], n) * np_rng.uniform(0.01, 0.9, n)
    directions = np.column_stack([np.cos(heading), np.sin(heading), slope])
    hits = wrt.trace(scene, origins.astype(np.float32), directions.astype(np.float32), layout=layout)
    assert hits.hit.all(), f"{np.count_nonzero(~hits.hit)} of {n} missed"
    np.testing.assert_array_equal(hits.t, 0.0)


def test_a_hit_at_the_origin_on_an_analytic_sphere_is_t_plus_zero():
    """From the top of a unit sphere, rays leaving upwards and downwards both meet it at t = 0 (analytic); the one
    leaving upwards got -0.0."""
    from wrt.primitives import Shape

    scene = wrt.Scene(shapes=[Shape("/S", "sphere", np.eye(4))])
    hits = wrt.trace(scene, [[0, 0, 1], [0, 0, 1]], [[0, 0, 1], [0, 0, -1]])
    assert hits.t.tolist() == [0.0, 0.0] and not np.signbit(hits.t).any(), hits.t


def test_limits_take_every_shape_numpy_broadcasts_as_one_value_per_ray():
    """A column ``(N, 1)`` (how numpy code writes a per-ray value next to ``(N, 3)`` rays) and ``(1,)``/``(1, 1)``
    (one value for all) were refused; they mean what ``(N,)`` and a scalar mean. Origins 1 above the triangle, so
    the only hit is at t = 1 (analytic) and a ``t_max`` of 1 loses it. ``(1, 3)`` and ``(N, 1, 1)`` are no value per
    ray: refused, naming the shapes taken."""
    scene = one_triangle_scene(False)
    origins, down = np.tile([[0.0, 0.0, 1.0]], (3, 1)), [0, 0, -1]
    per_ray = np.array([2.0, 0.5, 1.0])
    for query in (wrt.trace, wrt.occluded):
        for t_max, expected in ((per_ray[:, None], [True, False, False]), (per_ray.reshape(1, 3).T.tolist(),
                                [True, False, False]), ([0.5], [False] * 3), ([[2.0]], [True] * 3)):
            result = query(scene, origins, down, t_max=t_max)
            assert (result.hit if query is wrt.trace else result).tolist() == expected, (query, t_max)
        result = query(scene, origins, down, t_min=np.array([[1.0], [1.5], [-1.0]]))
        assert (result.hit if query is wrt.trace else result).tolist() == [True, False, True]
        for bad in (np.zeros((1, 3)), np.zeros((3, 1, 1)), np.zeros((2, 1)), np.zeros(2)):
            taken = "shape (), (1,), (1, 1), (3,) or (3, 1)"
            with pytest.raises(ValueError, match=re.escape(f"one value per ray: {taken}; got shape {bad.shape}")):
                query(scene, origins, down, t_max=bad)
    np.testing.assert_array_equal(wrt.trace(scene, origins, down, t_max=per_ray[:, None]).t, [1.0, np.inf, np.inf])
    with pytest.raises(ValueError, match=r"t_min must not be NaN \(ray 1 is the first of 1\)"):
        wrt.trace(scene, origins, down, t_min=np.array([[0.0], [np.nan], [0.0]]))
    with pytest.raises(ValueError, match=r"t_min must not be NaN$"):  # one value for all names no ray
        wrt.trace(scene, origins, down, t_min=[np.nan])


def test_nan_limits_raise_naming_the_first_bad_ray():
    scene = one_triangle_scene(False)
    origins, directions = np.tile([[0.0, 0.0, 1.0]], (4, 1)), [0, 0, -1]
    for name in ("t_min", "t_max"):
        for query in (wrt.trace, wrt.occluded):
            with pytest.raises(ValueError, match=rf"{name} must not be NaN \(ray 2 is the first of 2\)"):
                query(scene, origins, directions, **{name: [0.0, 0.5, np.nan, np.nan]})
    with pytest.raises(ValueError, match="t_max must not be NaN; use inf"):  # a scalar has no ray to name
        wrt.trace(scene, origins, directions, t_max=np.nan)


def float64_closest_hits(points, indices, origins, directions, t_min, t_max):
    """Closest hit of each ray over every triangle, in float64 (Moller-Trumbore): ``(t, prim, clear)``, with ``t``
    inf and ``prim`` -1 on a miss, and ``clear`` False for rays that float32 may decide either way (a triangle
    within 1e-4 of its edge, a hit within 1e-4 relative of a limit, two hits that close)."""
    p0, p1, p2 = (points[indices[:, k]].astype(np.float64) for k in range(3))
    o, d = np.asarray(origins, np.float64), np.asarray(directions, np.float64)
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(d[:, None], e2[None])
    det = np.einsum("nmk,mk->nm", pv, e1)
    tv = o[:, None] - p0[None]
    qv = np.cross(tv, e1[None])
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.einsum("nmk,nmk->nm", tv, pv) / det
        v = np.einsum("nk,nmk->nm", d, qv) / det
        t = np.einsum("mk,nmk->nm", e2, qv) / det
    margin = np.minimum(np.minimum(u, v), 1 - u - v)
    crossed = (margin > 0) & np.isfinite(t)
    candidates = np.where(crossed & (t >= t_min[:, None]) & (t < t_max[:, None]), t, np.inf)
    prim = candidates.argmin(axis=1)
    best = candidates[np.arange(len(o)), prim]
    slack = 1e-4 * (np.abs(t) + 1e-3 / np.linalg.norm(d, axis=1)[:, None])
    near_limit = crossed & ((np.abs(t - t_min[:, None]) < slack) | (np.abs(t - t_max[:, None]) < slack))
    near_edge = (np.abs(margin) < 1e-4) & np.isfinite(t)
    second = np.sort(candidates, axis=1)[:, 1] if candidates.shape[1] > 1 else np.full(len(o), np.inf)
    with np.errstate(invalid="ignore"):
        near_tie = np.isfinite(second) & (second - best < 1e-4 * np.abs(best))
    clear = ~(near_limit.any(axis=1) | near_edge.any(axis=1) | near_tie)
    return best, np.where(np.isfinite(best), prim, -1), clear


@pytest.mark.parametrize("builder", ["sah", "sweep_sah", "median", "middle", "lbvh", "ploc"])
def test_random_rays_and_ranges_in_any_array_form_match_a_float64_oracle(builder, np_rng):
    """Float64 rays in Fortran order and through negative strides, directions of lengths 1e-30 to 1e30, and per-ray
    ranges of every kind (negative ``t_min``, ``-inf``, empty, ``t_min > t_max``, ``t_min == t_max``): every layout,
    the two-level traversal and ``wp.Mesh`` give the float64 brute-force answer on every ray it can decide, and
    ``occluded`` agrees with ``trace``."""
    points, indices = random_soup(np_rng, 60)
    flat = wrt.Scene.from_triangles(points, indices)
    proto = Prototype("/P", [Mesh("/P/soup", points, indices, np.zeros(len(indices), np.int32))])
    instanced = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0], np.eye(4)[None]))
    n = 600
    origins = np_rng.uniform(-2, 2, (n, 3))
    aims = points[indices[np_rng.integers(0, len(indices), n)]].mean(axis=1) + np_rng.normal(scale=0.02, size=(n, 3))
    directions = (aims - origins) * 10.0 ** np_rng.uniform(-30, 30, (n, 1))
    origins32, directions32 = origins.astype(np.float32), directions.astype(np.float32)
    unit = 1.0 / np.linalg.norm(directions32.astype(np.float64), axis=1)  # t of one unit of distance
    a, b = np_rng.uniform(-2, 3, n) * unit, np_rng.uniform(0, 8, n) * unit
    # Ranges by ray: [0, inf), [-inf, a + b), [a, a + b), [a + b, a) (t_min > t_max), [a, a), [a, inf); a may be < 0.
    kind = np.arange(n) % 6
    t_min = np.select([kind == 0, kind == 1, kind == 3], [np.zeros(n), np.full(n, -np.inf), a + b], a)
    t_max = np.select([kind == 0, kind == 3, kind == 4, kind == 5], [np.full(n, np.inf), a, a, np.full(n, np.inf)],
                      a + b)
    t, prim, clear = float64_closest_hits(points, indices, origins32, directions32, t_min, t_max)
    assert (prim >= 0).sum() > n / 4 and clear.sum() > 0.95 * n
    fortran, reversed_view = np.asfortranarray(origins), directions[::-1, ::-1][::-1, ::-1]
    configs = [("wrt", layout, flat) for layout in ("binary", "compact", "wide", "wide8")] + [("wrt", "binary",
                                                                                              instanced)]
    if builder in WARP_BUILDERS:
        configs.append(("warp", "binary", flat))
    for accel, layout, scene in configs:
        query = {"accel": accel, "layout": layout, "builder": builder, "t_min": t_min, "t_max": t_max}
        hits = wrt.trace(scene, fortran, reversed_view, **query)
        label = (accel, layout, len(scene.instances))
        np.testing.assert_array_equal(hits.prim[clear], prim[clear], err_msg=str(label))
        np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-4, err_msg=str(label))
        reported = hits.t[hits.hit].astype(np.float64)
        assert ((reported >= t_min[hits.hit]) & (reported < t_max[hits.hit])).all(), label
        np.testing.assert_array_equal(wrt.occluded(scene, fortran, reversed_view, **query), hits.hit, str(label))


@pytest.mark.parametrize("accel, builder", [("wrt", "sah"), ("warp", "sah"), ("warp", "lbvh")])
def test_occluded_agrees_with_trace_on_intervals_ending_at_hits(accel, builder):
    """Any hit reports a ray blocked exactly when the closest-hit query finds a hit in ``[t_min, t_max)``, also for
    intervals whose ends sit on a hit: ``[t, t + 1 ulp)`` around each ray's own hit and ``[-inf, t)`` below it.
    ``accel="warp"`` decided its any-hit rays by ``wp.mesh_query_ray_anyhit`` from a start moved to ``t_min`` (or
    the box entry), with no ``t`` to check against the limits: 107 of 4,000 rays were blocked in ``[t, t + 1 ulp)``
    where its trace found nothing there, and 3 blocked below ``t_max = t``, two of them with no hit before ``t`` at
    all (float64 oracle)."""
    rng = np.random.default_rng(1)
    corners = rng.uniform(-6, 6, (300, 1, 3)) + rng.normal(0, 1, (300, 3, 3))  # a soup of 300 triangles
    scene = wrt.Scene.from_triangles(corners.reshape(-1, 3).astype(np.float32), np.arange(900).reshape(-1, 3))
    n = 4000
    origins = rng.uniform(-8, 8, (n, 3)).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    first = wrt.trace(scene, origins, directions, accel=accel, builder=builder)
    hit = first.hit
    assert hit.sum() > 1000
    o, d, t = origins[hit], directions[hit], first.t[hit]
    past = np.nextafter(t, np.float32(np.inf))
    for t_min, t_max in ((t, past), (np.float32(-np.inf), t), (np.nextafter(t, np.float32(-np.inf)), past)):
        hits = wrt.trace(scene, o, d, t_min=t_min, t_max=t_max, accel=accel, builder=builder)
        lo, hi = np.broadcast_to(t_min, t.shape), np.broadcast_to(t_max, t.shape)
        assert np.all(hits.t[hits.hit] >= lo[hits.hit]) and np.all(hits.t[hits.hit] < hi[hits.hit])
        blocked = wrt.occluded(scene, o, d, t_min=t_min, t_max=t_max, accel=accel, builder=builder)
        np.testing.assert_array_equal(blocked, hits.hit)


def test_hits_compare_by_their_arrays():
    """``hits == again`` and ``hits in results`` raised numpy's 'truth value of an array ... is ambiguous'."""
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    origins, directions = [[0.2, 0.2, 1.0], [0.2, 0.2, -1.0], [5.0, 5.0, 1.0]], [0.0, 0.0, -1.0]
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.t, [1.0, np.inf, np.inf])  # the plane z = 0 is 1 below the first origin only
    again = wrt.trace(scene, origins, directions)
    assert hits == again and not hits != again and hits in [again]
    fewer = wrt.trace(scene, origins, directions, t_max=0.5)  # the one hit is past t_max
    assert hits != fewer and hits not in [fewer] and fewer.t.tolist() == [np.inf] * 3
    assert hits != wrt.trace(scene, origins[:2], directions) and hits != "hits"


def test_wp_mesh_traces_directions_below_1e38_as_wrt_does(np_rng):
    """``accel="warp"`` missed every ray whose direction's components were all below about 1e-38 (``(0, 0, -1e-39)``
    straight down onto a triangle; ``wp.mesh_query_ray``'s inverses overflow), where wrt's kernels, which trace
    each ray scaled into ``[1, 2)`` by a power of two (``traverse.unit_ray``), hit them. Its kernels now scale
    alike. Oracle: the float64 closest hit of each ray (unit rays into a soup 2^-10 across, then the same rays
    scaled by 2^-127, whose hits lie at ``t`` up to 1e36); and the scaled ray's hit is the unit ray's exactly, ``t``
    times 2^127, limits scaled with it."""
    points, indices = random_soup(np_rng, 100)
    points = points * np.float32(2.0**-10)
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 1000, seed=4)
    directions = (directions / np.linalg.norm(directions, axis=1, keepdims=True)).astype(np.float32)
    tiny = directions * np.float32(2.0**-127)  # every component below 5.9e-39 (subnormal: rounded)
    assert (np.abs(tiny) < 1e-38).all()
    directions = tiny * np.float32(2.0**127)  # exact: the unit rays along the tiny ones
    n = len(tiny)
    t, prim, clear = float64_closest_hits(points, indices, origins, tiny, np.zeros(n), np.full(n, np.inf))
    assert clear.mean() > 0.9 and np.isfinite(t).mean() > 0.2
    unit = wrt.trace(scene, origins, directions, accel="warp")
    for accel in ("warp", "wrt"):
        hits = wrt.trace(scene, origins, tiny, accel=accel)
        np.testing.assert_array_equal(hits.prim[clear], prim[clear], err_msg=accel)
        np.testing.assert_allclose(hits.t[clear & hits.hit], t[clear & hits.hit], rtol=1e-4, err_msg=accel)
        np.testing.assert_array_equal(wrt.occluded(scene, origins, tiny, accel=accel), hits.hit, err_msg=accel)
    warp = wrt.trace(scene, origins, tiny, accel="warp")
    for name in ("t", "u", "v", "prim"):
        scale = np.float32(2.0**127) if name == "t" else np.float32(1)
        np.testing.assert_array_equal(getattr(warp, name), getattr(unit, name) * scale, err_msg=name)
    # Limits scale with the ray: [t_min, t_max) around each unit hit, as the tiny rays' limits.
    t_min = np.where(unit.hit, unit.t * np.float32(0.5), 0).astype(np.float32)
    t_max = np.where(unit.hit, unit.t, np.inf).astype(np.float32)  # exclusive: the hit itself is cut off
    limited_unit = wrt.trace(scene, origins, directions, t_min=t_min, t_max=t_max, accel="warp")
    scaled = np.float32(2.0**127)
    limited = wrt.trace(scene, origins, tiny, t_min=t_min * scaled, t_max=t_max * scaled, accel="warp")
    np.testing.assert_array_equal(limited.prim, limited_unit.prim)
    np.testing.assert_array_equal(limited.t, limited_unit.t * scaled)
    blocked = wrt.occluded(scene, origins, tiny, t_min=t_min * scaled, t_max=t_max * scaled, accel="warp")
    np.testing.assert_array_equal(blocked, limited.hit)
    # Straight down onto one triangle along directions of 1e-39, 3e-40 and 2^-140 (subnormal): t = 1e-5 / length.
    lengths = np.array([1e-39, 3e-40, 2.0**-140], np.float32)
    down = np.zeros((3, 3), np.float32)
    down[:, 2] = -lengths
    above = np.array([[0.0, 0.0, 1e-5]], np.float32)
    triangle = one_triangle_scene(False)
    for accel in ("warp", "wrt"):
        hits = wrt.trace(triangle, above, down, accel=accel)
        np.testing.assert_allclose(hits.t, 1e-5 / lengths.astype(np.float64), rtol=1e-6, err_msg=accel)
        assert wrt.occluded(triangle, above, down, accel=accel).all()
