"""``UsdGeom.TetMesh`` and ``UsdGeom.NurbsPatch`` prims read as triangle surfaces in the prim's own space, which
:mod:`wrt.usd` then places, colours and binds as it does meshes.

A TetMesh is drawn as its boundary: the faces of its tetrahedra that no other tetrahedron shares
(:func:`wrt.tetmesh.surface_faces`, computed from ``tetVertexIndices`` at the time read, as UsdImaging computes them;
``surfaceFaceVertexIndices`` is not read), wound as the schema orders them, flat-shaded. Colours: ``constant``,
``uniform`` (one per tetrahedron: its surface faces take it), ``vertex`` or ``varying`` (one per point).

A NurbsPatch is tessellated span by span (:mod:`wrt.nurbs`: rational tensor-product B-spline, points laid out u
fastest, ``uRange``/``vRange`` narrowing it) into a grid whose triangles stay within :data:`wrt.nurbs.PATCH_TOLERANCE`
of the diagonal of its control points' box from the surface, smooth-shaded, wound counter-clockwise in (u, v) as
Storm winds the patch's hull (so ``rightHanded`` faces point along ``dS/du x dS/dv``). ``uForm``/``vForm`` do not
change the surface (the schema: the points, orders, knots, weights and ranges are all that is needed to render it);
trim curves are not applied (a warning names the prim). Colours: ``constant``, ``uniform`` (one per knot-interval
patch, ``(nu - uOrder + 1) (nv - vOrder + 1)``, u fastest, as RenderMan's RiNuPatch counts them), ``varying`` (one
per knot-interval corner, ``(nu - uOrder + 2) (nv - vOrder + 2)``, bilinear) and ``vertex`` (one per control point,
through the patch's rational basis); ``faceVarying`` is read as ``varying``.

Texture coordinates (the primvar a material's UsdPrimvarReader_float2 names, ``st`` mostly) are read as colours are,
on both: per point (vertex, varying) through a TetMesh's surface faces, per tetrahedron (uniform), or over the
patch's control points, knot-interval corners or patches; a faceVarying one on a TetMesh, whose face-vertices the
schema does not define, is dropped with a warning (the texture is then read at the reader's fallback st).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pxr import Usd, UsdGeom

from .nurbs import PATCH_TOLERANCE, Direction, check_knots, check_range, grid_triangles, patch_steps, patch_values
from .tetmesh import inverted, surface_faces
from .usd_primvars import FieldReader
from .usd_values import value_at


@dataclasses.dataclass
class Surface:
    """Triangles drawing a TetMesh or NurbsPatch prim, in its own space.

    Attributes:
        points: ``(V, 3)`` float64 vertices.
        triangles: ``(T, 3)`` int64 rows into ``points``, wound so that the front is counter-clockwise when the
            prim is ``rightHanded``.
        face_ids: ``(T,)`` int64 tetrahedron (TetMesh) or knot-interval patch (NurbsPatch) of each triangle.
        colors: ``(values (K, 3) float32, corner index (T, 3))`` or None.
        smooth: shade with smooth vertex normals of the triangles (a NURBS surface) rather than flat.
        uvs: ``(values (K, 2) float64, corner index (T, 3))`` of the texture-coordinate primvar asked for, or None
            (none asked for, or dropped with a warning).
    """

    points: np.ndarray
    triangles: np.ndarray
    face_ids: np.ndarray
    colors: tuple | None
    smooth: bool
    uvs: tuple | None = None


class SurfaceReader(FieldReader):
    """Reads TetMesh and NurbsPatch prims at one time code (see :class:`wrt.usd_primvars.FieldReader`)."""

    def tet_mesh(self, prim: Usd.Prim, points: np.ndarray, color_primvar, left_handed: bool,
                 st_primvar=None) -> Surface | None:
        """The boundary of TetMesh ``prim`` of ``points`` ``(n, 3)``, or None when it has no tetrahedra; colours from
        ``color_primvar`` and texture coordinates from ``st_primvar`` (2-, 3- or 4-vectors: their first two
        components), each None or read as the module docstring says.

        Raises:
            SceneError: ``tetVertexIndices`` is not ``int4[]`` or indexes past the points, or a point is not finite
                (a colour of the wrong length for its interpolation is dropped with a warning); the caller skips the
                prim with a warning naming it (:meth:`wrt.usd_problems.ProblemReport._skipped_unreadable`).
        """
        attr = UsdGeom.TetMesh(prim).GetTetVertexIndicesAttr()
        raw = value_at(attr, self.time)
        if raw is None or (hasattr(raw, "__len__") and len(raw) == 0):  # (an asset path has no length)
            return None
        tets = np.asarray(raw)
        if tets.ndim != 2 or tets.shape[1] != 4 or tets.dtype.kind not in "iu":
            raise self.error(f"tetVertexIndices must be int4[], not {self.authored(attr)}", prim, attr)
        tets = tets.astype(np.int64)
        self._check_finite(prim, points)
        bad = ((tets < 0) | (tets >= len(points))).any(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise self.error(f"tetVertexIndices[{i}] = {tuple(tets[i].tolist())} is out of range for {len(points)} "
                             "points", prim, attr)
        flipped = inverted(points, tets, left_handed)
        if flipped.any():
            self.skip("TetMesh tetrahedra inverted for their orientation have faces that point inwards", prim,
                      f"{int(flipped.sum())} of {len(tets)}, first tetVertexIndices[{int(np.argmax(flipped))}]")
        faces, tet = surface_faces(tets, len(points))
        colors = self._tet_field(prim, color_primvar, 3, len(tets), len(points), faces, tet)
        colors = None if colors is None else (colors[0].astype(np.float32), colors[1])
        uvs = self._tet_field(prim, st_primvar, 2, len(tets), len(points), faces, tet)
        return Surface(points, faces, tet, colors, smooth=False, uvs=uvs)

    def _tet_field(self, prim, primvar, components, n_tets, n_points, faces, tet):
        """``(values (K, components) float64, corner index (T, 3))`` of a TetMesh's ``primvar`` on its surface
        ``faces`` (of tetrahedra ``tet``), or None: one per tetrahedron (uniform) or per point (vertex, varying: the
        faces' corners are points); faceVarying, of face-vertices the schema does not define, is dropped."""
        if primvar is None:
            return None
        sizes = {"constant": 1, "uniform": n_tets, "vertex": n_points, "varying": n_points}
        field = self.field(prim, primvar, sizes, components)
        if field is None:
            return None
        corner = {"constant": np.zeros_like(faces), "uniform": np.repeat(tet[:, None], 3, axis=1)}
        return field[1], corner.get(field[0], faces)

    def nurbs_patch(self, prim: Usd.Prim, points: np.ndarray, color_primvar, st_primvar=None) -> Surface:
        """NurbsPatch ``prim`` of control ``points`` ``(nu * nv, 3)`` tessellated (see the module docstring), with
        colours from ``color_primvar`` and texture coordinates from ``st_primvar`` (each None or read alike).

        Raises:
            SceneError: vertex counts that do not match the points, orders, knots or ranges that make no B-spline,
                weights that are not positive numbers, or a point that is not finite (a colour of the wrong length for
                its interpolation is dropped with a warning); the caller skips the prim with a warning naming it.
        """
        patch = UsdGeom.NurbsPatch(prim)
        nu, nv = (self._int(prim, a) for a in (patch.GetUVertexCountAttr(), patch.GetVVertexCountAttr()))
        if nu * nv != len(points):
            raise self.error(f"uVertexCount x vVertexCount = {nu} x {nv} but there are {len(points)} points", prim)
        directions = []
        for name, order_attr, knots_attr, range_attr, count in (
            ("u", patch.GetUOrderAttr(), patch.GetUKnotsAttr(), patch.GetURangeAttr(), nu),
            ("v", patch.GetVOrderAttr(), patch.GetVKnotsAttr(), patch.GetVRangeAttr(), nv),
        ):
            order = self._int(prim, order_attr)
            knots = self._numbers(prim, knots_attr)
            knots = knots if knots is not None else np.zeros(0)
            why = check_knots(knots, order, count)
            span = self._numbers(prim, range_attr) if why is None else None
            if span is not None and len(span) != 2:
                raise self.error(f"{range_attr.GetName()} must be 2 numbers, not {len(span)}", prim, range_attr)
            lo, hi = (float(span[0]), float(span[1])) if span is not None else (None, None)
            if why is None and span is not None:
                why = check_range(knots, order, count, lo, hi)
            if why is not None:
                raise self.error(f"{name}: {why}", prim, knots_attr)
            if span is None:
                lo, hi = float(knots[order - 1]), float(knots[count])
            directions.append((knots, order, count, lo, hi))
        weights_attr = patch.GetPointWeightsAttr()
        raw = self._numbers(prim, weights_attr)
        weights = np.ones(len(points)) if raw is None or len(raw) == 0 else raw
        if len(weights) != len(points):
            raise self.error(f"pointWeights has {len(weights)} values for {len(points)} points", prim, weights_attr)
        self.check_weights(prim, weights_attr, weights)
        self._check_finite(prim, points)
        counts = value_at(patch.GetTrimCurveCountsAttr(), self.time)
        if counts is not None and (not hasattr(counts, "__len__") or len(counts)):
            self.skip("NurbsPatch trim curves (trimCurve:*) are not applied; the untrimmed surface is drawn", prim)

        # Steps per span from the pilot grid, then the grid itself.
        size = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
        pilot = [Direction(*d) for d in directions]
        steps = patch_steps(*pilot, points, weights, nu, PATCH_TOLERANCE * size)
        u, v = (Direction(*d, steps=s) for d, s in zip(directions, steps))
        grid = patch_values(u, v, points, weights, nu).reshape(-1, 3)
        triangles = grid_triangles(len(u.u), len(v.u))
        cell = np.arange(len(triangles)) // 2
        cu, cv = cell % (len(u.u) - 1), cell // (len(u.u) - 1)
        face_ids = v.segment[cv] * u.n_segments + u.segment[cu]  # the knot-interval patch of each triangle
        grid_of = (u, v, points, weights, nu, face_ids, triangles)
        colors = self._patch_field(prim, color_primvar, 3, *grid_of)
        colors = None if colors is None else (colors[0].astype(np.float32), colors[1])
        uvs = self._patch_field(prim, st_primvar, 2, *grid_of)
        return Surface(grid, triangles, face_ids, colors, smooth=True, uvs=uvs)

    def _patch_field(self, prim, primvar, components, u, v, points, weights, nu, face_ids, triangles):
        """``(values (K, components) float64, corner index)`` of a patch's ``primvar`` on its tessellation, or
        None."""
        if primvar is None:
            return None
        n_varying = (u.n_segments + 1) * (v.n_segments + 1)
        sizes = {"constant": 1, "uniform": u.n_segments * v.n_segments, "vertex": len(points), "varying": n_varying,
                 "faceVarying": n_varying}
        field = self.field(prim, primvar, sizes, components)
        if field is None:
            return None
        interpolation, values = field
        if interpolation == "constant":
            return values, np.zeros_like(triangles)
        if interpolation == "uniform":
            return values, np.repeat(face_ids[:, None], 3, axis=1)
        if interpolation == "vertex":
            per_vertex = patch_values(u, v, values, weights, nu)
        else:  # varying: bilinear in each knot-interval patch
            corners = values.reshape(v.n_segments + 1, u.n_segments + 1, components)
            su, sv = u.segment[None, :], v.segment[:, None]
            tu, tv = u.segment_t[None, :, None], v.segment_t[:, None, None]
            per_vertex = ((1 - tv) * ((1 - tu) * corners[sv, su] + tu * corners[sv, su + 1])
                          + tv * ((1 - tu) * corners[sv + 1, su] + tu * corners[sv + 1, su + 1]))
        return per_vertex.reshape(-1, components), triangles

    def _check_finite(self, prim, points):
        """Raises SceneError naming the first point that is not finite, as for meshes."""
        bad = ~np.isfinite(points).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise self.error(f"points[{i}] = {tuple(points[i].tolist())} is not finite", prim,
                             UsdGeom.PointBased(prim).GetPointsAttr())

    def _numbers(self, prim, attr) -> np.ndarray | None:
        """``attr``'s value as float64 numbers, flattened (None where it has none), or SceneError naming it and the
        type authored where it holds no numbers: a ``string`` or ``string[]`` knots, range or pointWeights raised
        "could not convert string to float", naming no attribute (and a string "1.5" would have passed)."""
        raw = value_at(attr, self.time)
        if raw is None:
            return None
        values = np.asarray(raw)
        if values.dtype.kind not in "fiu":
            raise self.error(f"{attr.GetName()} must be numbers, not {self.authored(attr)}", prim, attr)
        return values.astype(np.float64).reshape(-1)

    def _int(self, prim, attr) -> int:
        """An ``int`` attribute's value (0 when it has none)."""
        value = value_at(attr, self.time)
        if value is not None and not isinstance(value, (int, np.integer)):
            raise self.error(f"{attr.GetName()} must be an int, not {self.authored(attr)}", prim, attr)
        return int(value or 0)


__all__ = ["Surface", "SurfaceReader"]
