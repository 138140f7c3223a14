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


def native_stage(tmp_path):
    """Instances of a class /Asset (cubes of render, default and proxy purpose; one render cube under an Xform
    whose renderVisibility = visible re-opens it) under opinions on and above them, one instance nested in another's
    prototype, a PointInstancer in the prototype whose prototype cube is of render purpose, and instances of render
    purpose (/Group/RI, /Plain/RI, /Hider/RK), whose default cube is then of render purpose too."""
    path = str(tmp_path / "native.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.CreateClassPrim("/Asset")
    UsdGeom.Cube.Define(stage, "/Asset/R").CreatePurposeAttr("render")
    UsdGeom.Cube.Define(stage, "/Asset/D")
    UsdGeom.Cube.Define(stage, "/Asset/P").CreatePurposeAttr("proxy")
    opened = UsdGeom.Xform.Define(stage, "/Asset/Open")
    UsdGeom.VisibilityAPI.Apply(opened.GetPrim()).CreateRenderVisibilityAttr("visible")
    UsdGeom.Cube.Define(stage, "/Asset/Open/R2").CreatePurposeAttr("render")
    pi = UsdGeom.PointInstancer.Define(stage, "/Asset/PI")
    UsdGeom.Cube.Define(stage, "/Asset/PI/Protos/R3").CreatePurposeAttr("render")
    pi.CreatePrototypesRel().SetTargets(["/Asset/PI/Protos/R3"])
    pi.CreateProtoIndicesAttr([0])
    pi.CreatePositionsAttr([(0, 0, 0)])
    stage.CreateClassPrim("/Kit")
    nested = stage.DefinePrim("/Kit/Inner", "Xform")
    nested.GetReferences().AddInternalReference("/Asset")
    nested.SetInstanceable(True)
    for name, opinion in [("/Group", "invisible"), ("/Group/Sub", "visible"), ("/Self", None), ("/Plain", None),
                          ("/Hider", "invisible")]:
        prim = UsdGeom.Xform.Define(stage, name).GetPrim()
        if opinion is not None:
            UsdGeom.VisibilityAPI.Apply(prim).CreateRenderVisibilityAttr(opinion)
    for name, source in [("/Group/I", "/Asset"), ("/Group/Sub/I", "/Asset"), ("/Self/I", "/Asset"),
                         ("/Plain/I", "/Asset"), ("/Hider/K", "/Kit"), ("/Plain/K", "/Kit"), ("/Group/RI", "/Asset"),
                         ("/Plain/RI", "/Asset"), ("/Hider/RK", "/Kit")]:
        instance = stage.DefinePrim(name, "Xform")
        instance.GetReferences().AddInternalReference(source)
        instance.SetInstanceable(True)
        if name.split("/")[-1].startswith("R"):  # of render purpose: the prims inside without one inherit it
            UsdGeom.Imageable(instance).CreatePurposeAttr("render")
    UsdGeom.VisibilityAPI.Apply(stage.GetPrimAtPath("/Self/I")).CreateRenderVisibilityAttr("invisible")
    stage.Save()
    return path, stage


def test_opinions_on_and_above_native_instances_reach_the_prims_inside(tmp_path):
    """USD computes a proxy's purpose visibility through its instance and the instance's ancestors; wrt read each
    prototype once and drew every render cube of every instance (with a warning). Oracle: the instance proxies' (and
    the PointInstancer prototype's) ComputeEffectiveVisibility."""
    path, stage = native_stage(tmp_path)
    predicate = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimIsDefined & ~Usd.PrimIsAbstract)
    expected = set()
    for prim in stage.Traverse(predicate):
        img = UsdGeom.Imageable(prim)
        if prim.IsA(UsdGeom.Cube) and img.ComputePurpose() in ("default", "render") and \
                img.ComputeEffectiveVisibility(img.ComputePurpose()) != UsdGeom.Tokens.invisible:
            expected.add(str(prim.GetPath()))
    assert "/Group/I/R" not in expected and "/Group/I/Open/R2" in expected and "/Self/I/PI/Protos/R3" not in expected
    assert "/Group/RI/D" not in expected and "/Plain/RI/D" in expected and "/Hider/RK/Inner/D" not in expected
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    assert set(scene.prim_paths()) == expected


def test_a_point_instancer_hidden_for_its_purpose_draws_no_instance_of_a_prototype_outside_it(tmp_path):
    """A PointInstancer of render purpose under renderVisibility = invisible, its prototype under an invisible /Protos
    (no purpose of its own: it takes the instancer's, as UsdImaging gives it): the instancer is invisible for its
    purpose, as ComputeEffectiveVisibility says, and an instancer that is not drawn draws no instance; wrt drew them
    (the prototype's own ancestors have no opinion). The one outside the opinion is drawn."""
    path = str(tmp_path / "pi_outside.usda")
    stage = Usd.Stage.CreateNew(path)
    world = UsdGeom.Xform.Define(stage, "/World")
    UsdGeom.VisibilityAPI.Apply(world.GetPrim()).CreateRenderVisibilityAttr("invisible")
    UsdGeom.Scope.Define(stage, "/Protos").MakeInvisible()
    instancers = {}
    for name, proto in [("/World/PI", "/Protos/C"), ("/Shown/PI", "/Protos/V")]:
        UsdGeom.Cube.Define(stage, proto)
        pi = instancers[name] = UsdGeom.PointInstancer.Define(stage, name)
        pi.CreatePurposeAttr("render")
        pi.CreatePrototypesRel().SetTargets([proto])
        pi.CreateProtoIndicesAttr([0])
        pi.CreatePositionsAttr([(0, 0, 0)])
    stage.Save()
    expected = sorted(str(pi.GetPrototypesRel().GetTargets()[0]) for pi in instancers.values()
                      if pi.ComputeEffectiveVisibility(pi.ComputePurpose()) != UsdGeom.Tokens.invisible)
    assert expected == ["/Protos/V"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    assert sorted(scene.prim_paths()) == expected


# case -> opinions on its /Cases/<case> PointInstancer (PI), the prototypes scope (Protos, invisible in every case),
# the prototype root Xform (Root) and the Xform (Inner) over the cube without a purpose: (purpose, renderVisibility)
PROTOTYPE_CASES = {
    "ScopeRender": {"Protos": ("render", "invisible")},
    "ScopeRenderRootHides": {"Protos": ("render", None), "Root": (None, "invisible")},
    "InstancerRender": {"PI": ("render", None), "Protos": (None, "invisible")},
    "InstancerRenderInnerHides": {"PI": ("render", None), "Inner": (None, "invisible")},
    "Reopened": {"Protos": ("render", "invisible"), "Inner": (None, "visible")},
    "InstancerRenderOnly": {"PI": ("render", None)},
    "ScopeProxy": {"Protos": ("proxy", None)},
    "Plain": {},
}


def test_a_purpose_inherited_from_above_a_prototype_meets_the_purpose_visibility_inside_and_above_it(tmp_path):
    """A PointInstancer prototype's cube without a purpose inherits render from the prototypes scope or the
    instancer, and renderVisibility = invisible on the scope, the prototype root or an Xform inside hides it, as
    ``ComputeEffectiveVisibility('render')`` says; wrt read the prototype with its prims of default purpose, which no
    purpose visibility hides, and drew them (unless the opinion sat on or above the instancer). The scope is invisible
    in every case, the common authoring pattern: its prototypes are still instanced, so the oracle is USD's answer
    with the scope made visible in a session layer."""
    path = str(tmp_path / "inherited_purpose.usda")
    stage = Usd.Stage.CreateNew(path)
    for case, opinions in PROTOTYPE_CASES.items():
        base = f"/Cases/{case}/PI"
        pi = UsdGeom.PointInstancer.Define(stage, base)
        prims = {"PI": pi, "Protos": UsdGeom.Scope.Define(stage, f"{base}/Protos"),
                 "Root": UsdGeom.Xform.Define(stage, f"{base}/Protos/Root"),
                 "Inner": UsdGeom.Xform.Define(stage, f"{base}/Protos/Root/Inner")}
        UsdGeom.Cube.Define(stage, f"{base}/Protos/Root/Inner/Cube")
        prims["Protos"].MakeInvisible()
        for name, (purpose, render_visibility) in opinions.items():
            if purpose is not None:
                prims[name].CreatePurposeAttr(purpose)
            if render_visibility is not None:
                UsdGeom.VisibilityAPI.Apply(prims[name].GetPrim()).CreateRenderVisibilityAttr(render_visibility)
        pi.CreatePrototypesRel().SetTargets([f"{base}/Protos/Root"])
        pi.CreateProtoIndicesAttr([0])
        pi.CreatePositionsAttr([(0, 0, 0)])
    stage.Save()
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        for case in PROTOTYPE_CASES:
            UsdGeom.Imageable(stage.GetPrimAtPath(f"/Cases/{case}/PI/Protos")).MakeVisible()
    expected = set()
    for case in PROTOTYPE_CASES:
        img = UsdGeom.Imageable(stage.GetPrimAtPath(f"/Cases/{case}/PI/Protos/Root/Inner/Cube"))
        purpose = img.ComputePurpose()
        if purpose in ("default", "render") and img.ComputeEffectiveVisibility(purpose) != UsdGeom.Tokens.invisible:
            expected.add(str(img.GetPath()))
    assert {p.split("/")[2] for p in expected} == {"Reopened", "InstancerRenderOnly", "Plain"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    assert set(scene.prim_paths()) == expected


def test_an_instance_purpose_meets_the_purpose_visibility_inside_its_prototype(tmp_path):
    """Native instances of render purpose of a class whose Xform has renderVisibility = invisible over a cube without
    a purpose: the cube's instance proxies inherit render and are hidden, as their ComputeEffectiveVisibility says;
    wrt read the prototype with the cube of default purpose and drew it in every instance. An instance of default
    purpose draws it."""
    path = str(tmp_path / "native_inner.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.CreateClassPrim("/Asset")
    hider = UsdGeom.Xform.Define(stage, "/Asset/Hider")
    UsdGeom.VisibilityAPI.Apply(hider.GetPrim()).CreateRenderVisibilityAttr("invisible")
    UsdGeom.Cube.Define(stage, "/Asset/Hider/Cube")
    for name in ("/R0", "/R1", "/D"):
        instance = UsdGeom.Xform.Define(stage, name)
        instance.GetPrim().GetReferences().AddInternalReference("/Asset")
        instance.GetPrim().SetInstanceable(True)
        if name.startswith("/R"):
            instance.CreatePurposeAttr("render")
    stage.Save()
    expected = set()
    for prim in stage.Traverse(Usd.TraverseInstanceProxies()):
        img = UsdGeom.Imageable(prim)
        if prim.IsA(UsdGeom.Cube) and img.ComputeEffectiveVisibility(img.ComputePurpose()) != "invisible":
            expected.add(str(prim.GetPath()))
    assert expected == {"/D/Hider/Cube"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    assert set(scene.prim_paths()) == expected
