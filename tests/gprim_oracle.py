"""A float64 oracle for UsdGeom gprims written from the schema's definitions alone (not from wrt's shapes).

Each solid gprim is a convex set ``{p : f(p) <= 0}`` in its own space, with ``f`` convex: a ``Sphere`` of ``radius``,
a ``Cube`` of edge ``size``, a capped ``Cylinder`` and ``Cone`` (apex at ``+height / 2`` along ``axis``, base of
``radius`` at ``-height / 2``), a ``Capsule`` (the points within ``radius`` of the spine ``|a| <= height / 2``), a
capped ``Cylinder_1`` (radius linear from ``radiusBottom`` at ``-height / 2`` to ``radiusTop``) and a ``Capsule_1``:
the cone of the two radii at the ends of ``height`` closed by the spheres tangent to it there (the schema's "cylinder
tangent and sphere tangent are coincident"), that is the convex hull of those spheres, the union of the balls whose
centre and radius move linearly between theirs. A ray meets a convex set in one interval of ``t``, found here by
minimising ``f`` along the ray (golden sections: ``f`` is convex along any line) and bisecting each side of the
minimum in float64. A ``Plane`` is the flat ``width`` x ``length`` rectangle across ``axis``.

Placements come from USD's own API: ``ComputeLocalToWorldTransform`` (instance proxies of native instances too) and
``PointInstancer.ComputeInstanceTransformsAtTime``. Front normals are outward (inward for ``leftHanded``), a
mirroring transform not changing which side is the front.
"""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom
from usd_placements import drawn_placements

AXES = {"X": 0, "Y": 1, "Z": 2}
GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


class Solid:
    """A gprim in its own space: ``f`` ``(N, 3) -> (N,)`` convex, ``<= 0`` inside; ``radius`` bounds it about the
    origin; ``flat`` for a ``Plane`` (then ``half`` is its half width and length, ``axis`` its normal's axis)."""

    def __init__(self, prim: Usd.Prim, time=Usd.TimeCode.Default()):
        self.type_name = prim.GetTypeName()
        get = {a.GetName(): a.Get(time) for a in prim.GetAttributes()}
        self.left_handed = UsdGeom.Gprim(prim).GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
        self.axis = AXES.get(str(get.get("axis", "Z")), 2)
        self.flat = self.type_name == "Plane"
        t = self.type_name
        self.empty = not self._drawn(get)
        if self.empty:
            self.f, self.radius, self.flat = None, 0.0, False
        elif t == "Sphere":
            r = get["radius"]
            self.f, self.radius = (lambda p: np.linalg.norm(p, axis=1) - r), r
        elif t == "Cube":
            s = get["size"] / 2.0
            self.f, self.radius = (lambda p: np.abs(p).max(axis=1) - s), s * np.sqrt(3.0)
        elif t in ("Cylinder", "Cone", "Cylinder_1"):
            h = get["height"] / 2.0
            if t == "Cylinder_1":
                bottom, top = get["radiusBottom"], get["radiusTop"]
            else:
                bottom, top = get["radius"], get["radius"] if t == "Cylinder" else 0.0
            k = (top - bottom) / (2.0 * h)  # radius change per unit along the axis

            def f(p):
                a, rho = self._split(p)
                return np.maximum((rho - (bottom + k * (a + h))) / np.sqrt(1.0 + k * k), np.abs(a) - h)

            self.f, self.radius = f, np.hypot(h, max(bottom, top))
        elif t in ("Capsule", "Capsule_1"):
            h = get["height"] / 2.0
            bottom, top = (get["radius"], get["radius"]) if t == "Capsule" else (get["radiusBottom"],
                                                                                 get["radiusTop"])
            # Spheres tangent to the cone of radius bottom at -h and top at +h: centres moved by k * radius.
            k = (top - bottom) / (2.0 * h) if h > 0 else 0.0
            c0, r0 = -h + k * bottom, bottom * np.sqrt(1.0 + k * k)
            c1, r1 = h + k * top, top * np.sqrt(1.0 + k * k)
            if h == 0.0:
                c0 = c1 = 0.0
                r0 = r1 = max(bottom, top)
            length = c1 - c0
            sigma = (r1 - r0) / length if length > 0 else 0.0

            def f(p):
                a, rho = self._split(p)
                x = a - c0
                if length <= 0:
                    return np.hypot(x, rho) - r0
                # The ball of the hull nearest p, s in [0, 1] minimising |p - c(s)| - r(s) (convex in s).
                s = np.clip((x + sigma * rho / np.sqrt(1.0 - sigma * sigma)) / length, 0.0, 1.0)
                return np.hypot(x - s * length, rho) - (r0 + s * (r1 - r0))

            self.f, self.radius = f, max(abs(c0) + r0, abs(c1) + r1)
        elif t == "Plane":
            self.half = np.array([get["width"], get["length"]]) / 2.0
            self.radius = float(np.hypot(*self.half))
            self.f = None
        else:
            raise ValueError(f"no oracle for {t}")

    def _drawn(self, get) -> bool:
        """Whether the schema's sizes make a shape: positive ones (a ``Capsule``'s height may be 0; one radius of a
        ``Cylinder_1`` or ``Capsule_1`` may be 0, and a ``Capsule_1``'s height)."""
        t = self.type_name
        sizes = {"Sphere": ["radius"], "Cube": ["size"], "Cylinder": ["radius", "height"], "Cone": ["radius", "height"],
                 "Capsule": ["radius"], "Plane": ["width", "length"], "Cylinder_1": ["height"]}.get(t, [])
        if any(not (get[k] > 0) for k in sizes):
            return False
        if t == "Capsule" and not get["height"] >= 0:
            return False
        if t in ("Cylinder_1", "Capsule_1"):
            radii = [get["radiusBottom"], get["radiusTop"]]
            if not (min(radii) >= 0 and max(radii) > 0 and get["height"] >= 0):
                return False
        return True

    def _split(self, p):
        """``(a, rho)``: the coordinate along the axis and the distance from it."""
        a = p[:, self.axis]
        others = np.delete(p, self.axis, axis=1)
        return a, np.linalg.norm(others, axis=1)

    def plane_coordinates(self, p):
        """A point's (width, length) coordinates on a ``Plane`` (the schema: width along X, or Z when the axis is
        X; length along Y, or Z when the axis is Y)."""
        w = 2 if self.axis == 0 else 0
        ln = 2 if self.axis == 1 else 1
        return p[:, w], p[:, ln]

    def normal(self, p, scale):
        """Outward unit normals at surface points ``p``: the central-difference gradient of ``f`` (``+axis`` on a
        ``Plane``), and whether it is sharp: the same at a tenth of the step (False near rims and edges)."""
        if self.flat:
            n = np.zeros_like(p)
            n[:, self.axis] = 1.0
            return n, np.ones(len(p), bool)
        grads = []
        for step in (1e-6 * scale, 1e-7 * scale):
            g = np.stack([self.f(p + step * e) - self.f(p - step * e) for e in np.eye(3)], axis=1)
            grads.append(g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300))
        return grads[0], np.einsum("ij,ij->i", grads[0], grads[1]) > 1.0 - 1e-6

    def interval(self, o, d):
        """``(t_in, t_out)`` ``(N,)`` of lines ``o + t d`` (own space), NaN where a line misses the solid (for a
        ``Plane``: the one crossing twice)."""
        if self.flat:
            with np.errstate(divide="ignore", invalid="ignore"):
                t = -o[:, self.axis] / d[:, self.axis]
            p = o + t[:, None] * d
            u, v = self.plane_coordinates(p)
            ok = np.isfinite(t) & (np.abs(u) <= self.half[0]) & (np.abs(v) <= self.half[1])
            t = np.where(ok, t, np.nan)
            return t, t.copy()
        # The part of the line inside the bounding sphere; minimise f there by golden sections.
        dd = np.einsum("ij,ij->i", d, d)
        tc = -np.einsum("ij,ij->i", o, d) / dd
        gap2 = np.einsum("ij,ij->i", o + tc[:, None] * d, o + tc[:, None] * d)
        reach2 = (self.radius * 1.001) ** 2 - gap2
        half = np.sqrt(np.maximum(reach2, 0.0) / dd)
        lo, hi = tc - half, tc + half
        c, e = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
        fc, fe = self.f(o + c[:, None] * d), self.f(o + e[:, None] * d)
        for _ in range(80):
            left = fc < fe  # the minimum is in [lo, e]
            lo, hi = np.where(left, lo, c), np.where(left, e, hi)
            c, e, fc, fe = np.where(left, hi - GOLDEN * (hi - lo), e), np.where(left, c, lo + GOLDEN * (hi - lo)), \
                np.where(left, 0.0, fe), np.where(left, fc, 0.0)
            new = np.where(left, c, e)
            f_new = self.f(o + new[:, None] * d)
            fc, fe = np.where(left, f_new, fc), np.where(left, fe, f_new)
        t_mid = np.where(fc < fe, c, e)
        inside = (np.minimum(fc, fe) <= 0.0) & (reach2 > 0)

        def bisect(t_out_side, t_in_side):
            for _ in range(80):
                m = (t_out_side + t_in_side) / 2.0
                m_in = self.f(o + m[:, None] * d) <= 0.0
                t_in_side, t_out_side = np.where(m_in, m, t_in_side), np.where(m_in, t_out_side, m)
            return (t_out_side + t_in_side) / 2.0

        t_in = bisect(tc - half, t_mid.copy())
        t_out = bisect(tc + half, t_mid.copy())
        return np.where(inside, t_in, np.nan), np.where(inside, t_out, np.nan)


def placements(stage: Usd.Stage, time=Usd.TimeCode.Default()):
    """``[(prim path as wrt names it, gprim prim, (4, 4) row-vector own-to-world)]``: every drawn gprim of
    :data:`ORACLE_TYPES` (:func:`usd_placements.drawn_placements`)."""
    keep = lambda prim: prim.IsA(UsdGeom.Gprim) and prim.GetTypeName() in ORACLE_TYPES  # noqa: E731
    return [(name, prim, m) for name, prim, m, _ in drawn_placements(stage, keep, time)]


ORACLE_TYPES = ("Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Cylinder_1", "Capsule_1", "Plane")


def trace(stage: Usd.Stage, origins, directions, t_min=0.0, time=Usd.TimeCode.Default()):
    """Closest hits of world rays on every placed gprim of ``stage`` in float64, ``t >= t_min``.

    Returns:
        dict of ``(N,)`` arrays: ``t`` (inf on a miss), ``path`` (object, "" on a miss), ``normal`` ``(N, 3)`` world
        unit front normal, ``sharp`` (the normal is well defined: not on a rim or edge) and ``size``: the hit
        placement's reach in the world (its bounding radius times its largest stretch), 0 on a miss.
    """
    origins = np.asarray(origins, np.float64)
    directions = np.asarray(directions, np.float64)
    n = len(origins)
    best = np.full(n, np.inf)
    path = np.full(n, "", object)
    normal = np.zeros((n, 3))
    sharp = np.zeros(n, bool)
    size = np.zeros(n)
    for name, prim, m in placements(stage, time):
        solid = Solid(prim, time)
        if solid.empty:
            continue
        inv = np.linalg.inv(m)
        o = origins @ inv[:3, :3] + inv[3, :3]
        d = directions @ inv[:3, :3]
        t_in, t_out = solid.interval(o, d)
        t = np.where(t_in >= t_min, t_in, np.where(t_out >= t_min, t_out, np.nan))
        hit = np.isfinite(t)
        closer = hit & (t < best)
        if closer.any():
            p = o[closer] + t[closer, None] * d[closer]
            n_local, ok = solid.normal(p, solid.radius)
            n_world = n_local @ np.linalg.inv(m[:3, :3]).T  # row vectors: p A + b carries normals by A^-T
            n_world /= np.linalg.norm(n_world, axis=1, keepdims=True)
            if solid.left_handed:
                n_world = -n_world
            best[closer], path[closer], normal[closer], sharp[closer] = t[closer], name, n_world, ok
            size[closer] = solid.radius * np.linalg.norm(m[:3, :3], 2)
    return {"t": best, "path": path, "normal": normal, "sharp": sharp, "size": size}
