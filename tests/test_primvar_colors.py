"""Material colours read from any colour primvar of a mesh (``primvars:temperature``, Houdini's ``Cd``, ...), through
a UsdPreviewSurface's ``UsdPrimvarReader_float3`` or MaterialX's ``geompropvalue`` / ``UsdPrimvarReader`` nodes, and
MaterialX math nodes folded at load time (wrt/materials.py, wrt/materialx.py, wrt/materialx_fold.py). Before, only
``displayColor`` was read; other primvars gave the reader's fallback (UsdPreviewSurface) or the surface's constant
(MaterialX, grey 0.8), and math nodes kept the constant."""

import warnings

import numpy as np
import pytest
from PIL import Image as PilImage
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt
from test_materials import bind, new_stage

import wrt

TEMPERATURE = [(0.9, 0.2, 0.1), (0.1, 0.4, 0.8)]  # the colour of the left and the right quad
STANDARD = "ND_standard_surface_surfaceshader"
CAMERA = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)  # sees x, y in [-1, 1]


def load(path, **kwargs):
    """``(scene, warning messages)``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path, **kwargs)
    return scene, [str(w.message) for w in caught]


def albedo(scene, res=4):
    """``(res, res, 3)`` albedo AOV of the square [-1, 1]^2 seen from +Z."""
    return wrt.render(scene, camera=CAMERA, width=res, height=res, device="cpu", integrator="albedo").aovs["albedo"]


def halves(left, right, res=4):
    """The albedo image of a left and a right half of these colours."""
    image = np.empty((res, res, 3))
    image[:, : res // 2], image[:, res // 2:] = left, right
    return image


def two_quads(stage, path="/Quads", x=0.0, scheme="none"):
    """Two quads sharing no point, left ``[x - 1, x] x [-1, 1]`` and right ``[x, x + 1] x [-1, 1]``, facing +Z."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = []
    for x0 in (x - 1.0, x):
        points += [(x0, -1, 0), (x0 + 1, -1, 0), (x0 + 1, 1, 0), (x0, 1, 0)]
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr(list(range(8)))
    mesh.CreateSubdivisionSchemeAttr(scheme)
    return mesh


def add_temperature(mesh, interpolation="vertex", name="temperature", colors=TEMPERATURE, alpha=False):
    """``primvars:<name>`` giving the left quad ``colors[0]`` and the right one ``colors[1]`` (indexed for
    ``"indexed"``: two values, one index per point)."""
    per_element = {"constant": [0], "uniform": [0, 1], "vertex": [0] * 4 + [1] * 4, "faceVarying": [0] * 4 + [1] * 4,
                   "indexed": [0] * 4 + [1] * 4}[interpolation]
    type_name = Sdf.ValueTypeNames.Color4fArray if alpha else Sdf.ValueTypeNames.Color3fArray
    values = [tuple(c) + ((0.5,) if alpha else ()) for c in colors]
    primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(name, type_name, "vertex" if interpolation == "indexed"
                                                      else interpolation)
    if interpolation == "indexed":
        primvar.Set(values)
        primvar.SetIndices(Vt.IntArray(per_element))
    else:
        primvar.Set([values[k] for k in per_element])
    return primvar


def preview_reader_material(stage, path, varname="temperature", fallback=None, interface=False):
    """A UsdPreviewSurface whose diffuseColor is a ``UsdPrimvarReader_float3`` of ``varname`` (a token; a string
    input of the Material it connects to with ``interface``)."""
    material = UsdShade.Material.Define(stage, path)
    surface = UsdShade.Shader.Define(stage, f"{path}/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    reader = UsdShade.Shader.Define(stage, f"{path}/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float3")
    if interface:
        material.CreateInput("colorPrimvar", Sdf.ValueTypeNames.String).Set(varname)
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).ConnectToSource(
            material.GetInput("colorPrimvar").GetAttr().GetPath())
    else:
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(varname)
    if fallback is not None:
        reader.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(*fallback))
    reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(reader.ConnectableAPI(), "result")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


def mtlx_node(stage, path, node_id, **inputs):
    """A MaterialX node of ``node_id`` with ``inputs`` (name -> (type, value or a node to connect to))."""
    node = UsdShade.Shader.Define(stage, path)
    node.CreateIdAttr(node_id)
    for name, (value_type, value) in inputs.items():
        inp = node.CreateInput(name, value_type)
        if isinstance(value, UsdShade.Shader):
            inp.ConnectToSource(value.ConnectableAPI(), "out")
        else:
            inp.Set(value)
    node.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    return node


def mtlx_base_color_material(stage, path, make_node):
    """A standard_surface whose base_color comes from ``make_node(stage, graph path)``'s ``out``, inside a
    NodeGraph."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr(STANDARD)
    graph = UsdShade.NodeGraph.Define(stage, f"{path}/Graph")
    node = make_node(stage, f"{path}/Graph")
    graph.CreateOutput("color", Sdf.ValueTypeNames.Color3f).ConnectToSource(node.ConnectableAPI(), "out")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(graph.ConnectableAPI(), "color")
    material.CreateSurfaceOutput("mtlx").ConnectToSource(shader.ConnectableAPI(), "out")
    return material


def geomprop(name="temperature", node_id="ND_geompropvalue_color3", default=None):
    """``make_node`` for :func:`mtlx_base_color_material`: a primvar reader node of ``name``."""
    def make(stage, graph):
        key = "varname" if "UsdPrimvarReader" in node_id else "geomprop"
        inputs = {key: (Sdf.ValueTypeNames.String, name)}
        if default is not None:
            inputs["fallback" if key == "varname" else "default"] = (Sdf.ValueTypeNames.Color3f, Gf.Vec3f(*default))
        return mtlx_node(stage, f"{graph}/Reader", node_id, **inputs)
    return make


@pytest.mark.parametrize("interpolation", ["vertex", "uniform", "faceVarying", "indexed"])
def test_a_preview_surface_reads_any_colour_primvar(tmp_path, interpolation):
    """diffuseColor from ``UsdPrimvarReader_float3`` of ``temperature`` shows the primvar; it was the reader's
    fallback (black) with a warning."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads, interpolation)
    quads.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0, 1, 0)])  # not the one the material reads
    bind(quads, preview_reader_material(stage, "/Looks/Heat"))
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene), halves(*TEMPERATURE), atol=1e-6)


def test_the_rgb_of_a_color4_primvar_is_read(tmp_path):
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads, alpha=True)
    bind(quads, preview_reader_material(stage, "/Looks/Heat"))
    stage.Save()
    np.testing.assert_allclose(albedo(load(path)[0]), halves(*TEMPERATURE), atol=1e-6)


COLOR4_STAGE = """#usda 1.0
def Mesh "Tri" {
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    uniform token subdivisionScheme = "none"
    color4f[] primvars:displayColor = [(0.1, 0.2, 0.3, 0.5), (0.4, 0.5, 0.6, 0.5), (0.7, 0.8, 0.9, 0.5)] (
        interpolation = "vertex")
}
def Xform "Parent" {
    color4f[] primvars:displayColor = [(0.6, 0.3, 0.2, 0.25)] (interpolation = "constant")
    def Mesh "Child" {
        point3f[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        uniform token subdivisionScheme = "none"
    }
}
def Cube "Box" {
    double3 xformOp:translate = (5, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    color4f[] primvars:displayColor = [(0.6, 0.3, 0.2, 0.25)] (interpolation = "constant")
}
"""


def test_a_color4f_display_color_gives_its_rgb_on_meshes_as_on_gprims(tmp_path):
    """A ``color4f[] primvars:displayColor`` (the schema says color3f[]; exporters write rgba) was dropped on meshes as
    "not an array of 3-vectors" (the mesh read the schema's type, not the authored one) while gprims, points, curves,
    PointInstancers and material colour primvars take its rgb: meshes take it too, their own or inherited, without a
    warning. The oracle is USD's flattened value of the primvar the mesh finds by inheritance."""
    path = tmp_path / "rgba.usda"
    path.write_text(COLOR4_STAGE)
    scene, told = load(str(path))
    assert not any("displayColor" in m for m in told), told
    stage = Usd.Stage.Open(str(path))
    meshes = {m.path: m for m in scene.meshes}
    for name in ("/Tri", "/Parent/Child"):
        primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(name)).FindPrimvarWithInheritance("displayColor")
        rgb = np.array(primvar.ComputeFlattened(), np.float64)[:, :3]
        corners = rgb if len(rgb) == 3 else np.repeat(rgb, 3, axis=0)  # vertex, or constant at each corner
        assert meshes[name].colors is not None, name
        np.testing.assert_allclose(np.asarray(meshes[name].colors, np.float64).reshape(-1, 3), corners, atol=1e-6)
    box_rgb = np.array(UsdGeom.Gprim(stage.GetPrimAtPath("/Box")).GetDisplayColorAttr().Get(), np.float64)[0, :3]
    np.testing.assert_allclose(scene.shapes[0].color, box_rgb, atol=1e-6)


@pytest.mark.parametrize("node_id", ["ND_geompropvalue_color3", "ND_UsdPrimvarReader_vector3"])
def test_materialx_reads_a_colour_primvar(tmp_path, node_id):
    """standard_surface base_color from a primvar reader node shows the primvar (times base 1); it was its constant,
    grey 0.8, with a warning naming the node."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads)
    bind(quads, mtlx_base_color_material(stage, "/Looks/Heat", geomprop(node_id=node_id)))
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene), halves(*TEMPERATURE), atol=1e-6)


@pytest.mark.parametrize("kind", ["preview", "mtlx"])
def test_a_mesh_without_the_primvar_shows_the_fallback(tmp_path, kind):
    """Of two meshes bound to one material, the one with ``temperature`` shows it, the one without shows the
    reader's fallback (MaterialX: its default), not its displayColor nor grey."""
    stage, path = new_stage(tmp_path)
    fallback = (0.25, 0.5, 0.75)
    material = (preview_reader_material(stage, "/Looks/Heat", fallback=fallback) if kind == "preview" else
                mtlx_base_color_material(stage, "/Looks/Heat", geomprop(default=fallback)))
    with_primvar = two_quads(stage, "/With", x=-1.0)  # x in [-2, 0]: the left half of the view
    add_temperature(with_primvar, "constant")
    without = two_quads(stage, "/Without", x=1.0)
    without.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0, 1, 0)])
    for mesh in (with_primvar, without):
        bind(mesh, material)
    stage.Save()
    scene, _ = load(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=4.0)
    image = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").aovs["albedo"]
    np.testing.assert_allclose(image[1:3], halves(TEMPERATURE[0], fallback)[1:3], atol=1e-6)  # rows on the quads


def test_a_display_color_reader_shows_its_fallback_on_a_mesh_without_display_color(tmp_path):
    """A reader of displayColor on a mesh without one showed grey 0.5 whatever its fallback; Storm shows the fallback
    (UsdImaging publishes no unauthored displayColor, and its primvar reader then returns the fallback), as wrt does
    for readers of other primvars. A mesh with displayColor still shows it, and one bound to no material grey."""
    stage, path = new_stage(tmp_path)
    fallback = (0.25, 0.5, 0.75)
    material = preview_reader_material(stage, "/Looks/Display", varname="displayColor", fallback=fallback)
    coloured = two_quads(stage, "/Coloured", x=-1.0)  # the left half of the view
    coloured.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0, 1, 0)])
    bare = two_quads(stage, "/Bare", x=1.0)
    for mesh in (coloured, bare):
        bind(mesh, material)
    two_quads(stage, "/Plain", x=1.0).AddTranslateOp().Set((0, 3, 0))  # above the view: no material, no colour
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=4.0)
    image = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").aovs["albedo"]
    np.testing.assert_allclose(image[1:3], halves((0, 1, 0), fallback)[1:3], atol=1e-6)  # rows on the quads
    high = wrt.Camera.orthographic(eye=(1, 3, 5), target=(1, 3, 0), height=1.0)
    plain = wrt.render(scene, camera=high, width=2, height=2, device="cpu", integrator="albedo").aovs["albedo"]
    np.testing.assert_allclose(plain, 0.5, atol=1e-6)


def test_varname_from_an_interface_input(tmp_path):
    """A reader's varname connected to a string input of the Material reads the primvar it names."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads, name="Cd")
    bind(quads, preview_reader_material(stage, "/Looks/Heat", varname="Cd", interface=True))
    stage.Save()
    np.testing.assert_allclose(albedo(load(path)[0]), halves(*TEMPERATURE), atol=1e-6)


def bind_faces(stage, mesh, materials):
    """A ``materialBind`` subset per face of ``mesh`` bound to ``materials[face]`` (None: left unbound)."""
    for face, material in enumerate(materials):
        if material is not None:
            subset = UsdGeom.Subset.Define(stage, f"{mesh.GetPath()}/Face{face}")
            subset.CreateElementTypeAttr("face")
            subset.CreateFamilyNameAttr("materialBind")
            subset.CreateIndicesAttr([face])
            bind(subset, material)


GREEN = (0.0, 1.0, 0.0)


@pytest.mark.parametrize("case", ["two primvars", "primvar and displayColor", "primvar missing"])
def test_faces_of_one_mesh_read_the_colour_primvar_of_their_own_material(tmp_path, case):
    """A mesh held one set of colours, the first its materials read, with a warning: the face whose material reads
    ``pressure`` showed ``temperature``, and an unbound face (the default material: displayColor) showed
    ``temperature`` too. Each face now shows its own material's primvar, or its reader's fallback where the mesh
    lacks it, in renders and in ``wrt preview``'s colours."""
    from wrt.image import to_srgb8
    from wrt.preview import triangle_colors

    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    fallback = (0.25, 0.5, 0.75)
    heat = preview_reader_material(stage, "/Looks/temperature", fallback=fallback)
    if case == "two primvars":
        add_temperature(quads)
        add_temperature(quads, name="pressure", colors=[(0, 0, 0), (1, 1, 1)])
        bind_faces(stage, quads, [heat, preview_reader_material(stage, "/Looks/pressure", varname="pressure")])
        expected = (TEMPERATURE[0], (1, 1, 1))
    else:
        if case == "primvar and displayColor":
            add_temperature(quads)
        quads.CreateDisplayColorPrimvar().Set([Gf.Vec3f(*GREEN)])
        bind_faces(stage, quads, [heat, None])  # the right face: the default material, displayColor
        expected = (TEMPERATURE[0] if case == "primvar and displayColor" else fallback, GREEN)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo(scene), halves(*expected), atol=1e-6)
    np.testing.assert_array_equal(triangle_colors(scene), np.repeat(to_srgb8(np.array(expected)), 2, axis=0))


def test_a_refined_subdivision_mesh_keeps_its_primvar_colours(tmp_path):
    """Catmull-Clark refinement (level 2) refines the primvar as it does displayColor: flat per quad, it stays."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage, scheme="catmullClark")
    add_temperature(quads)
    bind(quads, preview_reader_material(stage, "/Looks/Heat"))
    stage.Save()
    scene, _ = load(path, refine_level=2)
    np.testing.assert_allclose(albedo(scene, 8)[3:5, [1, 6]], [TEMPERATURE, TEMPERATURE], atol=1e-6)


def instancer_stage(tmp_path, own=None, material=None):
    """A PointInstancer of two quads (x = -0.5 and 0.5) whose ``primvars:temperature`` gives each instance its
    colour; the prototype (outside it) is bound to a material reading ``temperature`` (``material(stage)``, else a
    UsdPreviewSurface's reader) and, with ``own``, has a constant one of its own."""
    stage, path = new_stage(tmp_path, "pi.usda")
    protos = UsdGeom.Scope.Define(stage, "/Protos")
    protos.MakeInvisible()
    quad = UsdGeom.Mesh.Define(stage, "/Protos/Quad")
    quad.CreatePointsAttr([(-0.5, -1, 0), (0.5, -1, 0), (0.5, 1, 0), (-0.5, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if own is not None:
        UsdGeom.PrimvarsAPI(quad).CreatePrimvar("temperature", Sdf.ValueTypeNames.Color3fArray, "constant").Set([own])
    bind(quad, material(stage) if material else preview_reader_material(stage, "/Looks/Heat"))
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets([quad.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(-0.5, 0, 0), (0.5, 0, 0)])
    UsdGeom.PrimvarsAPI(pi).CreatePrimvar("temperature", Sdf.ValueTypeNames.Color3fArray, "vertex").Set(TEMPERATURE)
    UsdGeom.PrimvarsAPI(pi).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "constant").Set(
        [(0, 1, 0)])  # not the one the material reads
    stage.Save()
    return path


def test_point_instances_take_their_instancers_primvar(tmp_path):
    """Each instance shows its ``temperature`` from the instancer (usd-wg teapotScene's custom_color teapots);
    a prototype's own primvar wins, as in Hydra."""
    scene, _ = load(instancer_stage(tmp_path))
    assert len(scene.prototypes) == 1
    np.testing.assert_allclose(albedo(scene), halves(*TEMPERATURE), atol=1e-6)
    scene, _ = load(instancer_stage(tmp_path, own=(1, 1, 0)))
    np.testing.assert_allclose(albedo(scene), halves((1, 1, 0), (1, 1, 0)), atol=1e-6)


def test_native_instances_hand_down_a_constant_primvar(tmp_path):
    """A constant ``temperature`` on each of two instanceable prims colours the prototype's mesh (which lacks it)
    read by the material, as a constant displayColor does."""
    stage, path = new_stage(tmp_path)
    quad = UsdGeom.Mesh.Define(stage, "/Asset/Quad")
    quad.CreatePointsAttr([(-0.5, -1, 0), (0.5, -1, 0), (0.5, 1, 0), (-0.5, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(quad, preview_reader_material(stage, "/Asset/Heat"))
    stage.GetPrimAtPath("/Asset").SetSpecifier(Sdf.SpecifierClass)
    for k, (x, color) in enumerate(zip((-0.5, 0.5), TEMPERATURE)):
        prim = UsdGeom.Xform.Define(stage, f"/I{k}")
        prim.GetPrim().GetInherits().AddInherit("/Asset")
        prim.GetPrim().SetInstanceable(True)
        prim.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        UsdGeom.PrimvarsAPI(prim).CreatePrimvar("temperature", Sdf.ValueTypeNames.Color3fArray, "constant").Set(
            [color])
    stage.Save()
    scene, _ = load(path)
    assert len(scene.instances) == 2
    np.testing.assert_allclose(albedo(scene), halves(*TEMPERATURE), atol=1e-6)


# MaterialX constant folding

C3 = Sdf.ValueTypeNames.Color3f
F = Sdf.ValueTypeNames.Float


def folded_albedo(tmp_path, make_node, with_primvar=False):
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    if with_primvar:
        add_temperature(quads)
    bind(quads, mtlx_base_color_material(stage, "/Looks/Folded", make_node))
    stage.Save()
    scene, messages = load(path)
    assert not [m for m in messages if "/Looks/Folded" in m], messages
    return albedo(scene), scene


def test_multiply_of_two_constants_is_folded(tmp_path):
    """base_color = multiply(constant (0.5, 0.5, 0.5), constant (1, 0, 0)): (0.5, 0, 0). It was the surface's
    constant, grey 0.8, with a warning naming the multiply node."""
    def make(stage, graph):
        grey = mtlx_node(stage, f"{graph}/Grey", "ND_constant_color3", value=(C3, Gf.Vec3f(0.5)))
        red = mtlx_node(stage, f"{graph}/Red", "ND_constant_color3", value=(C3, Gf.Vec3f(1, 0, 0)))
        return mtlx_node(stage, f"{graph}/Times", "ND_multiply_color3", in1=(C3, grey), in2=(C3, red))
    image, _ = folded_albedo(tmp_path, make)
    np.testing.assert_allclose(image, halves((0.5, 0, 0), (0.5, 0, 0)), atol=1e-6)


def test_mix_convert_extract_combine_are_folded(tmp_path):
    """mix is ``fg * mix + bg * (1 - mix)``: fg = combine3(extract(blue, 2), 0, 0) = (1, 0, 0), bg blue, mix =
    convert(0.25) to color3 give (0.25, 0, 0.75); add (0, 0.1, 0) makes it (0.25, 0.1, 0.75)."""
    def make(stage, graph):
        blue = mtlx_node(stage, f"{graph}/Blue", "ND_constant_color3", value=(C3, Gf.Vec3f(0, 0, 1)))
        one = mtlx_node(stage, f"{graph}/One", "ND_extract_color3", **{"in": (C3, blue)},
                        index=(Sdf.ValueTypeNames.Int, 2))
        red = mtlx_node(stage, f"{graph}/Red", "ND_combine3_color3", in1=(F, one))
        quarter = mtlx_node(stage, f"{graph}/Quarter", "ND_convert_float_color3", **{"in": (F, 0.25)})
        mix = mtlx_node(stage, f"{graph}/Mix", "ND_mix_color3_color3", fg=(C3, red), bg=(C3, blue),
                        mix=(C3, quarter))
        return mtlx_node(stage, f"{graph}/Add", "ND_add_color3", in1=(C3, mix), in2=(C3, Gf.Vec3f(0, 0.1, 0)))
    image, _ = folded_albedo(tmp_path, make)
    np.testing.assert_allclose(image, halves((0.25, 0.1, 0.75), (0.25, 0.1, 0.75)), atol=1e-6)


@pytest.mark.parametrize("node_id, in_type, value, index", [
    ("ND_extract_vector2", Sdf.ValueTypeNames.Float2, Gf.Vec2f(0.2, 0.7), 2),
    ("ND_extract_color4", Sdf.ValueTypeNames.Color4f, Gf.Vec4f(0.2, 0.7, 0.4, 0.9), 4),
    ("ND_extract_color3", C3, Gf.Vec3f(0.2, 0.7, 0.4), -1),
    ("ND_extract_color3", C3, "image", 3)])
def test_an_extract_index_past_its_inputs_channels_is_reported(tmp_path, node_id, in_type, value, index):
    """An ``extract`` whose ``index`` is not a channel of its input's type (2 of a vector2, 4 of a color4, -1; 3 of
    a colour3 image) has no value in MaterialX: base_color keeps the standard_surface constant (base 0.8 times
    base_color 1), and the material's warning names the extract node and its index. Index 2 of a vector2 read its x
    again and 3 of a colour3 image its alpha (1), silently; -1 was called an unsupported node."""
    png = str(tmp_path / "red.png")
    PilImage.fromarray(np.array([[[200, 40, 10]]], np.uint8)).save(png)

    def make(stage, graph):
        if value == "image":
            source = mtlx_node(stage, f"{graph}/Image", "ND_image_color3", file=(Sdf.ValueTypeNames.Asset, png))
        else:
            source = value
        pick = mtlx_node(stage, f"{graph}/Pick", node_id, **{"in": (in_type, source)},
                         index=(Sdf.ValueTypeNames.Int, index))
        return mtlx_node(stage, f"{graph}/Grey", "ND_convert_float_color3", **{"in": (F, pick)})

    stage, path = new_stage(tmp_path)
    bind(two_quads(stage), mtlx_base_color_material(stage, "/Looks/Folded", make))
    stage.Save()
    scene, messages = load(path)
    told = [m for m in messages if "/Looks/Folded" in m and "/Looks/Folded/Graph/Pick" in m]
    assert len(told) == 1 and f"index {index}" in told[0] and "not supported" not in told[0], messages
    np.testing.assert_allclose(albedo(scene), halves((0.8,) * 3, (0.8,) * 3), atol=1e-6)


def test_an_image_times_a_colour_is_the_textures_scale(tmp_path):
    """multiply(image, (1, 0.5, 0.25)) reads the image scaled by that colour; it was the surface's constant."""
    png = str(tmp_path / "white_grey.png")
    PilImage.fromarray(np.array([[[255, 255, 255], [255, 255, 255]]], np.uint8)).save(png)

    def make(stage, graph):
        image = mtlx_node(stage, f"{graph}/Image", "ND_image_color3", file=(Sdf.ValueTypeNames.Asset, png))
        return mtlx_node(stage, f"{graph}/Tint", "ND_multiply_color3", in1=(C3, Gf.Vec3f(1, 0.5, 0.25)),
                         in2=(C3, image))
    image, scene = folded_albedo(tmp_path, make)
    (mat,) = scene.materials
    texture = mat.textures["diffuseColor"]
    np.testing.assert_allclose(texture.scale[:3], (1, 0.5, 0.25))
    # A colour3 image has no alpha of its own: its fourth channel reads 1 whatever the file's (MaterialX's convert).
    np.testing.assert_allclose([texture.scale[3] * a + texture.bias[3] for a in (0.0, 1.0)], 1.0)
    np.testing.assert_allclose(image, halves((1, 0.5, 0.25), (1, 0.5, 0.25)), atol=2e-3)


@pytest.mark.parametrize("tint, expected", [((1.0, 0.0, 0.0), None), ((0.5, 0.5, 0.5), 0.5 * 128 / 255)])
def test_one_image_channel_times_a_colour(tmp_path, tint, expected):
    """multiply(convert(extract(image, 3)), tint): the texture reads one channel (alpha 128) and broadcasts it, so a
    grey tint is its scale (0.25), but a coloured one cannot be (the scale applies before the channel is picked): the
    multiply is named and the constant kept. A red tint drew the alpha grey (0.5, 0.5, 0.5), and a grey one left
    alpha unscaled (0.5): the scale's fourth entry was 1."""
    png = str(tmp_path / "alpha.png")
    PilImage.fromarray(np.full((2, 2, 4), (255, 255, 255, 128), np.uint8)).save(png)

    def make(stage, graph):
        image = mtlx_node(stage, f"{graph}/Image", "ND_image_color4", file=(Sdf.ValueTypeNames.Asset, png))
        alpha = mtlx_node(stage, f"{graph}/Alpha", "ND_extract_color4", **{"in": (C3, image)},
                          index=(Sdf.ValueTypeNames.Int, 3))
        grey = mtlx_node(stage, f"{graph}/Grey", "ND_convert_float_color3", **{"in": (F, alpha)})
        return mtlx_node(stage, f"{graph}/Tint", "ND_multiply_color3", in1=(C3, grey), in2=(C3, Gf.Vec3f(*tint)))
    stage, path = new_stage(tmp_path)
    bind(two_quads(stage), mtlx_base_color_material(stage, "/Looks/Tinted", make))
    stage.Save()
    scene, messages = load(path)
    named = [m for m in messages if "/Looks/Tinted/Graph/Tint" in m]
    if expected is None:
        assert len(named) == 1, messages
        np.testing.assert_allclose(albedo(scene), halves((0.8,) * 3, (0.8,) * 3), atol=1e-6)
    else:
        assert not named, messages
        np.testing.assert_allclose(albedo(scene), halves((expected,) * 3, (expected,) * 3), atol=2e-3)


def test_a_primvar_times_a_float_is_scaled(tmp_path):
    """multiply(geompropvalue, 0.5) halves the primvar colours (and its default where the mesh lacks it)."""
    def make(stage, graph):
        reader = geomprop()(stage, graph)
        return mtlx_node(stage, f"{graph}/Half", "ND_multiply_color3FA", in1=(C3, reader), in2=(F, 0.5))
    image, _ = folded_albedo(tmp_path, make, with_primvar=True)
    np.testing.assert_allclose(image, halves(*(np.array(TEMPERATURE) * 0.5)), atol=1e-6)


def test_instances_primvar_times_a_float_is_scaled_in_the_render_and_the_preview(tmp_path):
    """multiply(geompropvalue, 0.5) on a prototype whose instances take their instancer's ``temperature``: the render
    and ``wrt preview``'s triangle colours both show half of it. The preview drew the instancer's colours unscaled
    (sRGB 243, 124, 89 for 179, 89, 63)."""
    from wrt.image import to_srgb8
    from wrt.preview import triangle_colors

    def half_reader(stage, graph):
        return mtlx_node(stage, f"{graph}/Half", "ND_multiply_color3FA", in1=(C3, geomprop()(stage, graph)),
                         in2=(F, 0.5))
    path = instancer_stage(tmp_path, material=lambda stage: mtlx_base_color_material(stage, "/Looks/Half",
                                                                                     half_reader))
    scene, _ = load(path)
    half = np.array(TEMPERATURE, np.float32) * 0.5
    np.testing.assert_allclose(albedo(scene), halves(*half), atol=1e-6)
    np.testing.assert_array_equal(triangle_colors(scene), np.repeat(to_srgb8(half), 2, axis=0))


def test_a_scale_past_float32_is_not_folded(tmp_path):
    """multiply(geompropvalue, 1e39 as a double) would scale the primvar by inf: the multiply is named and the
    constant (grey 0.8) kept instead."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads)

    def make(stage, graph):
        reader = geomprop()(stage, graph)
        return mtlx_node(stage, f"{graph}/Huge", "ND_multiply_color3FA", in1=(C3, reader),
                         in2=(Sdf.ValueTypeNames.Double, 1e39))
    bind(quads, mtlx_base_color_material(stage, "/Looks/Huge", make))
    stage.Save()
    scene, messages = load(path)
    assert any("/Looks/Huge/Graph/Huge" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene), halves((0.8,) * 3, (0.8,) * 3), atol=1e-6)


def test_a_node_read_by_several_inputs_is_folded_once(tmp_path, monkeypatch):
    """A chain of 12 add nodes, each adding the one before to itself (a node that two inputs read: a diamond),
    folds to 2^12 times the constant, reading each node's inputs once. Each input was folded again: 12,307 input
    look-ups for 12 nodes; a chain of 14 took 7.5 s to load, each node doubling it (20: some 8 minutes)."""
    from wrt.materials import MaterialReader

    n = 12
    lookups = []
    producer = MaterialReader._producer
    monkeypatch.setattr(MaterialReader, "_producer", lambda *args: lookups.append(args[2]) or producer(*args))

    def make(stage, graph):
        node = mtlx_node(stage, f"{graph}/N0", "ND_constant_color3", value=(C3, Gf.Vec3f(2.0 ** -n)))
        for k in range(1, n + 1):
            node = mtlx_node(stage, f"{graph}/N{k}", "ND_add_color3", in1=(C3, node), in2=(C3, node))
        return node
    image, _ = folded_albedo(tmp_path, make)
    np.testing.assert_allclose(image, halves((1, 1, 1), (1, 1, 1)), atol=1e-6)
    assert len(lookups) < 10 * n, len(lookups)


def test_an_image_that_two_inputs_scale_is_scaled_once_for_each(tmp_path):
    """mix(fg = image * 0.5, bg = image * 0.25, mix = 1) is the image times 0.5: the image node is folded once for
    both, and each multiply scales a copy of it (not 0.125, the one texture scaled twice)."""
    png = str(tmp_path / "white.png")
    PilImage.fromarray(np.full((2, 2, 3), 255, np.uint8)).save(png)

    def make(stage, graph):
        image = mtlx_node(stage, f"{graph}/Image", "ND_image_color3", file=(Sdf.ValueTypeNames.Asset, png))
        half = mtlx_node(stage, f"{graph}/Half", "ND_multiply_color3FA", in1=(C3, image), in2=(F, 0.5))
        quarter = mtlx_node(stage, f"{graph}/Quarter", "ND_multiply_color3FA", in1=(C3, image), in2=(F, 0.25))
        return mtlx_node(stage, f"{graph}/Mix", "ND_mix_color3", fg=(C3, half), bg=(C3, quarter), mix=(F, 1.0))
    image, _ = folded_albedo(tmp_path, make)
    np.testing.assert_allclose(image, halves((0.5,) * 3, (0.5,) * 3), atol=2e-3)


def test_a_node_that_cannot_be_folded_is_named_and_the_constant_kept(tmp_path):
    """multiply of a noise node: the noise node is named in the material's one warning, the constant beside the
    connection (here the specification's 0.8) is used."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)

    def make(stage, graph):
        noise = mtlx_node(stage, f"{graph}/Noise", "ND_noise3d_color3")
        return mtlx_node(stage, f"{graph}/Times", "ND_multiply_color3", in1=(C3, noise), in2=(C3, Gf.Vec3f(1, 0, 0)))
    bind(quads, mtlx_base_color_material(stage, "/Looks/Noisy", make))
    stage.Save()
    scene, messages = load(path)
    (warning,) = [m for m in messages if "/Looks/Noisy" in m]
    assert "ND_noise3d_color3" in warning and "/Looks/Noisy/Graph/Noise" in warning
    np.testing.assert_allclose(albedo(scene), halves((0.8,) * 3, (0.8,) * 3), atol=1e-6)


# A real scene

def test_teapot_scene_custom_color_teapots_show_their_instancers_primvar(assets):
    """usd-wg teapotScene: PointInstancers give each teapot a ``custom_color`` that its standard_surface reads
    through ``ND_UsdPrimvarReader_vector3``; every such teapot in view shows its colour (read with pxr here), where
    all were grey 0.8."""
    path = str(assets("teapot_scene_1000"))
    scene, _ = load(path, time=1)
    img = wrt.render(scene, width=80, height=60, device="cpu", integrator="albedo")
    stage = Usd.Stage.Open(path)
    instance, image = img.aovs["instance"], img.aovs["albedo"]
    checked = 0
    for k in np.unique(instance[instance >= 0]):
        source = scene.instances.sources[scene.instances.source[k]]
        primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(source)).GetPrimvar("custom_color")
        if not primvar:
            continue
        expected = np.asarray(primvar.ComputeFlattened(1))[scene.instances.index[k]]
        np.testing.assert_allclose(image[instance == k], np.broadcast_to(expected, image[instance == k].shape),
                                   atol=1e-6, err_msg=f"{source}[{scene.instances.index[k]}]")
        checked += 1
    assert checked >= 20


def test_a_primvar_narrowed_to_a_vector2_and_widened_has_a_third_of_zero(tmp_path):
    """convert(convert(geompropvalue vector3, vector2), vector3) is ``(x, y, 0)`` (MaterialX's convert keeps the
    first two channels and adds a third of 0), on the meshes and for the reader's default where the mesh lacks the
    primvar. The converts passed the primvar through, its third channel too."""
    def make(stage, graph):
        reader = geomprop(node_id="ND_UsdPrimvarReader_vector3", default=(0.3, 0.6, 0.9))(stage, graph)
        two = mtlx_node(stage, f"{graph}/Two", "ND_convert_vector3_vector2", **{"in": (C3, reader)})
        three = mtlx_node(stage, f"{graph}/Three", "ND_convert_vector2_vector3",
                          **{"in": (Sdf.ValueTypeNames.Float2, two)})
        return mtlx_node(stage, f"{graph}/Colour", "ND_convert_vector3_color3", **{"in": (C3, three)})
    left, right = (np.array(c, np.float64) * [1.0, 1.0, 0.0] for c in TEMPERATURE)
    assert not np.allclose(np.array(TEMPERATURE)[:, 2], 0.0)
    for with_primvar in (True, False):
        image, _ = folded_albedo(tmp_path / str(with_primvar), make, with_primvar=with_primvar)
        expected = halves(left, right) if with_primvar else halves((0.3, 0.6, 0.0), (0.3, 0.6, 0.0))
        np.testing.assert_allclose(image, expected, atol=1e-6)
