"""How a MaterialX image node's output type takes the channels of its file (wrt/materialx.py, wrt/textures.py).

MaterialX's Standard Nodes specification (``image``): the node outputs the file's first N channels, N its type's
channel count; channels past the file's are 0, but for a fourth channel (alpha, w), which is 1 (the clarification of
MaterialX pull requests 2985 and 3073, whose GLSL, MSL and OSL implementations all sample so). A grey file's one
channel is not repeated: a ``color3`` image of it is ``(c, 0, 0)``. UsdUVTexture reads the same files by the
UsdPreviewSurface specification's rule instead (grey ``(c, c, c, 1)``, grey + alpha ``(c, c, c, a)``), which
tests/test_texture_files.py covers. The expected values here come from the samples each test writes."""

import numpy as np
import pytest
from PIL import Image as PilImage
from pxr import Gf, Sdf, UsdShade
from test_materials import add_quad, bind, new_stage
from test_materialx import OPEN_PBR, albedo, load, mtlx_material
from test_stage_frames import counted_frames
from test_texture_files import write_exr

import wrt

# Per file: how it is written and its channels in the file's order (what MaterialX's output types take).
PNG_SAMPLES = {"L": [51], "LA": [51, 204], "RGB": [51, 102, 153], "RGBA": [51, 102, 153, 204]}
EXR_SAMPLES = {"R": [0.3], "RG": [0.3, 0.7], "RGB": [0.3, 0.7, 0.9], "RGBA": [0.3, 0.7, 0.9, 0.45]}
# Grey PNGs read by other paths: 16 bits, 8 bits with a tRNS sample (every pixel that value: alpha 0), and 1 bit
# (Pillow's mode "1": white).
GREY_PNGS = {"L16": ([13107], 65535.0), "L+tRNS": ([51, 0], 255.0), "L1": ([255], 255.0)}
FILES = ([f"png {mode}" for mode in PNG_SAMPLES] + [f"png {mode}" for mode in GREY_PNGS]
         + [f"exr {names}" for names in EXR_SAMPLES])
# Per node type: the nodes after the image that bring its output to base_color (a color3), as MaterialX converts:
# a float fills all three channels, a vector2 gains a third of 0, four channels drop the last.
TO_COLOR3 = {"float": ["ND_convert_float_color3"],
             "vector2": ["ND_convert_vector2_vector3", "ND_convert_vector3_color3"], "color3": [],
             "vector3": ["ND_convert_vector3_color3"], "color4": ["ND_convert_color4_color3"],
             "vector4": ["ND_convert_vector4_vector3", "ND_convert_vector3_color3"]}
SIZES = {"float": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4, "vector4": 4}
USD_TYPES = {"float": Sdf.ValueTypeNames.Float, "vector2": Sdf.ValueTypeNames.Float2,
             "color3": Sdf.ValueTypeNames.Color3f, "vector3": Sdf.ValueTypeNames.Float3,
             "color4": Sdf.ValueTypeNames.Color4f, "vector4": Sdf.ValueTypeNames.Float4}


def write_file(tmp_path, kind) -> tuple[str, np.ndarray]:
    """A 2 x 2 image of one colour, ``kind`` from :data:`FILES`, and its channels as numbers (float64)."""
    fmt, layout = kind.split()
    if layout in GREY_PNGS:
        samples, full = GREY_PNGS[layout]
        path = str(tmp_path / f"{layout}.png")
        grey = np.full((2, 2), samples[0], np.uint16 if full > 255 else np.uint8)
        image = PilImage.fromarray(grey)
        image = image.convert("1") if layout == "L1" else image
        image.save(path, **({"transparency": samples[0]} if len(samples) == 2 else {}))
        return path, np.asarray(samples, np.float64) / full
    if fmt == "png":
        samples = PNG_SAMPLES[layout]
        path = str(tmp_path / f"{layout}.png")
        pixels = np.tile(np.asarray(samples, np.uint8), (2, 2, 1))  # Pillow takes L, LA, RGB or RGBA by its shape
        PilImage.fromarray(pixels[..., 0] if len(samples) == 1 else pixels).save(path)
        return path, np.asarray(samples, np.float64) / 255.0
    samples = EXR_SAMPLES[layout]
    path = write_exr(tmp_path / f"{layout}.exr",
                     {name: np.full((2, 2), value, np.float32) for name, value in zip(layout, samples)})
    return path, np.asarray(samples, np.float32).astype(np.float64)


def materialx_output(channels: np.ndarray, size: int) -> np.ndarray:
    """The specification's output of ``size`` channels from a file of ``channels``: the first ones, 0 past the
    file's, a fourth of 1."""
    out = np.array([0.0, 0.0, 0.0, 1.0])[:size]
    n = min(size, len(channels))
    out[:n] = channels[:n]
    return out


def image_node(stage, material, png, node_type, chain=()):
    """An ``ND_image_<node_type>`` node of ``png`` (colour space raw) at ``{material}/Image`` and the nodes of
    ``chain`` after it, each reading the one before; returns the last (the image without a chain)."""
    image = UsdShade.Shader.Define(stage, f"{material}/Image")
    image.CreateIdAttr(f"ND_image_{node_type}")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.GetInput("file").GetAttr().SetColorSpace("raw")
    image.CreateOutput("out", USD_TYPES[node_type])
    last = image
    for k, node_id in enumerate(chain):
        node = UsdShade.Shader.Define(stage, f"{material}/Node{k}")
        node.CreateIdAttr(node_id)
        first = "in1" if node_id.startswith(("ND_add_", "ND_multiply_")) else "in"
        node.CreateInput(first, USD_TYPES[node_id.split("_")[2]]).ConnectToSource(last.ConnectableAPI(), "out")
        node.CreateOutput("out", USD_TYPES[node_id.split("_")[-1]])
        last = node
    return last


def base_color_of(tmp_path, png, node_type, chain) -> np.ndarray:
    """The albedo (one 2 x 2 render's mean) of a quad whose standard_surface base_color is ``chain`` after an
    ``ND_image_<node_type>`` of ``png``."""
    stage, path = new_stage(tmp_path, f"{node_type}.usda")
    material, shader = mtlx_material(stage, "/Looks/Image")
    last = image_node(stage, "/Looks/Image", png, node_type, chain)
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(last.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not [m for m in messages if "not supported" in m or "/Looks/Image/Image" in m], messages
    return albedo(scene, 2).reshape(-1, 3).mean(axis=0)


def test_a_vector2_image_converted_to_a_colour_has_no_third_channel(tmp_path):
    """A ``vector2`` image of an RGB file plus a constant vector2, converted to a colour (vector3, then color3), is
    ``(r + 0.1, g + 0.2, 0)``: the node outputs the file's first two channels, the add offsets those two, and the
    conversion adds a third of 0. The texture was read as rgb: the file's blue showed through (and the add's offset
    repeated into it)."""
    png, channels = write_file(tmp_path, "png RGB")
    chain = ["ND_add_vector2", "ND_convert_vector2_vector3", "ND_convert_vector3_color3"]
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Image")
    last = image_node(stage, "/Looks/Image", png, "vector2", chain)
    UsdShade.Shader.Get(stage, "/Looks/Image/Node0").CreateInput("in2", Sdf.ValueTypeNames.Float2).Set((0.1, 0.2))
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(last.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not [m for m in messages if "not supported" in m or "/Looks/Image/Image" in m], messages
    expected = [channels[0] + 0.1, channels[1] + 0.2, 0.0]
    np.testing.assert_allclose(albedo(scene, 2).reshape(-1, 3), np.tile(expected, (4, 1)), atol=2e-3)


@pytest.mark.parametrize("node_type", list(TO_COLOR3))
@pytest.mark.parametrize("kind", FILES)
def test_an_image_node_outputs_the_files_first_channels_and_zero_past_them(tmp_path, kind, node_type):
    """Each output type of an image node of each file, brought to base_color as MaterialX converts it, draws the
    file's first channels and 0 past them: a color3 of a grey PNG ``(c, 0, 0)``, of grey + alpha ``(c, a, 0)``, a
    vector2 of an R G EXR ``(R, G)``. The image nodes read the file as UsdUVTexture reads it: a grey file repeated
    into r, g and b, and the second of two channels as alpha (an R G EXR's vector2 was ``(R, R)``)."""
    png, channels = write_file(tmp_path, kind)
    out = materialx_output(channels, SIZES[node_type])
    expected = np.full(3, out[0]) if out.size == 1 else np.append(out, 0.0)[:3]  # convert: fill, or 0 for a third
    np.testing.assert_allclose(base_color_of(tmp_path, png, node_type, TO_COLOR3[node_type]), expected, atol=2e-3)


def uv_texture_material(stage, path, png):
    """A UsdPreviewSurface whose diffuseColor is the rgb of a UsdUVTexture of ``png`` (raw)."""
    material = UsdShade.Material.Define(stage, path)
    surface = UsdShade.Shader.Define(stage, f"{path}/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    texture = UsdShade.Shader.Define(stage, f"{path}/Image")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    texture.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(texture.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


def test_a_file_read_by_materialx_and_usduvtexture_over_the_frames_of_a_kept_stage(tmp_path, monkeypatch):
    """A grey PNG read by a MaterialX color3 image and by a UsdUVTexture gives each its own texels, ``(c, 0, 0)`` and
    ``(c, c, c)``; an RGB PNG read by both is one image. Over the frames of a kept stage each material is read once
    per kind of time (the MaterialX texels are kept with the file's pixels, so a kept read finds the same ones) and
    every frame equals a fresh load. The MaterialX image of the grey file was ``(c, c, c)``."""
    grey, grey_channels = write_file(tmp_path, "png L")
    colour, colour_channels = write_file(tmp_path, "png RGB")
    stage, path = new_stage(tmp_path, "frames.usda")
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    looks = {}
    for name, png in (("Grey", grey), ("Colour", colour)):
        material, shader = mtlx_material(stage, f"/Looks/{name}")
        last = image_node(stage, f"/Looks/{name}", png, "color3")
        shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(last.ConnectableAPI(), "out")
        looks[name] = material
        looks[f"{name}UV"] = uv_texture_material(stage, f"/Looks/{name}UV", png)
    for k, (name, material) in enumerate(looks.items()):
        bind(add_quad(stage, f"/World/{name}", center=(3.0 * k, 0.0, 0.0)), material)
    mover = add_quad(stage, "/World/Mover", center=(0.0, 3.0, 0.0)).AddTranslateOp()  # the frames differ
    mover.Set(Gf.Vec3d(0, 0, 0), 1)
    mover.Set(Gf.Vec3d(0, 0, 2), 3)
    stage.Save()
    frames, counts = counted_frames(path, (1, 2, None, 3), monkeypatch)
    assert counts == {f"/Looks/{name}": 2 for name in looks}, counts
    scene = frames.load(2)
    assert len(scene.textures) == 3, len(scene.textures)  # grey twice, colour once
    texel = {m.path: scene.textures[m.textures["diffuseColor"].image][0, 0].astype(np.float64)
             for m in scene.materials}
    np.testing.assert_allclose(texel["/Looks/Grey"], [grey_channels[0], 0.0, 0.0, 1.0], atol=1e-6)
    np.testing.assert_allclose(texel["/Looks/GreyUV"], [grey_channels[0]] * 3 + [1.0], atol=1e-6)
    np.testing.assert_allclose(texel["/Looks/Colour"], np.append(colour_channels, 1.0), atol=1e-6)
    colour_images = {m.textures["diffuseColor"].image for m in scene.materials if "Colour" in m.path}
    assert len(colour_images) == 1, colour_images


def srgb_decoded(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's sRGB to linear, in float64."""
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


@pytest.mark.parametrize("node_type", ["color3", "color4", "vector3"])
@pytest.mark.parametrize("kind", ["png L", "png LA", "png RGBA", "exr RG"])
def test_srgb_texture_decodes_the_colour_channels_of_the_nodes_output(tmp_path, kind, node_type):
    """With ``colorspace="srgb_texture"`` MaterialX transforms the image node's output (ShaderGraph's output colour
    transform, for color3 and color4 nodes only; ``mx_srgb_texture_to_lin_rec709_color4`` keeps alpha): every
    colour channel of the output is decoded, whichever file channel it holds, so a grey + alpha file's alpha in g
    is decoded too; a vector3 node reads the file as data. The alpha in g was left as the file stores it."""
    png, channels = write_file(tmp_path, kind)
    stage, path = new_stage(tmp_path, f"{node_type}.usda")
    material, shader = mtlx_material(stage, "/Looks/Image")
    last = image_node(stage, "/Looks/Image", png, node_type, TO_COLOR3[node_type])
    UsdShade.Shader.Get(stage, "/Looks/Image/Image").GetInput("file").GetAttr().SetColorSpace("srgb_texture")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(last.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not [m for m in messages if "not supported" in m or "/Looks/Image/Image" in m], messages
    out = materialx_output(channels, SIZES[node_type])[:3]
    expected = out if node_type.startswith("vector") else srgb_decoded(out)
    np.testing.assert_allclose(albedo(scene, 2).reshape(-1, 3).mean(axis=0), expected, atol=2e-3)


def spec_convert(value: np.ndarray, size: int) -> np.ndarray:
    """MaterialX's ``convert`` (Standard Nodes 1.39, channel nodes) of ``value`` to ``size`` channels, in float64: a
    float is copied to every channel; of more channels the first ``size`` are kept; of fewer, they are copied and
    the added ones are 0, but for a fourth of 1."""
    value = np.asarray(value, np.float64)
    if value.size == 1:
        return np.full(size, value[0])
    out = np.array([0.0, 0.0, 0.0, 1.0])[:size]
    n = min(size, value.size)
    out[:n] = value[:n]
    return out


def network_output(node_type: str, channels: np.ndarray, chain) -> np.ndarray:
    """The specification's output of an ``ND_image_<node_type>`` of a file of ``channels`` followed by the converts
    (and multiplies by 0.5) of ``chain``."""
    value = materialx_output(channels, SIZES[node_type])
    for node_id in chain:  # a multiply: by the 0.5 these tests give it
        step = SIZES[node_id.split("_")[-1]]
        value = value * 0.5 if node_id.startswith("ND_multiply_") else spec_convert(value, step)
    return value


# Converts that narrow an image's output and widen it again: the channels dropped come back 0 (a fourth 1), not as
# the file's.
NARROW_AND_WIDEN = {
    "vector3": ["ND_convert_vector3_vector2", "ND_convert_vector2_vector3", "ND_convert_vector3_color3"],
    "color3": ["ND_convert_color3_vector3", "ND_convert_vector3_vector2", "ND_convert_vector2_vector3",
               "ND_convert_vector3_color3"],
    "vector4": ["ND_convert_vector4_vector2", "ND_convert_vector2_vector3", "ND_convert_vector3_color3"],
}


@pytest.mark.parametrize("node_type", list(NARROW_AND_WIDEN))
def test_a_convert_that_narrows_an_image_drops_its_channels(tmp_path, node_type):
    """A vector3, color3 or vector4 image of an RGBA file converted to a vector2 and back to a colour is
    ``(r, g, 0)``: the narrowing convert keeps the first two channels, the widening one adds a third of 0. A convert of
    a texture passed it through unchanged, so the file's blue showed again."""
    png, channels = write_file(tmp_path, "png RGBA")
    expected = network_output(node_type, channels, NARROW_AND_WIDEN[node_type])
    assert expected[2] == 0.0 and channels[2] > 0.5
    np.testing.assert_allclose(base_color_of(tmp_path, png, node_type, NARROW_AND_WIDEN[node_type]), expected,
                               atol=2e-3)


# Per node type of fewer than four channels: the converts that widen its output to four (a vector2 through vector3).
TO_FOUR = {"color3": ["ND_convert_color3_color4"], "vector3": ["ND_convert_vector3_vector4"],
           "vector2": ["ND_convert_vector2_vector3", "ND_convert_vector3_vector4"]}
# Converts that drop a four-channel image's fourth and add it again (1), with the channel read afterwards.
FOURTH_DROPPED = {"color4": (["ND_convert_color4_color3", "ND_convert_color3_color4"], 3),
                  "vector4": (["ND_convert_vector4_vector3", "ND_convert_vector3_vector4"], 3),
                  "vector4 z": (["ND_convert_vector4_vector2", "ND_convert_vector2_vector3",
                                 "ND_convert_vector3_vector4"], 2)}
# A channel of an image node's output brought to four channels: (file, node type, the nodes after the image, the
# index extracted). A color4 or vector4 of every file as it is; a color3, vector3 or vector2 of an RGBA file widened
# to four (times 0.5 first where a multiply leads); a color4 or vector4 of it narrowed and widened again.
EXTRACTED = {
    **{f"{node_type}-{kind}": (kind, node_type, [], 3) for node_type in ("color4", "vector4") for kind in FILES},
    **{f"{node_type}-widened{'-multiplied' * multiply}": (
        "png RGBA", node_type, [f"ND_multiply_{node_type}"] * multiply + TO_FOUR[node_type], 3)
        for node_type in TO_FOUR for multiply in (False, True)},
    **{f"{case}-dropped": ("png RGBA", case.split()[0], chain, index)
       for case, (chain, index) in FOURTH_DROPPED.items()},
}


@pytest.mark.parametrize("case", list(EXTRACTED))
def test_an_image_nodes_fourth_channel_is_the_files_fourth_or_one(tmp_path, case):
    """A channel of an image node's output brought to four channels, read by an OpenPBR ``emission_luminance``
    through ``extract`` (of a surface that reflects nothing), is the specification's:

    - the fourth of a color4 or vector4 image is the file's fourth channel, 1 for a file of fewer: a grey + alpha
      PNG's alpha is its second channel (the node's g), not its fourth. It was the alpha UsdUVTexture reads, so an
      R G EXR emitted its G, a grey + alpha PNG its alpha;
    - a color3, vector3 or vector2 image of an RGBA file converted to a color4 or vector4 (times a constant of its
      own type first, where multiplied) has a fourth channel of 1: the node outputs the file's first channels only,
      and MaterialX's convert from three channels adds a fourth of 1. It was the file's alpha (0.8 here);
    - a color4 or vector4 image of an RGBA file narrowed to three channels (or two) and widened to four again has a
      fourth channel of 1 (and a third of 0 after two). It was the file's alpha (0.8) and blue (0.6)."""
    kind, node_type, chain, index = EXTRACTED[case]
    png, channels = write_file(tmp_path, kind)
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Image", OPEN_PBR, base_weight=0.0, specular_weight=0.0)
    shader.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).Set((1.0, 1.0, 1.0))
    last = image_node(stage, "/Looks/Image", png, node_type, chain)
    if chain and chain[0].startswith("ND_multiply_"):  # by 0.5 in every channel of the node's own
        UsdShade.Shader.Get(stage, "/Looks/Image/Node0").CreateInput("in2", USD_TYPES[node_type]).Set(
            (0.5,) * SIZES[node_type])
    four = chain[-1].split("_")[-1] if chain else node_type
    pick = UsdShade.Shader.Define(stage, "/Looks/Image/Pick")
    pick.CreateIdAttr(f"ND_extract_{four}")
    pick.CreateInput("in", USD_TYPES[four]).ConnectToSource(last.ConnectableAPI(), "out")
    pick.CreateInput("index", Sdf.ValueTypeNames.Int).Set(index)
    shader.CreateInput("emission_luminance", Sdf.ValueTypeNames.Float).ConnectToSource(pick.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not [m for m in messages if "not supported" in m or "comes from" in m or "/Looks/Image/Image" in m], \
        messages
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    rgb = wrt.render(scene, camera=cam, width=2, height=2, device="cpu").rgb
    expected = network_output(node_type, channels, chain)[index]
    if chain:  # the file's own channel there would be another answer
        assert expected != channels[index]
    np.testing.assert_allclose(rgb, expected, atol=2e-3)


@pytest.mark.parametrize("chain", [["ND_convert_float_vector2", "ND_convert_vector2_vector3"],
                                   ["ND_convert_float_vector3", "ND_convert_vector3_vector2",
                                    "ND_convert_vector2_vector3"]])
def test_a_repeated_float_image_widened_past_its_channels_is_named_not_drawn_grey(tmp_path, chain):
    """A float image repeated into a vector2 (or a vector3 narrowed to one) and widened to a vector3 is
    ``(r, r, 0)`` in MaterialX; wrt's texture reads one channel into all three or the file's channels, neither of
    which is that, so the material's warning names the widening convert and base_color keeps the constant authored
    beside its connection. It was drawn ``(r, r, r)`` without a word."""
    png, channels = write_file(tmp_path, "png RGB")
    chain = chain + ["ND_convert_vector3_color3"]
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Image", base=1.0)
    last = image_node(stage, "/Looks/Image", png, "float", chain)
    base_color = shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f)
    base_color.Set((0.1, 0.3, 0.5))
    base_color.ConnectToSource(last.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    widening = f"/Looks/Image/Node{len(chain) - 2}"
    named = [m for m in messages if "material /Looks/Image" in m and widening in m and "base_color" in m]
    assert named, messages
    assert "(x, x, 0)" in named[0], named
    spec = network_output("float", channels, chain)
    np.testing.assert_allclose(spec, [channels[0], channels[0], 0.0])
    np.testing.assert_allclose(albedo(scene, 2).reshape(-1, 3), np.tile([0.1, 0.3, 0.5], (4, 1)), atol=2e-3)
