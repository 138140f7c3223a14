"""Scenes of many lights: a light inside a PointInstancer's prototype is read from USD once and copied to every
instance, a light texture file is read once however many lights name it, and ``whitted`` lights many lights per launch.

Oracles: the lights read one by one (``read_light`` at each instance's transform, the per-light path, compared field
by field and bit for bit, warnings too), and USD itself (each light authored by hand at the world matrix USD computes
per instance, as ``test_point_instanced_lights`` does); images against the sum of one-light images (light transport
is linear, and point lights draw no random numbers), and bit for bit whatever the number of lights per launch."""

import copy
import dataclasses
import importlib
import math
import operator
import warnings

import numpy as np
import warp as wp
from pxr import Gf, Sdf, UsdGeom, UsdLux
from shading_helpers import quad
from test_point_instanced_lights import T, assert_same_light, author_by_hand, new_stage, usd_placed_lights

import wrt
import wrt.integrators.whitted as whitted
import wrt.textures
import wrt.usd_point_instancer
from wrt.affine_lights import right_angled, similar
from wrt.errors import SceneError
from wrt.image import write_srgb_png
from wrt.lights import RectLight, SphereLight
from wrt.materials import Material
from wrt.usd_placed_lights import placed_lights


def write_texture(path):
    rng = np.random.default_rng(123)
    write_srgb_png(path, rng.integers(30, 256, (4, 6, 3)).astype(np.uint8))


def lamp(stage, root, texture, kinds="all"):
    """A lamp prototype at ``root``: a normalized, shaped SphereLight and a normalized, textured, light-linked
    RectLight; with ``kinds="all"`` also a point-like SphereLight, a DiskLight, a CylinderLight, a normalized
    SphereLight small enough for float32 to lose its radiance at some instances, and a DistantLight."""
    UsdGeom.Xform.Define(stage, root).AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 0.2))
    bulb = UsdLux.SphereLight.Define(stage, f"{root}/Bulb")
    bulb.CreateRadiusAttr(0.05)
    bulb.CreateIntensityAttr(30.0)
    bulb.CreateNormalizeAttr(True)
    UsdLux.ShapingAPI.Apply(bulb.GetPrim()).CreateShapingConeAngleAttr(60.0)
    UsdGeom.Xformable(bulb).AddRotateXOp().Set(30.0)
    panel = UsdLux.RectLight.Define(stage, f"{root}/Panel")
    panel.CreateWidthAttr(0.3)
    panel.CreateHeightAttr(0.2)
    panel.CreateIntensityAttr(4.0)
    panel.CreateNormalizeAttr(True)
    panel.CreateTextureFileAttr(Sdf.AssetPath(texture))
    UsdLux.LightAPI(panel).GetLightLinkCollectionAPI().CreateExcludesRel().AddTarget("/Wall")
    UsdGeom.Xformable(panel).AddTranslateOp().Set(Gf.Vec3d(0.1, 0.0, 0.3))
    if kinds != "all":
        return
    point = UsdLux.SphereLight.Define(stage, f"{root}/Point")
    point.CreateTreatAsPointAttr(True)
    point.CreateColorAttr(Gf.Vec3f(1.0, 0.5, 0.2))
    UsdLux.DiskLight.Define(stage, f"{root}/Disk").CreateRadiusAttr(0.1)
    tube = UsdLux.CylinderLight.Define(stage, f"{root}/Tube")
    tube.CreateLengthAttr(0.5)
    tube.CreateRadiusAttr(0.02)
    tube.CreateNormalizeAttr(True)
    speck = UsdLux.SphereLight.Define(stage, f"{root}/Speck")  # radiance 1 / (4 pi r^2): past float32 when scaled
    speck.CreateRadiusAttr(1e-19)
    speck.CreateNormalizeAttr(True)
    UsdLux.DistantLight.Define(stage, f"{root}/Sun").CreateAngleAttr(0.0)


def scales(n: int) -> np.ndarray:
    """``(n, 3)`` instance scales: even ones, and (every third) uneven, sheared-by-rotation ones, scales just
    inside and outside the 1e-4 tolerance of a round sphere, a zero scale, tiny and huge ones."""
    rng = np.random.default_rng(7)
    out = np.repeat(rng.uniform(0.5, 2.0, (n, 1)), 3, axis=1)
    out[::3] = rng.uniform(0.5, 2.0, (len(out[::3]), 3))
    special = [(1.0, 1.0, 1.0 + 0.4e-4), (1.0, 1.0, 1.0 + 0.6e-4), (1.0, 1.0, 1.0 + 3e-4), (0.0, 1.0, 1.0),
               (1e-12, 1e-12, 1e-12), (1e30, 1e30, 1e30), (1.0, 1.0, 1.0)]
    out[1 : 1 + len(special)] = special
    return out


def instanced_stage(path, n: int, kinds="all", even=False):
    """A stage of a PointInstancer of ``n`` lamps (:func:`lamp`), turned every way and scaled by :func:`scales` (or
    only scaled evenly, ``even``), with the instancer itself moved and turned."""
    write_texture(path.parent / "glow.png")
    stage = new_stage(path)
    lamp(stage, "/Lamps/Protos/Lamp", "glow.png", kinds)
    pi = UsdGeom.PointInstancer.Define(stage, "/Lamps")
    pi.CreatePrototypesRel().SetTargets([Sdf.Path("/Lamps/Protos/Lamp")])
    pi.CreateProtoIndicesAttr([0] * n)
    rng = np.random.default_rng(11)
    pi.CreatePositionsAttr(rng.uniform(-3.0, 3.0, (n, 3)) + (0.0, 0.0, 2.0))
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    if not even:  # half-precision quaternions: turned spheres are ellipsoids to 1e-4 (read_light's tolerance)
        pi.CreateOrientationsAttr([Gf.Quath(*row) for row in q])
    pi.CreateScalesAttr(np.full((n, 3), 1.5) if even else scales(n))
    UsdGeom.Xformable(pi).AddTranslateOp().Set(Gf.Vec3d(0.2, -0.1, 0.05))
    UsdGeom.Xformable(pi).AddRotateZOp().Set(25.0)
    stage.Save()
    return stage, pi.GetPrim()


def read_one_by_one(to_worlds, names, read, skip_path, sphere_inputs):
    """The per-light path: ``read_light`` at each instance's transform, as wrt read these lights before."""
    lights = []
    for m, name in zip(to_worlds, names):
        light = read(m, lambda reason, _, detail=None, name=name: skip_path(reason, name, detail))
        if light is not None:
            light.path = name
        lights.append(light)
    return lights


def load(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(path))
    return scene, [str(w.message) for w in caught]


def assert_identical(a, b):
    """Lights ``a`` and ``b`` agree in every field, bit for bit (arrays in dtype and shape too)."""
    assert type(a) is type(b), (a, b)
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if dataclasses.is_dataclass(x) and not isinstance(x, type):
            assert_identical(x, y)
        elif isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert isinstance(x, np.ndarray) and isinstance(y, np.ndarray), (a.path, field.name)
            assert x.dtype == y.dtype and np.array_equal(x, y), (a.path, field.name, x, y)
        else:
            assert type(x) is type(y) and x == y, (a.path, field.name, x, y)


def test_placed_lights_are_the_lights_read_one_by_one(tmp_path, monkeypatch):
    stage, instancer = instanced_stage(tmp_path / "lamps.usda", 40)
    placed, messages = load(tmp_path / "lamps.usda")
    monkeypatch.setattr(wrt.usd_point_instancer, "placed_lights", read_one_by_one)
    one_by_one, expected_messages = load(tmp_path / "lamps.usda")
    assert messages == expected_messages
    # The instance scaled by 1e30: its area lights, 1e29 wide or less, fit float32's lengths (sampled in lengths
    # scaled per light since 8f7db73, they are kept); its point sphere's intensity pi r^2 L does not: skipped and
    # named, both ways alike.
    huge = [m for m in messages if "to fit in float32 were skipped" in m]
    assert len(huge) == 1 and "1 prim(s)" in huge[0] and "/Lamps/Protos/Lamp/Point[6]" in huge[0], huge
    assert len(placed.lights) == len(one_by_one.lights) == 7 * 40 - 1
    assert [light.path for light in placed.lights] == [light.path for light in one_by_one.lights]
    for a, b in zip(placed.lights, one_by_one.lights):
        assert_identical(a, b)
    kinds = {type(light).__name__ for light in placed.lights}
    assert kinds == {"SphereLight", "RectLight", "DiskLight", "CylinderLight", "DistantLight"}
    assert any(isinstance(light, SphereLight) and light.frame is not None for light in placed.lights)  # ellipsoids
    assert any(light.path.endswith("Speck[5]") and light.treat_as_point for light in placed.lights)
    # And USD's own placement: each light authored by hand at the world matrix USD computes for it.
    world = UsdGeom.XformCache(T).GetLocalToWorldTransform(instancer)
    even = [(p, m) for p, m in usd_placed_lights(stage, instancer, world) if p.GetName() == "Bulb"]
    author_by_hand(tmp_path / "by_hand.usda", even)
    by_hand, _ = load(tmp_path / "by_hand.usda")
    bulbs = [light for light in placed.lights if "/Bulb[" in light.path]
    assert len(bulbs) == len(by_hand.lights) == 40  # the bulb scaled by 1e30 too
    for a, b in zip(bulbs, by_hand.lights):
        if a.frame is None and not a.treat_as_point:  # round spheres, where float64 rounding does not move radiance
            assert_same_light(a, b)


def test_a_prototype_light_is_read_from_usd_once_for_all_its_instances(tmp_path, monkeypatch):
    stage, instancer = instanced_stage(tmp_path / "lamps.usda", 12, kinds="two", even=True)
    calls = []
    read_light = wrt.usd_point_instancer.read_light
    monkeypatch.setattr(wrt.usd_point_instancer, "read_light", lambda prim, *a, **k: (calls.append(prim),
                                                                                      read_light(prim, *a, **k))[1])
    scene, messages = load(tmp_path / "lamps.usda")
    assert len(scene.lights) == 24 and len(calls) == 2  # one read of the bulb, one of the panel: 24 before
    world = UsdGeom.XformCache(T).GetLocalToWorldTransform(instancer)
    author_by_hand(tmp_path / "by_hand.usda", usd_placed_lights(stage, instancer, world))
    by_hand, _ = load(tmp_path / "by_hand.usda")
    placed = {light.path: light for light in scene.lights}
    for k in range(12):
        assert_same_light(placed[f"/Lamps/Protos/Lamp/Bulb[{k}]"], by_hand.lights[2 * k])
        assert_same_light(placed[f"/Lamps/Protos/Lamp/Panel[{k}]"], by_hand.lights[2 * k + 1])


def test_a_light_texture_file_is_read_and_uploaded_once(tmp_path, monkeypatch):
    instanced_stage(tmp_path / "lamps.usda", 12, kinds="two", even=True)
    stage = new_stage(tmp_path / "plain.usda")
    for k in range(3):
        rect = UsdLux.RectLight.Define(stage, f"/Panel{k}")
        rect.CreateTextureFileAttr(Sdf.AssetPath("glow.png"))
        UsdGeom.Xformable(rect).AddTranslateOp().Set(Gf.Vec3d(k, 0.0, 2.0))
    stage.Save()
    reads = []
    load_image = wrt.textures.load_image
    monkeypatch.setattr(wrt.textures, "load_image", lambda *a: (reads.append(a), load_image(*a))[1])
    for name, lights in (("lamps.usda", 12), ("plain.usda", 3)):
        reads.clear()
        scene, _ = load(tmp_path / name)
        panels = [light for light in scene.lights if isinstance(light, RectLight)]
        assert len(panels) == lights and len(reads) == 1, (name, reads)  # one read per light before
        expected = load_image(panels[0].texture_path, "auto")
        for panel in panels:
            np.testing.assert_array_equal(panel.texture, expected)
        renderer = wrt.Renderer(scene, width=4, height=4, device="cpu")
        assert renderer.device_lights.texels.shape[0] == 1 + 4 * 6  # one white texel and the image, packed once
        info = renderer.device_lights.texture.numpy()
        assert len({tuple(row) for row in info[[k for k, light in enumerate(scene.lights)
                                                if isinstance(light, RectLight)]]}) == 1



def test_a_dome_and_a_rect_light_reading_one_image_upload_it_once_as_the_estimate_counts_it(tmp_path):
    """A DomeLight and a RectLight reading one file share its image, which the memory estimate
    (``device_texture_bytes``) counts once; the dome's texels were made apart from the rect light's memoised ones, so
    the image was uploaded twice. The oracle is the image's texel count, read with numpy."""
    write_texture(tmp_path / "glow.png")
    stage = new_stage(tmp_path / "dome.usda")
    UsdLux.DomeLight.Define(stage, "/Sky").CreateTextureFileAttr(Sdf.AssetPath("glow.png"))
    rect = UsdLux.RectLight.Define(stage, "/Panel")
    rect.CreateTextureFileAttr(Sdf.AssetPath("glow.png"))
    UsdGeom.Xformable(rect).AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 2.0))
    stage.Save()
    scene, _ = load(tmp_path / "dome.usda")
    dome, panel = (next(light for light in scene.lights if isinstance(light, kind)) for kind in (wrt.DomeLight,
                                                                                                RectLight))
    assert dome.texture is panel.texture
    height, width = np.shape(dome.texture)[:2]
    renderer = wrt.Renderer(scene, width=4, height=4, device="cpu")
    assert renderer.device_lights.texels.shape[0] == 1 + height * width  # one white texel and the image, once
    counted = wrt.resources.device_texture_bytes(scene) - (height + 1 + height * (width + 1)) * 4  # less the CDFs
    image_bytes = renderer.device_lights.texels.shape[0] * 12 - 12  # vec3 texels, less the white one
    material_bytes = 8 + 4 + 8 + 16  # no material image: one vec4h texel, its offset, size and vec4 of scales
    assert counted == image_bytes + material_bytes


def floor_and_box(box_material=None):
    """A white floor at z = 0 and a white box hovering over it (geometry for shadows)."""
    floor = quad((0, 0, 0), (8, 0, 0), (0, 8, 0), name="/floor")
    box = [quad((0.3, 0.2, 0.8), (0.8, 0, 0), (0, 0.8, 0), name="/box", material=box_material)]
    return [floor] + box


def point_lights(count: int) -> list:
    rng = np.random.default_rng(5)
    lights = [SphereLight(position=rng.uniform((-2, -2, 1), (2, 2, 3)), radius=0.1, color=rng.uniform(0.2, 2.0, 3),
                          treat_as_point=True, path=f"/P{k}") for k in range(count)]
    lights.append(wrt.DistantLight(direction=np.array([0.2, 0.3, -1.0]), color=np.array([0.5, 0.4, 0.3]),
                                   angle=0.0, path="/Sun"))
    return lights


CAMERA = wrt.Camera.look_at((0.5, -4.0, 4.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), fov_y_deg=50.0)


def test_whitted_image_of_many_point_lights_is_the_sum_of_one_light_images():
    lights = point_lights(14)
    scene = wrt.Scene(meshes=floor_and_box(), lights=lights)
    image = wrt.render(scene, camera=CAMERA, width=24, height=24, spp=1, device="cpu", integrator="whitted").rgb
    total = np.zeros_like(image)
    for light in lights:
        one = wrt.Scene(meshes=floor_and_box(), lights=[light])
        total += wrt.render(one, camera=CAMERA, width=24, height=24, spp=1, device="cpu", integrator="whitted").rgb
    assert image.mean() > 0.05
    np.testing.assert_allclose(image, total, rtol=1e-5, atol=1e-6)


def area_light_scene():
    """Sphere, textured rect, disk and cylinder lights, one of them shadow-linked, a glowing quad (emissive
    triangles: one light group) and a box of a cut-out material over a floor."""
    rng = np.random.default_rng(9)
    lights = []
    for k in range(5):
        m = np.eye(4)
        m[:3, 3] = rng.uniform((-2, -2, 1.5), (2, 2, 2.5))
        lights += [SphereLight(position=m[:3, 3].copy(), radius=0.2, color=np.full(3, 2.0), path=f"/S{k}"),
                   RectLight(to_world=m, width=0.5, height=0.3, color=np.full(3, 3.0), path=f"/R{k}",
                             texture=rng.uniform(0.0, 1.0, (3, 5, 3)).astype(np.float32)),
                   wrt.DiskLight(to_world=m, radius=0.2, color=np.full(3, 2.0), path=f"/D{k}"),
                   wrt.CylinderLight(to_world=m, length=0.5, radius=0.05, color=np.full(3, 2.0), path=f"/C{k}")]
    lights[0].shadow_link = wrt.LinkCollection.explicit("/floor")  # the box casts none of its shadow
    glow = quad((-1.5, 1.5, 1.2), (0.5, 0, 0), (0, 0.5, 0), name="/glow", material=1)
    materials = [Material(diffuse_color=0.8, opacity=0.3, opacity_threshold=0.5),
                 Material(diffuse_color=0.0, emissive_color=(2.0, 1.5, 1.0))]
    return wrt.Scene(meshes=floor_and_box(box_material=0) + [glow], lights=lights, materials=materials)


def test_whitted_image_is_the_same_whatever_the_lights_per_launch(monkeypatch):
    scene = area_light_scene()
    images = []
    for lights_per_launch in (1, 3, 100):
        monkeypatch.setattr(whitted, "SHADOW_RAYS_PER_BATCH", lights_per_launch * 16 * 16 * 2)
        renderer = wrt.Renderer(scene, camera=CAMERA, width=16, height=16, device="cpu", integrator="whitted")
        images.append(renderer.render(spp=2, seed=4).rgb)
    assert images[0].mean() > 0.05
    np.testing.assert_array_equal(images[1], images[0])  # one light per launch: as wrt lit them before
    np.testing.assert_array_equal(images[2], images[0])


def test_whitted_launches_do_not_grow_with_the_number_of_lights(monkeypatch):
    launches = []
    launch = wp.launch
    monkeypatch.setattr(wp, "launch", lambda kernel, *a, **k: (launches.append(kernel.key), launch(kernel, *a, **k)))
    counts = []
    for count in (2, 30):
        scene = wrt.Scene(meshes=floor_and_box(), lights=point_lights(count))
        renderer = wrt.Renderer(scene, camera=CAMERA, width=8, height=8, device="cpu", integrator="whitted")
        launches.clear()
        renderer.render(spp=1)
        counts.append(len(launches))
    assert counts[0] == counts[1], counts  # 30 lights: 3 launches more per light and bounce before


def test_check_fields_takes_a_float_as_float32_and_the_minimum_do():
    """The float fast path of ``check_fields`` (plain lights are read faster) refuses what numpy's path refuses."""
    edge = 2.0**128 - 2.0**103  # float32 rounds this and above to infinity
    values = [0.0, -0.0, 1e-300, 1.5, edge, np.nextafter(edge, 0.0), -edge, math.inf, -math.inf, math.nan, -1e-300]
    for value in values:
        with np.errstate(over="ignore"):
            finite = bool(np.isfinite(np.float32(value)))
        ok = finite and value >= 0.0
        try:
            light = SphereLight(position=np.zeros(3), radius=float(value), color=np.ones(3))
        except SceneError:
            assert not ok, value
        else:
            assert ok and type(light.radius) is float and light.radius == value, value


def test_check_fields_takes_small_float_arrays_as_numpy_does():
    """The array fast path of ``check_fields`` (a light's position, colour and axis) accepts exactly the arrays whose
    values are finite in float32 and not below the minimum, and stores them as the field's dtype, equal to numpy's
    conversion, as a new array, for float32 and float64 input alike."""
    edge = 2.0**128 - 2.0**103  # float32 rounds this and above to infinity
    values = [0.0, -0.0, 1e-300, 1.5, edge, np.nextafter(edge, 0.0), -edge, math.inf, math.nan, -1e-300, -2.0]
    for dtype in (np.float64, np.float32):
        for value in values:
            color = np.array([0.5, value, 2.0], dtype)
            with np.errstate(over="ignore"):
                ok = bool(np.all(np.isfinite(color.astype(np.float32))) and np.all(color.astype(np.float64) >= 0.0))
            try:
                light = SphereLight(position=color.copy(), radius=0.1, color=color)
            except SceneError:
                assert not ok, (dtype, value)
                continue
            assert ok, (dtype, value)
            assert light.color.dtype == np.float32 and light.color is not color
            np.testing.assert_array_equal(light.color, color.astype(np.float64).astype(np.float32))
            assert light.position.dtype == np.float64
            np.testing.assert_array_equal(light.position, color.astype(np.float64))


def test_similar_is_numpys_allclose_of_the_column_lengths_and_right_angles():
    rng = np.random.default_rng(3)
    for _ in range(3000):
        m = np.diag(1.0 + rng.uniform(-2e-4, 2e-4, 3)) * 10.0 ** rng.integers(-30, 30)
        m = m @ np.linalg.qr(rng.normal(size=(3, 3)))[0] if rng.uniform() < 0.5 else m
        lengths = np.linalg.norm(m, axis=0)
        # atol=0: relative alone, as bc9c79b made it (allclose's 1e-8 took any frame below 1e-8 for an even one)
        expected = np.allclose(lengths, lengths.mean(), rtol=1e-4, atol=0.0) and right_angled(*m.T)
        assert similar(m) == expected
    infinite = np.diag([np.inf, np.inf, np.inf])  # lengths np.allclose takes as equal
    with np.errstate(invalid="ignore"):
        assert similar(infinite) == (np.allclose([np.inf] * 3, np.inf) and right_angled(*infinite.T))


def device_bytes(*objects) -> int:
    """Bytes of the Warp arrays held by ``objects`` (their attributes, one level down)."""
    arrays = [v for o in objects for v in vars(o).values() if isinstance(v, wp.array)]
    return sum(a.capacity for a in arrays)


def test_the_memory_check_counts_whitteds_shadow_rays_of_several_lights(monkeypatch):
    asked = []
    render_module = importlib.import_module("wrt.render")  # wrt.render is the function
    monkeypatch.setattr(render_module, "check_memory", lambda needed, *a, **k: asked.append(needed))
    scene = wrt.Scene(meshes=floor_and_box(), lights=point_lights(30))
    renderer = wrt.Renderer(scene, camera=CAMERA, width=8, height=8, device="cpu", integrator="whitted")
    renderer.render(spp=1)
    w = renderer._wavefront
    batch = w.batch  # 31 lights per launch
    assert batch is not None and len(batch.origins) == 31 * 64
    wavefront = device_bytes(w, w.hits, w.scratch, w.scratch.hits)
    assert asked[-1] >= wavefront + device_bytes(batch, batch.scratch, batch.scratch.hits)


def test_a_light_with_no_instances_places_none():
    assert placed_lights(np.zeros((0, 4, 4)), [], None, None, None) == []


def reference_input_reader(prim, time):
    """The light input reader as it was (every input's ``HasAuthoredValue`` asked twice, every old name looked up):
    the slow reference the faster one must agree with on inputs of the schema's types (none mistyped)."""
    from wrt.usd_lights import INPUTS_PREFIX
    from wrt.usd_values import value_at

    legacy, read_from = [], {}

    def get(attr, default):
        name = attr.GetName() if attr is not None else ""
        if name.startswith(INPUTS_PREFIX) and not (attr and attr.HasAuthoredValue()):
            old = prim.GetAttribute(name[len(INPUTS_PREFIX):])
            if old and old.HasAuthoredValue():
                if old.GetName() not in legacy:
                    legacy.append(old.GetName())
                attr = old
        if attr and attr.HasAuthoredValue():
            read_from[name] = attr  # the attribute whose colorSpace the value takes
        value = value_at(attr, time) if attr else None
        return default if value is None else value

    return get, legacy, [], [], read_from


def test_plain_lights_are_the_lights_the_reference_reader_reads(tmp_path, monkeypatch):
    """Lights with old unprefixed inputs (alone, and beside an authored prefixed one), time samples only, blocked
    values, ShadowAPI and shaping inputs, a mesh light on a Sphere (whose schema defines ``radius``) read as the
    reference reader of every input reads them, field by field and bit for bit, warnings too."""
    stage = new_stage(tmp_path / "plain.usda")
    old = UsdLux.SphereLight.Define(stage, "/Old")
    old.GetPrim().CreateAttribute("intensity", Sdf.ValueTypeNames.Float).Set(7.0)
    old.GetPrim().CreateAttribute("radius", Sdf.ValueTypeNames.Float).Set(0.25)
    old.GetPrim().CreateAttribute("shaping:cone:angle", Sdf.ValueTypeNames.Float).Set(40.0)
    both = UsdLux.DiskLight.Define(stage, "/Both")
    both.CreateColorAttr(Gf.Vec3f(0.2, 0.4, 0.8))
    both.GetPrim().CreateAttribute("color", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1.0, 0.0, 0.0))
    both.GetPrim().CreateAttribute("exposure", Sdf.ValueTypeNames.Float).Set(1.0)
    sampled = UsdLux.RectLight.Define(stage, "/Sampled")
    sampled.CreateWidthAttr().Set(2.0, 3.0)
    sampled.CreateIntensityAttr().Set(5.0, 1.0)
    sampled.CreateHeightAttr().Block()
    shadowed = UsdLux.SphereLight.Define(stage, "/Shadowed")
    UsdLux.ShadowAPI.Apply(shadowed.GetPrim()).CreateShadowColorAttr(Gf.Vec3f(0.5, 0.0, 0.0))
    shadowed.CreateDiffuseAttr(0.5)
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr(0.5)
    UsdLux.MeshLightAPI.Apply(ball.GetPrim())
    ball.GetPrim().CreateAttribute("intensity", Sdf.ValueTypeNames.Float).Set(3.0)
    stage.Save()
    fast, fast_messages = load(tmp_path / "plain.usda")
    monkeypatch.setattr(wrt.usd_lights, "input_reader", reference_input_reader)
    slow, slow_messages = load(tmp_path / "plain.usda")
    assert fast_messages == slow_messages and any("inputs: prefix" in m for m in fast_messages)
    assert [light.path for light in fast.lights] == [light.path for light in slow.lights]
    assert len(fast.lights) == 5
    for a, b in zip(fast.lights, slow.lights):
        assert_identical(a, b)
    assert fast.lights[[light.path for light in fast.lights].index("/Old")].radius == 0.25


def test_dataclass_parts_walks_the_fields_as_dataclasses_does():
    """:func:`wrt.scene.dataclass_parts` (field names looked up once per class) lists each light and then its fields'
    values depth first, nested dataclasses (a shaping, a link collection) walked too, as the walk by
    ``dataclasses.is_dataclass`` and ``fields`` on every value lists them; a class given as a value is a value."""
    from wrt.light_shaping import Shaping
    from wrt.scene import dataclass_parts

    def reference(objects):
        parts = []
        for obj in objects:
            parts.append(obj)
            if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
                parts += reference([getattr(obj, f.name) for f in dataclasses.fields(obj)])
        return parts

    lights = [wrt.SphereLight(position=(0, 0, 1), radius=0.5, color=np.ones(3), shaping=Shaping(cone_angle=30.0),
                              light_link=wrt.LinkCollection.excluding("/a")),
              wrt.DistantLight(direction=(0, 0, -1), color=np.ones(3)), Shaping, 3.0, None]
    got, expected = dataclass_parts(lights), reference(lights)
    assert len(got) == len(expected) > 40 and all(map(operator.is_, got, expected))


def test_shallow_copies_of_a_light_made_from_lists_share_its_checked_arrays():
    """A sun made from a tuple direction is given arrays of its own by its check; 1000 shallow copies of it checked
    again (as a render does) keep sharing them, as copies of one made from arrays do. Before, each copy's check
    converted the direction again: 2**18 copies held 2**18 arrays (and froze each of them with a finalizer)."""
    sun = wrt.DistantLight(direction=(0, 0, -1), color=(1.0, 1.0, 1.0))
    copies = [copy.copy(sun) for _ in range(1000)]
    for light in copies:
        light.__post_init__()
    assert {id(light.direction) for light in copies} == {id(sun.direction)}
    assert {id(light.color) for light in copies} == {id(sun.color)}
    np.testing.assert_array_equal(copies[-1].direction, np.float64([0.0, 0.0, -1.0]))


def test_bsdf_rays_look_for_the_lights_they_can_meet_alone():
    """A BSDF-sampled ray adds the radiance of the area lights it passes through and of the dome and soft suns it
    escapes into; the device lists exactly those (by the lights' Python types, in order) for it to look at, and no
    delta sun, point or line light. Before, each ray looped over every analytic light: 2**18 delta suns made the
    many-light falloff test's 65k samples take a minute, for nothing."""
    from wrt.light_table import build_lights
    from wrt.lights import CylinderLight, DiskLight, DomeLight

    to_world = np.eye(4)
    lights = [wrt.DistantLight(direction=(0, 0, -1), color=np.ones(3)),
              SphereLight(position=(0, 0, 2), radius=0.5, color=np.ones(3)),
              wrt.DistantLight(direction=(0, 0, -1), color=np.ones(3), angle=1.0),
              SphereLight(position=(0, 0, 2), radius=0.5, color=np.ones(3), treat_as_point=True),
              RectLight(to_world=to_world, width=1.0, height=1.0, color=np.ones(3)),
              CylinderLight(to_world=to_world, length=1.0, radius=0.1, color=np.ones(3), treat_as_line=True),
              DomeLight(color=np.ones(3)),
              DiskLight(to_world=to_world, radius=0.5, color=np.ones(3)),
              CylinderLight(to_world=to_world, length=1.0, radius=0.1, color=np.ones(3)),
              wrt.DistantLight(direction=(0, 0, -1), color=np.ones(3))]
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (1, 0, 0), (0, 1, 0))], lights=lights)
    d = build_lights(lights, scene, [np.zeros(3)], "cpu").device_lights
    area = [k for k, light in enumerate(lights) if isinstance(light, (SphereLight, RectLight, DiskLight, CylinderLight))
            and not getattr(light, "treat_as_point", False) and not getattr(light, "treat_as_line", False)]
    sky = [k for k, light in enumerate(lights) if isinstance(light, DomeLight)
           or isinstance(light, wrt.DistantLight) and light.angle > 0.0]
    assert (d.num_segment_lights, d.num_sky_lights) == (len(area), len(sky)) == (4, 2)
    assert d.segment_lights.numpy().tolist() == area and d.sky_lights.numpy().tolist() == sky
