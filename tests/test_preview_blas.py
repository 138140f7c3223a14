"""``bvh_instance``: the preview draws one instance's own BVH (its prototype's BLAS) placed in the world by the
instance's transform; before, only the top level of a scene with instances could be drawn. The oracle: the BLAS
node boxes of the accelerator the renderer traces, their eight corners moved by the instance matrix in float64
numpy."""

import importlib
import itertools

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import wrt  # noqa: E402
from wrt.cli import main  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.scene import Mesh  # noqa: E402
from wrt.trace import get_accelerator  # noqa: E402


@pytest.fixture(scope="module")
def instanced():
    """Three instances (turned, stretched, one mirrored, moved far apart) of a prototype of 60 random triangles."""
    rng = np.random.default_rng(123)
    points = rng.uniform(-1.0, 1.0, (180, 3)).astype(np.float32)
    prototype = Prototype("/P", [Mesh("/P/soup", points, np.arange(180).reshape(60, 3), np.arange(60))])
    to_world = np.tile(np.eye(4), (3, 1, 1))
    for k in range(3):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        to_world[k, :3, :3] = q @ np.diag(rng.uniform(0.5, 3.0, 3))
        to_world[k, :3, 3] = rng.uniform(-50.0, 50.0, 3)
    to_world[1, :3, 0] *= -1.0  # mirrored
    return wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms(np.zeros(3, int), to_world))


def sorted_corners(boxes: np.ndarray) -> np.ndarray:
    """``(B, 8, 3)`` corners with each box's eight in lexicographic order (the drawing's corner order is its own)."""
    order = np.lexsort(boxes.transpose(2, 0, 1)[::-1], axis=-1)
    return np.take_along_axis(boxes, order[..., None], axis=1)


@pytest.mark.parametrize("which", [1, "/instances[1]"], ids=["index", "path"])
@pytest.mark.parametrize("depth", [None, 2], ids=["leaves", "depth2"])
def test_an_instances_blas_boxes_are_its_prototypes_tree_moved_by_its_transform(instanced, which, depth):
    blas = get_accelerator(instanced, "wrt", "sah", "cpu").blas[0]  # the one prototype's (no world-space meshes)
    levels = blas.depths()
    leaf = blas.prim_count > 0
    nodes = np.flatnonzero(leaf) if depth is None else np.flatnonzero((levels == depth) | (leaf & (levels < depth)))
    lowers, uppers = blas.lowers[nodes].astype(np.float64), blas.uppers[nodes].astype(np.float64)
    local = np.array([[np.where(bits, uppers[k], lowers[k]) for bits in itertools.product([0, 1], repeat=3)]
                      for k in range(len(nodes))])
    m = instanced.instances.to_world[1]
    expected = np.einsum("ij,bcj->bci", m[:3, :3], local) + m[:3, 3]
    options = {"bvh_leaves": True} if depth is None else {"bvh_depth": depth}
    plotter = wrt.preview(instanced, bvh_instance=which, window_size=(64, 48), show_lights=False, **options)
    try:
        drawn = np.asarray(plotter.actors["bvh"].mapper.dataset.points, np.float64).reshape(-1, 8, 3)
        assert len(drawn) == len(nodes)
        np.testing.assert_allclose(sorted_corners(drawn), sorted_corners(expected), rtol=1e-12, atol=1e-12)
        text = plotter.actors["summary"].GetText(2).replace("\n  ", " ")  # upper left; wrapped lines unwrapped
        assert "BLAS (sah) of instance /instances[1] (prototype /P" in text, text
    finally:
        plotter.close()


def test_the_blas_boxes_of_an_instance_of_an_off_centre_prototype_bound_its_triangles():
    """A prototype of 60 random triangles 40 of their sizes off its origin, whose BLAS is built about its box's
    centre (``wrt.tlas.blas_centres``): the leaf boxes drawn for a turned, stretched instance, taken back into
    prototype space through the instance's float64 inverse, hold every triangle of their leaves and together span
    the triangles' box. Drawn at ``to_world`` alone, they lay 40 sizes (moved by the instance) off the instance."""
    rng = np.random.default_rng(5)
    points = (rng.uniform(-1.0, 1.0, (180, 3)) + [40.0, -25.0, 10.0]).astype(np.float32)
    prototype = Prototype("/P", [Mesh("/P/soup", points, np.arange(180).reshape(60, 3), np.arange(60))])
    to_world = np.eye(4)
    to_world[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] @ np.diag([0.5, 2.0, 3.0])
    to_world[:3, 3] = (7.0, -3.0, 2.0)
    scene = wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms([0], to_world[None]))
    blas = get_accelerator(scene, "wrt", "sah", "cpu").blas[0]
    plotter = wrt.preview(scene, bvh_instance=0, bvh_leaves=True, window_size=(64, 48), show_lights=False)
    try:
        drawn = np.asarray(plotter.actors["bvh"].mapper.dataset.points, np.float64).reshape(-1, 8, 3)
    finally:
        plotter.close()
    local = (drawn - to_world[:3, 3]) @ np.linalg.inv(to_world[:3, :3]).T
    lowers, uppers = local.min(axis=1), local.max(axis=1)
    corners = points.astype(np.float64).reshape(60, 3, 3)
    slack = 1e-5 * np.abs(points).max()
    inside = ((corners.min(axis=1)[:, None] >= lowers[None] - slack)
              & (corners.max(axis=1)[:, None] <= uppers[None] + slack)).all(axis=2)
    assert len(drawn) == np.count_nonzero(blas.prim_count > 0)
    assert inside.any(axis=1).all(), np.flatnonzero(~inside.any(axis=1))
    np.testing.assert_allclose(lowers.min(axis=0), points.min(axis=0), atol=slack)
    np.testing.assert_allclose(uppers.max(axis=0), points.max(axis=0), atol=slack)


def test_bad_bvh_instances_are_refused_naming_the_choice(instanced):
    for which, needle in ((3, "the scene has 3 instances, 0 to 2"), ("/instances[7]", "names no instance"),
                          (True, "an instance index or path")):
        with pytest.raises(ValueError, match=needle):
            wrt.preview(instanced, bvh_leaves=True, bvh_instance=which, window_size=(32, 24))
    with pytest.raises(ValueError, match="give bvh_depth or bvh_leaves too"):
        wrt.preview(instanced, bvh_instance=0, window_size=(32, 24))
    lone = wrt.Scene(meshes=[Mesh("/T", np.eye(3, dtype=np.float32), np.int32([[0, 1, 2]]), [0])])
    with pytest.raises(ValueError, match="has no instances"):
        wrt.preview(lone, bvh_leaves=True, bvh_instance=0, window_size=(32, 24))


def test_cli_bvh_instance_needs_a_bvh_option(tmp_path, capsys, monkeypatch):
    """Refused before the scene loads (the bundled room), in the CLI's own option names."""
    monkeypatch.chdir(tmp_path)
    assert main(["preview", "--bvh-instance", "0", "-o", "x.png", "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "--bvh-instance 0 draws an instance's BVH boxes: give --bvh-depth K" in errors[0]


NESTED_USDA = """#usda 1.0
def PointInstancer "Outer" {
    point3f[] positions = [(0, 0, 0), (10, 0, 0)]
    int[] protoIndices = [0, 0]
    rel prototypes = </Outer/Protos/Row>
    def Scope "Protos" {
        def PointInstancer "Row" {
            point3f[] positions = [(0, 0, 0), (0, 3, 0)]
            int[] protoIndices = [0, 0]
            rel prototypes = </Outer/Protos/Row/Protos/Tri>
            def Scope "Protos" {
                def Mesh "Tri" {
                    int[] faceVertexCounts = [3]
                    int[] faceVertexIndices = [0, 1, 2]
                    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
                }
            }
        }
    }
}
"""


def test_a_path_that_names_several_instances_is_refused(tmp_path):
    """Instances of a PointInstancer nested in another's prototype are named by the outer instance: /Outer[0] holds
    both of its rows' triangles (the stage's two nested positions). Such a path named the first of them without a
    word, its BLAS drawn at one of two places; it is refused, naming the instances' indices to give instead."""
    path = tmp_path / "nested.usda"
    path.write_text(NESTED_USDA)
    scene = wrt.load_usd(path)
    rows = [i for i in range(len(scene.instances)) if scene.instances.path(i) == "/Outer[0]"]
    assert len(rows) == 2, [scene.instances.path(i) for i in range(len(scene.instances))]
    with pytest.raises(ValueError, match=rf"names 2 instances \({rows[0]}, {rows[1]}\)"):
        wrt.preview(scene, bvh_leaves=True, bvh_instance="/Outer[0]", window_size=(32, 24))


def test_cli_bad_bvh_instances_are_refused_naming_the_flag(tmp_path, capsys, monkeypatch):
    """Refused after the load, as the Python keyword is, but in the CLI's flag: ``--bvh-instance 5``, not
    ``bvh_instance=5`` (an option ``wrt preview`` does not have). The instance count is USD's own."""
    from pxr import Sdf, Usd, UsdGeom

    monkeypatch.chdir(tmp_path)
    stage = Usd.Stage.CreateNew(str(tmp_path / "pi.usda"))
    UsdGeom.Cube.Define(stage, "/Protos/Box")
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets([Sdf.Path("/Protos/Box")])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(0, 0, 0), (3, 0, 0)])
    UsdGeom.Sphere.Define(stage, "/Lone")
    stage.Save()
    n = len(pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default()))
    lone = Usd.Stage.CreateNew(str(tmp_path / "lone.usda"))
    UsdGeom.Sphere.Define(lone, "/Lone")
    lone.Save()
    for path, which, needle in (("pi.usda", "5", f"--bvh-instance 5: the scene has {n} instances, 0 to {n - 1}"),
                                ("pi.usda", "/PI[9]", "--bvh-instance /PI[9] names no instance"),
                                ("lone.usda", "0", "drawn with --bvh-depth K or --bvh-leaves alone")):
        assert main(["preview", path, "--bvh-leaves", "--bvh-instance", which, "-o", "x.png", "-q"]) == 2
        errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
        assert len(errors) == 1 and needle in errors[0] and "bvh_" not in errors[0], errors
    assert not (tmp_path / "x.png").exists()


MIXED_USDA = """#usda 1.0
def PointInstancer "PI" {
    point3f[] positions = [(0, 0, 0), (3, 0, 0), (6, 0, 0)]
    int[] protoIndices = [1, 0, 1]
    rel prototypes = [</PI/Protos/Tri>, </PI/Protos/Ball>]
    def Scope "Protos" {
        def Mesh "Tri" {
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }
        def Sphere "Ball" {
        }
    }
}
"""


def test_an_instance_without_a_blas_is_refused_first_naming_the_option_and_one_that_has_one(tmp_path, capsys,
                                                                                        monkeypatch):
    """/PI[0] is a Sphere gprim's instance (USD's protoIndices): an analytic shape, a TLAS entry with no BLAS. It was
    refused only after the scene, the rays and the whole TLAS were drawn and built, in words that named neither
    ``--bvh-instance`` nor an instance that has a BLAS. Now it is refused up front, naming the option and /PI[1], the
    instance of the triangle mesh, as one to give."""
    from pxr import Usd, UsdGeom

    monkeypatch.chdir(tmp_path)
    (tmp_path / "mixed.usda").write_text(MIXED_USDA)
    stage = Usd.Stage.Open(str(tmp_path / "mixed.usda"))
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    targets = pi.GetPrototypesRel().GetTargets()
    kinds = [stage.GetPrimAtPath(targets[k]).GetTypeName() for k in pi.GetProtoIndicesAttr().Get()]
    assert kinds == ["Sphere", "Mesh", "Sphere"]
    scene = wrt.load_usd(tmp_path / "mixed.usda")
    preview_module = importlib.import_module("wrt.preview")
    monkeypatch.setattr(preview_module, "get_accelerator", lambda *a, **k: pytest.fail("built the accelerator first"))
    with pytest.raises(ValueError, match=r"bvh_instance='/PI\[0\]'.*no BLAS.*such as '/PI\[1\]'"):
        wrt.preview(scene, bvh_leaves=True, bvh_instance="/PI[0]", window_size=(32, 24))
    assert main(["preview", "mixed.usda", "--bvh-depth", "1", "--bvh-instance", "2", "-o", "x.png", "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "--bvh-instance 2" in errors[0] and "'/PI[1]'" in errors[0], errors
    assert not (tmp_path / "x.png").exists()
