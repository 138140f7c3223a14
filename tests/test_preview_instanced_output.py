"""What the preview draws of an instanced scene, against USD's own answer: every triangle's world corners (the
instancer's transforms from ``ComputeInstanceTransformsAtTime``, its parent's from ``XformCache``) and colour (the
authored displayColor, else the instance's, else the renderer's grey 0.5, through the sRGB formula in float64)."""

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import wrt  # noqa: E402
from wrt.preview import to_pyvista  # noqa: E402

SCENE = """#usda 1.0
(
    upAxis = "Z"
)
def Mesh "Floor"
{
    int[] faceVertexCounts = [3, 3]
    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
    point3f[] points = [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)]
    color3f[] primvars:displayColor = [(0.2, 0.4, 0.6)]
}
def Xform "Group"
{
    double3 xformOp:translate = (1, 2, 3)
    float xformOp:rotateZ = 30
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    def PointInstancer "PI"
    {
        rel prototypes = [</Group/PI/Painted>, </Group/PI/Plain>]
        int[] protoIndices = [0, 1, 0, 1, 1]
        point3f[] positions = [(0, 0, 1), (2, 0, 1), (0, 3, 1), (4, 4, 2), (-3, 1, 0)]
        quath[] orientations = [(1, 0, 0, 0), (0.7071068, 0, 0, 0.7071068), (1, 0, 0, 0), (0.5, 0.5, 0.5, 0.5),
                                (1, 0, 0, 0)]
        float3[] scales = [(1, 1, 1), (2, 1, 1), (1, 1, 0.5), (1, 1, 1), (0.5, 0.5, 0.5)]
        color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0.9, 0.05, 0.5), (0.01, 0.002, 0.3)] (
            interpolation = "vertex"
        )
        def Mesh "Painted"
        {
            int[] faceVertexCounts = [3, 3]
            int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0.5), (0, 1, 0)]
            color3f[] primvars:displayColor = [(0.7, 0.1, 0.1), (0.001, 0.5, 0.25)] (
                interpolation = "uniform"
            )
        }
        def Mesh "Plain"
        {
            int[] faceVertexCounts = [3, 3, 3]
            int[] faceVertexIndices = [0, 1, 2, 0, 3, 1, 1, 3, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0.3, 0.3, 1)]
        }
    }
}
"""


def srgb8(linear) -> np.ndarray:
    """The sRGB transfer function in float64, rounded to 8 bits."""
    c = np.asarray(linear, np.float64)
    encoded = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(np.maximum(c, 0.0), 1 / 2.4) - 0.055)
    return np.round(255.0 * encoded).astype(np.uint8)


def usd_triangles(path):
    """``(T, 3, 3)`` world corners and ``(T, 3)`` uint8 sRGB colours of the triangles, in wrt's order (the meshes,
    then the instances in index order), from USD's API alone."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.XformCache()
    grey = np.full(3, 0.5)

    def faces(mesh_prim):
        mesh = UsdGeom.Mesh(mesh_prim)
        points = np.array(mesh.GetPointsAttr().Get(), np.float64)
        tris = np.array(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        primvar = UsdGeom.PrimvarsAPI(mesh_prim).GetPrimvar("displayColor")
        colors = np.array(primvar.Get(), np.float64) if primvar and primvar.HasAuthoredValue() else None
        if colors is not None and len(colors) == 1:
            colors = np.repeat(colors, len(tris), axis=0)
        return points, tris, colors

    corners, colours = [], []
    floor = stage.GetPrimAtPath("/Floor")
    points, tris, colors = faces(floor)
    world = np.array(cache.GetLocalToWorldTransform(floor))
    corners.append((np.c_[points, np.ones(len(points))] @ world)[:, :3][tris])
    colours.append(colors)
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/Group/PI"))
    parent = np.array(cache.GetLocalToWorldTransform(instancer.GetPrim()))
    prototypes = instancer.GetPrototypesRel().GetTargets()
    tints = np.array(UsdGeom.PrimvarsAPI(instancer.GetPrim()).GetPrimvar("displayColor").Get(), np.float64)
    transforms = instancer.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default())
    for i, (index, matrix) in enumerate(zip(instancer.GetProtoIndicesAttr().Get(), transforms)):
        points, tris, colors = faces(stage.GetPrimAtPath(prototypes[index]))
        world = np.array(Gf.Matrix4d(matrix)) @ parent  # row vectors: the instance's, then its parent's
        corners.append((np.c_[points, np.ones(len(points))] @ world)[:, :3][tris])
        colours.append(colors if colors is not None else np.repeat(tints[i][None], len(tris), axis=0))
    colours = [grey[None].repeat(len(c), 0) if c is None else c for c in colours]
    return np.concatenate(corners), srgb8(np.concatenate(colours))


@pytest.fixture
def scene_path(tmp_path):
    path = tmp_path / "instanced.usda"
    path.write_text(SCENE)
    return path


def test_to_pyvista_draws_usds_world_triangles_in_their_display_colours(scene_path):
    corners, colours = usd_triangles(scene_path)
    blocks = to_pyvista(wrt.load_usd(scene_path))
    assert len(blocks) == 6  # the floor, then the five instances
    drawn = np.concatenate([np.asarray(b.points, np.float64)[b.regular_faces] for b in blocks])
    np.testing.assert_allclose(drawn, corners, rtol=0, atol=1e-5)
    np.testing.assert_array_equal(np.concatenate([b.cell_data["color"] for b in blocks]), colours)


def test_preview_draws_usds_world_triangles_in_their_display_colours(scene_path):
    corners, colours = usd_triangles(scene_path)
    plotter = wrt.preview(wrt.load_usd(scene_path), window_size=(64, 48), show_text=False)
    try:
        mesh = plotter.actors["scene"].mapper.dataset
        drawn = np.asarray(mesh.points, np.float64)[mesh.regular_faces]
        drawn_colours = np.asarray(mesh.cell_data["color"])
    finally:
        plotter.close()
    np.testing.assert_allclose(drawn, corners, rtol=0, atol=1e-5)
    np.testing.assert_array_equal(drawn_colours, colours)
