"""Large and awkward inputs: costs that must grow linearly with the stage, not with its square.

No timing assertions: each test counts the work done (attribute reads, Python-level steps) or checks that the
result of the fast path equals an independent computation.
"""

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
