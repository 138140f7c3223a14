"""Surfaces fanned into slivers (a disc or a cylinder's cap cut into 2000 thin triangles around its centre) render as
the same surfaces cut coarsely: rays leaving a sliver do not meet it again (shadow acne), and camera rays re-traced
past culled back faces and cut-out holes of slivers see what a float64 ray caster sees.

With plain float32 edge functions a sliver's watertight test rounded them at the scale of its long edges squared and
divided them by twice its area, so the ``t`` it reported erred by about float32 epsilon times the triangle's aspect
(longest edge squared over twice its area: 318 for a disc cut into 2000 triangles): a ray leaving the surface met its
own triangle again at a small positive ``t``, and ray origins were lifted by a quarter of the aspect times more. The
edge functions are now compensated (``geometry.difference_of_products``) and the lift is a well-shaped triangle's:
slivers must neither shadow themselves nor lose the contact shadows of what stands on them."""

import numpy as np
import pytest

import wrt

ALBEDO = 0.5  # the default material's grey (README: displayColor, grey 0.5 without one)
HOLE = wrt.Material("/Looks/Hole", opacity=0.0, opacity_threshold=0.5)
# A rotation that tilts the disc off every axis: a plane across an axis gets its t from the plane's distance exactly.
TILT = (np.array([[1, 0, 0], [0, np.cos(0.4), -np.sin(0.4)], [0, np.sin(0.4), np.cos(0.4)]])
        @ np.array([[np.cos(0.3), 0, np.sin(0.3)], [0, 1, 0], [-np.sin(0.3), 0, np.cos(0.3)]]))


def fanned_disc(radius, segments, u=(1, 0, 0), v=(0, 1, 0), name="/disc", **kwargs) -> wrt.Mesh:
    """A disc of ``radius`` about the origin in the plane of unit vectors ``u, v`` (front: ``u x v``), cut into
    ``segments`` triangles around its centre."""
    angles = 2 * np.pi * np.arange(segments) / segments
    rim = radius * (np.cos(angles)[:, None] * np.asarray(u, float) + np.sin(angles)[:, None] * np.asarray(v, float))
    k = np.arange(segments)
    indices = np.stack([np.zeros(segments, int), 1 + k, 1 + (k + 1) % segments], -1)
    return wrt.Mesh(name, np.vstack([np.zeros(3), rim]), indices, k, **kwargs)


def sunlit_disc(segments, radius, instanced):
    """The tilted disc under a sun 40 degrees above it, flattened or as an instance that squashes it (a non-uniform
    scale: its world triangles are not its prototype's shapes); and the disc's world front normal and the direction
    to the sun."""
    u, v = TILT @ [1, 0, 0], TILT @ [0, 1, 0]
    linear = np.diag([1.0, 0.25, 1.0]) if instanced else np.eye(3)  # prototype to world
    normal = np.linalg.solve(linear.T, np.cross(u, v))
    normal /= np.linalg.norm(normal)
    tangent = linear @ u / np.linalg.norm(linear @ u)
    to_sun = np.cos(0.7) * tangent + np.sin(0.7) * normal
    sun = wrt.DistantLight(direction=-to_sun, color=np.ones(3))
    if not instanced:
        disc = fanned_disc(radius, segments, u, v, double_sided=True)
        return wrt.Scene(meshes=[disc], lights=[sun]), normal, to_sun
    proto = wrt.Prototype("/Proto", [fanned_disc(radius, segments, u, v, name="/Proto/disc", double_sided=True)])
    to_world = np.eye(4)
    to_world[:3, :3] = linear
    instances = wrt.Instances(np.zeros(1, np.int32), to_world[None], np.zeros(1, np.int32), np.full(1, -1), ["/I"])
    return wrt.Scene(meshes=[], prototypes=[proto], instances=instances, lights=[sun]), normal, to_sun


def tangent_of(normal):
    """A unit vector across ``normal`` (a camera's up)."""
    t = np.cross(normal, [0.0, 0.0, 1.0])
    return t / np.linalg.norm(t)


@pytest.mark.parametrize("instanced", [False, True], ids=["flat", "instanced"])
@pytest.mark.parametrize("radius", [1e-3, 1e4])
@pytest.mark.parametrize("integrator", ["whitted", "path", "ao"])
def test_a_disc_fanned_into_slivers_does_not_shadow_itself(integrator, radius, instanced):
    """A lone disc of 2000 slivers under a sun is lit evenly: ``albedo E cos / pi`` in ``whitted`` and in ``path``
    (direct light only), ambient occlusion 1 (nothing lies above it). Shadow and AO rays started at the surface met
    their own sliver at a small positive t: 2-4% of the pixels were black (AO 0: its one ray), from discs of 1e-3 to
    1e4, flattened or instanced."""
    scene, normal, to_sun = sunlit_disc(2000, radius, instanced)
    camera = wrt.Camera.orthographic(eye=3 * radius * normal, target=(0, 0, 0), up=tangent_of(normal),
                                     height=0.5 * radius, clipping_range=(0.0, 10 * radius))
    img = wrt.render(scene, camera=camera, width=32, height=32, spp=1, device="cpu", integrator=integrator,
                     max_depth=1)
    assert (img.aovs["prim"] >= 0).all()
    lit = 1.0 if integrator == "ao" else ALBEDO * np.dot(normal, to_sun) / np.pi
    np.testing.assert_allclose(img.rgb, lit, rtol=1e-4)


def closest_visible_hits(points, indices, seen_from_front, origins, directions, t_mins, t_maxs):
    """Float64 brute-force oracle of camera rays: per ray the ``(t, triangle)`` of the closest hit in its range
    (``inf, -1`` on a miss) among the triangles it sees, by the README's rules: a triangle is seen from its front
    where ``seen_from_front`` is True (not a cut-out hole), never from its back (single-sided meshes)."""
    corners = np.asarray(points, np.float64)[indices]
    a, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normal = np.cross(e1, e2)
    ts, hits = [], []
    for o, d, t0, t1 in zip(np.asarray(origins, np.float64), np.asarray(directions, np.float64), t_mins, t_maxs):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = o - a
            u = np.einsum("ij,ij->i", s, p) / det
            q = np.cross(s, e1)
            v = q @ d / det
            t = np.einsum("ij,ij->i", e2, q) / det
        ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= t0) & (t < t1) & seen_from_front & (normal @ d < 0)
        t = np.where(ok, t, np.inf)
        k = int(np.argmin(t))
        ts.append(t[k])
        hits.append(k if np.isfinite(t[k]) else -1)
    return np.array(ts), np.array(hits)


def can_on_a_floor(segments, radius):
    """A single-sided closed cylinder of ``radius`` (height 2 radius, 64 sides, front faces out) whose caps are
    fanned into ``segments`` slivers each, every other sliver of the top cap a cut-out hole; under it, facing up, a
    floor quad 2e-5 of the camera's distance below its bottom cap; tilted off the axes. Camera rays through the top
    cap's holes meet the bottom cap's back (culled) and must find the floor just past it."""
    angles = 2 * np.pi * np.arange(segments) / segments
    ring = np.stack([np.cos(angles), np.sin(angles), np.zeros(segments)], -1)
    k = np.arange(segments)
    bottom = np.stack([np.zeros(segments, int), 2 + (k + 1) % segments, 2 + k], -1)  # centre 0, faces -z
    top = np.stack([np.ones(segments, int), 2 + segments + k, 2 + segments + (k + 1) % segments], -1)  # faces +z
    s = np.arange(64)
    side_ring = np.stack([np.cos(2 * np.pi * s / 64), np.sin(2 * np.pi * s / 64), np.zeros(64)], -1)
    lo, hi = 2 + 2 * segments + 2 * s, 2 + 2 * segments + 2 * s + 1
    lo1, hi1 = 2 + 2 * segments + 2 * ((s + 1) % 64), 2 + 2 * segments + 2 * ((s + 1) % 64) + 1
    sides = np.concatenate([np.stack([lo, lo1, hi1], -1), np.stack([lo, hi1, hi], -1)])
    side_points = np.stack([side_ring - (0, 0, 1), side_ring + (0, 0, 1)], 1).reshape(-1, 3)
    points = np.vstack([[(0, 0, -1), (0, 0, 1)], ring - (0, 0, 1), ring + (0, 0, 1), side_points]) * radius
    indices = np.vstack([bottom, top, sides])
    materials = np.full(len(indices), -1, np.int32)
    materials[segments:2 * segments:2] = 0
    can = wrt.Mesh("/can", points @ TILT.T, indices, np.arange(len(indices)), material_ids=materials)
    drop = 1 + 2e-5 * 4  # the camera is about 4 radii from the floor
    floor = [(-3, -3, -drop), (3, -3, -drop), (3, 3, -drop), (-3, 3, -drop)]
    floor = wrt.Mesh("/floor", np.asarray(floor, float) * radius @ TILT.T, [[0, 1, 2], [0, 2, 3]], [0, 0])
    return wrt.Scene(meshes=[can, floor], materials=[HOLE])


@pytest.mark.parametrize("radius", [1e-3, 1e4])
def test_camera_rays_past_culled_and_cut_out_slivers_see_what_a_float64_caster_sees(radius):
    """The can of :func:`can_on_a_floor` seen from above: every pixel shows the triangle a float64 ray caster finds
    by the culling and cut-out rules (top-cap slivers, or the floor through their holes and the culled bottom cap),
    at its depth. A re-trace that started too far past a culled or cut-out sliver would show holes or the floor's
    absence; one that started short of its own hit would cull forever and keep the back face."""
    scene = can_on_a_floor(2000, radius)
    camera = wrt.Camera.look_at(np.array([0.4, 0.3, 3.0]) @ TILT.T * radius, (0, 0, 0), up=TILT @ [0, 1, 0],
                                fov_y_deg=30, clipping_range=(0.0, 10 * radius))
    img = wrt.render(scene, camera=camera, width=24, height=24, device="cpu", integrator="depth")
    origins, directions, t_mins, t_maxs = wrt.rays.camera_rays(scene, camera, 24, 24, t_range=True)
    can, floor = scene.meshes
    points = np.vstack([can.points, floor.points])
    indices = np.vstack([can.indices, floor.indices + len(can.points)])
    seen = np.concatenate([can.material_ids < 0, [True, True]])
    t, prim = closest_visible_hits(points, indices, seen, origins, directions, t_mins, t_maxs)
    floor_ids = len(can.indices) + np.arange(2)
    on_floor = np.isin(prim, floor_ids)
    assert 0.2 < on_floor.mean() < 0.8  # both the cap's slivers and the floor through its holes are in view
    got = img.aovs["prim"].reshape(-1)
    np.testing.assert_array_equal(np.isin(got, floor_ids), on_floor)
    np.testing.assert_array_equal(got >= 0, prim >= 0)
    np.testing.assert_allclose(img.aovs["depth"].reshape(-1), t * np.linalg.norm(directions, axis=1), rtol=1e-5)


def road_mesh(u, v, name="/road") -> wrt.Mesh:
    """A 1000 x 1 quad of two triangles (a road; aspect about 900) about the origin, long along ``u``, across ``v``."""
    corners = np.array([-500 * u - 0.5 * v, 500 * u - 0.5 * v, 500 * u + 0.5 * v, -500 * u + 0.5 * v])
    return wrt.Mesh(name, corners, [[0, 1, 2], [0, 2, 3]], [0, 0], double_sided=True)


def test_a_long_thin_quad_does_not_shadow_itself():
    """A 1000 x 1 strip of two triangles (a road; aspect about 900) under a low sun is lit evenly around its middle:
    there a tenth to a fifth of the pixels were black, shadow rays from 5e-4 off it meeting it again."""
    u, v = TILT @ [1, 0, 0], TILT @ [0, 1, 0]
    normal = np.cross(u, v)
    road = road_mesh(u, v)
    to_sun = np.cos(0.2) * (0.6 * u + 0.8 * v) + np.sin(0.2) * normal
    scene = wrt.Scene(meshes=[road], lights=[wrt.DistantLight(direction=-to_sun, color=np.ones(3))])
    camera = wrt.Camera.orthographic(eye=3 * normal, target=(0, 0, 0), up=v, height=0.9, clipping_range=(0.0, 10.0))
    img = wrt.render(scene, camera=camera, width=24, height=24, device="cpu", max_depth=1)
    assert (img.aovs["prim"] >= 0).all()
    np.testing.assert_allclose(img.rgb, ALBEDO * np.dot(normal, to_sun) / np.pi, rtol=1e-4)


def box_hit(origins, to_sun, lower, upper):
    """Float64 slab test in the frame of the box ``[lower, upper]``: whether each ray ``origins + t to_sun``, ``t > 0``,
    meets the box."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lower - origins) / to_sun, (upper - origins) / to_sun
    near = np.nanmax(np.minimum(t0, t1), axis=1)
    far = np.nanmin(np.maximum(t0, t1), axis=1)
    return (near <= far) & (far > 0)


@pytest.mark.parametrize("instanced", [False, True], ids=["flat", "instanced"])
def test_a_kerb_on_a_long_thin_quad_casts_its_contact_shadow(instanced):
    """A kerb 0.3 x 0.3 and 0.05 high standing on the 1000 x 1 road under a sun 17 degrees up shadows the road behind
    it (float64 oracle: the camera's pixel-centre rays met with the road's plane, shadow rays to the sun against the
    kerb's box, pixels within 1e-3 of the shadow's edge or of a 2e-3 lift left out). Shadow rays left the road 0.1 off
    it (its reach times a quarter of its aspect, sized for the triangle test before its edge functions were
    compensated), above the kerb: the road was lit all round it. Drawn through an instance too (a road 1000 x 4 in
    its prototype, squashed across)."""
    u, v = TILT @ [1, 0, 0], TILT @ [0, 1, 0]
    normal = np.cross(u, v)
    half, height = 0.15, 0.05
    frame = np.stack([u, v, normal])  # rows: the road's axes; kerb corners in that frame, then in the world
    kerb_lower, kerb_upper = np.array([-half, -half, 0.0]), np.array([half, half, height])
    box = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (0.0, height)]) @ frame
    faces = [[0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5], [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3], [0, 2, 3],
             [0, 3, 1], [4, 5, 7], [4, 7, 6]]
    kerb = wrt.Mesh("/kerb", box, faces, np.zeros(12, int), double_sided=True)
    to_sun = np.cos(0.3) * (0.9 * u + np.sqrt(0.19) * v) + np.sin(0.3) * normal
    sun = [wrt.DistantLight(direction=-to_sun, color=np.ones(3))]
    if instanced:
        to_world = np.eye(4)
        to_world[:3, :3] = np.eye(3) - 0.75 * np.outer(v, v)  # a road 4 wide in the prototype, 1 in the world
        proto = wrt.Prototype("/Proto", [road_mesh(u, 4 * v, name="/Proto/road")])
        instances = wrt.Instances(np.zeros(1, np.int32), to_world[None], np.zeros(1, np.int32), np.full(1, -1), ["/I"])
        scene = wrt.Scene(meshes=[kerb], prototypes=[proto], instances=instances, lights=sun)
    else:
        scene = wrt.Scene(meshes=[road_mesh(u, v), kerb], lights=sun)
    camera = wrt.Camera.orthographic(eye=3 * normal, target=(0, 0, 0), up=v, height=0.9, clipping_range=(0.0, 10.0))
    img = wrt.render(scene, camera=camera, width=24, height=24, device="cpu", max_depth=1)
    origins, directions = wrt.rays.camera_rays(scene, camera, 24, 24)
    origins, directions = origins.astype(np.float64) @ frame.T, directions.astype(np.float64) @ frame.T
    on_road = origins - (origins[:, 2] / directions[:, 2])[:, None] * directions  # in the road's frame, z = 0
    sun_in_frame = frame @ to_sun
    margin = 1e-3
    shadowed = box_hit(on_road + [0, 0, 2e-3], sun_in_frame, kerb_lower + margin, kerb_upper - margin)
    lit = ~box_hit(on_road, sun_in_frame, kerb_lower - margin, kerb_upper + margin)
    road = (img.aovs["prim"].reshape(-1) >= 0) & ((np.abs(on_road[:, :2]) > half).any(axis=1))  # not the kerb's top
    shade = img.rgb.reshape(-1, 3)
    assert (shadowed & road).sum() >= 15  # the shadow is about 0.16 long and 0.3 wide: 4 x 8 pixels of 0.0375
    np.testing.assert_array_equal(shade[shadowed & road], 0.0)
    np.testing.assert_allclose(shade[lit & road], ALBEDO * np.dot(normal, to_sun) / np.pi, rtol=1e-4)


@pytest.mark.parametrize("length", [1e5, 1e6])
@pytest.mark.parametrize("instanced", [False, True], ids=["flat", "instanced"])
def test_a_needle_is_shaded_by_the_normal_of_its_float32_corners(length, instanced):
    """A needle (half a ``length`` x 1 strip, aspect up to 2e6) under a sun 3 degrees up is lit as its own plane
    is: radiance ``ALBEDO cos / pi`` with ``cos`` from the float64 normal of the float32 corners wrt reads (a flat
    lit plane: no other surface). The float32 edges ``b - a`` round by half an ulp of ``length`` (0.03 at 1e6) against
    a width of 1, so a float32 cross product of them turned the normal by up to eps times the aspect: at 1e6 a
    tenth of a radian, and the needle was drawn from 0.6 to 2 times as bright as its plane is lit."""
    u, v = TILT @ [1, 0, 0], TILT @ [0, 1, 0]
    normal = np.cross(u, v)
    corners = np.array([-length / 2 * u - 0.5 * v, length / 2 * u - 0.5 * v, length / 2 * u + 0.5 * v])
    to_sun = np.cos(0.05) * (0.6 * u + 0.8 * v) + np.sin(0.05) * normal
    sun = [wrt.DistantLight(direction=-to_sun, color=np.ones(3))]
    if instanced:  # a prototype twice as long, halved along the needle
        to_world = np.eye(4)
        to_world[:3, :3] = np.eye(3) - 0.5 * np.outer(u, u)
        stretch = np.eye(3) + np.outer(u, u)
        proto = wrt.Prototype("/P", [wrt.Mesh("/P/needle", corners @ stretch.T, [[0, 1, 2]], [0], double_sided=True)])
        instances = wrt.Instances(np.zeros(1, np.int32), to_world[None], np.zeros(1, np.int32), np.full(1, -1), ["/I"])
        scene = wrt.Scene(prototypes=[proto], instances=instances, lights=sun)
        a, b, c = (np.asarray(proto.meshes[0].points, np.float32).astype(np.float64) @ to_world[:3, :3].T)
    else:
        scene = wrt.Scene(meshes=[wrt.Mesh("/needle", corners, [[0, 1, 2]], [0], double_sided=True)], lights=sun)
        a, b, c = scene.triangles()[0].astype(np.float64)
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    camera = wrt.Camera.orthographic(eye=3 * normal, target=(0, 0, 0), up=v, height=0.9, clipping_range=(0.0, 10.0))
    img = wrt.render(scene, camera=camera, width=16, height=16, device="cpu", max_depth=1)
    on = img.aovs["prim"].reshape(-1) >= 0
    assert on.sum() >= 100  # the half of the pixels the needle covers
    np.testing.assert_allclose(img.rgb.reshape(-1, 3)[on], ALBEDO * abs(np.dot(n, to_sun)) / np.pi, rtol=1e-3)


def test_a_long_thin_quad_stretched_along_its_normal_is_shaded_by_its_own_plane():
    """The 1000 x 1 road drawn through an instance that stretches it 1024 times along its normal (its world corners
    stay in the plane): each triangle is lit as the float64 transform of its float32 prototype corners is. The
    prototype normal of the triangle whose edges from its first corner are a thousandth of a radian apart was off by
    about epsilon times its aspect in float32, and the stretch multiplies that tilt by 1024: 1.8% too dark or bright
    (31% at 16384)."""
    u, v = TILT @ [1, 0, 0], TILT @ [0, 1, 0]
    normal = np.cross(u, v)
    to_sun = np.cos(0.2) * (0.6 * u + 0.8 * v) + np.sin(0.2) * normal
    to_world = np.eye(4)
    to_world[:3, :3] = np.eye(3) + 1023 * np.outer(normal, normal)
    road = road_mesh(u, v, name="/Proto/road")
    instances = wrt.Instances(np.zeros(1, np.int32), to_world[None], np.zeros(1, np.int32), np.full(1, -1), ["/I"])
    scene = wrt.Scene(prototypes=[wrt.Prototype("/Proto", [road])], instances=instances,
                      lights=[wrt.DistantLight(direction=-to_sun, color=np.ones(3))])
    camera = wrt.Camera.orthographic(eye=3 * normal, target=(0, 0, 0), up=v, height=0.9, clipping_range=(0.0, 10.0))
    img = wrt.render(scene, camera=camera, width=16, height=16, device="cpu", max_depth=1)
    corners = np.asarray(road.points, np.float32).astype(np.float64) @ to_world[:3, :3].T
    prim = img.aovs["prim"].reshape(-1)
    for k, (a, b, c) in enumerate(corners[[[0, 1, 2], [0, 2, 3]]]):
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n)
        assert (prim == k).sum() >= 50
        np.testing.assert_allclose(img.rgb.reshape(-1, 3)[prim == k], ALBEDO * abs(np.dot(n, to_sun)) / np.pi,
                                   rtol=1e-4, err_msg=f"triangle {k}")
