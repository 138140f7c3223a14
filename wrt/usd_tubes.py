"""``UsdGeom.Points`` and curves prims (``BasisCurves``, ``HermiteCurves``, ``NurbsCurves``) read as groups of
instances of one analytic shape each: the spheres of a point cloud, the spheres and tube segments of curves
(:mod:`wrt.tubes`), vectorised with numpy. Hermite curves are Bezier spans (:func:`wrt.tubes.hermite_spans`), their
per-point widths and colours linear along each segment (the schema defines no cubic primvars); NURBS curves are cut
span by span (:class:`wrt.nurbs.NurbsSpans`), ``vertex`` primvars following their rational basis, ``varying`` ones
(``count - order + 2`` per curve) linear across each knot interval.

Widths come from ``primvars:widths`` when it has a value (its own, else a constant one inherited from an ancestor,
or in a native prototype one its instance hands down), else from ``widths`` with its interpolation metadata, else 1
(UsdImaging's fallback for points; Storm draws curves without widths as one-pixel lines, which a ray tracer cannot
show, so they are tubes of width 1 too, with a warning).
They are scaled into the content's space by the length of the prim's transform applied to ``(1, 1, 1) / sqrt(3)``, as
Storm and RenderMan scale point widths, so points stay round spheres and tubes round under a non-uniform scale (an
instance's transform above scales them the same way: :func:`wrt.tubes.place_round`). Cubic spans are cut in the
prim's own space, so the cut is the same however the prim is placed or instanced. A width of 0 draws nothing;
negative, NaN or infinite widths and points that are not finite are left out with a warning. Colours
(``displayColor``, or the primvar the material reads) and ``displayOpacity`` of every interpolation become one colour
and opacity per instance: a segment takes the mean of its ends' values.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pxr import Usd, UsdGeom

from .nurbs import nurbs_curve_spans
from .tubes import (
    RHO_LEVELS,
    curve_spans,
    hermite_spans,
    sample_spans,
    segment_transforms,
    sphere_transforms,
)
from .usd_primvars import FieldReader, unit_opacities
from .usd_values import value_at

_CURVE_TOKENS = {  # attribute -> (allowed tokens, fallback used for any other, as UsdImaging does)
    "type": (("linear", "cubic"), "cubic"),
    "basis": (("bezier", "bspline", "catmullRom"), "bezier"),
    "wrap": (("nonperiodic", "periodic", "pinned"), "nonperiodic"),
}


@dataclasses.dataclass
class TubeGroup:
    """Instances of one shape that draw part of a Points or BasisCurves prim.

    Attributes:
        kind: ``"sphere"``, ``"cylinder"`` (open) or ``"cone"`` (open, ``rho = params[1]``).
        params: ``(4,)`` the shape's :attr:`wrt.primitives.Shape.params`.
        to_space: ``(K, 4, 4)`` column-vector transforms of the canonical shape into the prim's content space.
        index: ``(K,)`` int32 point (Points) or curve (BasisCurves) each instance draws.
        colors: ``(K, 3)`` float32 linear colour per instance, or None.
        opacities: ``(K,)`` float32 ``displayOpacity`` per instance, or None.
    """

    kind: str
    params: np.ndarray
    to_space: np.ndarray
    index: np.ndarray
    colors: np.ndarray | None
    opacities: np.ndarray | None = None


class TubeReader(FieldReader):
    """Reads Points and curves (BasisCurves, HermiteCurves, NurbsCurves) prims at one time code (see
    :class:`wrt.usd_primvars.FieldReader` for the arguments)."""

    def read(self, prim: Usd.Prim, points: np.ndarray, to_space: np.ndarray, color_primvar, counts=None,
             opacity_primvar=None, outer_widths=None):
        """The instance groups of ``prim`` and its constant colour.

        Args:
            points: ``(n, 3)`` float64 ``points`` in the prim's space (moved by velocities where they apply).
            to_space: ``(4, 4)`` column-vector transform from the prim to its content's space.
            color_primvar: the ``UsdGeom.Primvar`` of its colour (its own or a constant inherited one), or None.
            counts: ``curveVertexCounts`` ``(C,)`` int64 for curves, None for Points.
            opacity_primvar: its ``displayOpacity`` primvar when that gives values per point or curve (read per
                instance as colours are, NaN read as 1 and values clamped to [0, 1] with a warning), else None.
            outer_widths: the constant ``primvars:widths`` a native instance hands down to its prototype (float), or
                None: the widths where ``prim`` has no widths primvar (own or inherited inside the prototype).

        Returns:
            ``(groups, color)``: :class:`TubeGroup` list, and the ``(3,)`` float32 colour for all of them when the
            colour is one value (constant), else None (the groups carry per-instance colours, or there is none).

        Raises:
            SceneError: topology or values that make no curves (counts that are negative or do not add up to the
                points, too few vertices for a curve, NURBS orders or knots that make no B-spline, ...), naming
                ``prim``; the caller skips the prim with a warning naming it.
        """
        with np.errstate(invalid="ignore", over="ignore"):  # points that are not finite are named below
            centres = points @ to_space[:3, :3].T + to_space[:3, 3]
        scale = float(np.linalg.norm(to_space[:3, :3] @ np.full(3, 3.0**-0.5)))
        fields = (color_primvar, opacity_primvar)
        if counts is None:
            return self._points(prim, points, centres, scale, fields, outer_widths)
        return self._curves(prim, points, centres, scale, fields, counts, to_space, outer_widths)

    def _fields(self, prim, fields, sizes):
        """The ``(colors, opacities)`` fields (:meth:`FieldReader.field`) of the ``(colour, opacity)`` primvars
        ``fields`` (None where one is None), opacities clamped to [0, 1]."""
        color_primvar, opacity_primvar = fields
        colors = self.field(prim, color_primvar, sizes, 3) if color_primvar is not None else None
        opacities = self.field(prim, opacity_primvar, sizes, 1) if opacity_primvar is not None else None
        if opacities is not None:
            opacities = (opacities[0], unit_opacities(opacities[1][:, 0], prim, self.skip)[:, None])
        return colors, opacities

    # Points

    def _points(self, prim, points, centres, scale, fields, outer_widths):
        n = len(points)
        sizes = {"constant": 1, "uniform": 1, "vertex": n, "varying": n, "faceVarying": n}
        widths = self._widths(prim, UsdGeom.Points(prim), sizes, outer_widths)
        radii = self._radii(prim, widths, n) * scale
        colors, opacities = self._fields(prim, fields, sizes)
        # Points are independent: one that is not finite (a diverged particle) is left out, the others drawn.
        finite = _finite_boxes(centres, radii)
        if not finite.all():
            i = int(np.argmax(~finite))
            self.skip("points that are not finite (or past float32 with their width) were left out", prim,
                      f"{int((~finite).sum())} of {n}, first points[{i}]")
        keep = np.flatnonzero(finite & (radii > 0.0))
        # A Points prim is one element: uniform values are constant.
        colors, opacities = (f if f is None or f[0] != "uniform" else ("constant", f[1]) for f in (colors, opacities))
        per_point = [f is not None and f[0] != "constant" for f in (colors, opacities)]
        group = TubeGroup("sphere", _params(), sphere_transforms(centres[keep], radii[keep]), keep.astype(np.int32),
                          colors[1][keep].astype(np.float32) if per_point[0] else None,
                          opacities[1][keep, 0].astype(np.float32) if per_point[1] else None)
        return [group] if len(keep) else [], _constant(colors)

    # Curves

    def _curves(self, prim, points, centres, scale, fields, counts, to_space, outer_widths):
        curves = UsdGeom.Curves(prim)
        kind = prim.GetTypeName()
        counts_attr = curves.GetCurveVertexCountsAttr()
        if np.any(counts < 0):
            i = int(np.argmax(counts < 0))
            raise self.error(f"curveVertexCounts[{i}] = {counts[i]} is negative", prim, counts_attr)
        if int(counts.sum()) != len(points):
            raise self.error(f"curveVertexCounts sum to {int(counts.sum())} but there are {len(points)} points", prim,
                             counts_attr)
        # Spans are cut in the prim's own space (below): the cut follows the curve, not its transform, so a
        # flattened copy of an instance cuts it as the instance's prototype does (and an animated transform does not
        # change the cut).
        spans, controls, finite = self._spans(prim, points, counts)
        finite &= np.isfinite(centres).all(axis=1)
        if curves.GetNormalsAttr().HasValue() or UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals").HasValue():
            self.skip(f"{kind} with normals (ribbons) are drawn as round tubes", prim)
        sizes = {"constant": 1, "uniform": len(counts), "vertex": len(points), "varying": spans.n_varying,
                 "faceVarying": spans.n_varying}
        widths = self._widths(prim, curves, sizes, outer_widths)
        if widths is None:
            self.skip(f"{kind} without widths are drawn as tubes of width 1 (Storm draws one-pixel lines)", prim)
        colors, opacities = self._fields(prim, fields, sizes)
        if prim.IsA(UsdGeom.HermiteCurves):
            # The schema has no cubic interpolation of primvars: per-point values are linear along each segment.
            widths, colors, opacities = (("varying", f[1]) if f is not None and f[0] == "vertex" else f
                                         for f in (widths, colors, opacities))

        # A curve with a vertex that is not finite is left out; the others are drawn.
        curve_of_vertex = np.repeat(np.arange(len(counts)), counts)
        bad = np.unique(curve_of_vertex[~finite])
        if len(bad):
            self.skip("curves with points that are not finite were left out", prim,
                      f"{len(bad)} of {len(counts)}, first curve {int(bad[0])}")
            spans = spans.take(~np.isin(spans.curve, bad))
        # So is a curve with a width that is negative, NaN or infinite: drawn with that width as 0, it was a tube
        # pinched to nothing at the bad vertex, and the warning said the width was not drawn.
        bad_width = _bad_widths(widths)
        if bad_width.any():
            bad = _curves_of_values(spans, widths[0], bad_width, curve_of_vertex, len(counts))
            i = int(np.argmax(bad_width))
            self.skip("curves with widths that are negative, NaN or infinite were left out", prim,
                      f"{len(bad)} of {len(counts)}, first curve {int(bad[0])}, widths[{i}] = {widths[1][i, 0]:g}")
            spans = spans.take(~np.isin(spans.curve, bad))
        controls = spans.extend(controls)
        radius = _interpolator(spans, widths, self._radii(prim, widths, None, warn=False))

        # Cut each span into straight segments in the prim's space, move the polyline vertices into the content's
        # space (the bases are affine: the moved curve at t is the curve of the moved points), then place a sphere
        # at each vertex and a tube along each segment.
        sampled = np.repeat(np.arange(len(spans.curve)), len(spans.radius_t))
        sample_t = np.tile(spans.radius_t, len(spans.curve))
        segments = spans.segments(controls, radius(sampled, sample_t).reshape(len(spans.curve), len(spans.radius_t)))
        span, t, starts_segment, sphere = sample_spans(spans, segments)
        with np.errstate(invalid="ignore", over="ignore"):  # past float range: named below
            at = spans.at(controls, span, t) @ to_space[:3, :3].T + to_space[:3, 3]
        radii = np.maximum(radius(span, t), 0.0) * scale  # catmullRom overshoot can make a width negative
        finite = _finite_boxes(at, radii)
        if not finite.all():
            # A curve its transform and widths take past float32's range is left out, as one with a point that is
            # not finite is, the others drawn (it stopped the whole load). All rows of its spans go, so each kept
            # row that starts a segment still has its end next.
            bad = np.unique(spans.curve[span[~finite]])
            self.skip("curves past float32's range with their widths (after the world transform) were left out",
                      prim, f"{len(bad)} of {len(counts)}, first curve {int(bad[0])}")
            keep = ~np.isin(spans.curve[span], bad)
            span, t, starts_segment, sphere, at, radii = (v[keep] for v in (span, t, starts_segment, sphere, at, radii))
        # Per instance: the value at each sphere, and the mean of its ends' values along each tube piece.
        per_row = []
        for field, low, high in ((colors, 0.0, np.inf), (opacities, 0.0, 1.0)):
            at_t = None if field is None or field[0] == "constant" else _interpolator(spans, field, field[1])
            per_row.append(None if at_t is None else np.clip(at_t(span, t), low, high).astype(np.float32))  # overshoot
        rows_colors, rows_opacities = per_row[0], None if per_row[1] is None else per_row[1][:, 0]

        def pieces(values, a, b):
            return None if values is None else 0.5 * (values[a] + values[b])

        groups = []
        rows = np.flatnonzero(sphere & (radii > 0.0))
        if len(rows):
            groups.append(TubeGroup("sphere", _params(), sphere_transforms(at[rows], radii[rows]),
                                    spans.curve[span[rows]].astype(np.int32),
                                    None if rows_colors is None else rows_colors[rows],
                                    None if rows_opacities is None else rows_opacities[rows]))
        a = np.flatnonzero(starts_segment)
        b = a + 1
        drawn = (np.maximum(radii[a], radii[b]) > 0.0) & np.any(at[a] != at[b], axis=1)
        a, b = a[drawn], b[drawn]
        levels, transforms = segment_transforms(at[a], at[b], radii[a], radii[b])
        order = np.argsort(levels, kind="stable")
        bounds = np.searchsorted(levels[order], np.arange(RHO_LEVELS + 2))
        for level in range(RHO_LEVELS + 1):
            chosen = order[bounds[level] : bounds[level + 1]]
            if not len(chosen):
                continue
            cylinder = level == RHO_LEVELS
            groups.append(TubeGroup(
                "cylinder" if cylinder else "cone", _params(0.0 if cylinder else level / RHO_LEVELS),
                transforms[chosen], spans.curve[span[a[chosen]]].astype(np.int32),
                pieces(rows_colors, a[chosen], b[chosen]), pieces(rows_opacities, a[chosen], b[chosen])))
        return groups, _constant(colors)

    def _spans(self, prim, points, counts):
        """``(spans, control rows (n', 3), finite (n,) bool per point)`` of a curves prim of ``points`` ``(n, 3)``
        (the prim's own space): BasisCurves by their type, basis and wrap; HermiteCurves as Bezier spans of
        ``[P; P + T / 3; P - T / 3]``; NurbsCurves by their orders, knots, ranges and pointWeights."""
        finite = np.isfinite(points).all(axis=1)
        counts_attr = UsdGeom.Curves(prim).GetCurveVertexCountsAttr()
        if prim.IsA(UsdGeom.HermiteCurves):
            attr = UsdGeom.HermiteCurves(prim).GetTangentsAttr()
            tangents = self._array(prim, attr, (len(points), 3))
            if tangents is None:
                raise self.error(f"tangents has no value; {len(points)} points need one each", prim, attr)
            third = tangents / 3.0
            try:
                spans = hermite_spans(counts)
            except ValueError as e:
                raise self.error(str(e), prim, counts_attr) from None
            with np.errstate(invalid="ignore", over="ignore"):
                controls = np.concatenate([points, points + third, points - third])
            return spans, controls, finite & np.isfinite(third).all(axis=1)
        if prim.IsA(UsdGeom.NurbsCurves):
            schema = UsdGeom.NurbsCurves(prim)
            orders = self._array(prim, schema.GetOrderAttr(), (None,), np.int64)
            knots = self._array(prim, schema.GetKnotsAttr(), (None,))
            ranges = self._array(prim, schema.GetRangesAttr(), (None, 2))
            weights = self._array(prim, schema.GetPointWeightsAttr(), (len(points),))
            orders = np.zeros(0, np.int64) if orders is None else orders
            knots = np.zeros(0) if knots is None else knots
            weights = np.ones(len(points)) if weights is None else weights
            self.check_weights(prim, schema.GetPointWeightsAttr(), weights)
            try:
                return nurbs_curve_spans(counts, orders, knots, ranges, weights), points, finite
            except ValueError as e:
                raise self.error(str(e), prim) from None
        curves = UsdGeom.BasisCurves(prim)
        tokens = {name: self._token(prim, attr, name) for name, attr in
                  (("type", curves.GetTypeAttr()), ("basis", curves.GetBasisAttr()), ("wrap", curves.GetWrapAttr()))}
        try:
            return curve_spans(counts, tokens["type"], tokens["basis"], tokens["wrap"]), points, finite
        except ValueError as e:
            raise self.error(str(e), prim, counts_attr) from None

    # Attributes

    def _array(self, prim, attr, shape, dtype=np.float64):
        """The array value of ``attr`` as ``dtype`` checked against ``shape`` (None: any length), or None when it has
        no value (or an empty one).

        Raises:
            SceneError: a value of another type or shape (naming the attribute and what it needs).
        """
        raw = value_at(attr, self.time)
        if raw is None or (hasattr(raw, "__len__") and len(raw) == 0):  # (an asset path has no length)
            return None
        values = np.asarray(raw)
        fits = values.ndim == len(shape) and all(want in (None, got) for want, got in zip(shape, values.shape))
        if values.dtype.kind not in ("iu" if dtype == np.int64 else "fiu") or not fits:
            length = f"{shape[0]} " if shape[0] is not None else ""
            what = "integers" if dtype == np.int64 else "numbers" if len(shape) == 1 else f"{shape[1]}-vectors"
            # The authored type: the schema's named a string[] knots "double[]"; a value that is no array (a
            # string) stopped the load with "len() of unsized object".
            got = f"{len(values)} of {self.authored(attr)}" if values.ndim else f"one {self.authored(attr)} value"
            raise self.error(f"{attr.GetName()} must be {length}{what}, not {got}", prim, attr)
        return values.astype(dtype)

    def _token(self, prim, attr, name):
        """A BasisCurves token attribute; one outside its allowed tokens is read as UsdImaging reads it, with a
        warning."""
        allowed, fallback = _CURVE_TOKENS[name]
        value = str(value_at(attr, self.time) or fallback)
        if value not in allowed:
            self.skip(f"BasisCurves {name} tokens other than {', '.join(allowed)} are read as {fallback}", prim,
                      repr(value))
            value = fallback
        return value

    @staticmethod
    def has_widths_primvar(prim) -> bool:
        """Whether ``prim`` has a ``primvars:widths`` of its own or a constant one on an ancestor (inside a native
        prototype: up to its root)."""
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("widths")
        return bool(primvar and primvar.HasValue())

    def _widths(self, prim, schema, sizes, outer_widths=None):
        """``(interpolation, (k, 1) float64)`` widths of ``prim``, or None: its ``primvars:widths``, else a constant
        one of its nearest ancestor that has one (USD's primvar inheritance; inside a native prototype, past its
        root, ``outer_widths``: the one its instance hands down), else its ``widths`` attribute, the order
        UsdImaging's points and curves adapters read them in (an inherited primvar wins over the attribute)."""
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("widths")
        if primvar and primvar.HasValue():
            return self.field(prim, primvar, sizes, 1)
        if outer_widths is not None:
            return "constant", np.array([[outer_widths]], np.float64)
        attr = schema.GetWidthsAttr()
        if not attr.HasValue():
            return None
        return self.values(prim, attr, value_at(attr, self.time), schema.GetWidthsInterpolation(), sizes, 1)

    def _radii(self, prim, widths, n, warn=True):
        """Radii ``(n,)`` from ``widths`` for points (``n``), or the ``(k,)`` radii of its values (``n`` None); 0.5
        without widths. A negative, NaN or infinite width is 0 (not drawn), with a warning (``warn``)."""
        if widths is None:
            return np.full(n if n is not None else 1, 0.5)  # width 1
        values = widths[1][:, 0] * 0.5
        bad = _bad_widths(widths)
        if bad.any() and warn:
            i = int(np.argmax(bad))
            self.skip("widths that are negative, NaN or infinite were not drawn", prim,
                      f"{int(bad.sum())} of {len(values)}, first widths[{i}] = {2 * values[i]:g}")
            values = np.where(bad, 0.0, values)
        if n is None:
            return values
        return np.broadcast_to(values, (n,)) if widths[0] in ("constant", "uniform") else values


def _interpolator(spans, field, values):
    """``f(span, t) -> (M, k)`` (``(M,)`` for one component) values of a primvar ``field`` (its interpolation and
    ``values``, or None: ``values`` is the one constant) at parameters ``t`` of ``span``."""
    interpolation = field[0] if field is not None else "constant"
    values = np.asarray(values, np.float64)
    flat = values.ndim == 1
    values = values.reshape(len(values), -1)

    def at(span, t):
        if interpolation == "constant":
            out = np.broadcast_to(values[0], (len(span), values.shape[1]))
        elif interpolation == "uniform":
            out = values[spans.curve[span]]
        elif interpolation == "vertex":
            out = spans.at(spans.extend(values), span, t)
        else:  # varying: linear along each span (each knot interval of a NURBS curve)
            ends = values[spans.varying[span]]
            out = ends[:, 0] + spans.varying_t(span, t)[:, None] * (ends[:, 1] - ends[:, 0])
        return out[:, 0] if flat else out

    return at


def _bad_widths(widths) -> np.ndarray:
    """``(k,)`` bool: the values of a widths field (or None) that are negative, NaN or infinite."""
    if widths is None:
        return np.zeros(0, bool)
    values = widths[1][:, 0]
    return ~(np.isfinite(values) & (values >= 0.0))


def _curves_of_values(spans, interpolation: str, values: np.ndarray, curve_of_vertex: np.ndarray, n_curves: int):
    """Sorted curves that any of the primvar values marked in ``values`` ``(k,)`` bool applies to."""
    marked = np.flatnonzero(values)
    if interpolation == "constant":
        return np.arange(n_curves)
    if interpolation == "uniform":
        return marked
    if interpolation == "vertex":
        return np.unique(curve_of_vertex[marked])
    return np.unique(spans.curve[np.isin(spans.varying, marked).any(axis=1)])  # varying: the spans they end


def _finite_boxes(centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: the sphere's box is finite in float32, as the device holds it."""
    with np.errstate(over="ignore", invalid="ignore"):
        reach = np.abs(centres).max(axis=1) + radii
        return np.isfinite(reach.astype(np.float32)) & np.isfinite(centres).all(axis=1)


def _params(rho: float = 0.0) -> np.ndarray:
    """``Shape.params`` of an open shape (no caps) of narrowing ``rho``, facing outwards."""
    return np.array([0.0, rho, 0.0, 1.0], np.float32)


def _constant(colors):
    """The one colour of a constant colour field, else None."""
    if colors is None or colors[0] != "constant":
        return None
    return colors[1][0].astype(np.float32)


__all__ = ["TubeGroup", "TubeReader"]
