"""A float64 oracle for Loop refinement, written point by point from the published masks (Loop 1987; OpenSubdiv's
``loopScheme.h``): an edge point ``3/8 (a + b) + 1/8 (c + d)`` (``c``, ``d`` the far corners of its two triangles),
the midpoint on a sharp edge; a smooth vertex point ``(1 - n beta) S + beta sum(ring)``,
``beta = (5/8 - (3/8 + 1/4 cos(2 pi / n))^2) / n``; a crease or boundary vertex point ``1/8 a + 3/4 S + 1/8 b``; a
corner stays. Tagging and creasing (boundary and non-manifold sharpness, ``interpolateBoundary``, semi-sharp blends)
are scheme-independent in OpenSubdiv and come from ``catmark_reference``'s plain loops; nothing is shared with
``wrt``.

``refine(...)`` returns the refined triangles as ``(T, 3, k)`` corner values, for each face one triangle per corner
(the corner, its leading edge's point, its trailing edge's point) then the middle one (the edge points in order).
"""

from __future__ import annotations

import math

import numpy as np
from catmark_reference import INF, Level, _crease_pair, blended_vertex_points, child_sharpness, refine_levels


def beta(n: int) -> float:
    """Loop's neighbour weight at a smooth point of valence ``n``."""
    return (5.0 / 8.0 - (3.0 / 8.0 + 0.25 * math.cos(2.0 * math.pi / n)) ** 2) / n


def _vertex_mask(kind, level, v, p, edge_s):
    if kind == "corner":
        return p[v]
    if kind == "crease":
        a, b = _crease_pair(level, v, edge_s)
        return 0.125 * p[a] + 0.75 * p[v] + 0.125 * p[b]
    n = len(level.vertex_faces[v])
    ring = sum(p[level.other_end(e, v)] for e in level.vertex_edges[v])
    return (1.0 - n * beta(n)) * p[v] + beta(n) * ring


def refine_once(level: Level, p: np.ndarray, edge_s, vert_s, linear=False):
    """One Loop level: the child level, its points and sharpness (``linear``: points kept, midpoints on edges)."""
    if linear:
        edge_s = [INF] * len(level.edges)
        vert_s = [INF] * level.n_points
    edge_points = []
    for e, (a, b) in enumerate(level.edges):
        faces = level.edge_faces[e]
        mid = 0.5 * (p[a] + p[b])
        far = [next(v for v in level.faces[f] if v not in (a, b)) for f in faces if len(set(level.faces[f])) == 3]
        if edge_s[e] >= 1.0 or len(far) != len(faces):
            edge_points.append(mid)
            continue
        smooth = 0.375 * (p[a] + p[b]) + 0.125 * (2.0 / len(faces)) * sum(p[c] for c in far)
        s = edge_s[e]
        edge_points.append(s * mid + (1.0 - s) * smooth)

    vertex_points = blended_vertex_points(
        level, p, edge_s, vert_s, lambda kind, v, sharpness: _vertex_mask(kind, level, v, p, sharpness))

    n = level.n_points
    points = np.array(vertex_points + edge_points)
    faces = []
    for fi, f in enumerate(level.faces):
        fe = level.face_edges[fi]
        for i, v in enumerate(f):
            faces.append((v, n + fe[i], n + fe[i - 1]))
        faces.append(tuple(n + e for e in fe))
    child = Level(faces, len(points))
    c_edge, c_vert = child_sharpness(level, child, edge_s, vert_s, len(level.edges))
    return child, points, c_edge, c_vert


def refine(faces, points, levels, creases=None, corners=None, boundary="edgeAndCorner", linear=False):
    """``levels`` Loop steps of the triangles ``faces`` over ``points`` ``(V, k)``.

    Args:
        creases: ``{(a, b) with a < b: sharpness}``.
        corners: ``{point: sharpness}``.
        boundary: ``interpolateBoundary``.
        linear: linear refinement (``varying`` primvars).

    Returns:
        ``(triangles (T, 3, k) float64, parent face of each triangle (T,), base faces that are holes)``.
    """
    return refine_levels(faces, points, levels, creases, corners, boundary, lambda face: 4,
                         lambda *state: refine_once(*state, linear))
