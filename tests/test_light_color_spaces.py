"""The colour space of a UsdLux light's ``inputs:color``: its own ``colorSpace`` metadata, else ``UsdColorSpaceAPI`` on
the light or an ancestor (USD's ``UsdColorSpaceAPI::ComputeColorSpaceName``), else linear Rec.709. The light's
colour is brought to linear Rec.709 as USD itself converts it: the oracle is ``Gf.ColorSpace.Convert``."""

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
from test_materials import add_quad

import wrt

COLOR = (0.6, 0.5, 0.4)  # inside Rec.709's gamut from each space below
SPACES = ["lin_rec709_scene", "srgb_rec709_scene", "lin_ap1_scene", "g22_rec709_scene", "g22_ap1_scene",
          "srgb_p3d65_scene", "data"]


def usd_linear_rec709(space: str, rgb) -> np.ndarray:
    """``rgb`` in colour space ``space`` as linear Rec.709, converted by USD (``Gf.ColorSpace.Convert``)."""
    target = Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709)
    return np.array(target.Convert(Gf.ColorSpace(space), Gf.Vec3f(*rgb)).GetRGB(), np.float64)


def light_stage(tmp_path, space: str, where: str) -> str:
    """A DistantLight ``/Rig/Sun`` of colour :data:`COLOR` (intensity 1) in colour space ``space``, authored on its
    ``inputs:color`` (``own``), through ``UsdColorSpaceAPI`` on its parent ``/Rig`` (``ancestor``), or on the input of
    a light rig's NodeGraph its colour connects to (``rig``)."""
    path = str(tmp_path / "light.usda")
    stage = Usd.Stage.CreateNew(path)
    rig = stage.DefinePrim("/Rig", "Xform")
    light = UsdLux.DistantLight.Define(stage, "/Rig/Sun")
    light.CreateIntensityAttr(1.0)  # (its fallback is 50000)
    color = light.CreateColorAttr(Gf.Vec3f(*COLOR))
    if where == "own":
        color.SetColorSpace(space)
    elif where == "ancestor":
        Usd.ColorSpaceAPI.Apply(rig).CreateColorSpaceNameAttr(space)
    else:
        graph = UsdShade.NodeGraph.Define(stage, "/Rig/Controls")
        source = graph.CreateInput("tint", Sdf.ValueTypeNames.Color3f)
        source.Set(Gf.Vec3f(*COLOR))
        source.GetAttr().SetColorSpace(space)
        color.Clear()
        UsdShade.Input(color).ConnectToSource(source)
    stage.Save()
    if where != "rig" and Gf.ColorSpace.IsValid(space):  # USD's own resolution gives the light's colour that space
        assert Usd.ColorSpaceAPI.ComputeColorSpaceName(color, None) == space
    return path


def load(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    return scene, [str(w.message) for w in caught]


@pytest.mark.parametrize("where", ["own", "ancestor", "rig"])
@pytest.mark.parametrize("space", SPACES)
def test_a_light_colour_is_read_in_its_colour_space(tmp_path, space, where):
    """(0.6, 0.5, 0.4) in ``srgb_rec709_scene`` lights as sRGB's decode of each channel, in ``lin_ap1_scene``
    (ACEScg) as its Rec.709 conversion, ... whether the space is the attribute's own, inherited from UsdColorSpaceAPI
    on an ancestor, or that of the rig input the colour reads. Every one was read as linear Rec.709."""
    scene, messages = load(light_stage(tmp_path, space, where))
    assert not messages, messages
    (light,) = scene.lights
    np.testing.assert_allclose(light.color, usd_linear_rec709(space, COLOR), rtol=1e-5, atol=1e-6)


def test_an_unauthored_light_colour_under_a_colour_space_stays_white(tmp_path):
    """The schema's fallback white is white in every space these convert from (their white points adapted to
    D65): no warning, no change."""
    path = str(tmp_path / "light.usda")
    stage = Usd.Stage.CreateNew(path)
    Usd.ColorSpaceAPI.Apply(stage.DefinePrim("/Rig", "Xform")).CreateColorSpaceNameAttr("lin_ap1_scene")
    UsdLux.DistantLight.Define(stage, "/Rig/Sun").CreateIntensityAttr(1.0)
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.lights[0].color, 1.0, rtol=1e-6)


@pytest.mark.parametrize("where", ["own", "ancestor"])
def test_a_light_colour_in_an_unknown_colour_space_is_named_and_read_as_linear(tmp_path, where):
    """A colour space neither USD nor MaterialX names is read as linear Rec.709, with a warning naming the light,
    its ``inputs:color`` and the space (and the prim that carries an inherited one)."""
    scene, messages = load(light_stage(tmp_path, "bogus_space", where))
    named = [m for m in messages if "'bogus_space'" in m and "inputs:color" in m and "/Rig/Sun" in m]
    assert len(named) == 1, messages
    if where == "ancestor":
        assert "UsdColorSpaceAPI on /Rig" in named[0]
    np.testing.assert_allclose(scene.lights[0].color, COLOR, rtol=1e-6)


def test_a_light_colour_outside_rec709s_gamut_is_clamped_with_a_warning(tmp_path):
    """ACEScg (0.9, 0.5, 0.2) in ``g22_ap1_scene`` has a negative blue in linear Rec.709 (USD's conversion): a light
    cannot take light away, so it is clamped to 0 with the warning a negative colour gets; the rest as USD's."""
    path = light_stage(tmp_path, "g22_ap1_scene", "own")
    stage = Usd.Stage.Open(path)
    UsdLux.DistantLight(stage.GetPrimAtPath("/Rig/Sun")).GetColorAttr().Set(Gf.Vec3f(0.9, 0.5, 0.2))
    stage.Save()
    expected = usd_linear_rec709("g22_ap1_scene", (0.9, 0.5, 0.2))
    assert expected[2] < 0.0 < expected[:2].min()
    scene, messages = load(path)
    assert any("negative light colour" in m and "/Rig/Sun" in m for m in messages), messages
    np.testing.assert_allclose(scene.lights[0].color, np.maximum(expected, 0.0), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("space", ["srgb_rec709_scene", "lin_ap1_scene"])
def test_a_white_plane_under_a_light_in_a_colour_space_renders_its_converted_colour(tmp_path, space):
    """A white Lambertian quad (displayColor 1) facing a DistantLight straight above it, rendered with the whitted
    integrator: the pixels' channels stand in the ratios of the light's colour converted by USD (``Gf``), not of
    the authored numbers."""
    path = light_stage(tmp_path, space, "own")
    stage = Usd.Stage.Open(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    quad = add_quad(stage, "/Quad", size=4.0)
    quad.CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
    stage.Save()
    scene, messages = load(path)
    assert not messages, messages
    camera = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    rgb = wrt.render(scene, camera=camera, width=2, height=2, device="cpu", integrator="whitted").rgb
    pixel = np.asarray(rgb, np.float64).reshape(-1, 3).mean(axis=0)
    expected = usd_linear_rec709(space, COLOR)
    np.testing.assert_allclose(pixel / pixel[1], expected / expected[1], rtol=1e-3)


def test_an_empty_colour_space_of_its_own_is_not_inherited_through(tmp_path):
    """``colorSpace = ""`` authored on the colour under an ``srgb_rec709_scene`` ``/Rig``: USD resolves an attribute
    with a ``colorSpace`` of its own to that one, the empty one (linear Rec.709) too, without asking its prims. It
    was decoded by /Rig's sRGB."""
    path = light_stage(tmp_path, "srgb_rec709_scene", "ancestor")
    stage = Usd.Stage.Open(path)
    color = UsdLux.DistantLight(stage.GetPrimAtPath("/Rig/Sun")).GetColorAttr()
    color.SetColorSpace("")
    stage.Save()
    resolved = Usd.ColorSpaceAPI.ComputeColorSpaceName(color, None) or Gf.ColorSpaceNames.LinearRec709
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.lights[0].color, usd_linear_rec709(resolved, COLOR), rtol=1e-5, atol=1e-6)


SHADOW = (0.6, 0.5, 0.2)  # a tint inside Rec.709's gamut from each space below


@pytest.mark.parametrize("where", ["own", "ancestor"])
@pytest.mark.parametrize("space", ["srgb_rec709_scene", "lin_ap1_scene", "g22_rec709_scene"])
def test_a_shadow_colour_is_read_in_its_colour_space(tmp_path, space, where):
    """ShadowAPI's ``inputs:shadow:color`` (color3f, a colour value as ``inputs:color`` is) of (0.6, 0.5, 0.2) in
    ``space``, its own or through ``UsdColorSpaceAPI`` on ``/Rig``: the light's shadow tint is that colour as USD
    resolves its space (``ComputeColorSpaceName``) and converts it to linear Rec.709 (``Gf.ColorSpace``). It was read
    as linear Rec.709 whatever its space, while the light's own colour beside it was converted."""
    path = light_stage(tmp_path, space, where)
    stage = Usd.Stage.Open(path)
    shadow = stage.GetPrimAtPath("/Rig/Sun").CreateAttribute("inputs:shadow:color", Sdf.ValueTypeNames.Color3f)
    shadow.Set(Gf.Vec3f(*SHADOW))
    if where == "own":
        shadow.SetColorSpace(space)
    stage.Save()
    resolved = Usd.ColorSpaceAPI.ComputeColorSpaceName(shadow, None)
    assert resolved == space
    scene, messages = load(path)
    assert not messages, messages
    np.testing.assert_allclose(scene.lights[0].shadow_color, usd_linear_rec709(resolved, SHADOW), rtol=1e-5,
                               atol=1e-6)


def test_a_shadow_colour_outside_rec709s_gamut_is_clamped_with_a_warning(tmp_path):
    """ACEScg (0.9, 0.5, 0.2) as a shadow tint has a negative blue in linear Rec.709 (USD's conversion): clamped to 0
    with a warning naming the light, as a light colour's is, the rest of the tint kept."""
    path = light_stage(tmp_path, "g22_ap1_scene", "ancestor")
    stage = Usd.Stage.Open(path)
    shadow = stage.GetPrimAtPath("/Rig/Sun").CreateAttribute("inputs:shadow:color", Sdf.ValueTypeNames.Color3f)
    shadow.Set(Gf.Vec3f(0.9, 0.5, 0.2))
    stage.Save()
    expected = usd_linear_rec709("g22_ap1_scene", (0.9, 0.5, 0.2))
    assert expected[2] < 0.0 < expected[:2].min()
    scene, messages = load(path)
    assert any("shadow" in m and "gamut" in m and "/Rig/Sun" in m for m in messages), messages
    np.testing.assert_allclose(scene.lights[0].shadow_color, np.maximum(expected, 0.0), rtol=1e-5, atol=1e-6)
