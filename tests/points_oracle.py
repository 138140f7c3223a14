"""A float64 oracle for ``UsdGeom.Points`` written from the schema and USD's own API, not from wrt's loader.

Each point is a sphere of diameter ``widths[i]`` (the schema: "Widths are defined as the diameter of the points, in
object space"): ``primvars:widths`` when it has a value (the schema: it "has precedence" over ``widths``; USD's
``FindPrimvarWithInheritance``, so a constant one on an ancestor counts), else ``widths`` with
``GetWidthsInterpolation`` (``constant`` and ``uniform``: one for all; ``vertex`` and ``varying``: one per point), else
1 (the fallback wrt documents, UsdImaging's). Positions are ``UsdGeom.Points.ComputePointsAtTime`` (velocities and
accelerations as USD applies them). The whole transform to the world ``M`` (USD's ``XformCache``, instance proxies
of native instances, ``PointInstancer.ComputeInstanceTransformsAtTime``, which holds the prototype root's own)
moves the centres, and the radius scales by ``|M (1, 1, 1) / sqrt(3)|`` (the README's rule: spheres stay round).
"""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom
from usd_placements import drawn_placements


def oracle_widths(prim: Usd.Prim, n: int, time=Usd.TimeCode.Default()) -> np.ndarray:
    """``(n,)`` float64 diameters of the ``n`` points of ``prim`` as the schema defines them."""
    primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("widths")
    if primvar and primvar.HasValue():
        values, interpolation = primvar.ComputeFlattened(time), primvar.GetInterpolation()
    else:
        points = UsdGeom.Points(prim)
        values, interpolation = points.GetWidthsAttr().Get(time), points.GetWidthsInterpolation()
    if values is None or len(values) == 0:
        return np.ones(n)
    values = np.asarray(values, np.float64)
    return np.full(n, values[0]) if interpolation in ("constant", "uniform") else values


def placements(stage: Usd.Stage, time=Usd.TimeCode.Default()):
    """``[(prim path as wrt names it, Points prim, (4, 4) row-vector own-to-world, instance name)]`` of every drawn
    Points prim (:func:`usd_placements.drawn_placements`; instance name ``/Instancer[j]``, else None: each point is
    named ``/Points[i]``)."""
    return drawn_placements(stage, lambda prim: prim.IsA(UsdGeom.Points), time)


def spheres(stage: Usd.Stage, time=Usd.TimeCode.Default()):
    """``(centres (S, 3), radii (S,), paths (S,) object, instances (S,) object)``: every drawn point's world sphere,
    the prim path it belongs to and the instance path ``Scene.hit_paths`` names (``/Points[i]``, ``/Instancer[j]``);
    points with a width that is not positive and finite are left out (nothing to draw)."""
    centres, radii, paths, names = [], [], [], []
    for name, prim, m, instance in placements(stage, time):
        p = np.asarray(UsdGeom.Points(prim).ComputePointsAtTime(time, time), np.float64).reshape(-1, 3)
        w = oracle_widths(prim, len(p), time)
        scale = np.linalg.norm(np.ones(3) / np.sqrt(3.0) @ m[:3, :3])  # row vectors: |M (1,1,1)/sqrt 3|
        keep = np.isfinite(w) & (w > 0) & np.isfinite(p).all(axis=1)
        centres.append(p[keep] @ m[:3, :3] + m[3, :3])
        radii.append(0.5 * w[keep] * scale)
        paths.append(np.full(int(keep.sum()), name, object))
        names.append(np.array([instance or f"{name}[{i}]" for i in np.flatnonzero(keep)], object))
    if not centres:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, object), np.zeros(0, object)
    return np.concatenate(centres), np.concatenate(radii), np.concatenate(paths), np.concatenate(names)


def trace(centres, radii, origins, directions, t_min=0.0):
    """Closest hits ``t >= t_min`` of world rays on the spheres in float64, by chunks of rays.

    Returns:
        dict of ``(N,)`` arrays: ``t`` (inf on a miss), ``sphere`` (index, -1 on a miss), ``normal`` ``(N, 3)``
        outward unit normal, ``clearance``: the smallest relative distance of the ray from any sphere's silhouette
        or from starting on a sphere (hit and miss are rounding decisions where it is small).
    """
    origins = np.asarray(origins, np.float64)
    directions = np.asarray(directions, np.float64)
    n = len(origins)
    best, sphere = np.full(n, np.inf), np.full(n, -1)
    clearance = np.full(n, np.inf)
    for lo in range(0, len(centres), 512):
        c, r = centres[lo:lo + 512], radii[lo:lo + 512]
        oc = origins[:, None, :] - c[None]
        a = (directions * directions).sum(1)[:, None]
        b = (oc * directions[:, None, :]).sum(2)
        cc = (oc * oc).sum(2) - r[None] ** 2
        disc = b * b - a * cc
        root = np.sqrt(np.maximum(disc, 0.0))
        t0, t1 = (-b - root) / a, (-b + root) / a
        t = np.where(t0 >= t_min, t0, np.where(t1 >= t_min, t1, np.inf))
        t = np.where(disc >= 0, t, np.inf)
        # The ray's distance from the centre against the radius, and the origin's against it.
        miss_gap = np.abs(np.sqrt(np.maximum(cc - b * b / a + r[None] ** 2, 0.0)) - r[None]) / r[None]
        start_gap = np.abs(np.sqrt((oc * oc).sum(2)) - r[None]) / r[None]
        clearance = np.minimum(clearance, np.minimum(miss_gap, start_gap).min(axis=1))
        k = t.argmin(axis=1)
        tk = t[np.arange(n), k]
        closer = tk < best
        best[closer], sphere[closer] = tk[closer], lo + k[closer]
    normal = np.zeros((n, 3))
    hit = sphere >= 0
    p = origins[hit] + best[hit, None] * directions[hit]
    normal[hit] = (p - centres[sphere[hit]]) / radii[sphere[hit], None]
    return {"t": best, "sphere": sphere, "normal": normal, "clearance": clearance}
