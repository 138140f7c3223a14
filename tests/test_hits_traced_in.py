"""Hits name prims only in the scene, and the state of it, they were traced in: ``Scene.hit_paths``, ``hit_prims``
(given the Hits) and ``wrt.rays.secondary_rays`` refuse the hits of another scene, or of this one before an edit
(a mesh added, the instances changed), naming which. Their ids are rows and geometry ids of the scene as traced:
in range of another scene (or of the edited one) they named its prims without a word. The scene's own hits are
named by the USD prims a float64 ray cast against pxr's points finds."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402
from wrt.rays import secondary_rays  # noqa: E402

DOWN = np.array([0.0, 0.0, -1.0])


def triangle_mesh(stage, path, points, indices):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr([3] * (len(indices) // 3))
    mesh.CreateFaceVertexIndicesAttr(indices)


def write_stage(path, root: str, meshes: dict, proto: str, proto_points) -> str:
    """A stage of ``meshes`` (name -> (points, indices)) under ``root`` and a PointInstancer ``root/PI`` of one
    triangle prototype ``root/PI/Protos/<proto>`` drawn at y = 3 and y = 6."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, root)
    for name, (points, indices) in meshes.items():
        triangle_mesh(stage, f"{root}/{name}", points, indices)
    pi = UsdGeom.PointInstancer.Define(stage, f"{root}/PI")
    triangle_mesh(stage, f"{root}/PI/Protos/{proto}", proto_points, [0, 1, 2])
    pi.CreatePrototypesRel().SetTargets([f"{root}/PI/Protos/{proto}"])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(0, 3, 0), (0, 6, 0)])
    stage.Save()
    return str(path)


@pytest.fixture
def stages(tmp_path):
    """``(a.usda, b.usda)``: each two meshes of 1 and 2 triangles (in other orders) and an instanced triangle, so that
    the geometry ids and instances of one are in range of the other."""
    tri = [0, 1, 2]
    quad = [0, 1, 2, 0, 2, 3]
    a = write_stage(tmp_path / "a.usda", "/World", {
        "Left": ([(-3, -1, 0), (-1, -1, 0), (-2, 1, 0)], tri),
        "Right": ([(1, -1, 0), (3, -1, 0), (3, 1, 0), (1, 1, 0)], quad),
    }, "Tri", [(-1, -1, 0), (1, -1, 0), (0, 1, 0)])
    b = write_stage(tmp_path / "b.usda", "/Other", {
        "Ground": ([(-9, -9, -2), (9, -9, -2), (9, 9, -2), (-9, 9, -2)], quad),
        "Post": ([(5, 0, 0), (5, 0, 2), (5, 1, 1)], tri),
    }, "Shard", [(-1, 0, -1), (1, 0, -1), (0, 0, 1)])
    return a, b


def usd_triangles(path) -> tuple[np.ndarray, list, list]:
    """Every drawn triangle of the stage, float64 world space as pxr computes it, with its mesh's path and its
    instance's (``/World/PI[k]``; "" for none). Prototypes here have no transform of their own."""
    stage = Usd.Stage.Open(path)
    time = Usd.TimeCode.Default()
    tris, prims, instances = [], [], []

    def add(mesh, to_world, instance):
        points = np.array(mesh.GetPointsAttr().Get(), np.float64)
        world = np.c_[points, np.ones(len(points))] @ to_world  # USD's row vectors
        for face in np.array(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3):
            tris.append(world[face, :3])
            prims.append(str(mesh.GetPath()))
            instances.append(instance)

    cache = UsdGeom.XformCache(time)
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.PointInstancer):
            pi = UsdGeom.PointInstancer(prim)
            proto = UsdGeom.Mesh(stage.GetPrimAtPath(pi.GetPrototypesRel().GetTargets()[0]))
            for k, m in enumerate(pi.ComputeInstanceTransformsAtTime(time, time)):
                add(proto, np.array(m) @ np.array(cache.GetLocalToWorldTransform(prim)), f"{prim.GetPath()}[{k}]")
        elif prim.IsA(UsdGeom.Mesh) and "/Protos/" not in str(prim.GetPath()):
            add(UsdGeom.Mesh(prim), np.array(cache.GetLocalToWorldTransform(prim)), "")
    return np.array(tris), prims, instances


def closest_usd_prims(path, origins, direction) -> tuple[list, list]:
    """``(prims, instances)`` paths of the triangle each ray meets first (Moller-Trumbore in float64; "" on a miss)."""
    tris, prims, instances = usd_triangles(path)
    p0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    pvec = np.cross(direction, e2)
    det = np.einsum("tj,tj->t", e1, pvec)
    s = origins[:, None, :] - p0[None]
    u = np.einsum("rtj,tj->rt", s, pvec) / det
    q = np.cross(s, e1[None])
    v = np.einsum("j,rtj->rt", direction, q) / det
    t = np.einsum("tj,rtj->rt", e2, q) / det
    t = np.where((u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0), t, np.inf)
    first = t.argmin(axis=1)
    hit = np.isfinite(t.min(axis=1))
    return ([prims[k] if h else "" for k, h in zip(first, hit)],
            [instances[k] if h else "" for k, h in zip(first, hit)])


# Straight down onto Left, both triangles of Right, and the two instances of the prototype, well inside each.
TARGETS = np.array([[-2, -0.3, 0], [2.5, -0.5, 0], [1.5, 0.5, 0], [0, 2.7, 0], [0, 5.7, 0]], np.float64)


def traced(path):
    """``(scene, origins, hits, usd_prims, usd_instances)``: the stage loaded and traced down onto :data:`TARGETS`."""
    scene = wrt.load_usd(path)
    origins = TARGETS + (0, 0, 5)
    hits = wrt.trace(scene, origins, DOWN)
    return (scene, origins, hits, *closest_usd_prims(path, origins, DOWN))


def names(scene, geometry_ids, instances) -> list:
    """The paths the raw ids name in ``scene`` (its prim table, as hit_paths reads it), unchecked."""
    ids, _ = scene.hit_prims(geometry_ids, instances)
    return [scene.prim_paths()[i] if i >= 0 else "" for i in ids]


def test_the_scenes_own_hits_name_the_usd_prims_hit(stages):
    a, _ = stages
    scene, origins, hits, prims, instances = traced(a)
    assert prims == ["/World/Left", "/World/Right", "/World/Right", "/World/PI/Protos/Tri", "/World/PI/Protos/Tri"]
    assert instances == ["", "", "", "/World/PI[0]", "/World/PI[1]"]
    named = scene.hit_paths(hits)
    assert list(named[0]) == prims and list(named[1]) == instances
    ids, _ = scene.hit_prims(hits)  # the Hits themselves: checked, named as their ids are
    assert [scene.prim_paths()[i] for i in ids] == prims
    # Copies and pickles of the hits (a Dask result), and of the scene as it is, still name them; so does wp.Mesh's
    # trace, and Hits made by hand (no scene to check: their ids are the caller's).
    for again in (copy.deepcopy(hits), pickle.loads(pickle.dumps(hits))):
        assert list(scene.hit_paths(again)[0]) == prims
    assert list(pickle.loads(pickle.dumps(scene)).hit_paths(hits)[0]) == prims
    warp_hits = wrt.trace(scene, origins, DOWN, accel="warp")
    assert list(scene.hit_paths(warp_hits)[1]) == instances
    by_hand = wrt.Hits(hits.t, hits.u, hits.v, hits.prim, hits.nodes_visited, hits.triangles_tested,
                       instance=hits.instance, local_prim=hits.local_prim)
    assert list(scene.hit_paths(by_hand)[0]) == prims and by_hand == hits


def test_hits_of_another_scene_are_refused_naming_both(stages):
    a, b = stages
    _, _, hits, prims, _ = traced(a)
    other = wrt.load_usd(b)
    # Their ids are ids of b too: named there, they are b's prims, none of them the USD prim hit.
    wrong = names(other, hits.local_prim, hits.instance)
    assert all(w.startswith("/Other/") and w != p for w, p in zip(wrong, prims))
    here = r"these hits were traced in scene '.*a\.usda', not in this one \('.*b\.usda'\)"
    with pytest.raises(ValueError, match="^hit_paths: " + here):
        other.hit_paths(hits)
    with pytest.raises(ValueError, match="^hit_prims: " + here):
        other.hit_prims(hits)
    with pytest.raises(ValueError, match="^secondary_rays: " + here):
        secondary_rays(other, "shadow", TARGETS + (0, 0, 5), DOWN, hits)
    # The same file loaded again is another Scene: its hits are refused with the words for it.
    with pytest.raises(ValueError, match=r"^hit_paths: these hits were traced in another Scene of '.*a\.usda'"):
        wrt.load_usd(a).hit_paths(hits)


def test_hits_from_before_an_edit_are_refused(stages):
    a, _ = stages
    scene, origins, hits, prims, instances = traced(a)
    # A mesh added after the others: the prototype's triangle moves up one, and its old id is the new mesh's.
    scene.meshes.append(wrt.Mesh("/World/Added", [(9, 9, 0), (10, 9, 0), (9, 10, 0)], [[0, 1, 2]], [0]))
    assert names(scene, hits.local_prim, hits.instance) == [*prims[:3], "/World/Added", "/World/Added"]
    assert prims[3:] == ["/World/PI/Protos/Tri"] * 2
    edited = r"the scene was edited since these hits were traced .*: trace again"
    with pytest.raises(ValueError, match="^hit_paths: " + edited):
        scene.hit_paths(hits)
    with pytest.raises(ValueError, match="^hit_prims: " + edited):
        scene.hit_prims(hits)
    with pytest.raises(ValueError, match="^secondary_rays: " + edited):
        secondary_rays(scene, "diffuse", origins, DOWN, hits)
    again = wrt.trace(scene, origins, DOWN)  # traced again: named by the prims the edited scene draws
    assert list(scene.hit_paths(again)[0]) == prims

    scene, origins, hits, prims, instances = traced(a)
    scene.instances = scene.instances.take([1, 0])  # the instances swapped: instance 0 is /World/PI[1] now
    assert [scene.instances.path(int(i)) for i in hits.instance[3:]] == ["/World/PI[1]", "/World/PI[0]"]
    assert instances[3:] == ["/World/PI[0]", "/World/PI[1]"]
    with pytest.raises(ValueError, match="^hit_paths: " + edited):
        scene.hit_paths(hits)
    assert list(scene.hit_paths(wrt.trace(scene, origins, DOWN))[1]) == instances


def test_raw_ids_out_of_range_are_refused_by_hit_prims(stages):
    """``hit_prims(geometry_ids, instances)`` of ids that are no ids of the scene (another scene's, past its
    triangles or instances) gave them prim id -1, a miss, without a word; ``hit_paths`` refused them already. Raw ids
    carry no scene: in range they are the caller's to vouch for, out of range they are refused naming the array."""
    a, _ = stages
    scene = wrt.load_usd(a)  # geometry ids 0-3 (Left, Right's two triangles, the prototype's), instances 0-1
    assert scene.hit_prims([3], [1])[0].tolist() == [scene.prim_paths().index("/World/PI/Protos/Tri")]
    with pytest.raises(ValueError, match=r"^hit_prims: geometry_ids\[1\] = 4 is no id of this scene \(-1 to 3\)"):
        scene.hit_prims([0, 4], [-1, -1])
    with pytest.raises(ValueError, match=r"^hit_prims: instances\[0\] = 2 is no id of this scene \(-1 to 1\)"):
        scene.hit_prims([3], [2])
    with pytest.raises(TypeError, match=r"^hit_prims takes \(geometry_ids, instances\) or the Hits of wrt.trace"):
        scene.hit_prims(np.array([0]))


def test_raw_ids_pairing_an_instance_with_another_prototypes_geometry_are_refused():
    """Geometry id 2 (/P1/c) with instance 0 (of /P0) read the part of that index among instance 0's parts, or the
    next instance's: it was named /I1/b, a prim of another instance and another mesh, without a word (as
    ``Hits.prim``, rows of ``Scene.triangles()``, given for ``Hits.local_prim`` pairs them). Ids of unequal counts
    failed in numpy's words."""
    points, indices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32)
    p0 = wrt.Prototype("/P0", [wrt.Mesh("/P0/a", points, indices)])
    p1 = wrt.Prototype("/P1", [wrt.Mesh("/P1/b", points, indices), wrt.Mesh("/P1/c", points, indices)])
    instances = wrt.Instances(np.int32([0, 1]), np.stack([np.eye(4)] * 2), np.zeros(2, np.int32), np.int32([-1, -1]),
                              ["/PI"], roots=["/I0", "/I1"], root=np.int32([0, 1]))
    scene = wrt.Scene(prototypes=[p0, p1], instances=instances)
    paths = scene.prim_paths()
    assert paths == ["/I0/a", "/I1/b", "/I1/c"]
    # Each instance with its own prototype's geometry (geometry ids 0: /P0/a; 1, 2: /P1/b, /P1/c).
    assert [paths[k] for k in scene.hit_prims([0, 1, 2, -1], [0, 1, 1, -1])[0][:3]] == ["/I0/a", "/I1/b", "/I1/c"]
    for geometry in (1, 2):
        with pytest.raises(ValueError, match=rf"^hit_prims: geometry_ids\[1\] = {geometry} is geometry of prototype "
                                             r"/P1, not of instance 0's \(/P0\)"):
            scene.hit_prims([0, geometry], [0, 0])
    with pytest.raises(ValueError, match=r"geometry_ids and instances must have one entry per hit each, got 2 and 1"):
        scene.hit_prims([0, 1], [0])
