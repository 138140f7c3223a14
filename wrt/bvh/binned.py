"""Top-down binned builders, level by level in Warp kernels: binned SAH (``sah``) and the spatial median
(``middle``).

Binned SAH follows Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies" (2007): the centroids of
a node are sorted into ``min(bins, count)`` equal bins on each of the three axes, and the split is the bin
boundary with the least SAH cost ``A(L) N(L) + A(R) N(R)``. SAH leaf termination uses explicit traversal and
intersection costs (``choose_action``). ``middle`` splits the centroid box of a node at its middle along the widest
axis (the same kernel with two bins on one axis).

The tree is built in two phases that run the same per-node code (``split_nodes_kernel``), so the result does not
depend on where the phases meet:

1. Level phase: nodes above ``subtree_size`` triangles grow breadth first, one launch per level with one thread
   per node (bin, decide, stably partition the slots into the other slot buffer), then a prefix scan places the two
   children of every split node side by side. Nodes above ``parallel_min`` triangles are split by one thread per
   slot instead (``binned_parallel.py``: on a GPU a few threads over millions of triangles would take seconds),
   with the same decision functions and the same result.
2. Subtree phase: every node left at or below ``subtree_size`` triangles is built whole, depth first, by one
   thread, into a reserved node range; a final pass closes the gaps between the ranges. A subtree's slots and
   bins stay in cache while it is built, instead of every level streaming the whole slot array.

Slots carry the triangle's box with its id, and nodes at even and odd depths read the two slot buffers in turn, so
every pass streams. Work is ``O(N)`` per level. On a CPU device launches can be split between threads. The only
atomics (in ``binned_parallel.py``) add integers and take minima and maxima, which are exact, and FMA contraction is
off, so the tree does not depend on the device, the threads or the run. Its node numbering depends on
``subtree_size`` only (breadth first above it, depth first below), whose default differs between CPU and GPU.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from ..geometry import finite_max, finite_min
from .common import (
    ACTION_HALVE,
    ACTION_LEAF,
    ACTION_SPLIT,
    MAX_DEPTH,
    BuildInput,
    choose_action,
    half_area,
    read_int,
    widest_axis,
)
from .layout import DeviceFlatBvh

# No FMA contraction: SAH costs rounded alike on every device, so the CPU and a GPU build the same tree.
wp.set_module_options({"enable_backward": False, "fuse_fp": False})

SUBTREE_STACK = MAX_DEPTH + 2  # depth-first stack of the subtree phase: one entry per level, plus one
SUBTREE_SIZE = 4096  # default on a CPU: nodes of at most this many triangles are built whole by one thread
# Defaults on a GPU, from benchmarks/gpu_sah_build.py on an H200: the smallest subtrees and parallel nodes down to
# 256 triangles built chess_set's tree in 51 ms (4.8 s with one thread per node throughout).
SUBTREE_SIZE_CUDA = 64
PARALLEL_MIN_CUDA = 256  # nodes above this many triangles are split by one thread per slot
NO_PARALLEL = (1 << 31) - 1


@wp.struct
class SlotBox:
    """A triangle in a slot, with its box: partitions move the three together, so every pass streams."""

    lower: wp.vec3  # triangle box minimum
    upper: wp.vec3  # triangle box maximum
    prim: wp.int32  # triangle id


@wp.kernel
def init_slots_kernel(
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    # outputs
    slots: wp.array[SlotBox],
):
    """Slot ``i`` holds triangle ``i``."""
    i = wp.tid()
    s = SlotBox()
    s.lower = prim_lowers[i]
    s.upper = prim_uppers[i]
    s.prim = i
    slots[i] = s


@wp.func
def bin_scales(c_lower: wp.vec3, c_upper: wp.vec3, bins: int):
    """Per axis ``bins / extent`` of a centroid box, 0 for a flat axis (which cannot split)."""
    extent = c_upper - c_lower
    scale = wp.vec3(0.0)
    for axis in range(3):
        if extent[axis] > 0.0:
            scale[axis] = float(bins) / extent[axis]
    return scale


@wp.func
def bin_of(c: wp.vec3, c_lower: wp.vec3, scale: wp.vec3, axis: int, bins: int):
    """Bin of centroid ``c`` along ``axis``; the binning and the partition both call this, so they agree."""
    return wp.clamp(int((c[axis] - c_lower[axis]) * scale[axis]), 0, bins - 1)


@wp.func
def lower_of(a: wp.vec3, b: wp.vec3):
    """Component-wise minimum of finite vectors: ``wp.min`` without its CPU NaN handling, which costs two compares
    and two selects per component in the binning loop (the input checks reject NaN vertices)."""
    return wp.vec3(finite_min(a[0], b[0]), finite_min(a[1], b[1]), finite_min(a[2], b[2]))


@wp.func
def upper_of(a: wp.vec3, b: wp.vec3):
    """Component-wise maximum of finite vectors (see ``lower_of``)."""
    return wp.vec3(finite_max(a[0], b[0]), finite_max(a[1], b[1]), finite_max(a[2], b[2]))


@wp.struct
class Bin:
    """One SAH bin: the box of the triangles whose centroids fall in it, and their count (one record, so an update
    computes one address)."""

    lower: wp.vec3
    upper: wp.vec3
    count: wp.int32


@wp.func
def empty_bin():
    """A bin with no triangle: an inverted box, so any triangle's box replaces it."""
    b = Bin()
    b.lower = wp.vec3(wp.inf)
    b.upper = wp.vec3(-wp.inf)
    b.count = 0
    return b


@wp.func
def goes_left(
    c: wp.vec3, c_lo: wp.vec3, scale: wp.vec3, bins: int, action: int, axis: int, split: int, offset: int, n_left: int
):
    """The stable partition's rule for the triangle of centroid ``c`` at ``offset`` in its node's slots: left of
    the split bin, or in the first ``n_left`` slots when the node halves. Both split paths call it, so they agree."""
    left = offset < n_left
    if action == ACTION_SPLIT:
        left = bin_of(c, c_lo, scale, axis, bins) < split
    return left


@wp.struct
class BinnedBuild:
    """Device state of one binned build: nodes, the two slot buffers, bin scratch, and the build options."""

    node_starts: wp.array[wp.int32]  # first slot of the node's triangles
    node_counts: wp.array[wp.int32]  # triangles below the node
    node_depths: wp.array[wp.int32]  # root 0
    node_lefts: wp.array[wp.int32]  # left child, -1 for a leaf (or a node not split yet)
    node_lowers: wp.array[wp.vec3]  # node box minimum
    node_uppers: wp.array[wp.vec3]  # node box maximum
    node_c_lowers: wp.array[wp.vec3]  # centroid box minimum
    node_c_uppers: wp.array[wp.vec3]  # centroid box maximum
    slots: wp.array2d[SlotBox]  # row d % 2: the slots of nodes at depth d (partitions go to the other row)
    out_prims: wp.array[wp.int32]  # slot -> triangle id of the finished tree
    bins: wp.array[Bin]  # scratch: worker w owns bins [3 w max_bins, 3 (w + 1) max_bins)
    right_areas: wp.array[float]  # scratch: worker w owns sweep entries [w max_bins, (w + 1) max_bins)
    right_counts: wp.array[wp.int32]
    max_bins: int  # bins per axis (2 and one axis for the spatial median)
    use_sah: int  # 1: binned SAH on three axes, 0: spatial median
    max_leaf_size: int  # most triangles in a leaf
    traversal_cost: float  # SAH C_t
    intersection_cost: float  # SAH C_i
    max_depth: int  # MAX_DEPTH
    subtree_size: int  # nodes of at most this many triangles are built whole by one thread
    parallel_min: int  # level-phase nodes above this many triangles are split by many threads each


@wp.func
def binned_axes(st: BinnedBuild, n: int):
    """1 for each axis along which node ``n`` is binned: all three that can split for SAH, the widest one for the
    middle split."""
    extent = st.node_c_uppers[n] - st.node_c_lowers[n]
    widest = widest_axis(extent)
    use_axis = wp.vec3i(0)
    for axis in range(3):
        if st.node_counts[n] > 1 and extent[axis] > 0.0 and (st.use_sah == 1 or axis == widest):
            use_axis[axis] = 1
    return use_axis


@wp.func
def best_bin_split(st: BinnedBuild, base: int, sweep: int, bins: int, use_axis: wp.vec3i):
    """The best bin-boundary split of the node binned in ``st.bins[base:]``: least SAH cost over its axes, or the
    middle of the widest axis. Returns (cost, axis, first right bin, left count); axis -1 when none splits."""
    best_cost = float(wp.inf)
    best_axis = int(-1)
    best_split = int(0)
    best_left = int(0)
    for axis in range(3):
        if use_axis[axis] == 1:
            # Sweep from the right, keeping the area and count of bins [s, bins) for every split s.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            m = int(0)
            for s in range(bins - 1, 0, -1):
                bin = st.bins[base + axis * bins + s]
                lo = wp.min(lo, bin.lower)
                hi = wp.max(hi, bin.upper)
                m += bin.count
                st.right_areas[sweep + s] = half_area(lo, hi)
                st.right_counts[sweep + s] = m
            # Sweep from the left and evaluate each split s: bins [0, s) left, [s, bins) right.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            m = int(0)
            for s in range(1, bins):
                bin = st.bins[base + axis * bins + s - 1]
                lo = wp.min(lo, bin.lower)
                hi = wp.max(hi, bin.upper)
                m += bin.count
                if m > 0 and st.right_counts[sweep + s] > 0:
                    cost = float(0.0)
                    if st.use_sah == 1:
                        cost = half_area(lo, hi) * float(m) + st.right_areas[sweep + s] * float(
                            st.right_counts[sweep + s]
                        )
                    else:
                        # Spatial median: the split nearest the middle bin boundary wins.
                        cost = wp.abs(float(2 * s - bins))
                    if cost < best_cost:
                        best_cost = cost
                        best_axis = axis
                        best_split = s
                        best_left = m
    return best_cost, best_axis, best_split, best_left


@wp.func
def binned_action(st: BinnedBuild, n: int, best_cost: float, best_axis: int, best_left: int):
    """Leaf, the split found, or halving for node ``n``, and the triangle count of its left child."""
    count = st.node_counts[n]
    area = half_area(st.node_lowers[n], st.node_uppers[n])
    action = choose_action(
        count,
        st.node_depths[n],
        area,
        best_axis >= 0,
        best_cost,
        best_left,
        st.use_sah,
        st.max_leaf_size,
        st.traversal_cost,
        st.intersection_cost,
        st.max_depth,
    )
    n_left = best_left
    if action == ACTION_HALVE:
        n_left = count / 2
    return action, n_left


@wp.kernel
def split_nodes_kernel(
    st: BinnedBuild,
    items: wp.array[wp.int32],
    reserved: wp.array[wp.int32],
    first_worker: int,
    subtree: int,
    # outputs
    split_flags: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_lowers: wp.array[wp.vec3],
    child_uppers: wp.array[wp.vec3],
    child_c_lowers: wp.array[wp.vec3],
    child_c_uppers: wp.array[wp.vec3],
    node_pending: wp.array[wp.int32],
    used: wp.array[wp.int32],
):
    """One thread per node ``items[k]``: bin, choose leaf / SAH split / halving, and stably partition the node's
    slots from row ``depth % 2`` of ``st.slots`` into the other row (a leaf copies its triangle ids to
    ``st.out_prims``). Thread ``k`` uses bin scratch ``first_worker + k``, reused by every node it handles.

    Level phase (``subtree == 0``): a node above ``st.subtree_size`` triangles records its children for
    ``make_children_kernel``; a smaller one is only flagged in ``node_pending``. Subtree phase (``subtree == 1``):
    the thread builds the node's whole subtree depth first, numbering new nodes from ``reserved[k]``, children side
    by side, and reports the count in ``used[k]``.
    """
    k = wp.tid()
    worker = first_worker + k
    stack = wp.zeros(shape=SUBTREE_STACK, dtype=wp.int32)
    stack[0] = items[k]
    top = int(1)
    next_free = int(0)
    if subtree == 1:
        next_free = reserved[k]
    else:
        if st.node_counts[items[k]] > st.parallel_min:
            return  # split by the kernels of binned_parallel.py
        split_flags[k] = 0
        if st.node_counts[items[k]] <= st.subtree_size:
            node_pending[items[k]] = 1
            top = 0
    while top > 0:
        top -= 1
        n = stack[top]
        p = st.node_depths[n] % 2  # row of st.slots holding this node's triangles
        start = st.node_starts[n]
        count = st.node_counts[n]
        end = start + count
        c_lo = st.node_c_lowers[n]
        bins = wp.min(st.max_bins, count)
        scale = bin_scales(c_lo, st.node_c_uppers[n], bins)
        use_axis = binned_axes(st, n)
        base = 3 * st.max_bins * worker
        sweep = st.max_bins * worker

        # Bin every centroid on each axis that can split (all three for SAH, the widest one for the middle split).
        empty = empty_bin()
        for b in range(base, base + 3 * bins):
            st.bins[b] = empty
        if count > 1:
            for i in range(start, end):
                slot = st.slots[p, i]
                lo = slot.lower
                hi = slot.upper
                c = 0.5 * (lo + hi)
                for axis in range(3):
                    if use_axis[axis] == 1:
                        b = base + axis * bins + bin_of(c, c_lo, scale, axis, bins)
                        grown = st.bins[b]
                        grown.count = grown.count + 1  # not "+=", which compiles to an atomic add
                        grown.lower = lower_of(grown.lower, lo)
                        grown.upper = upper_of(grown.upper, hi)
                        st.bins[b] = grown

        best_cost, best_axis, best_split, best_left = best_bin_split(st, base, sweep, bins, use_axis)

        action, n_left = binned_action(st, n, best_cost, best_axis, best_left)
        if action == ACTION_LEAF:
            for i in range(start, end):
                st.out_prims[i] = st.slots[p, i].prim
            end = start  # nothing to partition

        # Partition the slots stably into [start, start + n_left) and the rest, growing both children's boxes.
        big = wp.vec3(wp.inf)
        l_lo = big
        l_hi = -big
        l_clo = big
        l_chi = -big
        r_lo = big
        r_hi = -big
        r_clo = big
        r_chi = -big
        n_l = int(0)
        n_r = int(0)
        for i in range(start, end):
            slot = st.slots[p, i]
            lo = slot.lower
            hi = slot.upper
            c = 0.5 * (lo + hi)
            left = goes_left(c, c_lo, scale, bins, action, best_axis, best_split, i - start, n_left)
            j = int(0)
            if left:
                j = start + n_l
                n_l += 1
                l_lo = lower_of(l_lo, lo)
                l_hi = upper_of(l_hi, hi)
                l_clo = lower_of(l_clo, c)
                l_chi = upper_of(l_chi, c)
            else:
                j = start + n_left + n_r
                n_r += 1
                r_lo = lower_of(r_lo, lo)
                r_hi = upper_of(r_hi, hi)
                r_clo = lower_of(r_clo, c)
                r_chi = upper_of(r_chi, c)
            st.slots[1 - p, j] = slot

        # Record the children: for the next level, or allocate them here and continue depth first.
        if action != ACTION_LEAF:
            if subtree == 0:
                split_flags[k] = 1
                child_counts[2 * k] = n_left
                child_counts[2 * k + 1] = count - n_left
                child_lowers[2 * k] = l_lo
                child_uppers[2 * k] = l_hi
                child_c_lowers[2 * k] = l_clo
                child_c_uppers[2 * k] = l_chi
                child_lowers[2 * k + 1] = r_lo
                child_uppers[2 * k + 1] = r_hi
                child_c_lowers[2 * k + 1] = r_clo
                child_c_uppers[2 * k + 1] = r_chi
            else:
                child = next_free
                next_free += 2
                st.node_lefts[n] = child
                st.node_starts[child] = start
                st.node_starts[child + 1] = start + n_left
                st.node_counts[child] = n_left
                st.node_counts[child + 1] = count - n_left
                st.node_depths[child] = st.node_depths[n] + 1
                st.node_depths[child + 1] = st.node_depths[n] + 1
                st.node_lefts[child] = -1
                st.node_lefts[child + 1] = -1
                st.node_lowers[child] = l_lo
                st.node_uppers[child] = l_hi
                st.node_c_lowers[child] = l_clo
                st.node_c_uppers[child] = l_chi
                st.node_lowers[child + 1] = r_lo
                st.node_uppers[child + 1] = r_hi
                st.node_c_lowers[child + 1] = r_clo
                st.node_c_uppers[child + 1] = r_chi
                stack[top] = child + 1
                stack[top + 1] = child
                top += 2
    if subtree == 1:
        used[k] = next_free - reserved[k]


@wp.kernel
def relocate_subtrees_kernel(
    st: BinnedBuild,
    pending: wp.array[wp.int32],
    reserved: wp.array[wp.int32],
    used: wp.array[wp.int32],
    used_offsets: wp.array[wp.int32],
    first_free: int,
    # outputs
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
):
    """Moves subtree ``k``'s nodes from its reserved range to ``first_free + used_offsets[k]``, closing the gaps,
    and writes their canonical fields; re-points the subtree's root at its moved children."""
    k = wp.tid()
    shift = reserved[k] - (first_free + used_offsets[k])
    root = pending[k]
    if st.node_lefts[root] >= 0:
        left_first[root] = st.node_lefts[root] - shift
        prim_count[root] = 0
    for j in range(used[k]):
        old = reserved[k] + j
        new = old - shift
        lowers[new] = st.node_lowers[old]
        uppers[new] = st.node_uppers[old]
        if st.node_lefts[old] >= 0:
            left_first[new] = st.node_lefts[old] - shift
            prim_count[new] = 0
        else:
            left_first[new] = st.node_starts[old]
            prim_count[new] = st.node_counts[old]


@wp.kernel
def finish_nodes_kernel(
    st: BinnedBuild,
    # outputs
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
):
    """Canonical fields of the level-phase nodes: an inner node points at its left child, a leaf at its first slot
    (subtree roots are fixed up by ``relocate_subtrees_kernel``)."""
    n = wp.tid()
    lowers[n] = st.node_lowers[n]
    uppers[n] = st.node_uppers[n]
    if st.node_lefts[n] >= 0:
        left_first[n] = st.node_lefts[n]
        prim_count[n] = 0
    else:
        left_first[n] = st.node_starts[n]
        prim_count[n] = st.node_counts[n]


@wp.kernel
def pending_sizes_kernel(
    st: BinnedBuild,
    pending: wp.array[wp.int32],
    # outputs
    sizes: wp.array[wp.int32],
):
    """Most nodes a pending node's subtree can add: ``2 (count - 1)``."""
    k = wp.tid()
    sizes[k] = 2 * (st.node_counts[pending[k]] - 1)


@wp.kernel
def make_children_kernel(
    active: wp.array[wp.int32],
    split_flags: wp.array[wp.int32],
    split_ranks: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_lowers: wp.array[wp.vec3],
    child_uppers: wp.array[wp.vec3],
    child_c_lowers: wp.array[wp.vec3],
    child_c_uppers: wp.array[wp.vec3],
    first_free: int,
    # outputs
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_depths: wp.array[wp.int32],
    node_lefts: wp.array[wp.int32],
    node_lowers: wp.array[wp.vec3],
    node_uppers: wp.array[wp.vec3],
    node_c_lowers: wp.array[wp.vec3],
    node_c_uppers: wp.array[wp.vec3],
    next_active: wp.array[wp.int32],
):
    """Allocates the two children of each split node side by side and queues them for the next level."""
    k = wp.tid()
    if split_flags[k] == 0:
        return
    n = active[k]
    child = first_free + 2 * split_ranks[k]
    node_lefts[n] = child
    start = node_starts[n]
    for j in range(2):
        node_starts[child + j] = start
        node_counts[child + j] = child_counts[2 * k + j]
        node_depths[child + j] = node_depths[n] + 1
        node_lowers[child + j] = child_lowers[2 * k + j]
        node_uppers[child + j] = child_uppers[2 * k + j]
        node_c_lowers[child + j] = child_c_lowers[2 * k + j]
        node_c_uppers[child + j] = child_c_uppers[2 * k + j]
        next_active[2 * split_ranks[k] + j] = child + j
        start += child_counts[2 * k]


@wp.kernel
def compact_flags_kernel(
    flags: wp.array[wp.int32],
    ranks: wp.array[wp.int32],
    # outputs
    items: wp.array[wp.int32],
):
    """Indices ``i`` with ``flags[i] == 1``, in order (``ranks`` is the inclusive scan of ``flags``)."""
    i = wp.tid()
    if flags[i] == 1:
        items[ranks[i] - 1] = i


def build_binned(
    data: BuildInput,
    *,
    use_sah: bool,
    leaf_size: int,
    bins: int,
    traversal_cost: float,
    intersection_cost: float,
    builder: str,
    threads: int = 1,
    subtree_size: int | None = None,
    parallel_min: int | None = None,
) -> DeviceFlatBvh:
    """Builds the tree over ``data`` (see module docstring), on ``data.device``.

    On a CPU device each launch is split into ``threads`` pieces of about equal triangle count that run at once
    (Warp's CPU launches release the GIL); the nodes are independent, so the tree does not depend on it.
    Level-phase nodes above ``parallel_min`` triangles are split by one thread per slot (``binned_parallel.py``;
    ``None``: ``PARALLEL_MIN_CUDA`` on a GPU, off on a CPU, whose launches run one thread each). ``subtree_size``
    (``None``: ``SUBTREE_SIZE_CUDA`` or ``SUBTREE_SIZE``) changes the node numbering only; ``parallel_min``
    changes nothing in the tree.
    """
    from .binned_parallel import LargeNodeSplitter

    n = data.num_prims
    if subtree_size is None:
        subtree_size = SUBTREE_SIZE_CUDA if data.device.is_cuda else SUBTREE_SIZE
    if subtree_size < 64:
        raise ValueError(f"subtree_size must be at least 64, got {subtree_size}")
    pool = ThreadPoolExecutor(threads) if threads > 1 else None
    with wp.ScopedDevice(data.device):
        capacity = 2 * n - 1
        st = BinnedBuild()
        st.node_starts = wp.zeros(capacity, dtype=wp.int32)
        st.node_counts = wp.full(capacity, n, dtype=wp.int32)  # the root's; the others are written when made
        st.node_depths = wp.zeros(capacity, dtype=wp.int32)
        st.node_lefts = wp.full(capacity, -1, dtype=wp.int32)
        st.node_lowers = wp.empty(capacity, dtype=wp.vec3)
        st.node_uppers = wp.empty(capacity, dtype=wp.vec3)
        st.node_c_lowers = wp.empty(capacity, dtype=wp.vec3)
        st.node_c_uppers = wp.empty(capacity, dtype=wp.vec3)
        root = data.root_bounds()
        for field, row in (("node_lowers", 0), ("node_uppers", 1), ("node_c_lowers", 2), ("node_c_uppers", 3)):
            wp.copy(getattr(st, field), root, 0, row, 1)
        st.slots = wp.empty((2, n), dtype=SlotBox)
        wp.launch(init_slots_kernel, n, inputs=[data.prim_lowers, data.prim_uppers], outputs=[st.slots[0]])
        st.out_prims = wp.empty(n, dtype=wp.int32)
        # One bin scratch per thread of a launch: a level holds at most 2 n / (subtree_size + 1) + 1 nodes, as
        # only nodes above subtree_size split there (the subtree phase grows it if it has more pending nodes).
        allocate_scratch(st, 2 * n // (int(subtree_size) + 1) + 2, int(bins))
        st.max_bins = int(bins) if use_sah else 2
        st.use_sah = int(use_sah)
        st.max_leaf_size = int(leaf_size)
        st.traversal_cost = float(traversal_cost)
        st.intersection_cost = float(intersection_cost)
        st.max_depth = MAX_DEPTH
        st.subtree_size = int(subtree_size)
        if parallel_min is None:
            parallel_min = PARALLEL_MIN_CUDA if data.device.is_cuda else NO_PARALLEL
        st.parallel_min = max(int(parallel_min), int(subtree_size))  # smaller nodes are built whole, below
        large = LargeNodeSplitter(st, n) if n > st.parallel_min else None

        # Level phase: nodes above subtree_size triangles, breadth first, one launch per level.
        node_pending = wp.zeros(capacity, dtype=wp.int32)
        active = wp.zeros(n, dtype=wp.int32)
        next_active = wp.empty(n, dtype=wp.int32)
        split_flags = wp.empty(n, dtype=wp.int32)
        split_ranks = wp.empty(n, dtype=wp.int32)
        child_counts = wp.empty(2 * n, dtype=wp.int32)
        children = [wp.empty(2 * n, dtype=wp.vec3) for _ in range(4)]  # box lower/upper, centroid lower/upper
        num_active, num_nodes, depth = 1, 1, 0
        while num_active > 0:
            k = num_active

            def split_level(a: int, b: int):
                wp.launch(
                    split_nodes_kernel,
                    b - a,
                    inputs=[st, active[a:b], active[a:b], a, 0],
                    outputs=[split_flags[a:b], child_counts[2 * a : 2 * b]]
                    + [c[2 * a : 2 * b] for c in children]
                    + [node_pending, split_flags[a:b]],
                )

            run_split(split_level, k, active, st.node_counts, pool, threads)
            if large is not None:
                large.split(active, k, children, split_flags, child_counts, depth % 2)
            wp.utils.array_scan(split_flags[:k], split_ranks[:k], inclusive=False)
            num_splits = read_int(split_ranks, k - 1) + read_int(split_flags, k - 1)
            wp.launch(
                make_children_kernel,
                k,
                inputs=[active, split_flags, split_ranks, child_counts, *children, num_nodes],
                outputs=[st.node_starts, st.node_counts, st.node_depths, st.node_lefts, st.node_lowers]
                + [st.node_uppers, st.node_c_lowers, st.node_c_uppers, next_active],
            )
            active, next_active = next_active, active
            num_nodes += 2 * num_splits
            num_active = 2 * num_splits
            depth += 1

        # Subtree phase: every pending node's subtree, whole, in reserved node ranges after the level phase's.
        top = num_nodes
        ranks = wp.empty(top, dtype=wp.int32)
        wp.utils.array_scan(node_pending[:top], ranks, inclusive=True)
        num_pending = read_int(ranks, top - 1)
        total = top
        if num_pending:
            pending = wp.empty(num_pending, dtype=wp.int32)
            if num_pending > len(st.right_counts) // int(bins):
                allocate_scratch(st, num_pending, int(bins))
            wp.launch(compact_flags_kernel, top, inputs=[node_pending[:top], ranks], outputs=[pending])
            sizes = wp.empty(num_pending, dtype=wp.int32)
            wp.launch(pending_sizes_kernel, num_pending, inputs=[st, pending], outputs=[sizes])
            reserved = wp.empty(num_pending, dtype=wp.int32)
            wp.utils.array_scan(sizes, reserved, inclusive=False)
            wp.launch(offset_kernel, num_pending, inputs=[top], outputs=[reserved])
            used = wp.empty(num_pending, dtype=wp.int32)

            def build_subtrees(a: int, b: int):
                wp.launch(
                    split_nodes_kernel,
                    b - a,
                    inputs=[st, pending[a:b], reserved[a:b], a, 1],
                    outputs=[used[a:b], used[a:b], *[c[:1] for c in children], node_pending, used[a:b]],
                )

            run_split(build_subtrees, num_pending, pending, st.node_counts, pool, threads)
            used_offsets = wp.empty(num_pending, dtype=wp.int32)
            wp.utils.array_scan(used, used_offsets, inclusive=False)
            total = top + read_int(used_offsets, num_pending - 1) + read_int(used, num_pending - 1)
        if pool is not None:
            pool.shutdown()

        # Canonical arrays: level-phase nodes in place, subtrees moved down to close the gaps.
        left_first = wp.empty(total, dtype=wp.int32)
        prim_count = wp.empty(total, dtype=wp.int32)
        lowers = wp.empty(total, dtype=wp.vec3)
        uppers = wp.empty(total, dtype=wp.vec3)
        wp.launch(finish_nodes_kernel, top, inputs=[st], outputs=[left_first, prim_count, lowers, uppers])
        if num_pending:
            wp.launch(
                relocate_subtrees_kernel,
                num_pending,
                inputs=[st, pending, reserved, used, used_offsets, top],
                outputs=[left_first, prim_count, lowers, uppers],
            )
        return DeviceFlatBvh(lowers, uppers, left_first, prim_count, st.out_prims, builder)


@wp.kernel
def offset_kernel(
    offset: int,
    # outputs
    values: wp.array[wp.int32],
):
    """Adds ``offset`` to every value."""
    i = wp.tid()
    values[i] = values[i] + offset


def allocate_scratch(st: BinnedBuild, workers: int, bins: int) -> None:
    """Bin scratch for ``workers`` threads of ``bins`` bins per axis."""
    st.bins = wp.empty(3 * bins * workers, dtype=Bin)
    st.right_areas = wp.empty(bins * workers, dtype=float)
    st.right_counts = wp.empty(bins * workers, dtype=wp.int32)


def run_split(launch, k: int, items: wp.array, node_counts: wp.array, pool, threads: int) -> None:
    """Calls ``launch(a, b)`` over ``k`` nodes ``items[:k]``: once, or in pieces of about equal triangle count on
    ``pool`` (Warp's CPU launches release the GIL). The nodes are independent, so the tree does not change."""
    if pool is None or k < 2:
        launch(0, k)
        return
    counts = node_counts.numpy()[items.numpy()[:k]].astype(np.int64)
    pieces = min(threads, k)
    bounds = np.searchsorted(np.cumsum(counts), np.arange(1, pieces) * counts.sum() / pieces, side="left") + 1
    bounds = np.unique(np.clip(np.concatenate([[0], bounds, [k]]), 0, k))
    futures = [pool.submit(launch, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
    for future in futures:
        future.result()
