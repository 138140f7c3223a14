"""Gprims traced by wrt against a float64 oracle written from the UsdGeom schema (:mod:`gprim_oracle`), not from
wrt's shapes: the sizes and axis come from the prim's attributes and the placement from USD's own transform API, so a
size folded into the wrong axis, a lost instance transform or a flipped front shows here even where the analytic
shape and its tessellation agree with each other (``test_gprim_differential.py``).

A ray is compared where it is *robust*: six copies moved a little along each world axis get the same answer from
the oracle (hit or miss, the prim hit and its normal), so it stays clear of silhouettes, rims and the surface near
its origin.
"""

from __future__ import annotations

import warnings

import gprim_oracle as oracle
import numpy as np
import pytest
from gprim_compare import hit_normals
from gprim_stages import write_stage
from pxr import Gf, Usd, UsdGeom, Vt

import wrt
from wrt.rays import camera_rays

TYPES = {"Sphere": {"radius": 1.0}, "Cube": {"size": 1.5}, "Cylinder": {"radius": 0.7, "height": 1.5},
         "Cone": {"radius": 0.8, "height": 1.6}, "Capsule": {"radius": 0.5, "height": 1.0},
         "Cylinder_1": {"radiusBottom": 0.3, "radiusTop": 0.9, "height": 1.2},
         "Capsule_1": {"radiusBottom": 0.2, "radiusTop": 0.7, "height": 1.0}, "Plane": {"width": 1.4, "length": 0.8}}


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zero sizes, flattened instances: named elsewhere
        return wrt.load_usd(path, **kwargs)


def aimed_rays(stage, rng, n, time=Usd.TimeCode.Default()):
    """``(origins, directions)`` float64 (float32 values, as wrt traces them) aimed at the placed gprims of
    ``stage`` from the oracle's own placements: from outside, from inside, along the gprim's axis, grazing, and
    along its own frame's axes; directions of lengths 0.1 to 10."""
    placed = [p for p in oracle.placements(stage, time) if not oracle.Solid(p[1], time).empty]
    origins, directions = [], []
    for k in range(n if placed else 0):
        _, prim, m = placed[rng.integers(len(placed))]
        solid = oracle.Solid(prim, time)
        r, kind = solid.radius, k % 5
        if kind == 0:  # from outside, through its bounding box
            d = rng.normal(size=3)
            o = rng.uniform(-1.2, 1.2, 3) * r - 4.0 * r * d / np.linalg.norm(d)
        elif kind == 1:  # from inside (or near the middle of a plane)
            o, d = rng.uniform(-0.5, 0.5, 3) * r, rng.normal(size=3)
        elif kind == 2:  # along the axis, through the centre or off it
            o = np.zeros(3)
            o[solid.axis] = rng.choice([-3.0, 3.0]) * r
            if rng.random() < 0.5:
                o[(solid.axis + 1) % 3] = rng.uniform(-1.1, 1.1) * r
            d = -o.copy()
            d[(solid.axis + 1) % 3] = 0.0
        elif kind == 3:  # grazing: perpendicular to a line from the centre
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            d = np.cross(u, rng.normal(size=3))
            o = u * r * rng.uniform(0.3, 1.0) - 4.0 * r * d / np.linalg.norm(d)
        else:  # along an axis of its own frame
            o = rng.uniform(-1.2, 1.2, 3) * r
            axis = rng.integers(3)
            o[axis] = rng.choice([-3.0, 3.0]) * r
            d = np.zeros(3)
            d[axis] = -np.sign(o[axis])
        origins.append(np.append(o, 1.0) @ m)
        directions.append(d @ m[:3, :3] * 10.0 ** rng.uniform(-1, 1))
    o = np.array(origins).reshape(-1, 4)[:, :3]
    d = np.array(directions).reshape(-1, 3)
    return o.astype(np.float32).astype(np.float64), d.astype(np.float32).astype(np.float64)


def robust_rays(stage, o, d, ref, jitter, t_min=0.0, time=Usd.TimeCode.Default(), view=oracle.trace):
    """Rays whose oracle answer (``view``: :func:`gprim_oracle.trace` or :func:`seen_from_front`) does not change
    when the origin moves by ``jitter`` (``(N,)`` world distance) along any world axis; ``ref`` is its answer for
    the rays themselves."""
    robust = np.ones(len(o), bool)
    for axis in range(3):
        for sign in (-1.0, 1.0):
            moved = view(stage, o + sign * jitter[:, None] * np.eye(3)[axis], d, t_min, time)
            robust &= np.isfinite(moved["t"]) == np.isfinite(ref["t"])
            robust &= moved["path"] == ref["path"]
            robust &= ~np.isfinite(ref["t"]) | (np.einsum("ij,ij->i", moved["normal"], ref["normal"]) > 0.99)
    return robust


def ray_scale(o, d, stage, time=Usd.TimeCode.Default()):
    """The world size each ray works at: the reach of the largest placed gprim, and float32's rounding of the
    origin (a tenth of the smallest gprim would lose its rims to the origin's ulps)."""
    sizes = [oracle.Solid(p, time).radius * np.linalg.norm(m[:3, :3], 2)
             for _, p, m in oracle.placements(stage, time) if not oracle.Solid(p, time).empty]
    return min(sizes), 4e-6 * np.abs(o).max(axis=1)


def compare(stage, scene, o, d, t_min=0.0, tessellated=0, time=Usd.TimeCode.Default()):
    """Asserts that ``scene`` (loaded from ``stage``) traces rays ``o + t d`` as the oracle does."""
    ref = oracle.trace(stage, o, d, t_min, time)
    smallest, rounding = ray_scale(o, d, stage, time)
    # The tessellation lies within a few sagittas of the surface (64 segments: 3.6e-3 of the size).
    surface = 3.0 * (1.0 - np.cos(np.pi / tessellated)) if tessellated else 1e-4
    robust = robust_rays(stage, o, d, ref, 2.0 * surface * smallest + rounding, t_min, time)
    hits = wrt.trace(scene, o, d, t_min=t_min)
    paths, _ = scene.hit_paths(hits)
    found = np.isfinite(ref["t"])
    assert robust.sum() > 0.7 * len(o)
    assert found[robust].sum() >= 10
    np.testing.assert_array_equal(np.isfinite(hits.t)[robust], found[robust])
    np.testing.assert_array_equal(paths[robust], ref["path"][robust])
    both = robust & found
    # t: a world distance within the surface's error, over the cosine of the incidence for a tessellation.
    length = np.linalg.norm(d, axis=1)
    cosine = np.abs(np.einsum("ij,ij->i", ref["normal"], d)) / length
    slack = surface * ref["size"] / (np.maximum(cosine, 0.05) if tessellated else 1.0)
    end = o + np.where(found, ref["t"], 0.0)[:, None] * d
    allowed = slack + 1e-6 * (np.abs(o).max(axis=1) + np.abs(end).max(axis=1))
    error = np.abs(np.where(both, hits.t, 0.0) - np.where(both, ref["t"], 0.0)) * length
    assert np.all(error[both] <= allowed[both]), np.max(error[both] / allowed[both])
    # The front: outward (inward when leftHanded) under any transform, mirrors included.
    normals = hit_normals(scene, hits, o, d)
    if tessellated:
        facing = np.einsum("ij,ij->i", normals, d) < 0
        clear = both & (cosine > 0.05)
        np.testing.assert_array_equal(facing[clear], (np.einsum("ij,ij->i", ref["normal"], d) < 0)[clear])
    else:
        sharp = both & ref["sharp"]
        assert np.all(np.einsum("ij,ij->i", normals, ref["normal"])[sharp] > 0.999)
    any_hit = np.asarray(wrt.occluded(scene, o, d, t_min=t_min))
    np.testing.assert_array_equal(any_hit[robust], found[robust])
    return robust


def test_the_oracle_meets_closed_forms():
    stage = Usd.Stage.CreateInMemory()
    expected = {  # type: (attributes, depth seen along -X, +Y... : distances from the centre of the hit)
        "Sphere": ({"radius": 2.0}, [2.0, 2.0, 2.0]),
        "Cube": ({"size": 3.0}, [1.5, 1.5, 1.5]),
        "Cylinder": ({"radius": 1.0, "height": 4.0, "axis": "X"}, [2.0, 1.0, 1.0]),
        "Cone": ({"radius": 1.0, "height": 2.0, "axis": "Y"}, [0.5, 1.0, 0.5]),  # apex at +height/2
        "Capsule": ({"radius": 1.0, "height": 2.0, "axis": "Z"}, [1.0, 1.0, 2.0]),
        # Tangent spheres: k = -0.25, top centre 0.875 of radius 0.5 sqrt(1.0625); the cone's 0.75 at the middle.
        "Capsule_1": ({"radiusBottom": 1.0, "radiusTop": 0.5, "height": 2.0},
                      [0.75, 0.75, 0.875 + 0.5 * 1.0625 ** 0.5]),
        "Cylinder_1": ({"radiusBottom": 1.0, "radiusTop": 0.5, "height": 2.0}, [0.75, 0.75, 1.0]),
        "Plane": ({"width": 2.0, "length": 4.0, "axis": "Z"}, [np.nan, np.nan, 0.0]),
    }
    for name, (attrs, depths) in expected.items():
        prim = stage.DefinePrim(f"/{name}", name)
        for key, value in attrs.items():
            prim.GetAttribute(key).Set(value)
        solid = oracle.Solid(prim)
        o = np.eye(3) * 10.0
        t_in, _ = solid.interval(o, -o)
        np.testing.assert_allclose(10.0 - 10.0 * t_in, depths, atol=1e-9, err_msg=name)
    # A ray from inside leaves through the far side; a capsule's caps are round.
    sphere = oracle.Solid(stage.GetPrimAtPath("/Sphere"))
    assert sphere.interval(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))[1][0] == pytest.approx(2.0)
    capsule = oracle.Solid(stage.GetPrimAtPath("/Capsule"))
    t_in, _ = capsule.interval(np.array([[0.6, 0.0, 10.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert t_in[0] == pytest.approx(10.0 - 1.0 - 0.8)


@pytest.mark.parametrize("seed", [10, 25, 57, 134])
def test_analytic_gprims_hit_where_the_schema_puts_them(tmp_path, seed):
    path = str(tmp_path / "g.usda")
    write_stage(path, seed)
    stage = Usd.Stage.Open(path)
    rng = np.random.default_rng(seed)
    o, d = aimed_rays(stage, rng, 250)
    if len(o) == 0:
        pytest.skip("every gprim of this stage has a size USD draws nothing for")
    t_min = np.where(rng.random(len(o)) < 0.5, rng.uniform(0.0, 2.0, len(o)), 0.0)
    compare(stage, load(path), o, d, t_min)


@pytest.mark.parametrize("seed", [20, 61])
def test_tessellated_gprims_hit_where_the_schema_puts_them(tmp_path, seed):
    path = str(tmp_path / "g.usda")
    write_stage(path, seed)
    stage = Usd.Stage.Open(path)
    o, d = aimed_rays(stage, np.random.default_rng(seed), 250)
    compare(stage, load(path, tessellate_gprims=64), o, d, tessellated=64)


def write_every_type(path, scale, how, rng):
    """One gprim of each type along a row, ``scale`` times the size of :data:`TYPES` through its attributes
    (``how = "attr"``) or an unevenly scaled transform, each turned at random and given a random axis."""
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/W")
    for k, (type_name, attrs) in enumerate(TYPES.items()):
        prim = stage.DefinePrim(f"/W/G{k}", type_name)
        for key, value in attrs.items():
            prim.GetAttribute(key).Set(value * (scale if how == "attr" else 1.0))
        if type_name not in ("Sphere", "Cube"):
            prim.GetAttribute("axis").Set(str(rng.choice(["X", "Y", "Z"])))
        xf = UsdGeom.Xformable(prim)
        xf.AddTranslateOp().Set(Gf.Vec3d(*(scale * 3.0 * np.array([k % 4, k // 4, 0]))))
        xf.AddRotateXYZOp().Set(Gf.Vec3f(*rng.uniform(0, 360, 3)))
        if how == "xform":
            xf.AddScaleOp().Set(Gf.Vec3f(scale, -1.3 * scale, 0.8 * scale))
    stage.GetRootLayer().Save()
    return stage


@pytest.mark.parametrize("scale", [1e-6, 1e6])
@pytest.mark.parametrize("how", ["attr", "xform"])
def test_tiny_and_huge_gprims_hit_where_the_schema_puts_them(tmp_path, scale, how):
    rng = np.random.default_rng(3)
    path = str(tmp_path / "g.usda")
    stage = write_every_type(path, scale, how, rng)
    o, d = aimed_rays(stage, rng, 300)
    compare(stage, load(path), o, d)


def test_time_sampled_sizes_and_instancer_prototypes(tmp_path):
    path = str(tmp_path / "t.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/W")
    sphere = stage.DefinePrim("/W/Ball", "Sphere")
    sphere.GetAttribute("radius").Set(0.5, 1.0)
    sphere.GetAttribute("radius").Set(1.5, 5.0)
    sphere.SetInstanceable(True)  # an instanceable gprim keeps its own geometry
    capsule = stage.DefinePrim("/W/Pill", "Capsule")
    for time, (radius, height) in {1.0: (0.2, 0.0), 5.0: (0.6, 2.0)}.items():
        capsule.GetAttribute("radius").Set(radius, time)
        capsule.GetAttribute("height").Set(height, time)
    capsule.GetAttribute("axis").Set("X")
    UsdGeom.Xformable(capsule).AddTranslateOp().Set(Gf.Vec3d(-4.0, 3.0, 0.0))
    UsdGeom.Xformable(capsule).AddScaleOp().Set(Gf.Vec3f(1.0, 2.0, -1.0))
    # A PointInstancer whose prototype root has a transform of its own, over gprims nested below it.
    instancer = UsdGeom.PointInstancer.Define(stage, "/W/PI")
    UsdGeom.Xformable(instancer).AddRotateXYZOp().Set(Gf.Vec3f(10, 20, 30))
    root = UsdGeom.Xform.Define(stage, "/W/PI/Protos/A")
    root.AddTranslateOp().Set(Gf.Vec3d(0.5, 0, 0))
    root.AddRotateZOp().Set(30.0)
    root.AddScaleOp().Set(Gf.Vec3f(1, 1.5, 0.5))
    cone = stage.DefinePrim("/W/PI/Protos/A/Cone", "Cone")
    cone.GetAttribute("axis").Set("Y")
    cone.GetAttribute("height").Set(0.5, 1.0)
    cone.GetAttribute("height").Set(1.5, 5.0)
    frustum = stage.DefinePrim("/W/PI/Protos/A/Sub/Frustum", "Cylinder_1")
    frustum.GetAttribute("radiusTop").Set(0.1)
    frustum.GetAttribute("radiusBottom").Set(0.3)
    UsdGeom.Xformable(frustum).AddScaleOp().Set(Gf.Vec3f(1, -1, 1))
    UsdGeom.Xformable(stage.GetPrimAtPath("/W/PI/Protos/A/Sub")).AddTranslateOp().Set(Gf.Vec3d(0, -0.6, 0.2))
    instancer.CreatePrototypesRel().SetTargets(["/W/PI/Protos/A"])
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0] * 4))
    rng = np.random.default_rng(11)
    for time in (1.0, 5.0):
        positions = Vt.Vec3fArray([Gf.Vec3f(*p) for p in rng.uniform(-1, 6, (4, 3))])
        instancer.CreatePositionsAttr().Set(positions, time)
        q = rng.normal(size=(4, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        instancer.CreateOrientationsAttr().Set(Vt.QuathArray([Gf.Quath(float(a[0]), *map(float, a[1:])) for a in q]),
                                               time)
        scales = rng.uniform(0.5, 1.5, (4, 3)) * rng.choice([-1, 1], (4, 3), p=[0.3, 0.7])
        instancer.CreateScalesAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*s) for s in scales]), time)
    stage.GetRootLayer().Save()
    for time in (1.0, 3.0):
        o, d = aimed_rays(stage, rng, 200, Usd.TimeCode(time))
        compare(stage, load(path, time=time), o, d, time=Usd.TimeCode(time))


def seen_from_front(stage, o, d, t_min=0.0, time=Usd.TimeCode.Default()):
    """:func:`gprim_oracle.trace` past the back faces of single-sided gprims, as camera rays see them: a convex
    solid's next crossing is its far side (a plane has none)."""
    ref = oracle.trace(stage, o, d, t_min, time)
    back = np.isfinite(ref["t"]) & (np.einsum("ij,ij->i", ref["normal"], d) > 0)
    past = oracle.trace(stage, o[back], d[back], ref["t"][back] * (1.0 + 1e-9), time)
    seen = np.einsum("ij,ij->i", past["normal"], d[back]) < 0
    ref["t"][back] = np.where(seen, past["t"], np.inf)
    ref["path"][back] = np.where(seen, past["path"], "")
    ref["normal"][back] = np.where(seen[:, None], past["normal"], 0.0)
    ref["sharp"][back] = seen & past["sharp"]
    return ref


@pytest.mark.parametrize("double_sided", [False, True])
@pytest.mark.parametrize("left_handed", [False, True])
def test_camera_aovs_show_the_front_the_schema_defines(tmp_path, double_sided, left_handed):
    """Depth, geometric normal and prim ids of a render: single-sided gprims are seen from their front only (the
    inside of a leftHanded one), a point mirror keeps the front where the mirrored normal points."""
    rng = np.random.default_rng(7)
    path = str(tmp_path / "a.usda")
    stage = write_every_type(path, 1.0, "attr", rng)
    for k, prim in enumerate(stage.GetPrimAtPath("/W").GetChildren()):
        gprim = UsdGeom.Gprim(prim)
        gprim.CreateDoubleSidedAttr(double_sided)
        if left_handed:
            gprim.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
        if k % 2:
            gprim.AddScaleOp(opSuffix="mirror").Set(Gf.Vec3f(-1.0, -1.0, -1.0))
    stage.GetRootLayer().Save()
    scene = load(path)
    camera = wrt.Camera.look_at([4.5, -4.0, 7.0], [4.5, 1.5, 0.0])
    width, height = 64, 40
    image = wrt.render(scene, camera=camera, width=width, height=height, integrator="normals", device="cpu")
    o, d = camera_rays(scene, camera, width, height)
    o, d = np.asarray(o, np.float64).reshape(-1, 3), np.asarray(d, np.float64).reshape(-1, 3)
    view = oracle.trace if double_sided else seen_from_front
    ref = view(stage, o, d)
    robust = robust_rays(stage, o, d, ref, np.full(len(o), 1e-3), view=view)
    depth = image.aovs["depth"].reshape(-1)
    prims, _ = scene.hit_prims(*scene.split_ids(image.aovs["prim"].reshape(-1)))
    names = np.array([*scene.prim_paths(), ""], object)[prims]
    found = np.isfinite(ref["t"])
    assert (robust & found).sum() > 300
    np.testing.assert_array_equal(np.isfinite(depth)[robust], found[robust])
    np.testing.assert_array_equal(names[robust], ref["path"][robust])
    both = robust & found
    np.testing.assert_allclose(depth[both], (ref["t"] * np.linalg.norm(d, axis=1))[both], rtol=1e-5, atol=1e-5)
    facing = ref["normal"] * -np.sign(np.einsum("ij,ij->i", ref["normal"], d))[:, None]
    geometric = image.aovs["geometric_normal"].reshape(-1, 3)
    sharp = both & ref["sharp"]
    assert np.all(np.einsum("ij,ij->i", geometric, facing)[sharp] > 0.999)
