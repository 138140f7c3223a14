"""Ray-by-ray comparison of two sets of hits (for example ``accel="wrt"`` against ``accel="warp"``).

Two results agree on a ray when both miss, or both hit with ``|t_a - t_b| <= rtol * |t_b| + atol``. Which triangle
was hit is not compared: two triangles can share the nearest point.

``atol`` is the float32 resolution of the scene's coordinates along the ray: ``COORD_ULPS`` ulps of the largest
coordinate magnitude ``scale``, divided by ``|direction|``. A hit next to the ray origin cannot be located more
finely than the points it is computed from, so below that floor a relative tolerance measures rounding only.

Ties: a ray that passes within ``edge_eps`` (barycentric) of a triangle's edge or vertex, as seen by either result,
is an *exact tie*: the two watertight tests may round it to different sides of the edge, e.g. onto the next triangle
or off a silhouette. Disagreements on such rays are counted separately as ``tie_disagreements``; all other
disagreements are real (``disagreements``).
"""

from __future__ import annotations

import numpy as np

EDGE_EPS = 1e-5  # barycentric distance to an edge below which a disagreement counts as a tie
COORD_ULPS = 64  # absolute t tolerance, in float32 ulps of the scene's largest coordinate


def near_edge(hits, edge_eps: float = EDGE_EPS) -> np.ndarray:
    """bool mask of hits whose barycentrics lie within ``edge_eps`` of an edge."""
    w = 1.0 - hits.u - hits.v
    return (hits.prim >= 0) & (np.minimum(np.minimum(w, hits.u), hits.v) < edge_eps)


def compare_hits(a, b, rtol: float = 1e-5, edge_eps: float = EDGE_EPS, directions=None, scale: float = 0.0) -> dict:
    """Counts agreement between hit sets ``a`` and ``b`` (see module docstring).

    Args:
        a: hits to check (a :class:`wrt.Hits`).
        b: reference hits for the same rays.
        rtol: relative tolerance on ``t``.
        edge_eps: barycentric distance to an edge that makes a ray an exact tie.
        directions: ``(N, 3)`` ray directions, for the absolute tolerance; none without them.
        scale: largest coordinate magnitude of the scene, for the absolute tolerance.

    Returns:
        dict with ``rays``, ``hits_a``, ``hits_b``, ``hit_mismatch`` (one hits, the other misses),
        ``t_mismatch`` (both hit, ``t`` differs beyond ``rtol``), ``tie_disagreements``, ``disagreements``
        (mismatches that are not ties) and ``agreement`` (fraction of rays that agree).
    """
    hit_a, hit_b = a.prim >= 0, b.prim >= 0
    both = hit_a & hit_b
    atol = np.zeros(len(a.t))
    if directions is not None and scale > 0.0:
        atol = COORD_ULPS * np.finfo(np.float32).eps * scale / np.linalg.norm(np.asarray(directions, np.float64), axis=1)
    t_bad = np.zeros_like(both)
    with np.errstate(invalid="ignore"):
        t_bad[both] = np.abs(a.t[both] - b.t[both]) > rtol * np.abs(b.t[both]) + atol[both]
    mismatch = (hit_a != hit_b) | t_bad
    tie = near_edge(a, edge_eps) | near_edge(b, edge_eps)
    n = len(a.prim)
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
