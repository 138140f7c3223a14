"""PLOC: bottom-up agglomerative clustering (Meister and Bittner, "Parallel Locally-Ordered Clustering for Bounding
Volume Hierarchy Construction", IEEE TVCG 2018), as Warp kernels on ``cpu`` and ``cuda``.

The clusters start as the triangles in Morton order (``lbvh.sorted_morton_order``). Each iteration:

1. every cluster finds its nearest neighbour among the ``radius`` clusters on either side, the distance being the
   surface area of the two boxes' union; ties are broken by a total order on pairs (``pair_less``), so the closest
   pair overall is always mutual and every iteration merges;
2. every pair of mutual nearest neighbours merges into a new internal node, stored at the lower position;
3. the cluster array is compacted with a prefix scan (which keeps the Morton order).

If an iteration merges fewer than 1/64 of the clusters (degenerate input, e.g. many identical triangles), the
next one merges neighbours pairwise instead, so the iteration count stays logarithmic.

Afterwards the tree's triangles are put in depth-first order (one launch per iteration, newest nodes first), which
gives every subtree a contiguous slot range, and ``flatten.py`` makes the canonical layout (depth guarantee,
bounds, SAH leaf collapse).
"""

from __future__ import annotations

import warp as wp

from .common import BuildInput, half_area, read_int, stage
from .flatten import flatten_source
from .layout import DeviceFlatBvh
from .lbvh import sorted_morton_order

wp.set_module_options({"enable_backward": False})

FORCE_FRACTION = 64  # an iteration merging fewer than clusters / FORCE_FRACTION makes the next one pairwise


@wp.func
def pair_less(d0: float, i0: int, j0: int, d1: float, i1: int, j1: int):
    """Total order on cluster pairs ``{i, j}``: distance, then gap, then pairs starting at even positions, then
    position. Symmetric in ``i, j``, so the least pair is the nearest neighbour of both its members."""
    g0 = wp.abs(i0 - j0)
    g1 = wp.abs(i1 - j1)
    m0 = wp.min(i0, j0)
    m1 = wp.min(i1, j1)
    less = False
    if d0 != d1:
        less = d0 < d1
    elif g0 != g1:
        less = g0 < g1
    elif (m0 & 1) != (m1 & 1):
        less = (m0 & 1) == 0
    else:
        less = m0 < m1
    return less


@wp.kernel
def init_clusters_kernel(
    slot_prims: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    # outputs
    refs: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
):
    """One cluster per triangle, in Morton order; a leaf reference is ``-prim - 1``."""
    i = wp.tid()
    p = slot_prims[i]
    refs[i] = -p - 1
    lowers[i] = prim_lowers[p]
    uppers[i] = prim_uppers[p]
    counts[i] = 1


@wp.kernel
def nearest_neighbour_kernel(
    n: int,
    radius: int,
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    # outputs
    neighbours: wp.array[wp.int32],
):
    """Nearest neighbour of cluster ``i`` within ``radius`` positions, by area of the union box."""
    i = wp.tid()
    lo = lowers[i]
    hi = uppers[i]
    best = int(-1)
    best_d = float(0.0)
    for j in range(wp.max(i - radius, 0), wp.min(i + radius + 1, n)):
        if j != i:
            d = half_area(wp.min(lo, lowers[j]), wp.max(hi, uppers[j]))
            if best < 0 or pair_less(d, i, j, best_d, i, best):
                best = j
                best_d = d
    neighbours[i] = best


@wp.kernel
def merge_flags_kernel(
    n: int,
    force_pairs: int,
    neighbours: wp.array[wp.int32],
    # outputs
    merge_flags: wp.array[wp.int32],
    keep_flags: wp.array[wp.int32],
):
    """``merge_flags[i] = 1`` where cluster ``i`` merges with a higher partner; ``keep_flags[i] = 0`` for the
    partner that is absorbed."""
    i = wp.tid()
    j = neighbours[i]
    if force_pairs == 1:
        j = i + 1 - 2 * (i & 1)
        if j >= n:
            j = -1
    mutual = False
    if j >= 0:
        if force_pairs == 1:
            mutual = True
        else:
            mutual = neighbours[j] == i
    merge_flags[i] = wp.where(mutual and i < j, 1, 0)
    keep_flags[i] = wp.where(mutual and i > j, 0, 1)


@wp.kernel
def merge_compact_kernel(
    force_pairs: int,
    first_node: int,
    neighbours: wp.array[wp.int32],
    merge_flags: wp.array[wp.int32],
    merge_ranks: wp.array[wp.int32],
    keep_flags: wp.array[wp.int32],
    keep_ranks: wp.array[wp.int32],
    refs: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
    # outputs
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    new_refs: wp.array[wp.int32],
    new_lowers: wp.array[wp.vec3],
    new_uppers: wp.array[wp.vec3],
    new_counts: wp.array[wp.int32],
):
    """Creates the internal node of every merging pair and writes the surviving clusters, compacted."""
    i = wp.tid()
    if keep_flags[i] == 0:
        return
    ref = refs[i]
    lo = lowers[i]
    hi = uppers[i]
    count = counts[i]
    if merge_flags[i] == 1:
        j = neighbours[i]
        if force_pairs == 1:
            j = i + 1
        node = first_node + merge_ranks[i] - 1  # inclusive rank
        node_left[node] = ref
        node_right[node] = refs[j]
        count = count + counts[j]
        node_counts[node] = count
        ref = node
        lo = wp.min(lo, lowers[j])
        hi = wp.max(hi, uppers[j])
    k = keep_ranks[i] - 1  # inclusive rank
    new_refs[k] = ref
    new_lowers[k] = lo
    new_uppers[k] = hi
    new_counts[k] = count


@wp.kernel
def assign_slots_kernel(
    first_node: int,
    node_counts: wp.array[wp.int32],
    # outputs
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
):
    """Depth-first slots for the nodes made in one iteration (their parents are done): the left subtree first.
    Leaf references are rewritten from ``-prim - 1`` to ``-slot - 1``."""
    node = first_node + wp.tid()
    start = node_starts[node]
    left = node_left[node]
    right = node_right[node]
    left_count = int(1)
    if left >= 0:
        left_count = node_counts[left]
        node_starts[left] = start
    else:
        slot_prims[start] = -left - 1
        node_left[node] = -start - 1
    right_start = start + left_count
    if right >= 0:
        node_starts[right] = right_start
    else:
        slot_prims[right_start] = -right - 1
        node_right[node] = -right_start - 1


def build_ploc(
    data: BuildInput,
    *,
    leaf_size: int,
    morton_bits: int,
    radius: int,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    timers: dict | None = None,
) -> DeviceFlatBvh:
    """Builds a PLOC tree over ``data`` (see module docstring) on ``data.device``; ``timers`` as in
    ``flatten_source``."""
    n = data.num_prims
    with wp.ScopedDevice(data.device):
        with stage("morton codes and sort", timers):
            morton_prims, _ = sorted_morton_order(data, morton_bits)
        # The n - 1 merges write every node; only the root's start (slot 0) is set here.
        inner = max(n - 1, 1)
        node_left = wp.empty(inner, dtype=wp.int32)
        node_right = wp.empty(inner, dtype=wp.int32)
        node_counts = wp.empty(inner, dtype=wp.int32)
        node_starts = wp.empty(inner, dtype=wp.int32)
        node_starts[max(n - 2, 0) :].fill_(0)
        refs = wp.empty(n, dtype=wp.int32)
        lowers = wp.empty(n, dtype=wp.vec3)
        uppers = wp.empty(n, dtype=wp.vec3)
        counts = wp.empty(n, dtype=wp.int32)
        new_refs, new_lowers, new_uppers, new_counts = (wp.empty_like(a) for a in (refs, lowers, uppers, counts))
        neighbours = wp.empty(n, dtype=wp.int32)
        merge_flags = wp.empty(n, dtype=wp.int32)
        merge_ranks = wp.empty(n, dtype=wp.int32)
        keep_flags = wp.empty(n, dtype=wp.int32)
        keep_ranks = wp.empty(n, dtype=wp.int32)
        wp.launch(
            init_clusters_kernel,
            n,
            inputs=[morton_prims, data.prim_lowers, data.prim_uppers],
            outputs=[refs, lowers, uppers, counts],
        )

        # Merge mutual nearest neighbours until one cluster is left; remember which nodes each iteration made.
        with stage("clustering", timers):
            batches = []
            clusters, next_node, force = n, 0, 0
            while clusters > 1:
                k = clusters
                if not force:
                    wp.launch(
                        nearest_neighbour_kernel, k, inputs=[k, int(radius), lowers, uppers], outputs=[neighbours]
                    )
                wp.launch(merge_flags_kernel, k, inputs=[k, force, neighbours], outputs=[merge_flags, keep_flags])
                wp.utils.array_scan(merge_flags[:k], merge_ranks[:k], inclusive=True)
                wp.utils.array_scan(keep_flags[:k], keep_ranks[:k], inclusive=True)
                merges = read_int(merge_ranks, k - 1)  # one device-to-host read per iteration
                wp.launch(
                    merge_compact_kernel,
                    k,
                    inputs=[force, next_node, neighbours, merge_flags, merge_ranks, keep_flags, keep_ranks]
                    + [refs, lowers, uppers, counts],
                    outputs=[node_left, node_right, node_counts, new_refs, new_lowers, new_uppers, new_counts],
                )
                batches.append((next_node, merges))
                next_node += merges
                clusters -= merges
                force = 1 if merges * FORCE_FRACTION < k else 0
                refs, new_refs = new_refs, refs
                lowers, new_lowers = new_lowers, lowers
                uppers, new_uppers = new_uppers, uppers
                counts, new_counts = new_counts, counts

        # Depth-first slot order, root (the last node made) first.
        with stage("depth-first slots", timers):
            slot_prims = wp.empty(n, dtype=wp.int32)
            if n == 1:
                wp.copy(slot_prims, morton_prims)
            for first, count in reversed(batches):
                wp.launch(
                    assign_slots_kernel,
                    count,
                    inputs=[first, node_counts],
                    outputs=[node_left, node_right, node_starts, slot_prims],
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
