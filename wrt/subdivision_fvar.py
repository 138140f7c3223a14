"""Face-varying data (texture coordinates) through Catmull-Clark or Loop refinement, as USD's
``faceVaryingLinearInterpolation`` asks: OpenSubdiv's ``Sdc::Options::FVarLinearInterpolation``, after its
``Vtr::FVarLevel``, ``Vtr::FVarRefinement`` and ``Far::PrimvarRefiner::InterpolateFaceVarying``. The seam and boundary
rules below are the same in both schemes (OpenSubdiv's); only the masks of values that match their point and the split
of the faces are the level's (``_Level.vertex`` and ``split``: Loop's edge points take the far corners as each
triangle holds them).

A face-varying channel has a value per face-vertex; face-vertices of one point that hold the same value are one value
of that point. An edge whose faces disagree on the value at either end is a seam (a face-varying boundary). Where a
point has one value and no seam reaches it, the value follows the point's own masks (the vertex ones, creases and
boundaries included), so seamless data refines as a ``vertex`` primvar would. The values of a point on a seam are
refined apart, each over its span (the faces around the point that hold it) as a boundary of its own:

- a corner keeps its value;
- a crease takes ``(6 v + a + b) / 8`` of the values ``a`` and ``b`` at the far ends of the span's two bounding edges;
- a semi-sharp one (semi-sharp edges inside its span, or a semi-sharp point) is a corner until that sharpness runs
  out, then a crease, blended on that step by OpenSubdiv's fractional weight.

Edge points on a seam are the midpoints in each face, face points (Catmull-Clark's) the face's average. The modes decide
which values are corners: ``none`` none of them, ``cornersOnly`` a value of a single face (and a boundary point of one
face where ``interpolateBoundary`` does not make it a corner), ``cornersPlus1`` also every value of a point with three
or more, and both of a point with two where a span holds a seam or an infinitely sharp edge, ``cornersPlus2`` also both
of a point with two where one is a corner, and a point with one value where a seam ends (a dart); ``boundaries`` every
value on a seam or on the mesh's boundary (linear along them); ``all`` is linear everywhere
(``Refinement.face_varying``'s linear path). Points that are infinitely sharp corners, or non-manifold, keep all their
values.
"""

from __future__ import annotations

import numpy as np

from .subdivision import INFINITELY_SHARP, _decrement

FACE_VARYING_MODES = ("none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all")
FALLBACK_FACE_VARYING_MODE = "cornersPlus1"  # UsdGeomMesh's fallback for faceVaryingLinearInterpolation

MATCH, CORNER, CREASE, SEMI = 0, 1, 2, 3  # kinds of value: the point's masks, kept, crease rule, corner to crease


class _Values:
    """The values of a face-varying channel on one level.

    Attributes:
        group: ``(N,)`` int, the value of each face-vertex (one per point and distinct datum around it).
        data: ``(G, k)`` float64 datum of each value.
        kind: ``(G,)`` MATCH, CORNER, CREASE or SEMI.
        start, end: ``(G,)`` face-vertices that end a crease's span (-1 for others): the datum after ``start`` in its
            face and the one before ``end`` in its face are the crease's neighbours.
        dependent: ``(G,)`` a SEMI value sharp only because the other value of its point is (``partner``).
        partner: ``(G,)`` the other value of a point with two, else -1.
        linear: ``(E,)`` edges whose midpoints are corners (``boundaries``: seams and the mesh's boundary edges).
    """

    def __init__(self, group, data, kind, start, end, dependent, partner, linear):
        self.group, self.data, self.kind = group, data, kind
        self.start, self.end, self.dependent, self.partner = start, end, dependent, partner
        self.linear = linear


def _uses(level) -> tuple[np.ndarray, np.ndarray]:
    """``(E,)`` each edge's first and last use: the first and last face-vertex whose leading edge it is (every edge
    has one). Found by a stable sort, not by assigning ``arange`` through repeated indices, whose winner numpy does
    not guarantee ("if an element is set more than once, it is not possible to predict the final result")."""
    order = np.argsort(level.fv_edge, kind="stable")
    ends = np.cumsum(level.edge_faces)  # edge_faces: the uses of each edge
    return order[ends - level.edge_faces], order[ends - 1]


def _across_lead_edge(level) -> np.ndarray:
    """``(N,)`` the face-vertex of the same point in the face across each face-vertex's leading edge (to the next
    point of its face), or -1 where that edge has not two faces running it oppositely."""
    fv_edge = level.fv_edge
    n = len(fv_edge)
    first, last = _uses(level)  # an edge of two faces: its first and last use are the two
    other = np.where(level.edge_faces[fv_edge] == 2, first[fv_edge] + last[fv_edge] - np.arange(n), -1)
    across = np.full(n, -1)
    has = np.flatnonzero(other >= 0)
    opposite = level.face_indices[other[has]] == level.face_indices[level.following[has]]
    has = has[opposite]
    across[has] = level.following[other[has]]
    return across


def _seams(level, group: np.ndarray) -> np.ndarray:
    """``(E,)`` edges whose faces do not all hold the same values at both its ends."""
    ends = level.edge_ends[level.fv_edge]
    forward = level.face_indices == ends[:, 0]
    here, there = group, group[level.following]
    low = np.where(forward, here, there)  # the value at the edge's first end, in this face
    high = np.where(forward, there, here)
    seam = np.zeros(len(level.edge_ends), bool)
    first = _uses(level)[0]
    for per_use in (low, high):
        seam |= np.bincount(level.fv_edge, weights=per_use != per_use[first][level.fv_edge], minlength=len(seam)) > 0
    return seam


def _same_across(level, group):
    """Per face-vertex: whether its leading and trailing edges join it to a face-vertex of the same value, and the
    face-vertex across its leading edge."""
    across = _across_lead_edge(level)
    lead_same = (across >= 0) & (group[np.maximum(across, 0)] == group)
    trail_same = np.zeros(len(group), bool)
    trail_same[across[lead_same]] = True
    return lead_same, trail_same, across


def _first_per_value(group: np.ndarray, chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The values that hold a ``chosen`` face-vertex, and the first such face-vertex of each (``np.unique``'s first
    index), not assigned through repeated indices, whose winner numpy does not guarantee."""
    at = np.flatnonzero(chosen)
    held, first = np.unique(group[at], return_index=True)
    return held, at[first]


def _classify(level, group: np.ndarray, data: np.ndarray, mode: str, corner_boundary: bool) -> _Values:
    """The kinds and crease ends of the values of the base level (``FVarLevel::completeTopologyFromFaceValues``)."""
    linear_boundaries = mode in ("boundaries", "all")
    dependent = mode in ("cornersPlus1", "cornersPlus2")
    corners_sharp = mode != "none"
    sharpen_darts = mode in ("cornersPlus2", "boundaries", "all")
    n_points, n_values = level.n_points, len(data)
    point = np.zeros(n_values, np.int64)
    point[group] = level.face_indices
    values_at = np.bincount(point, minlength=n_points)
    seam = _seams(level, group)

    # Points whose values do not simply follow the point: on a seam, with several values, or on the mesh's boundary
    # where the mode sharpens it.
    boundary_edge = level.edge_faces == 1
    on_boundary = np.zeros(n_points, bool)
    on_boundary[level.edge_ends[boundary_edge].reshape(-1)] = True
    split = np.zeros(n_points, bool)
    split[level.edge_ends[seam].reshape(-1)] = True
    # Linear boundaries: the mesh's boundary edges too. (FVarLevel tags them from a boundary point off the seams,
    # in the order it visits the points; an edge between two points on seams is linear here whatever that order.)
    linear = (seam | boundary_edge) & linear_boundaries
    if linear_boundaries:
        split |= on_boundary & (level.point_faces > 0)
    elif corners_sharp and not corner_boundary:
        split |= on_boundary & (level.point_faces == 1)
    split |= values_at > 1
    sharpness = level.corner_sharpness
    all_corners = (linear_boundaries | (sharpness >= INFINITELY_SHARP) | (dependent & (values_at > 2))
                   | (sharpen_darts & (values_at == 1) & ~on_boundary))

    # Spans: each value's face-vertices, the edges inside it (both sides hold it), and what those edges are.
    lead_same, trail_same, across = _same_across(level, group)
    edge = level.fv_edge
    s = level.edge_sharpness[edge]
    size = np.bincount(group, minlength=n_values)
    inner = np.bincount(group, weights=lead_same, minlength=n_values)
    seams_in = np.bincount(group, weights=lead_same & seam[edge], minlength=n_values)
    infinite_in = np.bincount(group, weights=lead_same & ~seam[edge] & (s >= INFINITELY_SHARP), minlength=n_values)
    semi_in = np.bincount(group, weights=lead_same & ~seam[edge] & (s > 0) & (s < INFINITELY_SHARP),
                          minlength=n_values)
    ring = inner == size  # all around an interior point: a dart, bounded by its one seam
    disjoint = np.where(ring, seams_in > 1, (seams_in > 0) | (size - inner > 1))

    # A point of two values sharpens both where either holds a seam or an infinitely sharp edge (or, cornersPlus2,
    # is a corner), and makes one dependent on the other where only that one is semi-sharp.
    two = values_at == 2
    per_point = np.bincount(point, weights=disjoint | (infinite_in > 0), minlength=n_points) > 0
    all_corners |= dependent & two & per_point
    if mode == "cornersPlus2":
        all_corners |= two & (np.bincount(point, weights=size == 1, minlength=n_points) > 0)
    to_sharpen = dependent & two & (np.bincount(point, weights=semi_in > 0, minlength=n_points) == 1)
    partner = np.where(two[point], np.bincount(point, weights=np.arange(n_values), minlength=n_points)[point]
                       - np.arange(n_values), -1).astype(np.int64)

    corner = disjoint | all_corners[point] | (infinite_in > 0) | ((size == 1) & corners_sharp)
    semi_point = (sharpness > 0) & (sharpness < INFINITELY_SHARP)
    semi = ~corner & ((semi_in > 0) | semi_point[point])
    dependent_value = ~corner & ~semi & to_sharpen[point]
    kind = np.where(corner, CORNER, np.where(semi | dependent_value, SEMI, CREASE))
    kind = np.where(split[point], kind, MATCH)

    # Crease ends: the face-vertices whose leading (start) and trailing (end) edges bound the span; a dart's span
    # starts and ends at its seam.
    # A value may have several (a disjoint one: a corner, whose ends are never read): its first face-vertex wins.
    start = np.full(n_values, -1)
    end = np.full(n_values, -1)
    held, at = _first_per_value(group, ~lead_same)
    start[held] = at
    held, at = _first_per_value(group, ~trail_same)
    end[held] = at
    held, at = _first_per_value(group, lead_same & seam[edge] & ring[group])
    start[held] = at
    end[held] = across[at]
    return _Values(group, data, kind, start, end, dependent_value, partner, linear)


def _fractional_weight(parent_point, child_point, parent_edges, child_edges, group, n_values):
    """``Crease::ComputeFractionalWeightAtVertex`` per value: the mean sharpness of the point and of the edges inside
    its span (face-vertex rows, ``parent_edges`` zero outside) that turn smooth in this step, at most 1."""
    point_ends = (parent_point > 0) & (child_point <= 0)
    edge_ends = (parent_edges > 0) & (child_edges <= 0)
    total = np.where(point_ends, parent_point, 0.0) + np.bincount(group, weights=np.where(edge_ends, parent_edges, 0.0),
                                                                  minlength=n_values)
    count = point_ends + np.bincount(group, weights=edge_ends, minlength=n_values)
    return np.where(count > 0, np.minimum(total / np.maximum(count, 1), 1.0), 0.0)


def _step(level, values: _Values, smooth_boundaries: bool, child_level) -> _Values:
    """One step of a face-varying channel over ``level`` (a Catmull-Clark or Loop ``_Level``: its masks and split):
    the values of the refined level (``PrimvarRefiner``'s ``interpFVarFromFaces``, ``...FromEdges`` and
    ``...FromVerts``, ``FVarRefinement``'s tag propagation); ``child_level`` is the next step's ``_Level`` (None after
    the last), whose linear edges it marks."""
    group, data, kind = values.group, values.data, values.kind
    fv_data = data[group]
    n, n_values, n_edges, n_points = len(group), len(data), len(level.edge_ends), level.n_points
    following, preceding = level.following, level.preceding
    n_faces = level.refined_points - n_points - n_edges  # face points: one per face (Catmull-Clark), none (Loop)
    face_points = level._face_average(fv_data) if n_faces else np.zeros((0, data.shape[1]))

    # The point's masks, for values that match it: each edge's end values from one of its faces (they agree on an
    # edge off the seams), each point's value from any face-vertex at it.
    use = _uses(level)[0]
    forward = (level.face_indices[use] == level.edge_ends[:, 0])[:, None, None]
    here, there = fv_data[use], fv_data[following[use]]
    edge_values = np.where(forward, np.stack([here, there], 1), np.stack([there, here], 1))
    point_values = np.zeros((n_points, data.shape[1]))
    point_values[level.face_indices] = fv_data
    smooth = level.vertex(point_values, edge_values, fv_data)
    smooth_points, smooth_edges = smooth[:n_points], smooth[n_points:n_points + n_edges]

    # Vertex values: kept (corners), the crease rule, or the blend of the two on the step a semi-sharp one runs out.
    point = np.zeros(n_values, np.int64)
    point[group] = level.face_indices
    neighbours = np.zeros_like(data)
    creased = (values.start >= 0) & (values.end >= 0)
    neighbours[creased] = fv_data[following[values.start[creased]]] + fv_data[preceding[values.end[creased]]]
    crease = 0.75 * data + 0.125 * neighbours

    lead_same, _, _ = _same_across(level, group)
    edge_sharpness = np.where(lead_same, level.edge_sharpness[level.fv_edge], 0.0)  # edges inside spans
    child_edges = _decrement(edge_sharpness)
    point_sharpness = level.corner_sharpness[point]
    child_point = _decrement(point_sharpness)
    semi_edge = (_decrement(level.edge_sharpness) > 0) & (_decrement(level.edge_sharpness) < INFINITELY_SHARP)
    semi_edges_at = np.bincount(level.edge_ends.reshape(-1), weights=np.repeat(semi_edge, 2), minlength=n_points)
    point_stays = (child_point > 0) & (child_point < INFINITELY_SHARP)
    own_stays = point_stays | (np.bincount(group, weights=(child_edges > 0), minlength=n_values) > 0)
    # A dependent value is sharp while its point has semi-sharp edges; it turns with its partner's weight.
    stays = np.where(values.dependent, point_stays | (semi_edges_at[point] > 0), own_stays) & (kind == SEMI)
    weight = _fractional_weight(point_sharpness, child_point, edge_sharpness, child_edges, group, n_values)
    partner = np.maximum(values.partner, 0)
    weight = np.where(values.dependent, weight[partner], weight)[:, None]
    turning = (1.0 - weight) * crease + weight * data

    vertex_data = np.where((kind == MATCH)[:, None], smooth_points[point], data)
    vertex_data = np.where((kind == CREASE)[:, None], crease, vertex_data)
    vertex_data = np.where(((kind == SEMI) & ~stays)[:, None], turning, vertex_data)
    child_kind = np.where((kind == SEMI) & ~stays, CREASE, kind)
    partner_stays = stays[partner] & (values.partner >= 0)
    child_dependent = values.dependent & stays & partner_stays

    # Child values, split as the level splits its faces: a point's values carry on, an edge on a seam (or linear)
    # gets one value per face (the midpoint there), others one, a face point one.
    seam = _seams(level, group)
    split = seam | values.linear
    # Child value ids: the parent's values, then one per face-vertex whose leading edge is split, one per other edge,
    # one per face point.
    lead = level.fv_edge
    uses = np.flatnonzero(split[lead])
    edges = np.flatnonzero(~split)
    use_id = np.full(n, -1)
    use_id[uses] = n_values + np.arange(len(uses))
    edge_id = np.full(n_edges, -1)
    edge_id[edges] = n_values + len(uses) + np.arange(len(edges))
    face_start = n_values + len(uses) + len(edges)
    child_group = level.split(group, np.where(split[lead], use_id, edge_id[lead]),
                              face_start + np.arange(len(level.counts)))
    n_child = face_start + n_faces
    from_use = slice(n_values, n_values + len(uses))
    child_data = np.zeros((n_child, data.shape[1]))
    child_data[:n_values] = vertex_data
    child_data[from_use] = 0.5 * (fv_data[uses] + fv_data[following[uses]])
    child_data[n_values + len(uses):face_start] = smooth_edges[edges]
    child_data[face_start:] = face_points

    kinds = np.full(n_child, MATCH)
    kinds[:n_values] = child_kind
    kinds[from_use] = CREASE if smooth_boundaries else CORNER
    # Crease ends carry on to the refined face-vertices at their points, first of their refined faces; a seam's
    # edge point's span runs from the edge point before the far end's corner to the one after this corner.
    corner = level.corner_children()
    start = np.full(n_child, -1)
    end = np.full(n_child, -1)
    carried = values.start >= 0
    start[:n_values] = np.where(carried, corner[values.start], -1)
    end[:n_values] = np.where(carried, corner[values.end], -1)
    start[from_use] = corner[following[uses]] + level.refined_corners - 1
    end[from_use] = corner[uses] + 1
    dependent = np.zeros(n_child, bool)
    dependent[:n_values] = child_dependent
    partner = np.full(n_child, -1)
    partner[:n_values] = values.partner

    # Linear edges carry on in their halves (from each end to the edge's point; the refined level's edge ends are
    # sorted).
    linear = np.zeros(0 if child_level is None else len(child_level.edge_ends), bool)
    if child_level is not None and values.linear.any():
        middles = n_points + np.flatnonzero(values.linear)
        ends = level.edge_ends[values.linear]
        stride = child_level.n_points
        halves = np.concatenate([ends[:, 0] * stride + middles, ends[:, 1] * stride + middles])
        linear = np.isin(child_level.edge_ends[:, 0] * stride + child_level.edge_ends[:, 1], halves)
    return _Values(child_group, child_data, kinds, start, end, dependent, partner, linear)


def refine_face_varying(levels, data: np.ndarray, value_ids: np.ndarray, mode: str, corner_boundary: bool):
    """Per-face-vertex ``data`` ``(N, k)`` of a mesh's first level through ``levels`` (``subdivision._Level`` or
    ``loop_subdivision._LoopLevel``) -> per face-vertex of the refined faces (float64).

    Args:
        levels: the refinement's steps.
        data: one row per face-vertex of the first level.
        value_ids: ``(N,)`` int: face-vertices of a point with the same id hold the same value (the primvar's indices).
        mode: ``faceVaryingLinearInterpolation``, one of ``FACE_VARYING_MODES`` but ``all``.
        corner_boundary: ``interpolateBoundary = edgeAndCorner`` (boundary points of one face are corners already).
    """
    if not levels:
        return data
    first = levels[0]
    value_ids = np.asarray(value_ids, np.int64)
    keys = first.face_indices * (int(value_ids.max(initial=0)) + 1) + value_ids
    _, at, group = np.unique(keys, return_index=True, return_inverse=True)
    values = _classify(first, group.reshape(-1), data[at], mode, corner_boundary)
    smooth_boundaries = mode not in ("boundaries", "all")
    for i, level in enumerate(levels):
        values = _step(level, values, smooth_boundaries, levels[i + 1] if i + 1 < len(levels) else None)
    return values.data[values.group]


__all__ = ["FACE_VARYING_MODES", "FALLBACK_FACE_VARYING_MODE", "refine_face_varying"]
