"""Gprims bound to a material that emits (UsdPreviewSurface ``emissiveColor``, constant or textured, or a MaterialX
``emission``): drawn as their tessellation, inside instances too, so ``whitted`` samples their triangles as lights. A
Sphere lights a white plane as the closed form for a sphere says, a Cube as the one for its bottom face; gprims that
do not emit stay analytic."""

import warnings

import numpy as np
import pytest
from light_oracle import polygon_irradiance
from PIL import Image as PilImage
from pxr import UsdGeom
from test_lights import rect_irradiance

import wrt

HEIGHT = 1.0  # of the emitter's centre above the plane z = 0
RADIANCE = 3.0  # of the emitter
RES = 4  # pixels per side of the patch checked: a handful, many samples each
UNSAMPLED = "not sampled as lights"  # what render.py's warning about emitters whitted cannot sample says


def white_plane():
    """USDA of a large plane z = 0 facing up, the default material of ``displayColor`` white (Lambertian albedo 1)."""
    return ('def Mesh "Floor"\n{\n    point3f[] points = [(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)]\n'
            "    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n"
            "    color3f[] primvars:displayColor = [(1, 1, 1)]\n}\n")


def glow(kind):
    """USDA of material ``/Glow`` emitting RADIANCE: a constant ``emissiveColor``, one read from a white texture
    times its ``scale``, or a MaterialX standard_surface's ``emission_color`` times ``emission``; ``dark_texture``:
    the texture with ``scale`` 0 (nothing emitted); ``diffuse``: a material that does not emit."""
    surface, image = "", ""
    if kind == "constant":
        surface = f"        color3f inputs:emissiveColor = ({RADIANCE}, {RADIANCE}, {RADIANCE})\n"
    elif kind == "diffuse":
        surface = "        color3f inputs:diffuseColor = (0.2, 0.4, 0.6)\n"
    elif kind in ("texture", "dark_texture"):
        scale = RADIANCE if kind == "texture" else 0.0
        surface = "        color3f inputs:emissiveColor.connect = </Glow/Image.outputs:rgb>\n"
        image = ('    def Shader "Image"\n    {\n        uniform token info:id = "UsdUVTexture"\n'
                 "        asset inputs:file = @white.png@\n"
                 f"        float4 inputs:scale = ({scale}, {scale}, {scale}, 1)\n"
                 "        float3 outputs:rgb\n    }\n")
    if kind == "materialx":
        return ('def Material "Glow"\n{\n    token outputs:mtlx:surface.connect = </Glow/Surface.outputs:out>\n'
                '    def Shader "Surface"\n    {\n        uniform token info:id = "ND_standard_surface_surfaceshader"\n'
                f"        float inputs:emission = 1\n        color3f inputs:emission_color = ({RADIANCE}, {RADIANCE}, "
                f"{RADIANCE})\n        token outputs:out\n    }}\n}}\n")
    return ('def Material "Glow"\n{\n    token outputs:surface.connect = </Glow/Surface.outputs:surface>\n'
            '    def Shader "Surface"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
            f"{surface}        token outputs:surface\n    }}\n{image}}}\n")


def gprim(kind, size, name="Lamp", bound=True):
    """USDA of a ``kind`` gprim (``size``: a Sphere's radius, a Cube's edge) centred at ``(0, 0, HEIGHT)``, bound to
    ``/Glow`` when ``bound``."""
    size_attr = f"double radius = {size}" if kind == "Sphere" else f"double size = {size}"
    bind = "    rel material:binding = </Glow>\n" if bound else ""
    return (f'def {kind} "{name}" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{{\n    {size_attr}\n'
            f"    double3 xformOp:translate = (0, 0, {HEIGHT})\n"
            '    uniform token[] xformOpOrder = ["xformOp:translate"]\n'
            f"{bind}}}\n")


def load(tmp_path, *prims):
    """``(scene, warning messages)`` of a Z-up stage of ``prims`` (beside a white 2 x 2 PNG, ``white.png``)."""
    PilImage.fromarray(np.full((2, 2, 3), 255, np.uint8)).save(tmp_path / "white.png")
    path = tmp_path / "stage.usda"
    path.write_text('#usda 1.0\n(\n    upAxis = "Z"\n)\n' + "".join(prims))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(path))
    return scene, [str(w.message) for w in caught]


def render_under(scene, patch, spp):
    """Whitted radiance ``(RES, RES)`` of the plane's ``patch`` x ``patch`` square under the emitter (an orthographic
    camera at z = 0.5, below it, looking down), and the warnings the render gave."""
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=patch)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=spp, seed=7, integrator="whitted")
    return img.rgb.mean(axis=-1), [str(w.message) for w in caught]


def pixel_mean(radiance, patch, sub=16):
    """``(RES, RES)`` mean of ``radiance(points)`` (``points`` ``(..., 3)`` on z = 0) over each pixel's square of the
    centred ``patch`` x ``patch`` view, by ``sub`` x ``sub`` midpoints: a pixel averages its jittered samples (a box
    filter), which for the sphere's peaked falloff is 1% below its value at the pixel centre."""
    pitch = patch / RES
    centres = (np.arange(RES) + 0.5) * pitch - patch / 2
    offsets = ((np.arange(sub) + 0.5) / sub - 0.5) * pitch
    xs = (centres[:, None] + offsets[None]).reshape(-1)
    gx, gy = np.meshgrid(xs, xs)
    values = radiance(np.stack([gx, gy, np.zeros_like(gx)], axis=-1))
    return values.reshape(RES, sub, RES, sub).mean(axis=(1, 3))


@pytest.mark.parametrize("material", ["constant", "texture", "materialx"])
def test_an_emissive_sphere_lights_a_plane_as_the_closed_form(tmp_path, material):
    """A Sphere of radius r and radiance L bound to a glowing material, centred at height h over a white Lambertian
    plane: it subtends sin^2 = r^2 / d^2 from a plane point at distance d, so E = pi L r^2 cos / d^2 with
    cos = h / d, and the plane shows albedo E / pi. It was drawn analytically, lit nothing under whitted (the plane
    black) and was named in a warning."""
    r = 0.1
    scene, messages = load(tmp_path, white_plane(), glow(material), gprim("Sphere", r))
    assert [m.path for m in scene.meshes] == ["/Floor", "/Lamp"] and not scene.shapes and not messages, messages
    rendered, messages = render_under(scene, patch=1.0, spp=8192)
    assert not [m for m in messages if UNSAMPLED in m], messages
    # Albedo 1 times E / pi, d the distance to the sphere's centre.
    expected = pixel_mean(lambda p: RADIANCE * r**2 * HEIGHT / np.linalg.norm(p - (0, 0, HEIGHT), axis=-1)**3, 1.0)
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.07, rendered / expected


def test_an_emissive_cube_lights_a_plane_as_its_bottom_face(tmp_path):
    """A Cube of edge s glowing with radiance L, centred at height h: a plane point under its bottom face sees that
    face alone (a parallel square at height h - s/2; the sides face away), so E is the closed form for a parallel
    rectangle. It lit nothing under whitted before."""
    s = 0.4
    scene, _ = load(tmp_path, white_plane(), glow("constant"), gprim("Cube", s))
    assert [m.path for m in scene.meshes] == ["/Floor", "/Lamp"] and not scene.shapes
    rendered, messages = render_under(scene, patch=0.3, spp=8192)
    assert not [m for m in messages if UNSAMPLED in m], messages
    expected = pixel_mean(lambda p: rect_irradiance(p, s / 2, s / 2, HEIGHT - s / 2, RADIANCE) / np.pi, 0.3)
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.12, rendered / expected  # 1 sample in 6 on the bottom face


@pytest.mark.parametrize("kind", ["Cylinder", "Cone", "Capsule", "Plane", "Cylinder_1", "Capsule_1"])
def test_every_gprim_kind_bound_to_a_glow_is_drawn_as_triangles(tmp_path, kind):
    """The other gprim kinds (at their schema's fallback sizes) bound to a glowing material are meshes of emissive
    triangles too, with the tessellation's 64 segments around; they were analytic shapes."""
    if not hasattr(UsdGeom, kind):
        pytest.skip(f"this usd-core has no {kind}")
    bound = f'def {kind} "Lamp" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{{\n' \
            "    rel material:binding = </Glow>\n}\n"
    scene, messages = load(tmp_path, white_plane(), glow("constant"), bound)
    assert [m.path for m in scene.meshes] == ["/Floor", "/Lamp"] and not scene.shapes and not messages, messages
    lamp = scene.meshes[1]
    assert len(lamp.indices) >= 2 * 64 if kind != "Plane" else len(lamp.indices) == 2
    np.testing.assert_array_equal(lamp.material_ids, 0)


@pytest.mark.parametrize("material", ["diffuse", "dark_texture", None])
def test_gprims_that_do_not_emit_stay_analytic(tmp_path, material):
    """A Sphere and a Cube bound to a material that emits nothing (a diffuse one, or an emissive texture of scale
    0), or to none, stay analytic shapes."""
    prims = [white_plane(), gprim("Sphere", 0.1, "Ball", bound=material is not None),
             gprim("Cube", 0.4, "Box", bound=material is not None)]
    scene, _ = load(tmp_path, *prims, *([glow(material)] if material else []))
    assert [m.path for m in scene.meshes] == ["/Floor"]
    assert [(s.path, s.kind) for s in scene.shapes] == [("/Ball", "sphere"), ("/Box", "box")]


def test_an_instanced_emissive_sphere_is_drawn_as_its_tessellation_and_not_named(tmp_path):
    """Inside a native instance the emissive Sphere is drawn as its tessellation too (a prototype mesh), whose
    triangles whitted samples in each instance (tests/test_instanced_emitters.py checks the light): the render names
    nothing. It stayed an analytic prototype shape that whitted did not sample, named in the warning."""
    prototype = f'over "Protos"\n{{\n    def Xform "Lamps"\n    {{\n{gprim("Sphere", 0.1)}    }}\n}}\n'
    instance = 'def Xform "Lamps" (\n    instanceable = true\n    prepend references = </Protos/Lamps>\n)\n{\n}\n'
    scene, _ = load(tmp_path, white_plane(), glow("constant"), prototype, instance)
    assert [m.path for m in scene.meshes] == ["/Floor"] and not scene.shapes
    assert not [s for p in scene.prototypes for s in p.shapes]
    assert [len(m.indices) >= 2 * 64 for p in scene.prototypes for m in p.meshes] == [True]
    _, messages = render_under(scene, patch=1.0, spp=1)
    assert not [m for m in messages if UNSAMPLED in m], messages


def uv_sphere(radius, around, rings):
    """``(points, triangles)`` of a UV sphere centred at ``(0, 0, HEIGHT)``, wound so that its front faces out."""
    theta = np.pi * np.arange(1, rings) / rings
    phi = 2 * np.pi * np.arange(around) / around
    ring_points = np.stack([np.outer(np.sin(theta), np.cos(phi)), np.outer(np.sin(theta), np.sin(phi)),
                            np.outer(np.cos(theta), np.ones(around))], -1).reshape(-1, 3)
    points = radius * np.concatenate([[(0, 0, 1)], ring_points, [(0, 0, -1)]]) + (0, 0, HEIGHT)
    i = np.arange(around)
    ring = lambda j, k: 1 + (j - 1) * around + k % around  # noqa: E731
    tris = [np.stack([np.zeros(around, int), ring(1, i), ring(1, i + 1)], -1)]
    for j in range(1, rings - 1):
        tris += [np.stack([ring(j, i), ring(j + 1, i), ring(j + 1, i + 1)], -1),
                 np.stack([ring(j, i), ring(j + 1, i + 1), ring(j, i + 1)], -1)]
    tris.append(np.stack([ring(rings - 1, i), np.full(around, len(points) - 1), ring(rings - 1, i + 1)], -1))
    return points.astype(np.float32), np.concatenate(tris)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_finely_tessellated_glowing_sphere_does_not_shadow_its_own_light(tmp_path, integrator):
    """A glowing mesh sphere of 16k triangles over the white plane: the plane point below it shows E / pi, E the
    exact irradiance of the triangles facing it (a convex mesh: they are the ones it sees). Shadow rays were aimed
    along the sampled direction from the offset start, so they ended beside the sampled point and crossed the
    sphere's surface in front of it where it is seen obliquely: 1.3% too dark at 65k triangles, 1.5% at 16k. Both
    integrators aim them with shadow_ray_to; ``path`` at one interaction is direct light (light samples weighted
    against BSDF samples, which need no shadow ray, so most of the light comes through the shadow rays)."""
    points, tris = uv_sphere(0.3, 128, 64)
    mesh = ('def Mesh "Lamp" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{\n'
            f"    point3f[] points = [{', '.join(f'({x!r}, {y!r}, {z!r})' for x, y, z in points.tolist())}]\n"
            f"    int[] faceVertexCounts = [{', '.join(['3'] * len(tris))}]\n"
            f"    int[] faceVertexIndices = [{', '.join(map(str, tris.ravel().tolist()))}]\n"
            "    rel material:binding = </Glow>\n}\n")
    scene, messages = load(tmp_path, white_plane(), glow("constant"), mesh)
    assert [m.path for m in scene.meshes] == ["/Floor", "/Lamp"] and not messages, messages
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=1e-3)
    depth = {"max_depth": 1} if integrator == "path" else {}  # path: direct light only
    rendered = wrt.render(scene, camera=cam, width=4, height=4, spp=65536, seed=3, integrator=integrator,
                          **depth).rgb.mean()
    corners = points.astype(np.float64)[tris]
    outward = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    facing = np.sum(outward * corners[:, 0], axis=1) < 0.0  # front side towards the plane point at the origin
    expected = polygon_irradiance(np.zeros(3), (0, 0, 1), corners[facing], RADIANCE) / np.pi
    assert abs(rendered / expected - 1) < 0.008, (rendered, expected)  # 1.5% low before; noise 0.15%


def test_gprims_sharing_a_textured_glow_read_its_texture_once(tmp_path, monkeypatch):
    """Forty spheres bound to one textured glow are all drawn as emitters, and the texture's emission is estimated
    once for the material, not once a gprim (a pass over every texel each time)."""
    import wrt.usd

    calls = []
    estimate = wrt.usd.can_emit
    monkeypatch.setattr(wrt.usd, "can_emit", lambda *a: calls.append(a) or estimate(*a))
    lamps = [gprim("Sphere", 0.1, name=f"Lamp{i}") for i in range(40)]
    scene, _ = load(tmp_path, white_plane(), glow("texture"), *lamps)
    assert sorted(m.path for m in scene.meshes) == sorted(["/Floor"] + [f"/Lamp{i}" for i in range(40)])
    assert len(calls) == 1
