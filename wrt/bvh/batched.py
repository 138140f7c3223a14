"""Many small binned trees (``sah``, ``middle``) built in one pass on a CPU device: one tree per mesh, each the
tree :func:`wrt.bvh.build_bvh` builds over that mesh alone, node for node and bit for bit.

A scene of thousands of small prototypes (robot links, URDF imports) spent about 2 ms per prototype building its
BLAS, nearly all of it a dozen launches and their allocations, whatever the tree's size. A tree of at most
``SUBTREE_SIZE`` triangles is built by ``build_binned`` as one pending root whose whole subtree one thread of
``split_nodes_kernel`` builds depth first from the node after the root. Here every mesh's root is such a pending
node of one shared build: the same kernels, the same per-node code and the same slot rows (depth 0 reads row 0),
so each subtree comes out as it would alone; only the node and slot numbers are offset, and are shifted back.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from .binned import (
    NO_PARALLEL,
    SUBTREE_SIZE,
    BinnedBuild,
    SlotBox,
    allocate_scratch,
    finish_nodes_kernel,
    init_slots_kernel,
    relocate_subtrees_kernel,
    run_split,
    split_nodes_kernel,
)
from .common import MAX_DEPTH, BuildInput
from .layout import FlatBvh
from .unit_scale import size_exponent

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile

BATCH_MAX_TRIANGLES = SUBTREE_SIZE  # meshes above this are built alone (their root is split in the level phase)
# Most triangles in one pass: a pass holds about 350 bytes per triangle of node and slot scratch, and one pass over
# all of teapot_scene_1000's 133 prototypes (329k triangles) raised the build's peak memory by 113 MB where building
# them one by one took next to none; a pass costs a dozen launches, so 64k-triangle passes keep the speed.
BATCH_PASS_TRIANGLES = 1 << 16


@wp.kernel
def segment_bounds_kernel(
    firsts: wp.array[wp.int32],
    counts: wp.array[wp.int32],
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
    # outputs
    bounds: wp.array[wp.vec3],
):
    """Root box and centroid box of segment ``k``, folded with the atomics of ``reduce_bounds_kernel`` in its
    order (a CPU launch runs its threads in turn), so the bits match a build of the segment alone."""
    k = wp.tid()
    for i in range(firsts[k], firsts[k] + counts[k]):
        wp.atomic_min(bounds, 4 * k, prim_lowers[i])
        wp.atomic_max(bounds, 4 * k + 1, prim_uppers[i])
        wp.atomic_min(bounds, 4 * k + 2, centroids[i])
        wp.atomic_max(bounds, 4 * k + 3, centroids[i])


def batchable(points, indices) -> bool:
    """Whether one mesh may join a batch: numpy ``(V, 3)`` float32 points and ``(T, 3)`` integer indices (anything
    else is left to ``build_bvh``'s conversions and messages), 1 to ``BATCH_MAX_TRIANGLES`` triangles, every index
    inside its own points (concatenated, an index past its mesh would silently reach the next mesh's points)."""
    if not (isinstance(points, np.ndarray) and isinstance(indices, np.ndarray)) or points.dtype != np.float32:
        return False
    if points.ndim != 2 or points.shape[1] != 3 or indices.ndim != 2 or indices.shape[1] != 3:
        return False
    n = len(indices)
    # A mesh past 2**32 (or under 2**-32) is built alone, at unit size (unit_scale.py): the batch's float32 areas
    # overflowed there and its SAH trees cost 4x those of the same mesh at unit size. Read from the coordinates its
    # triangles use, as build_bvh's unit_exponent reads them (from their boxes): an unused inf or NaN point (the
    # build allows it) hid a 2**70 mesh's size and it joined the batch (SAH cost 104.7 against 25.6 alone).
    return (indices.dtype.kind in "iu" and 0 < n <= BATCH_MAX_TRIANGLES and int(indices.min()) >= 0
            and int(indices.max()) < len(points) and not size_exponent(float(np.abs(points[indices]).max())))


def batch_groups(counts: list[int], limit: int = BATCH_PASS_TRIANGLES) -> list[list[int]]:
    """Consecutive runs of ``range(len(counts))`` of at most ``limit`` triangles each (``counts[j]``: mesh ``j``'s
    triangles; a mesh above the limit makes a run of its own): the meshes of each pass of the batch."""
    groups, size = [[]], 0
    for j, n in enumerate(counts):
        if groups[-1] and size + n > limit:
            groups.append([])
            size = 0
        groups[-1].append(j)
        size += n
    return [g for g in groups if g]


def build_binned_batch(
    meshes: list[tuple[np.ndarray, np.ndarray]],
    *,
    use_sah: bool,
    leaf_size: int,
    bins: int,
    traversal_cost: float,
    intersection_cost: float,
    builder: str,
    threads: int = 1,
) -> list[FlatBvh]:
    """The host tree of each ``(points, indices)`` mesh (each :func:`batchable`), on the CPU; options as
    ``build_binned``'s. Each tree's ``build_seconds`` is its share of the batch's time, by triangle count
    (:func:`wrt.bvh.build.build_bvhs` sets it anew over all of its passes).

    Raises:
        ValueError: as :class:`BuildInput` for non-finite vertices (naming a row of the concatenated triangles).
    """
    start_time = time.perf_counter()
    counts = np.array([len(i) for _, i in meshes], np.int64)
    firsts = np.concatenate([[0], np.cumsum(counts)])
    v_firsts = np.concatenate([[0], np.cumsum([len(p) for p, _ in meshes])])
    points = np.concatenate([np.asarray(p, np.float32).reshape(-1, 3) for p, _ in meshes])
    indices = np.concatenate([np.asarray(i, np.int64).reshape(-1, 3) + v for (_, i), v in zip(meshes, v_firsts)])
    data = BuildInput(points, indices.astype(np.int32), "cpu")
    n, k = data.num_prims, len(meshes)
    with wp.ScopedDevice(data.device):
        firsts_d = wp.array(firsts[:-1], dtype=wp.int32)
        counts_d = wp.array(counts, dtype=wp.int32)
        big = np.full(3, np.inf, np.float32)
        bounds = wp.array(np.tile(np.stack([big, -big, big, -big]), (k, 1)), dtype=wp.vec3)
        wp.launch(segment_bounds_kernel, k, inputs=[firsts_d, counts_d, data.prim_lowers, data.prim_uppers,
                                                    data.centroids], outputs=[bounds])
        roots = bounds.numpy().reshape(k, 4, 3)  # (k, 4, 3): lower, upper, centroid lower, centroid upper

        # Nodes 0..k-1 are the roots; subtree j is numbered from reserved[j], as build_binned reserves 2 (n - 1).
        reserved = k + np.concatenate([[0], np.cumsum(2 * (counts - 1))])[:-1]
        capacity = k + int(np.sum(2 * (counts - 1)))
        st = BinnedBuild()
        node_starts = np.zeros(capacity, np.int32)
        node_starts[:k] = firsts[:-1]
        node_counts = np.zeros(capacity, np.int32)
        node_counts[:k] = counts
        st.node_starts = wp.array(node_starts, dtype=wp.int32)
        st.node_counts = wp.array(node_counts, dtype=wp.int32)
        st.node_depths = wp.zeros(capacity, dtype=wp.int32)
        st.node_lefts = wp.full(capacity, -1, dtype=wp.int32)
        boxes = [np.zeros((capacity, 3), np.float32) for _ in range(4)]
        for row, box in enumerate(boxes):
            box[:k] = roots[:, row]
        st.node_lowers, st.node_uppers, st.node_c_lowers, st.node_c_uppers = (
            wp.array(b, dtype=wp.vec3) for b in boxes)
        st.slots = wp.empty((2, n), dtype=SlotBox)
        wp.launch(init_slots_kernel, n, inputs=[data.prim_lowers, data.prim_uppers], outputs=[st.slots[0]])
        st.out_prims = wp.empty(n, dtype=wp.int32)
        allocate_scratch(st, k, int(bins))
        st.max_bins = int(bins) if use_sah else 2
        st.use_sah = int(use_sah)
        st.max_leaf_size = int(leaf_size)
        st.traversal_cost = float(traversal_cost)
        st.intersection_cost = float(intersection_cost)
        st.max_depth = MAX_DEPTH
        st.subtree_size = SUBTREE_SIZE
        st.parallel_min = NO_PARALLEL

        pending = wp.array(np.arange(k, dtype=np.int32), dtype=wp.int32)
        reserved_d = wp.array(reserved.astype(np.int32), dtype=wp.int32)
        used = wp.zeros(k, dtype=wp.int32)
        unused = wp.empty(1, dtype=wp.vec3)
        node_pending = wp.empty(1, dtype=wp.int32)

        def build_subtrees(a: int, b: int):
            wp.launch(
                split_nodes_kernel,
                b - a,
                inputs=[st, pending[a:b], reserved_d[a:b], a, 1],
                outputs=[used[a:b], used[a:b], unused, unused, unused, unused, node_pending, used[a:b]],
            )

        pool = ThreadPoolExecutor(threads) if threads > 1 and k > 1 else None
        try:
            run_split(build_subtrees, k, pending, st.node_counts, pool, threads)
        finally:
            if pool is not None:
                pool.shutdown()
        used_np = used.numpy().astype(np.int64)
        used_offsets = np.concatenate([[0], np.cumsum(used_np)])
        total = k + int(used_offsets[-1])
        left_first = wp.empty(total, dtype=wp.int32)
        prim_count = wp.empty(total, dtype=wp.int32)
        lowers = wp.empty(total, dtype=wp.vec3)
        uppers = wp.empty(total, dtype=wp.vec3)
        wp.launch(finish_nodes_kernel, k, inputs=[st], outputs=[left_first, prim_count, lowers, uppers])
        wp.launch(
            relocate_subtrees_kernel,
            k,
            inputs=[st, pending, reserved_d, used, wp.array(used_offsets[:-1].astype(np.int32), dtype=wp.int32), k],
            outputs=[left_first, prim_count, lowers, uppers],
        )
        all_lowers, all_uppers = lowers.numpy(), uppers.numpy()
        all_left, all_count, all_prims = left_first.numpy(), prim_count.numpy(), st.out_prims.numpy()

    trees = []
    for j, (p, i) in enumerate(meshes):
        # Tree j alone: its root is node 0 and its subtree follows from node 1; leaves count slots from 0.
        a, b = k + int(used_offsets[j]), k + int(used_offsets[j + 1])
        nodes = np.concatenate([[j], np.arange(a, b)])
        count = all_count[nodes]
        left = all_left[nodes]
        left = np.where(count == 0, left - a + 1, left - firsts[j]).astype(np.int32)
        first, last = int(firsts[j]), int(firsts[j + 1])
        tree = FlatBvh(
            lowers=all_lowers[nodes],
            uppers=all_uppers[nodes],
            left_first=left,
            prim_count=count,
            prim_ids=(all_prims[first:last] - first).astype(np.int32),
            builder=builder,
        )
        tree.points, tree.indices = p, i
        trees.append(tree)
    seconds = time.perf_counter() - start_time
    for tree in trees:
        tree.build_seconds = seconds * tree.num_prims / n
    return trees

