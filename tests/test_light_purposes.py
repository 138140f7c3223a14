"""UsdLux lights of a purpose the render does not draw (guide, proxy; render where the render settings leave it out)
light the scene as Hydra's renderers light them (they give lights no purpose: OpenUSD issue 3059), and are named in
a warning, since UsdGeom says such a prim is not rendered. Which lights those are comes from USD's own
``ComputePurpose``."""

import re
import warnings

from pxr import Usd, UsdGeom

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
def Scope "Render"
{
    def RenderSettings "S"
    {
        uniform token[] includedPurposes = [INCLUDED]
    }
}
"""


def load(tmp_path, included):
    path = tmp_path / "lights.usda"
    path.write_text(STAGE.replace("INCLUDED", ", ".join(f'"{p}"' for p in included)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    named = [str(w.message) for w in caught if "purpose the render does not draw" in str(w.message)]
    return path, scene, named


def test_lights_of_a_purpose_not_drawn_still_light_and_are_named(tmp_path):
    path, scene, named = load(tmp_path, ["render"])
    stage = Usd.Stage.Open(str(path))
    drawn = ("default", "render")
    hidden = sorted(str(p.GetPath()) for p in stage.Traverse()
                    if p.GetTypeName().endswith("Light") and UsdGeom.Imageable(p).ComputePurpose() not in drawn)
    assert hidden == ["/Guide", "/Lamps/Protos/Bulb", "/Proxies/Panel"]
    # Every light lights, as before: purpose hides none.
    assert sorted(light.path for light in scene.lights) == ["/Guide", "/Lamps/Protos/Bulb[0]", "/Lamps/Protos/Bulb[1]",
                                                           "/Plain", "/Proxies/Panel"]
    (line,) = named
    assert sorted(line.rsplit("): ", 1)[1].split(", ")) == hidden, line
    assert re.search(r"purpose = guide: 2.*purpose = proxy: 1", line), line


def test_lights_of_a_purpose_the_render_settings_include_are_not_named(tmp_path):
    _, scene, named = load(tmp_path, ["render", "guide", "proxy"])
    assert len(scene.lights) == 5 and not named
