"""Emissive triangles inside instances (Python prototypes, native instances, PointInstancer prototypes) are sampled
as lights, each instance's copy in world space: a glowing quad under rotations, non-uniform scales and mirrors lights
a plane as Lambert's formula over its world-space triangles says, and as the same triangles flattened into world space
do, under ``whitted`` and ``path`` (whose MIS weights need the pdf of the entry a ray hits to be the one it was
sampled with); so do a glowing Sphere and a normalized mesh light inside native instances, the latter light- and
shadow-linked as the same light in world space is. Past the cap on instanced emitter entries the rest are named in a
warning."""

import warnings

import numpy as np
import pytest
import warp as wp
from light_oracle import polygon_irradiance, trs
from shading_helpers import pixel_points, quad
from test_emissive_gprims import glow, load, white_plane

import wrt
from wrt import light_table
from wrt.instancing import expand_instance_triangles
from wrt.integrators import INTEGRATORS

RADIANCE = 4.0  # of the glowing material
RES = 8  # pixels per side of the floor patch checked
PATCH = 1.2  # side of that patch, centred under the lamps
ALBEDO = 0.5  # the default material's grey: radiance = ALBEDO * E / pi
UNSAMPLED = "not sampled as lights"  # what render.py's warning about emitters left out of light sampling says

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
    return np.array([polygon_irradiance(p, (0, 0, 1), corners, radiance) for p in points])


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
    assert len(named) == 1 and "6 emissive triangle(s) of 3 instance(s) past the first 2 " in named[0], messages
    expected = expected_floor(world_corners(lamp, TRANSFORMS[:1]))
    assert abs(rendered.mean() / expected.mean() - 1) < 0.03, (rendered.mean(), expected.mean())


def light_table_bytes(instances):
    """``(rows, bytes)``: the light-table rows of :func:`lamp_scene` with ``instances`` copies of its quad (and a
    rect light), and the bytes of every device array of the table."""
    transforms = [trs((0.01 * i, 0.0, 1.0), (180, 0, 0)) for i in range(instances)]
    scene, _, _ = lamp_scene(transforms)
    scene.lights = [wrt.RectLight(trs((0.0, 0.0, 2.0)), 0.5, 0.4, np.full(3, 3.0))]
    lights = light_table.build_lights(scene.lights, scene, [np.zeros(3), np.full(3, RADIANCE)], "cpu").device_lights

    def size(struct):
        fields = [getattr(struct, name) for name in struct._cls.vars]
        return sum(f.size * wp.types.type_size_in_bytes(f.dtype) for f in fields if isinstance(f, wp.array)) + sum(
            size(f) for f in fields if hasattr(f, "_cls"))

    return lights.count, size(lights)


def test_a_triangle_light_takes_only_the_columns_a_triangle_reads():
    """Each instanced emitter row of the light table takes the bytes of what light sampling reads of a triangle
    light (radiance 12, params 16, triangle and instance 8, shadow mode 4, pmf, cdf and whitted's emitter cdf 12, lobe
    multipliers 8: 60), and each instance its first row's index (4): 2,000 more rows of 1,000 more instances of a quad
    take 62 bytes a row.
    Before, every row held the analytic lights' columns too (position, edges, normal, shaping, texture): 162."""
    rows, small = light_table_bytes(10)
    more_rows, large = light_table_bytes(1010)
    assert more_rows - rows == 2000
    assert (large - small) / 2000 == 60 + 4 / 2, (large - small) / 2000


# USD: a glowing quad mesh inside a native instance and inside a PointInstancer's prototype.

QUAD_POINTS = [(-0.2, -0.15, 0), (0.2, -0.15, 0), (0.2, 0.15, 0), (-0.2, 0.15, 0)]  # counter-clockwise: front +Z


def glowing_quad(name="Lamp"):
    """USDA of the single-sided glowing quad (front +Z by its winding), bound to ``/Glow``."""
    return (f'def Mesh "{name}" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{{\n'
            f"    point3f[] points = {QUAD_POINTS}\n    int[] faceVertexCounts = [4]\n"
            "    int[] faceVertexIndices = [0, 1, 2, 3]\n    uniform bool doubleSided = 0\n"
            "    rel material:binding = </Glow>\n}\n")


def native_instance(name, translate, rotate, scale):
    return (f'def Xform "{name}" (\n    instanceable = true\n    prepend references = </Protos/Lamp>\n)\n{{\n'
            f"    double3 xformOp:translate = {translate}\n    float3 xformOp:rotateXYZ = {rotate}\n"
            f"    float3 xformOp:scale = {scale}\n"
            '    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ", "xformOp:scale"]\n}\n')


def usd_lamps(tmp_path):
    """A glowing quad in two native instances (``/A``, ``/B``) and in a PointInstancer's two instances (``/PI``),
    loaded: ``(scene, warnings)``."""
    protos = 'over "Protos"\n{\n    def Xform "Lamp"\n    {\n' + glowing_quad().replace("\n", "\n        ") + "}\n}\n"
    natives = [native_instance("A", (0.3, -0.2, 1.0), (180, 0, 0), (1, 1, 1)),
               native_instance("B", (0.3, 0.3, 1.0), (0, 0, 20), (1, 1, -1))]
    instancer = ('def PointInstancer "PI"\n{\n    rel prototypes = </PI/Protos/Lamp>\n'
                 "    int[] protoIndices = [0, 0]\n    point3f[] positions = [(-0.4, 0.1, 1.0), (-0.3, -0.4, 1.0)]\n"
                 "    quath[] orientations = [(0, 0.9397, 0.342, 0), (0, 1, 0, 0)]\n"
                 "    float3[] scales = [(2, 0.5, 1), (1, 1, 1)]\n"
                 '    def Scope "Protos"\n    {\n        def Xform "Lamp"\n        {\n'
                 + glowing_quad("Quad").replace("\n", "\n            ") + "}\n    }\n}\n")
    scene, messages = load(tmp_path, white_plane(), glow("constant"), protos, *natives, instancer)
    return scene, messages


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_instanced_emitters_past_the_cap_are_named_once_by_every_integrator_that_samples_lights(
        tmp_path, monkeypatch, integrator):
    """With the cap at one quad's two triangles, native instance ``/A`` is sampled and the rest are not: whitted
    and path (the integrators that sample lights) each warn once, naming the six triangles left, the three
    instances and their sources (``/B``, and ``/PI`` with two), by the paths the stage authors; the others, which
    read no light, say nothing. Before, path said nothing (its light from them is only what BSDF rays find)."""
    monkeypatch.setattr(light_table, "MAX_INSTANCED_EMITTERS", 2)
    scene, _ = usd_lamps(tmp_path)
    _, messages = render_floor(scene, integrator, spp=1)
    named = [m for m in messages if UNSAMPLED in m]
    if integrator not in ("whitted", "path"):
        assert not named, messages
        return
    assert len(named) == 1, messages
    assert "6 emissive triangle(s) of 3 instance(s) past the first 2 " in named[0], named
    assert "(/B: 2 of 1 instance, /PI: 4 of 2 instances)" in named[0], named


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_an_instanced_mesh_light_past_the_cap_is_named(tmp_path, monkeypatch, integrator):
    """A mesh light without a material (``noMaterialResponse``: nothing glows by its material) inside two native
    instances, with no instanced emitter sampled (cap 0): the warning names both instances' triangles. Before,
    whitted said nothing, as it warned only where some material glows."""
    from test_mesh_lights import floor, mesh_light

    monkeypatch.setattr(light_table, "MAX_INSTANCED_EMITTERS", 0)
    protos = ('over "Protos"\n{\n    def Xform "Lamp"\n    {\n'
              + mesh_light(intensity=3.0).replace("\n", "\n        ") + "}\n}\n")
    natives = [native_instance("A", (-0.5, 0.0, 0.0), (0, 0, 0), (1, 1, 1)),
               native_instance("B", (0.9, 0.0, 0.0), (0, 0, 0), (1, 1, 1))]
    scene, _ = load(tmp_path, floor(), protos, *natives)
    _, messages = render_floor(scene, integrator, spp=1)
    named = [m for m in messages if UNSAMPLED in m]
    assert len(named) == 1 and "4 emissive triangle(s) of 2 instance(s) past the first 0 " in named[0], messages
    assert "(/A: 2 of 1 instance, /B: 2 of 1 instance)" in named[0], named


def test_usd_native_and_point_instancer_lamps_light_the_floor_as_the_formula_says(tmp_path):
    """A glowing quad in a native prototype (turned over, and mirrored by z -> -z) and in a PointInstancer's
    prototype (a rotation and a non-uniform scale, and a turn over) lights the floor under whitted as Lambert's
    formula over the world-space quads that face it says; USD's own ComputeInstanceTransformsAtTime and
    ComputeLocalToWorldTransform place the oracle's quads. Before, the floor was black with a warning."""
    from pxr import Usd, UsdGeom

    scene, messages = usd_lamps(tmp_path)
    assert len(scene.instances) == 4 and not messages, messages
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    transforms = [np.array(UsdGeom.Xformable(stage.GetPrimAtPath(p)).ComputeLocalToWorldTransform(0)).T
                  for p in ("/A", "/B")]
    placed = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")).ComputeInstanceTransformsAtTime(0, 0)
    transforms += [np.array(m).T for m in placed]
    local = np.array(QUAD_POINTS, np.float64)
    mesh = wrt.Mesh("/q", local, [[0, 1, 2], [0, 2, 3]], [0, 0])
    corners = world_corners(mesh, transforms)
    points = pixel_points((0.0, 0.0, 0.0), PATCH, RES, RES).reshape(-1, 3)
    expected = (lambert_irradiance(points, corners, 3.0) / np.pi).reshape(RES, RES)  # white floor: albedo 1
    rendered, messages = render_floor(scene, "whitted", spp=512)
    assert not [m for m in messages if UNSAMPLED in m], messages
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.1, rendered / expected


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_an_instanced_glowing_sphere_lights_the_floor_as_the_closed_form(tmp_path, integrator):
    """A Sphere of radius r = 0.1 bound to a glowing material (radiance 3) inside a native instance placed at
    height h = 1: drawn as its tessellation inside the prototype too, its triangles are sampled in the instance, and
    it lights the white floor with E = pi L r^2 cos / d^2, cos = h / d. Before, it stayed an analytic prototype
    shape that whitted did not sample (the floor black, with a warning)."""
    r = 0.1
    sphere = ('def Sphere "Ball" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{\n'
              f"    double radius = {r}\n    rel material:binding = </Glow>\n}}\n")
    protos = 'over "Protos"\n{\n    def Xform "Lamp"\n    {\n' + sphere.replace("\n", "\n        ") + "}\n}\n"
    scene, messages = load(tmp_path, white_plane(), glow("constant"), protos,
                           native_instance("A", (0, 0, 1.0), (0, 0, 0), (1, 1, 1)))
    assert not messages and not [s for p in scene.prototypes for s in p.shapes], messages
    assert [len(m.indices) >= 2 * 64 for p in scene.prototypes for m in p.meshes] == [True]  # its tessellation
    rendered, messages = render_floor(scene, integrator, spp=512 if integrator == "whitted" else 256)
    assert not [m for m in messages if UNSAMPLED in m], messages
    points = pixel_points((0.0, 0.0, 0.0), PATCH, RES, RES)
    expected = 3.0 * r**2 * 1.0 / np.linalg.norm(points - (0.0, 0.0, 1.0), axis=-1) ** 3  # albedo 1 times E / pi
    assert abs(rendered.mean() / expected.mean() - 1) < 0.03, (rendered.mean(), expected.mean())


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_normalized_mesh_light_in_two_native_instances_is_divided_by_each_ones_area(tmp_path, integrator):
    """A unit square with MeshLightAPI (intensity 3, normalize) inside a native prototype, drawn by two instances,
    one scaled to 1.5 x 0.5: each instance's copy is a light of its own, divided by its own world area (radiance 3
    and 4), and the floor shows Lambert's formula over both. Before, mesh lights inside instances emitted nothing
    (a warning named them)."""
    from test_mesh_lights import floor, mesh_light

    protos = ('over "Protos"\n{\n    def Xform "Lamp"\n    {\n'
              + mesh_light(intensity=3.0, normalize=True).replace("\n", "\n        ") + "}\n}\n")
    natives = [native_instance("A", (-0.5, 0.0, 0.0), (0, 0, 0), (1, 1, 1)),
               native_instance("B", (0.9, 0.0, 0.0), (0, 0, 0), (1.5, 0.5, 1))]
    scene, messages = load(tmp_path, floor(), protos, *natives)
    assert [type(light).__name__ for light in scene.lights] == ["MeshLight"] and not messages, messages
    square = np.array([(-0.5, -0.5, 1.0), (-0.5, 0.5, 1.0), (0.5, 0.5, 1.0), (0.5, -0.5, 1.0)])  # front: -Z
    points = pixel_points((0.0, 0.0, 0.0), PATCH, RES, RES).reshape(-1, 3)
    expected = np.zeros(len(points))
    for offset, scale, radiance in (((-0.5, 0, 0), (1, 1, 1), 3.0), ((0.9, 0, 0), (1.5, 0.5, 1), 4.0)):
        corners = (square * scale + offset)[[[0, 1, 2], [0, 2, 3]]]
        expected += ALBEDO * lambert_irradiance(points, corners, radiance) / np.pi
    rendered, messages = render_floor(scene, integrator, spp=256)
    assert not [m for m in messages if UNSAMPLED in m], messages
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected.reshape(RES, RES) - 1).max() < 0.15




def placed(name, translate, rotate, body):
    """USDA of Xform ``name`` at ``translate`` turned by ``rotate`` (degrees about X, Y, Z) holding ``body``."""
    return (f'def Xform "{name}"\n{{\n    double3 xformOp:translate = {translate}\n'
            f"    float3 xformOp:rotateXYZ = {rotate}\n"
            '    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]\n'
            + body.replace("\n", "\n    ") + "}\n")


def test_light_and_shadow_links_of_an_instanced_mesh_light_are_those_of_the_light_in_world_space(tmp_path):
    """A mesh light inside a native prototype, drawn by two instances, whose ``collection:lightLink`` leaves out the
    left floor and whose ``collection:shadowLink`` leaves out a card hanging between it and the right floor: the left
    floor stays black, the right one is lit unshadowed, as Lambert's formula over both instances' squares says and
    as the same lights authored in world space render under whitted."""
    from test_mesh_lights import HEIGHT, floor, mesh_light

    links = ("    prepend rel collection:lightLink:excludes = </Left>\n"
             "    uniform bool collection:lightLink:includeRoot = 1\n"
             "    prepend rel collection:shadowLink:excludes = </Card>\n"
             "    uniform bool collection:shadowLink:includeRoot = 1\n")
    lamp = mesh_light(intensity=3.0, scale=(0.4, 0.3, 1), extra=links).replace(
        '"MaterialBindingAPI"', '"MaterialBindingAPI", "CollectionAPI:lightLink", "CollectionAPI:shadowLink"')
    card = placed("Card", (0, 0, HEIGHT / 2), (0, 0, 0), floor("Strip", 0.3, 0.6))  # a strip over the right floor
    floors = (floor("Left", -20, 0), floor("Right", 0, 20), card)
    places = [((-0.5, 0.0, 0.0), (0, 0, 0)), ((0.5, 0.1, 0.0), (0, 0, 30))]
    protos = 'over "Protos"\n{\n' + placed("Lamp", (0, 0, 0), (0, 0, 0), lamp) + "}\n"
    instanced, messages = load(tmp_path, *floors, protos,
                               *(native_instance(n, t, r, (1, 1, 1)) for n, (t, r) in zip("AB", places)))
    assert len(instanced.instances) == 2 and len(instanced.lights) == 1 and not messages, messages
    in_world, _ = load(tmp_path, *floors, *(placed(n, t, r, lamp) for n, (t, r) in zip("AB", places)))
    assert not in_world.instances and len(in_world.lights) == 2
    square = np.array([(-0.2, -0.15, HEIGHT), (-0.2, 0.15, HEIGHT), (0.2, 0.15, HEIGHT), (0.2, -0.15, HEIGHT)])
    corners = world_corners(wrt.Mesh("/s", square, [[0, 1, 2], [0, 2, 3]], [0, 0]), [trs(t, r) for t, r in places])

    width, height = 2 * RES, RES
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.3), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    points = pixel_points((0.0, 0.0, 0.0), PATCH, width, height).reshape(-1, 3)
    expected = (ALBEDO * lambert_irradiance(points, corners, 3.0) / np.pi).reshape(height, width)[:, RES:]
    for name, scene in (("instanced", instanced), ("in world", in_world)):
        rgb = wrt.render(scene, camera=cam, width=width, height=height, spp=512, seed=3, integrator="whitted",
                         max_depth=1).rgb.mean(axis=-1)
        assert np.all(rgb[:, :RES] == 0.0), (name, rgb[:, :RES])  # x < 0: the left floor, not linked
        ratio = rgb[:, RES:] / expected  # no shadow of the card
        assert abs(rgb[:, RES:].mean() / expected.mean() - 1) < 0.03 and np.abs(ratio - 1).max() < 0.15, (name, ratio)


def test_instanced_mesh_lights_keep_their_names_when_usd_numbers_the_prototypes_otherwise(tmp_path):
    """Mesh lights inside two native prototypes (``/Protos/LampA``, drawn by ``/A`` and ``/C``; ``/Protos/LampB``,
    by ``/B``), read three times from the stage and three times from a stage that sublayers it with its root prims
    reordered: USD numbers the two prototypes either way round, from one opening to the next (of the same file too),
    yet each opening lists the same lights, each named by an instance-proxy path USD gives
    (``Usd.TraverseInstanceProxies``), its first instance's by path order, and each light still owns its triangles
    in every instance. Before, they were named by their prototype paths (``/__Prototype_2/Light`` in some openings,
    ``/__Prototype_1/Light`` in others)."""
    from pxr import Usd, UsdLux
    from test_mesh_lights import mesh_light

    def lamp(name, light):
        return f'    def Xform "{name}"\n    {{\n' + light.replace("\n", "\n        ") + "}\n"

    protos = ('over "Protos"\n{\n' + lamp("LampA", mesh_light(intensity=3.0))
              + lamp("LampB", mesh_light(intensity=2.0).replace('"Light"', '"Bulb"')) + "}\n")
    natives = "".join(f'def Xform "{n}" (\n    instanceable = true\n    prepend references = </Protos/{p}>\n)\n{{\n}}\n'
                      for n, p in (("A", "LampA"), ("B", "LampB"), ("C", "LampA")))
    (tmp_path / "stage.usda").write_text('#usda 1.0\n(\n    upAxis = "Z"\n)\n' + protos + natives)
    (tmp_path / "reordered.usda").write_text('#usda 1.0\n(\n    subLayers = [@stage.usda@]\n    upAxis = "Z"\n)\n'
                                             'reorder rootPrims = ["B", "C", "A", "Protos"]\n')
    names = []
    for name in ("stage.usda", "reordered.usda") * 3:
        path = str(tmp_path / name)
        stage = Usd.Stage.Open(path)
        proxies = {str(p.GetPath()) for p in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies())
                   if p.HasAPI(UsdLux.MeshLightAPI)}
        assert proxies == {"/A/Light", "/B/Bulb", "/C/Light"}
        scene = wrt.load_usd(path)
        lights = sorted(scene.lights, key=lambda light: light.path)
        assert {light.path for light in lights} <= proxies, [light.path for light in lights]
        names.append([light.path for light in lights])
        tris = light_table.emitter_triangles(scene, [np.zeros(3)], lights)
        assert np.bincount(tris.owner, minlength=2).tolist() == [4, 2]  # LampA's quad in /A and /C, LampB's in /B
    assert all(found == ["/A/Light", "/B/Bulb"] for found in names), names


def test_glowing_quads_instanced_by_a_scale_float32_cannot_hold_light_the_floor_as_lamberts_formula_says():
    """The quads of the first test 1e-36 of their size in the prototype, instanced by 1e39 (their ``L`` past
    float32's range) in a world 1000 times as large: the floor's radiance is that of Lambert's formula over the
    unscaled quads (the oracle; radiance does not change with the world's scale). Its emitter samples were moved to
    the world by the float32 inverse of ``A``, which overflowed: NaN points, and the floor was black without a word."""
    world, size = 1e3, 1e-36
    transforms = [np.diag([world] * 3 + [1.0]) @ np.asarray(t) @ np.diag([1 / size] * 3 + [1.0]) for t in TRANSFORMS]
    floor = quad((0, 0, 0), (40 * world, 0, 0), (0, 40 * world, 0), name="/floor")
    lamp = quad((0, 0, 0), (0.4 * size, 0, 0), (0, 0.3 * size, 0), name="/P/lamp", material=0, double_sided=False)
    instances = wrt.Instances.from_transforms(np.zeros(len(transforms)), np.array(transforms))
    glowing = wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE)
    scene = wrt.Scene(meshes=[floor], prototypes=[wrt.Prototype("/P", [lamp])], instances=instances,
                      materials=[glowing])
    _, _, unit_lamp = lamp_scene(TRANSFORMS)
    expected = expected_floor(world_corners(unit_lamp, TRANSFORMS))
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5 * world), target=(0, 0, 0), up=(0, 1, 0), height=PATCH * world)
    img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=512, seed=3, integrator="whitted", max_depth=1)
    rendered = img.rgb.mean(axis=-1)
    assert abs(rendered.mean() / expected.mean() - 1) < 0.02, (rendered.mean(), expected.mean())
    assert np.abs(rendered / expected - 1).max() < 0.1, rendered / expected
