"""``wrt.subdivision`` against independent float64 oracles: the uniform bicubic B-spline masks on a regular grid, the
Catmull-Clark rules at extraordinary points written from the paper, and ``catmark_reference`` (OpenSubdiv's rules
point by point) on creases, corners, boundaries and non-manifold input."""

import numpy as np
import pytest
from catmark_reference import refine

from wrt.subdivision import Refinement


def _wrt_quads(faces, points, levels, creases=None, corners=None, boundary="edgeAndCorner", triangle_smooth=False):
    """The refined quads' corner points ``(Q, 4, k)`` and parent faces of ``wrt.subdivision.Refinement``."""
    counts = [len(f) for f in faces]
    indices = [v for f in faces for v in f]
    crease_args = corner_args = None
    if creases:
        crease_args = (np.array([v for edge in creases for v in edge]), np.full(len(creases), 2),
                       np.array(list(creases.values()), np.float64))
    if corners:
        corner_args = (np.array(list(corners)), np.array(list(corners.values()), np.float64))
    r = Refinement(counts, indices, len(points), levels, crease_args, corner_args, boundary=boundary,
                   triangle_smooth=triangle_smooth)
    return r.vertex(points)[r.face_indices.reshape(-1, 4)], r.parent_face, r


def _grid(m, n, seed=1):
    """``(m + 1) x (n + 1)`` points with random heights and the ``m x n`` quads over them (counter-clockwise)."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(m + 1.0), np.arange(n + 1.0), indexing="ij")
    points = np.stack([x, y, rng.normal(size=x.shape)], axis=-1).reshape(-1, 3)
    at = lambda i, j: i * (n + 1) + j  # noqa: E731
    faces = [[at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)] for i in range(m) for j in range(n)]
    return points, faces


def test_regular_interior_points_are_the_bicubic_bspline_masks():
    """One step on a regular region is B-spline knot insertion: vertex points (1/64)[1 6 1; 6 36 6; 1 6 1], edge
    points (1/16)[1 6 1; 1 6 1] across the edge, face points (1/4)[1 1; 1 1]. Quad ``4 f + k`` of the refined mesh
    is corner ``k`` of face ``f``: its vertex point, the point of its leading edge, the face point."""
    m = n = 6
    points, faces = _grid(m, n, seed=4)
    grid = points.reshape(m + 1, n + 1, 3)
    quads, _, _ = _wrt_quads(faces, points, 1)
    vertex_mask = np.outer([1, 6, 1], [1, 6, 1]) / 64.0
    checked = 0
    for f, face in enumerate(faces):
        i, j = divmod(f, n)
        for k in range(4):
            q = quads[4 * f + k]
            np.testing.assert_allclose(q[2], grid[i:i + 2, j:j + 2].mean(axis=(0, 1)), atol=1e-12)
            (ci, cj), (di, dj) = divmod(face[k], n + 1), divmod(face[(k + 1) % 4], n + 1)
            if 0 < ci < m and 0 < cj < n:
                expected = np.einsum("ab,abk->k", vertex_mask, grid[ci - 1:ci + 2, cj - 1:cj + 2])
                np.testing.assert_allclose(q[0], expected, atol=1e-12)
                checked += 1
            lo_i, lo_j = min(ci, di), min(cj, dj)
            if ci != di and 0 < cj < n:  # an edge along i: [1 6 1] across it, in j
                expected = np.einsum("ab,abk->k", np.outer([1, 1], [1, 6, 1]) / 16.0,
                                     grid[lo_i:lo_i + 2, cj - 1:cj + 2])
            elif cj != dj and 0 < ci < m:
                expected = np.einsum("ab,abk->k", np.outer([1, 6, 1], [1, 1]) / 16.0,
                                     grid[ci - 1:ci + 2, lo_j:lo_j + 2])
            else:
                continue
            np.testing.assert_allclose(q[1], expected, atol=1e-12)
            checked += 1
    assert checked == 4 * 25 + 2 * 60  # each interior point in 4 quads, each interior edge leads in 2


@pytest.mark.parametrize("valence", [3, 5, 6])
def test_extraordinary_vertex_follows_the_catmull_clark_rule(valence):
    """A fan of ``valence`` quads around a centre point: the centre moves to (n - 3)/n V + 2/n R + 1/n F, with R the
    mean of the edge midpoints and F the mean of the face points (Catmull and Clark 1978)."""
    rng = np.random.default_rng(valence)
    spokes = [np.array([np.cos(a), np.sin(a), 0.0]) for a in 2 * np.pi * np.arange(valence) / valence]
    points = [rng.normal(size=3) * 0.1]
    for k in range(valence):
        points.append(spokes[k] + rng.normal(size=3) * 0.1)  # edge end
        points.append(spokes[k] + spokes[(k + 1) % valence] + rng.normal(size=3) * 0.1)  # opposite corner
    points = np.array(points)
    faces = [[0, 1 + 2 * k, 2 + 2 * k, 1 + 2 * ((k + 1) % valence)] for k in range(valence)]
    quads, _, _ = _wrt_quads(faces, points, 1)
    v = points[0]
    r = np.mean([(v + points[1 + 2 * k]) / 2 for k in range(valence)], axis=0)
    f = np.mean([points[face].mean(axis=0) for face in faces], axis=0)
    n = valence
    np.testing.assert_allclose(quads[0, 0], (n - 3) / n * v + 2 / n * r + 1 / n * f, atol=1e-12)


def _row_crease(points_per_row, row, sharpness):
    """Crease edges along grid row ``row`` (point indices ``row * points_per_row + j``), each of ``sharpness``
    (a number or one per edge)."""
    ids = row * points_per_row + np.arange(points_per_row)
    values = np.broadcast_to(np.asarray(sharpness, np.float64), (len(ids) - 1,))
    return {(int(a), int(b)): float(s) for a, b, s in zip(ids[:-1], ids[1:], values)}


GRID_POINTS, GRID_FACES = _grid(4, 4)

CASES = {
    "grid": dict(levels=3),
    "grid edgeOnly": dict(levels=3, boundary="edgeOnly"),
    "crease 1 to the boundary": dict(levels=3, creases=_row_crease(5, 2, 1.0)),
    "crease 10 to the boundary": dict(levels=3, creases=_row_crease(5, 2, 10.0)),
    "crease 0.3 to the boundary": dict(levels=3, creases=_row_crease(5, 2, 0.3)),
    "crease 1.5 to the boundary": dict(levels=3, creases=_row_crease(5, 2, 1.5)),
    "crease 2.7 to the boundary": dict(levels=3, creases=_row_crease(5, 2, 2.7)),
    "crease of mixed sharpness": dict(levels=3, creases=_row_crease(5, 2, [0.5, 3.0, 1.5, 0.25])),
    "semi-sharp corner on an edgeOnly boundary": dict(levels=2, corners={2: 0.5}, boundary="edgeOnly"),
    "semi-sharp corner inside": dict(levels=3, corners={12: 1.5}),
    "semi-sharp corner on a crease": dict(levels=3, corners={12: 2.5}, creases={(11, 12): 10.0, (12, 13): 10.0}),
    "three semi-sharp edges at a point": dict(levels=3, creases={(7, 12): 3.0, (11, 12): 3.0, (12, 13): 0.5}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_grid_matches_the_opensubdiv_rules(case):
    """Semi-sharp creases and corners change rule as their sharpness runs out; OpenSubdiv blends the rule of the
    step before with the rule after by the mean sharpness of what turns smooth. A semi-sharp crease that reaches the
    boundary pinned the boundary point as a corner (all its sharpness counted, 3 sharp edges: corner) where it turns
    into the boundary's crease rule; a crease of sharpness 0.5 and 3 at a point was fully sharp (mean 1.75) where
    the 0.5 edge turns smooth; a semi-sharp corner on a boundary was blended with the interior's smooth rule."""
    kw = dict(CASES[case])
    levels = kw.pop("levels")
    got, parents, _ = _wrt_quads(GRID_FACES, GRID_POINTS, levels, **kw)
    expected, expected_parents, _ = refine(GRID_FACES, GRID_POINTS, levels, **kw)
    np.testing.assert_array_equal(parents, expected_parents)
    np.testing.assert_allclose(got, expected, atol=1e-12)


CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
PYRAMID = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], np.float64)
PYRAMID_FACES = [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]


@pytest.mark.parametrize("mesh", ["cube", "pyramid"])
def test_closed_meshes_match_the_opensubdiv_rules(mesh):
    points, faces = {"cube": (CUBE, CUBE_FACES), "pyramid": (PYRAMID, PYRAMID_FACES)}[mesh]
    got, _, _ = _wrt_quads(faces, points, 3)
    expected, _, _ = refine(faces, points, 3)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def _non_manifold_meshes():
    """Non-manifold and degenerate inputs: ``name -> (points, faces)``."""
    points, faces = GRID_POINTS, GRID_FACES
    flipped = [list(f) for f in faces]
    flipped[5] = flipped[5][::-1]
    repeated = [list(f) for f in faces]
    repeated[0] = [0, 5, 6, 6]
    small = (CUBE - CUBE[0]) * np.array([0.5, 0.7, 0.3]) + CUBE[7]  # its point 0 on the cube's point 7
    two_cubes = np.concatenate([CUBE, small[1:]])
    other = {0: 7, **{k: 7 + k for k in range(1, 8)}}
    fin = np.concatenate([points, [[2, 2, 5], [3, 2, 5]]])
    top = np.array([[2, j, 3.0 + 0.1 * j] for j in range(5)])
    n = len(points)
    return {
        "a face wound the other way": (points, flipped),
        "two cubes meeting at a point": (two_cubes, CUBE_FACES + [[other[v] for v in f] for f in CUBE_FACES]),
        "a face repeating a point": (points, repeated),
        "a point no face uses": (np.concatenate([points, [[9.0, 9.0, 9.0]]]), faces),
        "a fin on one edge": (fin, faces + [[12, 13, n + 1, n]]),
        "a fin along a whole row": (np.concatenate([points, top]),
                                    faces + [[10 + j, 11 + j, n + j + 1, n + j] for j in range(4)]),
    }


@pytest.mark.parametrize("case", list(_non_manifold_meshes()))
def test_non_manifold_input_is_sharp_as_opensubdiv_tags_it(case):
    """OpenSubdiv makes non-manifold edges and points infinitely sharp (a point along a fin keeps the crease rule).
    wrt refined them with the smooth rule: the edges of a face wound the other way and the point where two cubes meet
    were averaged over both sides, and a fin's points took the crease rule of its two boundary edges (0.54 off
    OpenSubdiv's points on the flipped face, 0.99 at the fin)."""
    points, faces = _non_manifold_meshes()[case]
    got, _, _ = _wrt_quads(faces, points, 2)
    expected, _, _ = refine(faces, points, 2)
    np.testing.assert_allclose(got, expected, atol=1e-12)


@pytest.mark.parametrize("creases", [{}, {(0, 1): 10.0, (1, 2): 10.0, (2, 3): 10.0, (3, 4): 10.0}])
def test_interpolate_boundary_none_makes_the_boundary_faces_holes(creases):
    """USD: with ``none`` "boundary faces are effectively treated as holes"; OpenSubdiv hides the faces at a
    boundary point unless its boundary edges are authored infinitely sharp, and refines the rest as ``edgeOnly``.
    A 4 x 4 grid keeps its middle 2 x 2 faces (with the first row's edges creased: the middle 3 x 2). wrt drew
    ``none`` as ``edgeOnly``, boundary faces included."""
    got, _, r = _wrt_quads(GRID_FACES, GRID_POINTS, 2, creases=creases, boundary="none")
    expected, _, holes = refine(GRID_FACES, GRID_POINTS, 2, creases=creases, boundary="none")
    np.testing.assert_allclose(got, expected, atol=1e-12)
    assert sorted(r.boundary_holes.tolist()) == sorted(holes)
    assert 16 - len(holes) == (6 if creases else 4)


def test_triangle_subdivision_rule_smooth_weighs_edges_next_to_triangles():
    """``triangleSubdivisionRule = smooth`` (OpenSubdiv's TRI_SUB_SMOOTH): the pyramid's triangle edges get face
    weights 0.47 (0.36 next to the quad) instead of 0.25; a creased edge stays the midpoint."""
    creases = {(0, 1): 0.5}
    got, _, _ = _wrt_quads(PYRAMID_FACES, PYRAMID, 2, creases=creases, triangle_smooth=True)
    expected, _, _ = refine(PYRAMID_FACES, PYRAMID, 2, creases=creases, triangle_smooth=True)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    plain, _, _ = refine(PYRAMID_FACES, PYRAMID, 2, creases=creases)
    assert np.abs(expected - plain).max() > 0.01


@pytest.mark.parametrize("interpolation", ["vertex", "varying", "uniform"])
def test_loaded_mesh_is_the_reference_refinement_moved_and_coloured(tmp_path, interpolation):
    """A cube under a scale and a translation, its points sampled at times 1 and 3, read at 2 with refine_level 2:
    the refined points are the reference refinement of the points USD interpolates, moved by USD's transform, each
    triangle inside a reference quad of its control face; a ``vertex`` displayColor follows the same masks, a
    ``varying`` one the bilinear ones, a ``uniform`` one is its control face's on every child quad."""
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    import wrt

    stage = Usd.Stage.CreateNew(str(tmp_path / "cube.usda"))
    xform = UsdGeom.Xform.Define(stage, "/X")
    xform.AddTranslateOp().Set(Gf.Vec3d(10, 0, 0))
    xform.AddScaleOp().Set(Gf.Vec3f(2, 1, 0.5))
    mesh = UsdGeom.Mesh.Define(stage, "/X/Cube")
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE]), 1)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE * [1.0, 2.0, 1.0]]), 3)
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([v for f in CUBE_FACES for v in f])
    colours = np.random.default_rng(7).random((6 if interpolation == "uniform" else 8, 3))
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, interpolation).Set(
        [Gf.Vec3f(*v) for v in colours])
    stage.Save()

    to_world = np.array(xform.ComputeLocalToWorldTransform(2.0), np.float64)  # row vectors: p' = [p 1] M
    expected, parents, _ = refine(CUBE_FACES, np.array(mesh.GetPointsAttr().Get(2.0), np.float64), 2)
    expected = expected @ to_world[:3, :3] + to_world[3, :3]  # (Q, 4, 3)

    m = wrt.load_usd(tmp_path / "cube.usda", refine_level=2, time=2.0).meshes[0]
    corners = m.points[m.indices].astype(np.float64)  # (T, 3, 3): two triangles per refined quad
    assert len(corners) == 2 * len(expected)
    close = np.linalg.norm(corners[:, :, None, None] - expected[None, None], axis=-1) < 2e-5  # (T, 3, Q, 4)
    assert close.any(axis=(2, 3)).all()  # every corner is a reference point
    quad = np.argmax(close.any(axis=3).all(axis=1), axis=1)  # the reference quad holding all three corners
    assert close.any(axis=3).all(axis=1)[np.arange(len(quad)), quad].all()
    np.testing.assert_array_equal(parents[quad], m.face_ids)
    if interpolation == "uniform":
        np.testing.assert_allclose(m.colors, np.repeat(colours[m.face_ids][:, None], 3, axis=1), atol=1e-6)
        return
    refined, _, _ = refine(CUBE_FACES, colours, 2, linear=interpolation == "varying")
    corner_in_quad = np.argmax(close[np.arange(len(quad)), :, quad], axis=-1)  # (T, 3)
    np.testing.assert_allclose(m.colors, refined[quad[:, None], corner_in_quad], atol=1e-6)
