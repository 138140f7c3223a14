"""A float64 oracle for face-varying data through Catmull-Clark or Loop refinement, written corner by corner from
OpenSubdiv's face-varying rules (``Vtr::FVarLevel::completeTopologyFromFaceValues`` and ``gatherValueSpans``, the masks
of ``Far::PrimvarRefiner::interpFVarFrom{Faces,Edges,Verts}``, ``Sdc::Crease::ComputeFractionalWeightAtVertex``) and the
mode descriptions of USD's ``faceVaryingLinearInterpolation``. Slow and plain on purpose: it walks the faces around each
point in order and classifies every level afresh but for dependent sharpness, which it hands down (OpenSubdiv classifies
the base level and hands all tags down; they agree on manifold meshes without semi-sharp seam edges), and shares nothing
with ``wrt.subdivision_fvar``.

Geometry (sharpness, rules, the child topology) comes from ``catmark_reference`` (``loop_reference`` for Loop, whose
masks apply to values that match their point, the far corners of an edge's triangles as each triangle holds them;
the seam and boundary rules are the same). ``refine_face_varying(...)`` returns the refined faces' corner values
``(Q, 4, k)`` in ``catmark_reference.refine``'s quad order (``(T, 3, k)`` in ``loop_reference.refine``'s triangle
order for Loop).
"""

from __future__ import annotations

import loop_reference
import numpy as np
from catmark_reference import INF, Level, _vertex_mask, base_tags, decrement, fractional_weight, refine_once, rule


def curve(values, levels, linear):
    """A polyline's points after ``levels`` steps of the boundary-curve rule with pinned ends (``(6 v + a + b) / 8``
    at points, midpoints on segments), or of linear interpolation."""
    values = np.asarray(values, np.float64)
    for _ in range(levels):
        middles = 0.5 * (values[1:] + values[:-1])
        points = values.copy()
        if not linear:
            points[1:-1] = 0.75 * values[1:-1] + 0.125 * (values[2:] + values[:-2])
        values = np.empty((2 * len(points) - 1, points.shape[1]))
        values[0::2], values[1::2] = points, middles
    return values


def _ordered_corners(level: Level, v: int):
    """The corners ``(face, i)`` at ``v`` in order (each across the previous one's trailing edge ``(f[i-1], v)``),
    starting, on a boundary, at the one whose leading edge ``(v, f[i+1])`` is a boundary edge; None if ``v`` is not
    manifold."""
    if not level.vertex_faces[v] or not level.is_manifold_vertex(v):
        return None
    corners = [(f, level.faces[f].index(v)) for f in set(level.vertex_faces[v])]
    lead = {c: level.face_edges[c[0]][c[1]] for c in corners}
    trail = {c: level.face_edges[c[0]][c[1] - 1] for c in corners}
    start = next((c for c in corners if len(level.edge_faces[lead[c]]) == 1), corners[0])
    order = [start]
    while True:
        e = trail[order[-1]]
        if len(level.edge_faces[e]) != 2:
            break
        nxt = next(c for c in corners if lead[c] == e and c != order[-1])
        if nxt == start:
            break
        order.append(nxt)
    return order


def _seam_edges(level: Level, values) -> set:
    """Edges whose faces disagree on the value at either end."""
    seams = set()
    for e, (a, b) in enumerate(level.edges):
        seen = set()
        for f in level.edge_faces[e]:
            face = level.faces[f]
            seen.add((values[f][face.index(a)], values[f][face.index(b)]))
        if len(seen) > 1:
            seams.add(e)
    return seams


def classify(level: Level, values, edge_s, vert_s, mode: str, boundary: str, may_depend=None):
    """Per ``(point, value)``: ``(tag, span corners, interior edges)``, tag one of match, corner, crease, semi, dep
    (semi by dependency on the point's other value, named fourth). Dependency is decided on the base level
    (``may_depend`` None); on later ones only the values in ``may_depend`` keep it, as OpenSubdiv hands it down."""
    seams = _seam_edges(level, values)
    linear_boundaries = mode in ("boundaries", "all")
    dependent = mode in ("cornersPlus1", "cornersPlus2")
    corners_sharp = mode != "none"
    sharpen_darts = mode in ("cornersPlus2", "boundaries", "all")
    tags = {}
    for v in range(level.n_points):
        corners = _ordered_corners(level, v)
        if not level.vertex_faces[v]:
            continue
        on_boundary = any(len(level.edge_faces[e]) == 1 for e in level.vertex_edges[v])
        at_v = [values[f][level.faces[f].index(v)] for f in level.vertex_faces[v]]
        distinct = sorted(set(at_v), key=repr)
        split = any(e in seams for e in level.vertex_edges[v]) or len(distinct) > 1
        if on_boundary and linear_boundaries:
            split = True
        if on_boundary and len(level.vertex_faces[v]) == 1 and corners_sharp and boundary != "edgeAndCorner":
            split = True
        if not split:
            tags[(v, distinct[0])] = ("match", None, [])
            continue
        all_corners = (linear_boundaries or vert_s[v] >= INF or corners is None
                       or (dependent and len(distinct) > 2) or (sharpen_darts and len(distinct) == 1
                                                                 and not on_boundary))
        if corners is None:
            for x in distinct:
                tags[(v, x)] = ("corner", None, [])
            continue

        # Spans: runs of consecutive corners holding one value; the edge between corners k and k + 1 is corner k's
        # trailing edge, and on an interior point the last corner's trailing edge closes the ring.
        n = len(corners)
        vals = [values[f][i] for f, i in corners]
        between = [level.face_edges[f][i - 1] for f, i in corners]  # edge after corner k
        spans = {}
        for x in distinct:
            ks = [k for k in range(n) if vals[k] == x]
            inner = [k for k in range(n) if vals[k] == x and (k + 1 < n or not on_boundary)
                     and vals[(k + 1) % n] == x]
            seam_inner = [k for k in inner if between[k] in seams]
            if len(ks) == n and not on_boundary:  # a dart: the span starts after its seam
                disjoint = len(seam_inner) > 1
                first = (seam_inner[0] + 1) % n if seam_inner else 0
                run = [(first + j) % n for j in range(n)]
                interior = [between[k] for k in run[:-1]]
            else:
                runs = len(ks) - len(inner)
                disjoint = bool(seam_inner) or runs > 1
                first = next(k for k in ks if vals[k - 1] != x or (k == 0 and on_boundary))
                run = [(first + j) % n for j in range(len(ks))]
                interior = [between[k] for k in run[:-1]]
            infinite = any(edge_s[e] >= INF for e in interior if e not in seams)
            semi = any(0 < edge_s[e] < INF for e in interior if e not in seams)
            spans[x] = dict(size=len(ks), disjoint=disjoint, infinite=infinite, semi=semi, run=run,
                            interior=interior)
        depends = False
        if not all_corners and dependent and len(distinct) == 2:
            a, b = (spans[x] for x in distinct)
            all_corners = a["disjoint"] or b["disjoint"] or a["infinite"] or b["infinite"]
            if mode == "cornersPlus2":
                all_corners |= a["size"] == 1 or b["size"] == 1
            depends = a["semi"] != b["semi"]
        for x in distinct:
            span = spans[x]
            run = [corners[k] for k in span["run"]]
            if span["disjoint"] or all_corners or span["infinite"] or (span["size"] == 1 and corners_sharp):
                tags[(v, x)] = ("corner", run, span["interior"])
            elif span["semi"] or 0 < vert_s[v] < INF:
                tags[(v, x)] = ("semi", run, span["interior"])
            elif depends and (may_depend is None or x in may_depend):
                partner = next(y for y in distinct if y != x)
                tags[(v, x)] = ("dep", run, span["interior"], partner)
            else:
                tags[(v, x)] = ("crease", run, span["interior"])
    return tags, seams


def _geometric_vertex(level, v, value, values, data, face_values, edge_s, vert_s, loop=False):
    """The point's own mask (rules and blending as ``catmark_reference.refine_once``, Loop's masks with ``loop``) on
    face-varying values that match it: each neighbour's value seen from a face at ``v``."""

    def mask(kind, p, edge_s):
        if loop:
            return loop_reference._vertex_mask(kind, level, v, p, edge_s)
        return _vertex_mask(kind, level, v, p, face_values, edge_s)

    p = np.zeros((level.n_points, data.shape[1]))
    p[v] = data[value]
    for f in level.vertex_faces[v]:
        face = level.faces[f]
        for w in face:
            p[w] = data[values[f][face.index(w)]]
    p_edges = [edge_s[e] for e in level.vertex_edges[v]]
    p_rule = rule(vert_s[v], p_edges)
    parent = mask(p_rule, p, edge_s)
    if p_rule in ("smooth", "dart"):
        return parent
    c_edge_s = list(edge_s)
    for e in level.vertex_edges[v]:
        c_edge_s[e] = decrement(edge_s[e])
    c_rule = rule(decrement(vert_s[v]), [c_edge_s[e] for e in level.vertex_edges[v]])
    if c_rule == p_rule:
        return parent
    child = mask(c_rule, p, c_edge_s)
    w = fractional_weight(vert_s[v], decrement(vert_s[v]), p_edges)
    return w * parent + (1.0 - w) * child


def refine_face_varying(faces, data, value_ids, levels, mode="cornersPlus1", creases=None, corners=None,
                        boundary="edgeAndCorner", triangle_smooth=False, scheme="catmullClark"):
    """``levels`` steps of face-varying ``data`` (one row per face-vertex, in face order) on the mesh ``faces``.

    Args:
        value_ids: per face-vertex: face-vertices of a point with the same id hold the same value.
        mode: ``faceVaryingLinearInterpolation``; ``all`` interpolates linearly in each face.
        creases, corners, boundary, triangle_smooth: as ``catmark_reference.refine``.
        scheme: ``catmullClark`` or ``loop`` (triangles; ``triangle_smooth`` does not apply).

    Returns:
        ``(Q, 4, k)`` values at the refined quads' corners, ``(T, 3, k)`` at the refined triangles' for Loop.
    """
    loop = scheme == "loop"
    n_points = max(v for f in faces for v in f) + 1
    level = Level(faces, n_points)
    edge_s, vert_s, _ = base_tags(level, creases or {}, corners or {}, boundary)
    data = np.asarray(data, np.float64)
    # Values by key; each face corner names its value.
    store, values, at = {}, [], 0
    for face in faces:
        row = []
        for v in face:
            key = ("base", v, int(value_ids[at]))
            store.setdefault(key, data[at])
            row.append(key)
            at += 1
        values.append(row)

    may_depend = None
    for _ in range(levels):
        dummy = np.zeros((level.n_points, 1))
        if loop:
            child, _, c_edge, c_vert = loop_reference.refine_once(level, dummy, edge_s, vert_s)
        else:
            child, _, c_edge, c_vert = refine_once(level, dummy, edge_s, vert_s, triangle_smooth)
        tags, seams = classify(level, values, edge_s, vert_s, mode, boundary, may_depend)
        linear_edges = set(seams)
        if mode in ("boundaries", "all"):
            linear_edges |= {e for e in range(len(level.edges)) if len(level.edge_faces[e]) == 1}

        # Child keys: a point's values carry on, an edge on a seam (or linear) gets one value per face.
        def edge_key(e, f):
            return ("edge", e, f) if e in linear_edges else ("edge", e)

        c_values = []
        for fi, face in enumerate(level.faces):
            fe = level.face_edges[fi]
            for i, v in enumerate(face):
                if loop:  # a triangle at each corner, then the middle one
                    c_values.append([("vert", values[fi][i]), edge_key(fe[i], fi), edge_key(fe[i - 1], fi)])
                else:
                    c_values.append([("vert", values[fi][i]), edge_key(fe[i], fi), ("face", fi),
                                     edge_key(fe[i - 1], fi)])
            if loop:
                c_values.append([edge_key(e, fi) for e in fe])
        dependents = {("vert", key[1]) for key, tag in tags.items() if tag[0] == "dep"}
        c_tags, _ = classify(child, c_values, c_edge, c_vert, mode, boundary, dependents)

        new = {}
        face_values = [np.mean([store[x] for x in values[fi]], axis=0) for fi in range(len(level.faces))]
        for fi in range(len(level.faces)):
            new[("face", fi)] = face_values[fi]
        for e, (a, b) in enumerate(level.edges):
            ef = level.edge_faces[e]
            if e in linear_edges or mode == "all":
                for f in ef:
                    face = level.faces[f]
                    mid = 0.5 * (store[values[f][face.index(a)]] + store[values[f][face.index(b)]])
                    new[edge_key(e, f)] = mid
                continue
            face = level.faces[ef[0]]
            va, vb = store[values[ef[0]][face.index(a)]], store[values[ef[0]][face.index(b)]]
            mid = 0.5 * (va + vb)
            s = edge_s[e]
            if s >= 1.0:
                new[("edge", e)] = mid
                continue
            if loop:  # 3/8 (a + b) + 1/8 (c + d): the far corner of each triangle, as that triangle holds it
                far = [store[values[f][i]] for f in ef for i, w in enumerate(level.faces[f]) if w not in (a, b)]
                smooth = 0.75 * mid + 0.25 / len(ef) * sum(far)
            elif len(ef) == 2 and triangle_smooth and any(len(level.faces[f]) == 3 for f in ef):
                fw = 0.5 * sum(0.470 if len(level.faces[f]) == 3 else 0.25 for f in ef)
                smooth = (1.0 - 2.0 * fw) * mid + fw * (face_values[ef[0]] + face_values[ef[1]])
            else:
                smooth = 0.5 * mid + 0.5 / len(ef) * sum(face_values[f] for f in ef)
            new[("edge", e)] = s * mid + (1.0 - s) * smooth

        keys = {k for row in values for k in row}
        ordered = sorted(keys, key=repr)
        index = {k: i for i, k in enumerate(ordered)}
        dense = np.array([store[k] for k in ordered])
        int_values = [[index[k] for k in row] for row in values]
        point_of = {k: level.faces[f][i] for f, row in enumerate(values) for i, k in enumerate(row)}
        for key in ordered:
            v = point_of[key]
            tag = tags[(v, key)]
            value = store[key]
            if mode == "all":
                new[("vert", key)] = value
                continue
            if tag[0] == "match":
                new[("vert", key)] = _geometric_vertex(level, v, index[key], int_values, dense, face_values,
                                                       edge_s, vert_s, loop)
                continue
            if tag[0] == "corner":
                new[("vert", key)] = value
                continue
            (f0, i0), (f1, i1) = tag[1][0], tag[1][-1]
            ends = store[values[f0][(i0 + 1) % len(level.faces[f0])]] + store[values[f1][i1 - 1]]
            crease = 0.75 * value + 0.125 * ends
            if tag[0] == "crease":
                new[("vert", key)] = crease
                continue
            # Semi-sharp (or dependent on the other value): a corner while the child value is not a crease, then
            # blended once by the fractional weight of the point and of the edges inside the (partner's) span.
            if c_tags[(v, ("vert", key))][0] != "crease":  # the point keeps its number (points come first)
                new[("vert", key)] = value
                continue
            weighed = tags[(v, tag[3])] if tag[0] == "dep" else tag
            interior = weighed[2]
            w = fractional_weight(vert_s[v], decrement(vert_s[v]), [edge_s[e] for e in interior])
            new[("vert", key)] = (1.0 - w) * crease + w * value
        level, edge_s, vert_s, may_depend = child, c_edge, c_vert, dependents
        store, values = new, c_values
    return np.array([[store[k] for k in row] for row in values])
