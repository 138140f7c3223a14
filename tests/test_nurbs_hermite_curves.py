"""UsdGeom.NurbsCurves and UsdGeom.HermiteCurves drawn as round tubes: hits against curves evaluated here from their
definitions (a rational circle, the Cox-de Boor recursion written out, the cubic Hermite basis), widths and colours,
and bad knots, orders, ranges, weights and tangents."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from usda_text import GOOD_QUAD, assert_skipped_as_if_removed, floats, fmt, load, trace, write

import wrt

# Polyline tolerance of curves documented in the README (a fraction of the tube's radius), and the frustum rounding.
CURVE_TOLERANCE = 0.05
RHO_ROUNDING = 1 / 128


def nurbs_body(name, points, order, knots, weights=None, counts=None, extra=""):
    """A NurbsCurves prim of one curve (or ``counts``) of ``order`` (an int, or a list: one per curve)."""
    orders = [order] if np.ndim(order) == 0 else list(order)
    body = (f'def NurbsCurves "{name}"\n{{\n    int[] curveVertexCounts = {counts or [len(points)]}\n'
            f"    int[] order = {orders}\n    double[] knots = {floats(knots)}\n    point3f[] points = {fmt(points)}\n"
            '    float[] widths = [0.2] (interpolation = "constant")\n')
    if weights is not None:
        body += f"    double[] pointWeights = {floats(weights)}\n"
    return body + extra + "}\n"


# A circle of radius 2 in the z = 0 plane: nine control points on a square, weights 1 and sqrt(2)/2, order 3.
S = math.sqrt(0.5)
CIRCLE = [(2, 0, 0), (2, 2, 0), (0, 2, 0), (-2, 2, 0), (-2, 0, 0), (-2, -2, 0), (0, -2, 0), (2, -2, 0), (2, 0, 0)]
CIRCLE_WEIGHTS = [1, S, 1, S, 1, S, 1, S, 1]
CIRCLE_KNOTS = [0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4]


def test_rational_nurbs_circle_is_a_circle(tmp_path, np_rng):
    """A NURBS circle of weight sqrt(2)/2 is a circle: rays from its centre hit the tube's inside at R - r, rays
    from outside its outside at R + r, within the documented tolerance of r, at random angles."""
    radius, r = 2.0, 0.1
    scene = load(write(tmp_path, nurbs_body("C", CIRCLE, 3, CIRCLE_KNOTS, CIRCLE_WEIGHTS)))
    angles = np_rng.uniform(0, 2 * math.pi, 300)
    d = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(300)])
    tol = CURVE_TOLERANCE * r + 1e-5
    inside = trace(scene, np.zeros((300, 3)), d)
    np.testing.assert_allclose(inside.t, radius - r, atol=tol)
    outside = trace(scene, 5 * d, -d)
    np.testing.assert_allclose(outside.t, 5 - radius - r, atol=tol)
    # The same control points without weights are no circle: on the diagonal the quadratic B-spline passes
    # through (P0 + 2 P1 + P2) / 4 = (1.5, 1.5, 0).
    plain = load(write(tmp_path, nurbs_body("C", CIRCLE, 3, CIRCLE_KNOTS)))
    diagonal = trace(plain, [(0, 0, 0)], [(S, S, 0)])
    np.testing.assert_allclose(diagonal.t, 1.5 * math.sqrt(2) - r, atol=tol)


def test_nurbs_range_draws_part_of_the_curve(tmp_path):
    """ranges (0, 2) of the circle is its upper half (y >= 0): rays below miss, rays above hit."""
    body = nurbs_body("C", CIRCLE, 3, CIRCLE_KNOTS, CIRCLE_WEIGHTS, extra="    double2[] ranges = [(0, 2)]\n")
    scene = load(write(tmp_path, body))
    angles = np.radians([30, 90, 150, 210, 270, 330])
    d = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(6)])
    hits = trace(scene, np.zeros((6, 3)), d)
    assert np.isfinite(hits.t[:3]).all() and np.isinf(hits.t[3:]).all()


def cox_de_boor(knots, i, p, u):
    """The B-spline basis N_{i,p}(u) by its recursive definition (0/0 = 0), right-open intervals."""
    if p == 0:
        return 1.0 if knots[i] <= u < knots[i + 1] else 0.0
    a = knots[i + p] - knots[i]
    b = knots[i + p + 1] - knots[i + 1]
    left = (u - knots[i]) / a * cox_de_boor(knots, i, p - 1, u) if a > 0 else 0.0
    right = (knots[i + p + 1] - u) / b * cox_de_boor(knots, i + 1, p - 1, u) if b > 0 else 0.0
    return left + right


def nurbs_point(points, weights, knots, order, u):
    n = [cox_de_boor(knots, i, order - 1, u) * weights[i] for i in range(len(points))]
    return np.asarray(n) @ np.asarray(points) / sum(n)


@pytest.mark.parametrize("order", [2, 3, 4, 5])
def test_nurbs_curves_hit_at_the_recursive_definition(tmp_path, np_rng, order):
    """Two batched curves of random control points, weights and non-uniform knots (one repeated inside), widths per
    control point (vertex, through the same basis): rays down onto points of each curve, evaluated by the recursive
    Cox-de Boor definition, meet the tube's top at the radius there within the tolerance."""
    counts = [7, 6]
    pts = [np.column_stack([np.linspace(0, 8, n), np_rng.uniform(-2, 2, n), np.zeros(n)]) + [0, 6 * c, 0]
           for c, n in enumerate(counts)]
    weights = [np_rng.uniform(0.5, 2.0, n) for n in counts]
    widths = [np_rng.uniform(0.2, 0.4, n) for n in counts]
    knots = []
    for n in counts:
        inner = np.sort(np_rng.uniform(0, 3, n - order))
        if len(inner) > 2:
            inner[2] = inner[1]  # a repeated knot: a zero-length interval inside
        knots.append(np.concatenate([np.zeros(order), inner, np.full(order, 3.0)]))
    extra = f"    double[] pointWeights = {floats(np.concatenate(weights))}\n"
    body = (f'def NurbsCurves "N"\n{{\n    int[] curveVertexCounts = {counts}\n    int[] order = [{order}, {order}]\n'
            f"    double[] knots = {floats(np.concatenate(knots))}\n    point3f[] points = {fmt(np.concatenate(pts))}\n"
            f'    float[] widths = {floats(np.concatenate(widths))} (interpolation = "vertex")\n{extra}}}\n')
    scene = load(write(tmp_path, body))
    for c in range(2):
        us = np.linspace(0, 3, 23)[1:-1]
        centres = np.array([nurbs_point(pts[c], weights[c], knots[c], order, u) for u in us])
        radii = np.array([nurbs_point(widths[c][:, None], weights[c], knots[c], order, u)[0] for u in us]) / 2
        hits = trace(scene, centres + [0, 0, 5], [(0, 0, -1)] * len(us))
        np.testing.assert_allclose(hits.t, 5 - radii, atol=(CURVE_TOLERANCE + RHO_ROUNDING) * radii.max() + 1e-5)


@pytest.mark.parametrize("order, knots, points", [
    (2, [0, 0, 1, 1, 2, 2], [(0, 0, 0), (2, 0, 0), (5, 0, 0), (7, 0, 0)]),
    (3, [0, 0, 0, 1, 1, 1, 2, 2, 2], [(0, 0, 0), (1, 0, 0), (2, 0, 0), (5, 0, 0), (6, 0, 0), (7, 0, 0)]),
])
def test_nurbs_curve_broken_at_a_knot_of_full_multiplicity_is_capped_on_both_sides(tmp_path, order, knots, points):
    """A knot repeated ``order`` times breaks a NURBS curve: here into a piece from x = 0 to 2 and one from 5 to 7.
    Each piece ends in a round cap of the tube's radius, so rays along the axis from the gap meet the caps at x = 2.25
    and 4.75. The first piece's end had no sphere (a span's end was taken for the next span's start), so the ray
    into its open end went through the tube to the far side of the cap at x = 0."""
    body = nurbs_body("C", points, order, knots).replace("[0.2]", "[0.5]")
    scene = load(write(tmp_path, body))
    hits = trace(scene, [(3.5, 0, 0), (3.5, 0, 0)], [(-1, 0, 0), (1, 0, 0)])
    np.testing.assert_allclose(hits.t, [1.25, 1.25], atol=1e-5)


@pytest.mark.parametrize("weights", [None, [1.0, 3.0, 0.5, 1.0]])
def test_nurbs_widths_that_swell_inside_a_straight_span_are_followed(tmp_path, weights):
    """A straight cubic NURBS span with vertex widths (0, 1, 1, 0) or (0.1, 1, 1, 0.1) swells in its middle: rays
    down onto it meet its top, the rational basis' radius there, within the tolerance. Its pieces were counted from
    the bend of its points alone: one segment between its end radii, nothing drawn (or radius 0.05 where it is
    0.39), as BasisCurves' spans once were."""
    pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)]
    knots = [0, 0, 0, 0, 1, 1, 1, 1]
    w = [1.0] * 4 if weights is None else weights
    for widths in ([0.0, 1.0, 1.0, 0.0], [0.1, 1.0, 1.0, 0.1]):
        body = nurbs_body("C", pts, 4, knots, weights).replace(
            '[0.2] (interpolation = "constant")', f'{floats(widths)} (interpolation = "vertex")')
        scene = load(write(tmp_path, body))
        us = np.array([0.2, 0.35, 0.5, 0.7, 0.9])
        centres = np.array([nurbs_point(pts, w, knots, 4, u) for u in us])
        radii = np.array([nurbs_point(np.array(widths)[:, None], w, knots, 4, u)[0] for u in us]) / 2
        hits = trace(scene, centres + [0, 0, 5], [(0, 0, -1)] * len(us))
        np.testing.assert_allclose(hits.t, 5 - radii, atol=(CURVE_TOLERANCE + RHO_ROUNDING) * radii.max() + 1e-5)


def test_nurbs_curve_colours_uniform_and_varying(tmp_path):
    """A uniform displayColor colours each curve; varying (count - order + 2 values per curve, one per knot of its
    domain) changes linearly across each knot interval."""
    line = [(0, 0, 0), (2, 0, 0), (4, 0, 0), (6, 0, 0)]
    second = [(x, 3, 0) for x, _, _ in line]
    body = ('def NurbsCurves "U"\n{\n    int[] curveVertexCounts = [4, 4]\n    int[] order = [2, 2]\n'
            f"    double[] knots = {floats([0, 0, 1, 2, 3, 3] * 2)}\n    point3f[] points = {fmt(line + second)}\n"
            '    float[] widths = [0.4] (interpolation = "constant")\n'
            '    color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "uniform")\n}\n'
            'def NurbsCurves "V"\n{\n    int[] curveVertexCounts = [4]\n    int[] order = [2]\n'
            f"    double[] knots = {floats([0, 0, 1, 2, 3, 3])}\n"
            f"    point3f[] points = {fmt([(x, 6, 0) for x in (0, 2, 4, 6)])}\n"
            '    float[] widths = [0.4] (interpolation = "constant")\n'
            '    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)] (interpolation = '
            '"varying")\n}\n')
    scene = load(write(tmp_path, body))
    for (x, y), color in (((3, 0), (1, 0, 0)), ((3, 3), (0, 0, 1)), ((3, 6), (0, 0.5, 0.5)), ((1, 6), (0.5, 0.5, 0))):
        cam = wrt.Camera.orthographic((x, y, 5), (x, y, 0), height=0.05)
        img = wrt.render(scene, camera=cam, width=4, height=4)
        np.testing.assert_allclose(img.aovs["albedo"][2, 2], color, atol=0.02)


def hermite(p0, p1, t0, t1, t):
    """The cubic Hermite basis: h00 P0 + h10 T0 + h01 P1 + h11 T1."""
    return ((2 * t**3 - 3 * t**2 + 1) * p0 + (t**3 - 2 * t**2 + t) * t0 + (-2 * t**3 + 3 * t**2) * p1
            + (t**3 - t**2) * t1)


def test_hermite_curves_hit_at_the_hermite_basis(tmp_path):
    """Two Hermite curves (3 and 2 points): a segment's midpoint is (P0 + P1) / 2 + (T0 - T1) / 8; rays down onto
    points of every segment from the Hermite basis meet the tube's top; varying widths are linear per segment."""
    pts = np.array([(0, 0, 0), (4, 0, 0), (8, 2, 0), (0, 6, 0), (5, 6, 0)], np.float64)
    tangents = np.array([(0, 8, 0), (6, -6, 0), (4, 4, 0), (3, 3, 0), (3, -9, 0)], np.float64)
    widths = np.array([0.2, 0.4, 0.3, 0.3, 0.3])
    body = (f'def HermiteCurves "H"\n{{\n    int[] curveVertexCounts = [3, 2]\n    point3f[] points = {fmt(pts)}\n'
            f"    vector3f[] tangents = {fmt(tangents)}\n"
            f'    float[] widths = {floats(widths)} (interpolation = "varying")\n}}\n')
    scene = load(write(tmp_path, body))
    mid = trace(scene, [(2 + (0 - 6) / 8, 0 + (8 + 6) / 8, 5)], [(0, 0, -1)])
    np.testing.assert_allclose(mid.t, 5 - 0.15, atol=(CURVE_TOLERANCE + RHO_ROUNDING) * 0.2 + 1e-5)
    centres, radii = [], []
    for a in (0, 1, 3):
        for t in (0.1, 0.3, 0.5, 0.7, 0.9):
            centres.append(hermite(pts[a], pts[a + 1], tangents[a], tangents[a + 1], t))
            radii.append(((1 - t) * widths[a] + t * widths[a + 1]) / 2)
    radii = np.array(radii)
    hits = trace(scene, np.array(centres) + [0, 0, 5], [(0, 0, -1)] * len(centres))
    np.testing.assert_allclose(hits.t, 5 - radii, atol=(CURVE_TOLERANCE + RHO_ROUNDING) * radii.max() + 1e-5)


def test_curves_are_no_longer_skipped_and_move_with_time(tmp_path):
    """NurbsCurves and HermiteCurves load without the old 'not supported' warning; points read at a time sample
    move them."""
    body = ('def HermiteCurves "H"\n{\n    int[] curveVertexCounts = [2]\n'
            "    point3f[] points.timeSamples = {1: [(0, 0, 0), (4, 0, 0)], 2: [(0, 3, 0), (4, 3, 0)]}\n"
            '    vector3f[] tangents = [(4, 0, 0), (4, 0, 0)]\n'
            '    float[] widths = [0.5] (interpolation = "constant")\n}\n')
    path = write(tmp_path, body)
    for time, y in ((1, 0.0), (2, 3.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            scene = wrt.load_usd(path, time=time)
        hits = trace(scene, [(2, y, 5), (2, 3 - y, 5)], [(0, 0, -1)] * 2)
        np.testing.assert_allclose(hits.t, [4.75, np.inf], rtol=1e-6)


@pytest.mark.parametrize(
    "body, message",
    [
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS[::-1]), r"curve 0: knots decrease at 3 \(4 then 3\)"),
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS[:-1]), "knots has 11 values; the curves' counts plus orders need 12"),
        (nurbs_body("N", CIRCLE, [3, 3], CIRCLE_KNOTS), "order has 2 values for 1 curves"),
        (nurbs_body("N", CIRCLE, 3, [0] * 12), r"curve 0: the domain \[knots\[2\], knots\[9\]\] = \[0, 0\] is empty"),
        (nurbs_body("N", CIRCLE, 1, list(range(10))), "curve 0: order 1 is below 2"),
        (nurbs_body("N", CIRCLE, [3, 0], CIRCLE_KNOTS, counts=[9, 0]), "curve 1: order 0 is below 2"),
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS, extra="    double2[] ranges = [(-1, 2)]\n"),
         r"curve 0: range \(-1, 2\) is not an interval inside the knots' domain \[0, 4\]"),
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS, [1] * 8 + [0]), r"pointWeights\[8\] = 0 is not a positive number"),
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS[:-1] + [float("nan")]), "curve 0: knot 11 is nan"),
        ('def HermiteCurves "N"\n{\n    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n'
         '    vector3f[] tangents = [(1, 0, 0)]\n}\n', "tangents must be 2 3-vectors, not 1"),
        # Values of another type are named by the type authored, not the schema's (a string[] knots was "1 of
        # double[]"), and one that is no array (a string) raised "len() of unsized object" naming no attribute.
        ('def HermiteCurves "N"\n{\n    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n'
         '    string tangents = "x"\n}\n', "tangents must be 2 3-vectors, not one string value"),
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS).replace("double[] knots", 'string knots = "x"\n    double[] unused'),
         "knots must be numbers, not one string value"),
        (nurbs_body("N", CIRCLE, 3, CIRCLE_KNOTS).replace("int[] order = [3]", 'string[] order = ["3"]'),
         r"order must be integers, not 1 of string\[\]"),
        ('def HermiteCurves "N"\n{\n    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n'
         "}\n", "tangents has no value; 2 points need one each"),
        ('def HermiteCurves "N"\n{\n    int[] curveVertexCounts = [1, 1]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n    vector3f[] tangents = [(1, 0, 0), (1, 0, 0)]\n}\n',
         r"curveVertexCounts\[0\] = 1 makes no hermite curve"),
    ],
)
def test_bad_nurbs_and_hermite_curves_are_skipped_naming_the_prim(tmp_path, body, message):
    """NurbsCurves and HermiteCurves whose orders, knots, ranges, weights, tangents or counts make no curve are skipped
    with a warning naming the file, the prim and the fault, the rest of the stage drawn as without them (they raised
    SceneError, which stopped the load)."""
    path = write(tmp_path, body + GOOD_QUAD)
    assert_skipped_as_if_removed(path, "/N", message)


def test_hermite_curve_with_a_tangent_that_is_not_finite_is_left_out(tmp_path):
    body = ('def HermiteCurves "H"\n{\n    int[] curveVertexCounts = [2, 2]\n'
            "    point3f[] points = [(0, 0, 0), (4, 0, 0), (0, 3, 0), (4, 3, 0)]\n"
            "    vector3f[] tangents = [(4, 0, 0), (4, 0, 0), (nan, 0, 0), (4, 0, 0)]\n"
            '    float[] widths = [0.5] (interpolation = "constant")\n}\n')
    with pytest.warns(UserWarning, match="curves with points that are not finite were left out.*first curve 1"):
        scene = wrt.load_usd(write(tmp_path, body))
    hits = trace(scene, [(2, 0, 5), (2, 3, 5)], [(0, 0, -1)] * 2)
    np.testing.assert_allclose(hits.t, [4.75, np.inf], rtol=1e-6)
