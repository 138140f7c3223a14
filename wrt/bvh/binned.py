"""Top-down binned builders, level by level in Warp kernels: binned SAH (``sah``) and the spatial median
(``middle``).

Binned SAH follows Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies" (2007): the centroids of
a node are sorted into ``min(bins, count)`` equal bins on each of the three axes, and the split is the bin
boundary with the least SAH cost ``A(L) N(L) + A(R) N(R)``. SAH leaf termination uses explicit traversal and
intersection costs (``choose_action``). ``middle`` splits the centroid box of a node at its middle along the widest
axis (the same kernel with two bins on one axis).

The tree grows breadth first. Each level is one launch over the level's nodes, in which one thread bins, decides
and stably partitions its node's slots into a second slot buffer (and records its children's boxes), followed by
a prefix scan that places the two children of every split node side by side. Work per level is ``O(N)``; the
launch count is a few per level. On a CPU device this is as cache-friendly as a recursive builder; on a GPU the
first levels run on few threads (the price of a simple, deterministic builder).

The result does not depend on the device or on the run: there are no atomics in the per-node work.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

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

wp.set_module_options({"enable_backward": False})


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


@wp.kernel
def split_binned_kernel(
    active: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_depths: wp.array[wp.int32],
    node_lowers: wp.array[wp.vec3],
    node_uppers: wp.array[wp.vec3],
    node_c_lowers: wp.array[wp.vec3],
    node_c_uppers: wp.array[wp.vec3],
    src: wp.array[SlotBox],
    max_bins: int,
    use_sah: int,
    max_leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    max_depth: int,
    # outputs
    dst: wp.array[SlotBox],
    out_prims: wp.array[wp.int32],
    split_flags: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_lowers: wp.array[wp.vec3],
    child_uppers: wp.array[wp.vec3],
    child_c_lowers: wp.array[wp.vec3],
    child_c_uppers: wp.array[wp.vec3],
    bin_counts: wp.array[wp.int32],
    bin_lowers: wp.array[wp.vec3],
    bin_uppers: wp.array[wp.vec3],
    right_areas: wp.array[float],
    right_counts: wp.array[wp.int32],
):
    """One active node: bin, choose leaf / SAH split / halving, and partition its slots into ``dst_prims``."""
    k = wp.tid()
    n = active[k]
    start = node_starts[n]
    count = node_counts[n]
    end = start + count
    c_lo = node_c_lowers[n]
    c_hi = node_c_uppers[n]
    extent = c_hi - c_lo
    widest = widest_axis(extent)
    bins = wp.min(max_bins, count)
    scale = bin_scales(c_lo, c_hi, bins)
    use_axis = wp.vec3i(0)
    for axis in range(3):
        if count > 1 and extent[axis] > 0.0 and (use_sah == 1 or axis == widest):
            use_axis[axis] = 1
    # Scratch: 3 * bins <= 3 * count bins and bins <= count sweep entries, so the node's slot range is its own.
    base = 3 * start
    sweep = start

    # Bin every centroid on each axis that can split (all three for SAH, the widest one for the middle split).
    for b in range(base, base + 3 * bins):
        bin_counts[b] = 0
        bin_lowers[b] = wp.vec3(wp.inf)
        bin_uppers[b] = wp.vec3(-wp.inf)
    if count > 1:
        for i in range(start, end):
            slot = src[i]
            lo = slot.lower
            hi = slot.upper
            c = 0.5 * (lo + hi)
            for axis in range(3):
                if use_axis[axis] == 1:
                    b = base + axis * bins + bin_of(c, c_lo, scale, axis, bins)
                    bin_counts[b] = bin_counts[b] + 1  # not "+=", which compiles to an atomic add
                    bin_lowers[b] = wp.min(bin_lowers[b], lo)
                    bin_uppers[b] = wp.max(bin_uppers[b], hi)

    # Find the best bin-boundary split: least SAH cost over three axes, or the middle of the widest axis.
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
                b = base + axis * bins + s
                lo = wp.min(lo, bin_lowers[b])
                hi = wp.max(hi, bin_uppers[b])
                m += bin_counts[b]
                right_areas[sweep + s] = half_area(lo, hi)
                right_counts[sweep + s] = m
            # Sweep from the left and evaluate each split s: bins [0, s) left, [s, bins) right.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            m = int(0)
            for s in range(1, bins):
                b = base + axis * bins + s - 1
                lo = wp.min(lo, bin_lowers[b])
                hi = wp.max(hi, bin_uppers[b])
                m += bin_counts[b]
                if m > 0 and right_counts[sweep + s] > 0:
                    cost = float(0.0)
                    if use_sah == 1:
                        cost = half_area(lo, hi) * float(m) + right_areas[sweep + s] * float(right_counts[sweep + s])
                    else:
                        # Spatial median: the split nearest the middle bin boundary wins.
                        cost = wp.abs(float(2 * s - bins))
                    if cost < best_cost:
                        best_cost = cost
                        best_axis = axis
                        best_split = s
                        best_left = m

    # Decide between leaf, the split found, and halving.
    area = half_area(node_lowers[n], node_uppers[n])
    action = choose_action(
        count,
        node_depths[n],
        area,
        best_axis >= 0,
        best_cost,
        best_left,
        use_sah,
        max_leaf_size,
        traversal_cost,
        intersection_cost,
        max_depth,
    )
    if action == ACTION_LEAF:
        for i in range(start, end):
            out_prims[i] = src[i].prim
        split_flags[k] = 0
        return

    # Partition the slots stably into [start, start + n_left) and the rest, growing both children's boxes.
    n_left = best_left
    if action == ACTION_HALVE:
        n_left = count / 2
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
        slot = src[i]
        lo = slot.lower
        hi = slot.upper
        c = 0.5 * (lo + hi)
        left = False
        if action == ACTION_SPLIT:
            left = bin_of(c, c_lo, scale, best_axis, bins) < best_split
        else:
            left = i - start < n_left
        j = int(0)
        if left:
            j = start + n_l
            n_l += 1
            l_lo = wp.min(l_lo, lo)
            l_hi = wp.max(l_hi, hi)
            l_clo = wp.min(l_clo, c)
            l_chi = wp.max(l_chi, c)
        else:
            j = start + n_left + n_r
            n_r += 1
            r_lo = wp.min(r_lo, lo)
            r_hi = wp.max(r_hi, hi)
            r_clo = wp.min(r_clo, c)
            r_chi = wp.max(r_chi, c)
        dst[j] = slot
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
def finish_nodes_kernel(
    node_lefts: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    # outputs
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
):
    """Canonical node fields: an inner node points at its left child, a leaf at its first slot."""
    n = wp.tid()
    if node_lefts[n] >= 0:
        left_first[n] = node_lefts[n]
        prim_count[n] = 0
    else:
        left_first[n] = node_starts[n]
        prim_count[n] = node_counts[n]


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
) -> DeviceFlatBvh:
    """Builds the tree over ``data`` (see module docstring), on ``data.device``; on a CPU device each level's
    nodes are split into ``threads`` pieces of about equal triangle count that run at once."""
    n = data.num_prims
    with wp.ScopedDevice(data.device):
        capacity = 2 * n - 1
        node_lowers = wp.empty(capacity, dtype=wp.vec3)
        node_uppers = wp.empty(capacity, dtype=wp.vec3)
        node_c_lowers = wp.empty(capacity, dtype=wp.vec3)
        node_c_uppers = wp.empty(capacity, dtype=wp.vec3)
        node_starts = wp.zeros(capacity, dtype=wp.int32)
        node_counts = wp.zeros(capacity, dtype=wp.int32)
        node_depths = wp.zeros(capacity, dtype=wp.int32)
        node_lefts = wp.full(capacity, -1, dtype=wp.int32)
        node_counts.fill_(n)  # only the root's count matters; the others are written when allocated
        root = data.root_bounds()
        wp.copy(node_lowers, root, 0, 0, 1)
        wp.copy(node_uppers, root, 0, 1, 1)
        wp.copy(node_c_lowers, root, 0, 2, 1)
        wp.copy(node_c_uppers, root, 0, 3, 1)

        # Slot buffers, ping-ponged between levels: triangle id and box travel together, so every pass streams.
        src = wp.empty(n, dtype=SlotBox)
        dst = wp.empty(n, dtype=SlotBox)
        wp.launch(init_slots_kernel, n, inputs=[data.prim_lowers, data.prim_uppers], outputs=[src])
        out_prims = wp.empty(n, dtype=wp.int32)
        # Per-level arrays: a level never holds more than ceil(n / 2) split nodes, and at most n nodes.
        active = wp.zeros(n, dtype=wp.int32)
        next_active = wp.empty(n, dtype=wp.int32)
        split_flags = wp.empty(n, dtype=wp.int32)
        split_ranks = wp.empty(n, dtype=wp.int32)
        child_counts = wp.empty(2 * n, dtype=wp.int32)
        child_lowers = wp.empty(2 * n, dtype=wp.vec3)
        child_uppers = wp.empty(2 * n, dtype=wp.vec3)
        child_c_lowers = wp.empty(2 * n, dtype=wp.vec3)
        child_c_uppers = wp.empty(2 * n, dtype=wp.vec3)
        # Bin scratch: a node of c slots starting at slot s owns bins [3 s, 3 s + 3 c) and sweep entries [s, s + c).
        bin_counts = wp.empty(3 * n, dtype=wp.int32)
        bin_lowers = wp.empty(3 * n, dtype=wp.vec3)
        bin_uppers = wp.empty(3 * n, dtype=wp.vec3)
        right_areas = wp.empty(n, dtype=float)
        right_counts = wp.empty(n, dtype=wp.int32)
        scratch = [bin_counts, bin_lowers, bin_uppers, right_areas, right_counts]

        level_bins = int(bins) if use_sah else 2
        num_active, num_nodes = 1, 1
        pool = ThreadPoolExecutor(threads) if threads > 1 else None
        while num_active > 0:
            k = num_active

            def split_nodes(a: int, b: int):
                """Launches the per-node kernel over active nodes ``[a, b)`` (views, so pieces can run at once)."""
                wp.launch(
                    split_binned_kernel,
                    b - a,
                    inputs=[active[a:b], node_starts, node_counts, node_depths, node_lowers, node_uppers]
                    + [node_c_lowers, node_c_uppers, src, level_bins, int(use_sah)]
                    + [int(leaf_size), float(traversal_cost), float(intersection_cost), MAX_DEPTH],
                    outputs=[dst, out_prims, split_flags[a:b], child_counts[2 * a : 2 * b]]
                    + [child_lowers[2 * a : 2 * b], child_uppers[2 * a : 2 * b], child_c_lowers[2 * a : 2 * b]]
                    + [child_c_uppers[2 * a : 2 * b]]
                    + scratch,
                )

            run_split(split_nodes, k, active, node_counts, pool, threads)
            wp.utils.array_scan(split_flags[:k], split_ranks[:k], inclusive=False)
            num_splits = read_int(split_ranks, k - 1) + read_int(split_flags, k - 1)
            wp.launch(
                make_children_kernel,
                k,
                inputs=[active, split_flags, split_ranks, child_counts, child_lowers, child_uppers, child_c_lowers]
                + [child_c_uppers, num_nodes],
                outputs=[node_starts, node_counts, node_depths, node_lefts, node_lowers, node_uppers, node_c_lowers]
                + [node_c_uppers, next_active],
            )
            src, dst = dst, src
            active, next_active = next_active, active
            num_nodes += 2 * num_splits
            num_active = 2 * num_splits

        if pool is not None:
            pool.shutdown()
        return flat_from_nodes(
            num_nodes, node_lowers, node_uppers, node_starts, node_counts, node_lefts, out_prims, builder
        )


def run_split(split_nodes, k: int, active: wp.array, node_counts: wp.array, pool, threads: int) -> None:
    """Calls ``split_nodes(a, b)`` over the ``k`` active nodes: once, or in pieces of about equal triangle count on
    ``pool`` (Warp's CPU launches release the GIL). The nodes are independent, so the tree does not change."""
    if pool is None or k < 2:
        split_nodes(0, k)
        return
    counts = node_counts.numpy()[active.numpy()[:k]].astype(np.int64)
    pieces = min(threads, k)
    bounds = np.searchsorted(np.cumsum(counts), np.arange(1, pieces) * counts.sum() / pieces, side="left") + 1
    bounds = np.unique(np.clip(np.concatenate([[0], bounds, [k]]), 0, k))
    futures = [pool.submit(split_nodes, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
    for future in futures:
        future.result()


def flat_from_nodes(m, node_lowers, node_uppers, node_starts, node_counts, node_lefts, prims, builder):
    """The DeviceFlatBvh of the first ``m`` nodes of a top-down build (leaves: ``node_lefts < 0``)."""
    left_first = wp.empty(m, dtype=wp.int32)
    prim_count = wp.empty(m, dtype=wp.int32)
    wp.launch(finish_nodes_kernel, m, inputs=[node_lefts, node_starts, node_counts], outputs=[left_first, prim_count])
    return DeviceFlatBvh(node_lowers[:m], node_uppers[:m], left_first, prim_count, prims, builder)
