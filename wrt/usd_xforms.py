"""World transforms of USD prims under wrt's rule for the default time (:mod:`wrt.usd_values`): each transform op
is read at the default time, or at its first time sample when it has samples and no default value.

``UsdGeom.XformCache`` reads every op at one time code. At the default time that loses ops that have only time
samples (a transform animated from frame 1 would sit at the origin), and at ``EarliestTime`` it reads the first
sample of ops that also author a default, which the default time must give (as points, visibility and material
inputs are read). :class:`DefaultTimeXforms` resolves op by op instead where an op is read at its first sample, and
asks an ``XformCache`` at the default time elsewhere (the same matrices there); other times use ``XformCache`` itself.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom

from .usd_values import read_time

DEFAULT = Usd.TimeCode.Default()
PROJECTIVE = "world transform is projective; its last column was ignored"


def affine_part(m: np.ndarray, warn) -> np.ndarray:
    """``m``, a ``(4, 4)`` row-vector world transform (a ``Gf.Matrix4d`` as numpy reads it), with its last column set
    to ``(0, 0, 0, 1)``: meshes, gprims, curves, instances, cameras and lights are drawn by their affine part.
    ``warn(PROJECTIVE)`` is called when the column was not close to that. ``m`` itself is left as it is."""
    column = m[:, 3]
    # The exact column first: np.allclose took a twentieth of load_usd for 40k small meshes.
    if column.tolist() == [0.0, 0.0, 0.0, 1.0]:
        return m
    if not np.allclose(column, (0.0, 0.0, 0.0, 1.0)):
        warn(PROJECTIVE)
    affine = m.copy()
    affine[:, 3] = (0.0, 0.0, 0.0, 1.0)
    return affine


def xform_cache(time: Usd.TimeCode, stage: Usd.Stage | None = None):
    """An object with ``UsdGeom.XformCache``'s ``GetLocalToWorldTransform`` and ``ComputeRelativeTransform`` at
    ``time`` under wrt's rule for the default time, for the prims of ``stage``."""
    return DefaultTimeXforms(stage) if time.IsDefault() else UsdGeom.XformCache(time)


class DefaultTimeXforms:
    """Transforms at the default time, each op read at :func:`wrt.usd_values.read_time` (memoised per prim).

    Below prims none of whose ops is read at a time sample (most prims of most stages: no samples, or a default beside
    them) every op reads its default value, so ``XformCache`` at the default time gives the same matrices, from C++;
    on a stage with no time sample at all that holds for every prim. Resolving each prim's ops in Python was a
    quarter of the load of 100k native instances.
    """

    def __init__(self, stage: Usd.Stage | None = None):
        self._cache = UsdGeom.XformCache(DEFAULT)  # exact where no op up the chain is read at a time sample
        # No layer of the stage holds a time sample (a still robot fleet): every op reads its default, asked once for
        # the stage (in C++, and without the stage time queries that hang usd-core at timeCodesPerSecond = 0) rather
        # than op by op for each prim.
        self._still = stage is not None and not any(layer.ListAllTimeSamples() for layer in stage.GetUsedLayers())
        self._sampled = {}  # prim path -> the prim or an ancestor has an op read at a time sample
        self._world = {}  # prim path -> row-vector local-to-world Gf.Matrix4d, for prims where _sampled is True

    def _local(self, prim: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:
        """``prim``'s local transform and whether it resets the transform stack."""
        if not prim.IsA(UsdGeom.Xformable):
            return Gf.Matrix4d(1.0), False
        xformable = UsdGeom.Xformable(prim)
        m = Gf.Matrix4d(1.0)
        for op in xformable.GetOrderedXformOps():  # row vectors: the first op is applied first
            m = op.GetOpTransform(read_time(op.GetAttr(), DEFAULT)) * m
        return m, xformable.GetResetXformStack()

    def _has_sampled_op(self, prim: Usd.Prim) -> bool:
        """Whether ``prim`` or an ancestor has a transform op read at its first time sample rather than its default
        (memoised, walked without recursion: hierarchies can be deeper than Python's stack)."""
        if self._still:
            return False
        chain = []  # prims up to the first one already known (or the root)
        p, found = prim, False
        while p and not p.IsPseudoRoot():
            known = self._sampled.get(p.GetPath())
            if known is not None:
                found = known
                break
            chain.append(p)
            p = p.GetParent()
        for q in reversed(chain):
            # As read_time decides (Xformable.GetTimeSamples would be faster, but hangs usd-core on stages with
            # timeCodesPerSecond = 0, and does not see spline-valued ops).
            found = found or (q.IsA(UsdGeom.Xformable) and any(
                not read_time(op.GetAttr(), DEFAULT).IsDefault() for op in UsdGeom.Xformable(q).GetOrderedXformOps()))
            self._sampled[q.GetPath()] = found
        return found

    def GetLocalToWorldTransform(self, prim: Usd.Prim) -> Gf.Matrix4d:  # noqa: N802 (XformCache's name)
        if not self._has_sampled_op(prim):
            return self._cache.GetLocalToWorldTransform(prim)
        key = prim.GetPath()
        if key not in self._world:
            chain = []  # prims up to the first one whose world transform is known, or has no sampled op up its chain
            p = prim
            while p and not p.IsPseudoRoot() and p.GetPath() not in self._world and self._has_sampled_op(p):
                chain.append(p)
                p = p.GetParent()
            known = self._world.get(p.GetPath())
            world = known if known is not None else self._cache.GetLocalToWorldTransform(p)
            for q in reversed(chain):
                local, resets = self._local(q)
                world = local if resets else local * world
                self._world[q.GetPath()] = world
        return self._world[key]

    def ComputeRelativeTransform(self, prim: Usd.Prim, ancestor: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:  # noqa: N802
        """``prim``'s transform to ``ancestor``'s space; with a resetXformStack between them, to the world's (and
        True), as ``XformCache.ComputeRelativeTransform``."""
        if not self._has_sampled_op(prim):
            return self._cache.ComputeRelativeTransform(prim, ancestor)
        m = Gf.Matrix4d(1.0)
        p = prim
        while p and p != ancestor and not p.IsPseudoRoot():
            local, resets = self._local(p)
            m = m * local
            if resets:
                return m, True
            p = p.GetParent()
        return m, False
