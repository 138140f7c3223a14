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

Fast path: a source tree no deeper than ``MAX_DEPTH - 1`` needs no halving anywhere (a child of ``c`` triangles
at depth ``d + 1`` has a leaf at depth ``>= d + 1 + ceil(log2 c)``), so the tree of step 1 *is* the source tree.
Steps 1 and 2 then become one bottom-up launch over the source tree (Karras 2012, section 4: one thread per leaf,
the second thread to reach a node computes it), which also measures the height; only a deeper tree falls back to
the level-by-level steps. Both give the same tree, bit for bit. Each level of step 3 reads its size back to the
host (one small synchronizing copy per level).
"""

from __future__ import annotations

import warp as wp

from .common import MAX_DEPTH, ceil_log2, half_area, read_int, stage
from .layout import DeviceFlatBvh

wp.set_module_options({"enable_backward": False})


@wp.func_native(
    """
#if defined(__CUDA_ARCH__)
__threadfence();
#endif
"""
)
def thread_fence():
    """``__threadfence()`` on CUDA (nothing on the CPU, whose launches run one thread after another): with the
    arrival atomic it orders one thread's node writes before another thread's reads (release and acquire)."""
    ...


@wp.func
def source_node(ref: int, leaf_base: int):
    """Node of a source child reference in the bottom-up node space: internal nodes ``0 .. N-2``, then the leaf
    of slot ``s`` at ``leaf_base + s``."""
    return wp.where(ref >= 0, ref, leaf_base - ref - 1)


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


@wp.func
def collapsed_cost(
    area: float,
    cost_left: float,
    cost_right: float,
    count: int,
    leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
):
    """SAH cost of an inner node of half area ``area`` over ``count`` triangles, and 1 when it is cheaper as one leaf
    (at most ``leaf_size`` triangles) than split into its two children, 0 otherwise."""
    split = traversal_cost * area + cost_left + cost_right
    leaf = intersection_cost * float(count) * area
    if count <= leaf_size and leaf <= split:
        return leaf, 1
    return split, 0


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
    cost, flag = collapsed_cost(
        half_area(lo, hi), costs[first], costs[first + 1], count, leaf_size, traversal_cost, intersection_cost
    )
    costs[n] = cost
    collapse[n] = flag


@wp.kernel
def source_parents_kernel(
    root: int,
    leaf_base: int,
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    # outputs
    parents: wp.array[wp.int32],
    visits: wp.array[wp.int32],
):
    """Parent of every source node (-1 for the root) and a zero arrival count for every internal node."""
    i = wp.tid()
    parents[source_node(src_left[i], leaf_base)] = i
    parents[source_node(src_right[i], leaf_base)] = i
    visits[i] = 0
    if i == root:
        parents[i] = -1


@wp.kernel
def bottom_up_kernel(
    leaf_base: int,
    parents: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    # outputs
    visits: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    costs: wp.array[float],
    collapse: wp.array[wp.int32],
    starts: wp.array[wp.int32],
    counts: wp.array[wp.int32],
    heights: wp.array[wp.int32],
):
    """Steps 1 and 2 on the source tree for the leaf of slot ``s`` and, going up, every node it reaches second:
    box, best SAH cost, collapse flag (``collapsed_cost``, as ``bounds_and_cost_kernel``), first slot, triangle
    count and height."""
    s = wp.tid()
    node = leaf_base + s
    lo = prim_lowers[slot_prims[s]]
    hi = prim_uppers[slot_prims[s]]
    lowers[node] = lo
    uppers[node] = hi
    costs[node] = intersection_cost * float(1) * half_area(lo, hi)
    collapse[node] = 1
    starts[node] = s
    counts[node] = 1
    heights[node] = 0
    parent = parents[node]
    while parent >= 0:
        # Publish this child, then stop unless the sibling is done too.
        thread_fence()
        if wp.atomic_add(visits, parent, 1) == 0:
            return
        thread_fence()
        left = source_node(src_left[parent], leaf_base)
        right = source_node(src_right[parent], leaf_base)
        count = src_counts[parent]
        lo = wp.min(lowers[left], lowers[right])
        hi = wp.max(uppers[left], uppers[right])
        lowers[parent] = lo
        uppers[parent] = hi
        cost, flag = collapsed_cost(
            half_area(lo, hi), costs[left], costs[right], count, leaf_size, traversal_cost, intersection_cost
        )
        costs[parent] = cost
        collapse[parent] = flag
        starts[parent] = starts[left]
        counts[parent] = count
        heights[parent] = 1 + wp.max(heights[left], heights[right])
        parent = parents[parent]


@wp.kernel
def split_collapsed_kernel(
    level_begin: int,
    node_srcs: wp.array[wp.int32],
    leaf_base: int,
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
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
    """Step 3 for node ``level_begin + k``: copy full-tree node ``src``; a leaf if ``src`` is collapsed. With
    ``leaf_base >= 0`` the full tree is the source tree in bottom-up node space (children from ``src_left`` and
    ``src_right``), else the breadth-first tree of step 1 (children ``c, c + 1``)."""
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
    d = c + 1
    if leaf_base >= 0:
        c = source_node(src_left[s], leaf_base)
        d = source_node(src_right[s], leaf_base)
    child_starts[2 * k] = full_starts[c]
    child_counts[2 * k] = full_counts[c]
    child_srcs[2 * k] = c
    child_starts[2 * k + 1] = full_starts[d]
    child_counts[2 * k + 1] = full_counts[d]
    child_srcs[2 * k + 1] = d


class _Levels:
    """Breadth-first emission bookkeeping: node arrays of capacity ``2 N - 1`` and per-level scratch."""

    def __init__(self, n: int, root_src: int):
        # Every emitted node's entries are written by the level kernels, so only the root's are set here.
        capacity = 2 * n - 1
        self.left_first = wp.empty(capacity, dtype=wp.int32)  # left child (inner) or first slot (leaf)
        self.prim_count = wp.empty(capacity, dtype=wp.int32)  # triangles of a leaf, 0 for inner nodes
        self.starts = wp.empty(capacity, dtype=wp.int32)  # first slot of the subtree
        self.counts = wp.empty(capacity, dtype=wp.int32)  # triangles in the subtree
        self.srcs = wp.empty(capacity, dtype=wp.int32)  # source node, -1 for none
        self.starts[:1].fill_(0)
        self.counts[:1].fill_(n)
        self.srcs[:1].fill_(root_src)
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
    timers: dict | None = None,
    bottom_up: bool = True,
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
        timers: if given, the milliseconds of each stage are appended to ``timers[stage]`` (synchronizing).
        bottom_up: try the bottom-up fast path first; ``False`` forces the level-by-level steps 1 and 2 (tests
            compare the two).
    """
    n = len(slot_prims)
    device = slot_prims.device
    sah = [int(leaf_size), float(traversal_cost), float(intersection_cost)]
    with wp.ScopedDevice(device):
        fast = False
        if n > 1 and bottom_up:
            # Steps 1 and 2 in one bottom-up pass over the source tree; its height says whether that was valid.
            with stage("flatten: bottom-up boxes and costs", timers):
                m, leaf_base = 2 * n - 1, n - 1
                parents = wp.empty(m, dtype=wp.int32)
                visits = wp.empty(n - 1, dtype=wp.int32)
                lowers = wp.empty(m, dtype=wp.vec3)
                uppers = wp.empty(m, dtype=wp.vec3)
                costs = wp.empty(m, dtype=float)
                collapse = wp.empty(m, dtype=wp.int32)
                starts = wp.empty(m, dtype=wp.int32)
                counts = wp.empty(m, dtype=wp.int32)
                heights = wp.empty(m, dtype=wp.int32)
                wp.launch(
                    source_parents_kernel,
                    n - 1,
                    inputs=[root, leaf_base, src_left, src_right],
                    outputs=[parents, visits],
                )
                wp.launch(
                    bottom_up_kernel,
                    n,
                    inputs=[leaf_base, parents, src_left, src_right, src_counts, slot_prims, prim_lowers, prim_uppers]
                    + sah,
                    outputs=[visits, lowers, uppers, costs, collapse, starts, counts, heights],
                )
                fast = read_int(heights, root) <= MAX_DEPTH - 1
            if fast:
                full_left_first, root_src = starts, root  # full_left_first is unused with leaf_base >= 0
        if n <= 1 or not fast:
            with stage("flatten: full tree by levels", timers):
                full, lowers, uppers, costs, collapse = _full_tree(
                    slot_prims, src_left, src_right, src_counts, root, prim_lowers, prim_uppers, sah
                )
            leaf_base, full_left_first, starts, counts, root_src = -1, full.left_first, full.starts, full.counts, 0

        # Step 3: emit again, stopping at collapsed subtrees.
        with stage("flatten: emit by levels", timers):
            out = _Levels(n, root_src)
            out_lowers = wp.empty(len(out.left_first), dtype=wp.vec3)
            out_uppers = wp.empty(len(out.left_first), dtype=wp.vec3)
            begin, k = 0, 1
            while k > 0:
                wp.launch(
                    split_collapsed_kernel,
                    k,
                    inputs=[begin, out.srcs, leaf_base, src_left, src_right, full_left_first, starts, counts]
                    + [lowers, uppers, collapse],
                    outputs=[out.left_first, out.prim_count, out_lowers, out_uppers, out.split_flags]
                    + [out.child_starts, out.child_counts, out.child_srcs],
                )
                next_begin = out.num_nodes
                k = out.grow(begin, k)
                begin = next_begin

        m = out.num_nodes
        return DeviceFlatBvh(
            out_lowers[:m], out_uppers[:m], out.left_first[:m], out.prim_count[:m], slot_prims, builder
        )


def _full_tree(slot_prims, src_left, src_right, src_counts, root, prim_lowers, prim_uppers, sah) -> tuple:
    """Steps 1 and 2 level by level (any source tree): ``(levels, lowers, uppers, costs, collapse)`` of the full
    breadth-first tree."""
    n = len(slot_prims)
    full = _Levels(n, root if n > 1 else -1)
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

    # Boxes and collapse decisions, deepest level first.
    m = full.num_nodes
    lowers = wp.empty(m, dtype=wp.vec3)
    uppers = wp.empty(m, dtype=wp.vec3)
    costs = wp.empty(m, dtype=float)
    collapse = wp.empty(m, dtype=wp.int32)
    for lo, hi in reversed(full.bounds):
        wp.launch(
            bounds_and_cost_kernel,
            hi - lo,
            inputs=[lo, full.left_first, full.prim_count, full.counts, slot_prims, prim_lowers, prim_uppers] + sah,
            outputs=[lowers, uppers, costs, collapse],
        )
    return full, lowers, uppers, costs, collapse
