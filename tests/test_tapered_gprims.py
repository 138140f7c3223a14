"""USD ``Cylinder_1`` and ``Capsule_1`` (``radiusTop`` / ``radiusBottom``): hits, normals and silhouettes against
brute-force references computed here from the schema's definition (not from wrt's formulas), against a fine
tessellation traced by ``wp.Mesh``, and against ``Cylinder`` / ``Capsule`` when the radii are equal; inside
PointInstancers and native instances; time samples, attributes and bad sizes.

The references: a ``Cylinder_1`` is, in its (radius, spine) half-plane, the trapezoid with corners
``(0, -h/2), (rb, -h/2), (rt, h/2), (0, h/2)``; a ``Capsule_1`` is the cone of radii ``rb`` at ``-h/2`` and ``rt``
at ``+h/2`` closed by the spheres tangent to it there (:func:`capsule_spheres`, as ``UsdGeomCapsule_1::ComputeExtent``
and OpenUSD's capsule mesh generator place them), the convex hull of those two spheres, i.e. the union of the balls
swept between them (centre ``c(s)`` and radius ``r(s)`` linear in ``s`` in ``[0, 1]``), whose signed distance is
``min_s |p - c(s)| - r(s)``: a convex function of ``s``, minimised by ternary search.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade  # noqa: E402

import wrt  # noqa: E402
from wrt.instancing import world_boxes  # noqa: E402
from wrt.rays import camera_rays  # noqa: E402

AXES = {"X": 0, "Y": 1, "Z": 2}
SCALE = 1.5  # the uniform scale of every test prim, on top of a rotation and a translation
# (bottom, top) radii: equal, bottom larger, top larger, one of them zero (a cone / a capsule ending in a point)
RADII = {"equal": (0.6, 0.6), "bottom": (0.9, 0.4), "top": (0.3, 0.8), "point": (0.7, 0.0)}


def write_stage(path, type_name, height, bottom, top, axis="Z", extra=None) -> str:
    """A stage with one ``type_name`` gprim at ``/G``, rotated, translated and scaled by ``SCALE``."""
    stage = Usd.Stage.CreateNew(str(path))
    gprim = getattr(UsdGeom, type_name).Define(stage, "/G")
    gprim.CreateHeightAttr(height)
    if bottom is not None:
        gprim.CreateRadiusBottomAttr(bottom)
        gprim.CreateRadiusTopAttr(top)
    gprim.CreateAxisAttr(axis)
    gprim.AddTranslateOp().Set((1.0, -2.0, 3.0))
    gprim.AddRotateXYZOp().Set((10.0, 20.0, 30.0))
    gprim.AddScaleOp().Set((SCALE, SCALE, SCALE))
    if extra:
        extra(stage, gprim)
    stage.Save()
    return str(path)


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # these stages hold nothing wrt should skip
        return wrt.load_usd(path, **kwargs)


def prim_to_world(path) -> np.ndarray:
    """``(4, 4)`` USD local-to-world transform of ``/G`` (row vectors)."""
    stage = Usd.Stage.Open(str(path))  # held: a prim of a stage that is gone has no transform
    return np.array(UsdGeom.XformCache().GetLocalToWorldTransform(stage.GetPrimAtPath("/G")))


def to_local(path, points):
    """World points into the prim's own space."""
    return (np.c_[points, np.ones(len(points))] @ np.linalg.inv(prim_to_world(path)))[:, :3]


def spine_frame(local, axis):
    """``(radial distance, spine coordinate, unit radial direction)`` of local points for USD's ``axis``."""
    k = AXES[axis]
    others = [i for i in range(3) if i != k]
    radial = np.zeros_like(local)
    radial[:, others] = local[:, others]
    r = np.linalg.norm(radial, axis=1)
    return r, local[:, k], radial / np.maximum(r, 1e-300)[:, None]


def capsule_spheres(height, bottom, top):
    """``(bottom centre, bottom radius, top centre, top radius)`` on the spine of a ``Capsule_1``: the cone through
    radius ``bottom`` at ``-height/2`` and ``top`` at ``+height/2`` touches each sphere where it crosses that end, so
    the sphere's radius is the end's over the cosine of the cone's slope and its centre lies ``slope * radius`` past
    the end (towards the larger end)."""
    slope = (bottom - top) / height if height > 0 else 0.0
    secant = math.sqrt(1.0 + slope * slope)
    return -height / 2 - slope * bottom, bottom * secant, height / 2 - slope * top, top * secant


def minimise(f, n):
    """``(n,)`` arguments in ``[0, 1]`` of the minima of the convex, vectorised ``f`` (ternary search)."""
    lo, hi = np.zeros(n), np.ones(n)
    for _ in range(80):
        a, b = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        left = f(a) <= f(b)
        lo, hi = np.where(left, lo, a), np.where(left, b, hi)
    return (lo + hi) / 2


def reference_surface(type_name, height, bottom, top, axis, local):
    """Signed distance of local points to the gprim's surface and its outward unit gradient (local space), brute
    force from the definitions in the module docstring."""
    r, z, radial = spine_frame(local, axis)
    e = np.zeros(3)
    e[AXES[axis]] = 1.0
    if type_name == "Capsule_1":
        z0, r0, z1, r1 = capsule_spheres(height, bottom, top)

        def distance(s):
            return np.hypot(r, z - (z0 + (z1 - z0) * s)) - (r0 + (r1 - r0) * s)

        s = minimise(distance, len(local))
        n = local - (z0 + (z1 - z0) * s)[:, None] * e  # from the nearest swept ball's centre
        return distance(s), n / np.linalg.norm(n, axis=1, keepdims=True)
    # The trapezoid's three outer edges in (r, z): bottom cap, side, top cap; outward normals in (r, z).
    h2 = height / 2.0
    edges = [((0.0, -h2), (bottom, -h2), (0.0, -1.0)), ((bottom, -h2), (top, h2), (height, bottom - top)),
             ((top, h2), (0.0, h2), (0.0, 1.0))]
    dists, normals = [], []
    for (a_r, a_z), (b_r, b_z), normal in edges:
        ab = np.array([b_r - a_r, b_z - a_z])
        ap = np.stack([r - a_r, z - a_z], axis=1)
        along = np.clip(ap @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)  # a top cap of radius 0 is a point
        dists.append(np.linalg.norm(ap - along[:, None] * ab, axis=1))
        normals.append(np.array(normal) / np.linalg.norm(normal))
    nearest = np.argmin(dists, axis=0)
    rz = np.array(normals)[nearest]
    return np.min(dists, axis=0), rz[:, :1] * radial + rz[:, 1:] * e


def frustum_depth(height, bottom, top, axis, local):
    """The largest depth of ``local`` points inside a ``Cylinder_1`` (0 if none is inside)."""
    r, z, _ = spine_frame(local, axis)
    inside = np.minimum(height / 2 - np.abs(z), (bottom + (top - bottom) * (z / height + 0.5) - r)
                        * height / np.hypot(height, bottom - top))  # distance inside the caps' and the side's planes
    return max(inside.max(), 0.0)


def reference_miss_depth(type_name, height, bottom, top, axis, path, origins, directions):
    """How deep the deepest of the rays gets inside the gprim (0: all pass outside)."""
    o = to_local(path, origins)
    d = to_local(path, origins + directions) - o
    if type_name == "Capsule_1":
        # Inside the hull = inside one swept ball: the line's distance to c(s) less than r(s) (convex in s).
        k = AXES[axis]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        z0, r0, z1, r1 = capsule_spheres(height, bottom, top)

        def gap(s):
            to_centre = -o.copy()
            to_centre[:, k] += z0 + (z1 - z0) * s
            along = np.einsum("ij,ij->i", to_centre, d)
            return np.linalg.norm(to_centre - along[:, None] * d, axis=1) - (r0 + (r1 - r0) * s)

        return max(-gap(minimise(gap, len(o))).min(), 0.0)
    # The trapezoid is cheap: points every 0.003 (local units) along each ray, near the shape.
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    samples = o[:, None, :] + np.arange(4.0, 12.0, 0.003)[None, :, None] * d[:, None, :]
    return max(frustum_depth(height, bottom, top, axis, part.reshape(-1, 3)) for part in np.array_split(samples, 8))


def rays_towards(path, n=3000, seed=7):
    """Rays from all directions, 12 units from the prim's centre, aimed within 1.2 units of it (per axis)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    targets = prim_to_world(path)[3, :3] + rng.uniform(-1.2, 1.2, (n, 3))
    return (targets - 12.0 * d).astype(np.float32), d.astype(np.float32)


CASES = [(t, name, axis) for t in ("Cylinder_1", "Capsule_1") for name in RADII for axis in AXES]


@pytest.mark.parametrize("type_name, radii, axis", CASES)
def test_hits_lie_on_the_surface_with_outward_normals(tmp_path, type_name, radii, axis):
    """Every analytic hit lies on the surface (brute-force distance ~0), its normal is the surface's outward one,
    and rays that the reference says pass the shape by miss it."""
    bottom, top = RADII[radii]
    height = 1.8
    path = write_stage(tmp_path / "g.usda", type_name, height, bottom, top, axis)
    scene = load(path)
    origins, directions = rays_towards(path)
    hits = wrt.trace(scene, origins, directions)
    assert 0.3 < hits.hit.mean() < 0.95
    points = origins[hits.hit] + hits.t[hits.hit, None] * directions[hits.hit]
    local = to_local(path, points)
    sdf, _ = reference_surface(type_name, height, bottom, top, axis, local)
    # float32 rays of length ~12: t, so the points, good to about 1e-6 (a cone's side solved from the ray origin was
    # up to 3e-3 off near a tapered capsule's apex).
    assert np.abs(sdf).max() < 1e-5, np.abs(sdf).max()

    # Normals (world) through the geometric normal AOV of an image; compare away from the cylinder's rims.
    camera = wrt.Camera.look_at((6.0, 7.0, 9.0), (1.0, -2.0, 3.0), (0, 1, 0), 20.0)
    img = wrt.render(scene, camera=camera, width=64, height=64, integrator="normals")
    seen = img.aovs["prim"].reshape(-1) >= 0
    assert seen.mean() > 0.05
    o, d = camera_rays(scene, camera, 64, 64)
    p = o[seen] + img.aovs["depth"].reshape(-1)[seen, None] * d[seen]
    _, normal = reference_surface(type_name, height, bottom, top, axis, to_local(path, p))
    expected = normal @ prim_to_world(path)[:3, :3]  # rotation times uniform scale: normals move as vectors
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    got = img.aovs["geometric_normal"].reshape(-1, 3)[seen]
    r, z, _ = spine_frame(to_local(path, p), axis)
    rim = (np.abs(np.abs(z) - height / 2) < 1e-3) & (type_name == "Cylinder_1")
    dots = np.einsum("ij,ij->i", got, expected)[~rim]
    assert dots.min() > 0.9999, dots.min()

    # Misses pass outside: no point of theirs is more than 1e-4 inside the shape.
    assert reference_miss_depth(type_name, height, bottom, top, axis, path, origins[~hits.hit],
                                directions[~hits.hit]) < 1e-4


@pytest.mark.parametrize("type_name, radii, axis", [c for c in CASES if c[2] != "Y"])
def test_hits_agree_with_a_fine_tessellation_traced_by_wp_mesh(tmp_path, type_name, radii, axis):
    """The analytic shape against its tessellation (512 segments per circle) traced by ``accel="warp"``.

    Every vertex lies on the surface and the shape is convex, so the mesh lies inside it, at most about two chord
    sagittas ``R (1 - cos(pi / 512))`` deep (a chord across and one along a capsule's rings; ``R`` = largest world
    radius): a ray meeting the surface at incidence ``cos`` enters the mesh ``0 .. 2 sagitta / cos`` later."""
    bottom, top = RADII[radii]
    path = write_stage(tmp_path / "g.usda", type_name, 1.8, bottom, top, axis)
    origins, directions = rays_towards(path, seed=3)
    ours = wrt.trace(load(path), origins, directions)
    mesh = wrt.trace(load(path, tessellate_gprims=512), origins, directions, accel="warp")
    both = ours.hit & mesh.hit
    assert both.mean() > 0.3
    sagitta = SCALE * max(bottom, top) * (1.0 - math.cos(math.pi / 512))
    # The incidence at our hit, from the brute-force reference normal.
    points = origins[both] + ours.t[both, None] * directions[both]
    _, normal = reference_surface(type_name, 1.8, bottom, top, axis, to_local(path, points))
    normal = normal @ prim_to_world(path)[:3, :3]
    cos = np.abs(np.einsum("ij,ij->i", normal / np.linalg.norm(normal, axis=1, keepdims=True), directions[both]))
    steep = cos > 0.2
    late = mesh.t[both][steep] - ours.t[both][steep]
    assert late.min() > -2e-5, late.min()  # float32 rounding at t ~ 10
    assert np.all(late < 2.0 * sagitta / cos[steep] + 2e-5), (late.max(), sagitta)
    # Hits of one and misses of the other only at grazing incidence (the silhouette's chords).
    assert ours.hit.sum() - both.sum() <= 0.01 * ours.hit.sum() and mesh.hit.sum() == both.sum()

    # The mesh's winding faces out, and a capsule's vertex normals are the surface's (but at an apex, which has none).
    (tess,) = load(path, tessellate_gprims=32).meshes
    world = prim_to_world(path)[:3, :3]
    corners = tess.points[tess.indices]
    _, outward = reference_surface(type_name, 1.8, bottom, top, axis, to_local(path, corners.mean(axis=1)))
    winding = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert np.all(np.einsum("ij,ij->i", winding, outward @ world) > 0)
    if type_name == "Capsule_1":
        local = to_local(path, corners.reshape(-1, 3))
        _, normal = reference_surface(type_name, 1.8, bottom, top, axis, local)
        normal = normal @ world
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        r, z, _ = spine_frame(local, axis)
        smooth = (r > 1e-5) | (z < 0)  # the points are float32
        dots = np.einsum("ij,ij->i", tess.normals.reshape(-1, 3), normal)[smooth]
        assert dots.min() > 1 - 1e-6  # float32 normals


@pytest.mark.parametrize("type_name", ["Cylinder_1", "Capsule_1"])
@pytest.mark.parametrize("radii", ["bottom", "top"])
def test_silhouettes_have_the_radii_at_each_end(tmp_path, type_name, radii):
    """An orthographic grid of rays across a Z-axis gprim (untransformed): each row's hits span the width of the
    shape's outline at that height, from the brute-force outline (the trapezoid, or the hull of the two circles)."""
    bottom, top = RADII[radii]
    height = 1.8
    stage = Usd.Stage.CreateNew(str(tmp_path / "g.usda"))
    gprim = getattr(UsdGeom, type_name).Define(stage, "/G")
    gprim.CreateHeightAttr(height)
    gprim.CreateRadiusBottomAttr(bottom)
    gprim.CreateRadiusTopAttr(top)
    stage.Save()
    scene = load(str(tmp_path / "g.usda"))
    step = 0.004
    x = np.arange(-1.2, 1.2 + step / 2, step)
    zs = np.arange(-1.6, 1.6, 0.05) + 0.0123  # no row in a cap's plane
    grid_x, grid_z = np.meshgrid(x, zs)
    origins = np.stack([grid_x.ravel(), np.full(grid_x.size, -5.0), grid_z.ravel()], 1).astype(np.float32)
    hits = wrt.trace(scene, origins, np.tile(np.float32([0, 1, 0]), (len(origins), 1))).hit.reshape(grid_x.shape)
    if type_name == "Cylinder_1":
        inside = np.abs(zs) <= height / 2
        half = np.where(inside, bottom + (top - bottom) * (zs / height + 0.5), 0.0)
    else:
        s = np.linspace(0.0, 1.0, 40001)
        z0, r0, z1, r1 = capsule_spheres(height, bottom, top)
        centres, radius = z0 + (z1 - z0) * s, r0 + (r1 - r0) * s
        half = np.sqrt(np.maximum(radius[None] ** 2 - (zs[:, None] - centres[None]) ** 2, 0.0)).max(axis=1)
    got = np.where(hits.any(axis=1), np.where(hits, np.abs(grid_x), 0.0).max(axis=1), 0.0)
    np.testing.assert_allclose(got, half, atol=step)
    assert np.all(hits.sum(axis=1) >= np.floor(2 * half / step) - 1)  # no gaps inside the outline


@pytest.mark.parametrize("axis", list(AXES))
@pytest.mark.parametrize("tapered, plain, attrs", [
    ("Cylinder_1", "Cylinder", {"Height": 1.8, "Radius": 0.6}),
    ("Capsule_1", "Capsule", {"Height": 1.8, "Radius": 0.6}),
    ("Capsule_1", "Capsule", {"Height": 0.0, "Radius": 0.6}),
])
def test_equal_radii_hit_as_cylinder_and_capsule_do(tmp_path, tapered, plain, attrs, axis):
    """``radiusTop == radiusBottom == radius`` gives bit-identical hits and normals to the old gprim."""
    def stage(type_name, name):
        def extra(_, gprim):
            if type_name == plain:
                gprim.CreateRadiusAttr(attrs["Radius"])
        radius = attrs["Radius"] if type_name == tapered else None
        return write_stage(tmp_path / name, type_name, attrs["Height"], radius, radius, axis, extra)

    path = stage(tapered, "a.usda")
    a, b = load(path), load(stage(plain, "b.usda"))
    origins, directions = rays_towards(path, n=2000)
    ha, hb = wrt.trace(a, origins, directions), wrt.trace(b, origins, directions)
    assert ha.hit.mean() > 0.2
    np.testing.assert_array_equal(ha.t, hb.t)
    camera = wrt.Camera.look_at((6.0, 7.0, 9.0), (1.0, -2.0, 3.0), (0, 1, 0), 30.0)
    ia = wrt.render(a, camera=camera, width=32, height=32, integrator="normals")
    ib = wrt.render(b, camera=camera, width=32, height=32, integrator="normals")
    np.testing.assert_array_equal(ia.aovs["geometric_normal"], ib.aovs["geometric_normal"])


def test_point_instancer_and_native_instance_prototypes(tmp_path):
    """A PointInstancer whose prototype is a Cylinder_1 (radius 1 at the bottom, 0.5 at the top, height 2, along Z),
    and an instanceable prim holding a Capsule_1: rays straight down hit each instance's top where the frustum's
    and capsule's top are, analytically and tessellated."""
    path = str(tmp_path / "pi.usda")
    stage = Usd.Stage.CreateNew(path)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    cyl = UsdGeom.Cylinder_1.Define(stage, "/PI/Protos/Frustum")
    cyl.CreateHeightAttr(2.0)
    cyl.CreateRadiusBottomAttr(1.0)
    cyl.CreateRadiusTopAttr(0.5)
    pi.CreatePrototypesRel().SetTargets([cyl.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(5, 0, 0), Gf.Vec3f(10, 0, 1)])
    proto = stage.CreateClassPrim("/Proto")  # abstract: drawn only through the instances
    capsule = UsdGeom.Capsule_1.Define(stage, "/Proto/C")
    capsule.CreateHeightAttr(1.0)
    capsule.CreateRadiusBottomAttr(0.25)
    capsule.CreateRadiusTopAttr(0.5)
    for k, x in enumerate((20.0, 30.0)):
        inst = UsdGeom.Xform.Define(stage, f"/I{k}")
        inst.GetPrim().GetReferences().AddInternalReference(proto.GetPath())
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set((x, 0.0, 0.0))
    stage.Save()
    # Expected t from z = 10: the frustum's top cap (z = 1, radius 0.5) or its side (radius 0.75 - z / 4: 0.7 at
    # z = 0.2, 0.75 at z = 0), the capsule's top sphere (tangent to the cone of radius 0.5 at z = 0.5).
    _, _, top_centre, top_radius = capsule_spheres(1.0, 0.25, 0.5)
    xs = [0.0, 0.7, 5.0, 10.0, 10.75, 20.0, 30.2]
    expected = [9.0, 9.8, 9.0, 8.0, 9.0, 10.0 - top_centre - top_radius,
                10.0 - top_centre - math.sqrt(top_radius**2 - 0.04)]
    origins = np.array([[x, 0.0, 10.0] for x in xs], np.float32)
    directions = np.tile(np.float32([0, 0, -1]), (len(xs), 1))
    for tessellate in (False, 256):
        scene = load(path, tessellate_gprims=tessellate)
        assert len(scene.instances) == 5
        hits = wrt.trace(scene, origins, directions)
        np.testing.assert_allclose(hits.t, expected, atol=1e-5 if tessellate is False else 2e-4)
        np.testing.assert_array_equal(hits.instance, [0, 0, 1, 2, 2, 3, 4])


def test_attributes_time_samples_and_instancing_are_read(tmp_path):
    """displayColor, material, doubleSided and orientation reach the shape; a time-sampled radiusTop is read at each
    time code (and at its first sample with ``time=None``)."""
    def extra(stage, gprim):
        gprim.CreateDisplayColorAttr([(0.2, 0.4, 0.6)])
        gprim.CreateDoubleSidedAttr(True)
        gprim.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
        radius_top = gprim.GetRadiusTopAttr()
        radius_top.Clear()
        radius_top.Set(0.2, 1.0)
        radius_top.Set(0.6, 2.0)
        material = UsdShade.Material.Define(stage, "/M")
        shader = UsdShade.Shader.Define(stage, "/M/S")
        shader.CreateIdAttr("UsdPreviewSurface")
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((1.0, 0.0, 0.0))
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(gprim.GetPrim()).Bind(material)

    path = write_stage(tmp_path / "g.usda", "Cylinder_1", 2.0, 0.8, 0.2, "Z", extra)
    tops = {}
    for time in (None, 1.0, 2.0):
        (shape,) = load(path, time=time).shapes
        assert shape.kind == "cone" and shape.double_sided and shape.params[3] == -1.0 and shape.material_id >= 0
        np.testing.assert_allclose(shape.color, [0.2, 0.4, 0.6])
        tops[time] = float(shape.params[1])
    assert tops == pytest.approx({None: 0.25, 1.0: 0.25, 2.0: 0.75})


@pytest.mark.parametrize("type_name, height, bottom, top, shown", [
    ("Cylinder_1", 0.0, 0.5, 0.5, "height = 0"),
    ("Cylinder_1", 1.0, -0.5, 0.5, "radiusBottom = -0.5"),
    ("Capsule_1", 1.0, 0.5, float("nan"), "radiusTop = nan"),
    ("Capsule_1", -1.0, 0.5, 0.5, "height = -1"),
    ("Capsule_1", 1.0, 0.0, 0.0, "radiusBottom = radiusTop = 0"),
    ("Cylinder_1", 1.0, 0.5, float("inf"), "radiusTop = inf"),
])
def test_bad_sizes_are_skipped_with_a_warning_naming_the_prim(tmp_path, type_name, height, bottom, top, shown):
    path = write_stage(tmp_path / "g.usda", type_name, height, bottom, top)
    for tessellate in (False, True):
        with pytest.warns(UserWarning, match=rf"zero, negative or non-finite size.*/G.*{shown}|{shown}.*/G"):
            scene = wrt.load_usd(path, tessellate_gprims=tessellate)
        assert scene.shapes == [] and scene.meshes == []


@pytest.mark.parametrize("type_name", ["Cylinder_1", "Capsule_1"])
def test_bounds_hold_the_shape(tmp_path, type_name):
    """World bounds of an untransformed Z-axis gprim: USD's extent (the larger radius across; the height, plus for a
    capsule each end's sphere past it, along)."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "g.usda"))
    gprim = getattr(UsdGeom, type_name).Define(stage, "/G")
    gprim.CreateHeightAttr(2.0)
    gprim.CreateRadiusBottomAttr(0.3)
    gprim.CreateRadiusTopAttr(0.8)
    stage.Save()
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(gprim, Usd.TimeCode.Default())
    (shape,) = load(str(tmp_path / "g.usda")).shapes
    lower, upper = world_boxes(*shape.local_bounds(), shape.to_world[None])
    np.testing.assert_allclose(lower[0], np.array(extent[0]), atol=1e-6)  # the extent is float32
    np.testing.assert_allclose(upper[0], np.array(extent[1]), atol=1e-6)


def test_a_capsule_of_height_zero_is_its_larger_sphere_and_any_other_is_tapered(tmp_path):
    """Height 0: both spheres at the centre, the hull is the larger one (USD's extent: slope 0). A radius difference
    above the height still leaves the smaller sphere outside the larger (USD's spheres are centred past the ends), so
    the shape is a tapered capsule that fills USD's extent."""
    path = write_stage(tmp_path / "flat.usda", "Capsule_1", 0.0, 1.0, 0.25, "X")
    (shape,) = load(path).shapes
    assert shape.kind == "sphere"
    local = to_local(path, (shape.to_world @ [0.0, 0.0, 0.0, 1.0])[None, :3])
    np.testing.assert_allclose(local, [[0.0, 0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(shape.to_world[:3, :3], axis=0), [SCALE] * 3)
    path = write_stage(tmp_path / "g.usda", "Capsule_1", 0.5, 1.0, 0.25, "X")
    (shape,) = load(path).shapes
    assert shape.kind == "tapered"
    z0, r0, z1, r1 = capsule_spheres(0.5, 1.0, 0.25)
    assert z1 - z0 > r0 - r1
    lower, upper = shape.local_bounds()
    ends = to_local(path, np.array([[0.0, 0.0, lower[2]], [0.0, 0.0, upper[2]]]) @ shape.to_world[:3, :3].T
                    + shape.to_world[:3, 3])
    np.testing.assert_allclose(ends[:, 0], [z0 - r0, z1 + r1], atol=1e-9)


@pytest.mark.parametrize("axis", list(AXES))
@pytest.mark.parametrize("radii", ["bottom", "top", "point"])
def test_a_capsule_fills_the_extent_usd_computes_for_it(tmp_path, radii, axis):
    """A tapered ``Capsule_1``'s box is the one ``UsdGeomCapsule_1::ComputeExtent`` gives: the radii are the cone's
    at the ends of ``height``, and the spheres tangent to the cone there are larger by the secant of its slope and
    sit past the ends (as OpenUSD's capsule mesh generator draws it). Read as spheres of the two radii centred at the
    ends, the capsule's box was off USD's by up to 0.46 of the larger radius (USD's is longer at the larger end,
    shorter at the smaller, and wider)."""
    bottom, top = RADII[radii]
    path = write_stage(tmp_path / "g.usda", "Capsule_1", 1.8, bottom, top, axis)
    stage = Usd.Stage.Open(path)
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(stage.GetPrimAtPath("/G")),
                                                       Usd.TimeCode.Default())
    (shape,) = load(path).shapes
    # The canonical box moved by the shape's transform, into the prim's own space: a box again (the axis rotation
    # and the scales are axis-aligned there).
    lower, upper = shape.local_bounds()
    corners = np.array([[(lower, upper)[i][0], (lower, upper)[j][1], (lower, upper)[k][2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    local = to_local(path, corners @ shape.to_world[:3, :3].T + shape.to_world[:3, 3])
    np.testing.assert_allclose(local.min(axis=0), np.array(extent[0]), atol=1e-6)
    np.testing.assert_allclose(local.max(axis=0), np.array(extent[1]), atol=1e-6)


@pytest.mark.parametrize("radii", [(0.0, 1.0), (1.0, 0.0)], ids=["point at the bottom", "point at the top"])
def test_a_capsule_whose_point_end_lies_on_its_sphere_tessellates_to_usds_extent(tmp_path, radii):
    """A ``Capsule_1`` ending in a point (one radius 0) whose height is tiny beside its radius: the point lies on
    the sphere tangent to the cone there (the tangent latitude rounds to the pole), so the shape is that sphere, as
    USD's extent has it. Tessellated, its profile held two poles in a row, which the lathe joined with a ring of
    triangles to points past the end of the array: ``load_usd(tessellate_gprims=True)`` raised an IndexError."""
    path = write_stage(tmp_path / "g.usda", "Capsule_1", 1e-9, *radii)
    stage = Usd.Stage.Open(path)
    extent = np.array(UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(stage.GetPrimAtPath("/G")),
                                                                Usd.TimeCode.Default()))
    points, _ = load(path, tessellate_gprims=64).triangles()
    local = to_local(path, np.asarray(points, np.float64))
    size = np.linalg.norm(extent[1] - extent[0])
    np.testing.assert_allclose(local.min(axis=0), extent[0], atol=1e-6 * size)
    np.testing.assert_allclose(local.max(axis=0), extent[1], atol=1e-6 * size)
