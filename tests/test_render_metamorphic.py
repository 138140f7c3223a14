"""Metamorphic render tests: one small scene (meshes, an analytic mirror sphere and box, an instance, sphere, rect,
disk, distant and dome lights) rendered whole under changes that must leave the image alone: moved far from the
origin, scaled, turned a quarter, mirrored, a mesh split in two or drawn as an instance. Every transform is applied to
everything (geometry, camera, lights), with the same seed, so the path tracer draws the same samples."""

import math

import numpy as np
import pytest
from shading_helpers import uv_sphere

import wrt

WIDTH, HEIGHT = 64, 48
GREY, RED, GREEN, MIRROR = 0, 1, 2, 3  # material indices
MATERIALS = [
    wrt.Material(path="/grey", diffuse_color=np.full(3, 0.6, np.float32)),
    wrt.Material(path="/red", diffuse_color=np.array([0.8, 0.2, 0.2], np.float32)),
    wrt.Material(path="/green", diffuse_color=np.array([0.2, 0.7, 0.3], np.float32)),
    wrt.Material(path="/mirror", diffuse_color=np.full(3, 0.9, np.float32), metallic=1.0, roughness=0.0),
]
BOX_CENTRE = np.array([1.2, 0.5, 0.0])  # a unit cube standing on the floor


def translation(t) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = t
    return m


def scaling(s) -> np.ndarray:
    return np.diag([s, s, s, 1.0])


def quarter_turn(axis: int) -> np.ndarray:
    """An exact turn by 90 degrees about world axis 0, 1 or 2."""
    i, j = (axis + 1) % 3, (axis + 2) % 3
    m = np.eye(4)
    m[i, i] = m[j, j] = 0.0
    m[i, j], m[j, i] = -1.0, 1.0
    return m


def mirroring(axis: int) -> np.ndarray:
    m = np.eye(4)
    m[axis, axis] = -1.0
    return m


def unit_cube():
    """Corners and outward-wound triangles of the cube [-0.5, 0.5]^3."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.array([tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))], np.int32)
    normal = np.cross(corners[tris[:, 1]] - corners[tris[:, 0]], corners[tris[:, 2]] - corners[tris[:, 0]])
    inward = np.einsum("ij,ij->i", normal, corners[tris].mean(axis=1)) < 0
    tris[inward] = tris[inward][:, [0, 2, 1]]
    return corners, tris


def mesh(path, points, tris, to_world, material, normals=None) -> wrt.Mesh:
    """A mesh with its points moved by ``to_world`` in float64; a mirroring transform flips the winding, as the USD
    loader does, so the front side stays the front side."""
    linear = to_world[:3, :3]
    points = np.asarray(points, np.float64) @ linear.T + to_world[:3, 3]
    tris = np.asarray(tris, np.int32)
    if np.linalg.det(linear) < 0:
        tris = tris[:, [0, 2, 1]]
        normals = None if normals is None else normals[:, [0, 2, 1]]
    if normals is not None:
        normals = normals @ np.linalg.inv(linear)
        normals = (normals / np.linalg.norm(normals, axis=-1, keepdims=True)).astype(np.float32)
    return wrt.Mesh(path, points.astype(np.float32), tris, np.arange(len(tris)), normals=normals,
                    material_ids=np.full(len(tris), material, np.int32))


def scene_and_camera(to_world=np.eye(4), *, lights=("distant", "sphere", "rect", "disk", "dome"), box="mesh"):
    """The test scene and its camera, everything moved by the similarity ``to_world``. ``box``: the cube as one mesh
    (``"mesh"``), as two meshes (``"split"``), or as an instance of a prototype (``"instance"``)."""
    scale = abs(np.linalg.det(to_world[:3, :3])) ** (1.0 / 3.0)
    turn = to_world[:3, :3] / scale
    floor = np.array([[-6, 0, -6], [-6, 0, 6], [6, 0, 6], [6, 0, -6]], np.float64)  # front side up
    meshes = [mesh("/floor", floor, [[0, 1, 2], [0, 2, 3]], to_world, GREY)]
    corners, tris = unit_cube()
    prototypes, instances = [], wrt.Instances.empty()
    if box == "mesh":
        meshes.append(mesh("/box", corners + BOX_CENTRE, tris, to_world, RED))
    elif box == "split":
        meshes += [mesh("/boxA", corners + BOX_CENTRE, tris[:5], to_world, RED),
                   mesh("/boxB", corners + BOX_CENTRE, tris[5:], to_world, RED)]
    else:
        prototypes.append(wrt.Prototype("/proto", meshes=[mesh("/proto/box", corners, tris, np.eye(4), RED)]))
        instances = wrt.Instances.from_transforms([0], (to_world @ translation(BOX_CENTRE))[None])
    ball = uv_sphere(center=(-1.2, 0.6, 0.4), radius=0.6, rings=12, segments=24, smooth=True)
    meshes.append(mesh("/ball", ball.points, ball.indices, to_world, GREEN, normals=ball.normals))
    shapes = [
        wrt.Shape("/mirror", "sphere", to_world @ translation((0.0, 0.45, -1.4)) @ scaling(0.45), material_id=MIRROR),
        wrt.Shape("/cube", "box", to_world @ translation((-0.2, 0.25, 1.3)) @ scaling(0.25), material_id=GREEN),
    ]
    down = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])  # local -Z (emission) to world -Y
    made = {
        "distant": lambda: wrt.DistantLight(turn @ np.array([-0.4, -1.0, -0.3]), np.full(3, 2.0, np.float32)),
        "sphere": lambda: wrt.SphereLight((to_world @ [2.0, 2.2, 1.5, 1.0])[:3], 0.3 * scale,
                                          np.array([4.0, 3.5, 3.0], np.float32)),
        "rect": lambda: wrt.RectLight(to_world @ translation((-2.0, 2.5, -0.5)) @ down, 1.0, 0.6,
                                      np.array([3.0, 3.0, 3.5], np.float32)),
        "disk": lambda: wrt.DiskLight(to_world @ translation((0.0, 2.0, 2.5)) @ down, 0.4,
                                      np.array([2.0, 2.5, 2.0], np.float32)),
        "dome": lambda: wrt.DomeLight(np.full(3, 0.15, np.float32)),
    }
    scene = wrt.Scene(meshes=meshes, shapes=shapes, prototypes=prototypes, instances=instances,
                      lights=[made[name]() for name in lights], materials=MATERIALS)
    look = wrt.Camera.look_at((0.0, 2.2, 5.0), (0.0, 0.5, 0.0), fov_y_deg=45.0)
    camera = wrt.Camera(to_world=to_world @ look.to_world, focal_length=look.focal_length,
                        horizontal_aperture=look.horizontal_aperture, vertical_aperture=look.vertical_aperture,
                        fit=look.fit)
    return scene, camera


def render(to_world=np.eye(4), integrator="whitted", spp=1, **kwargs) -> wrt.Image:
    scene, camera = scene_and_camera(to_world, **kwargs)
    return wrt.render(scene, camera=camera, width=WIDTH, height=HEIGHT, spp=spp, seed=5, integrator=integrator,
                      device="cpu")


def block_means(rgb: np.ndarray) -> np.ndarray:
    """Means over 8x8 pixel blocks: Monte Carlo noise that the far scene's rounding reshuffles averages out."""
    return rgb.reshape(HEIGHT // 8, 8, WIDTH // 8, 8, 3).mean(axis=(1, 3))


FAR = (1.0e5, 7.0e4, -4.0e4)  # float32 ulps of 0.008: a hundredth of the cube's size


@pytest.mark.parametrize("integrator, spp", [("whitted", 4), ("path", 8), ("ao", 8)])
def test_a_scene_moved_far_from_the_origin_keeps_its_shadows(integrator, spp):
    """Moved 1e5 away, the scene keeps its shadows, contact shadows and occlusion: the same image up to its rounding.
    Shadow and bounce rays left a surface 256 float32 ulps of the hit point's coordinates above it (Wachter and
    Binder's offset), 2 units at 7e4, twice the cube's height: the surfaces were 3.2% (whitted), 7.5% (path) and 11%
    (ao) brighter, 8x8 blocks up to 0.12, 0.34 and 0.34 off."""
    near = render(integrator=integrator, spp=spp)
    far = render(translation(FAR), integrator, spp)
    # The first hits are the same up to the far scene's rounding (the lights' own pixels, seen directly, are not
    # compared: their edges move by its ulps).
    assert (far.aovs["prim"] == near.aovs["prim"]).mean() > 0.98
    on = ((near.aovs["prim"] >= 0) & (far.aovs["prim"] >= 0))[..., None]
    assert abs(far.rgb[on[..., 0]].mean() / near.rgb[on[..., 0]].mean() - 1.0) < 0.01
    assert np.abs(block_means(np.where(on, far.rgb, 0.0)) - block_means(np.where(on, near.rgb, 0.0))).max() < 0.04


@pytest.mark.parametrize("to_world", [scaling(2.0**-14), scaling(1.0e-4), scaling(3.7), scaling(1.0e4),
                                      quarter_turn(0), quarter_turn(1), mirroring(0), mirroring(2) @ quarter_turn(0),
                                      translation((1.0e3, -700.0, 400.0))],
                         ids=["2^-14", "1e-4", "3.7", "1e4", "turn-x", "turn-y", "mirror-x", "mirror-z-turn", "1e3"])
def test_similar_scenes_render_the_same_image_and_aovs(to_world):
    """Under a sun (a delta light) whitted draws no random numbers, so a scaled, turned, mirrored or moved scene gives
    the same picture pixel for pixel, its depth scaled, its normals turned, the rest unchanged (up to rounding: at
    1e3, grazing pixels' normals move by up to 3e-3)."""
    lights = ("distant",)
    ref = render(lights=lights)
    img = render(to_world, lights=lights)
    scale = abs(np.linalg.det(to_world[:3, :3])) ** (1.0 / 3.0)
    np.testing.assert_allclose(img.rgb, ref.rgb, atol=2e-3)
    np.testing.assert_array_equal(img.aovs["prim"], ref.aovs["prim"])
    np.testing.assert_array_equal(img.aovs["coverage"], ref.aovs["coverage"])
    np.testing.assert_array_equal(img.aovs["albedo"], ref.aovs["albedo"])
    hit = ref.aovs["prim"] >= 0
    np.testing.assert_allclose(img.aovs["depth"][hit], ref.aovs["depth"][hit] * scale, rtol=1e-3)
    turned = ref.aovs["normal"] @ (to_world[:3, :3] / scale).T
    np.testing.assert_allclose(img.aovs["normal"][hit], turned[hit], atol=5e-3)


@pytest.mark.parametrize("integrator", ["whitted", "path", "ao"])
@pytest.mark.parametrize("box", ["split", "instance"])
def test_a_mesh_split_in_two_or_drawn_as_an_instance_renders_the_same_image(integrator, box):
    """The cube as two meshes or as an instance of a prototype: the same samples give the same image and AOVs (the
    instance's triangle ids aside), every light type included."""
    ref = render(integrator=integrator, spp=2)
    img = render(integrator=integrator, spp=2, box=box)
    np.testing.assert_allclose(img.rgb, ref.rgb, atol=1e-5)
    for name in ("depth", "normal", "albedo", "coverage", "material"):
        np.testing.assert_allclose(img.aovs[name], ref.aovs[name], rtol=1e-6, atol=1e-6, err_msg=name)
    if box == "split":
        np.testing.assert_array_equal(img.aovs["prim"], ref.aovs["prim"])
    assert math.isclose(float((img.aovs["prim"] >= 0).mean()), float((ref.aovs["prim"] >= 0).mean()))


def closed_room(to_world, sun: bool):
    """A closed box room 4 across (inward-facing, single-sided) with a table on its floor, a sphere light inside and,
    with ``sun``, a bright sun outside that must not reach in; the camera inside looks at a corner."""
    corners, tris = unit_cube()
    meshes = [mesh("/room", corners * 4.0, tris[:, [0, 2, 1]], to_world, GREY),
              mesh("/table", corners * (1.0, 0.6, 1.0) + (0.5, -1.7, 0.2), tris, to_world, RED)]
    lights = [wrt.SphereLight((to_world @ [0.8, 1.2, -0.5, 1.0])[:3], 0.2, np.full(3, 5.0, np.float32))]
    if sun:
        lights.append(wrt.DistantLight(np.array([-0.3, -1.0, -0.2]), np.full(3, 50.0, np.float32)))
    look = wrt.Camera.look_at((1.5, 0.5, 1.9), (-1.0, -1.5, -1.0), fov_y_deg=80.0)
    camera = wrt.Camera(to_world=to_world @ look.to_world, focal_length=look.focal_length,
                        horizontal_aperture=look.horizontal_aperture, vertical_aperture=look.vertical_aperture,
                        fit=look.fit)
    return wrt.Scene(meshes=meshes, lights=lights, materials=MATERIALS), camera


@pytest.mark.parametrize("far", [FAR, (1.0e6, 7.0e5, -4.0e5)], ids=["1e5", "1e6"])
def test_a_closed_room_far_from_the_origin_lets_no_sunlight_in(far):
    """Far from the origin many hit points round onto the room's edges; a ray leaving the wall there along the wall's
    normal started in the floor's plane and passed through the floor. Whitted lit 81 (1e5) and 10,733 (1e6) of 12,288
    pixels from the sun outside with 256-ulp offsets, 3 and 32 with offsets along the normal alone; the path tracer's
    room was 97% brighter at 1e5, then 16%. Hit points are now summed from edge vectors (they do not round past a
    wall) and ray origins pulled into their triangle before the offset. (At 1e6 the offsets are 0.7, more than the
    table's height: the path tracer's room drifts there, see README.)"""
    images = {}
    for sun in (False, True):
        scene, camera = closed_room(translation(far), sun)
        images["whitted", sun] = wrt.render(scene, camera=camera, width=128, height=96, device="cpu").rgb
        if far == FAR:
            images["path", sun] = wrt.render(scene, camera=camera, width=WIDTH, height=HEIGHT, spp=32, seed=1,
                                             integrator="path", max_depth=2, device="cpu").rgb
    assert not (images["whitted", True] != images["whitted", False]).any()
    if far == FAR:
        dark, lit = images["path", False].mean(), images["path", True].mean()
        assert abs(lit / dark - 1.0) < 0.03  # the sun adds nothing; another light to choose from reshuffles the noise
