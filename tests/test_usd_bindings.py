"""The material and colours of every triangle ``wrt.load_usd`` draws, checked against USD's own answers
(``UsdShade.MaterialBindingAPI.ComputeBoundMaterial``, ``UsdGeom.PrimvarsAPI.FindPrimvarWithInheritance``, on
instance proxies for native instances): random stages of every kind of binding and colour primvar
(:mod:`binding_stages`, :mod:`binding_oracle`), and the cases they found by hand. ``WRT_BINDING_SEEDS=n`` runs
seeds 0 .. n-1 instead of the fixed ones."""

from __future__ import annotations

import collections
import glob
import os
import re
import warnings

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

pxr = pytest.importorskip("pxr")
import warp.examples  # noqa: E402
from binding_oracle import compare, face_material, material_key, rendered_rows  # noqa: E402
from binding_stages import preview_material, tint_material, write_stage  # noqa: E402
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdShade, Vt  # noqa: E402

import wrt  # noqa: E402

# Each fails on the commit before one fix: 13 and 36 bind a purpose on or above a native instance that an all-purpose
# binding, or one to a missing prim, inside its prototype lost or won against (wrt.usd_bindings' walks); 41 inherits
# two colour primvars through an instance, of which only the first reached its prototype; 37 blocks an instance's
# displayOpacity with a non-constant one inside; 6 and 22 bind collections that hold some of an instance's proxies;
# 0 binds a collection for a purpose (material:binding:collection:full:name), whose purpose was read as all-purpose
# (the stages named such bindings as USD does not until then, so none was one to USD).
# WRT_BINDING_SEEDS=400 passes (28 of the first 100 failed before these fixes).
SEEDS = (range(int(os.environ["WRT_BINDING_SEEDS"])) if "WRT_BINDING_SEEDS" in os.environ
         else (0, 6, 13, 22, 36, 37, 41))
WARP_ASSETS = sorted(glob.glob(os.path.join(warp.examples.get_asset_directory(), "*.usd")))


def load(path: str) -> wrt.Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # MDL looks, missing materials, overlapping subsets: as designed
        return wrt.load_usd(path)


@pytest.mark.parametrize("seed", SEEDS)
def test_random_stage_matches_usd(tmp_path, seed):
    path = write_stage(str(tmp_path), seed)
    assert compare(Usd.Stage.Open(path), load(path)) == []


@pytest.mark.parametrize("path", WARP_ASSETS, ids=os.path.basename)
def test_warp_example_asset_matches_usd(path):
    assert compare(Usd.Stage.Open(path), load(path)) == []


def _inner_and_outer(stage):
    """Materials /Looks/Inner (red) and /Looks/Outer (green): bound inside a prototype and above its instances."""
    return preview_material(stage, "/Looks/Inner", (1, 0, 0)), preview_material(stage, "/Looks/Outer", (0, 1, 0))


def _quads(stage, path, n=2):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(i, y, 0) for i in range(n + 1) for y in (0, 1)])
    mesh.CreateFaceVertexCountsAttr([4] * n)
    mesh.CreateFaceVertexIndicesAttr([v for i in range(n) for v in (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1)])
    return mesh.GetPrim()


def _bind(prim, material, purpose=""):
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material, materialPurpose=purpose or UsdShade.Tokens.allPurpose)


def _drawn_materials(scene) -> dict:
    """``{(prim path, face): material path or ""}`` of what ``scene`` draws."""
    names = [m.path for m in scene.materials]
    ids = scene.triangle_materials()
    return {(path, face): names[ids[g] - 1] if ids[g] > 0 else "" for path, face, g, _ in rendered_rows(scene)}


def _usd_materials(stage, drawn) -> dict:
    """The material of each face of ``drawn`` by ``ComputeBoundMaterial`` under wrt's rule
    (:func:`binding_oracle.bound`: ``full``, else a ``preview`` UsdPreviewSurface; a subset's on its faces)."""
    return {(path, face): material_key(face_material(stage.GetPrimAtPath(path), face)) for path, face in drawn}


@pytest.mark.parametrize("inside", ["all-purpose", "subset", "preview", "nested"])
def test_purpose_binding_on_an_instance_beats_other_purposes_inside_its_prototype(tmp_path, inside):
    """USD walks a binding purpose from the prim to the root before it falls back to all-purpose bindings, so a
    ``material:binding:full`` on a native instance wins over an all-purpose binding inside its prototype (on the
    mesh, or on a ``materialBind`` subset); wrt resolved the prototype on its own and drew the inner one (and an
    inner preview binding, its fallback, over the instance's full one)."""
    path = str(tmp_path / "instance.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    stage.DefinePrim("/Protos/P", "Xform")
    mesh = _quads(stage, "/Protos/P/Mesh")
    if inside == "subset":
        subset = UsdShade.MaterialBindingAPI.Apply(mesh).CreateMaterialBindSubset("sub", [0], UsdGeom.Tokens.face)
        _bind(subset.GetPrim(), inner)
    else:
        _bind(mesh, inner, "preview" if inside == "preview" else "")
    root = "/Protos/P"
    if inside == "nested":  # the mesh in an instance inside the prototype of the instance that binds
        stage.DefinePrim("/Protos/Q", "Xform")
        nested = stage.DefinePrim("/Protos/Q/Inner", "Xform")
        nested.GetReferences().AddInternalReference("/Protos/P")
        nested.SetInstanceable(True)
        root = "/Protos/Q"
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    for name, binds in (("Bound", True), ("Plain", False)):  # one prototype, two instances
        instance = stage.DefinePrim(f"/World/{name}", "Xform")
        instance.GetReferences().AddInternalReference(root)
        instance.SetInstanceable(True)
        if binds:
            _bind(instance, outer, "full")
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    expected = _usd_materials(Usd.Stage.Open(path), drawn)
    bound = [key for key in expected if key[0].startswith("/World/Bound")]
    assert bound and all(expected[key] == "/Looks/Outer" for key in bound)  # the case is what it says
    assert drawn == expected


def test_stronger_binding_above_an_instance_beats_its_prototype_and_weaker_one_does_not(tmp_path):
    """``strongerThanDescendants`` above an instance wins over every binding inside it; a weaker one of the same
    purpose only where nothing inside binds (as ``ComputeBoundMaterial`` on the proxies)."""
    path = str(tmp_path / "strength.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    stage.DefinePrim("/Protos/P", "Xform")
    _bind(_quads(stage, "/Protos/P/Bound"), inner)
    _quads(stage, "/Protos/P/Unbound")
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    for name, strength in (("Strong", UsdShade.Tokens.strongerThanDescendants),
                           ("Weak", UsdShade.Tokens.weakerThanDescendants)):
        group = stage.DefinePrim(f"/World/{name}", "Xform")
        UsdShade.MaterialBindingAPI.Apply(group).Bind(outer, bindingStrength=strength)
        instance = stage.DefinePrim(f"/World/{name}/I", "Xform")
        instance.GetReferences().AddInternalReference("/Protos/P")
        instance.SetInstanceable(True)
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    expected = _usd_materials(Usd.Stage.Open(path), drawn)
    assert expected[("/World/Weak/I/Bound", 0)] == "/Looks/Inner"
    assert expected[("/World/Strong/I/Bound", 0)] == "/Looks/Outer"
    assert drawn == expected
    assert np.all(np.array([v for v in drawn.values()]) != "")


@pytest.mark.parametrize("direct", ["stronger", "weaker"])
def test_a_weaker_collection_beside_a_stronger_direct_binding_above_an_instance_beats_its_prototype(tmp_path, direct):
    """On one prim ``ComputeBoundMaterial`` asks the direct binding first, then takes a collection binding that holds
    the prim over a direct binding won there: a weaker collection binding on a group beside its
    ``strongerThanDescendants`` direct binding wins over the binding inside the group's instances (beside a weaker
    direct binding it does not). wrt read the collection's own strength and drew the prototype's material in the
    instance, where a plain copy of it drew the collection's."""
    path = str(tmp_path / "beside.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    held = preview_material(stage, "/Looks/Held", (0, 0, 1))
    stage.DefinePrim("/Protos/P", "Xform")
    _bind(_quads(stage, "/Protos/P/Bound", 1), inner)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    group = stage.DefinePrim("/World/G", "Xform")
    binding = UsdShade.MaterialBindingAPI.Apply(group)
    binding.Bind(outer, bindingStrength=getattr(UsdShade.Tokens, f"{direct}ThanDescendants"))
    collection = Usd.CollectionAPI.Apply(group, "held")
    for name, instanceable in (("Instance", True), ("Plain", False)):
        prim = stage.DefinePrim(f"/World/G/{name}", "Xform")
        prim.GetReferences().AddInternalReference("/Protos/P")
        prim.SetInstanceable(instanceable)
        collection.GetIncludesRel().AddTarget(prim.GetPath())
    binding.Bind(collection, held, "held")
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    expected = _usd_materials(Usd.Stage.Open(path), drawn)
    looks = "/Looks/Held" if direct == "stronger" else "/Looks/Inner"
    assert expected == {("/World/G/Instance/Bound", 0): looks, ("/World/G/Plain/Bound", 0): looks}
    assert drawn == expected


@pytest.mark.parametrize("target", ["/Looks/Missing", "/World"])
def test_binding_to_no_material_inside_a_prototype_hides_the_instances_binding(tmp_path, target):
    """A binding to a prim that does not exist or is no Material is a binding all the same for USD: it wins over a
    weaker binding above it, and the prim has no material. wrt took it for no binding inside a prototype and drew
    the instance's material there."""
    path = str(tmp_path / "no_material.usda")
    stage = Usd.Stage.CreateNew(path)
    outer = preview_material(stage, "/Looks/Outer", (0, 1, 0))
    stage.DefinePrim("/Protos/P", "Xform")
    mesh = _quads(stage, "/Protos/P/Mesh")
    UsdShade.MaterialBindingAPI.Apply(mesh).GetDirectBindingRel().SetTargets([Sdf.Path(target)])
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    instance = stage.DefinePrim("/World/I", "Xform")
    instance.GetReferences().AddInternalReference("/Protos/P")
    instance.SetInstanceable(True)
    _bind(instance, outer)
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    assert drawn == _usd_materials(Usd.Stage.Open(path), drawn) == {("/World/I/Mesh", 0): "", ("/World/I/Mesh", 1): ""}


def _constant_color(prim, name, rgb):
    primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant)
    primvar.Set([Gf.Vec3f(*rgb)])


def test_an_instance_hands_down_every_colour_primvar_its_prototype_lacks(tmp_path):
    """A prototype whose plain mesh lacks displayColor and whose mesh bound to a material reading ``tint`` lacks
    ``tint``: an instance authoring both colours each (FindPrimvarWithInheritance on the proxies finds them); wrt
    handed down only the first name its prototype wanted, and the other mesh drew none."""
    path = str(tmp_path / "two_colors.usda")
    stage = Usd.Stage.CreateNew(path)
    tint = tint_material(stage, "/Looks/Tint")
    stage.DefinePrim("/Protos/P", "Xform")
    _bind(_quads(stage, "/Protos/P/Tinted", 1), tint)
    _quads(stage, "/Protos/P/Plain", 1)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    instance = stage.DefinePrim("/World/I", "Xform")
    instance.GetReferences().AddInternalReference("/Protos/P")
    instance.SetInstanceable(True)
    _constant_color(instance, "displayColor", (0.25, 0.5, 0.75))
    _constant_color(instance, "tint", (0.9, 0.1, 0.2))
    stage.GetRootLayer().Save()
    scene = load(path)
    stage = Usd.Stage.Open(path)
    colors = scene.corner_attributes()[1]
    for proxy, name in (("/World/I/Plain", "displayColor"), ("/World/I/Tinted", "tint")):
        rows = [g for p, _, g, _ in rendered_rows(scene) if p == proxy]
        want = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(proxy)).FindPrimvarWithInheritance(name).Get()[0]
        np.testing.assert_allclose(colors[rows].reshape(-1, 3), np.tile(np.array(want), (3 * len(rows), 1)),
                                   rtol=1e-6)
    assert compare(stage, scene) == []


@pytest.mark.parametrize("name", ["displayColor", "displayOpacity"])
def test_a_non_constant_primvar_inside_a_prototype_blocks_the_instances(tmp_path, name):
    """USD's primvar inheritance stops at a non-constant primvar on an ancestor (FindPrimvarWithInheritance gives
    none), inside a prototype too: the instance's constant one does not reach the mesh below it. wrt handed the
    instance's colour (and opacity) down to it."""
    path = str(tmp_path / "blocked.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.DefinePrim("/Protos/P", "Xform")
    group = stage.DefinePrim("/Protos/P/G", "Xform")
    _quads(stage, "/Protos/P/G/Mesh", 1)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    instance = stage.DefinePrim("/World/I", "Xform")
    instance.GetReferences().AddInternalReference("/Protos/P")
    instance.SetInstanceable(True)
    type_name = Sdf.ValueTypeNames.FloatArray if name == "displayOpacity" else Sdf.ValueTypeNames.Color3fArray
    value = [0.5] if name == "displayOpacity" else [Gf.Vec3f(1, 0, 0)]
    UsdGeom.PrimvarsAPI(instance).CreatePrimvar(name, type_name, UsdGeom.Tokens.constant).Set(value)
    UsdGeom.PrimvarsAPI(group).CreatePrimvar(name, type_name, UsdGeom.Tokens.uniform).Set(value)
    stage.GetRootLayer().Save()
    stage = Usd.Stage.Open(path)
    assert not UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/I/G/Mesh")).FindPrimvarWithInheritance(name)
    assert compare(stage, load(path)) == []


@pytest.mark.parametrize("members", ["one proxy", "the instance alone", "all but one proxy",
                                     "one proxy, the material targeted first"])
def test_a_collection_binding_that_names_instance_proxies_binds_them(tmp_path, members):
    """A collection bound above native instances may hold some of their proxies and not others
    (``ComputeBoundMaterial`` asks the collection about each proxy's path): only the named proxy
    takes the material, an ``explicitOnly`` instance binds none of its proxies, an excluded proxy keeps the
    prototype's own binding. wrt asked about the instance prim and bound all of its prims, or none. A binding whose
    relationship targets the material before the collection is the same binding to USD (it tells the two by their
    path kinds); wrt took its first target for the collection, found none, and bound none of the proxies."""
    path = str(tmp_path / "collection.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    stage.DefinePrim("/Protos/P", "Xform")
    _bind(_quads(stage, "/Protos/P/A"), inner)
    _quads(stage, "/Protos/P/B")
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    world = stage.DefinePrim("/World", "Xform")
    for name in ("I", "J"):
        instance = stage.DefinePrim(f"/World/{name}", "Xform")
        instance.GetReferences().AddInternalReference("/Protos/P")
        instance.SetInstanceable(True)
    collection = Usd.CollectionAPI.Apply(world, "looks")
    if members.startswith("one proxy"):
        collection.GetIncludesRel().AddTarget("/World/I/A")
    elif members == "the instance alone":
        collection.CreateExpansionRuleAttr(Usd.Tokens.explicitOnly)
        collection.GetIncludesRel().AddTarget("/World/I")
    else:
        collection.GetIncludesRel().AddTarget("/World/I")
        collection.GetExcludesRel().AddTarget("/World/I/B")
    UsdShade.MaterialBindingAPI.Apply(world).Bind(collection, outer, "looks",
                                                  UsdShade.Tokens.strongerThanDescendants)
    if members.endswith("first"):
        rel = world.GetRelationship("material:binding:collection:looks")
        rel.SetTargets(list(reversed(rel.GetTargets())))
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    expected = _usd_materials(Usd.Stage.Open(path), drawn)
    assert drawn == expected
    assert {expected["/World/J/A", 0], expected["/World/J/B", 0]} == {"/Looks/Inner", ""}  # J: its own bindings


def test_material_binding_purposes_walk_through_an_instance(tmp_path):
    """Under the render settings' ``materialBindingPurposes = ["preview", ""]`` a preview binding on a native
    instance wins over an all-purpose binding inside its prototype, as ``ComputeBoundMaterial("preview")`` on the
    proxy gives (the purposes' order as the README gives it; the prototype was resolved on its own before)."""
    from pxr import UsdRender

    path = str(tmp_path / "purposes.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    stage.DefinePrim("/Protos/P", "Xform")
    _bind(_quads(stage, "/Protos/P/Mesh", 1), inner)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    instance = stage.DefinePrim("/World/I", "Xform")
    instance.GetReferences().AddInternalReference("/Protos/P")
    instance.SetInstanceable(True)
    _bind(instance, outer, "preview")
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateMaterialBindingPurposesAttr(["preview", ""])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    stage = Usd.Stage.Open(path)
    proxy = stage.GetPrimAtPath("/World/I/Mesh")
    want = UsdShade.MaterialBindingAPI(proxy).ComputeBoundMaterial(UsdShade.Tokens.preview)[0].GetPath()
    assert str(want) == "/Looks/Outer"
    assert drawn == {("/World/I/Mesh", 0): "/Looks/Outer"}


def _bind_collection(holder, members, material, purpose):
    """A collection on ``holder`` of ``members`` bound to ``material`` for ``purpose`` through USD's own API, which
    names the relationship ``material:binding:collection:<purpose>:<name>``."""
    collection = Usd.CollectionAPI.Apply(holder, "looks")
    for member in members:
        collection.GetIncludesRel().AddTarget(member)
    UsdShade.MaterialBindingAPI.Apply(holder).Bind(collection, material, "looks",
                                                   UsdShade.Tokens.weakerThanDescendants, purpose)
    assert holder.GetRelationship(f"material:binding:collection:{purpose}:looks")


@pytest.mark.parametrize("purpose", ["full", "preview"])
def test_a_purpose_collection_binding_above_an_instance_beats_an_all_purpose_one_inside(tmp_path, purpose):
    """A collection bound for a purpose (``material:binding:collection:full:looks``) above a native instance wins
    over an all-purpose binding inside its prototype, as ``ComputeBoundMaterial`` on the proxy says (``full``; the
    ``preview`` one where the full walk finds an MDL look wrt cannot read). wrt took the purpose of such a binding
    for all-purpose (the ``collection`` part of its name), so the instance's walk found no binding of the purpose and
    the prototype's inner look was drawn."""
    path = str(tmp_path / "collection_purpose.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    if purpose == "preview":  # the inner look is one wrt cannot read: the preview binding is drawn instead
        inner = UsdShade.Material.Define(stage, "/Looks/Mdl")
        mdl = UsdShade.Shader.Define(stage, "/Looks/Mdl/Shader")
        mdl.SetSourceAsset(Sdf.AssetPath("OmniPBR.mdl"), "mdl")
        inner.CreateSurfaceOutput("mdl").ConnectToSource(mdl.ConnectableAPI(), "out")
    stage.DefinePrim("/Protos/P", "Xform")
    _bind(_quads(stage, "/Protos/P/Mesh", 1), inner)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    world = stage.DefinePrim("/World", "Xform")
    instance = stage.DefinePrim("/World/I", "Xform")
    instance.GetReferences().AddInternalReference("/Protos/P")
    instance.SetInstanceable(True)
    _bind_collection(world, ["/World/I"], outer, purpose)
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    stage = Usd.Stage.Open(path)
    proxy = stage.GetPrimAtPath("/World/I/Mesh")
    want = UsdShade.MaterialBindingAPI(proxy).ComputeBoundMaterial(purpose)[0].GetPath()
    assert str(want) == "/Looks/Outer"
    assert drawn == {("/World/I/Mesh", 0): "/Looks/Outer"}


@pytest.mark.parametrize("purpose", ["full", "preview"])
def test_material_binding_purposes_find_a_collection_bound_for_that_purpose(tmp_path, purpose):
    """Under the render settings' ``materialBindingPurposes = [purpose]`` a collection bound for that purpose binds
    its members, as ``ComputeBoundMaterial(purpose)`` gives; wrt found no binding of the purpose (it read the
    collection binding's purpose as all-purpose) and drew the default grey."""
    from pxr import UsdRender

    path = str(tmp_path / "purposes.usda")
    stage = Usd.Stage.CreateNew(path)
    inner, outer = _inner_and_outer(stage)
    world = stage.DefinePrim("/World", "Xform")
    _bind(_quads(stage, "/World/Mesh", 1), inner)
    _bind_collection(world, ["/World/Mesh"], outer, purpose)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateMaterialBindingPurposesAttr([purpose])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()
    drawn = _drawn_materials(load(path))
    stage = Usd.Stage.Open(path)
    mesh = stage.GetPrimAtPath("/World/Mesh")
    assert str(UsdShade.MaterialBindingAPI(mesh).ComputeBoundMaterial(purpose)[0].GetPath()) == "/Looks/Outer"
    assert drawn == {("/World/Mesh", 0): "/Looks/Outer"}


@pytest.mark.parametrize("value_type", ["int64[]", "float[]", "string", "string[]"])
def test_a_materialbind_subset_whose_indices_are_not_int_binds_no_face(tmp_path, value_type):
    """A ``materialBind`` subset's ``indices`` are ``int[]``; USD reads none from another type (its own
    ``GetUnassignedIndices`` leaves every face unassigned), so the subset binds no face and the mesh keeps its own
    look, with a warning naming the subset and the type. wrt read them as faces (``float[] [0.5]`` and ``string "0"``
    as face 0), and ``string[]`` ones stopped the load with SceneError."""
    path = str(tmp_path / "subset.usda")
    stage = Usd.Stage.CreateNew(path)
    mesh = UsdGeom.Mesh.Define(stage, "/M")
    mesh.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([3, 3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 0, 2, 3])
    subset = UsdGeom.Subset.Define(stage, "/M/Red")
    subset.CreateElementTypeAttr(UsdGeom.Tokens.face)
    subset.CreateFamilyNameAttr(UsdShade.Tokens.materialBind)
    UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(preview_material(stage, "/Looks/Red", (0.9, 0.1, 0.1)))
    stage.GetRootLayer().Save()
    types = {"int64[]": (Sdf.ValueTypeNames.Int64Array, Vt.Int64Array([0])),
             "float[]": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([0.5])),
             "string": (Sdf.ValueTypeNames.String, "0"),
             "string[]": (Sdf.ValueTypeNames.StringArray, Vt.StringArray(["x"]))}
    value_type_name, value = types[value_type]
    layer = Sdf.Layer.FindOrOpen(path)
    Sdf.AttributeSpec(layer.GetPrimAtPath("/M/Red"), "indices", value_type_name).default = value
    layer.Save()
    stage = Usd.Stage.Open(path)
    red = UsdGeom.Subset(stage.GetPrimAtPath("/M/Red"))
    assert list(UsdGeom.Subset.GetUnassignedIndices([red], 2, Usd.TimeCode.Default())) == [0, 1]  # USD: no face
    with pytest.warns(UserWarning, match=rf"(?s)indices are not int\[\].*indices is {re.escape(value_type)}.*/M/Red"):
        scene = wrt.load_usd(path)
    assert (scene.triangle_materials() == 0).all()  # every face of the mesh's own (default) look


SIX_PARTS = "material:binding:collection:full:a:b"


def _six_part_binding_stage(tmp_path) -> str:
    """/World binds /Looks/Outer to its collection holding /World/Mesh through :data:`SIX_PARTS`, saved."""
    path = str(tmp_path / "six_parts.usda")
    stage = Usd.Stage.CreateNew(path)
    _, outer = _inner_and_outer(stage)
    world = stage.DefinePrim("/World", "Xform")
    _quads(stage, "/World/Mesh", 1)
    collection = Usd.CollectionAPI.Apply(world, "looks")
    collection.GetIncludesRel().AddTarget("/World/Mesh")
    UsdShade.MaterialBindingAPI.Apply(world)
    world.CreateRelationship(SIX_PARTS).SetTargets([collection.GetCollectionPath(), outer.GetPath()])
    stage.GetRootLayer().Save()
    return path


def _messages(load) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load()
    return [str(w.message) for w in caught]


def _loaded_with_messages(path: str, **options) -> tuple:
    """``(wrt.load_usd(path, **options), the warnings it gave)``."""
    loaded = []
    messages = _messages(lambda: loaded.append(wrt.load_usd(path, **options)))
    return loaded[0], messages


def test_a_collection_binding_of_six_name_parts_is_named_as_ambiguous(tmp_path):
    """``material:binding:collection:full:a:b`` binds for ``full`` to ``ComputeBoundMaterial`` (which wrt follows),
    while ``GetCollectionBindingRels("")`` lists it among all-purpose bindings: USD's two calls disagree on its
    purpose, and wrt read it without a word. One warning names the prim and the relationship."""
    path = _six_part_binding_stage(tmp_path)
    stage = Usd.Stage.Open(path)
    world = stage.GetPrimAtPath("/World")
    # The disagreement, from USD itself.
    all_purpose = UsdShade.MaterialBindingAPI(world).GetCollectionBindingRels(UsdShade.Tokens.allPurpose)
    assert SIX_PARTS in [r.GetName() for r in all_purpose]
    mesh = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/World/Mesh"))
    assert str(mesh.ComputeBoundMaterial(UsdShade.Tokens.full)[0].GetPath()) == "/Looks/Outer"
    messages = _messages(lambda: wrt.load_usd(path))
    named = [m for m in messages if SIX_PARTS in m]
    assert len(named) == 1 and "/World" in named[0] and "ambiguous" in named[0], messages
    assert named[0].count(SIX_PARTS) == 1


def test_every_load_of_a_kept_stage_names_an_ambiguous_collection_binding(tmp_path):
    """A kept stage's later loads (StageFrames) keep each mesh's binding (MaterialMemo) without walking it again:
    the warning of :func:`test_a_collection_binding_of_six_name_parts_is_named_as_ambiguous` came with the first
    load only, where every fresh load of the same stage gives it."""
    from wrt.usd_frames import StageFrames

    path = _six_part_binding_stage(tmp_path)
    fresh = _messages(lambda: wrt.load_usd(path))
    assert any(SIX_PARTS in m for m in fresh), fresh
    frames = StageFrames(path)
    for _ in range(3):
        assert _messages(lambda: frames.load(None)) == fresh


def test_a_binding_to_no_material_is_named_in_a_warning(tmp_path):
    """A ``material:binding`` whose target is a missing prim or no Material binds nothing (USD's
    ``ComputeBoundMaterial`` gives its relationship and an invalid material), and the mesh is drawn as bound to no
    material: wrt drew it so without a word (found by a mutation fuzz of USD stages: a retargeted binding). One
    warning names the file, each binding prim and its target; an emptied binding (``material:binding = None``, no
    target: deliberately unbound) and a binding to a Material are not named."""
    path = str(tmp_path / "dangling.usda")
    stage = Usd.Stage.CreateNew(path)
    looks = preview_material(stage, "/Looks/Red", (1, 0, 0))
    stage.DefinePrim("/World", "Xform")
    targets = {"/World/Missing": "/Looks/Gone", "/World/Xform": "/World", "/World/Bound": str(looks.GetPath())}
    for mesh, target in targets.items():
        UsdShade.MaterialBindingAPI.Apply(_quads(stage, mesh, 1)).GetDirectBindingRel().SetTargets([target])
    UsdShade.MaterialBindingAPI.Apply(_quads(stage, "/World/Unbound", 1)).GetDirectBindingRel().SetTargets([])
    stage.GetRootLayer().Save()
    stage = Usd.Stage.Open(path)
    for mesh in ("/World/Missing", "/World/Xform"):  # USD: a binding found, that binds no material
        material, rel = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(mesh)).ComputeBoundMaterial()
        assert rel and rel.GetTargets() and not material
    assert not UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/World/Unbound")).ComputeBoundMaterial()[1]
    messages = _messages(lambda: wrt.load_usd(path))
    named = [m for m in messages if "no Material" in m]
    assert len(named) == 1, messages
    assert named[0].startswith(path) and "2 prim(s)" in named[0]
    for mesh in ("/World/Missing", "/World/Xform", "/Looks/Gone"):
        assert mesh in named[0]
    assert "/World/Bound" not in named[0] and "/World/Unbound" not in named[0]


def test_a_binding_to_no_material_inside_a_prototype_names_its_target_under_the_first_instance(tmp_path):
    """A binding inside a native prototype to a prim inside it that is missing, or a collection binding to the
    collection of a missing prim: its target was named by prototype path (``material:binding ->
    /__Prototype_1/Looks/Missing``, a name USD makes up per opening that no file holds), beside the mesh named under
    the prototype's first instance. Both are named under that instance now (the oracle: USD's ``GetPrototypes()``
    and ``GetInstances()``)."""
    path = str(tmp_path / "no_material_inside.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.DefinePrim("/Protos/P", "Xform")
    mesh = _quads(stage, "/Protos/P/Mesh")
    UsdShade.MaterialBindingAPI.Apply(mesh).GetDirectBindingRel().SetTargets([Sdf.Path("/Protos/P/Looks/Missing")])
    other = _quads(stage, "/Protos/P/Other")
    UsdShade.MaterialBindingAPI.Apply(other)
    red = preview_material(stage, "/Protos/P/Looks/Red", (1, 0, 0))
    other.CreateRelationship("material:binding:collection:grp").SetTargets(
        [Sdf.Path("/Protos/P/Nope.collection:grp"), red.GetPath()])
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)
    for name in ("B", "A"):
        instance = stage.DefinePrim(f"/World/{name}", "Xform")
        instance.GetReferences().AddInternalReference("/Protos/P")
        instance.SetInstanceable(True)
    stage.GetRootLayer().Save()
    opened = Usd.Stage.Open(path)
    (prototype,) = opened.GetPrototypes()
    first = min(str(p.GetPath()) for p in prototype.GetInstances())
    assert first == "/World/A"
    messages = _messages(lambda: wrt.load_usd(path))
    named = [m for m in messages if "no Material" in m or "no collection" in m]
    assert len(named) == 2, messages
    assert f"material:binding -> {first}/Looks/Missing" in named[0] + named[1], named
    assert f"material:binding:collection:grp -> {first}/Nope.collection:grp" in named[0] + named[1], named
    assert "__Prototype" not in named[0] + named[1]


def test_a_binding_that_usd_ignores_is_named_in_a_warning(tmp_path):
    """A direct binding whose targets are not one prim (a property, two materials) or a collection binding without a
    collection and a material is ignored by ``ComputeBoundMaterial`` (no relationship found), and the mesh is drawn
    as bound to what is above it, here nothing: wrt drew it so without a word (found by the mutation fuzz that
    retargets bindings to a property). One warning names the file, each binding prim and its relationship. A
    collection binding that targets its material first, then its collection, binds as USD binds it, unnamed: it was
    named as ignored while drawn bound."""
    path = str(tmp_path / "ignored.usda")
    stage = Usd.Stage.CreateNew(path)
    red, green = preview_material(stage, "/Looks/Red", (1, 0, 0)), preview_material(stage, "/Looks/Green", (0, 1, 0))
    stage.DefinePrim("/World", "Xform")
    cases = {"/World/Property": ["/World/Property.points"], "/World/Two": [red.GetPath(), green.GetPath()]}
    for mesh, targets in cases.items():
        UsdShade.MaterialBindingAPI.Apply(_quads(stage, mesh, 1)).GetDirectBindingRel().SetTargets(targets)
    collection = _quads(stage, "/World/Collection", 1)
    UsdShade.MaterialBindingAPI.Apply(collection)
    collection.CreateRelationship("material:binding:collection:looks").SetTargets([red.GetPath()])
    _bind(_quads(stage, "/World/Bound", 1), red)
    reversed_ = UsdShade.MaterialBindingAPI.Apply(_quads(stage, "/World/Reversed", 1)).GetPrim()
    Usd.CollectionAPI.Apply(reversed_, "mine").CreateIncludesRel().SetTargets([reversed_.GetPath()])
    reversed_.CreateRelationship("material:binding:collection:mine").SetTargets(
        [green.GetPath(), "/World/Reversed.collection:mine"])
    stage.GetRootLayer().Save()
    stage = Usd.Stage.Open(path)
    for mesh in ("/World/Property", "/World/Two", "/World/Collection"):  # USD: no binding found
        material, rel = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(mesh)).ComputeBoundMaterial()
        assert not rel and not material
    material, rel = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/World/Reversed")).ComputeBoundMaterial()
    assert rel and material.GetPath() == green.GetPath()
    scene, messages = _loaded_with_messages(path)
    named = [m for m in messages if "USD ignores" in m]
    assert len(named) == 1, messages
    assert named[0].startswith(path) and "3 prim(s)" in named[0]
    for part in ("/World/Property", "/World/Two", "/World/Collection", "material:binding:collection:looks"):
        assert part in named[0]
    assert "/World/Bound" not in named[0] and "/World/Reversed" not in named[0]
    drawn = _drawn_materials(scene)
    assert drawn == _usd_materials(stage, drawn) and drawn[("/World/Reversed", 0)] == "/Looks/Green"


def test_a_binding_through_a_relationship_is_named_only_where_usd_ignores_it(tmp_path):
    """A binding may target a relationship, which USD forwards (``GetForwardedTargets``): one forwarded to a Material
    (directly or through a chain of relationships, a collection binding's collection or material likewise) binds it
    for ``ComputeBoundMaterial``; one forwarded to two Materials or to nothing binds nothing. wrt named the forwarded
    ones that bind as bindings USD ignores ("drawn as bound to what is above them") while it drew their material.
    Named exactly where ``ComputeBoundMaterial`` finds no binding; the drawn materials are USD's."""
    path = str(tmp_path / "forwarded.usda")
    stage = Usd.Stage.CreateNew(path)
    red, green = preview_material(stage, "/Looks/Red", (1, 0, 0)), preview_material(stage, "/Looks/Green", (0, 1, 0))
    world = stage.DefinePrim("/World", "Xform")
    relays = {"one": [red.GetPath()], "chain": ["/World.one"], "two": [red.GetPath(), green.GetPath()], "none": []}
    for name, targets in relays.items():
        world.CreateRelationship(name).SetTargets(targets)
    Usd.CollectionAPI.Apply(world, "looks").CreateIncludesRel().SetTargets(["/World"])
    world.CreateRelationship("looks").SetTargets(["/World.collection:looks"])
    for name in relays:
        UsdShade.MaterialBindingAPI.Apply(_quads(stage, f"/World/{name}", 1)).GetDirectBindingRel().SetTargets(
            [f"/World.{name}"])
    collection = UsdShade.MaterialBindingAPI.Apply(_quads(stage, "/World/Collection", 1)).GetPrim()
    collection.CreateRelationship("material:binding:collection:looks").SetTargets(["/World.looks", "/World.chain"])
    stage.GetRootLayer().Save()
    stage = Usd.Stage.Open(path)
    meshes = [f"/World/{name}" for name in relays] + ["/World/Collection"]
    ignored = {mesh for mesh in meshes
               if not UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(mesh)).ComputeBoundMaterial()[1]}
    assert ignored == {"/World/two", "/World/none"}  # USD's own answer: the stage holds both kinds
    scene, messages = _loaded_with_messages(path)
    named = [m for m in messages if "USD ignores" in m]
    assert len(named) == 1, messages
    assert f"{len(ignored)} prim(s)" in named[0], named[0]
    for mesh in meshes:
        assert (re.search(re.escape(mesh) + r"\b", named[0]) is not None) == (mesh in ignored), (mesh, named[0])
    drawn = _drawn_materials(scene)
    assert drawn == _usd_materials(stage, drawn)


def test_a_binding_forwarded_to_no_material_names_the_prim_it_reaches(tmp_path):
    """A binding that targets a relationship which targets an Xform binds nothing (``ComputeBoundMaterial`` finds the
    relationship and no material): the warning named only the relationship it targets (``-> /World.relay``, read as
    a binding of a property), not the prim USD reached through it."""
    path = str(tmp_path / "relay.usda")
    stage = Usd.Stage.CreateNew(path)
    world = stage.DefinePrim("/World", "Xform")
    stage.DefinePrim("/World/Xform", "Xform")
    world.CreateRelationship("relay").SetTargets(["/World/Xform"])
    mesh = _quads(stage, "/World/Mesh", 1)
    UsdShade.MaterialBindingAPI.Apply(mesh).GetDirectBindingRel().SetTargets(["/World.relay"])
    stage.GetRootLayer().Save()
    stage = Usd.Stage.Open(path)
    material, rel = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/World/Mesh")).ComputeBoundMaterial()
    assert rel and not material and rel.GetForwardedTargets() == [Sdf.Path("/World/Xform")]
    named = [m for m in _messages(lambda: wrt.load_usd(path)) if "no Material" in m]
    assert len(named) == 1 and "/World/Mesh" in named[0], named
    assert "-> /World/Xform" in named[0], named[0]


@pytest.mark.parametrize("purposes, named_meshes", [
    (["full", ""], {"Full", "Xform"}),  # /World/Preview's preview binding is not asked for
    (["preview", "full", ""], {"Full", "Xform", "Preview", "Bound"}),  # /World/Bound's preview binding comes first
])
def test_a_listed_purposes_binding_to_no_material_is_named_and_binds_nothing(tmp_path, purposes, named_meshes):
    """With ``materialBindingPurposes`` authored, a ``material:binding:full`` (or ``:preview``) to a missing prim or
    an Xform is the purpose's binding to ``ComputeBoundMaterial(purpose)``, which binds no material and does not
    fall back (and Hydra takes the first purpose bound). wrt passed it over as no binding: ``["full", ""]`` drew the
    all-purpose material under it, without a word. Each mesh draws the material of the first listed purpose whose
    own walk USD finds a binding of, and those bindings to no Material are named; a purpose not listed is not."""
    from pxr import UsdRender

    path = str(tmp_path / "purposes.usda")
    stage = Usd.Stage.CreateNew(path)
    red, green = preview_material(stage, "/Looks/Red", (1, 0, 0)), preview_material(stage, "/Looks/Green", (0, 1, 0))
    stage.DefinePrim("/World", "Xform")
    bindings = {"/World/Full": {"full": "/Looks/Gone", "": red.GetPath()},
                "/World/Xform": {"full": "/World", "": red.GetPath()},
                "/World/Preview": {"preview": "/Looks/Gone", "": green.GetPath()},
                "/World/Bound": {"full": red.GetPath(), "preview": "/Looks/Gone"}}
    for mesh, targets in bindings.items():
        api = UsdShade.MaterialBindingAPI.Apply(_quads(stage, mesh, 1))
        for purpose, target in targets.items():
            api.GetDirectBindingRel(purpose or UsdShade.Tokens.allPurpose).SetTargets([target])
    settings = UsdRender.Settings.Define(stage, "/Render/S")
    settings.CreateMaterialBindingPurposesAttr(purposes)
    stage.GetRootLayer().Save()

    def usd_binding(prim):  # the first listed purpose whose own walk finds a binding (ComputeBoundMaterial's)
        for purpose in purposes:
            material, rel = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(
                purpose or UsdShade.Tokens.allPurpose)
            if rel and rel.GetName() == ":".join(["material:binding", purpose]).rstrip(":"):
                return material, rel
        return UsdShade.Material(), None

    stage = Usd.Stage.Open(path)
    expected = {mesh: usd_binding(stage.GetPrimAtPath(mesh)) for mesh in bindings}
    unbound = {mesh for mesh, (material, rel) in expected.items() if rel and not material}
    assert unbound == {f"/World/{name}" for name in named_meshes}
    scene, messages = _loaded_with_messages(path, render_settings="/Render/S")
    named = [m for m in messages if "no Material" in m]
    assert len(named) == 1 and f": {len(unbound)} prim(s)" in named[0], named
    details = collections.Counter(f"{rel.GetName()} -> {rel.GetTargets()[0]}" for mesh, (_, rel) in expected.items()
                                  if mesh in unbound)
    for detail, count in details.items():  # each binding USD found to no Material, as many times as it binds
        assert f"{detail}: {count}" in named[0], named[0]
    drawn = _drawn_materials(scene)
    assert drawn == {(mesh, 0): str(material.GetPath()) if material else "" for mesh, (material, _) in expected.items()}


@pytest.mark.parametrize("target", ["/Group.collection:absent", "/Group.collection:unapplied", "/Gone.collection:c",
                                    "/Group.points"])
@pytest.mark.parametrize("instanced", [False, True])
def test_a_collection_binding_to_no_collection_binds_nothing_as_usd_and_is_named(tmp_path, target, instanced):
    """A collection binding whose collection target is no collection USD finds (a collection the prim does not apply,
    one of a missing prim, an attribute) binds nothing to ``ComputeBoundMaterial``: its prims take the direct binding
    above (red). wrt said nothing of the first ones, and failed the whole load on an attribute ('cannot read this
    prim', USD's Python API raising the coding error its C++ only reports). One warning names the binding prim, the
    relationship and the target.
    Oracle: ComputeBoundMaterial; for the attribute, on the stage with it replaced by a collection the prim does not
    apply, which USD's C++ resolves through the same empty membership of an invalid collection (its Python raises on
    the attribute itself). (A relationship of a collection, which USD forwards to its prims, is a binding of two prims:
    :func:`test_a_binding_through_a_relationship_is_named_only_where_usd_ignores_it`.)"""
    path = str(tmp_path / "collections.usda")
    stage = Usd.Stage.CreateNew(path)
    red, green = preview_material(stage, "/Looks/Red", (1, 0, 0)), preview_material(stage, "/Looks/Green", (0, 1, 0))
    group = stage.DefinePrim("/Group", "Xform")
    _bind(group, red)
    group.CreateRelationship("collection:unapplied:includes").SetTargets(["/Group"])
    group.CreateRelationship("material:binding:collection:looks").SetTargets([target, green.GetPath()])
    _quads(stage, "/Group/Mesh", 1)
    if instanced:
        stage.DefinePrim("/Group/Inst").GetReferences().AddInternalReference("/Group/Mesh")
        stage.GetPrimAtPath("/Group/Inst").SetInstanceable(True)
    stage.GetRootLayer().Save()
    oracle = Usd.Stage.Open(path)
    if target == "/Group.points":
        with pytest.raises(Tf.ErrorException, match="Invalid collection path"):
            UsdShade.MaterialBindingAPI(oracle.GetPrimAtPath("/Group/Mesh")).ComputeBoundMaterial()
        with Usd.EditContext(oracle, oracle.GetSessionLayer()):  # the file's layer, shared with wrt's load, kept
            oracle.GetPrimAtPath("/Group").GetRelationship("material:binding:collection:looks").SetTargets(
                ["/Group.collection:absent", green.GetPath()])
    scene, messages = _loaded_with_messages(path)
    drawn = _drawn_materials(scene)
    assert drawn == _usd_materials(oracle, drawn)
    assert set(drawn.values()) == {"/Looks/Red"}, drawn
    named = [m for m in messages if "bind nothing" in m]
    assert len(named) == 1, messages
    assert named[0].endswith(f"(material:binding:collection:looks -> {target}: 1): /Group"), named
