"""Seeded generator of UsdSkel stages for differential tests of wrt's skinning (tests/test_skel_generated.py).

Each stage holds one or more SkelRoots (some nested, some under transformed Xforms), each with a random joint tree
(chains and branches), an animation that is time-sampled, static, partial and reordered, of blend shape weights only
or absent (rest pose), bound on the Skeleton or inherited from the SkelRoot, and meshes of triangles skinned by it:
influences of vertex or constant interpolation with 1 to 4 per point and weights that need not sum to 1, a local
``skel:joints`` order, a ``geomBindTransform``, blend shapes with and without ``pointIndices`` and inbetweens, either
skinning method, and transforms on the mesh and on Xforms between it and its SkelRoot; ``skel:skeleton`` bound on the
SkelRoot, on an Xform or on each mesh, a nested SkelRoot that borrows the outer one's skeleton, and constant
influences on an Xform inherited by a mesh beneath it.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt

TIMES = (1.0, 4.0, 6.5, 10.0)  # time codes the tests read (samples at 1, 5 and 10, and between them)


def _rotation(rng) -> Gf.Quatf:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return Gf.Quatf(float(q[0]), Gf.Vec3f(*(float(v) for v in q[1:])))


def _matrix(rng, scale=True) -> Gf.Matrix4d:
    """A random affine transform: rotation, translation and (``scale``) a positive non-uniform scale."""
    m = Gf.Matrix4d(1.0)
    q = _rotation(rng)
    m.SetRotate(Gf.Rotation(Gf.Quatd(q.GetReal(), Gf.Vec3d(q.GetImaginary()))))
    if scale:
        s = rng.uniform(0.6, 1.5, 3)
        m = Gf.Matrix4d(1.0).SetScale(Gf.Vec3d(*s)) * m
    m.SetTranslateOnly(Gf.Vec3d(*rng.uniform(-1.5, 1.5, 3)))
    return m


def _xform(prim, rng, what: str):
    """Random xformOps on ``prim`` (``what``: "none", "static" or "animated" over :data:`TIMES`)."""
    if what == "none":
        return
    xf = UsdGeom.Xformable(prim)
    translate = xf.AddTranslateOp()
    rotate = xf.AddRotateXYZOp()
    scale = xf.AddScaleOp()
    times = [Usd.TimeCode.Default()] if what == "static" else [Usd.TimeCode(t) for t in (1.0, 10.0)]
    for t in times:
        translate.Set(Gf.Vec3d(*rng.uniform(-2, 2, 3)), t)
        rotate.Set(Gf.Vec3f(*rng.uniform(-90, 90, 3)), t)
        scale.Set(Gf.Vec3f(*rng.uniform(0.7, 1.4, 3)), t)


def _joint_tree(rng, n: int) -> list[str]:
    """``n`` joint paths, parents first: each joint's parent is an earlier joint (chains and branches), or a root."""
    paths = []
    for k in range(n):
        parent = int(rng.integers(-1, k)) if k else -1
        name = f"j{k}"
        paths.append(name if parent < 0 or rng.random() < 0.1 else f"{paths[parent]}/{name}")
    return paths


def _local_of(paths, world):
    """Local (parent-relative) transforms of joints whose skeleton-space transforms are ``world``."""
    by_path = {p: i for i, p in enumerate(paths)}
    local = []
    for i, p in enumerate(paths):
        parent = by_path.get(p.rsplit("/", 1)[0]) if "/" in p else None
        local.append(world[i] if parent is None else world[i] * world[parent].GetInverse())
    return local


def _skeleton(stage, path, rng, options):
    skel = UsdSkel.Skeleton.Define(stage, path)
    n = int(rng.integers(2, 7))
    joints = _joint_tree(rng, n)
    skel.GetJointsAttr().Set(Vt.TokenArray(joints))
    bind_world = [_matrix(rng, scale=rng.random() < 0.3) for _ in joints]
    skel.GetBindTransformsAttr().Set(Vt.Matrix4dArray(bind_world))
    rest = _local_of(joints, [_matrix(rng, scale=False) for _ in joints])
    anim_kind = options.get("anim", rng.choice(["sampled", "static", "partial", "shapes", "none"]))
    if anim_kind != "none" or rng.random() < 0.8:  # no animation and no rest pose: skinning fails (the last case)
        skel.GetRestTransformsAttr().Set(Vt.Matrix4dArray(rest))
    _xform(skel.GetPrim(), rng, rng.choice(["none", "static", "animated"]))
    return skel, joints, anim_kind


def _animation(stage, path, rng, joints, kind, blend_shapes):
    anim = UsdSkel.Animation.Define(stage, path)
    order = list(joints)
    if kind == "partial":  # a subset of the joints, in another order: the rest keep their rest transforms
        order = [joints[i] for i in rng.permutation(len(joints))[: max(1, len(joints) - 1)]]
    elif kind == "shapes":  # blend shape weights only: every joint keeps its rest transform
        order = []
    anim.GetJointsAttr().Set(Vt.TokenArray(order))
    n = len(order)
    times = [Usd.TimeCode.Default()] if kind == "static" else [Usd.TimeCode(t) for t in (1.0, 5.0, 10.0)]
    for t in times if n else ():
        anim.GetTranslationsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*rng.uniform(-1, 1, 3)) for _ in range(n)]), t)
        anim.GetRotationsAttr().Set(Vt.QuatfArray([_rotation(rng) for _ in range(n)]), t)
        anim.GetScalesAttr().Set(Vt.Vec3hArray([Gf.Vec3h(*rng.uniform(0.6, 1.4, 3)) for _ in range(n)]), t)
    if blend_shapes:
        shapes = list(blend_shapes)
        rng.shuffle(shapes)  # the animation's order differs from the meshes'
        anim.GetBlendShapesAttr().Set(Vt.TokenArray(shapes))
        for t in times:
            anim.GetBlendShapeWeightsAttr().Set(Vt.FloatArray(list(rng.uniform(-0.3, 1.3, len(shapes)))), t)
    return anim


def _mesh(stage, path, rng, joints, shape_names, skeleton=None):
    """A mesh of random triangles skinned by ``joints`` (a random local ``skel:joints`` order or the skeleton's);
    blend shapes named from ``shape_names`` (which it extends). Returns the mesh."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    n_tris = int(rng.integers(1, 5))
    n_points = 3 * n_tris
    points = rng.uniform(-1, 1, (n_points, 3))
    if rng.random() < 0.2:  # points sampled over time, as a cache of a simulation under the skinning
        for t in (2.0, 8.0):
            moved = points + rng.uniform(-0.2, 0.2, points.shape)
            mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(moved.astype(np.float32)), Usd.TimeCode(t))
    else:
        mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    mesh.GetFaceVertexCountsAttr().Set(Vt.IntArray([3] * n_tris))
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray([int(i) for i in rng.permutation(n_points)]))
    mesh.GetSubdivisionSchemeAttr().Set("none")
    if rng.random() < 0.5:  # authored normals, skinned with the points
        normals = rng.normal(size=(n_points, 3))
        mesh.GetNormalsAttr().Set(Vt.Vec3fArray.FromNumpy(normals.astype(np.float32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.GetDoubleSidedAttr().Set(True)
    _xform(mesh.GetPrim(), rng, rng.choice(["none", "static", "animated"]))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    if skeleton is not None:
        binding.CreateSkeletonRel().SetTargets([skeleton])
    local = list(joints)
    if rng.random() < 0.5:  # a local joint order: a subset of the skeleton's joints, shuffled
        local = [joints[i] for i in rng.permutation(len(joints))[: int(rng.integers(1, len(joints) + 1))]]
        binding.CreateJointsAttr(Vt.TokenArray(local))
    influence = rng.choice(["vertex", "vertex", "constant", "blend shapes only"])
    if influence != "blend shapes only":
        per_point = int(rng.integers(1, 5))
        count = per_point * (n_points if influence == "vertex" else 1)
        indices = rng.integers(0, len(local), count)
        weights = rng.uniform(0.0, 1.0, count)
        if rng.random() < 0.5:  # normalized, as most exporters write them
            weights = (weights.reshape(-1, per_point) / weights.reshape(-1, per_point).sum(1, keepdims=True)).ravel()
        indices_primvar = binding.CreateJointIndicesPrimvar(influence == "constant", per_point)
        indices_primvar.Set(Vt.IntArray([int(i) for i in indices]))
        weights_primvar = binding.CreateJointWeightsPrimvar(influence == "constant", per_point)
        if rng.random() < 0.2:  # weights sampled over time
            for t in (3.0, 7.0):
                weights_primvar.Set(Vt.FloatArray(list(rng.uniform(0.0, 1.0, count))), Usd.TimeCode(t))
        else:
            weights_primvar.Set(Vt.FloatArray(list(weights)))
        if rng.random() < 0.6:
            binding.CreateGeomBindTransformAttr(_matrix(rng))
        if rng.random() < 0.5:
            binding.CreateSkinningMethodAttr(str(rng.choice(["classicLinear", "dualQuaternion"])))
    if rng.random() < 0.6 or influence == "blend shapes only":
        names, targets = [], []
        for k in range(int(rng.integers(1, 3))):
            name = f"{mesh.GetPrim().GetName()}_s{k}"
            shape = UsdSkel.BlendShape.Define(stage, mesh.GetPath().AppendChild(f"shape{k}"))
            sparse = rng.random() < 0.5
            at = rng.choice(n_points, int(rng.integers(1, n_points + 1)), replace=False) if sparse else None
            m = n_points if at is None else len(at)
            shape.GetOffsetsAttr().Set(Vt.Vec3fArray.FromNumpy(rng.uniform(-0.5, 0.5, (m, 3)).astype(np.float32)))
            if at is not None:
                shape.GetPointIndicesAttr().Set(Vt.IntArray([int(i) for i in at]))
            for w in sorted(rng.uniform(-0.5, 1.5, int(rng.integers(0, 3)))):
                inbetween = shape.CreateInbetween(f"ib{int(w * 1000) + 500}")
                inbetween.SetWeight(float(w))
                inbetween.SetOffsets(Vt.Vec3fArray.FromNumpy(rng.uniform(-0.5, 0.5, (m, 3)).astype(np.float32)))
            names.append(name)
            targets.append(shape.GetPath())
        binding.CreateBlendShapesAttr(Vt.TokenArray(names))
        binding.CreateBlendShapeTargetsRel().SetTargets(targets)
        shape_names.extend(names)
    return mesh


def _skel_root(stage, path: str, rng, options, depth=0):
    """A SkelRoot at ``path`` with a skeleton, its animation and meshes (some under Xforms); maybe a nested root."""
    root = UsdSkel.Root.Define(stage, path)
    _xform(root.GetPrim(), rng, rng.choice(["none", "static", "animated"]))
    skel, joints, anim_kind = _skeleton(stage, f"{path}/Skel", rng, options)
    bound_on_root = rng.random() < 0.5
    # skel:skeleton on the SkelRoot (inherited), on an Xform between it and the mesh, or on each mesh
    bind_at = rng.choice(["root", "group", "mesh"])
    if bind_at == "root":
        UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])
    shape_names = []
    meshes = []
    for k in range(int(rng.integers(1, 4))):
        parent = path
        if rng.random() < 0.5 or bind_at == "group":  # an Xform between the SkelRoot and the mesh
            parent = f"{path}/Group{k}"
            group = UsdGeom.Xform.Define(stage, parent).GetPrim()
            _xform(group, rng, rng.choice(["static", "animated"]))
            if bind_at == "group":
                UsdSkel.BindingAPI.Apply(group).CreateSkeletonRel().SetTargets([skel.GetPath()])
        bound = skel.GetPath() if bind_at == "mesh" else None
        meshes.append(_mesh(stage, f"{parent}/Mesh{k}", rng, joints, shape_names, bound))
        if parent != path and rng.random() < 0.3:
            # Constant influences on the Xform, inherited by a mesh of no influences of its own (bound rigidly)
            holder = UsdSkel.BindingAPI.Apply(stage.GetPrimAtPath(parent))
            per_point = int(rng.integers(1, 3))
            # in range of the sibling's own skel:joints too, should it inherit them (a blend-shape-only mesh does)
            local = UsdSkel.BindingAPI(meshes[-1]).GetJointsAttr().Get() or joints
            holder.CreateJointIndicesPrimvar(True, per_point).Set(
                Vt.IntArray([int(i) for i in rng.integers(0, len(local), per_point)]))
            holder.CreateJointWeightsPrimvar(True, per_point).Set(Vt.FloatArray(list(rng.uniform(0.2, 1, per_point))))
            plain = UsdGeom.Mesh.Define(stage, f"{parent}/Held{k}")
            plain.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(rng.uniform(-1, 1, (3, 3)).astype(np.float32)))
            plain.GetFaceVertexCountsAttr().Set(Vt.IntArray([3]))
            plain.GetFaceVertexIndicesAttr().Set(Vt.IntArray([0, 1, 2]))
            plain.GetSubdivisionSchemeAttr().Set("none")
            _xform(plain.GetPrim(), rng, "static")
            if bound is not None:
                UsdSkel.BindingAPI.Apply(plain.GetPrim()).CreateSkeletonRel().SetTargets([bound])
    if depth == 0 and options.get("borrow", rng.random() < 0.2):
        # A nested SkelRoot without a skeleton of its own: its mesh is bound to this one's (inherited or its own rel)
        inner = UsdSkel.Root.Define(stage, f"{path}/Borrow")
        _xform(inner.GetPrim(), rng, rng.choice(["none", "static"]))
        bound = skel.GetPath() if bind_at != "root" else None
        meshes.append(_mesh(stage, f"{path}/Borrow/Mesh", rng, joints, shape_names, bound))
    if anim_kind != "none":
        anim = _animation(stage, f"{path}/Anim", rng, joints, anim_kind, shape_names)
        holder = root.GetPrim() if bound_on_root else skel.GetPrim()
        UsdSkel.BindingAPI.Apply(holder).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    if depth == 0 and options.get("nested", rng.random() < 0.3):
        _skel_root(stage, f"{path}/Inner", rng, options, depth + 1)
    return root


def generate(seed: int, path: str, instanced: bool = False, **options) -> str:
    """Writes the stage of ``seed`` to ``path`` (``.usda``) and returns ``path``.

    Args:
        seed: the RNG seed; the same seed gives the same stage.
        path: the file to write.
        instanced: the SkelRoots live in a class prim referenced by two instanceable Xforms.
        options: ``anim`` ("sampled", "static", "partial", "shapes" or "none"), ``nested`` and ``borrow`` (bool)
            fix those choices.
    """
    rng = np.random.default_rng(seed)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(10)
    top = "/Proto" if instanced else "/World"
    if instanced:
        stage.CreateClassPrim(top)
    else:
        _xform(UsdGeom.Xform.Define(stage, top).GetPrim(), rng, "static")
    for k in range(int(rng.integers(1, 3))):
        parent = f"{top}/Above{k}"
        _xform(UsdGeom.Xform.Define(stage, parent).GetPrim(), rng, rng.choice(["static", "animated"]))
        _skel_root(stage, f"{parent}/Char", rng, options)
    if instanced:
        for name in ("A", "B"):
            prim = UsdGeom.Xform.Define(stage, f"/{name}").GetPrim()
            prim.GetReferences().AddInternalReference(Sdf.Path(top))
            prim.SetInstanceable(True)
            _xform(prim, rng, "static")
    stage.GetRootLayer().Export(path)
    return path
