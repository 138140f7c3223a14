"""Attributes authored with another value type than their schema's (``float radius`` where UsdGeom says ``double``,
``double focalLength`` where it says ``float``, ``point3d[] points``), as files written as text by hand or by
exporters hold them, read as USD's typed readers read them: ``BBoxCache``, ``ComputeExtent``,
``UsdGeom.Camera.GetCamera`` and ``ComputePointsAtTime`` are the oracles, not wrt's own values."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402

GPRIMS = """#usda 1.0
def Sphere "FloatRadius" {
    float radius = 3
}
def Cube "IntSize" {
    int size = 5
    double3 xformOp:translate = (10, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cylinder "HalfHeight" {
    half height = 4
    double radius = 2
    double3 xformOp:translate = (20, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cone "DoubleCone" {
    double height = 3
    double radius = 1.5
    double3 xformOp:translate = (30, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Capsule "FloatSamples" {
    float radius.timeSamples = {1: 0.25}
    double3 xformOp:translate = (40, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Sphere "OverWeaker" {
    double3 xformOp:translate = (50, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""

WEAKER = """#usda 1.0
over "OverWeaker" {
    double radius = 2.5
}
"""


def _load(path, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(path), **kwargs)
    return scene, [str(w.message) for w in caught]


def test_gprim_sizes_of_another_type_than_the_schemas_are_read_as_bbox_cache_reads_them(tmp_path):
    """A ``float radius = 3`` sphere is of radius 1 to USD (``Get<double>`` passes the float over for the fallback)
    and so to usdview; wrt drew it of radius 3. A ``float radius`` over a weaker layer's ``double radius`` reads
    the weaker one. Each gprim's tessellation fills the world box ``BBoxCache`` computes for it."""
    (tmp_path / "weak.usda").write_text(WEAKER)
    text = GPRIMS.replace('def Sphere "OverWeaker" {', 'def Sphere "OverWeaker" {\n    float radius = 7')
    text = text.replace("#usda 1.0\n", "#usda 1.0\n(\n    subLayers = [@./weak.usda@]\n)\n", 1)
    path = tmp_path / "gprims.usda"
    path.write_text(text)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path, tessellate_gprims=256)
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    drawn = {mesh.path: mesh for mesh in scene.meshes}
    assert sorted(drawn) == sorted(str(p.GetPath()) for p in stage.Traverse())
    for path_, mesh in drawn.items():
        box = cache.ComputeWorldBound(stage.GetPrimAtPath(path_)).ComputeAlignedRange()
        lower, upper = np.array(box.GetMin()), np.array(box.GetMax())
        np.testing.assert_allclose(mesh.points.min(0), lower, atol=2e-3, err_msg=path_)
        np.testing.assert_allclose(mesh.points.max(0), upper, atol=2e-3, err_msg=path_)
    wrong = [m for m in messages if "schema" in m]
    assert len(wrong) == 1, messages
    for name in ("5 prim(s)", "/FloatRadius", "float radius = 3", "int size = 5", "half height = 4",
                 "float radius = 7", "float radius = 0.25"):
        assert name in wrong[0]



def test_a_value_block_of_another_type_than_the_schemas_blocks_weaker_opinions(tmp_path):
    """A ``float radius = None`` between a ``float radius = 3`` and a weaker layer's ``double radius = 4`` blocks
    the weaker value: a block is no value of any type, so USD's typed read stops there (``ComputeExtent`` gets no
    radius, where without the block it has 4) and UsdImaging draws its default radius, the schema's fallback 1;
    wrt passed over the float-typed block as a value of another type and drew radius 4."""
    (tmp_path / "weak.usda").write_text('#usda 1.0\nover "Ball" {\n    double radius = 4\n}\n')
    (tmp_path / "block.usda").write_text('#usda 1.0\nover "Ball" {\n    float radius = None\n}\n')
    path = tmp_path / "blocked.usda"
    path.write_text('#usda 1.0\n(\n    subLayers = [@./block.usda@, @./weak.usda@]\n)\n'
                    'def Sphere "Ball" {\n    float radius = 3\n}\n')
    stage = Usd.Stage.Open(str(path))
    ball = stage.GetPrimAtPath("/Ball")
    assert UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Sphere(ball), Usd.TimeCode.Default()) is None
    stage.GetRootLayer().subLayerPaths.remove("./block.usda")
    assert UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Sphere(ball), Usd.TimeCode.Default())[1][0] == 4
    stage.GetRootLayer().subLayerPaths.insert(0, "./block.usda")  # (load_usd opens this layer as it is held)
    scene, messages = _load(path, tessellate_gprims=256)
    (mesh,) = scene.meshes
    fallback = ball.GetPrimDefinition().GetAttributeFallbackValue("radius")
    np.testing.assert_allclose(mesh.points.max(0), [fallback] * 3, atol=2e-3)
    assert any("float radius = 3" in m for m in messages), messages

CAMERAS = """#usda 1.0
(
    subLayers = [@./weak.usda@]
)
def Camera "Mistyped" {
    double focalLength = 35
    int horizontalAperture = 36
    double verticalAperture = 24
    double horizontalApertureOffset = 2
    double2 clippingRange = (0.5, 50)
    double fStop = 2.8
    float focusDistance = 10
}
def Camera "Samples" {
    double focalLength.timeSamples = {1: 24}
    float horizontalAperture.timeSamples = {1: 30}
}
def Camera "Weaker" {
    double focalLength = 35
}
def Camera "Shapes" {
    float clippingRange = 3
    float[] clippingPlanes = [1, 2]
    float2 focalLength = (1, 2)
}
"""

CAMERAS_WEAKER = """#usda 1.0
over "Weaker" {
    float focalLength = 20
}
"""


@pytest.mark.parametrize("time", [None, 1.0])
def test_camera_values_of_another_type_than_the_schemas_are_read_as_get_camera_reads_them(tmp_path, time):
    """``double focalLength = 35`` is a 50 mm lens to ``GetCamera`` (and to usdview), a ``double`` over a weaker
    layer's ``float`` the weaker value at the default time (at a time code, the fallback); wrt read 35. A ``float
    clippingRange = 3`` (or a ``float[] clippingPlanes``) skipped the camera, which ``GetCamera`` reads with the
    fallback there."""
    (tmp_path / "weak.usda").write_text(CAMERAS_WEAKER)
    path = tmp_path / "cameras.usda"
    path.write_text(CAMERAS)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path, time=time)
    assert sorted(scene.cameras) == ["/Mistyped", "/Samples", "/Shapes", "/Weaker"]
    for name, loaded in scene.cameras.items():
        # time=None reads defaults at the default time, and values that have only samples at the first one
        usd_time = Usd.TimeCode(time) if time is not None else (
            Usd.TimeCode.EarliestTime() if name == "/Samples" else Usd.TimeCode.Default())
        gf = UsdGeom.Camera(stage.GetPrimAtPath(name)).GetCamera(usd_time)
        np.testing.assert_allclose(
            [loaded.focal_length, loaded.horizontal_aperture, loaded.vertical_aperture,
             loaded.horizontal_aperture_offset, loaded.vertical_aperture_offset, loaded.f_stop, loaded.focus_distance,
             *loaded.clipping_range, len(loaded.clipping_planes)],
            [gf.focalLength, gf.horizontalAperture, gf.verticalAperture, gf.horizontalApertureOffset,
             gf.verticalApertureOffset, gf.fStop, gf.focusDistance, gf.clippingRange.min, gf.clippingRange.max,
             len(gf.clippingPlanes)], rtol=1e-6, err_msg=name)
    wrong = [m for m in messages if "another type than the schema's" in m]
    assert len(wrong) == 1, messages
    for words in ("4 prim(s)", "double focalLength = 35", "int horizontalAperture = 36", "double2 clippingRange",
                  "float clippingRange = 3", "float[] clippingPlanes"):
        assert words in wrong[0], wrong[0]


POINTS = """#usda 1.0
def Mesh "Double" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3d[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
def Mesh "Half" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    half3[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]
}
def Mesh "Float3" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    float3[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
}
def Mesh "Sampled" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    double3[] points.timeSamples = {1: [(0, 0, 3), (1, 0, 3), (0, 1, 3)]}
}
def Points "Dots" {
    point3d[] points = [(0, 0, 4)]
    float[] widths = [0.5]
}
def Points "Kept" {
    point3f[] points = [(0, 0, 5)]
    float[] widths = [0.5]
}
def BasisCurves "Hair" {
    uniform token type = "linear"
    int[] curveVertexCounts = [2]
    point3d[] points = [(0, 0, 6), (1, 0, 6)]
    float[] widths = [0.1]
}
"""


@pytest.mark.parametrize("time", [None, 1.0])
def test_points_of_another_type_than_point3f_are_none_as_compute_points_at_time_reads_them(tmp_path, time):
    """USD reads no points from ``point3d[] points`` (``ComputePointsAtTime`` warns "no positions", ``BBoxCache``
    has an empty box, usdview draws nothing); wrt drew them. Such a prim is skipped with a warning naming the type,
    and a ``float3[]`` (the same type as ``point3f[]``) is drawn."""
    path = tmp_path / "points.usda"
    path.write_text(POINTS)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path, time=time)
    usd_time = Usd.TimeCode.Default() if time is None else Usd.TimeCode(time)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        read = sorted(str(p.GetPath()) for p in stage.Traverse()
                      if len(UsdGeom.PointBased(p).ComputePointsAtTime(usd_time, usd_time)) > 0)
    assert read == ["/Float3", "/Kept"]
    assert sorted(scene.prim_paths()) == read
    wrong = [m for m in messages if "another type than the schema's" in m]
    assert len(wrong) == 1, messages
    for words in ("5 prim(s)", "point3d[] points", "half3[] points", "double3[] points"):
        assert words in wrong[0], wrong[0]


TOKENS = """#usda 1.0
def Cylinder "StringAxis" {
    string axis = "X"
    double height = 4
}
def Mesh "StringOrientation" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    string orientation = "leftHanded"
    uniform token subdivisionScheme = "none"
    int doubleSided = 1
}
def Sphere "IntDoubleSided" {
    int doubleSided = 1
    string orientation = "leftHanded"
}
def Mesh "StringScheme" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 5), (1, 0, 5), (0, 1, 5)]
    uniform string subdivisionScheme = "none"
}
"""


def test_tokens_and_switches_of_another_type_are_the_schemas_fallbacks(tmp_path):
    """``string axis = "X"`` is the fallback axis Z to ``ComputeExtent`` (``Get<TfToken>`` passes the string over),
    and so a ``string orientation = "leftHanded"`` is rightHanded, an ``int doubleSided = 1`` single-sided and a
    ``string subdivisionScheme = "none"`` catmullClark (smooth) to USD's typed readers and Hydra: wrt read the text
    and the integer, drawing the cylinder along X, flipping the triangle and showing its back."""
    path = tmp_path / "tokens.usda"
    path.write_text(TOKENS)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path, tessellate_gprims=64)
    meshes = {mesh.path: mesh for mesh in scene.meshes}
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(stage.GetPrimAtPath("/StringAxis")),
                                                        Usd.TimeCode.Default())
    np.testing.assert_allclose(meshes["/StringAxis"].points.min(0), np.array(extent[0]), atol=1e-3)
    np.testing.assert_allclose(meshes["/StringAxis"].points.max(0), np.array(extent[1]), atol=1e-3)
    fallback = stage.GetPrimAtPath("/StringOrientation").GetPrimDefinition().GetAttributeFallbackValue
    assert (fallback("orientation"), fallback("doubleSided")) == ("rightHanded", False)
    triangle = meshes["/StringOrientation"]
    p0, p1, p2 = triangle.points[triangle.indices[0]].astype(np.float64)
    assert np.cross(p1 - p0, p2 - p0)[2] > 0  # rightHanded: counter-clockwise seen from +Z is the front
    assert triangle.double_sided is False and meshes["/IntDoubleSided"].double_sided is False
    sphere = meshes["/IntDoubleSided"]
    corners = sphere.points[sphere.indices].astype(np.float64)
    fronts = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert (np.einsum("ij,ij->i", fronts, corners.mean(1)) > 0).all()  # outwards, as rightHanded
    assert triangle.normals is None  # subdivisionScheme "none": face normals
    assert meshes["/StringScheme"].normals is not None  # catmullClark: smooth normals of the cage
    wrong = [m for m in messages if "another type than the schema's" in m]
    assert len(wrong) == 1, messages
    for words in ("4 prim(s)", "string axis = 'X'", "string orientation = 'leftHanded'", "int doubleSided = 1",
                  "string subdivisionScheme = 'none'"):
        assert words in wrong[0], wrong[0]


LIGHTS = """#usda 1.0
def SphereLight "Ball" {
    double inputs:radius = 3
}
def RectLight "Panel" {
    double inputs:width = 3
    int inputs:height = 4
}
def DiskLight "Disk" {
    half inputs:radius = 2
}
def CylinderLight "Tube" {
    double inputs:length = 5
    float inputs:radius = 0.25
}
"""


def test_light_sizes_of_another_type_than_the_schemas_are_read_as_compute_extent_reads_them(tmp_path):
    """``double inputs:radius = 3`` is a SphereLight of radius 0.5 to USD (its extent, from ``Get<float>``, and
    Hydra's typed reads); wrt lit the scene with a light of radius 3. Each light's size is the one its extent
    (``ComputeExtentFromPlugins``) has."""
    path = tmp_path / "lights.usda"
    path.write_text(LIGHTS)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path)
    lights = {light.path: light for light in scene.lights}
    default = Usd.TimeCode.Default()
    half = {name: np.array(UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(stage.GetPrimAtPath(name)),
                                                                      default)[1], np.float64)
            for name in lights}
    np.testing.assert_allclose(lights["/Ball"].radius, half["/Ball"][0], rtol=1e-6)
    np.testing.assert_allclose([lights["/Panel"].width, lights["/Panel"].height], 2 * half["/Panel"][:2], rtol=1e-6)
    np.testing.assert_allclose(lights["/Disk"].radius, half["/Disk"][0], rtol=1e-6)
    np.testing.assert_allclose([lights["/Tube"].length, lights["/Tube"].radius],
                               [2 * half["/Tube"][0], half["/Tube"][1]], rtol=1e-6)
    wrong = [m for m in messages if "another type than the schema's" in m]
    assert len(wrong) == 1, messages
    for words in ("4 prim(s)", "double inputs:radius = 3", "int inputs:height = 4", "half inputs:radius = 2",
                  "double inputs:length = 5"):
        assert words in wrong[0], wrong[0]


ORDERS = """#usda 1.0
(
    subLayers = [@./weak.usda@]
)
def Mesh "StringOrder" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    double3 xformOp:translate = (5, 0, 0)
    uniform string[] xformOpOrder = ["xformOp:translate"]
}
def Xform "OverWeaker" {
    double3 xformOp:translate = (0, 5, 0)
    float xformOp:rotateZ = 90
    uniform string[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    def Mesh "Child" {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
}
"""

ORDERS_WEAKER = """#usda 1.0
over "OverWeaker" {
    uniform token[] xformOpOrder = ["xformOp:rotateZ"]
}
"""


def test_an_xform_op_order_of_another_type_than_token_is_read_as_xform_cache_reads_it(tmp_path):
    """``uniform string[] xformOpOrder`` names no op to USD (``GetOrderedXformOps`` is empty, the cache's transform
    the identity), or over a weaker layer's ``token[]`` the weaker order; wrt applied the ops the text names."""
    (tmp_path / "weak.usda").write_text(ORDERS_WEAKER)
    path = tmp_path / "orders.usda"
    path.write_text(ORDERS)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path)
    cache = UsdGeom.XformCache()
    assert sorted(mesh.path for mesh in scene.meshes) == ["/OverWeaker/Child", "/StringOrder"]
    for mesh in scene.meshes:
        prim = stage.GetPrimAtPath(mesh.path)
        local = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get(), np.float64)
        world = np.c_[local, np.ones(len(local))] @ np.array(cache.GetLocalToWorldTransform(prim))
        np.testing.assert_allclose(mesh.points, world[:, :3], atol=1e-6, err_msg=mesh.path)
    wrong = [m for m in messages if "xformOpOrder" in m and "another type" in m]
    assert len(wrong) == 1 and "/StringOrder" in wrong[0] and "/OverWeaker" in wrong[0], messages


def test_an_empty_string_xform_op_order_over_a_weaker_token_one_is_read_as_xform_cache_reads_it(tmp_path):
    """An empty ``uniform string[] xformOpOrder = []`` is passed over by USD's typed read as a filled one is: the
    weaker layer's ``token[]`` order applies (``XformCache`` translates the child by (0, 7, 0)). Under a parent read
    op by op (its own string[] order), wrt took the empty text for no ops and drew the child untranslated."""
    (tmp_path / "weak.usda").write_text('#usda 1.0\nover "Parent" {\n    over "Child" {\n'
                                        '        uniform token[] xformOpOrder = ["xformOp:translate"]\n    }\n}\n')
    path = tmp_path / "orders.usda"
    path.write_text('#usda 1.0\n(\n    subLayers = [@./weak.usda@]\n)\ndef Xform "Parent" {\n'
                    '    double3 xformOp:translate = (5, 0, 0)\n'
                    '    uniform string[] xformOpOrder = ["xformOp:translate"]\n'
                    '    def Mesh "Child" {\n        double3 xformOp:translate = (0, 7, 0)\n'
                    '        uniform string[] xformOpOrder = []\n'
                    '        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n'
                    '        int[] faceVertexCounts = [3]\n        int[] faceVertexIndices = [0, 1, 2]\n    }\n}\n')
    stage = Usd.Stage.Open(str(path))
    scene, _ = _load(path)
    prim = stage.GetPrimAtPath("/Parent/Child")
    local = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get(), np.float64)
    world = np.c_[local, np.ones(len(local))] @ np.array(UsdGeom.XformCache().GetLocalToWorldTransform(prim))
    assert not np.allclose(world[:, :3], local)  # the weaker order's translate applies
    (mesh,) = scene.meshes
    np.testing.assert_allclose(mesh.points, world[:, :3], atol=1e-6)


def test_a_light_texture_of_another_type_over_a_weaker_asset_is_the_weaker_asset_resolved_from_its_layer(tmp_path):
    """A ``string inputs:texture:file`` over a weaker layer's ``asset inputs:texture:file = @./sky.png@`` is passed
    over for the weaker asset, which USD resolves against the layer that authors it (here a subfolder's). wrt took
    the weaker spec's default as it is, an asset path with no resolved path, and dropped the dome's texture as "not
    found". The oracle: USD's resolved path of the weaker opinion alone (the string one removed)."""
    from PIL import Image

    (tmp_path / "sub").mkdir()
    Image.fromarray(np.full((8, 16, 3), 200, np.uint8)).save(tmp_path / "sub" / "sky.png")
    (tmp_path / "sub" / "weak.usda").write_text('#usda 1.0\nover "Dome" {\n'
                                                '    asset inputs:texture:file = @./sky.png@\n}\n')
    path = tmp_path / "dome.usda"
    path.write_text('#usda 1.0\n(\n    subLayers = [@./sub/weak.usda@]\n)\n'
                    'def DomeLight "Dome" {\n    string inputs:texture:file = "elsewhere.png"\n}\n')
    scene, messages = _load(path)
    stage = Usd.Stage.Open(str(path))
    stage.GetRootLayer().GetPrimAtPath("/Dome").RemoveProperty(
        stage.GetRootLayer().GetPropertyAtPath("/Dome.inputs:texture:file"))
    resolved = stage.GetPrimAtPath("/Dome").GetAttribute("inputs:texture:file").Get().resolvedPath
    assert resolved.endswith("sky.png")
    (dome,) = [light for light in scene.lights if light.path == "/Dome"]
    assert dome.texture_path == resolved and dome.texture is not None, messages
    assert any("string inputs:texture:file = 'elsewhere.png'" in m for m in messages), messages
