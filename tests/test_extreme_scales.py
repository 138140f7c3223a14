"""Scenes scaled by 1e-30 to 1e30 with their cameras: shading must not depend on the scene's size. Each float32
product of two lengths (a cross product of edges, a squared length) over- or underflows at such scales. And scenes
near float32's range, which the triangle test cannot trace exactly, are named in a warning."""

import warnings

import numpy as np
import pytest
from shading_helpers import uv_sphere
from test_instancing import barycentric_margins, closest_hits_numpy

import wrt
from wrt.rays import camera_rays

SCALES = [1.0e-30, 1.0e-25, 1.0e20, 1.0e30]


def scaled_camera(scale: float) -> wrt.Camera:
    """A camera at the origin looking down -Z, scaled with the scene."""
    return wrt.Camera(to_world=np.diag([scale, scale, scale, 1.0]), focal_length=50.0, horizontal_aperture=36.0)


def quad(path: str, corners, scale: float, double_sided=True) -> wrt.Mesh:
    points = (np.asarray(corners, np.float64) * scale).astype(np.float32)
    return wrt.Mesh(path, points, [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32), double_sided=double_sided)


@pytest.mark.parametrize("scale", SCALES)
def test_a_tilted_quad_has_its_plane_normal_at_any_scale(scale):
    """A quad tilted about X, filling the view: every pixel's geometric normal is the plane's (float64), facing the
    camera. Its float32 cross product of edges overflowed at 1e20 (a NaN normal) and vanished at 1e-25 (the
    normal of a degenerate triangle, facing the ray: off by up to 0.4)."""
    corners = [[-100, -100, -5], [100, -100, -5], [100, 100, -25], [-100, 100, -25]]
    scene = wrt.Scene(meshes=[quad("/quad", corners, scale)])
    img = wrt.render(scene, camera=scaled_camera(scale), width=12, height=8, device="cpu", integrator="normals")
    assert (img.aovs["prim"] >= 0).all()
    p = np.asarray(corners, np.float64)
    normal = np.cross(p[1] - p[0], p[2] - p[0])
    normal /= np.linalg.norm(normal)
    normal *= np.sign(normal[2])  # towards the camera at +Z
    np.testing.assert_allclose(img.aovs["geometric_normal"].reshape(-1, 3), np.tile(normal, (96, 1)), atol=1e-5)


@pytest.mark.parametrize("scale", SCALES)
def test_a_single_sided_quad_seen_from_behind_is_culled_at_any_scale(scale):
    """A tilted single-sided quad facing away from the camera, in front of a double-sided one: the camera sees the
    far quad through it. The back-face test's float32 cross product of edges was NaN at 1e20 and 0 at 1e-25, and
    the near quad's back was drawn."""
    near = [[-100, -100, -4], [-100, 100, -6], [100, 100, -8], [100, -100, -6]]  # tilted, clockwise seen from +Z
    far = [[-100, -100, -20], [100, -100, -20], [100, 100, -20], [-100, 100, -20]]
    scene = wrt.Scene(meshes=[quad("/near", near, scale, double_sided=False), quad("/far", far, scale)])
    img = wrt.render(scene, camera=scaled_camera(scale), width=12, height=8, device="cpu", integrator="normals")
    np.testing.assert_array_equal(img.aovs["prim"] // 2, 1)  # triangles 2 and 3: the far quad


def lit_shapes(scale: float):
    """A sphere (an analytic shape) resting on an instanced floor quad, under a sun, and a camera above them, all
    scaled by ``scale``."""
    s = np.diag([scale, scale, scale, 1.0])
    sphere = s.copy()
    sphere[:3, 3] = np.array([0.0, 0.0, -10.0]) * scale
    sphere[:3, :3] *= 3.0
    floor = wrt.Prototype("/floor", meshes=[quad("/floor/quad", [[-9, -9, -13], [9, -9, -13], [9, 9, -13],
                                                                  [-9, 9, -13]], 1.0)])
    instances = wrt.Instances.from_transforms([0], s[None])
    sun = wrt.DistantLight(np.array([0.3, -0.4, -1.0]), np.full(3, 2.0, np.float32))
    scene = wrt.Scene(shapes=[wrt.Shape("/ball", "sphere", sphere)], prototypes=[floor], instances=instances,
                      lights=[sun])
    return scene, scaled_camera(scale)


@pytest.mark.parametrize("scale", SCALES)
def test_a_lit_shape_and_instance_render_as_unscaled_at_any_scale(scale):
    """A sphere shape on an instanced floor under a sun (whitted draws no random numbers): the same image at any
    scale as unscaled. Shading moved hit points back to the world by ``wp.inverse`` of the shape's or instance's
    world-to-local matrix, whose float32 determinant vanished for a scale of 1e20 (and overflowed for 1e-20): NaN
    points, and the sphere and the floor were black."""
    ref, img = (wrt.render(scene, camera=camera, width=16, height=12, device="cpu")
                for scene, camera in (lit_shapes(1.0), lit_shapes(scale)))
    same = img.aovs["prim"] == ref.aovs["prim"]  # up to a pixel on the sphere's outline, which rounding moves
    assert same.mean() > 0.98 and (ref.aovs["prim"] >= 0).mean() > 0.9 and ref.rgb.max() > 0.1
    np.testing.assert_allclose(img.rgb[same], ref.rgb[same], atol=1e-3)


def smooth_ball_and_shapes(scale: float):
    """:func:`lit_shapes` with an instanced ball of smooth (authored) normals beside the sphere."""
    scene, camera = lit_shapes(scale)
    ball = uv_sphere(center=(0, 0, 0), radius=1.0, rings=8, segments=12, smooth=True)
    proto = wrt.Prototype("/ball", meshes=[wrt.Mesh("/ball/mesh", ball.points, ball.indices,
                                                     np.zeros(len(ball.indices), np.int32), normals=ball.normals)])
    placed = np.diag([3 * scale, 3 * scale, 3 * scale, 1.0])
    placed[:3, 3] = np.array([4.0, 3.0, -12.0]) * scale
    instances = wrt.Instances.from_transforms([0, 1], np.stack([scene.instances.to_world[0], placed]))
    return wrt.Scene(shapes=scene.shapes, prototypes=scene.prototypes + [proto], instances=instances,
                     lights=scene.lights), camera


@pytest.mark.parametrize("scale", [1.0e-25, 1.0e-20, 1.0e20, 1.0e30])
def test_shading_normals_of_shapes_and_instances_are_those_unscaled_at_any_scale(scale):
    """The shading normals of a sphere shape and of an instanced ball's authored normals are those of the unscaled
    scene: both are moved to the world by ``A^T``, as long as the inverse of the scale, and ``wp.length`` of one 1e20
    long overflowed (the ball's normals became zero and it was shaded flat: 0.17 off at 1e-20), of one 1e-20 long
    went subnormal (6e-5 off at 1e20)."""
    ref, img = (wrt.render(scene, camera=camera, width=16, height=12, device="cpu", integrator="normals")
                for scene, camera in (smooth_ball_and_shapes(1.0), smooth_ball_and_shapes(scale)))
    same = img.aovs["prim"] == ref.aovs["prim"]
    assert same.mean() > 0.98 and len(np.unique(ref.aovs["prim"][ref.aovs["instance"] == 1])) > 5
    np.testing.assert_allclose(img.aovs["normal"][same], ref.aovs["normal"][same], atol=1e-5)


@pytest.mark.parametrize("reach", [4.0e37, 2.5e38])
def test_a_scene_reaching_past_a_quarter_of_float32s_range_is_named_in_a_warning(reach):
    """A triangle soup (and an instance of it) reaching 2.5e38, rays from inside its box: the warning names both,
    since the triangle test's differences from the ray's origin overflow float32 there and rays miss (236 of 2,025
    did, without a word). Reaching 4e37, nothing is said, and every ray well inside a triangle hits the float64
    closest one."""
    rng = np.random.default_rng(2)
    centers = rng.uniform(-1, 1, (200, 1, 3))
    points = (centers + rng.normal(scale=0.15, size=(200, 3, 3))).reshape(-1, 3)
    points *= reach / np.abs(points).max()
    indices = np.arange(600).reshape(-1, 3)
    soup = wrt.Mesh("/soup", points.astype(np.float32), indices, np.zeros(200, np.int32), double_sided=True)
    proto = wrt.Prototype("/proto", meshes=[wrt.Mesh("/proto/tri", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]],
                                                     [0])])
    placed = np.diag([reach, reach, reach, 1.0])[None]
    scene = wrt.Scene(meshes=[soup], prototypes=[proto], instances=wrt.Instances.from_transforms([0], placed))
    n = 2000
    origins = (rng.uniform(-0.3, 0.3, (n, 3)) * reach).astype(np.float32)
    aims = points[indices[rng.integers(0, 200, n)]].mean(axis=1)
    directions = ((aims - origins) / reach).astype(np.float32)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hits = wrt.trace(scene, origins, directions)
    said = [str(w.message) for w in caught if "float32's range" in str(w.message)]
    if reach > 8.5e37:
        assert len(said) == 1 and "/soup" in said[0] and "/instances" in said[0] and "2 prim(s)" in said[0], said
        return
    assert not said
    world, tris = scene.triangles()
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t, row = closest_hits_numpy(world.astype(np.float64), tris, o64, d64, np.zeros(n), np.full(n, np.inf))
    clear = (row >= 0) & (barycentric_margins(world.astype(np.float64), tris, o64, d64, t, row) > 1e-3)
    assert clear.sum() > n / 2
    np.testing.assert_array_equal(hits.prim[clear], row[clear])


@pytest.mark.parametrize("scale", [1.0e-25, 1.0e-9, 1.0e20])
def test_the_default_camera_frames_a_scaled_scene_as_the_unscaled_one(scale):
    """Without a camera, a scene scaled by 1e-25 to 1e20 is seen as the unscaled one (the same prim in every pixel,
    up to one on an outline). The framing took the scene's radius as at least 1e-6, so a scene 1e-9 across was
    seen from 1e3 times too far and filled a pixel or two of the image."""
    ref, img = (wrt.render(lit_shapes(s)[0], width=16, height=12, device="cpu", integrator="normals")
                for s in (1.0, scale))
    assert (ref.aovs["prim"] >= 0).mean() > 0.2
    assert (img.aovs["prim"] == ref.aovs["prim"]).mean() > 0.98


@pytest.mark.parametrize("scale", [1.0e-12, 1.0e-8])
def test_a_path_traced_scene_scaled_down_draws_its_lights_with_the_same_odds(scale):
    """The sphere, floor and sun of :func:`lit_shapes` with a sphere light, path traced with one seed: the same image
    scaled by 1e-8 or 1e-12 as unscaled. The sun's odds of being sampled are its power over a disc of the scene's
    radius, against the sphere light's own power; that radius was held at 1e-6 or more, so in the scaled scene the
    sun was picked with other odds and the same seed drew another image (pixels 0.2 apart)."""
    def image(s):
        scene, camera = lit_shapes(s)
        scene.lights = scene.lights + [wrt.SphereLight(np.array([4.0, 4.0, -8.0]) * s, 0.5 * s,
                                                       np.full(3, 3.0, np.float32))]
        return wrt.render(scene, camera=camera, width=16, height=12, device="cpu", integrator="path", spp=2, seed=3)

    ref, img = image(1.0), image(scale)
    same = img.aovs["prim"] == ref.aovs["prim"]
    assert same.mean() > 0.98 and ref.rgb.max() > 0.1
    np.testing.assert_allclose(img.rgb[same], ref.rgb[same], atol=1e-3)


@pytest.mark.parametrize("scale", SCALES)
def test_z_of_a_camera_scaled_with_its_scene_is_the_scaled_distance_along_the_view(scale):
    """A camera and a quad 10 in front of it scaled together: ``z`` (distance along the viewing axis, scene units) is
    10 times the scale in every pixel. The axis was ``wp.normalize`` of the camera's scaled forward column, whose
    squares overflowed (1e20) or vanished (1e-25): a zero axis, and ``z`` was 0."""
    scene = wrt.Scene(meshes=[quad("/quad", [[-100, -100, -10], [100, -100, -10], [100, 100, -10],
                                             [-100, 100, -10]], scale)])
    img = wrt.render(scene, camera=scaled_camera(scale), width=8, height=6, device="cpu", integrator="depth")
    np.testing.assert_allclose(img.aovs["z"], 10.0 * scale, rtol=1e-5)


@pytest.mark.parametrize("scale", [1.0e-20, 1.0e-15, 1.0e8, 1.0e20])
def test_a_card_of_two_reversed_single_sided_quads_shows_its_facing_side_at_any_scale(scale):
    """A tilted card of two coincident single-sided quads facing away from each other (cut along other diagonals,
    so their triangles are partners, not twins): the camera sees the one facing it in every pixel, whichever comes
    first. The hit point's weights on the partner are ratios of products of up to six lengths, computed in float32,
    which overflowed in a card 2e10 across and vanished in one 2e-13 across: no partner held the point, and the camera
    saw through the card in 12 to 44 of its 48 pixels."""
    front = [[-100, -100, -4], [100, -100, -6], [100, 100, -8], [-100, 100, -6]]  # faces the camera at +Z
    for meshes, seen in (([quad("/a", front, scale, False), quad("/b", front[::-1], scale, False)], 0),
                         ([quad("/b", front[::-1], scale, False), quad("/a", front, scale, False)], 1)):
        img = wrt.render(wrt.Scene(meshes=meshes), camera=scaled_camera(scale), width=8, height=6, device="cpu",
                         integrator="normals")
        np.testing.assert_array_equal(img.aovs["prim"] // 2, seen)


def area_lit_shapes(scale: float, kinds: str):
    """The sphere and floor of :func:`lit_shapes` lit by ``kinds`` of ``"rect sphere disk tube ellipsoid etube
    glow"`` (a rect, sphere, disk and cylinder light, a sphere and a cylinder light scaled unevenly, and an emissive
    quad), no sun, all scaled by ``scale``."""
    scene, camera = lit_shapes(scale)
    s = np.diag([scale, scale, scale, 1.0])
    color = np.full(3, 3.0, np.float32)

    def placed(x, y, z):  # (the lights' -Z, where rect and disk lights emit, faces the floor)
        m = s.copy()
        m[:3, 3] = np.array([x, y, z]) * scale
        return m

    lights = {"rect": wrt.RectLight(placed(-4, 4, -6), 2.0, 1.5, color, path="/rect"),
              "sphere": wrt.SphereLight(np.array([4.0, 5.0, -7.0]) * scale, 0.7 * scale, color, path="/sphere"),
              "disk": wrt.DiskLight(placed(3, -4, -5), 0.8, color, path="/disk"),
              "tube": wrt.CylinderLight(placed(-3, -3, -7), 0.3, 3.0, color, path="/tube"),
              "ellipsoid": wrt.SphereLight(np.array([4.0, -4.0, -7.0]) * scale, 0.5, color,
                                           frame=np.diag([2.0, 1.0, 0.5]) * scale, path="/ellipsoid"),
              "etube": wrt.CylinderLight(placed(-4, 0, -7) @ np.diag([1.0, 2.0, 0.5, 1.0]), 3.0, 0.3, color,
                                         path="/etube")}
    scene.lights = [lights[k] for k in kinds.split() if k in lights]
    if "glow" in kinds:
        glow = wrt.Material(path="/glow", diffuse_color=np.zeros(3, np.float32),
                            emissive_color=np.full(3, 4.0, np.float32))
        lamp = quad("/lamp", [[5, 5, -6], [8, 5, -6], [8, 8, -6], [5, 8, -6]], scale)
        lamp.material_ids = np.zeros(2, np.int32)
        scene.meshes, scene.materials = [lamp], [glow]
    return scene, camera


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("kinds", ["rect", "sphere", "disk", "tube", "ellipsoid", "etube", "glow",
                                   "rect sphere disk tube ellipsoid etube glow"])
@pytest.mark.parametrize("scale", [1.0e-30, 1.0e-20, 1.0e-15, 1.0e15, 1.0e20, 1.0e30])
def test_area_lights_light_a_scene_as_unscaled_at_any_scale(scale, kinds, integrator):
    """Rect, sphere, disk and cylinder lights (round, and a sphere and a tube scaled unevenly) and an emissive quad
    light the sphere and floor of :func:`lit_shapes` as in the unscaled scene, with the same seed: their sampling pdf
    is an area over a distance squared, which over- or underflowed float32 (the lights were drawn up to 89 times too
    bright, too dim or black, with a warning; an elliptic tube 1e15 or 1e-15 across lit nothing, without one), and
    is now taken with lengths scaled per light by a power of two (exact). Nothing is warned."""
    def image(s):
        scene, camera = area_lit_shapes(s, kinds)
        return wrt.render(scene, camera=camera, width=16, height=12, device="cpu", integrator=integrator, spp=2,
                          seed=5)

    ref = image(1.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = image(scale)
    same = img.aovs["prim"] == ref.aovs["prim"]
    lit = ref.rgb[same].max(axis=-1) > 1e-3
    assert same.mean() > 0.95 and lit.mean() > 0.15
    np.testing.assert_allclose(img.rgb[same], ref.rgb[same], rtol=2e-3, atol=2e-4)
    assert not [str(w.message) for w in caught if "area light" in str(w.message)]


@pytest.mark.parametrize("placed_by", ["shape", "instance"])
@pytest.mark.parametrize("radius, missed", [(1.0, False), (1.0e-38, False), (6.0e-39, False), (5.0e-39, True)])
def test_analytic_shapes_too_small_for_float32_are_named_in_a_warning(radius, missed, placed_by):
    """A sphere shape of ``radius`` (placed by its own transform, or a unit one in a prototype by an instance's),
    traced by unit rays aimed at its centre from 10 radii away: down to 6e-39 every ray hits it at 9 radii and
    nothing is said; at 5e-39 (its world-to-shape matrix past 2^127, 1.7e38) rays miss it, and it is named in a
    warning (it vanished without a word, where a transform that float32 cannot invert at all is named)."""
    s = np.diag([radius, radius, radius, 1.0])
    if placed_by == "shape":
        scene = wrt.Scene(shapes=[wrt.Shape("/ball", "sphere", s)])
    else:
        proto = wrt.Prototype("/proto", shapes=[wrt.Shape("/proto/ball", "sphere", np.eye(4))])
        scene = wrt.Scene(prototypes=[proto], instances=wrt.Instances.from_transforms([0], s[None]))
    rng = np.random.default_rng(4)
    aims = rng.uniform(-0.3, 0.3, (64, 3)) * radius
    origins = np.tile(np.float32([0.0, 0.0, 10.0 * radius]), (64, 1))
    directions = (aims - origins) / np.linalg.norm(aims - origins, axis=1, keepdims=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hits = wrt.trace(scene, origins.astype(np.float32), directions.astype(np.float32))
    said = [str(w.message) for w in caught if "too small" in str(w.message)]
    if missed:
        name = "/ball" if placed_by == "shape" else "/proto/ball"
        assert len(said) == 1 and f"1 prim(s): {name}" in said[0], said
        return
    assert not said
    assert (hits.prim >= 0).all()
    np.testing.assert_allclose(hits.t, 9.0 * radius, rtol=0.02)


@pytest.mark.parametrize("instance_scale", [2.0**-110, 1.0e-30])
def test_an_instanced_shape_placed_past_float32s_inverse_is_named_in_a_warning(instance_scale):
    """A sphere in a prototype (radius 1e-6, or 2.5e-9), drawn by an instance of scale 1 and one of
    ``instance_scale`` (2^-110, or 1e-30): float32 inverts each of the two transforms but not their product (a
    sphere of radius 7.7e-40, or 2.5e-39). Rays aimed at the first sphere hit it at 9 radii, rays at the second miss
    it, and the warning names it as too small for float32. It vanished without a word, where a shape placed so by
    its own transform, or by an instance's, is named."""
    radius = 1e-6 if instance_scale == 2.0**-110 else 2.5e-9
    ball = np.diag([radius, radius, radius, 1.0])
    proto = wrt.Prototype("/proto", shapes=[wrt.Shape("/proto/ball", "sphere", ball)])
    to_world = np.stack([np.eye(4), np.diag([instance_scale] * 3 + [1.0])])
    to_world[:, 0, 3] = [0.0, 1.0]
    scene = wrt.Scene(prototypes=[proto], instances=wrt.Instances.from_transforms([0, 0], to_world))
    sizes = radius * np.array([1.0, instance_scale])
    origins = (to_world[:, :3, 3] + sizes[:, None] * [0.0, 0.0, 10.0]).astype(np.float32)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (2, 1))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hits = wrt.trace(scene, origins, directions)
    said = [str(w.message) for w in caught if "too small" in str(w.message)]
    assert len(said) == 1 and "1 prim(s): /proto/ball" in said[0], [str(w.message) for w in caught]
    np.testing.assert_array_equal(hits.instance, [0, -1])
    np.testing.assert_allclose(hits.t[0], 9.0 * radius, rtol=1e-6)


@pytest.mark.parametrize("thickness", [1.0e-20, 1.0e-28])
def test_a_card_instance_squashed_along_its_normal_renders_as_unsquashed(thickness):
    """A floor quad in its prototype's z = 0 plane, instanced flat under a small sphere light (a scale of
    ``thickness`` along z, which moves none of its points): the image of the unsquashed instance. inverse_linear
    scaled the whole world-to-local matrix ``diag(1/9, 1/9, 1/thickness)`` by one power of two, taking its two small
    entries to 2^-67 or less, and their float32 determinant underflowed: the inverse was inf or 0, the floor's hit
    points NaN or at its origin and the floor black or lit wrong, where ``wp.inverse`` of the unscaled matrix was
    exact."""
    def scene(t):
        floor = wrt.Prototype("/card", meshes=[quad("/card/quad", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                                                    1.0)])
        placed = np.diag([9.0, 9.0, t, 1.0])
        placed[:3, 3] = [0.0, 0.0, -13.0]
        lamp = wrt.SphereLight(np.array([2.0, 1.0, -10.0]), 0.2, np.full(3, 2000.0))  # lights each pixel differently
        return wrt.Scene(prototypes=[floor], instances=wrt.Instances.from_transforms([0], placed[None]), lights=[lamp])

    ref, img = (wrt.render(scene(t), camera=scaled_camera(1.0), width=8, height=6, device="cpu")
                for t in (1.0, thickness))
    assert (ref.aovs["prim"] >= 0).all() and ref.rgb.min() > 0.1 and np.ptp(ref.rgb) > 0.1
    np.testing.assert_array_equal(img.aovs["prim"], ref.aovs["prim"])
    np.testing.assert_allclose(img.rgb, ref.rgb, atol=1e-4)


def test_inverse_linear_of_unevenly_scaled_turned_matrices_is_their_float64_inverse():
    """``inverse_linear`` of world-to-local matrices of transforms that scale unevenly (up to 1e30 between axes),
    before, after or between turns, of any overall size: their float64 inverses (numpy), to float32's precision.
    One power of two for the whole matrix left its small entries' products to underflow."""
    import warp as wp

    from wrt.instancing import invert_transforms
    from wrt.transforms import inverse_linear, mat34

    @wp.kernel
    def invert(ms: wp.array[mat34], out: wp.array[wp.mat33]):
        i = wp.tid()
        out[i] = inverse_linear(ms[i])

    rng = np.random.default_rng(2)
    linear = []
    for scales in ([1, 1, 1e-20], [1e5, 1e5, 1e-15], [1, 1, 1e-30], [1e-10, 1e-10, 1e10], [1e20, 1e20, 1],
                   [3e-20, 1e-30, 1e-30], [1e15, 1, 1e-15]):
        turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        other = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        linear += [turn @ np.diag(scales), np.diag(scales) @ turn, np.diag(scales), turn @ np.diag(scales) @ other]
    to_world = np.tile(np.eye(4), (len(linear), 1, 1))
    to_world[:, :3, :3] = linear
    # Those that instances and shapes may have: invert_transforms refuses the ones too uneven for float32 (they are
    # thickened or skipped with a warning instead): a scale followed by a turn, whose float32 inverse misses by more
    # than FLOAT32_INVERSE_TOLERANCE, or one past float32's range.
    to_world = to_world[invert_transforms(to_world)[1]]
    assert len(to_world) >= 9
    world_to_local = np.linalg.inv(to_world)[:, :3, :]
    m = world_to_local.astype(np.float32)
    out = wp.zeros(len(m), dtype=wp.mat33, device="cpu")
    wp.launch(invert, len(m), inputs=[wp.array(m, dtype=mat34, device="cpu"), out], device="cpu")
    expected = np.linalg.inv(m[:, :, :3].astype(np.float64))  # of the float32 matrix the kernel was given
    got = out.numpy().astype(np.float64)
    size = np.abs(expected).max(axis=(1, 2), keepdims=True)
    error = (np.abs(got - expected) / size).max(axis=(1, 2))
    assert (error < 1e-5).all(), error


@pytest.mark.parametrize("scale", [1.0, 1.0e-30, 1.0e-34])
def test_a_face_just_behind_a_culled_back_face_is_seen_at_any_scale(scale):
    """A single-sided quad facing away from the camera and a double-sided one a tenth of its distance behind it, all
    scaled by ``scale`` with the camera: every pixel sees the far quad through the near one's back. The camera ray
    was traced again from ``t`` plus at least 1e-30 past the culled face (``hidden_hits.t_past``), an absolute step
    that in a scene scaled by 1e-30 passed the far quad too, and the camera saw nothing."""
    near = [[-100, -100, -5], [-100, 100, -5], [100, 100, -5], [100, -100, -5]]  # clockwise seen from +Z
    far = [[-100, -100, -5.5], [100, -100, -5.5], [100, 100, -5.5], [-100, 100, -5.5]]
    scene = wrt.Scene(meshes=[quad("/near", near, scale, double_sided=False), quad("/far", far, scale)])
    img = wrt.render(scene, camera=scaled_camera(scale), width=12, height=8, device="cpu", integrator="normals")
    np.testing.assert_array_equal(img.aovs["prim"] // 2, 1)  # triangles 2 and 3: the far quad


def sheared_card(scale: float, shear: float, back: bool):
    """A single-sided square card (facing the camera, or away from it with ``back``) instanced by ``scale`` times the
    inverse of ``[[1, shear, 0], [0, 1, 0], [0, 0, 1]]``, 10 ``scale`` in front of a camera scaled by ``scale``
    looking along ``(0.6, 0.6, -0.53)``, whose rays' world-to-card directions are ``(1.2, 0.6, -0.53) / scale`` for
    a shear of 1: past float32 for a scale of 1 / 3e38. ``(scene, camera)``."""
    n = np.array([0.1, -0.5, 0.8]) / np.linalg.norm([0.1, -0.5, 0.8])  # the card's normal, in its prototype
    u = np.cross(n, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    corners = np.array([-u - v, u - v, u + v, -u + v])  # counter-clockwise about n: its front faces along n
    mesh = wrt.Mesh("/card/quad", corners[::-1] if back else corners, [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32),
                    double_sided=False)
    view = np.array([0.6, 0.6, -0.53]) / np.linalg.norm([0.6, 0.6, -0.53])
    placed = np.eye(4)
    placed[:3, :3] = np.linalg.inv([[1.0, shear, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) * scale
    placed[:3, 3] = 10 * scale * view
    scene = wrt.Scene(prototypes=[wrt.Prototype("/card", meshes=[mesh])],
                      instances=wrt.Instances.from_transforms([0], placed[None]))
    right = np.cross([0.0, 0.0, 1.0], -view)
    right /= np.linalg.norm(right)
    camera = np.eye(4)
    camera[:3, :3] = np.stack([right, np.cross(-view, right), -view], axis=1) * scale
    return scene, wrt.Camera(to_world=camera, focal_length=500.0, horizontal_aperture=36.0)


@pytest.mark.parametrize("shear", [0.0, 1.0])
@pytest.mark.parametrize("scale", [1.0, 1.0e-36, 1.0e-38, 1.0 / 3.0e38])
def test_an_instanced_single_sided_card_is_culled_from_behind_at_any_scale(scale, shear):
    """A single-sided card instanced at scales down to 3.3e-39 (its world-to-card matrix's entries 3e38, near
    float32's limit), plain or sheared, seen from the front (drawn in every pixel, as at scale 1) and from behind
    (culled: nothing behind it). The back-face test took the camera ray into the card's space as ``A d``, which for
    the sheared card at 3.3e-39 overflowed (1.2 times 3e38): inf in one component decided the sign, and its back
    was drawn in every pixel."""
    for back in (False, True):
        scene, camera = sheared_card(scale, shear, back)
        img = wrt.render(scene, camera=camera, width=8, height=6, device="cpu", integrator="normals")
        if back:
            np.testing.assert_array_equal(img.aovs["prim"], -1)
        else:
            assert (img.aovs["prim"] >= 0).all()


@pytest.mark.parametrize("distance, instanced", [(1e8, False), (1e8, True), (1e30, False)])
def test_shapes_seen_from_too_far_for_float32_hit_points_are_named_in_a_warning(distance, instanced):
    """A unit sphere (single-sided) seen from ``distance`` through a lens whose view is 0.2 units wide there: in float64
    every pixel's ray meets it (the view lies inside its outline), but float32 puts the hit point ``o + t d`` within
    about ``distance * 2^-23`` (8 units at 1e8) of the sphere, its normal came out sideways, the hit was culled as a
    back face and the image was background without a word. The camera and the sphere are named in a warning; the
    same view from 1e4 (a hit point within 1e-3) renders the sphere and says nothing."""
    ball = wrt.Shape("/ball", "sphere", np.eye(4))
    if instanced:
        scene = wrt.Scene(prototypes=[wrt.Prototype("/proto", shapes=[wrt.Shape("/proto/ball", "sphere", np.eye(4))])],
                          instances=wrt.Instances.from_transforms([0], np.eye(4)[None]))
    else:
        scene = wrt.Scene(shapes=[ball])
    name = "/proto/ball" if instanced else "/ball"
    for far, expect_hits in ((1e4, True), (distance, False)):
        to_world = np.eye(4)
        to_world[2, 3] = far
        cam = wrt.Camera(to_world=to_world, focal_length=100.0 * far, horizontal_aperture=20.0, vertical_aperture=15.0,
                         clipping_range=(1.0, 10.0 * far), path="/Far")
        origins, directions = camera_rays(scene, cam, width=4, height=3)
        o, d = origins.astype(np.float64), directions.astype(np.float64)
        closest = o - np.sum(o * d, axis=1, keepdims=True) * d  # float64: every ray passes within 0.13 of the centre
        assert np.all(np.linalg.norm(closest, axis=1) < 0.2)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            image = wrt.render(scene, camera=cam, width=4, height=3, device="cpu")
        said = [str(w.message) for w in caught if "float32" in str(w.message) and "hit points" in str(w.message)]
        if expect_hits:
            assert not said and (image.aovs["prim"] >= 0).all(), said
        else:
            assert len(said) == 1 and "camera /Far" in said[0] and f"1 prim(s): {name}" in said[0], said


def test_a_camera_too_far_from_the_scene_for_float32_depths_is_named_in_a_warning():
    """A floor and a card 0.5 in front of it, framed from 1e8 by a lens whose view is 2 units wide there: float32
    resolves distances along the rays only to 8 units, so the ray through the card's centre (float64: it meets the
    card first) saw the floor behind it, without a word. The camera is named in a warning; the same view from 1e4
    sees the card and says nothing."""
    floor = wrt.Mesh("/floor", np.float32([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]]), [[0, 1, 2], [0, 2, 3]],
                     [0, 0], double_sided=True)
    card = wrt.Mesh("/card", np.float32([[0.15, 0.05, 0.5], [0.45, 0.05, 0.5], [0.45, 0.35, 0.5], [0.15, 0.35, 0.5]]),
                    [[0, 1, 2], [0, 2, 3]], [0, 0], double_sided=True)
    scene = wrt.Scene(meshes=[floor, card])
    for far, expect_card in ((1e4, True), (1e8, False)):
        to_world = np.eye(4)
        to_world[:3, 3] = [0.3, 0.2, far]  # the middle pixel's ray runs down the card's centre
        cam = wrt.Camera(to_world=to_world, focal_length=10.0 * far, horizontal_aperture=20.0,
                         vertical_aperture=20.0, clipping_range=(1.0, 10.0 * far), path="/Far")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            image = wrt.render(scene, camera=cam, width=3, height=3, device="cpu", integrator="normals")
        said = [str(w.message) for w in caught if "camera /Far is so far from the scene" in str(w.message)]
        if expect_card:
            assert not said and image.aovs["prim"][1, 1] in (2, 3), said  # the card's triangles
        else:
            assert len(said) == 1 and "float32" in said[0], said


def scene_too_far_warnings(card_at, eye, focal_length: float) -> list[str]:
    """The far-view warnings of a 2x2 card centred at ``card_at`` (in z = ``card_at[2]``), seen down -z from ``eye``
    through a square film 20 wide at ``focal_length``."""
    corners = np.float64([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) + card_at
    card = wrt.Mesh("/card", corners.astype(np.float32), [[0, 1, 2], [0, 2, 3]], [0, 0], double_sided=True)
    to_world = np.eye(4)
    to_world[:3, 3] = eye
    cam = wrt.Camera(to_world=to_world, focal_length=focal_length, horizontal_aperture=20.0, vertical_aperture=20.0,
                     clipping_range=(1.0, 1e9), path="/Cam")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.Renderer(wrt.Scene(meshes=[card]), camera=cam, width=8, height=8, device="cpu", integrator="normals")
    return [str(w.message) for w in caught if "float32 resolves distances" in str(w.message)]


def test_the_scene_too_far_warning_says_whether_the_camera_or_the_scene_is_far():
    """float32 loses depth order where the eye is far from the origin or the hit far from the eye. A card 1e7 from
    the origin seen from 5 units (its film 2 units wide there) was warned of as '/Cam is so far from the scene (5
    units ...)': the camera blamed for the scene's place. The warning now says the scene lies far from the origin
    there, and still says the camera is far from a card at the origin seen from 1e8 (the distances are numpy's)."""
    card_at, eye = np.array([1e7, 0.0, 0.0]), np.array([1e7, 0.0, 5.0])
    said = scene_too_far_warnings(card_at, eye, 50.0)
    assert len(said) == 1, said
    assert f"the scene lies so far from the world origin ({np.linalg.norm(card_at):.3g} units" in said[0], said
    assert f"/Cam {np.linalg.norm(eye - card_at):.3g} units from it" in said[0] and "is so far from" not in said[0]
    eye = np.array([0.0, 0.0, 1e8])
    said = scene_too_far_warnings(np.zeros(3), eye, 1e9)
    assert len(said) == 1, said
    assert f"/Cam is so far from the scene ({np.linalg.norm(eye):.3g} units" in said[0], said
    assert "world origin" not in said[0], said


def test_an_animated_far_camera_is_warned_of_once_per_renderer():
    """A camera flying at 1e8 from a unit sphere (its view 0.2 units wide there), given anew by ``set_cameras`` each
    frame: each far-view warning (the scene too far for float32 depths, the shape too far for its hit points) is
    said once by the Renderer, as its clipping warnings are; it was said again at every camera upload, once per
    frame, with the camera's distance of that frame."""
    scene = wrt.Scene(shapes=[wrt.Shape("/ball", "sphere", np.eye(4))])

    def far_camera(frame: int) -> wrt.Camera:
        to_world = np.eye(4)
        to_world[:3, 3] = [0.0, 0.0, 1e8 + 1e3 * frame]
        return wrt.Camera(to_world=to_world, focal_length=1e10, horizontal_aperture=20.0, vertical_aperture=15.0,
                          clipping_range=(1.0, 1e9), path="/Far")

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer = wrt.Renderer(scene, camera=far_camera(0), width=4, height=3, device="cpu", integrator="normals")
        renderer.render()
        for frame in range(1, 4):
            renderer.set_cameras([far_camera(frame)])
            renderer.render()
        renderer.render()
    said = [str(w.message) for w in caught if "camera /Far" in str(w.message)]
    scene_too_far = [m for m in said if "is so far from the scene" in m]
    shapes_too_far = [m for m in said if "sees analytic shapes from so far" in m]
    assert len(scene_too_far) == 1 and len(shapes_too_far) == 1, said
    assert len(said) == 2, said


def far_python_camera(z: float) -> wrt.Camera:
    """A camera made in Python (no path: labelled ``camera``) at ``(0, 0, z)`` looking down -z through a lens 0.2
    units wide at 1e8, far enough for both far-view warnings of a unit sphere at the origin."""
    to_world = np.eye(4)
    to_world[:3, 3] = [0.0, 0.0, z]
    return wrt.Camera(to_world=to_world, focal_length=1e10, horizontal_aperture=20.0, vertical_aperture=15.0,
                      clipping_range=(1.0, 1e9))


def far_view_warnings(make) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        make()
    return [str(w.message) for w in caught if "float32" in str(w.message)]


def test_each_far_camera_of_a_batch_made_in_python_is_warned_of():
    """Two far cameras made in Python, rendered in one batch: each warns, as each does rendered on its own (the
    oracle: a fresh Renderer per camera). The warnings were keyed by the label, ``camera`` for both, so the second
    camera's went unsaid; they name each camera by its place in the batch."""
    scene = wrt.Scene(shapes=[wrt.Shape("/ball", "sphere", np.eye(4))])
    cameras = [far_python_camera(1e8), far_python_camera(3e8)]
    alone = [far_view_warnings(lambda c=c: wrt.Renderer(scene, camera=c, width=4, height=3, device="cpu"))
             for c in cameras]
    assert all(len(said) == 2 for said in alone), alone  # the scene too far, and the shape
    said = far_view_warnings(lambda: wrt.Renderer(scene, cameras=cameras, width=4, height=3, device="cpu"))
    assert len(said) == sum(len(s) for s in alone), said
    for k in range(2):
        assert sum(f"cameras[{k}]" in message for message in said) == 2, said


def test_a_far_shape_is_warned_of_once_whatever_else_a_moving_camera_loses():
    """A camera moving along z loses the sphere below it (frame 0), then also the one above it, once that one is
    ahead too (frame 1), then only the first again (frame 2): each shape is named once, as each frame rendered fresh
    names it (the oracle). The key held the set of shapes lost, so the first sphere was named again at frame 1."""
    high = np.eye(4)
    high[2, 3] = 2e8
    scene = wrt.Scene(shapes=[wrt.Shape("/low", "sphere", np.eye(4)), wrt.Shape("/high", "sphere", high)])
    frames = [far_python_camera(z) for z in (1e8, 3e8, 1e8)]
    fresh = [far_view_warnings(lambda c=c: wrt.Renderer(scene, camera=c, width=4, height=3, device="cpu"))
             for c in frames]
    named = {path for said in fresh for message in said if "analytic shapes" in message
             for path in ("/low", "/high") if path in message}
    assert named == {"/low", "/high"}

    def animate():
        renderer = wrt.Renderer(scene, camera=frames[0], width=4, height=3, device="cpu")
        for camera in frames[1:]:
            renderer.set_cameras([camera])

    said = [message for message in far_view_warnings(animate) if "analytic shapes" in message]
    for path in named:
        assert sum(path in message for message in said) == 1, said


def shadowed_ball(size: float, scale: float) -> wrt.Scene:
    """A ball ``size`` across (a 12 x 8 faceted sphere) instanced by ``diag(3, 2, 3) scale`` 12 of its widths in front
    of the camera, under a sun that a card (in the world) hides it from: its world the same for every ``size`` with
    ``size * scale`` fixed."""
    ball = uv_sphere(center=(0, 0, 0), radius=1.0, rings=8, segments=12, smooth=False)
    proto = wrt.Prototype("/ball", meshes=[wrt.Mesh("/ball/mesh", (ball.points * size).astype(np.float32),
                                                     ball.indices, np.zeros(len(ball.indices), np.int32))])
    width = size * scale
    placed = np.diag([3 * scale, 2 * scale, 3 * scale, 1.0])
    placed[:3, 3] = np.array([0.0, 0.0, -12.0]) * width
    toward_sun = np.array([-0.8, 0.4, 0.4]) / np.linalg.norm([0.8, 0.4, 0.4])
    centre = np.array([0.0, 0.0, -12.0]) + 6 * toward_sun
    across, up = np.array([0.0, 0.0, 2.5]), np.array([0.0, 2.5, 0.0])
    card = np.array([centre - across - up, centre + across - up, centre + across + up, centre - across + up]) * width
    card = wrt.Mesh("/card", card.astype(np.float32), [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32))
    sun = wrt.DistantLight(-toward_sun, np.full(3, 2.0, np.float32))
    return wrt.Scene(meshes=[card], prototypes=[proto], instances=wrt.Instances.from_transforms([0], placed[None]),
                     lights=[sun])


@pytest.mark.parametrize("size, scale", [(1e-10, 1e39), (1e10, 1e-30)])
def test_an_instance_whose_to_world_scale_float32_cannot_hold_is_shaded_as_one_it_can(size, scale):
    """A ball 1e-10 across instanced by 3e39 (its ``L`` past float32's range, its ``A`` subnormal; traced in a BLAS
    scaled by 2^130, :func:`wrt.tlas.instance_exponents`), in a card's shadow, is drawn as the same world made of a
    ball 1 across scaled by 1e29 (the oracle; its ``L`` float32 holds): its shading points were moved to the world by
    the float32 inverse of ``A``, which overflowed (NaN points, NaN error bounds), so its shadow rays started nowhere,
    met nothing, and the ball was lit. The second case (``A`` 1e30, ``L`` 1e-30, both held) guards the ordinary
    path."""
    width = size * scale
    camera = wrt.Camera(to_world=np.diag([width, width, width, 1.0]), focal_length=50.0, horizontal_aperture=36.0)
    ref, img = (wrt.render(shadowed_ball(s, width / s), camera=camera, width=16, height=12, device="cpu")
                for s in (1.0, size))
    ball = ref.aovs["instance"] == 0
    shadowed = ref.rgb[ball].max(axis=1) == 0
    assert ball.sum() > 30 and 5 < shadowed.sum() < ball.sum(), shadowed.sum()  # in view, partly in the card's shadow
    np.testing.assert_array_equal(img.aovs["instance"], ref.aovs["instance"])
    np.testing.assert_allclose(img.rgb[ball], ref.rgb[ball], atol=1e-4)
