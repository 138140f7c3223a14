"""MaterialX node inputs wrt reads as constants (a ``normalmap``'s ``scale``, an image's ``uaddressmode``,
``vaddressmode`` and ``filtertype``) fed by a ``constant`` node, math of constants or a NodeGraph's interface input:
each material renders bit for bit as the same material with the constant authored on the input itself. A node fed
so was read as unauthored without a word (a scale of 1, periodic addressing, bilinear filtering); one that folds
to no constant is named in the material's warning."""

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdShade
from test_materials import add_quad, bind, new_stage
from test_materialx import PIXELS, load, mtlx_material, normal_mapped_mtlx_stage, write_png

import wrt

TOKENS = {"uaddressmode": "mirror", "vaddressmode": "clamp", "filtertype": "closest"}  # none of them the default


def feed(stage, node, name, value_type, value, form, graph=None):
    """Authors input ``name`` (``value_type``) of shader ``node`` as ``value``, by ``form``: ``constant`` on the
    input, ``node`` from a ``constant`` node, ``dot`` from a ``dot`` node of such a node, ``math`` (numbers only)
    from a ``multiply`` of half of it by 2, ``interface`` from an input of NodeGraph ``graph``; ``None`` left
    unauthored."""
    if form is None:
        return
    inp = node.CreateInput(name, value_type)
    if form == "constant":
        inp.Set(value)
        return
    if form == "interface":
        inp.ConnectToSource(graph.CreateInput(f"{name}_in", value_type).GetAttr().GetPath())
        graph.GetInput(f"{name}_in").Set(value)
        return
    kind = {"string": "string", "float": "float", "float2": "vector2"}[str(value_type)]
    parent = str(node.GetPath().GetParentPath())
    source = UsdShade.Shader.Define(stage, f"{parent}/{name}_source")
    if form == "math":
        source.CreateIdAttr(f"ND_multiply_{kind}")
        source.CreateInput("in1", value_type).Set(type(value)(value * 0.5))
        source.CreateInput("in2", value_type).Set(Gf.Vec2f(2.0, 2.0) if kind == "vector2" else 2.0)
    else:
        source.CreateIdAttr(f"ND_constant_{kind}")
        source.CreateInput("value", value_type).Set(value)
    source.CreateOutput("out", value_type)
    if form == "dot":
        dot = UsdShade.Shader.Define(stage, f"{parent}/{name}_dot")
        dot.CreateIdAttr(f"ND_dot_{kind}")
        dot.CreateInput("in", value_type).ConnectToSource(source.ConnectableAPI(), "out")
        dot.CreateOutput("out", value_type)
        source = dot
    inp.ConnectToSource(source.ConnectableAPI(), "out")


def image_stage(tmp_path, form, tokens=TOKENS, source_id=None):
    """A quad (``st`` over [0, 2]^2) whose standard_surface base_color is an ``ND_image_color3`` of :data:`PIXELS`
    inside a NodeGraph, its string inputs ``tokens`` authored by ``form`` (:func:`feed`); ``source_id``: each fed
    instead by a node of that id."""
    png = write_png(tmp_path / "pixels.png", PIXELS)
    stage, path = new_stage(tmp_path, f"image_{form}_{source_id}.usda")
    material, shader = mtlx_material(stage, "/Looks/Pixels")
    graph = UsdShade.NodeGraph.Define(stage, "/Looks/Pixels/Graph")
    image = UsdShade.Shader.Define(stage, "/Looks/Pixels/Graph/Image")
    image.CreateIdAttr("ND_image_color3")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(png))
    image.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    for name, value in tokens.items():
        if source_id is None:
            feed(stage, image, name, Sdf.ValueTypeNames.String, value, form, graph)
        else:
            other = UsdShade.Shader.Define(stage, f"/Looks/Pixels/Graph/{name}_source")
            other.CreateIdAttr(source_id)
            other.CreateOutput("out", Sdf.ValueTypeNames.Float)
            image.CreateInput(name, Sdf.ValueTypeNames.String).ConnectToSource(other.ConnectableAPI(), "out")
    graph.CreateOutput("color", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "out")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(graph.ConnectableAPI(), "color")
    bind(add_quad(stage, "/Quad", st_range=2.0), material)
    stage.Save()
    return path


def rendered(scene, integrator="path"):
    """The ``(8, 8, 3)`` image and the albedo of ``scene`` seen straight on (a seeded path trace under the default
    dome), bit for bit the same for the same material."""
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=8, height=8, spp=2, seed=5, device="cpu", integrator=integrator)
    return np.concatenate([img.rgb, img.aovs["albedo" if integrator == "path" else "normal"]], axis=-1)


@pytest.mark.parametrize("form", ["node", "dot", "interface"])
def test_address_modes_and_filtertype_fed_by_a_constant_render_as_the_constant(tmp_path, form):
    """``uaddressmode`` mirror, ``vaddressmode`` clamp and ``filtertype`` closest from ``constant`` string nodes
    (also through a ``dot``) or a NodeGraph interface input render bit for bit as the same tokens on the image node;
    the nodes were read as unauthored (periodic, bilinear) without a word."""
    expected, _ = load(image_stage(tmp_path, "constant"))
    scene, messages = load(image_stage(tmp_path, form))
    assert not messages, messages
    np.testing.assert_array_equal(rendered(scene), rendered(expected))
    unauthored, _ = load(image_stage(tmp_path, None))
    assert not np.array_equal(rendered(unauthored), rendered(expected))  # the tokens change the image


def test_an_address_mode_from_a_node_that_is_no_constant_is_named_and_read_as_unauthored(tmp_path):
    """A token input fed by a node that gives no constant string (a noise here) is named in the material's warning,
    with the node, and read as unauthored: the image renders as the one with none of them authored."""
    scene, messages = load(image_stage(tmp_path, "node", source_id="ND_noise2d_float"))
    (warning,) = [m for m in messages if "/Looks/Pixels" in m]
    for name in TOKENS:
        assert f"{name} comes from a ND_noise2d_float node (/Looks/Pixels/Graph/{name}_source)" in warning, warning
    unauthored, _ = load(image_stage(tmp_path, None))
    np.testing.assert_array_equal(rendered(scene), rendered(unauthored))


def normal_map_stage(tmp_path, form, map_node="ND_normalmap", scale=0.5, source_id=None):
    """:func:`test_materialx.normal_mapped_mtlx_stage` (a tilted normal map through ``map_node``) in a folder of its
    own, the normalmap's ``scale`` authored by ``form`` (:func:`feed`: a float, for ``ND_normalmap_vector2`` a
    float2), or fed by a node of ``source_id``."""
    from test_normal_map import MAP_NORMAL, write_normal_map

    folder = tmp_path / f"{form}_{map_node}_{source_id}"
    folder.mkdir()
    path = normal_mapped_mtlx_stage(folder, write_normal_map(folder / "tilt.png", MAP_NORMAL), map_node=map_node)
    from pxr import Usd

    stage = Usd.Stage.Open(path)
    node = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Bumpy/Graph/NormalMap"))
    graph = UsdShade.NodeGraph(stage.GetPrimAtPath("/Looks/Bumpy/Graph"))
    if source_id is not None:
        other = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Graph/scale_source")
        other.CreateIdAttr(source_id)
        other.CreateOutput("out", Sdf.ValueTypeNames.Float)
        node.CreateInput("scale", Sdf.ValueTypeNames.Float).ConnectToSource(other.ConnectableAPI(), "out")
    elif map_node.endswith("vector2"):
        feed(stage, node, "scale", Sdf.ValueTypeNames.Float2, Gf.Vec2f(scale, scale / 2), form, graph)
    else:
        feed(stage, node, "scale", Sdf.ValueTypeNames.Float, scale, form, graph)
    stage.Save()
    return path


@pytest.mark.parametrize("map_node, form", [("ND_normalmap", "node"), ("ND_normalmap", "math"),
                                            ("ND_normalmap", "interface"), ("ND_normalmap_float", "node"),
                                            ("ND_normalmap_vector2", "node"), ("ND_normalmap_vector2", "math")])
def test_a_normalmap_scale_fed_by_constants_renders_as_the_constant(tmp_path, map_node, form):
    """A normalmap's ``scale`` (0.5; (0.5, 0.25) for the vector2 node) from a ``constant`` node, a ``multiply`` of
    constants or a NodeGraph interface input tilts the normals bit for bit as the same scale on the node does; a
    node-fed scale was read as 1 without a word (a normal of (0.38, 0.32, 0.87) for (0.21, 0.18, 0.96))."""
    expected, _ = load(normal_map_stage(tmp_path, "constant", map_node))
    scene, messages = load(normal_map_stage(tmp_path, form, map_node))
    assert not messages, messages
    np.testing.assert_array_equal(rendered(scene, "normals"), rendered(expected, "normals"))
    unscaled, _ = load(normal_map_stage(tmp_path, None, map_node))
    assert not np.array_equal(rendered(unscaled, "normals"), rendered(expected, "normals"))


def test_a_normalmap_scale_from_a_node_that_is_no_constant_is_named_and_read_as_1(tmp_path):
    """A ``scale`` fed by a node that folds to no constant (a noise) is named in the material's warning, with the
    node, and read as its default, 1: the normals of the unscaled map."""
    scene, messages = load(normal_map_stage(tmp_path, None, source_id="ND_noise2d_float"))
    (warning,) = [m for m in messages if "/Looks/Bumpy" in m]
    assert "scale comes from a ND_noise2d_float node (/Looks/Bumpy/Graph/scale_source)" in warning, warning
    unscaled, _ = load(normal_map_stage(tmp_path, None))
    np.testing.assert_array_equal(rendered(scene, "normals"), rendered(unscaled, "normals"))


def test_a_tiledimage_uvtiling_fed_by_a_constant_node_renders_as_the_constant(tmp_path):
    """A ``tiledimage``'s ``uvtiling`` (2, 2) from an ``ND_constant_vector2`` node renders bit for bit as the same
    tiling on the node; it was read as unauthored, (1, 1), without a word."""
    from pxr import Usd
    from test_materialx import tiled_stage

    png = write_png(tmp_path / "tiles.png", PIXELS)
    expected, _ = load(tiled_stage(tmp_path, png, 2))
    path = tiled_stage(tmp_path, png, 1)
    stage = Usd.Stage.Open(path)
    image = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tiles/Graph/Image"))
    image.GetInput("uvtiling").GetAttr().Clear()
    feed(stage, image, "uvtiling", Sdf.ValueTypeNames.Float2, Gf.Vec2f(2.0, 2.0), "node")
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_array_equal(rendered(scene), rendered(expected))


@pytest.mark.parametrize("source_id, value, says", [
    ("ND_constant_float", float("inf"), "whose input value is not finite numbers (inf)"),
    ("ND_constant_string", "0.5", "whose output is of type string, not numbers"),
    ("ND_dot_float", None, "whose sources lie more than 32 nodes deep or loop back to it"),
], ids=["infinite", "string", "loop"])
def test_a_normalmap_scale_from_a_constant_that_gives_no_number_says_why(tmp_path, source_id, value, says):
    """A ``scale`` fed by a constant node of an infinite value or of a string, or by a dot that feeds itself, is
    named in the material's warning with what is wrong with it, and read as 1. The warning said the node "is not
    supported", of a constant or dot node, which wrt folds."""
    from pxr import Usd

    path = normal_map_stage(tmp_path, None)
    stage = Usd.Stage.Open(path)
    node = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Bumpy/Graph/NormalMap"))
    source = UsdShade.Shader.Define(stage, "/Looks/Bumpy/Graph/scale_source")
    source.CreateIdAttr(source_id)
    value_type = Sdf.ValueTypeNames.String if isinstance(value, str) else Sdf.ValueTypeNames.Float
    source.CreateOutput("out", value_type)
    if value is None:  # a loop: the dot's input is its own output
        source.CreateInput("in", value_type).ConnectToSource(source.ConnectableAPI(), "out")
    else:
        source.CreateInput("value", value_type).Set(value)
    node.CreateInput("scale", Sdf.ValueTypeNames.Float).ConnectToSource(source.ConnectableAPI(), "out")
    stage.Save()
    scene, messages = load(path)
    (warning,) = [m for m in messages if "/Looks/Bumpy" in m]
    assert f"scale comes from a {source_id} node (/Looks/Bumpy/Graph/scale_source), {says}; 1 is used" in warning, \
        warning
    (tmp_path / "unscaled").mkdir()
    unscaled, _ = load(normal_map_stage(tmp_path / "unscaled", None))
    np.testing.assert_array_equal(rendered(scene, "normals"), rendered(unscaled, "normals"))
