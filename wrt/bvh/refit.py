"""Refit: the same tree over moved vertices. Deforming meshes keep their topology from frame to frame, so their
BVH keeps its nodes and only the boxes change: every leaf box is recomputed from its triangles and every inner box
from its two children, one launch per tree level, deepest level first (a level only reads the level below it, so
no launch needs atomics or ordering within itself).

A refitted tree is always correct (every box holds its subtree) but its quality decays as triangles move away from
where the builder grouped them; :mod:`wrt.animation` measures its SAH cost and rebuilds when it has grown too much.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .common import check_triangles
from .layout import DeviceBvh, FlatBvh, gather_triangles_kernel, pack_nodes
from .presplit import write_references

wp.set_module_options({"enable_backward": False})


@wp.kernel
def refit_level_kernel(
    level: wp.array[wp.int32],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    v0: wp.array[wp.vec3],
    v1: wp.array[wp.vec3],
    v2: wp.array[wp.vec3],
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
):
    """Box of each node of one level: its triangles' bounds (leaf) or the union of its children's boxes."""
    node = level[wp.tid()]
    count = prim_count[node]
    first = left_first[node]
    if count > 0:
        lo = wp.min(wp.min(v0[first], v1[first]), v2[first])
        hi = wp.max(wp.max(v0[first], v1[first]), v2[first])
        for s in range(first + 1, first + count):
            lo = wp.min(lo, wp.min(wp.min(v0[s], v1[s]), v2[s]))
            hi = wp.max(hi, wp.max(wp.max(v0[s], v1[s]), v2[s]))
    else:
        lo = wp.min(lowers[first], lowers[first + 1])
        hi = wp.max(uppers[first], uppers[first + 1])
    lowers[node] = lo
    uppers[node] = hi


@wp.kernel
def refit_pieces_level_kernel(
    level: wp.array[wp.int32],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    slot_refs: wp.array[wp.int32],
    ref_lowers: wp.array[wp.vec3],
    ref_uppers: wp.array[wp.vec3],
    # outputs
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
):
    """``refit_level_kernel`` for a tree built with pre-splits: a leaf's box is that of its slots' references (the
    moved triangles cut again as at the build), not of their whole triangles."""
    node = level[wp.tid()]
    count = prim_count[node]
    first = left_first[node]
    if count > 0:
        lo = ref_lowers[slot_refs[first]]
        hi = ref_uppers[slot_refs[first]]
        for s in range(first + 1, first + count):
            lo = wp.min(lo, ref_lowers[slot_refs[s]])
            hi = wp.max(hi, ref_uppers[slot_refs[s]])
    else:
        lo = wp.min(lowers[first], lowers[first + 1])
        hi = wp.max(uppers[first], uppers[first + 1])
    lowers[node] = lo
    uppers[node] = hi


class Refitter:
    """Refits one uploaded tree (its :class:`DeviceBvh`) in place; the struct's arrays keep their addresses, so
    structures that hold it (a TLAS's BLAS table) stay valid.

    Args:
        host: the tree as built (:class:`FlatBvh`); its ``lowers``/``uppers`` are updated by every :meth:`refit`.
        device_bvh: the same tree uploaded with :meth:`FlatBvh.to_device`.
        device: the device it lives on.
    """

    def __init__(self, host: FlatBvh, device_bvh: DeviceBvh, device):
        self.host = host
        self.device_bvh = device_bvh
        self.device = device
        self.triangles = host.num_triangles
        # A tree built with pre-splits has more slots than triangles (``presplit.py``): the moved triangles are cut
        # again as at the build (the same halvings of their new boxes), and each leaf takes its pieces' boxes. Whole
        # triangle boxes made every piece of a sliver as large as the sliver: rays near a fan of them tested 4x the
        # triangles of a tree built without pre-splits.
        self.references = None
        if host.references is not None:
            r = host.references
            self.references = [wp.array(a, dtype=wp.int32, device=device) for a in (r.levels, r.offsets, r.slot_refs)]
            self.references.append(int(r.count))
        # Each level's nodes (ascending), deepest first: views of one upload (an upload per level made a refitter
        # of a small tree cost 1 ms, most of an update of thousands of deforming prototypes).
        depth = host.depths()
        order = np.argsort(-depth, kind="stable")
        nodes = wp.array(order[depth[order] >= 0].astype(np.int32), dtype=wp.int32, device=device)
        ends = np.cumsum(np.bincount(depth[depth >= 0])[::-1])
        self.levels = [nodes[int(a) : int(b)] for a, b in zip(np.concatenate([[0], ends[:-1]]), ends)]

    def refit(self, points: np.ndarray, indices: np.ndarray) -> FlatBvh:
        """Moves the tree's triangles to ``points`` (same ``indices`` as the build) and recomputes every box."""
        d = self.device_bvh
        indices = np.asarray(indices)
        if indices.ndim != 2 or indices.shape[1] != 3 or len(indices) != self.triangles:
            raise ValueError(
                f"refit needs the build's {self.triangles} triangles as (T, 3) indices, got shape {indices.shape}"
            )
        if self.host.num_prims == 0:
            return self.host
        # Checked like a build's input, since the slab test assumes finite boxes; then the moved triangles are
        # gathered into slot order on the device, straight into the tree's vertex arrays.
        with np.errstate(over="ignore"):  # float64 values past float32's range become inf, named by check_triangles
            points_d = wp.array(np.asarray(points, np.float32), dtype=wp.vec3, device=self.device)
        indices_d = wp.array(indices.astype(np.int32), dtype=wp.int32, device=self.device)
        check_triangles(points_d, indices_d)
        wp.launch(
            gather_triangles_kernel,
            self.host.num_prims,
            inputs=[d.prim_ids, points_d, indices_d],
            outputs=[d.v0, d.v1, d.v2],
            device=self.device,
        )
        if self.references is None:
            kernel, leaf_inputs = refit_level_kernel, [d.v0, d.v1, d.v2]
        else:
            levels, offsets, slot_refs, count = self.references
            ref_lowers, ref_uppers, _, _ = write_references(points_d, indices_d, levels, offsets, count)
            kernel, leaf_inputs = refit_pieces_level_kernel, [slot_refs, ref_lowers, ref_uppers]
        for level in self.levels:
            wp.launch(
                kernel,
                len(level),
                inputs=[level, d.left_first, d.prim_count, *leaf_inputs],
                outputs=[d.lowers, d.uppers],
                device=self.device,
            )
        pack_nodes(d, allocate=False)
        self.host.lowers = d.lowers.numpy().reshape(-1, 3)
        self.host.uppers = d.uppers.numpy().reshape(-1, 3)
        self.host.points, self.host.indices = points, indices
        return self.host


__all__ = ["Refitter", "refit_level_kernel", "refit_pieces_level_kernel"]
