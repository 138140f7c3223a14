"""Loop refinement (``wrt.loop_subdivision``, ``subdivisionScheme = "loop"``) and bilinear refinement
(``subdivisionScheme = "bilinear"``) of ``load_usd(refine_level=N)``: against ``loop_reference`` (the published masks,
point by point) and ``catmark_reference``'s bilinear masks, against properties that need no reference (flat patches,
linear precision on a regular lattice, the limit mask at an icosahedron's vertex, the exact bilinear patch), and the
USD side: primvars, holes, subsets, non-triangle faces, the memory check, a render."""

import itertools
import math

import numpy as np
import pytest
from catmark_reference import refine as catmark_refine
from fvar_reference import curve, refine_face_varying
from loop_reference import beta, refine
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import wrt
from wrt.loop_subdivision import LoopRefinement
from wrt.subdivision import BilinearRefinement

TETRA = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], np.float64)
TETRA_FACES = [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]
OCTA = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)
OCTA_FACES = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]


def _icosahedron():
    """The 12 points ``(0, +-1, +-phi)`` and their cyclic shifts, and the 20 triangles of edge 2, wound outward."""
    phi = (1.0 + math.sqrt(5.0)) / 2.0
    base = [(0.0, a, b * phi) for a in (-1, 1) for b in (-1, 1)]
    points = np.array([p[k:] + p[:k] for k in range(3) for p in base])
    faces = []
    for tri in itertools.combinations(range(12), 3):
        a, b, c = points[list(tri)]
        if all(np.isclose(np.linalg.norm(x - y), 2.0) for x, y in ((a, b), (b, c), (c, a))):
            faces.append(tri if np.dot(np.cross(b - a, c - a), a + b + c) > 0 else tri[::-1])
    assert len(faces) == 20
    return points, faces


ICOSA, ICOSA_FACES = _icosahedron()


def _triangle_grid(m, n, heights=None):
    """``(m + 1) x (n + 1)`` points over ``m x n`` squares cut along one diagonal direction (valence 6 inside)."""
    x, y = np.meshgrid(np.arange(m + 1.0), np.arange(n + 1.0), indexing="ij")
    z = np.zeros_like(x) if heights is None else heights
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    at = lambda i, j: i * (n + 1) + j  # noqa: E731
    faces = [f for i in range(m) for j in range(n)
             for f in ((at(i, j), at(i + 1, j), at(i + 1, j + 1)), (at(i, j), at(i + 1, j + 1), at(i, j + 1)))]
    return points, faces


def _wrt_triangles(faces, points, levels, creases=None, corners=None, boundary="edgeAndCorner",
                   face_varying="cornersPlus1"):
    """``(T, 3, k)`` corner values and parent faces of ``LoopRefinement``, creases and corners as dicts."""
    crease_args = corner_args = None
    if creases:
        crease_args = (np.array([v for edge in creases for v in edge]), np.full(len(creases), 2),
                       np.array(list(creases.values()), np.float64))
    if corners:
        corner_args = (np.array(list(corners)), np.array(list(corners.values()), np.float64))
    r = LoopRefinement([len(f) for f in faces], [v for f in faces for v in f], len(points), levels, crease_args,
                       corner_args, boundary, face_varying)
    return r.vertex(points)[r.face_indices.reshape(-1, 3)], r.parent_face, r


def test_tetrahedron_by_hand():
    """Valence 3: beta = 3/16, so a vertex point is 7/16 S + 3/16 (sum of the others) = S / 4 (the points sum to
    zero); an edge point is 3/8 (a + b) + 1/8 (c + d) = (a + b) / 4 (c + d = -(a + b))."""
    assert beta(3) == pytest.approx(3 / 16) and beta(6) == pytest.approx(1 / 16)
    triangles, parents, r = _wrt_triangles(TETRA_FACES, TETRA, 1)
    at_corners = np.array([[TETRA[a], TETRA[a] + TETRA[b], TETRA[a] + TETRA[c]]
                           for face in TETRA_FACES for a, b, c in zip(face, np.roll(face, -1), np.roll(face, 1))])
    corners = triangles.reshape(4, 4, 3, 3)[:, :3].reshape(-1, 3, 3)
    np.testing.assert_allclose(corners, at_corners / 4.0, atol=1e-15)
    np.testing.assert_array_equal(parents, np.repeat(np.arange(4), 4))
    assert (r.counts == 3).all() and len(r.counts) == 16


@pytest.mark.parametrize("mesh, levels", [("tetra", 3), ("octa", 2), ("icosa", 2)])
def test_closed_meshes_match_the_published_masks(mesh, levels):
    points, faces = {"tetra": (TETRA, TETRA_FACES), "octa": (OCTA, OCTA_FACES), "icosa": (ICOSA, ICOSA_FACES)}[mesh]
    points = points + np.random.default_rng(1).normal(scale=0.1, size=points.shape)  # no symmetry to hide behind
    got, parents, _ = _wrt_triangles(faces, points, levels)
    expected, expected_parents, _ = refine(faces, points, levels)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    np.testing.assert_array_equal(parents, expected_parents)


GRID_CASES = {
    "edgeAndCorner": {},
    "edgeOnly": {"boundary": "edgeOnly"},
    "none": {"boundary": "none"},
    "sharp crease": {"creases": {(6, 7): 10.0, (7, 8): 10.0, (8, 9): 10.0}},
    "semi-sharp crease": {"creases": {(6, 7): 1.5, (7, 8): 0.5, (8, 9): 2.0}},
    "crease to the boundary": {"creases": {(5, 6): 1.3, (6, 7): 1.3}},
    "corners": {"corners": {7: 10.0, 13: 0.6}},
}


@pytest.mark.parametrize("case", GRID_CASES)
def test_grid_with_a_boundary_matches_the_published_masks(case):
    """A 3 x 4 grid of 24 triangles with random heights: boundary edges 1/2 1/2, boundary points 1/8 3/4 1/8,
    corners kept (``edgeAndCorner``) or on the boundary curve (``edgeOnly``), the faces at boundary points holes
    (``none``), creases sharp and semi-sharp over three levels (sharpness dropping by one per level)."""
    heights = np.random.default_rng(4).normal(size=(4, 5))
    points, faces = _triangle_grid(3, 4, heights)
    options = GRID_CASES[case]
    got, parents, r = _wrt_triangles(faces, points, 3, **options)
    expected, expected_parents, holes = refine(faces, points, 3, **options)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    np.testing.assert_array_equal(parents, expected_parents)
    np.testing.assert_array_equal(r.boundary_holes, sorted(holes))
    assert (case == "none") == bool(len(holes))


def test_a_flat_patch_stays_flat():
    """A tilted planar patch of jittered triangles, with a crease and a corner: every mask is an affine
    combination, so every refined point stays on the plane."""
    rng = np.random.default_rng(8)
    flat, faces = _triangle_grid(5, 4)
    flat[:, :2] += rng.uniform(-0.2, 0.2, size=(len(flat), 2))
    normal = np.array([1.0, -2.0, 3.0]) / math.sqrt(14.0)
    basis = np.linalg.svd(normal[None])[2][1:]  # two unit vectors across the normal
    points = flat[:, :2] @ basis + 2.0 * normal
    triangles, _, _ = _wrt_triangles(faces, points, 3, creases={(7, 8): 1.5}, corners={12: 3.0})
    np.testing.assert_allclose(triangles @ normal, 2.0, atol=1e-12)


def test_a_regular_lattice_refines_to_the_half_lattice():
    """Points ``i u + j v`` of a lattice of equilateral triangles (valence 6 inside): the regular masks reproduce
    linear functions, so every refined point away from the grid's corners (which the boundary rules pull in) is a
    point of the lattice of half the spacing, on the plane."""
    m, n = 6, 6
    lattice, faces = _triangle_grid(m, n)
    u, v = np.array([1.0, 0.0, 0.0]), np.array([0.5, math.sqrt(3.0) / 2.0, 0.0])
    points = lattice[:, :1] * u + lattice[:, 1:2] * v
    r = LoopRefinement([3] * len(faces), [x for f in faces for x in f], len(points), 2)
    refined = r.vertex(points)
    ij = np.linalg.lstsq(np.stack([u[:2], v[:2]], axis=1), refined[:, :2].T, rcond=None)[0].T  # lattice coordinates
    inside = ((ij >= 1.0 - 1e-9) & (ij <= np.array([m, n]) - 1.0 + 1e-9)).all(axis=1)
    assert inside.sum() > 200
    np.testing.assert_allclose(refined[inside, 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(4.0 * ij[inside], np.round(4.0 * ij[inside]), atol=1e-12)


def test_icosahedron_vertices_converge_to_the_loop_limit_mask():
    """The limit of a smooth point of valence n is ``(1 - n chi) S + chi sum(ring)``, ``chi = 1 / (n + 3 / (8
    beta))`` (Loop 1987; Hoppe et al. 1994), from the control points alone. A vertex of a perturbed icosahedron
    (valence 5) refined 1 to 6 times approaches it geometrically."""
    points = ICOSA + np.random.default_rng(3).normal(scale=0.2, size=ICOSA.shape)
    faces = [v for f in ICOSA_FACES for v in f]
    ring = sorted({v for f in ICOSA_FACES if 0 in f for v in f} - {0})
    chi = 1.0 / (5 + 3.0 / (8.0 * beta(5)))
    limit = (1.0 - 5 * chi) * points[0] + chi * points[ring].sum(axis=0)
    errors = [np.linalg.norm(LoopRefinement([3] * 20, faces, 12, level).vertex(points)[0] - limit)
              for level in range(1, 7)]
    assert errors[0] > 0.05
    assert all(b < 0.5 * a for a, b in zip(errors, errors[1:]))
    assert errors[-1] < 1e-3


def test_all_keeps_face_varying_data_linear_in_each_triangle_and_varying_data_linear():
    """``faceVaryingLinearInterpolation = all``: face-varying data refine linearly within each triangle (the
    reference's linear masks on the triangles taken apart), even seamless ones; varying data linearly over the
    mesh."""
    rng = np.random.default_rng(6)
    points, faces = _triangle_grid(2, 3, rng.normal(size=(3, 4)))
    corners = np.array([v for f in faces for v in f])
    r = LoopRefinement([3] * len(faces), corners, len(points), 2, face_varying="all")
    apart = [(3 * k, 3 * k + 1, 3 * k + 2) for k in range(len(faces))]
    seamless = rng.normal(size=(len(points), 2))[corners]
    for fv, ids in ((rng.normal(size=(3 * len(faces), 2)), None), (seamless, corners)):
        expected, _, _ = refine(apart, fv, 2, linear=True)
        np.testing.assert_allclose(r.face_varying(fv, ids).reshape(-1, 3, 2), expected, atol=1e-12)
    data = rng.normal(size=(len(points), 3))
    expected, _, _ = refine(faces, data, 2, linear=True)
    np.testing.assert_allclose(r.varying(data)[r.face_indices.reshape(-1, 3)], expected, atol=1e-12)


# Face-varying data per faceVaryingLinearInterpolation, as OpenSubdiv applies it to Loop meshes.

FV_MODES = ("none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all")


def _smooth(p):
    """A smooth function of position, ``(V, 3) -> (V, 2)``: seamless face-varying data."""
    return np.stack([p[:, 0] + 0.3 * p[:, 1] ** 2, np.sin(p[:, 2]) + 0.5 * p[:, 0] * p[:, 1]], axis=-1)


def _wrt_face_varying(faces, data, ids, levels, mode, creases=None, corners=None, boundary="edgeAndCorner"):
    """``(T, 3, k)`` refined face-varying corner values of ``LoopRefinement``."""
    points = np.zeros((max(map(max, faces)) + 1, 1))
    r = _wrt_triangles(faces, points, levels, creases, corners, boundary, mode)[2]
    return r.face_varying(data, ids).reshape(-1, 3, np.shape(data)[1])
def _corners_of(faces):
    return np.array([v for f in faces for v in f])


CREASED_OCTA = {"creases": {(0, 2): 1.5, (2, 4): 10.0, (1, 5): 0.5}, "corners": {3: 2.0}}


@pytest.mark.parametrize("mode", FV_MODES[:-1])
@pytest.mark.parametrize("mesh", ["octahedron", "creased octahedron", "icosahedron"])
def test_seamless_face_varying_data_on_a_closed_loop_mesh_refines_as_vertex_data(mode, mesh):
    """Every corner of a point holding the same value (a smooth function of the points, indexed by point): the values
    follow Loop's masks at the points, creases and corners included, in every mode but ``all``, as OpenSubdiv
    refines them; they were linear in each triangle whatever the mode."""
    points, faces = (ICOSA, ICOSA_FACES) if mesh == "icosahedron" else (OCTA, OCTA_FACES)
    options = CREASED_OCTA if mesh == "creased octahedron" else {}
    data, corners = _smooth(points), _corners_of(faces)
    expected, _, _ = refine(faces, data, 3, **options)
    np.testing.assert_allclose(_wrt_face_varying(faces, data[corners], corners, 3, mode, **options), expected,
                               atol=1e-12)


def _octahedron_charts():
    """The octahedron cut along its equator into two charts (the faces at point 4, those at point 5), the second
    chart's values shifted (indexed by chart)."""
    corners = _corners_of(OCTA_FACES)
    chart = np.repeat([0, 0, 0, 0, 1, 1, 1, 1], 3)
    return OCTA_FACES, _smooth(OCTA)[corners] + chart[:, None] * [3.0, 0.0], corners * 2 + chart, {}


def _icosahedron_cap():
    """The five faces at the icosahedron's point 0 a chart of their own, bounded by five seam edges."""
    corners = _corners_of(ICOSA_FACES)
    cap = np.repeat([0 in f for f in ICOSA_FACES], 3)
    return ICOSA_FACES, _smooth(ICOSA)[corners] + cap[:, None] * [0.0, 2.0], corners * 2 + cap, {}


def _cut_triangle_grid(slit=False, **options):
    """A 4 x 4 triangle grid cut along the line y = 2 (the triangles on either side hold different values there);
    ``slit``: only from the boundary to the grid's middle point, where the cut ends inside a chart (a dart)."""
    points, faces = _triangle_grid(4, 4)
    corners = _corners_of(faces)
    side = np.repeat(points[np.array(faces)].mean(axis=1)[:, 1] > 2.0, 3)
    on_cut = points[corners, 1] == 2.0
    if slit:
        on_cut &= points[corners, 0] < 2.0
    moved = side & on_cut
    data = _smooth(points)[corners] + moved[:, None] * np.where(slit, 2.0 - points[corners, :1], 1.0) * [0.0, 1.0]
    return faces, data, corners * 2 + moved, options or {"boundary": "edgeOnly"}


def _seamless_grid(boundary):
    """A 3 x 3 triangle grid, seamless data of its jittered points: the modes differ on its boundary only."""
    points, faces = _triangle_grid(3, 3)
    corners = _corners_of(faces)
    data = _smooth(points + np.random.default_rng(5).normal(0.0, 0.2, points.shape))
    return faces, data[corners], corners, {"boundary": boundary}


FV_CASES = {
    "octahedron charts": _octahedron_charts,
    "octahedron charts creased": lambda: (*_octahedron_charts()[:3], CREASED_OCTA),
    "icosahedron cap": _icosahedron_cap,
    "cut grid": _cut_triangle_grid,
    "slit grid": lambda: _cut_triangle_grid(slit=True),
    # two values at the cut's middle point, one side's span holding a semi-sharp edge: the other is sharp with it
    "cut grid dependent": lambda: _cut_triangle_grid(creases={(11, 12): 1.5}),
    "seamless grid edgeAndCorner": lambda: _seamless_grid("edgeAndCorner"),
    "seamless grid edgeOnly": lambda: _seamless_grid("edgeOnly"),
}


@pytest.mark.parametrize("mode", FV_MODES)
@pytest.mark.parametrize("case", FV_CASES)
def test_loop_face_varying_data_follow_opensubdivs_rules(case, mode):
    """Charts cut apart on closed Loop meshes (the octahedron in two, a cap of the icosahedron), a triangle grid cut
    across or slit to its middle, creases and corners on and next to the seams, an open grid's boundary: each mode's
    values agree with the reference (OpenSubdiv's face-varying rules over Loop's masks) at every refined corner."""
    faces, data, ids, options = FV_CASES[case]()
    got = _wrt_face_varying(faces, data, ids, 3, mode, **options)
    expected = refine_face_varying(faces, data, ids, 3, mode, scheme="loop", **options)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def _diamond_grid():
    """4 x 4 squares cut along diagonals that meet at the middle point (mirror symmetric about x = 2 and y = 2): each
    end of the line y = 2 is a corner of one triangle on either side of it."""
    points, _ = _triangle_grid(4, 4)
    faces = []
    for i, j in itertools.product(range(4), range(4)):
        a, b, c, d = i * 5 + j, (i + 1) * 5 + j, (i + 1) * 5 + j + 1, i * 5 + j + 1
        faces += [(a, b, c), (a, c, d)] if (i < 2) == (j < 2) else [(a, b, d), (b, c, d)]
    return points, faces


@pytest.mark.parametrize("mode", ["cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries"])
def test_each_side_of_a_cut_across_a_loop_mesh_follows_the_curve_rule_along_it(mode):
    """Along a cut across a triangle grid each side's values are a curve of their own: the B-spline boundary rule
    with the ends (corners of one triangle each) pinned, or linear with ``boundaries``; the other side's values and
    the points around do not enter. Independent random values on each side of the cut and at every other point."""
    points, faces = _diamond_grid()
    corners = _corners_of(faces)
    rng = np.random.default_rng(11)
    per_point, other_side = rng.random((len(points), 2)), rng.random((len(points), 2))
    moved = np.repeat(points[np.array(faces)].mean(axis=1)[:, 1] > 2.0, 3) & (points[corners, 1] == 2.0)
    data = np.where(moved[:, None], other_side[corners], per_point[corners])
    levels = 3
    r = LoopRefinement([3] * len(faces), corners, len(points), levels, face_varying=mode)
    got = r.face_varying(data, corners * 2 + moved)
    # Where the refined corners lie, by linear refinement (exactly on the lattice of step 1 / 2^levels).
    at = r.varying(points)[r.face_indices]
    triangle_y = np.repeat(at.reshape(-1, 3, 3).mean(axis=1)[:, 1], 3)
    cut = np.flatnonzero(at[:, 1] == 2.0)
    for below, control in ((True, per_point), (False, other_side)):
        on = cut[(triangle_y[cut] < 2.0) == below]
        expected = curve(control[[i * 5 + 2 for i in range(5)]], levels, linear=mode == "boundaries")
        position = np.rint(at[on, 0] * 2**levels).astype(int)
        np.testing.assert_array_equal(np.unique(position), np.arange(len(expected)))
        np.testing.assert_allclose(got[on], expected[position], atol=1e-12)


def test_faces_of_more_than_three_corners_are_refused():
    with pytest.raises(ValueError, match="more than three corners"):
        LoopRefinement([3, 4], [0, 1, 2, 0, 2, 3, 4], 5, 1)


# Bilinear


def test_bilinear_quad_lies_on_its_bilinear_patch():
    """A non-planar quad ``B(u, v) = (1-u)(1-v) p0 + u(1-v) p1 + uv p2 + (1-u)v p3``: after N bilinear steps its
    points are exactly ``B(i / 2^N, j / 2^N)``, every one of them."""
    corners = np.array([[0.0, 0.0, 0.0], [2.0, 0.1, 0.5], [2.3, 1.9, -0.7], [-0.2, 1.5, 1.1]])
    for levels in (1, 3):
        r = BilinearRefinement([4], [0, 1, 2, 3], 4, levels)
        got = r.vertex(corners)
        t = np.arange(2**levels + 1) / 2**levels
        uu, vv = (g.reshape(-1, 1) for g in np.meshgrid(t, t, indexing="ij"))
        patch = (1 - uu) * (1 - vv) * corners[0] + uu * (1 - vv) * corners[1] + uu * vv * corners[2] \
            + (1 - uu) * vv * corners[3]
        assert len(got) == len(patch) and len(r.counts) == 4**levels
        nearest = np.linalg.norm(got[:, None] - patch[None], axis=-1).min(axis=1)
        np.testing.assert_allclose(nearest, 0.0, atol=1e-12)
        assert len(np.unique(np.round(got, 9), axis=0)) == len(patch)


def test_bilinear_splits_every_face_into_quads_as_opensubdiv():
    """A triangle, a quad and a pentagon: ``n`` quads per face of ``n`` corners over its edge midpoints and centroid
    (OpenSubdiv's bilinear scheme splits to quads), against ``catmark_reference``'s linear masks."""
    points = np.random.default_rng(2).normal(size=(8, 3))
    faces = [(0, 1, 2), (0, 2, 3, 4), (2, 5, 6, 7, 3)]
    r = BilinearRefinement([len(f) for f in faces], [v for f in faces for v in f], 8, 2)
    expected, parents, _ = catmark_refine(faces, points, 2, linear=True)
    np.testing.assert_allclose(r.vertex(points)[r.face_indices.reshape(-1, 4)], expected, atol=1e-12)
    np.testing.assert_array_equal(r.parent_face, parents)


# USD


def _mesh_stage(path, points, faces, scheme, **attrs):
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Mesh")
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    mesh.CreateFaceVertexCountsAttr([len(f) for f in faces])
    mesh.CreateFaceVertexIndicesAttr([int(v) for f in faces for v in f])
    mesh.CreateSubdivisionSchemeAttr(scheme)
    for name, value in attrs.items():
        mesh.GetPrim().GetAttribute(name).Set(value)
    stage.Save()
    return stage, mesh


@pytest.mark.parametrize("interpolation", ["vertex", "varying", "faceVarying", "uniform"])
def test_loaded_loop_mesh_is_the_reference_refinement_with_its_primvars_and_holes(tmp_path, interpolation):
    """An octahedron with ``subdivisionScheme = "loop"``, face 7 a hole, read with refine_level 2: its triangles are
    the reference's in order (a hole's 16 left out), ``Mesh.face_ids`` their control faces, and ``displayColor`` of
    each interpolation follows them: ``vertex`` by the Loop masks, ``varying`` and ``faceVarying`` linearly,
    ``uniform`` its control face's. Loop meshes were drawn as their cage with a warning."""
    points = OCTA * [1.0, 1.2, 0.8]
    stage, mesh = _mesh_stage(tmp_path / "octa.usda", points, OCTA_FACES, "loop", holeIndices=Vt.IntArray([7]))
    n_values = {"vertex": 6, "varying": 6, "faceVarying": 24, "uniform": 8}[interpolation]
    colours = np.random.default_rng(5).random((n_values, 3))
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, interpolation).Set(
        [Gf.Vec3f(*c) for c in colours])
    stage.Save()

    m = wrt.load_usd(tmp_path / "octa.usda", refine_level=2).meshes[0]
    expected, parents, _ = refine(OCTA_FACES, points, 2)
    drawn = parents != 7
    np.testing.assert_allclose(m.points[m.indices], expected[drawn], atol=1e-6)
    np.testing.assert_array_equal(m.face_ids, parents[drawn])
    if interpolation == "uniform":
        expected_colours = np.repeat(colours[parents[drawn]][:, None], 3, axis=1)
    elif interpolation == "faceVarying":
        apart = [(3 * k, 3 * k + 1, 3 * k + 2) for k in range(8)]
        expected_colours = refine(apart, colours, 2, linear=True)[0][drawn]
    else:
        expected_colours = refine(OCTA_FACES, colours, 2, linear=interpolation == "varying")[0][drawn]
    np.testing.assert_allclose(m.colors, expected_colours, atol=1e-6)
    assert m.normals is not None  # smooth normals of the refined points, as for catmullClark


@pytest.mark.parametrize("mode", ["none", "all"])
def test_a_loaded_loop_mesh_reads_face_varying_linear_interpolation(tmp_path, mode):
    """An indexed faceVarying ``displayColor`` of one value per point on a loop octahedron: with
    ``faceVaryingLinearInterpolation = none`` it refines as the points do (Loop's masks), with ``all`` linearly in each
    triangle. Loop meshes' face-varying data were linear whatever the mode."""
    stage, mesh = _mesh_stage(tmp_path / "octa.usda", OCTA, OCTA_FACES, "loop", faceVaryingLinearInterpolation=mode)
    colours = np.random.default_rng(3).random((6, 3))
    corners = _corners_of(OCTA_FACES)
    primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "faceVarying")
    primvar.Set([Gf.Vec3f(*c) for c in colours])
    primvar.SetIndices(Vt.IntArray([int(v) for v in corners]))
    stage.Save()
    m = wrt.load_usd(tmp_path / "octa.usda", refine_level=2).meshes[0]
    if mode == "none":
        expected = refine(OCTA_FACES, colours, 2)[0]
    else:
        expected = refine([(3 * k, 3 * k + 1, 3 * k + 2) for k in range(8)], colours[corners], 2, linear=True)[0]
    np.testing.assert_allclose(m.colors, expected, atol=1e-6)


def test_subsets_and_creases_of_a_loaded_loop_mesh(tmp_path):
    """A material bound to faces 2 and 5 by a subset binds their 16 child triangles each; crease and corner
    attributes and ``interpolateBoundary`` reach the Loop masks (against the reference)."""
    heights = np.random.default_rng(9).normal(size=(4, 5))
    points, faces = _triangle_grid(3, 4, heights)
    stage, mesh = _mesh_stage(tmp_path / "grid.usda", points, faces, "loop", interpolateBoundary="edgeOnly",
                              creaseIndices=Vt.IntArray([6, 7, 8]), creaseLengths=Vt.IntArray([3]),
                              creaseSharpnesses=Vt.FloatArray([1.5]), cornerIndices=Vt.IntArray([13]),
                              cornerSharpnesses=Vt.FloatArray([2.0]))
    material = UsdShade.Material.Define(stage, "/Red")
    shader = UsdShade.Shader.Define(stage, "/Red/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0, 0))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    subset = UsdGeom.Subset.CreateGeomSubset(mesh, "red", UsdGeom.Tokens.face, Vt.IntArray([2, 5]),
                                             familyName=UsdShade.Tokens.materialBind)
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(material)
    stage.Save()
    m = wrt.load_usd(tmp_path / "grid.usda", refine_level=2).meshes[0]
    expected, parents, _ = refine(faces, points, 2, creases={(6, 7): 1.5, (7, 8): 1.5}, corners={13: 2.0},
                                  boundary="edgeOnly")
    np.testing.assert_allclose(m.points[m.indices], expected, atol=1e-5)
    red = np.isin(parents, [2, 5])
    assert red.sum() == 32
    assert len(set(m.material_ids[red].tolist())) == 1
    assert set(m.material_ids[red].tolist()).isdisjoint(m.material_ids[~red].tolist())


def test_a_loop_mesh_with_quads_is_drawn_as_its_cage_with_a_warning_naming_it(tmp_path):
    """OpenSubdiv refuses a Loop mesh with faces of more than three corners ("non-triangular faces not supported by
    Loop scheme"); wrt draws its cage, smooth-shaded, and names it."""
    cube = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    _mesh_stage(tmp_path / "cube.usda", cube, quads, "loop")
    with pytest.warns(UserWarning, match=r"loop meshes with faces of more than three corners are not refined.*"
                                         r"drawn as their control cage.*/Mesh"):
        m = wrt.load_usd(tmp_path / "cube.usda", refine_level=2).meshes[0]
    assert len(m.indices) == 12 and m.normals is not None


def test_a_loop_refinement_past_the_memory_is_refused_naming_its_triangles(tmp_path, monkeypatch):
    import wrt.resources

    monkeypatch.setattr(wrt.resources, "available_host_bytes", lambda: 10 << 20)
    _mesh_stage(tmp_path / "octa.usda", OCTA, OCTA_FACES, "loop")
    with pytest.raises(MemoryError, match=rf"/Mesh: refine_level 6 \({8 * 4**6:,} triangles\) needs about"):
        wrt.load_usd(tmp_path / "octa.usda", refine_level=6)


def test_loaded_bilinear_mesh_is_refined_flat(tmp_path):
    """``subdivisionScheme = "bilinear"``: a non-planar quad next to a triangle, refined twice: 16 + 12 quads (32 +
    24 triangles), every point of the quad's on its bilinear patch, face normals (no smooth normals), creases
    ignored, a ``vertex`` colour interpolated linearly. Bilinear meshes were never refined."""
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 1], [0, 1, 0], [2, 0.5, 0]], np.float64)
    faces = [(0, 1, 2, 3), (1, 4, 2)]
    stage, mesh = _mesh_stage(tmp_path / "quad.usda", points, faces, "bilinear", creaseIndices=Vt.IntArray([0, 1]),
                              creaseLengths=Vt.IntArray([2]), creaseSharpnesses=Vt.FloatArray([10.0]))
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "vertex").Set(
        [Gf.Vec3f(*p) for p in points / 2.0])
    stage.Save()
    m = wrt.load_usd(tmp_path / "quad.usda", refine_level=2).meshes[0]
    assert len(m.indices) == 2 * (16 + 12) and m.normals is None
    corners = m.points[m.indices]
    on_quad = corners[m.face_ids == 0].reshape(-1, 3)
    np.testing.assert_allclose(on_quad[:, 2], on_quad[:, 0] * on_quad[:, 1], atol=1e-6)  # z = x y on this patch
    np.testing.assert_allclose(m.colors, corners / 2.0, atol=1e-6)  # linear data of linear data: the same map
    expected, parents, _ = catmark_refine(faces, points, 2, linear=True)
    assert len(np.unique(np.round(corners.reshape(-1, 3), 5), axis=0)) == len(
        np.unique(np.round(expected.reshape(-1, 3), 5), axis=0))


def _covered(triangles_xy, x, y):
    """``(P,)`` whether each point ``(x, y)`` lies in one of the triangles ``(T, 3, 2)`` (either winding)."""
    a, b, c = (triangles_xy[:, k][:, None] for k in range(3))
    p = np.stack([x, y], axis=-1)[None]

    def side(u, v):
        return (v[..., 0] - u[..., 0]) * (p[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (p[..., 0] - u[..., 0])

    s1, s2, s3 = side(a, b), side(b, c), side(c, a)
    inside = ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))
    return inside.any(axis=0)


def test_rendered_loop_octahedron_has_the_reference_silhouette_and_nears_its_limit(tmp_path):
    """An octahedron with ``subdivisionScheme = "loop"`` rendered through ``load_usd`` and ``render`` by an
    orthographic camera down -z (1 unit = 100 pixels): the cage's silhouette is the diamond |x| + |y| <= 1; refined 3
    times it is the reference refinement's triangles projected (pixels may differ on the outline only); and its
    half-width approaches the limit of the vertex (1, 0, 0), ``(1 - 4 chi) S + chi sum(ring)`` = 0.436 (valence 4,
    the ring sums to zero), from above, level by level."""
    stage, _ = _mesh_stage(tmp_path / "octa.usda", OCTA, OCTA_FACES, "loop")
    camera = UsdGeom.Camera.Define(stage, "/Camera")
    camera.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    camera.CreateHorizontalApertureAttr(24.0)  # tenths of a unit: 2.4 wide
    camera.CreateVerticalApertureAttr(24.0)
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    stage.Save()
    centres = (np.arange(240) + 0.5) / 100.0 - 1.2
    x, y = np.meshgrid(centres, -centres)  # row 0 at the top

    def silhouette(level):
        scene = wrt.load_usd(tmp_path / "octa.usda", refine_level=level)
        return wrt.render(scene, camera="/Camera", width=240, height=240, device="cpu").aovs["prim"] >= 0

    def half_width(hit):
        columns = np.flatnonzero(hit.any(axis=0))
        return (columns[-1] - columns[0] + 1) / 200.0

    cage = silhouette(0)
    assert half_width(cage) == pytest.approx(1.0, abs=0.01)
    off_outline = np.abs(np.abs(x) + np.abs(y) - 1.0) > 0.015  # pixel centres on the diamond's edges may go either way
    np.testing.assert_array_equal(cage[off_outline], (np.abs(x) + np.abs(y) < 1.0)[off_outline])

    refined = silhouette(3)
    expected = _covered(refine(OCTA_FACES, OCTA, 3)[0][..., :2], x.ravel(), y.ravel()).reshape(x.shape)
    near_outline = expected != (np.roll(expected, 1, 0) & np.roll(expected, -1, 0) & np.roll(expected, 1, 1)
                                & np.roll(expected, -1, 1))
    assert (refined == expected)[~near_outline].all() and (refined != expected).sum() < 0.01 * expected.sum()

    chi = 1.0 / (4 + 3.0 / (8.0 * beta(4)))
    limit = 1.0 - 4 * chi
    halves = [half_width(silhouette(level)) for level in (1, 2, 4)]
    assert halves[0] > halves[1] > halves[2] >= limit - 0.01 and halves[2] - limit < 0.01
