"""Coplanar partners: the pairs of single-sided triangles (or a single-sided and a double-sided one) that lie in one
plane, overlap in area and face each other's backs, found on the host in linear time (:func:`coplanar_pairs`).

Two triangles ``T`` and ``P`` are coplanar when their unit normals differ by at most ``m_T + m_P`` (``m``: the
angle :data:`ANGLE_TOLERANCE` plus what the float32 rounding of the triangle's corners can tilt its normal) and
each one's corners lie within ``delta`` of the other's plane (``delta``: :data:`COPLANAR_TOLERANCE` of its longest
edge plus the rounding of its corners). Every triangle is put in the cells of a hash over its canonical plane (unit
normal signed to a generic direction; offset along the centre of its normal cell, the same vector for all the
triangles in that cell, so two coplanar ones have offsets as near as their sizes times :data:`LEVER`, whatever
their distance from the origin): :data:`NORMAL_CELL` per normal component, 16 times a typical triangle's offset
margin along the offset, each triangle in every cell its margins reach (mostly one), so two coplanar triangles
share a cell. A scene where no cell holds two sides (single-sided triangles facing both ways, or a single-sided and
a double-sided one) stops there: a kernel over the triangles and a count of the cells. Within the cells that do, a
2D grid over the plane (cells the triangles' mean size) pairs only triangles near each other, and a float64 kernel
keeps those coplanar, overlapping in area and facing. These kernels run on the CPU, at load.

A triangle whose normal the rounding of its corners leaves uncertain by more than :data:`MAX_MARGIN` (a sliver
whose height is under about 1/4000 of its coordinates), or that would be in more than :data:`MAX_COPIES` cells, is
in none: the caller pairs it across its edges only (``wrt.twins.edge_partners``).
"""

import numpy as np
import warp as wp

# No FMA contraction (the same cells and tests whatever compiles it); no backward pass.
wp.set_module_options({"fuse_fp": False, "enable_backward": False})

COPLANAR_TOLERANCE = 1.0e-5  # corners this far off the other's plane, relative to their triangle's longest edge
ANGLE_TOLERANCE = 1.0e-5  # radians between two coplanar triangles' normals, beyond their rounding
CORNER_ROUNDING = 2.0 ** -23  # a float32 corner's rounding (an ulp: two roundings), relative to its largest coordinate
MAX_MARGIN = 2.0 ** -9  # the largest normal margin a hashed triangle may have (radians)
NORMAL_CELL = 2.0 ** -5  # hash cell per unit normal component (a margin, at most 1.5 MAX_MARGIN, spans <= 2 cells)
# Two coplanar triangles sharing a normal cell have offsets along its centre within the sum of their deltas plus
# LEVER times their longest edges: that centre is within sqrt(3) / 2 NORMAL_CELL + 1.5 MAX_MARGIN of each normal, and
# the centroids of two triangles that overlap are within 2 / 3 of the sum of their longest edges.
LEVER = 2.0 / 3.0 * (3.0 ** 0.5 / 2.0 * NORMAL_CELL + 1.5 * MAX_MARGIN)
MAX_COPIES = 4096  # a triangle in more cells (some 30,000 times the median size) is not hashed: edge partners only
GENERIC = (0.5773502691896258 * 0.8, 0.5773502691896258 * 1.1, 0.5773502691896258 * 1.05)  # canonical normal sign
BIG_CELLS = 256  # an entry whose box covers more 2D cells than this is paired with its whole plane cell instead

_ANGLE = wp.constant(wp.float64(ANGLE_TOLERANCE))
_TOLERANCE = wp.constant(wp.float64(COPLANAR_TOLERANCE))
_ROUNDING = wp.constant(wp.float64(CORNER_ROUNDING))
_MAX_MARGIN = wp.constant(wp.float64(MAX_MARGIN))
_LEVER = wp.constant(wp.float64(LEVER))
MIX_1 = wp.constant(wp.uint64(0xFF51AFD7ED558CCD))  # MurmurHash3 fmix64 constants
_MIX_2 = wp.constant(wp.uint64(0xC4CEB9FE1A85EC53))


@wp.func
def mix64(x: wp.uint64):
    """MurmurHash3's 64-bit finaliser (Appleby)."""
    x = x ^ (x >> wp.uint64(33))
    x = x * MIX_1
    x = x ^ (x >> wp.uint64(33))
    x = x * _MIX_2
    return x ^ (x >> wp.uint64(33))


@wp.func
def corner(points: wp.array[wp.vec3], indices: wp.array2d[wp.int32], t: int, k: int):
    """Corner ``k`` of triangle ``t`` in float64."""
    return wp.vec3d(points[indices[t, k]])


@wp.func
def longest_edge(a: wp.vec3d, b: wp.vec3d, c: wp.vec3d):
    return wp.sqrt(wp.max(wp.max(wp.length_sq(b - a), wp.length_sq(c - b)), wp.length_sq(a - c)))


@wp.func
def corner_rounding(a: wp.vec3d, b: wp.vec3d, c: wp.vec3d):
    """How far float32 rounding may have moved a corner: :data:`CORNER_ROUNDING` of the largest coordinate."""
    big = wp.max(wp.max(wp.abs(a), wp.abs(b)), wp.abs(c))
    return _ROUNDING * wp.max(wp.max(big[0], big[1]), big[2])


@wp.func
def normal_margin(area2: wp.float64, longest: wp.float64, rounding: wp.float64):
    """The angle by which a coplanar triangle's normal may differ from this one's on this one's account: the
    tolerance plus the tilt that moving each corner by the rounding gives (4 rounding / smallest height)."""
    return _ANGLE + wp.float64(4.0) * rounding * longest / area2


@wp.func
def normal_cells(u: wp.vec3d, r: wp.float64, per_n: wp.float64):
    """The first normal cell that the box ``u +- r`` reaches and how many it reaches along each component; ``per_n``:
    cells per unit. Cells are centred on 0 (cell ``q`` on ``q / per_n``), so the normals of axis-aligned and
    45-degree planes sit mid-cell, in one cell and not two."""
    half = wp.float64(0.5)
    lo = wp.vec3i(int(wp.floor((u[0] - r) * per_n + half)), int(wp.floor((u[1] - r) * per_n + half)),
                  int(wp.floor((u[2] - r) * per_n + half)))
    hi = wp.vec3i(int(wp.floor((u[0] + r) * per_n + half)), int(wp.floor((u[1] + r) * per_n + half)),
                  int(wp.floor((u[2] + r) * per_n + half)))
    return lo, hi - lo + wp.vec3i(1, 1, 1)


@wp.func
def nth_normal_cell(lo: wp.vec3i, n: wp.vec3i, k: int):
    """The ``k``-th cell of the box ``lo``, ``n`` cells along each component (the first fastest)."""
    return wp.vec3i(lo[0] + k % n[0], lo[1] + (k / n[0]) % n[1], lo[2] + k / (n[0] * n[1]))


@wp.func
def offset_cells(q: wp.vec3i, centroid: wp.vec3d, e: wp.float64, per_n: wp.float64, per_d: wp.float64):
    """The first offset cell and how many cells the offset ``+- e`` reaches, the offset taken along the centre of the
    normal cell ``q`` (the same vector for every triangle in it, which keeps the offsets of two coplanar triangles
    as near as their centroids are: module docstring)."""
    d = wp.dot(wp.vec3d(wp.float64(q[0]), wp.float64(q[1]), wp.float64(q[2])), centroid) / per_n
    half = wp.float64(0.5)
    lo = int(wp.floor((d - e) * per_d + half))
    return lo, int(wp.floor((d + e) * per_d + half)) - lo + 1


@wp.func
def cell_key(space: int, q: wp.vec3i, qd: int):
    """Hash of the plane cell (normal cell ``q``, offset cell ``qd``) in ``space``, and the projection axis of the
    normal cell (its centre's largest component)."""
    h = wp.uint64(space + 2)
    for i in range(3):
        h = h * MIX_1 + wp.uint64(wp.int64(q[i]) & wp.int64(0xFFFFFFFF))
    h = h * MIX_1 + wp.uint64(wp.int64(qd) & wp.int64(0xFFFFFFFF))
    x = wp.abs(q[0])
    y = wp.abs(q[1])
    z = wp.abs(q[2])
    axis = int(0)
    if y > x and y >= z:
        axis = 1
    elif z > x and z > y:
        axis = 2
    return mix64(h), axis


@wp.func
def before(p: wp.vec3d, q: wp.vec3d):
    """``p`` before ``q`` in lexicographic order."""
    if p[0] != q[0]:
        return p[0] < q[0]
    if p[1] != q[1]:
        return p[1] < q[1]
    return p[2] < q[2]


@wp.func
def triangle_plane(points: wp.array[wp.vec3], indices: wp.array2d[wp.int32], t: int, origin: wp.vec3d):
    """Unit normal, centroid (from ``origin``), normal margin, offset tolerance and longest edge of triangle ``t``;
    a margin of -1 for a degenerate triangle. The normal comes from the corners in lexicographic order (then signed
    by the winding), so a twin's, with its corners in another order, rounds to exactly the same or its negation: the
    two are hashed, or not, alike."""
    a = corner(points, indices, t, 0)
    b = corner(points, indices, t, 1)
    c = corner(points, indices, t, 2)
    centroid = (a + b + c) / wp.float64(3.0) - origin
    longest = longest_edge(a, b, c)
    rounding = corner_rounding(a, b, c)
    # Sort the corners (three swaps), each swap reversing the winding.
    sign = wp.float64(1.0)
    if before(b, a):
        a, b = b, a
        sign = -sign
    if before(c, b):
        b, c = c, b
        sign = -sign
    if before(b, a):
        a, b = b, a
        sign = -sign
    n = wp.cross(b - a, c - a) * sign
    area2 = wp.length(n)
    if area2 == wp.float64(0.0):
        return n, centroid, wp.float64(-1.0), wp.float64(0.0), wp.float64(0.0)
    return n / area2, centroid, normal_margin(area2, longest, rounding), _TOLERANCE * longest + rounding, longest


@wp.func
def sign_options(u: wp.vec3d, m: wp.float64, generic: wp.vec3d):
    """The canonical signs of ``u`` to hash under: the sign of ``u . generic``, and the other too when a coplanar
    normal (within ``1.5 (m + MAX_MARGIN)``) may have the other."""
    g = wp.dot(u, generic)
    first = wp.float64(1.0)
    if g < wp.float64(0.0):
        first = wp.float64(-1.0)
    both = int(0)
    if wp.abs(g) <= wp.float64(1.5) * (m + _MAX_MARGIN):
        both = 1
    return first, both


@wp.func
def side_code(sign: wp.float64, double_sided: int):
    """0: the triangle faces along the canonical normal, 1: against it, 2: double-sided (faces both)."""
    if double_sided == 1:
        return 2
    if sign < wp.float64(0.0):
        return 1
    return 0


@wp.kernel
def plane_cells_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    spaces: wp.array[wp.int32],
    double_sided: wp.array[wp.int32],
    origin: wp.vec3d,
    generic: wp.vec3d,
    per_n: wp.float64,
    per_d: wp.float64,
    max_copies: int,
    # outputs
    keys: wp.array[wp.uint64],
    codes: wp.array[wp.int32],
    copies: wp.array[wp.int32],
    sides_seen: wp.array[wp.int32],
):
    """Triangle ``t``'s first plane cell (``keys``; ``codes``: :func:`side_code` + 3 projection axis) and how many
    cells it is in (``copies``; 0 degenerate, -1 a normal too uncertain to hash or more than ``max_copies`` cells);
    1 in ``sides_seen[k]`` when some triangle hashed has side code ``k``."""
    t = wp.tid()
    u, centroid, m, delta, longest = triangle_plane(points, indices, t, origin)
    keys[t] = wp.uint64(0)
    codes[t] = -1
    copies[t] = 0
    if m < wp.float64(0.0):
        return
    if m > _MAX_MARGIN:
        copies[t] = -1
        return
    first, both = sign_options(u, m, generic)
    r = wp.float64(1.5) * m
    e = delta + _LEVER * longest
    count = int(0)
    for s in range(1 + both):
        sign = first
        if s == 1:
            sign = -first
        lo, n = normal_cells(sign * u, r, per_n)
        sides_seen[side_code(sign, double_sided[t])] = 1  # (every thread writes 1: no race to lose)
        for k in range(n[0] * n[1] * n[2]):
            qd, nd = offset_cells(nth_normal_cell(lo, n, k), centroid, e, per_n, per_d)
            if s == 0 and k == 0:
                h, axis = cell_key(spaces[t], lo, qd)
                keys[t] = h
                codes[t] = side_code(sign, double_sided[t]) + 3 * axis
            count += nd
    if count > max_copies:
        count = -1
    copies[t] = count


@wp.kernel
def plane_copies_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    spaces: wp.array[wp.int32],
    double_sided: wp.array[wp.int32],
    origin: wp.vec3d,
    generic: wp.vec3d,
    per_n: wp.float64,
    per_d: wp.float64,
    max_copies: int,
    triangles: wp.array[wp.int32],
    offsets: wp.array[wp.int32],
    # outputs
    keys: wp.array[wp.uint64],
    codes: wp.array[wp.int32],
    owners: wp.array[wp.int32],
):
    """Every plane cell of the triangles in more than one (:func:`plane_cells_kernel`), from ``offsets``."""
    i = wp.tid()
    t = triangles[i]
    u, centroid, m, delta, longest = triangle_plane(points, indices, t, origin)
    first, both = sign_options(u, m, generic)
    r = wp.float64(1.5) * m
    e = delta + _LEVER * longest
    out = offsets[i]
    for s in range(1 + both):
        sign = first
        if s == 1:
            sign = -first
        lo, n = normal_cells(sign * u, r, per_n)
        for k in range(n[0] * n[1] * n[2]):
            q = nth_normal_cell(lo, n, k)
            qd, nd = offset_cells(q, centroid, e, per_n, per_d)
            for j in range(nd):
                h, axis = cell_key(spaces[t], q, qd + j)
                keys[out] = h
                codes[out] = side_code(sign, double_sided[t]) + 3 * axis
                owners[out] = t
                out += 1


@wp.func
def project(p: wp.vec3d, axis: int):
    """``p`` on the plane of the two coordinates other than ``axis``."""
    return wp.vec2d(p[(axis + 1) % 3], p[(axis + 2) % 3])


@wp.func
def cross2(a: wp.vec2d, b: wp.vec2d):
    return a[0] * b[1] - a[1] * b[0]


@wp.func
def separated(a0: wp.vec2d, a1: wp.vec2d, a2: wp.vec2d, b0: wp.vec2d, b1: wp.vec2d, b2: wp.vec2d,
              eps: wp.float64):
    """True when a side of triangle ``a`` has all of ``b`` outside it or within ``eps`` inside (they share no area
    across it)."""
    turn = wp.float64(1.0)
    if cross2(a1 - a0, a2 - a0) < wp.float64(0.0):
        turn = wp.float64(-1.0)
    for k in range(3):
        p = a0
        q = a1
        if k == 1:
            p = a1
            q = a2
        elif k == 2:
            p = a2
            q = a0
        e = q - p
        scale = turn / wp.length(e)
        inside = wp.max(wp.max(cross2(e, b0 - p), cross2(e, b1 - p)), cross2(e, b2 - p)) * scale
        if turn < wp.float64(0.0):
            inside = wp.min(wp.min(cross2(e, b0 - p), cross2(e, b1 - p)), cross2(e, b2 - p)) * scale
        if inside <= eps:
            return True
    return False


@wp.func
def plane_distance(u: wp.vec3d, a: wp.vec3d, p: wp.vec3d, q: wp.vec3d, r: wp.vec3d):
    """Largest distance of ``p, q, r`` from the plane through ``a`` with unit normal ``u``."""
    return wp.max(wp.max(wp.abs(wp.dot(u, p - a)), wp.abs(wp.dot(u, q - a))), wp.abs(wp.dot(u, r - a)))


@wp.func
def coplanar_overlap(points: wp.array[wp.vec3], indices: wp.array2d[wp.int32], t: int, p: int, any_facing: int):
    """True when triangles ``t`` and ``p`` are coplanar (module docstring), face opposite ways (unless
    ``any_facing``: ``p`` is double-sided) and share area in their plane."""
    ta = corner(points, indices, t, 0)
    tb = corner(points, indices, t, 1)
    tc = corner(points, indices, t, 2)
    pa = corner(points, indices, p, 0)
    pb = corner(points, indices, p, 1)
    pc = corner(points, indices, p, 2)
    nt = wp.cross(tb - ta, tc - ta)
    np_ = wp.cross(pb - pa, pc - pa)
    at = wp.length(nt)
    ap = wp.length(np_)
    if at == wp.float64(0.0) or ap == wp.float64(0.0):
        return False
    ut = nt / at
    up = np_ / ap
    if any_facing == 0 and wp.dot(ut, up) >= wp.float64(0.0):
        return False
    # Coplanar: normals within both margins, each one's corners near the other's plane.
    lt = longest_edge(ta, tb, tc)
    lp = longest_edge(pa, pb, pc)
    rt = corner_rounding(ta, tb, tc)
    rp = corner_rounding(pa, pb, pc)
    if wp.length(wp.cross(ut, up)) > normal_margin(at, lt, rt) + normal_margin(ap, lp, rp):
        return False
    if plane_distance(ut, ta, pa, pb, pc) > _TOLERANCE * lp + rp:
        return False
    if plane_distance(up, pa, ta, tb, tc) > _TOLERANCE * lt + rt:
        return False
    # Overlapping in area: no side of either separates them, in the plane of the largest normal component.
    axis = int(0)
    if wp.abs(ut[1]) > wp.abs(ut[0]) and wp.abs(ut[1]) >= wp.abs(ut[2]):
        axis = 1
    elif wp.abs(ut[2]) > wp.abs(ut[0]) and wp.abs(ut[2]) > wp.abs(ut[1]):
        axis = 2
    t0, t1, t2 = project(ta, axis), project(tb, axis), project(tc, axis)
    p0, p1, p2 = project(pa, axis), project(pb, axis), project(pc, axis)
    eps = _TOLERANCE * wp.min(lt, lp)
    return not separated(t0, t1, t2, p0, p1, p2, eps) and not separated(p0, p1, p2, t0, t1, t2, eps)


@wp.func
def probe_match(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    entry_tris: wp.array[wp.int32],
    entry_codes: wp.array[wp.int32],
    entry_boxes: wp.array[wp.vec4d],
    entry_cells: wp.array[wp.float64],
    scan_entries: wp.array[wp.int32],
    scan_once: wp.array[wp.int32],
    e: int,
    j: int,
    mode: int,
    cell: wp.vec2i,
):
    """The partner triangle that scan slot ``j`` gives entry ``e`` (a single-sided seeker), or -1."""
    f = scan_entries[j]
    side_e = entry_codes[e] % 3
    side_f = entry_codes[f] % 3
    if f == e or side_f == side_e:
        return int(-1)
    be = entry_boxes[e]
    bf = entry_boxes[f]
    if mode == 0:
        # Both in this 2D cell: the pair counts in the cell of its boxes' overlap's lower corner only.
        s = entry_cells[e]
        if (int(wp.floor(wp.max(be[0], bf[0]) / s)) != cell[0]
                or int(wp.floor(wp.max(be[1], bf[1]) / s)) != cell[1]):
            return int(-1)
    elif scan_once[j] == 0:
        return int(-1)  # a small entry's later cells: it was met in its first
    if be[0] >= bf[2] or bf[0] >= be[2] or be[1] >= bf[3] or bf[1] >= be[3]:
        return int(-1)  # boxes that share no area
    any_facing = int(0)
    if side_f == 2:
        any_facing = 1
    t = entry_tris[e]
    p = entry_tris[f]
    if p != t and coplanar_overlap(points, indices, t, p, any_facing):
        return p
    return int(-1)


@wp.kernel
def pair_entries_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    spaces: wp.array[wp.int32],
    entry_tris: wp.array[wp.int32],
    entry_codes: wp.array[wp.int32],
    entry_boxes: wp.array[wp.vec4d],
    entry_cells: wp.array[wp.float64],
    scan_entries: wp.array[wp.int32],
    scan_once: wp.array[wp.int32],
    probes: wp.array[wp.vec4i],
    probe_cells: wp.array[wp.vec2i],
    limit: int,
    capacity: int,
    # outputs
    total: wp.array[wp.int32],
    partners: wp.array2d[wp.int32],
):
    """Probe ``i`` = (entry, first scan slot, end, mode) scans its slots for partners of its entry's triangle: mode 0
    the entries of one 2D cell (``probe_cells``) that may face it, mode 1 a plane cell's big entries or, for a big
    entry, all of its plane cell. Partners in another space (``spaces``, a key shared across spaces) are not pairs.
    Each pair found takes the next of ``capacity`` rows ``(triangle, partner)``; ``total`` counts them all (more than
    ``capacity``: launch again with room for them). A mode-0 probe, whose slots hold ascending triangles, stops at its
    ``limit``-th pair: the partners it leaves are all above those (``limit`` 0: no stop)."""
    i = wp.tid()
    probe = probes[i]
    e = probe[0]
    found = int(0)
    for j in range(probe[1], probe[2]):
        p = probe_match(points, indices, entry_tris, entry_codes, entry_boxes, entry_cells, scan_entries, scan_once,
                        e, j, probe[3], probe_cells[i])
        if p >= 0 and spaces[p] == spaces[entry_tris[e]]:
            slot = wp.atomic_add(total, 0, 1)
            if slot < capacity:
                partners[slot, 0] = entry_tris[e]
                partners[slot, 1] = p
            found += 1
            if probe[3] == 0 and found == limit:
                break


@wp.kernel
def triangle_margins_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    triangles: wp.array[wp.int32],
    area2: wp.array[wp.float64],
    # outputs
    margins: wp.array[wp.float64],
    deltas: wp.array[wp.float64],
):
    """The normal margin and offset tolerance of triangle ``triangles[i]`` (``area2[i]``: the length of its normal),
    by the rule the hash and the pairing use (module docstring), for callers on the host (``wrt.twins``)."""
    i = wp.tid()
    t = triangles[i]
    a = corner(points, indices, t, 0)
    b = corner(points, indices, t, 1)
    c = corner(points, indices, t, 2)
    longest = longest_edge(a, b, c)
    rounding = corner_rounding(a, b, c)
    margins[i] = normal_margin(area2[i], longest, rounding)
    deltas[i] = _TOLERANCE * longest + rounding


def triangle_margins(points, indices, triangles, area2) -> tuple[np.ndarray, np.ndarray]:
    """The normal margin (radians) and offset tolerance of each of ``triangles`` (module docstring), in float64.

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        triangles: ``(N,)`` int rows of ``indices``.
        area2: ``(N,)`` float64 length of each one's normal (twice its area).

    Returns:
        ``((N,) float64 margins, (N,) float64 offset tolerances)``.
    """
    device = "cpu"
    n = len(triangles)
    out = [wp.empty(n, dtype=wp.float64, device=device) for _ in range(2)]
    if n:
        wp.launch(triangle_margins_kernel, dim=n, device=device, outputs=out,
                  inputs=[wp.array(np.ascontiguousarray(points, np.float32), dtype=wp.vec3, device=device),
                          wp.array(np.ascontiguousarray(indices, np.int32), dtype=wp.int32, device=device),
                          wp.array(np.asarray(triangles, np.int32), dtype=wp.int32, device=device),
                          wp.array(np.asarray(area2, np.float64), dtype=wp.float64, device=device)])
    return out[0].numpy(), out[1].numpy()


def _plane_entries(points, indices, spaces, double_sided):
    """The plane cells of every triangle (:func:`plane_cells_kernel`): ``(keys, codes, owners, uncertain, opposed)``:
    ``uncertain`` the triangles too uncertain to hash, ``opposed`` whether a triangle hashed may face another's back
    (sides 0 and 1 seen, or 2 and either)."""
    pts = np.ascontiguousarray(points, np.float32)
    lower = np.array([pts[:, k].min() for k in range(3)], np.float64)  # by column: a reduction along axis 0 of
    upper = np.array([pts[:, k].max() for k in range(3)], np.float64)  # (V, 3) took 20 times as long
    # Offset cells 16 times a typical triangle's offset margin (its longest edge times LEVER: from a sample), so most
    # triangles are in one; any size is correct, this one keeps the copies few and the cells fine.
    sample = pts[indices[:: max(1, len(indices) // 4096)]].astype(np.float64)
    edges = np.linalg.norm(sample - np.roll(sample, 1, axis=1), axis=2).max(axis=1)
    typical = float(np.median(edges)) * LEVER if len(edges) else 0.0
    cell_d = 2.0 ** np.ceil(np.log2(16.0 * typical)) if typical > 0.0 else 1.0
    device = "cpu"
    args = [wp.array(pts, dtype=wp.vec3, device=device, copy=False),
            wp.array(np.ascontiguousarray(indices, np.int32), dtype=wp.int32, device=device, copy=False),
            wp.array(np.asarray(spaces, np.int32), dtype=wp.int32, device=device),
            wp.array(np.asarray(double_sided, np.int32), dtype=wp.int32, device=device),
            wp.vec3d(*((lower + upper) / 2.0)), wp.vec3d(*GENERIC), wp.float64(1.0 / NORMAL_CELL),
            wp.float64(1.0 / cell_d), MAX_COPIES]
    n = len(indices)
    keys = wp.empty(n, dtype=wp.uint64, device=device)
    codes = wp.empty(n, dtype=wp.int32, device=device)
    copies = wp.empty(n, dtype=wp.int32, device=device)
    seen = wp.zeros(3, dtype=wp.int32, device=device)
    wp.launch(plane_cells_kernel, dim=n, inputs=args, outputs=[keys, codes, copies, seen], device=device)
    keys, codes, copies = keys.numpy(), codes.numpy(), copies.numpy()
    present = seen.numpy() > 0  # (3,) the side codes seen
    opposed = bool(_partnered(present[None, :])[0][present].any())
    single = np.flatnonzero(copies == 1)
    multi = np.flatnonzero(copies > 1)
    if not len(multi):
        return keys[single], codes[single], single, np.flatnonzero(copies < 0), opposed
    offsets = np.concatenate([[0], np.cumsum(copies[multi])])
    out = [wp.empty(int(offsets[-1]), dtype=dtype, device=device) for dtype in (wp.uint64, wp.int32, wp.int32)]
    wp.launch(plane_copies_kernel, dim=len(multi), device=device, outputs=out,
              inputs=args + [wp.array(multi.astype(np.int32), dtype=wp.int32, device=device),
                             wp.array(offsets[:-1].astype(np.int32), dtype=wp.int32, device=device)])
    extra_keys, extra_codes, extra_owners = (a.numpy() for a in out)
    return (np.concatenate([keys[single], extra_keys]), np.concatenate([codes[single], extra_codes]),
            np.concatenate([single, extra_owners]), np.flatnonzero(copies < 0), opposed)


def two_sided_cells(keys: np.ndarray, sides: np.ndarray) -> np.ndarray:
    """Indices of the entries whose cell (``keys``) holds an entry that may face them from behind (``sides``: 0 and
    1 single-sided facing either way, 2 double-sided): the others can have no partner. Counting sides in buckets of
    a few of the keys' bits, three times with other bits, leaves few entries to sort by key and check exactly."""
    found = np.arange(len(keys))
    for shift in (0, 21, 42):
        if len(found) < 1024:
            break
        bits = min(21, int(np.log2(len(found))) + 2)
        some_keys, some_sides = (keys, sides) if shift == 0 else (keys[found], sides[found])  # (all at first)
        slot = ((some_keys >> np.uint64(shift)) & np.uint64((1 << bits) - 1)).astype(np.intp) * 3 + some_sides
        present = np.zeros(3 << bits, bool)  # (a scatter: a bincount's int64 counts took twice as long)
        present[slot] = True
        found = found[_partnered(present.reshape(-1, 3)).ravel()[slot]]
        if not len(found):
            return found
    order = found[np.argsort(keys[found], kind="stable")]
    starts = np.concatenate([[True], keys[order[1:]] != keys[order[:-1]]])
    run = np.cumsum(starts) - 1
    present = np.zeros((run[-1] + 1 if len(run) else 0, 3), bool)
    present[run, sides[order]] = True
    return order[_partnered(present)[run, sides[order]]]


def _partnered(present: np.ndarray) -> np.ndarray:
    """``(B, 3)`` bool from ``(B, 3)`` bool ``present`` (a cell holds an entry of side 0, 1, 2): an entry of that
    side in that cell may have a partner there (side 0 and 1 face each other, 2 faces both)."""
    s0, s1, s2 = present[:, 0], present[:, 1], present[:, 2]
    return np.stack([s1 | s2, s0 | s2, s0 | s1], axis=1)


def _ranks(counts: np.ndarray) -> np.ndarray:
    """``0, 1, ..., c - 1`` for each ``c`` in ``counts``, concatenated."""
    counts = np.asarray(counts, np.int64)
    return np.arange(int(counts.sum()), dtype=np.int64) - np.repeat(np.cumsum(counts) - counts, counts)


def coplanar_pairs(points, indices, spaces, double_sided, limit: int = 0) -> tuple[np.ndarray, np.ndarray, bool]:
    """Pairs ``(t, p)`` of triangles: ``t`` single-sided, ``p`` in the same space, coplanar with it (module
    docstring), overlapping it in area, and facing the other way or double-sided; the triangles whose normals are
    too uncertain to pair here; and whether any two hashed triangles may face each other's backs at all (the
    canonical sides of their normals (:func:`side_code`) both seen, or a double-sided one and a single-sided one).

    Args:
        points: ``(V, 3)`` float32 vertex positions.
        indices: ``(T, 3)`` int rows into ``points``.
        spaces: ``(T,)`` int: the space of each triangle's points (e.g. -1 world, ``k`` prototype ``k``).
        double_sided: ``(T,)`` bool: the triangle's mesh is double-sided.
        limit: > 0: of a triangle with more partners, at least its ``limit`` lowest are returned, maybe not the
            others (``wrt.twins`` keeps each triangle's lowest few: a stack of thousands of coplanar triangles facing
            both ways, or the fan of a large concave polygon, took minutes and gigabytes to pair in full); 0: all.

    Returns:
        ``((P, 2) int64 pairs (t, p), (U,) int64 uncertain triangles, opposed)``; a pair may repeat.
    """
    indices = np.ascontiguousarray(np.asarray(indices).reshape(-1, 3), np.int32)
    none = np.zeros((0, 2), np.int64)
    if not len(indices):
        return none, np.zeros(0, np.int64), False
    keys, codes, owners, uncertain, opposed = _plane_entries(points, indices, spaces, double_sided)
    chosen = two_sided_cells(keys, codes % 3) if opposed else np.zeros(0, np.int64)  # (a floor: all one side)
    if not len(chosen):  # the common case ends here
        return none, uncertain, opposed
    probes = _grid_probes(points, indices, keys[chosen], codes[chosen], owners[chosen])
    return _run_probes(points, indices, spaces, limit, *probes), uncertain, opposed


# Rows of a 2D cell are sorted by side in this order (1, 2, 0), so that the sides that may face a side-0 entry (1,
# 2) and a side-1 entry (2, 0) are each one slice of the cell's rows.
_SIDE_RANK = np.array([2, 0, 1])


def _grid_probes(points, indices, keys, codes, tris):
    """The scans that pair the entries of each plane cell (``keys``) through a 2D grid over their plane
    (:func:`pair_entries_kernel`): ``(tris, codes, boxes, cells, scan_entries, scan_once, probes, probe_cells)``,
    the entries sorted by plane cell."""
    # Entries sorted by plane cell (group) (:func:`two_sided_cells` gives them sorted: a stable sort would keep them);
    # their boxes in the plane of the cell's largest normal component.
    if len(keys) > 1 and not (keys[1:] >= keys[:-1]).all():
        order = np.argsort(keys, kind="stable")
        keys, codes, tris = keys[order], codes[order], tris[order]
    new_group = np.ones(len(keys), bool)
    new_group[1:] = keys[1:] != keys[:-1]
    group = np.cumsum(new_group) - 1
    axis, sides = codes // 3, codes % 3
    corner_ids, pts = np.asarray(indices)[tris], np.asarray(points)  # (E, 3)
    flat = np.empty(corner_ids.shape + (2,), np.float64)  # (E, 3, 2)
    for k in (1, 2):  # (gathered per coordinate: no (E, 3, 3) float64 corners)
        flat[:, :, k - 1] = pts[corner_ids, ((axis + k) % 3)[:, None]]
    # (Reductions over a short axis written out: numpy's took several times as long.)
    lower = np.minimum(np.minimum(flat[:, 0], flat[:, 1]), flat[:, 2])
    upper = np.maximum(np.maximum(flat[:, 0], flat[:, 1]), flat[:, 2])
    # 2D cells of the group's mean box size (a power of two); an entry over more than BIG_CELLS is big.
    members = np.bincount(group)
    mean = np.bincount(group, np.maximum(upper[:, 0] - lower[:, 0], upper[:, 1] - lower[:, 1])) / members
    cells = np.where(mean > 0.0, 2.0 ** np.ceil(np.log2(np.where(mean > 0.0, mean, 1.0))), 1.0)[group]
    first_cell = np.floor(lower / cells[:, None]).astype(np.int64)
    spans = np.floor(upper / cells[:, None]).astype(np.int64) - first_cell + 1
    big = spans[:, 0] * spans[:, 1] > BIG_CELLS
    # Small entries: one row per 2D cell, sorted by (group, cell, side rank); big entries after them, by group.
    small = np.flatnonzero(~big)
    count = spans[small, 0] * spans[small, 1]
    row_entry = np.repeat(small, count)
    rank = _ranks(count)
    row_cell = first_cell[row_entry] + np.stack([rank % spans[row_entry, 0], rank // spans[row_entry, 0]], axis=1)
    row_rank = _SIDE_RANK[sides[row_entry]]
    # (Ascending triangles within a side rank: a probe that stops at its limit has found the lowest partners.)
    order = _row_order(group[row_entry], row_cell, row_rank, tris[row_entry])
    row_entry, row_cell, row_first, row_rank = row_entry[order], row_cell[order], (rank == 0)[order], row_rank[order]
    row_group = group[row_entry]
    big_entries = np.flatnonzero(big)  # sorted by group already
    groups = np.arange(len(members))
    small_range = np.stack([np.searchsorted(row_group, groups), np.searchsorted(row_group, groups, "right")], 1)
    big_group = group[big_entries]
    big_range = len(row_entry) + np.stack([np.searchsorted(big_group, groups),
                                           np.searchsorted(big_group, groups, "right")], 1)
    # Each 2D cell's run of rows, and in it the bounds of side ranks 0 (side 1), 1 (side 2) and 2 (side 0).
    new_run = np.ones(len(row_entry), bool)
    new_run[1:] = ((row_group[1:] != row_group[:-1]) | (row_cell[1:, 0] != row_cell[:-1, 0])
                   | (row_cell[1:, 1] != row_cell[:-1, 1]))
    starts = np.flatnonzero(new_run)
    run = np.cumsum(new_run) - 1
    run_bounds = np.zeros((len(starts), 4), np.int64)  # (R, 4) each run's start and its side ranks' ends
    run_bounds[:, 1:] = np.bincount(run * 3 + row_rank, minlength=3 * len(starts)).reshape(-1, 3)
    run_bounds = np.cumsum(run_bounds, axis=1) + starts[:, None]
    # Probes, for single-sided seekers only: each small row the rows of its 2D cell that may face it (side 0: ranks
    # 0 and 1, side 1: ranks 1 and 2; a probe per rank, whose rows hold ascending triangles); each small entry (at
    # its first row) its plane cell's big entries; each big entry all of its plane cell.
    row_side = sides[row_entry]
    rows = np.flatnonzero(row_side != 2)
    at = run[rows] * 4 + np.where(row_side[rows] == 0, 0, 1)  # the first side rank row r may face, then the next
    lo, mid, hi = (run_bounds.ravel()[at + k] for k in range(3))
    firsts = rows[row_first[rows]]
    big_seekers = big_entries[sides[big_entries] != 2]
    # (Written into one int32 array, as the kernel reads them: stacks and concatenations of int64 took as long.)
    probes = np.zeros((2 * len(rows) + len(firsts) + 2 * len(big_seekers), 4), np.int32)
    probe_cells = np.zeros((len(probes), 2), np.int32)
    mode0 = probes[: 2 * len(rows)].reshape(-1, 2, 4)  # a view: two probes a row, its two side ranks
    mode0[:, :, 0] = row_entry[rows, None]
    mode0[:, 0, 1], mode0[:, 0, 2], mode0[:, 1, 1], mode0[:, 1, 2] = lo, mid, mid, hi
    probe_cells[: 2 * len(rows)].reshape(-1, 2, 2)[:] = row_cell[rows, None]
    at = 2 * len(rows)
    e = row_entry[firsts]  # each small seeker once (at its first row), though each row makes two probes above
    for seekers, ranges in ((e, big_range), (big_seekers, small_range), (big_seekers, big_range)):
        block = probes[at : at + len(seekers)]
        block[:, 0], block[:, 3] = seekers, 1
        block[:, 1], block[:, 2] = ranges[group[seekers], 0], ranges[group[seekers], 1]
        at += len(seekers)
    scans = probes[:, 2] > probes[:, 1]
    return (tris, codes, np.concatenate([lower, upper], 1), cells, np.concatenate([row_entry, big_entries]),
            np.concatenate([row_first, np.ones(len(big_entries), bool)]), probes[scans], probe_cells[scans])


def _row_order(groups, cells, ranks, tris):
    """The order of rows sorted by (``groups``, ``cells[:, 0]``, ``cells[:, 1]``, ``ranks``, ``tris``), ties in row
    order: ``np.lexsort`` of the five, or (a third of its time) a stable argsort of one int64 key packing them when
    their ranges fit in 63 bits (``groups`` ascending; cells from their group's first, which keeps the order)."""
    if not len(groups):
        return np.zeros(0, np.int64)
    if (groups[1:] < groups[:-1]).any() or tris.min() < 0:
        return np.lexsort((tris, ranks, cells[:, 1], cells[:, 0], groups))
    starts = np.flatnonzero(np.concatenate([[True], groups[1:] != groups[:-1]]))
    fields = [groups - groups[0]]
    for k in range(2):
        base = np.minimum.reduceat(cells[:, k], starts)
        fields.append(cells[:, k] - np.repeat(base, np.diff(np.append(starts, len(groups)))))
    fields += [ranks, tris]
    widths = [int(f.max()).bit_length() for f in fields]
    if sum(widths) > 63:
        return np.lexsort((tris, ranks, cells[:, 1], cells[:, 0], groups))
    key = np.zeros(len(groups), np.int64)
    for f, w in zip(fields, widths):
        key = (key << w) | f
    return np.argsort(key, kind="stable")


def _run_probes(points, indices, spaces, limit, tris, codes, boxes, cells, scan_entries, scan_once, probes,
                probe_cells):
    """The ``(t, p)`` pairs the probes find (:func:`pair_entries_kernel`; launched again when they outnumber its
    first guess of room)."""
    device = "cpu"
    if not len(probes):
        return np.zeros((0, 2), np.int64)
    inputs = [wp.array(np.asarray(points, np.float32), dtype=wp.vec3, device=device),
              wp.array(np.asarray(indices, np.int32), dtype=wp.int32, device=device),
              wp.array(np.asarray(spaces, np.int32), dtype=wp.int32, device=device),
              wp.array(tris.astype(np.int32), dtype=wp.int32, device=device),
              wp.array(codes.astype(np.int32), dtype=wp.int32, device=device),
              wp.array(boxes, dtype=wp.vec4d, device=device),
              wp.array(cells, dtype=wp.float64, device=device),
              wp.array(scan_entries.astype(np.int32), dtype=wp.int32, device=device),
              wp.array(scan_once.astype(np.int32), dtype=wp.int32, device=device),
              wp.array(np.asarray(probes, np.int32), dtype=wp.vec4i, device=device),
              wp.array(np.asarray(probe_cells, np.int32), dtype=wp.vec2i, device=device)]
    capacity = max(1024, 2 * len(probes))
    while True:
        total = wp.zeros(1, dtype=wp.int32, device=device)
        pairs = wp.empty((capacity, 2), dtype=wp.int32, device=device)
        wp.launch(pair_entries_kernel, dim=len(probes), inputs=inputs + [int(limit), capacity], outputs=[total, pairs],
                  device=device)
        found = int(total.numpy()[0])
        if found <= capacity:
            return pairs.numpy()[:found].astype(np.int64)
        capacity = found
