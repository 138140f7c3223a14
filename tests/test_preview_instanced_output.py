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


def naive_clustering(points, triangles, resolution: int):
    """Vertex clustering (Rossignac and Borrel 1993) written plainly: each point snapped to the mean of the points
    in its cell of a ``resolution``^3 grid over their bounds, triangles of fewer than three cells dropped, a repeat
    of the same three cells dropped, each kept one wound to face as its source. ``{(corner points): source row}``."""
    lower = points.min(axis=0)
    extent = (points.max(axis=0) - lower).max()
    cells = [tuple(np.minimum(((p - lower) * (resolution / extent)).astype(int), resolution - 1)) for p in points]
    members = {}
    for p, cell in zip(points, cells):
        members.setdefault(cell, []).append(p)
    means = {cell: np.mean(ps, axis=0) for cell, ps in members.items()}
    drawn, seen = {}, set()
    for row, tri in enumerate(triangles):
        corner_cells = [cells[k] for k in tri]
        if len(set(corner_cells)) < 3 or frozenset(corner_cells) in seen:
            continue
        seen.add(frozenset(corner_cells))
        a, b, c = (means[cell] for cell in corner_cells)
        source = np.cross(points[tri[1]] - points[tri[0]], points[tri[2]] - points[tri[0]])
        if np.dot(np.cross(b - a, c - a), source) < 0:
            b, c = c, b
        drawn[tuple(np.round(np.concatenate([a, b, c]), 9))] = row
    return drawn


def test_cluster_vertices_is_vertex_clustering_at_one_grid():
    """A wavy sheet of 1,800 triangles simplified to 400: the soup is the plain vertex clustering of one grid."""
    from wrt.preview import cluster_vertices

    u, v = np.meshgrid(np.linspace(0, 3, 31), np.linspace(0, 2, 31), indexing="ij")
    points = np.column_stack([u.ravel(), v.ravel(), 0.3 * np.sin(2 * u.ravel()) * np.cos(3 * v.ravel())])
    k = (np.arange(30)[:, None] * 31 + np.arange(30)[None]).ravel()
    triangles = np.concatenate([np.column_stack([k, k + 31, k + 1]), np.column_stack([k + 1, k + 31, k + 32])])
    rows = np.arange(len(triangles))
    p, i, r = cluster_vertices(points, triangles.astype(np.int32), rows[:, None], 400)
    assert 0 < len(i) <= 400
    drawn = {tuple(np.round(p[t].ravel(), 9)): int(row) for t, row in zip(i, r[:, 0])}
    assert any(naive_clustering(points, triangles, resolution) == drawn for resolution in range(2, 64))


def test_triangle_colors_of_runs_of_equal_colours_follow_each_rows_colour_and_material():
    """Rows of one colour in a row, broken by a NaN (no colour), a material or a colour that differs only in a
    corner: each row shows its own display colour (sRGB formula in float64)."""
    import types

    from wrt.preview import triangle_colors

    a, b = [0.2, 0.6, 0.01], [0.2, 0.6, 0.011]
    corners = [[a] * 3, [a] * 3, [[np.nan] * 3] * 3, [[np.nan] * 3] * 3, [a] * 3, [a] * 3, [a, a, b], [a] * 3]
    scene = wrt.Scene.from_triangles(np.eye(3), [[0, 1, 2]] * len(corners))
    scene.meshes[0].colors = np.array(corners, np.float32)
    scene.meshes[0].material_ids = np.array([-1, -1, -1, -1, 0, -1, -1, -1], np.int32)
    scene.materials = [types.SimpleNamespace(diffuse_color=np.array([1.0, 0.0, 0.0]), diffuse_from_display_color=False)]
    mean_ab = np.mean(np.array([a, a, b], np.float32), axis=0)
    expected = [a, a, [0.5] * 3, [0.5] * 3, [1, 0, 0], a, mean_ab, a]
    np.testing.assert_array_equal(triangle_colors(scene), srgb8(np.array(expected, np.float32)))
