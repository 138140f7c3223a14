"""Points and curves as spheres and round tubes: the instance transforms that draw a ``UsdGeom.Points`` or
``UsdGeom.BasisCurves`` prim with wrt's analytic shapes (:mod:`wrt.primitives`), numpy only, no Python object per
point or segment.

A point of width ``w`` is a sphere of radius ``w / 2``: an instance of the unit sphere scaled by the radius. A curve
is a round tube of radius ``width / 2`` around a polyline: each straight segment is the side of a cylinder (equal
radii at its ends; the unit cylinder scaled by the radius across and by half the segment's length along, exact) or of
a cone frustum (radii differ), and every polyline vertex carries a sphere of its radius, which rounds the joints and
caps the ends. A frustum's narrowing ``rho`` (small radius over large) is a shape parameter, not part of a transform,
so segments share :data:`RHO_LEVELS` + 1 cone shapes: ``rho`` is rounded down to a multiple of ``1 / RHO_LEVELS``,
which narrows the frustum's small end by less than ``1 / RHO_LEVELS`` of its large radius, inside the sphere there
(the spheres keep the exact radii).

Cubic spans (``bezier``, ``bspline``, ``catmullRom``; the ``vstep`` and ``wrap`` rules of the UsdGeomBasisCurves
documentation, ``pinned`` through its phantom points ``P[-1] = 2 P[0] - P[1]`` and ``P[n] = 2 P[n-1] - P[n-2]``)
are cut into ``K`` straight segments of equal parameter steps, vertices on the curve. The chord of a parameter step
``h`` strays at most ``h^2 / 8 max |C''|`` from the curve, and ``C''`` of a cubic is linear in ``t``, so its largest
length is at an end of the span: ``K = ceil(sqrt(max(|C''(0)|, |C''(1)|) / (8 tol)))`` keeps every chord within
``tol = CURVE_TOLERANCE`` times the span's largest radius of the curve (``1 <= K <= MAX_SPAN_SEGMENTS``). The radius
along the span is a cubic (or simpler) as well, linear between the segment ends: its ``|r''|`` counts in the same
bound, so the tube's radius strays as little (a straight span whose widths swell in its middle is cut too).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .instancing import invert_transforms

RHO_LEVELS = 128  # frustum narrowings are multiples of 1 / RHO_LEVELS (level RHO_LEVELS: a cylinder)
CURVE_TOLERANCE = 0.05  # a cubic span's polyline stays within this fraction of its largest radius of the curve
MAX_SPAN_SEGMENTS = 64  # most straight segments per cubic span
RADIUS_SAMPLES = np.arange(4) / 3.0  # parameters where a span's radius is sampled for its segment count

# Cubic bases in power form: a span's point at t is [t^3, t^2, t, 1] @ matrix @ its four vertices; and their vstep.
CUBIC_BASES = {
    "bezier": (np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 3, 0, 0], [1, 0, 0, 0]], np.float64), 3),
    "bspline": (np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 0, 3, 0], [1, 4, 1, 0]], np.float64) / 6.0, 1),
    "catmullRom": (np.array([[-1, 3, -3, 1], [2, -5, 4, -1], [-1, 0, 1, 0], [0, 2, 0, 0]], np.float64) / 2.0, 1),
}
# A linear segment in the same form, its two vertices in the first two columns: (1 - t) P0 + t P1.
LINEAR_BASIS = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [-1, 1, 0, 0], [1, 0, 0, 0]], np.float64)


@dataclasses.dataclass
class Spans:
    """The spans (segments of a linear curve, cubic pieces of a cubic one) of a BasisCurves prim.

    Attributes:
        vertices: ``(S, 4)`` int64 rows of the extended vertex arrays (:meth:`extend`) each span interpolates (a
            linear segment: its two vertices, then the second again).
        varying: ``(S, 2)`` int64 index of the ``varying`` primvar value at each end of each span.
        curve: ``(S,)`` int64 curve of each span.
        last: ``(S,)`` bool: the span ends a nonperiodic curve (its end vertex gets a sphere).
        phantoms: ``(Q, 2)`` int64 ``(a, b)``: extended row ``n + q`` is ``2 v[a] - v[b]`` (pinned curves' ends).
        matrix: ``(4, 4)`` the basis in power form.
        n_varying: the number of ``varying`` values the prim needs.
    """

    vertices: np.ndarray
    varying: np.ndarray
    curve: np.ndarray
    last: np.ndarray
    phantoms: np.ndarray
    matrix: np.ndarray
    n_varying: int

    def extend(self, values: np.ndarray) -> np.ndarray:
        """Per-vertex ``values`` ``(n, k)`` with the pinned curves' phantom rows appended."""
        a, b = self.phantoms[:, 0], self.phantoms[:, 1]
        return np.concatenate([values, 2.0 * values[a] - values[b]]) if len(a) else values

    def take(self, keep: np.ndarray) -> Spans:
        """The spans at ``keep`` (a boolean mask)."""
        return dataclasses.replace(self, vertices=self.vertices[keep], varying=self.varying[keep],
                                   curve=self.curve[keep], last=self.last[keep])

    def at(self, values: np.ndarray, span: np.ndarray, t: np.ndarray) -> np.ndarray:
        """``(M, k)`` the curve of per-vertex ``values`` (extended, ``(n', k)``) at parameters ``t`` of ``span``."""
        return np.einsum("mj,mjk->mk", span_weights(self.matrix, t), values[self.vertices[span]])

    def varying_t(self, span: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Where ``t`` of ``span`` lies between the span's two ``varying`` values (linear): ``t`` itself."""
        return t

    radius_t = RADIUS_SAMPLES  # parameters where :meth:`segments` wants each span's radius

    def segments(self, points: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """Straight segments per span (:func:`span_segments`); ``radii`` ``(S, 4)`` at :data:`RADIUS_SAMPLES`."""
        return span_segments(self, points, radii)


def curve_spans(counts: np.ndarray, curve_type: str, basis: str, wrap: str) -> Spans:
    """The spans of curves of ``counts`` vertices each (``curveVertexCounts``), by UsdGeomBasisCurves' segment rules.

    Raises:
        ValueError: a count that makes no curve of this type, basis and wrap (naming the curve).
    """
    counts = np.asarray(counts, np.int64).reshape(-1)
    starts = np.cumsum(counts) - counts
    periodic = wrap == "periodic"
    if curve_type == "linear":
        step, matrix, width = 1, LINEAR_BASIS, 2
        n_spans, need = (counts if periodic else counts - 1), "at least 2 vertices"
        bad = counts < 2
    else:
        matrix, step = CUBIC_BASES[basis]
        width = 4
        if periodic:
            n_spans, need = counts // step, f"a multiple of {step} vertices, at least {max(step, 3)}"
            bad = (counts < max(step, 3)) | (counts % step != 0)
        elif wrap == "pinned" and step == 1:
            n_spans, need = counts - 1, "at least 2 vertices"
            bad = counts < 2
        else:
            n_spans, need = (counts - 4) // step + 1, f"4 + {step} k vertices" if step > 1 else "at least 4 vertices"
            bad = (counts < 4) | ((counts - 4) % step != 0)
    if bad.any():
        i = int(np.argmax(bad))
        kind = "linear" if curve_type == "linear" else f"{wrap} {basis}"
        raise ValueError(f"curveVertexCounts[{i}] = {counts[i]} makes no {kind} curve (it needs {need})")
    pinned = curve_type != "linear" and wrap == "pinned" and step == 1
    n_spans = np.maximum(n_spans, 0)
    curve = np.repeat(np.arange(len(counts)), n_spans)
    k = np.arange(len(curve)) - (np.cumsum(n_spans) - n_spans)[curve]  # span index within its curve
    local = k[:, None] * step + np.arange(width)[None]  # vertex positions within the curve
    n = counts[curve][:, None]
    phantoms = np.zeros((0, 2), np.int64)
    if periodic:
        local = local % n
    elif pinned:
        # The curve runs over [P[-1], P[0], ..., P[n-1], P[n]]: position -1 and n are its phantom rows.
        first, last = starts, starts + counts - 1
        phantoms = np.concatenate([np.stack([first, first + 1], 1), np.stack([last, last - 1], 1)])
        local = local - 1
    vertices = starts[curve][:, None] + local
    if pinned:
        total = int(counts.sum())
        vertices = np.where(local < 0, total + curve[:, None], vertices)
        vertices = np.where(local >= n, total + len(counts) + curve[:, None], vertices)
    if width == 2:
        vertices = np.concatenate([vertices, vertices[:, 1:], vertices[:, 1:]], axis=1)
    # Varying values: one per span end (a periodic curve's last span ends at its first value).
    if curve_type == "linear":
        varying = vertices[:, :2]
        n_varying = int(counts.sum())
    else:
        per_curve = n_spans if periodic else n_spans + 1
        ends = np.stack([k, k + 1], axis=1)
        if periodic:
            ends = ends % np.maximum(n_spans[curve], 1)[:, None]
        elif pinned:
            # A pinned curve's varying values are those of the nonperiodic curve of its vertices, at least 2
            # (UsdGeomBasisCurves::ComputeVaryingDataSize): Hydra holds the first and the last over the spans the
            # phantom points add, half of them at each end (HdsiPinnedCurveExpandingSceneIndex).
            per_curve = np.maximum(counts - 4, 0) + 2
            front = (n_spans + 1 - per_curve + 1) // 2
            ends = np.clip(ends - front[curve][:, None], 0, (per_curve - 1)[curve][:, None])
        offsets = np.cumsum(per_curve) - per_curve
        varying = offsets[curve][:, None] + ends
        n_varying = int(per_curve.sum())
    last_span = k == n_spans[curve] - 1
    return Spans(vertices, varying, curve, last_span & (not periodic), phantoms, matrix, n_varying)


def hermite_spans(counts: np.ndarray) -> Spans:
    """The cubic spans of ``UsdGeom.HermiteCurves`` of ``counts`` points each: segment ``i`` of a curve runs from
    ``P[i]`` to ``P[i + 1]`` with tangents ``T[i]``, ``T[i + 1]``, which is the Bezier span ``P[i], P[i] + T[i] / 3,
    P[i + 1] - T[i + 1] / 3, P[i + 1]``. Its vertex rows index ``[P; P + T / 3; P - T / 3]`` (``3 n`` rows, made by
    the caller); ``varying`` values are the points' (linear along each segment, as the schema suggests).

    Raises:
        ValueError: a curve of fewer than 2 points (naming it).
    """
    counts = np.asarray(counts, np.int64).reshape(-1)
    if np.any(counts < 2):
        i = int(np.argmax(counts < 2))
        raise ValueError(f"curveVertexCounts[{i}] = {counts[i]} makes no hermite curve (it needs at least 2 points)")
    n = int(counts.sum())
    starts = np.cumsum(counts) - counts
    n_spans = counts - 1
    curve = np.repeat(np.arange(len(counts)), n_spans)
    a = starts[curve] + np.arange(len(curve)) - (np.cumsum(n_spans) - n_spans)[curve]
    vertices = np.stack([a, n + a, 2 * n + a + 1, a + 1], axis=1)
    last = a + 1 == starts[curve] + counts[curve] - 1
    return Spans(vertices, np.stack([a, a + 1], axis=1), curve, last, np.zeros((0, 2), np.int64),
                 CUBIC_BASES["bezier"][0], n)


def span_weights(matrix: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``(len(t), 4)`` weights of a span's four vertices at parameters ``t``."""
    t = np.asarray(t, np.float64)
    return np.stack([t**3, t**2, t, np.ones_like(t)], axis=1) @ matrix


def span_segments(spans: Spans, points: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """``(S,)`` int64 straight segments per span (see the module docstring); ``points`` extended, ``radii``
    ``(S, 4)`` the radius of each span at :data:`RADIUS_SAMPLES`."""
    # C''(t) = [6t, 2, 0, 0] @ matrix @ P: evaluated at t = 0 and 1.
    second = np.array([[0.0, 2.0, 0.0, 0.0], [6.0, 2.0, 0.0, 0.0]]) @ spans.matrix  # (2, 4)
    cps = points[spans.vertices]  # (S, 4, 3)
    bend = np.linalg.norm(np.einsum("ej,sjk->sek", second, cps), axis=2).max(axis=1)
    # The radius is a cubic in t too (or of lower degree): its r'' at t = 0 and 1 from its samples' second
    # differences, exact for a cubic. Straight spans of bezier widths (0, 1, 1, 0) were one segment of radius 0.
    steps = np.diff(radii, 2, axis=1) * (len(RADIUS_SAMPLES) - 1) ** 2  # r'' at t = 1/3 and 2/3
    bend = np.maximum(bend, np.abs(2.0 * steps - steps[:, ::-1]).max(axis=1))
    tolerance = CURVE_TOLERANCE * np.maximum(radii, 0.0).max(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.ceil(np.sqrt(bend / (8.0 * tolerance)))
    k = np.where(bend > 0.0, k, 1.0)  # straight: one segment
    k = np.where(tolerance > 0.0, k, 1.0)  # no radius: the span is not drawn
    return np.clip(k, 1, MAX_SPAN_SEGMENTS).astype(np.int64)


def sample_spans(spans, segments: np.ndarray):
    """Parameters of the polyline vertices: ``(span (M,) int64, t (M,) float64, starts_segment (M,) bool,
    sphere (M,) bool)``, ``segments[s] + 1`` rows per span ``s``; a row that is not its span's last starts a straight
    segment to the next row; ``sphere`` marks the rows drawn as joint spheres (all but each span's last, which is
    the next span's first, except at the end of a nonperiodic curve)."""
    rows = segments + 1
    span = np.repeat(np.arange(len(segments)), rows)
    j = np.arange(len(span)) - (np.cumsum(rows) - rows)[span]
    t = j / segments[span]
    is_last = j == segments[span]
    return span, t, ~is_last, ~is_last | spans.last[span]


def sphere_transforms(centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """``(N, 4, 4)`` column-vector transforms placing the unit sphere at ``centres`` ``(N, 3)`` with ``radii``."""
    m = np.zeros((len(centres), 4, 4))
    m[:, 0, 0] = m[:, 1, 1] = m[:, 2, 2] = radii
    m[:, :3, 3] = centres
    m[:, 3, 3] = 1.0
    return m


def perpendicular_frames(axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors ``(e1, e2)`` with ``(e1, e2, axis)`` a right-handed orthonormal frame for each unit axis
    ``(N, 3)`` (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017)."""
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    sign = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    e1 = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=1)
    e2 = np.stack([b, sign + y * y * a, -y], axis=1)
    return e1, e2


def segment_transforms(starts: np.ndarray, ends: np.ndarray, r0: np.ndarray, r1: np.ndarray):
    """Tube segments from ``starts`` to ``ends`` ``(E, 3)`` with radii ``r0``, ``r1`` ``(E,)`` (not both 0, length
    above 0) as ``(levels (E,) int64, transforms (E, 4, 4))``: level :data:`RHO_LEVELS` is the open unit cylinder, a
    lower level ``q`` the open canonical cone of ``rho = q / RHO_LEVELS`` (radius 1 at canonical ``z = -1``, ``rho``
    rounded down), its wide end on the larger radius."""
    big_at_start = r0 >= r1
    wide, narrow = np.where(big_at_start[:, None], starts, ends), np.where(big_at_start[:, None], ends, starts)
    big, small = np.maximum(r0, r1), np.minimum(r0, r1)
    # Rounded down: the frustum's narrow end never sticks out of the sphere of the exact radius there.
    levels = np.floor(small / big * RHO_LEVELS).astype(np.int64)
    return levels, _segment_matrices(0.5 * (wide + narrow), 0.5 * (narrow - wide), big)


def _segment_matrices(centres: np.ndarray, half: np.ndarray, big: np.ndarray) -> np.ndarray:
    """``(E, 4, 4)`` transforms of the canonical cylinder or cone onto segments of ``centres`` and half-axes ``half``
    ``(E, 3)`` (from the wide end to the narrow one) with wide radii ``big`` ``(E,)``; all zeros (a singular transform)
    for a segment of no length."""
    length = np.linalg.norm(half, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        e1, e2 = perpendicular_frames(half / length[:, None])
    m = np.zeros((len(centres), 4, 4))
    m[:, :3, 0] = e1 * big[:, None]
    m[:, :3, 1] = e2 * big[:, None]
    m[:, :3, 2] = half
    m[:, :3, 3] = centres
    m[:, 3, 3] = 1.0
    m[length == 0.0] = 0.0
    return m


def width_axis(linear: np.ndarray) -> np.ndarray:
    """The unit direction whose length under a transform scales widths: ``linear (1, 1, 1) / sqrt(3)`` (normalised;
    zeros where it vanishes), for a ``(3, 3)`` ``linear`` part, the prim's transform into its content's space. A
    transform ``A`` placed above then scales widths by ``|A axis|``, as ``|A linear (1, 1, 1)| / sqrt(3)`` would."""
    v = np.asarray(linear, np.float64) @ np.full(3, 3.0**-0.5)
    length = np.linalg.norm(v)
    return v / length if length > 0.0 else np.zeros(3)


def place_round(outer: np.ndarray, shapes: np.ndarray, sphere: bool, axis: np.ndarray) -> np.ndarray:
    """``(N * K, 4, 4)`` the spheres (``sphere``) or tube segments ``shapes`` ``(K, 4, 4)`` (:func:`sphere_transforms`,
    :func:`segment_transforms`) of one Points or curves prim, in its content's space, placed by each of ``outer``
    ``(N, 4, 4)`` (content -> world), as the prim's own transform places them: centres and segment axes move with
    ``outer``, radii scale by ``|outer axis|`` (``axis``: the prim's :func:`width_axis`), so spheres and tubes stay
    round under a non-uniform, sheared or mirrored ``outer``, just as in a flattened copy of the instance. Rows whose
    ``outer`` is a rotation and uniform scale (mirrored or not) keep the product ``outer @ shape``, as before: the
    same round shapes, their frames about the centre or axis turned with ``outer`` (no hit reports that frame)."""
    linear = outer[:, :3, :3]
    gram = np.swapaxes(linear, 1, 2) @ linear
    s2 = np.trace(gram, axis1=1, axis2=2) / 3.0
    similar = np.abs(gram - s2[:, None, None] * np.eye(3)).max(axis=(1, 2)) <= 1e-12 * s2
    if similar.all():
        return (outer[:, None] @ shapes[None]).reshape(-1, 4, 4)
    placed = np.empty((len(outer), len(shapes), 4, 4))
    placed[similar] = outer[similar, None] @ shapes[None]
    rows = np.flatnonzero(~similar)
    linear_t = np.swapaxes(linear[rows], 1, 2)
    scale = np.linalg.norm(linear[rows] @ axis, axis=1)  # (M,)
    centres = (shapes[None, :, :3, 3] @ linear_t + outer[rows, None, :3, 3]).reshape(-1, 3)
    if sphere:
        round_ = sphere_transforms(centres, (scale[:, None] * shapes[None, :, 0, 0]).reshape(-1))
    else:
        half = (shapes[None, :, :3, 2] @ linear_t).reshape(-1, 3)
        big = (scale[:, None] * np.linalg.norm(shapes[None, :, :3, 0], axis=2)).reshape(-1)
        round_ = _segment_matrices(centres, half, big)
    placed[rows] = round_.reshape(len(rows), len(shapes), 4, 4)
    # A singular outer (a zero scale) is an instance the loader skips with a warning: its spheres and tubes go with
    # it (placed round they kept their size, and the instance the warning called skipped was drawn).
    singular = rows[~invert_transforms(outer[rows])[1]]
    placed[singular, :, :3, :3] = 0.0
    return placed.reshape(-1, 4, 4)


__all__ = ["CUBIC_BASES", "Spans", "curve_spans", "hermite_spans", "place_round", "sample_spans",
           "segment_transforms", "span_segments", "span_weights", "sphere_transforms", "width_axis"]
