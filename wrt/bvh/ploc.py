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

The last ``TAIL_CLUSTERS`` clusters took most of the iterations (about 80 of 107 at 1M triangles, merging a few
percent each), so one launch finishes them: one thread block on CUDA (one thread on the CPU) runs the same steps
with block barriers in place of launches and no reads back to the host. These top levels search a radius of at
most ``TAIL_RADIUS``, which measured a lower SAH cost than the full radius (1M displaced sphere +11.2% -> +7.6%
over ``binned_sah``, turbineblade +9.3% -> +9.0%, chess_set +7.5% -> +7.0%; radius 2: +7.2%, +8.5%, +7.7%; a
wider tail radius made it worse: 16 gave +13.4% on the sphere).

Afterwards the tree's triangles are put in depth-first order (newest nodes first: the tail's in its launch, then
one launch per earlier iteration), which gives every subtree a contiguous slot range, and ``flatten.py`` makes the
canonical layout (depth guarantee, bounds, SAH leaf collapse).
"""

from __future__ import annotations

import warp as wp

from .common import BuildInput, half_area, read_int, stage
from .flatten import flatten_source
from .layout import DeviceFlatBvh
from .lbvh import sorted_morton_order

wp.set_module_options({"enable_backward": False})

FORCE_FRACTION = wp.constant(64)  # an iteration merging fewer than clusters / FORCE_FRACTION makes the next pairwise
TAIL_CLUSTERS = 8192  # from this many clusters down, clustering finishes in one launch
TAIL_THREADS = 512  # CUDA threads (one block) of that launch
TAIL_RADIUS = 4  # search radius of the tail, at most (see module docstring)


@wp.func_native(
    """
#if defined(__CUDA_ARCH__)
__syncthreads();
#endif
"""
)
def block_barrier():
    """``__syncthreads()`` on CUDA, which also makes the block's global memory writes visible to the block (nothing
    on the CPU, where the tail runs in one thread)."""
    ...


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


@wp.func
def nearest_neighbour(i: int, n: int, radius: int, base: int, lowers: wp.array[wp.vec3], uppers: wp.array[wp.vec3]):
    """Nearest neighbour of cluster ``i`` of ``n`` (stored from ``base``) within ``radius`` positions, by area of the
    union box."""
    lo = lowers[base + i]
    hi = uppers[base + i]
    best = int(-1)
    best_d = float(0.0)
    for j in range(wp.max(i - radius, 0), wp.min(i + radius + 1, n)):
        if j != i:
            d = half_area(wp.min(lo, lowers[base + j]), wp.max(hi, uppers[base + j]))
            if best < 0 or pair_less(d, i, j, best_d, i, best):
                best = j
                best_d = d
    return best


@wp.func
def merge_partner(i: int, n: int, force_pairs: int, neighbours: wp.array[wp.int32]):
    """The cluster that ``i`` merges with this iteration (a mutual nearest neighbour, or its pair in a pairwise
    iteration), -1 for none."""
    j = int(-1)
    if force_pairs == 1:
        j = i + 1 - 2 * (i & 1)
        if j >= n:
            j = -1
    else:
        j = neighbours[i]
        if j >= 0:  # nested: Warp evaluates both sides of ``and``
            if neighbours[j] != i:
                j = -1
    return j


@wp.kernel
def nearest_neighbour_kernel(
    n: int,
    radius: int,
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    # outputs
    neighbours: wp.array[wp.int32],
):
    """Nearest neighbour of every cluster."""
    i = wp.tid()
    neighbours[i] = nearest_neighbour(i, n, radius, 0, lowers, uppers)


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
    j = merge_partner(i, n, force_pairs, neighbours)
    merge_flags[i] = wp.where(j > i, 1, 0)
    keep_flags[i] = wp.where(j >= 0 and j < i, 0, 1)


@wp.func
def merged_cluster(
    i: int,
    j: int,
    node: int,
    refs: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
):
    """``(ref, lower, upper, count)`` of cluster ``i`` after an iteration: itself, or for a partner ``j > i`` the new
    internal node ``node`` over both (whose children and count are written here)."""
    ref = refs[i]
    lo = lowers[i]
    hi = uppers[i]
    count = counts[i]
    if j > i:
        count += counts[j]
        node_left[node] = ref
        node_right[node] = refs[j]
        node_counts[node] = count
        ref = node
        lo = wp.min(lo, lowers[j])
        hi = wp.max(hi, uppers[j])
    return ref, lo, hi, count


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
    j = int(-1)
    if merge_flags[i] == 1:
        j = wp.where(force_pairs == 1, i + 1, neighbours[i])
    node = first_node + merge_ranks[i] - 1  # inclusive rank
    ref, lo, hi, count = merged_cluster(i, j, node, refs, lowers, uppers, counts, node_left, node_right, node_counts)
    k = keep_ranks[i] - 1  # inclusive rank
    new_refs[k] = ref
    new_lowers[k] = lo
    new_uppers[k] = hi
    new_counts[k] = count


@wp.func
def assign_slots(
    node: int,
    node_counts: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
):
    """Depth-first slots for the children of ``node`` (its own start is set): the left subtree first. Leaf
    references are rewritten from ``-prim - 1`` to ``-slot - 1``."""
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
    """Depth-first slots below the nodes made in one iteration (their parents are done)."""
    assign_slots(first_node + wp.tid(), node_counts, node_left, node_right, node_starts, slot_prims)


@wp.kernel(launch_bounds=TAIL_THREADS)
def cluster_tail_kernel(
    clusters: int,
    first_node: int,
    force_pairs: int,
    radius: int,
    threads: int,
    refs: wp.array[wp.int32],
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    counts: wp.array[wp.int32],
    # outputs
    buf_refs: wp.array[wp.int32],
    buf_lowers: wp.array[wp.vec3],
    buf_uppers: wp.array[wp.vec3],
    buf_counts: wp.array[wp.int32],
    neighbours: wp.array[wp.int32],
    partials: wp.array[wp.int32],
    batch_firsts: wp.array[wp.int32],
    batch_counts: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
):
    """The iterations of ``build_ploc`` from ``clusters`` clusters down to one, in one block of ``threads``
    threads, then the depth-first slots below the nodes they made. Thread ``t`` owns a contiguous chunk of the
    clusters, so ranks are a sum over the lower threads' counts; the clusters alternate between the two halves of
    the ``buf_*`` arrays (``(2 C,)``, ``C = len(neighbours)``)."""
    t = wp.tid()
    capacity = neighbours.shape[0]
    for i in range(t, clusters, threads):
        buf_refs[i] = refs[i]
        buf_lowers[i] = lowers[i]
        buf_uppers[i] = uppers[i]
        buf_counts[i] = counts[i]
    block_barrier()
    k = int(clusters)
    node = int(first_node)
    force = int(force_pairs)
    src = int(0)
    batches = int(0)
    while k > 1:
        dst = capacity - src
        chunk = (k + threads - 1) / threads
        begin = wp.min(t * chunk, k)
        end = wp.min(begin + chunk, k)
        # Find nearest neighbours, then count this thread's merges and survivors.
        if force == 0:
            for i in range(begin, end):
                neighbours[i] = nearest_neighbour(i, k, radius, src, buf_lowers, buf_uppers)
        block_barrier()
        merges = int(0)
        keeps = int(0)
        for i in range(begin, end):
            j = merge_partner(i, k, force, neighbours)
            if j > i:
                merges += 1
            if j < 0 or j > i:
                keeps += 1
        partials[2 * t] = merges
        partials[2 * t + 1] = keeps
        block_barrier()
        # Exclusive ranks of this thread's first merge and survivor; merges of the whole iteration (over the
        # threads that own clusters).
        merge_rank = int(0)
        keep_rank = int(0)
        total = int(0)
        for u in range((k + chunk - 1) / chunk):
            if u < t:
                merge_rank += partials[2 * u]
                keep_rank += partials[2 * u + 1]
            total += partials[2 * u]
        # Merge and compact into the other half (merge_compact_kernel's work).
        for i in range(begin, end):
            j = merge_partner(i, k, force, neighbours)
            if j < 0 or j > i:
                ref, lo, hi, count = merged_cluster(
                    src + i,
                    wp.where(j > i, src + j, -1),
                    node + merge_rank,
                    buf_refs,
                    buf_lowers,
                    buf_uppers,
                    buf_counts,
                    node_left,
                    node_right,
                    node_counts,
                )
                if j > i:
                    merge_rank += 1
                buf_refs[dst + keep_rank] = ref
                buf_lowers[dst + keep_rank] = lo
                buf_uppers[dst + keep_rank] = hi
                buf_counts[dst + keep_rank] = count
                keep_rank += 1
        if t == 0:
            batch_firsts[batches] = node
            batch_counts[batches] = total
        batches += 1
        node += total
        force = wp.where(total * FORCE_FRACTION < k, 1, 0)
        k -= total
        src = dst
        block_barrier()

    # Depth-first slots, newest nodes first (the root's start is set).
    for b in range(batches - 1, -1, -1):
        first = batch_firsts[b]
        for n in range(first + t, first + batch_counts[b], threads):
            assign_slots(n, node_counts, node_left, node_right, node_starts, slot_prims)
        block_barrier()


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

        # Merge mutual nearest neighbours down to TAIL_CLUSTERS clusters; remember which nodes each iteration made.
        slot_prims = wp.empty(n, dtype=wp.int32)
        with stage("clustering", timers):
            batches = []
            clusters, next_node, force = n, 0, 0
            while clusters > TAIL_CLUSTERS:
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

            # The rest, and the slots below the nodes it makes, in one launch.
            if clusters > 1:
                threads = TAIL_THREADS if data.device.is_cuda else 1
                tail_radius = min(int(radius), TAIL_RADIUS)
                c = clusters
                buffers = [wp.empty(2 * c, dtype=a.dtype) for a in (refs, lowers, uppers, counts)]
                partials = wp.empty(2 * threads, dtype=wp.int32)
                scratch = [neighbours[:c], partials, merge_ranks[:c], keep_ranks[:c]]  # neighbours, batches
                wp.launch(
                    cluster_tail_kernel,
                    threads,
                    inputs=[c, next_node, force, tail_radius, threads, refs, lowers, uppers, counts],
                    outputs=buffers + scratch + [node_left, node_right, node_counts, node_starts, slot_prims],
                    block_dim=threads,
                )

        # Depth-first slot order for the older nodes, newest first.
        with stage("depth-first slots", timers):
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
