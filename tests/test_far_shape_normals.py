"""Normals of analytic gprims far from the world origin, against the float64 oracle written from the UsdGeom schema
(:mod:`gprim_oracle`): a shape's normal comes from the hit in its own frame, so its error is float32's rounding of
the way from the ray's origin to the shape, however far both lie from the world origin.

The shading normal of a shape hit (:func:`wrt.shade.shape_frame`) was taken from the world point ``o + t d``, rounded
at the scale of its distance from the world origin (8e-3 at 1e5): a sphere of radius 1 seen from 8 units away had
normals 0.2 degrees off at 1e5, 0.03 at 1e4, against 1e-4 at the origin.
"""

from __future__ import annotations

import warnings

import gprim_oracle as oracle
import numpy as np
import pytest
from gprim_compare import hit_normals
from pxr import Gf, Usd, UsdGeom

import wrt
from wrt.rays import camera_rays

EPS32 = 2.0**-24  # float32's unit roundoff
EYE_DISTANCE = 8.0  # from each gprim's centre to the ray origins aimed at it
# Each gprim: attributes, and its own transform (column vectors) in the world or in its prototype.
GPRIMS = {
    "Sphere": {"radius": 1.0},
    "Cylinder": {"radius": 0.7, "height": 1.5},
    "Cone": {"radius": 0.8, "height": 1.6},
}
TURN = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])  # about z, so z offsets stay exact


def affine(linear, translate) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = linear
    m[:3, 3] = translate
    return m


def set_transform(prim: Usd.Prim, m: np.ndarray) -> None:
    UsdGeom.Xformable(prim).AddTransformOp().Set(Gf.Matrix4d(np.asarray(m, np.float64).T.tolist()))


def native_instance(stage: Usd.Stage) -> UsdGeom.Xform:
    """An instanceable ``/World/I`` of the prototype ``/Protos/P`` (an Xform under a class prim), both made here."""
    stage.CreateClassPrim("/Protos")
    UsdGeom.Xform.Define(stage, "/Protos/P")
    instance = UsdGeom.Xform.Define(stage, "/World/I")
    instance.GetPrim().GetReferences().AddInternalReference("/Protos/P")
    instance.GetPrim().SetInstanceable(True)
    return instance


def define_gprims(stage: Usd.Stage, parent: str, gprims: dict) -> None:
    """Double-sided gprims under ``parent``, one per ``type name: (attributes, translate)`` of ``gprims``."""
    for type_name, (attrs, translate) in gprims.items():
        prim = stage.DefinePrim(f"{parent}/{type_name}", type_name)
        UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(*translate))
        UsdGeom.Gprim(prim).CreateDoubleSidedAttr(True)
        for key, value in attrs.items():
            prim.GetAttribute(key).Set(value)


def write_far_stage(path: str, position: float, instanced: bool) -> tuple[Usd.Stage, list[np.ndarray]]:
    """The gprims side by side near ``(position, -position / 2, position / 4)``, scaled non-uniformly and turned:
    each placed directly, or by an instanceable prim (scale ``(2, 0.5, 1)``) of a prototype holding it (scaled
    ``(0.5, 3, 0.75)``, raised by 1), so that both show the same world shape. The world centres are float32 numbers,
    as the traced shapes' are. Returns the stage and each gprim's world centre."""
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/World")
    if instanced:
        stage.CreateClassPrim("/Protos")
    centres = []
    for k, (type_name, attrs) in enumerate(GPRIMS.items()):
        base = np.array([position + 4.0 * k, -position / 2.0, position / 4.0])
        if instanced:
            UsdGeom.Xform.Define(stage, f"/Protos/P{k}")
            prim = stage.DefinePrim(f"/Protos/P{k}/G", type_name)
            set_transform(prim, affine(np.diag([0.5, 3.0, 0.75]), (0.0, 0.0, 1.0)))
            instance = UsdGeom.Xform.Define(stage, f"/World/I{k}").GetPrim()
            instance.GetReferences().AddInternalReference(f"/Protos/P{k}")
            instance.SetInstanceable(True)
            set_transform(instance, affine(TURN @ np.diag([2.0, 0.5, 1.0]), base))
            centres.append(base + [0.0, 0.0, 1.0])
        else:
            prim = stage.DefinePrim(f"/World/G{k}", type_name)
            set_transform(prim, affine(TURN @ np.diag([1.0, 1.5, 0.75]), base))
            centres.append(base)
        UsdGeom.Gprim(prim).CreateDoubleSidedAttr(True)
        for key, value in attrs.items():
            prim.GetAttribute(key).Set(value)
    stage.GetRootLayer().Save()
    return stage, centres


def aimed_rays(centres, rng, per_gprim: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays from ``EYE_DISTANCE`` away from each centre (in random directions) at random points within 1.2 of it,
    float32 values as wrt traces them, in float64."""
    origins, directions = [], []
    for centre in centres:
        away = rng.normal(size=(per_gprim, 3))
        eye = centre + EYE_DISTANCE * away / np.linalg.norm(away, axis=1, keepdims=True)
        target = centre + rng.uniform(-1.2, 1.2, (per_gprim, 3))
        origins.append(eye.astype(np.float32))
        directions.append((target - eye.astype(np.float32)).astype(np.float32))
    return np.concatenate(origins).astype(np.float64), np.concatenate(directions).astype(np.float64)


def angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles in radians between rows of ``a`` and ``b`` (``atan2`` of the cross and dot products: ``arccos`` of a
    float32 unit vector's dot product is off by ``sqrt(2 eps)``)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def facing(normals: np.ndarray, d: np.ndarray) -> np.ndarray:
    return normals * -np.sign(np.einsum("ij,ij->i", normals, d))[:, None]


def load(path: str) -> wrt.Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path)


def traced_with_oracle(stage, scene: wrt.Scene, centres, seed: int, per_gprim: int):
    """Rays aimed at ``centres`` traced by wrt and by the float64 oracle: ``(o, d, hits, ref, paths, expected,
    squarely)``, ``paths`` the prims wrt hit, ``expected`` the oracle's normals facing the rays and ``squarely`` the
    rays with a sharp hit (not at a rim) that the oracle sees not grazing (there a normal's conditioning is poor)."""
    o, d = aimed_rays(centres, np.random.default_rng(seed), per_gprim)
    ref = oracle.trace(stage, o, d)
    hits = wrt.trace(scene, o, d)
    paths, _ = scene.hit_paths(hits)
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    expected = facing(ref["normal"], d)
    squarely = np.isfinite(ref["t"]) & ref["sharp"] & (np.einsum("ij,ij->i", expected, -unit) > 0.2)
    return o, d, hits, ref, paths, expected, squarely


def normals_render_with_oracle(stage, scene, eye, target) -> tuple:
    """A 24 x 24 ``normals`` render of ``scene`` from ``eye`` towards ``target`` and the float64 oracle's trace of its
    rays: ``(image, the oracle's normals facing the rays, the image's prim ids, where the oracle meets a sharp surface
    squarely)``, per pixel. A camera far from the world origin is named in a warning, which is not what is tested."""
    camera = wrt.Camera.look_at(eye, target, (0, 0, 1), 20.0, clipping_range=(0.1, 100.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        image = wrt.render(scene, camera=camera, width=24, height=24, integrator="normals", device="cpu")
    o, d = (np.asarray(a, np.float64) for a in camera_rays(scene, camera, 24, 24))
    ref = oracle.trace(stage, o, d)
    expected = facing(ref["normal"], d)
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    squarely = np.isfinite(ref["t"]) & ref["sharp"] & (np.einsum("ij,ij->i", expected, -unit) > 0.2)
    return image, expected, image.aovs["prim"].reshape(-1), squarely


# The normal's error allowed: float32's rounding of the local problem, 16 ulps of the way from the ray's origin to the
# surface over the surface's smallest radius (0.35: the cylinder's 0.7 times 0.5). Measured: about 1 such ulp at 1e2,
# 1e4 and 1e5; taken from the world point, 9 at 1e2, 1000 at 1e4, 5000 at 1e5.
ALLOWED = 16.0 * EPS32 * EYE_DISTANCE / 0.35


@pytest.mark.parametrize("instanced", [False, True], ids=["world", "instanced"])
@pytest.mark.parametrize("position", [1e2, 1e4, 1e5])
def test_shape_normals_far_from_the_origin_keep_float32s_local_precision(tmp_path, position, instanced):
    """Normals of sphere, cylinder and cone hits (non-uniformly scaled and turned, in the world or instanced) seen
    from 8 units away are as exact at 1e5 as at 1e2: within a few float32 ulps of the local problem."""
    path = str(tmp_path / "far.usda")
    stage, centres = write_far_stage(path, position, instanced)
    scene = load(path)
    o, d, hits, ref, paths, expected, squarely = traced_with_oracle(stage, scene, centres, 5, 60)
    if instanced:
        assert (hits.instance[hits.prim >= 0] >= 0).all()  # the gprims were traced as instances
    clear = squarely & (paths == ref["path"])
    assert clear.sum() > 80
    got = facing(hit_normals(scene, hits, o, d), d)
    error = angles(got[clear], expected[clear])
    assert error.max() <= ALLOWED, f"{np.degrees(error.max()):.2e} degrees at {position:g}"


def test_the_normals_aov_of_a_shape_at_1e5_keeps_float32s_local_precision(tmp_path):
    """The ``normal`` and ``geometric_normal`` AOVs of a tiny render of the instanced gprims at 1e5 (a camera 8 units
    from the cone) against the oracle, as for the traced hits."""
    path = str(tmp_path / "far.usda")
    stage, centres = write_far_stage(path, 1e5, instanced=True)
    scene = load(path)
    eye = centres[2] + EYE_DISTANCE * np.array([0.48, 0.6, 0.64])
    image, expected, prim, squarely = normals_render_with_oracle(stage, scene, eye, centres[2])
    clear = (prim >= 0) & squarely
    assert clear.sum() > 40
    for aov in ("normal", "geometric_normal"):
        got = image.aovs[aov].reshape(-1, 3).astype(np.float64)
        error = angles(got[clear], expected[clear])
        assert error.max() <= ALLOWED, f"{aov}: {np.degrees(error.max()):.2e} degrees"


# Gprims of one prototype, each off the prototype's origin by a translate that a turned instance makes a world offset
# of no float32 value: (attributes, translate in the prototype).
OFF_CENTRE = {
    "Sphere": ({"radius": 1.0}, (-5.63, 0.71, -0.29)),
    "Cylinder": ({"radius": 0.7, "height": 1.5}, (-2.41, -0.37, 0.53)),
    "Cone": ({"radius": 0.8, "height": 1.6}, (0.37, 0.61, -0.23)),
    "Capsule": ({"radius": 0.5, "height": 1.0}, (3.13, -0.53, 0.41)),
    "Cube": ({"size": 1.2}, (6.29, 0.17, 0.67)),
}
ORIENTATION = Gf.Quath(0.7, 0.3, -0.5, 0.4)  # the point instance's turn (normalised by USD)
TURN_XYZ = (23.0, -41.0, 67.0)  # the native instance's rotateXYZ, in degrees


def write_off_centre_stage(path: str, position: float, instancer: str) -> Usd.Stage:
    """The gprims of :data:`OFF_CENTRE` in one prototype, drawn once, turned, at ``(position, -position / 2,
    position / 4)`` (float32 numbers): by a PointInstancer (whose positions are float32 anyway) or a native instance."""
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/World")
    where = Gf.Vec3f(position, -position / 2.0, position / 4.0)
    if instancer == "point_instancer":
        points = UsdGeom.PointInstancer.Define(stage, "/World/Points")
        UsdGeom.Xform.Define(stage, "/World/Points/Proto")
        points.CreatePrototypesRel().SetTargets(["/World/Points/Proto"])
        points.CreateProtoIndicesAttr([0])
        points.CreatePositionsAttr([where])
        points.CreateOrientationsAttr([ORIENTATION])
        proto = "/World/Points/Proto"
    else:
        instance = native_instance(stage)
        instance.AddTranslateOp().Set(Gf.Vec3d(where))
        instance.AddRotateXYZOp().Set(Gf.Vec3f(*TURN_XYZ))
        proto = "/Protos/P"
    define_gprims(stage, proto, OFF_CENTRE)
    stage.GetRootLayer().Save()
    return stage


# The largest way from a ray's origin, through the instance's origin, to the surface it hits in these tests (the eye 8
# from a gprim, moved up to 7 by float32 at 1e8, the gprim up to 7 from the instance's origin), over the smallest
# radius (the capsule's 0.5): the normal's error allowed is 16 float32 ulps of it.
OFF_CENTRE_ALLOWED = 16.0 * EPS32 * 24.0 / 0.5


@pytest.mark.parametrize("instancer", ["point_instancer", "native"])
@pytest.mark.parametrize("position", [1e5, 1e8])
def test_instanced_shapes_off_their_prototype_origin_keep_float32s_local_precision(tmp_path, position, instancer):
    """Gprims placed off their prototype's origin, in a turned instance at 1e5 or 1e8 (its position a float32 number),
    are hit where the float64 oracle hits them and shaded with its normals, to a few float32 ulps of the local problem.
    The trace placed each shape at its world centre rounded to float32 (off by up to 0.004 at 1e5 and 4 at 1e8) and
    shading at the instance's origin plus the shape's offset: hits 0.004 off the surface at 1e5 with normals 0.5
    degrees off, and at 1e8 a third of the rays missed or hit a sphere 2 units off, their normals up to 90 degrees
    off."""
    path = str(tmp_path / "off_centre.usda")
    stage = write_off_centre_stage(path, position, instancer)
    scene = load(path)
    centres = [m[3, :3] for _, _, m in oracle.placements(stage)]
    assert len(centres) == len(OFF_CENTRE)
    o, d, hits, ref, paths, expected, clear = traced_with_oracle(stage, scene, centres, 11, 60)
    assert (hits.instance[hits.prim >= 0] >= 0).all()  # the gprims were traced as instances
    assert clear.sum() > 100
    wrong = clear & (paths != ref["path"])
    assert not wrong.any(), f"{wrong.sum()} rays the oracle sees squarely missed or hit another prim at {position:g}"
    length = np.linalg.norm(d, axis=1)
    off_surface = np.abs(hits.t[clear] - ref["t"][clear]) * length[clear]
    assert off_surface.max() <= 16.0 * EPS32 * 24.0, f"hits {off_surface.max():.2e} off the surface at {position:g}"
    got = facing(hit_normals(scene, hits, o, d), d)
    error = angles(got[clear], expected[clear])
    assert error.max() <= OFF_CENTRE_ALLOWED, f"{np.degrees(error.max()):.2e} degrees at {position:g}"


def test_the_normals_aov_of_a_point_instanced_sphere_off_its_prototype_origin_at_1e8(tmp_path):
    """The ``normal`` AOV of a tiny render of the point-instanced gprims at 1e8, a camera 8 units from the sphere,
    against the oracle, as for the traced hits. The trace placed the sphere at its world centre rounded to float32,
    units off where shading places it: 250 of the 256 pixels where the oracle meets it squarely missed it."""
    path = str(tmp_path / "off_centre.usda")
    stage = write_off_centre_stage(path, 1e8, "point_instancer")
    scene = load(path)
    centre = [m[3, :3] for name, _, m in oracle.placements(stage) if name.endswith("/Sphere")][0]
    # A float32 eye (as the rays start there): looking from the float64 one, the rays were aimed from 4 units away.
    eye = (centre + EYE_DISTANCE * np.array([0.48, 0.6, 0.64])).astype(np.float32).astype(np.float64)
    image, expected, prim, clear = normals_render_with_oracle(stage, scene, eye, centre)
    assert clear.sum() > 200
    assert (prim[clear] >= 0).all(), f"{(prim[clear] < 0).sum()} pixels the oracle sees squarely missed"
    got = image.aovs["normal"].reshape(-1, 3).astype(np.float64)
    error = angles(got[clear], expected[clear])
    assert error.max() <= OFF_CENTRE_ALLOWED, f"{np.degrees(error.max()):.2e} degrees"


# Gprims far inside their prototype, which is instanced near the world origin: (attributes, translate in the
# prototype), float32 numbers, so that the world centres are float32 numbers as the traced shapes' are.
FAR_INSIDE = {
    "Sphere": ({"radius": 1.0}, (100000.3125, -50000.1015625, 25000.703125)),
    "Cone": ({"radius": 0.8, "height": 1.6}, (-99996.0625, 50003.8984375, -24999.296875)),
}


@pytest.mark.parametrize("turn", [0.0, 90.0], ids=["unturned", "quarter-turn"])
def test_shapes_far_inside_their_prototype_keep_float32s_local_precision(tmp_path, turn):
    """A gprim 1e5 from its prototype's origin, in an instance at the world origin, is shaded with the float64
    oracle's normals to a few float32 ulps of the local problem, as a world-placed one at 1e5 is: shading summed the
    hit point relative to the instance's origin, so it was rounded at 1e5 in the prototype (normals 0.5 degrees off)
    while the trace places the shape relative to its instance's origin plus its offset."""
    path = str(tmp_path / "far_inside.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/World")
    instance = native_instance(stage)
    instance.AddRotateZOp().Set(turn)  # a quarter turn swaps x and y: the world centres stay float32 numbers
    define_gprims(stage, "/Protos/P", FAR_INSIDE)
    stage.GetRootLayer().Save()
    scene = load(path)
    centres = [m[3, :3] for _, _, m in oracle.placements(stage)]
    assert len(centres) == len(FAR_INSIDE)
    o, d, hits, ref, paths, expected, clear = traced_with_oracle(stage, scene, centres, 7, 80)
    assert (hits.instance[hits.prim >= 0] >= 0).all()  # the gprims were traced as instances
    assert clear.sum() > 50 and (paths[clear] == ref["path"][clear]).all()
    got = facing(hit_normals(scene, hits, o, d), d)
    error = angles(got[clear], expected[clear])
    assert error.max() <= ALLOWED, f"{np.degrees(error.max()):.2e} degrees"


def test_a_sphere_far_inside_a_turned_instance_is_shaded_on_the_sphere_traced(tmp_path):
    """A sphere 1e5 inside its prototype, in a turned instance: its world offset from the instance's origin is no
    float32 number, so float32 places it half an ulp of 1e5 from the float64 oracle's; the trace places it at the
    instance's float32 origin plus that offset rounded once. Shading must place it there too: its own float32 offset
    (the instance's inverse times the prototype offset) put it an ulp away, and snapped the hits onto a sphere
    beside the one traced (normals 0.45 degrees off). The oracle: the float64 normal, from the float64 ray point at
    the traced ``t``, of the unit sphere at that float32 place (worked out from USD's own placement)."""
    path = str(tmp_path / "turned.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/World")
    instance = native_instance(stage)
    origin = np.array([3.25, -1.5, 7.0])
    instance.AddTranslateOp().Set(Gf.Vec3d(*origin))
    instance.AddRotateXYZOp().Set(Gf.Vec3f(*TURN_XYZ))
    define_gprims(stage, "/Protos/P", {"Sphere": ({}, FAR_INSIDE["Sphere"][1])})  # radius 1: the schema's fallback
    stage.GetRootLayer().Save()
    scene = load(path)
    ((_, _, m),) = oracle.placements(stage)
    placed = origin.astype(np.float32).astype(np.float64) + (m[3, :3] - origin).astype(np.float32)
    assert np.abs(placed - m[3, :3]).max() > 1e-3  # the float32 place is not the float64 one
    o, d = aimed_rays([m[3, :3]], np.random.default_rng(3), 200)
    hits = wrt.trace(scene, o, d)
    hit = hits.prim >= 0
    assert hit.sum() > 100 and (hits.instance[hit] >= 0).all()
    expected = (o + hits.t[:, None] * d)[hit] - placed
    assert np.abs(np.linalg.norm(expected, axis=1) - 1.0).max() < 1e-5  # the trace's sphere is the float32 one
    got = facing(hit_normals(scene, hits, o, d)[hit], d[hit])
    error = angles(got, facing(expected, d[hit]))
    assert error.max() <= ALLOWED, f"{np.degrees(error.max()):.2e} degrees"
