"""World transforms of USD prims under wrt's rule for the default time (:mod:`wrt.usd_values`): each transform op
is read at the default time, or at its first time sample when it has samples and no default value.

``UsdGeom.XformCache`` reads every op at one time code. At the default time that loses ops that have only time
samples (a transform animated from frame 1 would sit at the origin), and at ``EarliestTime`` it reads the first
sample of ops that also author a default, which the default time must give (as points, visibility and material
inputs are read). :class:`DefaultTimeXforms` resolves op by op instead; other times use ``XformCache`` itself.
"""

from __future__ import annotations

from pxr import Gf, Usd, UsdGeom

from .usd_values import read_time


def xform_cache(time: Usd.TimeCode):
    """An object with ``UsdGeom.XformCache``'s ``GetLocalToWorldTransform`` and ``ComputeRelativeTransform`` at
    ``time`` under wrt's rule for the default time."""
    return DefaultTimeXforms() if time.IsDefault() else UsdGeom.XformCache(time)


class DefaultTimeXforms:
    """Transforms at the default time, each op read at :func:`wrt.usd_values.read_time` (memoised per prim)."""

    def __init__(self):
        self._world = {}  # prim path -> row-vector local-to-world Gf.Matrix4d

    def _local(self, prim: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:
        """``prim``'s local transform and whether it resets the transform stack."""
        if not prim.IsA(UsdGeom.Xformable):
            return Gf.Matrix4d(1.0), False
        xformable = UsdGeom.Xformable(prim)
        m = Gf.Matrix4d(1.0)
        for op in xformable.GetOrderedXformOps():  # row vectors: the first op is applied first
            m = op.GetOpTransform(read_time(op.GetAttr(), Usd.TimeCode.Default())) * m
        return m, xformable.GetResetXformStack()

    def GetLocalToWorldTransform(self, prim: Usd.Prim) -> Gf.Matrix4d:  # noqa: N802 (XformCache's name)
        key = prim.GetPath()
        if key not in self._world:
            chain = []  # prims up to the first one whose world transform is known (or the root)
            p = prim
            while p and not p.IsPseudoRoot() and p.GetPath() not in self._world:
                chain.append(p)
                p = p.GetParent()
            world = self._world.get(p.GetPath(), Gf.Matrix4d(1.0)) if p else Gf.Matrix4d(1.0)
            for q in reversed(chain):
                local, resets = self._local(q)
                world = local if resets else local * world
                self._world[q.GetPath()] = world
        return self._world[key]

    def ComputeRelativeTransform(self, prim: Usd.Prim, ancestor: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:  # noqa: N802
        """``prim``'s transform to ``ancestor``'s space; with a resetXformStack between them, to the world's (and
        True), as ``XformCache.ComputeRelativeTransform``."""
        m = Gf.Matrix4d(1.0)
        p = prim
        while p and p != ancestor and not p.IsPseudoRoot():
            local, resets = self._local(p)
            m = m * local
            if resets:
                return m, True
            p = p.GetParent()
        return m, False
