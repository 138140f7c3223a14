"""Pre-split references (wrt/bvh/presplit.py): same hits, fewer triangle tests near fans, boxes that cover."""

import numpy as np
import pytest
import warp as wp
from test_instancing import closest_hits_numpy

import wrt
from wrt.bvh import build_bvh
from wrt.bvh.layout import LAYOUTS, convert_layout, layout_kernels
from wrt.bvh.presplit import MAX_REFERENCES_PER_TRIANGLE, presplit_references
from wrt.procedural import displaced_sphere
from wrt.trace import HitBuffer, occluded_bvh_kernel, trace_bvh_kernel


def pole_rays(n: int, seed: int = 0):
    """Rays from above aimed at points within a few ring widths of the sphere's north pole, where a fan of slivers
    meets, plus rays aimed anywhere at the sphere."""
    rng = np.random.default_rng(seed)
    targets = np.concatenate([
        np.column_stack([rng.normal(0, 0.02, n), np.ones(n), rng.normal(0, 0.02, n)]),
        rng.normal(size=(n, 3)) * 0.7,
    ])
    origins = targets + rng.normal(size=(2 * n, 3)) * 0.3 + np.array([0.0, 3.0, 0.0])
    return origins.astype(np.float32), (targets - origins).astype(np.float32)


def closest_hits(bvh, points, indices, layout, origins, directions):
    tree = convert_layout(bvh, layout).to_device(points, indices, "cpu")
    kernel = trace_bvh_kernel if layout == "binary" else layout_kernels(layout)[0]
    n = len(origins)
    rays = [wp.array(origins, dtype=wp.vec3, device="cpu"), wp.array(directions, dtype=wp.vec3, device="cpu"),
            wp.zeros(n, dtype=float, device="cpu"), wp.full(n, np.inf, dtype=float, device="cpu")]
    hits = HitBuffer(n, "cpu")
    wp.launch(kernel, n, inputs=[tree, *rays], outputs=hits.outputs, device="cpu")
    blocked = wp.zeros(n, dtype=wp.int32, device="cpu")
    occluded = occluded_bvh_kernel if layout == "binary" else layout_kernels(layout)[1]
    wp.launch(occluded, n, inputs=[tree, *rays], outputs=[blocked], device="cpu")
    return [a.numpy() for a in (hits.t, hits.u, hits.v, hits.prim)], hits.cost.numpy(), blocked.numpy()


@pytest.fixture(scope="module")
def uv_sphere():
    return displaced_sphere(80_000)


def test_presplit_trees_give_the_same_hits_with_fewer_tests_at_a_fan(uv_sphere):
    points, indices = uv_sphere
    plain = build_bvh(points, indices, "sah")
    split = build_bvh(points, indices, "sah", presplit=6)
    split.validate()
    assert len(indices) < split.num_prims <= MAX_REFERENCES_PER_TRIANGLE * len(indices)
    origins, directions = pole_rays(400)
    for layout in LAYOUTS:
        before, cost_before, blocked_before = closest_hits(plain, points, indices, layout, origins, directions)
        after, cost_after, blocked_after = closest_hits(split, points, indices, layout, origins, directions)
        assert (before[3] >= 0).mean() > 0.7
        for a, b in zip(before, after):
            assert np.array_equal(a.view(np.int32), b.view(np.int32)), layout
        assert np.array_equal(blocked_before, blocked_after), layout
        # The pole's fan of slivers: rays near the pole test far fewer triangles.
        near_pole = slice(0, len(origins) // 2)
        assert cost_after[near_pole, 1].sum() < 0.5 * cost_before[near_pole, 1].sum(), layout


def test_every_reference_box_covers_its_part_of_the_triangle():
    rng = np.random.default_rng(3)
    tris = []
    for scale in (1e-6, 1.0, 1e6):
        # Diagonal slivers in every orientation, offset far from the origin too.
        a = rng.normal(size=(200, 3))
        along = rng.normal(size=(200, 3))
        across = np.cross(along, rng.normal(size=(200, 3))) * 0.003
        offset = rng.normal(size=(200, 1, 1)) * 1e3
        tris.append(np.stack([a, a + along, a + along + across], 1) * scale + offset * scale)
    tris = np.concatenate(tris).astype(np.float32)
    points = wp.array(tris.reshape(-1, 3), dtype=wp.vec3)
    indices = wp.array(np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3), dtype=wp.int32)
    lowers, uppers, _, ref_prims = (a.numpy() for a in presplit_references(points, indices))
    assert len(ref_prims) > len(tris)
    assert np.array_equal(np.unique(ref_prims), np.arange(len(tris)))
    # Inside the triangle's own box, and together covering points all over the triangle (corners and edges too).
    assert np.all(lowers >= tris.min(1)[ref_prims]) and np.all(uppers <= tris.max(1)[ref_prims])
    w = np.concatenate([np.eye(3), [[0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]], rng.dirichlet(np.ones(3), 300)])
    for t in range(len(tris)):
        samples = (w @ tris[t].astype(np.float64)).astype(np.float32)
        mine = ref_prims == t
        inside = (samples[:, None] >= lowers[mine][None]) & (samples[:, None] <= uppers[mine][None])
        assert inside.all(-1).any(1).all(), f"triangle {t}: a point of it lies in none of its references"


def test_a_mesh_of_slivers_stays_within_the_reference_budget():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(3000, 3))
    tris = np.stack([a, a + np.array([1.0, 1.0, 1.0]), a + np.array([1.0, 1.0, 1.001])], 1).astype(np.float32)
    points, indices = tris.reshape(-1, 3), np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3)
    bvh = build_bvh(points, indices, "sah", presplit=6)
    bvh.validate()
    assert len(indices) < bvh.num_prims <= MAX_REFERENCES_PER_TRIANGLE * len(indices)


def test_triangles_of_no_area_stay_whole():
    points = np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2], [0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    indices = np.array([[0, 1, 2], [3, 4, 5]], np.int32)
    bvh = build_bvh(points, indices, "sah", presplit=6)
    bvh.validate()
    assert bvh.num_prims == 2


@pytest.mark.parametrize("bad", [-1, 7, 2.5, True])
def test_bad_presplit_is_refused_by_name(bad):
    with pytest.raises(ValueError, match="presplit"):
        build_bvh(np.eye(3, dtype=np.float32), np.array([[0, 1, 2]], np.int32), "sah", presplit=bad)


def test_epo_refuses_a_presplit_tree(uv_sphere):
    points, indices = uv_sphere
    bvh = build_bvh(points, indices, "sah", presplit=6)
    with pytest.raises(ValueError, match="one slot per triangle"):
        bvh.stats(epo_samples=1000)


def test_stats_of_a_presplit_tree_count_triangles_and_leave_out_epo():
    """``tree.stats()`` of a tree built with pre-splits raised the EPO error unless ``epo_samples=0`` was passed, and
    its ``triangles`` counted references (as ``wrt bvh-stats --presplit 6 --json`` reported them)."""
    points, indices = displaced_sphere(2000)
    bvh = build_bvh(points, indices, "sah", presplit=6)
    assert bvh.num_prims > len(indices)  # the poles' slivers were split
    stats = bvh.stats()
    assert stats["triangles"] == len(indices) and stats["slots"] == bvh.num_prims
    assert stats["epo"] is None and stats["epo_stderr"] is None
    assert sum(k * v for k, v in stats["leaf_size_histogram"].items()) == stats["slots"]
    with pytest.raises(ValueError, match="epo_samples=0"):
        bvh.stats(epo_samples=64)


def test_the_two_level_bvh_of_wrt_trace_presplits_a_large_blas_as_a_flat_scene_is():
    """``wrt.trace`` builds a scene's SAH tree with pre-splits, but a scene with an analytic shape or an instance
    goes to the two-level BVH, whose BLASes were built without them: the same mesh got another tree (the fan of a
    sphere's pole tested in full) once a gprim stood beside it. Oracle: ``build_bvh(..., presplit=6)`` of the mesh,
    the tree a scene of the mesh alone traces; the hits stay those of the flat scene."""
    from wrt.bvh.batched import BATCH_MAX_TRIANGLES
    from wrt.trace import ACCELERATOR_PRESPLIT, get_accelerator

    points, indices = displaced_sphere(2 * BATCH_MAX_TRIANGLES)
    mesh = wrt.Mesh("/ball", points, indices, np.zeros(len(indices), np.int32))
    cube = np.diag([0.1, 0.1, 0.1, 1.0])
    cube[0, 3] = 3.0  # beside the ball, out of the rays' way
    scene = wrt.Scene(meshes=[mesh], shapes=[wrt.Shape("/cube", "box", cube)])
    accel = get_accelerator(scene, "wrt", "sah", "cpu")
    assert type(accel).__name__ == "InstancedAccelerator"
    expected = build_bvh(points, indices, "sah", presplit=ACCELERATOR_PRESPLIT, device="cpu")  # (accel's device)
    assert expected.num_prims > len(indices)  # the poles' fans are split
    (blas,) = accel.blas
    for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids"):
        assert np.array_equal(getattr(blas, field), getattr(expected, field)), field
    origins, directions = pole_rays(300)
    flat = wrt.Scene(meshes=[mesh])
    a, b = wrt.trace(scene, origins, directions), wrt.trace(flat, origins, directions)
    sphere_rows = (a.prim >= 0) & (a.prim < len(indices))
    assert sphere_rows.mean() > 0.5 and np.array_equal(a.prim[sphere_rows], b.prim[sphere_rows])
    assert np.array_equal(a.t[sphere_rows], b.t[sphere_rows])


def long_slivers_across_the_origin(rng, n: int, scale: float) -> np.ndarray:
    """``(n, 3, 3)`` slivers ``2 scale`` long, each through the origin in a random direction, ``0.02 scale`` wide."""
    along = rng.normal(size=(n, 3))
    along /= np.linalg.norm(along, axis=1, keepdims=True)
    across = np.cross(along, rng.normal(size=(n, 3)))
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    return np.stack([-along, along, 0.02 * across], 1) * scale


def plane_crossings(tri: np.ndarray, axis: int, value: float) -> list:
    """Float64 points where the triangle's edges meet the plane ``x[axis] = value`` (its corners on the plane too)."""
    points = []
    for i in range(3):
        p, q = tri[i], tri[(i + 1) % 3]
        dp, dq = p[axis] - value, q[axis] - value
        if dp == 0:
            points.append(p)
        elif dq != 0 and (dp < 0) != (dq < 0):
            x = p + (q - p) * (dp / (dp - dq))
            x[axis] = value
            points.append(x)
    return points


@pytest.mark.parametrize("scale", [1.0, 1e4])
def test_reference_boxes_cover_long_triangles_that_cross_the_origin(scale):
    """The clipped bounds were widened by a few ulps of the half-box's own coordinates, but the clipped vertices are
    rounded at the scale of the whole triangle (its edges and corners): a piece near the origin of a triangle
    thousands of times its size got a box that left out a sliver of it (8e-5 of a 1e4 triangle, 11 ulps of the
    coordinate there), where rays hit nothing. Oracle: float64 points of the triangle on every plane of its
    references' boxes (where a clipped piece's bounds lie): each must lie in one of them."""
    rng = np.random.default_rng(16)
    slivers = long_slivers_across_the_origin(rng, 60, scale)
    filler = rng.uniform(-1, 1, (8000, 1, 3)) + rng.normal(scale=0.01, size=(8000, 3, 3))  # the references' budget
    tris = np.concatenate([slivers, filler]).astype(np.float32)
    points = wp.array(tris.reshape(-1, 3), dtype=wp.vec3)
    indices = wp.array(np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3), dtype=wp.int32)
    lowers, uppers, _, ref_prims = (a.numpy().astype(np.float64) for a in presplit_references(points, indices))
    split = 0
    for t in range(len(slivers)):
        mine = np.flatnonzero(ref_prims == t)
        split += len(mine) > 1
        tri = tris[t].astype(np.float64)
        on_planes = np.array([x for r in mine for axis in range(3) for value in (lowers[r, axis], uppers[r, axis])
                              for x in plane_crossings(tri, axis, value)])
        outside = np.maximum(lowers[mine][None] - on_planes[:, None], on_planes[:, None] - uppers[mine][None])
        gap = outside.max(-1).min(-1)  # how far each point lies outside the nearest of the references
        assert gap.max() <= 1e-12 * scale, f"triangle {t}: a point of it lies {gap.max():.3g} outside its references"
    assert split > 50


def test_rays_at_the_end_of_a_split_piece_hit_the_triangle():
    """The user's view of the gap above: axis-aligned rays (which hit at their own x and z exactly) at points of a
    1.5e4-long triangle just past where its edge crosses x = 0, the middle of its box, where it is cut. wrt.trace
    (``presplit=6``) missed half of the rays that a float64 test of the triangle says hit it."""
    tri = np.array([[7534.27, 5876.2324, 2950.367], [-7534.27, -5876.2324, -2950.367],
                    [126.2946, -154.3413, -15.114114]], np.float32)
    rng = np.random.default_rng(0)
    filler = rng.uniform(-1, 1, (300, 1, 3)) + rng.normal(scale=0.01, size=(300, 3, 3)) + [0.0, 0.0, 1e4]
    points = np.concatenate([tri[None], filler]).reshape(-1, 3).astype(np.float32)
    indices = np.arange(len(points), dtype=np.int32).reshape(-1, 3)
    b, c = tri[1].astype(np.float64), tri[2].astype(np.float64)
    crossing = b + (c - b) * (-b[0] / (c[0] - b[0]))  # where edge b-c meets x = 0
    x, z = np.meshgrid(np.linspace(2e-5, 2e-4, 8), crossing[2] + np.linspace(-2e-5, 1.2e-4, 30))
    origins = np.column_stack([x.ravel(), np.full(x.size, -1000.0), z.ravel()]).astype(np.float32)
    directions = np.tile(np.float32([0, 1, 0]), (len(origins), 1))
    t_ref, row_ref = closest_hits_numpy(points, indices, origins.astype(np.float64), directions.astype(np.float64),
                                        np.zeros(len(origins)), np.full(len(origins), np.inf))
    assert (row_ref == 0).sum() > 100
    hits = wrt.trace(wrt.Scene.from_triangles(points, indices), origins, directions)
    assert np.array_equal(hits.prim, row_ref), f"{np.count_nonzero(hits.prim != row_ref)} rays missed the triangle"
    np.testing.assert_allclose(hits.t[row_ref == 0], t_ref[row_ref == 0], rtol=1e-6)


def test_rays_along_a_sliver_far_from_the_origin_hit_it():
    """A sliver 0.3 long and 3e-4 wide at z = 36660, where float32 steps are 0.004 (the sliver spans 26 of them in
    z), cut into 32 pieces: rays along its normal at points down its middle hit it wherever a float64 test of the
    triangle says so. Clipped in float32, the pieces' vertices were rounded at z's scale, which moved the crossing of
    the next cut along the sliver by that error over its slope (0.006 in x, past the pad of x's scale): one piece
    left out a stretch of the sliver, and 32 of the 770 rays there missed it."""
    tri = np.array([[9664.15234375, -14.167632102966309, 36659.60546875],
                    [9664.453125, -14.01892375946045, 36659.50390625],
                    [9664.15234375, -14.167304039001465, 36659.60546875]], np.float32)
    rng = np.random.default_rng(0)
    filler = rng.uniform(-1, 1, (300, 1, 3)) + rng.normal(scale=0.01, size=(300, 3, 3)) + [9664.0, 0.0, 36000.0]
    points = np.concatenate([tri[None], filler]).reshape(-1, 3).astype(np.float32)
    indices = np.arange(len(points), dtype=np.int32).reshape(-1, 3)
    corners = tri.astype(np.float64)
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    normal /= np.linalg.norm(normal)
    s = np.linspace(0.0, 1.0, 2001)[:, None]
    targets = np.hstack([1 - s, 0.5 * s, 0.5 * s]) @ corners  # down the middle, from a (and c) to b
    origins = (targets + 5.0 * normal).astype(np.float32)
    directions = np.tile((-normal).astype(np.float32), (len(origins), 1))
    t_ref, row_ref = closest_hits_numpy(points, indices, origins.astype(np.float64), directions.astype(np.float64),
                                        np.zeros(len(origins)), np.full(len(origins), np.inf))
    assert (row_ref == 0).sum() > 500
    hits = wrt.trace(wrt.Scene.from_triangles(points, indices), origins, directions)
    assert np.array_equal(hits.prim, row_ref), f"{np.count_nonzero(hits.prim != row_ref)} rays missed the sliver"


def clipped_box(tri: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple:
    """Float64 Sutherland-Hodgman: the bounds of the triangle's part inside the box ``[lo, hi]``."""
    poly = list(tri)
    for axis in range(3):
        for bound, sign in ((lo[axis], 1.0), (hi[axis], -1.0)):
            out = []
            for i, p in enumerate(poly):
                q = poly[(i + 1) % len(poly)]
                dp, dq = sign * (p[axis] - bound), sign * (q[axis] - bound)
                if dp >= 0:
                    out.append(p)
                if (dp >= 0) != (dq >= 0):
                    out.append(p + (q - p) * (dp / (dp - dq)))
            poly = out
    return np.min(poly, axis=0), np.max(poly, axis=0)


def test_reference_boxes_of_slivers_far_from_the_origin_stay_tight():
    """The pad against rounding follows the triangle's corners (their magnitude) and its extent in separate measures:
    a 1-long sliver at 1000 is cut into pieces 1/16 long or less, and a pad of 2.4e-6 of the corners' magnitude
    (2.4e-3) would have grown the boxes of the shortest pieces by 5% of their size. Oracle: the float64 bounds of the
    triangle clipped to each reference box; every box exceeds them by at most 3% of the piece's size."""
    rng = np.random.default_rng(4)
    slivers = long_slivers_across_the_origin(rng, 20, 0.5) + np.array([1e3, -7e2, 3e2])
    filler = rng.uniform(-1, 1, (2000, 1, 3)) + rng.normal(scale=0.01, size=(2000, 3, 3))
    tris = np.concatenate([slivers, filler]).astype(np.float32)
    points = wp.array(tris.reshape(-1, 3), dtype=wp.vec3)
    indices = wp.array(np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3), dtype=wp.int32)
    lowers, uppers, _, ref_prims = (a.numpy().astype(np.float64) for a in presplit_references(points, indices))
    pieces = 0
    for r in np.flatnonzero(ref_prims < len(slivers)):
        lo, hi = clipped_box(tris[int(ref_prims[r])].astype(np.float64), lowers[r], uppers[r])
        size = (hi - lo).max()
        excess = max((lo - lowers[r]).max(), (uppers[r] - hi).max())
        assert excess <= 0.03 * size, f"reference {r}: its box exceeds its piece by {excess / size:.1%} of the piece"
        pieces += 1
    assert pieces > 10 * len(slivers)


def test_a_refitted_presplit_tree_keeps_its_pieces():
    """A refit gave every leaf of a pre-split tree its triangles' whole boxes: each of a pole sliver's references then
    held the whole sliver, and rays near the poles tested 117 triangles each after a refit to the same vertices,
    against 11 before it and 28 in a tree built without pre-splits (the refit-or-rebuild rule, on the SAH cost, saw
    1%). Oracles: a refit to the vertices of the build gives the build's boxes, bit for bit; after a refit to moved
    vertices, the hits are the brute-force ones and the pole rays test about as many triangles as in a tree built anew
    with pre-splits over the moved vertices."""
    from test_trace import brute_force

    from wrt.bvh.refit import Refitter

    points, indices = displaced_sphere(20_000)
    tree = build_bvh(points, indices, "sah", presplit=6)
    built = (tree.lowers.copy(), tree.uppers.copy())
    assert tree.num_prims > len(indices)
    refitter = Refitter(tree, tree.to_device(points, indices, "cpu"), "cpu")
    refitter.refit(points, indices)
    assert np.array_equal(tree.lowers, built[0]) and np.array_equal(tree.uppers, built[1])

    rng = np.random.default_rng(5)
    moved = (points * np.float32([1.3, 0.8, 1.1]) + rng.normal(scale=2e-3, size=points.shape)).astype(np.float32)
    refitter.refit(moved, indices)
    tree.validate()
    origins, directions = pole_rays(500)
    origins = origins * np.float32([1.3, 0.8, 1.1])
    (t, _, _, prim), cost, blocked = closest_hits(tree, moved, indices, "binary", origins, directions)
    t_ref, prim_ref = brute_force(moved, indices, origins, directions)
    assert np.array_equal(prim, prim_ref) and np.array_equal(t, t_ref)
    assert np.array_equal(blocked.astype(bool), prim_ref >= 0)
    fresh = build_bvh(moved, indices, "sah", presplit=6)
    _, fresh_cost, _ = closest_hits(fresh, moved, indices, "binary", origins, directions)
    near_pole = slice(0, len(origins) // 2)
    assert cost[near_pole, 1].mean() < 1.5 * fresh_cost[near_pole, 1].mean()


@pytest.mark.parametrize("exponent", [-110, -70, 70, 120])
def test_slivers_scaled_by_a_power_of_two_are_split_as_unscaled(exponent):
    """Slivers scaled by ``2^exponent`` (exactly: a power of two) are cut into as many references as unscaled, the
    ratio of box to triangle area that decides it being scale-free. ``split_levels`` squared lengths in float32: past
    about 1e19 the box area was inf, below about 1e-19 the triangle's area 0, and no triangle was cut, so a mesh
    1e20 across, or an instance scaled past 2^100 (traced in its prototype's BLAS scaled by 2^k, tlas.py), lost its
    pre-splits."""
    from wrt.bvh.presplit import split_plan

    rng = np.random.default_rng(4)
    a = rng.normal(size=(300, 3))
    along = rng.normal(size=(300, 3))
    across = np.cross(along, rng.normal(size=(300, 3))) * rng.uniform(1e-3, 0.3, (300, 1))
    tris = np.stack([a, a + along, a + along + across], 1).astype(np.float32)
    indices = wp.array(np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3), dtype=wp.int32)
    levels = []
    for e in (0, exponent):
        points = np.ldexp(tris.reshape(-1, 3), e).astype(np.float32)
        assert np.array_equal(np.ldexp(points, -e), tris.reshape(-1, 3))  # exact: no over- or underflow
        levels.append(split_plan(wp.array(points, dtype=wp.vec3), indices)[0].numpy())
    assert (levels[0] > 0).sum() > 50  # many are cut
    np.testing.assert_array_equal(levels[1], levels[0])


def test_slivers_past_half_of_float32s_range_are_cut_as_at_unit_size():
    # Past 2**127 (1.7e38) the halving plane 0.5 * (lower + upper) overflowed to inf: each cut's upper half was an
    # empty box at inf and its lower half the whole triangle, so the references were no tighter than the triangle
    # (a 30-triangle soup with one sliver, presplit=4: sah SAH cost 30.3 against 22.0). Oracle: the reference boxes
    # at unit size scaled by 2**128 (exact).
    from wrt.bvh.presplit import split_plan, write_references

    rng = np.random.default_rng(4)
    unit = rng.uniform(0.5, 0.99, (30, 3)).astype(np.float32)
    unit[:3] = [(0.5, 0.5, 0.5), (0.99, 0.99, 0.99), (0.99, 0.97, 0.99)]  # a long diagonal sliver
    indices = wp.array(np.arange(30, dtype=np.int32).reshape(-1, 3), dtype=wp.int32, device="cpu")
    boxes = []
    for e in (0, 128):
        points = wp.array(np.ldexp(unit.astype(np.float64), e).astype(np.float32), dtype=wp.vec3, device="cpu")
        lowers, uppers, _, _ = write_references(points, indices, *split_plan(points, indices, 4))
        boxes.append([np.ldexp(b.numpy().astype(np.float64), -e) for b in (lowers, uppers)])
    assert len(boxes[0][0]) > 12  # the sliver is cut
    np.testing.assert_array_equal(boxes[1][0], boxes[0][0])
    np.testing.assert_array_equal(boxes[1][1], boxes[0][1])
