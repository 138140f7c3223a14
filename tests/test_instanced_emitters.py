"""Emissive triangles inside instances are sampled as lights, each instance's copy in world space: a glowing quad
under rotations, non-uniform scales and mirrors lights a plane as Lambert's formula over its world-space triangles
says, and as the same triangles flattened into world space do, under ``whitted`` and ``path`` (whose MIS weights need
the pdf of the entry a ray hits to be the one it was sampled with). Past the cap on instanced emitter entries the rest
are named in a warning."""

import warnings

import numpy as np
from light_oracle import trs
from shading_helpers import pixel_points, quad

import wrt
from wrt import light_table
from wrt.instancing import expand_instance_triangles

RADIANCE = 4.0  # of the glowing material
RES = 8  # pixels per side of the floor patch checked
PATCH = 1.2  # side of that patch, centred under the lamps
ALBEDO = 0.5  # the default material's grey: radiance = ALBEDO * E / pi
UNSAMPLED = "not sampled as lights"  # what render.py's warning about emitters whitted cannot sample says

# Instance transforms of a quad whose front is prototype +Z, all at height 1 (coplanar and apart, so none shadows
# another from the floor): turned over to face the floor; turned and scaled unevenly; mirrored by a negative z scale
# (its front, carried by the inverse transpose, faces the floor); mirrored by a negative x scale, above the others
# (its front still faces up, away from the floor: it lights nothing there).
TRANSFORMS = [
    trs((0.3, -0.2, 1.0), (180, 0, 0)),
    trs((-0.4, 0.1, 1.0), (180, 0, 30), (2.0, 0.5, 1.0)),
    trs((0.3, 0.3, 1.0), (0, 0, 20), (1.0, 1.0, -1.0)),
    trs((0.0, 0.0, 1.5), (0, 0, 0), (-1.0, 1.0, 1.0)),
]


def lambert_irradiance(points, corners, radiance):
    """Irradiance at ``points`` ``(P, 3)`` of the plane z = 0 (normal +Z) from single-sided triangles ``corners``
    ``(T, 3, 3)`` (float64, world space, wound so that their front is ``cross(b - a, c - a)``) of ``radiance``: only
    those whose front faces the plane, above it, count. Lambert's formula: the sum over each triangle's edges of the
    angle they subtend times the z of their unit plane normal."""
    front = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    corners = corners[front[:, 2] < 0.0]
    total = np.zeros(len(points))
    for k, p in enumerate(points):
        u = corners - p
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        w = np.roll(u, -1, axis=1)
        angle = np.arccos(np.clip(np.sum(u * w, -1), -1.0, 1.0))
        normal = np.cross(u, w)
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        total[k] = radiance / 2.0 * np.abs(np.sum(angle * normal[..., 2], axis=1)).sum()
    return total


def world_corners(prototype_mesh, transforms):
    """``(N T, 3, 3)`` float64 world corners of ``prototype_mesh``'s triangles in each of ``transforms``, wound so
    that their front is the inverse transpose's image of the prototype's (corners 1 and 2 swapped where the
    transform mirrors)."""
    local = np.asarray(prototype_mesh.points, np.float64)[np.asarray(prototype_mesh.indices)]
    out = []
    for m in transforms:
        moved = local @ m[:3, :3].T + m[:3, 3]
        out.append(moved[:, [0, 2, 1]] if np.linalg.det(m[:3, :3]) < 0 else moved)
    return np.concatenate(out)


def lamp_scene(transforms, size=(0.4, 0.3)):
    """The floor and a single-sided glowing quad prototype (front +Z) drawn by ``transforms``, and the same
    triangles flattened into one world-space mesh."""
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor")
    lamp = quad((0, 0, 0), (size[0], 0, 0), (0, size[1], 0), name="/P/lamp", material=0, double_sided=False)
    prototype = wrt.Prototype("/P", [lamp])
    instances = wrt.Instances.from_transforms(np.zeros(len(transforms)), np.array(transforms))
    glowing = wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE)
    scene = wrt.Scene(meshes=[floor], prototypes=[prototype], instances=instances, materials=[glowing])
    points, indices = expand_instance_triangles([prototype], instances)
    flat_lamps = wrt.Mesh("/lamps", points, indices, np.arange(len(indices)), double_sided=False,
                          material_ids=np.zeros(len(indices), np.int32))
    flat = wrt.Scene(meshes=[floor, flat_lamps], materials=[glowing])
    return scene, flat, lamp


def render_floor(scene, integrator, spp, eye_height=0.5, seed=3):
    """Radiance ``(RES, RES)`` of the floor patch, seen from below the lamps (an orthographic camera looking down),
    direct light only, and the render's warnings."""
    cam = wrt.Camera.orthographic(eye=(0, 0, eye_height), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=spp, seed=seed, integrator=integrator,
                         max_depth=1)
    return img.rgb.mean(axis=-1), [str(w.message) for w in caught]


def expected_floor(corners):
    """ALBEDO * E / pi at the pixel centres of :func:`render_floor`."""
    points = pixel_points((0.0, 0.0, 0.0), PATCH, RES, RES).reshape(-1, 3)
    return (ALBEDO * lambert_irradiance(points, corners, RADIANCE) / np.pi).reshape(RES, RES)


def test_instanced_glowing_quads_light_the_floor_under_whitted_as_lamberts_formula_says():
    """Four instances of a small glowing quad (turned over; turned and scaled unevenly; mirrored by z -> -z, its
    front now facing the floor; mirrored by x -> -x, its front still up) light the floor as Lambert's formula over
    the three that face it says, and as the same triangles flattened into the world do. Before, whitted sampled no
    instanced emitter: the floor was black, with a warning."""
    scene, flat, lamp = lamp_scene(TRANSFORMS)
    expected = expected_floor(world_corners(lamp, TRANSFORMS))
    rendered, messages = render_floor(scene, "whitted", spp=512)
    assert not [m for m in messages if UNSAMPLED in m], messages
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.1, rendered / expected
    flattened, _ = render_floor(flat, "whitted", spp=512)
    assert abs(rendered.mean() / flattened.mean() - 1) < 0.02, (rendered.mean(), flattened.mean())


def test_a_mirrored_instance_emits_from_the_side_its_front_faces():
    """A single-sided glowing quad mirrored by x -> -x keeps its front up: the floor under it gets nothing, as its
    flattened copy (corners 1 and 2 swapped) gives nothing; mirrored by z -> -z its front faces the floor."""
    up = [trs((0.0, 0.0, 1.0), (0, 0, 0), (-1.0, 1.0, 1.0))]
    down = [trs((0.0, 0.0, 1.0), (0, 0, 0), (1.0, 1.0, -1.0))]
    for transforms, lit in ((up, False), (down, True)):
        scene, flat, lamp = lamp_scene(transforms)
        rendered, _ = render_floor(scene, "whitted", spp=64)
        flattened, _ = render_floor(flat, "whitted", spp=64)
        expected = expected_floor(world_corners(lamp, transforms))
        assert (expected.mean() > 0.01) == lit
        np.testing.assert_allclose(rendered.mean(), expected.mean(), rtol=0.03, atol=1e-6)
        np.testing.assert_allclose(rendered.mean(), flattened.mean(), rtol=0.03, atol=1e-6)


def test_path_samples_instanced_emitters_and_weighs_their_hits_by_the_pdf_they_were_sampled_with():
    """Path tracing direct light from large quads close to the floor (scaled 1 x 1.5 and 1.2 x 0.8 in the world,
    one mirrored; coplanar and apart), where BSDF-sampled rays hit them often, so that a hit weighed by a pdf other
    than that of the entry it was sampled with (the prototype's area, another instance's) would bias the sum of the
    MIS weights: it agrees with Lambert's formula and with the flattened triangles (with the prototype's area in
    the pdf of a hit, 40% too bright). The small quads' pixels at 256 samples are within 10% (RMS) of the formula;
    before, no instanced emitter was sampled and path found them by BSDF rays alone, about twice as noisy."""
    transforms = [trs((-0.75, 0.0, 0.4), (180, 0, 10), (1.0, 1.5, 1.0)),
                  trs((0.75, 0.1, 0.4), (0, 0, -20), (1.2, 0.8, -1.0))]
    scene, flat, lamp = lamp_scene(transforms, size=(1.0, 1.0))
    expected = expected_floor(world_corners(lamp, transforms))
    rendered, _ = render_floor(scene, "path", spp=1024, eye_height=0.2)
    assert abs(rendered.mean() / expected.mean() - 1) < 0.01, (rendered.mean(), expected.mean())
    flattened, _ = render_floor(flat, "path", spp=1024, eye_height=0.2)
    assert abs(rendered.mean() / flattened.mean() - 1) < 0.01, (rendered.mean(), flattened.mean())
    small, _, small_lamp = lamp_scene(TRANSFORMS)
    quick, _ = render_floor(small, "path", spp=256)
    error = quick / expected_floor(world_corners(small_lamp, TRANSFORMS)) - 1
    assert np.sqrt(np.mean(error**2)) < 0.1, error  # by BSDF rays alone: about 0.2


def test_instanced_emitters_past_the_cap_are_named_and_light_nothing_under_whitted(monkeypatch):
    """With the cap on instanced emitter entries at one quad's two triangles, the first instance is sampled and the
    three others are left as before: whitted lights with the first alone and names the six triangles left."""
    monkeypatch.setattr(light_table, "MAX_INSTANCED_EMITTERS", 2)
    scene, _, lamp = lamp_scene(TRANSFORMS)
    rendered, messages = render_floor(scene, "whitted", spp=256)
    named = [m for m in messages if UNSAMPLED in m]
    assert len(named) == 1 and "6 emissive triangle(s) of instances past the first 2 " in named[0], messages
    expected = expected_floor(world_corners(lamp, TRANSFORMS[:1]))
    assert abs(rendered.mean() / expected.mean() - 1) < 0.03, (rendered.mean(), expected.mean())
