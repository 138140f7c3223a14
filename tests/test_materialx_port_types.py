"""A value bound to an input of a MaterialX node is read as the node's definition types that input (its port), as
MaterialX's ShaderGraph reads it: a ``float`` port (``mix``'s ``mix``, ``in2`` of the ``FA`` forms, ``combine3``'s
inputs) authored with three numbers is no colour to decode from its ``colorSpace``, nor a float: the node is refused
with a note naming it and the input, and the surface input keeps its constant. A colour port is decoded whatever the
number of numbers authored on it. Expected values: the MaterialX nodes' formulas and sRGB's decode in float64."""

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdShade
from test_materials import add_quad, bind, new_stage
from test_materialx import load, mtlx_material
from test_materialx_color_spaces import srgb64

FG, BG = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
STANDARD_BASE_COLOR = 0.8  # standard_surface 1.0.1's base_color default, kept where the node is refused


def graph_stage(tmp_path, node_id: str, inputs: dict, space: str | None):
    """A standard_surface whose base_color is the output of one ``node_id`` node of constant ``inputs`` (name ->
    (Sdf type, value)); the inputs of three numbers carry colour space ``space``."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    node = UsdShade.Shader.Define(stage, "/Looks/Paint/Node")
    node.CreateIdAttr(node_id)
    for name, (type_name, value) in inputs.items():
        inp = node.CreateInput(name, type_name)
        inp.Set(Gf.Vec3f(*value) if isinstance(value, tuple) else value)
        if space is not None and isinstance(value, tuple):
            inp.GetAttr().SetColorSpace(space)
    node.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(node.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    return path


C3, F = Sdf.ValueTypeNames.Color3f, Sdf.ValueTypeNames.Float
THREE = (0.2, 0.5, 0.8)
# node -> (its inputs, the float port authored with three numbers)
FLOAT_PORTS = {
    "ND_mix_color3": ({"fg": (C3, FG), "bg": (C3, BG), "mix": (C3, THREE)}, "mix"),
    "ND_multiply_color3FA": ({"in1": (C3, (0.5, 0.5, 0.5)), "in2": (C3, THREE)}, "in2"),
    "ND_add_color3FA": ({"in1": (C3, (0.1, 0.1, 0.1)), "in2": (C3, THREE)}, "in2"),
    "ND_invert_color3FA": ({"in": (C3, (0.1, 0.1, 0.1)), "amount": (C3, THREE)}, "amount"),
    "ND_combine3_color3": ({"in1": (C3, THREE), "in2": (F, 0.5), "in3": (F, 0.5)}, "in1"),
}


@pytest.mark.parametrize("space", ["srgb_texture", None])
@pytest.mark.parametrize("node_id", list(FLOAT_PORTS))
def test_a_float_port_authored_with_three_numbers_is_refused_naming_the_node_and_input(tmp_path, node_id, space):
    """It was decoded as a colour (a mix of 0.5 in srgb_texture read 0.214) or read per channel (a mix of (0.2,
    0.5, 0.8) mixed each channel by its own amount), or its first number taken (combine3), without a word."""
    inputs, port = FLOAT_PORTS[node_id]
    scene, messages = load(graph_stage(tmp_path, node_id, inputs, space))
    assert any("/Looks/Paint/Node" in m and f"{port}, a float" in m and "3 numbers" in m for m in messages), messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, STANDARD_BASE_COLOR, rtol=1e-6)


def test_a_colour_mix_port_is_decoded_from_its_colour_space(tmp_path):
    """``ND_mix_color3_color3``'s ``mix`` is a color3 in its definition: decoded, each channel mixing its own."""
    inputs = {"fg": (C3, FG), "bg": (C3, BG), "mix": (C3, THREE)}
    scene, messages = load(graph_stage(tmp_path, "ND_mix_color3_color3", inputs, "srgb_texture"))
    mix = srgb64(THREE)
    expected = srgb64(FG) * mix + srgb64(BG) * (1.0 - mix)  # fg and bg carry the colour space too
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, expected, rtol=1e-5)



def test_a_colour_port_authored_as_one_float_is_decoded_from_its_colour_space(tmp_path):
    """``ND_multiply_color3``'s ``in2`` (color3) authored as one ``float`` 0.5 in ``srgb_texture``: MaterialX reads
    the port's type, a colour, so it is decoded in every channel, as a surface's colour input authored so is. It was
    kept (a single number was never decoded)."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    node = UsdShade.Shader.Define(stage, "/Looks/Paint/Node")
    node.CreateIdAttr("ND_multiply_color3")
    node.CreateInput("in1", C3).Set(Gf.Vec3f(0.5, 0.25, 1.0))
    half = node.CreateInput("in2", F)
    half.Set(0.5)
    half.GetAttr().SetColorSpace("srgb_texture")
    node.CreateOutput("out", C3)
    shader.CreateInput("base_color", C3).ConnectToSource(node.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, np.array([0.5, 0.25, 1.0]) * srgb64(0.5), rtol=1e-5)


def test_a_connected_colour_inputs_own_constant_is_decoded_where_its_node_is_not_read(tmp_path):
    """A base_color of (0.5, 0.25, 1) in ``srgb_texture`` connected to a node wrt does not fold (a noise) keeps its
    constant, decoded from its colour space as the same input unconnected reads. It was kept as authored."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    noise = UsdShade.Shader.Define(stage, "/Looks/Paint/Noise")
    noise.CreateIdAttr("ND_noise3d_color3")
    noise.CreateOutput("out", C3)
    base_color = shader.CreateInput("base_color", C3)
    base_color.Set(Gf.Vec3f(0.5, 0.25, 1.0))
    base_color.GetAttr().SetColorSpace("srgb_texture")
    base_color.ConnectToSource(noise.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load(path)
    assert any("ND_noise3d_color3" in m and "/Looks/Paint/Noise" in m for m in messages), messages
    np.testing.assert_allclose(scene.materials[0].diffuse_color, srgb64([0.5, 0.25, 1.0]), rtol=1e-5)


@pytest.mark.parametrize("reader_id, name_input, fallback_input, decoded", [
    ("ND_geompropvalue_color3", "geomprop", "default", True),
    ("ND_UsdPrimvarReader_color3", "varname", "fallback", True),
    ("ND_geompropvalue_vector3", "geomprop", "default", False),
])
def test_a_colour_primvar_readers_fallback_is_decoded_by_its_nodes_type(tmp_path, reader_id, name_input,
                                                                        fallback_input, decoded):
    """base_color from a primvar reader the mesh lacks shows the reader's fallback; a ``color3`` reader's (colour in
    its nodedef) of (0.2, 0.5, 0.8) in ``srgb_texture`` is sRGB's decode of it, a ``vector3`` reader's is kept. The
    colour one was kept as authored."""
    stage, path = new_stage(tmp_path)
    material, shader = mtlx_material(stage, "/Looks/Paint", base=1.0)
    reader = UsdShade.Shader.Define(stage, "/Looks/Paint/Reader")
    reader.CreateIdAttr(reader_id)
    reader.CreateInput(name_input, Sdf.ValueTypeNames.String).Set("paint")
    fallback = reader.CreateInput(fallback_input, C3 if decoded else Sdf.ValueTypeNames.Float3)
    fallback.Set(Gf.Vec3f(*THREE))
    fallback.GetAttr().SetColorSpace("srgb_texture")
    reader.CreateOutput("out", C3)
    shader.CreateInput("base_color", C3).ConnectToSource(reader.ConnectableAPI(), "out")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, _ = load(path)
    (mat,) = scene.materials
    assert mat.color_primvar == "paint"
    np.testing.assert_allclose(mat.diffuse_color, srgb64(THREE) if decoded else THREE, rtol=1e-5)
