"""``colorSpace`` on UsdPreviewSurface's colour inputs (``color3f`` in its Sdr definition: ``diffuseColor``,
``emissiveColor``, ``specularColor``). USD's colour guides make an attribute's ``colorSpace`` the source colour
space of its value, to be brought into the linear rendering space; wrt decodes it by the transfer function as it
decodes MaterialX's constants (:func:`wrt.materialx.decoded_color`). UsdUVTexture's ``fallback``, ``scale`` and
``bias`` are ``float4`` in its definition, no colours: a colour space on them is named, not read. The expected
values come from the transfer function USD declares for the name (``Gf.ColorSpace``), in float64."""

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdShade
from test_materials import add_quad, bind, new_stage, preview_material, textured_stage
from test_materialx import load, write_png
from test_materialx_color_spaces import usd_converted, usd_decoded

COLOR = (0.2, 0.5, 0.8)


def preview_stage(tmp_path, name: str, space: str | None = None, value=COLOR):
    """A UsdPreviewSurface quad whose input ``name`` is ``value`` in colour space ``space``."""
    stage, path = new_stage(tmp_path)
    material, shader = preview_material(stage, "/Looks/Paint", **{name: Gf.Vec3f(*value)})
    if space is not None:
        shader.GetInput(name).GetAttr().SetColorSpace(space)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    return stage, path


FIELDS = {"diffuseColor": "diffuse_color", "emissiveColor": "emissive_color", "specularColor": "specular_color"}


@pytest.mark.parametrize("name", list(FIELDS))
@pytest.mark.parametrize("space", ["srgb_rec709_scene", "g22_rec709_scene", "g18_rec709_scene"])
def test_a_preview_colour_in_a_non_linear_colour_space_is_decoded(tmp_path, name, space):
    """(0.2, 0.5, 0.8) in ``srgb_rec709_scene`` is sRGB's decode of each channel, in ``g22_rec709_scene``
    ``x^2.2``: the value USD's colour space declares. They were read as authored."""
    _, path = preview_stage(tmp_path, name, space)
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    np.testing.assert_allclose(getattr(mat, FIELDS[name]), usd_decoded(space, COLOR), rtol=1e-5)


@pytest.mark.parametrize("space", ["lin_rec709_scene", "data", "raw", ""])
def test_a_preview_colour_in_a_linear_or_data_colour_space_is_kept(tmp_path, space):
    _, path = preview_stage(tmp_path, "diffuseColor", space)
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, COLOR, rtol=1e-6)


@pytest.mark.parametrize("space", ["lin_ap1_scene", "g22_ap1_scene", "srgb_p3d65_scene", "lin_adobergb_scene",
                                   "lin_rec2020_scene", "srgb_ap1_scene", "acescg"])
def test_a_preview_colour_of_other_primaries_is_converted_to_linear_rec709(tmp_path, space):
    """``lin_ap1_scene`` (ACEScg) (0.2, 0.5, 0.8), and the other spaces of other primaries, read as USD converts
    them to linear Rec.709 (transfer function, then primaries: ``Gf.ColorSpace.Convert``; MaterialX's ``acescg`` as
    ``lin_ap1_scene``). They were decoded by the transfer function alone, the primaries named as not converted
    (``srgb_ap1_scene``, ``lin_rec2020_scene`` read as stored)."""
    _, path = preview_stage(tmp_path, "diffuseColor", space)
    scene, messages = load(path)
    assert not messages, messages
    oracle = usd_converted("lin_ap1_scene" if space == "acescg" else space, COLOR)
    np.testing.assert_allclose(scene.materials[0].diffuse_color, oracle, rtol=1e-5, atol=1e-6)


def test_an_unknown_preview_colour_space_is_named_and_read_as_linear(tmp_path):
    _, path = preview_stage(tmp_path, "diffuseColor", "bogus_space")
    scene, messages = load(path)
    assert any("'bogus_space'" in m and "/Looks/Paint" in m and "diffuseColor" in m for m in messages), messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, COLOR, rtol=1e-6)


def test_a_preview_colour_takes_the_colour_space_of_the_interface_input_it_reads(tmp_path):
    """diffuseColor connected to the Material's interface input, which carries ``srgb_rec709_scene``: decoded."""
    stage, path = new_stage(tmp_path)
    material, shader = preview_material(stage, "/Looks/Paint")
    face = material.CreateInput("paint", Sdf.ValueTypeNames.Color3f)
    face.Set(Gf.Vec3f(*COLOR))
    face.GetAttr().SetColorSpace("srgb_rec709_scene")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(face)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, usd_decoded("srgb_rec709_scene", COLOR), rtol=1e-5)


@pytest.mark.parametrize("inherited", ["srgb_rec709_scene", "lin_ap1_scene", "g22_rec709_scene"])
def test_a_preview_colour_takes_the_colour_space_inherited_through_usd_colour_space_api(tmp_path, inherited):
    """An input without a colour space of its own takes the one USD's resolution gives it (``ComputeColorSpaceName``:
    ``UsdColorSpaceAPI`` on an ancestor, ``/Looks``), and is converted as USD converts it. It was named and read as
    authored."""
    stage, path = preview_stage(tmp_path, "emissiveColor")
    Usd.ColorSpaceAPI.Apply(stage.GetPrimAtPath("/Looks")).CreateColorSpaceNameAttr(inherited)
    stage.Save()
    attr = UsdShade.Shader.Get(stage, "/Looks/Paint/Surface").GetInput("emissiveColor").GetAttr()
    assert Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None) == inherited
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].emissive_color, usd_converted(inherited, COLOR), rtol=1e-5,
                               atol=1e-6)


def test_a_preview_colours_own_colour_space_wins_over_an_inherited_one(tmp_path):
    """``colorSpace`` on the attribute comes before ``UsdColorSpaceAPI`` above it, as ``ComputeColorSpaceName``
    resolves them."""
    stage, path = preview_stage(tmp_path, "diffuseColor", "g22_rec709_scene")
    Usd.ColorSpaceAPI.Apply(stage.GetPrimAtPath("/Looks")).CreateColorSpaceNameAttr("lin_ap1_scene")
    stage.Save()
    attr = UsdShade.Shader.Get(stage, "/Looks/Paint/Surface").GetInput("diffuseColor").GetAttr()
    assert Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None) == "g22_rec709_scene"
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, usd_converted("g22_rec709_scene", COLOR), rtol=1e-5)


def test_an_unknown_inherited_preview_colour_space_is_named_with_the_prim_that_carries_it(tmp_path):
    stage, path = preview_stage(tmp_path, "diffuseColor")
    Usd.ColorSpaceAPI.Apply(stage.GetPrimAtPath("/Looks")).CreateColorSpaceNameAttr("bogus_space")
    stage.Save()
    scene, messages = load(path)
    assert any("'bogus_space'" in m and "UsdColorSpaceAPI on /Looks" in m and "diffuseColor" in m
               for m in messages), messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, COLOR, rtol=1e-6)


def test_a_preview_colour_past_float32_after_its_decode_keeps_its_default_with_a_warning(tmp_path):
    """1e20 in ``srgb_rec709_scene`` decodes past float32's range: the default, named."""
    _, path = preview_stage(tmp_path, "emissiveColor", "srgb_rec709_scene", value=(1e20, 0.0, 0.0))
    scene, messages = load(path)
    assert any("emissiveColor" in m and "float32" in m for m in messages), messages
    np.testing.assert_allclose(scene.materials[0].emissive_color, 0.0)


@pytest.mark.parametrize("name", ["fallback", "scale", "bias"])
def test_a_usd_uv_texture_float4_input_with_a_colour_space_is_named_not_decoded(tmp_path, name):
    """UsdUVTexture's ``fallback``, ``scale`` and ``bias`` are ``float4`` in its Sdr definition (no colours, unlike
    MaterialX's ``ND_UsdUVTexture``'s ``color4``): one in ``srgb_rec709_scene`` keeps its value and the colour space
    it carries is named. It was left out without a word."""
    from pxr import Sdr

    node = Sdr.Registry().GetShaderNodeByIdentifier("UsdUVTexture")
    assert node.GetShaderInput(name).GetTypeAsSdfType().GetSdfType() == Sdf.ValueTypeNames.Float4
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), 128))
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    tex = UsdShade.Shader.Get(stage, "/Looks/Tex/Image")
    value = (0.25, 0.5, 0.75, 1.0)
    inp = tex.CreateInput(name, Sdf.ValueTypeNames.Float4)
    inp.Set(Gf.Vec4f(*value))
    inp.GetAttr().SetColorSpace("srgb_rec709_scene")
    stage.Save()
    scene, messages = load(path)
    assert any(name in m and "'srgb_rec709_scene'" in m and "/Looks/Tex/Image" in m for m in messages), messages
    np.testing.assert_allclose(getattr(scene.materials[0].textures["diffuseColor"], name), value, rtol=1e-6)


@pytest.mark.parametrize("space", [None, "srgb_rec709_scene"])
def test_a_preview_colour_authored_as_a_string_keeps_its_default_with_a_warning(tmp_path, space):
    """A ``string`` diffuseColor of "0.7" is no colour (USD's typed reader gives none): it keeps Sdr's default with
    a warning, as before colour constants were decoded. Decoding read it through numpy as the grey 0.7, without a
    word. The default is the one UsdPreviewSurface's Sdr definition gives."""
    from pxr import Sdr

    stage, path = new_stage(tmp_path)
    material, shader = preview_material(stage, "/Looks/Paint")
    attr = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.String).GetAttr()
    attr.Set("0.7")
    if space is not None:
        attr.SetColorSpace(space)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    node = Sdr.Registry().GetShaderNodeByIdentifier("UsdPreviewSurface")
    default = node.GetShaderInput("diffuseColor").GetDefaultValue()
    np.testing.assert_allclose(scene.materials[0].diffuse_color, tuple(default), rtol=1e-6)
    assert any("is not a number; its default is used" in m and "diffuseColor" in m for m in messages), messages


@pytest.mark.parametrize("shader_kind", ["gltf_pbr", "OmniPBR"])
@pytest.mark.parametrize("where", ["own", "inherited"])
def test_an_unsupported_shaders_fallback_colour_is_read_in_its_colour_space(tmp_path, shader_kind, where):
    """A shader wrt does not read (MaterialX ``gltf_pbr``'s ``base_color``, OmniPBR's ``diffuse_color_constant``,
    both colour typed) falls back to a Lambertian surface of its base colour: (0.2, 0.5, 0.8) in
    ``srgb_rec709_scene``, its own ``colorSpace`` or through ``UsdColorSpaceAPI`` on ``/Looks``, is drawn as USD
    converts it to linear Rec.709 (``Gf.ColorSpace``), as every other colour constant is. It was drawn as authored."""
    stage, path = new_stage(tmp_path)
    material = UsdShade.Material.Define(stage, "/Looks/Other")
    shader = UsdShade.Shader.Define(stage, "/Looks/Other/Surface")
    if shader_kind == "gltf_pbr":
        shader.CreateIdAttr("ND_gltf_pbr_surfaceshader")
        name, context = "base_color", "mtlx"
    else:
        shader.SetSourceAsset(Sdf.AssetPath("OmniPBR.mdl"), "mdl")
        shader.SetSourceAssetSubIdentifier("OmniPBR", "mdl")
        name, context = "diffuse_color_constant", "mdl"
    attr = shader.CreateInput(name, Sdf.ValueTypeNames.Color3f).GetAttr()
    attr.Set(Gf.Vec3f(*COLOR))
    material.CreateSurfaceOutput(context).ConnectToSource(shader.ConnectableAPI(), "out")
    if where == "own":
        attr.SetColorSpace("srgb_rec709_scene")
    else:
        Usd.ColorSpaceAPI.Apply(stage.GetPrimAtPath("/Looks")).CreateColorSpaceNameAttr("srgb_rec709_scene")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    assert Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None) == "srgb_rec709_scene"
    scene, messages = load(path)
    assert any("falls back to a Lambertian surface" in m for m in messages), messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, usd_converted("srgb_rec709_scene", COLOR),
                               rtol=1e-5)
