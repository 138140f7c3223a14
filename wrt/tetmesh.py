"""The boundary surface of a tetrahedral mesh (``UsdGeom.TetMesh``), numpy only: the triangles of tetrahedra that no
other tetrahedron shares, as ``UsdGeomTetMesh::ComputeSurfaceFaces`` finds them, vectorised (a sort of the ``4 T``
face keys instead of a hash map).

The UsdGeomTetMesh schema orders each tetrahedron's faces ``[1 2 3], [0 3 2], [0 1 3], [0 2 1]``: counter-clockwise
seen from outside, so their normals point away from the tetrahedron, when ``orientation`` is ``rightHanded`` and the
tetrahedron is not inverted (``(p3 - p0) . ((p1 - p0) x (p2 - p0)) >= 0``; the opposite sign for ``leftHanded``, as
``UsdGeomTetMesh::FindInvertedElements`` tests it).
"""

from __future__ import annotations

import numpy as np

TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])  # a tetrahedron's faces, outward when rightHanded


def surface_faces(tets: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """The faces of ``tets`` ``(T, 4)`` (rows into ``n_points`` points) that belong to one tetrahedron only.

    Returns:
        ``(faces (F, 3) int64, tet (F,) int64)``: each surface triangle, wound as in its tetrahedron, and the
        tetrahedron it belongs to, in tetrahedron order. A face shared by two (or more) tetrahedra, whatever their
        windings, is inside.
    """
    faces = tets[:, TET_FACES].reshape(-1, 3)
    ordered = np.sort(faces, axis=1)
    if n_points < 1 << 21:  # three 21-bit indices in one int64 key
        keys = (ordered[:, 0] << 42) | (ordered[:, 1] << 21) | ordered[:, 2]
    else:
        keys = np.unique(ordered, axis=0, return_inverse=True)[1].reshape(-1)
    order = np.argsort(keys)
    sorted_keys = keys[order]
    new = np.ones(len(keys) + 1, bool)
    new[1:-1] = sorted_keys[1:] != sorted_keys[:-1]
    starts = np.flatnonzero(new)
    single = order[starts[:-1][np.diff(starts) == 1]]
    single.sort()
    return faces[single], single // 4


def inverted(points: np.ndarray, tets: np.ndarray, left_handed: bool) -> np.ndarray:
    """``(T,)`` bool: the tetrahedron's faces point inwards for this orientation (its signed volume, negated for
    leftHanded, is negative)."""
    p = points[tets]
    volume = np.einsum("ij,ij->i", p[:, 3] - p[:, 0], np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
    return (-volume if left_handed else volume) < 0.0


__all__ = ["TET_FACES", "inverted", "surface_faces"]
