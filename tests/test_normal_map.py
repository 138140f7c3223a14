"""Tangent-space normal maps (UsdPreviewSurface ``normal`` from a UsdUVTexture): the mapped shading normal in the
``normal`` AOV, its tangent frame under rotated, swapped, transformed and mirrored coordinates and geometry, Lambert
shading by it, and no black or non-finite pixels where it tilts away from the viewer."""

import math

import numpy as np
import pytest
import warp as wp
from PIL import Image as PilImage
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt
from test_materials import st_source

import wrt
from wrt.lights import DomeLight
from wrt.materials import Material, TextureInput, constant_st_transform
from wrt.shade import keep_reflection_above

TILT = math.radians(30.0)  # polar angle of the test map's normal
AZIMUTH = math.radians(40.0)  # its direction in the map's plane, from +X (s) towards +Y (t)
MAP_NORMAL = np.array([math.sin(TILT) * math.cos(AZIMUTH), math.sin(TILT) * math.sin(AZIMUTH), math.cos(TILT)])


def map_bytes(normal) -> np.ndarray:
    """The 8-bit texel storing tangent-space ``normal`` as ``(n + 1) / 2``."""
    return np.round((np.asarray(normal) + 1.0) * 127.5).astype(np.uint8)


def stored_normal(normal) -> np.ndarray:
    """The unit normal the texel of ``normal`` decodes to with scale 2 and bias -1 (the 8-bit rounding included)."""
    n = map_bytes(normal) / 255.0 * 2.0 - 1.0
    return n / np.linalg.norm(n)


def write_normal_map(path, normal) -> str:
    """A 4 x 4 PNG whose every texel stores ``normal``."""
    PilImage.fromarray(np.broadcast_to(map_bytes(normal), (4, 4, 3)).copy()).save(path)
    return str(path)


def normal_mapped_stage(tmp_path, png, left_handed=False, swap_st=False, rotation=None, xform=None,
                        scale_bias=True):
    """A 2 x 2 quad in the z = 0 plane, front +Z, ``st`` = ``(x, y) / 2 + 0.5`` (or swapped), whose material reads
    ``png`` as its normal map (raw, scale 2, bias -1), optionally through a ``UsdTransform2d`` of ``rotation``
    degrees; ``xform`` is a ``(scale, rotateZ degrees)`` pair for the mesh."""
    path = str(tmp_path / f"nm{len(list(tmp_path.glob('*.usda')))}.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    if left_handed:  # clockwise seen from +Z: the front is still +Z
        corners = corners[::-1]
        mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(x, y, 0) for x, y in corners]))
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateDoubleSidedAttr(True)
    st = [((y if swap_st else x) + 1) / 2 for x, y in corners], [((x if swap_st else y) + 1) / 2 for x, y in corners]
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec2fArray([Gf.Vec2f(s, t) for s, t in zip(*st)]))
    if xform is not None:
        scale, degrees = xform
        api = UsdGeom.XformCommonAPI(mesh)
        api.SetScale(Gf.Vec3f(*scale))
        api.SetRotate(Gf.Vec3f(0, 0, degrees))

    material = UsdShade.Material.Define(stage, "/Looks/Bumpy")
    surface = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set((0.8, 0.8, 0.8))
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    transform = None if rotation is None else {"rotation": rotation}
    tex = UsdShade.Shader.Define(stage, "/Looks/Bumpy/NormalMap")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(*st_source(stage, "/Looks/Bumpy", transform))
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    for wrap in ("wrapS", "wrapT"):  # a rotation moves st outside [0, 1]; unauthored, the map would be black there
        tex.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("repeat")
    if scale_bias:
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set((2, 2, 2, 1))
        tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set((-1, -1, -1, 0))
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.Save()
    return path


def aovs(scene, eye=(0, 0, 5), accel="wrt", res=4, integrator="normals"):
    """The AOVs of an orthographic camera at ``eye`` looking at the origin (its view 1 unit tall: on the quad)."""
    cam = wrt.Camera.orthographic(eye=eye, target=(0, 0, 0), up=(0, 1, 0) if eye[2] else (0, 0, 1), height=1.0)
    return wrt.render(scene, camera=cam, width=res, height=res, device="cpu", integrator=integrator, accel=accel).aovs


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_normal_map_tilts_the_shading_normal(tmp_path, accel):
    """The ``normal`` AOV is the map's normal in the quad's frame (s along +X, t along +Y, front +Z); the geometric
    normal and the albedo stay as they were. The map was ignored: every normal read (0, 0, 1)."""
    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    out = aovs(wrt.load_usd(normal_mapped_stage(tmp_path, png)), accel=accel)
    np.testing.assert_allclose(out["normal"].reshape(-1, 3), np.tile(stored_normal(MAP_NORMAL), (16, 1)), atol=1e-3)
    np.testing.assert_allclose(out["geometric_normal"].reshape(-1, 3), np.tile([0, 0, 1], (16, 1)), atol=1e-6)
    np.testing.assert_allclose(out["albedo"].reshape(-1, 3), 0.8, atol=1e-6)


@pytest.mark.parametrize(
    "case, options, frame",
    [
        # frame: the world directions of the map's +X, +Y and +Z
        ("quad rotated 90 degrees", {"xform": ((1, 1, 1), 90.0)}, [(0, 1, 0), (-1, 0, 0), (0, 0, 1)]),
        ("s and t swapped", {"swap_st": True}, [(0, 1, 0), (1, 0, 0), (0, 0, 1)]),
        ("UsdTransform2d rotation 90", {"rotation": 90.0}, [(0, -1, 0), (1, 0, 0), (0, 0, 1)]),
        ("orientation leftHanded", {"left_handed": True}, [(1, 0, 0), (0, 1, 0), (0, 0, 1)]),
        ("mirrored by scale -1", {"xform": ((-1, 1, 1), 0.0)}, [(-1, 0, 0), (0, 1, 0), (0, 0, 1)]),
    ],
)
def test_tangent_frame_follows_geometry_and_coordinates(tmp_path, case, options, frame):
    """Rotating the quad turns the frame with it; swapped or rotated coordinates move the map's axes to where s
    and t now increase (swapping them mirrors the map: its +Y follows t, not cross(N, T)); a left-handed mesh wound
    the other way is the same surface; a mirrored quad shows the mirrored tilt."""
    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    out = aovs(wrt.load_usd(normal_mapped_stage(tmp_path, png, **options)))
    expected = stored_normal(MAP_NORMAL) @ np.asarray(frame, np.float64)
    np.testing.assert_allclose(out["normal"].reshape(-1, 3), np.tile(expected, (16, 1)), atol=1e-3, err_msg=case)


def test_back_side_sees_the_map_about_its_own_normal(tmp_path):
    """Seen from behind (a double-sided quad), the map's +Z is the normal facing the viewer and its +X, +Y still
    follow s and t, as Storm's normal mapping does: the bumps stand out on both sides."""
    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    out = aovs(wrt.load_usd(normal_mapped_stage(tmp_path, png)), eye=(0, 0, -5))
    x, y, z = stored_normal(MAP_NORMAL)
    np.testing.assert_allclose(out["normal"].reshape(-1, 3), np.tile([x, y, -z], (16, 1)), atol=1e-3)


def test_map_without_scale_and_bias_is_used_as_stored(tmp_path):
    """Without ``scale`` and ``bias`` the texel itself is the normal, as the specification says and Storm does: a
    flat map stored in [0, 1] as (0.5, 0.5, 1) tilts every normal towards +X and +Y."""
    png = write_normal_map(tmp_path / "flat.png", (0.0, 0.0, 1.0))
    out = aovs(wrt.load_usd(normal_mapped_stage(tmp_path, png, scale_bias=False)))
    texel = map_bytes((0.0, 0.0, 1.0)) / 255.0
    np.testing.assert_allclose(out["normal"].reshape(-1, 3), np.tile(texel / np.linalg.norm(texel), (16, 1)),
                               atol=1e-3)


def test_constant_normal_is_ignored_with_a_warning(tmp_path):
    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    path = normal_mapped_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    surface = UsdShade.Shader.Get(stage, "/Looks/Bumpy/Surface")
    surface.GetInput("normal").GetAttr().ClearConnections()
    surface.GetInput("normal").Set(Gf.Vec3f(0.6, 0.0, 0.8))
    stage.Save()
    with pytest.warns(UserWarning, match="constant normal is ignored"):
        scene = wrt.load_usd(path)
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(aovs(scene)["normal"].reshape(-1, 3), np.tile([0, 0, 1], (16, 1)), atol=1e-6)


def quad_mesh(name="/quad", uvs=True) -> wrt.Mesh:
    """The 2 x 2 quad of :func:`normal_mapped_stage` built in Python, material 0, ``st = (x, y) / 2 + 0.5``."""
    points = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
    indices = np.array([[0, 1, 2], [0, 2, 3]])
    st = (points[indices, :2] + 1.0) / 2.0 if uvs else None
    return wrt.Mesh(name, points, indices, [0, 0], double_sided=True, uvs=st, material_ids=[0, 0])


def mapped_material(normal, **fields) -> tuple[Material, np.ndarray]:
    """A material whose normal map stores unit ``normal`` in a float texture (scale 2, bias -1), and the texture;
    Lambertian (no specular lobe) of albedo 0.8 unless ``fields`` say otherwise."""
    texel = np.ones((2, 2, 4), np.float32)
    texel[..., :3] = (np.asarray(normal) + 1.0) / 2.0
    scale, bias = np.array([2, 2, 2, 1], np.float32), np.array([-1, -1, -1, 0], np.float32)
    fields.setdefault("diffuse_color", np.full(3, 0.8, np.float32))
    fields.setdefault("use_specular_workflow", True)  # specularColor 0 and specular_edge 0: Lambertian
    fields.setdefault("specular_edge", 0.0)
    return Material(path="/bumpy", textures={"normal": TextureInput(image=0, scale=scale, bias=bias)}, **fields), texel


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_lambert_shading_follows_the_mapped_normal(integrator):
    """A Lambertian quad (albedo 0.8) under a DistantLight of illuminance E shows ``0.8 E / pi cos`` of the angle
    between the light and the mapped normal (closed form), for lights on either side of it."""
    material, texel = mapped_material(MAP_NORMAL)
    for toward_light in ([0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [-0.6, 0.0, 0.8], [0.0, -0.8, 0.6], [0.3, 0.6, 0.74]):
        to_light = np.asarray(toward_light) / np.linalg.norm(toward_light)
        sun = wrt.DistantLight(direction=-to_light, color=np.full(3, 2.0, np.float32))
        scene = wrt.Scene(meshes=[quad_mesh()], materials=[material], textures=[texel], lights=[sun])
        cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
        img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator=integrator)
        expected = 0.8 * 2.0 / math.pi * max(float(np.dot(MAP_NORMAL, to_light)), 0.0)
        np.testing.assert_allclose(img.rgb, expected, rtol=2e-3, atol=1e-6, err_msg=str(toward_light))


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_mirrored_instance_shows_the_mirrored_tilt(accel):
    """Two instances of a normal-mapped quad, the second mirrored by scale (-1, 1, 1): its normals tilt the other
    way along X (the tangent frame is taken in world space, so the mirroring reaches it)."""
    material, texel = mapped_material(MAP_NORMAL)
    shift = np.eye(4)
    shift[0, 3] = -1.5
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    mirror[0, 3] = 1.5
    instances = wrt.Instances.from_transforms([0, 0], np.stack([shift, mirror]))
    scene = wrt.Scene(prototypes=[wrt.Prototype("/proto", meshes=[quad_mesh()])], instances=instances,
                      materials=[material], textures=[texel])
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    out = wrt.render(scene, camera=cam, width=12, height=6, device="cpu", integrator="normals", accel=accel).aovs
    mirrored = MAP_NORMAL * (-1, 1, 1)
    for k, expected in ((0, MAP_NORMAL), (1, mirrored)):
        normals = out["normal"][out["instance"] == k]
        assert len(normals) > 10
        np.testing.assert_allclose(normals, np.tile(expected, (len(normals), 1)), atol=1e-3)


def test_quad_without_texture_coordinates_keeps_its_normal():
    """No ``st`` (all zero: no area in texture space): the frame is undefined and the normal stays the surface's."""
    material, texel = mapped_material(MAP_NORMAL)
    scene = wrt.Scene(meshes=[quad_mesh(uvs=False)], materials=[material], textures=[texel])
    np.testing.assert_allclose(aovs(scene)["normal"].reshape(-1, 3), np.tile([0, 0, 1], (16, 1)), atol=1e-6)


def rotation(axis, degrees) -> np.ndarray:
    """``(3, 3)`` float64 rotation by ``degrees`` about ``axis`` (Rodrigues' formula)."""
    k = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return c * np.eye(3) + s * cross + (1 - c) * np.outer(k, k)


def constant_st_material() -> tuple[Material, np.ndarray]:
    """:func:`mapped_material` of the tilted map read at the constant ``st`` (0.5, 0.5)."""
    material, texel = mapped_material(MAP_NORMAL)
    material.textures["normal"].transform = constant_st_transform(np.eye(3), (0.5, 0.5))
    material.textures["normal"].uv_set = None
    return material, texel


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_map_read_at_a_constant_st_keeps_the_normal_as_storm_does(tmp_path, integrator):
    """A normal map read at a constant ``st`` has no tangent directions (dp/ds, dp/dt are zero): Storm's
    UsdPreviewSurface builds ``T`` from the screen derivatives of ``st``, so ``T = B = 0`` and ``normalize(TBN n)``
    is the surface normal, as wrt keeps it for any triangle whose ``st`` have no area. It was tilted in a frame built
    about the world-space normal, whose azimuth turned with the object. Lit along the quad's normal the Lambertian
    quad shows ``0.8 E / pi`` (closed form), and the ``normal`` AOV of the stage with the UsdUVTexture's ``st``
    authored as a constant is the quad's +Z."""
    material, texel = constant_st_material()
    sun = wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 2.0, np.float32))
    scene = wrt.Scene(meshes=[quad_mesh(uvs=False)], materials=[material], textures=[texel], lights=[sun])
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator=integrator)
    np.testing.assert_allclose(img.rgb, 0.8 * 2.0 / math.pi, rtol=2e-3)

    path = normal_mapped_stage(tmp_path, write_normal_map(tmp_path / "tilt.png", MAP_NORMAL))
    stage = Usd.Stage.Open(path)
    st_input = UsdShade.Shader.Get(stage, "/Looks/Bumpy/NormalMap").GetInput("st")
    st_input.DisconnectSource()
    st_input.Set(Gf.Vec2f(0.5, 0.5))
    stage.Save()
    normals = aovs(wrt.load_usd(path))["normal"].reshape(-1, 3)
    np.testing.assert_allclose(normals, np.tile([0, 0, 1], (16, 1)), atol=1e-6)


@pytest.mark.parametrize("axis, degrees", [((0, 0, 1), 90.0), ((1, 2, 3), 70.0)], ids=["about z", "oblique"])
def test_a_rotated_constant_st_instance_shades_as_the_scene_rotated(axis, degrees):
    """The quad under a constant-``st`` normal map, lit from an oblique sun and seen from +Z, then the same as an
    instance rotated by R (and a flattened copy rotated by R), with the camera and the sun turned by R: the normals
    are R times the first render's and every pixel the same, which is the Lambert value ``0.8 E / pi cos`` of the
    sun's angle to the quad's own normal. The tilt's frame was built about the world-space normal, so the rotated
    instance's normals (and its shading) turned differently from the quad."""
    r = rotation(axis, degrees)
    to_world = np.eye(4)
    to_world[:3, :3] = r
    material, texel = constant_st_material()
    to_light = np.array([0.3, 0.6, 0.74]) / np.linalg.norm([0.3, 0.6, 0.74])

    def render(scene_kwargs, turn):
        sun = wrt.DistantLight(direction=-(turn @ to_light), color=np.full(3, 2.0, np.float32))
        scene = wrt.Scene(materials=[material], textures=[texel], lights=[sun], **scene_kwargs)
        cam = wrt.Camera.orthographic(eye=turn @ [0, 0, 5], target=(0, 0, 0), up=turn @ [0, 1, 0], height=1.0)
        return wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="whitted")

    plain = render({"meshes": [quad_mesh(uvs=False)]}, np.eye(3))
    instanced = render({"prototypes": [wrt.Prototype("/proto", meshes=[quad_mesh(uvs=False)])],
                        "instances": wrt.Instances.from_transforms([0], to_world[None])}, r)
    flat = quad_mesh(uvs=False)
    flat.points = flat.points @ r.T
    flattened = render({"meshes": [flat]}, r)
    for turned in (instanced, flattened):
        np.testing.assert_allclose(turned.aovs["normal"], plain.aovs["normal"] @ r.T, atol=1e-5)
        np.testing.assert_allclose(turned.rgb, plain.rgb, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(plain.rgb, 0.8 * 2.0 / math.pi * float(to_light[2]), rtol=2e-3)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_normal_tilted_away_from_a_grazing_viewer_gives_no_black_pixels(integrator):
    """A map tilted 50 degrees towards +X seen at 80 degrees from -X, lit from the camera: the mapped normal faces
    away from the viewer (dot -0.64), which made the BSDF zero. The normal is bent back towards the surface's until
    the view's mirror direction lies above it; every pixel is lit, finite and below the flat quad's value."""
    tilt = np.radians(50.0)
    material, texel = mapped_material([np.sin(tilt), 0.0, np.cos(tilt)])
    view = np.radians(80.0)
    to_eye = np.array([-np.sin(view), 0.0, np.cos(view)])
    sun = wrt.DistantLight(direction=-to_eye, color=np.full(3, 2.0, np.float32))
    scene = wrt.Scene(meshes=[quad_mesh()], materials=[material], textures=[texel], lights=[sun])
    cam = wrt.Camera.orthographic(eye=5 * to_eye, target=(0, 0, 0), up=(0, 0, 1), height=0.15)
    renderer = wrt.Renderer(scene, camera=cam, width=6, height=6, device="cpu", integrator=integrator)
    img = renderer.render(spp=4)
    assert np.all(img.aovs["prim"] >= 0)
    normals = img.aovs["normal"].reshape(-1, 3)
    mirror_directions = 2.0 * (normals @ to_eye)[:, None] * normals - to_eye
    assert np.all(mirror_directions[:, 2] > 0.0)  # above the quad, so also dot(normal, to_eye) > 0
    assert np.all(normals[:, 0] > 0.05)  # still tilted the map's way
    assert np.all(np.isfinite(img.rgb)) and renderer.dropped_samples == 0
    flat = 0.8 * 2.0 / np.pi * np.cos(view)
    assert np.all(img.rgb > 0.05 * flat)
    assert np.all(img.rgb <= flat * 1.001)


def test_white_furnace_with_a_normal_map_stays_at_most_one():
    """A white Lambertian sphere with a strongly tilted normal map under a white dome of radiance 1: shading normals
    lose some light where directions fall between the two hemispheres, but make none (at most 1, never NaN)."""
    rings, segments = 24, 48
    theta = np.linspace(0, np.pi, rings + 1)[:, None]
    phi = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    grid = np.stack(np.broadcast_arrays(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)), -1)
    st = np.stack(np.broadcast_arrays(phi / (2 * np.pi), 1 - theta / np.pi), -1)
    ids = np.arange((rings + 1) * (segments + 1)).reshape(rings + 1, segments + 1)
    a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    points = grid.reshape(-1, 3)
    material, texel = mapped_material([np.sin(np.radians(45)), 0.0, np.cos(np.radians(45))],
                                      diffuse_color=np.ones(3, np.float32))
    sphere = wrt.Mesh("/sphere", points, tris, np.arange(len(tris)), normals=points[tris].astype(np.float32),
                      uvs=st.reshape(-1, 2)[tris], material_ids=np.zeros(len(tris), np.int32))
    scene = wrt.Scene(meshes=[sphere], materials=[material], textures=[texel],
                      lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.orthographic(eye=(0, 0, 4), target=(0, 0, 0), height=2.2)
    renderer = wrt.Renderer(scene, camera=cam, width=24, height=24, device="cpu", integrator="path")
    img = renderer.render(spp=16)
    hit = img.aovs["prim"] >= 0
    mapped = img.aovs["normal"][hit]
    assert np.mean(np.abs(np.sum(mapped * img.aovs["geometric_normal"][hit], -1) - 1.0) > 0.1) > 0.5  # bumped
    assert renderer.dropped_samples == 0 and np.all(np.isfinite(img.rgb)) and np.all(img.rgb >= 0.0)
    mean = img.rgb[hit].mean()
    assert 0.75 < mean <= 1.01


@wp.kernel
def keep_reflection_above_kernel(
    normals: wp.array[wp.vec3],
    geometric: wp.array[wp.vec3],
    viewers: wp.array[wp.vec3],
    # outputs
    out: wp.array[wp.vec3],
):
    i = wp.tid()
    out[i] = keep_reflection_above(normals[i], geometric[i], viewers[i])


def test_bent_normals_reflect_every_view_above_the_surface():
    """Random shading normals (also below the surface), geometric normals and viewers on their side: the result is
    a unit vector on the geometric side whose mirror direction of the viewer lies above the surface, by at least
    ``min(0.9 cos, 0.01)`` of the viewer's own cosine (a lower rim would send mirror rays along the surface); a
    normal that already does so is returned unchanged."""
    rng = np.random.default_rng(123)

    def unit(v):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    n = 20000
    ng = unit(rng.normal(size=(n, 3)))
    wo = unit(rng.normal(size=(n, 3)))
    wo *= np.sign(np.sum(wo * ng, -1))[:, None]
    wo[: n // 4] = unit(wo[: n // 4] - 0.999 * np.sum(wo[: n // 4] * ng[: n // 4], -1)[:, None] * ng[: n // 4])
    ns = unit(rng.normal(size=(n, 3)))
    arrays = [wp.array(x.astype(np.float32), dtype=wp.vec3, device="cpu") for x in (ns, ng, wo)]
    out = wp.empty(n, dtype=wp.vec3, device="cpu")
    wp.launch(keep_reflection_above_kernel, n, inputs=arrays, outputs=[out], device="cpu")
    bent = out.numpy().astype(np.float64)
    assert np.all(np.isfinite(bent))
    np.testing.assert_allclose(np.linalg.norm(bent, axis=-1), 1.0, atol=1e-5)
    assert np.all(np.sum(bent * ng, -1) >= -1e-6)
    cos_o = np.sum(wo * ng, -1)
    reflected = 2.0 * np.sum(bent * wo, -1)[:, None] * bent - wo
    assert np.all(np.sum(reflected * ng, -1) > 0.0)
    # float32 rounding of the nearly vertical normals that the most grazing views (cos_o < 0.004) get
    assert np.all(np.sum(reflected * ng, -1) >= np.minimum(0.9 * cos_o, 0.01) - 1e-3)
    assert np.all(np.sum(bent * wo, -1) > 0.0)
    valid = (np.sum(ns * ng, -1) >= 0) & (np.sum((2 * np.sum(ns * wo, -1)[:, None] * ns - wo) * ng, -1)
                                          >= np.minimum(0.9 * cos_o, 0.01) + 1e-4)
    assert 0.1 < valid.mean() < 0.9
    np.testing.assert_allclose(bent[valid], ns[valid], atol=1e-6)


def test_a_mesh_frame_that_is_no_bool_names_the_material():
    """``TextureInput.mesh_frame`` (a normal map's frame from the untransformed st, MaterialX's) takes a bool; any
    other value is a TypeError naming the material and input, as the other fields' checks are."""
    with pytest.raises(TypeError, match=r"material /bumpy: normal: mesh_frame must be a bool, got str 'yes'"):
        Material(path="/bumpy", textures={"normal": TextureInput(image=0, mesh_frame="yes")})
    assert Material(path="/bumpy", textures={"normal": TextureInput(image=0, mesh_frame=True)}).textures[
        "normal"].mesh_frame
