"""UsdGeom.TetMesh drawn as its boundary triangles and UsdGeom.NurbsPatch tessellated: hits against ray-plane solves
and surfaces evaluated here from their definitions (a rational cylinder, a Bezier patch from the Bernstein basis), the
boundary against USD's own ``UsdGeom.TetMesh.ComputeSurfaceFaces``, orientation through back-face culling, colours of
every interpolation, time samples, and bad input."""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest
from pxr import Usd, UsdGeom, Vt
from usda_text import GOOD_QUAD, assert_skipped_as_if_removed, floats, fmt, load, preview_material, trace, write

import wrt

# A NURBS patch's triangles stay within this fraction of its control points' box diagonal (README).
PATCH_TOLERANCE = 1e-3


def ray_triangles(o, d, tris):
    """Nearest t > 0 of each ray with any of the triangles ``(F, 3, 3)`` (inf: none), by solving
    ``o + t d = a + s (b - a) + w (c - a)`` for every pair."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    best = np.full(len(o), np.inf)
    for f in range(len(tris)):
        m = np.stack([np.broadcast_to(-d, (len(o), 3)), np.broadcast_to(b[f] - a[f], (len(o), 3)),
                      np.broadcast_to(c[f] - a[f], (len(o), 3))], axis=2)
        t, s, w = np.linalg.solve(m, (o - a[f])[..., None])[..., 0].T
        ok = (t > 0) & (s >= 0) & (w >= 0) & (s + w <= 1)
        best = np.where(ok, np.minimum(best, t), best)
    return best


def tet_body(name, points, tets, extra=""):
    return (f'def TetMesh "{name}"\n{{\n    point3f[] points = {fmt(points)}\n'
            f"    int4[] tetVertexIndices = {fmt(tets)}\n{extra}}}\n")


# TetMesh

TET = np.array([(0.1, 0.2, 0.0), (2.0, 0.3, 0.2), (0.4, 1.9, -0.1), (0.6, 0.5, 1.7)])


def test_single_tet_surface_is_its_four_faces(tmp_path, np_rng):
    """A single tetrahedron draws its 4 faces: rays from random points around it toward random points inside hit
    where a numpy ray-plane solve over its 4 faces says (the nearest face, from outside)."""
    scene = load(write(tmp_path, tet_body("T", TET, [(0, 1, 2, 3)])))
    assert [len(m.indices) for m in scene.meshes] == [4]
    inside = np_rng.dirichlet(np.ones(4), 300) @ TET
    directions = np_rng.normal(size=(300, 3))
    origins = inside - 5 * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    expected = ray_triangles(origins, inside - origins, TET[[[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]])
    hits = trace(scene, origins, inside - origins)
    np.testing.assert_allclose(hits.t, expected, rtol=1e-5)
    assert np.isfinite(expected).all()


@pytest.mark.parametrize("orientation, order, front", [
    ("rightHanded", (0, 1, 2, 3), True),   # positive volume: faces outward
    ("rightHanded", (1, 0, 2, 3), False),  # inverted: faces inward, the near side culled
    ("leftHanded", (1, 0, 2, 3), True),    # leftHanded reverses the schema's face order: outward again
])
def test_tet_orientation_faces_outward_as_the_schema_orders_them(tmp_path, orientation, order, front):
    """A camera ray from outside meets the near face when the faces point outward; when they point inward
    (inverted for the orientation) it passes the culled near face and meets the far one (and a warning says so)."""
    extra = f'    uniform token orientation = "{orientation}"\n'
    path = write(tmp_path, tet_body("T", TET[list(order)], [(0, 1, 2, 3)], extra))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    said = any("inverted for their orientation" in str(w.message) and "/T" in str(w.message) for w in caught)
    assert said != front
    centre = TET.mean(axis=0)
    origin = centre + (0, 0, 5)
    cam = wrt.Camera.orthographic(tuple(origin), tuple(centre), height=0.01)
    img = wrt.render(scene, camera=cam, width=2, height=2)
    depth = float(img.aovs["depth"][1, 1])
    # The ray down through the centre crosses the faces at these distances (the near one is face 1 2 3).
    crossings = np.sort([t for t in [ray_triangles(origin[None], np.array([[0, 0, -1.0]]), TET[[f]])[0] for f in
                                     ([1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1])] if np.isfinite(t)])
    np.testing.assert_allclose(depth, crossings[0] if front else crossings[1], atol=0.01)  # pixel off the centre


def kuhn_cubes(n):
    """A tetrahedral mesh of an n x n x n grid of unit cubes, six positive tetrahedra per cube."""
    idx = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)
    cells = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    tets = []
    for perm in itertools.permutations(range(3)):
        path = [np.zeros(3, int)]
        for axis in perm:
            step = path[-1].copy()
            step[axis] += 1
            path.append(step)
        tet = np.stack([idx[tuple((cells + p).T)] for p in path], axis=1)
        # Make each tetrahedron positive (its parity follows the permutation).
        tets.append(tet if np.linalg.det(np.array(path[1:]) - path[0]) > 0 else tet[:, [1, 0, 2, 3]])
    points = np.stack(np.meshgrid(*[np.arange(n + 1.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    return points, np.concatenate(tets)


def test_tet_mesh_boundary_matches_usd_compute_surface_faces(tmp_path, np_rng):
    """A 3 x 3 x 3 cube of 162 shuffled tetrahedra draws exactly the triangles (and windings) that
    UsdGeom.TetMesh.ComputeSurfaceFaces returns, none of the inner ones; rays meet the cube's faces."""
    points, tets = kuhn_cubes(3)
    np_rng.shuffle(tets)
    scene = load(write(tmp_path, tet_body("T", points, tets)))
    stage = Usd.Stage.CreateInMemory()
    tet_mesh = UsdGeom.TetMesh.Define(stage, "/T")
    tet_mesh.GetTetVertexIndicesAttr().Set(Vt.Vec4iArray.FromNumpy(tets.astype(np.int32)))
    usd = np.array(UsdGeom.TetMesh.ComputeSurfaceFaces(tet_mesh, Usd.TimeCode.Default()))

    def cyclic(rows):  # each triangle rotated to start at its smallest index: windings compare
        rows = np.asarray(rows)
        k = rows.argmin(axis=1)
        return {tuple(np.roll(r, -i)) for r, i in zip(rows.tolist(), k)}

    (mesh,) = scene.meshes
    assert len(mesh.indices) == len(usd) == 6 * 9 * 2
    assert cyclic(mesh.indices) == cyclic(usd)
    xy = np_rng.uniform(0.05, 2.95, (50, 2))
    hits = trace(scene, np.column_stack([xy, np.full(50, 10.0)]), [(0, 0, -1)] * 50)
    np.testing.assert_allclose(hits.t, 7.0, rtol=1e-6)


def test_tet_mesh_colours_per_tet_and_per_point_and_a_material(tmp_path):
    """uniform displayColor: one per tetrahedron, its surface faces take it; vertex colours are interpolated
    across the faces; a bound material colours a third."""
    points = np.array([(0, 0, 0), (2, 0, 0), (0, 2, 0), (0, 0, 1), (2, 2, 0)], np.float64)
    # Two tetrahedra sharing the face (1, 2, 3); both positive.
    tets = [(0, 1, 2, 3), (4, 2, 1, 3)]
    uniform = '    color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "uniform")\n'
    vertex = ('    color3f[] primvars:displayColor = [(1, 0, 0), (1, 0, 0), (1, 0, 0), (1, 0, 0), (0, 1, 0)] '
              '(interpolation = "vertex")\n    double3 xformOp:translate = (0, 10, 0)\n'
              '    uniform token[] xformOpOrder = ["xformOp:translate"]\n')
    material = preview_material((0.1, 0.7, 0.3))
    bound = ('    rel material:binding = </M>\n    double3 xformOp:translate = (0, 20, 0)\n'
             '    uniform token[] xformOpOrder = ["xformOp:translate"]\n')
    body = (tet_body("U", points, tets, uniform) + tet_body("V", points, tets, vertex) + material
            + tet_body("B", points, tets, bound).replace('def TetMesh "B"', 'def TetMesh "B" (\n    prepend apiSchemas'
                                                          ' = ["MaterialBindingAPI"]\n)'))
    scene = load(write(tmp_path, body))
    # Looking down on the z = 0 bottoms is looking at their backs: look up from below instead.
    for (x, y), color in (((0.4, 0.4), (1, 0, 0)), ((1.6, 1.6), (0, 0, 1)), ((1.6, 11.6), (0.4, 0.6, 0)),
                          ((0.4, 20.4), (0.1, 0.7, 0.3))):
        cam = wrt.Camera.orthographic((x, y, -5), (x, y, 0), height=0.01)
        img = wrt.render(scene, camera=cam, width=2, height=2)
        np.testing.assert_allclose(img.aovs["albedo"][1, 1], color, atol=0.02)


def test_tet_mesh_points_move_with_time(tmp_path):
    """Simulation output: points with time samples are read at the time asked."""
    moved = TET + (0, 0, 3)
    body = ('def TetMesh "T"\n{\n'
            f"    point3f[] points.timeSamples = {{1: {fmt(TET)}, 2: {fmt(moved)}}}\n"
            "    int4[] tetVertexIndices = [(0, 1, 2, 3)]\n}\n")
    path = write(tmp_path, body)
    centre = TET.mean(axis=0)
    for time, shift in ((1, 0.0), (2, 3.0)):
        scene = load(path, time=time)
        hit = trace(scene, [centre + (0, 0, 10)], [(0, 0, -1)])
        near = ray_triangles((centre + (0, 0, 10))[None], np.array([[0, 0, -1.0]]), TET[[[1, 2, 3]]])[0]
        np.testing.assert_allclose(hit.t, near - shift, rtol=1e-5)


@pytest.mark.parametrize(
    "extra, tets, message",
    [
        ("", "[(0, 1, 2, 4)]", r"tetVertexIndices\[0\] = \(0, 1, 2, 4\) is out of range for 4 points"),
        ("", "[(0, 1, 2, 3), (0, -1, 2, 3)]", r"tetVertexIndices\[1\] = \(0, -1, 2, 3\) is out of range"),
    ],
)
def test_bad_tet_meshes_are_skipped_naming_the_prim(tmp_path, extra, tets, message):
    """A TetMesh with a tetVertexIndices entry out of range is skipped with a warning naming the file, the prim and
    the entry, the rest of the stage drawn as without it (it raised SceneError, which stopped the load)."""
    body = f'def TetMesh "T"\n{{\n    point3f[] points = {fmt(TET)}\n    int4[] tetVertexIndices = {tets}\n{extra}}}\n'
    path = write(tmp_path, body + GOOD_QUAD)
    assert_skipped_as_if_removed(path, "/T", message)


@pytest.mark.parametrize("extra, message", [
    ('    color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "uniform")\n',
     "displayColor has 2 values; uniform interpolation needs 1"),
    ('    color3f[] primvars:displayColor = [(1, 0, 0)] (interpolation = "faceVarying")\n',
     "displayColor has interpolation 'faceVarying'; TetMesh prims take constant, uniform, vertex, varying"),
])
def test_a_tet_mesh_colour_that_does_not_fit_is_dropped_with_a_warning(tmp_path, extra, message):
    """A TetMesh's displayColor of a length or interpolation it does not take is dropped (as Hydra drops such a
    primvar), the mesh drawn as without it, with a warning naming the file, the prim and the primvar; it stopped the
    load."""
    body = f'def TetMesh "T"\n{{\n    point3f[] points = {fmt(TET)}\n    int4[] tetVertexIndices = [(0, 1, 2, 3)]\n'
    path = write(tmp_path, body + extra + "}\n")
    unauthored = write(tmp_path, body + "}\n", name="unauthored.usda")
    with pytest.warns(UserWarning) as caught:
        scene = wrt.load_usd(path)
    (dropped,) = [str(w.message) for w in caught if "primvars that do not fit their prim" in str(w.message)]
    assert dropped.startswith(f"{path}: ") and dropped.endswith(": /T") and message in dropped, dropped
    (got,), (want,) = scene.meshes, load(unauthored).meshes
    assert got.colors is None and want.colors is None
    np.testing.assert_array_equal(got.indices, want.indices)

@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_tet_mesh_with_a_point_that_is_not_finite_is_skipped(tmp_path, bad):
    body = tet_body("T", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, bad)], [(0, 1, 2, 3)])
    path = write(tmp_path, body + GOOD_QUAD)
    assert_skipped_as_if_removed(path, "/T", rf"points\[3\] = \(0.0, 0.0, {bad}\) is not finite")


# NurbsPatch

S = math.sqrt(0.5)
CIRCLE = np.array([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)], np.float64)
CIRCLE_WEIGHTS = [1, S, 1, S, 1, S, 1, S, 1]
CIRCLE_KNOTS = [0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4]


def cylinder_body(radius=2.0, extra=""):
    """A NurbsPatch cylinder of radius ``radius`` about z, z from -1 to 1: the rational circle in u, linear in v."""
    points = [(radius * x, radius * y, z) for z in (-1.0, 1.0) for x, y in CIRCLE]
    return ('def NurbsPatch "P"\n{\n    int uVertexCount = 9\n    int vVertexCount = 2\n    int uOrder = 3\n'
            f"    int vOrder = 2\n    double[] uKnots = {floats(CIRCLE_KNOTS)}\n    double[] vKnots = [0, 0, 1, 1]\n"
            f"    double[] pointWeights = {floats(CIRCLE_WEIGHTS * 2)}\n    point3f[] points = {fmt(points)}\n"
            f"{extra}}}\n")


def test_rational_nurbs_patch_cylinder_is_a_cylinder(tmp_path, np_rng):
    """A cylinder patch (the rational circle swept along z): rays from its axis at random angles and heights meet
    it at its radius within the documented tolerance; rays past its ends miss."""
    scene = load(write(tmp_path, cylinder_body()))
    angles = np_rng.uniform(0, 2 * math.pi, 300)
    heights = np_rng.uniform(-0.99, 0.99, 300)
    d = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(300)])
    hits = trace(scene, np.column_stack([np.zeros((300, 2)), heights]), d)
    diagonal = math.sqrt(4**2 + 4**2 + 2**2)
    np.testing.assert_allclose(hits.t, 2.0, atol=PATCH_TOLERANCE * diagonal)
    past = trace(scene, [(0, 0, 1.1), (0, 0, -1.1)], [(1, 0, 0), (0, 1, 0)])
    assert np.isinf(past.t).all()


def test_nurbs_patch_faces_along_du_cross_dv_and_its_range(tmp_path):
    """rightHanded: the front is along dS/du x dS/dv, outward for this cylinder, so a camera outside sees the near
    wall (depth 3); leftHanded faces inward: the near wall is culled and the camera sees the far wall's inside
    (depth 7). uRange (0, 2) is the half at y >= 0."""
    for orientation, near in (("rightHanded", True), ("leftHanded", False)):
        scene = load(write(tmp_path, cylinder_body(extra=f'    uniform token orientation = "{orientation}"\n')))
        cam = wrt.Camera.orthographic((5, 0, 0), (0, 0, 0), height=0.01)
        depth = float(wrt.render(scene, camera=cam, width=2, height=2).aovs["depth"][1, 1])
        np.testing.assert_allclose(depth, 3.0 if near else 7.0, atol=0.01)
    half = load(write(tmp_path, cylinder_body(extra="    double2 uRange = (0, 2)\n")))
    hits = trace(half, [(0, 0, 0)] * 2, [(0, 1, 0), (0, -1, 0)])
    assert np.isfinite(hits.t[0]) and np.isinf(hits.t[1])


def bernstein(i, t):
    return math.comb(3, i) * t**i * (1 - t) ** (3 - i)


def test_bicubic_patch_hits_the_bernstein_surface(tmp_path, np_rng):
    """A 4 x 4 order-4 patch with knots [0 0 0 0 1 1 1 1] is a bicubic Bezier patch: rays down onto points of it,
    evaluated from the Bernstein basis (points u fastest), hit within the tolerance."""
    grid = np.array([(i, j, np_rng.uniform(-1, 1)) for j in range(4) for i in range(4)], np.float64)
    body = ('def NurbsPatch "P"\n{\n    int uVertexCount = 4\n    int vVertexCount = 4\n    int uOrder = 4\n'
            "    int vOrder = 4\n    double[] uKnots = [0, 0, 0, 0, 1, 1, 1, 1]\n"
            f"    double[] vKnots = [0, 0, 0, 0, 1, 1, 1, 1]\n    point3f[] points = {fmt(grid)}\n"
            '    uniform bool doubleSided = 1\n}\n')
    scene = load(write(tmp_path, body))
    uv = np_rng.uniform(0.02, 0.98, (100, 2))
    surface = np.array([sum(bernstein(i, u) * bernstein(j, v) * grid[j * 4 + i] for i in range(4) for j in range(4))
                        for u, v in uv])
    hits = trace(scene, surface + (0, 0, 10), [(0, 0, -1)] * 100)
    size = np.linalg.norm(grid.max(axis=0) - grid.min(axis=0))
    np.testing.assert_allclose(hits.t, 10.0, atol=PATCH_TOLERANCE * size * 4)  # vertical error of a tilted surface


def test_nurbs_patch_colours_uniform_varying_vertex(tmp_path):
    """A flat bilinear patch of 3 x 2 points (u fastest; two knot intervals in u): uniform colours each interval;
    varying (3 x 2 corners) changing along u only, and vertex colours changing along v only, are linear there
    (bilinear colours are drawn linear across the tessellation's triangles, exact for these); the trim curve
    warning names the prim."""
    points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
    head = ('    int uVertexCount = 3\n    int vVertexCount = 2\n    int uOrder = 2\n    int vOrder = 2\n'
            "    double[] uKnots = [0, 0, 1, 2, 2]\n    double[] vKnots = [0, 0, 1, 1]\n"
            f"    point3f[] points = {fmt(points)}\n")
    along_u = np.array([(1, 0, 0), (0, 1, 0), (0, 0, 1)] * 2, np.float64)
    along_v = np.array([(1, 0, 0)] * 3 + [(0, 0, 1)] * 3, np.float64)
    moved = '    double3 xformOp:translate = (0, {}, 0)\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n'
    body = (f'def NurbsPatch "U"\n{{\n{head}'
            '    color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "uniform")\n'
            "    int[] trimCurve:counts = [1]\n}\n"
            f'def NurbsPatch "V"\n{{\n{head}{moved.format(5)}'
            f'    color3f[] primvars:displayColor = {fmt(along_u)} (interpolation = "varying")\n}}\n'
            f'def NurbsPatch "W"\n{{\n{head}{moved.format(10)}'
            f'    color3f[] primvars:displayColor = {fmt(along_v)} (interpolation = "vertex")\n}}\n')
    with pytest.warns(UserWarning, match="trim curves .* are not applied.*/U"):
        scene = wrt.load_usd(write(tmp_path, body))
    expected = {(0.5, 0.5): (1, 0, 0), (1.5, 0.5): (0, 0, 1), (0.3, 5.7): (0.7, 0.3, 0), (1.6, 5.2): (0, 0.4, 0.6),
                (1.6, 10.2): (0.8, 0, 0.2), (0.3, 10.9): (0.1, 0, 0.9)}
    for (x, y), color in expected.items():
        cam = wrt.Camera.orthographic((x, y, 5), (x, y, 0), height=0.01)
        img = wrt.render(scene, camera=cam, width=2, height=2)
        np.testing.assert_allclose(img.aovs["albedo"][1, 1], color, atol=0.01)


@pytest.mark.parametrize(
    "change, message",
    [
        ((floats(CIRCLE_KNOTS), floats(CIRCLE_KNOTS[:-1])), "u: 11 knots; 9 control points of order 3 need 12"),
        (("double[] vKnots = [0, 0, 1, 1]", "double[] vKnots = [0, 0, 1, 0.5]"),
         r"v: knots decrease at 3 \(1 then 0.5\)"),
        (("int vVertexCount = 2", "int vVertexCount = 3"),
         "uVertexCount x vVertexCount = 9 x 3 but there are 18 points"),
        (("int uOrder = 3", "int uOrder = 1"), "u: order 1 is below 2"),
        (("double[] pointWeights = [1.0", "double[] pointWeights = [-1.0"),
         r"pointWeights\[0\] = -1 is not a positive"),
        (("(2.0, 0.0, -1.0)", "(nan, 0.0, -1.0)"), r"points\[0\] = \(nan, 0.0, -1.0\) is not finite"),
        (("double[] vKnots = [0, 0, 1, 1]", "double[] vKnots = [0, 0, 1, 1]\n    double2 vRange = (0.5, 2)"),
         r"v: range \(0.5, 2\) is not an interval inside the knots' domain \[0, 1\]"),
    ],
)
def test_bad_nurbs_patches_are_skipped_naming_the_prim(tmp_path, change, message):
    """A NurbsPatch whose counts, orders, knots, ranges, weights or points make no surface is skipped with a warning
    naming the file, the prim and the fault, the rest of the stage drawn as without it (it raised SceneError)."""
    body = cylinder_body()
    assert change[0] in body
    path = write(tmp_path, body.replace(change[0], change[1]) + GOOD_QUAD)
    assert_skipped_as_if_removed(path, "/P", message)


@pytest.mark.parametrize("authored, named", [('string[] tetVertexIndices = ["x"]', "tetVertexIndices must be int4"
                                              r"\[\], not string\[\]"),
                                             ('int uVertexCount = 2\n    int vVertexCount = 2\n    string uOrder = "x"',
                                              "uOrder must be an int, not string"),
                                             ('int uVertexCount = 2\n    int vVertexCount = 2\n    int uOrder = 2\n'
                                              '    string uKnots = "x"', "uKnots must be numbers, not string"),
                                             ('int uVertexCount = 2\n    int vVertexCount = 2\n    int uOrder = 2\n'
                                              '    int vOrder = 2\n    double[] uKnots = [0, 0, 1, 1]\n'
                                              '    double[] vKnots = [0, 0, 1, 1]\n    string[] pointWeights = ["x"]',
                                              r"pointWeights must be numbers, not string\[\]")])
def test_values_of_another_type_are_named_by_the_type_authored(tmp_path, authored, named):
    """A TetMesh's ``tetVertexIndices`` or a NurbsPatch's ``uOrder``, knots or ``pointWeights`` of another type skips
    the prim with a warning naming the attribute and the type the file authors: the message named the schema's type
    ("tetVertexIndices must be int4[], not int4[]", "uOrder must be an int, not int"), and string knots or weights
    raised "could not convert string to float", naming no attribute; the SceneError stopped the load."""
    kind = "TetMesh" if "tet" in authored else "NurbsPatch"
    body = (f'def {kind} "Bad"\n{{\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)]\n'
            f"    {authored}\n}}\n")
    assert_skipped_as_if_removed(write(tmp_path, body + GOOD_QUAD), "/Bad", named)
