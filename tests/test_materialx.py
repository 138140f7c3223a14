"""MaterialX standard_surface and OpenPBR materials read as wrt materials (wrt/materialx.py): their inputs against
the equivalent UsdPreviewSurface, the specification's defaults, interface inputs, image nodes inside NodeGraphs,
OpenPBR emission and the warning for nodes wrt cannot evaluate. Before wrt/materialx.py they were Lambertian."""

import warnings

import numpy as np
import pytest
from PIL import Image as PilImage
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
from test_materials import add_quad, bind, materialx_preview_stage, new_stage, preview_material
from test_texture_files import srgb_decoded

import wrt
from wrt.textures import srgb_to_linear

STANDARD = "ND_standard_surface_surfaceshader"
OPEN_PBR = "ND_open_pbr_surface_surfaceshader"
GOLD = Gf.Vec3f(1.0, 0.78, 0.34)
TYPES = {Gf.Vec3f: Sdf.ValueTypeNames.Color3f, float: Sdf.ValueTypeNames.Float, int: Sdf.ValueTypeNames.Float}


def mtlx_material(stage, path, shader_id=STANDARD, **inputs):
    """A Material whose ``outputs:mtlx:surface`` is a ``shader_id`` shader with constant ``inputs``."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr(shader_id)
    for name, value in inputs.items():
        shader.CreateInput(name, TYPES[type(value)]).Set(value)
    material.CreateSurfaceOutput("mtlx").ConnectToSource(shader.ConnectableAPI(), "out")
    return material, shader


def load(path):
    """``(scene, warning messages)``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    return scene, [str(w.message) for w in caught]


def lit_sphere_image(tmp_path, make_material, name):
    """Mean colour of the pixels of a sphere bound to ``make_material(stage)`` under a sun and a dome (whitted,
    8 spp)."""
    stage, path = new_stage(tmp_path, f"{name}.usda")
    sphere = UsdGeom.Sphere.Define(stage, "/Ball")
    sun = UsdLux.DistantLight.Define(stage, "/Sun")  # straight down, illuminance 3
    sun.CreateIntensityAttr(3.0)
    sun.CreateNormalizeAttr(True)
    UsdLux.DomeLight.Define(stage, "/Sky").CreateIntensityAttr(0.3)
    bind(sphere, make_material(stage))
    stage.Save()
    scene, _ = load(path)
    cam = wrt.Camera.look_at((0, -2.5, 2.5), (0, 0, 0), (0, 0, 1), 40.0)
    img = wrt.render(scene, camera=cam, width=24, height=24, spp=8, seed=3, device="cpu")
    return img.rgb[img.aovs["depth"] < np.inf].mean(axis=0)


def test_standard_surface_metal_renders_like_the_equivalent_preview_surface(tmp_path):
    """A gold standard_surface metal (metalness 1, roughness 0.2) was drawn as a Lambertian gold, clearly darker
    where the sun's highlight is and brighter elsewhere; now it renders as the UsdPreviewSurface of the same metal."""
    mtlx = lit_sphere_image(tmp_path, lambda s: mtlx_material(s, "/Looks/Gold", base_color=GOLD, metalness=1.0,
                                                              specular_roughness=0.2)[0], "mtlx")
    preview = lit_sphere_image(tmp_path, lambda s: preview_material(s, "/Looks/Gold", diffuseColor=GOLD, metallic=1.0,
                                                                    roughness=0.2)[0], "preview")
    lambert = lit_sphere_image(tmp_path, lambda s: preview_material(
        s, "/Looks/Gold", diffuseColor=GOLD, useSpecularWorkflow=1, specularColor=Gf.Vec3f(0), roughness=1.0)[0],
        "lambert")
    np.testing.assert_allclose(mtlx, preview, rtol=0.01)
    assert np.abs(lambert / preview - 1).max() > 0.1, (lambert, preview)  # what the old fallback drew


def test_specification_defaults_and_approximations(tmp_path):
    """Unauthored inputs take the MaterialX library's defaults (standard_surface 1.0.1 and 1.0.0, OpenPBR 1.1), with
    no warning; approximated inputs are named in one warning per material."""
    stage, path = new_stage(tmp_path)
    looks = {
        "Std": (STANDARD, {}),
        "Std100": ("ND_standard_surface_surfaceshader_100", {}),
        "Pbr": (OPEN_PBR, {}),
        "Glass": (STANDARD, {"specular": 0.0, "transmission": 0.25, "sheen": 0.5}),
        "Leaf": (OPEN_PBR, {"geometry_opacity": 0.3, "coat_weight": 1.0, "coat_roughness": 0.25}),
    }
    for k, (name, (shader_id, inputs)) in enumerate(looks.items()):
        bind(add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0)), mtlx_material(stage, f"/Looks/{name}", shader_id,
                                                                             **inputs)[0])
    stage.Save()
    scene, messages = load(path)
    mats = {m.path.rsplit("/", 1)[1]: m for m in scene.materials}
    for name in ("Std", "Std100"):
        np.testing.assert_allclose(mats[name].diffuse_color, 0.8)  # base 1 x 0.8 (1.0.1), base 0.8 x 1 (1.0.0)
        assert (mats[name].roughness, mats[name].ior, mats[name].clearcoat) == pytest.approx((0.2, 1.5, 0.0))
        assert (mats[name].metallic, mats[name].opacity, mats[name].opacity_threshold) == (0.0, 1.0, 0.0)
    np.testing.assert_allclose(mats["Pbr"].diffuse_color, 0.8)
    assert mats["Pbr"].roughness == pytest.approx(0.3)
    assert not any(f"/Looks/{n}:" in m for m in messages for n in ("Std", "Std100", "Pbr")), messages
    glass, leaf = mats["Glass"], mats["Leaf"]
    assert glass.ior == pytest.approx(1.0)  # specular 0: no dielectric reflection
    assert (glass.opacity, glass.opacity_threshold) == pytest.approx((0.75, 0.0))  # 1 - transmission
    assert (leaf.opacity, leaf.opacity_threshold) == pytest.approx((0.3, 0.5))  # a cut-out: drawn as a hole
    assert (leaf.clearcoat, leaf.clearcoat_roughness) == pytest.approx((1.0, 0.25))
    (glass_warning,) = [m for m in messages if "/Looks/Glass:" in m]
    assert "transmission" in glass_warning and "sheen (0.5) is ignored" in glass_warning
    (leaf_warning,) = [m for m in messages if "/Looks/Leaf:" in m]
    assert "geometry_opacity 0.3 is drawn a hole" in leaf_warning and "coat_ior" not in leaf_warning
    assert leaf.clearcoat_ior == pytest.approx(1.6)  # OpenPBR's default coat_ior, drawn as authored


@pytest.mark.parametrize("shader_id, coat, coat_ior", [(STANDARD, "coat", "coat_IOR"),
                                                      (OPEN_PBR, "coat_weight", "coat_ior")])
@pytest.mark.parametrize("ior", [1.2, 2.0, 3.0])
def test_the_coat_reflects_the_fresnel_reflectance_of_its_index(tmp_path, shader_id, coat, coat_ior, ior):
    """A smooth coat of index ``coat_IOR`` (OpenPBR ``coat_ior``) over a black base (base 0, specular 0: no other
    lobe) under a white dome, seen at normal incidence, shows the coat's F0 ``((1 - ior) / (1 + ior))^2``, as
    MaterialX's graphs make the coat a dielectric of that index. The index was ignored with a note: every coat
    showed 0.04 (index 1.5's), 0.36 of index 3's 0.25."""
    stage, path = new_stage(tmp_path, "coat.usda")
    base = {"base": 0.0} if shader_id == STANDARD else {"base_weight": 0.0}
    specular = {"specular": 0.0} if shader_id == STANDARD else {"specular_weight": 0.0}
    material, _ = mtlx_material(stage, "/Looks/Coat", shader_id, **base, **specular, **{coat: 1.0, coat_ior: ior},
                                coat_roughness=0.0)
    bind(add_quad(stage, "/Quad", size=20.0), material)
    UsdLux.DomeLight.Define(stage, "/Dome")
    stage.Save()
    scene, messages = load(path)
    assert not any(coat_ior in m for m in messages), messages
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="path")
    np.testing.assert_allclose(img.rgb, ((1.0 - ior) / (1.0 + ior)) ** 2, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("shader_id, transmission, thin", [(STANDARD, "transmission", "thin_walled"),
                                                          (OPEN_PBR, "transmission_weight", "geometry_thin_walled")])
def test_a_thin_walled_glass_is_drawn_as_a_thin_sheet(tmp_path, shader_id, transmission, thin):
    """``thin_walled`` (OpenPBR ``geometry_thin_walled``) authored true makes the material's dielectric a thin-walled
    sheet (``Material.thin_walled``, drawn unbent: see tests/test_integrators.py) and its warning says so instead of
    naming the input as ignored; false keeps a solid's boundary. On an opaque surface it changes nothing and adds no
    warning; fed by a node it is ignored, named in the warning. Before, every ``thin_walled`` true was "ignored"."""
    stage, path = new_stage(tmp_path)
    looks = {"Sheet": ({transmission: 1.0}, True), "Solid": ({transmission: 1.0}, False), "Opaque": ({}, True),
             "Wired": ({transmission: 1.0}, None)}
    for k, (name, (inputs, value)) in enumerate(looks.items()):
        material, shader = mtlx_material(stage, f"/Looks/{name}", shader_id, **inputs)
        attr = shader.CreateInput(thin, Sdf.ValueTypeNames.Bool)
        if value is None:
            node = UsdShade.Shader.Define(stage, f"/Looks/{name}/Flag")
            node.CreateIdAttr("ND_constant_boolean")
            attr.ConnectToSource(node.ConnectableAPI().CreateOutput("out", Sdf.ValueTypeNames.Bool))
        else:
            attr.Set(value)
        bind(add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0)), material)
    stage.Save()
    scene, messages = load(path)
    authored = {name: UsdShade.Shader.Get(stage, f"/Looks/{name}/Surface").GetInput(thin).Get() for name in looks}
    mats = {m.path.rsplit("/", 1)[1]: m for m in scene.materials}
    assert {name: mats[name].thin_walled for name in looks} == {**authored, "Wired": False}
    assert (mats["Sheet"].opacity, mats["Solid"].opacity, mats["Opaque"].opacity) == (0.0, 0.0, 1.0)
    notes = {name: [m for m in messages if f"/Looks/{name}:" in m] for name in looks}
    assert not any(f"{thin} (1) is ignored" in m for m in messages), messages
    (sheet,), (solid,), (wired,) = notes["Sheet"], notes["Solid"], notes["Wired"]
    assert f"{transmission} is drawn as a smooth thin-walled dielectric" in sheet
    assert f"{transmission} is drawn as a smooth dielectric" in solid and "is ignored" not in solid
    assert f"{thin} (connected to ND_constant_boolean) is ignored" in wired
    assert notes["Opaque"] == []


def test_a_scaled_specular_keeps_an_index_below_one_below_one_and_survives_a_negative_one(tmp_path):
    """The specular weight scales the dielectric F0 ``((ior - 1) / (ior + 1))^2``; the index drawn has that F0. An
    index below 1 (a bubble: transmission 1, specular_IOR 0.75) stays below 1, so refraction bends the authored way
    (it became 1.22); a negative index, drawn as wrt's smallest (1e-3) as UsdPreviewSurface's is, divided by zero
    at -1 and load_usd raised ZeroDivisionError."""
    stage, path = new_stage(tmp_path)
    looks = {"Bubble": {"specular_IOR": 0.75, "specular": 0.5, "transmission": 1.0},
             "Negative": {"specular_IOR": -1.0, "specular": 0.5}}
    for k, (name, inputs) in enumerate(looks.items()):
        bind(add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0)), mtlx_material(stage, f"/Looks/{name}", **inputs)[0])
    stage.Save()
    scene, _ = load(path)
    mats = {m.path.rsplit("/", 1)[1]: m for m in scene.materials}

    def f0(ior):
        return ((ior - 1.0) / (ior + 1.0)) ** 2

    bubble, negative = mats["Bubble"].ior, mats["Negative"].ior
    assert bubble < 1.0
    assert f0(bubble) == pytest.approx(0.5 * f0(0.75))
    assert f0(negative) == pytest.approx(0.5 * f0(1e-3))


def write_png(path, rows):
    PilImage.fromarray(np.asarray(rows, np.uint8)).save(path)
    return str(path)


def tiled_stage(tmp_path, png, uvtiling):
    """A quad bound to a standard_surface whose base_color is an ``ND_tiledimage_color3`` inside a NodeGraph, its
    file, roughness and metalness inputs of the Material (a file in ``srgb_texture``)."""
    stage, path = new_stage(tmp_path, f"tiled{uvtiling}.usda")
    quad = add_quad(stage, "/Quad")
    material, shader = mtlx_material(stage, "/Looks/Tiles")
    for name, value_type, value in (("rough", Sdf.ValueTypeNames.Float, 0.7),
                                    ("metal", Sdf.ValueTypeNames.Float, 0.25),
                                    ("file", Sdf.ValueTypeNames.Asset, Sdf.AssetPath(png))):
        material.CreateInput(name, value_type).Set(value)
    shader.CreateInput("specular_roughness", Sdf.ValueTypeNames.Float).ConnectToSource(
        material.GetInput("rough").GetAttr().GetPath())
    shader.CreateInput("metalness", Sdf.ValueTypeNames.Float).ConnectToSource(material.GetInput("metal").GetAttr()
                                                                              .GetPath())
    graph = UsdShade.NodeGraph.Define(stage, "/Looks/Tiles/Graph")
    image = UsdShade.Shader.Define(stage, "/Looks/Tiles/Graph/Image")
    image.CreateIdAttr("ND_tiledimage_color3")
    file_input = image.CreateInput("file", Sdf.ValueTypeNames.Asset)
    file_input.ConnectToSource(material.GetInput("file").GetAttr().GetPath())
    file_input.GetAttr().SetColorSpace("srgb_texture")
    image.CreateInput("uvtiling", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(uvtiling, uvtiling))
    texcoord = UsdShade.Shader.Define(stage, "/Looks/Tiles/Graph/Texcoord")
    texcoord.CreateIdAttr("ND_texcoord_vector2")
    image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(texcoord.ConnectableAPI(), "out")
    image.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    graph.CreateOutput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(graph.ConnectableAPI(), "base_color")
    bind(quad, material)
    stage.Save()
    return path


def test_a_tiling_past_float32_reads_the_image_default_with_a_note(tmp_path):
    """A ``tiledimage`` whose ``uvtiling`` and real-world sizes are each finite but whose texture transform passes
    float32's range reads its default (0: black), named in the material's note: it stopped the load with
    "transform must be a (3, 3) matrix of finite numbers"."""
    png = write_png(tmp_path / "tile.png", np.full((2, 2, 3), 200))
    path = tiled_stage(tmp_path, png, 3e38)
    stage = Usd.Stage.Open(path)
    image = UsdShade.Shader.Get(stage, "/Looks/Tiles/Graph/Image")
    image.CreateInput("realworldimagesize", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(1e-10, 1e-10))
    stage.Save()
    with pytest.warns(UserWarning, match=r"/Looks/Tiles.*float32"):
        scene = wrt.load_usd(path)
    np.testing.assert_allclose(albedo(scene, 2), 0.0)


@pytest.mark.parametrize("source", ["ND_image_color3", "ND_geompropvalue_color3"])
def test_a_base_weight_that_scales_a_texture_past_float32_keeps_the_defaults(tmp_path, source):
    """``base`` 3e38 times a base_color image (or colour primvar) already multiplied by 10: each finite, the
    texture's scale (the primvar's) past float32's range. The material keeps the library's base and base_color (0.8)
    with a note, where the load stopped with "scale must be ... finite numbers" (an image) or "diffuse_color must be
    finite numbers" (a primvar)."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray).Set([(0.5, 0.5, 0.5)])
    material, shader = mtlx_material(stage, "/Looks/Big", base=3e38)
    node = UsdShade.Shader.Define(stage, "/Looks/Big/Source")
    node.CreateIdAttr(source)
    if source == "ND_image_color3":
        node.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(write_png(tmp_path / "c.png", np.full((2, 2, 3), 200)))
    else:
        node.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("displayColor")
    node.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    times = UsdShade.Shader.Define(stage, "/Looks/Big/Times")
    times.CreateIdAttr("ND_multiply_color3FA")
    times.CreateInput("in1", Sdf.ValueTypeNames.Color3f).ConnectToSource(node.ConnectableAPI(), "out")
    times.CreateInput("in2", Sdf.ValueTypeNames.Float).Set(10.0)
    times.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(times.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Big" in m and "not a finite float; their defaults are used" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene, 2), 0.8, rtol=1e-6)


def albedo(scene, res):
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    return wrt.render(scene, camera=cam, width=res, height=res, device="cpu").aovs["albedo"]


# Six texels (3 wide, 2 high), each a different colour, for the nearest-texel oracles.
PIXELS = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]], [[255, 255, 0], [0, 255, 255], [255, 0, 255]]])


def base_color_image(stage, material, png, texcoord=None, node_id="ND_image_color3", **strings):
    """A ``node_id`` image node of ``png`` at ``{material}/Image`` with the string inputs ``strings`` (``filtertype``,
    ``layer``), read at the ``out`` of shader ``texcoord`` when one is given, feeding the ``base_color`` of
    ``{material}/Surface``."""
    image = UsdShade.Shader.Define(stage, f"{material}/Image")
    image.CreateIdAttr(node_id)
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    for name, value in strings.items():
        image.CreateInput(name, Sdf.ValueTypeNames.String).Set(value)
    if texcoord is not None:
        image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(texcoord.ConnectableAPI(), "out")
    UsdShade.Shader.Get(stage, f"{material}/Surface").CreateInput("base_color", Sdf.ValueTypeNames.Color3f
                                                                  ).ConnectToSource(image.ConnectableAPI(), "out")
    return image


def closest_image(stage, material, png, texcoord=None, node_id="ND_image_color3"):
    """:func:`base_color_image` with filtertype ``closest``."""
    return base_color_image(stage, material, png, texcoord, node_id, filtertype="closest")


def pixel_centre_st(res):
    """The st of each of ``res`` x ``res`` pixel centres over the unit square, row 0 at the top (t near 1)."""
    centres = (np.arange(res) + 0.5) / res
    s, t = np.meshgrid(centres, centres[::-1])
    return np.stack([s, t], axis=-1)


def assert_reads_the_texels_at(scene, texels, st):
    """The albedo of each pixel is texel ``(floor(s w) mod w, floor((1 - t) h) mod h)`` of ``texels`` at its ``st``
    (float64), but where a pixel centre within float32 rounding of a texel edge may fall either side of it."""
    h, w = texels.shape[:2]
    expected = texels[np.floor((1.0 - st[..., 1]) * h).astype(int) % h, np.floor(st[..., 0] * w).astype(int) % w]
    near_edge = np.any(np.abs(np.round(st * (w, h)) - st * (w, h)) < 1e-4, axis=-1)
    np.testing.assert_allclose(albedo(scene, len(st))[~near_edge], expected[~near_edge] / 255.0, atol=1e-3)


def test_interface_inputs_and_a_tiled_image_in_a_node_graph(tmp_path):
    """Inputs connected to the Material's interface take its values; a NodeGraph's ``ND_tiledimage_color3`` becomes
    the base colour texture (sRGB decoded), ``uvtiling`` 2 repeats it twice. It was a Lambertian of base_color."""
    texels = [[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [128, 128, 128]]]  # rows from the top
    png = write_png(tmp_path / "tiles.png", texels)
    grey = float(srgb_to_linear(np.float32(128 / 255)))
    expected = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [grey, grey, grey]]])
    scene, messages = load(tiled_stage(tmp_path, png, 1))
    assert not messages, messages
    (mat,) = scene.materials
    assert (mat.roughness, mat.metallic) == pytest.approx((0.7, 0.25))
    np.testing.assert_allclose(albedo(scene, 2), expected, atol=2e-3)  # pixel centres on texel centres
    scene, _ = load(tiled_stage(tmp_path, png, 2))
    np.testing.assert_allclose(albedo(scene, 4), np.tile(expected, (2, 2, 1)), atol=2e-3)


def test_a_udim_image_node_reads_its_tiles(tmp_path):
    """An image node's ``<UDIM>`` file reads tile 1001 + u + 10 v at st in [u, u + 1) x [v, v + 1) (here st over
    [0, 2)^2 by ``uvtiling`` 2), as a UsdUVTexture's does. It was refused with a warning, the base colour used."""
    colors = {1001: (255, 0, 0), 1002: (0, 255, 0), 1011: (0, 0, 255), 1012: (255, 255, 255)}
    for tile, color in colors.items():
        write_png(tmp_path / f"skin.{tile}.png", [[color]])
    scene, messages = load(tiled_stage(tmp_path, str(tmp_path / "skin.<UDIM>.png"), 2))
    assert not messages, messages
    expected = np.array([[colors[1011], colors[1012]], [colors[1001], colors[1002]]]) / 255.0  # row 0: v in [1, 2)
    np.testing.assert_allclose(albedo(scene, 2), expected, atol=1e-3)


def test_colour_times_weight_past_float32_takes_the_defaults(tmp_path):
    """base_color 1e38 times base 10 (each a finite float) is no float32: the defaults (0.8 grey) are used, with a
    note naming both inputs. The material raised a SceneError naming neither file nor mesh ('diffuse_color must be
    finite numbers'), and the stage did not load."""
    stage, path = new_stage(tmp_path)
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Hot", base_color=Gf.Vec3f(1e38, 0.5, 0.5),
                                                 base=10.0, emission_color=Gf.Vec3f(3e38, 1, 1), emission=2.0)[0])
    stage.Save()
    scene, messages = load(path)
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, 0.8)
    np.testing.assert_array_equal(mat.emissive_color, 0.0)
    (warning,) = [m for m in messages if "/Looks/Hot:" in m]
    assert "base_color 1e+38, 0.5, 0.5 times base 10 is not a finite float" in warning
    assert "emission_color 3e+38, 1, 1 times emission 2 is not a finite float" in warning


def test_open_pbr_emission_is_luminance_times_colour(tmp_path):
    """OpenPBR's emission_luminance (nits) times emission_color is the emitted radiance, in the units of a UsdLux
    light of intensity 1 (= 1 nit): a black emitter of 3 nits in (1, 0.5, 0.25) shows (3, 1.5, 0.75). It was a
    Lambertian of its base colour, which emitted nothing."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, _ = mtlx_material(stage, "/Looks/Panel", OPEN_PBR, base_weight=0.0, specular_weight=0.0,
                                emission_luminance=3.0, emission_color=Gf.Vec3f(1, 0.5, 0.25))
    bind(quad, material)
    stage.Save()
    scene, _ = load(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu")
    np.testing.assert_allclose(img.rgb, np.broadcast_to([3, 1.5, 0.75], (4, 4, 3)), rtol=1e-5)


@pytest.mark.parametrize("source", ["ND_constant_color3", "ND_noise2d_color3"])
def test_an_image_default_fed_by_a_constant_node_is_its_value(tmp_path, source):
    """An emission_color image node (a black texel, ``constant`` address mode) whose ``default`` comes from an
    ``ND_constant_color3`` of (2, 1, 0.5) shows that default where st lies outside [0, 1], as MaterialX defines the
    constant node's output: the quad (st over [2, 3]) glows (2, 1, 0.5). The connected default was read as
    unauthored, 0, without a word: the quad was black. A node that folds to no constant (``ND_noise2d_color3``)
    leaves MaterialX's default, 0, with a note naming it."""
    write_png(tmp_path / "black.png", [[(0, 0, 0)]])
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    st = quad.GetPrim().GetAttribute("primvars:st")
    st.Set([Gf.Vec2f(2 + u, v) for u, v in st.Get()])
    material, shader = mtlx_material(stage, "/Looks/Panel", base=0.0, specular=0.0, emission=1.0)
    node = UsdShade.Shader.Define(stage, "/Looks/Panel/Source")
    node.CreateIdAttr(source)
    node.CreateInput("value", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(2, 1, 0.5))
    node.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    image = UsdShade.Shader.Define(stage, "/Looks/Panel/Image")
    image.CreateIdAttr("ND_image_color3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./black.png")
    image.CreateInput("default", Sdf.ValueTypeNames.Color3f).ConnectToSource(node.ConnectableAPI(), "out")
    for key in ("uaddressmode", "vaddressmode"):
        image.CreateInput(key, Sdf.ValueTypeNames.String).Set("constant")
    image.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    scene, messages = load(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu")
    folded = source == "ND_constant_color3"
    np.testing.assert_allclose(img.rgb, np.broadcast_to([2, 1, 0.5] if folded else 0.0, (2, 2, 3)), rtol=1e-5)
    noted = [m for m in messages if "/Looks/Panel/Image's default comes from a ND_noise2d_color3 node" in m]
    assert len(noted) == (0 if folded else 1), messages


def test_an_unsupported_node_keeps_the_constant_with_one_warning(tmp_path):
    """base_color from a node wrt cannot fold (ND_noise3d_color3; math nodes are folded: test_primvar_colors.py)
    keeps the value authored beside the connection, with one warning naming the material and the node type; the old
    fallback found no constant and drew displayColor."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    quad.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.9, 0.9, 0.9)])
    material, shader = mtlx_material(stage, "/Looks/Mixed")
    node = UsdShade.Shader.Define(stage, "/Looks/Mixed/Noise")
    node.CreateIdAttr("ND_noise3d_color3")
    node.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    base_color = shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f)
    base_color.Set(Gf.Vec3f(0.2, 0.4, 0.6))
    base_color.ConnectToSource(node.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    scene, messages = load(path)
    mentions = [m for m in messages if "/Looks/Mixed" in m]
    assert len(mentions) == 1 and "ND_noise3d_color3" in mentions[0], messages
    np.testing.assert_allclose(albedo(scene, 2), np.broadcast_to([0.2, 0.4, 0.6], (2, 2, 3)), atol=1e-6)


def test_a_full_binding_to_standard_surface_wins_over_a_preview_binding(tmp_path):
    """A mesh bound to a standard_surface for ``full`` and to a UsdPreviewSurface for ``preview``: the preview
    binding served while wrt read no MaterialX; now that it reads standard_surface, the full look is the one to draw
    (as for a full UsdPreviewSurface)."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    full, _ = mtlx_material(stage, "/Looks/Full", base_color=Gf.Vec3f(1, 0, 0))
    preview, _ = preview_material(stage, "/Looks/Preview", diffuseColor=Gf.Vec3f(0, 0, 1))
    bind(quad, full, UsdShade.Tokens.full)
    bind(quad, preview, UsdShade.Tokens.preview)
    stage.Save()
    scene, _ = load(path)
    assert scene.materials[scene.meshes[0].material_ids[0]].path == "/Looks/Full"



@pytest.mark.parametrize("shader_id, full_id", [(STANDARD, None), (OPEN_PBR, None),
                                               (STANDARD, "ND_gltf_pbr_surfaceshader")])
def test_a_preview_binding_to_a_materialx_surface_is_drawn_where_the_full_one_binds_none(tmp_path, shader_id,
                                                                                          full_id):
    """A quad bound to a standard_surface (or OpenPBR) for ``preview`` only, or also to a look wrt cannot read
    (gltf_pbr) for ``full``: ``ComputeBoundMaterial("full")`` gives nothing (or that look), and wrt draws the
    material ``ComputeBoundMaterial("preview")`` gives, as it does a preview UsdPreviewSurface. Only UsdPreviewSurface
    was accepted there: the quad was drawn in the default grey (or as the unreadable look's fallback)."""
    stage, path = new_stage(tmp_path, "purpose.usda")
    quad = add_quad(stage, "/Quad")
    preview, _ = mtlx_material(stage, "/Looks/Preview", shader_id, base_color=Gf.Vec3f(1, 0, 0))
    bind(quad, preview, UsdShade.Tokens.preview)
    if full_id is not None:
        bind(quad, mtlx_material(stage, "/Looks/Full", full_id)[0], UsdShade.Tokens.full)
    stage.Save()
    api = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/Quad"))
    full = api.ComputeBoundMaterial(UsdShade.Tokens.full)[0]
    assert (full.GetPath() if full else None) == (None if full_id is None else Sdf.Path("/Looks/Full"))
    want = api.ComputeBoundMaterial(UsdShade.Tokens.preview)[0].GetPath()
    scene, _ = load(path)
    ids = scene.meshes[0].material_ids
    drawn = None if ids is None or ids[0] < 0 else scene.materials[ids[0]]  # None: the default material
    assert getattr(drawn, "path", None) == str(want)
    np.testing.assert_allclose(drawn.diffuse_color, [1, 0, 0], atol=1e-6)  # base 1 (both specifications)


def test_a_render_context_standard_surface_wins_over_the_universal_preview_surface(tmp_path):
    """A material with both a universal ``outputs:surface`` (UsdPreviewSurface, green) and ``outputs:mtlx:surface``
    (standard_surface, grey), as the usd-wg teapot and shader-ball assets are written: Storm takes a render
    context's output over the universal one, so it draws the standard_surface; wrt drew the green preview surface
    (the teapots of teapotScene.usd were green instead of 0.8 grey). An unreadable context surface (gltf_pbr) still
    leaves the universal preview surface to read."""
    stage, path = new_stage(tmp_path)
    for name, context_shader in (("Both", STANDARD), ("Gltf", "ND_gltf_pbr_surfaceshader")):
        quad = add_quad(stage, f"/{name}")
        material, shader = mtlx_material(stage, f"/Looks/{name}", context_shader, base_color=Gf.Vec3f(0.5, 0.6, 0.7))
        preview = UsdShade.Shader.Define(stage, f"/Looks/{name}/Preview")
        preview.CreateIdAttr("UsdPreviewSurface")
        preview.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.1, 0.9, 0.0))
        material.CreateSurfaceOutput().ConnectToSource(preview.ConnectableAPI(), "surface")
        bind(quad, material)
    stage.Save()
    scene, _ = load(path)
    colors = {m.path: m.diffuse_color for m in scene.materials}
    np.testing.assert_allclose(colors["/Looks/Both"], [0.5, 0.6, 0.7], atol=1e-6)  # base 1 * base_color
    np.testing.assert_allclose(colors["/Looks/Gltf"], [0.1, 0.9, 0.0], atol=1e-6)


def test_an_unreadable_context_surface_without_a_universal_one_is_named(tmp_path):
    """A material whose only surface output is ``outputs:mtlx:surface`` to a gltf_pbr: the warning names that shader,
    as it does a universal one. It said "no universal surface output (found: mtlx:surface)", as if nothing were
    connected, though render contexts are read first."""
    stage, path = new_stage(tmp_path)
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Gltf", "ND_gltf_pbr_surfaceshader")[0])
    stage.Save()
    _, messages = load(path)
    (warning,) = [m for m in messages if "/Looks/Gltf" in m]
    assert "shader ND_gltf_pbr_surfaceshader is not supported" in warning, warning

def normal_mapped_mtlx_stage(tmp_path, png, shader_id=STANDARD, map_node="ND_normalmap", scale=None):
    """A quad (s along +X, t along +Y, front +Z) whose standard_surface (or OpenPBR) normal input comes from a
    ``map_node`` reading ``png`` through an ``ND_image_vector3`` node without a colour space, in a NodeGraph."""
    stage, path = new_stage(tmp_path, f"nm_{map_node}_{shader_id[3:8]}.usda")
    quad = add_quad(stage, "/Quad")
    material, shader = mtlx_material(stage, "/Looks/Bumpy", shader_id)
    graph = UsdShade.NodeGraph.Define(stage, "/Looks/Bumpy/Graph")
    image = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Graph/Image")
    image.CreateIdAttr("ND_image_vector3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.CreateOutput("out", Sdf.ValueTypeNames.Float3)
    node = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Graph/NormalMap")
    node.CreateIdAttr(map_node)
    node.CreateInput("in", Sdf.ValueTypeNames.Float3).ConnectToSource(image.ConnectableAPI(), "out")
    if scale is not None:
        node.CreateInput("scale", Sdf.ValueTypeNames.Float).Set(scale)
    node.CreateOutput("out", Sdf.ValueTypeNames.Float3)
    graph.CreateOutput("normal", Sdf.ValueTypeNames.Float3).ConnectToSource(node.ConnectableAPI(), "out")
    name = "normal" if shader_id != OPEN_PBR else "geometry_normal"
    shader.CreateInput(name, Sdf.ValueTypeNames.Float3).ConnectToSource(graph.ConnectableAPI(), "normal")
    bind(quad, material)
    stage.Save()
    return path


def shading_normals(scene):
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    return wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="normals").aovs["normal"]


@pytest.mark.parametrize("shader_id, map_node", [(STANDARD, "ND_normalmap"), (OPEN_PBR, "ND_normalmap_float"),
                                                 (STANDARD, "ND_normalmap_vector2")])
def test_a_normalmap_node_is_a_tangent_space_normal_map(tmp_path, shader_id, map_node):
    """standard_surface ``normal`` (OpenPBR ``geometry_normal``) from a normalmap node of an 8-bit vector3 image
    tilts the shading normal as the same map does through UsdPreviewSurface (MaterialX's ``in * 2 - 1``; vector
    images are data, not sRGB). It was ignored without a word: every normal read (0, 0, 1)."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    scene, messages = load(normal_mapped_mtlx_stage(tmp_path, png, shader_id, map_node))
    assert not messages, messages
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile(stored_normal(MAP_NORMAL), (4, 1)),
                               atol=1e-3)


def test_normalmap_scale_multiplies_the_tangent_components(tmp_path):
    """The normalmap node's ``scale`` multiplies x and y of the decoded normal before it is normalised."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    scene, _ = load(normal_mapped_mtlx_stage(tmp_path, png, scale=0.5))
    n = stored_normal(MAP_NORMAL) * (0.5, 0.5, 1.0)
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile(n / np.linalg.norm(n), (4, 1)),
                               atol=1e-3)


def test_a_missing_udim_tile_of_a_normalmap_keeps_the_surface_normal(tmp_path):
    """A ``<UDIM>`` normal map whose tile 1001 (under the whole quad) has no file reads the image node's default,
    (0.5, 0.5, 1), decoded as every texel is: the normal (0, 0, 1). It was read as it is, a 35-degree tilt
    (0.41, 0.41, 0.82) on every pixel."""
    from test_normal_map import MAP_NORMAL, write_normal_map

    write_normal_map(tmp_path / "tilt.1002.png", MAP_NORMAL)
    scene, messages = load(normal_mapped_mtlx_stage(tmp_path, str(tmp_path / "tilt.<UDIM>.png")))
    assert not messages, messages
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile([0, 0, 1], (4, 1)), atol=1e-6)


@pytest.mark.parametrize("placement", ["place2d", "tiledimage"])
def test_a_normalmap_s_tangent_frame_is_the_mesh_s_whatever_places_its_image(tmp_path, placement):
    """MaterialX's ``normalmap`` takes its tangent from the geometry (``tangent``'s defaultgeomprop ``Tworld``, which
    Storm computes from the mesh's ``st``), not from the coordinates its image is read at: a ``place2d`` turning the
    image by 90 degrees, or a ``tiledimage`` mirrored by ``uvtiling`` (-1, 1), moves where texels land, not the
    frame they are decoded in. Oracle (float64): on the quad (dp/ds = +X, dp/dt = +Y) a uniform map's texel ``v``
    is the normal ``(v_x, v_y, v_z)`` normalised, as with no placement. The frame followed the placed coordinates:
    the tilt (0.381, 0.318, 0.868) was drawn turned, (-0.318, 0.382, 0.868), and mirrored, (-0.382, 0.318, 0.868)."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    path = normal_mapped_mtlx_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    image = UsdShade.Shader.Get(stage, "/Looks/Bumpy/Graph/Image")
    if placement == "place2d":
        place = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Graph/Place")
        place.CreateIdAttr("ND_place2d_vector2")
        place.CreateInput("rotate", Sdf.ValueTypeNames.Float).Set(90.0)
        place.CreateOutput("out", Sdf.ValueTypeNames.Float2)
        image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(place.ConnectableAPI(), "out")
    else:
        image.CreateIdAttr("ND_tiledimage_vector3")
        image.CreateInput("uvtiling", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(-1.0, 1.0))
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile(stored_normal(MAP_NORMAL), (4, 1)),
                               atol=1e-3)


def quad_frame_normal(texel_normal) -> np.ndarray:
    """Oracle (float64): the mapped normal of the quad of :func:`test_materials.add_quad` in its ``st`` frame
    (dp/ds = +X, dp/dt = +Y from its corners: x and y over 2, s and t over 1), the texel decoded ``in * 2 - 1``."""
    corners = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0]])  # (x, y); st = (x, y) / 2 + 0.5
    st = corners / 2.0 + 0.5
    dp = np.linalg.solve(st[1:] - st[0], corners[1:] - corners[0])  # rows: dp/ds, dp/dt in (x, y)
    tangent, bitangent = np.append(dp[0], 0.0), np.append(dp[1], 0.0)
    tangent, bitangent = tangent / np.linalg.norm(tangent), bitangent / np.linalg.norm(bitangent)
    n = texel_normal[0] * tangent + texel_normal[1] * bitangent + texel_normal[2] * np.array([0.0, 0.0, 1.0])
    return n / np.linalg.norm(n)


@pytest.mark.parametrize("texcoord", ["uv2", "constant", "preview_uv2"])
def test_a_normalmap_not_read_through_st_names_its_frame(tmp_path, texcoord):
    """MaterialX's normalmap frame is ``Tworld``, the tangent of texture-coordinate set 0: the mesh's ``st``. A mesh
    holds one set of coordinates, those its images read, so an image read through primvar ``uv2`` (here ``st``
    turned 90 degrees) draws the tilt in uv2's frame, and one read at a constant texcoord draws no tilt; each is
    named in the material's warning. Oracle (float64): in st's frame the texel is the normal (0.381, 0.318, 0.868);
    drawn (0.318, -0.382, 0.868) and (0, 0, 1), without a word."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    if texcoord == "preview_uv2":  # MaterialX's UsdPreviewSurface graph: a normalmap node too (Tworld)
        stage, path = new_stage(tmp_path, "preview_uv2.usda")
        material, shader = mtlx_material(stage, "/Looks/Bumpy", "ND_UsdPreviewSurface_surfaceshader")
        reader = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Reader")
        reader.CreateIdAttr("ND_UsdPrimvarReader_vector2")
        reader.CreateOutput("out", Sdf.ValueTypeNames.Float2)
        tex = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Map")
        tex.CreateIdAttr("ND_UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "out")
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
        tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        shader.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(add_quad(stage, "/Quad"), material)
    else:
        path = normal_mapped_mtlx_stage(tmp_path, png)
        stage = Usd.Stage.Open(path)
    quad = UsdGeom.PrimvarsAPI(UsdGeom.Mesh.Get(stage, "/Quad"))
    uv2 = [Gf.Vec2f(1.0 - t, s) for s, t in quad.GetPrimvar("st").Get()]
    quad.CreatePrimvar("uv2", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(uv2)
    if texcoord == "preview_uv2":
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("uv2")
    elif texcoord == "uv2":
        reader = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Graph/Reader")
        reader.CreateIdAttr("ND_geompropvalue_vector2")
        reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("uv2")
        reader.CreateOutput("out", Sdf.ValueTypeNames.Float2)
        image = UsdShade.Shader.Get(stage, "/Looks/Bumpy/Graph/Image")
        image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "out")
    else:
        image = UsdShade.Shader.Get(stage, "/Looks/Bumpy/Graph/Image")
        image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.3, 0.3))
    stage.Save()
    scene, messages = load(path)
    drawn = shading_normals(scene).reshape(-1, 3)
    in_st_frame = quad_frame_normal(stored_normal(MAP_NORMAL))
    assert np.max(np.abs(drawn - in_st_frame)) > 0.1  # what a mesh of one coordinate set cannot draw
    why = "reads primvar 'uv2'" if texcoord != "constant" else "is read at a constant texcoord"
    assert any(f"its normal map {why}" in m and "Tworld" in m for m in messages), messages


@pytest.mark.parametrize("scale", [None, 0.5])
def test_a_normalmap_s_black_texels_are_the_flat_normal(tmp_path, scale):
    """MaterialX's ``mx_normalmap`` decodes an input of exactly 0 as (0, 0, 1), not ``0 * 2 - 1`` (its GLSL:
    ``value == 0 ? (0, 0, 1) : value * 2 - 1``), as 1ba0348c made of the image's default outside [0, 1]: a black
    texel (the padding of a baked map) is the flat normal, whatever the node's ``scale``. Oracle: the closed form,
    (0, 0, 1) on the +Z quad. It was drawn as (-1, -1, -1) normalised and bent above the surface."""
    png = tmp_path / "black.png"
    PilImage.fromarray(np.zeros((4, 4, 3), np.uint8)).save(png)
    scene, messages = load(normal_mapped_mtlx_stage(tmp_path, str(png), scale=scale))
    assert not messages, messages
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile([0.0, 0.0, 1.0], (4, 1)), atol=1e-6)


@pytest.mark.parametrize("surface", ["UsdPreviewSurface", "ND_UsdPreviewSurface_surfaceshader"])
def test_a_preview_normal_map_turned_by_its_transform2d_takes_the_frame_its_surface_gives(tmp_path, surface):
    """A normal map (scale 2, bias -1) read through a UsdTransform2d turning st by 90 degrees: UsdPreviewSurface's
    frame is the map's own st (Storm's), so the tilt turns with it; MaterialX's UsdPreviewSurface graph feeds
    ``normal * 0.5 + 0.5`` to a ``normalmap`` node, whose tangent is the mesh's (``Tworld``), so the tilt keeps the
    quad's frame. Oracle (float64): the texel's normal (0.381, 0.318, 0.868), its x along +X (MaterialX) or along
    -Y, its y along +X (UsdTransform2d turns st counter-clockwise: the map's s runs along -Y, t along +X).
    MaterialX's was drawn turned, as UsdPreviewSurface's: (0.318, -0.382, 0.868)."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    stage, path = new_stage(tmp_path, f"turned_{surface}.usda")
    materialx = surface != "UsdPreviewSurface"
    prefix = "ND_" if materialx else ""
    material = UsdShade.Material.Define(stage, "/Looks/Bumpy")
    shader = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Surface")
    shader.CreateIdAttr(surface)
    material.CreateSurfaceOutput("mtlx" if materialx else "").ConnectToSource(shader.ConnectableAPI(),
                                                                              "out" if materialx else "surface")
    reader = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Reader")
    reader.CreateIdAttr("ND_UsdPrimvarReader_vector2" if materialx else "UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    reader.CreateOutput("out" if materialx else "result", Sdf.ValueTypeNames.Float2)
    turn = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Turn")
    turn.CreateIdAttr(f"{prefix}UsdTransform2d")
    turn.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(),
                                                                      "out" if materialx else "result")
    turn.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(90.0)
    turn.CreateOutput("out" if materialx else "result", Sdf.ValueTypeNames.Float2)
    tex = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Map")
    tex.CreateIdAttr(f"{prefix}UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(turn.ConnectableAPI(),
                                                                     "out" if materialx else "result")
    if not materialx:  # (MaterialX's node: raw and periodic unauthored)
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
        for key in ("wrapS", "wrapT"):  # the turned st lie outside [0, 1]
            tex.CreateInput(key, Sdf.ValueTypeNames.Token).Set("repeat")
    tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
    tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    shader.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    n = stored_normal(MAP_NORMAL)
    expected = n if materialx else np.array([n[1], -n[0], n[2]])
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile(expected, (4, 1)), atol=1e-3)


@pytest.mark.parametrize("default", [None, (0.0, 0.0, 0.0)])
def test_a_normalmap_s_image_outside_its_constant_addressing_is_the_flat_normal(tmp_path, default):
    """A normalmap of an image of ``constant`` address modes reads the image's ``default`` outside [0, 1], 0 when
    unauthored (or authored so), which MaterialX's normalmap decodes as the flat normal (0, 0, 1) (``mx_normalmap``:
    a value of 0 is (0, 0, 1)). Oracle: on st over [0, 2] the pixel inside the image shows the texel's normal
    (float64), the three outside (0, 0, 1). They read 0 * 2 - 1 = (-1, -1, -1), a normal bent into the surface:
    (-0.497, -0.497, 0.711) after it was kept above it."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    path = normal_mapped_mtlx_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    image = UsdShade.Shader.Get(stage, "/Looks/Bumpy/Graph/Image")
    for key in ("uaddressmode", "vaddressmode"):
        image.CreateInput(key, Sdf.ValueTypeNames.String).Set("constant")
    if default is not None:
        image.CreateInput("default", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(*default))
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad")).GetPrimvar("st")
    st.Set([Gf.Vec2f(2 * a, 2 * b) for a, b in st.Get()])  # shading_normals' pixel centres: st 0.75 and 1.25
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    expected = np.tile([0.0, 0.0, 1.0], (2, 2, 1))
    expected[1, 0] = stored_normal(MAP_NORMAL)  # the bottom-left pixel, st (0.75, 0.75)
    np.testing.assert_allclose(shading_normals(scene), expected, atol=1e-3)


@pytest.mark.parametrize("frame_input", ["normal", "tangent", "bitangent"])
def test_a_normalmap_s_authored_frame_is_named_in_the_warning(tmp_path, frame_input):
    """A ``normalmap``'s ``normal``, ``tangent`` or ``bitangent`` authored (the nodedefs' ``Nworld``, ``Tworld`` and
    ``Bworld`` replaced: here a tangent along +Y) is not followed: the material's warning names the node and the
    input, and the mesh's frame is drawn (float64: the texel's normal on the quad's frame). It was dropped without
    a word."""
    from test_normal_map import MAP_NORMAL, stored_normal, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    path = normal_mapped_mtlx_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    node = UsdShade.Shader.Get(stage, "/Looks/Bumpy/Graph/NormalMap")
    node.CreateInput(frame_input, Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.0, 1.0, 0.0))
    stage.Save()
    scene, messages = load(path)
    (warning,) = [m for m in messages if "/Looks/Bumpy" in m]
    assert f"/Looks/Bumpy/Graph/NormalMap: its {frame_input} (0, 1, 0) is not read" in warning, warning
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile(stored_normal(MAP_NORMAL), (4, 1)),
                               atol=1e-3)


def test_a_normal_from_another_node_is_named_in_the_warning(tmp_path):
    """``normal`` connected to anything but a normalmap node of an image (here an image node straight, a world-space
    normal in MaterialX) keeps the mesh's normals, and the material's warning says so."""
    from test_normal_map import MAP_NORMAL, write_normal_map

    png = write_normal_map(tmp_path / "tilt.png", MAP_NORMAL)
    path = normal_mapped_mtlx_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Bumpy/Surface")).GetInput("normal").ConnectToSource(
        UsdShade.Shader(stage.GetPrimAtPath("/Looks/Bumpy/Graph/Image")).ConnectableAPI(), "out")
    stage.Save()
    scene, messages = load(path)
    (warning,) = [m for m in messages if "/Looks/Bumpy" in m]
    assert "normal comes from a ND_image_vector3 node" in warning, warning
    np.testing.assert_allclose(shading_normals(scene).reshape(-1, 3), np.tile([0, 0, 1], (4, 1)), atol=1e-6)


def test_float_and_vector_images_are_data_not_srgb(tmp_path):
    """An ``ND_image_float`` without a colour space reading an 8-bit RGB file (a packed mask) gives the stored
    value: MaterialX colour-manages colour images only. It was sRGB-decoded: roughness 128/255 read as 0.22."""
    png = write_png(tmp_path / "mask.png", np.full((2, 2, 3), 128))
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, shader = mtlx_material(stage, "/Looks/Masked")
    image = UsdShade.Shader.Define(stage, "/Looks/Masked/Rough")
    image.CreateIdAttr("ND_image_float")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.CreateOutput("out", Sdf.ValueTypeNames.Float)
    shader.CreateInput("specular_roughness", Sdf.ValueTypeNames.Float).ConnectToSource(image.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    scene, _ = load(path)
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["roughness"].image]
    np.testing.assert_allclose(texels[..., 0], 128 / 255, atol=1e-3)


@pytest.mark.parametrize("node", ["ND_image_color3", "ND_tiledimage_color3", "interface input", "ND_UsdUVTexture",
                                  "empty colorSpace"])
def test_a_colour_image_without_a_colour_space_is_read_as_stored(tmp_path, node):
    """A MaterialX colour image whose ``file`` has no ``colorSpace`` (nor the Material input it connects to, nor a
    ``sourceColorSpace`` on an ``ND_UsdUVTexture``; or an empty one, which hdMtlx passes on as none) reads an 8-bit
    RGB PNG's samples as stored, ``s / 255``, without a word: the MaterialX specification's working colour space
    defaults to ``none``, no colour management, and Storm hands MaterialX's textures over raw
    (``_AddDefaultMtlxTextureValues``: sourceColorSpace raw), transforming only where a colour space is authored. It
    was read as UsdUVTexture's ``auto``: decoded as sRGB, 102/255 read as 0.133."""
    samples = np.array([51, 102, 153])
    png = write_png(tmp_path / "colour.png", np.tile(samples, (2, 2, 1)))
    if node == "ND_UsdUVTexture":
        path = materialx_preview_stage(tmp_path, png, None, "uv")
        stage = Usd.Stage.Open(path)
        UsdShade.Shader.Get(stage, "/Looks/Mx/Image").GetInput("file").GetAttr().ClearColorSpace()
    else:
        stage, path = new_stage(tmp_path)
        material, _ = mtlx_material(stage, "/Looks/Colour")
        image = base_color_image(stage, "/Looks/Colour", png, node_id=node if node.startswith("ND_") else
                                 "ND_image_color3")
        if node == "empty colorSpace":
            image.GetInput("file").GetAttr().SetColorSpace("")
        if node == "interface input":
            material.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
            image.GetInput("file").ConnectToSource(material.GetInput("file").GetAttr().GetPath())
        bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["diffuseColor"].image][..., :3].astype(np.float64)
    np.testing.assert_allclose(texels, np.broadcast_to(samples / 255.0, texels.shape), atol=1e-6)


# The MaterialX Specification's colour spaces (1.39) other than srgb_texture and lin_rec709: each one's transfer
# function to linear as MaterialX's colour transforms decode it (a power of max(x, 0), or sRGB's curve), and the USD
# name of the linear space of its primaries where they are other than Rec.709's (None), converted from as USD does.
TRANSFERS = {"g22_rec709": (lambda x: x**2.2, None), "g18_rec709": (lambda x: x**1.8, None),
             "rec709_display": (lambda x: x**2.4, None),
             "lin_srgb": (lambda x: x, None), "g22_ap1": (lambda x: x**2.2, "lin_ap1_scene"),
             "g18_ap1": (lambda x: x**1.8, "lin_ap1_scene"),
             "adobergb": (lambda x: x ** (563 / 256), "lin_adobergb_scene"),
             "srgb_displayp3": (lambda x: srgb_decoded(x, 1.0), "lin_p3d65_scene"),
             "lin_displayp3": (lambda x: x, "lin_p3d65_scene"), "acescg": (lambda x: x, "lin_ap1_scene"),
             "lin_ap1": (lambda x: x, "lin_ap1_scene"), "lin_adobergb": (lambda x: x, "lin_adobergb_scene")}


def colour_image_stage(tmp_path, image_path, space, node):
    """A quad whose MaterialX surface's diffuse comes from ``image_path`` with ``file`` in colour space ``space``,
    through an ``ND_image_color3`` under a standard_surface or an ``ND_UsdUVTexture`` under MaterialX's
    UsdPreviewSurface (``node``); ``node`` ``interface input``: the ``ND_image_color3``'s file connected to a Material
    input that holds the file and the colour space."""
    if node == "ND_UsdUVTexture":
        path = materialx_preview_stage(tmp_path, image_path, None, "uv")
        stage = Usd.Stage.Open(path)
        UsdShade.Shader.Get(stage, "/Looks/Mx/Image").GetInput("file").GetAttr().SetColorSpace(space)
    else:
        stage, path = new_stage(tmp_path)
        material, _ = mtlx_material(stage, "/Looks/Colour")
        file_input = base_color_image(stage, "/Looks/Colour", image_path).GetInput("file")
        if node == "interface input":
            file_input.ConnectToSource(material.CreateInput("file", Sdf.ValueTypeNames.Asset).GetAttr().GetPath())
            file_input = material.GetInput("file")
            file_input.Set(Sdf.AssetPath(image_path))
        file_input.GetAttr().SetColorSpace(space)
        bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    return path


@pytest.mark.parametrize("space, mode", [(space, "RGB") for space in TRANSFERS] + [
    ("g22_rec709", "LA"), ("g22_rec709", "ND_UsdUVTexture"), ("g22_rec709", "interface input"),
    ("srgb_displayp3", "interface input"), ("g22_ap1", "LA"), ("g22_ap1", "ND_UsdUVTexture")])
def test_a_colour_image_is_decoded_by_its_colour_spaces_transfer_function(tmp_path, space, mode):
    """An ``ND_image_color3`` (or ``ND_UsdUVTexture``) whose ``file`` is in one of the MaterialX colour spaces other
    than ``srgb_texture`` and ``lin_rec709`` reads an 8-bit PNG's samples through that space's transfer function
    (``g22_rec709``: ``(s / 255)^2.2``; of a grey + alpha file the alpha the node lays into g too, as MaterialX
    transforms the node's output), then converts the colour of a space of other primaries to Rec.709's as
    ``Gf.ColorSpace.Convert`` converts it from the linear space of those primaries, as MaterialX's colour transforms
    convert to its working space; the colour space may be that of the Material input the ``file`` connects to.
    Every one was read as stored, named as read linear: a ``g22_rec709`` texel of 128 read 0.502 for MaterialX's
    0.220, and ``lin_srgb``, the same space as ``lin_rec709``, was named; then the spaces of other
    primaries were decoded alone, named."""
    samples = np.array([51, 204]) if mode == "LA" else np.array([51, 102, 153])
    png = write_png(tmp_path / "colour.png", np.tile(samples, (2, 2, 1)))
    node = mode if mode in ("ND_UsdUVTexture", "interface input") else "ND_image_color3"
    scene, messages = load(colour_image_stage(tmp_path, png, space, node))
    decode, primaries = TRANSFERS[space]
    assert not messages, messages
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["diffuseColor"].image][..., :3].astype(np.float64)
    expected = np.append(decode(samples / 255.0), [0.0] * (3 - len(samples)))  # (c, a, 0) of grey + alpha
    if primaries is not None:
        rec709 = Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709)
        expected = np.array(rec709.Convert(Gf.ColorSpace(primaries), Gf.Vec3f(*expected)).GetRGB(), np.float64)
    np.testing.assert_allclose(texels, np.broadcast_to(expected, texels.shape), rtol=1e-5, atol=1e-6)


READER_INPUTS = {"ND_geompropvalue_vector2": ("geomprop", "default"),  # texcoord readers: (primvar, fallback)
                 "ND_UsdPrimvarReader_vector2": ("varname", "fallback"),
                 "UsdPrimvarReader_float2": ("varname", "fallback")}


def texcoord_stage(tmp_path, png, texcoord):
    """A quad without ``st`` whose standard_surface base_color is an ``ND_image_color3`` (``clamp`` addressing) of
    ``png``, its ``texcoord`` either ``(reader id, name, default)``: a reader of :data:`READER_INPUTS` of primvar
    ``name`` (``default`` authored unless None), or ``("constant", value)`` authored on the image node."""
    stage, path = new_stage(tmp_path, f"texcoord_{texcoord[0]}.usda")
    quad = add_quad(stage, "/Quad")
    UsdGeom.PrimvarsAPI(quad).RemovePrimvar("st")
    material, shader = mtlx_material(stage, "/Looks/Coords")
    image = UsdShade.Shader.Define(stage, "/Looks/Coords/Image")
    image.CreateIdAttr("ND_image_color3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    for key in ("uaddressmode", "vaddressmode"):
        image.CreateInput(key, Sdf.ValueTypeNames.String).Set("clamp")
    image.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    if texcoord[0] in READER_INPUTS:
        reader = UsdShade.Shader.Define(stage, "/Looks/Coords/Reader")
        reader.CreateIdAttr(texcoord[0])
        name_input, default_input = READER_INPUTS[texcoord[0]]
        reader.CreateInput(name_input, Sdf.ValueTypeNames.String).Set(texcoord[1])
        if texcoord[2] is not None:
            reader.CreateInput(default_input, Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*texcoord[2]))
        reader.CreateOutput("out", Sdf.ValueTypeNames.Float2)
        image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "out")
    else:
        image.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*texcoord[1]))
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    return path


# 2 x 2 texels, rows from the top: red, green over blue, white (0 and 255 only: the same in sRGB and linear).
CORNERS = [[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]]


@pytest.mark.parametrize("reader", list(READER_INPUTS))
def test_a_geompropvalue_texcoord_default_is_the_st_of_a_mesh_without_the_primvar(tmp_path, reader):
    """An ``ND_geompropvalue_vector2`` texcoord reading a primvar the mesh lacks gives its ``default`` on every
    point, as a UsdPrimvarReader_float2's fallback does (the warning names it). It gave (0, 0), the bottom-left
    texel, whatever the default. A UsdPrimvarReader (MaterialX's ``ND_UsdPrimvarReader_vector2`` or USD's own) as the
    texcoord reads its ``varname`` and ``fallback`` alike; it was named in a warning and ``st`` read."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    scene, messages = load(texcoord_stage(tmp_path, png, (reader, "uv_missing", (0.75, 0.25))))
    assert any("uv_missing, fallback (0.75, 0.25)" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene, 2), 1.0, atol=1e-3)  # the bottom-right texel: white


def name_from_a_constant_node(stage, reader, key: str, name: str) -> None:
    """Feeds string input ``key`` of shader ``reader`` from an ``ND_constant_string`` of ``name`` beside it."""
    constant = UsdShade.Shader.Define(stage, reader.GetPath().AppendElementString(f"{key}_name"))
    constant.CreateIdAttr("ND_constant_string")
    constant.CreateInput("value", Sdf.ValueTypeNames.String).Set(name)
    constant.CreateOutput("out", Sdf.ValueTypeNames.String)
    reader.CreateInput(key, Sdf.ValueTypeNames.String).ConnectToSource(constant.ConnectableAPI(), "out")


@pytest.mark.parametrize("reader", ["ND_geompropvalue_vector2", "ND_UsdPrimvarReader_vector2"])
def test_a_texcoord_primvar_named_by_a_constant_node_is_read(tmp_path, reader):
    """A texcoord reader whose ``geomprop`` (``varname``) is fed by an ``ND_constant_string`` of ``uv2`` reads the
    mesh's primvar ``uv2``, as with the name authored on the input. Oracle: ``uv2`` is the quad's st mirrored in s,
    so the 2 x 2 pixels show :data:`CORNERS` mirrored left to right. The name was read as none, the reader's
    ``default`` (0, 0) drawn on every point (blue) with a warning that it was empty or unauthored."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    path = texcoord_stage(tmp_path, png, (reader, "", None))
    stage = Usd.Stage.Open(path)
    source = UsdShade.Shader.Get(stage, "/Looks/Coords/Reader")
    name_from_a_constant_node(stage, source, READER_INPUTS[reader][0], "uv2")
    quad = UsdGeom.Mesh.Get(stage, "/Quad")
    mirrored = [Gf.Vec2f(1.0 - (p[0] + 1.0) / 2.0, (p[1] + 1.0) / 2.0) for p in quad.GetPointsAttr().Get()]
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar("uv2", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        mirrored)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene, 2), np.asarray(CORNERS)[:, ::-1] / 255.0, atol=1e-3)


@pytest.mark.parametrize("reader", list(READER_INPUTS))
def test_a_texcoord_default_fed_by_a_constant_node_is_its_value(tmp_path, reader):
    """A texcoord reader of a primvar the mesh lacks whose ``default`` (``fallback``) is fed by an
    ``ND_constant_vector2`` of (0.75, 0.25) reads that st on every point, as with the value authored on the input
    (the warning names the missing primvar and that st). Oracle: the bottom-right texel of :data:`CORNERS`, white.
    It was read as unauthored, (0, 0), without a word: the bottom-left texel, blue."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    path = texcoord_stage(tmp_path, png, (reader, "uv_missing", None))
    stage = Usd.Stage.Open(path)
    constant = UsdShade.Shader.Define(stage, "/Looks/Coords/Corner")
    constant.CreateIdAttr("ND_constant_vector2")
    constant.CreateInput("value", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.75, 0.25))
    constant.CreateOutput("out", Sdf.ValueTypeNames.Float2)
    UsdShade.Shader.Get(stage, "/Looks/Coords/Reader").CreateInput(READER_INPUTS[reader][1],
                                                                   Sdf.ValueTypeNames.Float2).ConnectToSource(
        constant.ConnectableAPI(), "out")
    stage.Save()
    scene, messages = load(path)
    assert any("uv_missing, fallback (0.75, 0.25)" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene, 2), 1.0, atol=1e-3)


def test_a_colour_primvar_named_by_a_constant_node_is_read(tmp_path):
    """An ``ND_geompropvalue_color3`` base_color whose ``geomprop`` is fed by an ``ND_constant_string`` of ``tint``
    reads the mesh's constant primvar ``tint`` (0.25, 0.5, 0.75), as with the name authored on the input. It was
    read as none: the reader's fallback (0) drawn, with a warning that it names no primvar."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar("tint", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant).Set(
        [Gf.Vec3f(0.25, 0.5, 0.75)])
    material, shader = mtlx_material(stage, "/Looks/Tinted")
    reader = UsdShade.Shader.Define(stage, "/Looks/Tinted/Reader")
    reader.CreateIdAttr("ND_geompropvalue_color3")
    reader.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    name_from_a_constant_node(stage, reader, "geomprop", "tint")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(reader.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene, 2), np.broadcast_to([0.25, 0.5, 0.75], (2, 2, 3)), atol=1e-6)


def test_a_primvar_name_from_another_node_is_named(tmp_path):
    """A texcoord reader's ``geomprop`` fed by a node that gives no constant string is named in a warning with the
    node; the reader names no primvar then (its default on every point, as before, with that warning too)."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    path = texcoord_stage(tmp_path, png, ("ND_geompropvalue_vector2", "", None))
    stage = Usd.Stage.Open(path)
    other = UsdShade.Shader.Define(stage, "/Looks/Coords/Other")
    other.CreateIdAttr("ND_geompropvalue_string")
    other.CreateOutput("out", Sdf.ValueTypeNames.String)
    UsdShade.Shader.Get(stage, "/Looks/Coords/Reader").GetInput("geomprop").ConnectToSource(other.ConnectableAPI(),
                                                                                          "out")
    stage.Save()
    _, messages = load(path)
    assert any("/Looks/Coords" in m and "geomprop comes from a ND_geompropvalue_string node (/Looks/Coords/Other)" in m
               for m in messages), messages


@pytest.mark.parametrize("surface", ["UsdPreviewSurface", "standard_surface"])
def test_a_colour_primvar_reader_that_names_no_primvar_gives_its_fallback(tmp_path, surface):
    """A colour primvar reader (USD's ``UsdPrimvarReader_float3``, MaterialX's ``ND_geompropvalue_color3``) whose
    primvar name is empty, Sdr's and the nodedefs' default, names no primvar: Storm's primvar redirect reads none and
    gives the reader's fallback (default), here (0.3, 0.5, 0.7), though the mesh has displayColor (red). wrt kept the
    surface's own constant (UsdPreviewSurface's diffuseColor 0.18, standard_surface's base_color 0.8)."""
    stage, path = new_stage(tmp_path, f"{surface}.usda")
    quad = add_quad(stage, "/Quad")
    UsdGeom.Mesh(quad).CreateDisplayColorAttr([(1.0, 0.0, 0.0)])
    if surface == "UsdPreviewSurface":
        material, shader = preview_material(stage, "/Looks/M")
        reader_id, name_input, fallback_input, target = "UsdPrimvarReader_float3", "varname", "fallback", "diffuseColor"
    else:
        material, shader = mtlx_material(stage, "/Looks/M", base=1.0)
        reader_id, name_input, fallback_input, target = "ND_geompropvalue_color3", "geomprop", "default", "base_color"
    reader = UsdShade.Shader.Define(stage, "/Looks/M/Reader")
    reader.CreateIdAttr(reader_id)
    reader.CreateInput(name_input, Sdf.ValueTypeNames.String).Set("")
    reader.CreateInput(fallback_input, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.3, 0.5, 0.7))
    reader.CreateOutput("result" if surface == "UsdPreviewSurface" else "out", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput(target, Sdf.ValueTypeNames.Color3f).ConnectToSource(
        reader.ConnectableAPI(), "result" if surface == "UsdPreviewSurface" else "out")
    bind(quad, material)
    stage.Save()
    scene, messages = load(path)
    assert any("names no primvar" in m and "/Looks/M/Reader" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene, 2), np.broadcast_to([0.3, 0.5, 0.7], (2, 2, 3)), atol=1e-3)


@pytest.mark.parametrize("reader", list(READER_INPUTS))
def test_a_texcoord_reader_that_names_no_primvar_gives_its_default_everywhere(tmp_path, reader):
    """A texcoord reader whose primvar name (``geomprop``, ``varname``) is empty names no primvar (the nodedefs'
    and Sdr's default is ``""``): its ``default`` (``fallback``) on every point, with a warning naming the node,
    though the mesh has ``st``. wrt read the mesh's ``st`` without a word: the four texels where one, the
    bottom-right (white), belongs."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    path = texcoord_stage(tmp_path, png, (reader, "", (0.75, 0.25)))
    stage = Usd.Stage.Open(path)
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad")).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set([(0, 0), (1, 0), (0, 1), (1, 1)])
    stage.Save()
    scene, messages = load(path)
    assert any("names no primvar" in m and "/Looks/Coords/Reader" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene, 2), 1.0, atol=1e-3)  # the bottom-right texel: white


def test_a_constant_texcoord_reads_one_point_of_the_image(tmp_path):
    """An image node's ``texcoord`` authored as a constant is where the image is read, on every point; it was
    named in a warning and the mesh's ``st`` read (here the mesh has none, and needs none: no warning)."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    scene, messages = load(texcoord_stage(tmp_path, png, ("constant", (0.25, 0.75))))
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene, 2), np.broadcast_to([1, 0, 0], (2, 2, 3)), atol=1e-3)  # top-left: red


def test_constant_addressing_reads_the_image_nodes_default_outside_the_unit_square(tmp_path):
    """``uaddressmode``/``vaddressmode`` ``constant`` give the node's ``default`` outside [0, 1], as the MaterialX
    specification defines it ("Texture coordinates outside the 0-1 range return the value of the node's default
    input"); the image inside. It read black (UsdUVTexture's ``black``) there, whatever the default."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    stage, path = new_stage(tmp_path, "constant.usda")
    bind(add_quad(stage, "/Quad", st_range=2.0), mtlx_material(stage, "/Looks/Border")[0])
    shader = UsdShade.Shader.Get(stage, "/Looks/Border/Surface")
    image = UsdShade.Shader.Define(stage, "/Looks/Border/Image")
    image.CreateIdAttr("ND_image_color3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.CreateInput("default", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.4, 0.6))
    for key in ("uaddressmode", "vaddressmode"):
        image.CreateInput(key, Sdf.ValueTypeNames.String).Set("constant")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    img = albedo(scene, 4)  # st over [0, 2]^2: the image fills the bottom-left quarter
    np.testing.assert_allclose(img[2:, :2], np.array(CORNERS) / 255.0, atol=1e-3)
    outside = np.concatenate([img[:2].reshape(-1, 3), img[2:, 2:].reshape(-1, 3)])
    np.testing.assert_allclose(outside, np.broadcast_to([0.2, 0.4, 0.6], outside.shape), atol=1e-3)


@pytest.mark.parametrize("readable", [False, True])
def test_an_extract_of_a_colour4_image_reads_the_channel_of_its_default(tmp_path, readable):
    """OpenPBR ``geometry_opacity`` from channel 3 (alpha) of an ``ND_image_color4`` through ``ND_extract_color4``:
    where the file cannot be read the node's ``default`` (0.9, 0.9, 0.9, 0.2) stands in for the image, so the
    opacity is its alpha, 0.2, a hole; where it can, the texture's fallback (a missing UDIM tile's texel) is that
    default too. The default was cut to the one number of the surface input it feeds, its red, 0.9: opaque."""
    stage, path = new_stage(tmp_path, "extract.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Leaf", OPEN_PBR)[0])
    shader = UsdShade.Shader.Get(stage, "/Looks/Leaf/Surface")
    png = write_png(tmp_path / "mask.png", np.full((2, 2, 4), 255)) if readable else "missing.png"
    image = UsdShade.Shader.Define(stage, "/Looks/Leaf/Image")
    image.CreateIdAttr("ND_image_color4")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.CreateInput("default", Sdf.ValueTypeNames.Color4f).Set(Gf.Vec4f(0.9, 0.9, 0.9, 0.2))
    alpha = UsdShade.Shader.Define(stage, "/Looks/Leaf/Alpha")
    alpha.CreateIdAttr("ND_extract_color4")
    alpha.CreateInput("in", Sdf.ValueTypeNames.Color4f).ConnectToSource(image.ConnectableAPI(), "out")
    alpha.CreateInput("index", Sdf.ValueTypeNames.Int).Set(3)
    shader.CreateInput("geometry_opacity", Sdf.ValueTypeNames.Float).ConnectToSource(alpha.ConnectableAPI(), "out")
    stage.Save()
    scene, _ = load(path)
    (mat,) = scene.materials
    assert mat.opacity_threshold == 0.5
    if readable:
        texture = mat.textures["opacity"]
        assert texture.channel == "a"
        assert texture.fallback[3] == pytest.approx(0.2)
    else:
        assert "opacity" not in mat.textures and mat.opacity == pytest.approx(0.2)


# MaterialX's stdlib_defs.mtlx (1.38, AcademySoftwareFoundation/MaterialX libraries/stdlib): the ``default`` input of
# each image node, 0 in every channel of the node's type.
IMAGE_DEFAULTS = {"ND_image_float": (0.0,), "ND_image_color3": (0.0, 0.0, 0.0),
                  "ND_tiledimage_color3": (0.0, 0.0, 0.0)}


@pytest.mark.parametrize("node_id, surface_input", [("ND_image_color3", "emission_color"),
                                                     ("ND_tiledimage_color3", "emission_color"),
                                                     ("ND_image_float", "emission")])
def test_a_missing_image_without_a_default_reads_materialx_s_default(tmp_path, node_id, surface_input):
    """An image node whose file is missing and which has no ``default`` reads MaterialX's default for it, 0, so a
    black panel whose ``emission_color`` (or ``emission`` weight) comes from it emits nothing: the render is black.
    The surface input's constant, 1 authored beside the connection, stood in for it: the panel glowed white.
    The warning names the file and the image node."""
    stage, path = new_stage(tmp_path, "glow.usda")
    material, shader = mtlx_material(stage, "/Looks/Panel", base=0.0, specular=0.0, emission=1.0,
                                     emission_color=Gf.Vec3f(1.0, 1.0, 1.0))
    image = UsdShade.Shader.Define(stage, "/Looks/Panel/Image")
    image.CreateIdAttr(node_id)
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("missing.png"))
    shader.GetInput(surface_input).ConnectToSource(image.ConnectableAPI(), "out")  # its value 1 stays authored
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert any("missing.png" in m and "/Looks/Panel/Image" in m for m in messages), messages
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.emissive_color, np.resize(IMAGE_DEFAULTS[node_id], 3) * 1.0, atol=1e-7)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu")
    np.testing.assert_allclose(img.rgb, 0.0, atol=1e-6)


def test_a_weight_read_from_an_images_alpha_is_scaled_by_its_colour(tmp_path):
    """OpenPBR ``emission_luminance`` from the alpha of an ``ND_image_color4`` (an emission mask, through
    ``ND_extract_color4`` index 3) times a constant grey ``emission_color`` 0.5 emits ``alpha * colour``: texels of
    alpha 0.6 show 0.3. The colour scaled only the texture's r, g and b, which the alpha output does not read: the
    emission was the bare alpha, 0.6."""
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 3] = 153  # alpha 0.6 (alpha is never sRGB-decoded)
    png = str(tmp_path / "mask.png")
    PilImage.fromarray(rgba, "RGBA").save(png)
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Panel", OPEN_PBR, base_weight=0.0, specular_weight=0.0,
                                     emission_color=Gf.Vec3f(0.5, 0.5, 0.5))
    image = UsdShade.Shader.Define(stage, "/Looks/Panel/Image")
    image.CreateIdAttr("ND_image_color4")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    alpha = UsdShade.Shader.Define(stage, "/Looks/Panel/Alpha")
    alpha.CreateIdAttr("ND_extract_color4")
    alpha.CreateInput("in", Sdf.ValueTypeNames.Color4f).ConnectToSource(image.ConnectableAPI(), "out")
    alpha.CreateInput("index", Sdf.ValueTypeNames.Int).Set(3)
    shader.CreateInput("emission_luminance", Sdf.ValueTypeNames.Float).ConnectToSource(alpha.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, _ = load(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu")
    np.testing.assert_allclose(img.rgb, 0.3, rtol=2e-3)


def test_a_separate3_splits_an_orm_image_into_roughness_and_metalness(tmp_path):
    """``specular_roughness`` and ``metalness`` from the ``outg`` and ``outb`` outputs of an ``ND_separate3_color3``
    of one packed (occlusion, roughness, metalness) image, as glTF-style ORM maps are wired, render as the same
    material of those constants (here one texel: roughness 0.6, metalness 0.2, read raw). The ``separate3`` was not
    folded: both inputs kept their defaults (0.2 and 0), with a warning."""
    png = write_png(tmp_path / "orm.png", [[[255, 153, 51]]])

    def orm(stage):
        material, shader = mtlx_material(stage, "/Looks/Orm", base_color=GOLD)
        image = UsdShade.Shader.Define(stage, "/Looks/Orm/Image")
        image.CreateIdAttr("ND_image_color3")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
        image.GetInput("file").GetAttr().SetColorSpace("raw")
        split = UsdShade.Shader.Define(stage, "/Looks/Orm/Split")
        split.CreateIdAttr("ND_separate3_color3")
        split.CreateInput("in", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
        for name, output in (("specular_roughness", "outg"), ("metalness", "outb")):
            split.CreateOutput(output, Sdf.ValueTypeNames.Float)
            shader.CreateInput(name, Sdf.ValueTypeNames.Float).ConnectToSource(split.ConnectableAPI(), output)
        return material

    packed = lit_sphere_image(tmp_path, orm, "orm")
    constants = lit_sphere_image(tmp_path, lambda s: mtlx_material(s, "/Looks/Orm", base_color=GOLD,
                                                                   specular_roughness=0.6, metalness=0.2)[0], "const")
    defaults = lit_sphere_image(tmp_path, lambda s: mtlx_material(s, "/Looks/Orm", base_color=GOLD)[0], "defaults")
    np.testing.assert_allclose(packed, constants, rtol=0.01)
    assert np.abs(defaults / constants - 1).max() > 0.05, (defaults, constants)  # the test tells them apart


def test_a_displacement_shader_beside_a_standard_surface_is_named(tmp_path):
    """A standard_surface material whose ``outputs:mtlx:displacement`` leads to an ``ND_displacement_float`` is
    named in the displacement warning, as a UsdPreviewSurface material's is (the surface is drawn undisplaced); the
    MaterialX surfaces were read before the displacement check and said nothing."""
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Bumpy")
    displace = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Displace")
    displace.CreateIdAttr("ND_displacement_float")
    displace.CreateInput("displacement", Sdf.ValueTypeNames.Float).Set(1.0)
    displace.CreateInput("scale", Sdf.ValueTypeNames.Float).Set(0.1)
    material.CreateDisplacementOutput("mtlx").ConnectToSource(displace.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    _, messages = load(path)
    assert any("displacement" in m and "/Looks/Bumpy" in m for m in messages), messages


@pytest.mark.parametrize("node_id, value, expected", [("ND_convert_vector2_color3", (0.2, 0.4), (0.2, 0.4, 0.0)),
                                                      ("ND_convert_vector2_vector3", (0.2, 0.4), (0.2, 0.4, 0.0)),
                                                      ("ND_convert_float_color3", 0.3, (0.3, 0.3, 0.3)),
                                                      ("ND_convert_color4_color3", (0.1, 0.2, 0.3, 0.4),
                                                       (0.1, 0.2, 0.3))])
def test_a_converted_constant_gets_the_channels_materialx_gives_it(tmp_path, node_id, value, expected):
    """``base_color`` from a ``convert`` of a constant: a vector2 widened to three channels gets a third of 0 (as
    MaterialX's implementations combine ``(x, y, 0)``), a float fills all three, a colour4 drops its alpha. The
    vector2 was widened by repeating it, ``(x, y, x)``."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Converted")
    convert = UsdShade.Shader.Define(stage, "/Looks/Converted/Convert")
    convert.CreateIdAttr(node_id)
    value_type = {1: Sdf.ValueTypeNames.Float, 2: Sdf.ValueTypeNames.Float2, 4: Sdf.ValueTypeNames.Color4f}
    convert.CreateInput("in", value_type[np.size(value)]).Set(value if np.size(value) == 1 else
                                                              {2: Gf.Vec2f, 4: Gf.Vec4f}[np.size(value)](*value))
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(convert.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, expected, atol=1e-6)


def test_a_colour_opacity_texture_is_named_as_read_by_its_red_channel(tmp_path):
    """standard_surface ``opacity`` (a colour) from an ``ND_image_color3`` is a cut-out of the image's red channel,
    which the material's warning says (the README gives a constant opacity's mean): red 1, green and blue 0 read as
    opaque. It was read so without a word."""
    png = write_png(tmp_path / "red.png", [[[255, 0, 0]]])
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Mask")
    image = UsdShade.Shader.Define(stage, "/Looks/Mask/Image")
    image.CreateIdAttr("ND_image_color3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert any("opacity is a colour image: its red channel is the cut-out" in m for m in messages), messages
    assert (albedo(scene, 2) > 0.5).all()  # opaque everywhere: the red channel, 1 (the mean, 1/3, is a hole)


@pytest.mark.parametrize("inputs", [{}, {"displacement": 0.0}, {"displacement": 1.0, "scale": 0.0},
                                    {"displacement": (0.0, 0.0, 0.0)}])
def test_a_displacement_shader_that_moves_nothing_is_not_named(tmp_path, inputs):
    """An ``ND_displacement_float`` (or ``_vector3``) whose ``displacement`` is 0, MaterialX's default where
    unauthored (``stdlib_defs.mtlx``: displacement 0, scale 1), or whose ``scale`` is 0 displaces nothing, as a
    UsdPreviewSurface's displacement of 0 does, which is not named: every such material was named in the displacement
    warning ('drawn undisplaced'), though its surface is where it would be drawn anyway."""
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Flat")
    displace = UsdShade.Shader.Define(stage, "/Looks/Flat/Displace")
    vector = isinstance(inputs.get("displacement"), tuple)
    displace.CreateIdAttr("ND_displacement_vector3" if vector else "ND_displacement_float")
    for name, value in inputs.items():
        kind = Sdf.ValueTypeNames.Vector3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        displace.CreateInput(name, kind).Set(value)
    material.CreateDisplacementOutput("mtlx").ConnectToSource(displace.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    _, messages = load(path)
    assert not any("displacement" in m for m in messages), messages


@pytest.mark.parametrize("name, type_name, value, field, default", [
    ("base_color", "Float2", Gf.Vec2f(0.1, 0.9), "diffuse_color", 0.8),  # was (0.1, 0.9, 0.1)
    ("base_color", "Matrix3d", Gf.Matrix3d(0.1), "diffuse_color", 0.8),  # was its first three entries
    ("specular_roughness", "Float3", Gf.Vec3f(0.9, 0.0, 0.0), "roughness", 0.2),  # was 0.9
    ("specular_roughness", "String", "0.9", "roughness", 0.2),  # a string of digits was read as 0.9
    ("specular_roughness", "StringArray", ["0.9"], "roughness", 0.2),  # a string[] of digits was read as 0.9
    ("base_color", "TokenArray", ["0.1", "0.9", "0.1"], "diffuse_color", 0.8),  # was (0.1, 0.9, 0.1)
])
def test_an_input_of_the_wrong_shape_keeps_its_default_with_a_note(tmp_path, name, type_name, value, field, default):
    """A standard_surface input authored with another shape than its type's (a float2 or matrix for a colour, a
    colour or a string of digits for a float) keeps the specification's default, named in the material's note, as a
    UsdPreviewSurface input does (eb95f91): it was resized into a colour of its first numbers, or read as its first
    number, without a word. The note says how many numbers it holds (it said "not a finite number", which they are)."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Odd")
    shader.CreateInput(name, getattr(Sdf.ValueTypeNames, type_name)).Set(value)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    (mat,) = scene.materials
    np.testing.assert_allclose(getattr(mat, field), default, rtol=1e-6)
    (warning,) = [m for m in messages if "/Looks/Odd:" in m]
    # Named by what is wrong: a string is no number; the others hold another count of numbers than the input takes
    # (USD's length of the authored value), which are all finite.
    count = len(value) * (len(value[0]) if type_name.startswith("Matrix") else 1)
    expected = "1, 3 or 4 are" if field == "diffuse_color" else "one is"
    text = type_name.startswith(("String", "Token"))
    problem = "not a number" if text else f"authored with {count} numbers where {expected} expected"
    assert f"{name} is {problem}; its default is used" in warning, warning


def test_a_tiling_past_float32_warns_only_in_wrts_words(tmp_path):
    """A ``tiledimage`` whose texture transform passes float32's range is named in the material's note and in no
    other warning: numpy's cast of the transform to float32 raised its own "overflow encountered in cast"
    RuntimeWarning first (an error where warnings are errors, which stopped the load)."""
    png = write_png(tmp_path / "tile.png", np.full((2, 2, 3), 200))
    path = tiled_stage(tmp_path, png, 3e38)
    stage = Usd.Stage.Open(path)
    image = UsdShade.Shader.Get(stage, "/Looks/Tiles/Graph/Image")
    image.CreateInput("realworldimagesize", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(1e-10, 1e-10))
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.load_usd(path)
    assert [w.category for w in caught] == [UserWarning], [str(w.message) for w in caught]
    assert "/Looks/Tiles" in str(caught[0].message) and "float32" in str(caught[0].message)


@pytest.mark.parametrize("node_id", ["ND_image_color3", "ND_tiledimage_color3"])
def test_closest_filtertype_reads_the_texel_under_each_point(tmp_path, node_id):
    """An image node's ``filtertype`` ``closest`` (MaterialX's nearest-texel filter: pixel art, id and mask maps,
    Maya's file nodes with filtering off) reads the one texel whose square holds ``st``, wrapped by the address mode.
    It was filtered bilinearly without a word: between texel centres the colours blended. The oracle: texel
    ``(floor(s w) mod w, floor((1 - t) h) mod h)`` of the image, at the ``st`` of each pixel centre."""
    texels = PIXELS
    png = write_png(tmp_path / "pixels.png", texels)
    stage, path = new_stage(tmp_path, "closest.usda")
    bind(add_quad(stage, "/Quad", st_range=2.0), mtlx_material(stage, "/Looks/Pixels")[0])
    closest_image(stage, "/Looks/Pixels", png, node_id=node_id)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    res = 12
    centres = (np.arange(res) + 0.5) / res * 2.0  # st over [0, 2]^2 (periodic: the image twice each way)
    s, t = np.meshgrid(centres, centres[::-1])  # row 0 at the top: t near 2
    h, w = texels.shape[:2]
    expected = texels[np.floor((2.0 - t) * h).astype(int) % h, np.floor(s * w).astype(int) % w] / 255.0
    np.testing.assert_allclose(albedo(scene, res), expected, atol=1e-3)


@pytest.mark.parametrize("filtertype, note", [("cubic", "filtertype cubic is read as linear"),
                                              ("box", "filtertype 'box' is none of closest, linear or cubic")])
def test_a_filtertype_other_than_closest_or_linear_is_named_and_read_as_linear(tmp_path, filtertype, note):
    """``cubic`` (which wrt does not filter with) and a token MaterialX does not define are named in the material's
    warning, with the image node, and read as ``linear``: bilinear blends of the two texels."""
    png = write_png(tmp_path / "pair.png", [[[255, 0, 0], [0, 0, 255]]])
    stage, path = new_stage(tmp_path, f"{filtertype}.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Pair")[0])
    base_color_image(stage, "/Looks/Pair", png, filtertype=filtertype)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Pair/Image" in m and note in m for m in messages), messages
    row = albedo(scene, 4)[1]  # s at 1/8, 3/8, 5/8, 7/8: a quarter texel from the centres (periodic at the edges)
    np.testing.assert_allclose(row, [[0.75, 0, 0.25], [0.75, 0, 0.25], [0.25, 0, 0.75], [0.25, 0, 0.75]], atol=1e-3)


@pytest.mark.parametrize("layer", ["diffuse", ""])
def test_an_image_layer_is_named_as_not_read(tmp_path, layer):
    """An image node's ``layer`` (which layer of a multi-layer EXR to read) was ignored without a word: wrt reads the
    file's unnamed layer. A layer authored and not empty is named in the material's warning, with the node; an empty
    one (MaterialX's default: the file's default layer) is what wrt reads, and says nothing."""
    png = write_png(tmp_path / "red.png", [[[255, 0, 0]]])
    stage, path = new_stage(tmp_path, "layer.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Layered")[0])
    base_color_image(stage, "/Looks/Layered", png, layer=layer)
    stage.Save()
    scene, messages = load(path)
    named = [m for m in messages if "/Looks/Layered/Image" in m and "layer 'diffuse'" in m]
    assert (len(named) == 1, len(messages)) == ((True, 1) if layer else (False, 0)), messages
    np.testing.assert_allclose(albedo(scene, 2), np.broadcast_to([1.0, 0, 0], (2, 2, 3)), atol=1e-3)  # still read


def test_an_address_mode_materialx_does_not_define_is_named_and_read_as_periodic(tmp_path):
    """``uaddressmode`` ``repeat`` (UsdUVTexture's token, not one of MaterialX's constant, clamp, periodic or
    mirror) is read as periodic, as Storm reads it, and named in the material's warning with the node and the
    token; it was read so without a word. The image (red, blue) over st in [0, 2]: periodic shows it twice."""
    png = write_png(tmp_path / "pair.png", [[[255, 0, 0], [0, 0, 255]]])
    stage, path = new_stage(tmp_path, "address.usda")
    bind(add_quad(stage, "/Quad", st_range=2.0), mtlx_material(stage, "/Looks/Pair")[0])
    image = closest_image(stage, "/Looks/Pair", png)
    image.CreateInput("uaddressmode", Sdf.ValueTypeNames.String).Set("repeat")
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Pair/Image" in m and "uaddressmode 'repeat'" in m for m in messages), messages
    row = albedo(scene, 4)[0]  # s at 1/4, 3/4, 5/4, 7/4: texel 0, 1, then 0, 1 again
    np.testing.assert_allclose(row, [[1, 0, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1]], atol=1e-3)


def place2d_oracle(st, pivot, scale, rotate, offset, order):
    """MaterialX's ``NG_place2d_vector2`` (stdlib_ng.mtlx) in float64: ``order`` 0 (SRT) ``rot((st - pivot) / scale)
    - offset + pivot``, 1 (TRS) ``rot(st - pivot - offset) / scale + pivot``; ``rotate2d`` by ``a`` degrees is
    ``(x cos a + y sin a, -x sin a + y cos a)``."""
    a = np.radians(rotate)

    def rot(v):
        return np.stack([v[..., 0] * np.cos(a) + v[..., 1] * np.sin(a), -v[..., 0] * np.sin(a) + v[..., 1] * np.cos(a)],
                        axis=-1)

    if order == 0:
        return rot((st - pivot) / scale) - offset + pivot
    return rot(st - pivot - offset) / scale + pivot


@pytest.mark.parametrize("order", [0, 1])
def test_a_place2d_node_maps_the_texture_coordinates(tmp_path, order):
    """An ``ND_place2d_vector2`` between an image node and its texture coordinates (as Maya's MaterialX export
    writes every file texture) moves the image by its pivot, scale, rotate, offset and operationorder, as MaterialX's
    node graph defines it; its own ``texcoord`` (here a ``geompropvalue`` of primvar ``uv``) is read. It was named
    as unsupported and primvar ``st`` read, unplaced. Oracle: the texel under each pixel centre's placed st."""
    texels = PIXELS
    png = write_png(tmp_path / "pixels.png", texels)
    stage, path = new_stage(tmp_path, f"place{order}.usda")
    quad = add_quad(stage, "/Quad")
    primvars = UsdGeom.PrimvarsAPI(quad)
    primvars.CreatePrimvar("uv", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        primvars.GetPrimvar("st").Get())
    primvars.RemovePrimvar("st")
    bind(quad, mtlx_material(stage, "/Looks/Placed")[0])
    reader = UsdShade.Shader.Define(stage, "/Looks/Placed/Uv")
    reader.CreateIdAttr("ND_geompropvalue_vector2")
    reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("uv")
    place = UsdShade.Shader.Define(stage, "/Looks/Placed/Place")
    place.CreateIdAttr("ND_place2d_vector2")
    place.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "out")
    inputs = {"pivot": (0.5, 0.25), "scale": (0.4, 1.6), "rotate": 30.0, "offset": (0.2, -0.35)}
    for name, value in inputs.items():
        type_name = Sdf.ValueTypeNames.Float if name == "rotate" else Sdf.ValueTypeNames.Float2
        place.CreateInput(name, type_name).Set(value)
    place.CreateInput("operationorder", Sdf.ValueTypeNames.Int).Set(order)
    closest_image(stage, "/Looks/Placed", png, place)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    st = place2d_oracle(pixel_centre_st(16), np.array(inputs["pivot"]), np.array(inputs["scale"]), inputs["rotate"],
                        np.array(inputs["offset"]), order)
    assert_reads_the_texels_at(scene, texels, st)


def test_a_place2d_s_inputs_fed_by_constant_nodes_place_the_image(tmp_path):
    """A ``place2d`` whose pivot, scale, rotate, offset and operationorder each come from a ``constant`` node (of
    vector2, float, integer) places the image as with them authored on it. Oracle: :func:`place2d_oracle`'s texel
    under each pixel centre (order 1). Such inputs were named and the place2d ignored: the image read unplaced."""
    texels = PIXELS
    png = write_png(tmp_path / "pixels.png", texels)
    stage, path = new_stage(tmp_path, "place_fed.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Placed")[0])
    place = UsdShade.Shader.Define(stage, "/Looks/Placed/Place")
    place.CreateIdAttr("ND_place2d_vector2")
    inputs = {"pivot": (0.5, 0.25), "scale": (0.4, 1.6), "rotate": 30.0, "offset": (0.2, -0.35),
              "operationorder": 1}
    for name, value in inputs.items():
        kind, type_name = {"rotate": ("float", Sdf.ValueTypeNames.Float),
                           "operationorder": ("integer", Sdf.ValueTypeNames.Int)}.get(
            name, ("vector2", Sdf.ValueTypeNames.Float2))
        constant = UsdShade.Shader.Define(stage, f"/Looks/Placed/{name}_value")
        constant.CreateIdAttr(f"ND_constant_{kind}")
        constant.CreateInput("value", type_name).Set(value)
        constant.CreateOutput("out", type_name)
        place.CreateInput(name, type_name).ConnectToSource(constant.ConnectableAPI(), "out")
    closest_image(stage, "/Looks/Placed", png, place)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    st = place2d_oracle(pixel_centre_st(16), np.array(inputs["pivot"]), np.array(inputs["scale"]), inputs["rotate"],
                        np.array(inputs["offset"]), 1)
    assert_reads_the_texels_at(scene, texels, st)


def test_a_place2d_input_fed_by_a_node_is_named_and_the_node_ignored(tmp_path):
    """A ``place2d`` whose ``offset`` comes from another node (wrt folds constants only) is named in the material's
    warning, with the input, and the image read at its unplaced texture coordinates: texel 0 then texel 1."""
    png = write_png(tmp_path / "pair.png", [[[255, 0, 0], [0, 0, 255]]])
    stage, path = new_stage(tmp_path, "fed.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Fed")[0])
    offset = UsdShade.Shader.Define(stage, "/Looks/Fed/Offset")
    offset.CreateIdAttr("ND_texcoord_vector2")
    place = UsdShade.Shader.Define(stage, "/Looks/Fed/Place")
    place.CreateIdAttr("ND_place2d_vector2")
    place.CreateInput("offset", Sdf.ValueTypeNames.Float2).ConnectToSource(offset.ConnectableAPI(), "out")
    closest_image(stage, "/Looks/Fed", png, place)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Fed/Place: offset comes from a node; the place2d is ignored" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene, 2), [[[1, 0, 0], [0, 0, 1]]] * 2, atol=1e-3)


def test_a_place2d_input_authored_as_strings_keeps_its_default_with_a_note(tmp_path):
    """A ``place2d`` ``offset`` authored as a ``string[]`` of digits (``["0.5", "0"]``) is no numbers: it keeps its
    default, (0, 0), named in the material's note, and the image is read unplaced (texel 0 then texel 1). numpy read
    the strings as the offset (0.5, 0), shifting the image by half of it without a word."""
    png = write_png(tmp_path / "pair.png", [[[255, 0, 0], [0, 0, 255]]])
    stage, path = new_stage(tmp_path, "strings.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Text")[0])
    place = UsdShade.Shader.Define(stage, "/Looks/Text/Place")
    place.CreateIdAttr("ND_place2d_vector2")
    place.CreateInput("offset", Sdf.ValueTypeNames.StringArray).Set(["0.5", "0"])
    closest_image(stage, "/Looks/Text", png, place)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Text/Place: offset is not 2 finite number(s); its default is used" in m for m in messages), \
        messages
    np.testing.assert_allclose(albedo(scene, 2), [[[1, 0, 0], [0, 0, 1]]] * 2, atol=1e-3)


def rotate2d_oracle(v, degrees):
    """MaterialX's ``rotate2d`` (mx_rotate_vector2): ``(x cos a + y sin a, -x sin a + y cos a)``."""
    a = np.radians(degrees)
    return np.stack([v[..., 0] * np.cos(a) + v[..., 1] * np.sin(a), -v[..., 0] * np.sin(a) + v[..., 1] * np.cos(a)],
                    axis=-1)


# Chains of vector2 math nodes between ND_texcoord_vector2 and an image: (node id, input the chain enters, other
# input's name and constant) from the texcoord on, and the map they compute (float64 oracle).
TEXCOORD_CHAINS = {
    "tile, shift, turn": ([("ND_multiply_vector2", "in1", "in2", (2.5, 1.5)),
                           ("ND_subtract_vector2FA", "in1", "in2", 0.3),
                           ("ND_rotate2d_vector2", "in", "amount", 40.0)],
                          lambda st: rotate2d_oracle(st * (2.5, 1.5) - 0.3, 40.0)),
    "divide, add, flip": ([("ND_divide_vector2", "in1", "in2", (0.5, 0.25)),
                           ("ND_add_vector2", "in2", "in1", (0.1, 0.7)),
                           ("ND_subtract_vector2", "in2", "in1", (1.0, 1.0)),
                           ("ND_multiply_vector2FA", "in1", "in2", 0.75)],
                          lambda st: ((1.0, 1.0) - ((0.1, 0.7) + st / (0.5, 0.25))) * 0.75),
}


@pytest.mark.parametrize("chain", list(TEXCOORD_CHAINS))
def test_vector2_math_of_constants_on_texture_coordinates_maps_them(tmp_path, chain):
    """``multiply``, ``divide``, ``add``, ``subtract`` (their ``FA`` forms too) and ``rotate2d`` nodes between the
    ``texcoord`` node and an image, each with a constant beside the coordinates (tiling and shifting, as node editors
    wire them), map the coordinates as MaterialX defines those nodes. They were named as unsupported and primvar st
    read unmapped. Oracle: the texel under each pixel centre's mapped st (closest filter, periodic)."""
    nodes, oracle = TEXCOORD_CHAINS[chain]
    texels = PIXELS
    png = write_png(tmp_path / "pixels.png", texels)
    stage, path = new_stage(tmp_path, "math.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Math")[0])
    source = UsdShade.Shader.Define(stage, "/Looks/Math/Texcoord")
    source.CreateIdAttr("ND_texcoord_vector2")
    for k, (node_id, chain_input, other_input, constant) in enumerate(nodes):
        node = UsdShade.Shader.Define(stage, f"/Looks/Math/Node{k}")
        node.CreateIdAttr(node_id)
        node.CreateInput(chain_input, Sdf.ValueTypeNames.Float2).ConnectToSource(source.ConnectableAPI(), "out")
        scalar = isinstance(constant, float)
        node.CreateInput(other_input, Sdf.ValueTypeNames.Float if scalar else Sdf.ValueTypeNames.Float2).Set(
            constant if scalar else Gf.Vec2f(*constant))
        source = node
    closest_image(stage, "/Looks/Math", png, source)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    assert_reads_the_texels_at(scene, texels, oracle(pixel_centre_st(16)))


# base_color chains on an image (colour3 or float, read raw): (nodes from the image on: id, input the chain enters,
# other input and its constant or None), and the colour they give of a texel (float64 oracle).
OFFSET_CHAINS = {
    "scale and shift": ("ND_image_color3", [("ND_multiply_color3FA", "in1", "in2", 0.5),
                                            ("ND_add_color3", "in2", "in1", (0.1, 0.2, 0.3))],
                        lambda c: c * 0.5 + (0.1, 0.2, 0.3)),
    "invert": ("ND_image_color3", [("ND_invert_color3", "in", None, None)], lambda c: 1.0 - c),
    "invert by an amount": ("ND_image_color3", [("ND_invert_color3FA", "in", "amount", 0.9)], lambda c: 0.9 - c),
    "subtract from": ("ND_image_color3", [("ND_subtract_color3", "in2", "in1", (0.9, 0.8, 0.7))],
                      lambda c: (0.9, 0.8, 0.7) - c),
    "grey plus grey": ("ND_image_float", [("ND_convert_float_color3", "in", None, None),
                                          ("ND_add_color3FA", "in1", "in2", 0.2),
                                          ("ND_subtract_color3FA", "in1", "in2", 0.05)],
                       lambda c: c[..., :1] + 0.15),
}


@pytest.mark.parametrize("chain", list(OFFSET_CHAINS))
def test_an_image_plus_minus_or_inverted_by_constants_is_folded_into_its_bias(tmp_path, chain):
    """``add``, ``subtract`` (the image on either side) and ``invert`` (``amount - in``, as gloss maps are turned
    into roughness) of an image and constants fold into the texture's scale and bias, as ``multiply`` already did:
    they were named as unfoldable and the input kept its constant (base_color 0.8). Oracle: the nodes' formulas on
    each texel (pixel centres on texel centres)."""
    image_id, nodes, oracle = OFFSET_CHAINS[chain]
    texels = np.array([[[200, 30, 90], [10, 250, 128]], [[64, 160, 220], [255, 0, 40]]])
    png = write_png(tmp_path / "colours.png", texels)
    stage, path = new_stage(tmp_path, "offset.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Offset")[0])
    source = UsdShade.Shader.Define(stage, "/Looks/Offset/Image")
    source.CreateIdAttr(image_id)
    source.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    source.GetInput("file").GetAttr().SetColorSpace("raw")
    for k, (node_id, chain_input, other_input, constant) in enumerate(nodes):
        node = UsdShade.Shader.Define(stage, f"/Looks/Offset/Node{k}")
        node.CreateIdAttr(node_id)
        node.CreateInput(chain_input, Sdf.ValueTypeNames.Color3f).ConnectToSource(source.ConnectableAPI(), "out")
        if other_input is not None:
            scalar = isinstance(constant, float)
            node.CreateInput(other_input, Sdf.ValueTypeNames.Float if scalar else Sdf.ValueTypeNames.Color3f).Set(
                constant if scalar else Gf.Vec3f(*constant))
        source = node
    UsdShade.Shader.Get(stage, "/Looks/Offset/Surface").CreateInput("base_color", Sdf.ValueTypeNames.Color3f
                                                                    ).ConnectToSource(source.ConnectableAPI(), "out")
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    expected = np.broadcast_to(oracle(texels / 255.0), texels.shape)
    np.testing.assert_allclose(albedo(scene, 2), np.maximum(expected, 0.0), atol=2e-3)


def test_a_multiply_whose_other_input_is_unauthored_takes_that_inputs_default(tmp_path):
    """``ND_multiply_vector2`` with the coordinates on ``in2`` and ``in1`` unauthored multiplies them by in1's
    default, (0, 0), as MaterialX defines the node: every point reads st (0, 0), the bottom-left texel (blue); taking
    in2's default, 1, read the image unmapped."""
    png = write_png(tmp_path / "corners.png", CORNERS)
    stage, path = new_stage(tmp_path, "zero.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Zero")[0])
    texcoord = UsdShade.Shader.Define(stage, "/Looks/Zero/Texcoord")
    texcoord.CreateIdAttr("ND_texcoord_vector2")
    times = UsdShade.Shader.Define(stage, "/Looks/Zero/Times")
    times.CreateIdAttr("ND_multiply_vector2")
    times.CreateInput("in2", Sdf.ValueTypeNames.Float2).ConnectToSource(texcoord.ConnectableAPI(), "out")
    image = closest_image(stage, "/Looks/Zero", png, times)
    for key in ("uaddressmode", "vaddressmode"):  # st (0, 0) is on the image's edge: keep it in the bottom row
        image.CreateInput(key, Sdf.ValueTypeNames.String).Set("clamp")
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene, 2), np.broadcast_to([0, 0, 1], (2, 2, 3)), atol=1e-3)


@pytest.mark.parametrize("space, where", [("srgb_texture", "input"), ("g22_rec709", "input"),
                                          ("srgb_texture", "interface input"), ("lin_rec709", "input"),
                                          ("acescg", "input")])
def test_a_constant_colour_in_a_colour_space_is_decoded_by_its_transfer_function(tmp_path, space, where):
    """A standard_surface ``base_color`` constant whose ``colorSpace`` (or that of the Material input it connects
    to) is ``srgb_texture`` or ``g22_rec709`` is decoded as MaterialX decodes a value bound to a node input with a
    colour space (ShaderGraph's colour transform of bound inputs): (0.2, 0.5, 0.8) in ``srgb_texture`` is the sRGB
    decode of each, in float64 here; ``lin_rec709`` keeps it and ``acescg`` is converted from ACEScg's primaries
    as USD converts ``lin_ap1_scene`` (``Gf.ColorSpace.Convert``; it was kept, named as not converted). Its colour
    space was ignored: the constant was read as linear."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    color = Gf.Vec3f(0.2, 0.5, 0.8)
    base_color = shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f)
    if where == "interface input":
        source = material.CreateInput("paint", Sdf.ValueTypeNames.Color3f)
        base_color.ConnectToSource(source.GetAttr().GetPath())
    else:
        source = base_color
    source.Set(color)
    source.GetAttr().SetColorSpace(space)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    if space == "acescg":
        source, target = Gf.ColorSpace(Gf.ColorSpaceNames.LinearAP1), Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709)
        expected = np.array(target.Convert(source, color).GetRGB(), np.float64)
    else:
        decode = {**TRANSFERS, "srgb_texture": (lambda x: srgb_decoded(x, 1.0), False),
                  "lin_rec709": (lambda x: x, False)}[space][0]
        expected = decode(np.array([0.2, 0.5, 0.8]))
    np.testing.assert_allclose(mat.diffuse_color, expected, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("node", ["ND_constant_color3", "ND_multiply_color3"])
def test_a_nodes_constant_colour_in_a_colour_space_is_decoded(tmp_path, node):
    """A colour value bound to an input of a node of the graph (a ``constant``'s ``value``, a ``multiply``'s ``in2``
    times 1) feeding ``base_color``, in ``srgb_texture``, is decoded as MaterialX's ShaderGraph decodes a value bound
    to any node's colour input: (0.2, 0.5, 0.8) reads the sRGB decode of each, in float64 here. Only the surface's
    own inputs were decoded: one node away the constant was read as linear without a word."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    paint = UsdShade.Shader.Define(stage, "/Looks/Paint/Paint")
    paint.CreateIdAttr(node)
    value = paint.CreateInput("value" if node == "ND_constant_color3" else "in2", Sdf.ValueTypeNames.Color3f)
    value.Set(Gf.Vec3f(0.2, 0.5, 0.8))
    value.GetAttr().SetColorSpace("srgb_texture")
    if node == "ND_multiply_color3":
        paint.CreateInput("in1", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1.0, 1.0, 1.0))
    paint.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(paint.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, srgb_decoded(np.array([0.2, 0.5, 0.8]), 1.0), rtol=1e-5)


@pytest.mark.parametrize("space", ["srgb_texture", "g22_rec709"])
def test_a_constant_colour_decoded_past_float32s_range_is_named_and_its_default_used(tmp_path, space):
    """An ``emission_color`` of (1e20, 0.5, 0.5), finite in float32, in ``srgb_texture`` or ``g22_rec709`` decodes to
    past float32's range (1e20^2.4, ^2.2): its default (1, 1, 1) is used, with a note naming the input, as for any
    input that is not a finite number, and the surface emits nothing (the emission weight's default is 0). Its decode
    was taken: the infinite colour times the emission weight 0 was NaN, and the whole stage failed to load
    (Material emissive_color must be finite)."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Glow")
    glow = shader.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f)
    glow.Set(Gf.Vec3f(1e20, 0.5, 0.5))
    glow.GetAttr().SetColorSpace(space)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert [m for m in messages if "emission_color" in m and "default" in m], messages
    (mat,) = scene.materials
    np.testing.assert_array_equal(mat.emissive_color, 0.0)


def test_an_image_default_decoded_past_float32s_range_is_named_and_materialx_default_used(tmp_path):
    """The same for a color3 image node's ``default`` of (1e20, 0.5, 0.5) in ``srgb_texture`` (its file missing):
    MaterialX's default of an unauthored one, black, is used, with a note naming the node's default."""
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Paint", base=1.0)
    default = base_color_image(stage, "/Looks/Paint", "missing.png").CreateInput("default", Sdf.ValueTypeNames.Color3f)
    default.Set(Gf.Vec3f(1e20, 0.5, 0.5))
    default.GetAttr().SetColorSpace("srgb_texture")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert [m for m in messages if "default decoded from its colour space" in m], messages
    (mat,) = scene.materials
    np.testing.assert_array_equal(mat.diffuse_color, 0.0)


def test_a_negative_constant_colour_in_srgb_texture_is_decoded_without_a_word(tmp_path):
    """A ``base_color`` of (-0.5, 0.02, 0.5) in ``srgb_texture`` reads MaterialX's decode, ``x / 12.92`` at and below
    0.04045 (negatives too), the power of ``max(x + 0.055, 0) / 1.055`` above, in float64 here, and says nothing:
    numpy's "invalid value encountered in power" (the power taken of every number before the choice) was passed on
    as a warning of the load."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    paint = shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f)
    paint.Set(Gf.Vec3f(-0.5, 0.02, 0.5))
    paint.GetAttr().SetColorSpace("srgb_texture")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, [-0.5 / 12.92, 0.02 / 12.92, (0.555 / 1.055) ** 2.4], rtol=1e-5)


@pytest.mark.parametrize("space", ["srgb_texture", "g18_rec709", "lin_rec709"])
def test_an_image_nodes_default_in_a_colour_space_is_decoded(tmp_path, space):
    """The ``default`` of a color3 image node whose file is missing, authored with a ``colorSpace``, is decoded by
    that space's transfer function, as the MaterialX Specification's example of an image's default "in lin_rec709"
    has it (both a file and a default are transformed to the working space): (0.2, 0.5, 0.8) in ``srgb_texture`` is
    the sRGB decode of each (float64 here). It was read as linear whatever its colour space."""
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Paint", base=1.0)
    default = base_color_image(stage, "/Looks/Paint", "missing.png").CreateInput("default", Sdf.ValueTypeNames.Color3f)
    default.Set(Gf.Vec3f(0.2, 0.5, 0.8))
    default.GetAttr().SetColorSpace(space)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert [m for m in messages if "missing.png" in m], messages
    decode = {"srgb_texture": lambda x: srgb_decoded(x, 1.0), "g18_rec709": TRANSFERS["g18_rec709"][0],
              "lin_rec709": lambda x: x}[space]
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, decode(np.array([0.2, 0.5, 0.8])), rtol=1e-5)


def image_node(stage, path, png, node_id="ND_image_float"):
    """An ``node_id`` image node of ``png`` (no colorSpace: read as stored) at ``path``; its ``out`` to connect."""
    image = UsdShade.Shader.Define(stage, path)
    image.CreateIdAttr(node_id)
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.CreateOutput("out", Sdf.ValueTypeNames.Color3f if node_id.endswith("color3") else Sdf.ValueTypeNames.Float)
    return image


def texture_beside_constant(shader, name, image, value=None):
    """Connects input ``name`` of ``shader`` to ``image``'s ``out``, with ``value`` authored beside the connection."""
    inp = shader.CreateInput(name, Sdf.ValueTypeNames.Float)
    if value is not None:
        inp.Set(value)
    inp.ConnectToSource(image.ConnectableAPI(), "out")


@pytest.mark.parametrize("shader_id, weight, authored, expected", [
    (STANDARD, "base", None, 1.0), (STANDARD, "base", 0.6, 0.6),  # standard_surface's base defaults to 1
    (OPEN_PBR, "base_weight", None, 1.0), (OPEN_PBR, "base_weight", 0.25, 0.25)])
def test_a_textured_weight_beside_a_textured_colour_keeps_its_constant(tmp_path, shader_id, weight, authored,
                                                                       expected):
    """``base_color`` and its weight each read from an image (as Houdini's and Substance's exports wire both maps):
    wrt keeps one texture, the colour's, and reads the weight as unconnected, its value authored beside the
    connection or the specification's default, as the warning says. The colour was multiplied by the weight image's
    ``default`` (0 unauthored) instead: the albedo was black."""
    texels = np.array([[[200, 40, 90], [10, 120, 250]], [[60, 60, 60], [255, 0, 128]]])
    colour = write_png(tmp_path / "colour.png", texels)
    grey = write_png(tmp_path / "weight.png", np.full((2, 2), 77))
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Painted", shader_id)
    closest_image(stage, "/Looks/Painted", colour)
    texture_beside_constant(shader, weight, image_node(stage, "/Looks/Painted/Weight", grey), authored)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Painted" in m and f"the texture of {weight} is ignored" in m and f"{expected:.3g} is used" in m
               for m in messages), messages
    got = albedo(scene, 4)  # 2 x 2 pixels per texel, each reading the texel under it (filtertype closest)
    np.testing.assert_allclose(got[::2, ::2], texels / 255.0 * expected, atol=1e-3)


@pytest.mark.parametrize("shader_id, name, authored, expected", [
    (STANDARD, "specular_IOR", None, 1.5), (STANDARD, "specular_IOR", 1.33, 1.33),  # the specification's default
    (OPEN_PBR, "specular_ior", None, 1.5), (OPEN_PBR, "specular_ior", 2.0, 2.0)])
def test_a_textured_specular_index_keeps_its_constant(tmp_path, shader_id, name, authored, expected):
    """An index of refraction read from an image, which wrt draws as one constant index: the input as unconnected
    (its authored value, else the specification's default), as the warning says. It took the image's ``default``,
    0, drawn as wrt's smallest index 1e-3: a dielectric of F0 0.996, a mirror."""
    grey = write_png(tmp_path / "ior.png", np.full((2, 2), 128))
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Glaze", shader_id)
    texture_beside_constant(shader, name, image_node(stage, "/Looks/Glaze/Index", grey), authored)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Glaze" in m and f"the texture of {name} is ignored" in m for m in messages), messages
    assert scene.materials[0].ior == pytest.approx(expected)


@pytest.mark.parametrize("shader_id, coat, name, expected", [
    (STANDARD, "coat", "coat_IOR", 1.5), (OPEN_PBR, "coat_weight", "coat_ior", 1.6)])  # the specification's defaults
def test_a_textured_coat_index_keeps_its_default(tmp_path, shader_id, coat, name, expected):
    """A coat's index read from an image: the specification's default index, as the warning says, not the image's
    ``default`` 0 (wrt's smallest index 1e-3: a mirror coat)."""
    grey = write_png(tmp_path / "ior.png", np.full((2, 2), 128))
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Lacquer", shader_id, **{coat: 1.0})
    texture_beside_constant(shader, name, image_node(stage, "/Looks/Lacquer/Index", grey))
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Lacquer" in m and f"the texture of {name} is ignored" in m for m in messages), messages
    assert scene.materials[0].clearcoat_ior == pytest.approx(expected)


def test_a_materialx_preview_surface_reads_materialx_image_nodes(tmp_path):
    """MaterialX's ``ND_UsdPreviewSurface_surfaceshader`` fed by MaterialX's own image nodes in a node graph, as
    MaterialX's example usd_preview_surface_brass_tiled.mtlx wires it: ``diffuseColor`` from an
    ``ND_tiledimage_color3`` (srgb_texture, uvtiling 2: the image twice across) and ``opacity`` from an
    ``ND_tiledimage_float`` of the same file (its red channel, data) cut at ``opacityThreshold`` 0.5. They were
    named as unsupported shaders and drawn in the defaults: grey 0.18, opaque."""
    blocks = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [128, 128, 128]]])
    png = write_png(tmp_path / "blocks.png", np.repeat(np.repeat(blocks, 4, 0), 4, 1))  # 4 x 4 texels per block
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Tiles", "ND_UsdPreviewSurface_surfaceshader",
                                     opacityThreshold=0.5)
    graph = UsdShade.NodeGraph.Define(stage, "/Looks/Tiles/Graph")
    for name, node_id, value_type, surface_input in (
            ("Colour", "ND_tiledimage_color3", Sdf.ValueTypeNames.Color3f, "diffuseColor"),
            ("Mask", "ND_tiledimage_float", Sdf.ValueTypeNames.Float, "opacity")):
        image = UsdShade.Shader.Define(stage, f"/Looks/Tiles/Graph/{name}")
        image.CreateIdAttr(node_id)
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
        image.GetInput("file").GetAttr().SetColorSpace("srgb_texture")  # (a float image is data whatever it says)
        image.CreateInput("uvtiling", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(2.0, 2.0))
        image.CreateOutput("out", value_type)
        graph.CreateOutput(name, value_type).ConnectToSource(image.ConnectableAPI(), "out")
        shader.CreateInput(surface_input, value_type).ConnectToSource(graph.ConnectableAPI(), name)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    st = pixel_centre_st(8) * 2.0 % 1.0  # every pixel centre lies inside a block, two texels from its edges
    block = blocks[(st[..., 1] < 0.5).astype(int), (st[..., 0] >= 0.5).astype(int)]
    hole = block[..., 0] / 255.0 < 0.5  # the mask's red channel, read as stored
    expected = np.where(hole[..., None], 0.0, srgb_decoded(block))
    np.testing.assert_allclose(albedo(scene, 8), expected, atol=1e-3)


@pytest.mark.parametrize("order", [0, 1])
def test_a_place2d_between_materialx_s_uv_texture_and_its_texcoord_maps_it(tmp_path, order):
    """MaterialX's ``ND_UsdUVTexture`` of a ``ND_UsdPreviewSurface_surfaceshader`` whose ``st`` comes through an
    ``ND_place2d_vector2`` of ``ND_texcoord_vector2``, as MaterialX's example usd_preview_normal_map.mtlx wires it:
    the texture is read at the placed st, as MaterialX's node graph defines place2d. It was named as an unsupported
    shader and primvar ``st`` read, unplaced. Oracle: the colour of the 4 x 4 texel block of the image under each
    pixel centre's placed st (bilinear lookups there read that block alone)."""
    blocks = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 0]]])
    png = write_png(tmp_path / "blocks.png", np.repeat(np.repeat(blocks, 4, 0), 4, 1))
    stage, path = new_stage(tmp_path, f"place{order}.usda")
    material, shader = mtlx_material(stage, "/Looks/Placed", "ND_UsdPreviewSurface_surfaceshader")
    texcoord = UsdShade.Shader.Define(stage, "/Looks/Placed/Texcoord")
    texcoord.CreateIdAttr("ND_texcoord_vector2")
    place = UsdShade.Shader.Define(stage, "/Looks/Placed/Place")
    place.CreateIdAttr("ND_place2d_vector2")
    place.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(texcoord.ConnectableAPI(), "out")
    inputs = {"pivot": (0.5, 0.5), "scale": (0.5, 0.5), "rotate": 90.0, "offset": (0.0625, 0.0625)}
    for name, value in inputs.items():
        place.CreateInput(name, Sdf.ValueTypeNames.Float if name == "rotate" else Sdf.ValueTypeNames.Float2).Set(value)
    place.CreateInput("operationorder", Sdf.ValueTypeNames.Int).Set(order)
    image = UsdShade.Shader.Define(stage, "/Looks/Placed/Image")
    image.CreateIdAttr("ND_UsdUVTexture")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))  # no colour space: raw
    image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(place.ConnectableAPI(), "out")
    image.CreateOutput("rgb", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "rgb")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    st = place2d_oracle(pixel_centre_st(4), np.array(inputs["pivot"]), np.array(inputs["scale"]), inputs["rotate"],
                        np.array(inputs["offset"]), order) % 1.0  # (periodic, the node's default wrap)
    assert np.all(np.abs(st * 2 - np.round(st * 2)) > 0.2), st  # a texel or more inside a block: one colour
    expected = blocks[(st[..., 1] < 0.5).astype(int), (st[..., 0] >= 0.5).astype(int)] / 255.0
    np.testing.assert_allclose(albedo(scene, 4), expected, atol=1e-3)


def place2d_chain(stage, material, count, **inputs):
    """``count`` ``ND_place2d_vector2`` nodes ``{material}/Place0`` ... in a chain (the first's ``texcoord``
    unconnected: primvar st), each of ``inputs``; the last one."""
    previous = None
    for k in range(count):
        place = UsdShade.Shader.Define(stage, f"{material}/Place{k}")
        place.CreateIdAttr("ND_place2d_vector2")
        for name, value in inputs.items():
            place.CreateInput(name, Sdf.ValueTypeNames.Float if name == "rotate" else Sdf.ValueTypeNames.Float2
                              ).Set(value)
        if previous is not None:
            place.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(previous.ConnectableAPI(), "out")
        previous = place
    return previous


def test_a_long_chain_of_place2d_nodes_applies_every_one(tmp_path):
    """Twenty ``place2d`` nodes in a row before an image node, each moving its coordinates by an offset of
    (0.05, 0): st read at s - 1. The walk stopped after sixteen and named the rest as an unsupported node, the image
    read at s - 0.8."""
    png = write_png(tmp_path / "pixels.png", PIXELS)
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Placed")
    closest_image(stage, "/Looks/Placed", png, place2d_chain(stage, "/Looks/Placed", 20, offset=(0.05, 0.0)))
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    assert_reads_the_texels_at(scene, PIXELS, pixel_centre_st(12) - (1.0, 0.0))


def test_place2d_nodes_that_loop_back_are_named_and_applied_once(tmp_path):
    """A ``place2d`` whose ``texcoord`` is its own output (a network that loops back): named in the material's
    warning, and applied once (a quarter turn about the centre). The walk went round sixteen times (four whole
    turns: the image unturned) and named the node as unsupported."""
    png = write_png(tmp_path / "pixels.png", PIXELS)
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Placed")
    inputs = {"pivot": (0.5, 0.5), "rotate": 90.0}
    place = place2d_chain(stage, "/Looks/Placed", 1, **inputs)
    place.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(place.ConnectableAPI(), "out")
    closest_image(stage, "/Looks/Placed", png, place)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    loop = "loop back on themselves (/Looks/Placed/Place0)"
    assert any("/Looks/Placed" in m and loop in m for m in messages), messages
    st = place2d_oracle(pixel_centre_st(12), np.array(inputs["pivot"]), np.ones(2), inputs["rotate"], np.zeros(2), 0)
    assert_reads_the_texels_at(scene, PIXELS, st)


@pytest.mark.parametrize("shader_id, name, field, default", [
    (STANDARD, "base_color", "diffuse_color", 0.8),  # was white: numpy's 1 for true
    (STANDARD, "specular_roughness", "roughness", 0.2),  # was 1
    (OPEN_PBR, "specular_roughness", "roughness", 0.3),
])
def test_an_input_authored_as_a_bool_keeps_its_default_with_a_note(tmp_path, shader_id, name, field, default):
    """``bool inputs:base_color = 1`` holds no colour USD's typed readers give for a color3 (nor a float for a
    roughness): it was read as 1 without a word. It keeps the specification's default, named with its shader prim
    in the material's note, as a UsdPreviewSurface input does (test_materials.py, 741d11b)."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Odd", shader_id)
    shader.CreateInput(name, Sdf.ValueTypeNames.Bool).Set(True)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    assert type(shader.GetInput(name).Get()) is bool  # USD's answer
    scene, messages = load(path)
    (mat,) = scene.materials
    np.testing.assert_allclose(getattr(mat, field), default, rtol=1e-6)
    (warning,) = [m for m in messages if "/Looks/Odd:" in m]
    assert f"{name} is a bool, not a number; its default is used" in warning and "/Looks/Odd/Surface" in warning, \
        warning


@pytest.mark.parametrize("connected", [True, False])
def test_a_usd_transform2d_moves_an_image_nodes_texture_coordinates(tmp_path, connected):
    """An ``ND_UsdTransform2d`` between an image node and its texture coordinates moves them as it moves a
    UsdUVTexture's st (``in * scale``, turned counter-clockwise by ``rotation`` degrees, plus ``translation``, the
    UsdPreviewSurface specification's order, MaterialX pull request 2924). It was named as an unsupported
    texture-coordinate node and primvar ``st`` read unmoved. Its ``in`` neither connected nor authored is the
    nodedef's (0, 0) (no defaultgeomprop), moved, on every point, named in the note. Oracle: the texel under each
    pixel centre's st moved so in float64."""
    texels = PIXELS
    png = write_png(tmp_path / "pixels.png", texels)
    stage, path = new_stage(tmp_path, "moved.usda")
    bind(add_quad(stage, "/Quad"), mtlx_material(stage, "/Looks/Moved")[0])
    move = UsdShade.Shader.Define(stage, "/Looks/Moved/Move")
    move.CreateIdAttr("ND_UsdTransform2d")
    if connected:
        coords = UsdShade.Shader.Define(stage, "/Looks/Moved/Coords")
        coords.CreateIdAttr("ND_texcoord_vector2")
        move.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(coords.ConnectableAPI(), "out")
    move.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set((1.5, 0.7))
    move.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(30.0)
    move.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set((0.2, 0.1))
    closest_image(stage, "/Looks/Moved", png, move)
    stage.Save()
    scene, messages = load(path)
    if connected:
        assert not messages, messages
    else:
        assert any("/Looks/Moved/Move: a UsdTransform2d's in that is neither connected nor authored reads (0, 0)" in m
                   for m in messages), messages
    st = pixel_centre_st(16) * (1.5, 0.7) * connected
    a = np.radians(30.0)
    st = np.stack([st[..., 0] * np.cos(a) - st[..., 1] * np.sin(a) + 0.2,
                   st[..., 0] * np.sin(a) + st[..., 1] * np.cos(a) + 0.1], axis=-1)
    assert_reads_the_texels_at(scene, texels, st)
