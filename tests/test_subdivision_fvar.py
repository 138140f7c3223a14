"""Face-varying primvars through Catmull-Clark refinement, per ``faceVaryingLinearInterpolation``: seamless data against
the vertex masks (``catmark_reference``), data with seams against ``fvar_reference`` (OpenSubdiv's face-varying rules,
corner by corner) and, along a cut, against the boundary-curve rule written out in one dimension, ``all`` against
linear interpolation in each face; through ``load_usd`` and a render's texture lookup."""

from pathlib import Path

import numpy as np
import pytest
from catmark_reference import refine
from fvar_reference import curve, refine_face_varying

from wrt.subdivision import Refinement

MODES = ("none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all")
SMOOTH_MODES = MODES[:-1]

CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
PYRAMID = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], np.float64)
PYRAMID_FACES = [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]


def _smooth(p):
    """A smooth function of position, ``(V, 3) -> (V, 2)``: seamless face-varying data."""
    return np.stack([p[:, 0] + 0.3 * p[:, 1] ** 2, np.sin(p[:, 2]) + 0.5 * p[:, 0] * p[:, 1]], axis=-1)


def _grid(m, n):
    """Uniform ``(m + 1) x (n + 1)`` points in the plane z = 0 and the ``m x n`` quads over them."""
    x, y = np.meshgrid(np.arange(m + 1.0), np.arange(n + 1.0), indexing="ij")
    points = np.stack([x, y, np.zeros_like(x)], axis=-1).reshape(-1, 3)
    faces = [[i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1]
             for i in range(m) for j in range(n)]
    return points, faces


def _wrt(faces, data, levels, ids=None, mode="cornersPlus1", creases=None, corners=None, boundary="edgeAndCorner",
         triangle_smooth=False):
    """``Refinement.face_varying`` as ``(Q, 4, k)`` quad corners (the reference's order)."""
    counts = [len(f) for f in faces]
    indices = [v for f in faces for v in f]
    crease_args = corner_args = None
    if creases:
        crease_args = (np.array([v for e in creases for v in e]), np.full(len(creases), 2),
                       np.array(list(creases.values()), np.float64))
    if corners:
        corner_args = (np.array(list(corners)), np.array(list(corners.values()), np.float64))
    r = Refinement(counts, indices, max(indices) + 1, levels, crease_args, corner_args, boundary, triangle_smooth,
                   mode)
    return r.face_varying(data, ids).reshape(-1, 4, np.shape(data)[1])


def _corners_of(faces):
    return np.array([v for f in faces for v in f])


# Seamless data: the point's own masks.


@pytest.mark.parametrize("mode", SMOOTH_MODES)
@pytest.mark.parametrize("mesh", ["cube", "creased cube", "pyramid"])
def test_seamless_data_on_a_closed_mesh_refines_as_vertex_data(mode, mesh):
    """Every corner of a point holding the same value (a smooth function of the points, indexed by point): the values
    follow the points' masks, creases and corners included, in every mode but ``all``; they were linear in each
    face."""
    points, faces = (PYRAMID, PYRAMID_FACES) if mesh == "pyramid" else (CUBE, CUBE_FACES)
    creases = {(0, 1): 1.5, (1, 3): 10.0, (4, 5): 0.5} if mesh == "creased cube" else None
    corners = {6: 2.0} if mesh == "creased cube" else None
    data = _smooth(points)
    expected, _, _ = refine(faces, data, 3, creases=creases, corners=corners)
    got = _wrt(faces, data[_corners_of(faces)], 3, _corners_of(faces), mode, creases, corners)
    np.testing.assert_allclose(got, expected, atol=1e-12)


@pytest.mark.parametrize("boundary", ["edgeAndCorner", "edgeOnly"])
@pytest.mark.parametrize("mode", MODES)
def test_seamless_data_on_an_open_mesh_follows_the_modes_boundary_rules(mode, boundary):
    """On a grid's boundary the modes differ: with edgeAndCorner every mode but ``boundaries`` and ``all`` refines as
    the points do (its corners are pinned either way); with edgeOnly only ``none`` does, the others pin the corners
    of a single face the points round off; ``boundaries`` is linear along the boundary. All agree with the
    reference."""
    points, faces = _grid(3, 3)
    data = _smooth(points + np.random.default_rng(5).normal(0.0, 0.2, points.shape))
    got = _wrt(faces, data[_corners_of(faces)], 3, _corners_of(faces), mode, boundary=boundary)
    expected = refine_face_varying(faces, data[_corners_of(faces)], _corners_of(faces), 3, mode, boundary=boundary)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    as_points, _, _ = refine(faces, data, 3, boundary=boundary)
    follows_points = mode == "none" or (boundary == "edgeAndCorner" and mode not in ("boundaries", "all"))
    assert np.abs(got - as_points).max() < 1e-12 if follows_points else np.abs(got - as_points).max() > 1e-3
    corner = got[0, 0]  # the refined grid's first corner: the control corner (0, 0) unless it is rounded off
    assert np.array_equal(corner, data[0]) == (boundary == "edgeAndCorner" or mode != "none")


# Seams: OpenSubdiv's face-varying rules.


def _two_charts():
    """The cube cut into two charts along the six edges between them: the faces around point 0 and those around
    point 7, the second chart's values shifted (indexed by chart)."""
    corners = _corners_of(CUBE_FACES)
    chart = np.repeat([0, 1, 0, 1, 0, 1], 4)
    return CUBE_FACES, _smooth(CUBE)[corners] + chart[:, None] * [3.0, 0.0], corners * 2 + chart, {}


def _cut_grid(slit=False):
    """A 4 x 4 grid cut along the line j = 2 (the faces on either side hold different values there); ``slit``: only
    from the boundary to the grid's middle point, where the cut ends inside a chart (a dart)."""
    points, faces = _grid(4, 4)
    corners = _corners_of(faces)
    side = np.repeat([j >= 2 for i in range(4) for j in range(4)], 4)
    on_cut = points[corners, 1] == 2.0
    if slit:
        on_cut &= points[corners, 0] < 2.0
    moved = side & on_cut
    data = _smooth(points)[corners] + moved[:, None] * np.where(slit, 2.0 - points[corners, :1], 1.0) * [0.0, 1.0]
    return faces, data, corners * 2 + moved, {"boundary": "edgeOnly"}


CASES = {
    "two charts": _two_charts,
    "two charts creased": lambda: (*_two_charts()[:3], {"creases": {(0, 1): 1.5, (0, 2): 10.0, (4, 6): 0.5},
                                                         "corners": {7: 1.5}}),
    "cut grid": _cut_grid,
    "slit grid": lambda: _cut_grid(slit=True),
    # two values at the cut's middle point, one side's span holding a semi-sharp edge: the other is sharp with it
    "cut grid dependent": lambda: (*_cut_grid()[:3], {"creases": {(11, 12): 1.5}}),
    "pyramid chart": lambda: (PYRAMID_FACES, _smooth(PYRAMID)[_corners_of(PYRAMID_FACES)]
                              + np.repeat([0, 1, 0, 0, 0], [4, 3, 3, 3, 3])[:, None],
                              _corners_of(PYRAMID_FACES) * 2 + np.repeat([0, 1, 0, 0, 0], [4, 3, 3, 3, 3]),
                              {"triangle_smooth": True}),
}


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("case", CASES)
def test_seams_follow_opensubdivs_face_varying_rules(case, mode):
    """Charts cut apart (a closed cube in two, a grid cut across or slit to its middle, creases and corners on and
    next to the seams, triangles): each mode's values agree with the reference at every corner of every quad."""
    faces, data, ids, options = CASES[case]()
    got = _wrt(faces, data, 3, ids, mode, **options)
    np.testing.assert_allclose(got, refine_face_varying(faces, data, ids, 3, mode, **options), atol=1e-12)


@pytest.mark.parametrize("mode", ["cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries"])
def test_each_side_of_a_cut_follows_the_curve_rule_along_it(mode):
    """Along a cut across a grid each side's values are a curve of their own: the B-spline boundary rule with the
    ends (corners of one face each) pinned, or linear with ``boundaries``; the other side's values and the points
    around do not enter. Independent random values on each side of the cut and at every other point."""
    points, faces = _grid(4, 4)
    corners = _corners_of(faces)
    rng = np.random.default_rng(11)
    per_point = rng.random((len(points), 2))
    side = np.repeat([j >= 2 for i in range(4) for j in range(4)], 4)
    on_cut = points[corners, 1] == 2.0
    other_side = rng.random((len(points), 2))
    data = np.where((side & on_cut)[:, None], other_side[corners], per_point[corners])
    levels = 3
    got = _wrt(faces, data, levels, corners * 2 + (side & on_cut), mode).reshape(-1, 2)
    # The refined points on the cut (y = 2 by symmetry) in order along it, and the corners there on each side.
    refined = refine(faces, points, levels)[0].reshape(-1, 3)
    face_y = np.repeat(refine(faces, points, levels)[0].mean(axis=1)[:, 1], 4)
    cut = np.flatnonzero(np.abs(refined[:, 1] - 2.0) < 1e-12)
    for below, control in ((True, per_point), (False, other_side)):
        at = cut[(face_y[cut] < 2.0) == below]
        order = np.argsort(refined[at, 0], kind="stable")
        xs, values = refined[at[order], 0], got[at[order]]
        expected = curve(control[[i * 5 + 2 for i in range(5)]], levels, linear=mode == "boundaries")
        np.testing.assert_allclose(xs[np.r_[True, np.diff(xs) > 1e-9]], np.linspace(0, 4, len(expected)))
        for x, value in zip(xs, values):
            np.testing.assert_allclose(value, expected[int(round(x * 2**levels))], atol=1e-12)


def test_all_keeps_linear_interpolation_in_each_face():
    """``all``: each control face's values are refined alone and linearly (bilinear masks), as before."""
    rng = np.random.default_rng(2)
    for faces in (CUBE_FACES, PYRAMID_FACES, _grid(2, 3)[1]):
        data = rng.random((sum(map(len, faces)), 3))
        got = _wrt(faces, data, 3, mode="all")
        starts = np.cumsum([0] + [len(f) for f in faces])
        expected = [refine([list(range(len(f)))], data[starts[i]:starts[i + 1]], 3, linear=True)[0]
                    for i, f in enumerate(faces)]
        np.testing.assert_allclose(got, np.concatenate(expected), atol=1e-12)


# Through USD.


def _bind_texture(stage, mesh, file: str, raw=False):
    """Binds ``mesh`` a UsdPreviewSurface whose diffuseColor is the texture ``file`` looked up at ``primvars:st``."""
    from pxr import Sdf, UsdShade

    material = UsdShade.Material.Define(stage, "/Textured")
    surface = UsdShade.Shader.Define(stage, "/Textured/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    texture = UsdShade.Shader.Define(stage, "/Textured/Texture")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    if raw:
        texture.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    reader = UsdShade.Shader.Define(stage, "/Textured/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(texture.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def _cube_usda(path: Path, token=None, indexed=True) -> Path:
    """The two-chart cube with ``primvars:st`` (indexed by chart, or the same values unindexed) read by a textured
    material, ``faceVaryingLinearInterpolation`` authored as ``token``."""
    from PIL import Image
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    faces, data, ids, _ = _two_charts()
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Cube")
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE]))
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr(_corners_of(faces).tolist())
    if token is not None:
        mesh.CreateFaceVaryingLinearInterpolationAttr(token)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    if indexed:
        table, first = np.unique(ids, return_index=True)
        st.Set([Gf.Vec2f(*v) for v in data[first]])
        st.SetIndices(Vt.IntArray(np.searchsorted(table, ids).tolist()))
    else:
        st.Set([Gf.Vec2f(*v) for v in data])
    Image.new("RGB", (2, 2), (0, 255, 0)).save(path.parent / "green.png")
    _bind_texture(stage, mesh, "green.png")
    stage.Save()
    return path


def _loaded_quads(path, levels=2):
    """The loaded mesh's uvs per refined quad ``(Q, 4, 2)``, undoing the fan of each quad into two triangles (each
    refined point checked against the reference's)."""
    import wrt

    m = wrt.load_usd(path, refine_level=levels).meshes[0]
    tris = m.uvs.astype(np.float64).reshape(-1, 2, 3, 2)
    points = m.points[m.indices].astype(np.float64).reshape(-1, 2, 3, 3)
    expected_points, _, _ = refine(CUBE_FACES, CUBE, levels)
    np.testing.assert_allclose(points[:, 0], expected_points[:, :3], atol=1e-5)  # fan: (0 1 2), (0 2 3)
    np.testing.assert_allclose(points[:, 1], expected_points[:, [0, 2, 3]], atol=1e-5)
    return np.concatenate([tris[:, 0], tris[:, 1, 2:]], axis=1)


@pytest.mark.parametrize("token", [None, "none", "cornersOnly", "boundaries", "all"])
def test_load_usd_reads_face_varying_linear_interpolation(tmp_path, token):
    """``load_usd(refine_level=2)`` refines ``st`` as the mesh's ``faceVaryingLinearInterpolation`` says (unauthored:
    USD's fallback ``cornersPlus1``), with seams where its indices differ; unindexed, the same values are a value per
    face-vertex (seams everywhere), as Storm hands them to OpenSubdiv."""
    faces, data, ids, _ = _two_charts()
    mode = token or "cornersPlus1"
    got = _loaded_quads(_cube_usda(tmp_path / "indexed.usda", token))
    np.testing.assert_allclose(got, refine_face_varying(faces, data, ids, 2, mode), atol=2e-6)
    unindexed = _loaded_quads(_cube_usda(tmp_path / "flat.usda", token, indexed=False))
    np.testing.assert_allclose(unindexed, refine_face_varying(faces, data, np.arange(len(data)), 2, mode), atol=2e-6)


def test_an_unknown_face_varying_interpolation_warns_and_reads_the_fallback(tmp_path):
    """A token USD does not know (USD does not check allowed tokens) is read as the fallback, cornersPlus1, with a
    warning naming the mesh and the token."""
    with pytest.warns(UserWarning, match=r"faceVaryingLinearInterpolation is not.*read as cornersPlus1.*"
                                         r"'cornersPlusOne'.*/Cube"):
        got = _loaded_quads(_cube_usda(tmp_path / "bad.usda", "cornersPlusOne"))
    np.testing.assert_array_equal(got, _loaded_quads(_cube_usda(tmp_path / "good.usda", "cornersPlus1")))


def _textured_grid(path: Path, token) -> Path:
    """A flat 3 x 3 grid (interior points moved in its plane) whose seamless ``st`` (indexed by point) is its points'
    (x, y) / 3, under a raw texture whose red and green rise linearly with s and t."""
    from PIL import Image
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    points, faces = _grid(3, 3)
    inner = (points[:, 0] % 3 != 0) & (points[:, 1] % 3 != 0)
    points[inner, :2] += np.random.default_rng(4).uniform(-0.35, 0.35, (int(inner.sum()), 2))
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Grid")
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    mesh.CreateFaceVertexCountsAttr([4] * len(faces))
    mesh.CreateFaceVertexIndicesAttr(_corners_of(faces).tolist())
    if token is not None:
        mesh.CreateFaceVaryingLinearInterpolationAttr(token)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set([Gf.Vec2f(*(p[:2] / 3.0)) for p in points])
    st.SetIndices(Vt.IntArray(_corners_of(faces).tolist()))
    ramp = (np.arange(64) + 0.5) / 64.0  # texel centres: bilinear lookups give s and t back
    rgb = np.stack(np.broadcast_arrays(ramp[None, :], ramp[::-1, None], 0.0), axis=-1)  # row 0 is t = 1
    Image.fromarray(np.round(rgb * 255).astype(np.uint8)).save(path.parent / "ramp.png")
    _bind_texture(stage, mesh, "ramp.png", raw=True)
    stage.Save()
    return path


def _ramp_errors(path):
    """``|albedo.rg - (x, y) / 3|`` at the hits of an orthographic view down onto the grid, away from the texture's
    border texels."""
    import wrt

    scene = wrt.load_usd(path, refine_level=3)
    to_world = np.eye(4)
    to_world[:3, 3] = (1.5, 1.5, 5.0)
    camera = wrt.Camera(to_world=to_world, projection="orthographic", horizontal_aperture=32.0,
                        vertical_aperture=32.0)
    aovs = wrt.render(scene, camera=camera, width=40, height=40, integrator="albedo").aovs
    # The first sample's ray goes through the pixel's centre (rows from the top); the view spans 3.2 units.
    centres = (np.arange(40) + 0.5) / 40 * 3.2 - 1.6
    expected = np.stack(np.broadcast_arrays(1.5 + centres[None, :], 1.5 - centres[:, None]), axis=-1) / 3.0
    inside = (aovs["prim"].reshape(40, 40) >= 0) & (expected > 0.02).all(-1) & (expected < 0.98).all(-1)
    assert inside.sum() > 1000
    return np.abs(aovs["albedo"].reshape(40, 40, 3)[..., :2] - expected)[inside]


def test_a_refined_texture_lookup_follows_the_smoothed_surface(tmp_path):
    """Refined twice over, the grid's texture coordinates follow its points' masks (``cornersPlus1``, unauthored), so
    the texture seen at each hit is the one at its (x, y), as a planar projection of the refined surface gives;
    interpolated linearly in each control face (``all``, as every mode was read before) they kink at the control
    edges and miss it by up to about a tenth of a control face."""
    smooth = _ramp_errors(_textured_grid(tmp_path / "smooth.usda", None))
    assert smooth.max() < 0.006
    linear = _ramp_errors(_textured_grid(tmp_path / "linear.usda", "all"))
    assert linear.max() > 0.02


def _first_span_ends(faces, ids):
    """Brute force over the face-vertices (flat order) of ``faces`` holding value ``ids``: per (point, id), the first
    face-vertex whose leading edge, and the first whose trailing edge, does not join it to a face-vertex of the same
    value across an edge of two opposite faces (-1 where there is none); a dart's, its seam and the face-vertex
    across it."""
    flat = [(f, k) for f, face in enumerate(faces) for k in range(len(face))]
    flat_id = {fk: i for i, fk in enumerate(flat)}
    edge_faces = {}
    for f, face in enumerate(faces):
        for k in range(len(face)):
            edge_faces.setdefault(frozenset((face[k], face[(k + 1) % len(face)])), []).append(f)

    def across(f, k):  # the face-vertex at the same point across the leading edge, or None
        p, q = faces[f][k], faces[f][(k + 1) % len(faces[f])]
        if len(edge_faces[frozenset((p, q))]) != 2:
            return None
        for g, face in enumerate(faces):
            for j in range(len(face)):
                if g != f and face[j] == p and face[j - 1] == q:
                    return (g, j)
        return None

    lead_same = {fk: (a := across(*fk)) is not None and ids[flat_id[a]] == ids[flat_id[fk]] for fk in flat}
    trail_same = {across(*fk) for fk in flat if lead_same[fk]}
    start, end = {}, {}
    for i, (f, k) in enumerate(flat):
        value = (faces[f][k], ids[i])
        start.setdefault(value, -1)
        end.setdefault(value, -1)
        if not lead_same[(f, k)] and start[value] < 0:
            start[value] = i
        if (f, k) not in trail_same and end[value] < 0:
            end[value] = i
    # A dart (a value all around an interior point, one seam reaching it) spans from its seam round to it.
    for i, (f, k) in enumerate(flat):
        value = (faces[f][k], ids[i])
        ring = all(lead_same[fk] for j, fk in enumerate(flat) if (faces[fk[0]][fk[1]], ids[j]) == value)
        if ring and start[value] < 0:
            g, j = across(f, k)
            far_here = ids[flat_id[(f, (k + 1) % len(faces[f]))]]
            if far_here != ids[flat_id[(g, j - 1 if j else len(faces[g]) - 1)]]:  # a seam: the far end differs
                start[value], end[value] = i, flat_id[(g, j)]
    return start, end


def test_span_ends_are_the_first_face_vertex_of_each_value():
    """A value with several face-vertices that bound its span (two fans of one value at a bowtie's shared point) gets
    the first of them as its crease ends, as a brute-force loop finds them; it was assigned through repeated indices
    (``start[group[at]] = at``), whose winner numpy does not guarantee. A 2 x 2 grid beside it has one each, and a
    dart."""
    from wrt.subdivision_fvar import _classify

    faces = [[0, 1, 2], [0, 3, 4], [5, 6, 9, 8], [6, 7, 10, 9], [8, 9, 12, 11], [9, 10, 13, 12]]
    ids = [0] * 6 + [p for face in faces[2:] for p in face]
    ids[9] = 1  # a seam at point 8 between the grid's quads 0 and 2: a dart at point 9
    counts, indices = [len(f) for f in faces], np.concatenate(faces)
    level = Refinement(counts, indices, 14, 1).levels[0]
    keys = indices * (max(ids) + 1) + np.array(ids)
    unique, group = np.unique(keys, return_inverse=True)
    values = _classify(level, group.reshape(-1), np.zeros((len(unique), 2)), "cornersPlus1", True)
    start, end = _first_span_ends(faces, ids)
    expected = [(start[(k // (max(ids) + 1), k % (max(ids) + 1))], end[(k // (max(ids) + 1), k % (max(ids) + 1))])
                for k in unique]
    np.testing.assert_array_equal(np.stack([values.start, values.end], 1), expected)
