"""A float64 oracle for Catmull-Clark refinement, written point by point from OpenSubdiv's ``Sdc`` rules (the masks
of ``catmarkScheme.h`` and ``scheme.h``, the creasing of ``crease.cpp``, uniform creasing as USD uses it) and the
tagging of ``Far::TopologyRefinerFactory`` and ``Vtr::Level`` (boundary and non-manifold edges infinitely sharp,
non-manifold vertices and, with ``edgeAndCorner``, corners of a single face infinitely sharp; ``none``: the faces at
boundary vertices become holes). Slow and plain on purpose: loops over dicts, nothing shared with
``wrt.subdivision``.

``refine(...)`` returns the refined quads as ``(Q, 4, k)`` corner values in the order OpenSubdiv makes child faces
(for each face, one quad per corner: the corner's vertex, its leading edge, the face, its trailing edge), so results
compare without matching point numbers.
"""

from __future__ import annotations

import numpy as np

INF = 10.0  # Sdc::Crease::SHARPNESS_INFINITE


def decrement(s: float) -> float:
    """Uniform creasing: one less per level, infinite stays infinite."""
    if s >= INF:
        return INF
    return s - 1.0 if s > 1.0 else 0.0


def rule(vertex_sharpness: float, edge_sharpness) -> str:
    """``Crease::DetermineVertexVertexRule``."""
    if vertex_sharpness > 0.0:
        return "corner"
    sharp = sum(1 for s in edge_sharpness if s > 0.0)
    return ["smooth", "dart", "crease"][sharp] if sharp <= 2 else "corner"


def fractional_weight(p_vertex: float, c_vertex: float, p_edges) -> float:
    """``Crease::ComputeFractionalWeightAtVertex`` (uniform creasing)."""
    total, count = 0.0, 0
    if p_vertex > 0.0 and c_vertex <= 0.0:
        total, count = p_vertex, 1
    for s in p_edges:
        if 0.0 < s <= 1.0:
            total += s
            count += 1
    return 0.0 if count == 0 else min(total / count, 1.0)


class Level:
    """Topology of one level: faces, edges (with their faces) and the vertex neighbourhoods."""

    def __init__(self, faces, n_points):
        self.faces = [tuple(f) for f in faces]
        self.n_points = n_points
        self.edges = []  # (a, b) as first met
        self.edge_faces = []  # faces of each edge, repeats kept
        self.non_manifold_edge = []
        self.face_edges = []
        by_key = {}
        for fi, f in enumerate(self.faces):
            row = []
            for i, a in enumerate(f):
                b = f[(i + 1) % len(f)]
                e = by_key.get((min(a, b), max(a, b))) if a != b else None
                nm = a == b  # a degenerate edge is its own non-manifold edge
                if e is not None:
                    if self.edge_faces[e][-1] == fi:  # the edge twice in one face: a new non-manifold edge
                        self.non_manifold_edge[e] = True
                        e, nm = None, True
                    elif len(self.edge_faces[e]) > 1 or self.edges[e][0] == a:  # 3rd face, or the same direction
                        self.non_manifold_edge[e] = True
                if e is None:
                    e = len(self.edges)
                    self.edges.append((a, b))
                    self.edge_faces.append([])
                    self.non_manifold_edge.append(nm)
                    if a != b:
                        by_key.setdefault((min(a, b), max(a, b)), e)
                self.edge_faces[e].append(fi)
                row.append(e)
            self.face_edges.append(row)
        self.vertex_edges = [[] for _ in range(n_points)]
        self.vertex_faces = [[] for _ in range(n_points)]
        for e, (a, b) in enumerate(self.edges):
            self.vertex_edges[a].append(e)
            if b != a:
                self.vertex_edges[b].append(e)
        for fi, f in enumerate(self.faces):
            for v in f:
                self.vertex_faces[v].append(fi)

    def other_end(self, e, v):
        a, b = self.edges[e]
        return b if a == v else a

    def is_manifold_vertex(self, v) -> bool:
        """``Level::orderVertexFacesAndEdges`` succeeds: one fan of faces, closed or with two boundary edges."""
        edges, faces = self.vertex_edges[v], self.vertex_faces[v]
        if not faces or len(edges) < 2 or any(self.non_manifold_edge[e] for e in edges):
            return False
        if len(set(faces)) != len(faces):
            return False
        boundary = [e for e in edges if len(self.edge_faces[e]) == 1]
        if not ((len(edges) == len(faces) and not boundary) or (len(edges) == len(faces) + 1 and len(boundary) == 2)):
            return False
        # Connected through the interior edges at v.
        seen, stack = {faces[0]}, [faces[0]]
        while stack:
            f = stack.pop()
            for e in edges:
                ef = self.edge_faces[e]
                if len(ef) == 2 and f in ef:
                    g = ef[0] if ef[1] == f else ef[1]
                    if g not in seen:
                        seen.add(g)
                        stack.append(g)
        return len(seen) == len(faces)


def base_tags(level: Level, creases: dict, corners: dict, boundary: str):
    """Edge and vertex sharpness of the base level and its hole faces, as ``prepareComponentTagsAndSharpness``."""
    edge_s = [0.0] * len(level.edges)
    for e, (a, b) in enumerate(level.edges):
        edge_s[e] = float(creases.get((min(a, b), max(a, b)), 0.0))
    holes = set()
    if boundary == "none":
        for v in range(level.n_points):
            edges = level.vertex_edges[v]
            if len(edges) == len(level.vertex_faces[v]) and level.is_manifold_vertex(v):
                continue
            if any(len(level.edge_faces[e]) == 1 and edge_s[e] < INF for e in edges):
                holes.update(level.vertex_faces[v])
    for e in range(len(level.edges)):
        if len(level.edge_faces[e]) < 2 or level.non_manifold_edge[e]:
            edge_s[e] = INF
    vert_s = [float(corners.get(v, 0.0)) for v in range(level.n_points)]
    for v in range(level.n_points):
        edges, faces = level.vertex_edges[v], level.vertex_faces[v]
        if len(faces) == 1 and len(edges) == 2 and boundary == "edgeAndCorner":
            vert_s[v] = INF
        elif not level.is_manifold_vertex(v):
            nm_edges = sum(level.non_manifold_edge[e] for e in edges)
            boundary_edges = sum(len(level.edge_faces[e]) == 1 for e in edges)
            if not (nm_edges == 2 and boundary_edges == 0 and len(faces) > len(edges)):
                vert_s[v] = INF
    return edge_s, vert_s, holes


def _crease_pair(level, v, edge_s):
    """The other ends of the first two sharp edges at ``v`` (``GetSharpEdgePairOfCrease``)."""
    ends = [level.other_end(e, v) for e in level.vertex_edges[v] if edge_s[e] > 0.0]
    return ends[:2]


def _vertex_mask(kind, level, v, p, face_points, edge_s):
    if kind == "corner":
        return p[v]
    if kind == "crease":
        a, b = _crease_pair(level, v, edge_s)
        return 0.75 * p[v] + 0.125 * (p[a] + p[b])
    n = len(level.vertex_faces[v])
    ring = sum(p[level.other_end(e, v)] for e in level.vertex_edges[v])
    centres = sum(face_points[f] for f in level.vertex_faces[v])
    return (n - 2.0) / n * p[v] + (ring + centres) / (n * n)



def blended_vertex_points(level, p, edge_s, vert_s, mask) -> list:
    """Each point's vertex point: ``mask(kind, v, edge sharpness)`` of its rule (smooth, dart, crease, corner), and
    where the rule after this step differs, the two blended by OpenSubdiv's fractional weight (the same in every
    scheme; ``mask`` is the scheme's)."""
    vertex_points = []
    for v in range(level.n_points):
        edges = level.vertex_edges[v]
        if not level.vertex_faces[v]:
            vertex_points.append(p[v])
            continue
        p_edges = [edge_s[e] for e in edges]
        p_rule = rule(vert_s[v], p_edges)
        parent = mask(p_rule, v, edge_s)
        if p_rule in ("smooth", "dart"):
            vertex_points.append(parent)
            continue
        c_vertex = decrement(vert_s[v])
        c_edge_s = {e: decrement(edge_s[e]) for e in edges}
        c_rule = rule(c_vertex, c_edge_s.values())
        if c_rule == p_rule:
            vertex_points.append(parent)
            continue
        child_s = list(edge_s)
        for e, s in c_edge_s.items():
            child_s[e] = s
        child = mask(c_rule, v, child_s)
        w = fractional_weight(vert_s[v], c_vertex, p_edges)
        vertex_points.append(w * parent + (1.0 - w) * child)
    return vertex_points


def child_sharpness(level, child, edge_s, vert_s, new_points: int):
    """``(edge sharpness, point sharpness)`` of the ``child`` level: each half of a sharp edge one less sharp (its
    point at index ``n + e``), boundary edges infinitely sharp, points one less sharp and ``new_points`` new ones
    smooth."""
    n = level.n_points
    halves = {}
    for e, (a, b) in enumerate(level.edges):
        s = decrement(edge_s[e])
        if s > 0.0:
            halves[(min(a, n + e), max(a, n + e))] = s
            halves[(min(b, n + e), max(b, n + e))] = s
    c_edge = [halves.get((min(a, b), max(a, b)), 0.0) for a, b in child.edges]
    for e in range(len(child.edges)):
        if len(child.edge_faces[e]) < 2:
            c_edge[e] = INF
    return c_edge, [decrement(s) for s in vert_s] + [0.0] * new_points

def refine_once(level: Level, p: np.ndarray, edge_s, vert_s, triangle_smooth=False, linear=False):
    """One level: the child level, its points and sharpness (``linear``: the bilinear masks, as ``varying``
    primvars refine: points stay, edge points are midpoints)."""
    face_points = [np.mean([p[v] for v in f], axis=0) for f in level.faces]
    if linear:
        edge_s = [INF] * len(level.edges)
        vert_s = [INF] * level.n_points

    edge_points = []
    for e, (a, b) in enumerate(level.edges):
        faces = level.edge_faces[e]
        mid = 0.5 * (p[a] + p[b])
        s = edge_s[e]
        if s >= 1.0:
            edge_points.append(mid)
            continue
        if len(faces) == 2 and triangle_smooth and any(len(level.faces[f]) == 3 for f in faces):
            fw = 0.5 * sum(0.470 if len(level.faces[f]) == 3 else 0.25 for f in faces)
            smooth = 0.5 * (1.0 - 2.0 * fw) * (p[a] + p[b]) + fw * (face_points[faces[0]] + face_points[faces[1]])
        else:
            smooth = 0.25 * (p[a] + p[b]) + 0.5 / len(faces) * sum(face_points[f] for f in faces)
        edge_points.append(s * mid + (1.0 - s) * smooth)

    vertex_points = blended_vertex_points(
        level, p, edge_s, vert_s, lambda kind, v, sharpness: _vertex_mask(kind, level, v, p, face_points, sharpness))

    # Child topology, points and sharpness.
    n, ne = level.n_points, len(level.edges)
    points = np.array(vertex_points + edge_points + face_points)
    faces = []
    for fi, f in enumerate(level.faces):
        fe = level.face_edges[fi]
        for i, v in enumerate(f):
            faces.append((v, n + fe[i], n + ne + fi, n + fe[i - 1]))
    child = Level(faces, len(points))
    c_edge, c_vert = child_sharpness(level, child, edge_s, vert_s, ne + len(level.faces))
    return child, points, c_edge, c_vert


def refine(faces, points, levels, creases=None, corners=None, boundary="edgeAndCorner", triangle_smooth=False,
           linear=False):
    """``levels`` steps of the mesh ``faces`` (lists of point indices) over ``points`` ``(V, k)``.

    Args:
        creases: ``{(a, b) with a < b: sharpness}``.
        corners: ``{point: sharpness}``.
        boundary: ``interpolateBoundary``.
        triangle_smooth: ``triangleSubdivisionRule = smooth``.
        linear: bilinear refinement (``varying`` primvars).

    Returns:
        ``(quads (Q, 4, k) float64, parent face of each quad (Q,), base faces that are holes)``.
    """
    return refine_levels(faces, points, levels, creases, corners, boundary, len,
                         lambda *state: refine_once(*state, triangle_smooth, linear))


def refine_levels(faces, points, levels, creases, corners, boundary, children, step):
    """``levels`` steps ``step(level, points, edge sharpness, point sharpness)`` (returning the same four for the
    child level) of the mesh ``faces`` over ``points``, each face becoming ``children(face)`` faces in its order.

    Returns:
        ``(faces (F, n, k) float64 corner values, parent face of each (F,), base faces that are holes)``.
    """
    level = Level(faces, len(points))
    edge_s, vert_s, holes = base_tags(level, creases or {}, corners or {}, boundary)
    p = np.asarray(points, np.float64)
    parent = list(range(len(level.faces)))
    for _ in range(levels):
        counts = [children(f) for f in level.faces]
        level, p, edge_s, vert_s = step(level, p, edge_s, vert_s)
        parent = [parent[f] for f, c in enumerate(counts) for _ in range(c)]
    return np.array([[p[v] for v in f] for f in level.faces]), np.array(parent), holes
