"""BVH builders: structural invariants, the depth guarantee and degenerate input."""

import numpy as np
import pytest

import wrt
from wrt.bvh import MAX_DEPTH, Builder, build_bvh

BUILDERS = [b.value for b in Builder]  # every builder: sah, sweep_sah, median, middle, lbvh, ploc


def soup(rng, n, spread=1.0, size=0.05):
    centers = rng.uniform(-spread, spread, (n, 1, 3))
    return (centers + rng.normal(scale=size, size=(n, 3, 3))).reshape(-1, 3).astype(np.float32), np.arange(
        3 * n, dtype=np.int32
    ).reshape(-1, 3)


def trace_through(points, indices, origins, directions, builder):
    scene = wrt.Scene.from_triangles(points, indices)
    return wrt.trace(scene, origins, directions, builder=builder), wrt.trace(scene, origins, directions, accel="warp")


@pytest.mark.parametrize("builder", BUILDERS)
def test_invariants_on_random_soup(builder, np_rng):
    points, indices = soup(np_rng, 5000)
    bvh = build_bvh(points, indices, builder, device="cpu")
    bvh.validate()
    assert bvh.num_prims == 5000
    assert bvh.prim_count.max() <= 8
    assert bvh.builder == builder
    # Every node box contains the triangles below it: check the leaves directly.
    leaves = np.flatnonzero(bvh.prim_count > 0)
    for leaf in leaves[:200]:
        first, count = bvh.left_first[leaf], bvh.prim_count[leaf]
        tri = points[indices[bvh.prim_ids[first : first + count]]].reshape(-1, 3)
        assert np.all(tri >= bvh.lowers[leaf]) and np.all(tri <= bvh.uppers[leaf])


@pytest.mark.parametrize("builder", BUILDERS)
def test_build_is_deterministic(builder, np_rng):
    points, indices = soup(np_rng, 3000)
    a = build_bvh(points, indices, builder, device="cpu")
    b = build_bvh(points, indices, builder, device="cpu")
    for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_cpu_threads_and_build_phases_do_not_change_the_tree(np_rng):
    from wrt.bvh.binned import build_binned
    from wrt.bvh.common import BuildInput

    points, indices = soup(np_rng, 20000)
    a = build_bvh(points, indices, "sah", threads=1, device="cpu")
    b = build_bvh(points, indices, "sah", threads=2, device="cpu")
    for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    # Level phase down to 64 triangles vs. one subtree for the whole mesh: same tree, up to node numbering.
    options = {"use_sah": True, "leaf_size": 8, "bins": 16, "traversal_cost": 1.0, "intersection_cost": 1.0}
    data = BuildInput(points, indices, "cpu")
    deep = build_binned(data, builder="sah", subtree_size=64, **options).to_host()
    whole = build_binned(data, builder="sah", subtree_size=1 << 20, **options).to_host()
    for tree in (deep, whole):
        tree.validate()
    np.testing.assert_array_equal(deep.prim_ids, whole.prim_ids)
    assert deep.num_nodes == whole.num_nodes == a.num_nodes
    np.testing.assert_allclose(deep.stats(epo_samples=0)["sah_cost"], whole.stats(epo_samples=0)["sah_cost"])


def _mixed_mesh(rng):
    """Clusters, a long thin fan, and 3000 copies of one triangle (coincident centroids: the nodes that halve)."""
    points, indices = soup(rng, 6000)
    fan = np.stack([np.zeros(400), np.linspace(0, 5, 400), np.linspace(-1, 1, 400)], axis=1)
    fan_tris = np.stack([np.zeros((399, 3)), fan[:-1], fan[1:]], axis=1).reshape(-1, 3)
    same = np.tile(np.float32([[2, 2, 2], [2.1, 2, 2], [2, 2.1, 2]]), (3000, 1))
    all_points = np.concatenate([points, fan_tris, same]).astype(np.float32)
    return all_points, np.arange(len(all_points), dtype=np.int32).reshape(-1, 3)


@pytest.mark.parametrize(
    "use_sah,leaf_size,bins",
    [(True, 8, 16), (True, 1, 2), (True, 1 << 16, 64), (False, 4, 16)],
)
def test_large_nodes_split_by_many_threads_give_the_same_tree(use_sah, leaf_size, bins, np_rng):
    """The GPU's path for large nodes (one thread per slot, atomics, a prefix-sum partition), forced on the CPU
    down to 64 triangles, against the one-thread-per-node path: the same tree, bit for bit."""
    from wrt.bvh.binned import build_binned
    from wrt.bvh.common import BuildInput

    points, indices = _mixed_mesh(np_rng)
    options = {"use_sah": use_sah, "leaf_size": leaf_size, "bins": bins, "traversal_cost": 1.0,
               "intersection_cost": 1.0}
    alone = build_binned(BuildInput(points, indices, "cpu"), builder="t", subtree_size=64, **options).to_host()
    shared = build_binned(BuildInput(points, indices, "cpu"), builder="t", subtree_size=64, parallel_min=64,
                          **options).to_host()
    alone.validate()
    assert alone.num_nodes > 1000 or leaf_size == 1 << 16
    for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids"):
        np.testing.assert_array_equal(getattr(shared, field), getattr(alone, field))


@pytest.mark.parametrize(
    "builder,options",
    [
        ("lbvh", {"morton_bits": 63}),
        ("ploc", {"morton_bits": 63}),
        ("ploc", {"ploc_radius": 1}),
        ("ploc", {"ploc_radius": 32}),
        ("sah", {"bins": 64}),
        ("sah", {"bins": 2}),
    ],
)
def test_builder_options(builder, options, np_rng):
    points, indices = soup(np_rng, 3000)
    bvh = build_bvh(points, indices, builder, device="cpu", **options)
    bvh.validate()
    assert bvh.num_prims == 3000


def test_read_int_gives_each_thread_its_own_pinned_word(monkeypatch):
    """``read_int`` copies a GPU value into a pinned host word, synchronizes and reads it: one word per device shared
    by every thread let a thread building a BVH on a GPU read the value another thread's copy had just written there
    (two Python threads building trees on one GPU). Each thread has its own word, kept for its later reads."""
    import threading

    import warp as wp

    from wrt.bvh.common import pinned_word

    monkeypatch.setattr(wp, "empty", lambda *args, **kwargs: object())  # a pinned allocation needs a CUDA driver
    words = []
    threads = [threading.Thread(target=lambda: words.append((pinned_word("cuda:0"), pinned_word("cuda:0"))))
               for _ in range(2)]
    for thread in threads:
        thread.start()
        thread.join()
    (a, a_again), (b, _) = words
    assert a is a_again and a is not b
    assert pinned_word("cuda:0") is not a and pinned_word("cuda:1") is not pinned_word("cuda:0")


def test_device_build_and_wp_array_input(np_rng):
    import warp as wp

    from wrt.bvh import build_bvh_device

    points, indices = soup(np_rng, 2000)
    for builder in BUILDERS:
        tree = build_bvh_device(
            wp.array(points, dtype=wp.vec3), wp.array(indices, dtype=wp.int32), builder, device="cpu"
        )
        assert isinstance(tree.left_first, wp.array) and tree.builder == builder
        host = tree.to_host()
        host.validate()
        ref = build_bvh(points, indices, builder, device="cpu")
        np.testing.assert_array_equal(host.prim_ids, ref.prim_ids)
        np.testing.assert_array_equal(host.left_first, ref.left_first)


def test_top_level_api_accepts_aliases_and_options(np_rng):
    points, indices = soup(np_rng, 500)
    bvh = wrt.build_bvh(points, indices, builder="binned_sah", leaf_size=2, device="cpu")
    assert bvh.builder == "sah" and bvh.prim_count.max() <= 2


def test_leaf_size_is_respected(np_rng):
    points, indices = soup(np_rng, 2000)
    for leaf_size in (1, 2, 16):
        bvh = build_bvh(points, indices, leaf_size=leaf_size, device="cpu")
        bvh.validate()
        assert bvh.prim_count.max() <= leaf_size


def test_validate_catches_a_broken_tree(np_rng):
    points, indices = soup(np_rng, 100)
    bvh = build_bvh(points, indices, device="cpu")
    bvh.prim_ids[0] = bvh.prim_ids[1]
    with pytest.raises(AssertionError, match="permutation|exactly once"):
        bvh.validate()
    bvh = build_bvh(points, indices, device="cpu")
    inner = np.flatnonzero(bvh.prim_count == 0)[0]
    bvh.lowers[bvh.left_first[inner]] -= 1.0
    with pytest.raises(AssertionError, match="below its parent"):
        bvh.validate()


@pytest.mark.parametrize("builder", BUILDERS)
def test_validate_names_the_node_a_corruption_breaks(builder, np_rng):
    points, indices = soup(np_rng, 40)
    leaves = lambda t: np.flatnonzero(t.prim_count > 0)  # noqa: E731
    # A leaf box pulled off its triangles (its parent's still holds them): rays at those triangles miss.
    bvh = build_bvh(points, indices, builder, leaf_size=2)
    leaf = leaves(bvh)[1]
    corners = points[indices[bvh.prim_ids[bvh.left_first[leaf]]]]
    bvh.uppers[leaf] = corners.max(0) - np.float32(0.5) * (corners.max(0) - corners.min(0))
    with pytest.raises(AssertionError, match=rf"^leaf {leaf}: box does not hold its triangles"):
        bvh.validate()
    # An inverted leaf box lies inside its parent's box and holds nothing, with the triangles at hand or not (a tree
    # copied from the device).
    bvh = build_bvh(points, indices, builder, leaf_size=2)
    bvh.lowers[leaf], bvh.uppers[leaf] = bvh.uppers[leaf].copy(), bvh.lowers[leaf].copy()
    bvh.points = bvh.indices = None
    with pytest.raises(AssertionError, match=rf"^node {leaf}: box inverted"):
        bvh.validate()
    # A child box grown past its parent's.
    bvh = build_bvh(points, indices, builder, leaf_size=2)
    child = bvh.left_first[np.flatnonzero(bvh.prim_count == 0)[-1]] + 1
    bvh.uppers[child] += np.float32(1.0)
    with pytest.raises(AssertionError, match=rf"^node {child}: child box above its parent's"):
        bvh.validate()
    # A leaf whose slot range runs past the slots.
    bvh = build_bvh(points, indices, builder, leaf_size=2)
    bvh.prim_count[leaf] += 40
    with pytest.raises(AssertionError, match=rf"^leaf {leaf}: slot range out of range"):
        bvh.validate()
    # A triangle in two slots (and another in none).
    bvh = build_bvh(points, indices, builder, leaf_size=2)
    bvh.prim_ids[7] = bvh.prim_ids[3]
    with pytest.raises(AssertionError, match=rf"triangle {bvh.prim_ids[3]} is in slots \[3, 7\]"):
        bvh.validate()
    # Arrays of different lengths are named, not an IndexError.
    bvh = build_bvh(points, indices, builder, leaf_size=2)
    bvh.uppers = bvh.uppers[:-1]
    with pytest.raises(AssertionError, match="uppers has shape"):
        bvh.validate()


def test_stats_of_a_tree_whose_child_links_loop_is_an_error_not_a_runaway():
    # Node 1's children are nodes 1 and 2: every level of the walk doubled, until memory ran out (stats() does not
    # validate the tree first).
    tree = wrt.bvh.FlatBvh(lowers=np.zeros((3, 3), np.float32), uppers=np.ones((3, 3), np.float32),
                           left_first=np.int32([1, 1, 0]), prim_count=np.int32([0, 0, 1]), prim_ids=np.int32([0]))
    with pytest.raises(ValueError, match="a child link leads back up the tree"):
        tree.stats(epo_samples=0)
    with pytest.raises(AssertionError, match="not reached exactly once"):
        tree.validate()


def reachable_slots(tree) -> set:
    """The slots a traversal from the root can reach, walked node by node (the oracle of the test below)."""
    slots, stack = set(), [0]
    while stack:
        node = stack.pop()
        if tree.prim_count[node] > 0:
            slots.update(range(tree.left_first[node], tree.left_first[node] + tree.prim_count[node]))
        else:
            stack += [int(tree.left_first[node]), int(tree.left_first[node]) + 1]
    return slots


def test_validate_refuses_nodes_the_root_does_not_reach():
    # Node 3's children are nodes 3 and 4: each node is some node's child once, every slot in one leaf and every box
    # inside its parent's, so validate() passed, yet no traversal from the root reaches node 4's slot: triangle 2 can
    # never be hit.
    tree = wrt.bvh.FlatBvh(lowers=np.zeros((5, 3), np.float32), uppers=np.ones((5, 3), np.float32),
                           left_first=np.int32([1, 0, 1, 3, 2]), prim_count=np.int32([0, 1, 1, 0, 1]),
                           prim_ids=np.int32([0, 1, 2]))
    assert reachable_slots(tree) == {0, 1}
    with pytest.raises(AssertionError, match=r"^node 3: not reached from the root"):
        tree.validate()


def test_validate_still_checks_under_python_dash_o(tmp_path):
    # ``assert`` statements vanish under ``python -O``: validate() passed every corrupted tree there.
    import os
    import subprocess
    import sys
    from pathlib import Path

    script = tmp_path / "corrupt.py"
    script.write_text(
        "import numpy as np\nfrom wrt.bvh import build_bvh\n"
        "p = np.random.default_rng(1).random((30, 3)).astype(np.float32)\n"
        "bvh = build_bvh(p, np.arange(30, dtype=np.int32).reshape(-1, 3), leaf_size=1)\n"
        "bvh.prim_ids[1] = bvh.prim_ids[0]\n"
        "try:\n    bvh.validate()\nexcept AssertionError as e:\n    print('caught:', e)\n"
    )
    root = str(Path(wrt.__file__).resolve().parents[1])  # the script's folder is no place to import wrt from
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))}
    out = subprocess.run([sys.executable, "-O", str(script)], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    assert "caught: prim_ids is not a permutation" in out.stdout


def degenerate_cases():
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    rng = np.random.default_rng(5)
    cases = {}
    cases["identical"] = (np.tile(tri, (2000, 1)), np.arange(6000).reshape(-1, 3))
    # Different triangles with one common bounds centre: every centroid is equal.
    scales = rng.uniform(0.1, 1.0, (1000, 1, 1)).astype(np.float32)
    sym = np.array([[-1, -1, -1], [1, 1, 1], [1, -1, 1]], np.float32)
    cases["equal_centroids"] = ((sym * scales).reshape(-1, 3), np.arange(3000).reshape(-1, 3))
    cases["zero_area"] = (
        np.tile(np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2]], np.float32), (500, 1)),
        np.arange(1500).reshape(-1, 3),
    )
    cases["single"] = (tri, np.array([[0, 1, 2]]))
    line = np.linspace(0, 1, 3000, dtype=np.float32)
    cases["collinear"] = (np.stack([line, 2 * line, 3 * line], 1), np.arange(3000).reshape(-1, 3))
    flat = rng.uniform(-1, 1, (3000, 3)).astype(np.float32)
    flat[:, 2] = 0.5
    cases["coplanar"] = (flat, np.arange(3000).reshape(-1, 3))
    cases["huge"] = (tri * np.float32(1e30) + np.float32(1e30), np.array([[0, 1, 2]]))
    tiny, tiny_idx = soup(rng, 500, spread=1.0, size=0.1)
    cases["tiny"] = (tiny * np.float32(1e-30), tiny_idx)
    return cases


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("case", list(degenerate_cases()))
def test_degenerate_input_builds_and_traces(builder, case):
    points, indices = degenerate_cases()[case]
    points = np.asarray(points, np.float32)
    indices = np.asarray(indices, np.int32)
    bvh = build_bvh(points, indices, builder, device="cpu")
    bvh.validate()
    assert bvh.depths().max() <= MAX_DEPTH - 1
    # Rays aimed at triangle centres (axis-aligned where the geometry allows): compare with wp.Mesh.
    centers = points[indices].mean(axis=1)
    lower, upper = points.min(0), points.max(0)
    extent = np.maximum(upper - lower, np.abs(upper) * 1e-3 + 1e-35)
    origins = (centers + np.array([0.31, 0.27, 1.0], np.float32) * extent * 2).astype(np.float32)
    directions = (centers - origins).astype(np.float32)
    ours, theirs = trace_through(points, indices, origins, directions, builder)
    if case in ("huge", "tiny"):
        # wp.Mesh's float32 triangle test loses these hits (edge functions ~ coordinate^2, distances ~ cube); every
        # ray is aimed at a triangle centre, so it hits at t <= 1 (another triangle may come first; the ray itself
        # carries float32 rounding of coordinates near 1e30, about 4e-5 of t here).
        assert ours.hit.all()
        assert (ours.t <= 1.0 + 1e-4).all()
        assert np.isclose(ours.t, 1.0, rtol=1e-4).mean() > 0.5
    else:
        np.testing.assert_array_equal(ours.hit, theirs.hit)
    both = ours.hit & theirs.hit
    np.testing.assert_allclose(ours.t[both], theirs.t[both], rtol=1e-5)


@pytest.mark.parametrize("builder", BUILDERS)
def test_million_copies_of_one_triangle_stay_within_the_stack(builder):
    n = 1_000_000
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    indices = np.zeros((n, 3), np.int32)
    indices[:, 1], indices[:, 2] = 1, 2
    bvh = build_bvh(points, indices, builder, device="cpu")
    bvh.validate()
    assert bvh.depths().max() <= MAX_DEPTH - 1
    scene = wrt.Scene.from_triangles(points, indices)
    hits = wrt.trace(scene, np.array([[0.2, 0.2, 1.0]]), np.array([[0.0, 0.0, -1.0]]), builder=builder)
    assert hits.prim[0] == 0 and hits.t[0] == pytest.approx(1.0)


def test_builder_names():
    assert Builder.from_str("binned_sah") is Builder.SAH
    # Exact, as every other name wrt takes (integrators, layouts, accelerators, devices): 'SAH' was taken here alone.
    with pytest.raises(ValueError, match=r"unknown BVH builder 'SAH' \(did you mean 'sah'\?\)"):
        Builder.from_str("SAH")
    with pytest.raises(ValueError, match="valid builders: sah, sweep_sah, median, middle, lbvh, ploc, binned_sah"):
        Builder.from_str("kdtree")


def test_bad_build_input_raises():
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    with pytest.raises(ValueError, match="finite"):
        build_bvh(np.array([[0, 0, 0], [1, np.nan, 0], [0, 1, 0]], np.float32), [[0, 1, 2]], device="cpu")
    with pytest.raises(ValueError, match="indices"):
        build_bvh(tri, [[0, 1, 3]], device="cpu")
    # The first offending triangle is named, also among many.
    many = np.tile([[0, 1, 2]], (50, 1))
    many[[31, 40], 1] = 7
    with pytest.raises(ValueError, match=r"must lie in \[0, 3\); triangle 31 "):
        build_bvh(tri, many, device="cpu")
    nan_points = np.vstack([tri, [[np.nan, 0, 0]]]).astype(np.float32)
    many[[31, 40], 1] = [1, 3]
    with pytest.raises(ValueError, match=r"finite in float32 \(found NaN or inf, .*\); triangle 40 uses one"):
        build_bvh(nan_points, many, device="cpu")
    # Finite float64 vertices past float32's range: the message named only NaN and inf, which the input had none of.
    with pytest.raises(ValueError, match=r"a value past float32's 3.4e38\); triangle 0 uses one"):
        build_bvh(tri.astype(np.float64) * 1e39, [[0, 1, 2]], device="cpu")
    # Malformed arrays are refused, not reinterpreted: 2**32 wrapped round to vertex 0 in the cast to int32, float
    # indices were truncated, and (V, 4) points or (T, 4) indices were reshaped into other vertices and triangles.
    for points, indices, needle in (
        (tri, np.array([[0, 1, 2**32]], np.int64), r"must lie in \[0, 3\); triangle 0 "),
        (tri, np.array([[0.0, 1.0, 2.9]]), "indices must be integers"),
        (np.zeros((3, 4), np.float32), [[0, 1, 2]], r"points must have shape \(N, 3\)"),
        (tri, np.zeros((3, 4), np.int32), r"indices must have shape \(N, 3\)"),
    ):
        with pytest.raises(ValueError, match=needle):
            build_bvh(points, indices, device="cpu")
        with pytest.raises(ValueError, match=needle):
            wrt.Scene.from_triangles(points, indices)
    with pytest.raises(ValueError, match="leaf_size"):
        build_bvh(tri, [[0, 1, 2]], leaf_size=0, device="cpu")
    with pytest.raises(ValueError, match="morton_bits"):
        build_bvh(tri, [[0, 1, 2]], "lbvh", morton_bits=31, device="cpu")
    with pytest.raises(ValueError, match="ploc_radius"):
        build_bvh(tri, [[0, 1, 2]], "ploc", ploc_radius=0, device="cpu")
    with pytest.raises(ValueError, match="threads"):
        build_bvh(tri, [[0, 1, 2]], threads=0, device="cpu")
    with pytest.raises(ValueError, match="bins"):
        build_bvh(tri, [[0, 1, 2]], bins=65, device="cpu")
    with pytest.raises(ValueError, match="unknown or unavailable device 'cuda:9'; available devices: "):
        build_bvh(tri, [[0, 1, 2]], device="cuda:9")  # Warp's own RuntimeError, as trace and render do not give


def test_malformed_warp_array_input_is_refused_like_numpy_input():
    """Warp arrays skipped the numpy input checks: a (3, 4) int32 index array was reshaped into four triangles,
    float indices were truncated, int64 index 2**32 wrapped round to vertex 0 and (3, 4) float points became four
    vertices; each is now refused with the numpy path's message."""
    import warp as wp

    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    for points, indices, needle in (
        (tri, wp.array(np.array([[0, 1, 2, 3], [1, 2, 3, 0], [2, 3, 0, 1]]), dtype=wp.int32),
         r"indices must have shape \(N, 3\)"),
        (tri, wp.array(np.array([[0.0, 1.0, 2.9]]), dtype=wp.float32), "indices must be integers"),
        (tri, wp.array(np.array([[0, 1, 2**32]]), dtype=wp.int64), r"must lie in \[0, 4\); triangle 0 "),
        (wp.array(np.zeros((3, 4), np.float32), dtype=wp.float32), [[0, 1, 2]], r"points must have shape \(N, 3\)"),
    ):
        with pytest.raises(ValueError, match=needle):
            build_bvh(points, indices, device="cpu")
    bvh = build_bvh(wp.array(tri, dtype=wp.vec3), wp.array([[0, 1, 2], [0, 2, 3]], dtype=wp.vec3i), device="cpu")
    assert bvh.num_prims == 2


def test_integer_build_options_are_checked_and_named():
    """int() alone truncated leaf_size=8.7 to 8 and took "8" and True, failed on None or NaN with messages that did
    not name the option, and threads=np.int64(2) was refused as not being a positive integer."""
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    for option, value in (("leaf_size", 8.7), ("leaf_size", "8"), ("leaf_size", True), ("leaf_size", None),
                          ("leaf_size", np.nan), ("bins", 16.5), ("ploc_radius", "8"), ("morton_bits", 30.5),
                          ("threads", True), ("threads", 2.0)):
        with pytest.raises(ValueError, match=f"{option} must (be an integer|lie in .* and be an integer)"):
            build_bvh(tri, [[0, 1, 2]], **{option: value}, device="cpu")
    bvh = build_bvh(tri, [[0, 1, 2]], leaf_size=np.int64(4), bins=np.int32(8), threads=np.int64(2), device="cpu")
    assert bvh.num_prims == 1


def test_integer_build_options_given_as_0d_integer_arrays_are_those_integers():
    """``np.array(8)`` is the integer 8 to numpy (``int()`` and ``operator.index`` read it, as numpy scalars, which
    were taken); check_int_option refused it as 'must be an integer' while check_costs takes ``np.array(2.0)``. The
    trees equal those of the Python ints; 0-d bool and float arrays and 1-element arrays are still refused."""
    import operator

    rng = np.random.default_rng(8)
    points = rng.normal(size=(60, 3)).astype(np.float32)
    indices = rng.integers(0, 60, (80, 3)).astype(np.int32)
    for builder, options in (("sah", dict(leaf_size=2, bins=4, presplit=1, threads=1)),
                             ("ploc", dict(leaf_size=2, morton_bits=63, ploc_radius=3))):
        expected = build_bvh(points, indices, builder, **options, device="cpu")
        as_arrays = {k: np.array(operator.index(v)) for k, v in options.items()}
        got = build_bvh(points, indices, builder, **as_arrays, device="cpu")
        for field in ("lowers", "uppers", "left_first", "prim_count", "prim_ids"):
            np.testing.assert_array_equal(getattr(got, field), getattr(expected, field))
    for value in (np.array(True), np.array(8.0), np.array([8]), np.array("8")):
        with pytest.raises(ValueError, match="leaf_size must lie in .* and be an integer"):
            build_bvh(points, indices, leaf_size=value, device="cpu")


def test_empty_input_gives_an_empty_tree():
    bvh = build_bvh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), device="cpu")
    bvh.validate()
    assert bvh.num_prims == 0




def _ploc_partners(neighbours: np.ndarray, dists: np.ndarray, radius: int, seed: int) -> np.ndarray:
    """The merge partners that one PLOC iteration picks for these nearest neighbours and distances."""
    import warp as wp

    from wrt.bvh import ploc

    n = len(neighbours)
    partners = wp.empty(n, dtype=wp.int32, device="cpu")
    flags = wp.empty(n, dtype=wp.int32, device="cpu")
    wp.launch(
        ploc.merge_flags_kernel,
        n,
        inputs=[n, 0, seed, radius, wp.array(neighbours, dtype=wp.int32, device="cpu"),
                wp.array(dists, dtype=float, device="cpu")],
        outputs=[partners, flags],
        device="cpu",
    )
    return partners.numpy()


def test_ploc_pairs_are_symmetric_and_keep_every_mutual_pair():
    rng = np.random.default_rng(3)
    n, radius = 5000, 8
    index = np.arange(n)
    offsets = rng.integers(1, radius + 1, n) * rng.choice([-1, 1], n)
    neighbours = np.clip(index + offsets, 0, n - 1)
    neighbours[neighbours == index] = np.where(index[neighbours == index] == 0, 1, index[neighbours == index] - 1)
    dists = rng.uniform(1.0, 1.1, n).astype(np.float32)
    mutual = neighbours[neighbours] == index
    for seed in range(4):
        partners = _ploc_partners(neighbours, dists, radius, seed)
        matched = partners >= 0
        assert np.array_equal(partners[partners[matched]], index[matched]), "a pair is not symmetric"
        assert np.array_equal(partners[mutual], neighbours[mutual]), "a mutual pair was not kept"
        assert np.all(np.abs(partners[matched] - index[matched]) <= radius)
        # The chain matching pairs a proposer with the cluster it chose as nearest neighbour.
        chained = matched & ~mutual
        assert np.all((neighbours[chained] == partners[chained]) | (neighbours[partners[chained]] == index[chained]))


def test_ploc_chain_of_shrinking_clusters_merges_many_pairs_per_iteration():
    # Each cluster's nearest neighbour is the next one, at a slowly shrinking distance: mutual pairs alone merge
    # only the last two; the chain matching must pair a good share of the rest.
    n = 4000
    neighbours = np.arange(1, n + 1)
    neighbours[-1] = n - 2
    dists = (1.0 - 1e-5 * np.arange(n)).astype(np.float32)
    for seed in range(3):
        partners = _ploc_partners(neighbours, dists, 8, seed)
        assert (partners >= 0).mean() > 0.3
        # Each proposer 20% farther than the acceptor's own nearest neighbour, beyond the tolerance: no match.
        steep = (1.2 ** -np.arange(n, dtype=np.float64) * 1e30).astype(np.float32)[:400]
        chain = np.append(np.arange(1, 400), 398)
        assert (_ploc_partners(chain, steep, 8, seed) >= 0).sum() == 2


def _inner_area_in_box(bvh, lower, upper) -> float:
    """Summed half areas of the inner nodes that lie in the box, over its own half area: the expected inner nodes a
    random ray through the box visits there (the SAH's traversal term)."""
    inside = np.all(bvh.lowers >= lower, axis=1) & np.all(bvh.uppers <= upper, axis=1) & (bvh.prim_count == 0)
    extent = np.maximum(bvh.uppers[inside] - bvh.lowers[inside], 0.0).astype(np.float64)
    areas = extent[:, 0] * extent[:, 1] + extent[:, 1] * extent[:, 2] + extent[:, 2] * extent[:, 0]
    box = (upper - lower).astype(np.float64)
    return float(areas.sum() / (box[0] * box[1] + box[1] * box[2] + box[2] * box[0]))


@pytest.mark.parametrize("builder", ["lbvh", "ploc"])
@pytest.mark.parametrize("morton_bits", [30, 63])
def test_morton_builders_order_a_cluster_whose_codes_are_all_equal(builder, morton_bits):
    """10k small triangles 1e-3 across and one triangle 1e10 away: in the centroid box every cluster triangle gets
    the same Morton code, so lbvh and ploc kept them in id order, a spatially random tree (rays into the cluster
    visited 3,600 nodes with lbvh and 1,300 with ploc, 44 with sah). Equal codes are now ordered by a second code
    in their run's own box, and the cluster's tree is about as good as the SAH builder's."""
    rng = np.random.default_rng(3)
    n = 10000
    centres = rng.random((n, 3)) * 1e-3
    centres[-1] = 1e10
    points = (np.repeat(centres, 3, axis=0) + rng.normal(0.0, 1e-5, (3 * n, 3))).astype(np.float32)
    indices = np.arange(3 * n, dtype=np.int32).reshape(n, 3)
    cluster = points[: 3 * (n - 1)]
    lower, upper = cluster.min(axis=0), cluster.max(axis=0)
    bvh = build_bvh(points, indices, builder, morton_bits=morton_bits)
    bvh.validate()
    reference = _inner_area_in_box(build_bvh(points, indices, "sah"), lower, upper)
    assert _inner_area_in_box(bvh, lower, upper) < 1.5 * reference
    # The same hits as wp.Mesh for rays from inside the cluster to points on its triangles.
    targets = points[indices[rng.integers(0, n - 1, 256)]].mean(axis=1)
    origins = (targets + rng.normal(0.0, 5e-4, targets.shape)).astype(np.float32)
    hits, ref = trace_through(points, indices, origins, targets - origins, builder)
    np.testing.assert_array_equal(hits.prim, ref.prim)


@pytest.mark.parametrize("exponent", [70, -70])
@pytest.mark.parametrize("builder", BUILDERS)
def test_a_scene_scaled_by_a_power_of_two_gets_the_same_tree_scaled(builder, exponent, np_rng):
    # Scaling by 2**exponent is exact, so the oracle is the unit-sized tree scaled: float32 areas of 2**70-sized boxes
    # overflowed to inf (2**-70: underflowed to 0) and the SAH decisions went blind (sah: SAH cost 95.0, not 66.8).
    points, indices = soup(np_rng, 300, size=0.3)
    unit = build_bvh(points, indices, builder, device="cpu")
    scaled = build_bvh(points * np.float32(2.0**exponent), indices, builder, device="cpu")
    scaled.validate()
    np.testing.assert_array_equal(scaled.left_first, unit.left_first)
    np.testing.assert_array_equal(scaled.prim_count, unit.prim_count)
    np.testing.assert_array_equal(scaled.prim_ids, unit.prim_ids)
    np.testing.assert_array_equal(scaled.lowers.astype(np.float64), unit.lowers * 2.0**exponent)
    np.testing.assert_array_equal(scaled.uppers.astype(np.float64), unit.uppers * 2.0**exponent)


@pytest.mark.parametrize("builder", BUILDERS)
def test_a_scene_past_half_of_float32s_range_gets_the_unit_tree_scaled(builder):
    # Triangles past 2**127 (1.7e38): their box centres, the float32 0.5 * (lower + upper), overflowed to inf and
    # stayed inf at unit size, so the builders split blind (sweep_sah: SAH cost 51.5, not 41.0; lbvh 53.4, not 44.0).
    # Oracle: the unit-sized tree scaled by 2**128 (exact).
    points = np.random.default_rng(2).uniform(0.5, 0.99, (180, 3)).astype(np.float32)
    indices = np.arange(180, dtype=np.int32).reshape(-1, 3)
    unit = build_bvh(points, indices, builder, device="cpu")
    scaled = build_bvh((points.astype(np.float64) * 2.0**128).astype(np.float32), indices, builder, device="cpu")
    np.testing.assert_array_equal(scaled.left_first, unit.left_first)
    np.testing.assert_array_equal(scaled.prim_ids, unit.prim_ids)
    np.testing.assert_array_equal(scaled.uppers.astype(np.float64), unit.uppers.astype(np.float64) * 2.0**128)
