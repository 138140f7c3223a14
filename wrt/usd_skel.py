"""Poses meshes skinned by a UsdSkel skeleton as USD poses them at the load's time (glTF, Maya and Houdini
characters keep their bind pose in ``points`` and move only through their skeleton).

A mesh is posed when it has joint influences (``primvars:skel:jointIndices``/``jointWeights``; constant ones may be
inherited from an ancestor, binding every mesh beneath it rigidly) or blend shapes (``skel:blendShapes``), a
skeleton bound to it or an ancestor (``skel:skeleton``, authored at or below a ``SkelRoot``) and a ``SkelRoot``
above it (below any PointInstancer above it): the same conditions as UsdSkel's. Its points go through its blend
shapes (weighted by the skeleton's animation), then through linear blend (or dual quaternion) skinning by
``UsdSkel.SkinPoints`` with the influences of its ``UsdSkel.SkinningQuery``, after ``geomBindTransform``; a rigidly
bound mesh (constant joint influences) is moved by ``UsdSkel.SkinTransform``. The result is in the skeleton's space:
the caller places it with the skeleton prim's transform, not the mesh's own, as ``UsdSkel.BakeSkinning`` and
UsdSkelImaging do. Authored normals (every interpolation) are skinned with the inverse transposes of the same joint
transforms and weights (``UsdSkel.SkinNormals``), after blend shapes' ``normalOffsets``.

Time: the animation is read at the load's time; with the default time, an animation whose joint transforms or blend
shape weights have only time samples is read at its first sample, as wrt reads every other attribute
(:func:`wrt.usd_values.read_time`), the mesh's jointIndices, jointWeights and geomBindTransform each on its own.
A mesh whose skinning fails (joint indices out of range, influences that do not match its points, a skeleton that cannot
be posed, bind transforms that do not match its joints or cannot be inverted, a ``geomBindTransform`` that is not finite
or cannot be inverted, an unknown skinning method, weights or a pose that are not finite, an inactive skeleton, a
``skel:skeleton`` that targets no Skeleton (a missing prim, an ``over``: USD warns naming no mesh), a SkelRoot or
skeleton outside the native prototype that holds it) keeps its unposed points, with a warning naming it (and the target,
for a binding to no Skeleton). A skeleton whose ``skel:animationSource`` targets no SkelAnimation (a missing prim, an
``over``, another type, an inactive one) poses its meshes at its rest transforms, as UsdSkel does, with a warning naming
it and the target. A ``skel:joints`` entry the skeleton lacks, weighted by some point, poses those points with the
identity as UsdSkel does, with a warning naming the mesh and the joint (USD says nothing). A blend shape that does not
fit its mesh (``offsets`` or ``normalOffsets`` of another length than its ``pointIndices``, or than the mesh's points
without them; a point index out of range; offsets that are not finite; a ``skel:blendShapeTargets`` entry that is no
BlendShape) is left out, with a warning naming the mesh, the BlendShape and what is wrong; the mesh's other blend shapes
and its skinning still apply (BakeSkinning, given a weight for an entry that is no BlendShape, applies none of them,
or that weight to the offsets of the sub-shape USD's query numbers it with where those have no pointIndices).
A ``skel:blendShapes`` longer than its ``skel:blendShapeTargets`` (or shorter) pairs them
entry by entry as far as the shorter goes and leaves out the rest, with a warning naming the mesh and the names (or
targets) left out; USD warns of the sizes only, naming no mesh, and applies none of the mesh's blend shapes.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt

from .usd_ancestors import KEEP_LOOKING, AncestorMemo
from .usd_primvars import flattened, index_problem
from .usd_problems import authored_type
from .usd_values import read_time

_ANIMATED = ("translations", "rotations", "scales", "blendShapeWeights")  # SkelAnimation attributes read per time
FAILED = "UsdSkel skinning failed; these meshes are drawn in their unposed points"  # warning reason
REFUSED_INFLUENCES = ("UsdSkel joint influences that UsdSkel cannot use (an elementSize of 0 or that differs, an "
                      "interpolation that differs, weights that are not numbers, indices not authored as int[] or "
                      "weights not as float[], indexed ones that cannot be flattened) were ignored, as UsdSkel "
                      "ignores them; these meshes are not skinned (blend shapes still apply)")  # warning reason
BAD_SHAPE = "UsdSkel blend shapes that do not fit their mesh were left out; the rest of its pose applies"  # reason
UNPAIRED_SHAPES = ("UsdSkel skel:blendShapes and skel:blendShapeTargets differ in length; the entries past the "
                   "shorter list were left out (USD leaves out every blend shape of the mesh); the rest of its pose "
                   "applies")  # warning reason: skel:blendShapes[i] pairs with skel:blendShapeTargets[i]
NO_ANIMATION = ("UsdSkel skel:animationSource targets no SkelAnimation; these skeletons pose their meshes at their "
                "rest transforms, as UsdSkel does")  # warning reason (the skeleton's prim named)
MISSING_JOINTS = ("UsdSkel skel:joints name joints their skeleton lacks; points weighted to them take the identity, "
                  "as UsdSkel's")  # warning reason: the mesh is posed as BakeSkinning poses it


class SkelPoser:
    """Poses the skinned meshes of one load; skeletons and their transforms are computed once each.

    Args:
        time: the load's time code.
        skip: ``skip(reason, prim, detail)`` records a mesh left unposed (one warning per reason).
        shown_path: ``shown_path(prim)``, the path naming a prim in warnings (a BlendShape in a prototype too).
    """

    def __init__(self, time: Usd.TimeCode, skip, shown_path=lambda prim: str(prim.GetPath())):
        self.time = time
        self.skip = skip
        self.shown_path = shown_path
        self.cache = UsdSkel.Cache()
        self.roots = set()  # SkelRoot paths populated in the cache
        # The nearest SkelRoot at or above a prim (within its prototype, for prims inside one) and below any
        # PointInstancer above it, or None; remembered for every prim walked, as every mesh asks. UsdSkel's cache
        # populated from a SkelRoot leaves out the subtrees of the PointInstancers below it: a prototype is skinned
        # by a SkelRoot of its own, or not at all.
        self.nearest_skel_root = AncestorMemo(
            lambda p: p if p.IsA(UsdSkel.Root) else None if p.IsA(UsdGeom.PointInstancer) else KEEP_LOOKING)
        self.poses = {}  # skeleton path -> (skinning transforms (Vt.Matrix4dArray) or why not, anim time, anim query)

    def pose(self, prim: Usd.Prim, points: np.ndarray, normals, vertex_ids: np.ndarray, content_root: str):
        """``prim``'s points (and normals) posed, in its skeleton's space.

        Args:
            prim: a ``UsdGeom.Mesh``.
            points: ``(V, 3)`` float64, the mesh's points as read (its own space, unposed).
            normals: ``(values (K, 3), corner index (T, 3))`` in the mesh's space, or None.
            vertex_ids: ``(T, 3)`` int rows into ``points`` of each triangle corner (the corners of ``normals``).
            content_root: path of the subtree being read (``/`` or a prototype's root); a skeleton outside it cannot
                be placed in its space, so the mesh stays unposed (with a warning).

        Returns:
            ``(points (V, 3) float64, normals like the argument's, the prim whose space they are in)``: the
            skeleton's, or ``prim``'s own for a mesh posed by blend shapes only. None when USD does not pose ``prim``
            or its skinning failed (recorded through ``skip``).
        """
        # Authored, not merely defined: SkelBindingAPI, which exporters apply to every mesh under a SkelRoot, defines
        # both on a static mesh too, which was then named as one whose skinning failed beside a bad skel:skeleton.
        own = any(prim.GetAttribute(name).HasAuthoredValue() for name in ("primvars:skel:jointIndices",
                                                                          "skel:blendShapes"))
        root = self.skel_root(prim)
        if root is None:
            if prim.IsInPrototype() and self._skinned_from_above_its_instance(prim):
                self.skip(FAILED, prim, "SkelRoot above its instance (each instance would be posed on its own)")
            return None  # USD does not pose it either
        skeleton = self._bound_skeleton(prim)
        if not skeleton:
            if skeleton is not None and self._has_influences_or_shapes(prim, own):  # a target that is no Skeleton
                target = self._skeleton_target(prim)
                why = _not_a("Skeleton", prim.GetStage(), target)
                self.skip(FAILED, prim, f"skel:skeleton targets {target}, but {why}")
            return None
        if not own:  # constant influences inherited from an ancestor bind it rigidly (UsdSkel's query knows)
            try:
                self._populate(root)
                query = self.cache.GetSkinningQuery(prim)
            except RuntimeError:  # Tf errors: nothing USD would pose either
                return None
            if not (query and query.HasJointInfluences()):
                return None
        if not skeleton.GetPath().HasPrefix(Sdf.Path(content_root)):
            self.skip(FAILED, prim, "skeleton outside the instance prototype")
            return None
        try:
            posed = self._pose(prim, root, skeleton, points, normals, vertex_ids)
            if not np.isfinite(posed[0]).all():  # the load would fail on them, naming the mesh's points
                raise ValueError("posed points are not finite (a joint transform or blend shape that is not)")
            return posed
        except (RuntimeError, ValueError, IndexError, TypeError) as e:  # RuntimeError: Tf errors, null prims
            self.skip(FAILED, prim, str(e).strip().splitlines()[-1][:120] or type(e).__name__)
            return None

    def skel_root(self, prim: Usd.Prim) -> Usd.Prim | None:
        """The outermost SkelRoot at or above ``prim`` (within its prototype, for prims inside one, and below any
        PointInstancer above it), or None: UsdSkel resolves a nested SkelRoot's meshes from the outer one
        (``ComputeSkelBindings`` of the inner one misses a binding above it, and the cache populated from it posed
        them without their blend shapes, 1.4 from USD's); but not across a PointInstancer, whose subtree the outer
        one's cache leaves out (a SkelRoot that is its prototype was drawn unposed, 5.9 from BakeSkinning's)."""
        root = self.nearest_skel_root(prim)
        while root is not None:
            outer = self.nearest_skel_root(root.GetParent())
            if outer is None:
                return root
            root = outer
        return None

    def _skinned_from_above_its_instance(self, prim: Usd.Prim) -> bool:
        """Whether USD skins ``prim``, a mesh in a native prototype with no SkelRoot in it, through its proxy in the
        first instance (by a SkelRoot, skeleton and influences found above that instance): USD poses each instance's
        proxy on its own, which a prototype read once cannot be."""
        proxy = prim.GetStage().GetPrimAtPath(self.shown_path(prim))
        if not proxy or proxy.IsInPrototype() or self.skel_root(proxy) is None:
            return False
        if not self._bound_skeleton(proxy):
            return False
        influences = UsdGeom.PrimvarsAPI(proxy).FindPrimvarWithInheritance("skel:jointIndices")
        shapes = proxy.GetAttribute("skel:blendShapes")  # (a Usd.Prim has no HasAuthoredValue of its own)
        return bool(influences and influences.HasAuthoredValue()) or shapes.HasAuthoredValue()

    def _bound_skeleton(self, prim: Usd.Prim) -> UsdSkel.Skeleton | None:
        """The Skeleton bound to ``prim``: by ``skel:skeleton`` on it or on the nearest ancestor that has one, as
        ``GetInheritedSkeleton`` finds it, but only up to its :meth:`skel_root` (None without one). UsdSkel resolves
        bindings walking down from that SkelRoot, so one authored above it binds nothing (``ComputeSkelBindings``
        and BakeSkinning leave the meshes unposed): above every SkelRoot wrt posed them, 5.9 from USD's."""
        root = self.skel_root(prim)
        if root is None:
            return None
        while prim:
            rel = prim.GetRelationship("skel:skeleton")
            if rel and rel.HasAuthoredTargets():
                return UsdSkel.BindingAPI(prim).GetSkeleton()
            if prim == root:
                return None
            prim = prim.GetParent()
        return None

    @staticmethod
    def _skeleton_target(prim: Usd.Prim) -> Sdf.Path:
        """The first target of the ``skel:skeleton`` that binds ``prim`` (its own or the nearest ancestor's)."""
        while not prim.GetRelationship("skel:skeleton").HasAuthoredTargets():
            prim = prim.GetParent()
        return prim.GetRelationship("skel:skeleton").GetTargets()[0]

    @staticmethod
    def _has_influences_or_shapes(prim: Usd.Prim, own: bool) -> bool:
        """``prim`` has joint influences (its own or constant ones inherited) or blend shapes: USD would pose it."""
        inherited = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("skel:jointIndices")
        return own or bool(inherited and inherited.HasAuthoredValue())

    def _populate(self, root: Usd.Prim):
        if str(root.GetPath()) not in self.roots:
            self.cache.Populate(UsdSkel.Root(root), Usd.PrimDefaultPredicate)
            self.roots.add(str(root.GetPath()))

    def _pose(self, prim, root, skeleton, points, normals, vertex_ids):
        self._populate(root)
        query = self.cache.GetSkinningQuery(prim)
        if not query:
            raise ValueError("invalid joint influences or skel:joints")
        xforms, anim_time, anim = self._skinning_transforms(skeleton)
        if query.HasBlendShapes() and anim:
            points, normals = self._blend(prim, query, anim, anim_time, points, normals, vertex_ids)
        if not query.HasJointInfluences():
            if prim.GetAttribute("primvars:skel:jointIndices").HasAuthoredValue():  # UsdSkel printed, naming no mesh
                self.skip(REFUSED_INFLUENCES, prim)
            return points, normals, prim  # blend shapes only: still in the mesh's own space
        unusable = _unusable_influences(query, self.time)
        if unusable is not None:  # BakeSkinning applies the blend shapes alone
            self.skip(REFUSED_INFLUENCES, prim, unusable)
            return points, normals, prim
        if isinstance(xforms, str):
            raise ValueError(xforms)
        skin = _Influences(query, xforms, self.time)
        missing = skin.weighted_joints_missing_from(self.cache.GetSkelQuery(skeleton).GetJointOrder())
        if missing:  # USD says nothing of them; almost always a skeleton renamed or re-exported without the mesh
            k, name = missing[0]
            self.skip(MISSING_JOINTS, prim, f"skel:joints[{k}] = '{name}' is not a joint of {skeleton.GetPath()}")
        if query.IsRigidlyDeformed():
            m = skin.rigid_transform()
            if normals is not None:
                values, corners = normals
                normals = values @ _inverse_transpose(m[:3, :3]), corners
            return points @ m[:3, :3] + m[3, :3], normals, skeleton.GetPrim()
        points = skin.points(points)
        return points, None if normals is None else skin.normals(normals, vertex_ids), skeleton.GetPrim()

    def _skinning_transforms(self, skeleton: UsdSkel.Skeleton):
        """``(skinning transforms in the skeleton's joint order, or why there are none (str); the time the animation
        is read at; its query, or None)`` of ``skeleton``, computed once per load."""
        key = str(skeleton.GetPath())
        if key not in self.poses:
            skel_query = self.cache.GetSkelQuery(skeleton)
            anim = skel_query.GetAnimQuery() if skel_query else None
            anim_time = self.time
            if anim and self.time.IsDefault():
                attrs = [anim.GetPrim().GetAttribute(name) for name in _ANIMATED]
                if any(a and read_time(a, self.time) != self.time for a in attrs):
                    anim_time = Usd.TimeCode.EarliestTime()
            if skel_query and not anim:
                self._name_missing_animation(skeleton.GetPrim())
            joints = len(skel_query.GetJointOrder()) if skel_query else 0
            binds = skel_query.GetJointWorldBindTransforms() if skel_query else []
            singular = [k for k, m in enumerate(binds) if not (np.isfinite(m).all() and m.GetDeterminant() != 0.0)]
            xforms = "the skeleton cannot be posed (no animation or rest transforms for its joints)"
            if not skeleton.GetPrim().IsActive():  # UsdSkel has no query for it; it has rest transforms all the same
                xforms = f"the skeleton {skeleton.GetPath()} is inactive"
            elif skel_query and len(binds) != joints:
                # ComputeSkinningTransforms then returns the joints' unbound transforms (its failure is not seen here).
                xforms = f"the skeleton's bindTransforms do not match its {joints} joints"
            elif singular:  # skinning uses their inverses; Gf's inverse of a singular matrix is FLT_MAX scaled
                xforms = f"the skeleton's bindTransforms[{singular[0]}] cannot be inverted"
            elif skel_query:
                computed = skel_query.ComputeSkinningTransforms(anim_time)
                xforms = computed if computed is not None and len(computed) == joints else xforms
            self.poses[key] = (xforms, anim_time, anim or None)
        return self.poses[key]

    def _name_missing_animation(self, skeleton: Usd.Prim):
        """Names ``skeleton`` where its ``skel:animationSource`` (its own, else the nearest ancestor's) targets no
        SkelAnimation UsdSkel takes: its meshes are posed at its rest transforms, as UsdSkel poses them, a still
        character where an animation was meant (USD warns of a missing target naming no mesh; of others, nothing)."""
        prim = skeleton
        while prim and not prim.IsPseudoRoot():
            rel = prim.GetRelationship("skel:animationSource")
            if rel and rel.HasAuthoredTargets():
                targets = rel.GetForwardedTargets()
                found = prim.GetStage().GetPrimAtPath(targets[0]) if targets else None
                if targets and not (found and found.IsA(UsdSkel.Animation) and found.IsActive()):  # (else: unbound)
                    why = _not_a("SkelAnimation", prim.GetStage(), targets[0])
                    self.skip(NO_ANIMATION, skeleton, f"skel:animationSource targets {targets[0]}, but {why}")
                return
            prim = prim.GetParent()

    def _blend(self, prim, query, anim, anim_time, points, normals, vertex_ids):
        """``points`` moved and ``normals`` (as :meth:`pose` takes them, or None) turned by the blend shapes of
        ``prim`` at the animation's weights (``BlendShapeQuery``), less those that do not fit it (recorded through
        ``skip``: USD fails the whole deformation for one of them)."""
        weights = anim.ComputeBlendShapeWeights(anim_time)
        mapper = query.GetBlendShapeMapper()
        if weights is None:
            return points, normals
        if mapper:
            # Into the mesh's skel:blendShapes order and size, as BakeSkinning poses them: a null mapper (the
            # animation names none of them, or no blend shapes at all: joints only) gives each weight 0, the identity
            # pads missing weights with 0.
            weights = mapper.Remap(weights, Vt.FloatArray())
        shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
        if len(weights) != shapes.GetNumBlendShapes():
            weights = self._paired_weights(prim, weights, shapes.GetNumBlendShapes())
        sub_weights, shape_ids, sub_ids = shapes.ComputeSubShapeWeights(weights)
        point_indices = shapes.ComputeBlendShapePointIndices()
        sub_offsets = shapes.ComputeSubShapePointOffsets()
        misfits = {}  # blend shape index -> what is wrong with it (at weight 0 it moves nothing, and USD skips it)
        targets = UsdSkel.BindingAPI(prim).GetBlendShapeTargetsRel().GetTargets()
        for shape in range(shapes.GetNumBlendShapes()):
            # A target that is no BlendShape has no sub-shape, yet ComputeSubShapeWeights gives it one past the end
            # (wrt's skinning failed on it, IndexError, the mesh unposed): left out, as BakeSkinning poses the mesh.
            if not shapes.GetBlendShape(shape):
                misfits[shape] = _not_a("BlendShape", prim.GetStage(), targets[shape])
                self.skip(BAD_SHAPE, prim, f"skel:blendShapeTargets[{shape}] = {targets[shape]}: {misfits[shape]}")
        for weight, shape, sub in zip(sub_weights, shape_ids, sub_ids):
            why = None if weight == 0.0 or shape in misfits else _misfit(
                shapes, shape, sub, point_indices[shape], sub_offsets[sub], len(points), normals is not None)
            if why:
                misfits[shape] = why
                self.skip(BAD_SHAPE, prim, f"{self.shown_path(shapes.GetBlendShape(shape).GetPrim())}: {why}")
        if misfits:
            keep = np.array([shape not in misfits for shape in shape_ids], bool)
            sub_weights = Vt.FloatArray.FromNumpy(np.asarray(sub_weights, np.float32)[keep])
            shape_ids = Vt.UIntArray.FromNumpy(np.asarray(shape_ids, np.uint32)[keep])
            sub_ids = Vt.UIntArray.FromNumpy(np.asarray(sub_ids, np.uint32)[keep])
        moved = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(points, np.float32))
        if not shapes.ComputeDeformedPoints(sub_weights, shape_ids, sub_ids, point_indices, sub_offsets, moved):
            raise ValueError("blend shapes do not match the points")
        if normals is not None:
            offsets = _normal_offsets(shapes, zip(sub_weights, shape_ids, sub_ids), point_indices, len(points))
            if offsets is not None:  # per triangle corner, as the skinned normals are
                values, corners = normals
                normals = (values[corners] + offsets[vertex_ids]).reshape(-1, 3), np.arange(corners.size).reshape(-1, 3)
        return np.array(moved, np.float64), normals

    def _paired_weights(self, prim, weights, count: int):
        """``weights`` (in ``skel:blendShapes`` order) cut or padded with zeros to the ``count`` blend shapes of
        ``skel:blendShapeTargets``, the entries past the shorter list recorded through ``skip``: ComputeSubShapeWeights
        refuses weights of another size, and with them every blend shape of the mesh."""
        binding = UsdSkel.BindingAPI(prim)
        if len(weights) > count:
            names = list(binding.GetBlendShapesAttr().Get() or [])[count : len(weights)]
            left_out = f"skel:blendShapes {names} past its {count} skel:blendShapeTargets"
        else:
            targets = [str(t) for t in binding.GetBlendShapeTargetsRel().GetTargets()][len(weights) : count]
            left_out = f"skel:blendShapeTargets {targets} past its {len(weights)} skel:blendShapes"
        self.skip(UNPAIRED_SHAPES, prim, left_out)
        paired = np.zeros(count, np.float32)
        n = min(count, len(weights))
        paired[:n] = np.asarray(weights, np.float32)[:n]
        return Vt.FloatArray.FromNumpy(paired)


class _Influences:
    """The joint influences of one skinned mesh at ``time`` and the skinning transforms of its skeleton in the mesh's
    ``skel:joints`` order, for its points, normals or rigid transform (``UsdSkel.SkinPoints``, ``SkinNormals`` and
    ``SkinTransform``, which take the transforms in the influences' order).

    The transforms are remapped here, once for points and normals: a joint of ``skel:joints`` that the skeleton lacks
    gets the identity, as in ``UsdSkel.BakeSkinning`` (the poser warns of it: :meth:`weighted_joints_missing_from`).
    ``SkinningQuery.ComputeSkinnedPoints``, which remaps inside, gave such a joint's points another joint's transform.
    """

    def __init__(self, query: UsdSkel.SkinningQuery, xforms, time: Usd.TimeCode):
        # Each attribute read at its own time, as points are (read_time: its first sample at the default time when it
        # has samples only), values and indices of an indexed primvar each on its own (flattened):
        # ComputeJointInfluences, GetGeomBindTransform and ComputeFlattened read all at one time, and raised at the
        # default time on indices with only time samples.
        primvars = query.GetJointIndicesPrimvar(), query.GetJointWeightsPrimvar()
        indices, weights = (flattened(p, time, query.GetPrim(), _refuse) for p in primvars)
        self.indices = None if indices is None else Vt.IntArray.FromNumpy(np.ascontiguousarray(indices, np.int32))
        self.weights = None if weights is None else Vt.FloatArray.FromNumpy(np.ascontiguousarray(weights, np.float32))
        self.per_point = query.GetNumInfluencesPerComponent()
        rigid = query.GetInterpolation() == "constant"
        if (self.indices is None or self.weights is None or len(self.indices) != len(self.weights)
                or (rigid and len(self.indices) != self.per_point)):
            raise ValueError("jointIndices and jointWeights do not match")
        weights = np.asarray(self.weights)
        if not np.isfinite(weights).all():
            i = int(np.argmin(np.isfinite(weights)))
            raise ValueError(f"jointWeights[{i}] = {weights[i]} is not finite")
        self.method = query.GetSkinningMethod()
        if self.method not in (UsdSkel.Tokens.classicLinear, UsdSkel.Tokens.dualQuaternion):
            # SkinPoints fails on it, but SkinTransform (rigid bindings) returns the identity, not seen from Python
            raise ValueError(f"unknown skel:skinningMethod '{self.method}'")
        bind = query.GetGeomBindTransformAttr()  # invalid when not authored (the identity)
        self.bind = query.GetGeomBindTransform(read_time(bind, time) if bind else time)
        # Refused as the skeleton's singular bindTransforms are: a zero or flat geomBindTransform (own or inherited)
        # collapsed the mesh to a point or a plane, its normals to zero, without a word.
        if not np.isfinite(np.array(self.bind)).all():
            raise ValueError("primvars:skel:geomBindTransform is not finite")
        if self.bind.GetDeterminant3() == 0.0:
            raise ValueError("primvars:skel:geomBindTransform cannot be inverted (it flattens the mesh)")
        mapper = query.GetJointMapper()
        if mapper and not mapper.IsNull() and not mapper.IsIdentity():
            xforms = mapper.RemapTransforms(xforms, Vt.Matrix4dArray())  # into the mesh's skel:joints order
        self.xforms = xforms
        self.joint_order = query.GetJointOrder()  # the mesh's skel:joints, or None
        # Checked here: SkinTransform (rigid bindings) returns the identity for an index out of range, and the failure
        # is not seen from Python.
        indices = np.asarray(self.indices)
        bad = np.flatnonzero((indices < 0) | (indices >= len(xforms)))
        if len(bad):
            raise ValueError(f"jointIndices[{bad[0]}] = {indices[bad[0]]} is out of range for {len(xforms)} joints")

    def weighted_joints_missing_from(self, skeleton_joints) -> list[tuple[int, str]]:
        """``(index, name)`` of each entry of the mesh's ``skel:joints`` that ``skeleton_joints`` lacks and that a
        non-zero joint weight refers to (unused entries move nothing)."""
        if self.joint_order is None:
            return []
        known = set(skeleton_joints)
        missing = [k for k, name in enumerate(self.joint_order) if name not in known]
        if not missing:
            return []
        weighted = set(np.asarray(self.indices)[np.asarray(self.weights) != 0.0].tolist())
        return [(k, str(self.joint_order[k])) for k in missing if k in weighted]

    def points(self, points: np.ndarray) -> np.ndarray:
        """``(V, 3)`` float64 ``points`` (the mesh's, blend shapes applied) skinned into the skeleton's space."""
        skinned = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(points, np.float32))
        if not UsdSkel.SkinPoints(self.method, self.bind, self.xforms, self.indices, self.weights, self.per_point,
                                  skinned):
            raise ValueError("SkinPoints failed (influences do not match the points)")
        return np.array(skinned, np.float64)

    def normals(self, normals, vertex_ids: np.ndarray):
        """Normals skinned per triangle corner with the influences of the corner's point (so faceVarying and uniform
        normals are skinned too): ``(values (3T, 3), corner index (T, 3))``."""
        values, corners = normals
        points = np.asarray(vertex_ids, np.int64).reshape(-1)
        indices = np.asarray(self.indices, np.int32).reshape(-1, self.per_point)[points].reshape(-1)
        weights = np.asarray(self.weights, np.float32).reshape(-1, self.per_point)[points].reshape(-1)
        joint_normal_xforms = Vt.Matrix3dArray([_gf3(_inverse_transpose(np.array(x)[:3, :3])) for x in self.xforms])
        bind = _gf3(_inverse_transpose(np.array(self.bind)[:3, :3]))
        skinned = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(values[corners].reshape(-1, 3), np.float32))
        if not UsdSkel.SkinNormals(self.method, bind, joint_normal_xforms, Vt.IntArray.FromNumpy(indices),
                                   Vt.FloatArray.FromNumpy(weights), self.per_point, skinned):
            raise ValueError("SkinNormals failed")
        return np.array(skinned, np.float64), np.arange(len(skinned)).reshape(-1, 3)

    def rigid_transform(self) -> np.ndarray:
        """``(4, 4)`` row-vector transform of a rigidly bound mesh (constant influences) into the skeleton's space."""
        return np.array(UsdSkel.SkinTransform(self.method, self.bind, self.xforms, self.indices, self.weights))


def _not_a(kind: str, stage: Usd.Stage, target: Sdf.Path) -> str:
    """Why relationship target ``target`` is no prim of type ``kind`` USD takes (``Skeleton``, ``SkelAnimation``,
    ``BlendShape``), in words (USD warns of a missing target without the mesh or skeleton)."""
    found = stage.GetPrimAtPath(target)
    if not found:
        why = "no prim is there"
    elif not found.HasDefiningSpecifier():
        why = "it is only an 'over' (defined nowhere)"
    elif not found.GetTypeName():
        why = f"it is a prim with no type, not a {kind}"
    elif found.GetTypeName() != kind:
        why = f"it is a {found.GetTypeName()}, not a {kind}"
    else:
        why = "it is inactive"
    return why


def _unusable_influences(query: UsdSkel.SkinningQuery, time: Usd.TimeCode) -> str | None:
    """Words for joint influences UsdSkel's typed reads fail on (``primvars:skel:jointIndices is float[], not int[]``;
    jointWeights: float[]), or whose indices it cannot flatten (:func:`wrt.usd_primvars.index_problem`), or None.
    BakeSkinning leaves such a mesh unskinned, its blend shapes applied. wrt cast values of another type to int32 and
    float32 through numpy and skinned the mesh without a word, and drew a mesh of unusable indices unposed, without
    its blend shapes."""
    for primvar, wanted in ((query.GetJointIndicesPrimvar(), Sdf.ValueTypeNames.IntArray),
                            (query.GetJointWeightsPrimvar(), Sdf.ValueTypeNames.FloatArray)):
        authored = authored_type(primvar.GetAttr(), time)
        if Sdf.ValueTypeNames.Find(authored) != wanted:
            return f"{primvar.GetAttr().GetName()} is {authored}, not {wanted}"
        problem = index_problem(primvar, time)
        if problem is not None:
            return problem
    return None


def _refuse(reason, prim, detail):
    """The ``skip`` of :func:`flattened` for joint influences: an index it cannot flatten fails the mesh's skinning
    (:func:`_unusable_influences` leaves such meshes unskinned first)."""
    raise ValueError(detail)


def _misfit(shapes, shape: int, sub: int, point_indices, offsets, n_points: int, with_normals: bool) -> str | None:
    """What keeps sub-shape ``sub`` (a primary shape or an inbetween) of blend shape ``shape`` from fitting a mesh of
    ``n_points`` points, in words, or None when it fits. ``with_normals``: its ``normalOffsets`` are used too."""
    at = np.asarray(point_indices, np.int64)
    bad = np.flatnonzero((at < 0) | (at >= n_points))
    if len(bad):
        return f"pointIndices[{bad[0]}] = {at[bad[0]]} is out of range for {n_points} points"
    inbetween = shapes.GetInbetween(sub)
    named = f"{inbetween.GetAttr().GetName()} " if inbetween else ""  # inbetweens:NAME, offsets of its own
    wanted = f"{len(at)} pointIndices" if len(at) else f"{n_points} points (no pointIndices)"
    if len(offsets) != (len(at) or n_points):
        return f"{len(offsets)} {named}offsets for {wanted}"
    if not np.isfinite(np.asarray(offsets, np.float64)).all():
        return f"{named}offsets are not finite"
    normal_offsets = _sub_normal_offsets(shapes, shape, sub) if with_normals else None
    if normal_offsets is not None and len(normal_offsets) != (len(at) or n_points):
        return f"{len(normal_offsets)} {named}normalOffsets for {wanted}"
    return None


def _sub_normal_offsets(shapes, shape: int, sub: int):
    """The ``normalOffsets`` of sub-shape ``sub`` of blend shape ``shape`` (its inbetween's or its own), or None
    when it has none."""
    inbetween = shapes.GetInbetween(sub)
    offsets = inbetween.GetNormalOffsets() if inbetween else shapes.GetBlendShape(shape).GetNormalOffsetsAttr().Get()
    return offsets if offsets is not None and len(offsets) else None


def _normal_offsets(shapes, sub_shapes, point_indices, n_points: int) -> np.ndarray | None:
    """``(V, 3)`` sum of the ``normalOffsets`` of the weighted ``sub_shapes`` (``(weight, blend shape, sub-shape)``;
    primary shapes' and inbetweens' offsets, each fitting the mesh: :func:`_misfit`), or None when none has any:
    ``BlendShapeQuery.ComputeDeformedNormals``, which Python cannot call."""
    total = np.zeros((n_points, 3))
    for weight, shape, sub in sub_shapes:
        offsets = _sub_normal_offsets(shapes, shape, sub)
        if weight == 0.0 or offsets is None:
            continue
        at = np.asarray(point_indices[shape], np.int64)
        np.add.at(total, at if len(at) else np.arange(n_points), weight * np.asarray(offsets, np.float64))
    return total if total.any() else None


def _inverse_transpose(linear: np.ndarray) -> np.ndarray:
    """``(3, 3)`` inverse transpose of ``linear`` (how normals transform); the cofactor matrix when singular."""
    r0, r1, r2 = linear
    cofactor = np.stack([np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)])  # = det * inv(linear).T
    det = float(np.dot(r0, cofactor[0]))
    return cofactor / det if det != 0.0 and np.isfinite(det) else cofactor


def _gf3(m: np.ndarray) -> Gf.Matrix3d:
    return Gf.Matrix3d(*(float(v) for v in m.reshape(-1)))
