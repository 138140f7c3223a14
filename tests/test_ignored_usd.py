"""Authored USD that changes the picture in other renderers but that wrt does not render is named at load: one
warning per kind and stage, naming the file, the attribute (or type) and the prims. What wrt renders as authored
(light linking, a presence material with a cut-out threshold) is not named."""

import numpy as np
import pytest
from PIL import Image as PilImage
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
from usda_text import load_recording_warnings

import wrt


def load_with_warnings(tmp_path, build):
    """``(scene, messages)``: the stage ``build(stage)`` writes, loaded, and every warning the load gave."""
    path = str(tmp_path / "ignored.usda")
    stage = Usd.Stage.CreateNew(path)
    build(stage)
    stage.Save()
    return load_recording_warnings(path)


def quad(stage, path, x=0.0):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(x, 0, 0), (x + 1, 0, 0), (x + 1, 1, 0), (x, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return mesh


def about(messages, *words):
    """The messages that contain every one of ``words``."""
    return [m for m in messages if all(w in m for w in words)]


def test_light_filters_are_named_and_light_links_are_read(tmp_path):
    """Light filters change what a light reaches in Storm, Karma and RenderMan; wrt shines unfiltered, so the load
    names each filtered light. Light and shadow linking are rendered (tests/test_light_linking.py): read as the
    lights' collections and not named; a collection that holds everything (includes beside the fallback includeRoot,
    an expression matching all) is UsdLux's default: no collection."""

    def build(stage):
        quad(stage, "/Quad")
        for name in ("Linked", "AlsoLinked"):
            link = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, f"/{name}")).GetLightLinkCollectionAPI()
            link.CreateIncludeRootAttr(False)
            link.CreateIncludesRel().AddTarget("/Quad")
        shadow = UsdLux.LightAPI(UsdLux.RectLight.Define(stage, "/ShadowLinked")).GetShadowLinkCollectionAPI()
        shadow.CreateExcludesRel().AddTarget("/Quad")
        UsdLux.LightFilter.Define(stage, "/Filter")
        UsdLux.LightAPI(UsdLux.DiskLight.Define(stage, "/Filtered")).CreateFiltersRel().AddTarget("/Filter")
        plain = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, "/Plain")).GetLightLinkCollectionAPI()
        plain.CreateIncludesRel().AddTarget("/Quad")  # includeRoot stays true: still every prim
        everything = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, "/Everything")).GetLightLinkCollectionAPI()
        everything.CreateIncludeRootAttr(False)
        everything.CreateMembershipExpressionAttr(Sdf.PathExpression("//"))

    scene, messages = load_with_warnings(tmp_path, build)
    lights = {light.path: light for light in scene.lights}
    assert len(lights) == 6
    assert not about(messages, "link"), messages
    assert lights["/Linked"].light_link.rules == {"/Quad": "expandPrims"}
    assert lights["/ShadowLinked"].shadow_link.rules == {"/": "expandPrims", "/Quad": "exclude"}
    assert lights["/Plain"].light_link is None and lights["/Everything"].light_link is None
    filters = about(messages, "ignored.usda", "light:filters")
    assert len(filters) == 1 and filters[0].endswith("(LightFilter: 1): /Filtered"), messages
    assert not about(messages, "/Plain") and not about(messages, "/Everything"), messages


def bind_preview(stage, prim, path, **inputs):
    """Binds a new UsdPreviewSurface material at ``path`` with ``inputs`` (name -> (type, value)) to ``prim``."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, (type_name, value) in inputs.items():
        shader.CreateInput(name, type_name).Set(value)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)
    return material, shader


def test_displacement_presence_and_unknown_st_sources_are_named(tmp_path):
    """A material that displaces (``displacement`` output connected to a UsdPreviewSurface whose ``displacement`` is
    not 0), ``opacityMode = presence`` with an opacity below 1 and no threshold (coverage in Storm; wrt draws glass),
    and a texture whose ``st`` comes from a shader wrt does not know are named with their material."""

    def build(stage):
        bumpy, surface = bind_preview(stage, quad(stage, "/Bumpy").GetPrim(), "/Looks/Bumpy",
                                      displacement=(Sdf.ValueTypeNames.Float, 0.1))
        bumpy.CreateDisplacementOutput().ConnectToSource(surface.ConnectableAPI(), "displacement")
        flat, surface = bind_preview(stage, quad(stage, "/Flat", 2.0).GetPrim(), "/Looks/Flat")
        flat.CreateDisplacementOutput().ConnectToSource(surface.ConnectableAPI(), "displacement")  # displaces by 0
        presence = (Sdf.ValueTypeNames.Token, "presence")
        bind_preview(stage, quad(stage, "/Veil", 4.0).GetPrim(), "/Looks/Veil", opacityMode=presence,
                     opacity=(Sdf.ValueTypeNames.Float, 0.5))
        bind_preview(stage, quad(stage, "/Leaf", 6.0).GetPrim(), "/Looks/Leaf", opacityMode=presence,
                     opacity=(Sdf.ValueTypeNames.Float, 0.5), opacityThreshold=(Sdf.ValueTypeNames.Float, 0.25))
        bind_preview(stage, quad(stage, "/Opaque", 8.0).GetPrim(), "/Looks/Opaque", opacityMode=presence)

        _, surface = bind_preview(stage, quad(stage, "/Projected", 10.0).GetPrim(), "/Looks/Projected")
        texture = UsdShade.Shader.Define(stage, "/Looks/Projected/Texture")
        texture.CreateIdAttr("UsdUVTexture")
        PilImage.fromarray(np.full((2, 2, 3), 200, np.uint8)).save(tmp_path / "grey.png")
        texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("grey.png")
        projection = UsdShade.Shader.Define(stage, "/Looks/Projected/Projection")
        projection.CreateIdAttr("MyCameraProjection")
        texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
            projection.CreateOutput("result", Sdf.ValueTypeNames.Float2))
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3))

    _, messages = load_with_warnings(tmp_path, build)
    displaced = about(messages, "ignored.usda", "outputs:displacement")
    assert len(displaced) == 1 and "/Looks/Bumpy" in displaced[0] and "/Looks/Flat" not in displaced[0], messages
    presence = about(messages, "ignored.usda", "opacityMode = presence")
    assert len(presence) == 1 and "/Looks/Veil" in presence[0], messages
    assert not about(messages, "/Looks/Leaf") and not about(messages, "/Looks/Opaque"), messages
    st = about(messages, "ignored.usda", "MyCameraProjection")
    assert len(st) == 1 and "/Looks/Projected" in st[0], messages


def test_generative_procedurals_are_named(tmp_path):
    """A ``GenerativeProcedural`` (Hydra's hdGp procedurals, drawn by usdview and Karma with their plugin) makes no
    geometry in wrt: named, as unsupported gprim types are."""

    def build(stage):
        quad(stage, "/Quad")
        procedural = stage.DefinePrim("/Crowd", "GenerativeProcedural")
        procedural.CreateAttribute("primvars:hdGp:proceduralType", Sdf.ValueTypeNames.Token).Set("Golaem")
        UsdGeom.Boundable(procedural).CreateExtentAttr([Gf.Vec3f(-1), Gf.Vec3f(1)])

    scene, messages = load_with_warnings(tmp_path, build)
    assert len(scene.meshes) == 1
    found = about(messages, "ignored.usda", "GenerativeProcedural")
    assert len(found) == 1 and found[0].endswith(": /Crowd"), messages


def test_prims_under_a_material_are_not_drawn_and_are_named(tmp_path):
    """Hydra populates none of a Material's descendants (its adapter represents the material and everything below
    it, the shaders read as its network): a mesh, light or camera kept under one (a preview swatch, say) is not
    drawn (UsdImaging's legacy delegate culls the subtree of every typed prim that is not imageable, a Material
    among them). wrt drew them as any other prim, in the world and inside native prototypes. Now it draws what lies
    outside materials alone, and names each material that held something. The oracle: the points USD authors for the
    meshes outside materials."""

    def build(stage):
        quad(stage, "/Host")
        material = UsdShade.Material.Define(stage, "/Looks/Mat")
        shader = UsdShade.Shader.Define(stage, "/Looks/Mat/Surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        quad(stage, "/Looks/Mat/Swatch", x=2.0)
        UsdLux.SphereLight.Define(stage, "/Looks/Mat/Lamp")
        UsdGeom.Camera.Define(stage, "/Looks/Mat/Cam")
        asset = stage.CreateClassPrim("/Asset")
        UsdShade.Material.Define(stage, "/Asset/Mat")
        quad(stage, "/Asset/Mat/Swatch", x=6.0)
        quad(stage, "/Asset/Body", x=8.0)
        instance = stage.DefinePrim("/Instance", "Xform")
        instance.GetReferences().AddInternalReference(asset.GetPath())
        instance.SetInstanceable(True)

    scene, messages = load_with_warnings(tmp_path, build)
    stage = Usd.Stage.Open(str(tmp_path / "ignored.usda"))
    points, indices = scene.triangles()
    drawn = np.unique(np.asarray(points, np.float64)[indices].reshape(-1, 3), axis=0)
    expected = np.unique(np.concatenate([np.array(UsdGeom.Mesh(stage.GetPrimAtPath(path)).GetPointsAttr().Get())
                                         for path in ("/Host", "/Instance/Body")]), axis=0)
    np.testing.assert_array_equal(drawn, expected)
    assert scene.lights == [] and list(scene.cameras) == []
    found = about(messages, "ignored.usda", "under a Material")
    assert len(found) == 1 and found[0].endswith("2 prim(s) (/Looks/Mat/Swatch, /Looks/Mat/Lamp, /Looks/Mat/Cam: 1, "
                                                 "/Instance/Mat/Swatch: 1): /Looks/Mat, /Instance/Mat"), messages


@pytest.mark.parametrize("holder", ["world", "instance", "hidden_instance", "instancer", "hidden_instancer"])
def test_a_light_under_a_material_is_no_light_of_the_stage_wherever_the_material_is(tmp_path, holder):
    """A light kept under a Material is not drawn (Hydra populates none of its descendants), and so it is no light
    of the stage either: the stage is lit as the same stage without it is (the default lights of a stage without
    lights), in the world and in a prototype of a native instance or a PointInstancer, drawn or hidden. Before, a
    prototype's lamp under a material was counted among the stage's lights (Scene.dark_lights) where its instance
    or instancer was hidden, and under any PointInstancer: no default lights, a black image. USD's own
    ``ComputeLightList`` lists it all the same: it does not cull materials as Hydra does."""

    def build(stage, lamp):
        quad(stage, "/Floor")
        root = "/Looks" if holder == "world" else "/Proto"
        if holder != "world":
            stage.CreateClassPrim(root)
        UsdShade.Material.Define(stage, f"{root}/Mat")
        if lamp:
            UsdLux.SphereLight.Define(stage, f"{root}/Mat/Lamp")
        if holder.endswith("instance"):
            instance = stage.DefinePrim("/Inst", "Xform")
            instance.GetReferences().AddInternalReference(root)
            instance.SetInstanceable(True)
            if holder == "hidden_instance":
                UsdGeom.Imageable(instance).CreateVisibilityAttr("invisible")
        elif holder.endswith("instancer"):
            instancer = UsdGeom.PointInstancer.Define(stage, "/Lamps")
            stage.DefinePrim("/Lamps/Protos/Lamp", "Xform").GetReferences().AddInternalReference(root)
            instancer.CreatePrototypesRel().SetTargets(["/Lamps/Protos/Lamp"])
            instancer.CreatePositionsAttr([(0.0, 0.0, 0.0)])
            instancer.CreateProtoIndicesAttr([0])
            if holder == "hidden_instancer":
                instancer.CreateVisibilityAttr("invisible")

    scene, _ = load_with_warnings(tmp_path, lambda stage: build(stage, True))
    stage = Usd.Stage.Open(str(tmp_path / "ignored.usda"))
    listed = UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(UsdLux.LightListAPI.ComputeModeIgnoreCache)
    assert [str(path).rsplit("/", 2)[-2:] for path in listed] == [["Mat", "Lamp"]]
    (tmp_path / "lampless").mkdir()
    lampless, _ = load_with_warnings(tmp_path / "lampless", lambda stage: build(stage, False))
    assert scene.lights == lampless.lights == [] and scene.dark_lights == lampless.dark_lights == []
    np.testing.assert_array_equal(wrt.render(scene, width=4, height=4, device="cpu").rgb,
                                  wrt.render(lampless, width=4, height=4, device="cpu").rgb)


def test_lights_on_gprims_make_them_mesh_lights(tmp_path):
    """``LightAPI`` on a gprim other than a mesh (a glowing ``Sphere``) makes it a light in UsdLux, as MeshLightAPI
    does a mesh: wrt draws that sphere alone as its tessellation, a mesh light, without a warning (it used to draw it
    analytically, emitting nothing, and say so); a plain Sphere stays analytic."""

    def build(stage):
        bulb = UsdGeom.Sphere.Define(stage, "/Bulb")
        UsdLux.LightAPI.Apply(bulb.GetPrim()).CreateIntensityAttr(50.0)
        UsdLux.MeshLightAPI.Apply(quad(stage, "/Panel").GetPrim())
        UsdGeom.Sphere.Define(stage, "/Plain")

    scene, messages = load_with_warnings(tmp_path, build)
    assert [s.path for s in scene.shapes] == ["/Plain"] and [m.path for m in scene.meshes] == ["/Bulb", "/Panel"]
    assert [light.path for light in scene.lights] == ["/Bulb", "/Panel"]
    assert not about(messages, "ignored.usda", "LightAPI"), messages


def test_model_draw_modes_that_ask_for_stand_ins_are_named_and_drawn_in_full(tmp_path):
    """``model:drawMode`` of ``cards``, ``bounds`` or ``origin`` makes usdview draw a model as a stand-in, where
    ``model:applyDrawMode`` is true or, unauthored, the model is a component (UsdGeomModelAPI); wrt drew its full
    geometry without a word. It still draws it, and names each such model with the mode USD resolves for it
    (inherited from a group, too). A mode of ``default``, ``applyDrawMode = false`` or a prim that is no model (no
    kind) changes nothing in usdview and is not named."""
    cases = {  # model: (kind, drawMode, applyDrawMode); None leaves it unauthored
        "/World/Bounds": ("component", "bounds", True),
        "/World/Cards": ("component", "cards", None),
        "/World/Off": ("component", "origin", False),
        "/World/Default": ("component", "default", True),
        "/World/Group/Child": ("component", None, True),  # inherits Group's origin
        "/NoModel": (None, "bounds", True),
    }

    def build(stage):
        Usd.ModelAPI(UsdGeom.Xform.Define(stage, "/World").GetPrim()).SetKind("assembly")
        group = UsdGeom.Xform.Define(stage, "/World/Group").GetPrim()
        Usd.ModelAPI(group).SetKind("group")
        UsdGeom.ModelAPI.Apply(group).CreateModelDrawModeAttr("origin")
        for x, (path, (kind, mode, apply)) in enumerate(cases.items()):
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            if kind:
                Usd.ModelAPI(prim).SetKind(kind)
            api = UsdGeom.ModelAPI.Apply(prim)
            if mode:
                api.CreateModelDrawModeAttr(mode)
            if apply is not None:
                api.CreateModelApplyDrawModeAttr(apply)
            quad(stage, path + "/Quad", x=2.0 * x)

    scene, messages = load_with_warnings(tmp_path, build)
    named = about(messages, "model:drawMode asks for a stand-in", "drawn as full geometry")
    assert len(named) == 1, messages
    stage = Usd.Stage.Open(str(tmp_path / "ignored.usda"))
    for path, mode in [("/World/Bounds", "bounds"), ("/World/Cards", "cards"), ("/World/Group/Child", "origin")]:
        prim = stage.GetPrimAtPath(path)
        assert prim.IsModel() and UsdGeom.ModelAPI(prim).ComputeModelDrawMode() == mode  # USD's resolution
        assert f"model:drawMode = {mode}" in named[0]
    assert set(named[0].rsplit("): ", 1)[1].split(", ")) == {"/World/Bounds", "/World/Cards", "/World/Group/Child"}
    assert not stage.GetPrimAtPath("/NoModel").IsModel()
    assert sorted(m.path for m in scene.meshes) == sorted(path + "/Quad" for path in cases)  # all drawn in full
