"""Catmull-Clark refinement of polygon meshes (``subdivisionScheme = "catmullClark"``), with USD's creases, corners
and boundary rules, for ``load_usd(..., refine_level=N)``; bilinear refinement (``"bilinear"``) on the same split;
the scheme-independent parts (sharpness, vertex rules, boundaries, non-manifold input) that Loop refinement
(:mod:`wrt.loop_subdivision`) shares.

Each level splits every face of ``n`` vertices into ``n`` quads (Catmull and Clark 1978) and moves the points by the
masks of DeRose, Kass and Truong 1998 ("Subdivision surfaces in character animation"):

- a face point is the average of its face's points;
- an edge point is the average of the edge's ends and its two faces' points, or the midpoint for a sharp edge
  (a boundary edge, an edge of more than two faces, or a crease of sharpness >= 1), blended by the sharpness of a
  semi-sharp crease;
- a vertex point is ``(Q + 2R + (n - 3)S) / n`` (face points ``Q`` and edge midpoints ``R`` averaged, ``n`` edges)
  for a smooth vertex or a dart, ``(6S + a + b) / 8`` on a crease (two sharp edges, ends ``a`` and ``b``), and ``S``
  at a corner (three or more sharp edges, or a ``cornerIndices`` entry). Where a step makes semi-sharp features run
  out, so that the rule after the step differs (a corner that becomes a crease or smooth, a crease that becomes
  smooth), the two rules are blended by the mean sharpness of the features that turn smooth (OpenSubdiv's
  ``Crease::ComputeFractionalWeightAtVertex``).

Sharpness drops by one per level (OpenSubdiv's "uniform" creasing); USD's 10 and above is infinitely sharp. Boundary
edges are sharp (``interpolateBoundary`` ``edgeOnly``, ``edgeAndCorner`` and ``none``), with ``edgeAndCorner`` (USD's
fallback) a boundary point of a single face is a corner, and with ``none`` the faces at boundary points are holes.
Per-point data (points, ``vertex`` primvars) follows the same masks; face-varying data (texture coordinates) follows
them too away from its seams, per ``faceVaryingLinearInterpolation`` (``wrt.subdivision_fvar``; ``all`` is linear in
each face, here). The result after ``N`` levels is a quad mesh whose points converge to the limit surface as ``N``
grows; it is not the limit surface itself.
"""

from __future__ import annotations

import numpy as np

INFINITELY_SHARP = 10.0  # UsdGeomMesh's SHARPNESS_INFINITE
MAX_REFINE_LEVEL = 8
REFINED_QUAD_BYTES = 1300  # host bytes a load holds at its peak per refined quad (1240 measured: a grid with uvs;
# about 880 per refined Loop triangle, which the same bound covers)


SMOOTH, CREASE, CORNER = 0, 1, 2  # vertex rules (a dart, one sharp edge, takes the smooth rule)


def _decrement(sharpness: np.ndarray) -> np.ndarray:
    """Sharpness one step later: one less, none below zero, infinitely sharp staying so (uniform creasing)."""
    return np.where(sharpness >= INFINITELY_SHARP, INFINITELY_SHARP, np.maximum(sharpness - 1.0, 0.0))


def _vertex_rule(corner_sharpness: np.ndarray, sharp_edges: np.ndarray) -> np.ndarray:
    """Rule per point: corner where it is sharp itself or has three or more sharp edges, crease with two, else
    smooth."""
    rule = np.where(sharp_edges >= 3, CORNER, np.where(sharp_edges == 2, CREASE, SMOOTH))
    return np.where(corner_sharpness > 0.0, CORNER, rule)


def _sum_by(index: np.ndarray, values: np.ndarray, size: int) -> np.ndarray:
    """``(size, k)``: row ``i`` is the sum of the rows of ``values`` ``(N, k)`` whose ``index`` is ``i``."""
    return np.stack([np.bincount(index, weights=values[:, j], minlength=size) for j in range(values.shape[1])], axis=1)


def _face_walk(counts: np.ndarray):
    """Face, next and previous face-vertex of every face-vertex of faces with ``counts`` corners."""
    starts = np.cumsum(counts) - counts
    face = np.repeat(np.arange(len(counts)), counts)
    position = np.arange(int(counts.sum())) - starts[face]
    count = counts[face]
    following = starts[face] + (position + 1) % count
    preceding = starts[face] + (position - 1) % count
    return face, following, preceding


def _edge_keys(a: np.ndarray, b: np.ndarray, n_points: int) -> np.ndarray:
    return np.minimum(a, b) * n_points + np.maximum(a, b)


def refined_quads(counts, levels: int) -> int:
    """Quads that ``levels`` (>= 1) Catmull-Clark or bilinear steps make of faces of ``counts`` corners: ``n`` per
    face of ``n >= 3`` corners, then 4 per quad each further step. Known before refining, so a refinement too large
    for the memory can be refused first."""
    counts = np.asarray(counts, np.int64)
    return int(counts[counts >= 3].sum()) * 4 ** (levels - 1)


class _Level:
    """One Catmull-Clark step of a mesh of ``counts`` faces (each >= 3 corners) over ``face_indices``."""

    def __init__(self, counts, face_indices, n_points, edge_sharpness, corner_sharpness, corner_boundary,
                 triangle_smooth=False):
        self.counts, self.face_indices, self.n_points = counts, face_indices, n_points
        self.triangle_smooth = triangle_smooth
        face, following, preceding = _face_walk(counts)
        self.face, self.following, self.preceding = face, following, preceding
        a, b = face_indices, face_indices[following]
        keys, self.fv_edge = np.unique(_edge_keys(a, b, n_points), return_inverse=True)
        self.fv_edge = self.fv_edge.reshape(-1)
        self.edge_ends = np.stack([keys // n_points, keys % n_points], axis=1)
        n_edges = len(keys)
        self.edge_faces = np.bincount(self.fv_edge, minlength=n_edges)
        sharp = edge_sharpness(keys)  # per edge, this level
        sharp = np.where(self.edge_faces != 2, INFINITELY_SHARP, sharp)  # boundary and non-manifold edges
        self.edge_sharpness = sharp

        # Per point: incident edges, faces, and its sharpness (corner) this level.
        ends = self.edge_ends.reshape(-1)
        self.valence = np.bincount(ends, minlength=n_points)
        self.point_faces = np.bincount(face_indices, minlength=n_points)
        corner = corner_sharpness.copy()
        sharp_edges = np.bincount(ends, weights=np.repeat(sharp > 0.0, 2), minlength=n_points)
        if corner_boundary:  # edgeAndCorner: a boundary point of one face is a corner
            corner[(self.point_faces == 1) & (sharp_edges >= 2)] = INFINITELY_SHARP
        self.corner_sharpness = corner

        # Vertex rules of this level (parent) and of the next (child), from the sharpness of the point and its edges
        # now and one step later, and the weight of the parent's rule where they differ (OpenSubdiv's
        # Crease::DetermineVertexVertexRule and ComputeFractionalWeightAtVertex, uniform creasing): the mean
        # sharpness of what turns smooth in this step (the point's, and its edges' of sharpness up to 1).
        self.parent_rule = _vertex_rule(corner, sharp_edges)
        child_sharp_edges = np.bincount(ends, weights=np.repeat(_decrement(sharp) > 0.0, 2), minlength=n_points)
        self.child_rule = _vertex_rule(_decrement(corner), child_sharp_edges)
        ending = (sharp > 0.0) & (sharp <= 1.0)
        ending_sum = np.bincount(ends, weights=np.repeat(np.where(ending, sharp, 0.0), 2), minlength=n_points)
        ending_count = np.bincount(ends, weights=np.repeat(ending, 2), minlength=n_points)
        corner_ends = (corner > 0.0) & (corner <= 1.0)
        ending_sum += np.where(corner_ends, corner, 0.0)
        ending_count += corner_ends
        self.parent_weight = np.minimum(ending_sum / np.maximum(ending_count, 1), 1.0)

    def child_sharpness(self):
        """Edge sharpness lookup and corner sharpness of the refined mesh (one less, none below zero)."""
        n_points = self.n_points
        parent = np.flatnonzero(self.edge_sharpness > 0.0)
        sharp = _decrement(self.edge_sharpness[parent])
        middle = n_points + parent
        new_points = self.refined_points
        keys = np.concatenate([_edge_keys(self.edge_ends[parent, 0], middle, new_points),
                               _edge_keys(self.edge_ends[parent, 1], middle, new_points)])
        values = np.concatenate([sharp, sharp])
        order = np.argsort(keys)
        keys, values = keys[order], values[order]
        corner = np.zeros(new_points)
        corner[:n_points] = _decrement(self.corner_sharpness)
        return _SharpnessTable(keys, values), corner

    refined_corners = 4  # corners of each refined face

    @property
    def refined_points(self) -> int:
        return self.n_points + len(self.edge_ends) + len(self.counts)

    def split(self, at_point: np.ndarray, at_lead: np.ndarray, at_face: np.ndarray) -> np.ndarray:
        """What each refined face-vertex holds, in ``topology``'s order, from what each face-vertex's point holds
        (``at_point`` ``(N, ...)``), its leading edge's point (``at_lead`` ``(N, ...)``) and each face's point
        (``at_face`` ``(F, ...)``): one quad per face-vertex (its point, its leading edge, its face, its trailing
        edge)."""
        quads = np.stack([at_point, at_lead, at_face[self.face], at_lead[self.preceding]], axis=1)
        return quads.reshape(-1, *quads.shape[2:])

    def corner_children(self) -> np.ndarray:
        """``(N,)`` the refined face-vertex at each face-vertex's point, first of its refined face (next to the
        leading edge's point, after the trailing one's)."""
        n = len(self.face_indices)
        held = self.split(np.arange(n), np.full(n, -1), np.full(len(self.counts), -1))
        corners = np.empty(n, np.int64)
        corners[held[held >= 0]] = np.flatnonzero(held >= 0)
        return corners

    def topology(self):
        """``(counts, face_indices, parent face)`` of the refined quads, one per face-vertex, winding kept."""
        n, e = self.n_points, len(self.edge_ends)
        quads = self.split(self.face_indices, n + self.fv_edge, n + e + np.arange(len(self.counts)))
        return np.full(len(self.face_indices), 4, np.int64), quads, self.face

    def vertex(self, data: np.ndarray, edge_values=None, corner_values=None) -> np.ndarray:
        """Per-point ``data`` ``(V, k)`` of the refined mesh: points first, then edge points, then face points.

        A face-varying channel (``wrt.subdivision_fvar``) passes the values at each edge's ends ``(E, 2, k)`` and at
        each face-vertex ``(N, k)``, as its points may hold several; by default both are ``data``'s."""
        fi = self.face_indices
        face_points = self._face_average(data[fi] if corner_values is None else corner_values)
        face_point_at = face_points[self.face]  # per face-vertex: its face's point

        if edge_values is None:
            edge_values = data[self.edge_ends]
        midpoint = 0.5 * (edge_values[:, 0] + edge_values[:, 1])
        face_sum = _sum_by(self.fv_edge, face_point_at, len(self.edge_ends))
        smooth_edge = 0.5 * midpoint + face_sum / (2.0 * np.maximum(self.edge_faces, 1)[:, None])
        if self.triangle_smooth:
            # triangleSubdivisionRule = smooth: an edge of two faces, a triangle among them, weighs each face point by
            # the mean of 0.47 per triangle and 0.25 per other face, its ends by the rest (OpenSubdiv's
            # TRI_SUB_SMOOTH, catmarkScheme.h).
            is_triangle = (self.counts == 3)[self.face]
            triangles = np.bincount(self.fv_edge, weights=is_triangle, minlength=len(self.edge_ends))
            weights = np.bincount(self.fv_edge, weights=np.where(is_triangle, 0.47, 0.25), minlength=len(triangles))
            face_weight = (0.5 * weights)[:, None]
            by_triangles = (1.0 - 2.0 * face_weight) * midpoint + face_weight * face_sum
            smooth_edge = np.where(((self.edge_faces == 2) & (triangles > 0))[:, None], by_triangles, smooth_edge)

        # Smooth vertex rule: (Q + 2R + (n - 3) S) / n.
        n_points = self.n_points
        valence = np.maximum(self.valence, 1)[:, None]
        q = _sum_by(fi, face_point_at, n_points) / np.maximum(self.point_faces, 1)[:, None]
        r = _sum_by(self.edge_ends.reshape(-1), np.repeat(midpoint, 2, axis=0), n_points) / valence
        smooth = (q + 2.0 * r + (valence - 3.0) * data) / valence
        return np.concatenate([self.vertex_points(data, smooth, edge_values), self.edge_points(midpoint, smooth_edge),
                               face_points])

    def _midpoints(self, data: np.ndarray) -> np.ndarray:
        """``(E, k)``: the middle of every edge."""
        return 0.5 * (data[self.edge_ends[:, 0]] + data[self.edge_ends[:, 1]])

    def edge_points(self, midpoint: np.ndarray, smooth_edge: np.ndarray) -> np.ndarray:
        """Edge points from the scheme's smooth edge points: the midpoint on a sharp edge, the two blended by the
        sharpness of a semi-sharp edge below 1 (the same in every scheme, OpenSubdiv's ``Scheme``)."""
        s = np.clip(self.edge_sharpness, 0.0, 1.0)[:, None]
        return (1.0 - s) * smooth_edge + s * midpoint

    def vertex_points(self, data: np.ndarray, smooth: np.ndarray, edge_values: np.ndarray) -> np.ndarray:
        """Vertex points of this level's rules from the scheme's smooth vertex points ``smooth`` ``(V, k)``: the crease
        rule ``(6 S + a + b) / 8`` and the corner rule ``S`` are those of Catmull-Clark and Loop alike (OpenSubdiv's
        ``Scheme``), and so is the blend of the rules before and after a step where semi-sharp features run out.
        ``edge_values`` ``(E, 2, k)``: the values at each edge's ends (a face-varying point may hold several)."""
        n_points = self.n_points
        ends = self.edge_ends.reshape(-1)
        # Crease rule over the other ends of the sharp edges (those of this step for the parent rule, those still
        # sharp after it for the child rule).
        others = edge_values[:, ::-1].reshape(-1, data.shape[1])  # per edge end: the value at the other end

        def crease(edge_is_sharp):
            at = np.repeat(edge_is_sharp, 2)
            return (6.0 * data + _sum_by(ends[at], others[at], n_points)) / 8.0

        def masked(rule, edge_is_sharp):
            by_rule = np.where((rule == CREASE)[:, None], crease(edge_is_sharp), data)
            return np.where((rule == SMOOTH)[:, None], smooth, by_rule)

        parent = masked(self.parent_rule, self.edge_sharpness > 0.0)
        child = masked(self.child_rule, _decrement(self.edge_sharpness) > 0.0)
        w = np.where(self.child_rule == self.parent_rule, 1.0, self.parent_weight)[:, None]
        vertex_points = np.where((self.parent_rule == SMOOTH)[:, None], smooth, w * parent + (1.0 - w) * child)
        lonely = self.point_faces == 0  # points no face uses stay where they are
        vertex_points[lonely] = data[lonely]
        return vertex_points

    def linear(self, data: np.ndarray) -> np.ndarray:
        """Per-point ``data`` of the refined mesh interpolated linearly (``varying`` primvars): points keep their
        value, edge points take the midpoint, face points the face's average."""
        return np.concatenate([data, self._midpoints(data), self._face_average(data[self.face_indices])])

    def _face_average(self, fv_data: np.ndarray) -> np.ndarray:
        return _sum_by(self.face, fv_data, len(self.counts)) / self.counts[:, None]

    def face_varying(self, data: np.ndarray) -> np.ndarray:
        """Per-face-vertex ``data`` ``(N, k)`` of the refined quads, interpolated linearly within each face."""
        return self.split(data, 0.5 * (data + data[self.following]), self._face_average(data))


class _SharpnessTable:
    """Sharpness of edges given by sorted keys; edges not listed are smooth."""

    def __init__(self, keys: np.ndarray, values: np.ndarray):
        self.keys, self.values = keys, values

    def with_infinite(self, keys: np.ndarray) -> _SharpnessTable:
        """This table with the edges ``keys`` infinitely sharp."""
        all_keys = np.concatenate([self.keys, keys])
        values = np.concatenate([self.values, np.full(len(keys), INFINITELY_SHARP)])
        order = np.argsort(all_keys, kind="stable")
        all_keys, values = all_keys[order], values[order]
        unique, first = np.unique(all_keys, return_index=True)
        return _SharpnessTable(unique, np.maximum.reduceat(values, first) if len(values) else values)

    def __call__(self, keys: np.ndarray) -> np.ndarray:
        if len(self.keys) == 0:
            return np.zeros(len(keys))
        at = np.clip(np.searchsorted(self.keys, keys), 0, len(self.keys) - 1)
        return np.where(self.keys[at] == keys, self.values[at], 0.0)


class Refinement:
    """``levels`` Catmull-Clark steps of a polygon mesh: its refined quads and maps for per-point, per-face-vertex
    and per-face data.

    Args:
        counts: ``faceVertexCounts``; faces of fewer than three corners draw nothing and are left out.
        face_indices: ``faceVertexIndices``.
        n_points: number of points.
        levels: steps, 1 to ``MAX_REFINE_LEVEL``.
        creases: ``(indices, lengths, sharpnesses)`` of ``creaseIndices``, ``creaseLengths`` and
            ``creaseSharpnesses`` (one per crease or one per crease edge), or None.
        corners: ``(indices, sharpnesses)`` of ``cornerIndices`` and ``cornerSharpnesses``, or None.
        boundary: ``interpolateBoundary``: ``edgeAndCorner`` (boundary points of one face are corners), ``edgeOnly``
            or ``none`` (as ``edgeOnly``, and the faces at boundary points are holes: ``boundary_holes``).
        triangle_smooth: ``triangleSubdivisionRule = smooth`` (other edge weights next to triangles).
        face_varying: ``faceVaryingLinearInterpolation``, how ``face_varying`` refines (``wrt.subdivision_fvar``).

    Raises:
        ValueError: creases or corners that do not fit the mesh (the message says which).
    """

    _level_type = _Level  # one step of the scheme

    def __init__(self, counts, face_indices, n_points, levels, creases=None, corners=None, boundary="edgeAndCorner",
                 triangle_smooth=False, face_varying="cornersPlus1"):
        self.face_varying_mode, self.corner_boundary = face_varying, boundary == "edgeAndCorner"
        counts = np.asarray(counts, np.int64)
        face_indices = np.asarray(face_indices, np.int64)
        drawn = counts >= 3
        kept_fv = np.repeat(drawn, counts)
        self.input_face_vertices = np.flatnonzero(kept_fv)  # face-vertices of the faces that are refined
        self.parent_face = np.flatnonzero(drawn)  # refined face -> input face, updated per level
        counts, face_indices = counts[drawn], face_indices[kept_fv]

        edge_sharpness = _crease_table(creases, n_points)
        corner_sharpness = np.zeros(n_points)
        if corners is not None:
            indices, sharpness = (np.asarray(x).reshape(-1) for x in corners)
            if len(indices) != len(sharpness):
                raise ValueError(f"{len(indices)} cornerIndices but {len(sharpness)} cornerSharpnesses")
            if len(indices) and (indices.min() < 0 or indices.max() >= n_points):
                raise ValueError(f"cornerIndices out of range for {n_points} points")
            corner_sharpness[indices.astype(np.int64)] = _sharpness(sharpness, "cornerSharpnesses")
        self.boundary_holes = np.zeros(0, np.int64)  # input faces not drawn, in faceVertexCounts numbering
        self.levels = []
        if not len(counts):  # no face of three corners or more: nothing to refine (the topology walk needs a face)
            self.counts, self.face_indices, self.n_points = counts, face_indices, n_points
            return
        # Non-manifold input (an edge of three faces or of two wound oppositely, a face that repeats a point, faces
        # that meet at a point only) is infinitely sharp, as OpenSubdiv tags it: refined smoothly, it was averaged
        # over faces that are not one surface around it.
        # interpolateBoundary = none: faces at a boundary point are holes (their points still shape the rest), unless
        # all its boundary edges are authored infinitely sharp (OpenSubdiv's VTX_BOUNDARY_NONE).
        if boundary == "none":
            self.boundary_holes = self.parent_face[_boundary_faces(counts, face_indices, n_points, edge_sharpness)]
        corner_boundary = boundary == "edgeAndCorner"
        sharp_edges, sharp_points = _non_manifold(counts, face_indices, n_points)
        edge_sharpness = edge_sharpness.with_infinite(sharp_edges)
        corner_sharpness[sharp_points] = INFINITELY_SHARP

        for _ in range(levels):
            level = self._level_type(counts, face_indices, n_points, edge_sharpness, corner_sharpness,
                                     corner_boundary, triangle_smooth)
            self.levels.append(level)
            edge_sharpness, corner_sharpness = level.child_sharpness()
            counts, face_indices, parent = level.topology()
            self.parent_face = self.parent_face[parent]
            n_points = level.refined_points
        self.counts, self.face_indices, self.n_points = counts, face_indices, n_points

    def vertex(self, data: np.ndarray) -> np.ndarray:
        """``(V, k)`` per-point data of the input mesh -> ``(V', k)`` of the refined one (float64)."""
        data = np.asarray(data, np.float64)
        for level in self.levels:
            data = level.vertex(data)
        return data

    def varying(self, data: np.ndarray) -> np.ndarray:
        """``(V, k)`` per-point data of the input mesh interpolated linearly (``varying`` primvars) -> ``(V', k)``."""
        data = np.asarray(data, np.float64)
        for level in self.levels:
            data = level.linear(data)
        return data

    def face_varying(self, data: np.ndarray, value_ids=None) -> np.ndarray:
        """``(N, k)`` per-face-vertex data of the input mesh -> per face-vertex of the refined one (float64), smooth
        or linear as ``face_varying`` asks. ``value_ids`` ``(N,)``: face-vertices of a point with the same id hold one
        value (an indexed primvar's indices); None: each face-vertex its own (an unindexed primvar, as Storm hands
        it to OpenSubdiv)."""
        data = np.asarray(data, np.float64)
        if self.face_varying_mode != "all":
            from .subdivision_fvar import refine_face_varying  # it builds on this module's levels

            if value_ids is None:
                value_ids = np.arange(len(data))
            kept = self.input_face_vertices
            return refine_face_varying(self.levels, data[kept], np.asarray(value_ids)[kept], self.face_varying_mode,
                                       self.corner_boundary)
        data = data[self.input_face_vertices]
        for level in self.levels:
            data = level.face_varying(data)
        return data


class _BilinearLevel(_Level):
    """One bilinear step: faces split as Catmull-Clark splits them (``n`` quads per face of ``n`` corners, triangles
    into 3), points kept, edge points the midpoints, face points the centroids (OpenSubdiv's bilinear scheme: its
    corner mask at points, crease mask on edges, whatever the sharpness)."""

    def vertex(self, data: np.ndarray) -> np.ndarray:
        return self.linear(data)


class BilinearRefinement(Refinement):
    """``levels`` bilinear steps of a polygon mesh (``subdivisionScheme = "bilinear"``): each quad into 4 quads over
    its edge midpoints and centroid, so a non-planar quad approaches its bilinear patch; creases, corners and
    ``interpolateBoundary`` change nothing (OpenSubdiv's bilinear scheme makes no boundary faces holes either)."""

    _level_type = _BilinearLevel

    def __init__(self, counts, face_indices, n_points, levels):
        super().__init__(counts, face_indices, n_points, levels, boundary="edgeOnly", face_varying="all")


def _boundary_faces(counts: np.ndarray, face_indices: np.ndarray, n_points: int, authored) -> np.ndarray:
    """Faces at a point with a boundary edge (of one face) that is not authored infinitely sharp."""
    face, following, _ = _face_walk(counts)
    keys, uses = np.unique(_edge_keys(face_indices, face_indices[following], n_points), return_counts=True)
    open_edges = keys[(uses == 1) & (authored(keys) < INFINITELY_SHARP)]
    at_boundary = np.zeros(n_points, bool)
    at_boundary[open_edges // n_points] = True
    at_boundary[open_edges % n_points] = True
    return np.unique(face[at_boundary[face_indices]])


def _non_manifold(counts: np.ndarray, face_indices: np.ndarray, n_points: int):
    """Edge keys and a point mask of the non-manifold parts of a mesh, as OpenSubdiv's ``Vtr::Level`` finds them and
    ``Far::TopologyRefinerFactory`` sharpens them: edges of more than two faces, of two faces that run it the same
    way (opposite windings), twice in one face, or from a point to itself; points on such an edge, points whose
    faces do not make one fan around them (two cones meeting at their apex), and points no face uses. A point
    between exactly two non-manifold edges with more faces than edges and no boundary (along a fin) keeps its
    crease rule."""
    face, following, _ = _face_walk(counts)
    a, b = face_indices, face_indices[following]
    keys, edge_of, uses = np.unique(_edge_keys(a, b, n_points), return_inverse=True, return_counts=True)
    edge_of = edge_of.reshape(-1)
    n_edges = len(keys)
    # Per edge: its uses, how many run from the smaller point, how many faces it has.
    forward = np.bincount(edge_of, weights=a < b, minlength=n_edges)
    order = np.lexsort((face, edge_of))
    repeated = np.zeros(n_edges, bool)
    twice = (edge_of[order][1:] == edge_of[order][:-1]) & (face[order][1:] == face[order][:-1])
    repeated[edge_of[order][1:][twice]] = True
    bad_edge = (uses > 2) | ((uses == 2) & (forward != 1)) | repeated | (keys // n_points == keys % n_points)

    ends = np.stack([keys // n_points, keys % n_points], axis=1).reshape(-1)
    point_edges = np.bincount(ends, minlength=n_points)  # a point-to-itself edge counts twice, as it ends twice
    point_faces = np.bincount(face_indices, minlength=n_points)
    boundary = np.bincount(ends, weights=np.repeat(uses == 1, 2), minlength=n_points)
    bad_at = np.bincount(ends, weights=np.repeat(bad_edge, 2), minlength=n_points)

    # Fans: join the two corners at each end of every manifold edge shared by two faces; a manifold point's corners
    # are then one component.
    inner = (uses == 2) & ~bad_edge
    first_use = np.full(n_edges, -1)
    second_use = np.full(n_edges, -1)
    sorted_edges = edge_of[order]
    starts = np.flatnonzero(np.r_[True, sorted_edges[1:] != sorted_edges[:-1]])
    first_use[sorted_edges[starts]] = order[starts]
    has_second = np.r_[starts[1:], len(order)] - starts >= 2
    second_use[sorted_edges[starts[has_second]]] = order[starts[has_second] + 1]
    i, j = first_use[inner], second_use[inner]
    links = np.concatenate([np.stack([i, following[j]], 1), np.stack([following[i], j], 1)])
    labels = np.arange(len(face_indices))
    while len(links):
        low = np.minimum(labels[links[:, 0]], labels[links[:, 1]])
        joined = labels.copy()
        np.minimum.at(joined, links[:, 0], low)
        np.minimum.at(joined, links[:, 1], low)
        joined = joined[joined]
        if np.array_equal(joined, labels):
            break
        labels = joined
    fans = np.bincount(np.unique(face_indices * len(face_indices) + labels) // len(face_indices), minlength=n_points)

    one_fan = (fans == 1) & (bad_at == 0) & (point_edges >= 2) & (
        ((boundary == 0) & (point_edges == point_faces)) | ((boundary == 2) & (point_edges == point_faces + 1)))
    along_fin = (bad_at == 2) & (boundary == 0) & (point_faces > point_edges)
    return keys[bad_edge], ~one_fan & ~along_fin


def _sharpness(values, name: str) -> np.ndarray:
    """``values`` of attribute ``name`` as float64 sharpnesses, negative ones smooth (0); raises ``ValueError`` on a
    NaN, which ``np.maximum`` keeps and which made every refined point NaN (the mesh was refused as not finite)."""
    values = np.asarray(values, np.float64)
    if np.isnan(values).any():
        raise ValueError(f"{name} has {int(np.isnan(values).sum())} NaN of {values.size}")
    return np.maximum(values, 0.0)


def _crease_table(creases, n_points: int) -> _SharpnessTable:
    if creases is None:
        return _SharpnessTable(np.zeros(0, np.int64), np.zeros(0))
    indices, lengths, sharpnesses = (np.asarray(x).reshape(-1) for x in creases)
    indices, lengths = indices.astype(np.int64), lengths.astype(np.int64)
    if (lengths < 2).any() or lengths.sum() != len(indices):
        raise ValueError(f"creaseLengths (sum {int(lengths.sum())}, each >= 2) do not match {len(indices)} "
                         "creaseIndices")
    if len(indices) and (indices.min() < 0 or indices.max() >= n_points):
        raise ValueError(f"creaseIndices out of range for {n_points} points")
    n_edges = int((lengths - 1).sum())
    if len(sharpnesses) == len(lengths):
        per_edge = np.repeat(sharpnesses, lengths - 1)
    elif len(sharpnesses) == n_edges:
        per_edge = sharpnesses
    else:
        raise ValueError(f"{len(sharpnesses)} creaseSharpnesses for {len(lengths)} creases of {n_edges} edges "
                         "(one per crease or one per edge)")
    starts = np.cumsum(lengths) - lengths
    crease = np.repeat(np.arange(len(lengths)), lengths - 1)
    step = np.arange(n_edges) - (np.cumsum(lengths - 1) - (lengths - 1))[crease]
    a = indices[starts[crease] + step]
    b = indices[starts[crease] + step + 1]
    keys = _edge_keys(a, b, n_points)
    values = _sharpness(per_edge, "creaseSharpnesses")
    order = np.argsort(keys, kind="stable")
    keys, values = keys[order], values[order]
    unique, first = np.unique(keys, return_index=True)
    maxima = np.maximum.reduceat(values, first) if len(values) else values
    return _SharpnessTable(unique, maxima)


__all__ = ["MAX_REFINE_LEVEL", "REFINED_QUAD_BYTES", "BilinearRefinement", "Refinement", "refined_quads"]
