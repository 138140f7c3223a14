"""Rows of many native instances against what USD computes for their instance proxies: a prototype of nested
Xforms and three meshes (one bound, two not, none coloured) placed 60 times under rotated groups, the instances
moved, turned and scaled, some coloured, made translucent, bound to a material or hidden on the instance, one group
bound above them, another binding a collection that holds two of its instances; and instances that author only their
transform under a hidden group, a guide group and a plain one. Each row's world points, material,
colour and opacity, and which instances are drawn, are checked against ``UsdGeom.XformCache``,
``ComputeBoundMaterial``, ``FindPrimvarWithInheritance`` and ``ComputeVisibility`` of the proxies (the loader reads
an instance's transform, bindings, colours and opacity from the instance prim and its ancestors, and shares them
among siblings that author nothing but their transform)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade  # noqa: E402

import wrt  # noqa: E402

N = 60  # native instances, 20 per group
PALETTE = [(0.8, 0.1, 0.1), (0.1, 0.7, 0.2), (0.2, 0.3, 0.9)]


def quad(stage, path, z):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(0, 0, z), (1, 0, z), (1, 1, z + 0.2), (0, 1, z)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return mesh


def material(stage, path, rgb):
    found = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgb))
    found.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return found


@pytest.fixture(scope="module")
def stage_path(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("proxies") / "natives.usda")
    stage = Usd.Stage.CreateNew(path)
    looks = [material(stage, f"/Looks/M{k}", rgb) for k, rgb in enumerate(PALETTE)]
    UsdGeom.Xform.Define(stage, "/Proto").GetPrim().SetSpecifier(Sdf.SpecifierClass)
    pivot = UsdGeom.Xform.Define(stage, "/Proto/Pivot")
    pivot.AddRotateZOp().Set(30.0)
    pivot.AddScaleOp().Set(Gf.Vec3f(1.5, 1.0, 0.7))
    quad(stage, "/Proto/Pivot/Body", 0.0)
    UsdShade.MaterialBindingAPI.Apply(quad(stage, "/Proto/Lit", 1.0).GetPrim()).Bind(looks[0])
    quad(stage, "/Proto/Plain", 2.0)
    rng = np.random.default_rng(123)
    for k in range(N):
        group = f"/World/G{k // 20}"
        if k % 20 == 0:
            UsdGeom.Xform.Define(stage, group).AddRotateZOp().Set(17.0 * (k // 20))
        prim = stage.DefinePrim(f"{group}/I{k}", "Xform")
        prim.GetReferences().AddInternalReference("/Proto")
        prim.SetInstanceable(True)
        xform = UsdGeom.Xformable(prim)
        xform.AddTranslateOp().Set(Gf.Vec3d(*rng.normal(0, 10, 3)))
        xform.AddRotateZOp().Set(float(rng.uniform(0, 360)))
        xform.AddScaleOp().Set(Gf.Vec3f(*rng.uniform(0.5, 1.5, 3)))
        primvars = UsdGeom.PrimvarsAPI(prim)
        if k % 3 == 0:
            primvars.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant).Set(
                [Gf.Vec3f(*PALETTE[k % 9 // 3])])
        if k % 4 == 1:
            UsdShade.MaterialBindingAPI.Apply(prim).Bind(looks[2])
        if k % 6 == 2:
            primvars.CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.constant).Set([0.5])
        if k % 5 == 4:
            UsdGeom.Imageable(prim).MakeInvisible()
    for group, kind in (("/World/Hidden", "invisible"), ("/World/Guides", "guide"), ("/World/Shown", None)):
        # Instances that author only their transform, under a hidden group, a guide group and a plain one.
        UsdGeom.Xform.Define(stage, group)
        if kind == "invisible":
            UsdGeom.Imageable(stage.GetPrimAtPath(group)).MakeInvisible()
        elif kind == "guide":
            UsdGeom.Imageable(stage.GetPrimAtPath(group)).CreatePurposeAttr(UsdGeom.Tokens.guide)
        for k in range(4):
            prim = stage.DefinePrim(f"{group}/I{k}", "Xform")
            prim.GetReferences().AddInternalReference("/Proto")
            prim.SetInstanceable(True)
            UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(3.0 * k, 40.0, 0.0))
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/G1")).Bind(looks[1])
    # A collection on the third group holds two of its instances: they bind unlike their siblings.
    some = Usd.CollectionAPI.Apply(stage.GetPrimAtPath("/World/G2"), "some")
    for k in (41, 43):
        some.GetIncludesRel().AddTarget(f"/World/G2/I{k}")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/World/G2")).Bind(some, looks[2], "some")
    stage.Save()
    return path


def test_native_instance_rows_are_what_usd_computes_for_their_proxies(stage_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing here is worth a warning
        scene = wrt.load_usd(stage_path)
    stage = Usd.Stage.Open(stage_path)
    paths = [f"/World/G{k // 20}/I{k}" for k in range(N)]
    paths += [f"{group}/I{k}" for group in ("/World/Hidden", "/World/Guides", "/World/Shown") for k in range(4)]
    shown = assert_rows_are_usds(scene, stage, paths)
    assert "/World/Shown/I0" in shown and "/World/Hidden/I0" not in shown and "/World/Guides/I0" not in shown


def assert_rows_are_usds(scene, stage, paths, time=Usd.TimeCode.Default()) -> set:
    """Checks the rows of ``scene``'s native instances (of ``/Proto``) at ``paths`` against USD's answers for their
    proxies at ``time``: which are drawn, each mesh's world points, material, colour, and the instance's opacity.
    Returns the paths drawn."""
    cache = UsdGeom.XformCache(time)
    instances = scene.instances
    drawn = {instances.path(i) for i in range(len(instances))}
    plain = [UsdGeom.Imageable(stage.GetPrimAtPath(f"{path}/Plain")) for path in paths]
    shown = {path for path, proxy in zip(paths, plain) if proxy.ComputeVisibility(time) != UsdGeom.Tokens.invisible
             and proxy.ComputePurpose() in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)}
    assert drawn == shown and len(instances) == len(shown)
    for i in range(len(instances)):
        prototype = scene.prototypes[instances.prototype[i]]
        assert {m.path.rsplit("/", 1)[1] for m in prototype.meshes} == {"Body", "Lit", "Plain"}
        opacity = None
        for mesh in prototype.meshes:
            proxy = stage.GetPrimAtPath(instances.path(i) + mesh.path[len(prototype.path):])
            assert proxy.IsInstanceProxy()
            usd_points = np.array(UsdGeom.Mesh(proxy).GetPointsAttr().Get(time), np.float64)
            to_world = np.array(cache.GetLocalToWorldTransform(proxy))  # row vectors
            expected = usd_points @ to_world[:3, :3] + to_world[3, :3]
            placed = mesh.points.astype(np.float64) @ instances.to_world[i][:3, :3].T + instances.to_world[i][:3, 3]
            np.testing.assert_allclose(placed, expected, rtol=1e-5, atol=1e-4)
            bound, _ = UsdShade.MaterialBindingAPI(proxy).ComputeBoundMaterial()
            ids = np.unique(mesh.material_ids) if mesh.material_ids is not None else [-1]  # None: unbound
            assert len(ids) == 1
            assert (scene.materials[ids[0]].path if ids[0] >= 0 else "") == (str(bound.GetPath()) if bound else "")
            color = UsdGeom.PrimvarsAPI(proxy).FindPrimvarWithInheritance("displayColor")
            if color and color.Get(time):
                assert mesh.colors is not None, instances.path(i)
                np.testing.assert_allclose(mesh.colors.reshape(-1, 3), np.broadcast_to(color.Get(time)[0], (
                    mesh.colors.size // 3, 3)), rtol=1e-6)
            else:
                assert mesh.colors is None
            found = UsdGeom.PrimvarsAPI(proxy).FindPrimvarWithInheritance("displayOpacity")
            opacity = float(found.Get(time)[0]) if found and found.Get(time) else None
        # One opacity per instance (Instances.opacities; NaN or no array: opaque), the same for its three meshes.
        got = instances.opacities[i] if len(instances.opacities) else np.nan
        assert (np.isnan(got) and opacity is None) or got == pytest.approx(opacity)
    return shown


ARC_INSTANCES = ("Plain0", "Inherits", "Plain1", "Specializes", "Hidden", "Guide", "SubLayer", "SubBound", "Payload",
                 "Variant", "TimeOnly", "Plain2")


@pytest.fixture(scope="module")
def arcs_path(tmp_path_factory):
    """Siblings of one prototype under one group, most of which author a colour, binding, opacity, visibility or
    purpose not in the instance's own opinions but through an arc: inherits, specializes, a sublayer's ``over``, a
    payload, a variant, or a time sample only; plain ones (transform only) between them."""
    folder = tmp_path_factory.mktemp("arcs")
    path, sub_path = str(folder / "arcs.usda"), str(folder / "sub.usda")
    stage = Usd.Stage.CreateNew(path)
    looks = [material(stage, f"/Looks/M{k}", rgb) for k, rgb in enumerate(PALETTE)]
    UsdGeom.Xform.Define(stage, "/Proto").GetPrim().SetSpecifier(Sdf.SpecifierClass)
    quad(stage, "/Proto/Body", 0.0)
    UsdShade.MaterialBindingAPI.Apply(quad(stage, "/Proto/Lit", 1.0).GetPrim()).Bind(looks[0])
    quad(stage, "/Proto/Plain", 2.0)

    def red(prim):
        UsdGeom.PrimvarsAPI(prim).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                UsdGeom.Tokens.constant).Set([Gf.Vec3f(*PALETTE[0])])

    red(stage.CreateClassPrim("/_Red"))
    UsdShade.MaterialBindingAPI.Apply(stage.CreateClassPrim("/_Bound")).Bind(looks[2])
    UsdGeom.Imageable(stage.CreateClassPrim("/_Hidden")).CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    UsdGeom.Imageable(stage.CreateClassPrim("/_Guide")).CreatePurposeAttr(UsdGeom.Tokens.guide)
    payload = stage.DefinePrim("/PayloadRoot", "Xform")
    payload.GetReferences().AddInternalReference("/Proto")
    UsdGeom.PrimvarsAPI(payload).CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray,
                                               UsdGeom.Tokens.constant).Set([0.5])
    group = UsdGeom.Xform.Define(stage, "/World/Arcs").GetPrim()
    UsdGeom.PrimvarsAPI(group).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                             UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.5, 0.5, 0.5)])
    UsdShade.MaterialBindingAPI.Apply(group).Bind(looks[1])
    for k, name in enumerate(ARC_INSTANCES):
        prim = stage.DefinePrim(f"/World/Arcs/{name}", "Xform")
        if name == "Payload":
            prim.GetPayloads().AddInternalPayload("/PayloadRoot")
        else:
            prim.GetReferences().AddInternalReference("/Proto")
        prim.SetInstanceable(True)
        UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(3.0 * k, 0.0, 0.0))
        if name in ("Inherits", "Hidden"):
            prim.GetInherits().AddInherit("/_Red" if name == "Inherits" else "/_Hidden")
        elif name in ("Specializes", "Guide"):
            prim.GetSpecializes().AddSpecialize("/_Bound" if name == "Specializes" else "/_Guide")
        elif name == "Variant":
            looks_set = prim.GetVariantSets().AddVariantSet("look")
            looks_set.AddVariant("red")
            looks_set.SetVariantSelection("red")
            with looks_set.GetVariantEditContext():
                red(prim)
        elif name == "TimeOnly":
            UsdGeom.PrimvarsAPI(prim).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                    UsdGeom.Tokens.constant).Set([Gf.Vec3f(*PALETTE[2])], 1.0)
    stage.Save()
    sub = Usd.Stage.CreateNew(sub_path)
    UsdGeom.Imageable(sub.OverridePrim("/World/Arcs/SubLayer")).CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    bound = sub.OverridePrim("/World/Arcs/SubBound")
    bound.CreateRelationship("material:binding").SetTargets([looks[0].GetPath()])
    bound.ApplyAPI(UsdShade.MaterialBindingAPI)
    sub.Save()
    stage.GetRootLayer().subLayerPaths.append("./sub.usda")
    stage.Save()
    return path


def test_siblings_that_author_through_arcs_are_drawn_as_usd_computes_their_proxies(arcs_path):
    """Transform-only siblings share one read of their prototype (bindings, colours, visibility, purpose): a sibling
    whose colour, binding, opacity, visibility or purpose comes through an arc has it among its composed properties
    and reads its own. Each row against USD's answers for the proxies at time 1 (the time-sampled colour)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(arcs_path, time=1.0)
    stage = Usd.Stage.Open(arcs_path)
    paths = [f"/World/Arcs/{name}" for name in ARC_INSTANCES]
    shown = assert_rows_are_usds(scene, stage, paths, Usd.TimeCode(1.0))
    assert shown == set(paths) - {"/World/Arcs/Hidden", "/World/Arcs/Guide", "/World/Arcs/SubLayer"}
