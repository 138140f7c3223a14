"""Materials from USD: UsdPreviewSurface inputs, binding rules (subsets, collections, purpose), fallbacks for other
shaders, UsdUVTexture lookups (colour spaces, wrap modes, UsdTransform2d), cut-outs and doubleSided culling."""

import math
import re
import struct
import warnings
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PilImage
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

import wrt
from wrt.textures import srgb_to_linear


def new_stage(tmp_path, name="m.usda"):
    path = str(tmp_path / name)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    return stage, path


def add_quad(stage, path, center=(0, 0, 0), size=2.0, st_range=1.0, faces=1, double_sided=None):
    """A square in the z = c plane facing +Z, split into ``faces`` vertical strips, with ``st`` over [0, st_range]."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    xs = np.linspace(-size / 2, size / 2, faces + 1)
    pts, st = [], []
    for y in (-size / 2, size / 2):
        for x in xs:
            pts.append(Gf.Vec3f(center[0] + x, center[1] + y, center[2]))
            st.append(Gf.Vec2f((x / size + 0.5) * st_range, (y / size + 0.5) * st_range))
    n = faces + 1
    counts, indices = [], []
    for f in range(faces):
        counts.append(4)
        indices += [f, f + 1, n + f + 1, n + f]
    mesh.CreatePointsAttr(Vt.Vec3fArray(pts))
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(indices)
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(st)
    if double_sided is not None:
        mesh.CreateDoubleSidedAttr(double_sided)
    return mesh


def preview_material(stage, path, **inputs):
    """A Material with a UsdPreviewSurface; ``inputs`` are constant values (name -> value)."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    types = {
        "diffuseColor": Sdf.ValueTypeNames.Color3f,
        "emissiveColor": Sdf.ValueTypeNames.Color3f,
        "specularColor": Sdf.ValueTypeNames.Color3f,
        "useSpecularWorkflow": Sdf.ValueTypeNames.Int,
    }
    for name, value in inputs.items():
        shader.CreateInput(name, types.get(name, Sdf.ValueTypeNames.Float)).Set(value)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material, shader


def bind(prim, material, purpose=None):
    api = UsdShade.MaterialBindingAPI.Apply(prim.GetPrim() if hasattr(prim, "GetPrim") else prim)
    if purpose:
        api.Bind(material, UsdShade.Tokens.weakerThanDescendants, purpose)
    else:
        api.Bind(material)


def test_preview_surface_inputs(tmp_path):
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, _ = preview_material(
        stage,
        "/Looks/Gold",
        diffuseColor=Gf.Vec3f(1.0, 0.8, 0.3),
        emissiveColor=Gf.Vec3f(0.1, 0.2, 0.3),
        metallic=0.9,
        roughness=0.25,
        opacity=0.5,
        ior=1.33,
        clearcoat=0.7,
        clearcoatRoughness=0.2,
        opacityThreshold=0.0,
        useSpecularWorkflow=1,
        specularColor=Gf.Vec3f(0.5, 0.5, 0.5),
    )
    bind(quad, material)
    stage.Save()
    scene = wrt.load_usd(path)
    (mat,) = scene.materials
    assert mat.path == "/Looks/Gold"
    np.testing.assert_allclose(mat.diffuse_color, (1.0, 0.8, 0.3))
    np.testing.assert_allclose(mat.emissive_color, (0.1, 0.2, 0.3))
    np.testing.assert_allclose(mat.specular_color, 0.5)
    assert mat.use_specular_workflow and mat.metallic == pytest.approx(0.9) and mat.roughness == pytest.approx(0.25)
    assert mat.opacity == pytest.approx(0.5) and mat.ior == pytest.approx(1.33)
    assert mat.clearcoat == pytest.approx(0.7) and mat.clearcoat_roughness == pytest.approx(0.2)
    assert (scene.meshes[0].material_ids == 0).all()


def test_inputs_that_are_not_finite_numbers_keep_their_defaults(tmp_path):
    """ior, opacityThreshold and colours of NaN or inf (or of a wrong type) fall back to the schema defaults, with a
    warning that names the material and the inputs: a NaN ior gave a near mirror (F0 = 0.996) and inf a black
    surface; a string stopped the load."""
    stage, path = new_stage(tmp_path)
    for k, value in enumerate((float("nan"), float("inf"))):
        quad = add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0))
        material, _ = preview_material(stage, f"/Looks/M{k}", ior=value, opacityThreshold=value,
                                       diffuseColor=Gf.Vec3f(0.5, value, 0.5))
        bind(quad, material)
    _, shader = preview_material(stage, "/Looks/M0")  # a string where a colour belongs: the default, one warning
    shader.CreateInput("roughness", Sdf.ValueTypeNames.String).Set("rough")
    stage.Save()
    with pytest.warns(UserWarning) as caught:
        materials = wrt.load_usd(path).materials
    for mat in materials:
        assert mat.ior == 1.5 and mat.opacity_threshold == 0.0, mat.path
        np.testing.assert_allclose(mat.diffuse_color, 0.18)
        warning = next(str(w.message) for w in caught if mat.path in str(w.message))
        assert "not a finite number" in warning and "ior" in warning and "diffuseColor" in warning, warning
    assert materials[0].roughness == 0.5
    assert "roughness" in next(str(w.message) for w in caught if "/M0" in str(w.message) and "not a number" in
                               str(w.message))


def test_inputs_of_the_wrong_shape_keep_their_defaults(tmp_path):
    """A colour authored as two numbers or as an array of colours, and a float input authored as a matrix, an array
    of numbers or a string of digits, keep the schema defaults with the warning naming the input. They were read
    without a word: the float2 colour (0.9, 0.1) as grey 0.9, the colour array as its first colour, the identity
    matrix as roughness 1, the array as its first number and the string "0.7" as metallic 0.7."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, shader = preview_material(stage, "/Looks/M")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.9, 0.1))
    shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3fArray).Set(
        Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0)]))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Matrix4d).Set(Gf.Matrix4d(1.0))
    shader.CreateInput("clearcoat", Sdf.ValueTypeNames.FloatArray).Set(Vt.FloatArray([0.25, 0.75]))
    shader.CreateInput("metallic", Sdf.ValueTypeNames.String).Set("0.7")
    bind(quad, material)
    stage.Save()
    with pytest.warns(UserWarning) as caught:
        mat = wrt.load_usd(path).materials[0]
    np.testing.assert_allclose(mat.diffuse_color, 0.18)  # the schema's defaults
    np.testing.assert_allclose(mat.emissive_color, 0.0)
    assert (mat.roughness, mat.clearcoat, mat.metallic) == (0.5, 0.0, 0.0)
    warning = " ".join(str(w.message) for w in caught if "/Looks/M" in str(w.message))  # one per problem
    for name in ("diffuseColor", "emissiveColor", "roughness", "clearcoat", "metallic"):
        assert name in warning, (name, warning)


def test_an_input_of_several_numbers_is_named_by_its_count_not_as_not_finite(tmp_path):
    """A float input authored with three numbers (a ``float3 roughness``) and a colour authored with two keep their
    defaults, and the warning says how many numbers each holds where one (or 1, 3 or 4) is expected: it said they
    were not finite numbers, which each of theirs is. The counts are USD's (the authored values' lengths)."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, shader = preview_material(stage, "/Looks/M")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.2, 0.3, 0.4))
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.1, 0.1, 0.1))
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.9, 0.1))
    bind(quad, material)
    stage.Save()
    with pytest.warns(UserWarning) as caught:
        mat = wrt.load_usd(path).materials[0]
    assert (mat.roughness, mat.opacity) == (0.5, 1.0)  # the schema's defaults
    np.testing.assert_allclose(mat.diffuse_color, 0.18)
    messages = [str(w.message) for w in caught if "/Looks/M" in str(w.message)]
    assert not [m for m in messages if "not a finite number" in m], messages
    floats = len(shader.GetInput("roughness").Get())
    (warning,) = [m for m in messages if f"authored with {floats} numbers where one is expected" in m]
    assert "roughness" in warning and "opacity" in warning and "diffuseColor" not in warning, warning
    colour = len(shader.GetInput("diffuseColor").Get())
    (warning,) = [m for m in messages if f"authored with {colour} numbers where 1, 3 or 4 are expected" in m]
    assert "diffuseColor" in warning, warning


@pytest.mark.parametrize("name, type_name, value", [
    ("diffuseColor", "StringArray", ["0.7"]),  # was the grey 0.7
    ("diffuseColor", "TokenArray", ["0.7", "0.1", "0.2"]),  # was the colour (0.7, 0.1, 0.2)
    ("emissiveColor", "StringArray", ["0.7"]),  # decoded through _rgb, then read by _set_constant
    ("roughness", "StringArray", ["0.3"]),  # was 0.3
])
def test_an_input_authored_as_an_array_of_strings_keeps_the_schema_default(tmp_path, name, type_name, value):
    """A ``string[]`` or ``token[]`` of digits is no number, as a ``string`` is not: numpy read ``["0.7"]`` as 0.7,
    so such an input became a grey or a roughness without a word. It keeps Sdr's default, named as not a number."""
    messages, _ = loaded_with_the_default(tmp_path, name, getattr(Sdf.ValueTypeNames, type_name), value)
    assert any("is not a number; its default is used" in m and name in m for m in messages), messages


def loaded_with_the_default(tmp_path, name: str, type_name, value) -> tuple[list[str], object]:
    """The warnings naming the material of a stage whose UsdPreviewSurface input ``name`` is authored as ``value`` of
    Sdf type ``type_name``, and the value USD reads back for it, after checking that the loaded material keeps Sdr's
    default for it."""
    from pxr import Sdr

    stage, path = new_stage(tmp_path)
    material, shader = preview_material(stage, "/Looks/M")
    shader.CreateInput(name, type_name).Set(value)
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    authored = shader.GetInput(name).GetAttr()
    assert authored.GetTypeName() == type_name  # USD's answer
    with pytest.warns(UserWarning) as caught:
        mat = wrt.load_usd(path).materials[0]
    default = Sdr.Registry().GetShaderNodeByIdentifier("UsdPreviewSurface").GetShaderInput(name).GetDefaultValue()
    field = {"diffuseColor": "diffuse_color", "emissiveColor": "emissive_color", "roughness": "roughness"}[name]
    np.testing.assert_allclose(np.ravel(getattr(mat, field)), np.ravel(default), rtol=1e-6)
    return [str(w.message) for w in caught if "/Looks/M" in str(w.message)], authored.Get()


@pytest.mark.parametrize("name", ["emissiveColor", "diffuseColor", "roughness"])
def test_an_input_authored_as_a_bool_keeps_the_schema_default(tmp_path, name):
    """``bool inputs:emissiveColor = 1`` holds no colour USD's typed readers give for its color3f (nor a float for
    roughness): it was read as grey 1 (roughness 1) without a word. It keeps Sdr's default, named, as a string does."""
    messages, authored = loaded_with_the_default(tmp_path, name, Sdf.ValueTypeNames.Bool, True)
    assert type(authored) is bool  # USD's answer
    assert any("bool" in m and "its default is used" in m and name in m for m in messages), messages


def test_an_input_connected_to_an_unsupported_shader_keeps_the_schema_default_and_says_so(tmp_path):
    """An input connected to a shader wrt does not know keeps UsdPreviewSurface's default (Sdr's), not the value
    authored beside the connection, as Storm draws it: UsdImaging hands Hydra no value for an input whose
    value-producing attribute is an output (``GetValueProducingAttributes``, checked here), and Storm's fallback for an
    unrecognized node is the Sdr default. The warning said "its constant value is used", which was never read."""
    from pxr import Sdr

    stage, path = new_stage(tmp_path)
    material, shader = preview_material(stage, "/Looks/M", roughness=0.9, diffuseColor=Gf.Vec3f(1.0, 0.0, 0.0))
    noise = UsdShade.Shader.Define(stage, "/Looks/M/Noise")
    noise.CreateIdAttr("MyNoise")
    shader.GetInput("roughness").ConnectToSource(noise.CreateOutput("out", Sdf.ValueTypeNames.Float))
    shader.GetInput("diffuseColor").ConnectToSource(noise.CreateOutput("rgb", Sdf.ValueTypeNames.Color3f))
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    for name in ("roughness", "diffuseColor"):  # USD's own answer: the value comes from the noise's output
        (attr,) = shader.GetInput(name).GetValueProducingAttributes()
        assert attr.GetPrim().GetPath() == noise.GetPath() and attr.GetName().startswith("outputs:")
    definition = Sdr.Registry().GetShaderNodeByIdentifier("UsdPreviewSurface")
    with pytest.warns(UserWarning) as caught:
        mat = wrt.load_usd(path).materials[0]
    assert mat.roughness == pytest.approx(definition.GetShaderInput("roughness").GetDefaultValue())
    np.testing.assert_allclose(mat.diffuse_color, definition.GetShaderInput("diffuseColor").GetDefaultValue(),
                               rtol=1e-6)
    messages = [str(w.message) for w in caught if "unsupported shader (MyNoise)" in str(w.message)]
    assert len(messages) == 2 and all("its default is used" in m and "constant value" not in m for m in messages), \
        messages


@pytest.mark.parametrize("ior", [1.0, 1.5, 2.0, 3.0])
def test_the_clearcoat_reflects_the_fresnel_reflectance_of_ior(tmp_path, ior):
    """The specification's ``ior`` is the index "including the clearcoat", whose F0 is ``((1 - ior) / (1 + ior))^2``
    (Storm and MaterialX's UsdPreviewSurface graph build it so). A smooth clearcoat over a black base (specular
    workflow, specularColor 0, a mirror: F0 = 0 at normal incidence) under a white dome, seen at normal incidence,
    shows that F0. It showed
    0.04 (ior 1.5's) for every index: 0.16 of ior 3's 0.25, and a coat for ior 1, which has none."""
    stage, path = new_stage(tmp_path)
    bind(add_quad(stage, "/Quad", size=20.0), preview_material(
        stage, "/Looks/Coat", diffuseColor=Gf.Vec3f(0.0), useSpecularWorkflow=1, specularColor=Gf.Vec3f(0.0),
        roughness=0.0, clearcoat=1.0, clearcoatRoughness=0.0, ior=ior)[0])
    UsdLux.DomeLight.Define(stage, "/Dome")
    stage.Save()
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(wrt.load_usd(path), camera=cam, width=2, height=2, device="cpu", integrator="path")
    np.testing.assert_allclose(img.rgb, ((1.0 - ior) / (1.0 + ior)) ** 2, rtol=1e-4, atol=1e-6)


def test_inputs_past_float32_keep_their_defaults(tmp_path):
    """Inputs authored as doubles beyond float32's range (``double ior = 1e300``, a ``color3d`` emissiveColor of
    1e39) keep the schema defaults with the not-a-finite-number warning, as NaN does, and the stage renders: they
    passed the float64 check and the render stopped with "Material ior must be a finite number"."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, shader = preview_material(stage, "/Looks/M")
    shader.CreateInput("ior", Sdf.ValueTypeNames.Double).Set(1e300)
    shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3d).Set(Gf.Vec3d(1e39, 0.0, 0.0))
    bind(quad, material)
    stage.Save()
    with pytest.warns(UserWarning) as caught:
        scene = wrt.load_usd(path)
    warning = next(str(w.message) for w in caught if "not a finite number" in str(w.message))
    assert "ior" in warning and "emissiveColor" in warning, warning
    mat = scene.materials[0]
    assert mat.ior == 1.5
    np.testing.assert_allclose(mat.emissive_color, 0.0)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="albedo")
    np.testing.assert_allclose(img.rgb, 0.18)


def define_surface(stage, path: str, context: str, kind: str):
    """Material ``path`` and its shader ``Surface``: an MDL ``kind`` (``context`` "mdl") or a node of id ``kind``."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    if context == "mdl":
        shader.SetSourceAsset(Sdf.AssetPath(f"{kind}.mdl"), "mdl")
        shader.SetSourceAssetSubIdentifier(kind, "mdl")
    else:
        shader.CreateIdAttr(kind)
    return material, shader


def test_colours_and_materialx_inputs_past_float32_do_not_stop_the_load(tmp_path):
    """A primvar reader's fallback, an OmniPBR base colour and MaterialX standard_surface inputs authored as doubles
    beyond float32's range are read as not finite: the stage loads and renders finite pixels (each stopped the load
    with "Material ... must be finite numbers"). The MaterialX surface keeps its specification defaults (base 1 and
    base_color 0.8: diffuse 0.8, specular_IOR 1.5) and the OmniPBR one falls back to the mesh's displayColor."""
    stage, path = new_stage(tmp_path)
    quads = [add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0)) for k in range(3)]
    for quad in quads:
        quad.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.2, 0.7, 0.1)])
    material, shader = preview_material(stage, "/Looks/Reader")
    reader = UsdShade.Shader.Define(stage, "/Looks/Reader/Primvar")
    reader.CreateIdAttr("UsdPrimvarReader_float3")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("missing")
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Double3).Set(Gf.Vec3d(1e39, 0.0, 0.0))
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(reader.ConnectableAPI(), "result")
    bind(quads[0], material)
    for k, (context, kind, inputs) in enumerate([
            ("mdl", "OmniPBR", {"diffuse_color_constant": Gf.Vec3d(1e39, 0.0, 0.0)}),
            ("mtlx", "ND_standard_surface_surfaceshader", {"base": 1e300, "specular_IOR": 1e300})], start=1):
        material, shader = define_surface(stage, f"/Looks/X{k}", context, kind)
        for name, value in inputs.items():
            shader.CreateInput(name, Sdf.ValueTypeNames.Double3 if isinstance(value, Gf.Vec3d)
                               else Sdf.ValueTypeNames.Double).Set(value)
        material.CreateSurfaceOutput(context).ConnectToSource(shader.ConnectableAPI(), "out")
        bind(quads[k], material)
    stage.Save()
    scene, _ = load_with_messages(path)
    mtlx = next(m for m in scene.materials if m.path == "/Looks/X2")
    np.testing.assert_allclose(mtlx.diffuse_color, 0.8)
    assert mtlx.ior == 1.5
    cam = wrt.Camera.orthographic(eye=(3, 0, 5), target=(3, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=12, height=4, device="cpu", integrator="albedo")
    assert np.isfinite(img.rgb).all()
    np.testing.assert_allclose(img.rgb[:, 4:8][img.aovs["prim"][:, 4:8] >= 0], np.tile([0.2, 0.7, 0.1], (16, 1)),
                               rtol=1e-5)  # OmniPBR: displayColor


def test_a_connection_to_nothing_is_named_and_keeps_the_inputs_value(tmp_path):
    """An input connected to a prim that does not exist, or to an output a shader does not declare, reads its own
    authored value (else the schema default), as USD resolves it (no connected source) and Storm draws it, and is
    named in a warning with its target: a renamed or deleted texture node was drawn in the default colour without a
    word."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, shader = preview_material(stage, "/Looks/M", diffuseColor=Gf.Vec3f(0.9, 0.1, 0.1))
    shader.GetInput("diffuseColor").GetAttr().AddConnection(Sdf.Path("/Looks/M/Gone.outputs:rgb"))
    tex = UsdShade.Shader.Define(stage, "/Looks/M/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).GetAttr().AddConnection(
        Sdf.Path("/Looks/M/Tex.outputs:r"))  # Tex declares no output r
    bind(quad, material)
    stage.Save()
    with pytest.warns(UserWarning) as caught:
        mat = wrt.load_usd(path).materials[0]
    np.testing.assert_allclose(mat.diffuse_color, (0.9, 0.1, 0.1))
    assert mat.roughness == 0.5 and mat.textures == {}
    warning = next((str(w.message) for w in caught if "connect" in str(w.message)), "")
    for name in ("diffuseColor", "/Looks/M/Gone.outputs:rgb", "roughness", "/Looks/M/Tex.outputs:r"):
        assert name in warning, (name, [str(w.message) for w in caught])


def test_material_interface_inputs_are_followed(tmp_path):
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material, shader = preview_material(stage, "/Looks/M")
    exposed = material.CreateInput("tint", Sdf.ValueTypeNames.Color3f)
    exposed.Set(Gf.Vec3f(0.2, 0.4, 0.6))
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(exposed)
    bind(quad, material)
    stage.Save()
    np.testing.assert_allclose(wrt.load_usd(path).materials[0].diffuse_color, (0.2, 0.4, 0.6), rtol=1e-6)


def test_geom_subset_bindings_override_the_mesh(tmp_path):
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad", faces=3)
    red, _ = preview_material(stage, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
    blue, _ = preview_material(stage, "/Looks/Blue", diffuseColor=Gf.Vec3f(0, 0, 1))
    bind(quad, red)
    subset = UsdShade.MaterialBindingAPI(quad.GetPrim()).CreateMaterialBindSubset("right", Vt.IntArray([2]))
    bind(subset, blue)
    stage.Save()
    scene = wrt.load_usd(path)
    names = [scene.materials[k].path for k in scene.meshes[0].material_ids]
    assert names == ["/Looks/Red"] * 4 + ["/Looks/Blue"] * 2  # two triangles per quad face


def test_material_subsets_of_points_are_not_read_as_faces(tmp_path):
    """A materialBind subset whose elementType is point lists point indices: it binds no face (they coloured the
    faces whose numbers matched the point numbers), and the load says so."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad", faces=3)
    red, _ = preview_material(stage, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
    blue, _ = preview_material(stage, "/Looks/Blue", diffuseColor=Gf.Vec3f(0, 0, 1))
    bind(quad, red)
    api = UsdShade.MaterialBindingAPI(quad.GetPrim())
    points = api.CreateMaterialBindSubset("corners", Vt.IntArray([0, 1]), UsdGeom.Tokens.point)
    bind(points, blue)
    stage.Save()
    with pytest.warns(UserWarning, match=r"elementType is not face.*/Quad/corners"):
        scene = wrt.load_usd(path)
    names = {scene.materials[k].path for k in scene.meshes[0].material_ids}
    assert names == {"/Looks/Red"}


def test_full_purpose_and_collection_bindings(tmp_path):
    stage, path = new_stage(tmp_path)
    group = UsdGeom.Xform.Define(stage, "/Group")
    a = add_quad(stage, "/Group/A")
    b = add_quad(stage, "/Group/B", center=(3, 0, 0))
    preview, _ = preview_material(stage, "/Looks/Preview", diffuseColor=Gf.Vec3f(0.1, 0.1, 0.1))
    full, _ = preview_material(stage, "/Looks/Full", diffuseColor=Gf.Vec3f(0.9, 0.9, 0.9))
    via_collection, _ = preview_material(stage, "/Looks/Coll", diffuseColor=Gf.Vec3f(0, 1, 0))
    bind(a, preview, UsdShade.Tokens.preview)
    bind(a, full, UsdShade.Tokens.full)
    # B gets its material through a collection binding authored on the group.
    collection = Usd.CollectionAPI.Apply(group.GetPrim(), "greens")
    collection.CreateIncludesRel().AddTarget(b.GetPath())
    UsdShade.MaterialBindingAPI.Apply(group.GetPrim()).Bind(collection, via_collection)
    stage.Save()
    scene = wrt.load_usd(path)
    by_mesh = {m.path: scene.materials[m.material_ids[0]].path for m in scene.meshes}
    assert by_mesh == {"/Group/A": "/Looks/Full", "/Group/B": "/Looks/Coll"}


def mdl_material(stage, path):
    """A Material whose only surface is an ``mdl:surface`` output to OmniPBR (no UsdPreviewSurface)."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.SetSourceAsset(Sdf.AssetPath("OmniPBR.mdl"), "mdl")
    material.CreateSurfaceOutput("mdl").ConnectToSource(shader.ConnectableAPI(), "out")
    return material


def test_preview_bindings_serve_where_full_binds_no_preview_surface(tmp_path):
    """As usdview shows them: a mesh bound only for ``preview`` was drawn in the default grey, and one whose full
    binding is an MDL look kept the MDL's fallback instead of its preview UsdPreviewSurface."""
    stage, path = new_stage(tmp_path)
    only_preview = add_quad(stage, "/OnlyPreview")
    mdl_full = add_quad(stage, "/MdlFull", center=(3, 0, 0))
    both = add_quad(stage, "/Both", center=(6, 0, 0))
    red, _ = preview_material(stage, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
    green, _ = preview_material(stage, "/Looks/Green", diffuseColor=Gf.Vec3f(0, 1, 0))
    mdl = mdl_material(stage, "/Looks/Mdl")
    bind(only_preview, red, UsdShade.Tokens.preview)
    bind(mdl_full, mdl, UsdShade.Tokens.full)
    bind(mdl_full, red, UsdShade.Tokens.preview)
    bind(both, green, UsdShade.Tokens.full)  # a full UsdPreviewSurface wins over the preview one
    bind(both, red, UsdShade.Tokens.preview)
    stage.Save()
    scene = wrt.load_usd(path)
    by_mesh = {m.path: scene.materials[m.material_ids[0]].path for m in scene.meshes}
    assert by_mesh == {"/OnlyPreview": "/Looks/Red", "/MdlFull": "/Looks/Red", "/Both": "/Looks/Green"}


@pytest.mark.parametrize("instanceable", [False, True])
def test_preview_bindings_on_native_instances_reach_the_prototype_meshes(tmp_path, instanceable):
    """Bindings on an instanceable prim follow the same rule as those on a mesh: an instance bound only for
    ``preview`` drew its prototype's meshes in the default grey, and one whose full binding is an MDL look drew the
    MDL's fallback, where the same stage without ``instanceable`` showed the preview UsdPreviewSurfaces."""
    stage, path = new_stage(tmp_path)
    red, _ = preview_material(stage, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
    green, _ = preview_material(stage, "/Looks/Green", diffuseColor=Gf.Vec3f(0, 1, 0))
    mdl = mdl_material(stage, "/Looks/Mdl")
    stage.CreateClassPrim("/Chair")
    add_quad(stage, "/Chair/Seat")
    chairs = {}
    for k, name in enumerate(["OnlyPreview", "MdlFull"]):
        chair = UsdGeom.Xform.Define(stage, f"/World/{name}")
        chair.GetPrim().GetInherits().AddInherit("/Chair")
        chair.AddTranslateOp().Set(Gf.Vec3d(3 * k, 0, 0))
        chair.GetPrim().SetInstanceable(instanceable)
        chairs[name] = chair
    bind(chairs["OnlyPreview"], red, UsdShade.Tokens.preview)
    bind(chairs["MdlFull"], mdl)
    bind(chairs["MdlFull"], green, UsdShade.Tokens.preview)
    stage.Save()
    scene = wrt.load_usd(path)
    if instanceable:
        assert len(scene.instances) == 2 and not scene.meshes
        prototypes = scene.instances.prototype
        meshes = {scene.instances.path(i): scene.prototypes[p].meshes[0] for i, p in enumerate(prototypes)}
    else:
        meshes = {m.path.removesuffix("/Seat"): m for m in scene.meshes}
    by_chair = {chair: {scene.materials[k].path for k in m.material_ids} for chair, m in meshes.items()}
    assert by_chair == {"/World/OnlyPreview": {"/Looks/Red"}, "/World/MdlFull": {"/Looks/Green"}}


def test_unsupported_shaders_fall_back_with_one_warning_per_material(tmp_path):
    stage, path = new_stage(tmp_path)
    for k, shader_id in enumerate(["ND_gltf_pbr_surfaceshader", "ND_surface_unlit"]):  # MaterialX, not read
        quad = add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0))
        quad.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.2, 0.7, 0.1)])
        material = UsdShade.Material.Define(stage, f"/Looks/X{k}")
        shader = UsdShade.Shader.Define(stage, f"/Looks/X{k}/Surface")
        shader.CreateIdAttr(shader_id)
        material.CreateSurfaceOutput("mtlx").ConnectToSource(shader.ConnectableAPI(), "out")
        bind(quad, material)
    stage.Save()
    scene, messages = load_with_messages(path)
    assert sum("/Looks/X0" in m for m in messages) == 1 and sum("/Looks/X1" in m for m in messages) == 1
    assert scene.materials == [] and all((m.material_ids == -1).all() for m in scene.meshes)  # -1: default material
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu")
    np.testing.assert_allclose(img.aovs["albedo"], np.broadcast_to([0.2, 0.7, 0.1], (4, 4, 3)), rtol=1e-6)


def write_png(path, pixels):
    PilImage.fromarray(np.asarray(pixels, np.uint8)).save(path)
    return str(path)


def st_source(stage, material_path, transform=None):
    """The ``(connectable, output)`` a texture's ``st`` connects to: a ``UsdPrimvarReader_float2`` of ``st`` under
    ``material_path``, through a ``UsdTransform2d`` of ``transform`` (input name -> value) when given."""
    reader = UsdShade.Shader.Define(stage, f"{material_path}/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    source = reader.ConnectableAPI(), "result"
    if transform is not None:
        xf = UsdShade.Shader.Define(stage, f"{material_path}/Xf")
        xf.CreateIdAttr("UsdTransform2d")
        xf.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(*source)
        for key, value in transform.items():
            xf.CreateInput(key, Sdf.ValueTypeNames.Float if key == "rotation" else Sdf.ValueTypeNames.Float2).Set(value)
        source = xf.ConnectableAPI(), "result"
    return source


def textured_stage(tmp_path, png, st_range=1.0, wrap=None, color_space=None, transform=None, channel="rgb",
                   input_name="diffuseColor"):
    stage, path = new_stage(tmp_path, f"textured{len(list(tmp_path.glob('*.usda')))}.usda")
    quad = add_quad(stage, "/Quad", st_range=st_range)
    material, shader = preview_material(stage, "/Looks/Tex")
    tex = UsdShade.Shader.Define(stage, "/Looks/Tex/Image")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(*st_source(stage, "/Looks/Tex", transform))
    if wrap:
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(wrap)
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(wrap)
    if color_space:
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(color_space)
    out_type = Sdf.ValueTypeNames.Float3 if channel == "rgb" else Sdf.ValueTypeNames.Float
    tex.CreateOutput(channel, out_type)
    in_type = Sdf.ValueTypeNames.Color3f if input_name.endswith("Color") else Sdf.ValueTypeNames.Float
    shader.CreateInput(input_name, in_type).ConnectToSource(tex.ConnectableAPI(), channel)
    bind(quad, material)
    stage.Save()
    return path


def load_with_messages(path):
    """``wrt.load_usd(path)`` and the messages of every warning it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    return scene, [str(w.message) for w in caught]


def albedo(path, res=4):
    scene = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    return wrt.render(scene, camera=cam, width=res, height=res, device="cpu", integrator="albedo").rgb


# 2x2 blocks of 4x4 texels (rows from the top), so bilinear lookups at pixel centres never mix two blocks.
CHECKER = np.repeat(np.repeat(np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [128, 128, 128]]]), 4, 0), 4, 1)


def test_texture_lookup_and_srgb_decoding(tmp_path):
    png = write_png(tmp_path / "checker.png", CHECKER)
    img = albedo(textured_stage(tmp_path, png))  # 4x4 pixels: 2x2 per texel, st (0,0) at the bottom-left
    grey = float(srgb_to_linear(np.float32(128 / 255)))
    np.testing.assert_allclose(img[0, 0], (1, 0, 0), atol=1e-3)  # top-left texel
    np.testing.assert_allclose(img[0, 3], (0, 1, 0), atol=1e-3)
    np.testing.assert_allclose(img[3, 0], (0, 0, 1), atol=1e-3)
    np.testing.assert_allclose(img[3, 3], (grey, grey, grey), atol=2e-3)
    raw = albedo(textured_stage(tmp_path, png, color_space="raw"))
    np.testing.assert_allclose(raw[3, 3], 128 / 255, atol=2e-3)


@pytest.mark.parametrize(
    "wrap, expected_right_half",
    [
        ("repeat", "same"),  # st in [1, 2] repeats the image
        ("mirror", "mirrored"),
        ("clamp", "edge"),
        ("black", "black"),
        # useMetadata asks for the file's wrap metadata; a PNG has none, and then the specification (and Storm) give
        # black. It was read as repeat.
        ("useMetadata", "black"),
        (None, "black"),  # unauthored: the schema's fallback, useMetadata
    ],
)
def test_wrap_modes(tmp_path, wrap, expected_right_half):
    png = write_png(tmp_path / "checker.png", CHECKER)
    img = albedo(textured_stage(tmp_path, png, st_range=2.0, wrap=wrap, color_space="raw"), res=8)
    left = img[6:8, 0:2]  # st in [0, 0.5]^2: the bottom-left texel (blue)
    np.testing.assert_allclose(left, np.broadcast_to([0, 0, 1], left.shape), atol=1e-3)
    right = img[6:8, 6:8].mean(axis=(0, 1))  # st around (1.75, 0.25)
    expected = {
        "same": [128 / 255] * 3,  # texel (1, 0) of the image: grey
        "mirrored": [0, 0, 1],  # mirrored back onto texel (0, 0): blue
        "edge": [128 / 255] * 3,  # the right edge column, bottom row: grey
        "black": [0, 0, 0],
    }[expected_right_half]
    np.testing.assert_allclose(right, expected, atol=2e-3)


@pytest.mark.parametrize("wrap", ["black", None])
def test_black_wrap_keeps_the_image_whole_inside_the_unit_square(tmp_path, wrap):
    """``black`` is black outside [0, 1]^2 and the image inside: the lookup mixed a black border into the outer half
    texel, so a 2 x 2 image came out at 3/4 or 9/16 of its value over three quarters of the quad."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), (200, 100, 50)))
    img = albedo(textured_stage(tmp_path, png, st_range=2.0, wrap=wrap, color_space="raw"), res=8)
    inside = img[4:8, 0:4]  # st in [0, 1]^2: pixel centres at st 0.125 .. 0.875
    np.testing.assert_allclose(inside, np.broadcast_to(np.array([200, 100, 50]) / 255, inside.shape), atol=2e-3)
    np.testing.assert_allclose(img[0:4], 0.0, atol=1e-6)  # t > 1
    np.testing.assert_allclose(img[:, 4:8], 0.0, atol=1e-6)  # s > 1


def test_unknown_source_color_space_is_named_and_read_as_auto(tmp_path):
    """``sourceColorSpace = "linear"`` (not a token of the schema) was read as auto without a word, so an 8-bit map
    meant linear was decoded as sRGB."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), 128))
    with pytest.warns(UserWarning, match=r"sourceColorSpace is not one of auto, sRGB or raw.*linear"):
        img = albedo(textured_stage(tmp_path, png, color_space="linear"))
    np.testing.assert_allclose(img, float(srgb_to_linear(np.float32(128 / 255))), atol=2e-3)  # auto: sRGB for 8 bits


@pytest.mark.parametrize(
    "mode, source_color_space, file_color_space",
    [("RGB", "raw", "srgb_rec709_scene"), ("L", "sRGB", "lin_rec709_scene"), ("RGB", None, "raw")],
)
def test_a_usd_uv_textures_file_color_space_is_named_and_its_source_color_space_decides(
        tmp_path, mode, source_color_space, file_color_space):
    """Storm decodes a UsdUVTexture by its ``sourceColorSpace`` alone (``auto`` where unauthored): hdSt's
    materialNetwork resolves that input and reads no ``colorSpace`` metadata for a glslfx texture node. So an 8-bit
    texel of 128 marked ``srgb_rec709_scene`` under ``sourceColorSpace = raw`` reads 128/255, a grey one marked
    ``lin_rec709_scene`` under ``sRGB`` and an RGB one marked ``raw`` under ``auto`` are sRGB-decoded (float64
    here). wrt read them so without a word about the colorSpace it left out; it is named now."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3) if mode == "RGB" else (2, 2), 128))
    path = textured_stage(tmp_path, png, color_space=source_color_space)
    stage = Usd.Stage.Open(path)
    UsdShade.Shader.Get(stage, "/Looks/Tex/Image").GetInput("file").GetAttr().SetColorSpace(file_color_space)
    stage.Save()
    scene, messages = load_with_messages(path)
    read_as = source_color_space or "auto"
    (note,) = [m for m in messages if "colorSpace is not read" in m]
    assert f"sourceColorSpace {read_as}" in note and file_color_space in note and "/Looks/Tex/Image" in note
    (mat,) = scene.materials
    texels = np.asarray(scene.textures[mat.textures["diffuseColor"].image][..., :3], np.float64)
    stored = 128 / 255
    want = stored if read_as == "raw" else ((stored + 0.055) / 1.055) ** 2.4
    np.testing.assert_allclose(texels, want, rtol=1e-5)


def test_unknown_texture_output_is_named_and_read_as_rgb(tmp_path):
    """A UsdUVTexture has the outputs r, g, b, a and rgb; one named otherwise (``result``, as other readers call it)
    was read as rgb without a word."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), (200, 100, 50)))
    with pytest.warns(UserWarning, match=r"UsdUVTexture output is none of r, g, b, a, rgb or rgba.*result"):
        img = albedo(textured_stage(tmp_path, png, color_space="raw", channel="result"))
    np.testing.assert_allclose(img, np.broadcast_to(np.array([200, 100, 50]) / 255, img.shape), atol=2e-3)


@pytest.mark.parametrize("channel", ["a", "rgb"])
def test_a_float3_scale_keeps_alpha_at_one(tmp_path, channel):
    """``scale`` authored as a float3 (the schema's is a float4) was stretched to four values by repeating its red,
    so the ``a`` output of an opaque image came out at the red scale (0.5) instead of 1; rgb keeps its three."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), (200, 100, 50)))
    path = textured_stage(tmp_path, png, color_space="raw", channel=channel)
    stage = Usd.Stage.Open(path)
    UsdShade.Shader.Get(stage, "/Looks/Tex/Image").CreateInput("scale", Sdf.ValueTypeNames.Float3).Set((0.5, 0.25, 2))
    stage.Save()
    img = albedo(path)
    expected = [1.0, 1.0, 1.0] if channel == "a" else np.array([200 * 0.5, 100 * 0.25, 50 * 2]) / 255
    np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3)


@pytest.mark.parametrize("name, type_name, value", [
    ("scale", "Float4", Gf.Vec4f(float("inf"), 1.0, 1.0, 1.0)),
    ("bias", "Float4", Gf.Vec4f(float("nan"), 0.0, 0.0, 0.0)),
    ("scale", "Float2", Gf.Vec2f(0.5, 0.5)),  # neither one number, rgb nor rgba
    ("fallback", "String", "grey"),
])
def test_a_texture_scale_bias_or_fallback_that_is_not_finite_numbers_keeps_its_default(tmp_path, name, type_name,
                                                                                      value):
    """A UsdUVTexture ``scale``, ``bias`` or ``fallback`` that is not 1, 3 or 4 finite numbers keeps the schema's
    default with a warning naming the input, as the UsdPreviewSurface inputs do. An infinite scale made the albedo
    infinite and a NaN bias black, without a word; a float2 scale was stretched to (0.5, 0.5, 0.5, 0.5); a string
    fallback stopped the load with "cannot read this prim". The oracle: the flat image's texel, unscaled."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), (200, 100, 50)))
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    tex = UsdShade.Shader.Get(stage, "/Looks/Tex/Image")
    tex.GetPrim().CreateAttribute(f"inputs:{name}", getattr(Sdf.ValueTypeNames, type_name)).Set(value)
    stage.Save()
    with pytest.warns(UserWarning, match=rf"scale, bias or fallback is not 1, 3 or 4 finite numbers.*{name} = "):
        img = albedo(path)
    np.testing.assert_allclose(img, np.broadcast_to(np.array([200, 100, 50]) / 255, img.shape), atol=2e-3)


def test_unknown_wrap_tokens_are_named_and_read_as_use_metadata(tmp_path):
    """A wrap token outside the schema's list (MaterialX's "periodic") was read as repeat without a word; Storm warns
    and reads it as useMetadata, black outside the image for a file without wrap metadata."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, st_range=2.0, wrap="periodic", color_space="raw")
    with pytest.warns(UserWarning, match=r"wrap[ST] is not one of black, clamp.*periodic"):
        img = albedo(path, res=8)
    np.testing.assert_allclose(img[6:8, 0:2], np.broadcast_to([0, 0, 1], (2, 2, 3)), atol=1e-3)  # inside: the image
    np.testing.assert_allclose(img[0:2, 6:8], 0.0, atol=1e-6)  # st around (1.75, 1.75): black


@pytest.mark.parametrize("mesh_st", ["st", None])
def test_mesh_without_the_primvar_reads_the_readers_fallback(tmp_path, mesh_st):
    """A mesh lacking the primvar its texture's UsdPrimvarReader_float2 names shows the texture at the reader's
    ``fallback`` st, as the specification's reader gives it. wrt read the mesh's only other 2-vector primvar instead
    (without a word), and a mesh with none sampled st = (0, 0) while the warning said it was left untextured."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St"))
    reader.GetInput("varname").Set("uv_missing")
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.75, 0.25))  # the grey block's middle
    if mesh_st is None:
        UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad")).RemovePrimvar("st")
    stage.Save()
    has = r"; the mesh has st" if mesh_st else r": 1\): /Quad"  # no other primvar to name
    with pytest.warns(UserWarning, match=r"reader's fallback st.*uv_missing, fallback \(0.75, 0.25\)" + has):
        img = albedo(path)
    np.testing.assert_allclose(img, np.full(img.shape, 128 / 255), atol=2e-3)  # CHECKER's bottom-right block


def define_tet_or_patch(stage, kind: str):
    """A TetMesh (one tetrahedron whose base covers the square [-1, 1]^2 in z = 0, its apex above) or a bilinear
    NurbsPatch (the square [-2, 2]^2 in z = 0), double-sided, at ``/Surface``."""
    if kind == "TetMesh":
        surface = UsdGeom.TetMesh.Define(stage, "/Surface")
        surface.CreatePointsAttr([(-4, -4, 0), (4, -4, 0), (0, 6, 0), (0, 0, 1)])
        surface.CreateTetVertexIndicesAttr([Gf.Vec4i(0, 1, 2, 3)])
    else:
        surface = UsdGeom.NurbsPatch.Define(stage, "/Surface")
        surface.CreatePointsAttr([(-2, -2, 0), (2, -2, 0), (-2, 2, 0), (2, 2, 0)])
        for attr, value in (("uVertexCount", 2), ("vVertexCount", 2), ("uOrder", 2), ("vOrder", 2)):
            getattr(surface, f"Create{attr[0].upper()}{attr[1:]}Attr")(value)
        surface.CreateUKnotsAttr([0, 0, 1, 1])
        surface.CreateVKnotsAttr([0, 0, 1, 1])
    surface.CreateDoubleSidedAttr(True)
    return surface


@pytest.mark.parametrize("kind", ["TetMesh", "NurbsPatch"])
def test_tet_meshes_and_nurbs_patches_read_their_texture_at_the_readers_fallback_st(tmp_path, kind):
    """A TetMesh or NurbsPatch without the texture-coordinate primvar shows a texture its material reads at the
    UsdPrimvarReader_float2's ``fallback`` st, as a mesh without the primvar (and a gprim). The render did so,
    while the warning said the prim was left untextured; it now names the primvar and the fallback read."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St"))
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.75, 0.25))  # the grey block's middle
    stage.RemovePrim("/Quad")
    bind(define_tet_or_patch(stage, kind), UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    stage.Save()
    fallback = reader.GetInput("fallback").Get()
    scene, messages = load_with_messages(path)
    (message,) = [m for m in messages if "/Surface" in m]
    assert "untextured" not in message, message
    assert "reader's fallback st" in message, message
    assert f"st, fallback ({fallback[0]:g}, {fallback[1]:g})" in message, message
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
    np.testing.assert_allclose(img, np.full(img.shape, 128 / 255), atol=2e-3)  # CHECKER's texel at the fallback st


def textured_tet_or_patch(tmp_path, kind: str):
    """The CHECKER textured stage (clamped, raw) with a TetMesh or NurbsPatch (:func:`define_tet_or_patch`) in place
    of its quad, bound to its material: ``(stage, path, surface)``."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    surface = define_tet_or_patch(stage, kind)
    bind(surface, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    return stage, path, surface


@pytest.mark.parametrize("kind, interpolation", [("TetMesh", "vertex"), ("TetMesh", "varying"),
                                                 ("TetMesh", "uniform"), ("NurbsPatch", "vertex"),
                                                 ("NurbsPatch", "varying"), ("NurbsPatch", "uniform")])
def test_tet_meshes_and_nurbs_patches_read_their_texture_coordinates(tmp_path, kind, interpolation):
    """An authored ``st`` on a TetMesh (its surface faces' points) or a NurbsPatch (its control points, or its
    knot-interval corners for varying) is read: it was not read at all, the texture shown at the reader's fallback
    st. The oracle: ``st`` authored as an affine function of the points, ``((x + 1) / 2, (y + 1) / 2)``, which the
    barycentric (TetMesh) and rational B-spline (affine invariant) interpolations of it keep, so a pixel sees the
    texel under its centre's (x, y) in the view of [-1, 1]^2; one value per tetrahedron or patch (uniform) is read
    everywhere on it."""
    stage, path, surface = textured_tet_or_patch(tmp_path, kind)
    points = np.array(surface.GetPointsAttr().Get(), np.float64)
    st = (points[:, :2] + 1.0) / 2.0 if interpolation != "uniform" else np.array([[0.75, 0.25]])
    primvar = UsdGeom.PrimvarsAPI(surface).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interpolation)
    primvar.Set(Vt.Vec2fArray([Gf.Vec2f(*v) for v in st]))
    stage.Save()
    assert UsdGeom.PrimvarsAPI(surface).GetPrimvar("st").GetInterpolation() == interpolation
    scene, messages = load_with_messages(path)
    assert not [m for m in messages if "/Surface" in m], messages
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
    centres = -0.75 + 0.5 * np.arange(4)
    x, y = np.meshgrid(centres, -centres)  # rows from the top
    s, t = ((x + 1) / 2, (y + 1) / 2) if interpolation != "uniform" else (np.full_like(x, 0.75), np.full_like(y, 0.25))
    # Each st lies in the middle of a 2x2 texel quarter of one CHECKER block: bilinear filtering reads that block.
    expected = CHECKER[((1 - t) * 8).astype(int), (s * 8).astype(int)] / 255
    np.testing.assert_allclose(img, expected, atol=2e-3)


def test_a_tet_mesh_st_of_an_interpolation_it_cannot_take_reads_the_fallback_with_a_warning(tmp_path):
    """A faceVarying ``st`` on a TetMesh (face-vertices of which faces? The schema gives a TetMesh none) is dropped
    with a warning naming the primvar and its interpolation, and the texture read at the reader's fallback st."""
    stage, path, surface = textured_tet_or_patch(tmp_path, "TetMesh")
    primvar = UsdGeom.PrimvarsAPI(surface).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
    primvar.Set(Vt.Vec2fArray([Gf.Vec2f(0, 0)] * 12))
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St"))
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.75, 0.25))  # the grey block's middle
    stage.Save()
    scene, messages = load_with_messages(path)
    assert any("primvars:st has interpolation 'faceVarying'" in m and "/Surface" in m for m in messages), messages
    assert any("fallback st" in m and "st, fallback (0.75, 0.25)" in m for m in messages), messages
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
    np.testing.assert_allclose(img, np.full(img.shape, 128 / 255), atol=2e-3)


@pytest.mark.parametrize("tessellate", [False, True])
@pytest.mark.parametrize("gprim", ["Cube", "Sphere"])
def test_a_gprim_reads_its_texture_at_the_readers_fallback_st(tmp_path, gprim, tessellate):
    """A gprim has no texture coordinates (Storm's generated meshes carry no st), so its textures read at the
    UsdPrimvarReader_float2's ``fallback`` st, as on a mesh without the primvar. Drawn analytically it read st =
    (0, 0), the image's bottom-left texel, whatever the fallback: unlike the same gprim tessellated."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St")).CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(
        Gf.Vec2f(0.75, 0.25))  # the grey block's middle
    stage.RemovePrim("/Quad")
    shape = getattr(UsdGeom, gprim).Define(stage, "/Shape")
    shape.CreateSizeAttr(1.0) if gprim == "Cube" else shape.CreateRadiusAttr(0.5)
    bind(shape, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    stage.Save()
    scene = wrt.load_usd(path, tessellate_gprims=tessellate)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=0.5)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
    np.testing.assert_allclose(img, np.full(img.shape, 128 / 255), atol=2e-3)  # CHECKER's bottom-right block


def grey_fallback_stage(tmp_path) -> tuple:
    """``(path, stage)``: the CHECKER stage without its quad, its st reader's fallback at (0.75, 0.25), the middle of
    CHECKER's grey block (read raw), for the tests of where a gprim's or an instance's st comes from."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St")).CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(
        Gf.Vec2f(0.75, 0.25))
    stage.RemovePrim("/Quad")
    return path, stage


@pytest.mark.parametrize("tessellate", [False, True])
@pytest.mark.parametrize("holder", ["/Group/Shape", "/Group"])
@pytest.mark.parametrize("kind", ["Sphere", "Points", "BasisCurves"])
def test_gprims_points_and_curves_read_their_texture_at_their_constant_st(tmp_path, kind, holder, tessellate):
    """A constant ``st`` primvar on a gprim, or inherited from a prim above it, is where its textures read (as
    Storm hands constant primvars to the meshes it makes of gprims, and as a mesh reads one): here (0.25, 0.75),
    CHECKER's top-left block, red, not the reader's fallback (0.75, 0.25). It was ignored. Points and curves, drawn
    as spheres and tubes, read theirs as gprims do (Storm hands constant primvars to them as to any gprim): their st
    was never read, and the texture showed at the reader's fallback, grey, without a word."""
    path, stage = grey_fallback_stage(tmp_path)
    UsdGeom.Xform.Define(stage, "/Group")
    if kind == "Sphere":
        shape = UsdGeom.Sphere.Define(stage, "/Group/Shape")
        shape.CreateRadiusAttr(0.5)
    elif kind == "Points":
        shape = UsdGeom.Points.Define(stage, "/Group/Shape")
        shape.CreatePointsAttr([(0.0, 0.0, 0.0)])
        shape.CreateWidthsAttr([1.0])
    else:
        shape = UsdGeom.BasisCurves.Define(stage, "/Group/Shape")
        shape.CreateTypeAttr(UsdGeom.Tokens.linear)
        shape.CreateCurveVertexCountsAttr([2])
        shape.CreatePointsAttr([(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)])
        shape.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        shape.CreateWidthsAttr([1.0])
    bind(shape, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(holder)).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.constant).Set([(0.25, 0.75)])
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # read without a word
        scene = wrt.load_usd(path, tessellate_gprims=tessellate)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=0.5)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
    np.testing.assert_allclose(img, np.broadcast_to([1.0, 0.0, 0.0], img.shape), atol=2e-3)


@pytest.mark.parametrize("case", ["sampled values", "sampled indices", "int64 indices"])
def test_a_gprims_indexed_constant_st_is_read_as_other_primvars_are(tmp_path, case):
    """An indexed constant ``st`` on a textured Sphere read with ``time=None``: values or indices with only time
    samples are read at their first sample, as USD's ``ComputeFlattened`` gives them there (0.25, 0.75: CHECKER's
    top-left block, red); indices authored as ``int64[]``, from which USD reads none, drop the primvar with a warning
    and the reader's fallback (0.75, 0.25) is read (grey 128). The first was ignored as 'not 2-, 3- or 4-vectors',
    the other two stopped the load with SceneError ('No indices authored for indexed primvar')."""
    path, stage = grey_fallback_stage(tmp_path)
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr(0.5)
    bind(ball, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    primvar = UsdGeom.PrimvarsAPI(ball).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                      UsdGeom.Tokens.constant)
    values = [(0.75, 0.75), (0.25, 0.75)]
    primvar.Set(values, 1.0) if case == "sampled values" else primvar.Set(values)
    if case == "int64 indices":
        ball.GetPrim().CreateAttribute("primvars:st:indices", Sdf.ValueTypeNames.Int64Array).Set(Vt.Int64Array([1]))
    else:
        primvar.CreateIndicesAttr().Set(Vt.IntArray([1]), 1.0 if case == "sampled indices" else Usd.TimeCode.Default())
    stage.Save()
    if case == "int64 indices":
        with pytest.warns(UserWarning, match="int64"):
            scene = wrt.load_usd(path)
        s, t = 0.75, 0.25  # the reader's fallback
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # read without a word
            scene = wrt.load_usd(path)
        s, t = primvar.ComputeFlattened(1.0)[0]  # USD's own, at the first sample
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=0.5)
    img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="albedo").rgb
    texel = CHECKER[int((1.0 - t) * CHECKER.shape[0]), int(s * CHECKER.shape[1])] / 255.0
    np.testing.assert_allclose(img, np.broadcast_to(texel, img.shape), atol=2e-3)


@pytest.mark.parametrize("geometry", ["Sphere", "Mesh"])
@pytest.mark.parametrize("on", ["own", "instance"])
def test_an_st_authored_as_quaternions_reads_the_fallback_st(tmp_path, on, geometry):
    """A constant ``st`` authored as ``quatf[]`` (no texture-coordinate type: numpy reads a quaternion as a 4-vector,
    imaginary part first), on the textured prim itself or on a native instance handing it down, is dropped with a
    warning and the reader's fallback (0.75, 0.25) is read, CHECKER's grey block, as a mesh drops its own: a gprim's
    own and any instance's were read as st (0.75, 0.75), the green block, without a word."""
    path, stage = grey_fallback_stage(tmp_path)
    root = "/Proto" if on == "instance" else "/Group"
    stage.DefinePrim(root).SetSpecifier(Sdf.SpecifierClass if on == "instance" else Sdf.SpecifierDef)
    if geometry == "Sphere":
        geo = UsdGeom.Sphere.Define(stage, f"{root}/Geo")
        geo.CreateRadiusAttr(0.5)
    else:
        geo = UsdGeom.Mesh.Define(stage, f"{root}/Geo")
        geo.CreatePointsAttr([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)])
        geo.CreateFaceVertexCountsAttr([4])
        geo.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(geo, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    holder = geo.GetPrim()
    if on == "instance":
        holder = stage.DefinePrim("/Inst", "Xform")
        holder.GetInherits().AddInherit("/Proto")
        holder.SetInstanceable(True)
    UsdGeom.PrimvarsAPI(holder).CreatePrimvar("st", Sdf.ValueTypeNames.QuatfArray, UsdGeom.Tokens.constant).Set(
        [Gf.Quatf(0.25, 0.75, 0.75, 0.75)])
    stage.Save()
    with pytest.warns(UserWarning, match="quatf"):
        scene = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=0.5)
    img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="albedo").rgb
    np.testing.assert_allclose(img, np.full(img.shape, CHECKER[7, 7, 0] / 255.0), atol=2e-3)  # (0.75, 0.25): grey


def add_textured_prototype_ball(stage) -> None:
    """A class prim ``/Proto`` holding a Sphere of radius 0.5 bound to ``/Looks/Tex`` (:func:`grey_fallback_stage`'s
    textured look), for native instances to inherit."""
    stage.DefinePrim("/Proto").SetSpecifier(Sdf.SpecifierClass)
    ball = UsdGeom.Sphere.Define(stage, "/Proto/Ball")
    ball.CreateRadiusAttr(0.5)
    bind(ball, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))


@pytest.mark.parametrize("tessellate", [False, True])
def test_native_instances_hand_their_constant_st_to_prototype_gprims(tmp_path, tessellate):
    """Two native instances of one prototype holding a textured Sphere, each with its own constant ``st`` (a palette
    texel per instance), show their own texel on the sphere, as they do on a prototype's mesh: CHECKER's top-left
    block (red) at (0.25, 0.75) and its top-right one (green) at (0.75, 0.75). The gprim read the reader's fallback,
    (0.75, 0.25), grey, in both."""
    path, stage = grey_fallback_stage(tmp_path)
    add_textured_prototype_ball(stage)
    for name, x, st in (("Left", -0.75, (0.25, 0.75)), ("Right", 0.75, (0.75, 0.75))):
        inst = UsdGeom.Xform.Define(stage, f"/{name}")
        inst.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        inst.GetPrim().GetInherits().AddInherit("/Proto")
        inst.GetPrim().SetInstanceable(True)
        UsdGeom.PrimvarsAPI(inst).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                UsdGeom.Tokens.constant).Set([st])
    stage.Save()
    scene = wrt.load_usd(path, tessellate_gprims=tessellate)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=0.5)
    for x, colour in ((-0.75, [1.0, 0.0, 0.0]), (0.75, [0.0, 1.0, 0.0])):
        cam = wrt.Camera.orthographic(eye=(x, 0, 5), target=(x, 0, 0), height=0.5)
        img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="albedo").rgb
        np.testing.assert_allclose(img, np.broadcast_to(colour, img.shape), atol=2e-3)


@pytest.mark.parametrize("st", [math.nan, 1e39])
@pytest.mark.parametrize("tessellate", [False, True])
def test_a_non_finite_st_handed_to_a_prototype_gprim_reads_the_fallback_st(tmp_path, tessellate, st):
    """A native instance handing down a constant ``st`` that is no finite float32 (NaN, or 1e39 past float32) to its
    prototype's textured Sphere: the gprim shows the texture at the primvar reader's fallback st, (0.75, 0.25),
    CHECKER's bottom-right block (grey 128, read raw), as for a non-finite ``st`` of its own, with a warning. The
    load stopped with SceneError ('st must be 2 finite numbers or None')."""
    path, stage = grey_fallback_stage(tmp_path)
    add_textured_prototype_ball(stage)
    inst = UsdGeom.Xform.Define(stage, "/Inst")
    inst.GetPrim().GetInherits().AddInherit("/Proto")
    inst.GetPrim().SetInstanceable(True)
    UsdGeom.PrimvarsAPI(inst).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                            UsdGeom.Tokens.constant).Set([(st, st)])
    stage.Save()
    with pytest.warns(UserWarning, match="st"):
        scene = wrt.load_usd(path, tessellate_gprims=tessellate)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=0.5)
    img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="albedo").rgb
    np.testing.assert_allclose(img, np.full(img.shape, CHECKER[7, 7, 0] / 255.0), atol=2e-3)


@pytest.mark.parametrize("on", ["mesh", "instance"])
def test_an_empty_constant_st_is_named_as_empty_and_reads_the_readers_fallback(tmp_path, on):
    """``texCoord2f[] primvars:st = []`` (constant) on a native instance, handed down to its prototype's mesh, was
    named "values that are not an array of 2-, 3- or 4-vectors", which an empty array of them is: it is named by its
    length now, as the mesh's own empty st is, and the mesh reads the reader's fallback. The oracle of the length is
    USD's own primvar API; of the colour, CHECKER's texel at the fallback."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St"))
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.75, 0.25))  # the grey block's middle
    holder = "/Quad"
    if on == "instance":
        stage.RemovePrim("/Quad")
        stage.CreateClassPrim("/Asset")
        quad = add_quad(stage, "/Asset/Quad")
        UsdGeom.PrimvarsAPI(quad).RemovePrimvar("st")
        bind(quad, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
        holder = "/A1"
        instance = UsdGeom.Xform.Define(stage, holder).GetPrim()
        instance.GetReferences().AddInternalReference("/Asset")
        instance.SetInstanceable(True)
        UsdGeom.PrimvarsAPI(instance).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.constant)
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(holder)).GetPrimvar("st")
    st.BlockIndices()
    st.Set(Vt.Vec2fArray())
    st.SetInterpolation(UsdGeom.Tokens.constant)
    stage.Save()
    assert len(UsdGeom.PrimvarsAPI(Usd.Stage.Open(path).GetPrimAtPath(holder)).GetPrimvar("st").Get()) == 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = albedo(path)
    messages = [str(w.message) for w in caught]
    assert not [m for m in messages if "not an array" in m], messages
    assert [m for m in messages if "primvars:st has 0 values; constant interpolation needs 1" in m
            and m.endswith(holder)], messages
    np.testing.assert_allclose(img, np.full(img.shape, 128 / 255), atol=2e-3)  # CHECKER's bottom-right block


@pytest.mark.parametrize("on", ["mesh", "instance"])
def test_an_st_of_doubles_past_float32_is_named_as_not_finite(tmp_path, on):
    """A ``texCoord2d[]`` st of 1e39 (finite in double, past float32) on a textured mesh, or on a native instance
    handing it down to its prototype's mesh: the mesh's float32 texture coordinates hold inf there, as they hold an
    authored inf, named in the same warning ("not finite"). Only numpy's "overflow encountered in cast", naming
    nothing, was given. The oracle of the coordinates: the same stage authoring inf."""
    def load(value, folder):
        folder.mkdir()
        path, stage = grey_fallback_stage(folder)
        root = "/Proto" if on == "instance" else "/Group"
        stage.DefinePrim(root).SetSpecifier(Sdf.SpecifierClass if on == "instance" else Sdf.SpecifierDef)
        geo = UsdGeom.Mesh.Define(stage, f"{root}/Geo")
        geo.CreatePointsAttr([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)])
        geo.CreateFaceVertexCountsAttr([4])
        geo.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        bind(geo, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
        holder, values = geo.GetPrim(), [(value, 0.25), (0.75, -value), (0.75, 0.25), (0.75, 0.25)]
        if on == "instance":
            holder, values = stage.DefinePrim("/Inst", "Xform"), values[:2]
            holder.GetInherits().AddInherit("/Proto")
            holder.SetInstanceable(True)
        UsdGeom.PrimvarsAPI(holder).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2dArray, UsdGeom.Tokens.vertex
                                                  if on == "mesh" else UsdGeom.Tokens.constant).Set(values[:4])
        stage.Save()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = wrt.load_usd(path)
        mesh = scene.meshes[0] if scene.meshes else scene.prototypes[0].meshes[0]
        return mesh.uvs, [f"{w.category.__name__}: {w.message}" for w in caught]

    uvs, messages = load(1e39, tmp_path / "past")
    expected, expected_messages = load(math.inf, tmp_path / "inf")
    np.testing.assert_array_equal(uvs, expected)
    assert np.isinf(uvs).any()
    assert [m for m in messages if "texture coordinates that are not finite were read as none" in m], messages
    assert not [m for m in messages if "overflow" in m], messages
    assert [m.split(".usda: ", 1)[-1] for m in messages] == [m.split(".usda: ", 1)[-1] for m in expected_messages]


@pytest.mark.parametrize("between", [None, "constant", "vertex"])
def test_a_mesh_without_st_reads_a_constant_st_of_an_ancestor(tmp_path, between):
    """A mesh without the texture-coordinate primvar its texture reads takes a constant one of its nearest ancestor
    that has one (USD's primvar inheritance, as for its colour primvars; UsdImaging hands constant primvars down to
    the gprims below): one st per group, say, picking a colour of a palette texture. wrt read the reader's fallback
    there, with a warning that the mesh had none. A non-constant st on a prim in between blocks the inheritance (the
    fallback is read). The oracle: CHECKER's texel at the st of ``FindPrimvarWithInheritance``, else the fallback."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    group = UsdGeom.Xform.Define(stage, "/Group")
    UsdGeom.PrimvarsAPI(group).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.constant).Set(
        [(0.75, 0.25)])  # the grey block's middle
    middle = UsdGeom.Xform.Define(stage, "/Group/Middle")
    if between is not None:
        UsdGeom.PrimvarsAPI(middle).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, between).Set(
            [(0.25, 0.25)] if between == "constant" else [(0.25, 0.25)] * 4)  # the blue block's middle
    quad = add_quad(stage, "/Group/Middle/Quad")
    UsdGeom.PrimvarsAPI(quad).RemovePrimvar("st")
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    reader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St"))
    reader.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.25, 0.75))  # the red block's middle
    stage.Save()
    inherited = UsdGeom.PrimvarsAPI(quad).FindPrimvarWithInheritance("st")
    s, t = inherited.Get()[0] if inherited else (0.25, 0.75)
    expected = CHECKER[int((1.0 - t) * 8), int(s * 8)] / 255  # (rows from the top)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the blocked mesh has no st: named in a warning
        img = albedo(path)
    np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3)


def test_native_instances_hand_their_constant_st_to_prototype_meshes_without_one(tmp_path):
    """A constant st on a native instance (or above it, a PointInstancer's too) reaches its prototype's meshes that
    have none, as ``FindPrimvarWithInheritance`` finds it through the instance proxies and UsdImaging hands it to the
    prototype: instances of one textured asset each showing their own palette texel (nested instances too). They
    all read the reader's fallback (wrt read the prototype once, at its own paths), and the warning named the
    prototype's first instance, which had one; now it names the instance proxies that read the fallback. The oracle:
    CHECKER's texel at the st USD finds on each instance proxy's mesh, else at the reader's fallback."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St")).CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(
        Gf.Vec2f(0.25, 0.75))  # the red block's middle
    asset = stage.CreateClassPrim("/Asset")
    quad = add_quad(stage, "/Asset/Quad")
    UsdGeom.PrimvarsAPI(quad).RemovePrimvar("st")
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    stage.CreateClassPrim("/Kit")
    inner = stage.DefinePrim("/Kit/In", "Xform")
    inner.GetReferences().AddInternalReference(asset.GetPath())
    inner.SetInstanceable(True)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    proto = stage.DefinePrim("/PI/Protos/P", "Xform")
    proto.GetReferences().AddInternalReference(asset.GetPath())
    proto.SetInstanceable(True)
    pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
    pi.CreateProtoIndicesAttr([0])
    pi.CreatePositionsAttr([(12, 0, 0)])
    st = {"/A1": (0.75, 0.25), "/A2": (0.25, 0.25), "/A3": None, "/K1": (0.75, 0.25), "/PI": (0.25, 0.25)}
    meshes = {"/A1": "/A1/Quad", "/A2": "/A2/Quad", "/A3": "/A3/Quad", "/K1": "/K1/In/Quad", "/PI": "/PI/Protos/P/Quad"}
    for k, name in enumerate(("/A1", "/A2", "/A3", "/K1")):
        instance = UsdGeom.Xform.Define(stage, name)
        instance.AddTranslateOp().Set((3.0 * k, 0.0, 0.0))
        instance.GetPrim().GetReferences().AddInternalReference("/Kit" if name == "/K1" else "/Asset")
        instance.GetPrim().SetInstanceable(True)
    for name, value in st.items():
        if value is not None:
            UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(name)).CreatePrimvar(
                "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.constant).Set([value])
    stage.Save()
    only_a3 = r"reader's fallback st: 1 prim\(s\) \(st, fallback \(0.25, 0.75\): 1\): /A3/Quad$"
    with pytest.warns(UserWarning, match=only_a3):
        scene = wrt.load_usd(path)
    for k, name in enumerate(st):
        inherited = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(meshes[name])).FindPrimvarWithInheritance("st")
        s, t = inherited.Get()[0] if inherited else (0.25, 0.75)
        expected = CHECKER[int((1.0 - t) * 8), int(s * 8)] / 255
        cam = wrt.Camera.orthographic(eye=(3.0 * k, 0, 5), target=(3.0 * k, 0, 0), height=2.0)
        img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
        np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3, err_msg=name)


def test_the_fallback_st_warning_names_a_prototype_outside_the_instance_at_its_own_path(tmp_path):
    """A PointInstancer inside a native instance may draw a prototype from outside the instance (``/Protos/Quad``);
    when it lacks st, the warning names it at its own path. The instance proxy path made for prims inside the
    instance (``/World/I`` + ``../Protos/Quad``) named ``/World/Protos/Quad``, another mesh, which has an st."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    material = UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex"))
    for name in ("/Protos/Quad", "/World/Protos/Quad"):
        quad = add_quad(stage, name)
        bind(quad, material)
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Protos/Quad")).RemovePrimvar("st")
    stage.CreateClassPrim("/Asset")
    pi = UsdGeom.PointInstancer.Define(stage, "/Asset/PI")
    pi.CreatePrototypesRel().SetTargets(["/Protos/Quad"])
    pi.CreateProtoIndicesAttr([0])
    pi.CreatePositionsAttr([(0, 0, 0)])
    instance = stage.DefinePrim("/World/I", "Xform")
    instance.GetReferences().AddInternalReference("/Asset")
    instance.SetInstanceable(True)
    stage.Save()
    with pytest.warns(UserWarning, match=r"reader's fallback st: 1 prim\(s\) .*\): /Protos/Quad$") as caught:
        wrt.load_usd(path)
    assert not [w for w in caught if "/World/Protos/Quad" in str(w.message)]


def test_native_instances_handing_down_one_nan_st_share_one_copy(tmp_path):
    """66 native instances of a textured asset whose mesh has no st, each with the same constant st (NaN, NaN), all
    show the texture's fallback colour, as a mesh's own st that is not finite does (and USD finds that one value on
    every instance proxy). NaN != NaN made each instance's st a new value: 64 copies of the prototype, then the 65th
    and 66th kept the prototype's own st, the reader's fallback, showing the checker's red texel there under a
    warning of more than 64 texture coordinates."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St")).CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(
        Gf.Vec2f(0.25, 0.75))  # the red block's middle
    texture_fallback = Gf.Vec4f(0.2, 0.4, 0.6, 1.0)
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/Image")).CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(
        texture_fallback)
    asset = stage.CreateClassPrim("/Asset")
    quad = add_quad(stage, "/Asset/Quad")
    UsdGeom.PrimvarsAPI(quad).RemovePrimvar("st")
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    count = 66
    for k in range(count):
        instance = UsdGeom.Xform.Define(stage, f"/A{k}")
        instance.AddTranslateOp().Set((3.0 * k, 0.0, 0.0))
        instance.GetPrim().GetReferences().AddInternalReference(asset.GetPath())
        instance.GetPrim().SetInstanceable(True)
        UsdGeom.PrimvarsAPI(instance.GetPrim()).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.constant).Set([(np.nan, np.nan)])
    stage.Save()
    scene, messages = load_with_messages(path)
    assert not any("more than 64" in m for m in messages), messages
    assert any("texture coordinates that are not finite" in m and "66 prim(s)" in m for m in messages), messages
    for k in (0, count - 1):
        inherited = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(f"/A{k}/Quad")).FindPrimvarWithInheritance("st").Get()
        assert np.isnan(np.asarray(inherited)).all()  # USD finds the NaN st on every proxy
        cam = wrt.Camera.orthographic(eye=(3.0 * k, 0, 5), target=(3.0 * k, 0, 0), height=2.0)
        img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="albedo").rgb
        np.testing.assert_allclose(img, np.broadcast_to(np.array(texture_fallback)[:3], img.shape), atol=2e-3,
                                   err_msg=f"/A{k}")


@pytest.mark.parametrize("type_name", ["TexCoord3fArray", "Float3Array", "Float4Array"])
def test_texture_coordinates_of_three_or_four_components_read_their_first_two(tmp_path, type_name):
    """A texture-coordinate primvar of 3-vectors (Houdini writes its ``uv`` attribute, a vector, as ``texCoord3f[]``
    where it is not renamed to ``st``; 4-vectors likewise) is read as its first two components, as Storm reads
    texture coordinates (``HdGet_<primvar>().xy``). It was ignored with a warning, so the quad showed one texel
    everywhere. The oracle: CHECKER's blocks at the pixels' st, the third component a large number that would move
    every lookup."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    UsdShade.Shader.Get(stage, "/Looks/Tex/St").GetInput("varname").Set("uv")
    api = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad"))
    st = np.array(api.GetPrimvar("st").Get(), np.float64)
    api.RemovePrimvar("st")
    width = 4 if type_name.startswith("Float4") else 3
    wide = np.concatenate([st, np.full((len(st), width - 2), 7.25)], axis=1)
    uv = api.CreatePrimvar("uv", getattr(Sdf.ValueTypeNames, type_name), UsdGeom.Tokens.vertex)
    uv.Set(getattr(Vt, "Vec4fArray" if width == 4 else "Vec3fArray").FromNumpy(wide.astype(np.float32)))
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = albedo(path)
    for (row, col), color in {(0, 0): (1, 0, 0), (0, 3): (0, 1, 0), (3, 0): (0, 0, 1),
                              (3, 3): [128 / 255] * 3}.items():
        np.testing.assert_allclose(img[row, col], color, atol=2e-3)


def test_texture_coordinates_that_are_not_finite_read_the_fallback_with_a_warning(tmp_path):
    """Where the mesh's st is NaN or infinite a texture shows its ``fallback`` (through ``scale``, as every texel),
    with a warning naming the mesh, as where a UDIM texture has no tile: sample_image gave transparent black there,
    without a word. The right face of a two-face quad has NaN and inf st at its outer corners; the left face reads
    CHECKER's left half as usual."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    quad = add_quad(stage, "/Quad", faces=2)
    st = UsdGeom.PrimvarsAPI(quad).GetPrimvar("st")
    values = np.array(st.Get(), np.float64)
    values[[2, 5]] = [[np.nan, 0.0], [1.0, np.inf]]  # the outer corners of the right face
    st.Set(Vt.Vec2fArray.FromNumpy(values.astype(np.float32)))
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    tex = UsdShade.Shader.Get(stage, "/Looks/Tex/Image")
    tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(0.2, 0.4, 0.6, 1.0))
    tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(0.5, 0.5, 0.5, 1.0))
    stage.Save()
    with pytest.warns(UserWarning, match=r"texture coordinates that are not finite.*\(st: 2 of 6 values: 1\): /Quad$"):
        img = albedo(path)
    np.testing.assert_allclose(img[:, 2:], np.broadcast_to([0.1, 0.2, 0.3], (4, 2, 3)), atol=1e-3)
    np.testing.assert_allclose(img[:2, :2], np.broadcast_to([0.5, 0.0, 0.0], (2, 2, 3)), atol=1e-3)  # red, scaled
    np.testing.assert_allclose(img[2:, :2], np.broadcast_to([0.0, 0.0, 0.5], (2, 2, 3)), atol=1e-3)  # blue


def test_transform2d_scales_and_translates_st(tmp_path):
    png = write_png(tmp_path / "checker.png", CHECKER)
    # st -> st * 0.5 + (0.5, 0): the quad shows only the right half of the image (green over grey).
    path = textured_stage(tmp_path, png, transform={"scale": (0.5, 1.0), "translation": (0.5, 0.0)}, color_space="raw")
    img = albedo(path)
    np.testing.assert_allclose(img[0, 1], (0, 1, 0), atol=1e-3)
    np.testing.assert_allclose(img[3, 1], [128 / 255] * 3, atol=2e-3)


def transform_chain(stage, material_path, count, **values):
    """``count`` UsdTransform2d nodes ``{material_path}/Xf0`` ... in a chain from the ``st`` reader of a
    :func:`textured_stage` material to its image, each of the inputs ``values`` (input name -> value)."""
    source = st_source(stage, material_path)
    for k in range(count):
        xf = UsdShade.Shader.Define(stage, f"{material_path}/Xf{k}")
        xf.CreateIdAttr("UsdTransform2d")
        xf.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(*source)
        for key, value in values.items():
            xf.CreateInput(key, Sdf.ValueTypeNames.Float if key == "rotation" else Sdf.ValueTypeNames.Float2).Set(value)
        source = xf.ConnectableAPI(), "result"
    UsdShade.Shader.Get(stage, f"{material_path}/Image").GetInput("st").ConnectToSource(*source)
    return source[0]


def filtered_texels(texels, st, wraps):
    """``(..., C)`` float64 oracle of a UsdUVTexture lookup of ``texels`` (``(H, W, C)``, row 0 at the top) at ``st``
    (``(..., 2)``, t up) under wrap modes ``wraps`` (wrapS, wrapT): bilinear between texel centres, each texel index
    wrapped (``repeat`` modulo the size, ``mirror`` back and forth, ``clamp`` and ``black`` to the edge), and 0
    along a ``black`` axis outside [0, 1]."""
    h, w = texels.shape[:2]

    def wrapped(i, n, mode):
        if mode == "repeat":
            return np.mod(i, n)
        if mode == "mirror":
            m = np.mod(i, 2 * n)
            return np.where(m < n, m, 2 * n - 1 - m)
        return np.clip(i, 0, n - 1)

    x, y = st[..., 0] * w - 0.5, (1.0 - st[..., 1]) * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]

    def texel(i, j):
        return texels[wrapped(j, h, wraps[1]), wrapped(i, w, wraps[0])].astype(np.float64)

    out = ((texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx) * (1 - fy)
           + (texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx) * fy)
    outside = np.zeros(st.shape[:-1], bool)
    for axis, mode in enumerate(wraps):
        if mode == "black":
            outside |= (st[..., axis] < 0.0) | (st[..., axis] > 1.0)
    return np.where(outside[..., None], 0.0, out)


@pytest.mark.parametrize("wraps", [("mirror", "repeat"), ("clamp", "black")])
def test_a_scaled_turned_and_moved_st_is_filtered_bilinearly_under_its_wrap_modes(tmp_path, wraps):
    """Guard: a UsdTransform2d of uneven scale, a turn that is not a quarter and a translation, read through each
    wrap mode over st from -0.5 to 2.5, matches the specification's order (``in * scale``, turned
    counter-clockwise, then moved) and a float64 bilinear oracle at every pixel, filtering across mirror and repeat
    seams included."""
    texels = np.random.default_rng(5).integers(0, 256, (3, 5, 3))
    inputs = {"scale": (1.7, 0.6), "rotation": 30.0, "translation": (0.3, -0.2)}
    path = textured_stage(tmp_path, write_png(tmp_path / "noise.png", texels), st_range=3.0, color_space="raw",
                          transform=inputs)
    stage = Usd.Stage.Open(path)
    image = UsdShade.Shader.Get(stage, "/Looks/Tex/Image")
    for name, mode in zip(("wrapS", "wrapT"), wraps):
        image.CreateInput(name, Sdf.ValueTypeNames.Token).Set(mode)
    st_attr = stage.GetAttributeAtPath("/Quad.primvars:st")  # st over [-0.5, 2.5]: the quad's [0, 3] moved
    st_attr.Set([Gf.Vec2f(v[0] - 0.5, v[1] - 0.5) for v in st_attr.Get()])
    stage.Save()
    res = 12
    centres = (np.arange(res) + 0.5) / res * 3.0 - 0.5
    s, t = np.meshgrid(centres, centres[::-1])
    a = math.radians(inputs["rotation"])
    xs, ys = s * inputs["scale"][0], t * inputs["scale"][1]
    st = np.stack([xs * math.cos(a) - ys * math.sin(a) + inputs["translation"][0],
                   xs * math.sin(a) + ys * math.cos(a) + inputs["translation"][1]], axis=-1)
    np.testing.assert_allclose(albedo(path, res), filtered_texels(texels / 255.0, st, wraps), atol=2e-3)


@pytest.mark.parametrize("wrap", ["repeat", "mirror", "clamp", "black"])
def test_texture_coordinates_on_whole_numbers_read_as_each_wrap_mode_defines(tmp_path, wrap):
    """Guard: constant st on whole numbers and on an edge, (1, 1), (2, 0), (-1, 3) and (1, 0.5), each read by one
    quad, match the float64 oracle of :func:`filtered_texels`: ``repeat`` blends the last texel with the first
    there, ``mirror`` and ``clamp`` read the edge, and ``black`` is black only outside [0, 1] (1 itself is in)."""
    texels = np.random.default_rng(6).integers(0, 256, (3, 5, 3))
    png = write_png(tmp_path / "noise.png", texels)
    stage, path = new_stage(tmp_path)
    points = [(1.0, 1.0), (2.0, 0.0), (-1.0, 3.0), (1.0, 0.5)]
    for k, st in enumerate(points):  # quads 1.5 wide at x = -3.5, -1.5, 0.5, 2.5: under pixel columns 0, 2, 4, 6
        quad = add_quad(stage, f"/Quad{k}", center=(2.0 * k - 3.5, 0.0, 0.0), size=1.5)
        material, surface = preview_material(stage, f"/Looks/M{k}")
        tex = UsdShade.Shader.Define(stage, f"/Looks/M{k}/Image")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
        for name in ("wrapS", "wrapT"):
            tex.CreateInput(name, Sdf.ValueTypeNames.Token).Set(wrap)
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*st))
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.CreateOutput(
            "rgb", Sdf.ValueTypeNames.Float3))
        bind(quad, material)
    stage.Save()
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(wrt.load_usd(path), camera=cam, width=8, height=2, device="cpu", integrator="albedo").rgb
    expected = filtered_texels(texels / 255.0, np.array(points), (wrap, wrap))
    np.testing.assert_allclose(img[:, ::2], np.broadcast_to(expected, (2, 4, 3)), atol=2e-3)
    np.testing.assert_array_equal(img[:, 1::2], 0.0)  # between the quads: nothing


def test_a_long_chain_of_transform2d_nodes_applies_every_one(tmp_path):
    """Ten UsdTransform2d nodes in a row, each moving st by (0.05, 0): the image moves by 0.5 in s (its halves
    swap). The walk stopped after eight without a word, so the image moved by 0.4."""
    halves = np.zeros((8, 8, 3))
    halves[:, :4] = (255, 0, 0)  # left half red, right half blue
    halves[:, 4:] = (0, 0, 255)
    path = textured_stage(tmp_path, write_png(tmp_path / "halves.png", halves), wrap="repeat", color_space="raw")
    stage = Usd.Stage.Open(path)
    transform_chain(stage, "/Looks/Tex", 10, translation=(0.05, 0.0))
    stage.Save()
    img = albedo(path)  # pixel centres at s = 0.125 ... 0.875, read at s + 0.5 (mod 1)
    s = ((np.arange(4) + 0.5) / 4 + 0.5) % 1.0
    expected = np.where(s[:, None] < 0.5, (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    np.testing.assert_allclose(img, np.broadcast_to(expected, (4, 4, 3)), atol=1e-3)


def test_transform2d_nodes_that_loop_back_are_named_and_applied_once(tmp_path):
    """A UsdTransform2d whose ``in`` is its own ``result`` (a network that loops back): named in a warning with the
    node, and applied once (a quarter turn and a move of (0.5, 0): st (s, t) read at (0.5 - t, s)). The walk went
    round eight times without a word, which here (four quarter turns twice, the moves cancelling) read st
    unmoved."""
    path = textured_stage(tmp_path, write_png(tmp_path / "checker.png", CHECKER), wrap="repeat", color_space="raw")
    stage = Usd.Stage.Open(path)
    xf = transform_chain(stage, "/Looks/Tex", 1, rotation=90.0, translation=(0.5, 0.0))
    UsdShade.Shader(xf.GetPrim()).GetInput("in").ConnectToSource(xf, "result")  # (replaces the reader)
    stage.Save()
    with pytest.warns(UserWarning, match=r"loop back on themselves.*/Looks/Tex/Xf0"):
        img = albedo(path)
    centres = (np.arange(4) + 0.5) / 4
    s, t = np.meshgrid(centres, centres[::-1])  # row 0 at the top
    read_s, read_t = (0.5 - t) % 1.0, s  # every point lies inside a 4 x 4 block of CHECKER, away from its edges
    expected = CHECKER[(np.floor((1.0 - read_t) * 2) * 4).astype(int), (np.floor(read_s * 2) * 4).astype(int)]
    np.testing.assert_allclose(img, expected / 255.0, atol=1e-3)


@pytest.mark.parametrize("case", ["constant st", "reader fallback", "transform overflow", "constant st strings",
                                  "reader fallback strings"])
def test_texture_coordinates_past_float32_do_not_stop_the_load(tmp_path, case):
    """A constant ``st`` or a primvar reader's ``fallback`` authored as a double2 beyond float32's range is not two
    finite numbers (the st primvar, or (0, 0), is read, with a warning), and a UsdTransform2d of a constant ``in``
    whose finite inputs map it past float32's range gives the texture's fallback (black), with a warning: each
    stopped the load with
    "transform must be a (3, 3) matrix of finite numbers" or "st_fallback must be 2 finite numbers". A ``string[]``
    of digits (``["0.5", "0"]``) is no two numbers either: numpy read it as (0.5, 0), without a word."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), (200, 100, 50)))
    path = textured_stage(tmp_path, png, color_space="raw", transform={"rotation": 0.0})
    stage = Usd.Stage.Open(path)
    tex, xf, reader = (UsdShade.Shader.Get(stage, f"/Looks/Tex/{name}") for name in ("Image", "Xf", "St"))
    strings = case.endswith(" strings")
    if case.startswith("constant st"):
        tex.GetPrim().RemoveProperty("inputs:st")  # (a float2 attribute would hold inf)
        if strings:
            tex.CreateInput("st", Sdf.ValueTypeNames.StringArray).Set(["0.5", "0"])
        else:
            tex.CreateInput("st", Sdf.ValueTypeNames.Double2).Set(Gf.Vec2d(1e39, 0.0))
    elif case.startswith("reader fallback"):
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("uv")  # the quad has no uv: the fallback
        if strings:
            reader.CreateInput("fallback", Sdf.ValueTypeNames.StringArray).Set(["0.5", "0"])
        else:
            reader.CreateInput("fallback", Sdf.ValueTypeNames.Double2).Set(Gf.Vec2d(1e39, 0.0))
    else:  # a constant in, (0.5, 0.5) * 3e38 + 3e38 for every point
        xf.GetInput("in").GetAttr().ClearConnections()
        xf.GetInput("in").Set(Gf.Vec2f(0.5, 0.5))
        xf.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(3e38, 3e38))
        xf.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(3e38, 0.0))
    stage.Save()
    scene, messages = load_with_messages(path)
    expected = {"constant st": "constant texture coordinate is not two finite numbers",
                "reader fallback": "fallback is not two finite numbers",
                "transform overflow": "float32"}[case.removesuffix(" strings")]
    assert any(expected in m for m in messages), messages
    img = albedo(path)
    color = (0.0, 0.0, 0.0) if case == "transform overflow" else np.array([200, 100, 50]) / 255
    np.testing.assert_allclose(img, np.broadcast_to(color, img.shape), atol=2e-3)


@pytest.mark.parametrize("name, type_name, value", [
    ("scale", "Float", 2.0),  # one number where the schema has float2
    ("scale", "String", "2"),
    ("rotation", "Float2", Gf.Vec2f(90.0, 0.0)),
    ("translation", "Float2", Gf.Vec2f(float("nan"), 0.5)),
    ("rotation", "Float", float("inf")),
])
def test_a_transform2d_input_that_is_not_finite_numbers_keeps_its_default(tmp_path, name, type_name, value):
    """A UsdTransform2d ``rotation``, ``scale`` or ``translation`` that is not as many finite numbers as the schema's
    type holds (a float for a float2, a string, NaN) keeps the schema's default with a warning naming the input, as
    UsdPreviewSurface inputs do. A wrong type stopped the load with "cannot read this prim" (a Python TypeError), and
    NaN made every lookup read the texture's fallback, without a word. The other inputs still apply: here the
    transform is the identity but for the bad input, so the quad shows CHECKER as it is."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, color_space="raw", transform={"rotation": 0.0})
    stage = Usd.Stage.Open(path)
    xf = stage.GetPrimAtPath("/Looks/Tex/Xf")
    xf.RemoveProperty(f"inputs:{name}")
    xf.CreateAttribute(f"inputs:{name}", getattr(Sdf.ValueTypeNames, type_name)).Set(value)
    stage.Save()
    with pytest.warns(UserWarning, match=rf"UsdTransform2d input is not .*finite number.*default is used.*{name} = "):
        img = albedo(path)
    for (row, col), color in {(0, 0): (1, 0, 0), (0, 3): (0, 1, 0), (3, 0): (0, 0, 1),
                              (3, 3): [128 / 255] * 3}.items():
        np.testing.assert_allclose(img[row, col], color, atol=2e-3)


@pytest.mark.parametrize("where", ["texture", "transform2d"])
def test_an_authored_constant_st_reads_one_point_of_the_image(tmp_path, where):
    """A UsdUVTexture's ``st`` authored as a constant and connected to nothing is where the image is read, on every
    point of the mesh; so is a UsdTransform2d's constant ``in``, transformed. The mesh's ``st`` primvar was read
    instead, so the quad showed the whole image. The mesh here has no ``st`` at all, and needs none: no warning."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    transform = {"translation": (0.5, 0.5)} if where == "transform2d" else None
    path = textured_stage(tmp_path, png, color_space="raw", transform=transform)
    stage = Usd.Stage.Open(path)
    target = stage.GetPrimAtPath("/Looks/Tex/Image" if where == "texture" else "/Looks/Tex/Xf")
    st_input = UsdShade.Shader(target).GetInput("st" if where == "texture" else "in")
    st_input.DisconnectSource()
    if where == "texture":
        st_input.Set(Gf.Vec2f(0.75, 0.25))  # the middle of CHECKER's bottom-right (grey) block
        expected = [128 / 255] * 3
    else:
        st_input.Set(Gf.Vec2f(0.25, 0.25))  # + (0.5, 0.5): the middle of the top-right (green) block
        expected = [0, 1, 0]
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad")).RemovePrimvar("st")
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = albedo(path)
    np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3)


def test_an_unauthored_unconnected_transform2d_in_is_sdrs_default_with_a_warning(tmp_path):
    """A UsdTransform2d whose ``in`` is neither connected nor authored reads Sdr's default for it, as Storm's material
    network does (an unconnected ``in`` is its authored value, else Sdr's default; never a primvar) and as
    MaterialX's ``ND_UsdTransform2d`` (no ``defaultgeomprop``) does: every point reads the image at that default,
    transformed, here the middle of CHECKER's bottom-right (grey) block. wrt read the mesh's ``st``, the whole image,
    as it does for a UsdUVTexture's ``st`` (MaterialX: ``defaultgeomprop="UV0"``). A warning names the shader."""
    from pxr import Sdr

    default = Sdr.Registry().GetShaderNodeByIdentifier("UsdTransform2d").GetShaderInput("in").GetDefaultValue()
    translation = (0.75, 0.25)
    u, v = default[0] + translation[0], default[1] + translation[1]
    expected = CHECKER[int((1.0 - v) * CHECKER.shape[0]), int(u * CHECKER.shape[1])] / 255.0
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, color_space="raw", transform={"translation": translation})
    stage = Usd.Stage.Open(path)
    xf = stage.GetPrimAtPath("/Looks/Tex/Xf")
    UsdShade.Shader(xf).GetInput("in").DisconnectSource()
    xf.RemoveProperty("inputs:in")
    stage.Save()
    with pytest.warns(UserWarning, match=r"UsdTransform2d's in that is neither connected nor authored reads \(0, 0\)"
                      r".*: /Looks/Tex/Xf$"):
        img = albedo(path)
    np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3)


def test_an_unauthored_unconnected_st_reads_the_mesh_st(tmp_path):
    """A UsdUVTexture whose ``st`` is neither connected nor authored reads the mesh's ``st`` primvar, as MaterialX's
    definition of the node gives it (``defaultgeomprop="UV0"``) and as assets such as the usd-wg Mini Car Kit expect
    (the schema's own fallback would be (0, 0))."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    UsdShade.Shader.Get(stage, "/Looks/Tex/Image").GetPrim().RemoveProperty("inputs:st")
    stage.Save()
    img = albedo(path)
    for (row, col), color in {(0, 0): (1, 0, 0), (0, 3): (0, 1, 0), (3, 0): (0, 0, 1),
                              (3, 3): [128 / 255] * 3}.items():
        np.testing.assert_allclose(img[row, col], color, atol=2e-3)


@pytest.mark.parametrize("varname", [None, "", "token"])
def test_a_primvar_reader_that_names_no_primvar_reads_its_fallback_st(tmp_path, varname):
    """A UsdPrimvarReader_float2 whose ``varname`` is unauthored (Sdr's default, checked here, is the empty string)
    or empty names no primvar: Storm's primvar redirect then has no primvar to read and gives the reader's
    ``fallback`` at every point. wrt read the mesh's ``st`` without a word, a textured quad where usdview shows one
    texel. Oracle: the texel at the fallback st, filtered by hand in float64 from the PNG's samples."""
    from pxr import Sdr

    assert Sdr.Registry().GetShaderNodeByIdentifier("UsdPrimvarReader_float2").GetShaderInput(
        "varname").GetDefaultValue() == ""
    samples = np.random.default_rng(21).integers(0, 256, (4, 4, 3))
    png = write_png(tmp_path / "random.png", samples)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    reader = stage.GetPrimAtPath("/Looks/Tex/St")
    reader.RemoveProperty("inputs:varname")
    if varname is not None:
        reader.CreateAttribute("inputs:varname", Sdf.ValueTypeNames.Token if varname else Sdf.ValueTypeNames.String
                               ).Set("")
    UsdShade.Shader(reader).CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.3, 0.6))
    stage.Save()
    with pytest.warns(UserWarning, match=r"names no primvar.*fallback.*/Looks/Tex/St"):
        img = albedo(path)
    x, y = 0.3 * 4 - 0.5, (1 - 0.6) * 4 - 0.5  # texel space, row 0 at the top: (0.7, 1.1)
    fx, fy = x - 0, y - 1
    texels = samples / 255.0
    expected = ((texels[1, 0] * (1 - fx) + texels[1, 1] * fx) * (1 - fy)
                + (texels[2, 0] * (1 - fx) + texels[2, 1] * fx) * fy)
    np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3)


@pytest.mark.parametrize("what", ["st", "tint"])
@pytest.mark.parametrize("holder", ["mesh", "gprim", "parent"])
def test_a_constant_primvar_authored_as_one_value_rather_than_an_array_is_read(tmp_path, what, holder):
    """A constant primvar may hold one value rather than an array of one (``texCoord2f primvars:st = (0.3, 0.6)``,
    ``color3f primvars:tint = (0.2, 0.4, 0.6)``): USD's ``ComputeFlattened`` gives that value, and Hydra hands it to
    the shader as the constant. wrt dropped it as "not an array of 2-vectors" (3-vectors) on meshes, gprims and from
    a parent: the texture showed at the reader's fallback st, the colour at its fallback, black. Oracles: the texel
    at (0.3, 0.6), filtered by hand in float64 from the PNG's samples; the authored colour."""
    samples = np.random.default_rng(22).integers(0, 256, (4, 4, 3))
    png = write_png(tmp_path / "random.png", samples)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    mesh = stage.GetPrimAtPath("/Quad")
    UsdGeom.PrimvarsAPI(mesh).RemovePrimvar("st")
    target = mesh
    if holder == "gprim":
        stage.RemovePrim("/Quad")
        target = UsdGeom.Cube.Define(stage, "/Quad").GetPrim()  # 2 wide: the camera sees its +Z face
        bind(target, UsdShade.Material.Get(stage, "/Looks/Tex"))
    owner = UsdGeom.Xform.Define(stage, "/Group").GetPrim() if holder == "parent" else target
    if holder == "parent":
        Sdf.CopySpec(stage.GetRootLayer(), "/Quad", stage.GetRootLayer(), "/Group/Quad")
        stage.RemovePrim("/Quad")
        target = stage.GetPrimAtPath("/Group/Quad")
    primvars = UsdGeom.PrimvarsAPI(owner)
    if what == "st":
        primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2f, UsdGeom.Tokens.constant).Set(Gf.Vec2f(0.3, 0.6))
        x, y = 0.3 * 4 - 0.5, (1 - 0.6) * 4 - 0.5  # texel space, row 0 at the top: (0.7, 1.1)
        fx, fy = x - 0, y - 1
        texels = samples / 255.0
        expected = ((texels[1, 0] * (1 - fx) + texels[1, 1] * fx) * (1 - fy)
                    + (texels[2, 0] * (1 - fx) + texels[2, 1] * fx) * fy)
    else:
        primvars.CreatePrimvar("tint", Sdf.ValueTypeNames.Color3f, UsdGeom.Tokens.constant).Set(
            Gf.Vec3f(0.2, 0.4, 0.6))
        reader = UsdShade.Shader.Define(stage, "/Looks/Tex/Tint")
        reader.CreateIdAttr("UsdPrimvarReader_float3")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("tint")
        reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
        surface = UsdShade.Shader.Get(stage, "/Looks/Tex/Surface")
        surface.GetInput("diffuseColor").GetAttr().ClearConnections()
        surface.GetInput("diffuseColor").ConnectToSource(reader.ConnectableAPI(), "result")
        expected = np.array([0.2, 0.4, 0.6])
    assert UsdGeom.PrimvarsAPI(target).FindPrimvarWithInheritance(what).ComputeFlattened() is not None
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # no primvar is dropped, no fallback read
        img = albedo(path)
    np.testing.assert_allclose(img, np.broadcast_to(expected, img.shape), atol=2e-3)


def write_png16(path, samples):
    """A 16-bit PNG (grey + alpha, RGB or RGBA by the channel count) written here byte by byte, rows filtered with
    Sub, Up, Average and Paeth in turn, so that reading it has to undo every PNG filter."""
    samples = np.asarray(samples, np.uint16)
    h, w, c = samples.shape
    bpp = 2 * c
    raw, prev = b"", bytes(w * bpp)
    for r in range(h):
        row, kind, out = samples[r].astype(">u2").tobytes(), 1 + r % 4, bytearray()
        for i, x in enumerate(row):
            a, b, up_left = (row[i - bpp] if i >= bpp else 0), prev[i], (prev[i - bpp] if i >= bpp else 0)
            p = a + b - up_left
            paeth = min((abs(p - a), 0, a), (abs(p - b), 1, b), (abs(p - up_left), 2, up_left))[2]
            out.append((x - (0, a, b, (a + b) // 2, paeth)[kind]) & 255)
        raw, prev = raw + bytes([kind]) + bytes(out), row

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    header = struct.pack(">IIBBBBB", w, h, 16, {2: 4, 3: 2, 4: 6}[c], 0, 0, 0)
    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw))
                           + chunk(b"IEND", b""))
    return str(path)


def srgb_decoded64(x):
    """The sRGB transfer function inverted in float64 (IEC 61966-2-1), of samples in [0, 1]."""
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


@pytest.mark.parametrize("channels", [2, 3, 4])
def test_16_bit_png_textures_keep_full_precision_and_colour_ones_read_as_srgb(tmp_path, channels):
    """16-bit colour and grey + alpha PNGs: Pillow keeps only their high bytes, so all 16 bits are read here. Under
    sourceColorSpace auto, colour (RGB, RGBA) without a colour space chunk is sRGB, as Hydra's PNG reader decides:
    stb_image hands every PNG over as 8-bit samples and Hio_StbImage guesses sRGB for 3 or 4 channels of bytes;
    grey + alpha stays raw (2 channels). They were read as linear colour: 0.5 stayed 0.5 where Storm shows 0.214."""
    samples = np.random.default_rng(5).integers(0, 65536, (3, 5, channels))
    samples[0, 0, :] = 0x8001  # 0.50001; its high byte alone would be 0.502
    image = wrt.textures.load_image(write_png16(tmp_path / f"c{channels}.png", samples), "auto")
    expected = np.ones((3, 5, 4))
    expected[..., :3] = srgb_decoded64(samples[..., :3] / 65535.0) if channels > 2 else samples[..., :1] / 65535.0
    if channels != 3:
        expected[..., 3] = samples[..., -1] / 65535.0
    np.testing.assert_allclose(image, expected, atol=1e-6)
    raw = wrt.textures.load_image(write_png16(tmp_path / f"c{channels}.png", samples), "raw")
    np.testing.assert_allclose(raw[..., :3], samples[..., :3] / 65535.0 if channels > 2 else expected[..., :3],
                               atol=1e-7)
    if channels == 3:  # and through a material
        png = write_png16(tmp_path / "flat.png", np.full((2, 2, 3), 0x8001))
        np.testing.assert_allclose(albedo(textured_stage(tmp_path, png)), srgb_decoded64(0x8001 / 65535.0),
                                   atol=2e-4)


def test_exr_texture_with_layer_named_channels(tmp_path):
    """An EXR whose only colour channels are a layer's (diffuse.R, diffuse.G, diffuse.B) was refused as having no RGB
    channels, so its material fell back to the texture's fallback colour."""
    OpenEXR = pytest.importorskip("OpenEXR")  # (the GPU host has none)

    rgb = np.random.default_rng(2).random((3, 5, 3)).astype(np.float32)
    path = str(tmp_path / "layer.exr")
    channels = {f"diffuse.{c}": np.ascontiguousarray(rgb[..., k]) for k, c in enumerate("RGB")}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(path)
    image = wrt.textures.load_image(path)
    np.testing.assert_array_equal(image[..., :3], rgb)
    np.testing.assert_array_equal(image[..., 3], 1.0)


def test_single_channel_texture_drives_a_float_input(tmp_path):
    png = write_png(tmp_path / "rough.png", [[[51, 0, 0], [51, 0, 0]], [[51, 0, 0], [51, 0, 0]]])
    scene = wrt.load_usd(textured_stage(tmp_path, png, channel="r", input_name="roughness", color_space="raw"))
    tex = scene.materials[0].textures["roughness"]
    assert tex.channel == "r" and scene.textures[tex.image].shape == (2, 2, 4)
    np.testing.assert_allclose(scene.textures[tex.image][..., 0], 0.2, atol=1e-6)


def test_a_texture_without_a_file_reads_its_fallback_with_a_warning(tmp_path):
    """A UsdUVTexture whose ``file`` is not authored reads its fallback (black), named in a warning: it was drawn
    without a word, where a file that is not found is named."""
    path = textured_stage(tmp_path, str(tmp_path / "unused.png"))
    stage = Usd.Stage.Open(path)
    stage.GetPrimAtPath("/Looks/Tex/Image").RemoveProperty("inputs:file")
    stage.Save()
    with pytest.warns(UserWarning, match=r"names no file.*/Looks/Tex/Image"):
        scene = wrt.load_usd(path)
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


def test_a_texture_whose_file_is_an_empty_asset_path_reads_its_fallback_naming_no_file(tmp_path):
    """A ``file`` authored as the empty asset path ``@@`` names no file, as an unauthored one: the warning says so
    and names the shader; it said ``texture @@: the file was not found``, a file no one named."""
    path = textured_stage(tmp_path, str(tmp_path / "unused.png"))
    stage = Usd.Stage.Open(path)
    UsdShade.Shader.Get(stage, "/Looks/Tex/Image").GetInput("file").Set(Sdf.AssetPath(""))
    stage.Save()
    scene, messages = load_with_messages(path)
    assert [m for m in messages if "names no file" in m and "/Looks/Tex/Image" in m], messages
    assert not [m for m in messages if "texture @@" in m or "not found" in m], messages
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


def test_missing_texture_uses_the_fallback_with_a_warning(tmp_path):
    path = textured_stage(tmp_path, str(tmp_path / "nope.png"))
    with pytest.warns(UserWarning, match="nope.png"):
        scene = wrt.load_usd(path)
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


REFERENCED_LOOK = """#usda 1.0
def Material "Mat"
{{
    token outputs:surface.connect = </Mat/Surface.outputs:surface>
    def Shader "Surface"
    {{
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </Mat/Image.outputs:rgb>
        token outputs:surface
    }}
    def Shader "Image"
    {{
        uniform token info:id = "UsdUVTexture"
        asset inputs:file = @{file}@
        float4 inputs:fallback = (0.25, 0.5, 0.75, 1)
        float3 outputs:rgb
    }}
}}
"""


@pytest.mark.parametrize("file", ["./missing.png", "./missing.<UDIM>.png"])
def test_a_missing_file_of_a_referenced_layer_is_named_where_it_was_looked_for(tmp_path, file):
    """Two looks author the same relative ``file``, one in a layer of a sub-folder the stage references, the other
    in the root layer; neither file is there. Each warning names the path the file was looked for at, anchored to
    the layer that authored it as USD anchors it (``Sdf.ComputeAssetPathRelativeToLayer``), with its own shader,
    and each look reads its fallback. The warning named the path as authored (``./missing.png``) under the root
    layer's name, where the file was never looked for, and one warning covered both files."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "look.usda").write_text(REFERENCED_LOOK.format(file=file))
    (tmp_path / "look.usda").write_text(REFERENCED_LOOK.format(file=file))
    stage, path = new_stage(tmp_path, "root.usda")
    for k, look in enumerate(("sub/look.usda", "look.usda")):
        material = UsdShade.Material(stage.DefinePrim(f"/Look{k}"))
        material.GetPrim().GetReferences().AddReference(f"./{look}", "/Mat")
        bind(add_quad(stage, f"/Quad{k}", center=(3.0 * k, 0.0, 0.0)), material)
    stage.Save()
    scene, messages = load_with_messages(path)
    for k, look in enumerate(("sub/look.usda", "look.usda")):
        anchored = Sdf.ComputeAssetPathRelativeToLayer(Sdf.Layer.FindOrOpen(str(tmp_path / look)), file)
        named = [m for m in messages if anchored in m]
        assert len(named) == 1, (anchored, messages)
        assert f"/Look{k}/Image" in named[0] and f"/Look{1 - k}/Image" not in named[0], named
    for mat in scene.materials:
        assert mat.textures == {}
        np.testing.assert_allclose(mat.diffuse_color, (0.25, 0.5, 0.75))


def test_a_missing_file_named_by_a_uri_is_named_as_authored(tmp_path):
    """A texture whose ``file`` is a URI no resolver finds is named in the warning as authored: anchoring it to its
    layer as a relative path would have named ``http:/example.com/wood.png``, a path no one wrote."""
    path = textured_stage(tmp_path, "http://example.com/wood.png")
    scene, messages = load_with_messages(path)
    named = [m for m in messages if "http://example.com/wood.png: the file was not found" in m]
    assert named and "/Looks/Tex/Image" in named[0], messages
    assert not [m for m in messages if "http:/example" in m], messages
    assert scene.materials[0].textures == {}


@pytest.mark.parametrize("where", ["absolute", "relative"])
@pytest.mark.parametrize("type_name", ["String", "Token"])
def test_a_file_authored_as_a_string_is_read_as_an_asset_path(tmp_path, where, type_name):
    """A UsdUVTexture ``file`` authored as a string or token rather than an asset is the path it holds: Storm opens
    it as written (its material network takes a string ``file`` as the path), and wrt resolves it as the asset path
    it should have been, against the layer that authored it, with a warning that names the prim. It was read as a
    file that was not found (the warning said so of a file that was there) and the fallback drawn. The oracle:
    CHECKER's blocks."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, color_space="raw")
    stage = Usd.Stage.Open(path)
    tex = stage.GetPrimAtPath("/Looks/Tex/Image")
    tex.RemoveProperty("inputs:file")
    tex.CreateAttribute("inputs:file", getattr(Sdf.ValueTypeNames, type_name)).Set(
        png if where == "absolute" else "./checker.png")
    stage.Save()
    with pytest.warns(UserWarning, match=r"authored as a string.*resolved as asset paths.*/Looks/Tex/Image"):
        img = albedo(path)
    for (row, col), color in {(0, 0): (1, 0, 0), (0, 3): (0, 1, 0), (3, 0): (0, 0, 1),
                              (3, 3): [128 / 255] * 3}.items():
        np.testing.assert_allclose(img[row, col], color, atol=2e-3)


def quads_reading_one_file(tmp_path, n: int, file: str, fallback=None) -> tuple:
    """``(path, shaders)``: a stage of ``n`` quads, each bound to its own UsdPreviewSurface whose diffuseColor reads
    ``file`` through its own UsdUVTexture (of ``fallback`` where given), and those textures' shader paths as USD's
    ``GetConnectedSources`` finds them."""
    stage, path = new_stage(tmp_path)
    shaders = []
    for k in range(n):
        quad = add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0))
        material, surface = preview_material(stage, f"/Looks/M{k}")
        tex = UsdShade.Shader.Define(stage, f"/Looks/M{k}/Image{k}")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./" + file)
        if fallback is not None:
            tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*fallback))
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(quad, material)
        (source,), _ = surface.GetInput("diffuseColor").GetConnectedSources()
        shaders.append(str(source.source.GetPath()))
    stage.Save()
    return path, shaders


@pytest.mark.parametrize("file", ["missing.png", "empty.png", "tiles.<UDIM>.png"])
def test_a_file_that_cannot_be_read_is_named_with_every_shader_that_reads_it(tmp_path, file):
    """A file that is missing, empty or a UDIM pattern with no tile, read by the textures of three materials: the
    warning names each texture's shader, found through USD's own connections (``GetConnectedSources`` of each
    surface's diffuseColor), and each material reads the fallback. The file's failure was kept and only the first
    shader named: a look with the same broken path elsewhere drew its fallback without a word."""
    (tmp_path / "empty.png").write_bytes(b"")
    path, shaders = quads_reading_one_file(tmp_path, 3, file, fallback=(0.25, 0.5, 0.75, 1.0))
    scene, messages = load_with_messages(path)
    named = [m for m in messages if file in m]
    assert named, messages
    for shader in shaders:
        assert any(shader in m for m in named), (shader, named)
    for mat in scene.materials:
        assert mat.textures == {}
        np.testing.assert_allclose(mat.diffuse_color, (0.25, 0.5, 0.75))


def test_a_udim_tile_that_cannot_be_read_is_named_with_every_shader_that_reads_it(tmp_path):
    """Tile 1002 of a UDIM pattern is an empty file, tile 1001 a good one; two materials read the pattern: the
    warning about the tile names both textures' shaders (USD's ``GetConnectedSources``). The pattern's tiles were
    kept, so the second material's read told nothing."""
    write_png(tmp_path / "body.1001.png", CHECKER)
    (tmp_path / "body.1002.png").write_bytes(b"")
    path, shaders = quads_reading_one_file(tmp_path, 2, "body.<UDIM>.png")
    scene, messages = load_with_messages(path)
    named = [m for m in messages if "body.1002.png" in m and "empty" in m]
    assert len(named) == 1, messages
    for shader in shaders:
        assert shader in named[0], (shader, named)
    assert all("diffuseColor" in mat.textures for mat in scene.materials)  # tile 1001 is read


@pytest.mark.parametrize("channel, input_name", [("rgb", "diffuseColor"), ("a", "roughness")])
def test_a_missing_texture_reads_its_fallback_through_scale_and_bias(tmp_path, channel, input_name):
    """The fallback stands in for the texture's value where the file cannot be read, and ``scale`` and ``bias``
    apply to it as to any texel (MaterialX's UsdUVTexture graph: the image's default, times scale, plus bias). The
    fallback was used as it is, so a normal map's flat fallback (0.5, 0.5, 1) would be no flat normal."""
    path = textured_stage(tmp_path, str(tmp_path / "nope.png"), channel=channel, input_name=input_name)
    stage = Usd.Stage.Open(path)
    tex = UsdShade.Shader.Get(stage, "/Looks/Tex/Image")
    fallback, scale, bias = (0.2, 0.4, 0.6, 0.8), (2.0, 1.0, 0.5, 0.5), (0.1, 0.0, 0.05, 0.1)
    for name, value in (("fallback", fallback), ("scale", scale), ("bias", bias)):
        tex.CreateInput(name, Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*value))
    stage.Save()
    with pytest.warns(UserWarning, match="nope.png"):
        (mat,) = wrt.load_usd(path).materials
    expected = np.array(fallback) * scale + bias  # (0.5, 0.4, 0.35, 0.5)
    assert mat.textures == {}
    if channel == "rgb":
        np.testing.assert_allclose(mat.diffuse_color, expected[:3], rtol=1e-6)
    else:
        assert mat.roughness == pytest.approx(expected[3])


def test_single_sided_back_faces_are_culled_for_camera_rays(tmp_path):
    stage, path = new_stage(tmp_path)
    add_quad(stage, "/Front", center=(-1.5, 0, 0), size=2.0)  # faces +Z, towards the camera
    back = add_quad(stage, "/Back", center=(1.5, 0, 0), size=2.0)
    back.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)  # faces -Z, away from the camera
    both = add_quad(stage, "/Both", center=(1.5, 0, -1), size=2.0, double_sided=True)
    both.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    stage.Save()
    scene = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=32, height=8, device="cpu")
    offsets = np.cumsum([0] + [len(m.indices) for m in scene.meshes])
    mesh_of = np.searchsorted(offsets, img.aovs["prim"], side="right") - 1
    assert (mesh_of[:, 7:13] == 0).all()  # the front-facing quad
    assert (mesh_of[:, 19:25] == 2).all()  # through the culled back face onto the double-sided quad behind
    assert (img.aovs["cost"][:, 19:25, 1] >= 2).all()  # the retrace counts in the traversal cost


def test_opacity_threshold_cuts_holes(tmp_path):
    stage, path = new_stage(tmp_path)
    front = add_quad(stage, "/Cutout", center=(0, 0, 1), size=2.0)
    add_quad(stage, "/Behind", center=(0, 0, 0), size=2.0)
    hole, _ = preview_material(stage, "/Looks/Hole", opacity=0.2, opacityThreshold=0.5, diffuseColor=Gf.Vec3f(1, 0, 0))
    bind(front, hole)
    stage.Save()
    scene = wrt.load_usd(path)
    stage.GetPrimAtPath("/Cutout").SetActive(False)
    stage.Save()
    without = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    for integrator in ("whitted", "path"):
        img = wrt.render(scene, camera=cam, width=4, height=4, spp=2, device="cpu", integrator=integrator)
        assert img.rgb.min() > 0.05
        np.testing.assert_allclose(img.rgb[..., 0], img.rgb[..., 1], atol=1e-6)  # the grey quad behind, not red
        # Shadow rays pass the holes too: the quad behind is lit by the headlight and the dome as if alone.
        alone = wrt.render(without, camera=cam, width=4, height=4, spp=2, device="cpu", integrator=integrator)
        np.testing.assert_allclose(img.rgb, alone.rgb, rtol=1e-5)


def test_camera_rays_see_through_textured_cut_outs(tmp_path):
    """The AOVs (depth, albedo, material, prim) and the quick looks showed the cut-out surface in its holes while
    the beauty image showed what lies behind; the path tracer spent its one bounce (max_depth=1) passing through."""
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 3] = [[0, 255], [0, 255]]  # alpha: holes in the left half of the quad (clamped lookups)
    path = textured_stage(tmp_path, write_png(tmp_path / "mask.png", rgba), wrap="clamp", channel="a",
                          input_name="opacity")
    stage = Usd.Stage.Open(path)
    shader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/Surface"))
    shader.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0, 0))
    add_quad(stage, "/Behind", center=(0, 0, -1), size=2.0)
    stage.Save()
    scene = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    for integrator in ("albedo", "whitted", "path"):
        img = wrt.render(scene, camera=cam, width=4, height=4, spp=8, device="cpu", integrator=integrator,
                         max_depth=1)
        holes, solid = np.s_[:, :2], np.s_[:, 2:]  # pixel columns at s = 0.125, 0.375 (alpha 0, 0.25) | 0.625, 0.875
        np.testing.assert_allclose(img.aovs["depth"][holes], 6.0, rtol=1e-6)
        np.testing.assert_allclose(img.aovs["depth"][solid], 5.0, rtol=1e-6)
        np.testing.assert_allclose(img.aovs["albedo"][holes], 0.5)  # the grey quad behind
        np.testing.assert_allclose(img.aovs["albedo"][solid], np.broadcast_to([1, 0, 0], (4, 2, 3)))
        assert (img.aovs["material"][holes] == -1).all() and (img.aovs["material"][solid] == 0).all()
        assert (img.aovs["prim"][holes] >= 2).all() and (img.aovs["prim"][solid] < 2).all()
        assert img.rgb[holes].mean() > 0.05  # the quad behind, lit by the default lights
        np.testing.assert_allclose(img.rgb[holes][..., 0], img.rgb[holes][..., 1], atol=1e-6)  # grey, not red


def test_emissive_material_lights_the_scene(tmp_path):
    stage, path = new_stage(tmp_path)
    glow = add_quad(stage, "/Glow")
    material, _ = preview_material(stage, "/Looks/Glow", emissiveColor=Gf.Vec3f(2, 1, 0.5),
                                   diffuseColor=Gf.Vec3f(0, 0, 0))
    bind(glow, material)
    stage.Save()
    scene = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    renderer = wrt.Renderer(scene, camera=cam, width=4, height=4, device="cpu")
    assert renderer.lights == ()  # an emissive surface is a light source: no default lights are added
    np.testing.assert_allclose(renderer.render().rgb, np.broadcast_to([2, 1, 0.5], (4, 4, 3)), rtol=1e-6)


@pytest.mark.parametrize("second", ["st1", "st"])
def test_textures_reading_two_uv_sets_on_one_mesh_are_reported(tmp_path, second):
    """diffuseColor through primvar st and roughness through st1: a mesh carries one set of texture coordinates, so
    the roughness would silently be looked up with st; the load says so. Two textures reading the same primvar are
    not reported (they were, as 'several texture-coordinate primvars (st, st)')."""
    png = write_png(tmp_path / "t.png", CHECKER)
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar("st1", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0), (1, 0), (0, 1), (1, 1)])
    material, shader = preview_material(stage, "/Mat")
    for input_name, uv, out_type in (("diffuseColor", "st", Sdf.ValueTypeNames.Color3f),
                                     ("roughness", second, Sdf.ValueTypeNames.Float)):
        reader = UsdShade.Shader.Define(stage, f"/Mat/Read_{input_name}")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set(uv)
        reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        tex = UsdShade.Shader.Define(stage, f"/Mat/Tex_{input_name}")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        channel = "rgb" if input_name == "diffuseColor" else "r"
        tex.CreateOutput(channel, Sdf.ValueTypeNames.Float3 if channel == "rgb" else Sdf.ValueTypeNames.Float)
        shader.CreateInput(input_name, out_type).ConnectToSource(tex.ConnectableAPI(), channel)
    bind(quad, material)
    stage.Save()
    if second == "st1":
        with pytest.warns(UserWarning, match=r"several texture-coordinate primvars \(st, st1\).*/Quad"):
            wrt.load_usd(path)
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            scene = wrt.load_usd(path)
        assert scene.meshes[0].uvs is not None


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"opacity": np.nan}, r"^/M: Material opacity must be a finite number, got nan"),
        ({"roughness": np.inf}, r"^/M: Material roughness must be a finite number"),
        ({"ior": "1.5"}, r"^/M: Material ior must be a finite number"),
        ({"diffuse_color": [1.0, np.nan, 0.0]}, r"^/M: Material diffuse_color must be finite numbers of shape \(3,\)"),
        ({"emissive_color": [1.0, 2.0]}, r"^/M: Material emissive_color must be finite numbers of shape \(3,\)"),
    ],
)
def test_materials_built_in_python_refuse_values_that_are_not_finite(kwargs, message):
    """``Material(opacity=nan)`` rendered black without a word (the USD reader already keeps defaults instead)."""
    with pytest.raises(wrt.SceneError, match=message):
        wrt.Material(path="/M", **kwargs)
    np.testing.assert_array_equal(wrt.Material(diffuse_color=0.25).diffuse_color, [0.25, 0.25, 0.25])


@pytest.mark.parametrize("material_ids, bad", [([0, 2], 2), ([-2, 0], -2)])
def test_material_indices_outside_the_material_list_are_refused(material_ids, bad):
    """A mesh built in Python whose ``material_ids`` name no material rendered those triangles with the default
    material without a word."""
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]])
    scene.materials = [wrt.Material(path="/A"), wrt.Material(path="/B")]
    scene.meshes[0].material_ids = np.array(material_ids, np.int32)
    with pytest.raises(wrt.SceneError, match=rf"^/triangles: material_ids: material index {bad} of triangle"):
        wrt.render(scene, width=4, height=4)
    scene.meshes[0].material_ids = np.array([1, -1], np.int32)  # -1 is the default material
    assert wrt.render(scene, width=4, height=4).rgb.shape == (4, 4, 3)
    # A shape's one index: named by its field, with no triangle (it said 'triangle 0').
    scene.shapes = [wrt.Shape("/Ball", "sphere", np.eye(4), material_id=bad)]
    with pytest.raises(wrt.SceneError, match=rf"^/Ball: material_id: material index {bad}, but the scene has 2"):
        wrt.render(scene, width=4, height=4)


def test_mdl_and_materialx_materials_fall_back_to_their_base_colour(tmp_path):
    """OmniPBR (an ``mdl:surface`` output only) and MaterialX gltf_pbr materials are drawn in their authored
    base colour times its weight, with a warning naming it: an OmniPBR of a red diffuse_color_constant was grey.
    One whose colour comes from a texture keeps the displayColor fallback."""
    stage, path = new_stage(tmp_path)
    looks = [
        ("mdl", "OmniPBR", {"diffuse_color_constant": Gf.Vec3f(0.8, 0.1, 0.1), "diffuse_tint": Gf.Vec3f(1, 1, 0.5)}),
        ("mtlx", "ND_gltf_pbr_surfaceshader", {"base_color": Gf.Vec3f(0.05, 0.1, 0.45)}),
        ("mdl", "OmniPBR", {"diffuse_color_constant": Gf.Vec3f(0.8, 0.1, 0.1),
                            "diffuse_texture": Sdf.AssetPath("a.png")}),
    ]
    for k, (context, kind, inputs) in enumerate(looks):
        quad = add_quad(stage, f"/Quad{k}", center=(3 * k, 0, 0))
        quad.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.2, 0.7, 0.1)])
        material, shader = define_surface(stage, f"/Looks/X{k}", context, kind)
        for name, value in inputs.items():
            value_type = {Gf.Vec3f: Sdf.ValueTypeNames.Color3f, float: Sdf.ValueTypeNames.Float}.get(
                type(value), Sdf.ValueTypeNames.Asset)
            shader.CreateInput(name, value_type).Set(value)
        material.CreateSurfaceOutput(context).ConnectToSource(shader.ConnectableAPI(), "out")
        bind(quad, material)
    stage.Save()
    scene, messages = load_with_messages(path)
    assert any("/Looks/X0" in m and "diffuse_color_constant (0.8, 0.1, 0.05)" in m for m in messages), messages
    assert any("/Looks/X1" in m and "base_color (0.05, 0.1, 0.45)" in m for m in messages), messages
    cam = wrt.Camera.orthographic(eye=(3, 0, 5), target=(3, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=36, height=8, device="cpu", integrator="albedo")  # x in [-1.5, 7.5]
    np.testing.assert_allclose(img.rgb[4, 6], (0.8, 0.1, 0.05), rtol=1e-6)  # the tint multiplies the colour
    np.testing.assert_allclose(img.rgb[4, 18], (0.05, 0.1, 0.45), rtol=1e-6)
    np.testing.assert_allclose(img.rgb[4, 30], (0.2, 0.7, 0.1), rtol=1e-6)  # textured: displayColor


def test_a_material_falling_back_to_its_base_colour_is_lambertian_at_grazing_views(tmp_path):
    """An OmniPBR material drawn as "a Lambertian surface of its diffuse_color_constant" (its warning's words) looks
    the same from every direction, as Lambert's law has it: seen at 82 degrees from its normal it shows what it
    shows head-on. The white grazing reflectance of UsdPreviewSurface's specular workflow (b5de5e2) also reached
    this fallback, whose Material kept the default ``specular_edge`` of 1: a white Fresnel rim, and 2% less red
    at the grazing view."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad", size=40.0)
    material = UsdShade.Material.Define(stage, "/Looks/X")
    shader = UsdShade.Shader.Define(stage, "/Looks/X/Surface")
    shader.SetSourceAsset(Sdf.AssetPath("OmniPBR.mdl"), "mdl")
    shader.SetSourceAssetSubIdentifier("OmniPBR", "mdl")
    shader.CreateInput("diffuse_color_constant", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.8, 0.5, 0.2))
    material.CreateSurfaceOutput("mdl").ConnectToSource(shader.ConnectableAPI(), "out")
    bind(quad, material)
    stage.Save()
    scene, messages = load_with_messages(path)
    assert any("falls back to a Lambertian surface" in m for m in messages), messages
    scene.lights = [wrt.DistantLight(direction=(0.0, 0.0, -1.0), color=np.ones(3, np.float32), angle=0.0)]
    views = {}
    for name, eye in (("head-on", (0.0, 0.0, 5.0)), ("grazing", (0.0, -5.0, 5.0 * np.tan(np.radians(8.0))))):
        cam = wrt.Camera.orthographic(eye=eye, target=(0, 0, 0), up=(0, 0, 1) if name == "grazing" else (0, 1, 0),
                                      height=0.5)
        views[name] = wrt.render(scene, camera=cam, width=4, height=4, device="cpu", integrator="whitted").rgb
    np.testing.assert_allclose(views["head-on"], np.broadcast_to(np.float32([0.8, 0.5, 0.2]) / np.pi, (4, 4, 3)),
                               rtol=1e-3)  # albedo E / pi
    np.testing.assert_allclose(views["grazing"], views["head-on"], rtol=1e-5)


def test_materialx_preview_surface_in_a_render_context_is_read(tmp_path):
    """A material whose only surface output is ``outputs:mtlx:surface`` to MaterialX's UsdPreviewSurface node (as
    pablode's MaterialX cornell box is written) is read like a UsdPreviewSurface: it was grey and did not emit."""
    stage, path = new_stage(tmp_path)
    quad = add_quad(stage, "/Quad")
    material = UsdShade.Material.Define(stage, "/Looks/M")
    shader = UsdShade.Shader.Define(stage, "/Looks/M/Surface")
    shader.CreateIdAttr("ND_UsdPreviewSurface_surfaceshader")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.63, 0.065, 0.05))
    shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(2, 1, 0.5))
    material.CreateSurfaceOutput("mtlx").ConnectToSource(shader.ConnectableAPI(), "surface")
    bind(quad, material)
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing to warn about
        scene = wrt.load_usd(path)
    (mat,) = scene.materials
    np.testing.assert_allclose(mat.diffuse_color, (0.63, 0.065, 0.05), rtol=1e-6)
    assert mat.emissive
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, device="cpu")
    np.testing.assert_allclose(img.rgb, np.broadcast_to([2, 1, 0.5], (4, 4, 3)), rtol=1e-6)


def test_the_missing_texture_coordinates_warning_names_the_meshs_2_3_and_4_vector_primvars(tmp_path):
    """Where the mesh lacks the primvar its reader names, the warning lists the primvars that could stand in: every
    array of 2-, 3- or 4-vectors, as 3- and 4-vector texture coordinates are read (their first two components). It
    listed texCoord2/3 and float2/double2 only, so Houdini's ``float3[] uv`` went unnamed. Colours, normals, points
    and a constant float2 that is no array are not texture coordinates."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    UsdShade.Shader.Get(stage, "/Looks/Tex/St").GetInput("varname").Set("uv_missing")
    api = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad"))
    names = {"uv3": "Float3Array", "uv4": "Float4Array", "uvd": "Double3Array", "uvh": "Half2Array",
             "uvw": "TexCoord3fArray", "Cd": "Color3fArray", "N": "Normal3fArray", "rest": "Point3fArray",
             "pivot": "Float2"}
    for name, type_name in names.items():
        value_type = getattr(Sdf.ValueTypeNames, type_name)
        primvar = api.CreatePrimvar(name, value_type, UsdGeom.Tokens.constant)
        primvar.Set(value_type.defaultValue if not value_type.isArray else
                    value_type.type.pythonClass([value_type.scalarType.defaultValue]))
    stage.Save()
    _, messages = load_with_messages(path)
    named = [m for m in messages if "uv_missing" in m]
    assert len(named) == 1, messages
    listed = re.search(r"the mesh has ([^:]*): 1\)", named[0]).group(1).split(", ")
    expected = {"st", "uv3", "uv4", "uvd", "uvh", "uvw"}  # st: the quad's own texCoord2f[]
    assert set(listed) == expected, named[0]


@pytest.mark.parametrize("bad", ["indices", "length"])
def test_texture_coordinates_that_do_not_fit_read_as_unauthored(tmp_path, bad):
    """An ``st`` with an index out of range (USD's ComputeFlattened gives None) or a length its interpolation does
    not take is dropped, as Hydra drops it: the mesh takes the primvar reader's fallback st, as a mesh without st
    does, with a warning naming the file, the mesh and the primvar. The stage failed to load."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png)
    stage = Usd.Stage.Open(path)
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad")).GetPrimvar("st")
    if bad == "indices":
        st.SetIndices(Vt.IntArray([0, 1, 2, 9]))
        assert st.ComputeFlattened() is None  # the oracle: USD cannot flatten it
    else:
        st.Set(st.Get()[:3])
    stage.Save()
    scene, messages = load_with_messages(path)
    (dropped,) = [m for m in messages if "primvars that do not fit their prim" in m]
    assert dropped.startswith(f"{path}: ") and dropped.endswith(": /Quad") and "primvars:st" in dropped, dropped
    stage.GetPrimAtPath("/Quad").RemoveProperty("primvars:st")
    stage.GetPrimAtPath("/Quad").RemoveProperty("primvars:st:indices")
    stage.GetRootLayer().Export(str(tmp_path / "unauthored.usda"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = wrt.load_usd(tmp_path / "unauthored.usda")
    (got,), (want,) = scene.meshes, expected.meshes
    np.testing.assert_array_equal(got.uvs, want.uvs)
    np.testing.assert_array_equal(albedo(path), albedo(str(tmp_path / "unauthored.usda")))


def test_constant_only_inputs_connected_to_a_texture_are_named_and_keep_their_defaults(tmp_path):
    """``ior`` and ``opacityThreshold`` connected to a UsdUVTexture (which wrt cannot vary over a surface) keep the
    schema's defaults, 1.5 and 0 (``Sdr``'s UsdPreviewSurface definition), with a warning naming the material and
    each input. They were dropped without a word: a textured cut-out mask drew no holes and nothing said why."""
    png = write_png(tmp_path / "mask.png", np.full((2, 2, 3), 255))
    stage, path = new_stage(tmp_path)
    material, shader = preview_material(stage, "/Looks/Mask")
    tex = UsdShade.Shader.Define(stage, "/Looks/Mask/Image")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
    tex.CreateOutput("r", Sdf.ValueTypeNames.Float)
    for name in ("ior", "opacityThreshold"):
        shader.CreateInput(name, Sdf.ValueTypeNames.Float).ConnectToSource(tex.ConnectableAPI(), "r")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    scene, messages = load_with_messages(path)
    from pxr import Sdr

    definition = Sdr.Registry().GetShaderNodeByIdentifier("UsdPreviewSurface")
    (mat,) = scene.materials
    assert mat.ior == pytest.approx(definition.GetShaderInput("ior").GetDefaultValue())
    assert mat.opacity_threshold == definition.GetShaderInput("opacityThreshold").GetDefaultValue()
    (warning,) = [m for m in messages if "read as constants only" in m]
    assert "/Looks/Mask" in warning and "ior <- UsdUVTexture" in warning and "opacityThreshold <- " in warning


def materialx_preview_stage(tmp_path, png, wrap, name):
    """A quad (``st`` over [0, 1]) bound to MaterialX's UsdPreviewSurface (``outputs:mtlx:surface``) whose diffuseColor
    is MaterialX's ``ND_UsdUVTexture`` of ``png`` (``file`` of colorSpace ``lin_rec709``, fallback (0.2, 0.4, 0.6,
    1), ``wrapS``/``wrapT`` ``wrap`` unless None), its ``st`` an ``ND_UsdTransform2d`` scaling by 2 an
    ``ND_UsdPrimvarReader_vector2`` of ``st``."""
    stage, path = new_stage(tmp_path, f"{name}.usda")
    material = UsdShade.Material.Define(stage, "/Looks/Mx")
    shader = UsdShade.Shader.Define(stage, "/Looks/Mx/Surface")
    shader.CreateIdAttr("ND_UsdPreviewSurface_surfaceshader")
    material.CreateSurfaceOutput("mtlx").ConnectToSource(shader.ConnectableAPI(), "out")
    reader = UsdShade.Shader.Define(stage, "/Looks/Mx/Reader")
    reader.CreateIdAttr("ND_UsdPrimvarReader_vector2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    xf = UsdShade.Shader.Define(stage, "/Looks/Mx/Xf")
    xf.CreateIdAttr("ND_UsdTransform2d")
    xf.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "out")
    xf.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(2, 2))
    tex = UsdShade.Shader.Define(stage, "/Looks/Mx/Image")
    tex.CreateIdAttr("ND_UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
    tex.GetInput("file").GetAttr().SetColorSpace("lin_rec709")
    tex.CreateInput("fallback", Sdf.ValueTypeNames.Color4f).Set(Gf.Vec4f(0.2, 0.4, 0.6, 1))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(xf.ConnectableAPI(), "out")
    if wrap:
        for key in ("wrapS", "wrapT"):
            tex.CreateInput(key, Sdf.ValueTypeNames.String).Set(wrap)
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Color3f)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    bind(add_quad(stage, "/Quad"), material)
    stage.Save()
    return path


@pytest.mark.parametrize("wrap", [None, "black"])
def test_materialx_preview_surface_textures_are_read(tmp_path, wrap):
    """MaterialX's own nodes of the UsdPreviewSurface network (``libraries/bxdf/usd_preview_surface.mtlx``:
    ``ND_UsdUVTexture``, ``ND_UsdTransform2d``, ``ND_UsdPrimvarReader_vector2``) texture an
    ``ND_UsdPreviewSurface_surfaceshader`` as the UsdPreviewSurface nodes do, by the MaterialX definitions: wrap
    modes ``periodic`` by default, ``black`` the node's fallback outside [0, 1] (MaterialX's ``constant``, the
    first of the node's wrap modes, reads the image's default, which is the fallback), and the file's colour space
    its ``colorSpace`` (``lin_rec709``: not decoded). The texture was dropped as an unsupported shader, the diffuse
    colour left at its default."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    scene, messages = load_with_messages(materialx_preview_stage(tmp_path, png, wrap, f"mx{wrap}"))
    assert not messages, messages
    img = albedo_of(scene, res=8)  # st over [0, 2]^2
    texels = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [128 / 255] * 3]])  # 2x2 blocks, rows from the top
    image = np.repeat(np.repeat(texels, 2, 0), 2, 1)  # the whole image on 4x4 pixels
    np.testing.assert_allclose(img[4:, :4], image, atol=2e-3)  # st in [0, 1]^2
    outside = np.tile(image, (2, 2, 1)) if wrap is None else np.broadcast_to([0.2, 0.4, 0.6], (8, 8, 3))
    np.testing.assert_allclose(img[:4], outside[:4], atol=2e-3)
    np.testing.assert_allclose(img[4:, 4:], outside[4:, 4:], atol=2e-3)


@pytest.mark.parametrize("source", ["ND_constant_string", "ND_dot_string"])
def test_materialx_usd_uv_texture_wrap_modes_fed_by_a_constant_node_are_its_token(tmp_path, source):
    """An ``ND_UsdUVTexture``'s ``wrapS`` and ``wrapT`` fed by an ``ND_constant_string`` of ``black`` (or a ``dot``
    of one) are ``black`` (MaterialX's ``constant``: the node's fallback outside [0, 1]), as an image node's
    address modes so fed are. Oracle: the 2 x 2 texels inside [0, 1]^2 and the fallback (0.2, 0.4, 0.6) outside,
    written out. They were read as unauthored, ``periodic``, without a word: the image repeated 4 times."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = materialx_preview_stage(tmp_path, png, None, f"fed_{source}")
    stage = Usd.Stage.Open(path)
    constant = UsdShade.Shader.Define(stage, "/Looks/Mx/Black")
    constant.CreateIdAttr("ND_constant_string")
    constant.CreateInput("value", Sdf.ValueTypeNames.String).Set("black")
    constant.CreateOutput("out", Sdf.ValueTypeNames.String)
    if source == "ND_dot_string":
        dot = UsdShade.Shader.Define(stage, "/Looks/Mx/Dot")
        dot.CreateIdAttr("ND_dot_string")
        dot.CreateInput("in", Sdf.ValueTypeNames.String).ConnectToSource(constant.ConnectableAPI(), "out")
        dot.CreateOutput("out", Sdf.ValueTypeNames.String)
        constant = dot
    tex = UsdShade.Shader.Get(stage, "/Looks/Mx/Image")
    for key in ("wrapS", "wrapT"):
        tex.CreateInput(key, Sdf.ValueTypeNames.String).ConnectToSource(constant.ConnectableAPI(), "out")
    stage.Save()
    scene, messages = load_with_messages(path)
    assert not messages, messages
    img = albedo_of(scene, res=8)  # st over [0, 2]^2
    texels = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [128 / 255] * 3]])  # 2x2 blocks, rows from the top
    expected = np.broadcast_to([0.2, 0.4, 0.6], (8, 8, 3)).copy()
    expected[4:, :4] = np.repeat(np.repeat(texels, 2, 0), 2, 1)  # st in [0, 1]^2
    np.testing.assert_allclose(img, expected, atol=2e-3)


def test_a_materialx_usd_primvar_reader_s_varname_from_a_constant_node_is_read(tmp_path):
    """An ``ND_UsdPrimvarReader_vector2`` feeding an ``ND_UsdUVTexture``'s ``st`` (through its ``ND_UsdTransform2d``
    scaling by 2) whose ``varname`` is fed by an ``ND_constant_string`` of ``half`` reads the mesh's primvar
    ``half`` (``st / 2``): the image once over the quad. Oracle: :data:`CHECKER`'s texels written out. The name
    was read as none, the fallback (0, 0) drawn on every point (the bottom-left texel, blue)."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = materialx_preview_stage(tmp_path, png, None, "varname_node")
    stage = Usd.Stage.Open(path)
    constant = UsdShade.Shader.Define(stage, "/Looks/Mx/Name")
    constant.CreateIdAttr("ND_constant_string")
    constant.CreateInput("value", Sdf.ValueTypeNames.String).Set("half")
    constant.CreateOutput("out", Sdf.ValueTypeNames.String)
    UsdShade.Shader.Get(stage, "/Looks/Mx/Reader").GetInput("varname").ConnectToSource(constant.ConnectableAPI(),
                                                                                      "out")
    quad = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad"))
    half = [Gf.Vec2f(st[0] / 2, st[1] / 2) for st in quad.GetPrimvar("st").Get()]
    quad.CreatePrimvar("half", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(half)
    stage.Save()
    scene, messages = load_with_messages(path)
    assert not messages, messages
    texels = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [128 / 255] * 3]])  # 2x2 blocks, rows from the top
    np.testing.assert_allclose(albedo_of(scene, res=8), np.repeat(np.repeat(texels, 4, 0), 4, 1), atol=2e-3)


def test_a_materialx_usd_uv_texture_wrap_mode_from_another_node_is_named(tmp_path):
    """An ``ND_UsdUVTexture``'s ``wrapS`` fed by a node that gives no constant string is named in a warning with the
    node, and read as unauthored (``periodic``)."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = materialx_preview_stage(tmp_path, png, None, "fed_other")
    stage = Usd.Stage.Open(path)
    other = UsdShade.Shader.Define(stage, "/Looks/Mx/Other")
    other.CreateIdAttr("ND_geompropvalue_string")
    other.CreateOutput("out", Sdf.ValueTypeNames.String)
    UsdShade.Shader.Get(stage, "/Looks/Mx/Image").CreateInput("wrapS", Sdf.ValueTypeNames.String).ConnectToSource(
        other.ConnectableAPI(), "out")
    stage.Save()
    _, messages = load_with_messages(path)
    assert any("/Looks/Mx" in m and "wrapS comes from a ND_geompropvalue_string node (/Looks/Mx/Other)" in m
               for m in messages), messages


@pytest.mark.parametrize("mode, source_color_space", [("RGB", "raw"), ("L", "sRGB")])
def test_a_materialx_usd_uv_texture_reads_its_source_color_space(tmp_path, mode, source_color_space):
    """An ``ND_UsdUVTexture`` whose ``file`` has no ``colorSpace`` reads an authored ``sourceColorSpace`` as a
    UsdUVTexture does: ``raw`` keeps an 8-bit RGB texel of 128 at 128/255, ``sRGB`` decodes an 8-bit grey one by the
    sRGB transfer function (IEC 61966-2-1, in float64 here). It was ignored, the image read as ``auto``: the RGB texel
    sRGB-decoded (0.216), the grey one kept (0.502)."""
    png = write_png(tmp_path / "grey.png", np.full((2, 2, 3) if mode == "RGB" else (2, 2), 128))
    path = materialx_preview_stage(tmp_path, png, None, f"{mode}{source_color_space}")
    stage = Usd.Stage.Open(path)
    tex = UsdShade.Shader.Get(stage, "/Looks/Mx/Image")
    tex.GetInput("file").GetAttr().ClearColorSpace()
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(source_color_space)
    stage.Save()
    scene, messages = load_with_messages(path)
    assert not messages, messages
    (mat,) = scene.materials
    texels = scene.textures[mat.textures["diffuseColor"].image][..., :3]
    stored = 128 / 255
    want = stored if source_color_space == "raw" else ((stored + 0.055) / 1.055) ** 2.4
    np.testing.assert_allclose(texels, want, rtol=1e-5)


def albedo_of(scene, res=4):
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    return wrt.render(scene, camera=cam, width=res, height=res, device="cpu", integrator="albedo").rgb


def test_an_emission_texture_with_a_negative_bias_still_lights_the_scene(tmp_path):
    """An emissive quad whose emissiveColor texture (a bright block on black, raw) is contrast-stretched by ``scale``
    2 and ``bias`` -1 glows where the block is (2 t - 1 > 0 there, clamped to 0 elsewhere, as every texel): it
    lights the floor below in ``whitted`` as the same quad with the stretch baked into its texture does. Its emission
    was estimated from the texture's mean, 2 * 0.25 - 1 < 0, so it was no light: the floor took none of it, and the
    stage, lit by nothing as far as wrt could tell, got the default light instead (a floor of 1.1, not 0.01)."""
    block = np.zeros((64, 64, 3), np.uint8)  # fine texels: the two filter their block's edge alike within 2%
    block[:32, :32] = 255

    def floor_brightness(name, png, scale, bias):
        stage, path = new_stage(tmp_path, f"{name}.usda")
        bind(add_quad(stage, "/Floor", size=6.0), preview_material(stage, "/Looks/White",
                                                                   diffuseColor=Gf.Vec3f(1, 1, 1))[0])
        material, shader = preview_material(stage, "/Looks/Glow", diffuseColor=Gf.Vec3f(0, 0, 0))
        tex = UsdShade.Shader.Define(stage, "/Looks/Glow/Image")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(scale, scale, scale, 1))
        tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(bias, bias, bias, 0))
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(add_quad(stage, "/Lamp", center=(0, 0, 1), size=1.0, double_sided=True), material)
        stage.Save()
        scene, _ = load_with_messages(path)
        cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=6.0)
        img = wrt.render(scene, camera=cam, width=12, height=12, spp=16, seed=1, device="cpu").rgb
        return img[3:5].mean()  # floor only, beside the lamp's footprint (rows 5 and 6)

    stretched = floor_brightness("stretched", write_png(tmp_path / "block.png", block), 2.0, -1.0)
    baked = floor_brightness("baked", write_png(tmp_path / "baked.png", block), 1.0, 0.0)  # 2 t - 1 clamped: t
    assert baked > 0.0
    assert stretched == pytest.approx(baked, rel=0.1)


@pytest.mark.parametrize("texel, as_stored", [(np.nan, 0.0), (np.inf, 65504.0)])
def test_an_emission_texel_past_float16_is_estimated_as_the_device_stores_it(texel, as_stored):
    """An emissive quad whose emission texture (``Scene.textures``, where an EXR's NaN and infinite texels stay) has
    one NaN or infinite texel lights the floor below in ``whitted`` as the same texture with that texel as the device
    stores it (NaN 0, inf 65504) does, beside a second, constant lamp. The NaN made the emission estimate NaN: the
    quad was no light, and the scene got the default light; inf made it infinite (with numpy's overflow warnings):
    the second lamp was never sampled."""
    from shading_helpers import quad, top_down_camera

    def floor_brightness(value):
        tex = np.ones((4, 4, 4), np.float32)
        tex[0, 0, :3] = value
        glow = wrt.Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": wrt.TextureInput(image=0)})
        lamp = quad((0, 0, 1), (1, 0, 0), (0, -1, 0), name="/lamp", material=0)
        lamp.uvs = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], np.float32)
        second = quad((2, 0, 1), (1, 0, 0), (0, -1, 0), name="/second", material=2)
        floor = quad((0, 0, 0), (6, 0, 0), (0, 6, 0), name="/floor", material=1)
        materials = [glow, wrt.Material(path="/White", diffuse_color=1.0),
                     wrt.Material(path="/Lamp", diffuse_color=0.0, emissive_color=np.full(3, 1000.0, np.float32))]
        scene = wrt.Scene(meshes=[floor, lamp, second], materials=materials, textures=[tex])
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no overflow warnings
            img = wrt.render(scene, camera=top_down_camera(height=6.0), width=12, height=12, spp=8, seed=1,
                             device="cpu")
        return img.rgb[3:5].mean()  # floor only, beside the lamp (rows 5 and 6)

    stored = floor_brightness(as_stored)
    assert floor_brightness(texel) == pytest.approx(stored, rel=1e-3)


@pytest.mark.parametrize("case", ["chained transforms", "constant in"])
def test_texture_transforms_past_float32_warn_only_in_wrts_words(tmp_path, case):
    """Texture transforms whose finite inputs multiply past float32's range (two UsdTransform2d scaling st by 1e30
    each, or one mapping a constant ``in`` to 4.5e38) give the texture's fallback with wrt's warning and no other:
    numpy's float32 product or cast raised its own "overflow encountered" RuntimeWarning first (an error where
    warnings are errors, which stopped the load)."""
    png = write_png(tmp_path / "flat.png", np.full((2, 2, 3), (200, 100, 50)))
    path = textured_stage(tmp_path, png, color_space="raw", transform={"rotation": 0.0})
    stage = Usd.Stage.Open(path)
    xf = UsdShade.Shader.Get(stage, "/Looks/Tex/Xf")
    if case == "chained transforms":
        xf.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(1e30, 1e30))
        outer = UsdShade.Shader.Define(stage, "/Looks/Tex/Xf2")
        outer.CreateIdAttr("UsdTransform2d")
        outer.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(xf.ConnectableAPI(), "result")
        outer.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(1e30, 1e30))
        st = UsdShade.Shader.Get(stage, "/Looks/Tex/Image").GetInput("st")
        st.GetAttr().ClearConnections()
        st.ConnectToSource(outer.ConnectableAPI(), "result")
    else:
        xf.GetInput("in").GetAttr().ClearConnections()
        xf.GetInput("in").Set(Gf.Vec2f(0.5, 0.5))
        xf.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(3e38, 3e38))
        xf.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(3e38, 0.0))
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.load_usd(path)
    assert [w.category for w in caught] == [UserWarning], [str(w.message) for w in caught]
    assert "float32" in str(caught[0].message)


@pytest.mark.parametrize("source, name_input, default_input", [("ND_geompropvalue_vector2", "geomprop", "default"),
                                                                ("ND_UsdPrimvarReader_vector2", "varname", "fallback")])
def test_a_materialx_texcoord_reader_that_names_no_primvar_gives_its_default_everywhere(tmp_path, source, name_input,
                                                                                      default_input):
    """An ``ND_geompropvalue_vector2`` or ``ND_UsdPrimvarReader_vector2`` feeding an ``ND_UsdUVTexture``'s ``st``
    (through its ``ND_UsdTransform2d``, scale 2) with an empty primvar name reads no primvar: its default (0.125,
    0.375), scaled to (0.25, 0.75), CHECKER's top-left block (red) on every point, with a warning naming the node.
    The geompropvalue read the mesh's ``st`` without a word: the checker tiled twice."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = materialx_preview_stage(tmp_path, png, None, source)
    stage = Usd.Stage.Open(path)
    reader = UsdShade.Shader.Get(stage, "/Looks/Mx/Reader")
    reader.GetPrim().RemoveProperty("inputs:varname")
    reader.SetShaderId(source)
    reader.CreateInput(name_input, Sdf.ValueTypeNames.String).Set("")
    reader.CreateInput(default_input, Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.125, 0.375))
    stage.Save()
    scene, messages = load_with_messages(path)
    assert any("names no primvar" in m and "/Looks/Mx/Reader" in m for m in messages), messages
    img = albedo_of(scene, res=8)
    np.testing.assert_allclose(img, np.broadcast_to([1.0, 0.0, 0.0], img.shape), atol=2e-3)


@pytest.mark.parametrize("source", ["ND_texcoord_vector2", "ND_geompropvalue_vector2"])
def test_materialx_texcoord_nodes_feed_a_materialx_usd_uv_texture(tmp_path, source):
    """MaterialX's own texture-coordinate nodes feeding an ``ND_UsdUVTexture``'s ``st`` (through its
    ``ND_UsdTransform2d``), as MaterialX graphs wire them: ``texcoord`` reads ``st`` (UV0) and ``geompropvalue`` the
    primvar it names (here ``uv``; the mesh has no ``st``), as for a MaterialX image node. They were named as
    unsupported shaders and primvar ``st`` read: the geompropvalue's texture showed at the fallback st."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = materialx_preview_stage(tmp_path, png, None, source)
    stage = Usd.Stage.Open(path)
    reader = UsdShade.Shader.Get(stage, "/Looks/Mx/Reader")
    reader.GetPrim().RemoveProperty("inputs:varname")
    reader.SetShaderId(source)
    if source == "ND_geompropvalue_vector2":
        reader.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("uv")
        primvars = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Quad"))
        primvars.CreatePrimvar("uv", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
            primvars.GetPrimvar("st").Get())
        primvars.RemovePrimvar("st")
    stage.Save()
    scene, messages = load_with_messages(path)
    assert not messages, messages
    img = albedo_of(scene, res=8)  # st over [0, 2]^2 (the transform's scale 2), periodic
    texels = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [128 / 255] * 3]])  # 2x2 blocks, rows from the top
    np.testing.assert_allclose(img, np.tile(np.repeat(np.repeat(texels, 2, 0), 2, 1), (2, 2, 1)), atol=2e-3)
