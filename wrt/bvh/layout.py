"""FlatBvh: the canonical flat binary BVH that every builder hands over, its device form, and the registry of the
other layouts, which are conversions from it (``convert_layout``): ``compact`` (``compact.py``, child boxes in the
parent) and ``wide``/``wide8`` (``wide.py``, BVH4/BVH8 collapsed by SAH).

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

from ..errors import did_you_mean
from ..options import LAYOUTS
from .packed import pack_child

wp.set_module_options({"enable_backward": False})


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
    # CUDA: per node two records, (lower, upper.x) and (upper.y, upper.z, left_first, prim_count), each read in one
    # 16-byte load (``packed.py``); the CPU's traversal reads the arrays above, and this holds one dummy entry there.
    nodes: wp.array[wp.vec4]


@wp.kernel
def pack_nodes_kernel(
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    nodes: wp.array[wp.vec4],
):
    i = wp.tid()
    pack_child(nodes, i, lowers[i], uppers[i], wp.vec2i(left_first[i], prim_count[i]))


def pack_nodes(bvh: DeviceBvh, allocate: bool = True) -> None:
    """Writes ``bvh.nodes`` from its node arrays, into a new array or (``allocate=False``, a refit) in place, where
    captured CUDA graphs keep reading it."""
    device = bvh.lowers.device
    n = len(bvh.lowers) if device.is_cuda else 0
    if allocate:
        bvh.nodes = wp.empty(2 * n, dtype=wp.vec4, device=device) if n else wp.zeros(1, dtype=wp.vec4, device=device)
    if n:
        wp.launch(pack_nodes_kernel, n, inputs=[bvh.lowers, bvh.uppers, bvh.left_first, bvh.prim_count],
                  outputs=[bvh.nodes], device=device)


@wp.kernel
def gather_triangles_kernel(
    prim_ids: wp.array[wp.int32],
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    # outputs
    v0: wp.array[wp.vec3],
    v1: wp.array[wp.vec3],
    v2: wp.array[wp.vec3],
):
    """Vertices of the triangle in slot ``s``, in slot order (the device twin of ``upload_triangles``)."""
    s = wp.tid()
    p = prim_ids[s]
    v0[s] = points[indices[p, 0]]
    v1[s] = points[indices[p, 1]]
    v2[s] = points[indices[p, 2]]


@dataclasses.dataclass
class FlatBvh:
    """Canonical binary BVH on the host. The root is node 0; an inner node ``i`` (``prim_count[i] == 0``) has the
    children ``left_first[i]`` and ``left_first[i] + 1``; a leaf holds the triangles
    ``prim_ids[left_first[i] : left_first[i] + prim_count[i]]`` (rows of the ``indices`` it was built over).

    Attributes:
        lowers: ``(M, 3)`` float32 node box minima, world space.
        uppers: ``(M, 3)`` float32 node box maxima.
        left_first: ``(M,)`` int32 left child (inner node) or first slot (leaf).
        prim_count: ``(M,)`` int32 triangle count of a leaf, 0 for inner nodes.
        prim_ids: ``(N,)`` int32 slot -> triangle id (``N`` = triangles, more with pre-splits).
        builder: name of the builder that made it.
        build_seconds: wall time of the build, seconds.
        points: the ``(V, 3)`` vertices it was built over (numpy or ``wp.array``), for :meth:`stats`; optional.
        indices: the ``(T, 3)`` triangles it was built over, for :meth:`stats`; optional.
        references: how a tree built with pre-splits cut its triangles (``presplit.References``), for refits; None
            when none was cut.
    """

    lowers: np.ndarray
    uppers: np.ndarray
    left_first: np.ndarray
    prim_count: np.ndarray
    prim_ids: np.ndarray
    builder: str = ""
    build_seconds: float = 0.0
    points: object = dataclasses.field(default=None, repr=False, compare=False)
    indices: object = dataclasses.field(default=None, repr=False, compare=False)
    references: object = dataclasses.field(default=None, repr=False, compare=False)

    @classmethod
    def empty(cls, builder: str = "") -> FlatBvh:
        """A tree over no triangles: one inner-looking root whose inverted box no ray can enter."""
        return cls(
            builder=builder,
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
        """Number of leaf slots: one per triangle, or more in a tree built with pre-splits (``presplit.py``)."""
        return len(self.prim_ids)

    @property
    def num_triangles(self) -> int:
        """Number of triangles the tree was built over (those attached by ``build_bvh``; else ``num_prims``)."""
        return self.num_prims if self.indices is None else int(np.size(self.indices)) // 3

    @property
    def bytes(self) -> int:
        """Node bytes (32 per node) plus slot -> triangle id bytes (the triangles themselves not counted)."""
        return 32 * self.num_nodes + 4 * self.num_prims

    def depths(self) -> np.ndarray:
        """``(M,)`` int depth of every node (root 0), computed level by level."""
        depth = np.full(self.num_nodes, -1, np.int64)
        if self.num_prims == 0:
            return np.zeros(self.num_nodes, np.int64)
        frontier = np.array([0])
        d, visited = 0, 0
        while len(frontier):
            # A child link back up the tree (a corrupted one) made the levels double for ever, until memory ran out.
            visited += len(frontier)
            if visited > self.num_nodes:
                raise ValueError(f"node {int(frontier[0])} is reached a second time at depth {d}: a child link leads "
                                 "back up the tree (FlatBvh.validate() names it)")
            depth[frontier] = d
            inner = frontier[self.prim_count[frontier] == 0]
            children = self.left_first[inner]
            frontier = np.concatenate([children, children + 1])
            d += 1
        return depth

    def validate(self, max_depth: int | None = None) -> None:
        """Checks the structural invariants; raises ``AssertionError`` naming the first one broken and the first node
        (or slot) that breaks it. The checks are explicit raises, not ``assert`` statements, so they also run under
        ``python -O`` (which strips those and let every corrupted tree through).

        Every slot sits in exactly one leaf, every triangle in at least one slot (exactly one unless the tree was
        built with pre-splits, ``presplit.py``), every node is reached from the root exactly once, no box is
        inverted, child boxes lie inside their parent's, no inner node is empty, no leaf is deeper than
        ``max_depth - 1`` (the traversal stack), and, where the tree holds the triangles it was built over, every leaf
        box holds its triangles' boxes (meets them, for a tree built with pre-splits, whose slots hold pieces of
        triangles).
        """
        from .common import MAX_DEPTH

        max_depth = MAX_DEPTH if max_depth is None else max_depth
        m, n = self.num_nodes, self.num_prims
        for name in ("lowers", "uppers"):
            _require(np.shape(getattr(self, name)) == (m, 3), f"{name} has shape {np.shape(getattr(self, name))}, "
                     f"not ({m}, 3) for {m} nodes")
        _require(np.shape(self.prim_count) == (m,), f"prim_count has {np.size(self.prim_count)} entries for {m} nodes")
        if n == 0:
            _require(m == 1 and self.prim_count[0] == 0, "an empty tree has exactly one empty root")
            return
        _require_each(self.prim_count >= 0, "node", "negative prim_count")
        leaf = self.prim_count > 0
        inner = ~leaf
        parents = np.flatnonzero(inner)
        children = self.left_first[inner]
        _require_each((children >= 1) & (children + 1 < m), "node", "child index out of range", parents)
        reached = np.zeros(m, np.int64)
        reached[0] += 1
        np.add.at(reached, children, 1)
        np.add.at(reached, children + 1, 1)
        _require(np.all(reached == 1), f"{np.count_nonzero(reached != 1)} nodes are not reached exactly once "
                 f"(first: node {np.flatnonzero(reached != 1)[0] if np.any(reached != 1) else 0})")
        first, count = self.left_first[leaf], self.prim_count[leaf]
        _require_each((first >= 0) & (first + count <= n), "leaf", f"slot range out of range (slots: {n})",
                      np.flatnonzero(leaf))
        covered = np.zeros(n, np.int64)
        np.add.at(covered, np.repeat(first, count) + _ranges(count), 1)
        _require_each(covered == 1, "slot", "not in exactly one leaf's slot range")
        triangles = self.num_triangles
        if n == triangles:
            _require_each((self.prim_ids >= 0) & (self.prim_ids < n), "slot", f"prim_ids out of range ({n} triangles)")
            slots_of = np.bincount(self.prim_ids, minlength=n)
            twice = np.flatnonzero(slots_of > 1)
            _require(len(twice) == 0, f"prim_ids is not a permutation: triangle {twice[0] if len(twice) else 0} is in "
                     f"slots {np.flatnonzero(self.prim_ids == (twice[0] if len(twice) else 0)).tolist()}")
        else:  # pre-split references: several slots may hold one triangle
            _require_each((self.prim_ids >= 0) & (self.prim_ids < triangles), "slot", "prim_ids out of range")
            _require(np.unique(self.prim_ids).size == triangles, "a triangle is in no slot")
        # An inverted (or NaN) box is entered by no ray; a leaf's, inside its parent's, passed every other check.
        _require_each(np.all(self.lowers <= self.uppers, axis=1), "node", "box inverted or not a number")
        for child in (children, children + 1):
            _require_each(np.all(self.lowers[child] >= self.lowers[parents], axis=1), "node",
                          "child box below its parent's", child)
            _require_each(np.all(self.uppers[child] <= self.uppers[parents], axis=1), "node",
                          "child box above its parent's", child)
        if self.points is not None and self.indices is not None:
            self._validate_leaf_boxes(leaf, first, count)
        depth = self.depths()
        # Each node being one node's child does not make it the root's descendant: a node that is its own child heads a
        # loop apart from the tree, whose leaves' triangles no traversal reaches (depths() leaves them at -1).
        _require_each(depth >= 0, "node", "not reached from the root (its chain of parents loops)")
        _require(depth.max() <= max_depth - 1, f"depth {depth.max()} exceeds the traversal stack ({max_depth})")

    def _validate_leaf_boxes(self, leaf: np.ndarray, first: np.ndarray, count: np.ndarray) -> None:
        """Every leaf box holds the boxes of its slots' triangles (meets them after pre-splits)."""
        points = self.points.numpy() if isinstance(self.points, wp.array) else np.asarray(self.points)
        indices = self.indices.numpy() if isinstance(self.indices, wp.array) else np.asarray(self.indices)
        corners = points.reshape(-1, 3)[indices.reshape(-1, 3)[self.prim_ids]]
        slot_leaf = np.repeat(np.flatnonzero(leaf), count)[np.argsort(np.repeat(first, count) + _ranges(count))]
        lo, hi = self.lowers[slot_leaf], self.uppers[slot_leaf]
        if self.num_prims == self.num_triangles:
            inside = np.all((corners.min(1) >= lo) & (corners.max(1) <= hi), axis=1)
            what = "box does not hold its triangles"
        else:
            inside = np.all((corners.max(1) >= lo) & (corners.min(1) <= hi), axis=1)
            what = "box misses a triangle of its slots"
        _require_each(inside, "leaf", what, slot_leaf)

    def stats(
        self,
        traversal_cost: float = 1.0,
        intersection_cost: float = 1.0,
        *,
        points=None,
        indices=None,
        epo_samples: int | None = None,
    ) -> dict:
        """Quality and size statistics (see ``stats.py`` for the definitions).

        Args:
            traversal_cost: SAH/EPO cost of visiting an inner node.
            intersection_cost: SAH/EPO cost of one ray-triangle test.
            points: ``(V, 3)`` vertices for the EPO estimate; default: the ones the tree was built over.
            indices: ``(T, 3)`` triangles for the EPO estimate; default: the ones the tree was built over.
            epo_samples: surface samples of the EPO estimate (``None``: ``stats.EPO_SAMPLES``, or none for a tree
                built with pre-splits, where EPO is not defined); 0 skips EPO.

        Returns:
            dict with ``sah_cost``, ``epo`` (``None`` without triangles or samples), ``epo_stderr``,
            ``triangles``, ``slots`` (leaf slots: more than ``triangles`` after pre-splits), ``nodes``,
            ``inner_nodes``, ``leaves``, ``max_depth``, ``mean_leaf_depth``, ``mean_prim_depth`` (per slot),
            ``mean_leaf_size``, ``leaf_size_histogram`` (size -> leaves), ``node_bytes``, ``bytes``,
            ``build_seconds``, the cost constants and the builder name.

        Raises:
            ValueError: cost constants that :func:`wrt.build_bvh` refuses too (negative, zero ``intersection_cost``,
                not finite), a bad ``epo_samples``, or samples asked of a tree built with pre-splits.
        """
        from .build import check_costs, check_int_option
        from .stats import EPO_SAMPLES, MAX_EPO_SAMPLES, bvh_stats

        traversal_cost, intersection_cost = check_costs(traversal_cost, intersection_cost)
        if epo_samples is None:
            epo_samples = EPO_SAMPLES if self.num_prims == self.num_triangles else 0
        epo_samples = check_int_option("epo_samples", epo_samples, 0, MAX_EPO_SAMPLES)

        points = self.points if points is None else points
        indices = self.indices if indices is None else indices
        if points is not None and indices is not None:
            points = points.numpy() if isinstance(points, wp.array) else points
            indices = indices.numpy() if isinstance(indices, wp.array) else indices
        return bvh_stats(
            self,
            points,
            indices,
            traversal_cost,
            intersection_cost,
            epo_samples,
        )

    def to_device(self, points: np.ndarray, indices: np.ndarray, device=None) -> DeviceBvh:
        """Uploads the tree and its triangles, in slot order, to ``device``.

        Args:
            points: ``(V, 3)`` float32 vertex positions the tree was built over.
            indices: ``(T, 3)`` int32 triangles the tree was built over.
            device: Warp device.
        """
        device = wp.get_device(device)
        s = DeviceBvh()
        s.lowers = wp.array(self.lowers, dtype=wp.vec3, device=device)
        s.uppers = wp.array(self.uppers, dtype=wp.vec3, device=device)
        s.left_first = wp.array(self.left_first, dtype=wp.int32, device=device)
        s.prim_count = wp.array(self.prim_count, dtype=wp.int32, device=device)
        s.prim_ids, s.v0, s.v1, s.v2 = upload_triangles(self.prim_ids, points, indices, device)
        s.num_prims = self.num_prims
        pack_nodes(s)
        return s


@dataclasses.dataclass
class DeviceFlatBvh:
    """The canonical layout in device memory, as a builder leaves it; :meth:`to_host` makes the :class:`FlatBvh`.

    Attributes:
        lowers: ``(M,)`` vec3 node box minima.
        uppers: ``(M,)`` vec3 node box maxima.
        left_first: ``(M,)`` int32 left child or first slot.
        prim_count: ``(M,)`` int32 triangle count of a leaf, 0 for inner nodes.
        prim_ids: ``(N,)`` int32 slot -> triangle id.
        builder: name of the builder that made it.
        references: the pre-splits' ``presplit.References`` (None without cut triangles), for refits.
    """

    lowers: wp.array
    uppers: wp.array
    left_first: wp.array
    prim_count: wp.array
    prim_ids: wp.array
    builder: str = ""
    references: object = None

    @property
    def num_nodes(self) -> int:
        """Number of nodes."""
        return len(self.left_first)

    def to_device_bvh(self, points: wp.array, indices: wp.array) -> DeviceBvh:
        """The tree as traversal input, without leaving the device: its arrays as they are, and the triangles in
        slot order gathered on the device (what :meth:`FlatBvh.to_device` uploads from the host).

        Args:
            points: ``(V,)`` vec3 vertices the tree was built over, on the tree's device.
            indices: ``(T, 3)`` int32 triangles the tree was built over, on the tree's device.
        """
        s = DeviceBvh()
        s.lowers, s.uppers, s.left_first, s.prim_count = self.lowers, self.uppers, self.left_first, self.prim_count
        s.prim_ids, s.v0, s.v1, s.v2 = self.slot_triangles(points, indices)
        s.num_prims = len(self.prim_ids)
        pack_nodes(s)
        return s

    def slot_triangles(self, points: wp.array, indices: wp.array) -> tuple:
        """``(prim_ids, v0, v1, v2)`` on the tree's device: the slot -> triangle map and the vertices of each slot's
        triangle, gathered there (a tree over nothing keeps one zero entry in each); arguments as
        :meth:`to_device_bvh`'s."""
        device = self.left_first.device
        n = len(self.prim_ids)
        prim_ids = self.prim_ids if n else wp.zeros(1, dtype=wp.int32, device=device)
        alloc = wp.empty if n else wp.zeros  # the gather fills every slot
        v0, v1, v2 = (alloc(max(n, 1), dtype=wp.vec3, device=device) for _ in range(3))
        wp.launch(gather_triangles_kernel, n, inputs=[self.prim_ids, points, indices], outputs=[v0, v1, v2],
                  device=device)
        return prim_ids, v0, v1, v2

    def to_host(self) -> FlatBvh:
        """Copies the tree to the host."""
        return FlatBvh(
            lowers=self.lowers.numpy().reshape(-1, 3),
            uppers=self.uppers.numpy().reshape(-1, 3),
            left_first=self.left_first.numpy(),
            prim_count=self.prim_count.numpy(),
            prim_ids=self.prim_ids.numpy(),
            builder=self.builder,
            references=None if self.references is None else self.references.numpy(),
        )


def upload_many(trees: list, meshes: list, device) -> list[DeviceBvh]:
    """``tree.to_device(points, indices, device)`` of each tree (over at least one triangle) and its ``(points,
    indices)`` mesh, the same arrays, each a view of one upload per field: eight uploads in all, where thousands of
    small BLASes spent most of their setup on eight allocations and copies each."""
    device = wp.get_device(device)
    node_ends = np.cumsum([0] + [len(t.left_first) for t in trees])
    prim_ends = np.cumsum([0] + [len(t.prim_ids) for t in trees])
    v_firsts = np.cumsum([0] + [len(p) for p, _ in meshes])

    def upload(parts, dtype, ends):  # one field at a time, so only one concatenation is alive at once
        return wp.array(np.ascontiguousarray(np.concatenate(parts)), dtype=dtype, device=device), ends

    uploads = [upload([t.lowers for t in trees], wp.vec3, node_ends),
               upload([t.uppers for t in trees], wp.vec3, node_ends),
               upload([t.left_first for t in trees], wp.int32, node_ends),
               upload([t.prim_count for t in trees], wp.int32, node_ends),
               upload([t.prim_ids for t in trees], wp.int32, prim_ends)]
    # The slots' vertices as rows of all meshes' points: a list of every tree's (T, 3, 3) corners and their
    # concatenation, alive together, were most of the peak memory of a two-level BVH's setup.
    points = np.concatenate([np.asarray(p, np.float32).reshape(-1, 3) for p, _ in meshes])
    slot_corners = np.concatenate([np.asarray(i)[t.prim_ids] + v for t, (_, i), v in zip(trees, meshes, v_firsts)])
    uploads += [upload([points[slot_corners[:, k]]], wp.vec3, prim_ends) for k in range(3)]
    out = []
    for j, tree in enumerate(trees):
        s = DeviceBvh()
        s.lowers, s.uppers, s.left_first, s.prim_count, s.prim_ids, s.v0, s.v1, s.v2 = (
            a[int(ends[j]) : int(ends[j + 1])] for a, ends in uploads)
        s.num_prims = tree.num_prims
        pack_nodes(s)
        out.append(s)
    return out


def upload_triangles(prim_ids: np.ndarray, points: np.ndarray, indices: np.ndarray, device) -> tuple:
    """``(prim_ids, v0, v1, v2)`` on ``device``: the slot -> triangle map and the triangles' vertices in slot order.

    Arrays stay non-empty for a tree over no triangles (whose ``num_prims = 0`` stops every traversal).
    """
    n = len(prim_ids)
    corners = np.asarray(points, np.float32)[np.asarray(indices)[prim_ids]] if n else np.zeros((1, 3, 3), np.float32)
    ids = prim_ids if n else np.zeros(1, np.int32)
    return (
        wp.array(ids, dtype=wp.int32, device=device),
        wp.array(np.ascontiguousarray(corners[:, 0]), dtype=wp.vec3, device=device),
        wp.array(np.ascontiguousarray(corners[:, 1]), dtype=wp.vec3, device=device),
        wp.array(np.ascontiguousarray(corners[:, 2]), dtype=wp.vec3, device=device),
    )


def _require(ok, message: str) -> None:
    """Raises ``AssertionError(message)`` unless ``ok`` (an ``assert`` that ``python -O`` keeps)."""
    if not ok:
        raise AssertionError(message)


def _require_each(ok: np.ndarray, kind: str, message: str, ids: np.ndarray | None = None) -> None:
    """Raises ``AssertionError`` naming the first ``kind`` (``ids[j]``, else ``j``) whose ``ok[j]`` is false."""
    bad = np.flatnonzero(~np.asarray(ok, bool))
    if len(bad):
        named = bad if ids is None else np.unique(np.asarray(ids)[bad])
        j = int(bad[0]) if ids is None else int(np.asarray(ids)[bad[0]])
        more = f" (and {len(named) - 1} more)" if len(named) > 1 else ""
        raise AssertionError(f"{kind} {j}: {message}{more}")


def _ranges(counts: np.ndarray) -> np.ndarray:
    """``concatenate([arange(c) for c in counts])`` without a Python loop."""
    counts = np.asarray(counts, np.int64)
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total) - starts


def check_layout(layout: str) -> str:
    """Returns ``layout`` if it is a known layout name; raises ``ValueError`` listing the valid ones."""
    if layout not in LAYOUTS:
        raise ValueError(f"unknown BVH layout {layout!r}{did_you_mean(layout, LAYOUTS)}; valid layouts: "
                         f"{', '.join(LAYOUTS)}")
    return layout


def convert_layout(bvh: FlatBvh, layout: str):
    """The tree in ``layout``: the FlatBvh itself for ``binary``, else a ``CompactBvh`` or ``WideBvh``; each has
    ``to_device(points, indices, device)``, ``num_nodes`` and ``bytes``."""
    check_layout(layout)
    if layout == "binary":
        return bvh
    if layout == "compact":
        from .compact import convert_compact

        return convert_compact(bvh)
    from .wide import WIDE_WIDTHS, convert_wide

    return convert_wide(bvh, WIDE_WIDTHS[layout])


def layout_kernels(layout: str, counted: bool = True) -> tuple:
    """``(trace_kernel, occluded_kernel)`` of a non-binary layout (the binary ones live in ``wrt/trace.py``); with
    ``counted=False`` the trace kernel that does not count each ray's traversal cost."""
    check_layout(layout)
    if layout == "compact":
        from .compact import occluded_compact_kernel, trace_compact_kernel, trace_compact_kernel_uncounted

        return (trace_compact_kernel if counted else trace_compact_kernel_uncounted), occluded_compact_kernel
    if layout in ("wide", "wide8"):
        from .wide import WIDE_KERNELS, WIDE_WIDTHS

        trace, uncounted, occluded = WIDE_KERNELS[WIDE_WIDTHS[layout]]
        return (trace if counted else uncounted), occluded
    raise ValueError("the binary layout's kernels live in wrt.trace")
