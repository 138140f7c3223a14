"""An independent float64 oracle of curves prims, written from the UsdGeomBasisCurves and UsdGeomNurbsCurves schema
documentation, one curve at a time in plain loops: the segments of each curve (vstep 3 for bezier, 1 for bspline and
catmullRom; nonperiodic, periodic, and pinned through the phantom points ``P[-1] = 2 P[0] - P[1]`` and
``P[n] = 2 P[n-1] - P[n-2]``), the centreline and the width at any parameter of a segment (constant, uniform,
varying and vertex widths), NURBS curves by de Boor's algorithm; and the swept-sphere surface of radius
``width / 2`` around them, sampled densely, as a signed distance ``f(p) = min_t |p - C(t)| - r(t)`` and the ray
queries the tests compare wrt's hits with.

Two counts the documentation leaves open follow ``UsdGeomBasisCurves::ComputeVaryingDataSize`` and Hydra, as wrt's
README states: a pinned cubic curve has the varying values of the nonperiodic curve of its vertices (at least 2),
its first and last held over the spans the phantom points add (``HdsiPinnedCurveExpandingSceneIndex``).
"""

from __future__ import annotations

import numpy as np

VSTEP = {"bezier": 3, "bspline": 1, "catmullRom": 1}


def basis_weights(basis: str, t: float) -> np.ndarray:
    """The four control weights of a cubic segment at ``t`` in [0, 1] (the schema's basis matrices written out)."""
    t = np.asarray(t, np.float64)
    s = 1.0 - t
    if basis == "bezier":
        return np.array([s**3, 3 * s * s * t, 3 * s * t * t, t**3])
    if basis == "bspline":
        return np.array([s**3, 3 * t**3 - 6 * t**2 + 4, -3 * t**3 + 3 * t**2 + 3 * t + 1, t**3]) / 6.0
    if basis == "catmullRom":
        return 0.5 * np.array([-t**3 + 2 * t**2 - t, 3 * t**3 - 5 * t**2 + 2, -3 * t**3 + 4 * t**2 + t, t**3 - t**2])
    raise ValueError(basis)


class BasisCurve:
    """One curve of a BasisCurves prim: its segments as rows of its extended control points.

    Args:
        points: ``(n, 3)`` the curve's own points; ``curve_type``, ``basis``, ``wrap``: the prim's tokens.
    """

    def __init__(self, points, curve_type: str, basis: str, wrap: str):
        self.points = np.asarray(points, np.float64)
        self.type, self.basis, self.wrap = curve_type, basis, wrap
        n = len(self.points)
        self.n = n
        # A pinned cubic bspline or catmullRom curve runs over its phantom points (bezier ignores pinned).
        self.pinned = curve_type == "cubic" and wrap == "pinned" and basis != "bezier"
        self.periodic = wrap == "periodic"
        if curve_type == "linear":
            count = n if self.periodic else n - 1
            self.segments = [[k, (k + 1) % n] for k in range(count)]
        else:
            step = VSTEP[basis]
            if self.periodic:
                count = n // step
                self.segments = [[(k * step + j) % n for j in range(4)] for k in range(count)]
            elif self.pinned:
                # Rows of [P[-1], P[0], ..., P[n-1], P[n]]: row 0 is P[-1].
                self.segments = [[k + j for j in range(4)] for k in range(n - 1)]
            else:
                count = (n - 4) // step + 1
                self.segments = [[k * step + j for j in range(4)] for k in range(count)]

    def extended(self, values) -> np.ndarray:
        """Per-vertex ``values`` ``(n, k)`` as the segments' rows index them (the phantom rows of a pinned curve)."""
        values = np.asarray(values, np.float64).reshape(self.n, -1)
        if not self.pinned:
            return values
        return np.concatenate([[2 * values[0] - values[1]], values, [2 * values[-1] - values[-2]]])

    def interpolate(self, values, segment: int, t: float) -> np.ndarray:
        """Per-vertex ``values`` along ``segment`` at ``t`` (the basis for cubic curves, linear for linear ones)."""
        rows = self.extended(values)[self.segments[segment]]
        t = np.asarray(t, np.float64)
        if self.type == "linear":
            return np.multiply.outer(1 - t, rows[0]) + np.multiply.outer(t, rows[1])
        return np.moveaxis(basis_weights(self.basis, t), 0, -1) @ rows

    def point(self, segment: int, t: float) -> np.ndarray:
        return self.interpolate(self.points, segment, t)

    def varying_count(self) -> int:
        """Varying values of this curve: one per segment end (periodic: one per segment)."""
        if self.type == "linear":
            return self.n
        if self.periodic:
            return len(self.segments)
        return max((self.n - 4) // VSTEP[self.basis], 0) + 2

    def varying_ends(self, segment: int) -> tuple[int, int]:
        """Indices (within the curve's varying values) at the start and the end of ``segment``."""
        count = self.varying_count()
        if self.periodic:
            return segment % count, (segment + 1) % count
        if self.pinned:
            # Hydra holds the first and the last value over the spans the phantom points add (half at each end).
            front = (len(self.segments) + 1 - count + 1) // 2
            return (min(max(segment - front, 0), count - 1), min(max(segment + 1 - front, 0), count - 1))
        return segment, segment + 1


class NurbsCurve:
    """One curve of a NurbsCurves prim, evaluated by de Boor's algorithm on homogeneous points ("The NURBS Book",
    A4.1 / A3.1), segments being the knot intervals of non-zero length inside its range."""

    def __init__(self, points, order: int, knots, weights=None, range_=None):
        self.points = np.asarray(points, np.float64)
        self.n = len(self.points)
        self.order = int(order)
        self.knots = np.asarray(knots, np.float64)
        self.weights = np.ones(self.n) if weights is None else np.asarray(weights, np.float64)
        p = self.order - 1
        lo, hi = self.knots[p], self.knots[self.n]
        if range_ is not None:
            lo, hi = float(range_[0]), float(range_[1])
        self.segments = []
        for i in range(p, self.n):
            a, b = max(self.knots[i], lo), min(self.knots[i + 1], hi)
            if b > a:
                self.segments.append((i, a, b))

    def _de_boor(self, values, i: int, u: float) -> np.ndarray:
        """de Boor's algorithm on the rows ``values[i - p .. i]`` at ``u`` in knot interval ``i``."""
        p, U = self.order - 1, self.knots
        d = [np.array(values[j + i - p], np.float64) for j in range(p + 1)]
        for r in range(1, p + 1):
            for j in range(p, r - 1, -1):
                denom = U[j + 1 + i - r] - U[j + i - p]
                alpha = (u - U[j + i - p]) / denom
                d[j] = (1 - alpha) * d[j - 1] + alpha * d[j]
        return d[p]

    def interpolate(self, values, segment: int, t: float) -> np.ndarray:
        """Per-control-point ``values`` by the rational basis at ``t`` of ``segment``."""
        if np.ndim(t):
            return np.array([self.interpolate(values, segment, x) for x in t])
        i, a, b = self.segments[segment]
        u = a + t * (b - a)
        values = np.asarray(values, np.float64).reshape(self.n, -1)
        homogeneous = np.concatenate([values * self.weights[:, None], self.weights[:, None]], axis=1)
        h = self._de_boor(homogeneous, i, u)
        return h[:-1] / h[-1]

    def point(self, segment: int, t: float) -> np.ndarray:
        return self.interpolate(self.points, segment, t)

    def varying_count(self) -> int:
        return self.n - self.order + 2

    def varying_ends(self, segment: int):
        i = self.segments[segment][0] - (self.order - 1)
        return i, i + 1

    def varying_t(self, segment: int, t: float) -> float:
        i, a, b = self.segments[segment]
        u = a + t * (b - a)
        return (u - self.knots[i]) / (self.knots[i + 1] - self.knots[i])


def curves_of(points, counts, make) -> list:
    """The curves of a prim: ``make(curve index, its points)`` for each run of ``counts`` points."""
    starts = np.concatenate([[0], np.cumsum(counts)])
    return [make(c, np.asarray(points)[starts[c] : starts[c + 1]]) for c in range(len(counts))]


def width_at(curves, c: int, segment: int, t: float, widths, interpolation: str, counts) -> float:
    """The width of curve ``c`` at ``t`` of ``segment``, for ``widths`` of ``interpolation``."""
    widths = np.asarray(widths, np.float64).reshape(-1)
    curve = curves[c]
    if interpolation == "constant":
        return widths[0] + 0.0 * np.asarray(t)
    if interpolation == "uniform":
        return widths[c] + 0.0 * np.asarray(t)
    if interpolation == "vertex":
        start = int(np.sum(counts[:c]))
        return curve.interpolate(widths[start : start + curve.n], segment, t)[..., 0]
    # varying: linear between the segment's two varying values (across the knot interval of a NURBS curve)
    offset = sum(k.varying_count() for k in curves[:c])
    a, b = curve.varying_ends(segment)
    s = curve.varying_t(segment, t) if isinstance(curve, NurbsCurve) else t
    return (1 - s) * widths[offset + a] + s * widths[offset + b]


def sample(curves, widths, interpolation, counts, spacing: float = 0.02):
    """``(centres (M, 3), radii (M,), curve (M,))``: the curves densely sampled, consecutive points at most
    ``spacing`` times the largest radius apart (a union of spheres that close strays ``spacing^2 / 8`` of the radius
    from the swept sphere), radii ``max(width, 0) / 2`` (a catmullRom overshoot below 0 draws nothing there)."""
    centres, radii, which = [], [], []
    for c, curve in enumerate(curves):
        for s in range(len(curve.segments)):
            pilot = np.linspace(0.0, 1.0, 65)
            speed = np.linalg.norm(np.diff(curve.point(s, pilot), axis=0), axis=1).max() * 64
            r = np.maximum(width_at(curves, c, s, pilot, widths, interpolation, counts), 0.0) / 2
            ts = np.linspace(0.0, 1.0, int(min(max(64, speed / (spacing * max(r.max(), 1e-6))), 20000)) + 1)
            centres.append(curve.point(s, ts))
            radii.append(np.maximum(width_at(curves, c, s, ts, widths, interpolation, counts), 0.0) / 2)
            which.append(np.full(len(ts), c))
    return np.concatenate(centres), np.concatenate(radii), np.concatenate(which)


def _segment_distance(o, e, c):
    """``(R, M)`` distances from the segments ``o -> e`` ``(R, 3)`` to points ``c`` ``(R, M, 3)``."""
    d = e - o
    length2 = np.maximum((d * d).sum(1), 1e-300)
    s = np.clip(((c - o[:, None]) * d[:, None]).sum(2) / length2[:, None], 0.0, 1.0)
    return np.linalg.norm(o[:, None] + s[..., None] * d[:, None] - c, axis=2)


def _nearest_blocks(o, e, centres, radii, block=64, near=6, chunk=1024):
    """``(R,)`` ``min_i (dist(segment o -> e, c_i) - r_i)`` over all samples, exact: the samples are grouped in
    blocks of consecutive ones bounded by a sphere; each segment is measured against its ``near`` closest blocks by
    lower bound, and against all of them where a further block could be closer."""
    pad = (-len(centres)) % block
    c = np.concatenate([centres, np.repeat(centres[-1:], pad, 0)]).reshape(-1, block, 3)
    r = np.concatenate([radii, np.repeat(radii[-1:], pad)]).reshape(-1, block)
    middle = c.mean(axis=1)
    reach = np.linalg.norm(c - middle[:, None], axis=2).max(axis=1) + r.max(axis=1)
    near = min(near, len(c))
    out = np.empty(len(o))
    for a in range(0, len(o), chunk):
        oa, ea = o[a : a + chunk], e[a : a + chunk]
        lower = _segment_distance(oa, ea, np.broadcast_to(middle, (len(oa), *middle.shape))) - reach[None]
        order = np.argsort(lower, axis=1)
        chosen = order[:, :near]
        exact = _segment_distance(oa, ea, c[chosen].reshape(len(oa), -1, 3)) - r[chosen].reshape(len(oa), -1)
        best = exact.min(axis=1)
        if near < len(c):
            unsure = np.flatnonzero(best > np.take_along_axis(lower, order[:, near : near + 1], 1)[:, 0])
            for k in unsure:
                whole = _segment_distance(oa[k : k + 1], ea[k : k + 1], centres[None]) - radii[None]
                best[k] = whole.min()
        out[a : a + chunk] = best
    return out


def signed_distance(p, centres, radii) -> np.ndarray:
    """``(P,)`` ``min_i |p - c_i| - r_i`` of points ``p`` ``(P, 3)``: the distance to the swept surface outside it
    (exact for the union of the sampled spheres), negative inside."""
    p = np.asarray(p, np.float64)
    return _nearest_blocks(p, p, centres, radii)


def deepest_along(origins, ends, centres, radii) -> np.ndarray:
    """``(R,)`` ``min_i (dist(segment origin -> end, c_i) - r_i)``: how deep each ray segment goes into the swept
    surface (negative: that deep inside)."""
    return _nearest_blocks(np.asarray(origins, np.float64), np.asarray(ends, np.float64), centres, radii)
