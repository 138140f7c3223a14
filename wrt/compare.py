"""Ray-by-ray comparison of two sets of hits (for example ``accel="wrt"`` against ``accel="warp"``).

Two results agree on a ray when both miss, or both hit with ``|t_a - t_b| <= rtol * |t_b| + atol``. Which triangle
was hit is not compared: two triangles can share the nearest point. A hit off the triangle it names
(:func:`off_triangle`, passed as ``wrong``) is a disagreement even at the right ``t``: it names a wrong triangle.

``atol`` is the float32 resolution of the scene's coordinates along the ray: ``COORD_ULPS`` ulps of the largest
coordinate magnitude ``scale``, divided by ``|direction|``. A hit next to the ray origin cannot be located more
finely than the points it is computed from, so below that floor a relative tolerance measures rounding only.

Ties: a ray that passes within ``edge_eps`` (barycentric) of a triangle's edge or vertex, as seen by either result,
is an *exact tie*: the two watertight tests may round it to different sides of the edge, e.g. onto the next triangle
or off a silhouette. Disagreements on such rays are counted separately as ``tie_disagreements``; all other
disagreements are real (``disagreements``), and so are those of a hit off its own triangle (:func:`off_triangle`,
passed as ``wrong``), whatever barycentrics it reports.

Instances: an instance traced in its own space (``accel="wrt"``) and its flattened world-space copy in
``Scene.triangles()`` (``accel="warp"``) are the same triangles rounded differently to float32, by up to a few ulps
of the world coordinates. A ray that meets such a triangle at grazing incidence moves along it by that amount
divided by the cosine of incidence, which can cross an edge far from ``edge_eps``. :func:`near_edge_world` marks
those rays (hit within ``COORD_ULPS`` ulps of ``scale`` / ``|cos|`` of an edge); pass them as ``ties``.
"""

from __future__ import annotations

import numpy as np

EDGE_EPS = 1e-5  # barycentric distance to an edge below which a disagreement counts as a tie
COORD_ULPS = 64  # absolute t tolerance, in float32 ulps of the scene's largest coordinate


def near_edge(hits, edge_eps: float = EDGE_EPS) -> np.ndarray:
    """bool mask of hits whose barycentrics lie within ``edge_eps`` of an edge."""
    w = 1.0 - hits.u - hits.v
    return (hits.prim >= 0) & (np.minimum(np.minimum(w, hits.u), hits.v) < edge_eps)


def near_edge_world(scene, hits, origins, directions, scale: float) -> np.ndarray:
    """bool mask of hits lying within the float32 rounding of the scene's coordinates of an edge of their triangle,
    as seen along the ray: distance to the nearest edge below ``COORD_ULPS`` ulps of ``scale`` divided by the
    cosine of incidence (see the module docstring).

    Args:
        scene: the :class:`wrt.Scene` whose ``triangles()`` rows ``hits.prim`` indexes.
        hits: a :class:`wrt.Hits`.
        origins: ``(N, 3)`` ray origins.
        directions: ``(N, 3)`` ray directions.
        scale: largest coordinate magnitude of the scene.
    """
    out = np.zeros(len(hits.prim), bool)
    h = np.flatnonzero(hits.prim >= 0)
    if len(h) == 0:
        return out
    points, indices = scene.triangles()
    tri = points[indices[hits.prim[h]]].astype(np.float64)
    d = np.asarray(directions, np.float64)[h]
    p = np.asarray(origins, np.float64)[h] + hits.t[h, None].astype(np.float64) * d
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs(np.einsum("ij,ij->i", n, d)) / (np.linalg.norm(n, axis=1) * np.linalg.norm(d, axis=1))
        dist = np.full(len(h), np.inf)
        for a, b in ((0, 1), (1, 2), (2, 0)):
            edge = tri[:, b] - tri[:, a]
            dist = np.minimum(dist, np.linalg.norm(np.cross(edge, p - tri[:, a]), axis=1)
                              / np.linalg.norm(edge, axis=1))
        delta = COORD_ULPS * np.finfo(np.float32).eps * scale
        out[h] = ~(dist * cos >= delta)  # NaN (degenerate triangles) counts as a tie
    return out


OFF_TRIANGLE_RTOL = 1e-4  # a hit farther than this (relative to the coordinates) from its own triangle is wrong


def off_triangle(hits, points, indices, origins, directions, scale: float, edge_eps: float = EDGE_EPS) -> np.ndarray:
    """bool mask of hits that contradict themselves: the point ``origin + t * direction`` is not the point of
    triangle ``prim`` at barycentrics ``(u, v)`` (farther apart than ``OFF_TRIANGLE_RTOL`` of the coordinates'
    magnitude), or those barycentrics lie outside the triangle by more than ``edge_eps``. Such a hit is wrong
    whatever the other answer is; its barycentrics, on an edge or not, make it no tie.

    Args:
        hits: a :class:`wrt.Hits` whose ``prim`` indexes the rows of ``indices``.
        points: ``(V, 3)`` vertices, world space; ``indices``: ``(T, 3)`` triangles (``Scene.triangles()``).
        origins: ``(N, 3)`` ray origins; ``directions``: ``(N, 3)`` ray directions.
        scale: largest coordinate magnitude of the scene.
    """
    out = np.zeros(len(hits.prim), bool)
    h = np.flatnonzero(hits.prim >= 0)
    if len(h) == 0:
        return out
    tri = np.asarray(points, np.float64)[np.asarray(indices)[hits.prim[h]]]
    u, v = hits.u[h].astype(np.float64), hits.v[h].astype(np.float64)
    w = 1.0 - u - v
    on_triangle = w[:, None] * tri[:, 0] + u[:, None] * tri[:, 1] + v[:, None] * tri[:, 2]
    with np.errstate(invalid="ignore", over="ignore"):
        along = np.asarray(origins, np.float64)[h] + hits.t[h, None].astype(np.float64) * np.asarray(
            directions, np.float64)[h]
        apart = np.linalg.norm(along - on_triangle, axis=1)
        near = apart <= OFF_TRIANGLE_RTOL * (scale + np.linalg.norm(along, axis=1))
        inside = np.minimum(np.minimum(w, u), v) >= -edge_eps
    out[h] = ~(near & inside)  # NaN anywhere: off
    return out


def compare_hits(
    a, b, rtol: float = 1e-5, edge_eps: float = EDGE_EPS, directions=None, scale: float = 0.0, ties=None,
    wrong=None
) -> dict:
    """Counts agreement between hit sets ``a`` and ``b`` (see module docstring).

    Args:
        a: hits to check (a :class:`wrt.Hits`).
        b: reference hits for the same rays.
        rtol: relative tolerance on ``t``.
        edge_eps: barycentric distance to an edge that makes a ray an exact tie.
        directions: ``(N, 3)`` ray directions, for the absolute tolerance; none without them.
        scale: largest coordinate magnitude of the scene, for the absolute tolerance.
        ties: optional ``(N,)`` bool mask of further rays to count as exact ties (e.g. :func:`near_edge_world`).
        wrong: optional ``(N,)`` bool mask of rays answered wrongly by ``a`` or ``b`` on their own (e.g.
            :func:`off_triangle`): disagreements whatever their ``t`` (a hit at the right distance naming a triangle
            that does not hold it agreed), never counted as ties, whatever barycentrics they report.

    Returns:
        dict with ``rays``, ``hits_a``, ``hits_b``, ``hit_mismatch`` (one hits, the other misses),
        ``t_mismatch`` (both hit, ``t`` differs beyond ``rtol``), ``tie_disagreements``, ``disagreements``
        (mismatches that are not ties) and ``agreement`` (fraction of rays that agree).

    Raises:
        ValueError: when ``b``, ``directions`` or ``ties`` do not have one entry per ray of ``a``.
    """
    n = len(a.prim)
    # Checked here: numpy would raise an IndexError about boolean masks, or broadcast one tie to every ray.
    for name, array, ndim in (("b", b.prim, 1), ("directions", directions, 2), ("ties", ties, 1),
                              ("wrong", wrong, 1)):
        if array is not None and (np.ndim(array) != ndim or len(array) != n):
            shape = np.shape(array)
            raise ValueError(f"compare_hits: {name} must have one entry per ray of a ({n}), got shape {shape}")
    hit_a, hit_b = a.prim >= 0, b.prim >= 0
    both = hit_a & hit_b
    atol = np.zeros(len(a.t))
    if directions is not None and scale > 0.0:
        # Zero and NaN directions miss (wrt.trace takes them): their inf or NaN tolerance is never read below.
        with np.errstate(divide="ignore", invalid="ignore"):
            atol = (COORD_ULPS * np.finfo(np.float32).eps * scale
                    / np.linalg.norm(np.asarray(directions, np.float64), axis=1))
    t_bad = np.zeros_like(both)
    with np.errstate(invalid="ignore"):
        # Written as "not within tolerance": a NaN t on a hit compares False either way and must count as bad.
        t_bad[both] = ~(np.abs(a.t[both] - b.t[both]) <= rtol * np.abs(b.t[both]) + atol[both])
    mismatch = (hit_a != hit_b) | t_bad
    tie = near_edge(a, edge_eps) | near_edge(b, edge_eps)
    if ties is not None:
        tie = tie | np.asarray(ties, bool)
    if wrong is not None:
        mismatch = mismatch | np.asarray(wrong, bool)
        tie = tie & ~np.asarray(wrong, bool)
    return {
        "rays": int(n),
        "hits_a": int(hit_a.sum()),
        "hits_b": int(hit_b.sum()),
        "hit_mismatch": int((hit_a != hit_b).sum()),
        "t_mismatch": int(t_bad.sum()),
        "tie_disagreements": int((mismatch & tie).sum()),
        "disagreements": int((mismatch & ~tie).sum()),
        "agreement": float(1.0 - mismatch.sum() / max(n, 1)),
    }
