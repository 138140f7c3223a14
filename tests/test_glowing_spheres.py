"""Glowing analytic spheres are sampled as lights (wrt.glowing_spheres): a ``wrt.Shape`` sphere of a scene built in
Python and the spheres of a ``Points`` prim bound to an emissive material light a white floor as the closed form of a
uniform spherical emitter says, under whitted (they lit nothing before) and path (MIS against BSDF-sampled hits, no
light counted twice); instanced spheres past the cap on light-table entries are named in a warning."""

import warnings

import numpy as np
import pytest

import wrt
from wrt import light_table
from wrt.glowing_spheres import GlowingSpheres

RADIANCE = 3.0  # of every glowing sphere
RES = 4  # pixels per side of the floor patch seen
PATCH = 1.0  # side of the patch, centred under the spheres
UNSAMPLED = "not sampled as lights"  # what render.py's warning about emitters it does not sample says


def floor_mesh():
    """A 40 x 40 floor at z = 0 facing up, of material 0 (white, Lambertian albedo 1)."""
    points = np.array([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)], np.float32)
    return wrt.Mesh("/Floor", points, np.array([[0, 1, 2], [0, 2, 3]]), np.array([0, 0]),
                    material_ids=np.zeros(2, np.int32))


def materials():
    """``[white floor, glow]``, neither with a specular lobe (F0 0 at ``ior`` 1, F90 0): the floor Lambertian of
    albedo 1, the glow emitting RADIANCE and reflecting nothing."""
    bare = dict(ior=1.0, specular_edge=0.0)
    return [wrt.Material("/White", diffuse_color=(1.0, 1.0, 1.0), **bare),
            wrt.Material("/Glow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(RADIANCE,) * 3, **bare)]


def sphere_shape(centre, radius):
    to_world = np.diag([radius, radius, radius, 1.0])
    to_world[:3, 3] = centre
    return wrt.Shape("/Lamp", "sphere", to_world, material_id=1)


def render_floor(scene, integrator, spp, seed=3):
    """``(RES, RES)`` radiance of the floor patch seen from below the spheres (an orthographic camera at z = 0.05
    looking down, image up along +Y) and the warnings the render gave."""
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.05), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=spp, seed=seed, integrator=integrator)
    return img.rgb.mean(axis=-1).astype(np.float64), [str(w.message) for w in caught]


def closed_form(spheres, sub=32):
    """``(RES, RES)`` float64 floor radiance under ``spheres`` (``(centre, radius)``, each wholly above the floor and
    none shadowing another): a uniform spherical emitter of radiance L gives E = pi L (r / d)^2 cos(theta), and the
    white floor shows E / pi, averaged over each pixel's square by ``sub`` x ``sub`` midpoints (row 0 at +Y)."""
    xs = ((np.arange(RES * sub) + 0.5) / (RES * sub) - 0.5) * PATCH
    gx, gy = np.meshgrid(xs, -xs)
    p = np.stack([gx, gy, np.zeros_like(gx)], axis=-1)
    total = np.zeros_like(gx)
    for centre, r in spheres:
        d = np.linalg.norm(p - np.asarray(centre, np.float64), axis=-1)
        total += RADIANCE * (r / d) ** 2 * (centre[2] / d)
    return total.reshape(RES, sub, RES, sub).mean(axis=(1, 3))


def no_glowing_spheres(scene, glow, cap, shape_glow=None):
    """A stand-in for :func:`wrt.glowing_spheres.glowing_spheres` that samples none: path then finds glowing spheres
    only by the rays that hit them, as before they were lights."""
    empty = np.zeros(0, np.int32)
    nowhere = np.full(len(scene.instances), -1, np.int32)
    return GlowingSpheres(empty, empty, np.zeros((0, 4)), np.zeros(0), nowhere, empty)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_glowing_shape_sphere_lights_the_floor_as_the_closed_form(integrator):
    """A ``wrt.Shape`` sphere of radius r glowing with L at height h: the floor shows L r^2 cos / d^2 under both
    integrators; whitted drew the floor black (the sphere lit nothing, with a warning), and a shadow ray the sphere
    blocked itself would darken it."""
    centre, r = (0.1, -0.05, 1.0), 0.3
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere_shape(centre, r)], materials=materials())
    rendered, messages = render_floor(scene, integrator, spp=256)
    assert not [m for m in messages if UNSAMPLED in m], messages
    expected = closed_form([(centre, r)])
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.06, rendered / expected


def test_path_agrees_with_and_without_sampling_the_glowing_sphere(monkeypatch):
    """MIS consistency: path with the sphere sampled as a light (its BSDF-sampled hits weighted against the light's
    pdf) and path finding it only by the rays that hit it (the table left without it) converge to the same floor,
    the closed form: a hit counted twice, or weighted against another pdf, would not."""
    centre, r = (0.0, 0.0, 1.0), 0.5
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere_shape(centre, r)], materials=materials())
    sampled, _ = render_floor(scene, "path", spp=512)

    monkeypatch.setattr(light_table, "glowing_spheres", no_glowing_spheres)
    hit_only, _ = render_floor(scene, "path", spp=1024)
    expected = closed_form([(centre, r)])
    assert abs(sampled.mean() / hit_only.mean() - 1) < 0.03, (sampled.mean(), hit_only.mean())
    assert abs(sampled.mean() / expected.mean() - 1) < 0.02, (sampled.mean(), expected.mean())
    assert abs(hit_only.mean() / expected.mean() - 1) < 0.04, (hit_only.mean(), expected.mean())


SPARKS = [((-0.6, 0.1, 1.0), 0.12), ((0.0, -0.1, 0.9), 0.2), ((0.7, 0.2, 1.1), 0.15)]


# A Z-up stage's material /Glow, glowing with RADIANCE, and a white floor 40 across at z = 0.
GLOW_AND_FLOOR = (
    '#usda 1.0\n(\n    upAxis = "Z"\n)\n'
    'def Material "Glow"\n{\n    token outputs:surface.connect = </Glow/Surface.outputs:surface>\n'
    '    def Shader "Surface"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
    f"        color3f inputs:emissiveColor = ({RADIANCE}, {RADIANCE}, {RADIANCE})\n"
    "        color3f inputs:diffuseColor = (0, 0, 0)\n        token outputs:surface\n    }\n}\n"
    'def Mesh "Floor"\n{\n    point3f[] points = [(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)]\n'
    "    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n"
    "    color3f[] primvars:displayColor = [(1, 1, 1)]\n}\n"
)


def points_stage(tmp_path):
    """A Z-up stage: the white floor and a Points prim of the SPARKS (widths twice their radii) bound to a material
    glowing with RADIANCE."""
    points = ", ".join(f"({x}, {y}, {z})" for (x, y, z), _ in SPARKS)
    widths = ", ".join(str(2 * r) for _, r in SPARKS)
    path = tmp_path / "sparks.usda"
    path.write_text(
        GLOW_AND_FLOOR +
        'def Points "Sparks" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{\n'
        f"    point3f[] points = [{points}]\n    float[] widths = [{widths}]\n"
        "    rel material:binding = </Glow>\n}\n")
    return wrt.load_usd(str(path))


def test_glowing_points_light_the_floor_under_whitted(tmp_path):
    """The spheres of a ``Points`` prim bound to a glowing material (instances of one sphere) light the floor under
    whitted as the sum of their closed forms; they lit nothing before, and the render said so."""
    scene = points_stage(tmp_path)
    assert len(scene.instances) == len(SPARKS) and not scene.shapes
    rendered, messages = render_floor(scene, "whitted", spp=1024)  # one of the three drawn per sample
    assert not [m for m in messages if UNSAMPLED in m], messages
    expected = closed_form(SPARKS)
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.06, rendered / expected


def test_glowing_points_past_the_cap_are_named_and_the_rest_still_light(tmp_path, monkeypatch):
    """With room for one instanced entry, the first spark is sampled and the other two are named in the warning
    (under path too): whitted lights the floor with the first alone."""
    monkeypatch.setattr(light_table, "MAX_INSTANCED_EMITTERS", 1)
    scene = points_stage(tmp_path)
    rendered, messages = render_floor(scene, "whitted", spp=256)
    named = [m for m in messages if UNSAMPLED in m]
    past = "2 glowing sphere(s), tube(s) or other shape(s) of instances past the first 1"
    assert len(named) == 1 and past in named[0], messages
    expected = closed_form(SPARKS[:1])
    assert abs(rendered.mean() / expected.mean() - 1) < 0.03, (rendered.mean(), expected.mean())
    _, messages = render_floor(scene, "path", spp=1)
    assert [m for m in messages if "2 glowing sphere(s)" in m], messages


def test_an_unevenly_scaled_glowing_sphere_is_sampled_as_an_ellipsoid():
    """A sphere scaled into an ellipsoid is sampled (wrt.glowing_hulls; whitted named it and it lit nothing): whitted
    names nothing and lights the floor (tests/test_glowing_hulls.py checks the light it sends)."""
    shape = sphere_shape((0.0, 0.0, 1.0), 0.3)
    shape.to_world = np.diag([0.3, 0.2, 0.3, 1.0]) + np.pad(np.array([[0.0], [0.0], [1.0]]), ((0, 1), (3, 0)))
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=materials())
    rendered, messages = render_floor(scene, "whitted", spp=4)
    assert not [m for m in messages if "emissive analytic primitive" in m], messages
    assert rendered.min() > 0.0


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_camera_sees_a_sampled_glowing_sphere_once(integrator):
    """A camera looking straight at the sampled sphere sees its radiance L, not 2 L: the entry of the light table
    adds no second emission to the surface's own (no analytic light is met along the ray besides the shape)."""
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere_shape((0.0, 0.0, 1.0), 0.3)], materials=materials())
    cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 1), up=(0, 1, 0), height=0.2)
    img = wrt.render(scene, camera=cam, width=2, height=2, spp=4, seed=3, integrator=integrator, max_depth=1)
    np.testing.assert_allclose(img.rgb, RADIANCE, rtol=1e-5)


def test_a_glowing_curve_under_path_agrees_with_and_without_its_joint_spheres_sampled(tmp_path, monkeypatch):
    """A glowing linear curve is tubes joined by spheres, all sampled (wrt.glowing_tubes samples the tubes), the
    spheres half hidden in the tubes (shadow rays to their hidden half stop at a tube). Path converges to the same
    floor as path finding the whole curve by the rays that hit it: MIS stays unbiased where sampled emitters cover
    each other. Whitted names nothing unsampled."""
    path = tmp_path / "wire.usda"
    path.write_text(
        GLOW_AND_FLOOR +
        'def BasisCurves "Wire" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{\n'
        '    uniform token type = "linear"\n    int[] curveVertexCounts = [4]\n'
        "    point3f[] points = [(-0.6, 0, 1), (-0.2, 0.1, 0.9), (0.2, -0.1, 1.0), (0.6, 0, 1.1)]\n"
        '    float[] widths = [0.3] (\n        interpolation = "constant"\n    )\n'
        "    rel material:binding = </Glow>\n}\n")
    scene = wrt.load_usd(str(path))
    assert sorted({s.kind for p in scene.prototypes for s in p.shapes}) == ["cylinder", "sphere"]
    _, messages = render_floor(scene, "whitted", spp=1)
    assert not [m for m in messages if UNSAMPLED in m], messages
    sampled, _ = render_floor(scene, "path", spp=2048)

    monkeypatch.setattr(light_table, "glowing_spheres", no_glowing_spheres)
    hit_only, _ = render_floor(scene, "path", spp=4096)
    assert abs(sampled.mean() / hit_only.mean() - 1) < 0.03, (sampled.mean(), hit_only.mean())


def test_a_kept_renderer_follows_a_glowing_sphere_that_moved():
    """A simulation step: the glowing sphere of a kept Renderer moves (its Shape replaced); the light table is built
    again with the scene, so whitted lights the floor from the sphere's new place, not the old."""
    old, new, r = (-0.3, 0.0, 1.0), (0.3, 0.2, 0.8), 0.2
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere_shape(old, r)], materials=materials())
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.05), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    renderer = wrt.Renderer(scene, camera=cam, width=RES, height=RES, integrator="whitted")
    before = renderer.render(spp=256, seed=3).rgb.mean(axis=-1)
    scene.shapes[0] = sphere_shape(new, r)
    after = renderer.render(spp=256, seed=3).rgb.mean(axis=-1)
    for rendered, centre in ((before, old), (after, new)):
        expected = closed_form([(centre, r)])
        assert np.abs(rendered / expected - 1).max() < 0.06, rendered / expected
