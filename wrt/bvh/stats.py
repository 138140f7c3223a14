"""Quality and size statistics of a FlatBvh: SAH cost, end-point overlap (EPO), node and leaf counts, depths, the
leaf-size histogram and bytes.

SAH cost (Goldsmith and Salmon 1987, MacDonald and Booth 1990), with the traversal and intersection constants
``C_t`` and ``C_i`` stated by the caller::

    SAH = ( C_t * sum_{inner n} A(n) + C_i * sum_{leaf l} N(l) A(l) ) / A(root)

EPO (Aila, Karras and Laine, "On Quality Metrics of Bounding Volume Hierarchies", HPG 2013) is the surface area
of geometry that lies inside a node's box but not in the node's subtree, weighted like the SAH terms::

    EPO = sum_n C(n) * A({surface not below n} inside box(n)) / A(surface),  C(n) = C_t (inner) or C_i N(n) (leaf)

It is estimated here by Monte Carlo: points sampled uniformly by area on the triangles are located in the tree
with a point query (a Warp kernel), and every node that contains a sample from outside its own subtree adds
``C(n)`` to that sample; the mean over samples is the estimate (standard error reported as ``epo_stderr``).
Subtrees must cover contiguous slot ranges, which every wrt builder and ``read_warp_bvh`` guarantee.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..options import EPO_SAMPLES
from ..options import MAX_EPO_SAMPLES as MAX_EPO_SAMPLES  # re-exported: see wrt.options
from .common import MAX_DEPTH

wp.set_module_options({"enable_backward": False})

NODE_BYTES = 32  # canonical node: lower (12) + upper (12) + left_first (4) + prim_count (4)


@wp.kernel
def epo_samples_kernel(
    lowers: wp.array[wp.vec3d],
    uppers: wp.array[wp.vec3d],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    range_lo: wp.array[wp.int32],
    range_hi: wp.array[wp.int32],
    node_cost: wp.array[float],
    points: wp.array[wp.vec3d],
    slots: wp.array[wp.int32],
    # outputs
    sums: wp.array[float],
):
    """For sample ``i`` at ``points[i]`` on the triangle in slot ``slots[i]``: the summed cost of the nodes whose
    (closed) boxes contain the point but whose subtrees do not hold that triangle.

    Points and boxes are float64: a point rounded to float32 far from the origin (1e6, where float32 steps by 1/16)
    lands on box faces, shared by touching boxes, a measurable part of the time, and was counted in both."""
    i = wp.tid()
    p = points[i]
    s = slots[i]
    stack = wp.zeros(shape=MAX_DEPTH, dtype=wp.int32)
    top = int(0)
    total = float(0.0)
    node = int(-1)
    if wp.min(p - lowers[0]) >= wp.float64(0.0) and wp.min(uppers[0] - p) >= wp.float64(0.0):
        node = 0
    while node >= 0:
        if s < range_lo[node] or s >= range_hi[node]:
            total += node_cost[node]
        next_node = int(-1)
        if prim_count[node] == 0:
            # Visit every child whose box holds the point: go to the first, push the second.
            for j in range(2):
                c = left_first[node] + j
                if wp.min(p - lowers[c]) >= wp.float64(0.0) and wp.min(uppers[c] - p) >= wp.float64(0.0):
                    if next_node < 0:
                        next_node = c
                    else:
                        stack[top] = c
                        top += 1
        node = next_node
        if node < 0 and top > 0:
            top -= 1
            node = stack[top]
    sums[i] = total


def subtree_ranges(bvh) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)``: the slot range ``[lo, hi)`` below every node, bottom-up over the levels."""
    m = bvh.num_nodes
    leaf = bvh.prim_count > 0
    lo = np.where(leaf, bvh.left_first, np.iinfo(np.int32).max).astype(np.int64)
    hi = np.where(leaf, bvh.left_first + bvh.prim_count, -1).astype(np.int64)
    depth = bvh.depths()
    inner = np.flatnonzero(~leaf)
    for d in range(int(depth.max()), -1, -1):
        nodes = inner[depth[inner] == d]
        c = bvh.left_first[nodes]
        lo[nodes] = np.minimum(lo[c], lo[c + 1])
        hi[nodes] = np.maximum(hi[c], hi[c + 1])
    assert m == len(lo)
    return lo, hi


def half_areas(lowers: np.ndarray, uppers: np.ndarray) -> np.ndarray:
    """Half surface area of each box (float64), 0 for inverted boxes; boxes along the last axis of ``(..., 3)``."""
    d = np.maximum(np.asarray(uppers, np.float64) - np.asarray(lowers, np.float64), 0.0)
    return d[..., 0] * d[..., 1] + d[..., 1] * d[..., 2] + d[..., 2] * d[..., 0]


def sah_cost(bvh, traversal_cost: float = 1.0, intersection_cost: float = 1.0) -> float:
    """SAH cost of the tree (see module docstring); 0 for an empty tree or a root of zero area."""
    if bvh.num_prims == 0:
        return 0.0
    areas = half_areas(bvh.lowers, bvh.uppers)
    if areas[0] <= 0.0:
        return 0.0
    leaf = bvh.prim_count > 0
    total = traversal_cost * areas[~leaf].sum() + intersection_cost * (areas[leaf] * bvh.prim_count[leaf]).sum()
    return float(total / areas[0])


def epo(
    bvh,
    points,
    indices,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    samples: int = EPO_SAMPLES,
    seed: int = 0,
    device="cpu",
) -> tuple[float, float]:
    """Monte-Carlo EPO estimate and its standard error (see module docstring); ``nan`` for zero surface area."""
    points = np.asarray(points, np.float32).reshape(-1, 3)
    indices = np.asarray(indices, np.int64).reshape(-1, 3)
    if bvh.num_prims == 0:
        return 0.0, 0.0
    if bvh.num_prims != len(indices):
        raise ValueError(f"EPO needs one slot per triangle: this tree has {bvh.num_prims} slots for {len(indices)} "
                         "triangles (built with presplit); pass epo_samples=0 for the other statistics")
    tri = points[indices].astype(np.float64)
    tri_areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total_area = tri_areas.sum()
    if not total_area > 0.0 or not np.isfinite(total_area):
        return float("nan"), float("nan")
    # Sample triangles by area, then a uniform point on each.
    rng = np.random.default_rng(seed)
    cdf = np.cumsum(tri_areas)
    ids = np.minimum(np.searchsorted(cdf, rng.random(samples) * cdf[-1], side="right"), len(cdf) - 1)
    r1, r2 = rng.random(samples), rng.random(samples)
    su = np.sqrt(r1)
    w = np.stack([1.0 - su, su * (1.0 - r2), su * r2], 1)
    corners = tri[ids]
    sample_points = np.einsum("sk,skd->sd", w, corners)  # float64, see epo_samples_kernel
    # Clamp onto the triangle's box, which float rounding of the interpolation might leave.
    np.clip(sample_points, corners.min(1), corners.max(1), out=sample_points)
    del corners
    slot_of = np.empty(bvh.num_prims, np.int32)
    slot_of[bvh.prim_ids] = np.arange(bvh.num_prims, dtype=np.int32)
    lo, hi = subtree_ranges(bvh)
    if np.any(hi - lo != subtree_counts(bvh, lo, hi)):
        raise ValueError("EPO needs subtrees over contiguous slot ranges")
    leaf = bvh.prim_count > 0
    node_cost = np.where(leaf, intersection_cost * bvh.prim_count, traversal_cost).astype(np.float32)
    dev = wp.get_device(device)
    sums = wp.empty(samples, dtype=float, device=dev)
    wp.launch(
        epo_samples_kernel,
        samples,
        inputs=[
            wp.array(bvh.lowers.astype(np.float64), dtype=wp.vec3d, device=dev),  # exact: float32 values
            wp.array(bvh.uppers.astype(np.float64), dtype=wp.vec3d, device=dev),
            wp.array(bvh.left_first, dtype=wp.int32, device=dev),
            wp.array(bvh.prim_count, dtype=wp.int32, device=dev),
            wp.array(lo.astype(np.int32), dtype=wp.int32, device=dev),
            wp.array(hi.astype(np.int32), dtype=wp.int32, device=dev),
            wp.array(node_cost, dtype=float, device=dev),
            wp.array(sample_points, dtype=wp.vec3d, device=dev),
            wp.array(slot_of[ids], dtype=wp.int32, device=dev),
        ],
        outputs=[sums],
        device=dev,
    )
    values = sums.numpy().astype(np.float64)
    return float(values.mean()), float(values.std() / np.sqrt(samples))


def subtree_counts(bvh, lo, hi) -> np.ndarray:
    """Triangles below every node (bottom-up sum of leaf counts)."""
    leaf = bvh.prim_count > 0
    counts = np.where(leaf, bvh.prim_count, 0).astype(np.int64)
    depth = bvh.depths()
    inner = np.flatnonzero(~leaf)
    for d in range(int(depth.max()), -1, -1):
        nodes = inner[depth[inner] == d]
        c = bvh.left_first[nodes]
        counts[nodes] = counts[c] + counts[c + 1]
    return counts


def bvh_stats(
    bvh,
    points=None,
    indices=None,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    epo_samples: int = EPO_SAMPLES,
    device="cpu",
) -> dict:
    """Every statistic of :meth:`FlatBvh.stats` as a dict (EPO only when the triangles are given)."""
    leaf = bvh.prim_count > 0
    depth = bvh.depths()
    sizes, counts = np.unique(bvh.prim_count[leaf], return_counts=True)
    node_bytes = NODE_BYTES * bvh.num_nodes
    stats = {
        "builder": bvh.builder,
        "triangles": int(bvh.num_triangles),
        "slots": int(bvh.num_prims),
        "nodes": int(bvh.num_nodes),
        "inner_nodes": int(bvh.num_nodes - leaf.sum()),
        "leaves": int(leaf.sum()),
        "max_depth": int(depth.max()) if bvh.num_prims else 0,
        "mean_leaf_depth": float(depth[leaf].mean()) if leaf.any() else 0.0,
        "mean_prim_depth": float((depth[leaf] * bvh.prim_count[leaf]).sum() / max(bvh.num_prims, 1)),
        "mean_leaf_size": float(bvh.prim_count[leaf].mean()) if leaf.any() else 0.0,
        "leaf_size_histogram": {int(s): int(c) for s, c in zip(sizes, counts)},
        "traversal_cost": float(traversal_cost),
        "intersection_cost": float(intersection_cost),
        "sah_cost": sah_cost(bvh, traversal_cost, intersection_cost),
        "epo": None,
        "epo_stderr": None,
        "node_bytes": int(node_bytes),
        "bytes": int(node_bytes + 4 * bvh.num_prims),  # nodes + slot -> triangle ids
        "build_seconds": float(bvh.build_seconds),
    }
    if points is not None and indices is not None and epo_samples > 0:
        stats["epo"], stats["epo_stderr"] = epo(
            bvh, points, indices, traversal_cost, intersection_cost, epo_samples, device=device
        )
    return stats
