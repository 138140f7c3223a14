"""USD's canonical colour space names (``GfColorSpaceNames``: ``srgb_rec709_scene``, ``lin_ap1_scene``, ``data``,
...) on MaterialX image files and constant colours, read as MaterialX 1.39's default colour management system reads
them: its ``COLOR_SPACE_REMAP`` maps the Color Interop Forum names to its own (``srgb_rec709_scene`` to
``srgb_texture``, ``g22_ap1_scene`` to ``g22_ap1``, ...), whose transforms decode by the transfer function; a name it
has no transform for is read as stored. The expected values are computed in float64 from the transfer function USD
itself declares for the name (``Gf.ColorSpace``'s gamma and linear bias), and the primaries that need a note from
``Gf.ColorSpace``'s primaries."""

from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade
from test_materials import add_quad, bind, materialx_preview_stage, new_stage, textured_stage
from test_materialx import base_color_image, colour_image_stage, load, mtlx_material, write_png
from test_texture_files import srgb_decoded, write_exr

import wrt

# The canonical names MaterialX 1.39's DefaultColorManagementSystem remaps to one of its colour transforms.
MATERIALX_DECODES = ("srgb_rec709_scene", "lin_rec709_scene", "g22_rec709_scene", "g18_rec709_scene",
                     "g24_rec709_scene", "lin_ap1_scene", "g22_ap1_scene", "srgb_p3d65_scene", "lin_p3d65_scene",
                     "lin_adobergb_scene", "g22_adobergb_scene")
# Canonical names MaterialX has no transform for: read as stored, named.
MATERIALX_UNKNOWN = ("srgb_ap1_scene", "lin_ap0_scene", "lin_rec2020_scene", "lin_ciexyzd65_scene")
# USD's names of no colour transform (Gf.ColorSpace(name).IsData()): read as stored without a word.
DATA_NAMES = ("data", "raw", "identity", "unknown")


def usd_decoded(name: str, x: np.ndarray) -> np.ndarray:
    """``x`` decoded to linear by the transfer function USD declares for colour space ``name``, in float64:
    ``((x + a) / (1 + a))^g`` above the breakpoint, ``x / slope`` below it (``a`` the linear bias, ``g`` the gamma;
    a bias of 0 is a pure power)."""
    space = Gf.ColorSpace(name)
    gamma, bias = float(space.GetGamma()), float(space.GetLinearBias())
    x = np.asarray(x, np.float64)
    if bias == 0.0:
        return np.maximum(x, 0.0) ** gamma
    breakpoint_, slope = space.GetTransferFunctionParams()
    return np.where(x > breakpoint_, ((x + bias) / (1.0 + bias)) ** gamma, x / slope)


REC709 = Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709)


def usd_converted(space: str, values) -> np.ndarray:
    """``(3,)`` float64: ``values`` in USD colour space ``space`` in linear Rec.709 as USD converts them
    (``Gf.ColorSpace.Convert``: the transfer function decoded, then the primaries converted)."""
    return np.array(REC709.Convert(Gf.ColorSpace(space), Gf.Vec3f(*values)).GetRGB(), np.float64)


def other_primaries(name: str) -> bool:
    """Whether colour space ``name``'s primaries or white point differ from linear Rec.709's (Gf's)."""
    mine = Gf.ColorSpace(name).GetPrimariesAndWhitePoint()
    rec709 = Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709).GetPrimariesAndWhitePoint()
    return not all(Gf.IsClose(a, b, 1e-6) for a, b in zip(mine, rec709))


def test_the_names_are_usds_own():
    """Every name these tests use is one ``Gf.ColorSpace`` knows, and the data names are its data spaces."""
    for name in MATERIALX_DECODES + MATERIALX_UNKNOWN + DATA_NAMES:
        assert Gf.ColorSpace.IsValid(name), name
    assert all(Gf.ColorSpace(name).IsData() for name in DATA_NAMES)


@pytest.mark.parametrize("node", ["ND_image_color3", "ND_UsdUVTexture"])
@pytest.mark.parametrize("kind", ["png", "exr"])
@pytest.mark.parametrize("space", MATERIALX_DECODES + MATERIALX_UNKNOWN + DATA_NAMES)
def test_a_colour_image_in_a_usd_colour_space_is_decoded_as_materialx_decodes_it(tmp_path, space, kind, node):
    """A colour image whose ``file`` carries a USD canonical colour space reads its samples through that space's
    transfer function where MaterialX 1.39 has a transform for it (``srgb_rec709_scene`` as ``srgb_texture``,
    ``g22_rec709_scene`` as ``g22_rec709``, ...; a space of other primaries converted to Rec.709's as USD converts
    it, ``Gf.ColorSpace.Convert``), as stored and named where it has none (``srgb_ap1_scene``, ``lin_ap0_scene``,
    ...), and as stored without a word for USD's data spaces (``data``, ``raw``, ``identity``, ``unknown``). Every
    one but ``raw`` was read as stored and named as an unknown colour space: an ``srgb_rec709_scene`` texel of 102
    read 0.4 for MaterialX's 0.133; then the spaces of other primaries were decoded alone, named."""
    if kind == "png":
        samples = np.array([51, 102, 153])
        image = write_png(tmp_path / "colour.png", np.tile(samples, (2, 2, 1)))
        stored = samples / 255.0
    else:
        stored = np.array([0.2, 0.5, 0.9])
        image = write_exr(tmp_path / "colour.exr", {c: np.full((2, 2), v, np.float32) for c, v in zip("RGB", stored)})
    scene, messages = load(colour_image_stage(tmp_path, image, space, node))
    if space in MATERIALX_DECODES:  # decoded, then converted from its primaries, as USD converts it
        expected = usd_converted(space, stored) if other_primaries(space) else usd_decoded(space, stored)
        named = False
    else:
        expected, named = stored, space in MATERIALX_UNKNOWN
    if named:
        assert any(repr(space) in m for m in messages), messages
    else:
        assert not messages, messages
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["diffuseColor"].image][..., :3].astype(np.float64)
    np.testing.assert_allclose(texels, np.broadcast_to(expected, texels.shape), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("space", ["srgb_rec709_scene", "g22_ap1_scene", "g24_rec709_scene", "data", "unknown"])
def test_a_constant_colour_in_a_usd_colour_space_is_decoded_as_materialx_decodes_it(tmp_path, space):
    """A standard_surface ``base_color`` constant in a USD canonical colour space is decoded by that space's
    transfer function as MaterialX transforms a value bound to a colour input (``srgb_rec709_scene`` (0.2, 0.5,
    0.8) is sRGB's decode of each; ``g22_ap1_scene`` converted from its primaries too, as USD converts it:
    ``Gf.ColorSpace.Convert``), and a data space keeps it without a word. It was kept as authored and named as an
    unknown colour space; then ``g22_ap1_scene`` was decoded by its transfer function alone, named."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    base_color = shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f)
    base_color.Set(Gf.Vec3f(0.2, 0.5, 0.8))
    base_color.GetAttr().SetColorSpace(space)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    value = np.array([0.2, 0.5, 0.8])
    assert not messages, messages
    (mat,) = scene.materials
    if other_primaries(space):
        target = Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709)
        expected = np.array(target.Convert(Gf.ColorSpace(space), Gf.Vec3f(*value)).GetRGB(), np.float64)
    else:
        expected = usd_decoded(space, value) if space in MATERIALX_DECODES else value
    np.testing.assert_allclose(mat.diffuse_color, expected, rtol=1e-5, atol=1e-6)


def srgb64(x) -> np.ndarray:
    """MaterialX's ``srgb_texture`` decode (``mx_srgb_texture_to_lin_rec709``) in float64: IEC 61966-2-1's inverse
    transfer function of values in [0, 1] (:func:`test_texture_files.srgb_decoded`)."""
    return srgb_decoded(x, full=1.0)


@pytest.mark.parametrize("type_name", ["color4f", "float4"])
def test_usd_uv_texture_fallback_scale_and_bias_are_decoded_as_colour4_inputs(tmp_path, type_name):
    """MaterialX's ``ND_UsdUVTexture`` declares ``fallback``, ``scale`` and ``bias`` ``color4``, and MaterialX
    transforms a value bound to an input of a colour type from its ``colorSpace`` (the port's type is the nodedef's,
    whatever the USD attribute's): a fallback (0.2, 0.4, 0.6, 1) in ``srgb_texture`` is sRGB's decode of the colour,
    alpha kept, a scale (0.5, 0.25, 1, 1) in ``g22_rec709`` ``x^2.2``, a bias (0.1, 0.1, 0.1, 0) in
    ``srgb_rec709_scene`` decoded too. They were read as authored."""
    png = write_png(tmp_path / "colour.png", np.full((2, 2, 3), 128))
    path = materialx_preview_stage(tmp_path, png, None, "uvcs")
    stage = Usd.Stage.Open(path)
    tex = UsdShade.Shader.Get(stage, "/Looks/Mx/Image")
    tex.GetPrim().RemoveProperty("inputs:fallback")
    values = {"fallback": ((0.2, 0.4, 0.6, 1.0), "srgb_texture", srgb64),
              "scale": ((0.5, 0.25, 1.0, 1.0), "g22_rec709", lambda x: np.asarray(x, np.float64) ** 2.2),
              "bias": ((0.1, 0.1, 0.1, 0.0), "srgb_rec709_scene", srgb64)}
    for name, (value, space, _) in values.items():
        inp = tex.CreateInput(name, getattr(Sdf.ValueTypeNames, type_name[0].upper() + type_name[1:]))
        inp.Set(Gf.Vec4f(*value))
        inp.GetAttr().SetColorSpace(space)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    texture = scene.materials[0].textures["diffuseColor"]
    for name, (value, _, decode) in values.items():
        expected = np.append(decode(value[:3]), value[3])
        np.testing.assert_allclose(getattr(texture, name), expected, rtol=1e-5, atol=1e-7, err_msg=name)


@pytest.mark.parametrize("type_name, value", [("Float3", (0.2, 0.5, 0.8)), ("Float", 0.5)])
def test_a_colour_input_authored_as_float3_or_float_is_decoded_by_its_colour_space(tmp_path, type_name, value):
    """A standard_surface ``base_color`` (``color3`` in MaterialX's nodedef) authored as ``float3`` or as one
    ``float`` with a ``colorSpace`` is decoded as MaterialX decodes it, the port's type being the nodedef's: (0.2,
    0.5, 0.8) in ``srgb_texture`` is sRGB's decode of each, 0.5 that of 0.5 in each channel. A ``float`` input
    (``specular_roughness``) with one is not a colour and keeps its value. Only a ``color3f`` was decoded."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    base_color = shader.CreateInput("base_color", getattr(Sdf.ValueTypeNames, type_name))
    base_color.Set(Gf.Vec3f(*value) if type_name == "Float3" else value)
    base_color.GetAttr().SetColorSpace("srgb_texture")
    roughness = shader.CreateInput("specular_roughness", Sdf.ValueTypeNames.Float)
    roughness.Set(0.5)
    roughness.GetAttr().SetColorSpace("srgb_texture")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, srgb64(np.broadcast_to(value, 3)), rtol=1e-5)
    assert mat.roughness == pytest.approx(0.5)


def test_a_colour_image_default_authored_as_float3_is_decoded_by_its_colour_space(tmp_path):
    """The ``default`` of an ``ND_image_color3`` (``color3`` in the nodedef) authored as ``float3`` in
    ``srgb_texture`` is decoded where the file is missing, as a ``color3f`` one is. It was kept as authored."""
    stage, path = new_stage(tmp_path)
    material, _ = mtlx_material(stage, "/Looks/Colour", base=1.0)
    image = base_color_image(stage, "/Looks/Colour", str(tmp_path / "missing.png"))
    default = image.CreateInput("default", Sdf.ValueTypeNames.Float3)
    default.Set(Gf.Vec3f(0.2, 0.5, 0.8))
    default.GetAttr().SetColorSpace("srgb_texture")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, _ = load(path)
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, srgb64([0.2, 0.5, 0.8]), rtol=1e-5)


@pytest.mark.parametrize("inherited", ["srgb_rec709_scene", "g22_ap1_scene", "lin_rec709_scene", "data"])
def test_a_colour_space_inherited_through_usd_colour_space_api_is_read(tmp_path, inherited):
    """A colour space applied with ``UsdColorSpaceAPI`` on an ancestor of the material, which USD's resolution
    (``UsdColorSpaceAPI::ComputeColorSpaceName``) gives an image file and a constant colour without a ``colorSpace``
    of their own, is read as their own would be: the file and the emission_color converted as USD converts them
    (``Gf.ColorSpace.Convert``); a linear Rec.709 or data one reads as stored, without a word. Both were read as
    stored, the space named as not read; then the file of other primaries was decoded alone, named."""
    png = write_png(tmp_path / "colour.png", np.tile([51, 102, 153], (2, 2, 1)))
    stage, path = new_stage(tmp_path)
    looks = stage.DefinePrim("/Looks", "Scope")
    Usd.ColorSpaceAPI.Apply(looks).CreateColorSpaceNameAttr(inherited)
    material, shader = mtlx_material(stage, "/Looks/Colour", base=1.0, emission=1.0)
    file_attr = base_color_image(stage, "/Looks/Colour", png).GetInput("file").GetAttr()
    glow = shader.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f)
    glow.Set(Gf.Vec3f(0.2, 0.5, 0.8))
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    for attr in (file_attr, glow.GetAttr()):  # USD's own resolution gives both the ancestor's colour space
        assert not attr.HasColorSpace()
        assert Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None) == inherited
    scene, messages = load(path)
    assert not messages, messages
    stored = np.array([0.2, 0.4, 0.6])
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["diffuseColor"].image][..., :3].astype(np.float64)
    decoded = stored if Gf.ColorSpace(inherited).IsData() else usd_converted(inherited, stored)
    np.testing.assert_allclose(texels, np.broadcast_to(decoded, texels.shape), rtol=1e-5, atol=1e-6)
    converted = usd_converted(inherited, (0.2, 0.5, 0.8))
    np.testing.assert_allclose(mat.emissive_color, converted, rtol=1e-5, atol=1e-6)


def test_a_usd_uv_textures_inherited_colour_space_is_named_and_its_source_color_space_decides(tmp_path):
    """A (glslfx) UsdUVTexture under a prim whose ``UsdColorSpaceAPI`` says ``srgb_rec709_scene`` is decoded by its
    ``sourceColorSpace`` alone (``raw``: 128/255), as Storm decodes it, and the inherited colour space it leaves
    out is named, as an authored one is. It was left out without a word."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), 128))
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    Usd.ColorSpaceAPI.Apply(stage.GetPrimAtPath("/Looks")).CreateColorSpaceNameAttr("srgb_rec709_scene")
    stage.Save()
    file_attr = UsdShade.Shader.Get(stage, "/Looks/Tex/Image").GetInput("file").GetAttr()
    assert Usd.ColorSpaceAPI.ComputeColorSpaceName(file_attr, None) == "srgb_rec709_scene"
    scene, messages = load(path)
    (note,) = [m for m in messages if "UsdColorSpaceAPI" in m]
    assert "srgb_rec709_scene" in note and "sourceColorSpace raw" in note, note
    (mat,) = scene.materials
    texels = np.asarray(scene.textures[mat.textures["diffuseColor"].image][..., :3], np.float64)
    np.testing.assert_allclose(texels, 128 / 255, rtol=1e-6)


@pytest.mark.parametrize("node, type_name, decoded", [("ND_constant_color3", "Float3", True),
                                                      ("ND_constant_vector3", "Color3f", False)])
def test_a_nodes_constant_is_decoded_by_the_type_its_definition_gives_it(tmp_path, node, type_name, decoded):
    """A value bound to a node of the graph is decoded from its ``colorSpace`` when the node's definition types the
    input a colour, whatever the USD attribute's type, as MaterialX's ShaderGraph decides by the nodedef's port: an
    ``ND_constant_color3``'s ``value`` authored ``float3`` in ``srgb_texture`` is decoded, an
    ``ND_constant_vector3``'s authored ``color3f`` (converted to the colour) is not. The USD type decided: the first
    was kept, the second decoded."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    paint = UsdShade.Shader.Define(stage, "/Looks/Paint/Paint")
    paint.CreateIdAttr(node)
    value = paint.CreateInput("value", getattr(Sdf.ValueTypeNames, type_name))
    value.Set(Gf.Vec3f(0.2, 0.5, 0.8))
    value.GetAttr().SetColorSpace("srgb_texture")
    source = paint
    if node == "ND_constant_vector3":
        paint.CreateOutput("out", Sdf.ValueTypeNames.Float3)
        source = UsdShade.Shader.Define(stage, "/Looks/Paint/Convert")
        source.CreateIdAttr("ND_convert_vector3_color3")
        source.CreateInput("in", Sdf.ValueTypeNames.Float3).ConnectToSource(paint.ConnectableAPI(), "out")
    source.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(source.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    (mat,) = scene.materials
    value = np.array([0.2, 0.5, 0.8])
    np.testing.assert_allclose(mat.diffuse_color, srgb64(value) if decoded else value, rtol=1e-5)


@pytest.mark.parametrize("node, space", [("ND_image_color3", "acescg"), ("ND_UsdUVTexture", "lin_ap1_scene")])
def test_an_acescg_texture_renders_its_texels_converted_to_rec709_as_usd_converts_them(tmp_path, node, space):
    """A flat quad whose diffuse colour is an ACEScg image (MaterialX's ``acescg``, USD's ``lin_ap1_scene``: AP1
    primaries, linear) shows in the ``albedo`` AOV the texel converted to linear Rec.709 as
    ``Gf.ColorSpace.Convert`` converts it: ACEScg (0.5, 0.4, 0.3) is Rec.709 (0.579, 0.388, 0.282). The texels were
    read as if they were Rec.709's, (0.5, 0.4, 0.3), with a warning that said so."""
    stored = np.array([0.5, 0.4, 0.3])
    exr = write_exr(tmp_path / "ap1.exr", {c: np.full((2, 2), v, np.float32) for c, v in zip("RGB", stored)})
    path = colour_image_stage(tmp_path, exr, space, node)
    if node == "ND_image_color3":  # the albedo is base times base_color
        stage = Usd.Stage.Open(path)
        UsdShade.Shader.Get(stage, "/Looks/Colour/Surface").CreateInput("base", Sdf.ValueTypeNames.Float).Set(1.0)
        stage.Save()
    scene, messages = load(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    albedo = wrt.render(scene, camera=cam, width=2, height=2, device="cpu").aovs["albedo"]
    expected = usd_converted("lin_ap1_scene", stored)
    assert np.all(expected > 0.25)  # inside Rec.709's gamut: no channel clamped
    np.testing.assert_allclose(albedo, np.broadcast_to(expected, albedo.shape), rtol=1e-3)
    assert not messages, messages


@pytest.mark.parametrize("node, rgb", [("ND_image_color3", (0.5, 0.4, 0.3)),  # R G A laid out as r g b
                                       ("ND_UsdUVTexture", (0.5, 0.4, 0.0))])  # R, G in place, B missing: 0
def test_an_image_of_other_primaries_missing_a_colour_channel_is_converted_as_each_node_lays_it_out(tmp_path, node,
                                                                                                   rgb):
    """An ACEScg EXR of channels ``R G A`` (no blue) is converted to Rec.709 as each node lays its channels out: a
    MaterialX image node's colour is the file's first three channels (``R, G, A``), UsdUVTexture's has ``R`` and ``G``
    in their places and blue 0; the conversion applies to that colour (MaterialX transforms the node's output),
    ``Gf.ColorSpace.Convert``'s."""
    exr = write_exr(tmp_path / "rga.exr", {c: np.full((2, 2), v, np.float32) for c, v in zip("RGA", (0.5, 0.4, 0.3))})
    scene, messages = load(colour_image_stage(tmp_path, exr, "lin_ap1_scene", node))
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["diffuseColor"].image][..., :3].astype(np.float64)
    expected = usd_converted("lin_ap1_scene", rgb)
    np.testing.assert_allclose(texels, np.broadcast_to(expected, texels.shape), rtol=1e-5, atol=1e-6)
    assert not messages, messages


@pytest.mark.parametrize("node", ["ND_image_color3", "ND_UsdUVTexture"])
def test_a_grey_image_of_other_primaries_is_laid_out_and_converted_once_over_the_frames(tmp_path, monkeypatch,
                                                                                       node):
    """A grey PNG in ACEScg, whose colour each node lays out anew (an image node's ``(c, 0, 0)``, UsdUVTexture's
    ``(c, c, c)``) and converts, keeps its converted texels with the file's over the frames of a kept stage: the
    material is read once, every frame equal to a fresh load."""
    from test_stage_frames import counted_frames

    png = write_png(tmp_path / "grey.png", np.full((2, 2), 128))
    path = colour_image_stage(tmp_path, png, "acescg", node)
    stage = Usd.Stage.Open(path)
    mover = UsdGeom.Xformable(stage.GetPrimAtPath("/Quad")).AddTranslateOp()  # something varies: frames differ
    mover.Set(Gf.Vec3d(0, 0, 0), 1), mover.Set(Gf.Vec3d(0, 0, 1), 3)
    stage.Save()
    frames, counts = counted_frames(Path(path), (1, 2, 3), monkeypatch)
    assert list(counts.values()) == [1], counts
    (mat,) = frames.load(2).materials
    texels = frames.load(2).textures[mat.textures["diffuseColor"].image][..., :3].astype(np.float64)
    c = 128 / 255
    expected = usd_converted("lin_ap1_scene", (c, 0.0, 0.0) if node == "ND_image_color3" else (c, c, c))
    np.testing.assert_allclose(texels, np.broadcast_to(expected, texels.shape), rtol=1e-5, atol=1e-6)
