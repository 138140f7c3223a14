"""World-space points of the meshes of a stage as USD's own UsdSkel API poses them (the oracle of
tests/test_skel_generated.py).

For each SkelRoot, ``UsdSkel.Cache.ComputeSkelBindings`` gives the skeleton bound to each skinned mesh. A mesh is
deformed by its blend shapes (``BlendShapeQuery``, weights from the animation remapped by
``GetBlendShapeMapper``), then by ``SkinningQuery.ComputeSkinnedPoints`` (or ``ComputeSkinnedTransform`` when it is
rigidly deformed) with ``SkeletonQuery.ComputeSkinningTransforms``. Skinned points are in the skeleton's space (the
skinning transforms map bind-pose points into it), so they are placed by the Skeleton prim's local-to-world
transform, not the mesh's (UsdSkel schema: "skinning is computed in skeleton space"; ``UsdSkel.BakeSkinning`` writes
them back into the mesh's space through the inverse of the mesh's transform). A mesh with blend shapes only stays in
its own space. Meshes USD does not pose (or whose posing fails) keep their authored points under their own transform.
"""

from __future__ import annotations

import numpy as np
from pxr import Tf, Usd, UsdGeom, UsdSkel, Vt

PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


def _rows(m) -> np.ndarray:
    return np.array(m, np.float64)


def _place(points, m: np.ndarray) -> np.ndarray:
    return np.asarray(points, np.float64) @ m[:3, :3] + m[3, :3]


def _posed(query: UsdSkel.SkinningQuery, skel_query: UsdSkel.SkeletonQuery, skeleton: Usd.Prim, time, xf_cache):
    """World points of the mesh of ``query`` posed by ``skel_query`` at ``time`` and placed by ``skeleton`` (the
    bound Skeleton prim: an instance proxy inside instances, where ``skel_query``'s prim is the prototype's), or None
    when USD fails to pose it."""
    prim = query.GetPrim()
    points = UsdGeom.Mesh(prim).GetPointsAttr().Get(time)
    anim = skel_query.GetAnimQuery()
    if query.HasBlendShapes() and anim:
        weights = anim.ComputeBlendShapeWeights(time)
        if weights is not None and len(weights):
            mapper = query.GetBlendShapeMapper()
            if mapper and not mapper.IsNull():
                weights = mapper.Remap(weights, Vt.FloatArray())
            shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
            sub_weights, shape_ids, sub_ids = shapes.ComputeSubShapeWeights(weights)
            points = Vt.Vec3fArray(points)
            if not shapes.ComputeDeformedPoints(sub_weights, shape_ids, sub_ids,
                                                shapes.ComputeBlendShapePointIndices(),
                                                shapes.ComputeSubShapePointOffsets(), points):
                return None
    if not query.HasJointInfluences():
        return _place(points, _rows(xf_cache.GetLocalToWorldTransform(prim)))
    xforms = skel_query.ComputeSkinningTransforms(time)
    if xforms is None or len(xforms) != len(skel_query.GetJointOrder()):
        return None
    skel_to_world = _rows(xf_cache.GetLocalToWorldTransform(skeleton))
    if query.IsRigidlyDeformed():
        xform = query.ComputeSkinnedTransform(xforms, time)
        if xform is None:
            return None
        return _place(points, _rows(xform) @ skel_to_world)
    points = Vt.Vec3fArray(points)
    if not query.ComputeSkinnedPoints(xforms, points, time):
        return None
    return _place(points, skel_to_world)


def world_points(stage: Usd.Stage, time: float) -> dict[str, np.ndarray | None]:
    """Mesh path (instance-proxy paths inside instances) -> ``(V, 3)`` float64 world points at ``time`` as USD poses
    them; None for a mesh USD binds to a skeleton but fails to pose."""
    at = Usd.TimeCode(time)
    xf_cache = UsdGeom.XformCache(at)
    cache = UsdSkel.Cache()
    posed = {}
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), PREDICATE):
        if prim.IsA(UsdSkel.Root):
            root = UsdSkel.Root(prim)
            cache.Populate(root, PREDICATE)
            for binding in cache.ComputeSkelBindings(root, PREDICATE):
                skel_query = cache.GetSkelQuery(binding.GetSkeleton())
                skeleton = binding.GetSkeleton().GetPrim()
                for query in binding.GetSkinningTargets():
                    path = str(query.GetPrim().GetPath())
                    try:
                        answer = _posed(query, skel_query, skeleton, at, xf_cache)
                    except Tf.ErrorException:  # USD's own failure (a skeleton whose joints are not a tree)
                        answer = None
                    posed.setdefault(path, []).append(answer)
    out = {}
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), PREDICATE):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        path = str(prim.GetPath())
        if path in posed:
            answers = posed[path]
            out[path] = answers[0]  # a mesh under nested SkelRoots is posed by each: the caller checks they agree
            out[path + "#all"] = answers
        else:
            points = UsdGeom.Mesh(prim).GetPointsAttr().Get(at)
            out[path] = _place(points, _rows(xf_cache.GetLocalToWorldTransform(prim)))
    return out
