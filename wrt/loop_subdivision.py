"""Loop refinement of triangle meshes (``subdivisionScheme = "loop"``), for ``load_usd(..., refine_level=N)``.

Each level splits every triangle into four over its edge points (Loop 1987, "Smooth subdivision surfaces based on
triangles") and moves the points by the masks OpenSubdiv's ``Sdc::Scheme<SCHEME_LOOP>`` uses:

- an edge point is ``3/8 (a + b) + 1/8 (c + d)`` (its ends ``a``, ``b``; ``c``, ``d`` the far corners of its two
  triangles), or the midpoint on a sharp edge (a boundary edge, an edge of more than two faces, a crease of
  sharpness >= 1), blended by the sharpness of a semi-sharp crease;
- a vertex point is ``(1 - n beta) S + beta sum(ring)`` with Loop's ``beta = (5/8 - (3/8 + 1/4 cos(2 pi / n))^2) / n``
  over its ``n`` neighbours for a smooth point or a dart, ``3/4 S + 1/8 (a + b)`` on a crease or boundary, ``S`` at a
  corner.

Everything but these masks and the split is the scheme-independent part of :mod:`wrt.subdivision`, shared with
Catmull-Clark: crease and corner sharpness (dropping by one per level, the rules before and after blended where
semi-sharp features run out), ``interpolateBoundary`` (``edgeAndCorner``, ``edgeOnly``, ``none``), non-manifold parts
made infinitely sharp, lonely points kept, ``varying`` data interpolated linearly, and face-varying data per
``faceVaryingLinearInterpolation`` (:mod:`wrt.subdivision_fvar`: Loop's masks away from seams, the same seam and
boundary rules; ``all`` linear in each triangle), as OpenSubdiv applies the modes to Loop meshes.
OpenSubdiv refuses a Loop mesh with faces of more than three corners ("non-triangular faces not supported by Loop
scheme", ``Far::TopologyRefinerFactory``); so does :class:`LoopRefinement`.
"""

from __future__ import annotations

import numpy as np

from .subdivision import Refinement, _Level, _sum_by


def loop_beta(valence: np.ndarray) -> np.ndarray:
    """Loop's weight of each neighbour of a smooth point of ``valence`` neighbours (1/16 at 6, 3/16 at 3)."""
    n = np.maximum(np.asarray(valence, np.float64), 1.0)
    return (0.625 - (0.375 + 0.25 * np.cos(2.0 * np.pi / n)) ** 2) / n


def refined_triangles(counts, levels: int) -> int:
    """Triangles that ``levels`` Loop steps make of the triangles among faces of ``counts`` corners (4 per triangle
    per step): known before refining, for the memory check."""
    return int((np.asarray(counts) == 3).sum()) * 4**levels


class _LoopLevel(_Level):
    """One Loop step of a triangle mesh: points first, then one point per edge; no face points."""

    refined_corners = 3  # corners of each refined face

    @property
    def refined_points(self) -> int:
        return self.n_points + len(self.edge_ends)

    def split(self, at_point: np.ndarray, at_lead: np.ndarray, at_face=None) -> np.ndarray:
        """What each refined face-vertex holds, in ``topology``'s order, from what each face-vertex's point holds
        (``at_point`` ``(N, ...)``) and its leading edge's point (``at_lead`` ``(N, ...)``); no face points
        (``at_face`` unused): four triangles per triangle, one at each corner (the corner, its leading edge's point,
        its trailing edge's point), then the middle one."""
        corners = np.stack([at_point, at_lead, at_lead[self.preceding]], axis=1)
        corners = corners.reshape(-1, 3, *corners.shape[1:])
        middle = at_lead.reshape(-1, 1, 3, *at_lead.shape[1:])
        triangles = np.concatenate([corners, middle], axis=1)
        return triangles.reshape(-1, *triangles.shape[3:])

    def topology(self):
        """``(counts, face_indices, parent face)`` of the refined triangles, four per triangle in its winding
        (``split``)."""
        triangles = self.split(self.face_indices, self.n_points + self.fv_edge)
        return np.full(4 * len(self.counts), 3, np.int64), triangles, np.repeat(np.arange(len(self.counts)), 4)

    def vertex(self, data: np.ndarray, edge_values=None, corner_values=None) -> np.ndarray:
        """Per-point ``data`` ``(V, k)`` of the refined mesh by Loop's masks: vertex points, then edge points.

        A face-varying channel (``wrt.subdivision_fvar``) passes the values at each edge's ends ``(E, 2, k)`` and at
        each face-vertex ``(N, k)`` (an edge's far corners are those of its triangles), as its points may hold
        several; by default both are ``data``'s."""
        if edge_values is None:
            edge_values = data[self.edge_ends]
        if corner_values is None:
            corner_values = data[self.face_indices]
        midpoint = 0.5 * (edge_values[:, 0] + edge_values[:, 1])
        far_corners = _sum_by(self.fv_edge, corner_values[self.preceding], len(self.edge_ends))
        smooth_edge = 0.75 * midpoint + 0.25 * far_corners / np.maximum(self.edge_faces, 1)[:, None]
        ends = self.edge_ends.reshape(-1)
        ring = _sum_by(ends, edge_values[:, ::-1].reshape(-1, data.shape[1]), self.n_points)
        beta = loop_beta(self.valence)[:, None]
        smooth = (1.0 - self.valence[:, None] * beta) * data + beta * ring
        vertex_points = self.vertex_points(data, smooth, edge_values)
        return np.concatenate([vertex_points, self.edge_points(midpoint, smooth_edge)])

    def linear(self, data: np.ndarray) -> np.ndarray:
        """Per-point ``data`` interpolated linearly (``varying`` primvars): points kept, edge points the midpoints."""
        return np.concatenate([data, self._midpoints(data)])

    def face_varying(self, data: np.ndarray) -> np.ndarray:
        """Per-face-vertex ``data`` ``(N, k)`` of the refined triangles, interpolated linearly within each triangle."""
        return self.split(data, 0.5 * (data + data[self.following]))


class LoopRefinement(Refinement):
    """``levels`` Loop steps of a triangle mesh: its refined triangles and maps for per-point, per-face-vertex and
    per-face data, with the arguments of :class:`wrt.subdivision.Refinement` (``triangleSubdivisionRule`` is
    Catmull-Clark's only), ``face_varying`` included.

    Raises:
        ValueError: a face of more than three corners (OpenSubdiv refuses those for Loop), or creases or corners
            that do not fit the mesh.
    """

    _level_type = _LoopLevel

    def __init__(self, counts, face_indices, n_points, levels, creases=None, corners=None, boundary="edgeAndCorner",
                 face_varying="cornersPlus1"):
        counts = np.asarray(counts, np.int64)
        if (counts > 3).any():
            raise ValueError(f"{int((counts > 3).sum())} of {len(counts)} faces have more than three corners; Loop "
                             "subdivision takes triangles only")
        super().__init__(counts, face_indices, n_points, levels, creases, corners, boundary, face_varying=face_varying)


__all__ = ["LoopRefinement", "loop_beta", "refined_triangles"]
