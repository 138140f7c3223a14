"""The wide layout's SAH collapse of the canonical binary tree (the rule is in ``wide.py``'s docstring), as Warp
kernels, so that a tree built on a GPU becomes wide without leaving it.

Wide nodes are made level by level: one thread per node of a level opens its binary children (largest surface area
first), a prefix scan numbers the inner children, which become the next level's nodes, and one small read back
gives the next level's size. Areas are float64 and FMA contraction is off, so the choice of child (first one on
ties) is the same on every device.
"""

from __future__ import annotations

import warp as wp

from .common import read_int

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def half_area64(lower: wp.vec3, upper: wp.vec3):
    """Half the surface area of a box in float64 (0 for an inverted box), as ``stats.half_areas``."""
    zero = wp.float64(0.0)
    d0 = wp.max(wp.float64(upper[0]) - wp.float64(lower[0]), zero)
    d1 = wp.max(wp.float64(upper[1]) - wp.float64(lower[1]), zero)
    d2 = wp.max(wp.float64(upper[2]) - wp.float64(lower[2]), zero)
    return d0 * d1 + d1 * d2 + d2 * d0


@wp.kernel
def open_children_kernel(
    width: int,
    sources: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    # outputs
    slots: wp.array[wp.int32],
    inner_counts: wp.array[wp.int32],
):
    """The binary nodes (-1: empty) in the ``width`` child slots of wide node ``i``, made from binary inner node
    ``sources[i]`` (or holding it, for a leaf root), and how many of them are inner nodes."""
    i = wp.tid()
    base = i * width
    source = sources[i]
    for j in range(width):
        slots[base + j] = -1
    if prim_count[source] > 0:
        slots[base] = source
        inner_counts[i] = 0
        return
    slots[base] = left_first[source]
    slots[base + 1] = left_first[source] + 1
    for step in range(width - 2):
        # Open the inner child of largest area (slots 0 .. step + 1 are in use); stop when there is none.
        best = int(-1)
        best_area = wp.float64(0.0)
        for j in range(step + 2):
            c = slots[base + j]
            if prim_count[c] == 0:
                area = half_area64(lowers[c], uppers[c])
                if best < 0 or area > best_area:
                    best = j
                    best_area = area
        if best < 0:
            break
        c = slots[base + best]
        slots[base + best] = left_first[c]
        slots[base + step + 2] = left_first[c] + 1
    inner = int(0)
    for j in range(width):
        c = slots[base + j]
        if c >= 0 and prim_count[c] == 0:
            inner += 1
    inner_counts[i] = inner


@wp.kernel
def emit_children_kernel(
    width: int,
    level_offset: int,
    next_offset: int,
    slots: wp.array[wp.int32],
    inner_counts: wp.array[wp.int32],
    inner_ends: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    # outputs
    out_lowers: wp.array[wp.vec3],
    out_uppers: wp.array[wp.vec3],
    out_refs: wp.array[wp.int32],
    out_counts: wp.array[wp.int32],
    next_sources: wp.array[wp.int32],
):
    """Child slot ``e`` of the level: box, and a leaf's slot range, an inner child's wide node (numbered after the
    level, in slot order) or an empty slot. Inner children become the next level's sources."""
    e = wp.tid()
    i = e / width
    out = level_offset * width + e
    c = slots[e]
    if c < 0:
        out_lowers[out] = wp.vec3(wp.inf)
        out_uppers[out] = wp.vec3(-wp.inf)
        out_refs[out] = 0
        out_counts[out] = -1
        return
    out_lowers[out] = lowers[c]
    out_uppers[out] = uppers[c]
    if prim_count[c] > 0:
        out_refs[out] = left_first[c]
        out_counts[out] = prim_count[c]
        return
    rank = inner_ends[i] - inner_counts[i]
    for j in range(i * width, e):
        if slots[j] >= 0 and prim_count[slots[j]] == 0:
            rank += 1
    out_refs[out] = next_offset + rank
    out_counts[out] = 0
    next_sources[rank] = c


def collapse_wide(lowers: wp.array, uppers: wp.array, left_first: wp.array, prim_count: wp.array, width: int):
    """``(lowers, uppers, refs, counts, depth)`` of the ``width``-wide tree of a binary tree with at least one
    node; arrays on the binary tree's device, ``width`` child slots per wide node (see ``wide.WideBvh``)."""
    device = left_first.device
    capacity = max(1, (len(left_first) - 1) // 2)  # a wide node per binary inner node at most
    with wp.ScopedDevice(device):
        out = [wp.empty(capacity * width, dtype=t) for t in (wp.vec3, wp.vec3, wp.int32, wp.int32)]
        slots = wp.empty(capacity * width, dtype=wp.int32)
        inner_counts = wp.empty(capacity, dtype=wp.int32)
        inner_ends = wp.empty(capacity, dtype=wp.int32)
        sources = wp.zeros(capacity, dtype=wp.int32)  # the root first
        next_sources = wp.empty(capacity, dtype=wp.int32)
        binary = [lowers, uppers, left_first, prim_count]
        offset, k, levels = 0, 1, 0
        while k > 0:
            wp.launch(open_children_kernel, k, inputs=[width, sources] + binary, outputs=[slots, inner_counts])
            wp.utils.array_scan(inner_counts[:k], inner_ends[:k], inclusive=True)
            inner = read_int(inner_ends, k - 1)  # one read back per level
            wp.launch(
                emit_children_kernel,
                k * width,
                inputs=[width, offset, offset + k, slots, inner_counts, inner_ends] + binary,
                outputs=out + [next_sources],
            )
            offset, k, levels = offset + k, inner, levels + 1
            sources, next_sources = next_sources, sources
        return tuple(a[: offset * width] for a in out) + (levels - 1,)
