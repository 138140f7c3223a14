"""Material colours read from any colour primvar of a mesh (``primvars:temperature``, Houdini's ``Cd``, ...) through
a UsdPreviewSurface's ``UsdPrimvarReader_float3`` (wrt/materials.py, wrt/usd.py). Before, only ``displayColor`` was
read; other primvars gave the reader's fallback with a warning."""

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdShade, Vt
from test_materials import bind, new_stage

import wrt

TEMPERATURE = [(0.9, 0.2, 0.1), (0.1, 0.4, 0.8)]  # the colour of the left and the right quad
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


@pytest.mark.parametrize("kind", ["preview"])
def test_a_mesh_without_the_primvar_shows_the_fallback(tmp_path, kind):
    """Of two meshes bound to one material, the one with ``temperature`` shows it, the one without shows the
    reader's fallback (MaterialX: its default), not its displayColor nor grey."""
    stage, path = new_stage(tmp_path)
    fallback = (0.25, 0.5, 0.75)
    material = preview_reader_material(stage, "/Looks/Heat", fallback=fallback)
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


def test_varname_from_an_interface_input(tmp_path):
    """A reader's varname connected to a string input of the Material reads the primvar it names."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads, name="Cd")
    bind(quads, preview_reader_material(stage, "/Looks/Heat", varname="Cd", interface=True))
    stage.Save()
    np.testing.assert_allclose(albedo(load(path)[0]), halves(*TEMPERATURE), atol=1e-6)


def test_materials_reading_two_primvars_on_one_mesh_use_the_first_with_a_warning(tmp_path):
    """A mesh holds one set of colours: its face subsets bound to materials reading ``temperature`` and
    ``pressure`` both show ``temperature`` (the mesh's first material's), with a warning naming both."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage)
    add_temperature(quads)
    add_temperature(quads, name="pressure", colors=[(0, 0, 0), (1, 1, 1)])
    for face, name in ((0, "temperature"), (1, "pressure")):
        subset = UsdGeom.Subset.Define(stage, f"/Quads/Face{face}")
        subset.CreateElementTypeAttr("face")
        subset.CreateFamilyNameAttr("materialBind")
        subset.CreateIndicesAttr([face])
        bind(subset, preview_reader_material(stage, f"/Looks/{name}", varname=name))
    stage.Save()
    scene, messages = load(path)
    assert any("several colour primvars (temperature, pressure)" in m and "/Quads" in m for m in messages), messages
    np.testing.assert_allclose(albedo(scene), halves(*TEMPERATURE), atol=1e-6)


def test_a_refined_subdivision_mesh_keeps_its_primvar_colours(tmp_path):
    """Catmull-Clark refinement (level 2) refines the primvar as it does displayColor: flat per quad, it stays."""
    stage, path = new_stage(tmp_path)
    quads = two_quads(stage, scheme="catmullClark")
    add_temperature(quads)
    bind(quads, preview_reader_material(stage, "/Looks/Heat"))
    stage.Save()
    scene, _ = load(path, refine_level=2)
    np.testing.assert_allclose(albedo(scene, 8)[3:5, [1, 6]], [TEMPERATURE, TEMPERATURE], atol=1e-6)


def instancer_stage(tmp_path, own=None):
    """A PointInstancer of two quads (x = -0.5 and 0.5) whose ``primvars:temperature`` gives each instance its
    colour; the prototype (outside it) is bound to a material reading ``temperature`` and, with ``own``, has a
    constant one of its own."""
    stage, path = new_stage(tmp_path, "pi.usda")
    protos = UsdGeom.Scope.Define(stage, "/Protos")
    protos.MakeInvisible()
    quad = UsdGeom.Mesh.Define(stage, "/Protos/Quad")
    quad.CreatePointsAttr([(-0.5, -1, 0), (0.5, -1, 0), (0.5, 1, 0), (-0.5, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if own is not None:
        UsdGeom.PrimvarsAPI(quad).CreatePrimvar("temperature", Sdf.ValueTypeNames.Color3fArray, "constant").Set([own])
    bind(quad, preview_reader_material(stage, "/Looks/Heat"))
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
