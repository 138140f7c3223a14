"""UsdLux light inputs connected to other prims (UsdShade connections, as light rigs author them): an input's value is
its value-producing attribute's (``UsdShade.Input.GetValueProducingAttributes``, the interface input a connection
leads to), as Hydra 2's UsdImaging reads a light's parameters (``_UsdImagingDataSourceShadingNodeParameters``); an
input connected to a shader's output (a shading network, which wrt does not evaluate) is read as authored on the light,
as Storm reads it, and named. The expected values come from USD's own API."""

import warnings

import numpy as np
import pytest
from pxr import Usd, UsdShade

import wrt

RIG = """#usda 1.0
def NodeGraph "Rig"
{
    float inputs:gain = 5
    color3f inputs:tint = (1, 0.5, 0.25)
    bool inputs:even = 1
    float inputs:unset
    float inputs:cone = 30
    def SphereLight "Lamp"
    {
        float inputs:intensity.connect = </Rig.inputs:gain>
        color3f inputs:color = (0.1, 0.1, 0.1)
        color3f inputs:color.connect = </Rig.inputs:tint>
        bool inputs:normalize.connect = </Rig.inputs:even>
        float inputs:exposure = 1
        float inputs:exposure.connect = </Rig.inputs:unset>
        float inputs:shaping:cone:angle.connect = </Rig.inputs:cone>
        double3 xformOp:translate = (0, 3, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def RectLight "Panel"
    {
        float inputs:intensity = 7
        float inputs:intensity.connect = </Rig/Noise.outputs:r>
    }
    def Shader "Noise"
    {
        uniform token info:id = "UsdUVTexture"
        float outputs:r
    }
}
"""


def usd_value(prim, name):
    """A light input's value by USD's rule: the first value-producing input its connections lead to, else its own."""
    light_input = UsdShade.ConnectableAPI(prim).GetInput(name)
    sources = [a for a in light_input.GetValueProducingAttributes()
               if UsdShade.Utils.GetType(a.GetName()) == UsdShade.AttributeType.Input]
    return sources[0].Get() if sources else light_input.Get()


def test_light_inputs_connected_to_a_rig_read_the_rigs_values(tmp_path):
    """A SphereLight whose intensity, colour, normalize and cone angle (no ShapingAPI: Hydra reads the input all the
    same) are connected to a NodeGraph's inputs shines with the rig's values (5 x (1, 0.5, 0.25), normalized, a cone
    of 30 degrees), and an exposure connected to a rig input of no value keeps its own (1); they were read as
    authored on the light (intensity 1 and colour 0.1: 25 times too dim, unnormalized, unshaped)."""
    path = tmp_path / "rig.usda"
    path.write_text(RIG)
    stage = Usd.Stage.Open(str(path))
    lamp = stage.GetPrimAtPath("/Rig/Lamp")
    expected = (np.array(usd_value(lamp, "color"), np.float64) * usd_value(lamp, "intensity")
                * 2.0 ** usd_value(lamp, "exposure"))
    assert usd_value(lamp, "intensity") == 5.0 and usd_value(lamp, "exposure") == 1.0  # the oracle itself
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lights = {light.path: light for light in wrt.load_usd(path).lights}
    sphere = lights["/Rig/Lamp"]
    np.testing.assert_allclose(sphere.color, expected, rtol=1e-6)
    assert sphere.normalize is usd_value(lamp, "normalize") is True
    assert sphere.shaping is not None and sphere.shaping.cone_angle == usd_value(lamp, "shaping:cone:angle") == 30.0
    assert not [w for w in caught if "/Rig/Lamp" in str(w.message)]


def test_a_light_input_connected_to_a_shader_output_is_read_as_authored_and_named(tmp_path):
    """An intensity connected to a texture's output is read as authored on the light (7), as Storm reads it, and
    named with the light and the source in a warning: it was dropped without a word."""
    path = tmp_path / "rig.usda"
    path.write_text(RIG)
    stage = Usd.Stage.Open(str(path))
    panel = stage.GetPrimAtPath("/Rig/Panel")
    with pytest.warns(UserWarning, match=r"shading network.*/Rig/Noise\.outputs:r.*/Rig/Panel"):
        lights = {light.path: light for light in wrt.load_usd(path).lights}
    np.testing.assert_allclose(lights["/Rig/Panel"].color, [usd_value(panel, "intensity")] * 3)
