"""Trial (reverted in the next commit): hierarchical PLOC, one thread per radix-tree node; see GPU_NOTES.md row 14."""
"""Hierarchical PLOC (prototype)."""

from __future__ import annotations

import warp as wp

from .cluster_buffer import CLUSTER_BUILD_OPTIONS, ClusterBuffer
from .common import BuildInput, half_area, read_int, stage
from .flatten import flatten_source, source_node, source_parents_kernel, thread_fence
from .layout import DeviceFlatBvh
from .lbvh import radix_tree_kernel, sorted_morton_order

wp.set_module_options({"enable_backward": False, "extra_build_options": CLUSTER_BUILD_OPTIONS})


@wp.kernel
def cluster_climb_kernel(
    leaf_base: int,
    threshold: int,
    parents: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    # outputs
    visits: wp.array[wp.int32],
    node_clusters: wp.array[wp.int32],
    c_refs: wp.array[wp.int32],
    c_lowers: wp.array[wp.vec3],
    c_uppers: wp.array[wp.vec3],
    c_counts: wp.array[wp.int32],
    c_heights: wp.array[wp.int32],
    next_node: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
):
    s = wp.tid()
    p = slot_prims[s]
    c_refs[s] = -s - 1
    c_lowers[s] = prim_lowers[p]
    c_uppers[s] = prim_uppers[p]
    c_counts[s] = 1
    c_heights[s] = 0
    node = leaf_base + s
    node_clusters[node] = 1
    first = s
    parent = parents[node]
    while parent >= 0:
        thread_fence()
        if wp.atomic_add(visits, parent, 1) == 0:
            return
        thread_fence()
        left = src_left[parent]
        left_node = source_node(left, leaf_base)
        right_node = source_node(src_right[parent], leaf_base)
        left_count = int(1)
        if left >= 0:
            left_count = src_counts[left]
        if node != left_node:
            first -= left_count
        ml = node_clusters[left_node]
        mr = node_clusters[right_node]
        m = ml + mr
        grand = parents[parent]
        target = wp.where(grand >= 0, threshold, 1)
        if m <= target:
            if ml < left_count:
                for k in range(mr):
                    src = first + left_count + k
                    dst = first + ml + k
                    c_refs[dst] = c_refs[src]
                    c_lowers[dst] = c_lowers[src]
                    c_uppers[dst] = c_uppers[src]
                    c_counts[dst] = c_counts[src]
                    c_heights[dst] = c_heights[src]
        else:
            # The children's clusters into a thread-local buffer (the right child's after the left's).
            b = ClusterBuffer()
            for k in range(m):
                src = first + k
                if k >= ml:
                    src = first + left_count + k - ml
                wp.wrt_cluster_set(b, k, c_refs[src], c_lowers[src], c_uppers[src], c_counts[src], c_heights[src])
            # Merge the closest pair until ``target`` are left. Nearest neighbours are cached: after a merge only
            # the merged cluster and those whose neighbour it absorbed are searched again (a merged box is never
            # closer to a third cluster than its parts were).
            ia = int(-1)
            ib = int(-1)
            while m >= target:
                for k in range(m):
                    nk = wp.wrt_cluster_nearest(b, k)
                    if ia < 0 or k == ia or nk == ia or nk == ib:
                        lo = wp.wrt_cluster_lower(b, k)
                        hi = wp.wrt_cluster_upper(b, k)
                        best = int(-1)
                        best_d = float(0.0)
                        for j in range(m):
                            if j != k:
                                d = half_area(wp.min(lo, wp.wrt_cluster_lower(b, j)), wp.max(hi, wp.wrt_cluster_upper(b, j)))
                                if best < 0 or d < best_d:
                                    best = j
                                    best_d = d
                        wp.wrt_cluster_set_nearest(b, k, best, best_d)
                    elif nk == m:
                        wp.wrt_cluster_set_nearest(b, k, ib, wp.wrt_cluster_distance(b, k))
                if m == target:
                    break
                bi = int(0)
                best_d = wp.wrt_cluster_distance(b, 0)
                for k in range(1, m):
                    d = wp.wrt_cluster_distance(b, k)
                    if d < best_d:
                        best_d = d
                        bi = k
                bj = wp.wrt_cluster_nearest(b, bi)
                ia = wp.min(bi, bj)
                ib = wp.max(bi, bj)
                new_node = wp.atomic_add(next_node, 0, 1)
                count = wp.wrt_cluster_count(b, ia) + wp.wrt_cluster_count(b, ib)
                node_left[new_node] = wp.wrt_cluster_ref(b, ia)
                node_right[new_node] = wp.wrt_cluster_ref(b, ib)
                node_counts[new_node] = count
                wp.wrt_cluster_set(
                    b,
                    ia,
                    new_node,
                    wp.min(wp.wrt_cluster_lower(b, ia), wp.wrt_cluster_lower(b, ib)),
                    wp.max(wp.wrt_cluster_upper(b, ia), wp.wrt_cluster_upper(b, ib)),
                    count,
                    1 + wp.max(wp.wrt_cluster_height(b, ia), wp.wrt_cluster_height(b, ib)),
                )
                m -= 1
                if ib != m:
                    wp.wrt_cluster_move(b, m, ib)
            for k in range(m):
                dst = first + k
                c_refs[dst] = wp.wrt_cluster_ref(b, k)
                c_lowers[dst] = wp.wrt_cluster_lower(b, k)
                c_uppers[dst] = wp.wrt_cluster_upper(b, k)
                c_counts[dst] = wp.wrt_cluster_count(b, k)
                c_heights[dst] = wp.wrt_cluster_height(b, k)
        node_clusters[parent] = m
        node = parent
        parent = grand


@wp.kernel
def cluster_climb_global_kernel(
    leaf_base: int,
    threshold: int,
    pools: int,
    parents: wp.array[wp.int32],
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    # outputs
    visits: wp.array[wp.int32],
    node_clusters: wp.array[wp.int32],
    c_refs: wp.array[wp.int32],
    c_lowers: wp.array[wp.vec3],
    c_uppers: wp.array[wp.vec3],
    c_counts: wp.array[wp.int32],
    c_heights: wp.array[wp.int32],
    c_nn: wp.array[wp.int32],
    c_nd: wp.array[float],
    next_node: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
):
    s = wp.tid()
    p = slot_prims[s]
    c_refs[s] = -s - 1
    c_lowers[s] = prim_lowers[p]
    c_uppers[s] = prim_uppers[p]
    c_counts[s] = 1
    c_heights[s] = 0
    node = leaf_base + s
    node_clusters[node] = 1
    first = s
    parent = parents[node]
    while parent >= 0:
        thread_fence()
        if wp.atomic_add(visits, parent, 1) == 0:
            return
        thread_fence()
        left = src_left[parent]
        left_node = source_node(left, leaf_base)
        right_node = source_node(src_right[parent], leaf_base)
        left_count = int(1)
        if left >= 0:
            left_count = src_counts[left]
        if node != left_node:
            first -= left_count
        ml = node_clusters[left_node]
        mr = node_clusters[right_node]
        m = ml + mr
        grand = parents[parent]
        target = wp.where(grand >= 0, threshold, 1)
        if m <= target:
            if ml < left_count:
                for k in range(mr):
                    src = first + left_count + k
                    dst = first + ml + k
                    c_refs[dst] = c_refs[src]
                    c_lowers[dst] = c_lowers[src]
                    c_uppers[dst] = c_uppers[src]
                    c_counts[dst] = c_counts[src]
                    c_heights[dst] = c_heights[src]
        else:
            # The children's clusters into a thread-local buffer (the right child's after the left's).
            if ml < left_count:
                for k in range(mr):
                    src = first + left_count + k
                    dst = first + ml + k
                    c_refs[dst] = c_refs[src]
                    c_lowers[dst] = c_lowers[src]
                    c_uppers[dst] = c_uppers[src]
                    c_counts[dst] = c_counts[src]
                    c_heights[dst] = c_heights[src]
            merges = int(0)
            # Merge the closest pair until ``target`` are left. Nearest neighbours are cached: after a merge only
            # the merged cluster and those whose neighbour it absorbed are searched again (a merged box is never
            # closer to a third cluster than its parts were).
            ia = int(-1)
            ib = int(-1)
            while m >= target:
                for k in range(m):
                    nk = c_nn[first + k]
                    if ia < 0 or k == ia or nk == ia or nk == ib:
                        lo = c_lowers[first + k]
                        hi = c_uppers[first + k]
                        best = int(-1)
                        best_d = float(0.0)
                        for j in range(m):
                            if j != k:
                                d = half_area(wp.min(lo, c_lowers[first + j]), wp.max(hi, c_uppers[first + j]))
                                if best < 0 or d < best_d:
                                    best = j
                                    best_d = d
                        c_nn[first + k] = best
                        c_nd[first + k] = best_d
                    elif nk == m:
                        c_nn[first + k] = ib
                if m == target:
                    break
                bi = int(0)
                best_d = c_nd[first + 0]
                for k in range(1, m):
                    d = c_nd[first + k]
                    if d < best_d:
                        best_d = d
                        bi = k
                bj = c_nn[first + bi]
                ia = wp.min(bi, bj)
                ib = wp.max(bi, bj)
                new_node = int(0)
                if pools == 1:
                    new_node = parent * (2 * threshold - 1) + merges
                    merges += 1
                else:
                    new_node = wp.atomic_add(next_node, 0, 1)
                count = c_counts[first + ia] + c_counts[first + ib]
                node_left[new_node] = c_refs[first + ia]
                node_right[new_node] = c_refs[first + ib]
                node_counts[new_node] = count
                c_refs[first + ia] = new_node
                c_lowers[first + ia] = wp.min(c_lowers[first + ia], c_lowers[first + ib])
                c_uppers[first + ia] = wp.max(c_uppers[first + ia], c_uppers[first + ib])
                c_counts[first + ia] = count
                c_heights[first + ia] = 1 + wp.max(c_heights[first + ia], c_heights[first + ib])
                m -= 1
                if ib != m:
                    c_refs[first + ib] = c_refs[first + m]
                    c_lowers[first + ib] = c_lowers[first + m]
                    c_uppers[first + ib] = c_uppers[first + m]
                    c_counts[first + ib] = c_counts[first + m]
                    c_heights[first + ib] = c_heights[first + m]
                    c_nn[first + ib] = c_nn[first + m]
                    c_nd[first + ib] = c_nd[first + m]
        node_clusters[parent] = m
        node = parent
        parent = grand


@wp.kernel
def out_links_kernel(
    leaf_base: int,
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    # outputs
    jump: wp.array[wp.int32],
    offset: wp.array[wp.int32],
):
    i = wp.tid()
    left = node_left[i]
    ln = source_node(left, leaf_base)
    rn = source_node(node_right[i], leaf_base)
    jump[ln] = i
    jump[rn] = i
    offset[ln] = 0
    offset[rn] = wp.where(left >= 0, node_counts[wp.max(left, 0)], 1)


@wp.kernel
def offset_round_kernel(
    jump: wp.array[wp.int32],
    offset: wp.array[wp.int32],
    # outputs
    new_jump: wp.array[wp.int32],
    new_offset: wp.array[wp.int32],
):
    i = wp.tid()
    j = jump[i]
    if j >= 0:
        new_offset[i] = offset[i] + offset[j]
        new_jump[i] = jump[j]
    else:
        new_offset[i] = offset[i]
        new_jump[i] = -1


@wp.kernel
def place_slots_kernel(
    leaf_base: int,
    morton_prims: wp.array[wp.int32],
    starts: wp.array[wp.int32],
    # outputs
    slot_prims: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
):
    i = wp.tid()
    s = starts[leaf_base + i]
    slot_prims[s] = morton_prims[i]
    if i < leaf_base:
        left = node_left[i]
        if left < 0:
            node_left[i] = -starts[leaf_base - left - 1] - 1
        right = node_right[i]
        if right < 0:
            node_right[i] = -starts[leaf_base - right - 1] - 1


def build_hploc(
    data: BuildInput,
    *,
    leaf_size: int,
    morton_bits: int,
    threshold: int = 8,
    variant: str = "local",
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    timers: dict | None = None,
) -> DeviceFlatBvh:
    n = data.num_prims
    with wp.ScopedDevice(data.device):
        with stage("morton codes and sort", timers):
            morton_prims, codes = sorted_morton_order(data, morton_bits)
        inner = max(n - 1, 1)
        node_left = wp.empty(inner, dtype=wp.int32)
        node_right = wp.empty(inner, dtype=wp.int32)
        node_counts = wp.empty(inner, dtype=wp.int32)
        slot_prims = wp.empty(n, dtype=wp.int32)
        if n == 1:
            wp.copy(slot_prims, morton_prims)
        else:
            with stage("radix tree", timers):
                src_left = wp.empty(inner, dtype=wp.int32)
                src_right = wp.empty(inner, dtype=wp.int32)
                src_counts = wp.empty(inner, dtype=wp.int32)
                wp.launch(radix_tree_kernel, n - 1, inputs=[codes, n], outputs=[src_left, src_right, src_counts])
                leaf_base = n - 1
                parents = wp.empty(2 * n - 1, dtype=wp.int32)
                visits = wp.empty(n - 1, dtype=wp.int32)
                parents[0:1].fill_(-1)
                wp.launch(source_parents_kernel, n - 1, inputs=[leaf_base, src_left, src_right], outputs=[parents, visits])
            with stage("clustering", timers):
                node_clusters = wp.empty(2 * n - 1, dtype=wp.int32)
                c_refs = wp.empty(n, dtype=wp.int32)
                c_lowers = wp.empty(n, dtype=wp.vec3)
                c_uppers = wp.empty(n, dtype=wp.vec3)
                c_counts = wp.empty(n, dtype=wp.int32)
                c_heights = wp.empty(n, dtype=wp.int32)
                next_node = wp.zeros(1, dtype=wp.int32)
                if variant == "local":
                  wp.launch(
                    cluster_climb_kernel,
                    n,
                    inputs=[leaf_base, int(threshold), parents, src_left, src_right, src_counts, morton_prims]
                    + [data.prim_lowers, data.prim_uppers],
                    outputs=[visits, node_clusters, c_refs, c_lowers, c_uppers, c_counts, c_heights, next_node]
                    + [node_left, node_right, node_counts],
                  )
                else:
                  pools = 1 if variant == "pools" else 0
                  if pools:
                    size = (n - 1) * (2 * threshold - 1)
                    node_left = wp.empty(size, dtype=wp.int32); node_right = wp.empty(size, dtype=wp.int32); node_counts = wp.empty(size, dtype=wp.int32)
                  c_nn = wp.empty(n, dtype=wp.int32); c_nd = wp.empty(n, dtype=float)
                  wp.launch(
                    cluster_climb_global_kernel,
                    n,
                    inputs=[leaf_base, int(threshold), pools, parents, src_left, src_right, src_counts, morton_prims]
                    + [data.prim_lowers, data.prim_uppers],
                    outputs=[visits, node_clusters, c_refs, c_lowers, c_uppers, c_counts, c_heights, c_nn, c_nd, next_node]
                    + [node_left, node_right, node_counts],
                  )
                  if pools:
                    return None
                height = read_int(c_heights, 0)
            with stage("depth-first slots", timers):
                jump, jump2, offset, offset2 = (wp.empty(2 * n - 1, dtype=wp.int32) for _ in range(4))
                root = n - 2
                jump[root : root + 1].fill_(-1)
                offset[root : root + 1].fill_(0)
                wp.launch(
                    out_links_kernel, n - 1, inputs=[leaf_base, node_left, node_right, node_counts], outputs=[jump, offset]
                )
                for _ in range(int(height).bit_length()):
                    wp.launch(offset_round_kernel, 2 * n - 1, inputs=[jump, offset], outputs=[jump2, offset2])
                    jump, jump2, offset, offset2 = jump2, jump, offset2, offset
                wp.launch(
                    place_slots_kernel,
                    n,
                    inputs=[leaf_base, morton_prims, offset],
                    outputs=[slot_prims, node_left, node_right],
                )
        return flatten_source(
            slot_prims,
            node_left,
            node_right,
            node_counts,
            max(n - 2, 0),
            data.prim_lowers,
            data.prim_uppers,
            leaf_size=leaf_size,
            traversal_cost=traversal_cost,
            intersection_cost=intersection_cost,
            builder="ploc",
            timers=timers,
        )
