"""Reads the BVH inside a Warp ``wp.Mesh`` into a canonical :class:`FlatBvh`, for side-by-side statistics.

Warp 1.19 exposes no Python accessor for a mesh's tree, so this module reads the native structs directly: a mesh's
``id`` is the address of its ``wp::Mesh`` (host memory for a CPU mesh, device memory for a CUDA mesh), whose
``bvh`` member (``warp/native/bvh.h``, ``struct BVH``) points at packed nodes ``BVHPackedNodeHalf {float x, y, z;
uint32 i:31, b:1}``: ``node_lowers[n].b`` marks a leaf, an inner node's children are ``node_lowers[n].i`` and
``node_uppers[n].i``, and a leaf holds ``primitive_indices[lower.i : upper.i]``. The root index is ``*bvh.root``.

The ctypes mirrors below follow ``warp/native/mesh.h`` and ``bvh.h`` of warp-lang 1.19.0; :func:`read_warp_bvh`
checks the counts it reads against the mesh (triangles, nodes, leaves) and raises ``RuntimeError`` rather than
return a tree from a layout it does not recognise.
"""

from __future__ import annotations

import ctypes
import time

import numpy as np
import warp as wp

from ..options import MAX_WARP_LEAF_SIZE
from ..options import WARP_BUILDERS as WARP_BUILDERS  # re-exported: see wrt.options
from .layout import FlatBvh


class _ArrayT(ctypes.Structure):
    """``wp::array_t<T>`` (``warp/native/array.h``)."""

    _fields_ = (
        ("data", ctypes.c_uint64),
        ("grad", ctypes.c_uint64),
        ("shape", ctypes.c_int32 * 4),
        ("strides", ctypes.c_int32 * 4),
        ("ndim", ctypes.c_uint16),
        ("flags", ctypes.c_uint16),
    )


class _Bvh(ctypes.Structure):
    """``wp::BVH`` (``warp/native/bvh.h``)."""

    _fields_ = (
        ("node_lowers", ctypes.c_uint64),
        ("node_uppers", ctypes.c_uint64),
        ("node_parents", ctypes.c_uint64),
        ("node_counts", ctypes.c_uint64),
        ("primitive_indices", ctypes.c_uint64),
        ("max_depth", ctypes.c_int32),
        ("max_nodes", ctypes.c_int32),
        ("num_nodes", ctypes.c_int32),
        ("num_leaf_nodes", ctypes.c_int32),
        ("root", ctypes.c_uint64),
        ("item_lowers", ctypes.c_uint64),
        ("item_uppers", ctypes.c_uint64),
        ("item_groups", ctypes.c_uint64),
        ("num_items", ctypes.c_int32),
        ("leaf_size", ctypes.c_int32),
        ("constructor_type", ctypes.c_int32),
        ("context", ctypes.c_uint64),
    )


class _Mesh(ctypes.Structure):
    """``wp::Mesh`` (``warp/native/mesh.h``), up to and including its BVH."""

    _fields_ = (
        ("points", _ArrayT),
        ("velocities", _ArrayT),
        ("indices", _ArrayT),
        ("lowers", ctypes.c_uint64),
        ("uppers", ctypes.c_uint64),
        ("solid_angle_props", ctypes.c_uint64),
        ("num_points", ctypes.c_int32),
        ("num_tris", ctypes.c_int32),
        ("bvh", _Bvh),
    )


def _read(address: int, dtype, count: int, device) -> np.ndarray:
    """``count`` elements of ``dtype`` at ``address`` on ``device``, copied to a numpy array."""
    return wp.array(ptr=int(address), dtype=dtype, shape=(count,), device=device, copy=False).numpy().copy()


def read_warp_bvh(mesh: wp.Mesh, builder: str = "warp") -> FlatBvh:
    """The tree inside ``mesh`` as a canonical FlatBvh (renumbered breadth first, slots in depth-first leaf order).

    Raises:
        RuntimeError: when the native structs do not look like warp-lang 1.19's.
    """
    device = mesh.device
    raw = _read(mesh.id, wp.uint8, ctypes.sizeof(_Mesh), device)
    m = _Mesh.from_buffer_copy(raw.tobytes())
    bvh = m.bvh
    num_tris = int(mesh.indices.shape[0] // 3)
    if m.num_tris != num_tris or bvh.num_items != num_tris or not 0 < bvh.num_nodes <= max(2 * num_tris, 1):
        raise RuntimeError(
            "cannot read wp.Mesh's BVH: the native Mesh/BVH layout differs from warp-lang 1.19's "
            f"(num_tris={m.num_tris}, num_items={bvh.num_items}, num_nodes={bvh.num_nodes})"
        )
    count = bvh.num_nodes
    lower = _read(bvh.node_lowers, wp.uint32, 4 * count, device).reshape(count, 4)
    upper = _read(bvh.node_uppers, wp.uint32, 4 * count, device).reshape(count, 4)
    prims = _read(bvh.primitive_indices, wp.int32, num_tris, device)
    root = int(_read(bvh.root, wp.int32, 1, device)[0])
    lows = lower[:, :3].copy().view(np.float32)
    highs = upper[:, :3].copy().view(np.float32)
    is_leaf = (lower[:, 3] >> 31).astype(bool)
    a = (lower[:, 3] & 0x7FFFFFFF).astype(np.int64)
    b = (upper[:, 3] & 0x7FFFFFFF).astype(np.int64)
    if is_leaf.sum() != bvh.num_leaf_nodes or not 0 <= root < count:
        raise RuntimeError("cannot read wp.Mesh's BVH: leaf count or root index out of range")
    flat = flat_from_binary(lows, highs, is_leaf, a, b, prims, root)
    flat.builder = builder
    return flat


def flat_from_binary(lowers, uppers, is_leaf, a, b, prims, root) -> FlatBvh:
    """Canonical FlatBvh of a binary tree in any node order.

    Args:
        lowers: ``(M, 3)`` node box minima.
        uppers: ``(M, 3)`` node box maxima.
        is_leaf: ``(M,)`` bool.
        a: ``(M,)`` left child (inner) or first index into ``prims`` (leaf).
        b: ``(M,)`` right child (inner) or one past the last index into ``prims`` (leaf).
        prims: triangle ids referenced by the leaves.
        root: index of the root node.
    """
    # Breadth-first order with the two children of a node side by side.
    order = [np.array([root])]
    while True:
        inner = order[-1][~is_leaf[order[-1]]]
        if len(inner) == 0:
            break
        order.append(np.stack([a[inner], b[inner]], 1).reshape(-1))
    old = np.concatenate(order)
    m = len(old)
    new_of = np.full(len(is_leaf), -1, np.int64)
    new_of[old] = np.arange(m)
    leaf = is_leaf[old]
    counts = np.where(leaf, b[old] - a[old], 0)
    # Subtree sizes bottom-up, then slot starts top-down, so every subtree owns a contiguous slot range.
    size = counts.copy()
    left = np.where(leaf, -1, new_of[np.where(leaf, 0, a[old])])
    for level in reversed(order):
        n = new_of[level]
        n = n[~leaf[n]]
        size[n] = size[left[n]] + size[left[n] + 1]
    start = np.zeros(m, np.int64)
    for level in order:
        n = new_of[level]
        n = n[~leaf[n]]
        start[left[n]] = start[n]
        start[left[n] + 1] = start[n] + size[left[n]]
    prim_ids = np.empty(int(counts.sum()), np.int32)
    leaves = np.flatnonzero(leaf)
    if len(leaves):
        src = np.repeat(a[old][leaves], counts[leaves]) + _ranges(counts[leaves])
        dst = np.repeat(start[leaves], counts[leaves]) + _ranges(counts[leaves])
        prim_ids[dst] = prims[src]
    return FlatBvh(
        lowers=np.ascontiguousarray(lowers[old], np.float32),
        uppers=np.ascontiguousarray(uppers[old], np.float32),
        left_first=np.where(leaf, start, left).astype(np.int32),
        prim_count=counts.astype(np.int32),
        prim_ids=prim_ids,
    )


def _ranges(counts):
    from .layout import _ranges as ranges

    return ranges(counts)


def check_warp_builder(builder: str, device) -> None:
    """Raises ValueError for ``lbvh`` on the CPU: wp.Mesh then builds its ``sah`` tree (with only a warning), so
    statistics or timings labelled ``warp:lbvh`` would be those of ``warp:sah``."""
    if builder == "lbvh" and wp.get_device(device).is_cpu:
        raise ValueError("wp.Mesh has no lbvh builder on the CPU (Warp builds its sah tree instead); use a CUDA "
                         "device for warp:lbvh, or warp:sah")


def check_warp_leaf_size(leaf_size) -> None:
    """Raises ValueError unless ``leaf_size`` is None or an integer from 1 to ``MAX_WARP_LEAF_SIZE``; Warp itself
    refuses 0 and less, but 2^31 and more ended the process with a segmentation fault."""
    if leaf_size is None:
        return
    if isinstance(leaf_size, bool) or not isinstance(leaf_size, (int, np.integer)) or not (
            1 <= leaf_size <= MAX_WARP_LEAF_SIZE):
        raise ValueError(f"Warp's bvh_leaf_size must be an integer from 1 to {MAX_WARP_LEAF_SIZE}, got {leaf_size!r}")


def warp_mesh_bvh(points, indices, builder: str = "sah", leaf_size: int | None = None, device="cpu") -> FlatBvh:
    """Builds ``wp.Mesh(points, indices, bvh_constructor=builder)`` and reads its tree (build time included).

    Args:
        points: ``(V, 3)`` float32 vertices.
        indices: ``(T, 3)`` int32 triangles.
        builder: Warp's ``bvh_constructor``: ``sah``, ``median``, ``lbvh`` (CUDA only) or ``cubql``.
        leaf_size: Warp's ``bvh_leaf_size`` (its default when ``None``).
        device: Warp device.
    """
    device = wp.get_device(device)
    check_warp_builder(builder, device)
    check_warp_leaf_size(leaf_size)
    pts = wp.array(np.asarray(points, np.float32).reshape(-1, 3), dtype=wp.vec3, device=device)
    idx = wp.array(np.asarray(indices, np.int32).reshape(-1), dtype=wp.int32, device=device)
    if idx.shape[0] == 0:  # wp.Mesh holds no tree at all (0 nodes): the empty tree wrt's builders give
        flat = FlatBvh.empty(builder=f"warp:{builder}")
        flat.points, flat.indices = points, indices
        return flat
    wp.synchronize_device(device)
    start = time.perf_counter()
    mesh = wp.Mesh(pts, idx, bvh_constructor=builder, bvh_leaf_size=leaf_size)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    flat = read_warp_bvh(mesh, builder=f"warp:{builder}")
    flat.build_seconds = seconds
    flat.points, flat.indices = points, indices
    return flat
