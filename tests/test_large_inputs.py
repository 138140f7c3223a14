"""Large and awkward inputs: costs that must grow linearly with the stage, not with its square.

No timing assertions: each test counts the work done (attribute reads, Python-level steps) or checks that the
result of the fast path equals an independent computation.
"""

import sys

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom  # noqa: E402
from test_transform_edge_cases import triangle  # noqa: E402

import wrt.usd_visibility as usd_visibility  # noqa: E402
from wrt.usd import load_usd  # noqa: E402


def test_visibility_of_a_deep_hierarchy_reads_each_prim_once(tmp_path, monkeypatch):
    """A mesh under each of ``depth`` nested Xforms: visibility used to be read for every ancestor of every mesh
    (depth^2 / 2 reads). Each prim's visibility is now read once, and an invisible level still hides all below."""
    depth, hidden = 120, 80
    stage = Usd.Stage.CreateNew(str(tmp_path / "deep.usda"))
    path = ""
    for level in range(depth):
        path += f"/X{level}"
        xform = UsdGeom.Xform.Define(stage, path)
        xform.AddTranslateOp().Set(Gf.Vec3d(1.0, 0.0, 0.0))
        if level == hidden:
            xform.MakeInvisible()
        triangle(stage, path + "/M")
    stage.Save()

    reads = []
    original = usd_visibility.value_at

    def counting(attr, time):
        if attr.GetName() == "visibility":
            reads.append(str(attr.GetPrimPath()))
        return original(attr, time)

    monkeypatch.setattr(usd_visibility, "value_at", counting)
    scene = load_usd(tmp_path / "deep.usda")
    # Meshes above the hidden Xform are drawn (one translate per level: mesh k sits at x = k + 1); none below it.
    assert len(scene.meshes) == hidden
    xs = sorted(float(mesh.points[0, 0]) for mesh in scene.meshes)
    np.testing.assert_allclose(xs, np.arange(1, hidden + 1))
    # No prim's visibility is read twice; at most one read per prim of the stage.
    assert len(reads) == len(set(reads))
    assert len(reads) <= 2 * depth


def test_instance_transforms_are_inverted_once_per_scene(monkeypatch):
    """The TLAS build, its BLAS list and the device transforms each inverted every instance's transform again
    (three 5M-instance inversions of several seconds each before the first ray); the scene now keeps one."""
    import wrt
    import wrt.scene as wrt_scene
    import wrt.tlas as wrt_tlas
    from wrt.instancing import Instances, Prototype
    from wrt.scene import Mesh, Scene

    n = 64
    corners = np.array([[-0.4, -0.4, 0.0], [0.4, -0.4, 0.0], [0.0, 0.4, 0.0]])
    proto = Prototype("/Tri", [Mesh("/Tri/mesh", corners, np.array([[0, 1, 2]]), np.arange(1), double_sided=True)])
    to_world = np.tile(np.eye(4), (n, 1, 1))
    to_world[:, 0, 3] = np.arange(n)  # instance k at x = k
    to_world[5, :3, :3] = 0.0  # a zero scale: left out
    calls = []
    original = wrt_scene.invert_transforms

    def counting(transforms):
        calls.append(len(transforms))
        return original(transforms)

    monkeypatch.setattr(wrt_scene, "invert_transforms", counting)
    monkeypatch.setattr(wrt_tlas, "invert_transforms", counting)
    # Built after the patch: the scene inverts the transforms as it is made (to find instances flattened to a plane)
    # and keeps them for the first trace.
    scene = Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(n), to_world))
    origins = np.stack([np.arange(n), np.zeros(n), np.full(n, 2.0)], axis=1).astype(np.float32)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (n, 1))
    hits = wrt.trace(scene, origins, directions)
    expected = np.where(np.arange(n) == 5, -1, np.arange(n))
    np.testing.assert_array_equal(hits.instance, expected)
    np.testing.assert_allclose(hits.t[expected >= 0], 2.0)
    assert calls.count(n) == 1


def test_hits_take_the_mirroring_of_the_instances_hit_only(monkeypatch):
    """``wrt.trace`` swaps ``u`` and ``v`` of hits on mirrored instances (rows of ``Scene.triangles()`` have their
    corners 1 and 2 swapped there): it took the determinant of every instance on each call, 0.4 s for 16 rays into
    1M instances, and now of the distinct instances hit. The barycentrics place each hit where the ray meets the
    triangle, its corners moved by the instance's transform in float64 numpy, swapped where ``det < 0``."""
    import wrt
    from wrt.instancing import Instances, Prototype
    from wrt.scene import Mesh, Scene

    rng = np.random.default_rng(123)
    n = 300
    corners = np.array([[-0.4, -0.3, 0.0], [0.45, -0.35, 0.0], [0.05, 0.4, 0.0]])
    proto = Prototype("/Tri", [Mesh("/Tri/mesh", corners, np.array([[0, 1, 2]]), np.arange(1), double_sided=True)])
    to_world = np.tile(np.eye(4), (n, 1, 1))
    to_world[:, :3, :3] = np.diag([1.0, 1.0, 1.0]) * rng.uniform(0.8, 1.2, (n, 1, 3))
    to_world[::3, 0, :3] *= -1.0  # mirrored in x
    to_world[:, 0, 3] = 3.0 * np.arange(n)
    scene = Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(n), to_world))
    aimed = np.array([0, 1, 2, 3, 6, 7, 299])
    origins = np.stack([3.0 * aimed + 0.05, np.full(len(aimed), 0.02), np.full(len(aimed), 2.0)], axis=1)
    directions = np.tile([0.0, 0.0, -1.0], (len(aimed), 1))
    wrt.trace(scene, origins, directions)  # built before the determinants are counted
    rows = []
    det = np.linalg.det
    monkeypatch.setattr(np.linalg, "det", lambda a: rows.append(len(a)) or det(a))
    hits = wrt.trace(scene, origins, directions)
    assert sum(rows) <= len(aimed)
    np.testing.assert_array_equal(hits.instance, aimed)
    moved = np.einsum("nij,kj->nki", to_world[aimed, :3, :3], corners) + to_world[aimed, None, :3, 3]
    flipped = np.linalg.det(to_world[aimed, :3, :3]) < 0
    moved[flipped] = moved[flipped][:, [0, 2, 1]]
    u, v = hits.u.astype(np.float64), hits.v.astype(np.float64)
    at = (1 - u - v)[:, None] * moved[:, 0] + u[:, None] * moved[:, 1] + v[:, None] * moved[:, 2]
    np.testing.assert_allclose(at, origins + hits.t[:, None] * directions, atol=1e-5)


@pytest.mark.parametrize("mode", ["RGB", "RGBA", "P"])
@pytest.mark.parametrize("color_space", ["auto", "sRGB", "raw"])
def test_8_bit_textures_decode_without_image_sized_float_temporaries(tmp_path, monkeypatch, mode, color_space):
    """An 8-bit texture became float32 and then went through the sRGB curve on the whole image, several
    image-sized float32 temporaries at once (3.7 GB peak for the 1 GB of texels of an 8k x 8k texture), and packing
    it to float16 made four more. The values are those of the whole-image conversions, and the peaks are now little
    above the results themselves."""
    import tracemalloc

    from PIL import Image as PilImage

    import wrt.textures as wrt_textures
    from wrt.textures import load_image, pack_images, srgb_to_linear

    h, w = 301, 517  # odd sizes; every 8-bit value occurs
    # Smooth (a small file, so the PNG's bytes weigh little next to the texels), with every 8-bit value.
    y, x = np.mgrid[0:h, 0:w]
    samples = np.stack([x % 256, y % 256, (x + y) % 256, 255 - x % 256], axis=-1).astype(np.uint8)
    img = PilImage.fromarray(samples, "RGBA")
    img = img.convert("RGB").quantize(256) if mode == "P" else img.convert(mode)
    path = str(tmp_path / f"t_{mode}.png")
    img.save(path)

    expected = np.asarray(PilImage.open(path).convert("RGBA"), np.float32) / 255.0
    if color_space in ("auto", "sRGB"):
        expected[..., :3] = srgb_to_linear(expected[..., :3])
    load_image(path, color_space)  # first use: Pillow loads its plugins
    tracemalloc.start()
    try:
        rgba = load_image(path, color_space)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(rgba, expected)
    assert rgba.dtype == np.float32 and rgba.flags.c_contiguous
    assert peak < 1.75 * rgba.nbytes  # the texels, their 8-bit samples, one channel at a time (was 2 to 3.5x)

    # Packing to float16 gives each image's texels in turn, converted as a whole array would be.
    other = np.random.default_rng(123).normal(size=(3, 5, 4)).astype(np.float32) * 1e5
    other[0, 0] = [np.nan, np.inf, -np.inf, 1.0]
    monkeypatch.setattr(wrt_textures, "PACK_TEXELS", 4096, raising=False)
    tracemalloc.start()
    try:
        texels, offsets, sizes, scales = pack_images([other, rgba])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1.5 * texels.nbytes  # the float16 texels and one slice (were four image-sized copies)
    np.testing.assert_array_equal(offsets, [0, 15])
    np.testing.assert_array_equal(sizes, [[5, 3], [w, h]])
    # other's largest finite texels (about 3e5) are past float16's: each channel is stored divided by the power of
    # two that brings its largest into [2^14, 2^15), the 8-bit image as it is
    flat = other.reshape(-1, 4).astype(np.float64)
    largest = np.abs(np.where(np.isfinite(flat), flat, 0.0)).max(axis=0)
    scale = 2.0 ** (np.floor(np.log2(largest)) - 14)
    np.testing.assert_array_equal(scales, [scale, np.ones(4)])
    whole = np.concatenate([other.reshape(-1, 4) / scale.astype(np.float32), rgba.reshape(-1, 4)])
    whole = np.clip(np.nan_to_num(whole, nan=0.0), -65504.0, 65504.0).astype(np.float16)
    np.testing.assert_array_equal(texels, whole)


def test_expanded_instance_triangles_are_each_instance_moved_in_order(monkeypatch):
    """``Scene.triangles()`` of an instanced scene looped over the instances in Python (8 s for 1M PointInstancer
    instances); it is vectorised per prototype, in slices. Every instance's block equals its prototype moved by
    its own transform, in instance order, with mirrored instances' corners swapped and singular ones collapsed."""
    import wrt.instancing as wrt_instancing
    from wrt.instancing import Instances, Prototype, expand_instance_triangles, transform_points
    from wrt.scene import Mesh

    rng = np.random.default_rng(123)

    def mesh(path, n_points, n_tris):
        return Mesh(path, rng.normal(size=(n_points, 3)).astype(np.float32),
                    rng.integers(0, n_points, (n_tris, 3)), np.arange(n_tris))

    prototypes = [
        Prototype("/A", [mesh("/A/m0", 5, 4), mesh("/A/m1", 3, 1)]),
        Prototype("/Empty"),  # no triangles: its instances add no rows
        Prototype("/B", [mesh("/B/m", 7, 6)]),
    ]
    n = 300
    proto = rng.integers(0, 3, n)
    to_world = np.tile(np.eye(4), (n, 1, 1))
    to_world[:, :3, :3] = rng.normal(size=(n, 3, 3))  # about half of them mirrored
    to_world[:, :3, 3] = rng.normal(size=(n, 3)) * 100.0
    to_world[::17, :3, :3] = 0.0  # singular
    instances = Instances.from_transforms(proto, to_world)

    def python_calls(k):
        """Function calls (Python and C) made expanding the first ``k`` instances."""
        calls = [0]

        def count(frame, event, arg):
            calls[0] += event in ("call", "c_call")

        some = Instances.from_transforms(proto[:k], to_world[:k])
        sys.setprofile(count)
        try:
            expand_instance_triangles(prototypes, some)
        finally:
            sys.setprofile(None)
        return calls[0]

    # The Python work does not grow with the number of instances (it grew by a few calls per instance).
    assert python_calls(n) <= python_calls(30) + 10
    monkeypatch.setattr(wrt_instancing, "EXPAND_POINTS", 40, raising=False)  # several slices per prototype

    points, indices = expand_instance_triangles(prototypes, instances)

    ref_points, ref_indices, base = [], [], 0
    for i in range(n):
        meshes = prototypes[proto[i]].meshes
        if not meshes:
            continue
        pts = np.concatenate([m.points for m in meshes]).astype(np.float64)
        idx = np.concatenate([meshes[0].indices, meshes[1].indices + 5]) if len(meshes) == 2 else meshes[0].indices
        m = to_world[i].copy()
        if i % 17 == 0:
            m[:3, :3] = 0.0
        ref_points.append(transform_points(pts, m).astype(np.float32))
        ref_indices.append((idx[:, [0, 2, 1]] if np.linalg.det(to_world[i, :3, :3]) < 0 else idx) + base)
        base += len(pts)
    np.testing.assert_array_equal(points, np.concatenate(ref_points))
    np.testing.assert_array_equal(indices, np.concatenate(ref_indices))
    assert indices.dtype == np.int64 and points.dtype == np.float32


@pytest.mark.parametrize("block", [7, 1 << 20], ids=["blocks", "one-block"])
def test_instance_transforms_are_inverted_in_blocks_each_as_numpy_inverts_it(monkeypatch, block):
    """``invert_transforms`` works in blocks of ``INVERT_ROWS`` rows (its temporaries took 560 MB more at the load
    peak of a 1M-instance PointInstancer); whether the rows fall in one block or many (7 rows here, the last one
    short), each invertible one is ``np.linalg.inv`` of it in float64, and the singular ones (a zero scale, a NaN)
    are refused with zero rows."""
    import wrt.instancing as wrt_instancing

    monkeypatch.setattr(wrt_instancing, "INVERT_ROWS", block)
    rng = np.random.default_rng(123)
    n = 52
    to_world = np.tile(np.eye(4), (n, 1, 1))
    to_world[:, :3, :3] = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0] * rng.uniform(0.5, 4.0, (n, 1, 3))
    to_world[:, :3, 3] = rng.uniform(-100.0, 100.0, (n, 3))
    singular = np.zeros(n, bool)
    singular[[3, 7, 20, 51]] = True
    to_world[[3, 20], :3, 1] = 0.0  # a zero scale
    to_world[7, :3, :3] = 0.0
    to_world[51, 0, 2] = np.nan

    world_to_local, ok = wrt_instancing.invert_transforms(to_world)

    np.testing.assert_array_equal(ok, ~singular)
    np.testing.assert_array_equal(world_to_local[singular], 0.0)
    expected = np.linalg.inv(to_world[~singular])[:, :3, :]
    np.testing.assert_allclose(world_to_local[~singular], expected, rtol=1e-12, atol=1e-12)


def _many_prototypes_scene(n_prototypes, n_instances, seed=123):
    from wrt.instancing import Instances, Prototype
    from wrt.scene import Mesh, Scene

    rng = np.random.default_rng(seed)
    prototypes = []
    for p in range(n_prototypes):
        n_points = 3 + p % 4
        mesh = Mesh(f"/P{p}/m", rng.normal(size=(n_points, 3)), rng.integers(0, n_points, (2, 3)), np.arange(2))
        prototypes.append(Prototype(f"/P{p}", [mesh]))
    to_world = np.tile(np.eye(4), (n_instances, 1, 1))
    to_world[:, :3, 3] = rng.normal(size=(n_instances, 3)) * 10.0
    to_world[::7, :3, :3] = 0.0  # singular: not drawn
    proto = rng.integers(0, n_prototypes, n_instances)
    proto[: n_prototypes // 2] = np.arange(n_prototypes // 2)  # every other prototype may have no instance left
    proto[proto % 2 == 1] = 0
    return Scene(prototypes=prototypes, instances=Instances.from_transforms(proto, to_world))


def test_many_prototypes_are_grouped_once_not_scanned_per_prototype():
    """Thousands of PointInstancer prototypes: every BLAS part summed the vertex counts of all prototypes (quadratic:
    6 s for 2000), and the TLAS, the BLAS list, the bounds and the flattening each scanned every instance once per
    prototype. The parts, rows and bounds are those of the per-prototype scans."""
    from wrt.tlas import _part_triangles, blas_parts

    scene = _many_prototypes_scene(60, 500)
    instances, n = scene.instances, len(scene.prototypes)
    rows = instances.rows_of_prototypes(n)
    for p in range(n):
        np.testing.assert_array_equal(rows[p], np.flatnonzero(instances.prototype == p))

    _, invertible = scene.instance_inverses()
    points, indices = scene.geometry()
    ranges = scene.prototype_ranges()
    expected = [(p + 1, int(ranges[p][0]), int(ranges[p][1]), 0) for p in range(n)  # no instance at 2^+-100
                if np.any((instances.prototype == p) & invertible)]
    parts = blas_parts(scene)
    assert [tuple(part) for part in parts] == expected and 0 < len(parts) < n
    starts = np.cumsum([0] + [len(proto.meshes[0].points) for proto in scene.prototypes])
    for part, first, count, exponent in parts:
        sub_points, sub = _part_triangles(scene, points, indices, part, first, count, exponent)
        np.testing.assert_array_equal(sub_points, scene.prototypes[part - 1].meshes[0].points)
        np.testing.assert_array_equal(sub + starts[part - 1], indices[first : first + count])

    lower, upper = scene.bounds()
    corners = []
    for i in range(len(instances)):
        m = instances.to_world[i]
        lo, hi = scene.prototypes[instances.prototype[i]].bounds()
        box = np.array(np.meshgrid(*zip(lo, hi))).reshape(3, -1).T
        corners.append(box @ m[:3, :3].T + m[:3, 3])
    corners = np.concatenate(corners)
    np.testing.assert_allclose(lower, corners.min(axis=0), rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(upper, corners.max(axis=0), rtol=1e-6, atol=1e-6)


def test_blas_parts_cost_grows_linearly_with_the_prototypes():
    """The Python calls made slicing every BLAS part grow linearly with the number of prototypes (they grew with its
    square)."""
    from wrt.tlas import _part_triangles, blas_parts

    def python_calls(n_prototypes):
        scene = _many_prototypes_scene(n_prototypes, 4 * n_prototypes)
        points, indices = scene.geometry()
        parts = blas_parts(scene)
        calls = [0]

        def count(frame, event, arg):
            calls[0] += event in ("call", "c_call")

        sys.setprofile(count)
        try:
            for part in parts:
                _part_triangles(scene, points, indices, *part)
        finally:
            sys.setprofile(None)
        return calls[0] / max(len(parts), 1)

    assert python_calls(160) < 2 * python_calls(40)  # per part: constant (it was proportional to the prototypes)


def test_point_instancer_with_many_prototypes_groups_its_instances_once(tmp_path, monkeypatch):
    """A PointInstancer with many prototypes scanned all its instances once per prototype while loading (6 s for
    10000 prototypes and 1M instances); it now groups them once. Every visible instance keeps its prototype and
    position, in index order."""
    n_protos, n = 150, 3000
    rng = np.random.default_rng(123)
    stage = Usd.Stage.CreateNew(str(tmp_path / "pi.usda"))
    instancer = UsdGeom.PointInstancer.Define(stage, "/PI")
    targets = []
    for k in range(n_protos):
        triangle(stage, f"/PI/Protos/P{k}")
        targets.append(f"/PI/Protos/P{k}")
    instancer.CreatePrototypesRel().SetTargets(targets)
    proto_indices = rng.integers(0, n_protos, n)
    positions = rng.normal(size=(n, 3)).astype(np.float32) * 50.0
    instancer.CreateProtoIndicesAttr(proto_indices.tolist())
    instancer.CreatePositionsAttr([Gf.Vec3f(*p) for p in positions.tolist()])
    hidden = rng.choice(n, 40, replace=False)
    instancer.CreateInvisibleIdsAttr(sorted(hidden.tolist()))
    stage.Save()

    scanned = [0]
    flatnonzero = np.flatnonzero

    def counting(a):
        scanned[0] += np.size(a)
        return flatnonzero(a)

    monkeypatch.setattr(np, "flatnonzero", counting)
    scene = load_usd(tmp_path / "pi.usda")
    monkeypatch.undo()

    shown = np.setdiff1d(np.arange(n), hidden)
    np.testing.assert_array_equal(scene.instances.index, shown)
    np.testing.assert_array_equal(scene.instances.prototype, proto_indices[shown])  # prototypes read in order
    np.testing.assert_allclose(scene.instances.to_world[:, :3, 3], positions[shown], rtol=1e-6)
    assert scanned[0] < 10 * n  # a few passes over the instances, not one per prototype


def test_loaded_instances_are_not_inverted_again_before_the_first_trace(tmp_path, monkeypatch):
    """The loader inverts every instance to find the singular ones; the scene then inverted them all again before
    its first ray (about 1 s per 1M instances). The loader's inverses are kept, and they are those the scene would
    compute: instance k is hit at its own place, the zero-scaled one is left out."""
    import wrt
    import wrt.scene as wrt_scene
    from wrt.instancing import invert_transforms

    n = 40
    stage = Usd.Stage.CreateNew(str(tmp_path / "pi.usda"))
    instancer = UsdGeom.PointInstancer.Define(stage, "/PI")
    triangle(stage, "/PI/Protos/Tri")
    instancer.CreatePrototypesRel().SetTargets(["/PI/Protos/Tri"])
    instancer.CreateProtoIndicesAttr([0] * n)
    instancer.CreatePositionsAttr([Gf.Vec3f(3.0 * k, 0.0, 0.0) for k in range(n)])
    instancer.CreateScalesAttr([Gf.Vec3f(0.0 if k == 7 else 1.0 + k / n) for k in range(n)])
    stage.Save()
    scene = load_usd(tmp_path / "pi.usda")

    original = wrt_scene.invert_transforms

    def refuse(transforms):
        if len(transforms) == len(scene.instances):  # the shapes' (a placeholder here) are inverted elsewhere
            raise AssertionError("instances inverted again")
        return original(transforms)

    monkeypatch.setattr(wrt_scene, "invert_transforms", refuse)
    inverses, ok = scene.instance_inverses()
    expected, expected_ok = invert_transforms(scene.instances.to_world)
    np.testing.assert_array_equal(inverses, expected)
    assert ok.all() and expected_ok.all() and len(ok) == n - 1
    assert wrt.trace(scene, np.float32([[0.1, 0.1, 5.0]]), np.float32([[0.0, 0.0, -1.0]])).instance[0] == 0


def test_instanced_shapes_get_their_tlas_boxes_without_a_python_step_each(monkeypatch):
    """A prototype of analytic shapes drawn by many instances (a PointInstancer of spheres): the TLAS build took
    each shape entry's canonical box and moved it in a Python step of its own (44 s to the first hit for 1M spheres,
    7 s now). The boxes now come from one canonical box per unique shape, and every instance is still
    hit where it is."""
    import wrt
    from wrt.instancing import Instances, Prototype
    from wrt.primitives import Shape, shape_transform

    capsule_to_proto = shape_transform(0.5 * np.eye(3))
    capsule_to_proto[:3, 3] = (0.0, 5.0, 0.0)
    squashed = np.diag([0.0, 0.0, 0.0, 1.0])  # a zero-size shape: a box no ray enters
    proto = Prototype("/P", [], [Shape("/P/S", "sphere", np.eye(4)),
                                 Shape("/P/C", "capsule", capsule_to_proto, np.float32([2, 0, 0, 1])),
                                 Shape("/P/Z", "sphere", squashed)])
    n = 400
    scales = np.linspace(0.5, 1.5, n)
    to_world = np.tile(np.eye(4), (n, 1, 1))
    to_world[:, :3, :3] *= scales[:, None, None]
    to_world[:, 0, 3] = 10.0 * np.arange(n)
    scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(n), to_world))

    calls = []
    original = Shape.local_bounds

    def counting(self):
        calls.append(self.path)
        return original(self)

    monkeypatch.setattr(Shape, "local_bounds", counting)
    # From above, onto each instance's sphere (top at z = s) and capsule (centre y = 5 s, top at z = 1.5 s).
    x = 10.0 * np.arange(n)
    origins = np.concatenate([np.stack([x, np.zeros(n), np.full(n, 10.0)], 1),
                              np.stack([x, 5.0 * scales, np.full(n, 10.0)], 1)]).astype(np.float32)
    hits = wrt.trace(scene, origins, np.tile(np.float32([0, 0, -1]), (2 * n, 1)))
    np.testing.assert_array_equal(hits.instance, np.tile(np.arange(n), 2))
    np.testing.assert_allclose(hits.t, np.concatenate([10.0 - scales, 10.0 - 1.5 * scales]), rtol=1e-5)
    assert len(calls) <= 4 * len(proto.shapes)  # per unique shape, not per instance


def _record_many_valued_uniques(monkeypatch):
    """``np.unique`` calls on integer arrays of more than 1000 distinct values (sizes), recorded: numpy's hash table
    takes 10 to 20 times as long as a sort on those (``wrt.unique``)."""
    seen = []
    original = np.unique

    def recording(values, *args, **kwargs):
        arr = np.asarray(values)
        if arr.dtype.kind in "iu" and arr.size > 1000 and not args and not kwargs:
            ordered = np.sort(arr.ravel())
            seen.append(int(np.count_nonzero(ordered[1:] != ordered[:-1])) + 1)
        return original(values, *args, **kwargs)

    monkeypatch.setattr(np, "unique", recording)
    return seen


def test_stacked_coincident_quads_facing_both_ways_pair_without_a_hash_table_pass(monkeypatch):
    """Coincident quads stacked on one plane, every other one turned over: every triangle of one facing is the
    partner of the triangle with the same corners in each quad of the other facing. Their pairs (quadratic in the
    stack) were made unique by ``np.unique``'s hash table: 31 s for 2,000 quads; now by a sort. The partners are those
    of the corner sets."""
    from wrt.twins import find_partners

    seen = _record_many_valued_uniques(monkeypatch)
    n = 60  # quads; 30 each way, so each triangle has 30 partners (under MAX_PARTNERS)
    corners = np.float32([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    points = np.tile(corners, (n, 1))
    up = np.array([[0, 1, 2], [0, 2, 3]])
    indices = np.concatenate([4 * q + (up if q % 2 == 0 else up[:, ::-1]) for q in range(n)])
    offsets, ranges = find_partners(points, indices, np.full(2 * n, -1), np.zeros(2 * n, bool))
    corner_sets = [frozenset(map(tuple, points[row].tolist())) for row in indices]
    for t in range(2 * n):
        partners = {int(first) + k for first, count in ranges[offsets[t]:offsets[t + 1]] for k in range(count)}
        same_corners = {p for p in range(2 * n) if (p // 2) % 2 != (t // 2) % 2 and corner_sets[p] == corner_sets[t]}
        assert partners == same_corners
    assert not seen


def test_prototype_bounds_take_the_used_points_without_a_hash_table_pass(monkeypatch):
    """A prototype's box is that of the points its triangles use (an unused far point left out), found by a sort of
    the vertex indices, not ``np.unique``'s hash table (``wrt.unique``)."""
    from wrt.instancing import Prototype
    from wrt.scene import Mesh

    seen = _record_many_valued_uniques(monkeypatch)
    rng = np.random.default_rng(123)
    points = rng.normal(size=(3001, 3)).astype(np.float32)
    points[1500] = (1e3, -1e3, 1e3)  # used by no triangle
    indices = rng.permutation(np.delete(np.arange(3001), 1500)).reshape(-1, 3)
    lower, upper = Prototype("/P", [Mesh("/P/m", points, indices, np.arange(len(indices)))]).bounds()
    used = np.delete(points, 1500, axis=0).astype(np.float64)
    np.testing.assert_array_equal(lower, used.min(axis=0))
    np.testing.assert_array_equal(upper, used.max(axis=0))
    assert not seen


def test_a_tall_stack_of_coplanar_quads_facing_both_ways_pairs_each_triangle_a_bounded_number_of_times(monkeypatch):
    """1,200 coincident quads, every other one turned over: each triangle overlaps the 600 with its corners facing
    the other way, more than it keeps (``MAX_PARTNERS``). All those pairs were found and then cut (quadratic: 197 s
    and gigabytes for 4,000 quads); the pairing now stops at the lowest ones a triangle keeps. The partners kept
    are the ``MAX_PARTNERS`` lowest with the same corners, and every triangle is named as capped."""
    import wrt.coplanar as wrt_coplanar
    from wrt.twins import MAX_PARTNERS, find_partners

    found = []
    original = wrt_coplanar.coplanar_pairs

    def recording(*args, **kwargs):
        result = original(*args, **kwargs)
        found.append(result[0])
        return result

    monkeypatch.setattr(wrt_coplanar, "coplanar_pairs", recording)
    n = 1200
    corners = np.float32([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    up = np.array([[0, 1, 2], [0, 2, 3]])
    indices = np.concatenate([4 * q + (up if q % 2 == 0 else up[:, ::-1]) for q in range(n)])
    capped = []
    offsets, ranges = find_partners(np.tile(corners, (n, 1)), indices, np.full(2 * n, -1), np.zeros(2 * n, bool),
                                    on_capped=capped.append)
    # Triangle t = 2 q + k (k: which half of quad q) shares its corners with triangle 2 r + k of each quad r.
    for t in range(2 * n):
        partners = [int(first) + k for first, count in ranges[offsets[t]:offsets[t + 1]] for k in range(count)]
        same_corners = [p for p in range(2 * n) if p % 2 == t % 2 and (p // 2) % 2 != (t // 2) % 2]
        assert partners == same_corners[:MAX_PARTNERS]
    np.testing.assert_array_equal(np.sort(np.concatenate(capped)), np.arange(2 * n))
    per_triangle = np.bincount(found[0][:, 0], minlength=2 * n)
    assert per_triangle.max() <= 4 * (MAX_PARTNERS + 1)  # each keeps MAX_PARTNERS; the 600 are not all paired


def test_a_deep_hierarchy_asks_usd_no_ancestor_walking_query_per_mesh(tmp_path, monkeypatch):
    """A mesh under each of 150 nested Xforms, with colours, an opacity, a material and a purpose authored part way
    down: every mesh asked USD's FindPrimvarWithInheritance (three times), ComputePurpose and ComputeBoundMaterial,
    each walking all its ancestors (quadratic in the depth: 2,000 levels took 39 s to load). Each ancestor's answer is
    now kept, and USD's walking queries are not asked per mesh; what each mesh gets is what those queries give."""
    from pxr import Sdf, UsdShade

    depth = 150
    stage = Usd.Stage.CreateNew(str(tmp_path / "deep.usda"))
    material = UsdShade.Material.Define(stage, "/Looks/Green")
    shader = UsdShade.Shader.Define(stage, "/Looks/Green/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.0, 1.0, 0.0))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    path, levels = "", []
    for level in range(depth):
        path += f"/X{level}"
        xform = UsdGeom.Xform.Define(stage, path)
        primvars = UsdGeom.PrimvarsAPI(xform)
        if level in (20, 100):  # constant colours, inherited below
            primvars.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "constant").Set([(level, 0, 1)])
        if level == 60:  # a non-constant one blocks the inheritance
            primvars.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "vertex").Set([(0, 0, 0)])
        if level == 80:
            primvars.CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray, "constant").Set([0.5])
        if level == 120:
            UsdShade.MaterialBindingAPI.Apply(xform.GetPrim()).Bind(material)
        if level == 140:
            xform.CreatePurposeAttr(UsdGeom.Tokens.guide)
        levels.append(triangle(stage, path + "/M").GetPrim())
    stage.Save()

    # The oracle: USD's own queries, asked here before they are counted.
    expected = {}
    for prim in levels:
        if UsdGeom.Imageable(prim).ComputePurpose() != UsdGeom.Tokens.default_:
            continue
        color = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("displayColor")
        opacity = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("displayOpacity")
        bound, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        expected[str(prim.GetPath())] = (
            np.array(color.Get()[0]) if color and color.HasValue() else None,
            float(opacity.Get()[0]) if opacity and opacity.HasValue() else None,
            bool(bound))

    calls = []
    for cls, name in ((UsdGeom.PrimvarsAPI, "FindPrimvarWithInheritance"), (UsdGeom.Imageable, "ComputePurpose"),
                      (UsdShade.MaterialBindingAPI, "ComputeBoundMaterial")):
        def counting(self, *args, _original=getattr(cls, name), _name=name):
            calls.append(_name)
            return _original(self, *args)

        monkeypatch.setattr(cls, name, counting)
    scene = load_usd(tmp_path / "deep.usda")
    assert {mesh.path for mesh in scene.meshes} == set(expected)
    assert len(expected) == 140  # the guide purpose hides the rest
    for mesh in scene.meshes:
        color, opacity, bound = expected[mesh.path]
        if color is None:
            assert mesh.colors is None or np.isnan(mesh.colors).all()
        else:
            np.testing.assert_array_equal(mesh.colors, np.broadcast_to(color, (1, 3, 3)))
        if opacity is None or bound:  # an opacity is carried for the default material only
            assert mesh.opacities is None or np.isnan(mesh.opacities).all()
        else:
            np.testing.assert_array_equal(mesh.opacities, np.full((1, 3), opacity, np.float32))
        assert (mesh.material_ids is not None and (mesh.material_ids >= 0).all()) == bound
    # Only the meshes under the binding ask USD which material they get; nothing else walks the ancestors.
    assert sorted(set(calls)) == ["ComputeBoundMaterial"]
    assert len(calls) <= 2 * (depth - 120)


def test_thousands_of_products_of_one_name_get_their_suffixes_without_trying_each_taken_one():
    """2,000 RenderProducts of one productName: each tried ``_2``, ``_3``, ... from the start (quadratic: 1.1 s of
    2.3 s for 2,000 products, some 30 s for 10,000). The names are still the first free ``name_k`` (compared without
    case, a product named ``beauty_5.exr`` on its own taking that one), and the work per product is bounded."""
    import warnings
    from types import SimpleNamespace

    from wrt.render_products import TakenNames, product_file_name

    names = ["beauty.exr"] * 2000
    names[3], names[700] = "beauty_5.exr", "BEAUTY.exr"
    products = [SimpleNamespace(product_name=name, product=f"/Render/P{i}") for i, name in enumerate(names)]

    def calls_naming(products):
        """Function calls (Python and C) made naming ``products``, and the names."""
        calls, taken, out = [0], TakenNames(), []

        def count(frame, event, arg):
            calls[0] += event in ("call", "c_call")

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sys.setprofile(count)
            try:
                out = [product_file_name(p, False, "shot.usda", taken) for p in products]
            finally:
                sys.setprofile(None)
        return calls[0], out

    calls, got = calls_naming(products)
    # The rule, the slow way: the first of name, name_2, name_3, ... not taken yet, without case.
    taken, expected = set(), []
    for name in names:
        stem, k, candidate = name[:-4], 1, name
        while candidate.casefold() in taken:
            k += 1
            candidate = f"{stem}_{k}.exr"
        taken.add(candidate.casefold())
        expected.append(candidate)
    assert got == expected
    assert calls <= 2 * calls_naming(products[:20])[0] * len(products) / 20  # about as many per product as for 20
