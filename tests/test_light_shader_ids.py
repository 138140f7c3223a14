"""A UsdLux light whose ``light:shaderId`` (or a render context's ``<context>:light:shaderId``) names a shader other
than its type's is rendered as its type says, wrt running no light shaders, and is named in one warning with the
id; ids that name the light's own shader are not. Which ids are foreign comes from USD: ``LightAPI.GetShaderId``
and the schema registry's fallback for the type."""

import re
import warnings

import pytest
from pxr import Usd, UsdLux

import wrt

STAGE = """#usda 1.0
def SphereLight "Plain"
{
}
def SphereLight "Same"
{
    uniform token light:shaderId = "SphereLight"
}
def SphereLight "Other"
{
    uniform token light:shaderId = "StudioBulb"
}
def RectLight "Ri"
{
    uniform token ri:light:shaderId = "PxrRectLight"
}
def RectLight "Empty"
{
    uniform token light:shaderId = ""
}
def DomeLight_1 "Sky"
{
    uniform token light:shaderId = "DomeLight_1"
}
def Mesh "Panel" (
    prepend apiSchemas = ["MeshLightAPI"]
)
{
    uniform token light:shaderId = "MeshLight"
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
}
def PointInstancer "Lamps"
{
    rel prototypes = </Lamps/Protos/Bulb>
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (2, 0, 0)]
    def Scope "Protos"
    {
        def DiskLight "Bulb"
        {
            uniform token karma:light:shaderId = "KarmaDisk"
        }
    }
}
"""
REASON = ("lights naming a shader (light:shaderId, or a render context's <context>:light:shaderId) other than their "
          "UsdLux type's are rendered as that type says: wrt runs no light shaders")


def foreign_ids(stage) -> dict:
    """``{prim path: ["name = id", ...]}`` from USD alone: each authored shader id attribute's id as
    ``LightAPI.GetShaderId`` gives it for its render context, where it is neither empty nor the schema registry's
    fallback id of the prim's type (or applied MeshLightAPI) nor the type's own name."""
    registry = Usd.SchemaRegistry()
    found = {}
    for prim in stage.Traverse():
        if not prim.HasAPI(UsdLux.LightAPI):
            continue
        api = UsdLux.LightAPI(prim)
        if prim.HasAPI(UsdLux.MeshLightAPI):
            definition = registry.FindAppliedAPIPrimDefinition("MeshLightAPI")
        else:
            definition = registry.FindConcretePrimDefinition(prim.GetTypeName())
        own = {str(definition.GetAttributeFallbackValue("light:shaderId")), prim.GetTypeName()}
        for name in prim.GetAuthoredPropertyNames():
            if not name.endswith("light:shaderId"):
                continue
            context = name[: -len(":light:shaderId")] if name != "light:shaderId" else None
            shader_id = str(api.GetShaderId([context] if context else []))
            if shader_id and shader_id not in own:
                found.setdefault(str(prim.GetPath()), []).append(f"{name} = {shader_id}")
    return found


def test_lights_naming_other_shaders_are_named_once_and_drawn_as_their_type(tmp_path):
    path = tmp_path / "lights.usda"
    path.write_text(STAGE)
    stage = Usd.Stage.Open(str(path))
    foreign = foreign_ids(stage)
    assert foreign == {"/Other": ["light:shaderId = StudioBulb"], "/Ri": ["ri:light:shaderId = PxrRectLight"],
                       "/Lamps/Protos/Bulb": ["karma:light:shaderId = KarmaDisk"]}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    lines = [str(w.message) for w in caught if REASON in str(w.message)]
    assert len(lines) == 1, lines
    (line,) = lines
    # Placed lights are named per instance, as every warning names them (the first three of the four shown).
    assert ": 4 prim(s) (" in line and line.endswith("): /Other, /Ri, /Lamps/Protos/Bulb[0], ..."), line
    for ids in foreign.values():
        for words in ids:
            assert re.search(rf"\b{re.escape(words)}: \d", line), (words, line)
    by_path = {light.path: light for light in scene.lights}
    assert type(by_path["/Other"]) is type(by_path["/Plain"]) is wrt.SphereLight
    assert by_path["/Other"].radius == pytest.approx(by_path["/Plain"].radius)
    assert type(by_path["/Ri"]).__name__ == "RectLight"
    assert {"/Same", "/Empty", "/Sky", "/Panel"} <= set(by_path)
