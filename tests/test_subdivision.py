"""Catmull-Clark refinement (``wrt.subdivision``, ``load_usd(refine_level=N)``): the masks against independent
derivations (the cube corner by hand, bicubic B-spline refinement on a regular grid, the cubic B-spline curve rule on
creases and boundaries), and the USD side: primvars, subsets, holes, creases, options."""

from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import wrt
from wrt.subdivision import Refinement

CUBE_POINTS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
CUBE_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])


def test_cube_corner_moves_to_five_ninths():
    # By hand for the corner (1, 1, 1) of [-1, 1]^3, valence 3: face points (1,0,0), (0,1,0), (0,0,1) average to
    # Q = 1/3; edge midpoints (1,1,0), (1,0,1), (0,1,1) average to R = 2/3; (Q + 2R + 0 S) / 3 = 5/9 per axis.
    r = Refinement([4] * 6, CUBE_FACES.reshape(-1), 8, 1)
    moved = r.vertex(CUBE_POINTS)[:8]
    np.testing.assert_allclose(moved, CUBE_POINTS * 5.0 / 9.0, atol=1e-12)
    assert len(r.counts) == 24 and (r.counts == 4).all()


def _torus_grid(m, n):
    """Quads of an m x n grid closed in both directions (every point of valence 4)."""
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    a = i * n + j
    b = ((i + 1) % m) * n + j
    c = ((i + 1) % m) * n + (j + 1) % n
    d = i * n + (j + 1) % n
    return np.stack([a, b, c, d], axis=-1).reshape(-1, 4)


def _bspline_refine(p, axis):
    """One step of periodic cubic B-spline subdivision along ``axis``: (1, 6, 1)/8 at the points, 1/2 between."""
    before, after = np.roll(p, 1, axis), np.roll(p, -1, axis)
    even = (before + 6.0 * p + after) / 8.0
    odd = 0.5 * (p + after)
    out = np.stack([even, odd], axis=axis + 1)
    shape = list(p.shape)
    shape[axis] *= 2
    return out.reshape(shape)


def test_regular_grid_refines_as_bicubic_bspline():
    m, n = 6, 7
    rng = np.random.default_rng(3)
    control = rng.normal(size=(m, n, 3))
    r = Refinement(np.full(m * n, 4), _torus_grid(m, n).reshape(-1), m * n, 2)
    refined = r.vertex(control.reshape(-1, 3))
    expected = control
    for _ in range(2):
        expected = _bspline_refine(_bspline_refine(expected, 0), 1)
    expected = expected.reshape(-1, 3)
    assert len(refined) == len(expected)
    order = np.lexsort(refined.T)
    np.testing.assert_allclose(refined[order], expected[np.lexsort(expected.T)], atol=1e-12)


def _open_grid(m, n, rng):
    """An (m + 1) x (n + 1) point patch of m x n quads with random heights."""
    x, y = np.meshgrid(np.arange(m + 1.0), np.arange(n + 1.0), indexing="ij")
    points = np.stack([x, y, rng.normal(size=x.shape)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    a = i * (n + 1) + j
    quads = np.stack([a, a + n + 1, a + n + 2, a + 1], axis=-1).reshape(-1)
    return points, quads


def test_boundary_follows_the_curve_rule_and_corners_stay():
    rng = np.random.default_rng(5)
    m, n = 4, 5
    points, quads = _open_grid(m, n, rng)
    edge_and_corner = Refinement(np.full(m * n, 4), quads, len(points), 1).vertex(points)
    edge_only = Refinement(np.full(m * n, 4), quads, len(points), 1, boundary="edgeOnly").vertex(points)
    corner = 0  # grid point (0, 0): neighbours along the boundary are points 1 and n + 1
    np.testing.assert_allclose(edge_and_corner[corner], points[corner])
    np.testing.assert_allclose(edge_only[corner], (6 * points[0] + points[1] + points[n + 1]) / 8)
    # A boundary point between corners: (a + 6 S + b) / 8 along the boundary, whatever the interior does.
    k = 2  # grid point (0, 2)
    np.testing.assert_allclose(edge_and_corner[k], (points[1] + 6 * points[2] + points[3]) / 8)
    interior_moved = points.copy()
    interior_moved[n + 2 :, 2] += 10.0  # every point off the x = 0 boundary row
    moved = Refinement(np.full(m * n, 4), quads, len(points), 1).vertex(interior_moved)
    np.testing.assert_allclose(moved[: n + 1], edge_and_corner[: n + 1])


def test_sharp_crease_ignores_its_neighbours_and_semi_sharp_blends():
    rng = np.random.default_rng(9)
    m, n = 4, 4
    points, quads = _open_grid(m, n, rng)
    row = 2 * (n + 1) + np.arange(n + 1)  # grid points (2, 0..4): an interior line of edges
    creases = (row, [len(row)], [10.0])
    counts = np.full(m * n, 4)
    sharp = Refinement(counts, quads, len(points), 1, creases=creases).vertex(points)
    k = row[2]
    np.testing.assert_allclose(sharp[k], (points[row[1]] + 6 * points[k] + points[row[3]]) / 8)
    pushed = points.copy()
    pushed[np.setdiff1d(np.arange(len(points)), row), 2] += 3.0
    np.testing.assert_allclose(Refinement(counts, quads, len(points), 1, creases=creases).vertex(pushed)[row[1:-1]],
                               sharp[row[1:-1]])
    smooth = Refinement(counts, quads, len(points), 1).vertex(points)
    half = Refinement(counts, quads, len(points), 1, creases=(row, [len(row)], [0.5])).vertex(points)
    np.testing.assert_allclose(half[k], 0.5 * (smooth[k] + sharp[k]))


def test_crease_sharpness_runs_out_after_its_levels():
    """Sharpness 1 is sharp for one step, then smooth: two steps differ from both the smooth and the sharp
    surface."""
    rng = np.random.default_rng(2)
    points, quads = _open_grid(4, 4, rng)
    row = 2 * 5 + np.arange(5)
    counts = np.full(16, 4)
    results = [Refinement(counts, quads, len(points), 2, creases=(row, [5], [s])).vertex(points) for s in (0, 1, 10)]
    assert not np.allclose(results[1], results[0]) and not np.allclose(results[1], results[2])


def test_bad_creases_are_refused():
    with pytest.raises(ValueError, match="creaseSharpnesses"):
        Refinement([4] * 6, CUBE_FACES.reshape(-1), 8, 1, creases=([0, 1, 3], [3], [1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="out of range"):
        Refinement([4] * 6, CUBE_FACES.reshape(-1), 8, 1, creases=([0, 9], [2], [1.0]))


# USD


def _cube_stage(path: Path, scheme="catmullClark", **attrs) -> Path:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/Cube")
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE_POINTS]))
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr(CUBE_FACES.reshape(-1).tolist())
    mesh.CreateSubdivisionSchemeAttr(scheme)
    for name, value in attrs.items():
        mesh.GetPrim().GetAttribute(name).Set(value)
    stage.GetRootLayer().Save()
    return path


def test_load_refines_catmull_clark_meshes_only(tmp_path):
    path = _cube_stage(tmp_path / "cube.usda")
    cage = wrt.load_usd(path)
    refined = wrt.load_usd(path, refine_level=2)
    assert len(cage.meshes[0].indices) == 12
    assert len(refined.meshes[0].indices) == 6 * 16 * 2
    points = refined.meshes[0].points
    radius = np.linalg.norm(points, axis=1)
    assert radius.max() < np.sqrt(3.0) - 0.1 and radius.min() > 0.7  # rounded, inside the cage
    assert (refined.meshes[0].face_ids >= 0).all() and set(refined.meshes[0].face_ids.tolist()) == set(range(6))
    none = wrt.load_usd(_cube_stage(tmp_path / "flat.usda", scheme="none"), refine_level=2)
    assert len(none.meshes[0].indices) == 12


def test_refined_cube_renders_round(tmp_path):
    """Orthographic rays down the axis: the cage's square silhouette becomes the rounded one of the refined
    surface, and the hit distance at the centre moves from the face (z = 1) to the refined surface."""
    path = _cube_stage(tmp_path / "cube.usda")
    xs = np.linspace(-0.99, 0.99, 41)
    grid = np.stack(np.meshgrid(xs, xs, indexing="ij"), -1).reshape(-1, 2)
    origins = np.concatenate([grid, np.full((len(grid), 1), 5.0)], axis=1).astype(np.float32)
    directions = np.tile(np.float32([0, 0, -1]), (len(grid), 1))
    cage = wrt.trace(wrt.load_usd(path), origins, directions)
    refined_scene = wrt.load_usd(path, refine_level=3)
    refined = wrt.trace(refined_scene, origins, directions)
    assert (cage.prim >= 0).all()
    corner = np.abs(grid).min(axis=1) > 0.85
    assert (refined.prim[corner] < 0).all() and (refined.prim[~corner & (np.abs(grid).max(axis=1) < 0.5)] >= 0).all()
    centre = np.argmin(np.linalg.norm(grid, axis=1))
    assert 5.0 - refined.t[centre] < 0.9  # the face's middle sinks below z = 1
    same = wrt.trace(refined_scene, origins, directions, accel="warp")  # rays on shared edges may pick either side
    np.testing.assert_array_equal(same.prim >= 0, refined.prim >= 0)
    np.testing.assert_allclose(same.t[same.prim >= 0], refined.t[refined.prim >= 0], rtol=1e-6)


def test_primvars_follow_the_refinement(tmp_path):
    path = tmp_path / "cube.usda"
    _cube_stage(path)
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Cube"))
    # vertex colours: red on the x = 1 side, blue on the other; smooth data stays within the hull of its values
    color = mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex)
    color.Set([Gf.Vec3f(1, 0, 0) if p[0] > 0 else Gf.Vec3f(0, 0, 1) for p in CUBE_POINTS])
    # face-varying uv: each face's corners (0,0), (1,0), (1,1), (0,1): linear in the face
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set([Gf.Vec2f(*c) for _ in range(6) for c in ((0, 0), (1, 0), (1, 1), (0, 1))])
    # a subset binding a material to face 2
    material = UsdShade.Material.Define(stage, "/Red")
    shader = UsdShade.Shader.Define(stage, "/Red/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0, 0))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    subset = UsdGeom.Subset.CreateGeomSubset(mesh, "red", UsdGeom.Tokens.face, Vt.IntArray([2]),
                                             familyName=UsdShade.Tokens.materialBind)
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(material)
    # a textured material on the whole mesh, so its st primvar is read
    from PIL import Image

    Image.new("RGB", (2, 2), (0, 255, 0)).save(tmp_path / "green.png")
    textured = UsdShade.Material.Define(stage, "/Textured")
    surface = UsdShade.Shader.Define(stage, "/Textured/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    texture = UsdShade.Shader.Define(stage, "/Textured/Texture")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("green.png")
    reader = UsdShade.Shader.Define(stage, "/Textured/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(texture.ConnectableAPI(), "rgb")
    textured.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(textured)
    mesh.CreateHoleIndicesAttr([5])
    stage.Save()

    scene = wrt.load_usd(path, refine_level=2)
    m = scene.meshes[0]
    assert len(m.indices) == 5 * 16 * 2  # the hole's 16 quads are not drawn
    assert 5 not in m.face_ids
    red = m.colors[..., 0]
    assert m.colors.min() >= 0.0 and m.colors.max() <= 1.0 + 1e-6
    x = m.points[m.indices][..., 0]
    assert (red[x > 0.5] > 0.5).all() and (red[x < -0.5] < 0.5).all()
    np.testing.assert_allclose(m.colors.sum(axis=-1), 1.0, atol=1e-6)  # red + blue = 1: an affine mix of the two
    assert m.uvs.min() >= 0.0 and m.uvs.max() <= 1.0
    assert np.isclose(m.uvs, 0.5).all(axis=-1).any()  # face centres reach the middle of their face's uv square
    on_face_2 = m.face_ids == 2
    assert on_face_2.sum() == 32
    assert len(set(m.material_ids[on_face_2].tolist())) == 1
    assert set(m.material_ids[on_face_2].tolist()).isdisjoint(m.material_ids[~on_face_2].tolist())


def test_crease_attributes_are_read(tmp_path):
    plain = wrt.load_usd(_cube_stage(tmp_path / "a.usda"), refine_level=2).meshes[0].points
    corners = wrt.load_usd(_cube_stage(tmp_path / "b.usda", **{"cornerIndices": Vt.IntArray([7]),
                                                              "cornerSharpnesses": Vt.FloatArray([10.0])}),
                           refine_level=2).meshes[0].points
    assert np.linalg.norm(plain, axis=1).max() < 1.5
    assert np.isclose(np.abs(corners).min(axis=1), 1.0).any()  # the sharp corner (1, 1, 1) stays where it is
    with pytest.warns(UserWarning, match="creases or corners"):
        bad = wrt.load_usd(_cube_stage(tmp_path / "c.usda", **{"creaseIndices": Vt.IntArray([0, 1]),
                                                               "creaseLengths": Vt.IntArray([3]),
                                                               "creaseSharpnesses": Vt.FloatArray([1.0])}),
                           refine_level=2).meshes[0].points
    np.testing.assert_allclose(bad, plain)


@pytest.mark.parametrize("attrs", [
    {"creaseIndices": Vt.IntArray([0, 1]), "creaseLengths": Vt.IntArray([2]),
     "creaseSharpnesses": Vt.FloatArray([float("nan")])},
    {"cornerIndices": Vt.IntArray([7]), "cornerSharpnesses": Vt.FloatArray([float("nan")])},
])
def test_a_nan_sharpness_is_ignored_with_a_warning_naming_the_mesh(tmp_path, attrs):
    """A NaN crease sharpness made every refined point NaN and the load failed ("/Cube: points are not finite after
    the world transform"); a NaN corner sharpness passed without a word. Both are ignored with the warning."""
    plain = wrt.load_usd(_cube_stage(tmp_path / "a.usda"), refine_level=2).meshes[0].points
    with pytest.warns(UserWarning, match=r"creases or corners that do not fit the mesh were ignored.*NaN.*/Cube"):
        bad = wrt.load_usd(_cube_stage(tmp_path / "nan.usda", **attrs), refine_level=2).meshes[0].points
    np.testing.assert_allclose(bad, plain)


def _refined_quad(path, **attrs):
    """Points of the unit quad ``/Quad`` with ``attrs`` authored, written to ``path`` and refined once."""
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    for attr, value in attrs.items():
        mesh.GetPrim().GetAttribute(attr).Set(value)
    stage.Save()
    return wrt.load_usd(path, refine_level=1).meshes[0].points


def test_bad_creases_keep_the_boundary_rule(tmp_path):
    """A quad with ``interpolateBoundary = edgeOnly`` and creases that do not fit: the creases are dropped, the
    boundary rule stays (its corners move by the curve rule, where edgeAndCorner pins them). The fallback
    refinement used to take edgeAndCorner whatever was authored."""
    edge_only = _refined_quad(tmp_path / "a.usda", interpolateBoundary="edgeOnly")
    assert not np.allclose(edge_only[0], (0, 0, 0))  # the corner moved
    with pytest.warns(UserWarning, match="creases or corners"):
        bad = _refined_quad(tmp_path / "b.usda", interpolateBoundary="edgeOnly", creaseIndices=Vt.IntArray([0, 1]),
                            creaseLengths=Vt.IntArray([3]), creaseSharpnesses=Vt.FloatArray([1.0]))
    np.testing.assert_array_equal(bad, edge_only)


def test_an_unknown_interpolate_boundary_is_read_as_edge_and_corner_with_a_warning(tmp_path):
    """A token USD does not know (a misspelt edgeAndCorner; USD does not check allowed tokens) is read as the
    fallback, edgeAndCorner, which pins the quad's corners, and named; it was drawn as edgeOnly without a word (the
    corner (0, 0) moved to (0.125, 0.125))."""
    with pytest.warns(UserWarning, match=r"interpolateBoundary is not.*read as edgeAndCorner.*'edgeAndCorners'.*/Quad"):
        misspelt = _refined_quad(tmp_path / "m.usda", interpolateBoundary="edgeAndCorners")
    np.testing.assert_array_equal(misspelt, _refined_quad(tmp_path / "c.usda", interpolateBoundary="edgeAndCorner"))
    np.testing.assert_array_equal(misspelt[0], (0, 0, 0))


def test_a_refinement_past_the_memory_is_refused_before_it_starts_naming_the_mesh(tmp_path, monkeypatch):
    """With 10 MiB free, refine_level 6 of the cube (6 * 4^6 quads, ~30 MiB to load) is a MemoryError naming the file,
    the mesh and the quads, raised before refining; it was refined until numpy failed without naming anything (or the
    system killed the load: refine_level 8 of a 10x10 grid wants ~8 GiB). Level 2 still fits."""
    import wrt.resources

    monkeypatch.setattr(wrt.resources, "available_host_bytes", lambda: 10 << 20)
    path = _cube_stage(tmp_path / "cube.usda")
    with pytest.raises(MemoryError, match=rf"cube.usda: /Cube: refine_level 6 \({6 * 4**6:,} quads\) needs about"):
        wrt.load_usd(path, refine_level=6)
    assert len(wrt.load_usd(path, refine_level=2).meshes[0].indices) == 6 * 16 * 2


@pytest.mark.parametrize("level", [-1, 9, True, 1.5, "2"])
def test_refine_level_is_checked(tmp_path, level):
    with pytest.raises(ValueError, match="refine_level"):
        wrt.load_usd(_cube_stage(tmp_path / "cube.usda"), refine_level=level)


def test_cli_refine_level(tmp_path, capsys):
    from wrt.cli import main

    path = _cube_stage(tmp_path / "cube.usda")
    out = tmp_path / "cube.png"
    assert main(["render", str(path), "-o", str(out), "--width", "32", "--height", "24", "--refine-level", "1",
                 "-q"]) == 0
    assert out.exists()
    with pytest.raises(SystemExit):
        main(["render", str(path), "-o", str(out), "--refine-level", "12"])
    assert "must be 0 to 8" in capsys.readouterr().err


def test_interpolate_boundary_none_hides_the_boundary_faces(tmp_path):
    """A 3 x 3 grid of quads with ``interpolateBoundary = none`` (USD: "boundary faces are effectively treated as
    holes"): only the middle face is drawn, its points those of ``edgeOnly``; it was drawn whole as ``edgeOnly``,
    with a warning."""
    def grid_stage(path, boundary):
        stage = Usd.Stage.CreateNew(str(path))
        mesh = UsdGeom.Mesh.Define(stage, "/Grid")
        mesh.CreatePointsAttr([(i, j, 0.1 * ((i * 7 + j * 3) % 5)) for i in range(4) for j in range(4)])
        mesh.CreateFaceVertexCountsAttr([4] * 9)
        mesh.CreateFaceVertexIndicesAttr([v for i in range(3) for j in range(3)
                                          for v in (4 * i + j, 4 * i + j + 4, 4 * i + j + 5, 4 * i + j + 1)])
        mesh.CreateInterpolateBoundaryAttr(boundary)
        stage.Save()
        return wrt.load_usd(path, refine_level=2).meshes[0]

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        none = grid_stage(tmp_path / "none.usda", "none")
    edge_only = grid_stage(tmp_path / "edge.usda", "edgeOnly")
    assert set(none.face_ids.tolist()) == {4} and len(none.indices) == 16 * 2
    middle = edge_only.face_ids == 4
    np.testing.assert_array_equal(none.points[none.indices], edge_only.points[edge_only.indices[middle]])


def test_triangle_subdivision_rule_is_read(tmp_path):
    """A tetrahedron with ``triangleSubdivisionRule = smooth``: an edge point between two triangles is
    0.03 (a + b) + 0.47 (F0 + F1) (OpenSubdiv's TRI_SUB_SMOOTH weights) where the standard rule gives
    (a + b + F0 + F1) / 4. The attribute was not read."""
    points = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], np.float64)
    faces = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]

    def refined(path, rule):
        stage = Usd.Stage.CreateNew(str(path))
        mesh = UsdGeom.Mesh.Define(stage, "/Tet")
        mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
        mesh.CreateFaceVertexCountsAttr([3] * 4)
        mesh.CreateFaceVertexIndicesAttr([v for f in faces for v in f])
        if rule:
            mesh.CreateTriangleSubdivisionRuleAttr(rule)
        stage.Save()
        return wrt.load_usd(path, refine_level=1).meshes[0].points

    a, b = points[0], points[1]  # edge 0-1 between faces 0 and 1
    f0, f1 = points[faces[0]].mean(axis=0), points[faces[1]].mean(axis=0)
    smooth = refined(tmp_path / "s.usda", "smooth")
    standard = refined(tmp_path / "c.usda", None)
    for got, expected in ((smooth, 0.03 * (a + b) + 0.47 * (f0 + f1)), (standard, (a + b + f0 + f1) / 4)):
        assert np.isclose(np.linalg.norm(got - expected, axis=1), 0.0, atol=1e-6).any()


@pytest.mark.parametrize("scheme", ["catmullClark", "loop", "bilinear"])
def test_a_mesh_with_no_face_of_three_corners_refines_to_nothing_beside_a_refined_one(tmp_path, scheme):
    """A mesh whose faces all have fewer than three corners draws nothing; refined, it stopped the whole load with an
    IndexError from the topology walk (numpy's, naming neither mesh nor file). The other mesh still refines."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "lines.usda"))
    for name, counts, indices in (("Lines", [2, 1], [0, 1, 2]), ("Tri", [3], [0, 1, 2])):
        mesh = UsdGeom.Mesh.Define(stage, f"/{name}")
        mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
        mesh.CreateFaceVertexCountsAttr(counts)
        mesh.CreateFaceVertexIndicesAttr(indices)
        mesh.CreateSubdivisionSchemeAttr(scheme)
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
        st.Set([(0, 0), (1, 0), (0, 1)])
        st.SetIndices(Vt.IntArray(indices))
    stage.Save()
    r = Refinement([2, 1], [0, 1, 2], 3, 2)
    assert len(r.counts) == 0 and len(r.face_indices) == 0
    by_path = {m.path: m for m in wrt.load_usd(tmp_path / "lines.usda", refine_level=1).meshes}
    assert "/Lines" not in by_path or len(by_path["/Lines"].indices) == 0
    assert len(by_path["/Tri"].indices) == (4 if scheme == "loop" else 6)


@pytest.mark.parametrize("scheme", ["catmullClark", "loop", "bilinear", "none"])
@pytest.mark.parametrize("refine_level", [0, 1])
def test_faces_of_fewer_than_three_corners_are_warned_about(tmp_path, scheme, refine_level):
    """Faces of 0, 1 or 2 corners draw nothing, refined or not; a warning names the file, the prim and how many (as
    Storm warns "degenerated face found"). Refined, they were dropped without a word; the triangle still draws."""
    path = tmp_path / "few.usda"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Few")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([2, 3, 0, 1])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 0, 1, 2, 2])
    mesh.CreateSubdivisionSchemeAttr(scheme)
    stage.Save()
    with pytest.warns(UserWarning, match=r"few\.usda: faces of fewer than three corners draw nothing: 1 prim\(s\) "
                                         r"\(3 of 4 faces: 1\): /Few"):
        (m,) = wrt.load_usd(path, refine_level=refine_level).meshes
    assert (m.face_ids == 1).all() and len(m.indices) == (1 if not refine_level or scheme == "none"
                                                          else 4 if scheme == "loop" else 6)
