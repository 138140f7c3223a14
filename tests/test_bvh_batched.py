"""Small trees built together on the CPU (``wrt.bvh.batched``): each is, bit for bit, the tree ``build_bvh`` builds
over its mesh alone, and a scene of many prototypes no longer costs a dozen launches per prototype."""

import numpy as np
import pytest
import warp as wp

import wrt
import wrt.tlas
from wrt.bvh.build import build_bvh, build_bvhs
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh

FIELDS = ("lowers", "uppers", "left_first", "prim_count", "prim_ids")


def random_meshes(rng, count: int) -> list:
    """Small meshes of every awkward kind: 1 to 3 triangles, degenerate triangles (a repeated index), duplicate
    points, coplanar and coincident vertices, coordinates on a coarse grid (ties in every bin), and up to 300
    triangles."""
    meshes = []
    for j in range(count):
        n = int(rng.integers(1, 4)) if j % 4 == 0 else int(rng.integers(1, 300))
        v = int(rng.integers(1, max(2, n)))
        points = rng.normal(size=(v, 3)).astype(np.float32) * rng.choice([1e-3, 1.0, 1e3])
        if j % 3 == 0:
            points = np.round(points, 0).astype(np.float32)  # many equal centroids and boxes
        if j % 5 == 0:
            points[:, 2] = 0.0  # flat
        if j % 7 == 0 and v > 1:
            points[v // 2 :] = points[: v - v // 2]  # duplicate points
        indices = rng.integers(0, v, size=(n, 3)).astype(np.int32)
        degenerate = rng.random(n) < 0.2
        indices[degenerate, 1] = indices[degenerate, 0]  # a repeated vertex
        indices[::5, 2] = indices[::5, 0]
        meshes.append((points, indices))
    return meshes


def assert_same_trees(alone, together):
    assert len(alone) == len(together)
    for j, (a, b) in enumerate(zip(alone, together)):
        for field in FIELDS:
            x, y = np.asarray(getattr(a, field)), np.asarray(getattr(b, field))
            assert x.dtype == y.dtype and x.shape == y.shape, (j, field)
            assert np.array_equal(x.view(np.uint8), y.view(np.uint8)), (j, field)  # bits: -0.0 and 0.0 differ


@pytest.mark.parametrize("builder, options", [("sah", {}), ("middle", {}), ("sah", {"leaf_size": 1, "bins": 4}),
                                               ("sah", {"leaf_size": 3, "traversal_cost": 0.0, "threads": 1})])
def test_trees_built_together_are_the_trees_built_alone(builder, options):
    """Random small meshes, built one by one by the kernel builder and together: every array of every flattened
    tree is bit for bit the same."""
    meshes = random_meshes(np.random.default_rng(len(options) + len(builder)), 60)
    alone = [build_bvh(p, i, builder, device="cpu", **options) for p, i in meshes]
    together = build_bvhs(meshes, builder, device="cpu", **options)
    assert_same_trees(alone, together)
    assert [t.points is p and t.indices is i for t, (p, i) in zip(together, meshes)] == [True] * len(meshes)


def test_meshes_that_cannot_join_a_batch_are_built_alone_with_build_bvhs_errors():
    """An empty mesh and a mesh above the batch's size are built alone (the same trees); a bad index or a NaN vertex
    raises build_bvh's error for that mesh."""
    rng = np.random.default_rng(3)
    big = (rng.normal(size=(6000, 3)).astype(np.float32), rng.integers(0, 6000, (5000, 3)).astype(np.int32))
    empty = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32))
    meshes = random_meshes(rng, 5) + [big, empty] + random_meshes(rng, 5)
    assert_same_trees([build_bvh(p, i, "sah", device="cpu") for p, i in meshes], build_bvhs(meshes, device="cpu"))
    tri = np.eye(3, dtype=np.float32)
    with pytest.raises(ValueError, match=r"indices must lie in \[0, 3\)"):
        build_bvhs([(tri, np.array([[0, 1, 2]])), (tri, np.array([[0, 1, 3]])), (tri, np.array([[0, 1, 2]]))],
                   device="cpu")
    nan = tri.copy()
    nan[1, 0] = np.nan
    with pytest.raises(ValueError, match="must be finite"):
        build_bvhs([(tri, np.array([[0, 1, 2]], np.int32)), (nan, np.array([[0, 1, 2]], np.int32))], device="cpu")


def prototype_scene(count: int, rng) -> wrt.Scene:
    """``count`` distinct small prototypes, each under two instances."""
    protos = []
    for p, (points, indices) in enumerate(random_meshes(rng, count)):
        protos.append(Prototype(f"/P{p}", [Mesh(f"/P{p}/m", points, indices, np.arange(len(indices)))]))
    to_world = np.stack([np.eye(4)] * (2 * count))
    to_world[:, :3, 3] = rng.uniform(-50, 50, (2 * count, 3))
    return wrt.Scene(prototypes=protos, instances=Instances.from_transforms(np.arange(2 * count) // 2, to_world))


def test_many_prototypes_cost_no_launches_per_prototype(monkeypatch):
    """The two-level BVH of 20 and of 40 small prototypes makes as many build launches (every BLAS built in one
    pass; it made a dozen per prototype), and its trees are those built one by one."""
    launches = []
    real_launch = wp.launch
    monkeypatch.setattr(wp, "launch", lambda kernel, *a, **k: (launches.append(kernel.key), real_launch(kernel, *a,
                                                                                                        **k))[1])
    counts = []
    for count in (20, 40):
        scene = prototype_scene(count, np.random.default_rng(count))
        launches.clear()
        acc = wrt.tlas.InstancedAccelerator(scene, "sah", "cpu", threads=1)  # (more threads split launches by size)
        counts.append(len(launches))
        alone = [build_bvh(t.points, t.indices, "sah", device="cpu") for t in acc.blas]
        assert_same_trees(alone, acc.blas)
    assert counts[0] == counts[1], counts


def test_uploads_of_many_trees_hold_what_each_tree_uploads_alone():
    """``upload_many``'s views (one upload per field for every BLAS) hold, array by array, what ``to_device`` uploads
    for each tree alone."""
    from wrt.bvh.layout import upload_many

    meshes = random_meshes(np.random.default_rng(5), 30)
    trees = build_bvhs(meshes, device="cpu")
    for tree, (points, indices), many in zip(trees, meshes, upload_many(trees, meshes, "cpu")):
        alone = tree.to_device(points, indices, "cpu")
        for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids", "v0", "v1", "v2"):
            x, y = getattr(alone, field).numpy(), getattr(many, field).numpy()
            assert x.dtype == y.dtype and np.array_equal(x.view(np.uint8), y.view(np.uint8)), field
        assert alone.num_prims == many.num_prims


def test_build_seconds_of_batched_trees_add_up_to_the_whole_build(monkeypatch):
    """On a clock that moves one second at each batchable check and each tree made, the batched trees'
    ``build_seconds`` add up to every second ``build_bvhs`` took: the scan and the slicing into trees (most of a
    batch of thousands of tiny trees) were left out."""
    import time

    import wrt.bvh.batched as batched

    clock = [0.0]
    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])

    def ticking(real):
        def call(*args, **kwargs):
            clock[0] += 1.0
            return real(*args, **kwargs)
        return call

    monkeypatch.setattr(batched, "batchable", ticking(batched.batchable))
    monkeypatch.setattr(batched, "FlatBvh", ticking(batched.FlatBvh))
    meshes = random_meshes(np.random.default_rng(11), 12)
    start = time.perf_counter()
    trees = build_bvhs(meshes, device="cpu", threads=1)
    wall = time.perf_counter() - start
    assert wall >= len(meshes) and sum(t.build_seconds for t in trees) == pytest.approx(wall)


def test_many_small_meshes_build_in_passes_of_bounded_memory():
    """3,000 meshes of 100 triangles: one pass over all of them held every tree's node and slot scratch at once
    (numpy's share alone 4x the trees it made); built in passes, the peak above the result stays near a pass's, and
    the trees are those built alone."""
    import tracemalloc

    rng = np.random.default_rng(12)
    meshes = [(rng.normal(size=(60, 3)).astype(np.float32), rng.integers(0, 60, (100, 3)).astype(np.int32))
              for _ in range(3000)]
    tracemalloc.start()
    try:
        trees = build_bvhs(meshes, device="cpu")
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    result = sum(getattr(t, f).nbytes for t in trees for f in FIELDS)
    assert peak - kept < result, (peak, kept, result)
    picks = [0, 1234, 2999]
    assert_same_trees([build_bvh(*meshes[j], device="cpu") for j in picks], [trees[j] for j in picks])


def test_upload_of_many_trees_holds_little_more_than_one_copy_of_the_slot_vertices():
    """``upload_many`` held every tree's (T, 3, 3) slot corners and their three concatenations at once (72 bytes a
    triangle); one column at a time from the meshes' points, its transient host peak stays under 48 bytes a triangle
    plus the points, and the uploads hold what each tree uploads alone."""
    import tracemalloc

    from wrt.bvh.layout import upload_many

    rng = np.random.default_rng(13)
    meshes = [(rng.normal(size=(60, 3)).astype(np.float32), rng.integers(0, 60, (100, 3)).astype(np.int32))
              for _ in range(2000)]
    trees = build_bvhs(meshes, device="cpu")
    tracemalloc.start()
    try:
        uploads = upload_many(trees, meshes, "cpu")
        kept, peak = tracemalloc.get_traced_memory()  # kept: the views' Python objects, as each upload alone makes
    finally:
        tracemalloc.stop()
    triangles, vertices = sum(len(i) for _, i in meshes), sum(len(p) for p, _ in meshes)
    assert peak - kept < 48 * triangles + 12 * vertices, (peak, kept, triangles)
    for j in (0, 999, 1999):
        alone = trees[j].to_device(*meshes[j], "cpu")
        for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids", "v0", "v1", "v2"):
            assert np.array_equal(getattr(alone, field).numpy(), getattr(uploads[j], field).numpy()), field


def test_one_batchable_mesh_among_others_is_built_alone():
    """One small mesh beside an empty one and one above the batch's size: nothing to batch, each built alone (the
    time sharing read the lone mesh's tree before anything had built it)."""
    rng = np.random.default_rng(14)
    big = (rng.normal(size=(6000, 3)).astype(np.float32), rng.integers(0, 6000, (5000, 3)).astype(np.int32))
    empty = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32))
    for meshes in ([random_meshes(rng, 1)[0], big, empty], random_meshes(rng, 1), []):
        assert_same_trees([build_bvh(p, i, device="cpu") for p, i in meshes], build_bvhs(meshes, device="cpu"))


@pytest.mark.parametrize("name", ["traversal_cost", "intersection_cost"])
@pytest.mark.parametrize("value", ["2.0", True, None, [1.0]])
def test_batched_and_single_builds_refuse_a_cost_that_is_no_number_alike(name, value):
    """``traversal_cost="2.0"`` was taken by the batched CPU build (float("2.0")) and refused by build_bvh in
    Python's words ('<=' not supported between 'float' and 'str'); True was taken by both as 1. Now one ValueError
    naming the option, from both paths."""
    rng = np.random.default_rng(5)
    meshes = [(rng.normal(size=(9, 3)).astype(np.float32), np.arange(9, dtype=np.int32).reshape(3, 3))
              for _ in range(3)]
    message = f"{name} must be a number, got {value!r}"
    with pytest.raises(ValueError) as single:
        build_bvh(*meshes[0], "sah", **{name: value}, device="cpu")
    with pytest.raises(ValueError) as batched:
        build_bvhs(meshes, "sah", **{name: value}, device="cpu")
    assert str(single.value) == str(batched.value) == message


@pytest.mark.parametrize("name", ["traversal_cost", "intersection_cost"])
def test_a_cost_given_as_a_0d_array_is_that_number(name):
    """``np.array(2.0)`` is the number 2 to numpy (``float()`` reads it, as numpy scalars, which were taken); the
    check refused it as 'must be a number'. A 0-d array of a real number now builds the trees that 2.0 builds, by
    itself and batched, and measures as 2.0 does; a 0-d bool, string or complex array, and a 1-element array, are
    still no number."""
    rng = np.random.default_rng(6)
    meshes = [(rng.normal(size=(30, 3)).astype(np.float32), rng.integers(0, 30, (40, 3)).astype(np.int32))
              for _ in range(3)]
    expected = build_bvhs(meshes, "sah", **{name: 2.0}, device="cpu")
    for value in (np.array(2.0), np.array(2), np.array(2.0, np.float32)):
        assert_same_trees(expected, [build_bvh(*meshes[0], "sah", **{name: value}, device="cpu")] +
                          build_bvhs(meshes[1:], "sah", **{name: value}, device="cpu"))
        assert expected[0].stats(**{name: value}, epo_samples=0) == expected[0].stats(**{name: 2.0}, epo_samples=0)
    for value in (np.array(True), np.array("2"), np.array(2 + 0j), np.array([2.0])):
        with pytest.raises(ValueError, match=f"{name} must be a number"):
            build_bvh(*meshes[0], "sah", **{name: value}, device="cpu")


def test_an_update_keeps_the_build_time_and_reports_its_own_in_update_seconds():
    """After ``update()`` (refits, a BLAS built anew, a new TLAS) ``build_seconds`` was the first build's BLAS
    times plus the new TLAS's (and the new BLAS's): the time of neither the build nor the update. It now stays the
    build's, and ``update_seconds`` is the update's, within the wall time of the call around it."""
    import time

    scene = prototype_scene(6, np.random.default_rng(11))
    acc = wrt.tlas.InstancedAccelerator(scene, "sah", "cpu", threads=1)
    built = acc.build_seconds
    assert built == sum(b.build_seconds for b in acc.blas) + acc.tlas.build_seconds
    start = time.perf_counter()
    assert acc.update(scene, refit_blas=True, rebuild=lambda b, tree: b == 0) == [0]
    outer = time.perf_counter() - start
    assert acc.build_seconds == built
    assert 0.0 < acc.update_seconds <= outer
    assert wrt.tlas.InstancedAccelerator(scene, "sah", "cpu", threads=1).update_seconds is None  # none yet


def moved_scene(scene: wrt.Scene, rng) -> wrt.Scene:
    """``scene`` with every prototype vertex moved at random (the same topology and instances): trees built for the
    old vertices no longer fit."""
    protos = [Prototype(p.path, [Mesh(m.path, rng.normal(size=m.points.shape).astype(np.float32) * 10, m.indices,
                                      np.arange(len(m.indices))) for m in p.meshes]) for p in scene.prototypes]
    return wrt.Scene(prototypes=protos, instances=scene.instances)


def test_update_rebuilds_its_trees_together_as_each_is_built_alone(monkeypatch):
    """``InstancedAccelerator.update`` built each BLAS past its refit limit alone (``build_bvh``: a dozen launches
    per tree); it builds them together now. Rebuilding every tree of 20 and of 40 moved prototypes costs as many
    launches more than refitting them only; every other tree rebuilt is, bit for bit, the tree ``build_bvh`` builds
    over its moved mesh and holds that tree's ``to_device`` upload, the others are the refitted trees kept; and a
    later refit moves the rebuilt trees' boxes to the next frame's vertices."""

    launches = []
    real_launch = wp.launch
    monkeypatch.setattr(wp, "launch", lambda kernel, *a, **k: (launches.append(kernel.key), real_launch(kernel, *a,
                                                                                                        **k))[1])
    extra = []
    for count in (20, 40):
        scene = prototype_scene(count, np.random.default_rng(count))
        moved = moved_scene(scene, np.random.default_rng(count + 1))
        made = []
        for rebuild in (None, lambda b, tree: True):
            acc = wrt.tlas.InstancedAccelerator(scene, "sah", "cpu", threads=1)
            launches.clear()
            acc.update(moved, refit_blas=True, rebuild=rebuild)
            made.append(len(launches))
        extra.append(made[1] - made[0])
    assert extra[0] == extra[1], extra  # one by one: 12 launches a tree

    acc = wrt.tlas.InstancedAccelerator(scene, "sah", "cpu", threads=1)
    kept = list(acc.blas)
    assert acc.update(moved, refit_blas=True, rebuild=lambda b, tree: b % 2 == 0) == list(range(0, count, 2))
    points, indices = moved.geometry()
    meshes = [wrt.tlas._part_triangles(moved, points, indices, *part) for part in wrt.tlas.blas_parts(moved)]
    assert_same_trees([build_bvh(*meshes[b], device="cpu") for b in range(0, count, 2)], acc.blas[::2])
    assert all(acc.blas[b] is kept[b] for b in range(1, count, 2))
    for b in range(0, count, 2):
        alone = acc.blas[b].to_device(*meshes[b], "cpu")
        for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids", "v0", "v1", "v2"):
            assert np.array_equal(getattr(alone, field).numpy(), getattr(acc._device_blas[b], field).numpy()), field
    later = moved_scene(moved, np.random.default_rng(99))
    acc.update(later, refit_blas=True)
    points, indices = later.geometry()
    for b, part in enumerate(wrt.tlas.blas_parts(later)):
        p, i = wrt.tlas._part_triangles(later, points, indices, *part)
        corners = p[i].reshape(-1, 3)
        np.testing.assert_array_equal(acc.blas[b].lowers[0], corners.min(axis=0))
        np.testing.assert_array_equal(acc._device_blas[b].uppers.numpy()[0], corners.max(axis=0))


@pytest.mark.parametrize("exponent", [70, -70])
@pytest.mark.parametrize("builder", ["sah", "middle"])
def test_meshes_scaled_by_a_power_of_two_get_the_unit_trees_scaled(builder, exponent):
    # Scaling by 2**exponent is exact, so the oracle is the unit-sized tree scaled: batched, the float32 areas of
    # 2**70-sized boxes overflowed and the sah trees cost 4x (SAH 124.5 against 31.4).
    rng = np.random.default_rng(7)
    centres = rng.uniform(-1, 1, (200, 1, 3))
    points = (centres + rng.normal(scale=0.3, size=(200, 3, 3))).reshape(-1, 3).astype(np.float32)
    meshes = [(points, np.arange(600, dtype=np.int32).reshape(-1, 3)), (points[:90], np.arange(90).reshape(-1, 3))]
    unit = build_bvhs(meshes, builder, device="cpu")
    scaled = build_bvhs([(p * np.float32(2.0**exponent), i) for p, i in meshes], builder, device="cpu")
    for a, b in zip(unit, scaled):
        for field in ("left_first", "prim_count", "prim_ids"):
            np.testing.assert_array_equal(getattr(b, field), getattr(a, field))
        np.testing.assert_array_equal(b.lowers.astype(np.float64), a.lowers * 2.0**exponent)
        np.testing.assert_array_equal(b.uppers.astype(np.float64), a.uppers * 2.0**exponent)


@pytest.mark.parametrize("unused", [np.inf, np.nan])
def test_an_unused_non_finite_point_does_not_take_a_huge_mesh_into_the_batch(unused):
    # The batch check read the largest of all points: an unused inf or NaN one (which the build allows) hid the
    # 2**70 size, the mesh joined the batch and its tree was built at world size (SAH cost 124.5 against 31.4).
    # Oracle: the unit-sized tree scaled by 2**70 (exact).
    rng = np.random.default_rng(7)
    centres = rng.uniform(-1, 1, (200, 1, 3))
    points = (centres + rng.normal(scale=0.3, size=(200, 3, 3))).reshape(-1, 3).astype(np.float32)
    indices = np.arange(600, dtype=np.int32).reshape(-1, 3)
    unit = build_bvh(points, indices, "sah", device="cpu")
    far = np.concatenate([points * np.float32(2.0**70), np.full((1, 3), unused, np.float32)])
    trees = build_bvhs([(far, indices), (points[:90], np.arange(90).reshape(-1, 3))], "sah", device="cpu")
    np.testing.assert_array_equal(trees[0].prim_ids, unit.prim_ids)
    np.testing.assert_array_equal(trees[0].lowers.astype(np.float64), unit.lowers * 2.0**70)
