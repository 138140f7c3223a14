"""Top-down builders over presorted centroids, level by level in Warp kernels: the full-sweep SAH (``sweep_sah``)
and the object median (``median``).

The triangles are sorted once by centroid along each axis (three stable radix sorts). Every node owns the same slot
range ``[start, start + count)`` in all three sorted lists, and a stable partition keeps each list sorted, so a
node always sees its triangles in order along every axis (the classic ``O(N log N)`` SAH builder; MacDonald and
Booth 1990, Wald 2007 "full sweep").

- ``sweep_sah`` evaluates the SAH cost ``A(L) N(L) + A(R) N(R)`` at every one of the ``count - 1`` positions of
  all three lists (a right-to-left sweep stores the right boxes' areas, a left-to-right sweep evaluates) and keeps
  the cheapest; SAH leaf termination and the depth guarantee are those of ``choose_action``.
- ``median`` splits the list of the axis with the largest centroid extent at ``count / 2``.
- The halving fallback of the depth guarantee is the object median on the widest axis.

Each level is one launch with one thread per node: it chooses the split, flags the triangles that go left and
partitions the three lists into the second buffer. Triangle boxes travel with the ids, so every pass streams.
"""

from __future__ import annotations

import warp as wp

from .binned import make_children_kernel
from .common import ACTION_LEAF, ACTION_SPLIT, MAX_DEPTH, BuildInput, choose_action, half_area, read_int, widest_axis
from .layout import DeviceFlatBvh

wp.set_module_options({"enable_backward": False})


@wp.kernel
def axis_keys_kernel(
    centroids: wp.array[wp.vec3],
    axis: int,
    # outputs
    keys: wp.array[float],
    values: wp.array[wp.int32],
):
    """Sort keys (centroid coordinate) and values (triangle id) for one axis."""
    i = wp.tid()
    keys[i] = centroids[i][axis]
    values[i] = i


@wp.kernel
def gather_boxes_kernel(
    order: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    axis: int,
    # outputs
    ids: wp.array2d[wp.int32],
    lowers: wp.array2d[wp.vec3],
    uppers: wp.array2d[wp.vec3],
):
    """Row ``axis`` of the sorted lists: triangle ids and their boxes in centroid order."""
    i = wp.tid()
    p = order[i]
    ids[axis, i] = p
    lowers[axis, i] = prim_lowers[p]
    uppers[axis, i] = prim_uppers[p]


@wp.kernel
def split_sorted_kernel(
    active: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_depths: wp.array[wp.int32],
    node_lowers: wp.array[wp.vec3],
    node_uppers: wp.array[wp.vec3],
    src_ids: wp.array2d[wp.int32],
    src_lowers: wp.array2d[wp.vec3],
    src_uppers: wp.array2d[wp.vec3],
    use_sah: int,
    max_leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    max_depth: int,
    # outputs
    dst_ids: wp.array2d[wp.int32],
    dst_lowers: wp.array2d[wp.vec3],
    dst_uppers: wp.array2d[wp.vec3],
    out_prims: wp.array[wp.int32],
    goes_left: wp.array[wp.uint8],
    right_areas: wp.array[float],
    split_flags: wp.array[wp.int32],
    child_counts: wp.array[wp.int32],
    child_lowers: wp.array[wp.vec3],
    child_uppers: wp.array[wp.vec3],
):
    """One active node: choose leaf / split position / halving and partition the three sorted lists."""
    k = wp.tid()
    n = active[k]
    start = node_starts[n]
    count = node_counts[n]
    end = start + count

    # Centroid extent per axis: first and last entries of each sorted list.
    extent = wp.vec3(0.0)
    for axis in range(3):
        first = 0.5 * (src_lowers[axis, start] + src_uppers[axis, start])
        last = 0.5 * (src_lowers[axis, end - 1] + src_uppers[axis, end - 1])
        extent[axis] = last[axis] - first[axis]
    widest = widest_axis(extent)

    # Find the split: every position of every axis (SAH), or the middle of the widest axis (median).
    best_cost = float(wp.inf)
    best_axis = widest
    best_left = count / 2
    if use_sah == 1 and count > 1:
        for axis in range(3):
            # Sweep from the right, keeping the area of slots [i, end) for every split i.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            for i in range(end - 1, start, -1):
                lo = wp.min(lo, src_lowers[axis, i])
                hi = wp.max(hi, src_uppers[axis, i])
                right_areas[i] = half_area(lo, hi)
            # Sweep from the left: slots [start, i) left, [i, end) right.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            for i in range(start + 1, end):
                lo = wp.min(lo, src_lowers[axis, i - 1])
                hi = wp.max(hi, src_uppers[axis, i - 1])
                cost = half_area(lo, hi) * float(i - start) + right_areas[i] * float(end - i)
                # Equal costs (e.g. identical triangles): prefer the more balanced split.
                balance = wp.abs(2 * (i - start) - count)
                if cost < best_cost or (cost == best_cost and balance < wp.abs(2 * best_left - count)):
                    best_cost = cost
                    best_axis = axis
                    best_left = i - start

    # Decide between leaf, the split found, and halving (object median on the widest axis).
    area = half_area(node_lowers[n], node_uppers[n])
    action = choose_action(
        count,
        node_depths[n],
        area,
        count > 1,
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
            out_prims[i] = src_ids[0, i]
        split_flags[k] = 0
        return
    if action != ACTION_SPLIT:
        best_axis = widest
        best_left = count / 2

    # Flag the triangles that go left, then partition all three lists stably.
    for i in range(start, end):
        goes_left[src_ids[best_axis, i]] = wp.uint8(wp.where(i - start < best_left, 1, 0))
    big = wp.vec3(wp.inf)
    l_lo = big
    l_hi = -big
    r_lo = big
    r_hi = -big
    for axis in range(3):
        n_l = int(0)
        n_r = int(0)
        for i in range(start, end):
            p = src_ids[axis, i]
            lo = src_lowers[axis, i]
            hi = src_uppers[axis, i]
            j = int(0)
            if goes_left[p] == wp.uint8(1):
                j = start + n_l
                n_l += 1
                if axis == 0:
                    l_lo = wp.min(l_lo, lo)
                    l_hi = wp.max(l_hi, hi)
            else:
                j = start + best_left + n_r
                n_r += 1
                if axis == 0:
                    r_lo = wp.min(r_lo, lo)
                    r_hi = wp.max(r_hi, hi)
            dst_ids[axis, j] = p
            dst_lowers[axis, j] = lo
            dst_uppers[axis, j] = hi
    split_flags[k] = 1
    child_counts[2 * k] = best_left
    child_counts[2 * k + 1] = count - best_left
    child_lowers[2 * k] = l_lo
    child_uppers[2 * k] = l_hi
    child_lowers[2 * k + 1] = r_lo
    child_uppers[2 * k + 1] = r_hi


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


def build_sweep(
    data: BuildInput,
    *,
    use_sah: bool,
    leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    builder: str,
) -> DeviceFlatBvh:
    """Builds the tree over ``data`` (see module docstring), on ``data.device``."""
    n = data.num_prims
    with wp.ScopedDevice(data.device):
        # Sort the triangles by centroid along each axis (stable, so ties stay in id order).
        src_ids = wp.empty((3, n), dtype=wp.int32)
        src_lowers = wp.empty((3, n), dtype=wp.vec3)
        src_uppers = wp.empty((3, n), dtype=wp.vec3)
        keys = wp.empty(2 * n, dtype=float)
        values = wp.empty(2 * n, dtype=wp.int32)
        for axis in range(3):
            wp.launch(axis_keys_kernel, n, inputs=[data.centroids, axis], outputs=[keys, values])
            wp.utils.radix_sort_pairs(keys, values, n)
            wp.launch(
                gather_boxes_kernel,
                n,
                inputs=[values, data.prim_lowers, data.prim_uppers, axis],
                outputs=[src_ids, src_lowers, src_uppers],
            )
        del keys, values
        dst_ids = wp.empty_like(src_ids)
        dst_lowers = wp.empty_like(src_lowers)
        dst_uppers = wp.empty_like(src_uppers)

        capacity = 2 * n - 1
        node_lowers = wp.empty(capacity, dtype=wp.vec3)
        node_uppers = wp.empty(capacity, dtype=wp.vec3)
        node_starts = wp.zeros(capacity, dtype=wp.int32)
        node_counts = wp.zeros(capacity, dtype=wp.int32)
        node_depths = wp.zeros(capacity, dtype=wp.int32)
        node_lefts = wp.full(capacity, -1, dtype=wp.int32)
        node_counts.fill_(n)
        root = data.root_bounds()
        wp.copy(node_lowers, root, 0, 0, 1)
        wp.copy(node_uppers, root, 0, 1, 1)

        out_prims = wp.empty(n, dtype=wp.int32)
        goes_left = wp.empty(n, dtype=wp.uint8)
        right_areas = wp.empty(n, dtype=float)
        active = wp.zeros(n, dtype=wp.int32)
        next_active = wp.empty(n, dtype=wp.int32)
        split_flags = wp.empty(n, dtype=wp.int32)
        split_ranks = wp.empty(n, dtype=wp.int32)
        child_counts = wp.empty(2 * n, dtype=wp.int32)
        child_lowers = wp.empty(2 * n, dtype=wp.vec3)
        child_uppers = wp.empty(2 * n, dtype=wp.vec3)
        unused = wp.empty(capacity, dtype=wp.vec3)  # centroid boxes, which sorted lists do not need

        num_active, num_nodes = 1, 1
        while num_active > 0:
            k = num_active
            wp.launch(
                split_sorted_kernel,
                k,
                inputs=[active, node_starts, node_counts, node_depths, node_lowers, node_uppers]
                + [src_ids, src_lowers, src_uppers, int(use_sah), int(leaf_size), float(traversal_cost)]
                + [float(intersection_cost), MAX_DEPTH],
                outputs=[dst_ids, dst_lowers, dst_uppers, out_prims, goes_left, right_areas, split_flags]
                + [child_counts, child_lowers, child_uppers],
            )
            wp.utils.array_scan(split_flags[:k], split_ranks[:k], inclusive=False)
            num_splits = read_int(split_ranks, k - 1) + read_int(split_flags, k - 1)
            wp.launch(
                make_children_kernel,
                k,
                inputs=[active, split_flags, split_ranks, child_counts, child_lowers, child_uppers, child_lowers]
                + [child_uppers, num_nodes],
                outputs=[node_starts, node_counts, node_depths, node_lefts, node_lowers, node_uppers, unused]
                + [unused, next_active],
            )
            src_ids, dst_ids = dst_ids, src_ids
            src_lowers, dst_lowers = dst_lowers, src_lowers
            src_uppers, dst_uppers = dst_uppers, src_uppers
            active, next_active = next_active, active
            num_nodes += 2 * num_splits
            num_active = 2 * num_splits

        m = num_nodes
        left_first = wp.empty(m, dtype=wp.int32)
        prim_count = wp.empty(m, dtype=wp.int32)
        wp.launch(
            finish_nodes_kernel, m, inputs=[node_lefts, node_starts, node_counts], outputs=[left_first, prim_count]
        )
        return DeviceFlatBvh(node_lowers[:m], node_uppers[:m], left_first, prim_count, out_prims, builder)
