"""How a MaterialX image node's output type takes the channels of its file (wrt/materialx.py, wrt/textures.py).

MaterialX's Standard Nodes specification (``image``): the node outputs the file's first N channels, N its type's
channel count; channels past the file's are 0, but for a fourth channel (alpha, w), which is 1 (the clarification of
MaterialX pull requests 2985 and 3073, whose GLSL, MSL and OSL implementations all sample so). A grey file's one
channel is not repeated: a ``color3`` image of it is ``(c, 0, 0)``. UsdUVTexture reads the same files by the
UsdPreviewSurface specification's rule instead (grey ``(c, c, c, 1)``, grey + alpha ``(c, c, c, a)``), which
tests/test_texture_files.py covers. The expected values here come from the samples each test writes."""

import numpy as np
from PIL import Image as PilImage
from pxr import Sdf, UsdShade
from test_materials import add_quad, bind, new_stage
from test_materialx import albedo, load, mtlx_material
from test_texture_files import write_exr

# Per file: how it is written and its channels in the file's order (what MaterialX's output types take).
PNG_SAMPLES = {"L": [51], "LA": [51, 204], "RGB": [51, 102, 153], "RGBA": [51, 102, 153, 204]}
EXR_SAMPLES = {"R": [0.3], "RG": [0.3, 0.7], "RGB": [0.3, 0.7, 0.9], "RGBA": [0.3, 0.7, 0.9, 0.45]}
FILES = [f"png {mode}" for mode in PNG_SAMPLES] + [f"exr {names}" for names in EXR_SAMPLES]
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
    assert not [m for m in messages if "/Looks/Image" in m], messages
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
    assert not [m for m in messages if "/Looks/Image" in m], messages
    expected = [channels[0] + 0.1, channels[1] + 0.2, 0.0]
    np.testing.assert_allclose(albedo(scene, 2).reshape(-1, 3), np.tile(expected, (4, 1)), atol=2e-3)
