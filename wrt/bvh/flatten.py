"""Bottom-up builder output -> canonical FlatBvh, in Warp kernels: breadth-first renumbering, the depth guarantee,
bounds, and SAH-based leaf collapsing.

The input ("source tree") is a binary tree over ``N`` triangles in slot order, as the bottom-up builders make it:
internal nodes ``0 .. N-2`` with child references ``src_left[k], src_right[k]`` (``>= 0``: internal node,
``< 0``: the single triangle in slot ``-ref - 1``) and triangle counts ``src_counts[k]``, such that every
subtree covers a contiguous slot range (the left child's first). Karras radix trees have this property directly
(slots = Morton order); PLOC trees get it from a depth-first slot assignment.

1. Emit the source tree breadth first, level by level, with the two children of a node side by side. A split
   that would break the depth guarantee (``common.py``) is replaced by halving the node's slot range, and the
   halves are halved further ("virtual" nodes). Leaves hold one triangle.
2. Bottom-up over the levels: node boxes, and the SAH cost of the best collapse of every subtree: a subtree of at
   most ``leaf_size`` triangles becomes a leaf when ``C_i N A <= C_t A + cost(left) + cost(right)``.
3. Emit again from the tree of step 1, stopping at collapsed subtrees (boxes and slot ranges carry over).
"""

from __future__ import annotations

import warp as wp

from .common import MAX_DEPTH, ceil_log2, half_area, read_int
from .layout import DeviceFlatBvh

wp.set_module_options({"enable_backward": False})


@wp.kernel
def split_source_kernel(
    level_begin: int,
    depth: int,
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_srcs: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
    max_depth: int,
    # outputs
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    split_flags: wp.array[wp.int32],
    child_starts: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_srcs: wp.array[wp.int32],
):
    """Step 1 for node ``level_begin + k``: a one-triangle leaf, the source split, or halving."""
    k = wp.tid()
    n = level_begin + k
    start = node_starts[n]
    count = node_counts[n]
    src = node_srcs[n]
    if count <= 1:
        left_first[n] = start
        prim_count[n] = count
        split_flags[k] = 0
        return
    # Halve unless the source split keeps both children within the depth guarantee.
    n_left = count / 2
    l_src = int(-1)
    r_src = int(-1)
    if src >= 0:
        left = src_left[src]
        cl = int(1)
        if left >= 0:
            cl = src_counts[left]
        if depth + 1 + ceil_log2(wp.max(cl, count - cl)) <= max_depth - 1:
            n_left = cl
            l_src = wp.max(left, -1)
            r_src = wp.max(src_right[src], -1)
    prim_count[n] = 0
    split_flags[k] = 1
    child_starts[2 * k] = start
    child_counts[2 * k] = n_left
    child_srcs[2 * k] = l_src
    child_starts[2 * k + 1] = start + n_left
    child_counts[2 * k + 1] = count - n_left
    child_srcs[2 * k + 1] = r_src


@wp.kernel
def make_level_children_kernel(
    level_begin: int,
    first_free: int,
    split_flags: wp.array[wp.int32],
    split_ranks: wp.array[wp.int32],
    child_starts: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_srcs: wp.array[wp.int32],
    # outputs
    left_first: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_srcs: wp.array[wp.int32],
):
    """Places the two children of every split node of the level side by side, after the nodes allocated so far."""
    k = wp.tid()
    if split_flags[k] == 0:
        return
    child = first_free + 2 * (split_ranks[k] - 1)  # inclusive rank
    left_first[level_begin + k] = child
    for j in range(2):
        node_starts[child + j] = child_starts[2 * k + j]
        node_counts[child + j] = child_counts[2 * k + j]
        node_srcs[child + j] = child_srcs[2 * k + j]


@wp.kernel
def bounds_and_cost_kernel(
    level_begin: int,
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    costs: wp.array[float],
    collapse: wp.array[wp.int32],
):
    """Step 2 for node ``level_begin + k`` (its children are done): box, best SAH cost, collapse flag."""
    n = level_begin + wp.tid()
    first = left_first[n]
    count = node_counts[n]
    lo = wp.vec3(wp.inf)
    hi = wp.vec3(-wp.inf)
    if prim_count[n] > 0:
        for s in range(first, first + count):
            lo = wp.min(lo, prim_lowers[slot_prims[s]])
            hi = wp.max(hi, prim_uppers[slot_prims[s]])
        lowers[n] = lo
        uppers[n] = hi
        costs[n] = intersection_cost * float(count) * half_area(lo, hi)
        collapse[n] = 1
        return
    lo = wp.min(lowers[first], lowers[first + 1])
    hi = wp.max(uppers[first], uppers[first + 1])
    lowers[n] = lo
    uppers[n] = hi
    area = half_area(lo, hi)
    split = traversal_cost * area + costs[first] + costs[first + 1]
    leaf = intersection_cost * float(count) * area
    if count <= leaf_size and leaf <= split:
        costs[n] = leaf
        collapse[n] = 1
    else:
        costs[n] = split
        collapse[n] = 0


@wp.kernel
def split_collapsed_kernel(
    level_begin: int,
    node_srcs: wp.array[wp.int32],
    full_left_first: wp.array[wp.int32],
    full_starts: wp.array[wp.int32],
    full_counts: wp.array[wp.int32],
    full_lowers: wp.array[wp.vec3],
    full_uppers: wp.array[wp.vec3],
    collapse: wp.array[wp.int32],
    # outputs
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    split_flags: wp.array[wp.int32],
    child_starts: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_srcs: wp.array[wp.int32],
):
    """Step 3 for node ``level_begin + k``: copy full-tree node ``src``; a leaf if ``src`` is collapsed."""
    k = wp.tid()
    n = level_begin + k
    s = node_srcs[n]
    lowers[n] = full_lowers[s]
    uppers[n] = full_uppers[s]
    if collapse[s] == 1:
        left_first[n] = full_starts[s]
        prim_count[n] = full_counts[s]
        split_flags[k] = 0
        return
    prim_count[n] = 0
    split_flags[k] = 1
    c = full_left_first[s]
    for j in range(2):
        child_starts[2 * k + j] = full_starts[c + j]
        child_counts[2 * k + j] = full_counts[c + j]
        child_srcs[2 * k + j] = c + j


class _Levels:
    """Breadth-first emission bookkeeping: node arrays of capacity ``2 N - 1`` and per-level scratch."""

    def __init__(self, n: int):
        capacity = 2 * n - 1
        self.left_first = wp.zeros(capacity, dtype=wp.int32)  # left child (inner) or first slot (leaf)
        self.prim_count = wp.zeros(capacity, dtype=wp.int32)  # triangles of a leaf, 0 for inner nodes
        self.starts = wp.zeros(capacity, dtype=wp.int32)  # first slot of the subtree
        self.counts = wp.zeros(capacity, dtype=wp.int32)  # triangles in the subtree
        self.srcs = wp.zeros(capacity, dtype=wp.int32)  # source node, -1 for none
        half = max(n, 1)
        self.split_flags = wp.empty(half, dtype=wp.int32)
        self.split_ranks = wp.empty(half, dtype=wp.int32)
        self.child_starts = wp.empty(2 * half, dtype=wp.int32)
        self.child_counts = wp.empty(2 * half, dtype=wp.int32)
        self.child_srcs = wp.empty(2 * half, dtype=wp.int32)
        self.bounds = []  # [begin, end) of every level
        self.num_nodes = 1

    def grow(self, begin: int, k: int) -> int:
        """Allocates the children of level ``[begin, begin + k)``; returns the next level's size."""
        wp.utils.array_scan(self.split_flags[:k], self.split_ranks[:k], inclusive=True)
        splits = read_int(self.split_ranks, k - 1)  # one device-to-host read per level
        wp.launch(
            make_level_children_kernel,
            k,
            inputs=[begin, self.num_nodes, self.split_flags, self.split_ranks]
            + [self.child_starts, self.child_counts, self.child_srcs],
            outputs=[self.left_first, self.starts, self.counts, self.srcs],
        )
        self.num_nodes += 2 * splits
        return 2 * splits


def flatten_source(
    slot_prims: wp.array,
    src_left: wp.array,
    src_right: wp.array,
    src_counts: wp.array,
    root: int,
    prim_lowers: wp.array,
    prim_uppers: wp.array,
    *,
    leaf_size: int,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    builder: str = "",
) -> DeviceFlatBvh:
    """Canonical tree (on the device) of a source tree (see module docstring); all arrays on one device.

    Args:
        slot_prims: ``(N,)`` int32 triangle in each slot.
        src_left: ``(N-1,)`` int32 left child reference of each internal source node.
        src_right: ``(N-1,)`` int32 right child reference.
        src_counts: ``(N-1,)`` int32 triangles below each internal source node.
        root: the root's internal index (ignored for ``N == 1``).
        prim_lowers: ``(N,)`` vec3 triangle box minima, by triangle id.
        prim_uppers: ``(N,)`` vec3 triangle box maxima.
        leaf_size: most triangles in a collapsed leaf.
        traversal_cost: SAH ``C_t`` of the collapse decision.
        intersection_cost: SAH ``C_i``.
        builder: name recorded on the result.
    """
    n = len(slot_prims)
    device = slot_prims.device
    with wp.ScopedDevice(device):
        # Step 1: the full tree, breadth first, one triangle per leaf.
        full = _Levels(n)
        full.counts.fill_(n)  # only the root's entries matter here
        full.srcs.fill_(root if n > 1 else -1)
        begin, k, depth = 0, 1, 0
        while k > 0:
            full.bounds.append((begin, begin + k))
            wp.launch(
                split_source_kernel,
                k,
                inputs=[begin, depth, full.starts, full.counts, full.srcs, src_left, src_right, src_counts, MAX_DEPTH],
                outputs=[full.left_first, full.prim_count, full.split_flags, full.child_starts, full.child_counts]
                + [full.child_srcs],
            )
            next_begin = full.num_nodes
            k = full.grow(begin, k)
            begin, depth = next_begin, depth + 1

        # Step 2: boxes and collapse decisions, deepest level first.
        m = full.num_nodes
        lowers = wp.empty(m, dtype=wp.vec3)
        uppers = wp.empty(m, dtype=wp.vec3)
        costs = wp.empty(m, dtype=float)
        collapse = wp.empty(m, dtype=wp.int32)
        for lo, hi in reversed(full.bounds):
            wp.launch(
                bounds_and_cost_kernel,
                hi - lo,
                inputs=[lo, full.left_first, full.prim_count, full.counts, slot_prims, prim_lowers, prim_uppers]
                + [int(leaf_size), float(traversal_cost), float(intersection_cost)],
                outputs=[lowers, uppers, costs, collapse],
            )

        # Step 3: emit again, stopping at collapsed subtrees.
        out = _Levels(n)
        out.srcs.fill_(0)
        out_lowers = wp.empty(m, dtype=wp.vec3)
        out_uppers = wp.empty(m, dtype=wp.vec3)
        begin, k = 0, 1
        while k > 0:
            wp.launch(
                split_collapsed_kernel,
                k,
                inputs=[begin, out.srcs, full.left_first, full.starts, full.counts, lowers, uppers, collapse],
                outputs=[out.left_first, out.prim_count, out_lowers, out_uppers, out.split_flags, out.child_starts]
                + [out.child_counts, out.child_srcs],
            )
            next_begin = out.num_nodes
            k = out.grow(begin, k)
            begin = next_begin

        m = out.num_nodes
        return DeviceFlatBvh(
            out_lowers[:m], out_uppers[:m], out.left_first[:m], out.prim_count[:m], slot_prims, builder
        )
