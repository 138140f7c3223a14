"""The pdf of a glowing hull's draw (wrt.glowing_hulls; planes and disks drawn as rect and disk lights) against float64
quadrature over the sphere of directions: at points around turned boxes (one in a mirrored, sheared instance), an
ellipsoid, a sheared tube, planes and disks (near, beside, grazing, sheared, mirrored) and inside a sphere glowing
inwards, the pdf read back as path reads it (at the shape's first hit along a direction) integrates to the share of
draws that meet the shape's emitting side, and equals, at each drawn direction, the pdf the draw reported; whitted's
pick weighs every point a glowing box lights."""

import numpy as np
import pytest
import warp as wp
from shading_helpers import quad, top_down_camera

import wrt
from wrt.emitter_resampling import seen_hull
from wrt.glowing_hulls import first_hit
from wrt.light_sampling import DeviceLights, glowing_hull_pdf, sample_light
from wrt.materials import DeviceMaterials
from wrt.scene import DeviceScene
from wrt.shade import DeviceSurfaces

DRAWS = 100_000
GRID = 800  # cos(theta) rows of the direction grid (twice as many phi columns)
PLANE_GRID = 300  # log radius rows of the grid over a plane (twice as many angle columns)


@wp.func
def read_back(lights: DeviceLights, scene: DeviceScene, surf: DeviceSurfaces, k: int, p: wp.vec3, ns: wp.vec3,
              d: wp.vec3):
    """Path's pdf of hull ``k`` along unit ``d`` from ``p`` (shading normal ``ns``): at the shape's first hit, 0 where
    none or its back."""
    prim = lights.prims[k]
    t, n = first_hit(scene, prim, lights.instances[k], p, d, 0.0)
    if t == wp.inf:
        return 0.0
    cos_l = -wp.dot(d, n)
    if surf.double_sided[prim] == 1:
        cos_l = wp.abs(cos_l)
    if cos_l <= 0.0:
        return 0.0
    return glowing_hull_pdf(lights, scene, k, p, ns, d, t, n)


@wp.kernel
def draw_hull_kernel(lights: DeviceLights, scene: DeviceScene, mats: DeviceMaterials, surf: DeviceSurfaces, k: int,
                     p: wp.vec3, ns: wp.vec3,
                     # outputs
                     pdfs: wp.array[float], read: wp.array[float]):
    i = wp.tid()
    state = wp.rand_init(11, i)
    u1 = wp.randf(state)
    u2 = wp.randf(state)
    ls = sample_light(lights, scene, mats, surf.uvs, surf.materials, surf.double_sided, k, p, ns, u1, u2)
    pdfs[i] = ls.pdf
    read[i] = 0.0
    if ls.pdf > 0.0:
        read[i] = read_back(lights, scene, surf, k, p, ns, ls.wi)


@wp.kernel
def hull_pdf_kernel(lights: DeviceLights, scene: DeviceScene, surf: DeviceSurfaces, k: int, p: wp.vec3, ns: wp.vec3,
                    dirs: wp.array[wp.vec3],
                    # outputs
                    pdfs: wp.array[float]):
    i = wp.tid()
    pdfs[i] = read_back(lights, scene, surf, k, p, ns, dirs[i])


def placed(linear, centre):
    to_world = np.eye(4)
    to_world[:3, :3] = linear
    to_world[:3, 3] = centre
    return to_world


def turned(x_degrees, z_degrees):
    a, b = np.radians(x_degrees), np.radians(z_degrees)
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
    return rz @ rx


BOX = placed(turned(15, 30) @ np.diag([0.8, 0.6, 0.3]), (0.1, 0.0, 0.55))
PANEL = placed(turned(180, 20) * 0.5, (0.0, 0.0, 1.0))  # a unit square at z = 1 facing down, turned about Z
SHEAR = np.array([[1.0, 0.8, 0.3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def box_point(b):
    """The world point at box coordinates ``b`` (``[-1, 1]^3`` the box)."""
    return BOX[:3, :3] @ np.asarray(b, np.float64) + BOX[:3, 3]


CASES = {
    "box far": ("box", BOX, {}, (3.0, 1.0, -2.0)),
    "box near, in its ellipsoid": ("box", BOX, {}, box_point((0.3, -0.2, -1.4))),
    "box on a face's plane": ("box", BOX, {}, box_point((1.0, 2.1, 0.4))),
    "box on an edge's line": ("box", BOX, {}, box_point((1.0, 1.0, 2.5))),
    # 1/128 of a half edge off a face's plane, beside that face: the area draw leaves the face out
    "box just off a face's plane": ("box", BOX, {}, box_point((1.0078, 1.5, 0.2))),
    "double-sided box from inside": ("box", BOX, {"double_sided": True}, box_point((0.2, 0.1, -0.3))),
    "ellipsoid": ("sphere", placed(turned(-20, 40) @ np.diag([0.7, 0.25, 0.4]), (0.0, 0.1, 0.8)), {},
                  (0.3, -0.2, 0.0)),
    "sheared tube": ("cylinder", placed(np.array([[0.3, 0.2, 0.0], [0.0, 0.1, 0.3], [0.0, 0.0, 0.4]]), (0, 0, 1)), {},
                     (0.2, 0.1, 0.0)),
    "inward sphere from inside": ("sphere", placed(np.eye(3) * 3.0, (0, 0, 0)),
                                  {"params": np.array([0.0, 0.0, 0.0, -1.0])}, (0.5, 0.2, 0.1)),
    # A prototype's unit box under an instance that mirrors and shears it (the ray moved by the instance, then the
    # shape).
    "box in a mirrored, sheared instance": ("box", placed(SHEAR @ np.diag([-1.0, 1.0, 1.0]) @ BOX[:3, :3], BOX[:3, 3]),
                                            {"instanced": True}, (1.5, 1.0, -0.5)),
    # Planes and disks, drawn as rect and disk lights (by solid angle where they look large, with the cosine-weighted
    # share about the shading normal; by area where they look small; a plane sheared into a parallelogram by the solid
    # angles of its two triangles; the square around a disk, draws off the ellipse dropped): their normal on the side
    # their shape's front lies (leftHanded, mirrored by an instance), where path reads the pdf back.
    "ellipse just off its front": ("disk", placed(turned(10, 20) @ np.diag([1.0, 0.5, 1.0]), (0.0, 0.0, 1.0)), {},
                                   (0.2, 0.1, 1.01)),
    "plane near, shading normal": ("plane", PANEL, {"normal": (0.3, 0.0, 1.0)}, (0.1, 0.2, 0.99)),
    # a normal leaning away from the plane, which lies partly above its horizon: the cosine-weighted draws about the
    # normal (where an opaque surface takes light) meet the plane at grazing angles only
    "plane near, normal leaning away": ("plane", PANEL, {"normal": (0.3, 0.0, -1.0), "least_share": 0.02},
                                        (0.1, 0.2, 0.99)),
    # a wall beside a plane 600 wide, 1 below its plane: the draw by solid angle clipped at 256 heights, mixed with
    # the draw by area over the whole plane
    "wide plane beside, grazing": ("plane", placed(turned(180, 20) * 300.0, (0.0, 0.0, 1.0)),
                                   {"normal": (-np.cos(np.radians(20)), -np.sin(np.radians(20)), 0.0)},
                                   (301.0 * np.cos(np.radians(20)), 301.0 * np.sin(np.radians(20)), 0.0)),
    "leftHanded plane in a mirrored instance": ("plane", placed(np.diag([-1.0, 1.0, 1.0]) @ PANEL[:3, :3],
                                                                PANEL[:3, 3]),
                                                {"instanced": True, "params": np.array([0.0, 0.0, 0.0, -1.0])},
                                                (0.1, 0.2, 1.05)),
    "sheared plane": ("plane", placed(SHEAR @ PANEL[:3, :3], PANEL[:3, 3]), {}, (0.1, 0.2, 0.95)),
    "sheared plane just off, shading normal": ("plane", placed(SHEAR @ PANEL[:3, :3], PANEL[:3, 3]),
                                               {"normal": (0.3, 0.0, 1.0)}, (0.1, 0.2, 0.99)),
    # as "plane near, normal leaning away": the cosine-weighted draws about the normal meet the plane at grazing
    # angles only
    "sheared plane just off, normal leaning away": ("plane", placed(SHEAR @ PANEL[:3, :3], PANEL[:3, 3]),
                                                    {"normal": (0.3, 0.0, -1.0), "least_share": 0.02},
                                                    (0.1, 0.2, 0.99)),
    "sheared disk": ("disk", placed(SHEAR @ PANEL[:3, :3], PANEL[:3, 3]), {"double_sided": True}, (0.1, 0.2, 1.02)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_hull_pdf_integrates_to_its_draws_share_and_is_read_back_as_drawn(case):
    assert_read_back_as_drawn(*CASES[case])


def test_a_hit_nearer_than_a_draw_takes_is_read_back_as_not_drawn():
    """A box 1e4 from the origin seen from 0.005 off a face: the draw passes by hits nearer than 2^-20 of the lengths
    about (its own surface's rounding: 0.019 here), but the pdf read back there was the cone's: it integrated to 0.495
    where 0.124 of the draws met the box, and path showed a floor within 0.01 of such a box at 0.895 +- 0.009 of
    float64 quadrature (MIS weighed down BSDF hits light sampling never makes), 0.972 +- 0.008 now."""
    assert_read_back_as_drawn("box", placed(np.eye(3) * 0.5, (1e4, 0.0, 0.5)), {}, (1e4 + 0.505, 0.1, 0.3), 0.1)


def sphere_directions():
    """``(directions, solid angles)``: the midpoints of a (cos theta, phi) grid over the sphere."""
    z = 1.0 - (np.arange(GRID) + 0.5) * 2.0 / GRID
    phi = (np.arange(2 * GRID) + 0.5) * np.pi / GRID
    zz, ff = (g.reshape(-1) for g in np.meshgrid(z, phi))
    s = np.sqrt(1.0 - zz * zz)
    return np.stack([s * np.cos(ff), s * np.sin(ff), zz], axis=1), np.full(len(zz), 4.0 * np.pi / len(zz))


def plane_directions(to_world, p):
    """``(directions, solid angles)`` from ``p`` towards the points of the plane of a plane or disk ``to_world`` (its
    canonical X and Y columns) out to past the shape: a polar grid about ``p``'s foot, midpoints in log radius (from
    1e-4 heights) and angle, each point's area ``r^2 d(ln r) d(phi)`` seen as ``cos / d^2``. The integral over the
    shape resolves every part of it, however near the plane ``p`` lies; the sphere's grid lost the thin band of
    directions a plane seen nearly edge-on fills."""
    x, y, c = to_world[:3, 0], to_world[:3, 1], to_world[:3, 3]
    normal = np.cross(x, y) / np.linalg.norm(np.cross(x, y))
    h = (p - c) @ normal
    foot = p - h * normal
    e1 = x / np.linalg.norm(x)
    e2 = np.cross(normal, e1)
    reach = np.linalg.norm(foot - c) + np.linalg.norm(x) + np.linalg.norm(y)
    log_r = np.linspace(np.log(1e-4 * abs(h)), np.log(reach), PLANE_GRID + 1)
    phi = (np.arange(2 * PLANE_GRID) + 0.5) * np.pi / PLANE_GRID
    lr, ff = (g.reshape(-1) for g in np.meshgrid(0.5 * (log_r[1:] + log_r[:-1]), phi))
    r = np.exp(lr)
    to_q = foot + r[:, None] * (np.cos(ff)[:, None] * e1 + np.sin(ff)[:, None] * e2) - p
    d = np.linalg.norm(to_q, axis=1)
    area = r * r * (log_r[1] - log_r[0]) * (np.pi / PLANE_GRID)
    return to_q / d[:, None], area * abs(h) / d**3


def assert_read_back_as_drawn(kind, to_world, options, p, least_share=0.5):
    """At least ``least_share`` of the draws from ``p`` meet the glowing shape, their pdfs are read back as drawn,
    and the read-back pdf integrates over the sphere of directions to the share of draws met, returned."""
    options = dict(options)
    normal = np.asarray(options.pop("normal", (0.0, 0.0, 0.0)), np.float64)
    least_share = options.pop("least_share", least_share)
    normal = wp.vec3(*(normal / max(np.linalg.norm(normal), 1e-30)).astype(np.float32))
    materials = [wrt.Material("/Glow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(1.0, 1.0, 1.0))]
    floor = quad((0, 0, -50), (1, 0, 0), (0, 1, 0))
    if options.pop("instanced", False):
        proto = wrt.Prototype("/Lamp", shapes=[wrt.Shape("/Lamp/Glow", kind, np.eye(4), material_id=0, **options)])
        instances = wrt.Instances.from_transforms([0], to_world[None])
        scene = wrt.Scene(meshes=[floor], prototypes=[proto], instances=instances, materials=materials)
    else:
        scene = wrt.Scene(meshes=[floor], shapes=[wrt.Shape("/Glow", kind, to_world, material_id=0, **options)],
                          materials=materials)
    r = wrt.Renderer(scene, camera=top_down_camera((0, 0, 0), height=1.0), width=2, height=2, device="cpu",
                     integrator="path")
    lights, k, point = r.device_lights, r.device_lights.first_glowing_sphere, wp.vec3(*np.asarray(p, np.float32))
    # Launched on the renderer's device: the GPU host's render_on_cuda plugin moves it to cuda:0, where a CPU launch
    # reading its arrays crashed the process.
    pdfs, read = (wp.zeros(DRAWS, dtype=float, device=r.device) for _ in range(2))
    wp.launch(draw_hull_kernel, DRAWS, inputs=[lights, r.device_scene, r.materials, r.surfaces, k, point, normal],
              outputs=[pdfs, read], device=r.device)
    drawn, read = pdfs.numpy().astype(np.float64), read.numpy().astype(np.float64)
    met = drawn > 0.0
    # A point drawn on the shape's very rim can be passed by its own ray traced back (a rounding tie at the edge: 1 of
    # 87,776 grazing draws beside a wide plane on an H100): a few in 10^4 are let through, every other read as drawn.
    tie = met & (read == 0.0)
    assert tie.sum() <= 1e-4 * met.sum(), f"{tie.sum()} of {met.sum()} draws not read back"
    np.testing.assert_allclose(read[met & ~tie], drawn[met & ~tie], rtol=1e-4)

    if kind in ("plane", "disk"):
        directions, weights = plane_directions(to_world, np.asarray(p, np.float64))
    else:
        directions, weights = sphere_directions()
    dirs = wp.array(directions.astype(np.float32), dtype=wp.vec3, device=r.device)
    grid = wp.zeros(len(dirs), dtype=float, device=r.device)
    wp.launch(hull_pdf_kernel, len(dirs), inputs=[lights, r.device_scene, r.surfaces, k, point, normal, dirs],
              outputs=[grid], device=r.device)
    integral = grid.numpy().astype(np.float64) @ weights
    share = met.mean()
    assert share >= least_share, share
    assert integral == pytest.approx(share, abs=4.0 * np.sqrt(share * (1 - share) / DRAWS) + 0.005), (integral, share)
    return share


@pytest.mark.parametrize("kind", ["plane", "disk"])
def test_nothing_is_drawn_from_behind_a_single_sided_plane_or_disk(kind):
    """From behind a plane or disk (PANEL faces down), where it sends nothing, no draw is kept and no direction reads
    a pdf back."""
    assert assert_read_back_as_drawn(kind, PANEL, {"normal": (0.0, 0.0, 1.0)}, (0.1, 0.2, 1.1), 0.0) == 0.0


@wp.kernel
def seen_hull_kernel(lights: DeviceLights, k: int, points: wp.array[wp.vec3], normals: wp.array[wp.vec3],
                     # outputs
                     weights: wp.array[float]):
    i = wp.tid()
    weight, towards = seen_hull(lights, k, points[i], normals[i])
    weights[i] = weight


def box_faces_seen(to_world, points, normals, n=12):
    """Whether some point of the box ``to_world [-1, 1]^3`` (an n x n grid and the edges of each face) faces each
    point from the front and lies above its horizon (float64)."""
    grid = np.linspace(-1.0, 1.0, n)
    u, v = (g.reshape(-1) for g in np.meshgrid(grid, grid))
    linear, centre = to_world[:3, :3], to_world[:3, 3]
    lit = np.zeros(len(points), bool)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        for s in (-1.0, 1.0):
            q = centre + s * linear[:, i] + u[:, None] * linear[:, j] + v[:, None] * linear[:, k]
            outward = s * np.linalg.inv(linear).T[:, i]  # the face's normal (A^T e_i), sign for its side
            to_q = q[None, :, :] - points[:, None, :]
            front = np.einsum("pqc,c->pq", to_q, outward) < 0.0
            above = np.einsum("pqc,pc->pq", to_q, normals) > 0.0
            lit |= (front & above).any(axis=1)
    return lit


@pytest.mark.parametrize("linear", [turned(15, 30) @ np.diag([0.8, 0.6, 0.3]),
                                    turned(40, 10) @ np.diag([3.0, 0.02, 0.05]), np.diag([1e-4, 2.0, 1e-3])],
                         ids=["box", "long thin bar", "sliver"])
def test_whitted_weighs_every_point_a_glowing_box_lights(linear, np_rng):
    """Whitted's pick (wrt.emitter_resampling.seen_hull) keeps a positive weight wherever the box sends light (some
    point of it faces the shading point above its horizon): a zero weight there would be a bias."""
    to_world = placed(linear, (0.0, 0.0, 0.0))
    materials = [wrt.Material("/Glow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(1.0, 1.0, 1.0))]
    scene = wrt.Scene(meshes=[quad((0, 0, -50), (1, 0, 0), (0, 1, 0))],
                      shapes=[wrt.Shape("/Glow", "box", to_world, material_id=0)], materials=materials)
    r = wrt.Renderer(scene, camera=top_down_camera((0, 0, 0), height=1.0), width=2, height=2, device="cpu",
                     integrator="whitted")
    count = 4000
    size = np.abs(linear).sum(axis=1)
    points = np_rng.normal(size=(count, 3)) * size * np.exp(np_rng.uniform(-1.0, 4.0, (count, 1)))
    normals = np_rng.normal(size=(count, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    weights = wp.zeros(count, dtype=float, device=r.device)
    wp.launch(seen_hull_kernel, count, inputs=[r.device_lights, r.device_lights.first_glowing_sphere,
                                               wp.array(points.astype(np.float32), dtype=wp.vec3, device=r.device),
                                               wp.array(normals.astype(np.float32), dtype=wp.vec3, device=r.device)],
              outputs=[weights], device=r.device)
    lit = box_faces_seen(to_world, points, normals)
    assert lit.mean() > 0.3
    assert (weights.numpy()[lit] > 0.0).all()
