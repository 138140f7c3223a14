"""Face-varying primvars through Catmull-Clark refinement, per ``faceVaryingLinearInterpolation``: seamless data against
the vertex masks (``catmark_reference``), data with seams against ``fvar_reference`` (OpenSubdiv's face-varying rules,
corner by corner) and, along a cut, against the boundary-curve rule written out in one dimension, ``all`` against
linear interpolation in each face."""

import numpy as np
import pytest
from catmark_reference import refine
from fvar_reference import refine_face_varying

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


def _curve(values, levels, linear):
    """A polyline's points after ``levels`` steps of the boundary-curve rule with pinned ends (``(6 v + a + b) / 8``
    at points, midpoints on segments), or of linear interpolation."""
    values = np.asarray(values, np.float64)
    for _ in range(levels):
        middles = 0.5 * (values[1:] + values[:-1])
        points = values.copy()
        if not linear:
            points[1:-1] = 0.75 * values[1:-1] + 0.125 * (values[2:] + values[:-2])
        values = np.empty((2 * len(points) - 1, points.shape[1]))
        values[0::2], values[1::2] = points, middles
    return values


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
        expected = _curve(control[[i * 5 + 2 for i in range(5)]], levels, linear=mode == "boundaries")
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

