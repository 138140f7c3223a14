"""BVH builders: the builder registry and the top-down binned-SAH builder, as Warp kernels.

The builder works level by level (breadth first), so each step is one kernel launch over all primitive slots
or over all nodes of the current level, on ``cpu`` and ``cuda`` alike:

1. reduce the bounds and centroid bounds of every active node (float min/max atomics);
2. bin the centroids of each node on all three axes (Wald, "On fast Construction of SAH-based Bounding Volume
   Hierarchies", 2007), with ``min(bins, count)`` bins per axis so the bin storage never exceeds ``3 N``;
3. pick, per node, the cheapest SAH split or a leaf (SAH leaf termination with explicit cost constants);
4. partition each node's slots stably with one prefix scan (no atomics, so the result is deterministic);
5. allocate the two children of every split node next to each other, again with a prefix scan.

Only integer additions and float min/max are done atomically, so the tree is identical from run to run.

Depth guarantee: a node at depth ``d`` holding ``c`` primitives can always be finished by ``d + ceil(log2 c)``
by halving. The builder keeps ``d + ceil(log2 c) <= MAX_DEPTH - 1`` for every node and falls back to a split
that halves the count whenever the SAH split would break it (also when all centroids coincide). Traversal can
therefore use a fixed stack of ``MAX_DEPTH`` entries.
"""

from __future__ import annotations

import enum
import time

import numpy as np
import warp as wp

from .layout import FlatBvh

MAX_DEPTH = 64  # deepest leaf is at depth MAX_DEPTH - 1; traversal stacks hold MAX_DEPTH entries
MAX_BINS = 64  # upper bound on SAH bins per axis

ACTION_LEAF = wp.constant(0)  # node becomes a leaf
ACTION_BINNED = wp.constant(1)  # split at a bin boundary on one axis
ACTION_HALVE = wp.constant(2)  # split the slot range in half (depth guarantee, coincident centroids)


class Builder(enum.Enum):
    """Builder names shared by wrt and Warp's ``wp.Mesh(bvh_constructor=...)`` where they mean the same thing."""

    SAH = "sah"  # binned SAH ("binned_sah" is an alias)
    MIDDLE = "middle"  # spatial median of the centroid bounds on the widest axis

    @classmethod
    def from_str(cls, name: str) -> Builder:
        """Parses a builder name; raises ``ValueError`` listing the valid names."""
        key = {"binned_sah": "sah"}.get(str(name).lower(), str(name).lower())
        for b in cls:
            if b.value == key:
                return b
        valid = ", ".join([b.value for b in cls] + ["binned_sah"])
        raise ValueError(f"unknown BVH builder {name!r}; valid builders: {valid}")


@wp.func
def ceil_log2(n: int):
    """Smallest ``k`` with ``2**k >= n`` (0 for ``n <= 1``)."""
    k = int(0)
    while (1 << k) < n:
        k += 1
    return k


@wp.func
def half_area(lower: wp.vec3, upper: wp.vec3):
    """Half the surface area of a box; 0 for an empty (inverted) box."""
    d = wp.max(upper - lower, wp.vec3(0.0))
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0]


@wp.func
def bin_of(c: wp.vec3, c_lower: wp.vec3, c_upper: wp.vec3, axis: int, bins: int):
    """Bin of centroid ``c`` along ``axis``; both the binning and the partition kernels call this, so they agree."""
    extent = c_upper[axis] - c_lower[axis]
    b = int(0)
    if extent > 0.0:
        b = int((c[axis] - c_lower[axis]) * (float(bins) / extent))
    return wp.clamp(b, 0, bins - 1)


@wp.kernel
def compute_prim_bounds_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    # outputs
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
):
    """Bounds and bounds-centre of every triangle."""
    i = wp.tid()
    a = points[indices[i, 0]]
    b = points[indices[i, 1]]
    c = points[indices[i, 2]]
    lo = wp.min(wp.min(a, b), c)
    hi = wp.max(wp.max(a, b), c)
    prim_lowers[i] = lo
    prim_uppers[i] = hi
    centroids[i] = 0.5 * (lo + hi)


@wp.kernel
def begin_level_kernel(
    active: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    max_bins: int,
    # outputs
    node_lowers: wp.array[wp.vec3],
    node_uppers: wp.array[wp.vec3],
    node_active: wp.array[wp.int32],
    act_c_lowers: wp.array[wp.vec3],
    act_c_uppers: wp.array[wp.vec3],
    act_bins: wp.array[wp.int32],
    act_bin_slots: wp.array[wp.int32],
):
    """Resets the per-level state of each active node and sizes its bins."""
    k = wp.tid()
    n = active[k]
    node_active[n] = k
    big = wp.vec3(wp.inf)
    node_lowers[n] = big
    node_uppers[n] = -big
    act_c_lowers[k] = big
    act_c_uppers[k] = -big
    bins = wp.min(max_bins, node_counts[n])
    act_bins[k] = bins
    act_bin_slots[k] = 3 * bins


@wp.kernel
def reduce_node_bounds_kernel(
    slot_prims: wp.array[wp.int32],
    slot_owner: wp.array[wp.int32],
    node_active: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
    # outputs
    node_lowers: wp.array[wp.vec3],
    node_uppers: wp.array[wp.vec3],
    act_c_lowers: wp.array[wp.vec3],
    act_c_uppers: wp.array[wp.vec3],
):
    """Grows each active node's box and centroid box by the primitives in its slots."""
    i = wp.tid()
    n = slot_owner[i]
    k = node_active[n]
    if k < 0:
        return
    p = slot_prims[i]
    wp.atomic_min(node_lowers, n, prim_lowers[p])
    wp.atomic_max(node_uppers, n, prim_uppers[p])
    wp.atomic_min(act_c_lowers, k, centroids[p])
    wp.atomic_max(act_c_uppers, k, centroids[p])


@wp.kernel
def reset_bins_kernel(
    # outputs
    bin_counts: wp.array[wp.int32],
    bin_lowers: wp.array[wp.vec3],
    bin_uppers: wp.array[wp.vec3],
):
    """Empties the bins used by this level."""
    b = wp.tid()
    bin_counts[b] = 0
    bin_lowers[b] = wp.vec3(wp.inf)
    bin_uppers[b] = wp.vec3(-wp.inf)


@wp.kernel
def bin_prims_kernel(
    slot_prims: wp.array[wp.int32],
    slot_owner: wp.array[wp.int32],
    node_active: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
    act_c_lowers: wp.array[wp.vec3],
    act_c_uppers: wp.array[wp.vec3],
    act_bins: wp.array[wp.int32],
    act_bin_offsets: wp.array[wp.int32],
    # outputs
    bin_counts: wp.array[wp.int32],
    bin_lowers: wp.array[wp.vec3],
    bin_uppers: wp.array[wp.vec3],
):
    """Counts and bounds every primitive into its bin on each axis."""
    i = wp.tid()
    n = slot_owner[i]
    k = node_active[n]
    if k < 0:
        return
    p = slot_prims[i]
    bins = act_bins[k]
    for axis in range(3):
        b = act_bin_offsets[k] + axis * bins + bin_of(centroids[p], act_c_lowers[k], act_c_uppers[k], axis, bins)
        wp.atomic_add(bin_counts, b, 1)
        wp.atomic_min(bin_lowers, b, prim_lowers[p])
        wp.atomic_max(bin_uppers, b, prim_uppers[p])


@wp.kernel
def choose_splits_kernel(
    active: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_depths: wp.array[wp.int32],
    node_lowers: wp.array[wp.vec3],
    node_uppers: wp.array[wp.vec3],
    act_c_lowers: wp.array[wp.vec3],
    act_c_uppers: wp.array[wp.vec3],
    act_bins: wp.array[wp.int32],
    act_bin_offsets: wp.array[wp.int32],
    bin_counts: wp.array[wp.int32],
    bin_lowers: wp.array[wp.vec3],
    bin_uppers: wp.array[wp.vec3],
    use_sah: int,
    max_leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    max_depth: int,
    # outputs
    act_actions: wp.array[wp.int32],
    act_axes: wp.array[wp.int32],
    act_split_bins: wp.array[wp.int32],
):
    """Chooses leaf, SAH split or halving for each active node."""
    k = wp.tid()
    n = active[k]
    count = node_counts[n]
    depth = node_depths[n]
    bins = act_bins[k]
    base = act_bin_offsets[k]

    # Find the best bin-boundary split: SAH cost over three axes, or the middle of the widest axis.
    best_cost = float(wp.inf)
    best_axis = int(-1)
    best_split = int(0)
    best_left = int(0)
    extent = act_c_uppers[k] - act_c_lowers[k]
    widest = int(0)
    if extent[1] > extent[widest]:
        widest = 1
    if extent[2] > extent[widest]:
        widest = 2
    right_areas = wp.zeros(shape=MAX_BINS, dtype=float)
    right_counts = wp.zeros(shape=MAX_BINS, dtype=wp.int32)
    for axis in range(3):
        if extent[axis] > 0.0 and (use_sah == 1 or axis == widest):
            # Sweep from the right, keeping the area and count of bins [s, bins) for every split s.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            c = int(0)
            for s in range(bins - 1, 0, -1):
                b = base + axis * bins + s
                lo = wp.min(lo, bin_lowers[b])
                hi = wp.max(hi, bin_uppers[b])
                c += bin_counts[b]
                right_areas[s] = half_area(lo, hi)
                right_counts[s] = c
            # Sweep from the left and evaluate each split s: bins [0, s) left, [s, bins) right.
            lo = wp.vec3(wp.inf)
            hi = wp.vec3(-wp.inf)
            c = int(0)
            for s in range(1, bins):
                b = base + axis * bins + s - 1
                lo = wp.min(lo, bin_lowers[b])
                hi = wp.max(hi, bin_uppers[b])
                c += bin_counts[b]
                if c > 0 and right_counts[s] > 0:
                    cost = float(0.0)
                    if use_sah == 1:
                        cost = half_area(lo, hi) * float(c) + right_areas[s] * float(right_counts[s])
                    else:
                        # Spatial median: the split nearest the middle bin boundary wins.
                        cost = wp.abs(float(2 * s - bins))
                    if cost < best_cost:
                        best_cost = cost
                        best_axis = axis
                        best_split = s
                        best_left = c

    # Decide between leaf, the split found, and halving.
    area = half_area(node_lowers[n], node_uppers[n])
    leaf_ok = count <= max_leaf_size
    if use_sah == 1 and leaf_ok and best_axis >= 0 and area > 0.0:
        # SAH leaf termination: split only when it is expected to be cheaper than testing every triangle.
        leaf_ok = intersection_cost * float(count) <= traversal_cost + intersection_cost * best_cost / area
    action = ACTION_HALVE
    if count <= 1 or leaf_ok:
        action = ACTION_LEAF
    elif best_axis >= 0 and depth + 1 + ceil_log2(wp.max(best_left, count - best_left)) <= max_depth - 1:
        action = ACTION_BINNED
    act_actions[k] = action
    act_axes[k] = best_axis
    act_split_bins[k] = best_split


@wp.kernel
def flag_left_kernel(
    slot_prims: wp.array[wp.int32],
    slot_owner: wp.array[wp.int32],
    node_active: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    centroids: wp.array[wp.vec3],
    act_c_lowers: wp.array[wp.vec3],
    act_c_uppers: wp.array[wp.vec3],
    act_bins: wp.array[wp.int32],
    act_actions: wp.array[wp.int32],
    act_axes: wp.array[wp.int32],
    act_split_bins: wp.array[wp.int32],
    # outputs
    goes_left: wp.array[wp.int32],
):
    """1 for every slot that moves to the left child of a node split at this level, else 0."""
    i = wp.tid()
    n = slot_owner[i]
    k = node_active[n]
    flag = int(0)
    if k >= 0:
        action = act_actions[k]
        if action == ACTION_BINNED:
            b = bin_of(centroids[slot_prims[i]], act_c_lowers[k], act_c_uppers[k], act_axes[k], act_bins[k])
            if b < act_split_bins[k]:
                flag = 1
        elif action == ACTION_HALVE:
            if i - node_starts[n] < node_counts[n] / 2:
                flag = 1
    goes_left[i] = flag


@wp.kernel
def make_children_kernel(
    active: wp.array[wp.int32],
    act_actions: wp.array[wp.int32],
    split_ranks: wp.array[wp.int32],
    left_ranks: wp.array[wp.int32],
    goes_left: wp.array[wp.int32],
    first_free: int,
    # outputs
    node_starts: wp.array[wp.int32],
    node_counts: wp.array[wp.int32],
    node_depths: wp.array[wp.int32],
    node_lefts: wp.array[wp.int32],
    next_active: wp.array[wp.int32],
):
    """Allocates the two children of each split node side by side and queues them for the next level."""
    k = wp.tid()
    if act_actions[k] == ACTION_LEAF:
        return
    n = active[k]
    start = node_starts[n]
    end = start + node_counts[n]
    # Inclusive scan: left slots in [start, end) = scan[end - 1] - scan[start] + flag[start].
    n_left = left_ranks[end - 1] - left_ranks[start] + goes_left[start]
    child = first_free + 2 * split_ranks[k]
    node_lefts[n] = child
    node_starts[child] = start
    node_counts[child] = n_left
    node_starts[child + 1] = start + n_left
    node_counts[child + 1] = node_counts[n] - n_left
    node_depths[child] = node_depths[n] + 1
    node_depths[child + 1] = node_depths[n] + 1
    next_active[2 * split_ranks[k]] = child
    next_active[2 * split_ranks[k] + 1] = child + 1


@wp.kernel
def partition_slots_kernel(
    slot_prims: wp.array[wp.int32],
    slot_owner: wp.array[wp.int32],
    node_active: wp.array[wp.int32],
    node_starts: wp.array[wp.int32],
    node_lefts: wp.array[wp.int32],
    goes_left: wp.array[wp.int32],
    left_ranks: wp.array[wp.int32],
    # outputs
    new_slot_prims: wp.array[wp.int32],
    new_slot_owner: wp.array[wp.int32],
):
    """Stable partition of every split node's slots into its two children."""
    i = wp.tid()
    n = slot_owner[i]
    pos = i
    owner = n
    if node_active[n] >= 0 and node_lefts[n] >= 0:
        start = node_starts[n]
        left = node_lefts[n]
        lefts_before = left_ranks[i] - goes_left[i] - (left_ranks[start] - goes_left[start])
        if goes_left[i] == 1:
            pos = start + lefts_before
            owner = left
        else:
            pos = node_starts[left + 1] + (i - start - lefts_before)
            owner = left + 1
    new_slot_prims[pos] = slot_prims[i]
    new_slot_owner[pos] = owner


@wp.kernel
def end_level_kernel(
    active: wp.array[wp.int32],
    # outputs
    node_active: wp.array[wp.int32],
):
    """Marks this level's nodes as done."""
    node_active[active[wp.tid()]] = -1


@wp.kernel
def flag_splits_kernel(
    act_actions: wp.array[wp.int32],
    # outputs
    split_flags: wp.array[wp.int32],
):
    """1 for every active node that splits."""
    k = wp.tid()
    split_flags[k] = wp.where(act_actions[k] == ACTION_LEAF, 0, 1)


def build_bvh(
    points,
    indices,
    builder: str = "sah",
    *,
    leaf_size: int = 8,
    bins: int = 16,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    device=None,
) -> FlatBvh:
    """Builds a BVH over triangles and returns it in the canonical flat layout.

    Args:
        points: ``(V, 3)`` float32 vertex positions, numpy or ``wp.array``.
        indices: ``(T, 3)`` int32 triangle vertex indices, numpy or ``wp.array``.
        builder: a :class:`Builder` name (``"sah"``/``"binned_sah"``, ``"middle"``).
        leaf_size: most triangles in a leaf; SAH may stop earlier when splitting does not pay.
        bins: SAH bins per axis (at most ``MAX_BINS``).
        traversal_cost: SAH cost of visiting a node, relative to ``intersection_cost``.
        intersection_cost: SAH cost of one ray-triangle test.
        device: Warp device to build on; the default device when ``None``.

    Returns:
        The :class:`FlatBvh` on the host, with ``build_seconds`` set.
    """
    kind = Builder.from_str(builder)
    if not 1 <= int(leaf_size) <= 1 << 16:
        raise ValueError(f"leaf_size must lie in [1, 65536], got {leaf_size}")
    if not 2 <= int(bins) <= MAX_BINS:
        raise ValueError(f"bins must lie in [2, {MAX_BINS}], got {bins}")
    device = wp.get_device(device)
    start_time = time.perf_counter()
    points_np = np.asarray(points.numpy() if isinstance(points, wp.array) else points, dtype=np.float32)
    indices_np = np.asarray(indices.numpy() if isinstance(indices, wp.array) else indices, dtype=np.int32)
    points_np = points_np.reshape(-1, 3)
    indices_np = indices_np.reshape(-1, 3)
    num_prims = len(indices_np)
    if num_prims == 0:
        return FlatBvh.empty()
    if num_prims >= 1 << 30:
        raise ValueError(f"too many triangles for one BVH: {num_prims}")
    if indices_np.min() < 0 or indices_np.max() >= len(points_np):
        raise ValueError(f"triangle indices must lie in [0, {len(points_np)})")
    if not np.all(np.isfinite(points_np[np.unique(indices_np)])):
        raise ValueError("triangle vertices must be finite (found NaN or inf)")

    with wp.ScopedDevice(device):
        pts = wp.array(points_np, dtype=wp.vec3)
        idx = wp.array(indices_np, dtype=wp.int32)
        prim_lowers = wp.empty(num_prims, dtype=wp.vec3)
        prim_uppers = wp.empty(num_prims, dtype=wp.vec3)
        centroids = wp.empty(num_prims, dtype=wp.vec3)
        wp.launch(compute_prim_bounds_kernel, num_prims, inputs=[pts, idx], outputs=[prim_lowers, prim_uppers, centroids])

        capacity = 2 * num_prims - 1
        node_lowers = wp.empty(capacity, dtype=wp.vec3)
        node_uppers = wp.empty(capacity, dtype=wp.vec3)
        node_starts = wp.zeros(capacity, dtype=wp.int32)
        node_counts = wp.zeros(capacity, dtype=wp.int32)
        node_depths = wp.zeros(capacity, dtype=wp.int32)
        node_lefts = wp.full(capacity, -1, dtype=wp.int32)
        node_active = wp.full(capacity, -1, dtype=wp.int32)
        node_counts.fill_(num_prims)  # only the root's count matters; the others are written when allocated

        slot_prims = wp.array(np.arange(num_prims, dtype=np.int32))
        slot_owner = wp.zeros(num_prims, dtype=wp.int32)
        new_slot_prims = wp.empty_like(slot_prims)
        new_slot_owner = wp.empty_like(slot_owner)
        goes_left = wp.empty(num_prims, dtype=wp.int32)
        left_ranks = wp.empty(num_prims, dtype=wp.int32)
        bin_counts = wp.empty(3 * num_prims, dtype=wp.int32)
        bin_lowers = wp.empty(3 * num_prims, dtype=wp.vec3)
        bin_uppers = wp.empty(3 * num_prims, dtype=wp.vec3)

        # Per-level arrays: a level never holds more than num_prims nodes.
        active = wp.zeros(num_prims, dtype=wp.int32)
        next_active = wp.empty(num_prims, dtype=wp.int32)
        act_c_lowers = wp.empty(num_prims, dtype=wp.vec3)
        act_c_uppers = wp.empty(num_prims, dtype=wp.vec3)
        act_bins = wp.empty(num_prims, dtype=wp.int32)
        act_bin_slots = wp.empty(num_prims, dtype=wp.int32)
        act_bin_offsets = wp.empty(num_prims, dtype=wp.int32)
        act_actions = wp.empty(num_prims, dtype=wp.int32)
        act_axes = wp.empty(num_prims, dtype=wp.int32)
        act_split_bins = wp.empty(num_prims, dtype=wp.int32)
        split_flags = wp.empty(num_prims, dtype=wp.int32)
        split_ranks = wp.empty(num_prims, dtype=wp.int32)

        use_sah = 1 if kind == Builder.SAH else 0
        level_bins = int(bins) if use_sah else 2
        num_active, num_nodes = 1, 1
        while num_active > 0:
            k = num_active
            wp.launch(
                begin_level_kernel,
                k,
                inputs=[active, node_counts, level_bins],
                outputs=[node_lowers, node_uppers, node_active, act_c_lowers, act_c_uppers, act_bins, act_bin_slots],
            )
            wp.utils.array_scan(act_bin_slots[:k], act_bin_offsets[:k], inclusive=False)
            wp.launch(
                reduce_node_bounds_kernel,
                num_prims,
                inputs=[slot_prims, slot_owner, node_active, prim_lowers, prim_uppers, centroids],
                outputs=[node_lowers, node_uppers, act_c_lowers, act_c_uppers],
            )
            total_bins = int(act_bin_offsets[k - 1 : k].numpy()[0] + act_bin_slots[k - 1 : k].numpy()[0])
            wp.launch(reset_bins_kernel, total_bins, outputs=[bin_counts, bin_lowers, bin_uppers])
            wp.launch(
                bin_prims_kernel,
                num_prims,
                inputs=[slot_prims, slot_owner, node_active, prim_lowers, prim_uppers, centroids]
                + [act_c_lowers, act_c_uppers, act_bins, act_bin_offsets],
                outputs=[bin_counts, bin_lowers, bin_uppers],
            )
            wp.launch(
                choose_splits_kernel,
                k,
                inputs=[active, node_counts, node_depths, node_lowers, node_uppers, act_c_lowers, act_c_uppers]
                + [act_bins, act_bin_offsets, bin_counts, bin_lowers, bin_uppers, use_sah, int(leaf_size)]
                + [float(traversal_cost), float(intersection_cost), MAX_DEPTH],
                outputs=[act_actions, act_axes, act_split_bins],
            )
            wp.launch(
                flag_left_kernel,
                num_prims,
                inputs=[slot_prims, slot_owner, node_active, node_starts, node_counts, centroids]
                + [act_c_lowers, act_c_uppers, act_bins, act_actions, act_axes, act_split_bins],
                outputs=[goes_left],
            )
            wp.utils.array_scan(goes_left, left_ranks, inclusive=True)
            wp.launch(flag_splits_kernel, k, inputs=[act_actions], outputs=[split_flags])
            wp.utils.array_scan(split_flags[:k], split_ranks[:k], inclusive=False)
            num_splits = int(split_ranks[k - 1 : k].numpy()[0] + split_flags[k - 1 : k].numpy()[0])
            wp.launch(
                make_children_kernel,
                k,
                inputs=[active, act_actions, split_ranks, left_ranks, goes_left, num_nodes],
                outputs=[node_starts, node_counts, node_depths, node_lefts, next_active],
            )
            wp.launch(
                partition_slots_kernel,
                num_prims,
                inputs=[slot_prims, slot_owner, node_active, node_starts, node_lefts, goes_left, left_ranks],
                outputs=[new_slot_prims, new_slot_owner],
            )
            wp.launch(end_level_kernel, k, inputs=[active], outputs=[node_active])
            slot_prims, new_slot_prims = new_slot_prims, slot_prims
            slot_owner, new_slot_owner = new_slot_owner, slot_owner
            active, next_active = next_active, active
            num_nodes += 2 * num_splits
            num_active = 2 * num_splits

        m = num_nodes
        lefts = node_lefts.numpy()[:m]
        counts = node_counts.numpy()[:m]
        is_leaf = lefts < 0
        bvh = FlatBvh(
            lowers=node_lowers.numpy()[:m],
            uppers=node_uppers.numpy()[:m],
            left_first=np.where(is_leaf, node_starts.numpy()[:m], lefts).astype(np.int32),
            prim_count=np.where(is_leaf, counts, 0).astype(np.int32),
            prim_ids=slot_prims.numpy(),
            builder=kind.value,
            build_seconds=time.perf_counter() - start_time,
        )
    return bvh
