"""BasisCurves drawn by wrt against an independent float64 oracle written from the UsdGeomBasisCurves documentation
(``curve_oracle.py``): segment counts and end points, the centreline and widths of every type, basis, wrap and
widths interpolation, random rays against the swept sphere, the tessellated tube's vertices and USD's own extent."""

from __future__ import annotations

import numpy as np
import pytest
from curve_oracle import BasisCurve, NurbsCurve, curves_of, deepest_along, sample, signed_distance, width_at
from pxr import Gf, Usd, UsdGeom, Vt
from usda_text import floats, fmt, load, trace, write

from wrt.tubes import curve_spans

# The README's promises: a cubic span's polyline within 5% of its largest radius, a frustum's narrow end up to 1/128
# of its wide radius thin; and a circle of 64 sides (tessellate_gprims=True) within 1 - cos(pi / 64) of round.
CURVE_TOLERANCE = 0.05
RHO_ROUNDING = 1 / 128
SIDES_ROUNDING = 1 - np.cos(np.pi / 64)

KINDS = [("linear", "bezier", "nonperiodic"), ("linear", "catmullRom", "periodic"), ("linear", "bspline", "pinned")]
KINDS += [("cubic", basis, wrap) for basis in ("bezier", "bspline", "catmullRom")
          for wrap in ("nonperiodic", "periodic", "pinned")]


def valid_count(rng, curve_type, basis, wrap):
    """A random vertex count the schema accepts for this type, basis and wrap."""
    if curve_type == "linear":
        return int(rng.integers(3 if wrap == "periodic" else 2, 7))
    step = 3 if basis == "bezier" else 1
    if wrap == "periodic":
        return step * int(rng.integers(2, 5)) if step == 3 else int(rng.integers(3, 8))
    if wrap == "pinned" and step == 1:
        return int(rng.integers(2, 8))
    return 4 + step * int(rng.integers(0, 3))


def random_prim(rng, curve_type, basis, wrap, n_curves=2):
    """Points (a wandering walk per curve), counts, and widths of a random interpolation for one prim."""
    counts = np.array([valid_count(rng, curve_type, basis, wrap) for _ in range(n_curves)])
    points = []
    for c, n in enumerate(counts):
        steps = rng.normal(0.0, 1.0, (n, 3)) + [1.2, 0, 0]
        points.append(np.cumsum(steps, axis=0) + [0, 4.0 * c, 0])
    points = np.concatenate(points)
    curves = curves_of(points, counts, lambda c, p: BasisCurve(p, curve_type, basis, wrap))
    interpolation = str(rng.choice(["constant", "uniform", "varying", "vertex"]))
    size = {"constant": 1, "uniform": len(counts), "vertex": len(points),
            "varying": sum(k.varying_count() for k in curves)}[interpolation]
    widths = rng.uniform(0.2, 0.6, size)
    return points, counts, curves, widths, interpolation


def stage_text(points, counts, widths, interpolation, curve_type, basis, wrap):
    return (f'def BasisCurves "C"\n{{\n    uniform token type = "{curve_type}"\n    uniform token basis = "{basis}"\n'
            f'    uniform token wrap = "{wrap}"\n    int[] curveVertexCounts = {list(map(int, counts))}\n'
            f'    point3f[] points = {fmt(np.float32(points))}\n'
            f'    float[] widths = {floats(np.float32(widths))} (interpolation = "{interpolation}")\n}}\n')


def tolerance(curve_type, centres, radii):
    """How far wrt's tube may lie from the oracle's: the polyline and frustum roundings of the largest radius, a
    frustum's side inside the swept sphere's tangent cone (``r (1 / cos(a) - 1)``, ``sin(a)`` the radius' slope
    along the curve: README's tubes are frustums between joint spheres), and float32 points."""
    chord = CURVE_TOLERANCE if curve_type == "cubic" else 0.0
    slope = np.abs(np.diff(radii)) / np.maximum(np.linalg.norm(np.diff(centres, axis=0), axis=1), 1e-12)
    slope = np.minimum(slope, 0.9)  # from one curve to the next: far apart
    cone = 1.0 / np.sqrt(1.0 - slope.max(initial=0.0) ** 2) - 1.0
    return (chord + RHO_ROUNDING + cone) * radii.max() + 2e-4


def check_rays(scene, rng, centres, radii, e, n=200):
    """Random rays from outside at points near the oracle's curve: wrt's hit lies on the oracle's surface within
    ``e``, and the ray never goes deeper than ``e`` into the oracle's tube before it (or at all, on a miss)."""
    pick = rng.choice(np.flatnonzero(radii >= 0.2 * radii.max()), n)  # where the tube is not a thread
    targets = centres[pick] + rng.normal(0.0, 1.0, (n, 3)) * radii[pick, None]
    directions = rng.normal(0.0, 1.0, (n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = targets - 12.0 * directions
    outside = signed_distance(origins, centres, radii) > e  # a ray from inside a tube meets it from within
    origins, directions = origins[outside], directions[outside]
    hits = trace(scene, origins, directions)
    hit = np.isfinite(hits.t)
    ends = np.where(hit[:, None], origins + np.where(hit, hits.t, 0)[:, None] * directions, origins + 30 * directions)
    on_surface = signed_distance(ends[hit], centres, radii)
    assert np.abs(on_surface).max(initial=0.0) <= e, ("hit off the oracle's surface", np.abs(on_surface).max())
    deepest = deepest_along(origins, ends, centres, radii)
    assert deepest.min() >= -e, ("passed through the oracle's tube", deepest.min(), (~hit)[np.argmin(deepest)])
    assert hit.sum() > n // 4, ("the rays aimed near the tube missed it", hit.sum(), len(hit))


@pytest.mark.parametrize("curve_type, basis, wrap", KINDS)
def test_spans_are_the_schemas_segments(curve_type, basis, wrap):
    """wrt's spans (:func:`wrt.tubes.curve_spans`) are the schema's segments: as many as USD's ComputeSegmentCounts
    (for pinned cubic curves the documentation's n - 1), with the oracle's points and vertex and varying widths at
    their ends and inside; pinned curves start at P[0] and end at P[n-1]; periodic ones close."""
    rng = np.random.default_rng(7)
    for _ in range(5):
        points, counts, curves, widths, _ = random_prim(rng, curve_type, basis, wrap, n_curves=3)
        stage = Usd.Stage.CreateInMemory()
        prim = UsdGeom.BasisCurves.Define(stage, "/C")
        prim.CreateTypeAttr(curve_type), prim.CreateBasisAttr(basis), prim.CreateWrapAttr(wrap)
        prim.CreateCurveVertexCountsAttr(Vt.IntArray(list(map(int, counts))))
        assert [len(k.segments) for k in curves] == list(prim.ComputeSegmentCounts(Usd.TimeCode.Default()))
        spans = curve_spans(counts, curve_type, basis, wrap)
        assert len(spans.curve) == sum(len(k.segments) for k in curves)
        assert list(np.bincount(spans.curve, minlength=len(counts))) == [len(k.segments) for k in curves]
        ts = np.array([0.0, 0.3, 0.75, 1.0])
        span = np.repeat(np.arange(len(spans.curve)), len(ts))
        t = np.tile(ts, len(spans.curve))
        at = spans.at(spans.extend(points), span, t)
        vertex_widths = rng.uniform(0.2, 0.6, len(points))
        at_w = spans.at(spans.extend(vertex_widths[:, None]), span, t)[:, 0]
        n_varying = sum(k.varying_count() for k in curves)
        assert spans.n_varying == n_varying
        varying = rng.uniform(0.2, 0.6, n_varying)
        ends = varying[spans.varying[span]]
        at_v = ends[:, 0] + t * (ends[:, 1] - ends[:, 0])
        row = 0
        for c, curve in enumerate(curves):
            for s in range(len(curve.segments)):
                for tt in ts:
                    np.testing.assert_allclose(at[row], curve.point(s, tt), atol=1e-9)
                    np.testing.assert_allclose(at_w[row], width_at(curves, c, s, tt, vertex_widths, "vertex", counts),
                                               atol=1e-9)
                    np.testing.assert_allclose(at_v[row], width_at(curves, c, s, tt, varying, "varying", counts),
                                               atol=1e-9)
                    row += 1
            if curve.pinned:
                np.testing.assert_allclose(curve.point(0, 0.0), curve.points[0], atol=1e-9)
                np.testing.assert_allclose(curve.point(len(curve.segments) - 1, 1.0), curve.points[-1], atol=1e-9)
            if curve.periodic:
                np.testing.assert_allclose(curve.point(len(curve.segments) - 1, 1.0), curve.point(0, 0.0), atol=1e-9)


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("curve_type, basis, wrap", KINDS)
def test_tubes_are_the_oracles_swept_spheres(tmp_path, curve_type, basis, wrap, seed):
    """Random curves of random widths: rays hit wrt's tube where they meet the oracle's swept sphere (within the
    documented tolerance), every joint sphere sits on the oracle's curve with its width, and a nonperiodic curve's
    end caps sit at the curve's ends."""
    rng = np.random.default_rng([seed, KINDS.index((curve_type, basis, wrap))])
    points, counts, curves, widths, interpolation = random_prim(rng, curve_type, basis, wrap)
    scene = load(write(tmp_path, stage_text(points, counts, widths, interpolation, curve_type, basis, wrap)))
    centres, radii, _ = sample(curves, widths, interpolation, counts)
    e = tolerance(curve_type, centres, radii)
    check_rays(scene, rng, centres, radii, e)
    # Joint spheres: on the curve (the polyline's vertices), of the oracle's radius there.
    sphere = np.flatnonzero(scene.instances.prototype == 0)
    assert scene.prototypes[0].shapes[0].kind == "sphere"
    m = scene.instances.to_world[sphere]
    at, r = m[:, :3, 3], np.linalg.norm(m[:, :3, 0], axis=1)
    gap = np.linalg.norm(at[:, None] - centres[None], axis=2)
    nearest = gap.argmin(axis=1)
    spacing = np.linalg.norm(np.diff(centres, axis=0), axis=1).max()
    assert gap.min(axis=1).max() <= 1e-4 + spacing, "a joint sphere off the curve"
    np.testing.assert_allclose(r, radii[nearest], atol=2e-3 * radii.max() + np.abs(np.diff(radii)).max())
    for c, curve in enumerate(curves):
        if not curve.periodic:
            for s, t in ((0, 0.0), (len(curve.segments) - 1, 1.0)):
                if width_at(curves, c, s, t, widths, interpolation, counts) > 0.0:
                    end = curve.point(s, t)
                    assert np.linalg.norm(at - end, axis=1).min() <= 1e-5 * (1 + np.abs(end).max())


@pytest.mark.parametrize("curve_type, basis, wrap", KINDS)
def test_tessellated_tubes_stay_on_the_oracle_and_in_usds_extent(tmp_path, curve_type, basis, wrap):
    """Tessellated (``tessellate_gprims=True``), no vertex of wrt's triangles lies outside the oracle's tube, rays
    still hit it within the tolerance (and the 64 sides' flattening), and USD's ComputeExtent bounds the triangles
    (catmullRom, whose curve leaves the hull of its points, aside)."""
    rng = np.random.default_rng([3, KINDS.index((curve_type, basis, wrap))])
    points, counts, curves, widths, interpolation = random_prim(rng, curve_type, basis, wrap)
    path = write(tmp_path, stage_text(points, counts, widths, interpolation, curve_type, basis, wrap))
    scene = load(path, tessellate_gprims=True)
    centres, radii, _ = sample(curves, widths, interpolation, counts)
    e = tolerance(curve_type, centres, radii) + SIDES_ROUNDING * radii.max()
    vertices, triangles = scene.triangles()
    used = vertices[np.unique(triangles)].astype(np.float64)
    used = used[rng.choice(len(used), min(len(used), 20000), replace=False)]
    assert signed_distance(used, centres, radii).max() <= e
    check_rays(scene, rng, centres, radii, e)
    if curve_type == "linear" or basis != "catmullRom":
        stage = Usd.Stage.Open(path)
        extent = np.array(UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(stage.GetPrimAtPath("/C")),
                                                                      Usd.TimeCode.Default()))
        slack = 1e-5 * (1 + np.abs(extent).max())
        assert (used >= extent[0] - slack).all() and (used <= extent[1] + slack).all()


def random_nurbs_prim(rng):
    """Two NURBS curves of random orders (2 to 5), knots (integers, so often repeated: zero-length intervals, and
    breaks where a knot repeats ``order`` times; or reals), maybe weights and ranges, and widths of a random
    interpolation: the prim's USDA text and its oracle curves, widths and interpolation."""
    orders = rng.integers(2, 6, 2)
    counts = np.array([int(rng.integers(o, o + 5)) for o in orders])
    use_ranges, use_weights = rng.random() < 0.5, rng.random() < 0.6
    knots, ranges, points, weights, curves = [], [], [], [], []
    for c, (o, n) in enumerate(zip(orders, counts)):
        k = np.sort(rng.integers(0, 4, n + o)).astype(float)
        k = k if rng.random() < 0.7 else np.sort(rng.uniform(0, 5, n + o))
        while not k[n] > k[o - 1]:
            k = np.sort(rng.integers(0, 6, n + o)).astype(float)
        if use_ranges:
            a, b = np.sort(rng.uniform(k[o - 1], k[n], 2))
            ranges.append((a, b) if b - a > 1e-3 else (k[o - 1], k[n]))
        p = np.float32(np.cumsum(rng.normal(0, 1, (n, 3)) + [1.2, 0, 0], axis=0) + [0, 4.0 * c, 0])
        w = np.float32(rng.uniform(0.3, 3.0, n)) if use_weights else np.ones(n, np.float32)
        points.append(p), weights.append(w), knots.append(k)
        curves.append(NurbsCurve(p, o, k, w, ranges[-1] if use_ranges else None))
    interpolation = str(rng.choice(["constant", "uniform", "varying", "vertex"]))
    size = {"constant": 1, "uniform": 2, "vertex": int(counts.sum()), "varying": int((counts - orders + 2).sum())}
    widths = np.float32(rng.uniform(0.2, 0.6, size[interpolation]))
    body = (f'def NurbsCurves "C"\n{{\n    int[] curveVertexCounts = {list(map(int, counts))}\n'
            f'    int[] order = {list(map(int, orders))}\n    double[] knots = {floats(np.concatenate(knots))}\n'
            f'    point3f[] points = {fmt(np.concatenate(points))}\n'
            f'    float[] widths = {floats(widths)} (interpolation = "{interpolation}")\n')
    if use_weights:
        body += f"    double[] pointWeights = {floats(np.concatenate(weights))}\n"
    if use_ranges:
        body += f"    double2[] ranges = {fmt(ranges)}\n"
    return body + "}\n", curves, counts, widths, interpolation


@pytest.mark.parametrize("seed", [42, 49, 3])
def test_nurbs_tubes_are_the_oracles_swept_spheres(tmp_path, seed):
    """Random NURBS curves against the oracle's de Boor evaluation: rays hit where they meet its swept sphere, and
    both ends of every knot interval carry a sphere (a joint, or the cap of a piece where a knot repeated ``order``
    times breaks the curve: seeds 42 and 49)."""
    rng = np.random.default_rng(seed)
    body, curves, counts, widths, interpolation = random_nurbs_prim(rng)
    scene = load(write(tmp_path, body))
    centres, radii, _ = sample(curves, widths, interpolation, counts)
    check_rays(scene, rng, centres, radii, tolerance("cubic", centres, radii))
    at = scene.instances.to_world[scene.instances.prototype == 0][:, :3, 3]
    for curve in curves:
        for s in range(len(curve.segments)):
            for end in (curve.point(s, 0.0), curve.point(s, 1.0)):
                assert np.linalg.norm(at - end, axis=1).min() <= 1e-5 * (1 + np.abs(end).max()), "no sphere there"


@pytest.mark.parametrize("curve_type, basis, wrap", [("cubic", "catmullRom", "pinned"),
                                                     ("linear", "catmullRom", "periodic"),
                                                     ("cubic", "bspline", "nonperiodic")])
def test_instanced_tubes_are_the_oracles_swept_spheres(tmp_path, curve_type, basis, wrap):
    """Curves in a PointInstancer's prototype (instances turned and scaled uniformly) and under a native instance:
    rays hit each instance where they meet the oracle's swept sphere moved by its transform, radii scaled."""
    rng = np.random.default_rng([5, KINDS.index((curve_type, basis, wrap))])
    points, counts, curves, widths, interpolation = random_prim(rng, curve_type, basis, wrap)
    curve = stage_text(points, counts, widths, interpolation, curve_type, basis, wrap)
    body = ('def PointInstancer "PI"\n{\n    rel prototypes = [</PI/Protos/P>]\n    int[] protoIndices = [0, 0]\n'
            '    point3f[] positions = [(0, 0, 0), (20, 0, 0)]\n'
            '    float3[] scales = [(1.5, 1.5, 1.5), (0.5, 0.5, 0.5)]\n'
            '    quath[] orientations = [(1, 0, 0, 0), (0.8, 0, 0.6, 0)]\n'
            '    def Scope "Protos"\n    {\n        def Xform "P"\n        {\n' + curve + '        }\n    }\n}\n'
            'def Xform "N" (\n    instanceable = true\n    references = </PI/Protos/P>\n)\n{\n'
            '    double3 xformOp:translate = (0, -30, 0)\n'
            '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n')
    scene = load(write(tmp_path, body))
    centres, radii, _ = sample(curves, widths, interpolation, counts)
    placed_centres, placed_radii = [], []
    for quat, scale, move in (((1, 0, 0, 0), 1.5, (0, 0, 0)), ((0.8, 0, 0.6, 0), 0.5, (20, 0, 0)),
                              ((1, 0, 0, 0), 1.0, (0, -30, 0))):
        turn = np.array(Gf.Matrix4d().SetRotate(Gf.Quatd(quat[0], Gf.Vec3d(*quat[1:]))))[:3, :3]  # row vectors
        placed_centres.append(scale * centres @ turn + move)
        placed_radii.append(scale * radii)
    centres, radii = np.concatenate(placed_centres), np.concatenate(placed_radii)
    check_rays(scene, rng, centres, radii, tolerance(curve_type, centres, radii), n=300)
