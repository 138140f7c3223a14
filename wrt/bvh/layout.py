"""FlatBvh: the canonical flat binary BVH that every builder hands over, and its device form.

Node ``i`` has a box ``lowers[i], uppers[i]``. A leaf has ``prim_count[i] > 0`` and owns the slots
``[left_first[i], left_first[i] + prim_count[i])``; slot ``s`` holds triangle ``prim_ids[s]``. An inner node
has ``prim_count[i] == 0`` and children ``left_first[i]`` and ``left_first[i] + 1``. The root is node 0.
This is the node of Wald's tinybvh (``aabbMin, leftFirst, aabbMax, triCount``), as structure of arrays.

On the device the triangle vertices are copied into slot order, so the traversal loop reads them without going
through ``prim_ids`` and the mesh's index buffer; ``prim_ids`` is read once per ray, for the final hit.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp


@wp.struct
class DeviceBvh:
    """A FlatBvh and its triangles in device memory."""

    lowers: wp.array[wp.vec3]  # node box minimum
    uppers: wp.array[wp.vec3]  # node box maximum
    left_first: wp.array[wp.int32]  # left child (inner node) or first slot (leaf)
    prim_count: wp.array[wp.int32]  # triangles in a leaf, 0 for an inner node
    prim_ids: wp.array[wp.int32]  # slot -> triangle id (row of Scene.triangles())
    v0: wp.array[wp.vec3]  # triangle vertices in slot order
    v1: wp.array[wp.vec3]
    v2: wp.array[wp.vec3]
    num_prims: int  # triangles in the tree; 0 means every ray misses


@dataclasses.dataclass
class FlatBvh:
    """Canonical binary BVH on the host (see module docstring for the layout).

    Attributes:
        lowers: ``(M, 3)`` float32 node box minima, world space.
        uppers: ``(M, 3)`` float32 node box maxima.
        left_first: ``(M,)`` int32 left child or first slot.
        prim_count: ``(M,)`` int32 triangle count of a leaf, 0 for inner nodes.
        prim_ids: ``(N,)`` int32 slot -> triangle id.
        builder: name of the builder that made it.
        build_seconds: wall time of the build, seconds.
    """

    lowers: np.ndarray
    uppers: np.ndarray
    left_first: np.ndarray
    prim_count: np.ndarray
    prim_ids: np.ndarray
    builder: str = ""
    build_seconds: float = 0.0

    @classmethod
    def empty(cls) -> FlatBvh:
        """A tree over no triangles: one inner-looking root whose inverted box no ray can enter."""
        return cls(
            lowers=np.full((1, 3), np.inf, np.float32),
            uppers=np.full((1, 3), -np.inf, np.float32),
            left_first=np.zeros(1, np.int32),
            prim_count=np.zeros(1, np.int32),
            prim_ids=np.zeros(0, np.int32),
        )

    @property
    def num_nodes(self) -> int:
        """Number of nodes."""
        return len(self.left_first)

    @property
    def num_prims(self) -> int:
        """Number of triangles."""
        return len(self.prim_ids)

    def depths(self) -> np.ndarray:
        """``(M,)`` int depth of every node (root 0), computed level by level."""
        depth = np.full(self.num_nodes, -1, np.int64)
        if self.num_prims == 0:
            return np.zeros(self.num_nodes, np.int64)
        frontier = np.array([0])
        d = 0
        while len(frontier):
            depth[frontier] = d
            inner = frontier[self.prim_count[frontier] == 0]
            children = self.left_first[inner]
            frontier = np.concatenate([children, children + 1])
            d += 1
        return depth

    def validate(self, max_depth: int | None = None) -> None:
        """Checks the structural invariants; raises ``AssertionError`` naming the first one broken.

        Every triangle sits in exactly one leaf, every node is reached exactly once, child boxes lie inside their
        parent's, no inner node is empty, and no leaf is deeper than ``max_depth - 1`` (the traversal stack).
        """
        from .build import MAX_DEPTH

        max_depth = MAX_DEPTH if max_depth is None else max_depth
        m, n = self.num_nodes, self.num_prims
        if n == 0:
            assert m == 1 and self.prim_count[0] == 0, "an empty tree has exactly one empty root"
            return
        leaf = self.prim_count > 0
        inner = ~leaf
        assert np.all(self.prim_count >= 0), "negative prim_count"
        children = self.left_first[inner]
        assert np.all((children >= 1) & (children + 1 < m)), "child index out of range"
        reached = np.zeros(m, np.int64)
        reached[0] += 1
        np.add.at(reached, children, 1)
        np.add.at(reached, children + 1, 1)
        assert np.all(reached == 1), f"{np.count_nonzero(reached != 1)} nodes are not reached exactly once"
        first, count = self.left_first[leaf], self.prim_count[leaf]
        assert np.all(first >= 0) and np.all(first + count <= n), "leaf slot range out of range"
        covered = np.zeros(n, np.int64)
        np.add.at(covered, np.repeat(first, count) + _ranges(count), 1)
        assert np.all(covered == 1), "leaf slot ranges do not cover every slot exactly once"
        assert np.array_equal(np.sort(self.prim_ids), np.arange(n)), "prim_ids is not a permutation"
        for child in (children, children + 1):
            parents = np.flatnonzero(inner)
            assert np.all(self.lowers[child] >= self.lowers[parents]), "child box below its parent's"
            assert np.all(self.uppers[child] <= self.uppers[parents]), "child box above its parent's"
        depth = self.depths()
        assert depth.max() <= max_depth - 1, f"depth {depth.max()} exceeds the traversal stack ({max_depth})"

    def to_device(self, points: np.ndarray, indices: np.ndarray, device=None) -> DeviceBvh:
        """Uploads the tree and its triangles, in slot order, to ``device``.

        Args:
            points: ``(V, 3)`` float32 vertex positions the tree was built over.
            indices: ``(T, 3)`` int32 triangles the tree was built over.
            device: Warp device.
        """
        device = wp.get_device(device)
        corners = np.asarray(points, np.float32)[np.asarray(indices)[self.prim_ids]] if self.num_prims else None
        if corners is None:
            corners = np.zeros((1, 3, 3), np.float32)  # keep arrays non-empty; num_prims = 0 stops traversal
        s = DeviceBvh()
        s.lowers = wp.array(self.lowers, dtype=wp.vec3, device=device)
        s.uppers = wp.array(self.uppers, dtype=wp.vec3, device=device)
        s.left_first = wp.array(self.left_first, dtype=wp.int32, device=device)
        s.prim_count = wp.array(self.prim_count, dtype=wp.int32, device=device)
        s.prim_ids = wp.array(self.prim_ids if self.num_prims else np.zeros(1, np.int32), dtype=wp.int32, device=device)
        s.v0 = wp.array(np.ascontiguousarray(corners[:, 0]), dtype=wp.vec3, device=device)
        s.v1 = wp.array(np.ascontiguousarray(corners[:, 1]), dtype=wp.vec3, device=device)
        s.v2 = wp.array(np.ascontiguousarray(corners[:, 2]), dtype=wp.vec3, device=device)
        s.num_prims = self.num_prims
        return s


def _ranges(counts: np.ndarray) -> np.ndarray:
    """``concatenate([arange(c) for c in counts])`` without a Python loop."""
    counts = np.asarray(counts, np.int64)
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total) - starts
