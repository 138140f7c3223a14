"""UsdLux lights of a purpose the render does not draw (guide, proxy; render where the render settings leave it out)
light the scene as Hydra's renderers light them (they give lights no purpose: OpenUSD issue 3059), and are named in
a warning, since UsdGeom says such a prim is not rendered. Which lights those are comes from USD's own
``ComputePurpose``."""

import re
import warnings

from pxr import Usd, UsdGeom, UsdLux

import wrt

STAGE = """#usda 1.0
(
    renderSettingsPrimPath = "/Render/S"
)
def SphereLight "Plain"
{
}
def SphereLight "Guide"
{
    uniform token purpose = "guide"
}
def Xform "Proxies"
{
    uniform token purpose = "proxy"
    def RectLight "Panel"
    {
    }
}
def PointInstancer "Lamps"
{
    uniform token purpose = "guide"
    rel prototypes = </Lamps/Protos/Bulb>
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (2, 0, 0)]
    def Scope "Protos"
    {
        def SphereLight "Bulb"
        {
        }
    }
}
def Scope "Guides"
{
    uniform token purpose = "guide"
    def SphereLight "Loose"
    {
    }
    def "Typeless"
    {
        def SphereLight "Deep"
        {
        }
    }
    def PointInstancer "Lanterns"
    {
        rel prototypes = </Protos/Lantern>
        int[] protoIndices = [0]
        point3f[] positions = [(0, 0, 0)]
    }
}
def PointInstancer "Stands"
{
    rel prototypes = [</Protos/Stage>, </Protos/Lantern>]
    int[] protoIndices = [0, 1]
    point3f[] positions = [(0, 0, 0), (2, 0, 0)]
}
def Scope "Protos"
{
    token visibility = "invisible"
    def SphereLight "Lantern"
    {
    }
    def SphereLight "Stage"
    {
        uniform token purpose = "render"
    }
}
def Xform "Kit"
{
    def SphereLight "Lamp"
    {
    }
    def PointInstancer "Bulbs"
    {
        rel prototypes = </Kit/Bulbs/P/Bulb>
        int[] protoIndices = [0]
        point3f[] positions = [(0, 0, 0)]
        def Scope "P"
        {
            def SphereLight "Bulb"
            {
            }
        }
    }
}
def Xform "GuideKit" (
    instanceable = true
    references = </Kit>
)
{
    uniform token purpose = "guide"
}
def Xform "PlainKit" (
    instanceable = true
    references = </Kit>
)
{
}
def Scope "Render"
{
    def RenderSettings "S"
    {
        uniform token[] includedPurposes = [INCLUDED]
    }
}
"""


def load(tmp_path, included, monkeypatch):
    """``(stage, scene, warning lines about purpose, every light those lines name with its detail)``."""
    path = tmp_path / "lights.usda"
    path.write_text(STAGE.replace("INCLUDED", ", ".join(f'"{p}"' for p in included)))
    recorded = []
    record = wrt.usd_problems.ProblemReport._skip_path

    def spy(self, reason, shown, detail=None):  # the warning lists three names: the records hold them all
        if "purpose the render does not draw" in reason:
            recorded.append((shown, detail))
        return record(self, reason, shown, detail)

    monkeypatch.setattr(wrt.usd_problems.ProblemReport, "_skip_path", spy)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    named = [str(w.message) for w in caught if "purpose the render does not draw" in str(w.message)]
    return Usd.Stage.Open(str(path)), scene, named, sorted(set(recorded))


def is_light(p) -> bool:
    return p.GetTypeName().endswith("Light")


def undrawn_lights(stage, drawn) -> list:
    """``(name, "purpose = ...")`` of every light whose purpose is not ``drawn``, from USD alone. A light walked in
    place (instance proxies too, hidden ones left out) has ``ComputePurpose``'s. A light in a PointInstancer's
    prototype, named ``path[k]`` per instance ``k`` (``path[/Instancer[k]]`` for a prototype outside the instancer,
    which another instancer may place too), has the purpose ``ComputePurposeInfo`` finds authored on it or
    its ancestors (``isInheritable``), else the instancer's ``ComputePurpose``: an instance inherits the instancer's
    purpose, as UsdImaging gives it (``instanceInheritablePurpose``)."""
    found = []
    it = iter(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))
    for p in it:
        if p.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()
            instancer = UsdGeom.PointInstancer(p)
            indices = list(instancer.GetProtoIndicesAttr().Get())
            for target_index, target in enumerate(instancer.GetPrototypesRel().GetTargets()):
                for light in Usd.PrimRange(stage.GetPrimAtPath(target), Usd.TraverseInstanceProxies()):
                    if not is_light(light):
                        continue
                    info = UsdGeom.Imageable(light).ComputePurposeInfo()
                    purpose = info.purpose if info.isInheritable else UsdGeom.Imageable(p).ComputePurpose()
                    beneath = light.GetPath().HasPrefix(p.GetPath())
                    if purpose not in drawn:
                        found += [(f"{light.GetPath()}[{k if beneath else f'{p.GetPath()}[{k}]'}]",
                                   f"purpose = {purpose}")
                                  for k, index in enumerate(indices) if index == target_index]
        elif is_light(p) and UsdGeom.Imageable(p).ComputeVisibility() != UsdGeom.Tokens.invisible:
            purpose = UsdGeom.Imageable(p).ComputePurpose()
            if purpose not in drawn:
                found.append((str(p.GetPath()), f"purpose = {purpose}"))
    return sorted(found)


def test_lights_of_a_purpose_not_drawn_still_light_and_are_named(tmp_path, monkeypatch):
    """Each light whose purpose is guide or proxy is named, and no other: a purpose inherited from an Xform, a
    typeless prim or a Scope, through a native instance (an instance proxy; the PointInstancer in a guide instance's
    prototype too: its instances were not named, USD's ComputePurpose of the prototype's prim inside the prototype
    saying default) and from a PointInstancer whose prototype lies outside it (not named either)."""
    stage, scene, named, recorded = load(tmp_path, ["render"], monkeypatch)
    expected = undrawn_lights(stage, ("default", "render"))
    assert [name for name, _ in expected] == sorted(
        ["/Guide", "/Proxies/Panel", "/Lamps/Protos/Bulb[0]", "/Lamps/Protos/Bulb[1]", "/Guides/Loose",
         "/Guides/Typeless/Deep", "/Protos/Lantern[/Guides/Lanterns[0]]", "/GuideKit/Lamp",
         "/GuideKit/Bulbs/P/Bulb[0]"])
    assert recorded == expected
    # Every light lights, as before: purpose hides none.
    assert sorted(light.path for light in scene.lights) == sorted(
        ["/Plain", "/Guide", "/Proxies/Panel", "/Lamps/Protos/Bulb[0]", "/Lamps/Protos/Bulb[1]", "/Guides/Loose",
         "/Guides/Typeless/Deep", "/Protos/Lantern[/Guides/Lanterns[0]]", "/Protos/Stage[/Stands[0]]",
         "/Protos/Lantern[/Stands[1]]", "/Kit/Lamp",
         "/Kit/Bulbs/P/Bulb[0]", "/GuideKit/Lamp", "/GuideKit/Bulbs/P/Bulb[0]", "/PlainKit/Lamp",
         "/PlainKit/Bulbs/P/Bulb[0]"])
    (line,) = named
    assert re.search(r": 9 prim\(s\) \(purpose = guide: 8, purpose = proxy: 1\)", line), line


def test_lights_of_a_purpose_the_render_settings_include_are_not_named(tmp_path, monkeypatch):
    _, scene, named, recorded = load(tmp_path, ["render", "guide", "proxy"], monkeypatch)
    assert len(scene.lights) == 16 and not named and not recorded


MESH_LIGHTS = """#usda 1.0
def DistantLight "Sun"
{
}
def Mesh "Lit" (
    prepend apiSchemas = ["MeshLightAPI"]
)
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]
}
def Xform "Guides"
{
    uniform token purpose = "guide"
    def Mesh "Panel" (
        prepend apiSchemas = ["MeshLightAPI"]
    )
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
    }
}
def Sphere "Orb" (
    prepend apiSchemas = ["LightAPI"]
)
{
    uniform token purpose = "proxy"
}
def Sphere "Hidden" (
    prepend apiSchemas = ["LightAPI"]
)
{
    uniform token purpose = "guide"
    token visibility = "invisible"
}
"""


def test_mesh_lights_of_a_purpose_not_drawn_are_named_as_giving_no_light(tmp_path):
    """A mesh light (MeshLightAPI, or LightAPI on a gprim) of guide or proxy purpose gives no light, its geometry not
    drawn, where the other lights of that purpose light: it went dark without a word beside a sun. Named are exactly
    the visible mesh lights whose ``ComputePurpose`` is not drawn."""
    path = tmp_path / "mesh_lights.usda"
    path.write_text(MESH_LIGHTS)
    stage = Usd.Stage.Open(str(path))
    expected = sorted(str(p.GetPath()) for p in stage.Traverse()
                      if p.IsA(UsdGeom.Gprim) and p.HasAPI(UsdLux.LightAPI)
                      and UsdGeom.Imageable(p).ComputeVisibility() != UsdGeom.Tokens.invisible
                      and UsdGeom.Imageable(p).ComputePurpose() not in ("default", "render"))
    assert expected == ["/Guides/Panel", "/Orb"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    lines = [str(w.message) for w in caught if "mesh lights of a purpose the render does not draw" in str(w.message)]
    assert len(lines) == 1, [str(w.message) for w in caught]
    assert sorted(lines[0].rsplit("): ", 1)[1].split(", ")) == expected, lines[0]
    assert "(purpose = guide: 1, purpose = proxy: 1)" in lines[0], lines[0]
    assert sorted(light.path for light in scene.lights) == ["/Lit", "/Sun"]


INSTANCEABLE_MESH_LIGHT = """#usda 1.0
def DistantLight "Sun"
{
}
class "Source"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
    def Xform "Inside"
    {
    }
}
def Mesh "Panel" (
    prepend apiSchemas = ["MeshLightAPI"]
    instanceable = true
    inherits = </Source>
)
{
    uniform token purpose = "guide"
}
"""


def test_an_instanceable_mesh_light_of_a_purpose_not_drawn_is_named_as_giving_no_light(tmp_path):
    """An instanceable mesh keeps its geometry on the instance prim, read apart from the other gprims: one of guide
    purpose that is a mesh light went dark without a word, as the plain ones did. Named as they are; the oracle is
    USD's IsInstance and ComputePurpose."""
    path = tmp_path / "instanceable_mesh_light.usda"
    path.write_text(INSTANCEABLE_MESH_LIGHT)
    stage = Usd.Stage.Open(str(path))
    panel = stage.GetPrimAtPath("/Panel")
    assert panel.IsInstance() and UsdGeom.Imageable(panel).ComputePurpose() == "guide"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    lines = [str(w.message) for w in caught if "mesh lights of a purpose the render does not draw" in str(w.message)]
    assert len(lines) == 1, [str(w.message) for w in caught]
    assert lines[0].endswith("(purpose = guide: 1): /Panel"), lines[0]
    assert [light.path for light in scene.lights] == ["/Sun"]
