"""UsdGeom.Points drawn as spheres and UsdGeom.BasisCurves as round tubes: hits against closed forms computed here
with numpy from the authored points and widths (and, for cubic curves, the bases as the UsdGeomBasisCurves
documentation defines them), colours in the albedo AOV, instancing, and bad input."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom
from usda_text import (
    GOOD_QUAD,
    assert_skipped_as_if_removed,
    floats,
    fmt,
    load,
    load_recording_warnings,
    preview_material,
    trace,
    write,
)

import wrt

# Polyline tolerance of cubic spans documented in the README (a fraction of the tube's radius).
CUBIC_TOLERANCE = 0.05


def ray_sphere(o, d, centres, radii):
    """Nearest t >= 0 of each ray ``o + t d`` with any of the spheres (inf: none); ``o``, ``d`` ``(R, 3)``."""
    oc = o[:, None, :] - centres[None]
    a = (d * d).sum(1)[:, None]
    b = (oc * d[:, None, :]).sum(2)
    c = (oc * oc).sum(2) - radii[None] ** 2
    disc = b * b - a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    t0, t1 = (-b - root) / a, (-b + root) / a
    t = np.where(t0 >= 0, t0, t1)
    t = np.where((disc >= 0) & (t >= 0), t, np.inf)
    return t.min(axis=1)


def ray_cylinder(o, d, a, b, r):
    """Nearest t >= 0 of each ray with the open cylinder side of radius ``r`` around each segment ``a -> b``."""
    axis = b - a
    length = np.linalg.norm(axis, axis=1)
    u = axis / length[:, None]
    oa = o[:, None, :] - a[None]
    dp = d[:, None, :] - (d @ u.T)[..., None] * u[None]  # d without its part along the axis
    op = oa - (oa * u[None]).sum(2)[..., None] * u[None]
    qa = (dp * dp).sum(2)
    qb = (op * dp).sum(2)
    qc = (op * op).sum(2) - r[None] ** 2
    disc = qb * qb - qa * qc
    root = np.sqrt(np.maximum(disc, 0.0))
    best = np.full(qa.shape, np.inf)
    for sign in (-1.0, 1.0):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (-qb + sign * root) / qa
        along = ((oa + t[..., None] * d[:, None, :]) * u[None]).sum(2)
        ok = (disc >= 0) & (qa > 0) & (t >= 0) & (along >= 0) & (along <= length[None])
        best = np.minimum(best, np.where(ok, t, np.inf))
    return best.min(axis=1)


# Points


def test_points_hit_their_spheres_and_miss_between(tmp_path, np_rng):
    """Rays at random targets among 60 points of random widths hit where an analytic ray-sphere solution says;
    rays between the points miss; each point's displayColor shows in the albedo AOV."""
    n = 60
    centres = np_rng.uniform(-4, 4, (n, 3))
    centres[:, 2] = np_rng.uniform(-0.5, 0.5, n)
    widths = np_rng.uniform(0.1, 0.5, n)
    colors = np_rng.uniform(0.1, 0.9, (n, 3))
    path = write(tmp_path, f'def Points "P"\n{{\n    point3f[] points = {fmt(centres)}\n'
                 f'    float[] widths = {floats(widths)} (interpolation = "vertex")\n'
                 f'    color3f[] primvars:displayColor = {fmt(colors)} (interpolation = "vertex")\n}}\n')
    scene = load(path)

    origins = np.column_stack([np_rng.uniform(-5, 5, (400, 2)), np.full(400, 10.0)])
    targets = np.concatenate([centres + np_rng.normal(0, 0.1, (n, 3)) for _ in range(5)])
    targets = np.concatenate([targets, np_rng.uniform(-4, 4, (100, 3))])[:400]
    directions = targets - origins
    expected = ray_sphere(origins, directions, centres, widths / 2)
    # Leave out rays that graze a sphere (their hit or miss is a rounding decision).
    oc = origins[:, None] - centres[None]
    along = (oc * directions[:, None]).sum(2) / (directions * directions).sum(1)[:, None]
    gap = np.linalg.norm(oc - along[..., None] * directions[:, None], axis=2) - widths / 2
    clear = np.abs(gap).min(axis=1) > 1e-3
    hits = trace(scene, origins, directions)
    assert clear.sum() > 300 and np.isfinite(expected[clear]).sum() > 150
    np.testing.assert_array_equal(np.isfinite(hits.t[clear]), np.isfinite(expected[clear]))
    hit = clear & np.isfinite(expected)
    np.testing.assert_allclose(hits.t[hit], expected[hit], rtol=1e-5, atol=1e-5)

    # The albedo AOV: a pixel over each point's centre shows its colour (points far from their neighbours).
    width = height = 96
    cam = wrt.Camera.orthographic((0, 0, 10), (0, 0, 0), height=10.0)
    img = wrt.render(scene, camera=cam, width=width, height=height)
    px = np.rint((centres[:, 0] + 5) / 10 * width - 0.5).astype(int)
    py = np.rint((5 - centres[:, 1]) / 10 * height - 0.5).astype(int)
    first = ray_sphere(np.column_stack([centres[:, :2], np.full(n, 10.0)]), np.tile([0.0, 0.0, -1.0], (n, 1)),
                       centres, widths / 2)  # which sphere a camera ray at each centre meets first
    shown = np.abs(first - (10.0 - centres[:, 2] - widths / 2)) < 1e-6
    albedo = img.aovs["albedo"][py, px]
    np.testing.assert_allclose(albedo[shown], colors[shown], atol=1e-5)
    assert shown.sum() > 30


def test_points_widths_fallback_constant_colour_and_zero_width(tmp_path):
    """Without widths a point is 1 wide (UsdImaging's fallback); a constant width and colour apply to all; a width
    of 0 draws nothing, without a warning; a prim scale scales the radius."""
    body = ('def Points "A"\n{\n    point3f[] points = [(0, 0, 0), (3, 0, 0)]\n}\n'
            'def Points "B"\n{\n    point3f[] points = [(0, 3, 0), (3, 3, 0)]\n'
            '    float[] widths = [0.4] (interpolation = "constant")\n'
            '    color3f[] primvars:displayColor = [(0.2, 0.4, 0.6)]\n}\n'
            'def Points "C"\n{\n    point3f[] points = [(0, 6, 0), (3, 6, 0)]\n'
            '    float[] widths = [0, 0.4] (interpolation = "vertex")\n'
            '    double3 xformOp:scale = (2, 2, 2)\n    uniform token[] xformOpOrder = ["xformOp:scale"]\n}\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(write(tmp_path, body))
    origins = [(0, 0, 5), (3, 0, 5), (0, 3, 5), (3, 3, 5), (0, 12, 5), (6, 12, 5)]
    hits = trace(scene, origins, [(0, 0, -1)] * 6)
    np.testing.assert_allclose(hits.t, [4.5, 4.5, 4.8, 4.8, np.inf, 4.6], rtol=1e-6)
    img = wrt.render(scene, camera=wrt.Camera.orthographic((0, 3, 5), (0, 3, 0), height=0.2), width=8, height=8)
    np.testing.assert_allclose(img.aovs["albedo"][4, 4], [0.2, 0.4, 0.6], atol=1e-6)


def test_points_with_a_material_animated_and_hidden(tmp_path):
    """A bound material colours the points; points read at a time sample move; an invisible Points prim and one of
    guide purpose are not drawn."""
    body = preview_material((0.1, 0.7, 0.3)) + '''def Points "P" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </M>
    point3f[] points.timeSamples = {1: [(0, 0, 0)], 2: [(2, 0, 0)]}
    float[] widths = [1] (interpolation = "constant")
}
def Points "Hidden"
{
    token visibility = "invisible"
    point3f[] points = [(0, 5, 0)]
}
def Points "Guide"
{
    uniform token purpose = "guide"
    point3f[] points = [(2, 5, 0)]
}
'''
    path = write(tmp_path, body)
    for time, x in ((1, 0.0), (2, 2.0)):
        scene = load(path, time=time)
        hits = trace(scene, [(x, 0, 5), (2 - x, 0, 5), (0, 5, 5), (2, 5, 5)], [(0, 0, -1)] * 4)
        np.testing.assert_allclose(hits.t, [4.5, np.inf, np.inf, np.inf])
    img = wrt.render(scene, camera=wrt.Camera.orthographic((2, 0, 5), (2, 0, 0), height=0.2), width=8, height=8)
    np.testing.assert_allclose(img.aovs["albedo"][4, 4], [0.1, 0.7, 0.3], atol=1e-6)


def test_points_inside_a_point_instancer_and_a_native_instance(tmp_path):
    """A Points prim as a PointInstancer's prototype is drawn at every instance, coloured by the instancer's
    displayColor; inside a native instance at each instance."""
    body = '''def PointInstancer "PI"
{
    rel prototypes = [</PI/Protos/Cloud>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (10, 0, 0)]
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 0, 1)] (interpolation = "vertex")
    def Scope "Protos"
    {
        def Points "Cloud"
        {
            point3f[] points = [(0, 0, 0), (1, 0, 0)]
            float[] widths = [0.5] (interpolation = "constant")
        }
    }
}
class Xform "Proto"
{
    def BasisCurves "Wire"
    {
        uniform token type = "linear"
        int[] curveVertexCounts = [2]
        point3f[] points = [(0, 0, 0), (1, 0, 0)]
        float[] widths = [0.5] (interpolation = "constant")
    }
}
def Xform "I1" (
    instanceable = true
    prepend references = </Proto>
)
{
    double3 xformOp:translate = (0, 5, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "I2" (
    instanceable = true
    prepend references = </Proto>
)
{
    double3 xformOp:translate = (0, 8, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
'''
    scene = load(write(tmp_path, body))
    origins = [(0, 0, 5), (1, 0, 5), (10, 0, 5), (11, 0, 5), (5, 0, 5), (0.5, 5, 5), (0.5, 8, 5), (0.5, 6.5, 5)]
    hits = trace(scene, origins, [(0, 0, -1)] * len(origins))
    np.testing.assert_allclose(hits.t, [4.75] * 4 + [np.inf, 4.75, 4.75, np.inf], rtol=1e-6)
    img = wrt.render(scene, camera=wrt.Camera.orthographic((10, 0, 5), (10, 0, 0), height=0.2), width=8, height=8)
    np.testing.assert_allclose(img.aovs["albedo"][4, 4], [0, 0, 1], atol=1e-6)
    assert {scene.instances.path(int(i)) for i in hits.instance[:4]} == {"/PI[0]", "/PI[1]"}


def test_points_tessellated_and_through_wp_mesh(tmp_path):
    """With tessellate_gprims the points are instances of a tessellated sphere: wrt's BVH and wp.Mesh (which flattens
    them) hit within the tessellation's error of the sphere."""
    path = write(tmp_path, 'def Points "P"\n{\n    point3f[] points = [(0, 0, 0), (3, 0, 0)]\n'
                 '    float[] widths = [2] (interpolation = "constant")\n}\n')
    scene = load(path, tessellate_gprims=32)
    assert scene.stats()["rendered_triangles"] == 2 * scene.stats()["unique_triangles"] > 0
    for accel in ("wrt", "warp"):
        hits = wrt.trace(scene, np.array([(0, 0, 5), (3, 0, 5), (1.5, 0, 5)], np.float32),
                         np.array([(0, 0, -1)] * 3, np.float32), accel=accel)
        np.testing.assert_allclose(hits.t, [4, 4, np.inf], rtol=1e-6)


# Linear curves


def linear_stage(tmp_path, points, counts, widths, extra=""):
    return write(tmp_path, f'def BasisCurves "C"\n{{\n    uniform token type = "linear"\n'
                 f'    int[] curveVertexCounts = {counts}\n    point3f[] points = {fmt(points)}\n'
                 f'    float[] widths = {floats(widths)} (interpolation = "vertex")\n{extra}}}\n')


def test_linear_curve_is_a_round_tube_with_round_joints_and_caps(tmp_path, np_rng):
    """A polyline of constant width: across a segment the ray meets the tube at the radius, at a joint the sphere,
    and past an end cap nothing; random rays agree with a union of capsules solved here."""
    pts = np.array([(0, 0, 0), (2, 0, 0), (2, 2, 0), (4, 3, 1)], np.float64)
    r = 0.25
    scene = load(linear_stage(tmp_path, pts, [4], [2 * r] * 4))
    down = [(0, 0, -1)] * 5
    # Across segment 0; at the joint (2, 0, 0) from outside the corner; just past the start cap; into the cap.
    origins = [(1, 0.1, 5), (2 + 0.12, -0.12, 5), (-r - 1e-3, 0, 5), (-0.2, 0, 5), (3, 2.5, 5)]
    hits = trace(scene, origins, down)
    joint = 5 - math.sqrt(r * r - 2 * 0.12**2)
    cap = 5 - math.sqrt(r * r - 0.04)
    seg3 = ray_cylinder(np.array([origins[4]], float), np.array([down[0]], float), pts[2:3], pts[3:4], np.array([r]))
    np.testing.assert_allclose(hits.t, [5 - math.sqrt(r * r - 0.01), joint, np.inf, cap, seg3[0]], rtol=1e-6)

    origins = np_rng.uniform(-2, 6, (600, 3)) + [0, 0, 6]
    targets = np.concatenate([pts[:-1] + np_rng.uniform(0, 1, (3, 1)) * (pts[1:] - pts[:-1]) for _ in range(150)])
    targets += np_rng.normal(0, 0.3, targets.shape)
    directions = targets - origins[: len(targets)]
    origins = origins[: len(targets)]
    expected = np.minimum(ray_cylinder(origins, directions, pts[:-1], pts[1:], np.full(3, r)),
                          ray_sphere(origins, directions, pts, np.full(4, r)))
    hits = trace(scene, origins, directions)
    with np.errstate(invalid="ignore"):  # inf - inf: both miss
        near = ~((hits.t == expected) | (np.abs(hits.t - expected) <= 1e-4 * np.maximum(1.0, expected)))
    # Only grazing rays may disagree on hit or miss.
    assert near.sum() <= 2, (hits.t[near], expected[near])
    assert np.isfinite(expected).sum() > 200


def test_linear_curve_widths_varying_along_segments_make_frustums(tmp_path):
    """Widths that change along a segment: its side is the cone frustum between the two radii (rounded to
    1/128 of the larger, down), the vertices spheres of their own radii."""
    pts = [(0, 0, 0), (4, 0, 0)]
    scene = load(linear_stage(tmp_path, pts, [2], [1.0, 0.5]))
    xs = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    hits = trace(scene, np.column_stack([xs, np.zeros(5), np.full(5, 5.0)]), [(0, 0, -1)] * 5)
    radius = 0.5 + (0.25 - 0.5) * xs / 4  # along the axis; the frustum's side rises above it by cos(slope) less
    slope = math.atan(0.25 / 4)
    cone_top = radius / math.cos(slope)
    expected = 5 - np.maximum(cone_top, [0.5, 0, 0, 0, 0.25])
    np.testing.assert_allclose(hits.t, expected, atol=0.5 / 128 + 1e-6)


def test_curves_uniform_and_varying_colours_and_periodic_wrap(tmp_path):
    """A uniform displayColor colours each curve; a periodic linear curve closes (a segment from its last vertex to
    its first)."""
    body = '''def BasisCurves "C"
{
    uniform token type = "linear"
    uniform token wrap = "periodic"
    int[] curveVertexCounts = [3, 3]
    point3f[] points = [(0, 0, 0), (4, 0, 0), (4, 4, 0), (10, 0, 0), (14, 0, 0), (14, 4, 0)]
    float[] widths = [0.5] (interpolation = "constant")
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)] (interpolation = "uniform")
}
'''
    scene = load(write(tmp_path, body))
    hits = trace(scene, [(2, 2, 5), (12, 2, 5), (2, 1, 5)], [(0, 0, -1)] * 3)  # the closing diagonals; a miss
    np.testing.assert_allclose(hits.t, [4.75, 4.75, np.inf], rtol=1e-6)
    for x, color in ((2, (1, 0, 0)), (12, (0, 1, 0))):
        img = wrt.render(scene, camera=wrt.Camera.orthographic((x, 2, 5), (x, 2, 0), height=0.1), width=4, height=4)
        np.testing.assert_allclose(img.aovs["albedo"][2, 2], color, atol=1e-6)


# Cubic curves


def bezier(p, t):
    s = 1 - t
    return s**3 * p[0] + 3 * s * s * t * p[1] + 3 * s * t * t * p[2] + t**3 * p[3]


def bspline(p, t):
    s = 1 - t
    return (s**3 * p[0] + (3 * t**3 - 6 * t**2 + 4) * p[1] + (-3 * t**3 + 3 * t**2 + 3 * t + 1) * p[2]
            + t**3 * p[3]) / 6


def catmull_rom(p, t):
    return 0.5 * (2 * p[1] + (-p[0] + p[2]) * t + (2 * p[0] - 5 * p[1] + 4 * p[2] - p[3]) * t**2
                  + (-p[0] + 3 * p[1] - 3 * p[2] + p[3]) * t**3)


CUBICS = {"bezier": (bezier, 3), "bspline": (bspline, 1), "catmullRom": (catmull_rom, 1)}


@pytest.mark.parametrize("basis", list(CUBICS))
@pytest.mark.parametrize("wrap", ["nonperiodic", "periodic", "pinned"])
def test_cubic_curves_hit_at_the_evaluated_curve(tmp_path, basis, wrap):
    """Rays down onto points of the curve, evaluated here from each basis' definition (vstep, wrap, pinned phantom
    points), hit the tube's top within the documented polyline tolerance of its radius; widths interpolated by the
    basis (vertex)."""
    evaluate, step = CUBICS[basis]
    cvs = np.array([(0, 0, 0), (2, 3, 0), (4, -2, 0), (6, 1, 0), (8, 4, 0), (9, 0, 0), (7, -3, 0)], np.float64)
    n = 7 if wrap != "periodic" or step == 1 else 6
    cvs = cvs[:n]
    widths = np.linspace(0.4, 0.2, n)
    path = write(tmp_path, f'def BasisCurves "C"\n{{\n    uniform token basis = "{basis}"\n'
                 f'    uniform token wrap = "{wrap}"\n    int[] curveVertexCounts = [{n}]\n'
                 f'    point3f[] points = {fmt(cvs)}\n    float[] widths = {floats(widths)}\n}}\n')
    # The spans, as the UsdGeomBasisCurves documentation defines them.
    if wrap == "periodic":
        spans = [[(k * step + j) % n for j in range(4)] for k in range(n // step)]
        ext, ext_w = cvs, widths
    elif wrap == "pinned" and step == 1:
        ext = np.concatenate([[2 * cvs[0] - cvs[1]], cvs, [2 * cvs[-1] - cvs[-2]]])
        ext_w = np.concatenate([[2 * widths[0] - widths[1]], widths, [2 * widths[-1] - widths[-2]]])
        spans = [[k + j for j in range(4)] for k in range(n - 1)]
    else:
        spans = [[k * step + j for j in range(4)] for k in range((n - 4) // step + 1)]
        ext, ext_w = cvs, widths
    scene = load(path)
    ts = np.array([0.0, 0.23, 0.37, 0.5, 0.81])
    centres = np.array([evaluate(ext[s], t) for s in spans for t in ts])
    radii = np.array([evaluate(ext_w[s], t) for s in spans for t in ts]) / 2
    hits = trace(scene, centres + [0, 0, 5], [(0, 0, -1)] * len(centres))
    # Each ray meets the tube at its top, 5 - r above the curve's point, off by at most the polyline's tolerance
    # (and a frustum's narrowing rounded down, 1/128 of the radius).
    np.testing.assert_allclose(hits.t, 5 - radii, atol=(CUBIC_TOLERANCE + 1 / 128) * radii.max() + 1e-6)
    if wrap == "pinned" and step == 1:  # pinned curves run from the first vertex to the last: their caps are there
        ends = trace(scene, [cvs[0] + (0, 0, 5), cvs[-1] + (0, 0, 5)], [(0, 0, -1)] * 2)
        np.testing.assert_allclose(ends.t, 5 - widths[[0, -1]] / 2, rtol=1e-6)


def test_pinned_curve_varying_widths_have_usds_count(tmp_path):
    """Varying widths of pinned cubic curves are as many as the nonperiodic curve of the same vertices needs (pxr's
    ComputeVaryingDataSize, 2 for curves of 2 or 3 vertices): the first and the last are held over the spans the
    phantom points add, as Hydra expands them. wrt wanted one per vertex (SceneError: 5 values, needs 8)."""
    from pxr import Usd, UsdGeom

    cvs = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0), (4, 0, 0), (10, 0, 0), (11, 0, 0), (12, 0, 0)]
    widths = [0.2, 0.4, 0.6, 0.8, 0.3]
    path = write(tmp_path, f'def BasisCurves "C"\n{{\n    uniform token basis = "catmullRom"\n'
                 f'    uniform token wrap = "pinned"\n    int[] curveVertexCounts = [5, 3]\n'
                 f'    point3f[] points = {fmt(cvs)}\n'
                 f'    float[] widths = {floats(widths)} (interpolation = "varying")\n}}\n')
    # pxr's count for the first curve alone (below 4 vertices its unsigned arithmetic wraps; Hydra wants 2).
    stage = Usd.Stage.CreateInMemory()
    curve = UsdGeom.BasisCurves.Define(stage, "/C")
    curve.CreateTypeAttr("cubic"), curve.CreateBasisAttr("catmullRom"), curve.CreateWrapAttr("pinned")
    curve.CreateCurveVertexCountsAttr([5])
    assert curve.ComputeVaryingDataSize(Usd.TimeCode.Default()) == 3
    scene = load(path)
    # A straight catmullRom runs through its vertices; the width at each: the value of the vertex before it (a
    # nonperiodic curve's varying values sit at its vertices 1 to n - 2), the first and the last held.
    expected = np.array([0.2, 0.2, 0.4, 0.6, 0.6, 0.8, 0.8, 0.3]) / 2
    hits = trace(scene, [(x, 0, 5) for x, _, _ in cvs], [(0, 0, -1)] * len(cvs))
    np.testing.assert_allclose(hits.t, 5 - expected, rtol=1e-6)


def test_cubic_polyline_tolerance_is_what_the_module_promises(tmp_path):
    """A tightly bent bezier span: the tube's top over 200 points of the curve stays within the tolerance (a fixed
    low segment count would not)."""
    cvs = np.array([(0, 0, 0), (0, 10, 0), (10, 10, 0), (10, 0, 0)], np.float64)
    path = write(tmp_path, f'def BasisCurves "C"\n{{\n    int[] curveVertexCounts = [4]\n'
                 f'    point3f[] points = {fmt(cvs)}\n    float[] widths = [0.2] (interpolation = "constant")\n}}\n')
    scene = load(path)
    ts = np.linspace(0, 1, 200)
    centres = np.array([bezier(cvs, t) for t in ts])
    # Rays along the curve's normal in its plane, from outside the bend: they meet the tube's side.
    tangent = np.array([3 * (1 - t) ** 2 * (cvs[1] - cvs[0]) + 6 * (1 - t) * t * (cvs[2] - cvs[1])
                        + 3 * t * t * (cvs[3] - cvs[2]) for t in ts])
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0], np.zeros(len(ts))])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    outside = np.where(((centres - [5, 5, 0]) * normal).sum(1, keepdims=True) > 0, normal, -normal)
    hits = trace(scene, centres + 3 * outside, -outside)
    err = np.abs(hits.t - (3 - 0.1))
    assert err.max() <= CUBIC_TOLERANCE * 0.1 + 1e-5, err.max()


def test_widths_that_swell_inside_a_straight_span_are_followed(tmp_path):
    """A straight bezier span with widths (0, 1, 1, 0) is a spindle, thickest (radius 0.375) in its middle: rays down
    onto it meet its top within the polyline tolerance. Its segments were counted from the bend of the curve and
    the radii at its ends alone: one segment of radius 0, nothing drawn (and widths (0.1, 1, 1, 0.1) drew radius
    0.05 where it is 0.3875)."""
    cvs = np.array([(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)], np.float64)
    for widths in ([0.0, 1.0, 1.0, 0.0], [0.1, 1.0, 1.0, 0.1]):
        path = write(tmp_path, f'def BasisCurves "C"\n{{\n    int[] curveVertexCounts = [4]\n'
                     f'    point3f[] points = {fmt(cvs)}\n    float[] widths = {floats(widths)}\n}}\n')
        scene = load(path)
        ts = np.array([0.2, 0.35, 0.5, 0.7, 0.9])
        centres = np.array([bezier(cvs, t) for t in ts])
        radii = np.array([bezier(np.array(widths), t) for t in ts]) / 2
        hits = trace(scene, centres + [0, 0, 5], [(0, 0, -1)] * len(ts))
        np.testing.assert_allclose(hits.t, 5 - radii, atol=(CUBIC_TOLERANCE + 1 / 128) * radii.max() + 1e-6)


# warp.render.UsdRenderer output


def test_warp_usd_renderer_particles_and_line_strips(tmp_path):
    """A stage written by warp's UsdRenderer: render_points(as_spheres=False) writes a UsdGeom.Points (drawn as
    spheres of the authored radii), render_line_strip a PointInstancer of capsules scaled along their axis (drawn
    through the instancer); rays hit both on the authored geometry and the render shows them."""
    from warp.render import UsdRenderer

    path = str(tmp_path / "warp.usda")
    renderer = UsdRenderer(path, up_axis="Y")
    renderer.begin_frame(0.0)
    # Four particles: with exactly three, warp 1.19 takes the three colours for one rgb and fails to author them.
    particles = np.array([(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)], np.float32)
    colors = np.array([(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0)], np.float32)
    renderer.render_points("particles", particles, radius=0.1, colors=colors, as_spheres=False)
    strip = np.array([(0, 2, 0), (2, 2, 0), (2, 4, 0)], np.float32)
    renderer.render_line_strip("rope", strip, color=(0.5, 0.5, 0.5), radius=0.05)
    renderer.end_frame()
    renderer.save()
    scene = load(path)
    origins = [(0, 0, 5), (1, 0, 5), (2, 0, 5), (0.5, 0, 5), (1, 2, 5), (2, 3, 5), (1, 3, 5)]
    hits = trace(scene, origins, [(0, 0, -1)] * len(origins))
    np.testing.assert_allclose(hits.t, [4.9, 4.9, 4.9, np.inf, 4.95, 4.95, np.inf], rtol=1e-5)
    img = wrt.render(scene, camera=wrt.Camera.orthographic((1, 0, 5), (1, 0, 0), height=0.1), width=4, height=4)
    np.testing.assert_allclose(img.aovs["albedo"][2, 2], [0, 1, 0], atol=1e-6)


# Bad input


def test_bad_points_and_widths_are_named(tmp_path):
    """A point that is not finite and negative or NaN widths are left out with a warning naming the file and prim;
    the other points are drawn."""
    body = ('def Points "P"\n{\n    point3f[] points = [(0, 0, 0), (nan, 0, 0), (2, 0, 0), (4, 0, 0), (6, 0, 0)]\n'
            '    float[] widths = [1, 1, -1, nan, 1] (interpolation = "vertex")\n}\n')
    path = write(tmp_path, body)
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(path)
    text = " | ".join(str(w.message) for w in record)
    assert "points that are not finite" in text and "1 of 5, first points[1]" in text and "/P" in text
    assert "widths that are negative, NaN or infinite" in text and "2 of 5, first widths[2] = -1" in text
    assert path in text
    hits = trace(scene, [(0, 0, 5), (2, 0, 5), (4, 0, 5), (6, 0, 5)], [(0, 0, -1)] * 4)
    np.testing.assert_allclose(hits.t, [4.5, np.inf, np.inf, 4.5])


def test_curves_without_points_are_skipped_with_a_warning(tmp_path):
    """BasisCurves with curveVertexCounts but no points are skipped with a warning naming them, as meshes with faces
    but no points are (they vanished without a word); empty Points and curves are nothing to say."""
    body = ('def BasisCurves "C"\n{\n    uniform token type = "linear"\n    int[] curveVertexCounts = [3]\n}\n'
            'def BasisCurves "Empty"\n{\n    int[] curveVertexCounts = []\n    point3f[] points = []\n}\n'
            'def Points "P"\n{\n    point3f[] points = []\n}\n')
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(write(tmp_path, body))
    text = " | ".join(str(w.message) for w in record)
    assert "BasisCurves prims with curves but no points were skipped" in text and "/C" in text
    assert "/Empty" not in text and "/P" not in text
    assert scene.stats()["rendered_shapes"] == 0


@pytest.mark.parametrize(
    "body, message",
    [
        ('int[] curveVertexCounts = [3]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]',
         "curveVertexCounts sum to 3 but there are 2 points"),
        ('uniform token type = "linear"\n    int[] curveVertexCounts = [-1, 3]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0)]', r"curveVertexCounts\[0\] = -1 is negative"),
        ('int[] curveVertexCounts = [3]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0)]',
         r"curveVertexCounts\[0\] = 3 makes no nonperiodic bezier curve \(it needs 4 \+ 3 k vertices\)"),
        ('uniform token basis = "bspline"\n    uniform token wrap = "periodic"\n    int[] curveVertexCounts = [2]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0)]', r"curveVertexCounts\[0\] = 2 makes no periodic bspline"),
        # A wrap token USD does not allow is read as nonperiodic (with a warning), as UsdImaging reads it.
        ('uniform token wrap = "loop"\n    int[] curveVertexCounts = [3]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0)]', r"= 3 makes no nonperiodic bezier"),
        ('uniform token type = "linear"\n    int[] curveVertexCounts = [2, 1]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0)]', r"curveVertexCounts\[1\] = 1 makes no linear"),
    ],
)
def test_bad_curve_topology_skips_the_prim(tmp_path, body, message):
    """BasisCurves whose topology makes no curves are skipped with a warning naming the file, the prim and the fault,
    as a mesh of invalid topology is, and the rest of the stage is drawn as without them (it raised SceneError)."""
    path = write(tmp_path, f'def BasisCurves "C"\n{{\n    {body}\n}}\n' + GOOD_QUAD)
    assert_skipped_as_if_removed(path, "/C", message)


LINES = ('    uniform token type = "linear"\n    int[] curveVertexCounts = [2, 2]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)]\n')
DOTS = '    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n    float[] widths = [0.5, 0.5] (interpolation = "vertex")\n'


@pytest.mark.parametrize("prim, body, attribute, message", [
    ('BasisCurves "C"', LINES + '    float[] widths = [1, 1, 1]', "widths",
     "widths has 3 values; vertex interpolation needs 4"),
    ('BasisCurves "C"', LINES + '    color3f[] primvars:displayColor = [(1, 0, 0)] (interpolation = "uniform")',
     "primvars:displayColor", "primvars:displayColor has 1 values; uniform interpolation needs 2"),
    ('Points "C"', '    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n    float[] widths = [1, 1, 1] (interpolation = '
     '"vertex")', "widths", "widths has 3 values; vertex interpolation needs 2"),
    ('Points "C"', DOTS + '    color3f[] primvars:displayColor = [(1, 0, 0)] (interpolation = "vertex")\n'
     '    int[] primvars:displayColor:indices = [0, 4]', "primvars:displayColor",
     "displayColor:indices[1] = 4 is out of range for 1 values"),
    ('Points "C"', DOTS + '    float[] primvars:displayOpacity = [0.5] (interpolation = "vertex")\n'
     '    int[] primvars:displayOpacity:indices = [0, -1]', "primvars:displayOpacity",
     "displayOpacity:indices[1] = -1 is out of range for 1 values"),
    ('Sphere "C"', '    color3f[] primvars:displayColor = [(1, 0, 0)] (interpolation = "constant")\n'
     '    int[] primvars:displayColor:indices = [2]', "primvars:displayColor",
     "displayColor:indices[0] = 2 is out of range for 1 values"),
])
def test_a_primvar_that_does_not_fit_is_dropped_with_a_warning(tmp_path, prim, body, attribute, message):
    """Widths, colours and opacities of points, curves and gprims whose length does not fit their interpolation, or
    whose indices are out of range (USD's ComputeFlattened gives None), are dropped, as Hydra drops such a primvar:
    the prim is drawn as if it had none, with a warning naming the file, the prim and the primvar. The stage failed
    to load (or, for a gprim's colour, went grey without a word)."""
    path = write(tmp_path, f'def {prim}\n{{\n{body}\n}}\n')
    stage = Usd.Stage.Open(path)
    primvar = UsdGeom.Primvar(stage.GetPrimAtPath("/C").GetAttribute(attribute))
    if primvar.IsIndexed():
        assert primvar.ComputeFlattened() is None  # the oracle: USD cannot flatten it
    scene, messages = load_recording_warnings(path)
    (dropped,) = [m for m in messages if "primvars that do not fit their prim" in m]
    assert dropped.startswith(f"{path}: ") and dropped.endswith(": /C") and message in dropped, dropped
    assert_drawn_as_unauthored(tmp_path, stage, scene, attribute)


def assert_drawn_as_unauthored(tmp_path, stage, scene, attribute):
    """``scene`` (loaded from ``stage``) renders as ``stage`` with ``attribute`` of ``/C`` (and its indices) removed."""
    stage.GetPrimAtPath("/C").RemoveProperty(attribute)
    stage.GetPrimAtPath("/C").RemoveProperty(attribute + ":indices")
    unauthored = str(tmp_path / "unauthored.usda")
    stage.GetRootLayer().Export(unauthored)
    camera = wrt.Camera.orthographic(eye=(0.5, 0.5, 5), target=(0.5, 0.5, 0), height=3.0)
    images = []
    for scene in (scene, load(unauthored)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            images.append(wrt.render(scene, camera=camera, width=16, height=16, device="cpu", integrator="albedo"))
    np.testing.assert_array_equal(images[0].rgb, images[1].rgb)
    np.testing.assert_array_equal(images[0].aovs["prim"], images[1].aovs["prim"])


TET = ('    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]\n'
       '    int4[] tetVertexIndices = [(0, 1, 2, 3)]\n')


@pytest.mark.parametrize("prim, body", [('Points "C"', DOTS), ('BasisCurves "C"', LINES), ('TetMesh "C"', TET)],
                         ids=["points", "curves", "tetmesh"])
@pytest.mark.parametrize("value", ['float[] primvars:displayColor = [0.1, 0.2]',
                                   'string[] primvars:displayColor = ["red", "red"]',
                                   'float2[] primvars:displayColor = [(1, 0), (0, 1)]'],
                         ids=["float", "string", "float2"])
def test_a_colour_primvar_of_the_wrong_type_is_dropped_with_a_warning_as_on_meshes(tmp_path, prim, body, value):
    """A displayColor that is not an array of 3- or 4-vectors on Points, curves or a TetMesh is dropped with the
    meshes' warning (naming the file, the prim, the type authored and the value read), the prim drawn as if it had
    none, as a mesh's is since d1121a3; it stopped the whole load with SceneError ("must be an array of 3- or
    4-vectors"). The oracle is the stage with the primvar removed, and a mesh beside it, dropped with the same
    warning."""
    mesh = ('def Mesh "M"\n{\n    point3f[] points = [(5, 0, 0), (6, 0, 0), (5, 1, 0)]\n'
            '    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
            f'    {value} (interpolation = "constant")\n}}\n')
    path = write(tmp_path, f'def {prim}\n{{\n{body}    {value} (interpolation = "constant")\n}}\n' + mesh)
    stage = Usd.Stage.Open(path)
    held = stage.GetPrimAtPath("/C").GetAttribute("primvars:displayColor").Get()
    assert type(held).__name__ not in ("Vec3fArray", "Vec4fArray")  # the oracle: USD holds no colours there
    type_name = str(stage.GetRootLayer().GetAttributeAtPath("/C.primvars:displayColor").typeName)
    scene, messages = load_recording_warnings(path)
    (dropped,) = [m for m in messages if "displayColor values that are not an array of 3-vectors were ignored" in m]
    assert dropped.startswith(f"{path}: ") and dropped.endswith(": /C, /M") and type_name in dropped, dropped
    assert_drawn_as_unauthored(tmp_path, stage, scene, "primvars:displayColor")


def test_material_bind_subsets_of_curves_are_ignored_with_a_warning(tmp_path):
    """A BasisCurves prim bound to red with a materialBind subset of 'face' 0 to blue: curves have no faces, so both
    curves stay red and a warning names the subset. The subset holding index 0 bound every curve blue."""
    look = ('def Material "{0}"\n{{\n    token outputs:surface.connect = </{0}/S.outputs:surface>\n'
            '    def Shader "S"\n    {{\n        uniform token info:id = "UsdPreviewSurface"\n'
            '        color3f inputs:diffuseColor = {1}\n        token outputs:surface\n    }}\n}}\n')
    body = look.format("Red", "(1, 0, 0)") + look.format("Blue", "(0, 0, 1)") + '''def BasisCurves "C" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    uniform token type = "linear"
    int[] curveVertexCounts = [2, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 2, 0), (1, 2, 0)]
    float[] widths = [0.4] (interpolation = "constant")
    rel material:binding = </Red>
    def GeomSubset "Tip" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token elementType = "face"
        uniform token familyName = "materialBind"
        int[] indices = [0]
        rel material:binding = </Blue>
    }
}
'''
    with pytest.warns(UserWarning, match="materialBind subsets of prims other than meshes were ignored.*Tip"):
        scene = wrt.load_usd(write(tmp_path, body))
    for y in (0, 2):
        img = wrt.render(scene, camera=wrt.Camera.orthographic((0.5, y, 5), (0.5, y, 0), height=0.1), width=4,
                         height=4)
        np.testing.assert_allclose(img.aovs["albedo"][2, 2], (1, 0, 0), atol=1e-6)


def test_curves_without_widths_or_with_normals_warn(tmp_path):
    """Curves without widths are tubes of width 1 and say so; curves with normals (ribbons) are tubes too, with a
    warning; a curve with a point that is not finite is left out, the others drawn."""
    body = '''def BasisCurves "C"
{
    uniform token type = "linear"
    int[] curveVertexCounts = [2, 2]
    point3f[] points = [(0, 0, 0), (2, 0, 0), (0, 3, 0), (inf, 3, 0)]
    normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)]
}
'''
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(write(tmp_path, body))
    text = " | ".join(str(w.message) for w in record)
    assert "without widths are drawn as tubes of width 1" in text and "ribbons" in text
    assert "curves with points that are not finite were left out" in text and "first curve 1" in text
    hits = trace(scene, [(1, 0, 5), (1, 3, 5)], [(0, 0, -1)] * 2)
    np.testing.assert_allclose(hits.t, [4.5, np.inf])


def test_widths_inherited_from_an_ancestor_as_pxr_finds_them(tmp_path):
    """``primvars:widths`` authored constant on an ancestor Xform applies to Points and curves below it that have no
    ``primvars:widths`` of their own, also over their own ``widths`` attribute (UsdImaging's order); a ``uniform`` one
    is not inherited (USD inherits constant primvars only), nor is one above a child's own. Each prim's expected width
    is what pxr's ``FindPrimvarWithInheritance("widths")`` gives, else its ``widths``, else 1. (Before, the inherited
    widths were not read: the points were 1 and 0.2 wide, not 0.4, and the curve warned that it had no widths.)"""
    from pxr import Usd, UsdGeom

    def point(name, x, extra=""):
        return f'    def Points "{name}"\n    {{\n        point3f[] points = [({x}, 0, 0)]\n{extra}    }}\n'

    body = (
        'def Xform "Group"\n{\n    float[] primvars:widths = [0.4] (interpolation = "constant")\n'
        '    color3f[] primvars:displayColor = [(0.1, 0.7, 0.2)]\n    float[] primvars:displayOpacity = [0.5]\n'
        + point("Plain", 0) + point("OwnAttr", 3, '        float[] widths = [0.2]\n')
        + point("OwnPrimvar", 6, '        float[] primvars:widths = [0.6] (interpolation = "constant")\n')
        + '    def BasisCurves "Curve"\n    {\n        uniform token type = "linear"\n'
        '        int[] curveVertexCounts = [2]\n        point3f[] points = [(9, -1, 0), (9, 1, 0)]\n    }\n}\n'
        'def Xform "Uniform"\n{\n    float[] primvars:widths = [0.4] (interpolation = "uniform")\n'
        + point("Plain", 12) + '}\n')
    path = write(tmp_path, body)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    messages = [str(w.message) for w in caught]
    assert not [m for m in messages if "without widths" in m], messages

    stage = Usd.Stage.Open(path)
    expected = {}
    for prim_path, x in (("/Group/Plain", 0), ("/Group/OwnAttr", 3), ("/Group/OwnPrimvar", 6), ("/Group/Curve", 9),
                         ("/Uniform/Plain", 12)):
        prim = stage.GetPrimAtPath(prim_path)
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("widths")
        attr = prim.GetAttribute("widths")
        width = primvar.Get()[0] if primvar else attr.Get()[0] if attr.HasValue() else 1.0
        expected[x] = width
    assert expected == pytest.approx({0: 0.4, 3: 0.4, 6: 0.6, 9: 0.4, 12: 1.0})  # pxr's answer, as documented
    xs = sorted(expected)
    hits = trace(scene, [(x, 0, 5) for x in xs], [(0, 0, -1)] * len(xs))
    np.testing.assert_allclose(hits.t, [5 - expected[x] / 2 for x in xs], rtol=1e-5)
    # displayColor and displayOpacity are inherited the same way (the Group's constant ones), points and curve alike.
    opacities = {s.path: s.opacity for p in scene.prototypes for s in p.shapes}
    assert opacities == {"/Group/Plain": 0.5, "/Group/OwnAttr": 0.5, "/Group/OwnPrimvar": 0.5, "/Group/Curve": 0.5,
                         "/Uniform/Plain": None}
    cam = wrt.Camera.orthographic((4.5, 0, 5), (4.5, 0, 0), height=2.75)  # x in [-1, 10]: the Group only
    albedo = wrt.render(scene, camera=cam, width=64, height=16, integrator="albedo").aovs["albedo"]
    hit = np.isfinite(wrt.render(scene, camera=cam, width=64, height=16, integrator="depth").aovs["depth"])
    np.testing.assert_allclose(albedo[hit], np.broadcast_to([0.1, 0.7, 0.2], albedo[hit].shape), atol=1e-6)
    assert hit.sum() > 20


@pytest.mark.parametrize("interpolation", ["vertex", "varying"])
def test_curves_with_a_bad_width_are_left_out_whole(tmp_path, interpolation):
    """A negative, NaN or infinite width on one vertex of a curve leaves that whole curve out with a warning naming
    the prim and the curve, as a vertex that is not finite does (the README's rule); the curve used to be drawn with
    a cone pinched to nothing at the bad vertex. The other curves are drawn at their radius."""
    points = [(0, 0, 0), (2, 0, 0), (4, 0, 0), (0, 3, 0), (2, 3, 0), (4, 3, 0), (0, 6, 0), (4, 6, 0)]
    body = (f'def BasisCurves "C"\n{{\n    uniform token type = "linear"\n    int[] curveVertexCounts = [3, 3, 2]\n'
            f'    point3f[] points = {fmt(points)}\n'
            f'    float[] widths = [0.4, -0.4, 0.4, 0.4, 0.4, 0.4, 0.4, nan] (interpolation = "{interpolation}")\n}}\n')
    path = write(tmp_path, body)
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(path)
    text = " | ".join(str(w.message) for w in record)
    assert "/C" in text and "2 of 3, first curve 0" in text and "widths[1] = -0.4" in text
    # Over each curve's vertices and segment middles: the good curve is a tube of radius 0.2, the others are gone.
    xs = [0.0, 0.5, 1.0, 2.0, 3.5, 4.0]
    origins = [(x, y, 5.0) for y in (0.0, 3.0, 6.0) for x in xs]
    hits = trace(scene, origins, [(0, 0, -1)] * len(origins))
    expected = np.array([np.inf] * 6 + [4.8] * 6 + [np.inf] * 6)
    np.testing.assert_allclose(hits.t, expected, rtol=1e-6)


LINEAR_LINE = 'def BasisCurves "C"\n{\n    uniform token type = "linear"\n'
NURBS_LINE = 'def NurbsCurves "C"\n{\n    int[] order = [2]\n    double[] knots = [0, 0, 1, 1]\n'


@pytest.mark.parametrize("head, points, widths", [
    (LINEAR_LINE, "[(0, 0, 0), (nan, 0, 0)]", "[1]"),
    (LINEAR_LINE, "[(0, 0, 0), (1, 0, 0)]", "[-1]"),
    (NURBS_LINE, "[(0, 0, 0), (nan, 0, 0)]", "[1]"),
], ids=["nan-point", "negative-width", "nurbs-nan-point"])
def test_curves_prim_with_every_curve_left_out_loads_empty(tmp_path, head, points, widths):
    """When every curve of a prim is left out (a point that is not finite, a bad constant width) the prim draws
    nothing with its warning and the stage's other prims load; it raised 'cannot read this prim' (a reshape of no
    spans)."""
    body = (f'{head}    int[] curveVertexCounts = [2]\n'
            f'    point3f[] points = {points}\n    float[] widths = {widths} (interpolation = "constant")\n}}\n'
            'def Points "P"\n{\n    point3f[] points = [(0, 3, 0)]\n    float[] widths = [1]\n}\n')
    with pytest.warns(UserWarning, match="were left out") as record:
        scene = wrt.load_usd(write(tmp_path, body))
    assert "/C" in " | ".join(str(w.message) for w in record)
    hits = trace(scene, [(0, 0, 5), (0, 3, 5)], [(0, 0, -1)] * 2)
    np.testing.assert_allclose(hits.t, [np.inf, 4.5])


SPHERE_COLOURS = [
    ('float[] primvars:displayColor = [1, 0, 0] (interpolation = "constant")', "drop"),
    ('float[] primvars:displayColor = [1, 0] (interpolation = "vertex")', "drop"),
    ('color3f[] primvars:displayColor = [(1, 0, 0)] (interpolation = "sideways")', "drop"),
    ('color3f[] primvars:displayColor = [] (interpolation = "vertex")', "drop"),
    ('color3f[] primvars:displayColor = [(1, 0, 0), (nan, 0, 0), (0, 0, 1)] (interpolation = "vertex")', "grey"),
]


@pytest.mark.parametrize("value, outcome", SPHERE_COLOURS, ids=["float3", "float2", "sideways", "empty", "nan"])
def test_a_gprims_unusable_colour_primvar_is_dropped_with_a_mesh_warning(tmp_path, value, outcome):
    """A Sphere's displayColor that is not an array of 3-vectors (a float[] of three was read as one red; of two it
    failed with numpy's reshape message), of an unknown interpolation or of no values is dropped with the warning a
    mesh beside it gets, the sphere coloured as if it had none; non-finite values are grey with the meshes' warning
    (they turned the whole sphere grey without a word), the rest of them still averaged (a mesh names that warning's
    primvar displayColor, points, curves and gprims primvars:displayColor). Oracles: the stage with the
    primvar removed; ``ComputeFlattened``'s values in float64."""
    mesh = ('def Mesh "M"\n{\n    point3f[] points = [(5, 0, 0), (6, 0, 0), (5, 1, 0)]\n'
            '    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
            f'    {value.replace("vertex", "constant") if outcome == "drop" else value}\n}}\n')
    mesh = mesh.replace('"constant")', '"sideways")') if "sideways" in value else mesh
    path = write(tmp_path, f'def Sphere "C"\n{{\n    {value}\n}}\n' + mesh)
    stage = Usd.Stage.Open(path)
    primvar = UsdGeom.Gprim(stage.GetPrimAtPath("/C")).GetDisplayColorPrimvar()
    scene, messages = load_recording_warnings(path)
    (shape,) = scene.shapes
    if outcome == "drop":
        (warned,) = [m for m in messages if "/C" in m]
        assert warned.startswith(f"{path}: ") and "displayColor" in warned and warned.endswith("/C, /M"), messages
        stage.GetPrimAtPath("/C").RemoveProperty("primvars:displayColor")
        unauthored = str(tmp_path / "unauthored.usda")
        stage.GetRootLayer().Export(unauthored)
        np.testing.assert_array_equal(shape.color, load(unauthored).shapes[0].color)
    else:
        values = np.array(primvar.ComputeFlattened(), np.float64)
        values[~np.isfinite(values).all(axis=1)] = 0.5
        np.testing.assert_allclose(shape.color, values.mean(axis=0), rtol=1e-6)
        (warned,) = [m for m in messages if "non-finite" in m and m.endswith(": /C")]
        assert warned.startswith(f"{path}: ") and "replaced by grey 0.5" in warned, messages


def test_light_api_on_points_and_curves_is_named_not_ignored(tmp_path):
    """MeshLightAPI on Points and LightAPI on curves (each a light per UsdLux) are not drawn as lights: wrt names
    both prims and their types in one warning, and draws their spheres and tubes as the geometry they are, adding no
    light (USD's own ``ComputeLightList`` lists both)."""
    from pxr import UsdLux

    path = str(tmp_path / "glow.usda")
    stage = Usd.Stage.CreateNew(path)
    dots = UsdGeom.Points.Define(stage, "/Dots")
    dots.CreatePointsAttr([(0, 0, 0), (1, 0, 0)])
    dots.CreateWidthsAttr([0.2, 0.2])
    UsdLux.MeshLightAPI.Apply(dots.GetPrim())
    hair = UsdGeom.BasisCurves.Define(stage, "/Hair")
    hair.CreatePointsAttr([(0, 0, 0), (0, 1, 0)])
    hair.CreateCurveVertexCountsAttr([2])
    hair.CreateTypeAttr(UsdGeom.Tokens.linear)
    hair.CreateWidthsAttr([0.1, 0.1])
    UsdLux.LightAPI.Apply(hair.GetPrim())
    stage.Save()
    listed = UsdLux.ListAPI(stage.GetPseudoRoot()).ComputeLightList(UsdLux.ListAPI.ComputeModeIgnoreCache)
    assert {str(p) for p in listed} == {"/Dots", "/Hair"}
    with pytest.warns(UserWarning, match=r"lights on Points and curves .*not supported.*\(Points: 1, BasisCurves: 1\)"
                                         r": /Dots, /Hair"):
        scene = wrt.load_usd(path)
    assert scene.lights == [] and scene.instances  # the spheres and the tube are drawn (as instanced shapes)


@pytest.mark.parametrize("interpolation, beneath", [("vertex", True), ("vertex", False), ("constant", False),
                                                    ("uniform", True)])
def test_a_point_instancer_widths_primvar_sizes_the_points_of_each_instance(tmp_path, interpolation, beneath):
    """UsdGeomPointInstancer's primvar rules: a ``primvars:widths`` on the instancer applies to each instance at the
    root of its prototype (its whole value for constant or uniform, one value per instance for vertex), as a constant
    one there would, sizing the prototype's points that have no widths of their own. Only a constant one beneath the
    instancer did (by inheritance); the others were dropped without a word, every point drawn 1 wide. The oracle is
    USD's flattened primvar and ``ComputeInstanceTransformsAtTime``."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "widths.usda"))
    root = "/PI/Protos" if beneath else "/Protos"
    UsdGeom.Scope.Define(stage, root).MakeInvisible()
    UsdGeom.Points.Define(stage, f"{root}/Cloud").CreatePointsAttr([(0, 0, 0), (1, 0, 0)])
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets([f"{root}/Cloud"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(0, 0, 0), (10, 0, 0), (20, 0, 0)])
    widths = [0.5, 0.2, 0.5] if interpolation == "vertex" else [0.3]
    UsdGeom.PrimvarsAPI(pi).CreatePrimvar("widths", Sdf.ValueTypeNames.FloatArray, interpolation).Set(widths)
    stage.Save()
    flattened = np.asarray(UsdGeom.PrimvarsAPI(pi).GetPrimvar("widths").ComputeFlattened(), np.float64)
    t = Usd.TimeCode.Default()
    expected = {}
    for i, m in enumerate(pi.ComputeInstanceTransformsAtTime(t, t)):
        for point in ((0, 0, 0), (1, 0, 0)):
            centre = tuple(np.round(np.array(m).T @ np.array([*point, 1.0]), 6)[:3])
            expected[centre] = flattened[i if len(flattened) > 1 else 0] / 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(str(tmp_path / "widths.usda"))
    spheres = scene.instances.to_world
    drawn = {tuple(np.round(m[:3, 3], 6)): float(np.linalg.norm(m[:3, 0])) for m in spheres}
    assert drawn.keys() == expected.keys()
    np.testing.assert_allclose([drawn[c] for c in expected], list(expected.values()), rtol=1e-6)


def test_points_primvars_blocked_at_one_time_sample_are_read_as_unauthored_there_without_a_warning(tmp_path):
    """A time sample of None (a value block: no value at that time, USD's ``Get`` gives None) of a Points prim's
    widths and displayColor was read as 0 values and warned about as not fitting the prim ('widths has 0 values;
    vertex interpolation needs 2'). It is read as USD reads it there, no value, as if unauthored: the points drawn
    as those without widths or colour are, without that warning."""
    blocked = tmp_path / "blocked.usda"
    blocked.write_text("""#usda 1.0
def Points "P"
{
    point3f[] points = [(0, 0, 0), (1, 0, 0)]
    float[] widths.timeSamples = { 1: [0.2, 0.2], 2: None }
    color3f[] primvars:displayColor.timeSamples = { 1: [(1, 0, 0)], 2: None }
}
""")
    unauthored = tmp_path / "unauthored.usda"
    unauthored.write_text('#usda 1.0\ndef Points "P"\n{\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n}\n')
    stage = Usd.Stage.Open(str(blocked))
    prim = stage.GetPrimAtPath("/P")
    assert prim.GetAttribute("widths").Get(2.0) is None and prim.GetAttribute("primvars:displayColor").Get(2.0) is None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(blocked, time=2.0)
    assert not [str(w.message) for w in caught if "do not fit" in str(w.message)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = wrt.load_usd(unauthored, time=2.0)
    assert len(scene.instances) == len(expected.instances) == 2
    np.testing.assert_array_equal(scene.instances.to_world, expected.instances.to_world)  # radius 0.5: no widths
    np.testing.assert_array_equal(scene.instances.colors, expected.instances.colors)
