"""Bottom-up builder output -> canonical FlatBvh, in Warp kernels: the depth guarantee, bounds, SAH-based leaf
collapsing and a depth-first node order, with a fixed number of launches (no pass per tree level).

The input ("source tree") is a binary tree over ``N`` triangles in slot order, as the bottom-up builders make it:
internal nodes ``0 .. N-2`` with child references ``src_left[k], src_right[k]`` (``>= 0``: internal node,
``< 0``: the single triangle in slot ``-ref - 1``) and triangle counts ``src_counts[k]``, such that every
subtree covers a contiguous slot range (the left child's first). Karras radix trees have this property directly
(slots = Morton order); PLOC trees get it from a depth-first slot assignment.

1. Bottom-up over the source tree (Karras 2012, section 4: one thread per leaf, the second thread to reach a node
   computes it): node boxes, slot ranges, heights, and the SAH cost of the best collapse of every subtree: a
   subtree of at most ``leaf_size`` triangles becomes a leaf when ``C_i N A <= C_t A + cost(left) + cost(right)``.
2. Only if the tree is deeper than ``MAX_DEPTH - 1`` (``common.py``): the topmost nodes whose source split breaks
   the depth guarantee (a child of ``c`` triangles at depth ``d + 1`` needs ``d + 1 + ceil(log2 c) <=
   MAX_DEPTH - 1``) get their subtree replaced by one that halves the slot range at every node. Depths and the
   topmost failing ancestor come from pointer jumping (``log2`` of the height in launches). A subtree over slots
   ``[s, e]`` has one inner node per split position ``s .. e-1`` whichever its shape, so the halving subtree
   reuses the replaced subtree's node ids, each taking the split position it had; then step 1 runs again.
3. Emit the nodes that no collapsed ancestor hides, the two children of an inner node side by side, the pairs in
   depth-first (pre-)order of their parents. Pre-order sorts inner nodes by first slot, then depth; the inner
   nodes that share a first slot form a chain of left children, so a node's pair index is the number of inner
   nodes with a lower first slot (a prefix scan over slots) plus its place in its chain.
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
def source_parents_kernel(
    leaf_base: int,
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    # outputs
    parents: wp.array[wp.int32],
    visits: wp.array[wp.int32],
):
    """Parent of both children of internal node ``i``, and a zero arrival count for it."""
    i = wp.tid()
    parents[source_node(src_left[i], leaf_base)] = i
    parents[source_node(src_right[i], leaf_base)] = i
    visits[i] = 0


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
def init_depth_kernel(parents: wp.array[wp.int32], jump: wp.array[wp.int32], depth: wp.array[wp.int32]):
    """Pointer jumping, start: each internal node's parent and its distance to it."""
    i = wp.tid()
    p = parents[i]
    jump[i] = p
    depth[i] = wp.where(p >= 0, 1, 0)


@wp.kernel
def depth_round_kernel(
    jump: wp.array[wp.int32],
    depth: wp.array[wp.int32],
    # outputs
    new_jump: wp.array[wp.int32],
    new_depth: wp.array[wp.int32],
):
    """One round of pointer jumping: the distance to the ancestor ``2^k`` steps up is added, the jump doubles."""
    i = wp.tid()
    j = jump[i]
    if j >= 0:
        new_depth[i] = depth[i] + depth[j]
        new_jump[i] = jump[j]
    else:
        new_depth[i] = depth[i]
        new_jump[i] = -1


@wp.kernel
def depth_failures_kernel(
    parents: wp.array[wp.int32],
    depth: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
    starts: wp.array[wp.int32],
    max_depth: int,
    # outputs
    jump: wp.array[wp.int32],
    top: wp.array[wp.int32],
    split_pos: wp.array[wp.int32],
    split_node: wp.array[wp.int32],
):
    """For internal node ``i``: itself as ``top`` if its source split breaks the depth guarantee (else -1), and its
    split position (the last slot of its left child), in both directions."""
    i = wp.tid()
    left = src_left[i]
    cl = int(1)
    if left >= 0:
        cl = src_counts[left]
    count = src_counts[i]
    fails = depth[i] + 1 + ceil_log2(wp.max(cl, count - cl)) > max_depth - 1
    top[i] = wp.where(fails, i, -1)
    jump[i] = parents[i]
    m = starts[i] + cl - 1
    split_pos[i] = m
    split_node[m] = i


@wp.kernel
def top_round_kernel(
    jump: wp.array[wp.int32],
    top: wp.array[wp.int32],
    # outputs
    new_jump: wp.array[wp.int32],
    new_top: wp.array[wp.int32],
):
    """One round of pointer jumping for the topmost failing node among a node and its ancestors."""
    i = wp.tid()
    j = jump[i]
    t = top[i]
    if j >= 0:
        if top[j] >= 0:
            t = top[j]
        new_jump[i] = jump[j]
    else:
        new_jump[i] = -1
    new_top[i] = t


@wp.func
def halving_split(first: int, last: int):
    """Split position of a halving node over slots ``[first, last]``: the last slot of its left half."""
    return first + (last - first + 1) / 2 - 1


@wp.func
def halving_ref(first: int, last: int, root_split: int, cut_split: int, split_node: wp.array[wp.int32]):
    """Reference to the node over slots ``[first, last]`` of a halving subtree: a triangle slot, or the node
    whose split position the halving split is (the cut root's own position is taken by the halving root, which
    trades with the node that had the root's position)."""
    if first == last:
        return -first - 1
    m = halving_split(first, last)
    if m == cut_split:
        m = root_split
    return split_node[m]


@wp.kernel
def halve_cuts_kernel(
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
    starts: wp.array[wp.int32],
    top: wp.array[wp.int32],
    split_pos: wp.array[wp.int32],
    split_node: wp.array[wp.int32],
    # outputs
    new_left: wp.array[wp.int32],
    new_right: wp.array[wp.int32],
    new_counts: wp.array[wp.int32],
):
    """Internal node ``i`` of the depth-bounded tree: unchanged outside cut subtrees; inside one, the halving node
    of its role's split position, found by descending from the halving root."""
    i = wp.tid()
    cut = top[i]
    if cut < 0:
        new_left[i] = src_left[i]
        new_right[i] = src_right[i]
        new_counts[i] = src_counts[i]
        return
    first = starts[cut]
    last = first + src_counts[cut] - 1
    root_split = halving_split(first, last)
    cut_split = split_pos[cut]
    role = split_pos[i]
    if i == cut:
        role = root_split
    elif role == root_split:
        role = cut_split
    m = halving_split(first, last)
    while m != role:
        if role < m:
            last = m
        else:
            first = m + 1
        m = halving_split(first, last)
    new_left[i] = halving_ref(first, m, root_split, cut_split, split_node)
    new_right[i] = halving_ref(m + 1, last, root_split, cut_split, split_node)
    new_counts[i] = last - first + 1


@wp.kernel
def emit_flags_kernel(
    parents: wp.array[wp.int32],
    counts: wp.array[wp.int32],
    collapse: wp.array[wp.int32],
    starts: wp.array[wp.int32],
    leaf_size: int,
    # outputs
    emit: wp.array[wp.int32],
    chain_len: wp.array[wp.int32],
):
    """Node ``j``: 0 when a collapsed ancestor hides it, 1 for an emitted leaf, 2 for an emitted inner node (which
    counts itself in the chain of its first slot). Only ancestors of at most ``leaf_size`` triangles can be
    collapsed, so the walk up is short."""
    j = wp.tid()
    p = parents[j]
    while p >= 0 and counts[p] <= leaf_size:
        if collapse[p] == 1:
            emit[j] = 0
            return
        p = parents[p]
    if collapse[j] == 1:
        emit[j] = 1
        return
    emit[j] = 2
    wp.atomic_add(chain_len, starts[j], 1)


@wp.kernel
def pair_rank_kernel(
    leaf_base: int,
    parents: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    starts: wp.array[wp.int32],
    emit: wp.array[wp.int32],
    chain_len: wp.array[wp.int32],
    chain_end: wp.array[wp.int32],
    # outputs
    ranks: wp.array[wp.int32],
):
    """Pre-order rank of emitted inner node ``i``: the inner nodes of lower first slots (``chain_end``, an
    inclusive scan of ``chain_len``), plus the left-child steps up to the top of its own chain."""
    i = wp.tid()
    if emit[i] != 2:
        return
    above = int(0)
    node = i
    p = parents[node]
    while p >= 0 and source_node(src_left[p], leaf_base) == node:
        above += 1
        node = p
        p = parents[node]
    s = starts[i]
    ranks[i] = chain_end[s] - chain_len[s] + above


@wp.kernel
def emit_nodes_kernel(
    leaf_base: int,
    parents: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    emit: wp.array[wp.int32],
    ranks: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    starts: wp.array[wp.int32],
    counts: wp.array[wp.int32],
    # outputs
    out_lowers: wp.array[wp.vec3],
    out_uppers: wp.array[wp.vec3],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
):
    """Writes emitted node ``j`` beside its sibling, in its parent's pair (the root at 0)."""
    j = wp.tid()
    kind = emit[j]
    if kind == 0:
        return
    p = parents[j]
    pos = int(0)
    if p >= 0:
        pos = 1 + 2 * ranks[p] + wp.where(source_node(src_left[p], leaf_base) == j, 0, 1)
    out_lowers[pos] = lowers[j]
    out_uppers[pos] = uppers[j]
    if kind == 2:
        left_first[pos] = 1 + 2 * ranks[j]
        prim_count[pos] = 0
    else:
        left_first[pos] = starts[j]
        prim_count[pos] = counts[j]


class _Pass:
    """Step 1's arrays over the ``2 N - 1`` nodes of a source tree (internal ``0 .. N-2``, then the leaf of slot
    ``s`` at ``N - 1 + s``)."""

    def __init__(self, n: int, root: int, src_left, src_right, src_counts, slot_prims, prim_lowers, prim_uppers, sah):
        m, self.leaf_base = 2 * n - 1, n - 1
        self.root = root if n > 1 else 0
        self.parents = wp.empty(m, dtype=wp.int32)
        self.lowers = wp.empty(m, dtype=wp.vec3)
        self.uppers = wp.empty(m, dtype=wp.vec3)
        self.costs = wp.empty(m, dtype=float)
        self.collapse = wp.empty(m, dtype=wp.int32)
        self.starts = wp.empty(m, dtype=wp.int32)
        self.counts = wp.empty(m, dtype=wp.int32)
        self.heights = wp.empty(m, dtype=wp.int32)
        visits = wp.empty(n - 1, dtype=wp.int32)
        self.parents[self.root : self.root + 1].fill_(-1)
        wp.launch(
            source_parents_kernel,
            n - 1,
            inputs=[self.leaf_base, src_left, src_right],
            outputs=[self.parents, visits],
        )
        wp.launch(
            bottom_up_kernel,
            n,
            inputs=[self.leaf_base, self.parents, src_left, src_right, src_counts, slot_prims, prim_lowers, prim_uppers]
            + sah,
            outputs=[visits, self.lowers, self.uppers, self.costs, self.collapse, self.starts, self.counts]
            + [self.heights],
        )

    @property
    def height(self) -> int:
        return read_int(self.heights, self.root)


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
) -> DeviceFlatBvh:
    """Canonical tree (on the device) of a source tree (see module docstring); all arrays on one device.

    Args:
        slot_prims: ``(N,)`` int32 triangle in each slot, ``N >= 1``.
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
    """
    n = len(slot_prims)
    sah = [int(leaf_size), float(traversal_cost), float(intersection_cost)]
    with wp.ScopedDevice(slot_prims.device):
        source = (src_left, src_right, src_counts)
        with stage("flatten: bottom-up boxes and costs", timers):
            tree = _Pass(n, root, *source, slot_prims, prim_lowers, prim_uppers, sah)
            height = tree.height  # one read back
        if height > MAX_DEPTH - 1:
            with stage("flatten: depth bound", timers):
                source = _bound_depth(tree, height, *source)
                tree = _Pass(n, root, *source, slot_prims, prim_lowers, prim_uppers, sah)
        with stage("flatten: emit", timers):
            return _emit(tree, n, source[0], slot_prims, int(leaf_size), builder)


def _bound_depth(tree: _Pass, height: int, src_left, src_right, src_counts) -> tuple:
    """Step 2: ``(left, right, counts)`` of the source tree with every subtree that breaks the depth guarantee
    replaced by a halving one."""
    inner = len(src_left)
    rounds = int(height).bit_length()  # 2^rounds > height: every jump reaches the root
    jump, jump2, depth, depth2 = (wp.empty(inner, dtype=wp.int32) for _ in range(4))
    wp.launch(init_depth_kernel, inner, inputs=[tree.parents], outputs=[jump, depth])
    for _ in range(rounds):
        wp.launch(depth_round_kernel, inner, inputs=[jump, depth], outputs=[jump2, depth2])
        jump, jump2, depth, depth2 = jump2, jump, depth2, depth
    top, top2, split_pos, split_node = (wp.empty(inner, dtype=wp.int32) for _ in range(4))
    wp.launch(
        depth_failures_kernel,
        inner,
        inputs=[tree.parents, depth, src_left, src_counts, tree.starts, MAX_DEPTH],
        outputs=[jump, top, split_pos, split_node],
    )
    for _ in range(rounds):
        wp.launch(top_round_kernel, inner, inputs=[jump, top], outputs=[jump2, top2])
        jump, jump2, top, top2 = jump2, jump, top2, top
    new = [wp.empty(inner, dtype=wp.int32) for _ in range(3)]
    wp.launch(
        halve_cuts_kernel,
        inner,
        inputs=[src_left, src_right, src_counts, tree.starts, top, split_pos, split_node],
        outputs=new,
    )
    return tuple(new)


def _emit(tree: _Pass, n: int, src_left, slot_prims, leaf_size: int, builder: str) -> DeviceFlatBvh:
    """Step 3."""
    m = 2 * n - 1
    emit = wp.empty(m, dtype=wp.int32)
    chain_len = wp.zeros(n, dtype=wp.int32)
    chain_end = wp.empty(n, dtype=wp.int32)
    ranks = wp.empty(max(n - 1, 1), dtype=wp.int32)
    wp.launch(
        emit_flags_kernel,
        m,
        inputs=[tree.parents, tree.counts, tree.collapse, tree.starts, leaf_size],
        outputs=[emit, chain_len],
    )
    wp.utils.array_scan(chain_len, chain_end, inclusive=True)
    nodes = 1 + 2 * read_int(chain_end, n - 1)  # one read back
    wp.launch(
        pair_rank_kernel,
        n - 1,
        inputs=[tree.leaf_base, tree.parents, src_left, tree.starts, emit, chain_len, chain_end],
        outputs=[ranks],
    )
    lowers = wp.empty(nodes, dtype=wp.vec3)
    uppers = wp.empty(nodes, dtype=wp.vec3)
    left_first = wp.empty(nodes, dtype=wp.int32)
    prim_count = wp.empty(nodes, dtype=wp.int32)
    wp.launch(
        emit_nodes_kernel,
        m,
        inputs=[tree.leaf_base, tree.parents, src_left, emit, ranks, tree.lowers, tree.uppers, tree.starts]
        + [tree.counts],
        outputs=[lowers, uppers, left_first, prim_count],
    )
    return DeviceFlatBvh(lowers, uppers, left_first, prim_count, slot_prims, builder)
