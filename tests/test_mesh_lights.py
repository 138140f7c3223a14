"""Mesh lights (UsdLux ``MeshLightAPI``, or ``LightAPI`` on another gprim): the irradiance a quad mesh light gives a
plane against Lambert's closed form and against the same light authored as a ``RectLight``; ``normalize``,
``exposure`` and ``color``; light linking; ``materialSyncMode`` with an emissive material; analytic gprims as mesh
lights (a sphere against its closed form); mesh lights inside instances; volumes, which cannot be lights, are
named."""

import numpy as np
import pytest
from shading_helpers import pixel_points, quad, top_down_camera
from test_lights import ALBEDO, RES, rect_irradiance
from usda_text import load_recording_warnings

import wrt

HEIGHT = 1.0  # of the light above the floor z = 0
PATCH = 0.8  # side of the floor patch the camera sees, centred under the light


def floor(name="Floor", x0=-20.0, x1=20.0):
    """USDA of a grey (default material) rectangle at z = 0 from ``x0`` to ``x1`` (y from -20 to 20), facing up."""
    pts = [(x0, -20, 0), (x1, -20, 0), (x1, 20, 0), (x0, 20, 0)]
    return f'def Mesh "{name}"\n{{\n    point3f[] points = {pts}\n    int[] faceVertexCounts = [4]\n' \
           '    int[] faceVertexIndices = [0, 1, 2, 3]\n}\n'


def inputs(intensity=1.0, exposure=0.0, color=(1, 1, 1), normalize=False, sync=None, extra=""):
    text = (f"    float inputs:intensity = {intensity}\n    float inputs:exposure = {exposure}\n"
            f"    color3f inputs:color = {tuple(color)}\n    bool inputs:normalize = {int(normalize)}\n")
    if sync is not None:
        text += f'    uniform token light:materialSyncMode = "{sync}"\n'
    return text + extra


def mesh_light(api="MeshLightAPI", scale=(1, 1, 1), material=None, extra="", **kw):
    """USDA of a unit square mesh light (times ``scale``) at z = HEIGHT whose front (by its winding) faces the floor."""
    pts = [(-0.5, -0.5, 0), (-0.5, 0.5, 0), (0.5, 0.5, 0), (0.5, -0.5, 0)]  # clockwise from above: front is -Z
    bind = "" if material is None else f"    rel material:binding = <{material}>\n"
    return (f'def Mesh "Light" (\n    prepend apiSchemas = ["{api}", "MaterialBindingAPI"]\n)\n{{\n'
            f"    point3f[] points = {pts}\n    int[] faceVertexCounts = [4]\n"
            "    int[] faceVertexIndices = [0, 1, 2, 3]\n"
            f'    double3 xformOp:translate = (0, 0, {HEIGHT})\n    float3 xformOp:scale = {tuple(scale)}\n'
            '    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]\n'
            f"{bind}{inputs(**kw)}{extra}}}\n")


def rect_light(scale=(1, 1, 1), **kw):
    """USDA of the RectLight that :func:`mesh_light` is (UsdLux rect lights emit along their -Z)."""
    return (f'def RectLight "Light"\n{{\n    double3 xformOp:translate = (0, 0, {HEIGHT})\n'
            f'    float3 xformOp:scale = {tuple(scale)}\n'
            '    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]\n'
            f"{inputs(**kw)}}}\n")


def glowing_material(glow):
    return ('def Material "Glow"\n{\n    token outputs:surface.connect = </Glow/Surface.outputs:surface>\n'
            '    def Shader "Surface"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
            f"        color3f inputs:emissiveColor = {tuple(glow)}\n        token outputs:surface\n    }}\n}}\n")


def load(tmp_path, *prims, name="stage.usda"):
    path = tmp_path / name
    path.write_text('#usda 1.0\n(\n    upAxis = "Z"\n)\n' + "".join(prims))
    return load_recording_warnings(str(path))


def render_floor(scene, integrator, spp=64, center=(0.0, 0.0, 0.0)):
    """Radiance ``(H, W, 3)`` of the floor patch under the light, seen from above (through the back of a
    single-sided mesh light, which camera rays cull), direct light only."""
    img = wrt.render(scene, camera=top_down_camera(center, height=PATCH), width=RES, height=RES, spp=spp, seed=3,
                     integrator=integrator, max_depth=1)
    return img.rgb


def closed_form(radiance, scale=(1, 1, 1), center=(0.0, 0.0, 0.0)):
    points = pixel_points(center, PATCH, RES, RES)
    return ALBEDO * rect_irradiance(points, scale[0] / 2, scale[1] / 2, HEIGHT, radiance) / np.pi


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_quad_mesh_light_gives_the_closed_form_and_the_rect_lights_irradiance(tmp_path, integrator):
    """A unit square of MeshLightAPI with intensity 3 (no material: it is the light alone) lights the floor under
    it as Lambert's closed form for a rectangle of radiance 3 says, and as the same RectLight does. Before, the mesh
    was drawn as geometry that emitted nothing (the floor black, with a warning)."""
    scene, messages = load(tmp_path, floor(), mesh_light(intensity=3.0))
    assert not messages and isinstance(scene.lights[0], wrt.MeshLight), messages
    meshed = render_floor(scene, integrator).mean(axis=-1)
    expected = closed_form(3.0)
    assert abs(meshed.mean() / expected.mean() - 1) < 0.02, (meshed.mean(), expected.mean())
    assert np.abs(meshed / expected - 1).max() < 0.25
    rect, _ = load(tmp_path, floor(), rect_light(intensity=3.0), name="rect.usda")
    reference = render_floor(rect, integrator).mean(axis=-1)
    assert abs(meshed.mean() / reference.mean() - 1) < 0.02, (meshed.mean(), reference.mean())


@pytest.mark.parametrize("normalize", [False, True])
def test_normalize_divides_by_the_world_space_area(tmp_path, normalize):
    """``inputs:normalize`` divides by the mesh's area in the world: a unit square scaled to 2 x 1.5 (area 3)."""
    scale = (2.0, 1.5, 1.0)
    scene, _ = load(tmp_path, floor(), mesh_light(intensity=6.0, normalize=normalize, scale=scale))
    rendered = render_floor(scene, "path").mean(axis=-1)
    expected = closed_form(6.0 / 3.0 if normalize else 6.0, scale)
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())


def test_exposure_and_colour_scale_the_radiance(tmp_path):
    """``intensity * 2^exposure * color``, per channel, as for other UsdLux lights."""
    color = (1.0, 0.5, 0.25)
    scene, _ = load(tmp_path, floor(), mesh_light(intensity=0.5, exposure=3.0, color=color))
    rendered = render_floor(scene, "path").reshape(-1, 3).mean(axis=0)
    expected = closed_form(4.0).mean() * np.asarray(color)
    np.testing.assert_allclose(rendered, expected, rtol=0.02)


SHADOWS_PASS_THE_BLOCKER = {
    "shadow_enable_off": "    bool inputs:shadow:enable = 0\n",
    "shadow_link_excludes": "    rel collection:shadowLink:excludes = </Blocker>\n",
}


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("passed", sorted(SHADOWS_PASS_THE_BLOCKER))
def test_diffuse_multiplier_shadow_enable_and_shadow_link_apply(tmp_path, integrator, passed):
    """``inputs:diffuse`` scales what the (diffuse) floor reflects of the mesh light; ``inputs:shadow:enable = 0``,
    or a shadowLink that excludes it, lets its light through a blocker between it and the floor (single-sided, facing
    down: camera rays from above cull it). ``path`` gives light sampling the whole weight: its BSDF rays stop at the
    blocker (the floor was 5.5% too dark when they kept their MIS share)."""
    pts = [(-2, -2, 0.5), (-2, 2, 0.5), (2, 2, 0.5), (2, -2, 0.5)]
    blocker = (f'def Mesh "Blocker"\n{{\n    point3f[] points = {pts}\n    int[] faceVertexCounts = [4]\n'
               '    int[] faceVertexIndices = [0, 1, 2, 3]\n}\n')
    extra = "    float inputs:diffuse = 0.25\n" + SHADOWS_PASS_THE_BLOCKER[passed]
    scene, _ = load(tmp_path, floor(), blocker, mesh_light(intensity=3.0, extra=extra))
    rendered = render_floor(scene, integrator).mean()
    assert abs(rendered / (0.25 * closed_form(3.0).mean()) - 1) < 0.02, rendered


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_light_linking_leaves_out_an_excluded_prim(tmp_path, integrator):
    """The mesh light prim's ``collection:lightLink`` decides what it lights: of two floors meeting under the light,
    the excluded one stays black and the other is lit as without linking."""
    link = "    rel collection:lightLink:excludes = </Dark>\n"
    scene, messages = load(tmp_path, floor("Lit", x1=0.0), floor("Dark", x0=0.0), mesh_light(intensity=3.0, extra=link))
    assert not messages and scene.lights[0].light_link is not None, messages
    lit = render_floor(scene, integrator, center=(-0.5, 0.0, 0.0)).mean()
    dark = render_floor(scene, integrator, center=(0.5, 0.0, 0.0)).max()
    assert dark == 0.0
    assert abs(lit / closed_form(3.0, center=(-0.5, 0.0, 0.0)).mean() - 1) < 0.03


def light_seen_from_below(scene):
    """Radiance of the mesh light's front seen straight up from below it, one pixel."""
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 1.0), up=(0, 1, 0), height=0.2)
    return wrt.render(scene, camera=cam, width=1, height=1, integrator="path", max_depth=1).rgb[0, 0]


@pytest.mark.parametrize("sync, lights_with, shows", [
    (None, (4.0, 2.0, 1.0), (2.0, 1.0, 0.5)),  # MeshLightAPI's fallback, materialGlowTintsLight: 2 x the glow
    ("independent", (2.0, 2.0, 2.0), (2.0, 1.0, 0.5)),  # the light's colour; cameras see the glow
    ("noMaterialResponse", (2.0, 2.0, 2.0), (2.0, 2.0, 2.0)),  # the light's colour, seen too; no material
])
def test_material_sync_mode_with_an_emissive_material(tmp_path, sync, lights_with, shows):
    """A mesh light of intensity 2 bound to a material glowing (2, 1, 0.5): UsdLux's ``materialSyncMode`` decides
    the radiance that lights the floor (the glow times the light, or the light alone) and what camera rays see (the
    material's glow, or the light where the mesh has no material response)."""
    scene, messages = load(tmp_path, floor(), glowing_material((2.0, 1.0, 0.5)),
                           mesh_light(intensity=2.0, sync=sync, material="/Glow"))
    assert not messages, messages
    lit = render_floor(scene, "path").reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(lit, closed_form(1.0).mean() * np.asarray(lights_with), rtol=0.02)
    np.testing.assert_allclose(light_seen_from_below(scene), shows, rtol=1e-5)
    whitted = render_floor(scene, "whitted").reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(whitted, lit, rtol=0.03)


def test_a_light_that_tints_a_glow_its_texture_gives_by_its_fallback_is_not_named(tmp_path):
    """materialGlowTintsLight with a material whose UDIM emission texture has no file for the tile the mesh reads
    (tile 1001: a mesh without st reads st (0, 0); tile 1002 is black) glows by the texture's fallback, 1: the light
    lights the floor as its intensity times that glow, and is not named as a light that emits nothing (its texels'
    mean, 0, named it though it lit the floor)."""
    from PIL import Image

    Image.fromarray(np.zeros((2, 2, 3), np.uint8)).save(tmp_path / "glow.1002.png")
    material = ('def Material "Glow"\n{\n    token outputs:surface.connect = </Glow/Surface.outputs:surface>\n'
                '    def Shader "Surface"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
                "        color3f inputs:emissiveColor.connect = </Glow/Image.outputs:rgb>\n"
                "        token outputs:surface\n    }\n"
                '    def Shader "Image"\n    {\n        uniform token info:id = "UsdUVTexture"\n'
                "        asset inputs:file = @./glow.<UDIM>.png@\n        float4 inputs:fallback = (1, 1, 1, 1)\n"
                "        float3 outputs:rgb\n    }\n}\n")
    scene, messages = load(tmp_path, floor(), material, mesh_light(intensity=2.0, material="/Glow"))
    assert not any("materialGlowTintsLight" in m for m in messages), messages
    lit = render_floor(scene, "whitted", spp=16).mean()
    assert abs(lit / closed_form(2.0).mean() - 1) < 0.02, lit


def test_a_light_that_tints_a_glow_the_material_has_not_is_named(tmp_path):
    """materialGlowTintsLight with a material that does not glow emits nothing, as UsdLux defines it: named."""
    scene, messages = load(tmp_path, floor(), glowing_material((0.0, 0.0, 0.0)), mesh_light(material="/Glow"))
    assert any("materialGlowTintsLight" in m and "/Light" in m for m in messages), messages
    assert render_floor(scene, "path", spp=1).max() == 0.0


# USDA of a sun of illuminance 5 shining along +Z, onto the -Z front of the mesh lights the tests below move to z = -1.
SUN = ('def DistantLight "Sun"\n{\n    float inputs:intensity = 5\n    float inputs:angle = 0\n'
       '    float3 xformOp:rotateXYZ = (180, 0, 0)\n    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]\n}\n')


def test_a_mesh_light_of_no_material_response_reflects_nothing(tmp_path):
    """LightAPI alone on a mesh (fallback noMaterialResponse) makes it a light that reflects no other light."""
    scene, _ = load(tmp_path, SUN, mesh_light(api="LightAPI", intensity=0.0).replace("(0, 0, 1.0)", "(0, 0, -1.0)"))
    cam = wrt.Camera.orthographic(eye=(0, 0, -3), target=(0, 0, -1), up=(0, 1, 0), height=0.2)
    img = wrt.render(scene, camera=cam, width=1, height=1)
    assert img.aovs["prim"][0, 0] >= 0 and img.rgb.max() == 0.0


def test_a_python_mesh_light_of_no_material_response_reflects_nothing_as_one_read_from_usd(tmp_path):
    """A ``wrt.MeshLight`` of ``material_sync="noMaterialResponse"`` (its default) on a white quad under a sun: the
    quad reflects nothing and the material AOV shows no material, as for the same mesh light read from USD (one code
    path: the lights' build gives such triangles a surface that reflects nothing, whatever their mesh's material).
    Before, the Python quad kept its white material and reflected the sun (1.79 where the USD one showed 0), and
    the material AOV of the USD one named a material of its own."""
    white = ('def Material "White"\n{\n    token outputs:surface.connect = </White/Surface.outputs:surface>\n'
             '    def Shader "Surface"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
             "        color3f inputs:diffuseColor = (1, 1, 1)\n        token outputs:surface\n    }\n}\n")
    light = mesh_light(intensity=0.0, sync="noMaterialResponse", material="/White").replace("(0, 0, 1.0)",
                                                                                             "(0, 0, -1.0)")
    read, messages = load(tmp_path, white, SUN, light)
    assert not messages, messages
    panel = quad((0, 0, -1), (0, 1, 0), (1, 0, 0), name="/panel", material=0, double_sided=False)  # front: -Z
    built = wrt.Scene(meshes=[panel], materials=[wrt.Material(path="/White", diffuse_color=(1.0, 1.0, 1.0))],
                      lights=[wrt.DistantLight(direction=(0, 0, 1), color=(5.0, 5.0, 5.0), angle=0.0),
                              wrt.MeshLight("/panel", color=np.zeros(3))])
    cam = wrt.Camera.orthographic(eye=(0, 0, -3), target=(0, 0, -1), up=(0, 1, 0), height=0.2)
    for scene in (read, built):
        img = wrt.render(scene, camera=cam, width=1, height=1)
        assert img.aovs["prim"][0, 0] >= 0 and img.rgb.max() == 0.0, (scene, img.rgb)
        assert img.aovs["material"][0, 0] == -1
    built.lights[1].material_sync = "independent"  # the material reflects again: white under E = 5, plus specular
    assert wrt.render(built, camera=cam, width=1, height=1).rgb.min() > 5.0 / np.pi


def gprim_light(kind, radius=None, x=0.0, extra=""):
    """USDA of a ``kind`` gprim with MeshLightAPI (no material) centred at ``(x, 0, HEIGHT)``, scaled by 0.3 unless
    ``radius`` (a Sphere's) is given."""
    size = (f"    double radius = {radius}\n" if radius is not None else
            '    float3 xformOp:scale = (0.3, 0.3, 0.3)\n')
    order = '"xformOp:translate"' + ("" if radius is not None else ', "xformOp:scale"')
    return (f'def {kind} "Bulb" (\n    prepend apiSchemas = ["MeshLightAPI"]\n)\n{{\n{size}'
            f"    double3 xformOp:translate = ({x}, 0, {HEIGHT})\n    uniform token[] xformOpOrder = [{order}]\n"
            f"{extra}{inputs(intensity=3.0)}}}\n")


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_an_analytic_sphere_with_mesh_light_api_emits_as_its_closed_form(tmp_path, integrator):
    """A Sphere gprim of radius r = 0.1 and radiance L = 3 at height h = 1 (no material: it is the light alone)
    lights the floor as a sphere light does: it subtends sin^2 = r^2 / d^2 from a floor point at distance d, so
    E = pi L r^2 cos(a) / d^2 with cos(a) = h / d (a point source of power pi L 4 pi r^2, intensity pi L r^2).
    The patch seen lies beside the sphere (x from 0.6 to 1.4), which the camera does not see. Before, it was drawn
    analytically as geometry that emitted nothing, with a warning."""
    r, center = 0.1, (1.0, 0.0, 0.0)
    scene, messages = load(tmp_path, floor(), gprim_light("Sphere", radius=r))
    assert not messages and [type(light).__name__ for light in scene.lights] == ["MeshLight"], messages
    rendered = render_floor(scene, integrator, center=center).mean(axis=-1)
    points = pixel_points(center, PATCH, RES, RES)
    d = np.linalg.norm(points - (0.0, 0.0, HEIGHT), axis=-1)
    expected = ALBEDO * 3.0 * r**2 * HEIGHT / d**3  # ALBEDO * E / pi
    assert abs(rendered.mean() / expected.mean() - 1) < 0.03, (rendered.mean(), expected.mean())
    blocks = (rendered / expected).reshape(4, RES // 4, 4, RES // 4).mean(axis=(1, 3))  # its falloff: 4x4 blocks
    assert np.abs(blocks - 1).max() < 0.15, blocks


@pytest.mark.parametrize("kind", ["Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Plane"])
def test_every_analytic_gprim_with_mesh_light_api_emits(tmp_path, kind):
    """Each gprim kind with MeshLightAPI (a double-sided Plane, whose one side faces up) is a mesh light: it lights
    the floor under it and cameras see its radiance (it has no material). Before, each emitted nothing, named in a
    warning."""
    scene, messages = load(tmp_path, floor(), gprim_light(kind, extra="    uniform bool doubleSided = 1\n"))
    assert not messages and [light.path for light in scene.lights] == ["/Bulb"], messages
    lit = render_floor(scene, "path", spp=8, center=(0.6, 0.0, 0.0)).mean()
    assert lit > 0.01, lit
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.2), target=(0, 0, 1.0), up=(0, 1, 0), height=0.05)
    np.testing.assert_allclose(wrt.render(scene, camera=cam, width=1, height=1, integrator="path").rgb[0, 0], 3.0,
                               rtol=1e-5)


def test_volumes_are_named_and_instanced_mesh_lights_are_lights(tmp_path):
    """VolumeLightAPI volumes emit nothing: named. Mesh lights inside instance prototypes (a mesh and a gprim) are
    lights, one each for all of their instances, and light the floor under the instance; they were drawn as
    geometry that emitted nothing, named. A gprim with LightAPI drawn in the world is a mesh light, analytic or
    tessellated."""
    sphere = ('def Sphere "Bulb" (\n    prepend apiSchemas = ["LightAPI"]\n)\n{\n    double radius = 0.3\n'
              '    double3 xformOp:translate = (0, 0, 1)\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n'
              '    float inputs:intensity = 4\n}\n')
    volume = 'def Volume "Fog" (\n    prepend apiSchemas = ["VolumeLightAPI"]\n)\n{\n}\n'
    instanced = ('class Xform "Source"\n{\n    ' + (mesh_light() + gprim_light("Cube")).replace("\n", "\n    ") +
                 '\n}\ndef Xform "Proto" (\n    instanceable = true\n    prepend references = </Source>\n)\n{\n'
                 '    double3 xformOp:translate = (10, 0, 0)\n'
                 '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n')
    scene, messages = load(tmp_path, floor(), sphere, volume, instanced)
    assert [light.path for light in scene.lights][0] == "/Bulb"
    assert sorted(light.path.rsplit("/", 1)[1] for light in scene.lights[1:]) == ["Bulb", "Light"]
    assert all(isinstance(light, wrt.MeshLight) for light in scene.lights[1:])
    assert any("VolumeLightAPI" in m and "/Fog" in m for m in messages), messages
    assert not any("inside instances" in m for m in messages), messages
    assert render_floor(scene, "whitted", spp=4, center=(10.5, 0.0, 0.0)).mean() > 0.05
    tessellated, _ = load_recording_warnings(str(tmp_path / "stage.usda"), tessellate_gprims=16)
    assert [type(light).__name__ for light in tessellated.lights] == ["MeshLight"] * 3
    img = wrt.render(tessellated, camera=top_down_camera(height=PATCH), width=RES, height=RES, spp=4,
                     integrator="path", max_depth=1)
    np.testing.assert_allclose(img.rgb[6:10, 6:10], 4.0, rtol=1e-5)  # cameras see the light: it has no material
    assert img.rgb[img.aovs["prim"] < 2].mean() > 0.05  # the floor's two triangles come first


def test_a_mesh_or_gprim_with_volume_light_api_is_named_and_emits_nothing(tmp_path):
    """VolumeLightAPI (which brings LightAPI along) on a Mesh or a Sphere lights the volume inside, which wrt does
    not have: each is named and drawn as geometry that emits nothing. Before, both were read as surface mesh lights
    (the Sphere drawn as its tessellation), the Sphere named as not supported though it lit the scene."""
    volume_light = 'prepend apiSchemas = ["VolumeLightAPI"]'
    sphere = gprim_light("Sphere", radius=0.1).replace('prepend apiSchemas = ["MeshLightAPI"]', volume_light)
    mesh = mesh_light(api="VolumeLightAPI")
    scene, messages = load(tmp_path, floor(), sphere, mesh)
    assert scene.lights == [] and [mesh.path for mesh in scene.meshes] == ["/Floor", "/Light"], scene.lights
    named = [m for m in messages if "VolumeLightAPI" in m]
    assert len(named) == 1 and "/Bulb" in named[0] and "/Light" in named[0], messages


def test_a_point_instancer_of_a_world_mesh_light_emits_in_place_and_in_its_instances(tmp_path):
    """A PointInstancer whose prototypes are mesh lights drawn in the world too (a mesh and a Sphere, not under an
    ``over``): those prims emit where they stand and in each instance, each prim one light. Before, the instances
    emitted nothing and a warning said so."""
    instancer = ('def PointInstancer "PI"\n{\n    rel prototypes = [</Light>, </Bulb>]\n'
                 "    int[] protoIndices = [0, 1]\n    point3f[] positions = [(5, 0, 0), (-5, 0, 0)]\n}\n")
    scene, messages = load(tmp_path, floor(), mesh_light(intensity=3.0), gprim_light("Sphere", radius=0.1, x=3.0),
                           instancer)
    assert sorted(light.path for light in scene.lights) == ["/Bulb", "/Light"]
    assert len(scene.instances.prototype) == 2
    assert not [m for m in messages if "/Light" in m or "/Bulb" in m], messages
    for integrator in ("whitted", "path"):
        for center in ((0.0, 0.0, 0.0), (5.0, 0.0, 0.0)):  # the Sphere and the other copy add under 0.5%
            lit = render_floor(scene, integrator, center=center).mean()
            assert abs(lit / closed_form(3.0).mean() - 1) < 0.03, (integrator, center, lit)  # the same light


def test_the_whitted_warning_on_unsampled_instanced_emitters_names_what_the_command_line_can_do(tmp_path, monkeypatch):
    """A Sphere bound to a glowing material (no light) inside a native instance, drawn as its tessellation with
    or without ``tessellate_gprims``, past the cap on sampled instanced emitters (0 here) is not sampled by
    ``whitted``: the warning's way out names the Python option and its ``wrt render`` equivalent, and no longer
    offers ``tessellate_gprims`` (``--accel warp``), which changes nothing for it."""
    from wrt import light_table

    monkeypatch.setattr(light_table, "MAX_INSTANCED_EMITTERS", 0)
    prototype = ('over "Protos"\n{\n    def Xform "Lamp"\n    {\n        def Sphere "Ball" (\n'
                 '            prepend apiSchemas = ["MaterialBindingAPI"]\n        )\n        {\n'
                 "            double radius = 0.1\n            rel material:binding = </Glow>\n        }\n    }\n}\n")
    instance = 'def Xform "Lamp" (\n    instanceable = true\n    prepend references = </Protos/Lamp>\n)\n{\n}\n'
    default, _ = load(tmp_path, floor(), glowing_material((1.0, 1.0, 1.0)), prototype, instance)
    tessellated = wrt.load_usd(str(tmp_path / "stage.usda"), tessellate_gprims=True)
    for scene in (default, tessellated):
        with pytest.warns(UserWarning, match="not sampled as lights") as record:
            render_floor(scene, "whitted", spp=1)
        message = str(record[0].message)
        assert "integrator='path'" in message and "--integrator path" in message, message
        assert "tessellate_gprims" not in message and "--accel warp" not in message, message


def test_a_python_mesh_light_names_its_mesh():
    """``wrt.MeshLight(path, color)`` in a scene built in Python makes the meshes at ``path`` emit (by default as
    LightAPI's noMaterialResponse: the light's colour, seen by cameras too); a path no mesh has is an error naming
    it, not a dark light, and so are two lights on one mesh (the second took every triangle)."""
    ground = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/ground")
    panel = quad((0, 0, HEIGHT), (0, 1, 0), (1, 0, 0), name="/panel", double_sided=False)  # front: -Z
    scene = wrt.Scene(meshes=[ground, panel], lights=[wrt.MeshLight("/panel", color=np.full(3, 3.0))])
    np.testing.assert_allclose(render_floor(scene, "path").mean() / closed_form(3.0).mean(), 1.0, rtol=0.02)
    scene.lights = [wrt.MeshLight("/nothing", color=np.ones(3))]
    with pytest.raises(wrt.SceneError, match="/nothing"):
        render_floor(scene, "path", spp=1)
    scene.lights = [wrt.MeshLight("/panel", color=np.ones(3)), wrt.MeshLight("/panel", color=np.full(3, 5.0))]
    with pytest.raises(wrt.SceneError, match="panel: two MeshLights name the same mesh"):  # the second took all
        render_floor(scene, "path", spp=1)


DARK_LIGHTS = {  # a light its author put on the stage that gives none, and the warning naming it at load
    "mesh_light_of_invalid_topology": (mesh_light(intensity=3.0).replace("[0, 1, 2, 3]", "[0, 1, 2, 7]"),
                                       "mesh lights whose geometry was left out give no light"),
    "emissive_mesh_of_invalid_topology": (
        mesh_light(material="/Glow").replace('"MeshLightAPI", ', "").replace("[0, 1, 2, 3]", "[0, 1, 2, 7]")
        + glowing_material((3.0, 3.0, 3.0)), "meshes of invalid topology were skipped"),
    "sphere_gprim_light_of_negative_radius": (
        'def Sphere "Light" (\n    prepend apiSchemas = ["MeshLightAPI"]\n)\n{\n    double radius = -1\n'
        f'    double3 xformOp:translate = (0, 0, {HEIGHT})\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n'
        "    float inputs:intensity = 3\n}\n", "mesh lights whose geometry was left out give no light"),
    "emissive_sphere_of_negative_radius": (  # a gprim, not a mesh: it was not counted (default lights)
        'def Sphere "Light" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{\n    double radius = -1\n'
        f'    double3 xformOp:translate = (0, 0, {HEIGHT})\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n'
        "    rel material:binding = </Glow>\n}\n" + glowing_material((3.0, 3.0, 3.0)),
        "gprims with a zero, negative or non-finite size were skipped"),
    "rect_light_of_nan_intensity": (rect_light(intensity="nan"), "lights whose colour * intensity"),
    "hidden_rect_light": (rect_light(intensity=3.0).replace("{\n", '{\n    token visibility = "invisible"\n', 1),
                          None),
}


@pytest.mark.parametrize("case", sorted(DARK_LIGHTS))
def test_a_stage_whose_only_light_gives_none_gets_no_default_lights(tmp_path, case):
    """A stage whose author lit it, with a mesh light whose mesh is skipped (invalid topology), a mesh of an emissive
    material skipped likewise, a gprim light or a gprim of an emissive material of a bad size, a light of a NaN
    intensity or a hidden light, got the
    default headlight and dome (meant for stages without lights), which lit the floor as 0.5 * (0.8 + 0.2) = 0.5 in
    place of the author's lighting. USD lists such a stage's lights (``ComputeLightList``, hidden ones too): no
    light reaches the floor now (0 exactly), the load names the light (but a hidden one, which is no mistake) and the
    render says why the image is dark. A stage without the light still gets the default lights."""
    from pxr import Usd, UsdLux

    text, warned = DARK_LIGHTS[case]
    scene, messages = load(tmp_path, floor(), text)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    listed = [str(p) for p in UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(
        UsdLux.LightListAPI.ComputeModeIgnoreCache)]
    assert scene.lights == [] and scene.dark_lights == (listed or ["/Light"]) == ["/Light"], (scene.dark_lights, listed)
    if warned is not None:
        assert any(m.startswith(f"{tmp_path / 'stage.usda'}: {warned}") and m.endswith("/Light") for m in messages), \
            messages
    camera = top_down_camera(height=PATCH)
    with pytest.warns(UserWarning, match=r"no light: the stage's lights give none .*: /Light; rendered without"):
        img = wrt.render(scene, camera=camera, width=2, height=2, device="cpu")
    np.testing.assert_array_equal(img.rgb, 0.0)
    unlit, _ = load(tmp_path, floor(), name="unlit.usda")
    assert unlit.dark_lights == []
    np.testing.assert_allclose(wrt.render(unlit, camera=camera, width=2, height=2, device="cpu").rgb, ALBEDO,
                               rtol=1e-5)


@pytest.mark.parametrize("integrator", ["ao", "normals", "depth", "albedo"])
def test_integrators_that_read_no_light_do_not_warn_that_a_stage_is_dark(tmp_path, integrator):
    """An integrator that samples no light (ao, normals, depth, albedo) draws a stage whose only light gives none as
    it draws the stage without it: the lights change nothing there. Yet its render warned "no light: ...; rendered
    without the default lights" (so did ``wrt preview --rays``, whose rays are a depth render), a warning about an
    image that no light could have changed. The image is the same as the unlit stage's (no light, default lights)."""
    import warnings

    text, _ = DARK_LIGHTS["rect_light_of_nan_intensity"]
    dark, _ = load(tmp_path, floor(), text)
    unlit, _ = load(tmp_path, floor(), name="unlit.usda")
    assert dark.dark_lights == ["/Light"] and unlit.dark_lights == []
    camera = top_down_camera(height=PATCH)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = wrt.render(dark, camera=camera, width=2, height=2, integrator=integrator, device="cpu")
    np.testing.assert_array_equal(img.rgb, wrt.render(unlit, camera=camera, width=2, height=2,
                                                      integrator=integrator, device="cpu").rgb)


@pytest.mark.parametrize("shown, indices, prototypes", [
    ("invisible", "[0]", "</Lamps/Protos/Lamp>"), ("inherited", "[]", "</Lamps/Protos/Lamp>"),
    ("invisible", "[0]", "</Lamps.relay>\n    rel relay = </Lamps/Protos/Lamp>"),  # forwarded (GetForwardedTargets)
], ids=["invisible", "no_instances", "invisible_relayed"])
def test_the_lights_in_the_prototypes_of_a_point_instancer_that_draws_none_are_the_stages_lights_too(
        tmp_path, shown, indices, prototypes):
    """A stage lit only by a lamp prototype's light, instanced by a hidden PointInstancer (or one of no instances),
    got the default lights: the walk does not enter an instancer's subtree and reads the prototypes only for the
    instances it draws, so the light was never met. ``ComputeLightList`` lists it, at its path under the instancer:
    such a stage gets no default lights either, as for a hidden native instance's light. So too where
    ``prototypes`` targets a relationship that USD forwards to the lamp (it was taken for no prim)."""
    from pxr import Usd, UsdLux

    lamps = (f'def PointInstancer "Lamps"\n{{\n    token visibility = "{shown}"\n'
             f"    rel prototypes = {prototypes}\n    point3f[] positions = [(0, 0, 0)]\n"
             f"    int[] protoIndices = {indices}\n"
             '    def Xform "Protos"\n    {\n        def Xform "Lamp"\n        {\n'
             + rect_light(intensity=3.0) + "        }\n    }\n}\n")
    scene, _ = load(tmp_path, floor(), lamps)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    listed = [str(p) for p in UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(
        UsdLux.LightListAPI.ComputeModeIgnoreCache)]
    assert scene.lights == [] and scene.dark_lights == listed == ["/Lamps/Protos/Lamp/Light"], \
        (scene.dark_lights, listed)
    with pytest.warns(UserWarning, match=r"no light: the stage's lights give none .*: /Lamps/Protos/Lamp/Light"):
        img = wrt.render(scene, camera=top_down_camera(height=PATCH), width=2, height=2, device="cpu")
    np.testing.assert_array_equal(img.rgb, 0.0)


def test_the_lights_of_a_hidden_instance_are_the_stages_lights_too(tmp_path):
    """A stage lit only by a lamp prototype's light, drawn through a hidden native instance, lists that light
    (``ComputeLightList`` lists it at its instance-proxy path): it gets no default lights either, as for a hidden
    light of its own."""
    from pxr import Usd, UsdLux

    lamp = ('class Xform "Protos"\n{\n' + rect_light(intensity=3.0) + '}\n'
            'def Xform "Lamp" (\n    instanceable = true\n    references = </Protos>\n)\n{\n'
            '    token visibility = "invisible"\n}\n')
    scene, _ = load(tmp_path, floor(), lamp)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    listed = [str(p) for p in UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(
        UsdLux.LightListAPI.ComputeModeIgnoreCache)]
    assert scene.lights == [] and scene.dark_lights == listed == ["/Lamp/Light"], (scene.dark_lights, listed)
    with pytest.warns(UserWarning, match=r"no light: the stage's lights give none .*: /Lamp/Light; rendered"):
        img = wrt.render(scene, camera=top_down_camera(height=PATCH), width=2, height=2, device="cpu")
    np.testing.assert_array_equal(img.rgb, 0.0)


@pytest.mark.parametrize("drawn_none", ["hidden_instancer", "no_instances", "all_ids_invisible",
                                        "hidden_instancer_of_native_lamps"])
def test_the_lights_of_an_instancer_that_draws_none_are_the_stages_lights_too(tmp_path, drawn_none):
    """A stage lit only by a lamp prototype of a PointInstancer that draws none of its instances (the instancer
    hidden, no instances, or every id in invisibleIds; a lamp that is a native instance too) lists that light
    (``ComputeLightList`` lists the prototype's light, at its instance-proxy path in a native instance): it gets no
    default lights, as for a hidden native instance. The walk does not enter an instancer, so its lamps were not
    counted, and the default headlight and dome lit the floor to 0.5."""
    from pxr import Usd, UsdLux

    instances, positions = ("[]", "[]") if drawn_none == "no_instances" else ("[0]", "[(0, 0, 0)]")
    extra = {"all_ids_invisible": "    int64[] invisibleIds = [0]\n",
             "no_instances": ""}.get(drawn_none, '    token visibility = "invisible"\n')
    native = drawn_none.endswith("native_lamps")
    lamp = rect_light(intensity=3.0)
    inner = "" if native else "".join("        " + line + "\n" for line in lamp.splitlines())
    lamps = ('def PointInstancer "Lamps"\n{\n    rel prototypes = </Lamps/Protos/Lamp>\n'
             f'    int[] protoIndices = {instances}\n    point3f[] positions = {positions}\n'
             f'{extra}    def Xform "Protos"\n    {{\n        def Xform "Lamp"'
             + (' (\n            instanceable = true\n            references = </LampClass>\n        )' * native)
             + f'\n        {{\n{inner}        }}\n    }}\n}}\n')
    if native:
        lamps += 'class Xform "LampClass"\n{\n' + lamp + '}\n'
    scene, _ = load(tmp_path, floor(), lamps)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    listed = [str(p) for p in UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(
        UsdLux.LightListAPI.ComputeModeIgnoreCache)]
    assert scene.lights == [] and scene.dark_lights == listed == ["/Lamps/Protos/Lamp/Light"], (scene.dark_lights,
                                                                                                 listed)
    with pytest.warns(UserWarning, match=r"no light: the stage's lights give none .*: /Lamps/Protos/Lamp/Light"):
        img = wrt.render(scene, camera=top_down_camera(height=PATCH), width=2, height=2, device="cpu")
    np.testing.assert_array_equal(img.rgb, 0.0)


def test_shadow_api_of_a_usd_mesh_light_is_read_as_a_rect_lights_is(tmp_path):
    """ShadowAPI inputs on a mesh light are read as on a rect light (the same values, as USD's ShadowAPI gives them),
    with no warning: wrt casts their shadows so (tests/test_lights.py renders them). Before, a mesh light's shadow
    colour and distance were named in a warning and left out."""
    from pxr import Usd, UsdLux

    shadow = ('    color3f inputs:shadow:color = (0.5, 0.25, 0)\n    float inputs:shadow:distance = 0.4\n'
              '    float inputs:shadow:falloff = 0.1\n    float inputs:shadow:falloffGamma = 2\n')
    api = '(\n    prepend apiSchemas = ["ShadowAPI"]\n)'
    scene, messages = load(tmp_path, floor(), mesh_light(api="MeshLightAPI\", \"ShadowAPI", extra=shadow),
                           rect_light().replace('"Light"\n', f'"Rect" {api}\n').replace("}\n", shadow + "}\n", 1))
    assert not [m for m in messages if "hadow" in m], messages
    lights = {light.path: light for light in scene.lights}
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    for path in ("/Light", "/Rect"):
        api = UsdLux.ShadowAPI(stage.GetPrimAtPath(path))
        light = lights[path]
        np.testing.assert_array_equal(light.shadow_color, np.float32(api.GetShadowColorAttr().Get()))
        assert (light.shadow_distance, light.shadow_falloff, light.shadow_falloff_gamma) == (
            api.GetShadowDistanceAttr().Get(), api.GetShadowFalloffAttr().Get(), api.GetShadowFalloffGammaAttr().Get())
    assert isinstance(lights["/Light"], wrt.MeshLight) and isinstance(lights["/Rect"], wrt.RectLight)
