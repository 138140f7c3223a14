"""The wide layout's SAH collapse of the canonical binary tree (the rule is in ``wide.py``'s docstring), as Warp
kernels, so that a tree built on a GPU becomes wide without leaving it.

1. Bottom-up over the binary tree (one thread per leaf; the second thread to reach a node computes it, as in
   ``flatten.py``): for every node ``n`` and every ``j`` in ``1 .. width`` the least cost of ``n``'s subtree
   spread over at most ``j`` child slots (Ylitie et al., "Efficient Incoherent Ray Traversal on GPUs Through
   Compressed Wide BVHs", 2017, section 3.1).
2. Top down, level by level: one thread per wide node takes the distribution of least cost of its binary node's
   subtree over ``width`` slots, a prefix scan numbers the inner children, which become the next level's nodes, and
   one small read back gives the next level's size.

Costs are float64 and FMA contraction is off, and ties go to the first split and then to the most slots, so the tree
is the same on every device.
"""

from __future__ import annotations

import warp as wp

from .common import read_int
from .flatten import thread_fence

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
def binary_parents_kernel(
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    # outputs
    parents: wp.array[wp.int32],
    visits: wp.array[wp.int32],
):
    """Parent of both children of inner node ``i`` (the root keeps -1), and a zero arrival count for it."""
    i = wp.tid()
    visits[i] = 0
    if prim_count[i] == 0:
        parents[left_first[i]] = i
        parents[left_first[i] + 1] = i


@wp.func
def split_cost(costs: wp.array[wp.float64], width: int, left: int, right: int, slots: int):
    """Least cost of giving ``k`` of ``slots`` child slots to ``left`` and the rest to ``right``, and that ``k``
    (the first on ties)."""
    best = wp.float64(wp.inf)
    best_k = int(1)
    for k in range(1, slots):
        cost = costs[left * width + k - 1] + costs[right * width + slots - k - 1]
        if cost < best:
            best = cost
            best_k = k
    return best, best_k


@wp.kernel
def slot_costs_kernel(
    width: int,
    parents: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    # outputs
    visits: wp.array[wp.int32],
    costs: wp.array[wp.float64],
):
    """Step 1 for binary leaf ``node`` (other threads return) and, going up, every node it reaches second.
    ``costs[n * width + j - 1]``: the summed half areas of the wide nodes that ``n``'s subtree needs when it may fill
    ``j`` child slots; a leaf fills one and needs none, an inner node in one slot becomes a wide node itself (its area
    plus the cost of its own ``width`` slots), in ``j >= 2`` slots it may also be opened (its children share the
    slots)."""
    node = wp.tid()
    if prim_count[node] == 0:
        return
    for j in range(width):
        costs[node * width + j] = wp.float64(0.0)
    parent = parents[node]
    while parent >= 0:
        thread_fence()
        if wp.atomic_add(visits, parent, 1) == 0:
            return
        thread_fence()
        left = left_first[parent]
        own, k = split_cost(costs, width, left, left + 1, width)  # also the opened cost in all width slots
        best = half_area64(lowers[parent], uppers[parent]) + own
        costs[parent * width] = best
        for j in range(2, width):
            opened, k = split_cost(costs, width, left, left + 1, j)
            best = wp.min(best, opened)
            costs[parent * width + j - 1] = best
        costs[parent * width + width - 1] = wp.min(best, own)
        parent = parents[parent]


@wp.kernel
def open_children_kernel(
    width: int,
    sources: wp.array[wp.int32],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    costs: wp.array[wp.float64],
    # outputs
    slots: wp.array[wp.int32],
    budgets: wp.array[wp.int32],
    inner_counts: wp.array[wp.int32],
):
    """The binary nodes (-1: empty) in the ``width`` child slots of wide node ``i``, made from binary inner node
    ``sources[i]`` (or holding it, for a leaf root), and how many of them are inner nodes. Each slot holds a node
    and the slots it may fill; a node that its least cost opens gives its slot to its left child and a new slot to
    its right child, each with its share of the slots (most slots on ties)."""
    i = wp.tid()
    base = i * width
    source = sources[i]
    for j in range(width):
        slots[base + j] = -1
    if prim_count[source] > 0:
        slots[base] = source
        inner_counts[i] = 0
        return
    left = left_first[source]
    own, k = split_cost(costs, width, left, left + 1, width)
    slots[base] = left
    budgets[base] = k
    slots[base + 1] = left + 1
    budgets[base + 1] = width - k
    used = int(2)
    j = int(0)
    while j < used:
        c = slots[base + j]
        share = int(0)  # slots that c's least cost opens it into (0: c stays in one slot)
        share_left = int(0)  # of those, the left child's
        if prim_count[c] == 0:
            b = budgets[base + j]
            target = costs[c * width + b - 1]
            for s in range(2, b + 1):
                opened, k = split_cost(costs, width, left_first[c], left_first[c] + 1, s)
                if opened == target:
                    share = s
                    share_left = k
        if share == 0:
            j += 1
        else:
            slots[base + j] = left_first[c]
            budgets[base + j] = share_left
            slots[base + used] = left_first[c] + 1
            budgets[base + used] = share - share_left
            used += 1
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
        binary = [lowers, uppers, left_first, prim_count]
        n = len(left_first)
        parents = wp.full(n, -1, dtype=wp.int32)
        visits = wp.empty(n, dtype=wp.int32)
        costs = wp.empty(n * width, dtype=wp.float64)
        wp.launch(binary_parents_kernel, n, inputs=[left_first, prim_count], outputs=[parents, visits])
        wp.launch(slot_costs_kernel, n, inputs=[width, parents] + binary, outputs=[visits, costs])
        del parents, visits
        slots = wp.empty(capacity * width, dtype=wp.int32)
        budgets = wp.empty(capacity * width, dtype=wp.int32)
        inner_counts = wp.empty(capacity, dtype=wp.int32)
        inner_ends = wp.empty(capacity, dtype=wp.int32)
        sources = wp.zeros(capacity, dtype=wp.int32)  # the root first
        next_sources = wp.empty(capacity, dtype=wp.int32)
        offset, k, levels = 0, 1, 0
        while k > 0:
            wp.launch(
                open_children_kernel,
                k,
                inputs=[width, sources, left_first, prim_count, costs],
                outputs=[slots, budgets, inner_counts],
            )
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
