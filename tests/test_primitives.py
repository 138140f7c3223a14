"""Analytic primitives: closed-form hits and normals of spheres, boxes, cylinders, cones, capsules, planes and disks
(transformed: non-uniform scale, shear, mirroring), USD gprims mapped to them, tessellation converging as O(h^2),
and real gprim scenes rendered analytically and tessellated.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402
from wrt.compare import compare_hits  # noqa: E402
from wrt.instancing import Instances, Prototype, world_boxes  # noqa: E402
from wrt.primitives import Shape, axis_rotation, shape_transform  # noqa: E402
from wrt.rays import camera_rays, random_rays  # noqa: E402


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path, **kwargs)


def placed(linear=np.eye(3), translate=(0.0, 0.0, 0.0)) -> np.ndarray:
    m = shape_transform(np.asarray(linear, np.float64))
    m[:3, 3] = translate
    return m


def one_shape(kind, to_world, params=(1, 0, 0, 1), double_sided=True) -> wrt.Scene:
    return wrt.Scene(shapes=[Shape("/s", kind, to_world, np.asarray(params, np.float32), double_sided=double_sided)])


def trace_one(scene, origin, direction):
    hits = wrt.trace(scene, np.array([origin], np.float32), np.array([direction], np.float32))
    return float(hits.t[0])


# Closed forms: (kind, transform, params, ray origin, ray direction, expected t), in canonical terms scaled by USD's
# parameters. Rays start outside unless noted.
R45 = np.array([[math.cos(math.pi / 4), -math.sin(math.pi / 4), 0],
                [math.sin(math.pi / 4), math.cos(math.pi / 4), 0],
                [0, 0, 1]])
SHEAR = np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
CLOSED_FORMS = {
    "sphere_r2": ("sphere", placed(2 * np.eye(3), (1, 2, 3)), (0, 0, 0, 1), (1, 2, 13), (0, 0, -1), 8.0),
    "sphere_from_inside": ("sphere", placed(2 * np.eye(3), (1, 2, 3)), (0, 0, 0, 1), (1, 2, 3), (0, 0, 2), 1.0),
    "ellipsoid_x": ("sphere", placed(np.diag([3, 1, 1])), (0, 0, 0, 1), (10, 0, 0), (-1, 0, 0), 7.0),
    "ellipsoid_y": ("sphere", placed(np.diag([3, 1, 1])), (0, 0, 0, 1), (0, 10, 0), (0, -2, 0), 4.5),
    "mirrored_sphere": ("sphere", placed(np.diag([-2, 2, 2])), (0, 0, 0, 1), (0, 0, 10), (0, 0, -1), 8.0),
    "box_rotated_45": ("box", placed(R45), (0, 0, 0, 1), (5, 0, 0), (-1, 0, 0), 5 - math.sqrt(2)),
    "box_sheared": ("box", placed(SHEAR), (0, 0, 0, 1), (5, 1, 0), (-1, 0, 0), 5 - 1.5),
    "cylinder_side_axis_x": ("cylinder", placed(axis_rotation("X") @ np.diag([1, 1, 2])), (1, 0, 0, 1), (0, 5, 0),
                             (0, -1, 0), 4.0),
    "cylinder_cap_axis_x": ("cylinder", placed(axis_rotation("X") @ np.diag([1, 1, 2])), (1, 0, 0, 1), (5, 0, 0),
                            (-1, 0, 0), 3.0),
    "open_cylinder_inside": ("cylinder", placed(np.diag([1, 1, 2])), (0, 0, 0, 1), (0, 0, 5), (0, 0, -1), math.inf),
    "cone_apex_axis_y": ("cone", placed(axis_rotation("Y")), (1, 0, 0, 1), (0, 5, 0), (0, -1, 0), 4.0),
    "cone_base_axis_y": ("cone", placed(axis_rotation("Y")), (1, 0, 0, 1), (0, -5, 0), (0, 1, 0), 4.0),
    "cone_side_axis_y": ("cone", placed(axis_rotation("Y")), (1, 0, 0, 1), (5, 0, 0), (-1, 0, 0), 4.5),
    "capsule_top": ("capsule", placed(0.5 * np.eye(3)), (2.0, 0, 0, 1), (0, 0, 5), (0, 0, -1), 3.5),
    "capsule_cap_side": ("capsule", placed(0.5 * np.eye(3)), (2.0, 0, 0, 1), (5, 0, 1.2), (-1, 0, 0),
                         5 - math.sqrt(0.21)),
    "capsule_body": ("capsule", placed(0.5 * np.eye(3)), (2.0, 0, 0, 1), (5, 0, 0.3), (-1, 0, 0), 4.5),
    "plane_axis_y_hit": ("plane", placed(axis_rotation("Y") @ np.diag([2, 1, 1])), (0, 0, 0, 1), (1.5, 3, 0.5),
                         (0, -1, 0), 3.0),
    "plane_axis_y_miss": ("plane", placed(axis_rotation("Y") @ np.diag([2, 1, 1])), (0, 0, 0, 1), (0, 3, 1.5),
                          (0, -1, 0), math.inf),
    "disk_edge_miss": ("disk", placed(), (0, 0, 0, 1), (0.8, 0.7, 1), (0, 0, -1), math.inf),
    "disk_hit": ("disk", placed(), (0, 0, 0, 1), (0.6, 0.7, 1), (0, 0, -1), 1.0),
}


@pytest.mark.parametrize("case", list(CLOSED_FORMS))
def test_analytic_hits_match_closed_forms(case):
    kind, to_world, params, origin, direction, expected = CLOSED_FORMS[case]
    t = trace_one(one_shape(kind, to_world, params), origin, direction)
    if math.isinf(expected):
        assert math.isinf(t)
    else:
        assert t == pytest.approx(expected, rel=1e-5)


def render_normals(scene, camera, size=48):
    img = wrt.render(scene, camera=camera, width=size, height=size, integrator="normals")
    origins, directions = camera_rays(scene, camera, size, size)
    hit = (img.aovs["prim"] >= 0).reshape(-1)
    points = origins[hit] + img.aovs["depth"].reshape(-1)[hit, None] * directions[hit]
    return img, hit, points


def test_ellipsoid_and_sheared_normals_are_the_inverse_transpose():
    """World normals of a sheared, non-uniformly scaled, mirrored sphere: the gradient of its implicit function."""
    linear = np.array([[2.0, 0.6, 0.0], [0.0, -1.0, 0.3], [0.0, 0.0, 1.5]])  # det < 0: mirrored
    scene = one_shape("sphere", placed(linear, (0.5, 0.2, -0.3)), double_sided=False)
    camera = wrt.Camera.look_at((6, 5, 7), (0.5, 0.2, -0.3), (0, 1, 0), 40.0)
    img, hit, points = render_normals(scene, camera)
    assert hit.mean() > 0.05
    inv = np.linalg.inv(linear)
    local = (points - [0.5, 0.2, -0.3]) @ inv.T
    np.testing.assert_allclose(np.linalg.norm(local, axis=1), 1.0, atol=1e-4)  # the hit lies on the surface
    gradient = local @ inv  # grad of |A^-1 (p - c)|^2 / 2 = A^-T A^-1 (p - c)
    expected = gradient / np.linalg.norm(gradient, axis=1, keepdims=True)
    got = img.aovs["geometric_normal"].reshape(-1, 3)[hit]
    np.testing.assert_allclose(got, expected, atol=1e-4)  # outward, as the camera sees the outside


@pytest.mark.parametrize("device", ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else []))
@pytest.mark.parametrize("kind, params", [("sphere", (0.0, 0.0)), ("cylinder", (0.0, 0.0)), ("cone", (1.0, 0.0)),
                                          ("cone", (1.0, 0.4)), ("capsule", (0.5, 0.0)), ("tapered", (0.5, 0.3))])
def test_quadric_hits_do_not_depend_on_the_scene_scale(kind, params, device):
    """A shape of radius R seen by unit rays has a canonical direction of length 1/R: at R = 1e-20 or 1e25 its
    ``d . d`` overflowed or underflowed and the shape was missed, while triangles traced fine at every scale. The
    same rays, scaled with the shape, must give the same ``t / R``, and a unit shape the same ``t |d|`` for any
    direction length."""
    def hits(radius, length=1.0):
        shape = Shape("/S", kind, np.diag([radius, radius, radius, 1.0]), np.array([*params, 0, 1], np.float32))
        origins = np.array([[0.3, 0.2, 5.0], [5.0, 0.2, 0.3], [0.1, 4.0, -0.2]], np.float32) * np.float32(radius)
        directions = np.array([[0, 0, -1], [-1, 0, 0], [0, -1, 0.05]], np.float32) * np.float32(length)
        scene = wrt.Scene(shapes=[shape])
        t = wrt.trace(scene, origins, directions, device=device).t * np.float32(length) / np.float32(radius)
        return t, wrt.occluded(scene, origins, directions, device=device)

    reference, blocked = hits(1.0)
    assert np.isfinite(reference).sum() >= 2
    for radius, length in [(1e-20, 1.0), (1e-30, 1.0), (1e25, 1.0), (1.0, 1e-25), (1.0, 1e20)]:
        t, occluded = hits(radius, length)
        np.testing.assert_allclose(t, reference, rtol=1e-5, err_msg=f"R={radius:g}, |d|={length:g}")
        np.testing.assert_array_equal(occluded, blocked)


def test_left_handed_orientation_turns_the_inside_to_the_front():
    """A single-sided sphere: camera rays see its near side; with orientation = leftHanded its outside is the back,
    culled, and they see the inside of the far side instead."""
    camera = wrt.Camera.look_at((0, 0, 10), (0, 0, 0), (0, 1, 0), 10.0)
    depths = {}
    for sign in (1.0, -1.0):
        scene = one_shape("sphere", placed(np.diag([-2, 2, 2])), (0, 0, 0, sign), double_sided=False)
        img = wrt.render(scene, camera=camera, width=9, height=9, integrator="depth")
        depths[sign] = img.aovs["depth"][4, 4]
    assert depths[1.0] == pytest.approx(8.0, rel=1e-5) and depths[-1.0] == pytest.approx(12.0, rel=1e-5)


def test_shapes_trace_against_their_tessellations_converging_as_h_squared(tmp_path):
    """A USD sphere traced analytically and tessellated with 8..64 segments: the largest position error of rays that
    hit squarely falls by about 4 each time the segments double (the sagitta of a chord)."""
    path = str(tmp_path / "sphere.usda")
    stage = Usd.Stage.CreateNew(path)
    sphere = UsdGeom.Sphere.Define(stage, "/S")
    sphere.CreateRadiusAttr(1.5)
    sphere.AddTranslateOp().Set((1, 2, 3))
    stage.Save()
    analytic = load(path)
    rng = np.random.default_rng(5)
    # Rays from 20 units away towards points within half a radius of the centre: incidence within 30 degrees.
    n = 4000
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    targets = np.array([1, 2, 3]) + rng.uniform(-0.5, 0.5, (n, 3))
    origins = (targets - 20 * directions).astype(np.float32)
    directions = directions.astype(np.float32)
    exact = wrt.trace(analytic, origins, directions)
    assert exact.hit.all()
    np.testing.assert_allclose(exact.prim, analytic.stats()["rendered_triangles"])  # the one shape's id
    errors = []
    for segments in (8, 16, 32, 64):
        tess = wrt.trace(load(path, tessellate_gprims=segments), origins, directions)
        assert tess.hit.all()
        errors.append(float(np.max(np.abs(tess.t - exact.t))))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 3.0) & (ratios < 5.5)), (errors, ratios)
    assert errors[-1] < 1.5 * (1 - math.cos(2 * math.pi / 64)) * 2  # within a few sagittas of the chord


def gprim_stage(tmp_path, kind, axis="Z", **attrs) -> tuple[str, str]:
    path = str(tmp_path / f"{kind}_{axis}.usda")
    stage = Usd.Stage.CreateNew(path)
    schema = getattr(UsdGeom, kind).Define(stage, f"/{kind}")
    for name, value in attrs.items():
        getattr(schema, f"Create{name}Attr")(value)
    if hasattr(schema, "CreateAxisAttr"):
        schema.CreateAxisAttr(axis)
    schema.AddTranslateOp().Set((1, -2, 3))
    schema.AddRotateXYZOp().Set((10, 20, 30))
    stage.Save()
    return path, f"/{kind}"


@pytest.mark.parametrize("axis", ["X", "Y", "Z"])
@pytest.mark.parametrize(
    "kind, attrs",
    [
        ("Sphere", {"Radius": 1.5}),
        ("Cube", {"Size": 3.0}),
        ("Cylinder", {"Height": 3.0, "Radius": 0.5}),
        ("Cone", {"Height": 3.0, "Radius": 0.5}),
        ("Capsule", {"Height": 3.0, "Radius": 0.5}),
        ("Plane", {"Width": 3.0, "Length": 1.0}),
        ("Cylinder_1", {"Height": 3.0, "RadiusBottom": 0.5, "RadiusTop": 0.2}),
        ("Cylinder_1", {"Height": 3.0, "RadiusBottom": 0.2, "RadiusTop": 0.5}),
        ("Capsule_1", {"Height": 3.0, "RadiusBottom": 0.5, "RadiusTop": 0.5}),
    ],
)
def test_gprim_parameters_and_axis_match_usd_bounds(tmp_path, kind, attrs, axis):
    """Each gprim's shape, moved to the world, has the world bounds USD computes for it (size, axis and transform)."""
    path, prim_path = gprim_stage(tmp_path, kind, axis, **attrs)
    (shape,) = load(path).shapes
    stage = Usd.Stage.Open(path)
    prim = stage.GetPrimAtPath(prim_path)
    extent = np.array(UsdGeom.Boundable(prim).ComputeExtent(Usd.TimeCode.Default()), np.float64)
    world = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(prim)).T
    expected = world_boxes(extent[0], extent[1], world[None])
    got = world_boxes(*shape.local_bounds(), shape.to_world[None])
    np.testing.assert_allclose(got, expected, atol=1e-6)


def test_cone_apex_points_along_the_positive_axis(tmp_path):
    path, _ = gprim_stage(tmp_path, "Cone", "X", Height=2.0, Radius=1.0)
    (shape,) = load(path).shapes
    apex = shape.to_world @ [0, 0, 1, 1]
    base = shape.to_world @ [0, 0, -1, 1]
    stage = Usd.Stage.Open(path)
    world = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(stage.GetPrimAtPath("/Cone"))).T
    np.testing.assert_allclose(apex[:3], (world @ [1, 0, 0, 1])[:3], atol=1e-9)
    np.testing.assert_allclose(base[:3], (world @ [-1, 0, 0, 1])[:3], atol=1e-9)


def test_cone_hits_from_far_away_lie_on_the_surface(tmp_path):
    """Rays from 12 units away at a Cone (radius 0.7, height 1.8): every hit lies on its surface (distance to the
    side or base, in the cone's (radius, height) half-plane). The side's quadratic was solved from the far ray origin,
    its constant term the difference of two numbers some 300 times larger, and hits (most near the apex, where rays
    pass close to the surface) were up to 3.2e-4 off; 2.8e-6 when solved from the ray's point nearest the centre."""
    path, prim_path = gprim_stage(tmp_path, "Cone", "Z", Height=1.8, Radius=0.7)
    stage = Usd.Stage.Open(path)
    world = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(stage.GetPrimAtPath(prim_path)))  # row vectors
    rng = np.random.default_rng(11)
    directions = rng.normal(size=(3000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = world[3, :3] + rng.uniform(-1.0, 1.0, (3000, 3)) - 12.0 * directions
    hits = wrt.trace(load(path), origins.astype(np.float32), directions.astype(np.float32))
    assert hits.hit.mean() > 0.3
    points = origins[hits.hit] + hits.t[hits.hit, None] * directions[hits.hit]
    local = (np.c_[points, np.ones(len(points))] @ np.linalg.inv(world))[:, :3]
    rz = np.stack([np.linalg.norm(local[:, :2], axis=1), local[:, 2]], axis=1)
    distances = []
    for a, b in (((0.0, -0.9), (0.7, -0.9)), ((0.7, -0.9), (0.0, 0.9))):  # the base and the side
        a, b = np.array(a), np.array(b)
        along = np.clip((rz - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        distances.append(np.linalg.norm(rz - a - along[:, None] * (b - a), axis=1))
    assert np.min(distances, axis=0).max() < 1e-5


def test_zero_size_gprims_are_skipped_with_a_warning_naming_them(tmp_path):
    path, _ = gprim_stage(tmp_path, "Sphere", Radius=0.0)
    with pytest.warns(UserWarning, match=r"zero, negative or non-finite size.*/Sphere"):
        scene = wrt.load_usd(path)
    assert scene.shapes == []


def test_a_gprim_size_of_the_wrong_type_is_the_schemas_fallback_with_a_warning_naming_it(tmp_path):
    """A string radius stopped the whole load with "cannot read this prim (could not convert string to float)",
    naming no attribute, and was then skipped; USD's typed read passes it over for the schema's fallback, so
    ``BBoxCache`` (and usdview) has a sphere of radius 1 and a cube of size 2 there, and so does wrt."""
    path = tmp_path / "mistyped.usda"
    path.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    string radius = "big"\n}\n'
                    'def Cube "Box"\n{\n    token size = "small"\n}\ndef Sphere "Kept"\n{\n}\n')
    with pytest.warns(UserWarning) as caught:
        scene = wrt.load_usd(path)
    found = [str(w.message) for w in caught if "another type than the schema's" in str(w.message)]
    assert len(found) == 1 and "string radius = 'big'" in found[0] and "token size = 'small'" in found[0], found
    assert "/Ball" in found[0] and "/Box" in found[0]
    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    assert [shape.path for shape in scene.shapes] == ["/Ball", "/Box", "/Kept"]
    for shape in scene.shapes:
        box = cache.ComputeWorldBound(stage.GetPrimAtPath(shape.path)).ComputeAlignedRange()
        np.testing.assert_allclose(np.diag(shape.to_world)[:3], np.array(box.GetMax()), err_msg=shape.path)


NESTED_KITS = """#usda 1.0
class Xform "Lib"
{
    def Xform "Inner"
    {
        def Sphere "Ball"
        {
            double radius = 0
        }
        def Cube "Box"
        {
        }
    }
}
class Xform "Kit"
{
    def Xform "A" (instanceable = true
        references = </Lib>)
    {
    }
    def Xform "B" (instanceable = true
        references = </Lib>)
    {
        double3 xformOp:translate = (3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def Xform "World"
{
    def Xform "K1" (instanceable = true
        references = </Kit>)
    {
    }
    def Xform "K2" (instanceable = true
        references = </Kit>)
    {
        double3 xformOp:translate = (0, 5, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Xform "K3" (instanceable = true
        references = </Kit>)
    {
        double3 xformOp:translate = (0, 10, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"""


def test_a_zero_size_gprim_in_nested_instances_is_named_with_the_number_of_instances(tmp_path):
    """A zero-radius sphere inside an instance of a kit that three instances draw is skipped in all six places;
    the warning named only the first (``/World/K1/A/Inner/Ball``). It still names that one, as usdview selects it,
    and says how many others there are, counted here through USD's instance proxies."""
    path = tmp_path / "kits.usda"
    path.write_text(NESTED_KITS)
    stage = Usd.Stage.Open(str(path))
    ball = stage.GetPrimAtPath("/World/K1/A/Inner/Ball").GetPrimInPrototype().GetPath()
    proxies = [str(p.GetPath()) for p in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies())
               if p.IsInstanceProxy() and p.GetPrimInPrototype().GetPath() == ball]
    assert len(proxies) == 6
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(path))
    found = [str(w.message) for w in caught if "zero, negative or non-finite size" in str(w.message)]
    assert len(found) == 1, found
    assert found[0].endswith(f": 1 prim(s) (radius = 0: 1): /World/K1/A/Inner/Ball (and in {len(proxies) - 1} "
                             "other instances)") and str(path) in found[0]
    assert len(scene.instances) == 6 and [s.kind for s in scene.prototypes[0].shapes] == ["box"]


def test_gprims_flattened_by_a_zero_scale_are_drawn_flat(tmp_path):
    """A Cube and a Sphere under a zero scale on one axis have no canonical space to intersect in: drawn
    analytically they vanished without a word, while ``tessellate_gprims`` (and so ``--accel warp``) drew them flat,
    as a mesh with that transform and Storm draw them. They were then drawn as their flat tessellation (whose halves
    overlap without sharing edges, so culling hid much of them from camera rays); now they are drawn 1e-4 of their
    size thick (``wrt.instancing.thicken_flat_transforms``), analytic or tessellated, without a warning."""
    path = tmp_path / "flat.usda"
    path.write_text(
        '#usda 1.0\ndef Cube "Flat"\n{\n    double size = 2\n    double3 xformOp:scale = (1, 0, 1)\n'
        '    uniform token[] xformOpOrder = ["xformOp:scale"]\n}\n'
        'def Sphere "Disk"\n{\n    double3 xformOp:translate = (4, 0, 0)\n    double3 xformOp:scale = (1, 0, 1)\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]\n}\n'
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(path)
    tessellated = load(path, tessellate_gprims=True)
    # Straight down onto the square (|x|, |z| < 1) and the disk (radius 1 around x = 4), and beside them.
    origins = np.array([[0, 5, 0], [0.9, 5, -0.9], [4, 5, 0], [4.5, 5, 0.5], [2.5, 5, 0], [4, 5, 1.5]], np.float32)
    expected = [5, 5, 5, 5, np.inf, np.inf]
    for s in (scene, tessellated):
        hits = wrt.trace(s, origins, [0, -1, 0])
        np.testing.assert_allclose(hits.t, expected, atol=2e-4)
        np.testing.assert_array_equal(wrt.occluded(s, origins, [0, -1, 0]), np.isfinite(expected))
    assert scene.meshes == [] and [s.path for s in scene.shapes] == ["/Flat", "/Disk"]


@pytest.mark.parametrize("kind, attrs", [("Sphere", {"Radius": 1e39}), ("Cylinder_1", {"RadiusBottom": 1e39})])
def test_gprims_past_float32_are_skipped_naming_them(tmp_path, kind, attrs):
    """A finite double size whose box is past float32's range is skipped with a warning naming it, as mesh points
    so placed are. It loaded, and the render raised 'ao_radius must be a positive number, got inf' from the scene's
    infinite bounds; then it was refused with SceneError, stopping the whole load."""
    path, prim_path = gprim_stage(tmp_path, kind, **attrs)
    with pytest.warns(UserWarning, match=rf"{kind}_Z.usda: .*float32's range.*: 1 prim\(s\): {prim_path}$"):
        scene = wrt.load_usd(path)
    assert scene.shapes == [] and scene.meshes == []


@pytest.mark.parametrize("kind, attrs", [("Cylinder", {"Height": 4.0}), ("Cone", {}), ("Capsule", {}),
                                         ("Plane", {})])
def test_gprims_with_an_invalid_axis_are_skipped_with_a_warning_naming_them(tmp_path, kind, attrs):
    """axis = "x" (lower case) is no USD axis: USD computes no extent for it, and wrt used to draw the gprim along Z
    without a word; it is skipped with a warning naming the prim and the value, as zero-size gprims are."""
    path, prim_path = gprim_stage(tmp_path, kind, "x", **attrs)
    assert UsdGeom.Boundable(Usd.Stage.Open(path).GetPrimAtPath(prim_path)).ComputeExtent(0) is None
    for tessellate in (False, True):
        with pytest.warns(UserWarning, match=rf"axis other than X, Y or Z.*axis = 'x'.*{prim_path}"):
            scene = wrt.load_usd(path, tessellate_gprims=tessellate)
        assert scene.shapes == [] and scene.meshes == []


@pytest.mark.parametrize("scale", ["(1, 1, 1)", "(-1, 1, 1)", "(-1, -2, 0.5)", "(-2, 1, 1)"])
def test_tessellated_gprims_keep_outward_normals_under_mirroring(tmp_path, scale):
    """A tessellated sphere under any scale, mirroring ones included: winding and stored normals both point out
    (Mesh's contract; a sign(det) factor once turned mirrored normals inward)."""
    path = tmp_path / "sphere.usda"
    path.write_text(
        f'#usda 1.0\ndef Sphere "S"\n{{\n    double radius = 1\n    double3 xformOp:scale = {scale}\n'
        '    uniform token[] xformOpOrder = ["xformOp:scale"]\n}\n'
    )
    mesh = load(path, tessellate_gprims=16).meshes[0]
    corners = mesh.points[mesh.indices]
    outward = corners.mean(axis=1)  # the sphere is centred at the origin
    winding = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert ((winding * outward).sum(axis=1) > 0).all()
    assert ((mesh.normals.mean(axis=1) * outward).sum(axis=1) > 0).all()


def test_warp_accel_asks_for_tessellated_gprims(tmp_path):
    path, _ = gprim_stage(tmp_path, "Sphere", Radius=1.0)
    with pytest.raises(ValueError, match="tessellate_gprims=True"):
        wrt.trace(load(path), np.zeros((1, 3)), np.ones((1, 3)), accel="warp")
    tessellated = load(path, tessellate_gprims=True)
    assert tessellated.shapes == [] and tessellated.stats()["rendered_triangles"] > 0
    # A segment count is bounded: 100000 ran out of memory with an empty MemoryError (or the process died).
    for bad in (2, 4097, 100000, 3.5, "yes"):
        with pytest.raises(ValueError, match="tessellate_gprims must be a bool or an int from 3 to 4096"):
            load(path, tessellate_gprims=bad)


def test_instanced_shapes_ids_round_trip():
    """Shapes inside a prototype: each instance's copy has its own id after the rendered triangles."""
    proto = Prototype("/P", [], [Shape("/P/S", "sphere", np.eye(4)),
                                 Shape("/P/B", "box", placed(0.5 * np.eye(3), (0, 3, 0)))])
    m = np.tile(np.eye(4), (3, 1, 1))
    m[:, 0, 3] = [0, 10, 20]
    scene = wrt.Scene(shapes=[Shape("/W", "plane", placed(np.diag([40, 40, 1]), (0, 0, -5)))], prototypes=[proto],
                      instances=Instances.from_transforms([0, 0, 0], m))
    assert scene.stats()["rendered_shapes"] == 7 and scene.stats()["shapes"] == 3
    origins = np.array([[0, 0, 10], [10, 3, 10], [20, 0, 10], [30, 30, 10]], np.float32)
    hits = wrt.trace(scene, origins, np.tile([0, 0, -1], (4, 1)).astype(np.float32))
    np.testing.assert_allclose(hits.t, [9, 9.5, 9, 15], rtol=1e-6)
    np.testing.assert_array_equal(hits.instance, [0, 1, 2, -1])
    np.testing.assert_array_equal(hits.prim, [1, 4, 5, 0])  # plane first, then per instance: sphere, box
    prim, instance = scene.split_ids(hits.prim)
    np.testing.assert_array_equal(scene.expanded_ids(prim, instance), hits.prim)



def test_shape_ids_follow_the_rendered_triangles_when_a_prototype_has_no_instances():
    """A prototype with triangles but no instances adds geometry ids and no rows of ``Scene.triangles()``: a shape's
    id in ``Hits.prim`` and the ``prim`` AOV is still the number of rendered triangles plus its index (it was its
    geometry id, past the prototype's triangles)."""
    from wrt.scene import Mesh

    tri = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32)
    unused = Prototype("/P", [Mesh("/P/M", tri, np.array([[0, 1, 2]] * 5, np.int32), np.zeros(5, np.int32))])
    scene = wrt.Scene(meshes=[Mesh("/Tri", tri, np.array([[0, 1, 2]], np.int32), np.zeros(1, np.int32))],
                      shapes=[Shape("/S", "sphere", placed(translate=(5, 0, 0)))], prototypes=[unused])
    rendered = len(scene.triangles()[1])
    hits = wrt.trace(scene, np.array([[0, 0, 5], [5, 0, 5]], np.float32), np.array([[0, 0, -1]] * 2, np.float32))
    np.testing.assert_array_equal(hits.prim, [0, rendered])
    np.testing.assert_array_equal(hits.local_prim, [0, scene.num_geometry_triangles])
    image = wrt.render(scene, camera=wrt.Camera.look_at((5, 0, 5), (5, 0, 0), (0, 1, 0), 20), width=4, height=4)
    assert set(np.unique(image.aovs["prim"])) == {rendered}

# Real gprim scenes


@pytest.mark.parametrize("asset_id", ["all_primitives", "simple_asset_scene", "xform_nested_scopes"])
def test_gprim_scenes_render_analytically_like_their_tessellations(assets, asset_id):
    analytic = load(assets(asset_id))
    tessellated = load(assets(asset_id), tessellate_gprims=96)
    assert analytic.stats()["rendered_shapes"] > 0 and analytic.stats()["rendered_triangles"] == 0
    camera = wrt.camera.frame_scene(*analytic.bounds(), analytic.up_axis)
    a = wrt.render(analytic, camera=camera, width=120, height=90)
    b = wrt.render(tessellated, camera=camera, width=120, height=90)
    hit_a, hit_b = a.aovs["prim"] >= 0, b.aovs["prim"] >= 0
    assert hit_a.mean() > 0.005 and np.mean(hit_a != hit_b) < 0.01  # silhouettes differ by the chords
    both = hit_a & hit_b
    np.testing.assert_array_equal(a.aovs["instance"][both], b.aovs["instance"][both])
    close = np.abs(a.aovs["depth"][both] - b.aovs["depth"][both]) < 1e-2 * a.aovs["depth"][both]
    assert close.mean() > 0.97
    dots = np.einsum("...k,...k->...", a.aovs["normal"][both], b.aovs["normal"][both])
    assert np.mean(dots > 0.99) > 0.97
    if asset_id == "simple_asset_scene":
        assert analytic.stats()["rendered_shapes"] == 1000 and len(np.unique(a.aovs["instance"][hit_a])) > 50


@pytest.mark.parametrize("asset_id", ["xform_nested_scopes", "xform_weird_matrix", "xform_complex"])
def test_cube_gprims_agree_with_their_exact_tessellation(assets, asset_id):
    """Boxes tessellate exactly: analytic cubes under nested, sheared (weird matrix) and pivoted transforms hit where
    their triangles do, ray by ray."""
    analytic = load(assets(asset_id))
    tessellated = load(assets(asset_id), tessellate_gprims=True)
    assert analytic.stats()["rendered_shapes"] > 0
    o1, d1 = camera_rays(analytic, wrt.camera.frame_scene(*analytic.bounds(), "Y"), 200, 150)
    o2, d2 = random_rays(analytic, 20_000, seed=2)
    origins, directions = np.concatenate([o1, o2]), np.concatenate([d1, d2])
    ours = wrt.trace(analytic, origins, directions)
    theirs = wrt.trace(tessellated, origins, directions, accel="warp")
    scale = float(np.abs(tessellated.triangles()[0]).max())
    report = compare_hits(ours, theirs, directions=directions, scale=scale)
    assert report["hits_a"] > 300 and report["disagreements"] == 0, report
    assert report["tie_disagreements"] <= 1e-4 * report["rays"], report


@pytest.mark.parametrize("device", ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else []))
def test_limits_below_float32_normals_keep_their_meaning_on_scaled_shapes(device):
    """Rays from points on the top face of a box and on a disk, both 1000 across, with limits of 2^-149 (the smallest
    float32): ``t_min`` excludes the hit at ``t = 0`` on the surface (a ray into the box then meets its far face),
    ``t_max`` keeps it. The shape's test scales the limits by the inverse of its canonical direction's length again
    (1/1000 here), which rounded them to 0: every hit at 0 came back despite ``t_min > 0`` (the far faces were
    missed), and every one was lost with ``t_max > 0``, while triangles keep both limits as given."""
    tiny = np.nextafter(np.float32(0), np.float32(1))
    scale = np.diag([1000.0, 1000.0, 1000.0, 1.0])
    rng = np.random.default_rng(3)
    n = 200
    radius, angle = 900.0 * np.sqrt(rng.uniform(0, 1, n)), rng.uniform(0, 2 * np.pi, n)  # inside the disk too
    origins = np.stack([radius * np.cos(angle), radius * np.sin(angle), np.full(n, 1000.0)], 1).astype(np.float32)
    directions = np.concatenate([rng.uniform(-0.3, 0.3, (n, 2)), -np.ones((n, 1))], 1).astype(np.float32)
    # float64: where each ray leaves the box [-1000, 1000]^3 (the far face, z = -1000, or a side).
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    exit_t = ((1000.0 * np.sign(d64) - o64) / d64).min(axis=1)
    box = wrt.Scene(shapes=[Shape("/Box", "box", scale)])
    moved_up = scale.copy()
    moved_up[2, 3] = 1000.0  # the disk in the box's top face plane
    disk = wrt.Scene(shapes=[Shape("/Disk", "disk", moved_up)])
    for name, scene in (("box", box), ("disk", disk)):
        at_zero = wrt.trace(scene, origins, directions, t_max=tiny, device=device)
        assert (at_zero.t == 0.0).all(), name
        assert wrt.occluded(scene, origins, directions, t_max=tiny, device=device).all(), name
        past_zero = wrt.trace(scene, origins, directions, t_min=tiny, device=device)
        expected = exit_t if name == "box" else np.full(n, np.inf)
        np.testing.assert_allclose(past_zero.t, expected, rtol=1e-5, err_msg=name)
        np.testing.assert_array_equal(wrt.occluded(scene, origins, directions, t_min=tiny, device=device),
                                      np.isfinite(expected), err_msg=name)
