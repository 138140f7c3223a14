"""Large nodes of the binned build, each split by many threads: one thread per triangle slot instead of per node.

``binned.py`` gives each node of a level one thread. Near the root a GPU then runs a handful of threads over
millions of triangles (a 10M-triangle ``sah`` build took 40 s on an H200). Here nodes above ``parallel_min``
triangles are split by kernels over all slots:

1. bin: each slot adds its triangle to its node's bins with atomics (count, box minimum and maximum, all exact, so
   the order does not matter); a node's bins are kept in several copies, picked by slot, so that fewer threads
   contend for one address;
2. one thread per (node, axis, bin) folds the copies into the node's bins in ``BinnedBuild.bins``, and one thread
   per node chooses the split with the same functions as the one-thread path (``best_bin_split``,
   ``binned_action``);
3. partition: a prefix sum over "goes left" flags gives each slot its place, which is the place the one-thread
   stable partition gives it; the children's boxes grow with atomics, in copies again.

The tree is the one ``binned.py`` builds alone, bit for bit, on any device.
"""

import numpy as np
import warp as wp

from .binned import (
    BinnedBuild,
    best_bin_split,
    bin_of,
    bin_scales,
    binned_action,
    binned_axes,
    empty_bin,
    goes_left,
)
from .common import ACTION_LEAF, read_int

# No FMA contraction: SAH costs rounded alike on every device, so the CPU and a GPU build the same tree.
wp.set_module_options({"enable_backward": False, "fuse_fp": False})

MAX_COPIES = 32  # most copies of a node's bins and child boxes (for the root's millions of slots)
SLOTS_PER_COPY = 1 << 15  # one more copy per this many slots of the level's average large node


@wp.struct
class LargeNodes:
    """The large nodes of one level, in slot order."""

    active: wp.array[wp.int32]  # the level's nodes (``build_binned``'s active list)
    items: wp.array[wp.int32]  # large node j is active[items[j]]
    starts: wp.array[wp.int32]  # its slot range [starts[j], ends[j])
    ends: wp.array[wp.int32]
    count: int


@wp.func
def large_node_of(i: int, nodes: LargeNodes):
    """Index of the large node whose slot range holds slot ``i``, or -1 (ranges are sorted and disjoint)."""
    lo = int(0)
    hi = int(nodes.count)  # answer in [lo, hi): the last range starting at or before i
    while hi - lo > 1:
        mid = (lo + hi) / 2
        if nodes.starts[mid] <= i:
            lo = mid
        else:
            hi = mid
    j = int(-1)
    if nodes.starts[lo] <= i and i < nodes.ends[lo]:
        j = lo
    return j


@wp.kernel
def list_large_kernel(
    st: BinnedBuild,
    ranks: wp.array[wp.int32],
    # outputs
    nodes: LargeNodes,
):
    """Fills ``nodes.items``, ``starts`` and ``ends`` from the level's ``nodes.active`` (``ranks``: exclusive scan of
    the large flags)."""
    k = wp.tid()
    n = nodes.active[k]
    if st.node_counts[n] > st.parallel_min:
        j = ranks[k]
        nodes.items[j] = k
        nodes.starts[j] = st.node_starts[n]
        nodes.ends[j] = st.node_starts[n] + st.node_counts[n]


@wp.kernel
def large_flags_kernel(
    st: BinnedBuild,
    active: wp.array[wp.int32],
    # outputs
    flags: wp.array[wp.int32],
):
    k = wp.tid()
    flags[k] = wp.where(st.node_counts[active[k]] > st.parallel_min, 1, 0)


@wp.kernel
def clear_copies_kernel(
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
):
    i = wp.tid()
    lowers[i] = wp.vec3(wp.inf)
    uppers[i] = wp.vec3(-wp.inf)
    counts[i] = 0


@wp.kernel
def bin_slots_kernel(
    st: BinnedBuild,
    row: int,
    nodes: LargeNodes,
    copies: int,
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
):
    """Slot ``i`` adds its triangle to copy ``i % copies`` of its large node's bins, on every binned axis."""
    i = wp.tid()
    j = large_node_of(i, nodes)
    if j < 0:
        return
    n = nodes.active[nodes.items[j]]
    c_lo = st.node_c_lowers[n]
    scale = bin_scales(c_lo, st.node_c_uppers[n], st.max_bins)  # a large node has more triangles than bins
    use_axis = binned_axes(st, n)
    slot = st.slots[row, i]
    c = 0.5 * (slot.lower + slot.upper)
    base = (j * copies + i % copies) * 3 * st.max_bins
    for axis in range(3):
        if use_axis[axis] == 1:
            b = base + axis * st.max_bins + bin_of(c, c_lo, scale, axis, st.max_bins)
            wp.atomic_add(counts, b, 1)
            wp.atomic_min(lowers, b, slot.lower)
            wp.atomic_max(uppers, b, slot.upper)


@wp.kernel
def fold_bins_kernel(
    st: BinnedBuild,
    nodes: LargeNodes,
    copies: int,
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
):
    """Bin ``b`` of large node ``j``: the union of its copies, into the node's worker scratch in ``st.bins``."""
    j, b = wp.tid()
    per_copy = 3 * st.max_bins
    merged = empty_bin()
    for r in range(copies):
        e = (j * copies + r) * per_copy + b
        merged.lower = wp.min(merged.lower, lowers[e])
        merged.upper = wp.max(merged.upper, uppers[e])
        merged.count = merged.count + counts[e]
    st.bins[nodes.items[j] * per_copy + b] = merged


@wp.kernel
def choose_splits_kernel(
    st: BinnedBuild,
    nodes: LargeNodes,
    # outputs
    actions: wp.array[wp.vec3i],
    split_flags: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
):
    """Large node ``j``'s action, split axis and bin, and left count (``actions[j]``: action, axis, split; the
    left count goes to ``child_counts`` as the one-thread path writes it)."""
    j = wp.tid()
    k = nodes.items[j]
    n = nodes.active[k]
    use_axis = binned_axes(st, n)
    cost, axis, split, left = best_bin_split(st, 3 * st.max_bins * k, st.max_bins * k, st.max_bins, use_axis)
    action, n_left = binned_action(st, n, cost, axis, left)
    actions[j] = wp.vec3i(action, axis, split)
    split_flags[k] = wp.where(action == ACTION_LEAF, 0, 1)
    child_counts[2 * k] = n_left
    child_counts[2 * k + 1] = st.node_counts[n] - n_left


@wp.kernel
def left_flags_kernel(
    st: BinnedBuild,
    row: int,
    nodes: LargeNodes,
    actions: wp.array[wp.vec3i],
    child_counts: wp.array[wp.int32],
    # outputs
    flags: wp.array[wp.int32],
):
    """1 where slot ``i`` goes to its large node's left child (0 outside large nodes and in leaves)."""
    i = wp.tid()
    flags[i] = 0
    j = large_node_of(i, nodes)
    if j >= 0 and actions[j][0] != ACTION_LEAF:
        k = nodes.items[j]
        n = nodes.active[k]
        slot = st.slots[row, i]
        c_lo = st.node_c_lowers[n]
        scale = bin_scales(c_lo, st.node_c_uppers[n], st.max_bins)
        c = 0.5 * (slot.lower + slot.upper)
        a = actions[j]
        if goes_left(c, c_lo, scale, st.max_bins, a[0], a[1], a[2], i - nodes.starts[j], child_counts[2 * k]):
            flags[i] = 1


@wp.kernel
def partition_slots_kernel(
    st: BinnedBuild,
    row: int,
    nodes: LargeNodes,
    actions: wp.array[wp.vec3i],
    child_counts: wp.array[wp.int32],
    flags: wp.array[wp.int32],
    left_ranks: wp.array[wp.int32],
    copies: int,
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
):
    """Slot ``i`` moves to its place in the other row (a leaf's slot only writes its triangle id) and grows copy
    ``i % copies`` of its child's box and centroid box: entries ``4 (2 (j copies + copy) + side) + {0, 1}``."""
    i = wp.tid()
    j = large_node_of(i, nodes)
    if j < 0:
        return
    k = nodes.items[j]
    start = nodes.starts[j]
    slot = st.slots[row, i]
    if actions[j][0] == ACTION_LEAF:
        st.out_prims[i] = slot.prim
        return
    lefts_before = left_ranks[i] - left_ranks[start]
    side = 1 - flags[i]
    dst = start + lefts_before
    if side == 1:
        dst = start + child_counts[2 * k] + (i - start - lefts_before)
    st.slots[1 - row, dst] = slot
    c = 0.5 * (slot.lower + slot.upper)
    e = 2 * (2 * (j * copies + i % copies) + side)
    wp.atomic_min(lowers, e, slot.lower)
    wp.atomic_max(uppers, e, slot.upper)
    wp.atomic_min(lowers, e + 1, c)
    wp.atomic_max(uppers, e + 1, c)


@wp.kernel
def fold_children_kernel(
    nodes: LargeNodes,
    actions: wp.array[wp.vec3i],
    copies: int,
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    # outputs
    child_lowers: wp.array[wp.vec3],
    child_uppers: wp.array[wp.vec3],
    child_c_lowers: wp.array[wp.vec3],
    child_c_uppers: wp.array[wp.vec3],
):
    """Child ``side`` of large node ``j``: the union of its box copies, where ``make_children_kernel`` reads it."""
    j, side = wp.tid()
    if actions[j][0] == ACTION_LEAF:
        return
    lo = wp.vec3(wp.inf)
    hi = wp.vec3(-wp.inf)
    c_lo = wp.vec3(wp.inf)
    c_hi = wp.vec3(-wp.inf)
    for r in range(copies):
        e = 2 * (2 * (j * copies + r) + side)
        lo = wp.min(lo, lowers[e])
        hi = wp.max(hi, uppers[e])
        c_lo = wp.min(c_lo, lowers[e + 1])
        c_hi = wp.max(c_hi, uppers[e + 1])
    out = 2 * nodes.items[j] + side
    child_lowers[out] = lo
    child_uppers[out] = hi
    child_c_lowers[out] = c_lo
    child_c_uppers[out] = c_hi


class LargeNodeSplitter:
    """Splits the large nodes of each level (see module docstring); scratch grows as needed and is reused."""

    def __init__(self, st: BinnedBuild, num_slots: int):
        self.st, self.n = st, num_slots
        self.flags = wp.empty(num_slots, dtype=wp.int32)
        self.ranks = wp.empty(num_slots, dtype=wp.int32)
        self.done = False  # no large node left: children are smaller than their parents
        self.capacity = 0

    def _reserve(self, num_large: int, copies: int) -> None:
        need = num_large * copies * max(3 * self.st.max_bins, 4)
        if need > self.capacity:
            self.lowers = wp.empty(need, dtype=wp.vec3)
            self.uppers = wp.empty(need, dtype=wp.vec3)
            self.counts = wp.empty(need, dtype=wp.int32)
            self.capacity = need

    def split(self, active: wp.array, k: int, children: list, split_flags: wp.array, child_counts: wp.array,
              row: int) -> None:
        """Splits the large ones among nodes ``active[:k]`` (slot row ``row``), writing their results where
        ``split_nodes_kernel`` writes those of the others."""
        if self.done:
            return
        st, n = self.st, self.n
        wp.launch(large_flags_kernel, k, inputs=[st, active], outputs=[self.flags])
        wp.utils.array_scan(self.flags[:k], self.ranks[:k], inclusive=False)
        num_large = read_int(self.ranks, k - 1) + read_int(self.flags, k - 1)
        if num_large == 0:
            self.done = True
            return
        nodes = LargeNodes()
        nodes.active, nodes.count = active, num_large
        nodes.items, nodes.starts, nodes.ends = (wp.empty(num_large, dtype=wp.int32) for _ in range(3))
        wp.launch(list_large_kernel, k, inputs=[st, self.ranks], outputs=[nodes])
        copies = int(np.clip(n // (num_large * SLOTS_PER_COPY), 1, MAX_COPIES))
        self._reserve(num_large, copies)
        bins = num_large * copies * 3 * st.max_bins
        wp.launch(clear_copies_kernel, bins, outputs=[self.lowers, self.uppers, self.counts])
        wp.launch(bin_slots_kernel, n, inputs=[st, row, nodes, copies], outputs=[self.lowers, self.uppers,
                                                                                 self.counts])
        wp.launch(fold_bins_kernel, (num_large, 3 * st.max_bins),
                  inputs=[st, nodes, copies, self.lowers, self.uppers, self.counts])
        actions = wp.empty(num_large, dtype=wp.vec3i)
        wp.launch(choose_splits_kernel, num_large, inputs=[st, nodes], outputs=[actions, split_flags, child_counts])
        wp.launch(left_flags_kernel, n, inputs=[st, row, nodes, actions, child_counts], outputs=[self.flags])
        wp.utils.array_scan(self.flags, self.ranks, inclusive=False)
        wp.launch(clear_copies_kernel, num_large * copies * 4, outputs=[self.lowers, self.uppers, self.counts])
        wp.launch(partition_slots_kernel, n,
                  inputs=[st, row, nodes, actions, child_counts, self.flags, self.ranks, copies],
                  outputs=[self.lowers, self.uppers])
        wp.launch(fold_children_kernel, (num_large, 2),
                  inputs=[nodes, actions, copies, self.lowers, self.uppers], outputs=children)
