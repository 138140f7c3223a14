"""Every builder x every layout against wp.Mesh, ray by ray, on the test scenes; layouts agree bit for bit; the
converted layouts keep their invariants."""

import functools

import numpy as np
import pytest
import warp as wp
from conftest import WARP_USD_ASSETS, manifest, warp_assets
from test_trace import MAX_TIE_FRACTION, SHARED_SCENES, agreement_rays

import wrt
from wrt.bvh import Builder, build_bvh
from wrt.bvh.compact import convert_compact
from wrt.bvh.layout import LAYOUTS, convert_layout
from wrt.bvh.stats import half_areas
from wrt.bvh.wide import convert_wide
from wrt.compare import compare_hits
from wrt.rays import random_rays

BUILDERS = [b.value for b in Builder]


@functools.lru_cache(maxsize=None)
def scene_and_reference(source: str, name: str):
    """The scene, the 1e5 agreement rays of tests/test_trace.py (5e4 camera, 5e4 random) and wp.Mesh's hits for
    them, loaded once per scene."""
    import warnings

    from conftest import assets_dir

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        path = warp_assets(name) if source == "warp" else assets_dir() / manifest()[name]["path"]
        scene = wrt.load_usd(path, tessellate_gprims=True)  # wp.Mesh and the layouts trace triangles only
    origins, directions = agreement_rays(scene)
    return scene, origins, directions, wrt.trace(scene, origins, directions, accel="warp")


def scene_ids():
    ids = [("warp", name) for name in WARP_USD_ASSETS]
    entries = manifest()
    ids += [("shared", name) for name in SHARED_SCENES if name in entries]
    return ids


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("source,name", scene_ids(), ids=[n for _, n in scene_ids()])
def test_every_layout_agrees_with_wp_mesh(source, name, builder):
    scene, origins, directions, theirs = scene_and_reference(source, name)
    points = scene.triangles()[0]
    scale = float(np.abs(points).max()) if len(points) else 0.0
    first = None
    for layout in LAYOUTS:
        ours = wrt.trace(scene, origins, directions, builder=builder, layout=layout)
        report = compare_hits(ours, theirs, directions=directions, scale=scale)
        assert report["disagreements"] == 0, (layout, report)
        assert report["tie_disagreements"] <= MAX_TIE_FRACTION * report["rays"], (layout, report)
        if first is None:
            first = ours
        else:
            # Same triangle test and tie rule: identical answers, bit for bit, in every layout.
            for field in ("t", "u", "v", "prim"):
                np.testing.assert_array_equal(getattr(ours, field), getattr(first, field), err_msg=f"{layout} {field}")
    assert first.hit.any() or len(points) == 0


@pytest.mark.parametrize("layout", LAYOUTS)
def test_occluded_matches_closest_hit_in_every_layout(layout, np_rng):
    n = 400
    centers = np_rng.uniform(-1, 1, (n, 1, 3))
    points = (centers + np_rng.normal(scale=0.15, size=(n, 3, 3))).reshape(-1, 3).astype(np.float32)
    indices = np.arange(3 * n, dtype=np.int32).reshape(-1, 3)
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 4000, seed=5)
    hits = wrt.trace(scene, origins, directions, layout=layout)
    t_max = np.where(np_rng.random(len(origins)) < 0.5, np.inf, 0.5).astype(np.float32)
    blocked = wrt.occluded(scene, origins, directions, t_max=t_max, layout=layout)
    np.testing.assert_array_equal(blocked, hits.t < t_max)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_uncounted_kernels_give_the_same_hits_and_leave_costs_alone(layout, np_rng):
    """``costs=False`` runs the kernels that count nothing: same hits bit for bit (the barycentrics are recomputed
    from the winning slot in both), and the cost buffer keeps what it held."""
    from wrt.trace import HitBuffer, get_accelerator

    n = 300
    centers = np_rng.uniform(-1, 1, (n, 1, 3))
    points = (centers + np_rng.normal(scale=0.2, size=(n, 3, 3))).reshape(-1, 3).astype(np.float32)
    scene = wrt.Scene.from_triangles(points, np.arange(3 * n, dtype=np.int32).reshape(-1, 3))
    origins, directions = random_rays(scene, 3000, seed=3)
    accel = get_accelerator(scene, layout=layout, device="cpu")
    rays = [wp.array(origins, dtype=wp.vec3), wp.array(directions, dtype=wp.vec3), wp.zeros(len(origins), dtype=float),
            wp.full(len(origins), np.inf, dtype=float)]
    counted, uncounted = HitBuffer(len(origins), "cpu"), HitBuffer(len(origins), "cpu")
    uncounted.cost.fill_(wp.vec2i(-7, -7))
    accel.intersect(*rays, counted)
    accel.intersect(*rays, uncounted, costs=False)
    for a, b in zip(counted.outputs[:4], uncounted.outputs[:4]):
        np.testing.assert_array_equal(a.numpy().view(np.int32), b.numpy().view(np.int32))
    assert (counted.prim.numpy() >= 0).mean() > 0.2  # the rays hit something
    assert (counted.cost.numpy()[:, 0] > 0).all()
    assert (uncounted.cost.numpy() == -7).all()


def degenerate_scenes():
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    cases = {
        "single": (tri, [[0, 1, 2]]),
        "identical": (np.tile(tri, (500, 1)), np.arange(1500).reshape(-1, 3)),
        "zero_area": (
            np.tile(np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2]], np.float32), (200, 1)),
            np.arange(600).reshape(-1, 3),
        ),
        "huge": (tri * np.float32(1e30), [[0, 1, 2]]),
        "tiny": (tri * np.float32(1e-30), [[0, 1, 2]]),
    }
    line = np.linspace(0, 1, 900, dtype=np.float32)
    cases["collinear"] = (np.stack([line, 2 * line, 3 * line], 1), np.arange(900).reshape(-1, 3))
    return cases


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("case", list(degenerate_scenes()))
def test_degenerate_input_in_every_layout(layout, case):
    points, indices = degenerate_scenes()[case]
    points = np.asarray(points, np.float32)
    indices = np.asarray(indices, np.int32)
    scene = wrt.Scene.from_triangles(points, indices)
    # Axis-aligned rays down onto the triangle centres, and oblique rays at them.
    centers = points[indices].mean(axis=1)
    extent = float(np.abs(points).max()) + 1e-35
    down = np.array([0, 0, -1], np.float32)
    origins = np.concatenate(
        [centers + np.float32(extent) * -down, centers + np.float32(extent) * np.float32([0.3, 0.2, 1])]
    )
    directions = np.concatenate([np.tile(down, (len(centers), 1)), centers - origins[len(centers) :]]).astype(
        np.float32
    )
    ours = wrt.trace(scene, origins, directions, layout=layout, builder="lbvh" if case == "identical" else "sah")
    theirs = wrt.trace(scene, origins, directions, accel="warp")
    if case in ("huge", "tiny"):
        # One triangle, every ray aimed at its centre: a hit at the distance from the origin (down rays: the
        # extent; oblique rays: t = 1). wp.Mesh's float32 test loses these hits, so there is nothing to agree with.
        expected = np.concatenate([np.full(len(centers), extent), np.ones(len(centers))])
        assert ours.hit.all()
        np.testing.assert_allclose(ours.t, expected, rtol=1e-5)
    else:
        np.testing.assert_array_equal(ours.hit, theirs.hit)
    both = ours.hit & theirs.hit
    np.testing.assert_allclose(ours.t[both], theirs.t[both], rtol=1e-5)


def leaf_slots(refs, counts):
    """Every slot referenced by the leaf children, with multiplicity."""
    leaf = counts > 0
    return np.concatenate([np.arange(r, r + c) for r, c in zip(refs[leaf], counts[leaf])])


@pytest.mark.parametrize("builder", ["sah", "ploc"])
def test_conversions_keep_every_triangle_once_and_boxes_inside(builder, np_rng):
    n = 3000
    centers = np_rng.uniform(-1, 1, (n, 1, 3))
    points = (centers + np_rng.normal(scale=0.05, size=(n, 3, 3))).reshape(-1, 3).astype(np.float32)
    indices = np.arange(3 * n, dtype=np.int32).reshape(-1, 3)
    bvh = build_bvh(points, indices, builder, leaf_size=4, device="cpu")
    bvh.validate()
    inner = int((bvh.prim_count == 0).sum())
    # Compact: one node per inner node, every slot in exactly one leaf child, child refs in range.
    c = convert_compact(bvh)
    assert c.num_nodes == inner and c.bytes == 64 * inner + 4 * n
    refs = c.children[:, :2].reshape(-1)
    counts = c.children[:, 2:].reshape(-1)
    np.testing.assert_array_equal(np.sort(leaf_slots(refs, counts)), np.arange(n))
    assert np.all(refs[counts == 0] < c.num_nodes) and np.all(refs[counts == 0] > 0)
    # Wide: every slot once, child boxes inside the parent's box, every node reached once, fill > 1/2.
    for width in (4, 8):
        w = convert_wide(bvh, width)
        assert w.num_nodes < inner and w.depth <= bvh.depths().max()
        np.testing.assert_array_equal(np.sort(leaf_slots(w.refs, w.counts)), np.arange(n))
        inner_children = np.flatnonzero(w.counts == 0)
        targets = w.refs[inner_children]
        np.testing.assert_array_equal(np.sort(targets), np.arange(1, w.num_nodes))
        for j in range(width):
            kids = targets * width + j
            ok = w.counts[kids] >= 0
            assert np.all(w.lowers[kids[ok]] >= w.lowers[inner_children[ok]])
            assert np.all(w.uppers[kids[ok]] <= w.uppers[inner_children[ok]])
        assert w.fill() > 0.5


def least_wide_cost(bvh, width):
    """By exhaustive search: every choice of which binary inner nodes below the root are opened into their parent's
    wide node; the least summed half area of the wide nodes (the root and the inner nodes not opened) among the
    choices that give no wide node more than ``width`` children."""
    areas = half_areas(bvh.lowers, bvh.uppers)
    below_root = [int(i) for i in np.flatnonzero(bvh.prim_count == 0) if i != 0]
    best = np.inf
    for mask in range(1 << len(below_root)):
        opened = {c for k, c in enumerate(below_root) if mask >> k & 1}
        wide_nodes = [0] + [c for c in below_root if c not in opened]
        fits = True
        for node in wide_nodes:
            pending, children = [bvh.left_first[node], bvh.left_first[node] + 1], 0
            while pending:
                c = pending.pop()
                if c in opened:
                    pending += [bvh.left_first[c], bvh.left_first[c] + 1]
                else:
                    children += 1
            fits = fits and children <= width
        if fits:
            best = min(best, sum(areas[node] for node in wide_nodes))
    return best


@pytest.mark.parametrize("width", [4, 8])
@pytest.mark.parametrize("builder", ["sah", "lbvh"])
def test_wide_collapse_has_the_least_sah_cost(builder, width, np_rng):
    """The collapse's wide nodes have the least summed surface area that any collapse of the binary tree can have
    (exhaustive search over trees of 13 leaves). Also with identical triangles (equal areas: ties)."""
    for trial in range(4):
        n = 13
        points = (np_rng.uniform(-1, 1, (n, 1, 3)) + np_rng.normal(scale=0.2, size=(n, 3, 3))).reshape(-1, 3)
        if trial == 3:
            points[3:15] = points[:3].reshape(1, 3, 3).repeat(4, axis=0).reshape(-1, 3)
        indices = np.arange(3 * n, dtype=np.int32).reshape(-1, 3)
        bvh = build_bvh(points.astype(np.float32), indices, builder, leaf_size=1, device="cpu")
        w = convert_wide(bvh, width)
        inner_boxes = w.counts == 0
        got = half_areas(bvh.lowers[:1], bvh.uppers[:1])[0]
        got += half_areas(w.lowers[inner_boxes], w.uppers[inner_boxes]).sum()
        want = least_wide_cost(bvh, width)
        assert np.isclose(got, want, rtol=1e-12), (trial, got, want)
        assert np.count_nonzero(bvh.prim_count == 0) >= 10  # a search over enough choices to matter


def test_single_leaf_and_empty_trees_convert():
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    bvh = build_bvh(tri, [[0, 1, 2]], device="cpu")
    assert bvh.num_nodes == 1
    for layout in LAYOUTS:
        assert convert_layout(bvh, layout).num_nodes == 1
    empty = build_bvh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), device="cpu")
    for layout in LAYOUTS[1:]:
        assert convert_layout(empty, layout).num_nodes == 0
    scene = wrt.Scene()
    for layout in LAYOUTS:
        hits = wrt.trace(scene, np.zeros((2, 3)), np.ones((2, 3)), layout=layout)
        assert hits.prim.tolist() == [-1, -1]


def test_unknown_layout_raises():
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="valid layouts: binary, compact, wide, wide8"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), layout="bvh16")
    with pytest.raises(ValueError, match="accel='wrt' only"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), accel="warp", layout="wide")
