"""Instance and prim paths of a stage of many instances (a PointInstancer of three prototypes in shuffled order,
native instances of two classes in turn, a PointInstancer inside a native instance): ``Scene.hit_paths``,
``Scene.prim_paths`` and the preview's ``instance_row`` against what pxr says of the same stage (the prims under
each instance, the instancer's prototypes and ``ComputeInstanceTransformsAtTime``). The prims are grouped by one key
per (prototype, root), and ``instance_row`` matches the sources' paths, without a path string per instance."""

from __future__ import annotations

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402
from wrt.preview_blas import instance_row  # noqa: E402

N_POINTS = 40  # instances of /PI
N_NATIVE = 6  # native instances /N0.. of /ClassA and /ClassB in turn, from B
PROTOS = ["/PI/Protos/C", "/PI/Protos/A", "/PI/Protos/B"]  # targets order: not the order of the prims


def tetrahedron(stage, path, size):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(-size, -size, 0), (size, -size, 0), (0, size, 0), (0, 0, -size)])
    mesh.CreateFaceVertexCountsAttr([3] * 4)
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 0, 3, 1, 1, 3, 2, 2, 3, 0])
    mesh.CreateDoubleSidedAttr(True)


@pytest.fixture(scope="module")
def stage_path(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("paths") / "many.usda")
    stage = Usd.Stage.CreateNew(path)
    rng = np.random.default_rng(123)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    for k, proto in enumerate(sorted(PROTOS)):
        tetrahedron(stage, f"{proto}/Mesh", 0.5 + 0.2 * k)
    pi.CreatePrototypesRel().SetTargets(PROTOS)
    pi.CreateProtoIndicesAttr(rng.integers(0, 3, N_POINTS).tolist())
    pi.CreatePositionsAttr([(4.0 * i, 0, 0) for i in range(N_POINTS)])
    pi.CreateOrientationsAttr([Gf.Quath(*q) for q in rng.normal(size=(N_POINTS, 4)) / 4 + (1, 0, 0, 0)])
    pi.CreateScalesAttr([tuple(s) for s in rng.uniform(0.8, 1.2, (N_POINTS, 3))])
    for name in ("ClassA", "ClassB", "Nest"):
        UsdGeom.Xform.Define(stage, f"/{name}").GetPrim().SetSpecifier(Sdf.SpecifierClass)
    tetrahedron(stage, "/ClassA/Body", 0.6)
    tetrahedron(stage, "/ClassB/Body", 0.9)
    kit = UsdGeom.PointInstancer.Define(stage, "/Nest/Kit")
    tetrahedron(stage, "/Nest/Kit/Protos/P/Mesh", 0.5)
    kit.CreatePrototypesRel().SetTargets(["/Nest/Kit/Protos/P"])
    kit.CreateProtoIndicesAttr([0, 0, 0])
    kit.CreatePositionsAttr([(0, 0, 0), (4, 0, 0), (8, 0, 0)])
    placed = [(f"/N{i}", "/ClassB" if i % 2 == 0 else "/ClassA", (4.0 * i, 10, 0)) for i in range(N_NATIVE)]
    for name, source, at in placed + [("/Outer", "/Nest", (0, 20, 0))]:
        xform = UsdGeom.Xform.Define(stage, name)
        xform.GetPrim().GetReferences().AddInternalReference(source)
        xform.GetPrim().SetInstanceable(True)
        xform.AddTranslateOp().Set(at)
    stage.Save()
    return path


def usd_instances(stage) -> list:
    """``(instance path, prim path, (4, 4) float64 row-vector to-world)`` of every instance, from pxr alone."""
    found = []
    for instancer, at in ((UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")), ""),
                          (UsdGeom.PointInstancer(stage.GetPrimAtPath("/Outer/Kit")), "/Outer/Kit/Protos/P")):
        targets = [str(t) for t in instancer.GetPrototypesRel().GetTargets()]
        if at:  # the instancer is an instance proxy: its prototype's prims are named under it
            targets = [at] * len(targets)
        indices = instancer.GetProtoIndicesAttr().Get()
        xforms = instancer.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default())
        parent = np.array(UsdGeom.Xformable(instancer.GetPrim()).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
        for i, (k, xform) in enumerate(zip(indices, xforms)):
            found.append((f"{instancer.GetPath()}[{i}]", f"{targets[k]}/Mesh", np.array(xform) @ parent))
    for i in range(N_NATIVE):
        prim = stage.GetPrimAtPath(f"/N{i}")
        mesh = [p for p in Usd.PrimRange(prim, Usd.TraverseInstanceProxies()) if p.IsA(UsdGeom.Mesh)]
        assert len(mesh) == 1 and mesh[0].IsInstanceProxy()
        found.append((str(prim.GetPath()), str(mesh[0].GetPath()),
                      np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))))
    return found


def test_hit_paths_and_prim_ids_are_the_usd_prims_under_each_instance(stage_path):
    """A ray onto each instance's origin names the prim pxr finds under that instance and the instance itself; the
    prim ids index :meth:`prim_paths`, which holds each drawn path once: the prototypes' meshes of ``/PI``, each
    native instance's body at its instance-proxy path and the nested instancer's prototype under ``/Outer``."""
    stage = Usd.Stage.Open(stage_path)
    expected = usd_instances(stage)
    scene = wrt.load_usd(stage_path)
    assert len(scene.instances) == len(expected)
    origins = np.array([to_world[3, :3] for *_, to_world in expected]) + (0, 0, 5)
    hits = wrt.trace(scene, origins, [0, 0, -1])
    prims, instances = scene.hit_paths(hits)
    assert list(instances) == [name for name, *_ in expected]
    assert list(prims) == [prim for _, prim, _ in expected]
    ids, _ = scene.hit_prims(hits.local_prim, hits.instance)
    paths = scene.prim_paths()
    assert [paths[i] for i in ids] == list(prims)
    assert sorted(paths) == sorted({prim for _, prim, _ in expected})


def test_instance_row_finds_each_instance_by_its_usd_path(stage_path):
    """``bvh_instance="/PI[7]"`` picks the instance that pxr places there (its transform is
    ``ComputeInstanceTransformsAtTime``'s, in float64); a path that names none, an index written otherwise than
    ``Instances.path`` writes it among them, is refused."""
    stage = Usd.Stage.Open(stage_path)
    scene = wrt.load_usd(stage_path)
    for name, _, to_world in usd_instances(stage):
        row = instance_row(scene, name)
        np.testing.assert_allclose(scene.instances.to_world[row], to_world.T, rtol=1e-6, atol=1e-6)
        assert scene.instances.path(row) == name
    for name in ("/PI", "/PI[07]", "/PI[+7]", "/PI[ 7]", "/PI[7]x", "/PI[-1]", f"/PI[{N_POINTS}]", "/PI[99999999999]",
                 "/N1[0]", "/N", "/Outer", "/Outer/Kit", "/PI[\u0667]"):
        with pytest.raises(ValueError, match="names no instance"):
            instance_row(scene, name)


def test_an_instance_root_below_minus_one_is_refused():
    """``root`` holds -1 (no root) or a row of ``roots``: -2 was taken, and since the (prototype, root) pairs are
    keyed by one int64, an instance of /P1 under root -2 was named as /P0's part under the last root, /R0/m (and one of
    /P0 as the last prototype's): both instances' prims were /R0/m, not /P0/m and /P1/m."""
    def prototype(path):
        points, indices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32)
        return wrt.Prototype(path, [wrt.Mesh(f"{path}/m", points, indices)])

    def instances(root):
        return wrt.Instances(np.array([0, 1], np.int32), np.stack([np.eye(4)] * 2), np.zeros(2, np.int32),
                             np.arange(2, dtype=np.int32), ["/PI"], roots=["/R0"], root=np.array(root, np.int32))

    with pytest.raises(ValueError, match=r"root must hold one index into roots \(1\), or -1 for none"):
        instances([-2, -2])
    scene = wrt.Scene(prototypes=[prototype("/P0"), prototype("/P1")], instances=instances([-1, 0]))
    assert scene.prim_paths() == ["/P0/m", "/R0/m"]  # -1: the prototype's own path; 0: under /R0
    scene.instances.root = np.array([-2, 0], np.int32)  # assigned later: refused at the next lookup or trace
    with pytest.raises(ValueError, match="root must hold"):
        scene.prim_paths()
