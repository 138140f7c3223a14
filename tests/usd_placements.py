"""Where USD draws the prims of a stage, from USD's own API, not from wrt's loader: the placement walk the schema
oracles (``gprim_oracle``, ``points_oracle``) share."""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom


def drawn_placements(stage: Usd.Stage, keep, time=Usd.TimeCode.Default()):
    """``[(prim path as wrt names it, prim, (4, 4) row-vector own-to-world, instance name)]`` of every drawn prim
    that ``keep(prim)`` accepts: in native instances at its instance-proxy path, in a PointInstancer once per
    instance at the prototype prim's path (instance name ``/Instancer[j]``; None elsewhere)."""
    out = []
    cache = UsdGeom.XformCache(time)
    predicate = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimIsDefined & ~Usd.PrimIsAbstract)
    for prim in stage.Traverse(predicate):
        if prim.IsA(UsdGeom.PointInstancer):
            instancer = UsdGeom.PointInstancer(prim)
            targets = instancer.GetPrototypesRel().GetForwardedTargets()  # as UsdImaging reads them
            indices = instancer.GetProtoIndicesAttr().Get(time)
            xforms = instancer.ComputeInstanceTransformsAtTime(time, time)
            to_world = np.array(cache.GetLocalToWorldTransform(prim))
            for j, (index, m) in enumerate(zip(indices, xforms)):
                proto = stage.GetPrimAtPath(targets[index])
                for g in Usd.PrimRange(proto):
                    if keep(g):
                        # ComputeInstanceTransformsAtTime holds the prototype root's own transform already.
                        below = np.array(cache.ComputeRelativeTransform(g, proto)[0]) if g != proto else np.eye(4)
                        out.append((str(g.GetPath()), g, below @ np.array(m) @ to_world, f"{prim.GetPath()}[{j}]"))
            continue
        if not keep(prim):
            continue
        if any(p.IsA(UsdGeom.PointInstancer) for p in _ancestors(prim)):
            continue
        if UsdGeom.Imageable(prim).ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            continue
        out.append((str(prim.GetPath()), prim, np.array(cache.GetLocalToWorldTransform(prim)), None))
    return out


def _ancestors(prim):
    prim = prim.GetParent()
    while prim and not prim.IsPseudoRoot():
        yield prim
        prim = prim.GetParent()
