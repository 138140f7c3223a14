"""PLOC: bottom-up agglomerative clustering (Meister and Bittner, "Parallel Locally-Ordered Clustering for Bounding
Volume Hierarchy Construction", IEEE TVCG 2018), as Warp kernels on ``cpu`` and ``cuda``.

The clusters start as the triangles in Morton order (``lbvh.sorted_morton_order``). Each iteration:

1. every cluster finds its nearest neighbour among the ``radius`` clusters on either side, the distance being the
   surface area of the two boxes' union; ties are broken by a total order on pairs (``pair_less``), so the closest
   pair overall is always mutual and every iteration merges;
2. every pair of mutual nearest neighbours merges into a new internal node, stored at the lower position; so does
   every pair found by the chain matching below;
3. the cluster array is compacted with one prefix scan over the merges (which keeps the Morton order).

Chain matching. Mutual pairs alone stall on runs of clusters whose union areas shrink steadily along the Morton
order (strips of triangles growing smaller towards a pole, say): each one's nearest neighbour is the next, so a run
merges only at its end, one pair per iteration. On a 10M-triangle displaced sphere, 30k clusters were still single
triangles after 60 iterations, each merging 2-3% of the clusters. So the clusters left over also pair up, as in a
proposal round: a hash of position and iteration puts each on the proposing or the accepting side; a proposer
offers itself to its nearest neighbour, and an accepting cluster that is not in a mutual pair takes the closest of
its proposers, if that one's distance is at most ``CHAIN_TOLERANCE`` times its own nearest-neighbour distance (so
the pair is nearly as good for it as its own choice). This keeps about 20% of the clusters merging per iteration
down to about a thousand clusters: the 10M sphere reaches ``TAIL_CLUSTERS`` after 26 iterations instead of 72, its
tree is 49 levels deep before the leaf collapse instead of about 110 (so ``flatten.py`` needs no depth bound), and
the SAH cost is as good (1M displaced sphere +7.6% -> +7.5% over ``binned_sah``, turbineblade +9.0% -> +7.9%, chess_set
+7.0% -> +7.1%; a tolerance of 1.25 gave +7.6%, +8.3%, +9.2% in a trial; unlimited, +14.1%, +11.6%, +17.8%).

If an iteration merges fewer than 1/64 of the clusters (degenerate input, e.g. many identical triangles), the
next one merges neighbours pairwise instead, so the iteration count stays logarithmic.

The last ``TAIL_CLUSTERS`` clusters take many iterations that merge a few percent each (before chain matching,
about 80 of 107 at 1M triangles), so one launch finishes them: one thread block on CUDA (one thread on the CPU)
runs the same steps with block barriers in place of launches and no reads back to the host. These top levels
search a radius of at most ``TAIL_RADIUS``, which measured a lower SAH cost than the full radius (before chain
matching: 1M displaced sphere +11.2% -> +7.6% over ``binned_sah``, turbineblade +9.3% -> +9.0%, chess_set +7.5% ->
+7.0%; radius 2: +7.2%, +8.5%, +7.7%; a wider tail radius made it worse: 16 gave +13.4% on the sphere).

Afterwards the tree's triangles are put in depth-first order (newest nodes first: the tail's in its launch, then
one launch per earlier iteration), which gives every subtree a contiguous slot range; the internal nodes are
renumbered by split position (``renumber_kernel``), and ``flatten.py`` makes the canonical layout (depth guarantee,
bounds, SAH leaf collapse).
"""

from __future__ import annotations

import warp as wp

from .common import BuildInput, half_area, read_int, stage
from .flatten import flatten_source
from .layout import DeviceFlatBvh
from .lbvh import sorted_morton_order

wp.set_module_options({"enable_backward": False})

FORCE_FRACTION = wp.constant(64)  # an iteration merging fewer than clusters / FORCE_FRACTION makes the next pairwise
CHAIN_TOLERANCE = wp.constant(1.05)  # chain matching: a proposer at most this much farther than the acceptor's own NN
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
    union box, and that area."""
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
    return best, best_d


@wp.func
def accepts(i: int, seed: int):
    """Whether cluster ``i`` takes the accepting side in this iteration's chain matching (a hash of position and
    iteration: the same on every device)."""
    h = wp.uint32(i) + wp.uint32(seed) * wp.uint32(668265261)
    # Integer mix (xor-shift-multiply): neighbouring positions get independent sides.
    h = (h ^ (h >> wp.uint32(16))) * wp.uint32(2146120493)
    h = (h ^ (h >> wp.uint32(15))) * wp.uint32(830770091)
    h = h ^ (h >> wp.uint32(16))
    return (h & wp.uint32(1)) == wp.uint32(1)


@wp.func
def is_mutual(i: int, neighbours: wp.array[wp.int32]):
    """Whether ``i`` and its nearest neighbour are each other's."""
    return neighbours[neighbours[i]] == i


@wp.func
def best_proposer(j: int, n: int, radius: int, seed: int, neighbours: wp.array[wp.int32], nn_dists: wp.array[float]):
    """Of the proposing clusters whose nearest neighbour is ``j``, the one closest to ``j`` (``pair_less``); -1 for
    none."""
    best = int(-1)
    best_d = float(0.0)
    for c in range(wp.max(j - radius, 0), wp.min(j + radius + 1, n)):
        if c != j:
            if neighbours[c] == j:  # nested: Warp evaluates both sides of ``and``
                d = nn_dists[c]
                if not accepts(c, seed) and d <= CHAIN_TOLERANCE * nn_dists[j]:
                    if best < 0 or pair_less(d, c, j, best_d, best, j):
                        best = c
                        best_d = d
    return best


@wp.func
def merge_partner(
    i: int,
    n: int,
    force_pairs: int,
    radius: int,
    seed: int,
    neighbours: wp.array[wp.int32],
    nn_dists: wp.array[float],
):
    """The cluster that ``i`` merges with this iteration, -1 for none: its pair in a pairwise iteration; else its
    nearest neighbour if that is mutual, or if the chain matching pairs them (module docstring). Symmetric:
    ``j = merge_partner(i) >= 0`` gives ``merge_partner(j) = i``."""
    j = int(-1)
    if force_pairs == 1:
        j = i + 1 - 2 * (i & 1)
        if j >= n:
            j = -1
    else:
        nn = neighbours[i]
        if is_mutual(i, neighbours):
            j = nn
        elif accepts(i, seed):
            j = best_proposer(i, n, radius, seed, neighbours, nn_dists)
        elif accepts(nn, seed):
            # Proposes to its nearest neighbour: a match if that one is not in a mutual pair and has no closer
            # proposer.
            if not is_mutual(nn, neighbours):
                if best_proposer(nn, n, radius, seed, neighbours, nn_dists) == i:
                    j = nn
    return j


@wp.kernel
def nearest_neighbour_kernel(
    n: int,
    radius: int,
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    # outputs
    neighbours: wp.array[wp.int32],
    nn_dists: wp.array[float],
):
    """Nearest neighbour of every cluster, and its distance."""
    i = wp.tid()
    j, d = nearest_neighbour(i, n, radius, 0, lowers, uppers)
    neighbours[i] = j
    nn_dists[i] = d


@wp.kernel
def merge_flags_kernel(
    n: int,
    force_pairs: int,
    seed: int,
    radius: int,
    neighbours: wp.array[wp.int32],
    nn_dists: wp.array[float],
    # outputs
    partners: wp.array[wp.int32],
    merge_flags: wp.array[wp.int32],
):
    """``partners[i]``: the cluster that ``i`` merges with, -1 for none; ``merge_flags[i] = 1`` where that partner
    is higher (``i`` makes the new node)."""
    i = wp.tid()
    j = merge_partner(i, n, force_pairs, radius, seed, neighbours, nn_dists)
    partners[i] = j
    merge_flags[i] = wp.where(j > i, 1, 0)


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
    max_gap: int,
    first_node: int,
    partners: wp.array[wp.int32],
    merge_ranks: wp.array[wp.int32],
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
    """Creates the internal node of every merging pair and writes the surviving clusters, compacted.

    Only the merges are scanned (``merge_ranks``, inclusive). A cluster's place among the survivors follows from
    it: the clusters absorbed up to ``i`` are the pairs closed by then, i.e. the merges up to ``i`` less those still
    open (partner beyond ``i``), and an open pair started at most ``max_gap - 1`` positions back."""
    i = wp.tid()
    j = partners[i]
    if j >= 0 and j < i:
        return
    open_pairs = int(0)
    for lower in range(wp.max(i - max_gap + 1, 0), i + 1):
        if partners[lower] > i:
            open_pairs += 1
    node = first_node + merge_ranks[i] - 1
    ref, lo, hi, count = merged_cluster(i, j, node, refs, lowers, uppers, counts, node_left, node_right, node_counts)
    k = i - merge_ranks[i] + open_pairs  # survivors before i
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
    split_ids: wp.array[wp.int32],
):
    """Depth-first slots for the children of ``node`` (its own start is set): the left subtree first. Leaf
    references are rewritten from ``-prim - 1`` to ``-slot - 1``; ``split_ids[node]`` is the node's split position
    (the last slot of its left child), its id after ``renumber_kernel``."""
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
    split_ids[node] = right_start - 1
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
    split_ids: wp.array[wp.int32],
):
    """Depth-first slots below the nodes made in one iteration (their parents are done)."""
    assign_slots(first_node + wp.tid(), node_counts, node_left, node_right, node_starts, slot_prims, split_ids)


@wp.func
def node_id(k: int, root_split: int, split_ids: wp.array[wp.int32]):
    """Id of internal node ``k`` after ``renumber_kernel``: its split position, except that the root and the node
    of split position 0 trade ids, so the root is node 0 as in a Karras tree."""
    m = split_ids[k]
    if m == root_split:
        m = 0
    elif m == 0:
        m = root_split
    return m


@wp.kernel
def renumber_kernel(
    root: int,
    split_ids: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    # outputs
    new_left: wp.array[wp.int32],
    new_right: wp.array[wp.int32],
    new_counts: wp.array[wp.int32],
):
    """Moves internal node ``k`` to ``node_id(k)``. Every split position of a tree over contiguous slot ranges
    belongs to exactly one node, so this is a permutation; it puts nodes near their slots, as the ids of a Karras
    radix tree are, where the merge order scatters them: the flatten's bottom-up pass and node emission then read
    and write neighbouring nodes together (10M triangles on an H200: those kernels 4.6 -> 2.1 ms)."""
    k = wp.tid()
    root_split = split_ids[root]
    left = node_left[k]
    right = node_right[k]
    if left >= 0:
        left = node_id(left, root_split, split_ids)
    if right >= 0:
        right = node_id(right, root_split, split_ids)
    m = node_id(k, root_split, split_ids)
    new_left[m] = left
    new_right[m] = right
    new_counts[m] = node_counts[k]


@wp.kernel(launch_bounds=TAIL_THREADS)
def cluster_tail_kernel(
    clusters: int,
    first_node: int,
    force_pairs: int,
    radius: int,
    seed: int,
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
    nn_dists: wp.array[float],
    partners: wp.array[wp.int32],
    partials: wp.array[wp.int32],
    batch_firsts: wp.array[wp.int32],
    batch_counts: wp.array[wp.int32],
    node_left: wp.array[wp.int32],
    node_right: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    slot_prims: wp.array[wp.int32],
    split_ids: wp.array[wp.int32],
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
        # Find nearest neighbours and merge partners, then count this thread's merges and survivors.
        if force == 0:
            for i in range(begin, end):
                nn, d = nearest_neighbour(i, k, radius, src, buf_lowers, buf_uppers)
                neighbours[i] = nn
                nn_dists[i] = d
            block_barrier()
        for i in range(begin, end):
            partners[i] = merge_partner(i, k, force, radius, seed + batches, neighbours, nn_dists)
        block_barrier()
        merges = int(0)
        keeps = int(0)
        for i in range(begin, end):
            j = partners[i]
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
            j = partners[i]
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
            assign_slots(n, node_counts, node_left, node_right, node_starts, slot_prims, split_ids)
        block_barrier()


def replay(launch: wp.Launch, dim: int, *leading_params) -> None:
    """Launches a recorded kernel launch over ``dim`` threads with new values for its first parameters."""
    launch.set_dim(dim)
    for index, value in enumerate(leading_params):
        launch.set_param_at_index(index, value)
    launch.launch()


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
    ``flatten_source``.

    The clustering's scratch arrays are freed before the flatten allocates its own, with no synchronization
    between, so CUDA's memory pool hands the same memory over; after a synchronization it returns freed memory to
    the system (at its default release threshold, 0), and new memory must be mapped again. On an H200, 1 GB takes
    0.8-1.5 ms to allocate after a synchronization and 0.02-0.06 ms right after a free
    (``benchmarks/gpu_mempool_probe.py``); this took about 2.5 ms off the 10M-triangle build.
    """
    n = data.num_prims
    with wp.ScopedDevice(data.device):
        with stage("morton codes and sort", timers):
            morton_prims, _, _ = sorted_morton_order(data, morton_bits)
        slot_prims, split_ids, *source = _cluster(data, morton_prims, radius, timers)
        del morton_prims
        if n > 1:
            with stage("node ids", timers):
                renumbered = [wp.empty(n - 1, dtype=wp.int32) for _ in range(3)]
                wp.launch(renumber_kernel, n - 1, inputs=[n - 2, split_ids, *source], outputs=renumbered)
                source = renumbered
                del split_ids  # freed before the flatten allocates (see above)
        return flatten_source(
            slot_prims,
            *source,
            0,
            data.prim_lowers,
            data.prim_uppers,
            leaf_size=leaf_size,
            traversal_cost=traversal_cost,
            intersection_cost=intersection_cost,
            builder="ploc",
            timers=timers,
        )


def _cluster(data: BuildInput, morton_prims: wp.array, radius: int, timers: dict | None) -> tuple:
    """Clustering and depth-first slots: ``(slot_prims, split_ids, node_left, node_right, node_counts)``, internal
    node ``n - 2`` the root. Its scratch arrays are freed on return."""
    n = data.num_prims
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
    nn_dists = wp.empty(n, dtype=float)
    partners = wp.empty(n, dtype=wp.int32)
    merge_flags = wp.empty(n, dtype=wp.int32)
    merge_ranks = wp.empty(n, dtype=wp.int32)
    wp.launch(
        init_clusters_kernel,
        n,
        inputs=[morton_prims, data.prim_lowers, data.prim_uppers],
        outputs=[refs, lowers, uppers, counts],
    )
    # Merge pairs down to TAIL_CLUSTERS clusters; remember which nodes each iteration made.
    # The launches are recorded once (one per cluster buffer for the two that alternate) and replayed with a
    # new size: a plain wp.launch spends more host time packing its arguments than these kernels run for.
    slot_prims = wp.empty(n, dtype=wp.int32)
    split_ids = wp.empty(inner, dtype=wp.int32)
    with stage("clustering", timers):
        clusters_ab = ([refs, lowers, uppers, counts], [new_refs, new_lowers, new_uppers, new_counts])
        if n > TAIL_CLUSTERS:  # small builds go straight to the tail launch
            nn_launches = [
                wp.launch(
                    nearest_neighbour_kernel,
                    n,
                    inputs=[n, int(radius), c[1], c[2]],
                    outputs=[neighbours, nn_dists],
                    record_cmd=True,
                )
                for c in clusters_ab
            ]
            flags_launch = wp.launch(
                merge_flags_kernel,
                n,
                inputs=[n, 0, 0, int(radius), neighbours, nn_dists],
                outputs=[partners, merge_flags],
                record_cmd=True,
            )
            merge_launches = [
                wp.launch(
                    merge_compact_kernel,
                    n,
                    inputs=[1, 0, partners, merge_ranks, *src],
                    outputs=[node_left, node_right, node_counts, *dst],
                    record_cmd=True,
                )
                for src, dst in (clusters_ab, clusters_ab[::-1])
            ]
        batches = []
        clusters, next_node, force, parity = n, 0, 0, 0
        while clusters > TAIL_CLUSTERS:
            k = clusters
            if not force:
                replay(nn_launches[parity], k, k)
            replay(flags_launch, k, k, force, len(batches))
            wp.utils.array_scan(merge_flags[:k], merge_ranks[:k], inclusive=True)
            merges = read_int(merge_ranks, k - 1)  # one device-to-host read per iteration
            replay(merge_launches[parity], k, 1 if force else int(radius), next_node)
            batches.append((next_node, merges))
            next_node += merges
            clusters -= merges
            force = 1 if merges * FORCE_FRACTION < k else 0
            parity = 1 - parity
        refs, lowers, uppers, counts = clusters_ab[parity]

        # The rest, and the slots below the nodes it makes, in one launch.
        if clusters > 1:
            threads = TAIL_THREADS if data.device.is_cuda else 1
            tail_radius = min(int(radius), TAIL_RADIUS)
            c = clusters
            buffers = [wp.empty(2 * c, dtype=a.dtype) for a in (refs, lowers, uppers, counts)]
            partials = wp.empty(2 * threads, dtype=wp.int32)
            scratch = [neighbours[:c], nn_dists[:c], partners[:c], partials, merge_ranks[:c], merge_flags[:c]]
            wp.launch(
                cluster_tail_kernel,
                threads,
                inputs=[c, next_node, force, tail_radius, len(batches), threads, refs, lowers, uppers, counts],
                outputs=buffers + scratch + [node_left, node_right, node_counts, node_starts, slot_prims, split_ids],
                block_dim=threads,
            )

    # Depth-first slot order for the older nodes, newest first.
    with stage("depth-first slots", timers):
        if n == 1:
            wp.copy(slot_prims, morton_prims)
        if batches:
            slots_launch = wp.launch(
                assign_slots_kernel,
                1,
                inputs=[0, node_counts],
                outputs=[node_left, node_right, node_starts, slot_prims, split_ids],
                record_cmd=True,
            )
            for first, count in reversed(batches):
                replay(slots_launch, count, first)
    return slot_prims, split_ids, node_left, node_right, node_counts
