"""A prototype whose triangles lie far off its origin has its BLAS built about their box's centre ``m``
(:func:`wrt.tlas.blas_centres`), and each instance's ray is moved into it from ``c + L m`` (``blas_origins``). Every
other reader of the hit (shading's point, normals and primvars, light sampling of a glowing instance, shadow rays,
the cost AOV) and every later state of the accelerator (instances moved, prototype points refitted so that the
centre moves) must see the same surfaces as the equivalent scene whose prototype lies at its origin and whose
instances compensate. The oracle: that equivalent scene (each instance's ``to_world @ translate(-m)`` composed in
float64, so both scenes place the same world triangles), and float64 ray casting on the world triangles."""

import numpy as np
import pytest
import warp as wp
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt
from test_instancing import OCTAHEDRON, aimed_from_afar, barycentric_margins, closest_hits_numpy, stretched_octahedra

import wrt
from wrt.animation import follow, tree_costs
from wrt.instancing import Instances, Prototype
from wrt.scene import DeviceScene, Mesh
from wrt.shade import DeviceSurfaces, hit_point
from wrt.tlas import InstancedAccelerator, blas_centres
from wrt.trace import HitBuffer, get_accelerator, upload_rays


@wp.kernel
def shading_points_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    ts: wp.array[float],
    us: wp.array[float],
    vs: wp.array[float],
    prims: wp.array[wp.int32],
    instances: wp.array[wp.int32],
    # outputs
    points: wp.array[wp.vec3],
):
    """The shading point (``wrt.shade.hit_point``'s ``p``) of each hit, as the accelerator reported it."""
    i = wp.tid()
    if prims[i] >= 0:
        points[i] = hit_point(scene, surf, prims[i], instances[i], us[i], vs[i], origins[i], directions[i], ts[i]).p

FAR = np.array([1000.0, 0.0, 0.0])  # the prototype's geometry, this far off its origin


def card_stage(path: str, off: np.ndarray) -> None:
    """Eight turned, stretched (every third mirrored) instances of a card with vertex normals and a vertex
    displayColor, one instance of a glowing card above them, a ground and a sun; the cards' points lie ``off`` from
    their prototype's origin and every instance's transform is composed with ``translate(-off)``, so that the world
    is the same for every ``off``."""
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, "Y")
    for name, glows in (("Card", False), ("Lamp", True)):
        stage.CreateClassPrim(f"/{name}")
        mesh = UsdGeom.Mesh.Define(stage, f"/{name}/m")
        corners = np.array([[-1, 0, -1], [1, 0, -1], [1, 0.3, 1], [-1, 0, 1]], float) + off
        mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in corners]))
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        mesh.CreateSubdivisionSchemeAttr("none")
        mesh.CreateDoubleSidedAttr(True)
        normals = ((0.3, 1, 0), (-0.2, 1, 0.1), (0, 1, -0.3), (0.1, 1, 0.2))
        mesh.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(*n) for n in normals]))
        mesh.SetNormalsInterpolation("vertex")
        colors = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                         UsdGeom.Tokens.vertex)
        colors.Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 0, 1), Gf.Vec3f(1, 1, 0)]))
        if glows:
            material = UsdShade.Material.Define(stage, f"/{name}/glow")
            shader = UsdShade.Shader.Define(stage, f"/{name}/glow/s")
            shader.CreateIdAttr("UsdPreviewSurface")
            shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(20, 18, 15))
            shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
            material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
            UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    ground = UsdGeom.Mesh.Define(stage, "/World/ground")
    ground.CreatePointsAttr([(-30, -3, -30), (30, -3, -30), (30, -3, 30), (-30, -3, 30)])
    ground.CreateSubdivisionSchemeAttr("none")
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    rng = np.random.default_rng(1)
    placements = []
    for k in range(8):
        m = np.eye(4)
        turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        m[:3, :3] = turn @ np.diag(rng.uniform(0.5, 2, 3) * (-1 if k % 3 == 0 else 1))
        m[:3, 3] = rng.uniform(-8, 8, 3)
        placements.append(m)
    placements.append(np.diag([3.0, -1.0, -3.0, 1.0]))  # the lamp, turned over, above the cards
    placements[-1][:3, 3] = (0.0, 9.0, 0.0)
    back = np.eye(4)
    back[:3, 3] = -off
    for k, m in enumerate(placements):
        xform = UsdGeom.Xform.Define(stage, f"/World/I{k}")
        xform.AddTransformOp().Set(Gf.Matrix4d((m @ back).T.tolist()))
        xform.GetPrim().GetReferences().AddInternalReference("/Lamp" if k == len(placements) - 1 else "/Card")
        xform.GetPrim().SetInstanceable(True)
    sun = UsdLux.DistantLight.Define(stage, "/World/sun")
    sun.CreateIntensityAttr(2.0)
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set(Gf.Vec3f(-60, 20, 0))
    stage.GetRootLayer().Save()


def test_instances_of_a_far_off_prototype_render_as_the_centred_equivalent(tmp_path):
    """Depth, normals, geometric normals, displayColor albedo, prim, instance and cost AOVs of the cards 1000 off
    their prototype's origin (BLAS built about their centre) are those of the same world with the cards at the
    origin (no centre), to float32's rounding of the instances' translations (up to 2000, 1.2e-4 a step); the
    ground, lit by the sun past the cards' shadows and by the glowing instance, to 1% on 98% of its pixels (shadow
    edges move with that rounding)."""
    camera = wrt.Camera.look_at((3, 25, 14), (0, 0, 0), fov_y_deg=55)
    images = []
    for name, off in (("far", FAR), ("near", np.zeros(3))):
        path = str(tmp_path / f"{name}.usda")
        card_stage(path, off)
        scene = wrt.load_usd(path)
        assert blas_centres(scene).any() == (name == "far")
        images.append(wrt.render(scene, camera=camera, width=32, height=24, device="cpu", integrator="whitted"))
    far, near = images
    for aov in ("prim", "instance", "cost"):
        np.testing.assert_array_equal(far.aovs[aov], near.aovs[aov], err_msg=aov)
    hit = near.aovs["prim"] >= 0
    assert (near.aovs["instance"][hit] >= 0).sum() > 30  # the cards and the lamp are in view (46 pixels)
    np.testing.assert_allclose(far.aovs["depth"][hit], near.aovs["depth"][hit], rtol=0, atol=1e-3)
    for aov in ("normal", "geometric_normal", "albedo"):
        np.testing.assert_allclose(far.aovs[aov], near.aovs[aov], rtol=0, atol=1e-4, err_msg=aov)
    ground = near.aovs["instance"] == -1
    ground &= hit
    off = np.abs(far.rgb - near.rgb).max(axis=2)[ground] > 1e-2 * np.maximum(near.rgb.max(axis=2)[ground], 1e-3)
    assert off.mean() < 0.02, f"{off.sum()} of {ground.sum()} ground pixels differ"


def octahedra(offset: np.ndarray, to_world: np.ndarray):
    """The scene of ``to_world``'s instances of the unit octahedron moved ``offset`` off its prototype's origin, and
    its world triangles (float64)."""
    points, faces = OCTAHEDRON
    points = (points.astype(np.float64) + offset).astype(np.float32)
    prototype = Prototype("/Octa", [Mesh("/Octa/mesh", points, faces, np.arange(8))])
    scene = wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms(np.zeros(len(to_world), int),
                                                                                 to_world))
    world = np.concatenate([points.astype(np.float64) @ m[:3, :3].T + m[:3, 3] for m in to_world])
    return scene, world, np.concatenate([faces + 6 * k for k in range(len(to_world))])


def turned_placements(rng, n: int = 5) -> np.ndarray:
    """``(n, 4, 4)`` turned, stretched placements within 60 of the origin, every second one mirrored."""
    to_world = np.tile(np.eye(4), (n, 1, 1))
    for k in range(n):
        scale = rng.uniform(0.5, 2.0, 3) * (-1 if k % 2 else 1)
        to_world[k, :3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] @ np.diag(scale)
    to_world[:, :3, 3] = rng.uniform(-60, 60, (n, 3))
    return to_world


def aimed_rays(rng, world, indices, n: int = 1000):
    """Float32 rays from 3 to 30 away at points of random triangles, their float64 closest hits ``(t, row)``,
    whether each passes more than 1% of its triangle inside it, and the ``t`` error float32 allows each (1e-5 over
    the cosine with the triangle's normal: a grazing ray's ``t`` moves most with its hit point)."""
    aim = rng.integers(0, len(indices), n)
    targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[indices[aim]])
    away = rng.normal(size=(n, 3))
    away *= (rng.uniform(3, 30, n) / np.linalg.norm(away, axis=1))[:, None]
    origins = (targets + away).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t, row = closest_hits_numpy(world, indices, o64, d64, np.zeros(n), np.full(n, np.inf))
    clear = barycentric_margins(world, indices, o64, d64, t, row) > 1e-2
    p0, p1, p2 = (world[indices[np.maximum(row, 0), k]] for k in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    cosine = np.abs((normal * d64).sum(1)) / np.linalg.norm(normal, axis=1) / np.linalg.norm(d64, axis=1)
    return origins, directions, t, row, clear, 1e-5 / cosine


def test_moved_instances_of_an_off_centre_prototype_are_hit_where_float64_puts_them():
    """Instances of an octahedron (50, 15, -7) off its prototype's origin moved to other placements (the kept BLAS,
    a TLAS built anew with the new offsets ``L m``): every ray aimed well inside a triangle hits that triangle at the
    float64 ``t``, and exactly as a fresh scene of those placements does."""
    rng = np.random.default_rng(5)
    offset = np.array([50.0, 15.0, -7.0])
    first, second = turned_placements(rng), turned_placements(rng)
    scene, _, _ = octahedra(offset, first)
    wrt.trace(scene, np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))  # built for the first placements
    scene.instances.to_world = second
    fresh, world, indices = octahedra(offset, second)
    origins, directions, t, row, clear, allowed = aimed_rays(rng, world, indices)
    moved, again = wrt.trace(scene, origins, directions), wrt.trace(fresh, origins, directions)
    np.testing.assert_array_equal(moved.prim[clear], row[clear])
    assert (np.abs(moved.t - t) <= allowed)[clear].all()
    np.testing.assert_array_equal(moved.t, again.t)
    np.testing.assert_array_equal(moved.prim, again.prim)


@pytest.mark.parametrize("before, after", [(0.0, 1.0), (1.0, 2.0), (1.0, 0.0)])
def test_a_refit_that_moves_the_prototypes_centre_traces_as_a_fresh_build(before, after):
    """An animated frame whose prototype points move so that its BLAS centre changes (none to ``m``, ``m`` to
    ``2 m``, ``m`` to none; ``m = (50, 15, -7)``), followed by refitting its BLAS (``wrt.animation.follow``): rays
    aimed well inside the new triangles hit them at the float64 ``t``, and at the ``t`` of a fresh build."""
    rng = np.random.default_rng(7)
    offset = np.array([50.0, 15.0, -7.0])
    to_world = turned_placements(rng)
    old, _, _ = octahedra(before * offset, to_world)
    new, world, indices = octahedra(after * offset, to_world)
    assert [bool(blas_centres(s).any()) for s in (old, new)] == [before != 0, after != 0]
    accel = InstancedAccelerator(old, "sah", wp.get_device("cpu"))
    accel.built_sah = tree_costs(accel)
    assert follow(accel, new, "refit") == ("refit", 0)
    origins, directions, t, row, clear, allowed = aimed_rays(rng, world, indices)
    rays = upload_rays(origins, directions, 0.0, np.inf, accel.device, True)
    hits = HitBuffer(len(origins), accel.device)
    accel.intersect(*rays, hits)
    fresh = wrt.trace(new, origins, directions)
    refitted_t = hits.t.numpy()
    assert (np.abs(refitted_t - t) <= allowed)[clear].all()
    np.testing.assert_array_equal(refitted_t, fresh.t)
    np.testing.assert_array_equal(hits.instance.numpy()[clear], row[clear] // 8)


def shading_points(scene, origins: np.ndarray, directions: np.ndarray):
    """``(points, instance)``: the float64 shading point (:func:`wrt.shade.hit_point`) of each ray's closest hit in
    ``scene`` (NaN on a miss), from the hit the two-level accelerator reports, and its instance."""
    renderer = wrt.Renderer(scene, camera=wrt.Camera.look_at((0, 0, 5e3), (0, 0, 0)), width=2, height=2, device="cpu")
    accel = get_accelerator(scene, "wrt", "sah", "cpu")
    rays = upload_rays(origins, directions, 0.0, np.inf, accel.device, True)
    hits = HitBuffer(len(origins), accel.device)
    accel.intersect(*rays, hits)
    points = wp.full(len(origins), wp.vec3(np.nan), dtype=wp.vec3, device="cpu")
    plain = (wp.array(origins, dtype=wp.vec3, device="cpu"), wp.array(directions, dtype=wp.vec3, device="cpu"))
    wp.launch(shading_points_kernel, len(origins), inputs=[renderer.device_scene, renderer.surfaces, *plain, hits.t,
              hits.u, hits.v, hits.prim, hits.instance], outputs=[points], device="cpu")
    return points.numpy().astype(np.float64), hits.instance.numpy()


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (50.0, 15.0, 0.0)], ids=["centred", "off_centre"])
def test_shading_points_of_sheared_instances_lie_on_their_triangles(offset):
    """The sheared octahedra of ``test_instancing``'s far rays (sheared by 300: needles 300 long and 1/300 thin,
    within 2000 of the origin), their prototype's octahedron at its origin or 50 of its sizes off it (its BLAS built
    about its centre): the shading point that ``hit_point`` places from each hit (the instance's corners moved to
    the world) lies within 2e-3 of the float64 plane of the triangle the ray meets (less than the needles'
    thickness; the trace's own hit points lie within 7e-4). The corners were moved by the float32 inverse of ``A``
    (adjugate over determinant, 6% off for these matrices of condition 9e4), applied about the prototype's origin:
    up to 0.011 off for the centred octahedra and 0.37 for the off-centre ones (0.009 in the median); now by the
    instance's ``L`` rounded once, about the BLAS's centre: 1.2e-4 and 4.4e-4."""
    rng = np.random.default_rng(3)
    to_world = stretched_octahedra(rng, "sheared", 6)
    scene, world, indices = octahedra(np.array(offset), to_world)
    assert blas_centres(scene).any() == any(offset)
    origins, directions, t, row, clear = aimed_from_afar(rng, world, indices)
    points, instance = shading_points(scene, origins, directions)
    met = clear & (instance == row // 8)
    assert met.sum() > 0.9 * len(origins)
    p0, p1, p2 = (world[indices[row[met], k]] for k in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    off_plane = np.abs(((points[met] - p0) * normal).sum(axis=1))
    assert off_plane.max() < 2e-3, f"{np.count_nonzero(off_plane >= 2e-3)} shading points off (max {off_plane.max()})"


def test_instances_that_bring_a_far_off_prototype_back_are_hit_where_float64_puts_them():
    """Turned, stretched (some mirrored) instances of an octahedron 1e6 off its prototype's origin whose transforms
    bring it back within 60 of the world origin (``c`` near ``-L m``, up to 2e6): rays from 3 to 30 away aimed well
    inside random triangles hit that triangle at the float64 ``t`` on the triangles placed from each instance's
    float32 origin ``c`` (which float32 holds to 0.125 there; shading and shapes place the instance from it too).
    With ``c`` and ``L m`` held apart, each ray's ``origin - c`` was rounded at ``c``'s size: the octahedra were met
    up to 0.125 off, ray by ray (rays hit other triangles and missed); the BLAS's origin ``c + L m`` is held as the
    float32 nearest it and what that leaves (``wrt.tlas.blas_origins``), so ``origin - (c + L m)`` is exact there."""
    rng = np.random.default_rng(11)
    offset = np.array([1e6, -3e5, 2e5])
    back = np.eye(4)
    back[:3, 3] = -offset
    to_world = turned_placements(rng) @ back
    scene, _, indices = octahedra(offset, to_world)
    placed = to_world.copy()
    placed[:, :3, 3] = to_world[:, :3, 3].astype(np.float32)  # the instances' float32 origins
    points = (OCTAHEDRON[0].astype(np.float64) + offset).astype(np.float32).astype(np.float64)
    world = np.concatenate([points @ m[:3, :3].T + m[:3, 3] for m in placed])
    origins, directions, t, row, clear, allowed = aimed_rays(rng, world, indices)
    hits = wrt.trace(scene, origins, directions)
    wrong = np.count_nonzero(hits.prim[clear] != row[clear])
    assert wrong == 0, f"{wrong} of {clear.sum()} rays hit another triangle or missed"
    off = np.abs(hits.t - t) > allowed
    assert not off[clear].any(), f"{np.count_nonzero(off[clear])} of {clear.sum()} rays hit off the float64 t"
