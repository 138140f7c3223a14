"""Authored USD that changes the picture in other renderers but that wrt does not render is named at load: one
warning per kind and stage, naming the file, the attribute (or type) and the prims. What wrt renders as authored
(default light linking, a displayOpacity of 1, a presence material with a cut-out threshold) is not named."""

import warnings

from pxr import Sdf, Usd, UsdGeom, UsdLux

import wrt


def load_with_warnings(tmp_path, build):
    """``(scene, messages)``: the stage ``build(stage)`` writes, loaded, and every warning the load gave."""
    path = str(tmp_path / "ignored.usda")
    stage = Usd.Stage.CreateNew(path)
    build(stage)
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    return scene, [str(w.message) for w in caught]


def quad(stage, path, x=0.0):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(x, 0, 0), (x + 1, 0, 0), (x + 1, 1, 0), (x, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return mesh


def about(messages, *words):
    """The messages that contain every one of ``words``."""
    return [m for m in messages if all(w in m for w in words)]


def test_light_linking_and_light_filters_are_named(tmp_path):
    """Light linking, shadow linking and light filters change what a light reaches in Storm, Karma and RenderMan;
    wrt lights everything, so the load names each light. A collection that still holds everything (includes beside
    the fallback includeRoot, an expression matching all) is UsdLux's default and not named."""

    def build(stage):
        quad(stage, "/Quad")
        for name in ("Linked", "AlsoLinked"):  # two lights of one kind: one warning naming both
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
    assert len(scene.lights) == 6  # all still lit, as before
    linked = about(messages, "ignored.usda", "collection:lightLink")
    assert len(linked) == 1 and linked[0].endswith("2 prim(s): /Linked, /AlsoLinked"), messages
    shadow = about(messages, "ignored.usda", "collection:shadowLink")
    assert len(shadow) == 1 and shadow[0].endswith(": /ShadowLinked"), messages
    filters = about(messages, "ignored.usda", "light:filters")
    assert len(filters) == 1 and filters[0].endswith("(LightFilter: 1): /Filtered"), messages
    assert not about(messages, "/Plain") and not about(messages, "/Everything"), messages
