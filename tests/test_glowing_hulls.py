"""Glowing analytic shapes that are not round spheres or tubes (boxes, ellipsoids, planes, squeezed cylinders, shapes
that glow inwards) are sampled as lights (wrt.glowing_hulls): a white floor under a glowing box or ellipsoid shows
the irradiance float64 quadrature over the shape's surface gives, under whitted (which lit nothing with them before)
and path (MIS against BSDF-sampled hits: a pdf read back wrong would bias it), within a few standard errors over
seeds; the warning about emitters left unsampled no longer names them."""

import warnings

import numpy as np
import pytest
from light_oracle import polygon_irradiance

import wrt

RADIANCE = 3.0  # of the glowing shape
RES = 4  # pixels per side of the floor patch seen
PATCH = 1.0  # side of the patch, centred under the shape
SUB = 6  # quadrature points per pixel side
UNSAMPLED = "emissive analytic primitive"  # how render.py's warning counts glowing shapes it does not sample


def floor_and_materials():
    """A 40 x 40 white Lambertian floor (albedo 1, no specular lobe) at z = 0, and ``[white, glow]`` materials."""
    points = np.array([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)], np.float32)
    floor = wrt.Mesh("/Floor", points, np.array([[0, 1, 2], [0, 2, 3]]), np.array([0, 0]),
                     material_ids=np.zeros(2, np.int32))
    bare = dict(ior=1.0, specular_edge=0.0)
    return floor, [wrt.Material("/White", diffuse_color=(1.0, 1.0, 1.0), **bare),
                   wrt.Material("/Glow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(RADIANCE,) * 3, **bare)]


def rotation(x_degrees, z_degrees):
    """A turn about X, then about Z."""
    a, b = np.radians(x_degrees), np.radians(z_degrees)
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
    return rz @ rx


def placed(linear, centre):
    to_world = np.eye(4)
    to_world[:3, :3] = linear
    to_world[:3, 3] = centre
    return to_world


BOX = placed(rotation(15, 30) @ np.diag([0.8, 0.6, 0.3]), (0.1, 0.0, 0.55))  # low over the patch, turned
ELLIPSOID = placed(rotation(-20, 40) @ np.diag([0.7, 0.25, 0.4]), (0.0, 0.1, 0.8))


def patch_points():
    """``(RES * SUB, RES * SUB, 3)`` floor points: SUB x SUB midpoints of each pixel's square (row 0 at +Y)."""
    xs = ((np.arange(RES * SUB) + 0.5) / (RES * SUB) - 0.5) * PATCH
    gx, gy = np.meshgrid(xs, -xs)
    return np.stack([gx, gy, np.zeros_like(gx)], axis=-1)


def floor_radiance(surface):
    """``(RES, RES)`` float64 radiance of the white floor, E / pi averaged over each pixel, where ``surface`` gives
    ``(points (Q, 3), outward unit normals (Q, 3), area weights (Q,))`` of the glowing shape: the irradiance is
    L times the sum of cos_floor cos_shape / d^2 over the surface points that face the floor point."""
    q, normals, weights = surface
    p = patch_points().reshape(-1, 3)
    out = np.empty(len(p))
    for i, point in enumerate(p):
        d = q - point
        dist = np.linalg.norm(d, axis=1)
        cos_shape = np.clip(-(d * normals).sum(axis=1) / dist, 0.0, None)
        cos_floor = np.clip(d[:, 2] / dist, 0.0, None)
        out[i] = RADIANCE * np.sum(weights * cos_shape * cos_floor / dist**2) / np.pi
    return out.reshape(RES, SUB, RES, SUB).mean(axis=(1, 3))


def box_surface(to_world, n=48):
    """Gauss-Legendre points of the six faces of the box ``to_world [-1, 1]^3``."""
    x, wx = np.polynomial.legendre.leggauss(n)
    u, v = (g.reshape(-1) for g in np.meshgrid(x, x))
    w = np.outer(wx, wx).reshape(-1)
    linear, centre = to_world[:3, :3], to_world[:3, 3]
    sign = np.sign(np.linalg.det(linear))
    parts = []
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        cross = np.cross(linear[:, j], linear[:, k]) * sign  # along the face's outward normal for s = +1
        for s in (-1.0, 1.0):
            q = centre + s * linear[:, i] + u[:, None] * linear[:, j] + v[:, None] * linear[:, k]
            normal = s * cross / np.linalg.norm(cross)
            parts.append((q, np.tile(normal, (len(q), 1)), w * np.linalg.norm(cross)))
    return tuple(np.concatenate(p) for p in zip(*parts))


def ellipsoid_surface(to_world, n=300):
    """Midpoints of the unit sphere's (theta, phi) grid mapped onto the ellipsoid ``to_world`` B: area elements
    ``|cof(M) u| sin(theta)``, normals along ``M^-T u``."""
    theta = (np.arange(n) + 0.5) * np.pi / n
    phi = (np.arange(2 * n) + 0.5) * np.pi / n
    t, f = (g.reshape(-1) for g in np.meshgrid(theta, phi))
    u = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], axis=1)
    linear, centre = to_world[:3, :3], to_world[:3, 3]
    cofactor = np.linalg.det(linear) * np.linalg.inv(linear).T
    stretched = u @ cofactor.T
    area = np.linalg.norm(stretched, axis=1)
    return centre + u @ linear.T, stretched / area[:, None], area * np.sin(t) * (np.pi / n) ** 2


def render_patch(shapes, integrator, spp, seed, **scene_fields):
    """``(RES, RES)`` radiance of the floor patch seen from below the shapes (and the ``prototypes`` and ``instances``
    of ``scene_fields``) and the warnings the render gave."""
    floor, materials = floor_and_materials()
    scene = wrt.Scene(meshes=[floor], shapes=shapes, materials=materials, **scene_fields)
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.05), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=spp, seed=seed, integrator=integrator)
    return img.rgb.mean(axis=-1).astype(np.float64), [str(w.message) for w in caught]


def assert_within_standard_errors(shapes, expected, integrator, seeds=12, spp=256, **scene_fields):
    """The patch's mean over ``seeds`` renders is the quadrature's within 4 standard errors of that mean."""
    means = []
    for seed in range(seeds):
        rendered, messages = render_patch(shapes, integrator, spp, seed, **scene_fields)
        assert not [m for m in messages if UNSAMPLED in m], messages
        means.append(rendered.mean())
    means = np.array(means)
    error = means.std(ddof=1) / np.sqrt(seeds)
    assert abs(means.mean() - expected.mean()) < 4.0 * error, (means.mean(), expected.mean(), error)
    assert error < 0.02 * expected.mean(), error  # (a test that says something)


def test_the_box_quadrature_is_the_closed_form_of_a_square_over_a_point():
    """The oracle itself: a square of side 2 a facing down at height h (a box of no height) sends a point on its
    axis E / L = 4 (a / s) arctan(a / s), s = sqrt(a^2 + h^2): four times a corner's form factor in closed form."""
    a, h = 0.5, 0.7
    to_world = placed(np.diag([a, a, 1e-9]), (0.0, 0.0, h))
    q, normals, weights = box_surface(to_world, n=64)
    d = q
    dist = np.linalg.norm(d, axis=1)
    e = np.sum(weights * np.clip(-(d * normals).sum(axis=1) / dist, 0, None) * np.clip(d[:, 2] / dist, 0, None)
               / dist**2)
    s = np.hypot(a, h)
    assert e == pytest.approx(4.0 * (a / s) * np.arctan(a / s), rel=1e-6)


def panel_radiance(corners):
    """``(RES, RES)`` float64 radiance of the white floor under a glowing polygon ``corners`` ``(k, 3)`` facing it,
    wholly above each floor point's horizon: E / pi by Lambert's closed form, averaged over each pixel."""
    p = patch_points().reshape(-1, 3)
    e = np.array([polygon_irradiance(point, (0.0, 0.0, 1.0), corners, RADIANCE) for point in p])
    return (e / np.pi).reshape(RES, SUB, RES, SUB).mean(axis=(1, 3))


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("kind", ["plane", "disk"])
def test_a_glowing_panel_just_over_the_floor_lights_it_smoothly_as_lamberts_formula_gives(kind, integrator):
    """A plane 1.6 wide and a disk of radius 0.8, 0.02 over the floor patch, facing it: drawn in their ellipsoid's
    cone, as noisy there as by area (a relative noise per draw of 20 to 30), whitted's mean of the patch over 8
    renders at 32 spp had a standard error of 1.1 (of 3.0); drawn by solid angle as a rect or disk light is, 5e-4.
    Path's BSDF draws lit the patch smoothly before; its MIS weights read the pdf back at each hit as drawn."""
    to_world = placed(rotation(180, 30) * 0.8, (0.05, -0.03, 0.02))
    if kind == "plane":
        unit = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    else:
        phi = np.arange(256) * (2.0 * np.pi / 256)
        unit = np.stack([np.cos(phi), np.sin(phi)], axis=1)
    corners = [to_world[:3, 3] + a * to_world[:3, 0] + b * to_world[:3, 1] for a, b in unit]
    shape = wrt.Shape("/Panel", kind, to_world, material_id=1)
    assert_within_standard_errors([shape], panel_radiance(corners), integrator, seeds=8, spp=32)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_glowing_box_lights_the_floor_as_quadrature_gives(integrator):
    """A turned glowing box low over the floor (the floor partly inside its ellipsoid, so drawn both ways)."""
    shape = wrt.Shape("/Box", "box", BOX, material_id=1)
    assert_within_standard_errors([shape], floor_radiance(box_surface(BOX)), integrator)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_glowing_ellipsoid_lights_the_floor_as_quadrature_gives(integrator):
    """A sphere scaled unevenly and turned: an ellipsoid, drawn in its own cone."""
    shape = wrt.Shape("/Ellipsoid", "sphere", ELLIPSOID, material_id=1)
    assert_within_standard_errors([shape], floor_radiance(ellipsoid_surface(ELLIPSOID)), integrator)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_instanced_glowing_boxes_light_the_floor_as_quadrature_gives(integrator):
    """A prototype of a glowing unit box and a glowing sphere inside it, in two instances: one places the box as
    BOX (its sphere, an ellipsoid there, hidden inside it), the other under the floor. Each instance's rows find
    their own maps (two hull rows each), and the floor shows the one box's light."""
    proto = wrt.Prototype("/Lamp", shapes=[wrt.Shape("/Lamp/Ball", "sphere", np.eye(4) * [0.5, 0.5, 0.5, 1.0],
                                                     material_id=1),
                                           wrt.Shape("/Lamp/Box", "box", np.eye(4), material_id=1)])
    below = placed(np.eye(3), (0.0, 0.0, -5.0))
    instances = wrt.Instances.from_transforms([0, 0], np.stack([BOX, below]))
    assert_within_standard_errors([], floor_radiance(box_surface(BOX)), integrator, prototypes=[proto],
                                  instances=instances)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_vast_turned_glowing_disk_lights_the_floor_as_an_endless_plane(integrator):
    """A double-sided disk of radius 1e5, turned and stretched to an ellipse by its instance, about 0.65 over the
    patch: the floor sees an endless plane, L (1 + |n_z|) / 2. The solid-angle draw measured the plane's height from
    the corner of the square around it, rounded at its size (ulp 0.03): the points drawn lay off the plane, and where
    past it the disk's own surface shadowed them (whitted 2.55 +- 0.02, path 2.72 +- 0.01 of 2.877)."""
    turn = rotation(30, 40)
    proto = wrt.Prototype("/Lamp", shapes=[wrt.Shape("/Lamp/Glow", "disk", placed(turn * 1e5, (0.0, 0.0, 0.0)),
                                                     material_id=1, double_sided=True)])
    stretch = np.diag([1.0, 2.0, 1.0])
    instances = wrt.Instances.from_transforms([0], placed(stretch, (0.0, 0.0, 1.0))[None])
    normal = np.linalg.inv(stretch @ turn).T[:, 2]
    expected = RADIANCE * (1.0 + abs(normal[2]) / np.linalg.norm(normal)) / 2.0
    assert_within_standard_errors([], np.full((RES, RES), expected), integrator, seeds=6, spp=32, prototypes=[proto],
                                  instances=instances)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_floor_inside_an_inward_glowing_sphere_shows_its_radiance(integrator):
    """A sphere glowing inwards (leftHanded) around the floor patch: every direction above the floor sees radiance
    L, so the white floor shows L (E = pi L); whitted showed it black (the sphere was not sampled). Drawn from
    inside the hull's ellipsoid, over every direction."""
    inward = wrt.Shape("/Sky", "sphere", placed(np.eye(3) * 3.0, (0.0, 0.0, 0.0)), material_id=1,
                       params=np.array([0.0, 0.0, 0.0, -1.0]))
    assert_within_standard_errors([inward], np.full((RES, RES), RADIANCE), integrator, seeds=8, spp=64)


def test_whitted_lights_the_floor_under_a_glowing_box():
    """Whitted drew the floor under a glowing box black (the box lit nothing, with a warning)."""
    rendered, messages = render_patch([wrt.Shape("/Box", "box", BOX, material_id=1)], "whitted", 16, 0)
    assert not [m for m in messages if UNSAMPLED in m], messages
    assert rendered.min() > 0.0
    assert abs(rendered.mean() / floor_radiance(box_surface(BOX)).mean() - 1.0) < 0.3


def test_the_unsampled_warning_names_no_box_ellipsoid_plane_squeezed_or_inward_shape():
    """Every glowing shape below is sampled now: the warning that counted them (whitted showed them, lighting
    nothing) is not given."""
    down = placed(rotation(180, 0) * 0.3, (0.0, 0.0, 1.5))  # a plane facing the floor
    squeezed = placed(np.diag([0.3, 0.1, 0.4]), (0.5, 0.0, 1.0))  # an elliptic capped cylinder
    inward = wrt.Shape("/Inward", "sphere", placed(np.eye(3) * 0.2, (-0.5, 0.0, 1.0)), material_id=1,
                       params=np.array([0.0, 0.0, 0.0, -1.0]))
    shapes = [wrt.Shape("/Box", "box", BOX, material_id=1), wrt.Shape("/Ellipsoid", "sphere", ELLIPSOID, material_id=1),
              wrt.Shape("/Plane", "plane", down, material_id=1), wrt.Shape("/Disk", "disk", down, material_id=1),
              wrt.Shape("/Tube", "cylinder", squeezed, material_id=1), inward]
    rendered, messages = render_patch(shapes, "whitted", 4, 0)
    assert not [m for m in messages if UNSAMPLED in m], messages
    assert rendered.min() > 0.0


@pytest.mark.parametrize("scale", [1e-20, 1e30])
def test_a_glowing_box_scaled_far_from_one_lights_the_floor_as_the_unscaled_one(scale):
    """The scene (floor, box, camera) scaled by 1e-20 or 1e30 renders as the unscaled one: the light's lengths are
    taken times a power of two near the box's size. The world normal at a box 1e-19 wide, A^T n, squared past
    float32 when normalised, and whitted lit nothing."""
    floor, materials = floor_and_materials()
    images = []
    for s in (1.0, scale):
        scaled = wrt.Mesh("/Floor", floor.points * np.float32(s), floor.indices, np.array([0, 0]),
                          material_ids=np.zeros(2, np.int32))
        to_world = BOX.copy()
        to_world[:3, :] *= s
        scene = wrt.Scene(meshes=[scaled], shapes=[wrt.Shape("/Box", "box", to_world, material_id=1)],
                          materials=materials)
        cam = wrt.Camera.orthographic(eye=(0, 0, 0.05 * s), target=(0, 0, 0), up=(0, 1, 0), height=PATCH * s,
                                      clipping_range=(0.01 * s, 1e6 * s))
        images.append(wrt.render(scene, camera=cam, width=RES, height=RES, spp=16, seed=2, integrator="whitted").rgb)
    assert images[0].min() > 0.0
    np.testing.assert_allclose(images[1], images[0], rtol=1e-3)


def test_hull_selection_weights_are_the_shapes_areas():
    """A hull's selection weight is pi times its world area times its glow: a turned box's exactly (its faces'
    parallelograms in float64), an ellipsoid's within the 16-segment tessellation's 4% (quadrature of its surface),
    a sheared plane's exactly, for world shapes and for the rows of instances alike."""
    from wrt.glowing_spheres import glowing_spheres

    floor, materials = floor_and_materials()
    sheared = placed(np.array([[1.0, 0.5, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]), (0.0, 0.0, 3.0))
    shapes = [wrt.Shape("/Box", "box", BOX, material_id=1), wrt.Shape("/Ellipsoid", "sphere", ELLIPSOID, material_id=1),
              wrt.Shape("/Plane", "plane", sheared, material_id=1)]
    proto = wrt.Prototype("/Lamp", shapes=[wrt.Shape("/Lamp/Box", "box", np.eye(4), material_id=1)])
    scene = wrt.Scene(meshes=[floor], shapes=shapes, materials=materials, prototypes=[proto],
                      instances=wrt.Instances.from_transforms([0], BOX[None]))
    rows = glowing_spheres(scene, np.array([0.0, 0.0, 1.0]), 10)
    box = sum(2.0 * 4.0 * np.linalg.norm(np.cross(BOX[:3, i], BOX[:3, (i + 1) % 3])) for i in range(3))
    ellipsoid = ellipsoid_surface(ELLIPSOID)[2].sum()
    plane = 4.0 * np.linalg.norm(np.cross(sheared[:3, 0], sheared[:3, 1]))
    areas = rows.power / np.pi
    assert len(areas) == 4 and rows.left_out == 0
    np.testing.assert_allclose(areas[[0, 2, 3]], [box, plane, box], rtol=1e-9)
    assert abs(areas[1] / ellipsoid - 1.0) < 0.04, (areas[1], ellipsoid)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("half_height", [0.1, 0.3])
def test_a_glowing_box_resting_on_the_floor_lights_it_as_quadrature_gives(integrator, half_height):
    """A turned box standing on the floor beside the patch (its bottom face in the floor's plane). Rounding put the
    floor's points just below the bottom face's plane, where its area draw counted that face (seen edge-on) as
    facing them, and the offset origin of path's BSDF rays just above it, where the read-back did not: the MIS
    weights of the two pdfs did not sum to 1, and path showed the floor 5% (half height 0.3) to 13% (0.1) dark."""
    to_world = placed(rotation(0, 30) @ np.diag([0.4, 0.3, half_height]), (1.05, 0.1, half_height))
    shape = wrt.Shape("/Box", "box", to_world, material_id=1)
    assert_within_standard_errors([shape], floor_radiance(box_surface(to_world)), integrator, seeds=16)


@pytest.mark.parametrize("integrator, expected", [("whitted", 1.5), ("path", 2.0)])
def test_the_inside_of_an_inward_glowing_grey_sphere_shows_its_own_light(integrator, expected):
    """Inside a sphere that glows inwards (radiance 1) and reflects half (albedo 0.5), every direction from its wall
    sees radiance 1: whitted (direct light only) shows the wall 1 + 0.5 and path 1 / (1 - 0.5) = 2. The draws from
    a point on the wall met the wall itself at distance 0 (the back of its inward face: nothing drawn), and where
    rounding put the point just outside the ellipsoid its cone of draws (a hemisphere) was not the one read back at
    path's ray origin, moved inside (every direction): whitted showed 1.27, path 1.92."""
    material = wrt.Material("/Grey", diffuse_color=(0.5, 0.5, 0.5), emissive_color=(1.0, 1.0, 1.0), ior=1.0,
                            specular_edge=0.0)
    far = wrt.Mesh("/Far", np.array([(-1, -1, -50), (1, -1, -50), (1, 1, -50)], np.float32), np.array([[0, 1, 2]]),
                   np.array([0]), material_ids=np.zeros(1, np.int32))
    sphere = wrt.Shape("/Sky", "sphere", placed(np.eye(3) * 3.0, (0.0, 0.0, 0.0)), material_id=0,
                       params=np.array([0.0, 0.0, 0.0, -1.0]))
    scene = wrt.Scene(meshes=[far], shapes=[sphere], materials=[material])
    cam = wrt.Camera.look_at((0, 0, 0), (1, 0.3, 0.2), up=(0, 0, 1), fov_y_deg=60)
    means = [wrt.render(scene, camera=cam, width=8, height=8, spp=64, seed=seed, integrator=integrator,
                        max_depth=40).rgb.mean() for seed in range(8)]
    error = np.std(means, ddof=1) / np.sqrt(len(means))
    assert abs(np.mean(means) - expected) < 4.0 * error + 1e-3 * expected, (np.mean(means), error)
