"""Large and awkward inputs: costs that must grow linearly with the stage, not with its square.

No timing assertions: each test counts the work done (attribute reads, Python-level steps) or checks that the
result of the fast path equals an independent computation.
"""

import sys

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom  # noqa: E402

import wrt.usd as wrt_usd  # noqa: E402
from wrt.usd import load_usd  # noqa: E402


def _triangle(stage, path):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    return mesh


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
        _triangle(stage, path + "/M")
    stage.Save()

    reads = []
    original = wrt_usd.value_at

    def counting(attr, time):
        if attr.GetName() == "visibility":
            reads.append(str(attr.GetPrimPath()))
        return original(attr, time)

    monkeypatch.setattr(wrt_usd, "value_at", counting)
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
    scene = Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(n), to_world))

    calls = []
    original = wrt_scene.invert_transforms

    def counting(transforms):
        calls.append(len(transforms))
        return original(transforms)

    monkeypatch.setattr(wrt_scene, "invert_transforms", counting)
    monkeypatch.setattr(wrt_tlas, "invert_transforms", counting)
    origins = np.stack([np.arange(n), np.zeros(n), np.full(n, 2.0)], axis=1).astype(np.float32)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (n, 1))
    hits = wrt.trace(scene, origins, directions)
    expected = np.where(np.arange(n) == 5, -1, np.arange(n))
    np.testing.assert_array_equal(hits.instance, expected)
    np.testing.assert_allclose(hits.t[expected >= 0], 2.0)
    assert calls.count(n) == 1


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
        texels, offsets, sizes = pack_images([other, rgba])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1.5 * texels.nbytes  # the float16 texels and one slice (were four image-sized copies)
    np.testing.assert_array_equal(offsets, [0, 15])
    np.testing.assert_array_equal(sizes, [[5, 3], [w, h]])
    whole = np.concatenate([other.reshape(-1, 4), rgba.reshape(-1, 4)])
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
