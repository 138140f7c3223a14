"""``UsdGeomVisibilityAPI``'s purpose visibility (``renderVisibility``, ``proxyVisibility``, ``guideVisibility``): a
prim of a drawn purpose other than default is hidden where its nearest authored opinion for that purpose is
``invisible``, as ``UsdGeomImageable.ComputeEffectiveVisibility(purpose)`` computes it (an opinion counts only on a
prim with the API applied; ``visible`` or ``inherited`` nearer re-opens). The oracle is that USD call."""

from __future__ import annotations

import warnings

import pytest

pxr = pytest.importorskip("pxr")
from pxr import Sdf, Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402

# path -> purpose of the cubes, and prim -> (purpose visibility attribute, value) opinions (VisibilityAPI applied)
CUBES = {"/World/R1": "render", "/World/Sub/R2": "render", "/World/Sub/D": "default", "/World/P": "proxy",
         "/Other/P2": "proxy", "/Other/R3": "render", "/Hidden/R4": "render", "/Unapplied/R5": "render",
         "/Guides/G1": "guide", "/Guides/Open/G2": "guide", "/Typeless/R6": "render"}
OPINIONS = {"/World": ("render", "invisible"), "/World/Sub": ("render", "visible"), "/Other": ("proxy", "invisible"),
            "/Hidden": ("render", "visible"), "/Guides": ("guide", "invisible"), "/Guides/Open": ("guide", "visible"),
            "/Typeless": ("render", "invisible")}


def purpose_stage(tmp_path, included=None):
    path = str(tmp_path / "purpose_visibility.usda")
    stage = Usd.Stage.CreateNew(path)
    for name in OPINIONS.keys() | {"/Unapplied"}:
        if name != "/Typeless":  # (USD reads visibility opinions on imageable prims only)
            UsdGeom.Xform.Define(stage, name)
    for name, purpose in CUBES.items():
        cube = UsdGeom.Cube.Define(stage, name)
        if purpose != "default":
            cube.CreatePurposeAttr(purpose)
    for name, (purpose, value) in OPINIONS.items():
        api = UsdGeom.VisibilityAPI.Apply(stage.GetPrimAtPath(name))
        {"render": api.CreateRenderVisibilityAttr, "proxy": api.CreateProxyVisibilityAttr,
         "guide": api.CreateGuideVisibilityAttr}[purpose](value)
    UsdGeom.Imageable(stage.GetPrimAtPath("/Hidden")).MakeInvisible()
    # Authored without the API applied: USD reads no opinion there.
    stage.GetPrimAtPath("/Unapplied").CreateAttribute("renderVisibility", Sdf.ValueTypeNames.Token,
                                                      variability=Sdf.VariabilityUniform).Set("invisible")
    if included is not None:
        settings = stage.DefinePrim("/Render/S", "RenderSettings")
        settings.CreateAttribute("includedPurposes", Sdf.ValueTypeNames.TokenArray,
                                 variability=Sdf.VariabilityUniform).Set(included)
        stage.SetMetadata("renderSettingsPrimPath", "/Render/S")
    stage.Save()
    return path, stage


def drawn_by_usd(stage, drawn_purposes):
    """The cubes USD's effective visibility shows, among those of a drawn purpose. A guide with no opinion is
    ``invisible`` by the schema's fallback; wrt draws guides where the render settings ask for them and hides them
    only by an authored ``invisible``, so guides are compared where some opinion is authored above them."""
    shown = []
    for name in CUBES:
        img = UsdGeom.Imageable(stage.GetPrimAtPath(name))
        purpose = img.ComputePurpose()
        if purpose in drawn_purposes and img.ComputeEffectiveVisibility(purpose) != UsdGeom.Tokens.invisible:
            shown.append(name)
    return sorted(shown)


@pytest.mark.parametrize("included", [None, ["render"], ["proxy"], ["render", "guide"]])
def test_purpose_visibility_hides_prims_of_that_purpose(tmp_path, included):
    """renderVisibility = invisible on /World hid nothing (wrt did not read the API): /World/R1 was drawn."""
    path, stage = purpose_stage(tmp_path, included)
    drawn_purposes = {"default", *(included if included is not None else ["render"])}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    assert sorted(s.path for s in scene.shapes) == drawn_by_usd(stage, drawn_purposes)


def test_a_point_instancer_prototype_follows_its_own_purpose_visibility(tmp_path):
    """A prototype of render purpose under a renderVisibility = invisible scope: its instances are not drawn, as
    ``ComputeEffectiveVisibility('render')`` on the prototype's prim says; its sibling of default purpose is."""
    path = str(tmp_path / "pi.usda")
    stage = Usd.Stage.CreateNew(path)
    protos = UsdGeom.Scope.Define(stage, "/PI/Protos")
    UsdGeom.VisibilityAPI.Apply(protos.GetPrim()).CreateRenderVisibilityAttr("invisible")
    render = UsdGeom.Cube.Define(stage, "/PI/Protos/R")
    render.CreatePurposeAttr("render")
    UsdGeom.Cube.Define(stage, "/PI/Protos/D")
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets([render.GetPath(), "/PI/Protos/D"])
    pi.CreateProtoIndicesAttr([0, 1])
    pi.CreatePositionsAttr([(0, 0, 0), (3, 0, 0)])
    stage.Save()
    assert UsdGeom.Imageable(render).ComputeEffectiveVisibility("render") == UsdGeom.Tokens.invisible
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    drawn = sorted(shape.path for proto in scene.prototypes for shape in proto.shapes)
    assert drawn == ["/PI/Protos/D"]


def test_an_opinion_above_a_native_instance_is_named_in_a_warning(tmp_path):
    """Inside a native prototype the opinions on and above its instance are not applied (wrt reads a prototype once
    for all instances): a warning names the instance rather than drawing it silently."""
    path = str(tmp_path / "native.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.CreateClassPrim("/Asset")
    UsdGeom.Cube.Define(stage, "/Asset/R").CreatePurposeAttr("render")
    group = UsdGeom.Xform.Define(stage, "/Group")
    UsdGeom.VisibilityAPI.Apply(group.GetPrim()).CreateRenderVisibilityAttr("invisible")
    instance = stage.DefinePrim("/Group/I", "Xform")
    instance.GetReferences().AddInternalReference("/Asset")
    instance.SetInstanceable(True)
    stage.Save()
    with pytest.warns(UserWarning, match=r"renderVisibility.*native instances.*/Group/I"):
        wrt.load_usd(path)
