"""Non-uniform rational B-splines, numpy only: knot checks, the basis functions of many parameters at once, and the
spans (knot intervals) that ``UsdGeom.NurbsCurves`` and ``UsdGeom.NurbsPatch`` prims are drawn by.

A curve of ``n`` control points ``P`` (weights ``w``, 1 when not authored) and order ``k`` (degree ``p = k - 1``) has
``n + k`` non-decreasing knots ``U`` and is defined on ``[U[p], U[n]]`` (narrowed by ``ranges``); on the knot
interval ``[U[i], U[i + 1])`` only ``P[i - p] .. P[i]`` count: ``C(u) = sum N_j(u) w_j P_j / sum N_j(u) w_j``, the
``N_j`` the Cox-de Boor basis of degree ``p`` ("The NURBS Book", Piegl and Tiller, algorithm A2.2 BasisFuns),
evaluated here for every parameter in one array pass per degree. Points are not pre-weighted (the UsdGeom schemas
say so). A surface is the tensor product of two such bases.

A span is one knot interval of non-zero length inside the range; the spans are what is cut into straight pieces (a
curve) or a grid (a patch). ``C''`` within a span is not a low-degree polynomial once weights differ, so the number
of pieces comes from second differences of ``C`` on :data:`PILOT_SAMPLES` points per span: with ``K`` equal steps
of the span's parameter ``t`` in ``[0, 1]``, a chord strays at most ``max |C''| / (8 K^2)`` from the curve (and a
curve's radius, sampled on the same points, as little from its own).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .tubes import CURVE_TOLERANCE, MAX_SPAN_SEGMENTS

PILOT_SAMPLES = 17  # points per span on which C'' is estimated (second differences) to choose the tessellation


def check_knots(knots: np.ndarray, order: int, count: int) -> str | None:
    """Why ``knots`` (one curve's or one patch direction's) cannot define a B-spline of ``count`` control points
    and ``order``, or None when they can: their number, finite values, that they never decrease, and that the
    domain ``[U[order - 1], U[count]]`` has a length."""
    if order < 2:
        return f"order {order} is below 2 (a curve of degree {order - 1} draws no line)"
    if count < order:
        return f"{count} control points are fewer than the order {order}"
    if len(knots) != count + order:
        return f"{len(knots)} knots; {count} control points of order {order} need {count + order}"
    if not np.isfinite(knots).all():
        i = int(np.argmax(~np.isfinite(knots)))
        return f"knot {i} is {knots[i]}"
    drops = np.flatnonzero(np.diff(knots) < 0.0)
    if len(drops):
        i = int(drops[0]) + 1
        return f"knots decrease at {i} ({knots[i - 1]:g} then {knots[i]:g})"
    if not knots[count] > knots[order - 1]:
        return f"the domain [knots[{order - 1}], knots[{count}]] = [{knots[order - 1]:g}, {knots[count]:g}] is empty"
    return None


def check_range(knots: np.ndarray, order: int, count: int, lo: float, hi: float) -> str | None:
    """Why ``(lo, hi)`` is not a valid ``range`` of these knots (inside the domain, lo < hi), or None."""
    a, b = knots[order - 1], knots[count]
    if not (np.isfinite(lo) and np.isfinite(hi) and a <= lo < hi <= b):
        return f"range ({lo:g}, {hi:g}) is not an interval inside the knots' domain [{a:g}, {b:g}]"
    return None


def spans_of(knots: np.ndarray, order: int, count: int, lo: float, hi: float):
    """The spans of one curve: ``(interval (S,) int64 knot index i of [U[i], U[i+1]], start (S,), end (S,))``, the
    knot intervals of the domain that overlap ``(lo, hi)`` with a length, clipped to it."""
    i = np.arange(order - 1, count)
    start = np.maximum(knots[i], lo)
    end = np.minimum(knots[i + 1], hi)
    keep = end > start
    return i[keep], start[keep], end[keep]


def basis(local_knots: np.ndarray, u: np.ndarray, degree: int) -> np.ndarray:
    """``(M, degree + 1)`` B-spline basis values ``N[i - p .. i]`` at parameters ``u`` ``(M,)`` each in its knot
    interval ``[U[i], U[i + 1])`` of non-zero length; ``local_knots`` ``(M, 2 p)`` holds ``U[i - p + 1 .. i + p]``
    for each parameter (Piegl and Tiller A2.2)."""
    m = len(u)
    n = np.zeros((m, degree + 1))
    n[:, 0] = 1.0
    # left[j] = u - U[i + 1 - j], right[j] = U[i + j] - u, for j = 1 .. p (local index of U[i + 1 - j] is p - j).
    left = np.zeros((m, degree + 1))
    right = np.zeros((m, degree + 1))
    for j in range(1, degree + 1):
        left[:, j] = u - local_knots[:, degree - j]
        right[:, j] = local_knots[:, degree - 1 + j] - u
        saved = np.zeros(m)
        for r in range(j):
            # right[r + 1] + left[j - r] = U[i + r + 1] - U[i + 1 - j + r] >= U[i + 1] - U[i] > 0.
            temp = n[:, r] / (right[:, r + 1] + left[:, j - r])
            n[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        n[:, j] = saved
    return n


def basis_rows(knots: np.ndarray, interval: np.ndarray, u: np.ndarray, degree: int):
    """``(rows (M, degree + 1) int64, N (M, degree + 1))``: the knot indices ``i - p .. i`` (control point indices
    when the knots start at the curve's first) and the B-spline basis values at parameters ``u`` ``(M,)``, each in
    its knot interval ``[knots[i], knots[i + 1])``, ``interval`` ``(M,)`` its ``i``."""
    local = knots[interval[:, None] + np.arange(-degree + 1, degree + 1)[None]] if degree else np.zeros((len(u), 0))
    return interval[:, None] - degree + np.arange(degree + 1)[None], basis(local, u, degree)


def rational_weights(knots: np.ndarray, interval: np.ndarray, u: np.ndarray, degree: int, first: np.ndarray,
                     weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rows (M, p + 1) int64, R (M, p + 1))``: the control points (rows of the prim's arrays) that count at each
    parameter ``u`` and their rational basis values ``R_j = w_j N_j / sum w N`` (sum 1).

    Args:
        knots: the prim's flat knot array; ``interval`` ``(M,)`` the index in it of each parameter's ``U[i]``.
        first: ``(M,)`` row of the curve's ``P[0]`` minus the knot index of the curve's ``U[0]`` (so that the
            control point ``P[i - p + j]`` is row ``first + i - p + j``).
        weights: the prim's ``pointWeights`` ``(n,)`` (ones when not authored).
    """
    rows, n = basis_rows(knots, interval, u, degree)
    rows = rows + first[:, None]
    wn = n * weights[rows]
    total = wn.sum(axis=1, keepdims=True)
    return rows, wn / total


def pieces(samples: np.ndarray, tolerance: np.ndarray, most: int) -> np.ndarray:
    """``(S,)`` int64 equal parameter steps per span so that chords stay within ``tolerance`` ``(S,)`` of the curve,
    from ``samples`` ``(S, PILOT_SAMPLES, d)`` of it at equal steps of the span's ``t`` in ``[0, 1]``: ``max |C''|``
    from second differences, ``K = ceil(sqrt(max |C''| / (8 tol)))``, 1 to ``most``."""
    h = 1.0 / (samples.shape[1] - 1)
    second = (samples[:, 2:] - 2.0 * samples[:, 1:-1] + samples[:, :-2]) / (h * h)
    bend = np.linalg.norm(second, axis=2).max(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.ceil(np.sqrt(bend / (8.0 * tolerance)))
    k = np.where((bend > 0.0) & (tolerance > 0.0), k, 1.0)
    return np.clip(np.nan_to_num(k, nan=most), 1, most).astype(np.int64)


@dataclasses.dataclass
class NurbsSpans:
    """The spans of a ``UsdGeom.NurbsCurves`` prim, with the interface of :class:`wrt.tubes.Spans` that
    :class:`wrt.usd_tubes.TubeReader` draws curves through.

    Attributes:
        interval: ``(S,)`` int64 index in ``knots`` of each span's knot ``U[i]``.
        start, end: ``(S,)`` float64 parameter range of each span (its knot interval clipped to the curve's range).
        degree: ``(S,)`` int64 degree (order - 1) of the span's curve.
        first: ``(S,)`` int64 row of the curve's ``P[0]`` minus the index in ``knots`` of its ``U[0]``.
        curve: ``(S,)`` int64 curve of each span.
        last: ``(S,)`` bool: the span ends its curve, or a piece of it that a knot of multiplicity ``order``
            breaks off (its end gets a sphere).
        varying: ``(S, 2)`` int64 ``varying`` value at each end of the span's knot interval.
        n_varying: ``varying`` values the prim needs: ``count - order + 2`` per curve (one per knot of its domain,
            as RenderMan's RiNuCurves counts them).
        knots: the prim's flat ``knots``; weights: ``(n,)`` its ``pointWeights`` (ones when not authored).
    """

    interval: np.ndarray
    start: np.ndarray
    end: np.ndarray
    degree: np.ndarray
    first: np.ndarray
    curve: np.ndarray
    last: np.ndarray
    varying: np.ndarray
    n_varying: int
    knots: np.ndarray
    weights: np.ndarray

    def take(self, keep: np.ndarray) -> NurbsSpans:
        """The spans at ``keep`` (a boolean mask)."""
        return dataclasses.replace(self, **{f: getattr(self, f)[keep] for f in (
            "interval", "start", "end", "degree", "first", "curve", "last", "varying")})

    def extend(self, values: np.ndarray) -> np.ndarray:
        """Per-vertex values as they are (a NURBS curve has no phantom vertices)."""
        return values

    def at(self, values: np.ndarray, span: np.ndarray, t: np.ndarray) -> np.ndarray:
        """``(M, k)`` the rational curve of per-control-point ``values`` ``(n, k)`` at ``t`` in ``[0, 1]`` of
        ``span``."""
        u = self.start[span] + t * (self.end[span] - self.start[span])
        out = np.zeros((len(span), values.shape[1]))
        for degree in np.unique(self.degree[span]):
            sel = np.flatnonzero(self.degree[span] == degree)
            s = span[sel]
            rows, r = rational_weights(self.knots, self.interval[s], u[sel], int(degree), self.first[s], self.weights)
            out[sel] = np.einsum("mj,mjk->mk", r, values[rows])
        return out

    def varying_t(self, span: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Where ``t`` of ``span`` lies in its knot interval (``varying`` values are linear across it)."""
        a, b = self.knots[self.interval[span]], self.knots[self.interval[span] + 1]
        u = self.start[span] + t * (self.end[span] - self.start[span])
        return (u - a) / (b - a)

    radius_t = np.linspace(0.0, 1.0, PILOT_SAMPLES)  # parameters where :meth:`segments` wants each span's radius

    def segments(self, points: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """``(S,)`` straight segments per span: chords within ``CURVE_TOLERANCE`` of the span's largest radius
        (:func:`pieces`), and the radius along them as close (widths that swell inside a straight span are cut
        too); ``radii`` ``(S, PILOT_SAMPLES)`` at :attr:`radius_t` of each span."""
        s = np.repeat(np.arange(len(self.curve)), PILOT_SAMPLES)
        t = np.tile(self.radius_t, len(self.curve))
        samples = self.at(points, s, t)
        samples = samples.reshape(len(self.curve), PILOT_SAMPLES, samples.shape[-1])  # no spans: no samples
        tolerance = CURVE_TOLERANCE * radii.max(axis=1)
        return np.maximum(pieces(samples, tolerance, MAX_SPAN_SEGMENTS),
                          pieces(radii[:, :, None], tolerance, MAX_SPAN_SEGMENTS))


def nurbs_curve_spans(counts: np.ndarray, orders: np.ndarray, knots: np.ndarray, ranges: np.ndarray | None,
                      weights: np.ndarray) -> NurbsSpans:
    """The spans of NURBS curves of ``counts`` control points and ``orders`` each, their knots one flat array.

    Args:
        ranges: ``(C, 2)`` parameter range of each curve, or None (each curve's whole domain).

    Raises:
        ValueError: the orders, knots or ranges do not fit the curves (naming the first curve that is wrong).
    """
    counts = np.asarray(counts, np.int64)
    orders = np.asarray(orders, np.int64)
    if len(orders) != len(counts):
        raise ValueError(f"order has {len(orders)} values for {len(counts)} curves")
    if ranges is not None and len(ranges) != len(counts):
        raise ValueError(f"ranges has {len(ranges)} values for {len(counts)} curves")
    if len(knots) != int((counts + orders).sum()):
        raise ValueError(f"knots has {len(knots)} values; the curves' counts plus orders need "
                         f"{int((counts + orders).sum())}")
    knot_starts = np.cumsum(counts + orders) - counts - orders
    row_starts = np.cumsum(counts) - counts
    varying_starts = np.cumsum(counts - orders + 2) - (counts - orders + 2)

    # Check every curve at once; the first that fails is checked again alone for the message.
    bad = (orders < 2) | (counts < orders)
    # Each curve's domain [U[order - 1], U[count]] (any knot, kept in bounds, for a curve already found bad).
    padded = np.append(knots, 0.0)
    lo = padded[np.minimum(np.where(bad, knot_starts, knot_starts + orders - 1), len(knots))]
    hi = padded[np.minimum(np.where(bad, knot_starts, knot_starts + counts), len(knots))]
    with np.errstate(invalid="ignore"):
        drops = np.diff(knots) < 0.0
    curve_of_knot = np.repeat(np.arange(len(counts)), counts + orders)
    inside = curve_of_knot[1:] == curve_of_knot[:-1]  # a drop between two curves' knots is no error
    bad |= np.bincount(curve_of_knot[1:][drops & inside], minlength=len(counts)) > 0
    bad |= np.bincount(curve_of_knot[~np.isfinite(knots)], minlength=len(counts)) > 0
    bad |= ~(hi > lo)
    if ranges is not None:
        ranges = np.asarray(ranges, np.float64)
        with np.errstate(invalid="ignore"):
            bad |= ~((lo <= ranges[:, 0]) & (ranges[:, 0] < ranges[:, 1]) & (ranges[:, 1] <= hi))
        lo, hi = np.where(bad, lo, ranges[:, 0]), np.where(bad, hi, ranges[:, 1])
    if bad.any():
        c = int(np.argmax(bad))
        n, k, k0 = int(counts[c]), int(orders[c]), int(knot_starts[c])
        own = knots[k0 : k0 + n + k]
        why = check_knots(own, k, n) or check_range(own, k, n, *map(float, ranges[c]))
        raise ValueError(f"curve {c}: {why}")

    # Spans: each curve's knot intervals of its domain that overlap its range, clipped to it.
    per_curve = np.maximum(counts - orders + 1, 0)
    curve = np.repeat(np.arange(len(counts)), per_curve)
    first = np.cumsum(per_curve) - per_curve
    interval = knot_starts[curve] + orders[curve] - 1 + np.arange(len(curve)) - first[curve]
    start = np.maximum(knots[interval], lo[curve])
    end = np.minimum(knots[interval + 1], hi[curve])
    keep = end > start
    interval, start, end, curve = interval[keep], start[keep], end[keep], curve[keep]
    degree = orders[curve] - 1
    local = interval - knot_starts[curve] - degree  # knot interval within the curve's domain, from 0
    varying = varying_starts[curve][:, None] + local[:, None] + np.array([0, 1])
    # A span ends its curve's drawn piece at the curve's last span, and where a knot repeated ``order`` times breaks
    # the curve (the next span starts elsewhere): both ends get a sphere there.
    last = np.append(curve[1:] != curve[:-1], True) if len(curve) else np.zeros(0, bool)
    last |= _knot_multiplicity(knots, curve_of_knot)[interval + 1] >= orders[curve]
    return NurbsSpans(interval, start, end, degree, row_starts[curve] - knot_starts[curve], curve, last, varying,
                      int((counts - orders + 2).sum()), knots, weights)


def _knot_multiplicity(knots: np.ndarray, curve_of_knot: np.ndarray) -> np.ndarray:
    """``(len(knots),)`` how many times each knot's value appears among its curve's knots (they never decrease)."""
    new_run = np.ones(len(knots), bool)
    new_run[1:] = (knots[1:] != knots[:-1]) | (curve_of_knot[1:] != curve_of_knot[:-1])
    run = np.cumsum(new_run) - 1
    return np.bincount(run)[run]


PATCH_TOLERANCE = 1e-3  # a NURBS patch's triangles stay within this fraction of its control box's diagonal
MAX_PATCH_STEPS = 64  # most steps per span and direction of a NURBS patch


class Direction:
    """One parametric direction (u or v) of a NURBS patch, cut into steps: its grid parameters, their basis values
    and control-point indices, and where each lies in the knot intervals (for ``uniform`` and ``varying``
    primvars).

    Args:
        knots, order, count: the direction's knots, order and control points (checked with :func:`check_knots`).
        lo, hi: its range.
        steps: ``(S,)`` steps per span; ``None``: the pilot grid, :data:`PILOT_SAMPLES` parameters per span from
            its start to its end (span ends twice).
    """

    def __init__(self, knots: np.ndarray, order: int, count: int, lo: float, hi: float, steps=None):
        interval, start, end = spans_of(knots, order, count, lo, hi)
        self.order = order
        self.n_spans = len(interval)
        if steps is None:
            span = np.repeat(np.arange(len(interval)), PILOT_SAMPLES)
            frac = np.tile(np.linspace(0.0, 1.0, PILOT_SAMPLES), len(interval))
        else:
            # Every step of every span, then the range's end (shared span ends appear once).
            steps = np.asarray(steps, np.int64)
            span = np.repeat(np.arange(len(interval)), steps)
            j = np.arange(len(span)) - (np.cumsum(steps) - steps)[span]
            frac = np.append(j / steps[span], 1.0)
            span = np.append(span, len(interval) - 1)
        self.span = span  # (M,) span of each grid parameter
        self.u = start[span] + frac * (end[span] - start[span])  # (M,) grid parameters
        i = interval[span]
        self.rows, self.n = basis_rows(knots, i, self.u, order - 1)  # (M, order) control indices and N values
        self.segment = i - (order - 1)  # (M,) knot interval within the domain (uniform and varying index)
        self.segment_t = (self.u - knots[i]) / (knots[i + 1] - knots[i])  # (M,) place within it, 0 to 1
        self.n_segments = count - order + 1  # knot intervals of the domain, zero-length ones too (RenderMan's count)


def patch_values(u: Direction, v: Direction, values: np.ndarray, weights: np.ndarray, nu: int) -> np.ndarray:
    """``(Mv, Mu, k)`` the rational tensor-product surface of per-control-point ``values`` ``(nu * nv, k)`` (u
    fastest, as the schema lays points out) on the grid of ``u`` and ``v``."""
    out = np.empty((len(v.u), len(u.u), values.shape[1]))
    # Rows of the grid a few at a time: the gathered control values are (rows, Mu, jv, ju, k).
    step = max(1, (1 << 22) // (len(u.u) * u.n.shape[1] * v.n.shape[1] * max(values.shape[1], 1)))
    for b in range(0, len(v.u), step):
        rows = slice(b, b + step)
        index = v.rows[rows, None, :, None] * nu + u.rows[None, :, None, :]  # (rows, Mu, jv, ju)
        basis_uv = v.n[rows, None, :, None] * u.n[None, :, None, :] * weights[index]
        total = basis_uv.sum(axis=(2, 3))
        out[rows] = np.einsum("baji,bajik->bak", basis_uv, values[index]) / total[..., None]
    return out


def patch_steps(u: Direction, v: Direction, points: np.ndarray, weights: np.ndarray, nu: int, tolerance: float):
    """Steps per span in u and in v so that the triangles stay within ``tolerance`` of the surface, from second
    differences on the pilot grid (``u`` and ``v`` made with ``steps=None``): a cell of steps ``(hu, hv)`` in the
    spans' ``t`` is within ``(hu^2 (Suu + Suv) + hv^2 (Svv + Suv)) / 8`` of the surface (``S..`` the largest second
    derivatives over its span row or column), and each direction is given half of ``tolerance``."""
    p = PILOT_SAMPLES
    grid = patch_values(u, v, points, weights, nu).reshape(v.n_spans, p, u.n_spans, p, -1)
    h2 = (1.0 / (p - 1)) ** 2

    def largest(difference, axes):
        return np.linalg.norm(difference, axis=-1).max(axis=axes) / h2

    # Second differences within each span block (a kink at a repeated knot is no curvature of either span).
    second_u = grid[:, :, :, 2:] - 2.0 * grid[:, :, :, 1:-1] + grid[:, :, :, :-2]
    second_v = grid[:, 2:] - 2.0 * grid[:, 1:-1] + grid[:, :-2]
    mixed = grid[:, 1:, :, 1:] - grid[:, 1:, :, :-1] - grid[:, :-1, :, 1:] + grid[:, :-1, :, :-1]
    suu, svv = largest(second_u, (0, 1, 3)), largest(second_v, (1, 2, 3))
    suv_u, suv_v = largest(mixed, (0, 1, 3)), largest(mixed, (1, 2, 3))
    steps = []
    for bend in (suu + suv_u, svv + suv_v):
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.ceil(np.sqrt(bend / (4.0 * tolerance)))
        k = np.where((bend > 0.0) & (tolerance > 0.0), k, 1.0)
        steps.append(np.clip(np.nan_to_num(k, nan=MAX_PATCH_STEPS), 1, MAX_PATCH_STEPS).astype(np.int64))
    return steps


def grid_triangles(mu: int, mv: int) -> np.ndarray:
    """``(2 (mu - 1) (mv - 1), 3)`` triangles of a grid of ``mv`` rows of ``mu`` vertices (u fastest): each cell
    ``(u, v), (u + 1, v), (u + 1, v + 1), (u, v + 1)``, counter-clockwise in (u, v) as Storm winds a patch's hull,
    cut along its diagonal from ``(u, v)``."""
    a = (np.arange(mv - 1)[:, None] * mu + np.arange(mu - 1)[None]).reshape(-1)
    b, c, d = a + 1, a + mu + 1, a + mu
    return np.stack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)], 1).reshape(-1, 3)


__all__ = ["MAX_PATCH_STEPS", "PATCH_TOLERANCE", "PILOT_SAMPLES", "Direction", "NurbsSpans", "basis", "basis_rows",
           "check_knots", "check_range", "grid_triangles", "nurbs_curve_spans", "patch_steps", "patch_values", "pieces",
           "rational_weights", "spans_of"]
