"""World-level instances of one prototype, placed together (``wrt.usd_placement_groups``), give the scene that
placing every nested instance one at a time gives: the same prototypes, instance rows, names, roots, colours,
opacities and Points elements, array for array and byte for byte."""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, Vt  # noqa: E402

import wrt  # noqa: E402
import wrt.usd  # noqa: E402
import wrt.usd_contents  # noqa: E402


def _quad(stage, path, color=None):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0.2), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if color is not None:
        mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(*color)])
    return mesh


def _instance(stage, path, target, translate=None, rotate=None, color=None):
    prim = stage.DefinePrim(path, "Xform")
    prim.GetReferences().AddInternalReference(target)
    prim.SetInstanceable(True)
    if translate is not None:
        UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(*translate))
    if rotate is not None:
        UsdGeom.Xformable(prim).AddRotateXYZOp().Set(Gf.Vec3f(*rotate))
    if color is not None:
        UsdGeom.PrimvarsAPI(prim).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                UsdGeom.Tokens.constant).Set([Gf.Vec3f(*color)])
    return prim


def _instancer(stage, path, targets, n, rng, colors=False, opacities=False):
    pi = UsdGeom.PointInstancer.Define(stage, path)
    pi.CreatePrototypesRel().SetTargets([Sdf.Path(t) for t in targets])
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy((np.arange(n) % len(targets)).astype(np.int32)))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(rng.normal(0, 3, (n, 3)).astype(np.float32)))
    q = rng.normal(size=(n, 4)).astype(np.float32)
    pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(*map(float, r / np.linalg.norm(r))) for r in q]))
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(0.5, 2, (n, 3)).astype(np.float32)))
    api = UsdGeom.PrimvarsAPI(pi.GetPrim())
    if colors:
        api.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex).Set(
            Vt.Vec3fArray.FromNumpy(rng.random((n, 3)).astype(np.float32)))
    if opacities:
        api.CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(
            Vt.FloatArray.FromNumpy(rng.random(n).astype(np.float32)))
    return pi


def nested_groups_stage(path):
    """Native trees (a trunk, native branches of native leaves, a Points prim, a PointInstancer of fruit whose
    prototype holds another PointInstancer and a native leaf), several of each kind: world-level trees, some
    coloured (a copy of the prototype per colour), with instances of another prototype between them, and
    PointInstancers of one prototype and one instance count, with per-instance colours and opacities, then one of two
    prototypes (its instances of each are entries of their own, one after the other)."""
    rng = np.random.default_rng(5)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/Protos/Leaf")
    _quad(stage, "/Protos/Leaf/Blade")
    UsdGeom.Xform.Define(stage, "/Protos/Branch")
    _quad(stage, "/Protos/Branch/Stem", color=(0.4, 0.3, 0.1))
    for j in range(3):
        _instance(stage, f"/Protos/Branch/Leaf{j}", "/Protos/Leaf", translate=(0.3 * j, 0, 1), rotate=(10 * j, 0, 5))
    UsdGeom.Xform.Define(stage, "/Protos/Tree")
    _quad(stage, "/Protos/Tree/Trunk")
    for j in range(2):
        _instance(stage, f"/Protos/Tree/Branch{j}", "/Protos/Branch", rotate=(0, 0, 90.0 * j + 7))
    points = UsdGeom.Points.Define(stage, "/Protos/Tree/Seeds")
    points.CreatePointsAttr([(0, 0, 2), (0.5, 0, 2), (0, 0.5, 2.5)])
    points.CreateWidthsAttr([0.1, 0.2, 0.15])
    _instancer(stage, "/Protos/Tree/Fruit", ["/Protos/Tree/Fruit/Protos/Cluster"], 4, rng, colors=True)
    UsdGeom.Imageable(stage.DefinePrim("/Protos/Tree/Fruit/Protos", "Scope")).MakeInvisible()
    UsdGeom.Xform.Define(stage, "/Protos/Tree/Fruit/Protos/Cluster")
    _instancer(stage, "/Protos/Tree/Fruit/Protos/Cluster/Berries", ["/Protos/Tree/Fruit/Protos/Cluster/Berries/P"],
               3, rng, opacities=True)
    UsdGeom.Sphere.Define(stage, "/Protos/Tree/Fruit/Protos/Cluster/Berries/P/Ball").CreateRadiusAttr(0.1)
    _instance(stage, "/Protos/Tree/Fruit/Protos/Cluster/Leaf", "/Protos/Leaf", translate=(0, 0.2, 0))
    colors = [None, None, (1, 0, 0), (1, 0, 0), None, (0, 1, 0), None]
    for k, color in enumerate(colors):
        _instance(stage, f"/World/Tree{k}", "/Protos/Tree", translate=rng.normal(0, 9, 3), rotate=rng.normal(0, 40, 3),
                  color=color)
        if k in (1, 3, 4):
            _instance(stage, f"/World/Lone{k}", "/Protos/Branch", translate=(k, 0, 9))
    UsdGeom.Xform.Define(stage, "/World/Forest")
    _instance(stage, "/World/Forest/Protos/T", "/Protos/Tree")
    UsdGeom.Xform.Define(stage, "/World/Forest/Protos/Bush")
    _instance(stage, "/World/Forest/Protos/Bush/B", "/Protos/Branch", translate=(1, 0, 0))
    for k in range(3):  # one prototype, as many instances each: a run of instancers
        _instancer(stage, f"/World/Forest/PI{k}", ["/World/Forest/Protos/T"], 5, rng, colors=True, opacities=True)
    _instancer(stage, "/World/Forest/Mixed", ["/World/Forest/Protos/T", "/World/Forest/Protos/Bush"], 6, rng,
               colors=True)
    for holder in ("/Protos", "/World/Forest/Protos"):  # (Define made them defs): not drawn in place
        stage.GetPrimAtPath(holder).SetSpecifier(Sdf.SpecifierOver)
    stage.GetRootLayer().Save()
    return path


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path)


def test_instances_of_one_prototype_placed_together_place_what_one_at_a_time_placement_does(tmp_path, monkeypatch):
    path = nested_groups_stage(tmp_path / "groups.usda")
    walked = []
    expand_group = wrt.usd_contents.expand_group

    def counted(members, *args):
        walked.append(len(members))
        return expand_group(members, *args)

    monkeypatch.setattr(wrt.usd_contents, "expand_group", counted)
    together = _load(path)
    assert walked == [4, 3, 2, 3]  # plain trees 0, 1, 4, 6; the branches between; red trees 2, 3; instancers 0-2
    one_by_one_place = functools.partial(wrt.usd_contents.place_instances, min_group=10**9)
    monkeypatch.setattr(wrt.usd, "place_instances", one_by_one_place)
    walked.clear()
    alone = _load(path)
    assert walked == []

    a, b = together.instances, alone.instances
    assert len(a.to_world) > 500
    for name in ("prototype", "to_world", "source", "index", "colors", "root", "opacities", "elements"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert x.tobytes() == y.tobytes(), name
    assert a.sources == b.sources and a.roots == b.roots
    assert np.isfinite(a.colors).any() and np.isfinite(a.opacities).any() and (a.elements >= 0).any()
    assert [p.path for p in together.prototypes] == [p.path for p in alone.prototypes]
    for p, q in zip(together.prototypes, alone.prototypes):
        assert [m.path for m in p.meshes] == [m.path for m in q.meshes]
        assert [s.path for s in p.shapes] == [s.path for s in q.shapes]
