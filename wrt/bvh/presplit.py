"""Pre-splitting of long, thin, diagonal triangles before a build (early split clipping: Ernst and Greiner, "Early
Split Clipping for Bounding Volume Hierarchies", 2007; Dammertz and Keller, "The Edge Volume Heuristic", 2008).

Why: the box of a sliver that runs diagonally to the axes is mostly empty, and a fan of such slivers around a
shared vertex (the poles of a UV sphere, the tips of a lathed chess piece) gives hundreds of boxes that all overlap
there. A ray passing near the fan's centre enters every one of them: on an H200 the 32 costliest of a 2M-triangle
sphere's 2M primary rays (up to 419 nodes and 1,369 triangle tests each, against 4.6 and 0.7 on average) took as
long to trace by themselves as all 2M rays together, so a launch lasts as long as its worst ray.

What: a triangle whose box surface area exceeds ``SPLIT_RATIO`` times its area is cut into ``2^k`` references: its
box is halved at the middle of its longest axis, the triangle clipped to each half (Sutherland-Hodgman) and the half
tightened to the clipped part, ``k`` times. Each halving about halves a sliver's box-to-area ratio. The builders then
partition references instead of triangles, and ``prim_ids`` maps each leaf slot back to its triangle, so one
triangle may sit in several leaves. Traversal is unchanged: a ray may test a triangle twice, which gives the same
``t`` and id (the tie rule keeps the first), and any-hit answers do not change.

Every reference box contains the part of its triangle in its half-box (the clipping runs in double precision, in
which the float corners and planes are exact; the clipped bound is rounded to float and widened against rounding by
fractions of the triangle's corners and extent, then clamped to the half-box, whose split planes are exact), so the
references together cover the triangle and no ray that hits it misses all its boxes.
"""

from __future__ import annotations

import dataclasses
import math

import warp as wp

from ..floats import unit_scales
from ..options import MAX_SPLIT_LEVELS

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile

# A piece whose box surface area is below this multiple of its triangle's area is not split. A tilted, well-shaped
# triangle has 6-12; 16 split far more of chess_set and slowed its diffuse rays on an H200 (GPU_NOTES.md, row 41).
SPLIT_RATIO = 32.0
MAX_REFERENCES_PER_TRIANGLE = 2.0  # on average: above it, fewer levels are allowed (memory stays bounded)
MAX_REFERENCES = (1 << 30) - 1  # the builders' limit on primitives


@wp.func_native("""
    // Sutherland-Hodgman in double precision: the triangle clipped to the box [lo, hi], then the bounds of what is
    // left (3 + 6 vertices at most). Returns (lower, upper), rounded to float; an empty result comes back inverted
    // (lower > upper). In float the clipped vertices' rounding at the scale of one coordinate moves the crossing of a
    // later plane along the edge by that error over the edge's slope: a sliver 0.3 long at z = 36660 lost 0.006 of
    // its length in x, beyond any pad of x's own scale, and rays there missed it. The corners and planes are floats,
    // exact in double, whose clipped vertices err 2^29 times less.
    double poly[2][9][3];
    int n = 3;
    int cur = 0;
    for (int k = 0; k < 3; ++k) {
        poly[0][0][k] = a[k];
        poly[0][1][k] = b[k];
        poly[0][2][k] = c[k];
    }
    for (int plane = 0; plane < 6 && n > 0; ++plane) {
        const int axis = plane % 3;
        const bool upper = plane >= 3;
        const double bound = upper ? hi[axis] : lo[axis];
        const double (*in)[3] = poly[cur];
        double (*out)[3] = poly[cur ^ 1];
        int m = 0;
        for (int i = 0; i < n; ++i) {
            const double* p = in[i];
            const double* q = in[i + 1 < n ? i + 1 : 0];
            const double dp = upper ? bound - p[axis] : p[axis] - bound;  // >= 0: inside
            const double dq = upper ? bound - q[axis] : q[axis] - bound;
            if (dp >= 0.0) {
                for (int k = 0; k < 3; ++k)
                    out[m][k] = p[k];
                ++m;
            }
            if ((dp >= 0.0) != (dq >= 0.0)) {
                const double s = dp / (dp - dq);
                for (int k = 0; k < 3; ++k)
                    out[m][k] = p[k] + (q[k] - p[k]) * s;
                out[m][axis] = bound;
                ++m;
            }
        }
        n = m;
        cur ^= 1;
    }
    double lower[3] = {INFINITY, INFINITY, INFINITY};
    double upper_[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            const double x = poly[cur][i][k];
            lower[k] = x < lower[k] ? x : lower[k];
            upper_[k] = x > upper_[k] ? x : upper_[k];
        }
    wp::spatial_vector r;
    for (int k = 0; k < 3; ++k) {
        r[k] = (float)lower[k];
        r[k + 3] = (float)upper_[k];
    }
    return r;
""")
def clipped_bounds(a: wp.vec3, b: wp.vec3, c: wp.vec3, lo: wp.vec3, hi: wp.vec3) -> wp.spatial_vector:
    """``(lower, upper)`` of triangle ``abc`` clipped to the box ``[lo, hi]``; inverted when nothing is left."""


@wp.func
def split_levels(a: wp.vec3, b: wp.vec3, c: wp.vec3, max_levels: int, max_ratio: float):
    """How many times to halve the triangle's box: until a sliver's box-to-area ratio is below ``max_ratio``
    (each halving about halves it), at most ``max_levels``; 0 for a triangle of no area. The lengths are first
    scaled by the power of two that brings the box's largest extent into ``[1, 2)``: the same ratio, bit for bit,
    where nothing over- or underflows, but the squares cannot (a mesh 1e20 across, or an instance scaled past 2^100
    and traced in its prototype's BLAS scaled by 2^k, had an infinite box area or a zero area and no cut triangle)."""
    e = wp.max(wp.max(a, b), c) - wp.min(wp.min(a, b), c)
    down, _ = unit_scales(e)
    e = e * down
    box_area = 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
    area = 0.5 * wp.length(wp.cross((b - a) * down, (c - a) * down))
    levels = int(0)
    if area > 0.0 and wp.isfinite(box_area):
        ratio = box_area / area
        while ratio > max_ratio and levels < max_levels:
            ratio *= 0.5
            levels += 1
    return levels


@wp.kernel
def count_references_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    max_levels: int,
    max_ratio: float,
    levels: wp.array[wp.int32],
    counts: wp.array[wp.int32],
):
    i = wp.tid()
    k = split_levels(points[indices[i, 0]], points[indices[i, 1]], points[indices[i, 2]], max_levels, max_ratio)
    levels[i] = k
    counts[i] = 1 << k


# Pads of a clipped bound, relative to the triangle's corners' magnitude and to its extent, per axis. A clipped vertex
# ``p + (q - p) * s`` is rounded at the scale of the whole triangle, not of the half-box: each of the up to 6 clips
# errs by about ``u |x|`` (the sum) plus ``5 u |q - p|`` (the edge times a quotient of two differences), u = 2^-24,
# and the errors add up from clip to clip. A pad of the half-box's own size left out a sliver of a long triangle cut
# near the origin, where the half-box's coordinates are far smaller than the triangle's edges.
CORNER_PAD = wp.constant(6.0e-7)  # 10 u
EXTENT_PAD = wp.constant(2.4e-6)  # 40 u


@wp.func
def widened(lo: wp.vec3, hi: wp.vec3, tri_lo: wp.vec3, tri_hi: wp.vec3):
    """``[lo, hi]`` grown by the clipped vertices' rounding error, which scales with the triangle (its box
    ``[tri_lo, tri_hi]``), per axis."""
    pad = wp.max(wp.abs(tri_lo), wp.abs(tri_hi)) * CORNER_PAD + (tri_hi - tri_lo) * EXTENT_PAD
    return lo - pad, hi + pad


@wp.kernel
def write_references_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    levels: wp.array[wp.int32],
    offsets: wp.array[wp.int32],
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
    ref_prims: wp.array[wp.int32],
):
    """The ``2^levels[i]`` references of triangle ``i`` at ``offsets[i]``: reference ``j`` follows the halvings
    chosen by the bits of ``j`` (bit ``l`` set: the upper half at level ``l``)."""
    i = wp.tid()
    a = points[indices[i, 0]]
    b = points[indices[i, 1]]
    c = points[indices[i, 2]]
    tri_lo = wp.min(wp.min(a, b), c)
    tri_hi = wp.max(wp.max(a, b), c)
    k = levels[i]
    for j in range(1 << k):
        lo = tri_lo
        hi = tri_hi
        for level in range(k):
            e = hi - lo
            axis = int(0)
            if e[1] > e[axis]:
                axis = 1
            if e[2] > e[axis]:
                axis = 2
            mid = 0.5 * lo[axis] + 0.5 * hi[axis]  # the sum overflowed to inf past 2**127 (1.7e38)
            half_lo = lo
            half_hi = hi
            if (j >> level) & 1:
                half_lo[axis] = mid
            else:
                half_hi[axis] = mid
            r = clipped_bounds(a, b, c, half_lo, half_hi)
            c_lo, c_hi = widened(wp.vec3(r[0], r[1], r[2]), wp.vec3(r[3], r[4], r[5]), tri_lo, tri_hi)
            if r[0] <= r[3] and r[1] <= r[4] and r[2] <= r[5]:
                lo = wp.max(c_lo, half_lo)
                hi = wp.min(c_hi, half_hi)
            else:  # nothing left after rounding: keep the half-box itself
                lo = half_lo
                hi = half_hi
        s = offsets[i] + j
        lowers[s] = lo
        uppers[s] = hi
        centroids[s] = 0.5 * (lo + hi)
        ref_prims[s] = i


@dataclasses.dataclass
class References:
    """How the slots of a tree built with pre-splits were cut, so that a refit cuts the moved triangles alike
    (``refit.py``): each triangle's ``levels`` and first reference (``offsets``), the inputs of
    ``write_references_kernel``, ``count`` references in all, and ``slot_refs``, the reference in each leaf slot.
    Arrays are Warp arrays on the tree's device (``DeviceFlatBvh``) or numpy arrays (``FlatBvh``)."""

    levels: object
    offsets: object
    slot_refs: object
    count: int

    def numpy(self) -> References:
        """The same on the host."""
        return References(self.levels.numpy(), self.offsets.numpy(), self.slot_refs.numpy(), self.count)


def split_plan(points: wp.array, indices: wp.array, max_levels: int = MAX_SPLIT_LEVELS) -> tuple:
    """``(levels, offsets, count)``: how many times each triangle is halved (see module docstring), where its
    references start, and how many there are, on the triangles' device. Where the references would outnumber the
    triangles more than ``MAX_REFERENCES_PER_TRIANGLE`` times (a mesh made of slivers), fewer levels are allowed."""
    device = points.device
    n = indices.shape[0]
    levels = wp.empty(n, dtype=wp.int32, device=device)
    counts = wp.empty(n, dtype=wp.int32, device=device)
    offsets = wp.empty(n, dtype=wp.int32, device=device)
    budget = min(MAX_REFERENCES_PER_TRIANGLE * n, MAX_REFERENCES)
    # Counts and offsets are int32: no triangle count times 2^levels may overflow them.
    max_levels = min(int(max_levels), int(math.log2((2**31 - 1) / n)))
    for allowed in range(max_levels, -1, -1):
        wp.launch(count_references_kernel, n, inputs=[points, indices, allowed, float(SPLIT_RATIO)],
                  outputs=[levels, counts], device=device)
        wp.utils.array_scan(counts, offsets, inclusive=False)
        total = int(offsets[n - 1:].numpy()[0]) + int(counts[n - 1:].numpy()[0])
        if total <= budget:
            break
    return levels, offsets, total


def write_references(points: wp.array, indices: wp.array, levels: wp.array, offsets: wp.array, count: int) -> tuple:
    """``(lowers, uppers, centroids, ref_prims)`` of the ``count`` references of a :func:`split_plan`."""
    device = points.device
    out = [wp.empty(count, dtype=wp.vec3, device=device) for _ in range(3)]
    ref_prims = wp.empty(count, dtype=wp.int32, device=device)
    wp.launch(write_references_kernel, indices.shape[0], inputs=[points, indices, levels, offsets],
              outputs=[*out, ref_prims], device=device)
    return (*out, ref_prims)


def presplit_references(points: wp.array, indices: wp.array, max_levels: int = MAX_SPLIT_LEVELS):
    """``(lowers, uppers, centroids, ref_prims)`` of the references of every triangle (see module docstring and
    :func:`split_plan`), on the triangles' device; ``ref_prims`` maps a reference to its triangle."""
    return write_references(points, indices, *split_plan(points, indices, max_levels))


@wp.kernel
def map_slots_kernel(ref_prims: wp.array[wp.int32], prim_ids: wp.array[wp.int32]):
    """Slot -> reference becomes slot -> triangle."""
    s = wp.tid()
    prim_ids[s] = ref_prims[prim_ids[s]]
