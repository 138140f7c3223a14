"""Compact GPU-friendly layout: child boxes stored in the parent, 64 bytes per inner node (Aila and Laine,
"Understanding the Efficiency of Ray Traversal on GPUs", HPG 2009; tinybvh's ``BVH_GPU``).

A converted tree keeps only the inner nodes of the canonical FlatBvh. Inner node ``i`` holds both children's
boxes in three ``vec4`` (``c0.lo.x c0.hi.x c0.lo.y c0.hi.y | c1.lo.x c1.hi.x c1.lo.y c1.hi.y | c0.lo.z c0.hi.z
c1.lo.z c1.hi.z``, the Aila-Laine order) and one ``vec4i`` of child references ``(ref0, ref1, count0, count1)``:
``count > 0`` makes the child a leaf over slots ``[ref, ref + count)``, ``count == 0`` an inner node ``ref``, and
``count < 0`` an empty child (only in the one-node tree made for a root leaf). Visiting a node reads both child
boxes at once, so a ray never fetches a node whose box it misses. Triangles are stored in slot (leaf) order next to
the nodes, as in the binary layout. ``convert_compact`` converts a tree on the host; ``device_compact_bvh`` converts
a tree where it was built (one prefix scan numbers the inner nodes, one kernel writes them), so a GPU-built tree
never leaves the GPU.

Traversal follows the binary one (nearer child first, entry distances on the stack, the same tie rule), so the
result is identical ray by ray.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from ..geometry import (
    box_origins,
    intersect_ray_box,
    intersect_ray_triangle,
    make_sheared_ray,
    ray_can_hit,
    safe_inverse,
)
from .common import read_int
from .layout import DeviceFlatBvh, FlatBvh, upload_triangles
from .stack import STACK_BUILD_OPTIONS, NodeStack
from .traverse import any_hit_kernel, closest_hit_kernels, reachable, reported_hit
from .turns import waits

# No FMA contraction, as in wrt/trace.py: on CUDA it fused the triangle test's distance (and ray_is_valid), so hits
# differed from the binary layout's and from the CPU's.
wp.set_module_options({"enable_backward": False, "fuse_fp": False, "extra_build_options": STACK_BUILD_OPTIONS})

COMPACT_NODE_BYTES = 64  # three vec4 of child bounds + one vec4i of child references


@wp.struct
class DeviceCompactBvh:
    """A CompactBvh and its triangles in device memory."""

    xy0: wp.array[wp.vec4]  # child 0 (lo.x, hi.x, lo.y, hi.y)
    xy1: wp.array[wp.vec4]  # child 1 (lo.x, hi.x, lo.y, hi.y)
    zz: wp.array[wp.vec4]  # (child 0 lo.z, hi.z, child 1 lo.z, hi.z)
    children: wp.array[wp.vec4i]  # (ref0, ref1, count0, count1)
    prim_ids: wp.array[wp.int32]  # slot -> triangle id
    v0: wp.array[wp.vec3]  # triangle vertices in slot order
    v1: wp.array[wp.vec3]
    v2: wp.array[wp.vec3]
    num_prims: int  # triangles in the tree; 0 means every ray misses


@dataclasses.dataclass
class CompactBvh:
    """Host form of the compact layout (see module docstring).

    Attributes:
        xy0: ``(K, 4)`` float32 child 0 x/y bounds of each inner node.
        xy1: ``(K, 4)`` float32 child 1 x/y bounds.
        zz: ``(K, 4)`` float32 z bounds of both children.
        children: ``(K, 4)`` int32 ``(ref0, ref1, count0, count1)``.
        prim_ids: ``(N,)`` int32 slot -> triangle id (the FlatBvh's).
    """

    xy0: np.ndarray
    xy1: np.ndarray
    zz: np.ndarray
    children: np.ndarray
    prim_ids: np.ndarray

    @property
    def num_nodes(self) -> int:
        """Number of (inner) nodes."""
        return len(self.children)

    @property
    def num_prims(self) -> int:
        """Number of triangles."""
        return len(self.prim_ids)

    @property
    def bytes(self) -> int:
        """Node bytes plus slot -> triangle id bytes (the triangles themselves not counted)."""
        return COMPACT_NODE_BYTES * self.num_nodes + 4 * self.num_prims

    def to_device(self, points: np.ndarray, indices: np.ndarray, device=None) -> DeviceCompactBvh:
        """Uploads the nodes and the triangles, in slot order, to ``device``."""
        device = wp.get_device(device)
        s = DeviceCompactBvh()
        s.xy0 = wp.array(self.xy0, dtype=wp.vec4, device=device)
        s.xy1 = wp.array(self.xy1, dtype=wp.vec4, device=device)
        s.zz = wp.array(self.zz, dtype=wp.vec4, device=device)
        s.children = wp.array(self.children, dtype=wp.vec4i, device=device)
        s.prim_ids, s.v0, s.v1, s.v2 = upload_triangles(self.prim_ids, points, indices, device)
        s.num_prims = self.num_prims
        return s


def convert_compact(bvh: FlatBvh) -> CompactBvh:
    """Converts the canonical layout into the compact one (inner nodes renumbered in their FlatBvh order)."""
    leaf = bvh.prim_count > 0
    inner = np.flatnonzero(~leaf)
    if bvh.num_prims == 0:
        z = np.zeros((0, 4), np.float32)
        return CompactBvh(z, z.copy(), z.copy(), np.zeros((0, 4), np.int32), bvh.prim_ids.copy())
    if len(inner) == 0:
        # A single leaf: one node whose second child is empty.
        lo, hi = bvh.lowers[0], bvh.uppers[0]
        xy0 = np.array([[lo[0], hi[0], lo[1], hi[1]]], np.float32)
        zz = np.array([[lo[2], hi[2], 0.0, 0.0]], np.float32)
        children = np.array([[bvh.left_first[0], -1, bvh.prim_count[0], -1]], np.int32)
        return CompactBvh(xy0, np.zeros((1, 4), np.float32), zz, children, bvh.prim_ids.copy())
    rank = np.full(bvh.num_nodes, -1, np.int64)
    rank[inner] = np.arange(len(inner))
    c0 = bvh.left_first[inner]
    c1 = c0 + 1
    lo0, hi0, lo1, hi1 = bvh.lowers[c0], bvh.uppers[c0], bvh.lowers[c1], bvh.uppers[c1]
    xy0 = np.stack([lo0[:, 0], hi0[:, 0], lo0[:, 1], hi0[:, 1]], 1)
    xy1 = np.stack([lo1[:, 0], hi1[:, 0], lo1[:, 1], hi1[:, 1]], 1)
    zz = np.stack([lo0[:, 2], hi0[:, 2], lo1[:, 2], hi1[:, 2]], 1)

    def ref(c):
        return np.where(leaf[c], bvh.left_first[c], rank[c])

    children = np.stack([ref(c0), ref(c1), bvh.prim_count[c0], bvh.prim_count[c1]], 1)
    return CompactBvh(
        xy0.astype(np.float32),
        xy1.astype(np.float32),
        zz.astype(np.float32),
        children.astype(np.int32),
        bvh.prim_ids.copy(),
    )


@wp.kernel
def _inner_flags_kernel(prim_count: wp.array[wp.int32], flags: wp.array[wp.int32]):
    i = wp.tid()
    flags[i] = wp.where(prim_count[i] == 0, 1, 0)


@wp.func
def _child_ref(c: int, left_first: wp.array[wp.int32], prim_count: wp.array[wp.int32], ranks: wp.array[wp.int32]):
    return wp.where(prim_count[c] > 0, left_first[c], ranks[c])


@wp.kernel
def _compact_nodes_kernel(
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    left_first: wp.array[wp.int32],
    prim_count: wp.array[wp.int32],
    ranks: wp.array[wp.int32],
    # outputs
    xy0: wp.array[wp.vec4],
    xy1: wp.array[wp.vec4],
    zz: wp.array[wp.vec4],
    children: wp.array[wp.vec4i],
):
    """Compact node ``ranks[i]`` from binary inner node ``i`` (``convert_compact``'s rule)."""
    i = wp.tid()
    if prim_count[i] > 0:
        return
    c0 = left_first[i]
    c1 = c0 + 1
    lo0, hi0, lo1, hi1 = lowers[c0], uppers[c0], lowers[c1], uppers[c1]
    k = ranks[i]
    xy0[k] = wp.vec4(lo0[0], hi0[0], lo0[1], hi0[1])
    xy1[k] = wp.vec4(lo1[0], hi1[0], lo1[1], hi1[1])
    zz[k] = wp.vec4(lo0[2], hi0[2], lo1[2], hi1[2])
    ref0 = _child_ref(c0, left_first, prim_count, ranks)
    ref1 = _child_ref(c1, left_first, prim_count, ranks)
    children[k] = wp.vec4i(ref0, ref1, prim_count[c0], prim_count[c1])


def device_compact_bvh(tree: DeviceFlatBvh, points: wp.array, indices: wp.array) -> DeviceCompactBvh:
    """The compact layout of a tree over at least one triangle, made where the tree lives (a GPU-built tree never
    leaves the GPU); ``points`` and ``indices`` are the build's, on the same device."""
    device = tree.left_first.device
    s = DeviceCompactBvh()
    s.prim_ids, s.v0, s.v1, s.v2 = tree.slot_triangles(points, indices)
    s.num_prims = len(tree.prim_ids)
    n = tree.num_nodes
    if n == 1:  # a root leaf: convert_compact's one-node tree
        host = convert_compact(tree.to_host())
        s.xy0, s.xy1, s.zz = (wp.array(a, dtype=wp.vec4, device=device) for a in (host.xy0, host.xy1, host.zz))
        s.children = wp.array(host.children, dtype=wp.vec4i, device=device)
        return s
    with wp.ScopedDevice(device):
        flags = wp.empty(n, dtype=wp.int32)
        ranks = wp.empty(n, dtype=wp.int32)
        wp.launch(_inner_flags_kernel, n, inputs=[tree.prim_count], outputs=[flags])
        wp.utils.array_scan(flags, ranks, inclusive=False)
        inner = read_int(ranks, n - 1) + read_int(flags, n - 1)
        s.xy0, s.xy1, s.zz = (wp.empty(inner, dtype=wp.vec4) for _ in range(3))
        s.children = wp.empty(inner, dtype=wp.vec4i)
        wp.launch(
            _compact_nodes_kernel,
            n,
            inputs=[tree.lowers, tree.uppers, tree.left_first, tree.prim_count, ranks],
            outputs=[s.xy0, s.xy1, s.zz, s.children],
        )
    return s


@wp.func
def root_reach(bvh: DeviceCompactBvh):
    """``geometry.box_reach`` of the tree's root box, the union of inner node 0's two child boxes (a root leaf's empty
    second child holds zeros), for ``box_origins``."""
    reach = float(0.0)
    a = bvh.xy0[0]
    b = bvh.xy1[0]
    z = bvh.zz[0]
    for k in range(4):
        reach = wp.max(reach, wp.max(wp.max(wp.abs(a[k]), wp.abs(b[k])), wp.abs(z[k])))
    return reach


@wp.func
def compact_intersect(bvh: DeviceCompactBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Closest hit with ``t_min <= t < t_max``.

    Returns:
        ``(t, u, v, prim, nodes_visited, triangles_tested)``; ``prim = -1`` and ``t = inf`` on a miss.
        ``nodes_visited`` counts inner nodes and leaves entered.
    """
    best_t = t_max
    best_slot = int(-1)
    nodes = int(0)
    tests = int(0)
    ray = make_sheared_ray(origin, direction)  # also for rays that cannot hit: reported_hit takes it
    if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, t_max):
        inv_dir = safe_inverse(direction)
        origin_lower, origin_upper = box_origins(origin, direction, root_reach(bvh))
        stack = NodeStack()
        top = int(0)
        ref = int(0)  # current node or leaf; the root is inner node 0
        count = int(0)
        while ref >= 0:
            if waits(count > 0):
                continue
            nodes += 1
            if count > 0:
                # Leaf: test its triangles, stored in slot order.
                for s in range(ref, ref + count):
                    tests += 1
                    hit, t, u, v = intersect_ray_triangle(ray, bvh.v0[s], bvh.v1[s], bvh.v2[s])
                    if hit and t >= t_min:
                        if t < best_t or (t == best_t and best_slot >= 0 and bvh.prim_ids[s] < bvh.prim_ids[best_slot]):
                            best_t = t
                            best_slot = s
                ref = -1
            else:
                # Inner node: both child boxes are here; go to the nearer child entered, push the other one.
                a = bvh.xy0[ref]
                b = bvh.xy1[ref]
                z = bvh.zz[ref]
                ch = bvh.children[ref]
                t0 = float(wp.inf)
                t1 = float(wp.inf)
                if ch[2] >= 0:
                    t0 = intersect_ray_box(
                        origin_lower, origin_upper, inv_dir, wp.vec3(a[0], a[2], z[0]),
                        wp.vec3(a[1], a[3], z[1]), t_min, best_t,
                    )
                if ch[3] >= 0:
                    t1 = intersect_ray_box(
                        origin_lower, origin_upper, inv_dir, wp.vec3(b[0], b[2], z[2]),
                        wp.vec3(b[1], b[3], z[3]), t_min, best_t,
                    )
                near_ref = ch[0]
                near_count = ch[2]
                far_ref = ch[1]
                far_count = ch[3]
                if t1 < t0:
                    near_ref = ch[1]
                    near_count = ch[3]
                    far_ref = ch[0]
                    far_count = ch[2]
                    tmp = t0
                    t0 = t1
                    t1 = tmp
                ref = -1
                if reachable(t0, best_t):
                    ref = near_ref
                    count = near_count
                    if reachable(t1, best_t):
                        wp.wrt_stack_push(stack, top, far_ref, far_count, t1)
                        top += 1
            # Pop the next node that may still hold a hit no farther than the best one.
            while ref < 0 and top > 0:
                top -= 1
                if wp.wrt_stack_t(stack, top) <= best_t:
                    ref = wp.wrt_stack_ref(stack, top)
                    count = wp.wrt_stack_count(stack, top)
    t, u, v, prim = reported_hit(ray, bvh.v0, bvh.v1, bvh.v2, bvh.prim_ids, best_slot, best_t)
    return t, u, v, prim, nodes, tests


@wp.func
def compact_occluded(bvh: DeviceCompactBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Any hit with ``t_min <= t < t_max``: True as soon as one is found."""
    found = bool(False)
    if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, t_max):
        ray = make_sheared_ray(origin, direction)
        inv_dir = safe_inverse(direction)
        origin_lower, origin_upper = box_origins(origin, direction, root_reach(bvh))
        stack = NodeStack()
        top = int(0)
        ref = int(0)
        count = int(0)
        while ref >= 0 and not found:
            if waits(count > 0):
                continue
            if count > 0:
                for s in range(ref, ref + count):
                    hit, t, u, v = intersect_ray_triangle(ray, bvh.v0[s], bvh.v1[s], bvh.v2[s])
                    if hit and t >= t_min and t < t_max:
                        found = True
                ref = -1
            else:
                a = bvh.xy0[ref]
                b = bvh.xy1[ref]
                z = bvh.zz[ref]
                ch = bvh.children[ref]
                t0 = float(wp.inf)
                t1 = float(wp.inf)
                if ch[2] >= 0:
                    t0 = intersect_ray_box(
                        origin_lower, origin_upper, inv_dir, wp.vec3(a[0], a[2], z[0]),
                        wp.vec3(a[1], a[3], z[1]), t_min, t_max,
                    )
                if ch[3] >= 0:
                    t1 = intersect_ray_box(
                        origin_lower, origin_upper, inv_dir, wp.vec3(b[0], b[2], z[2]),
                        wp.vec3(b[1], b[3], z[3]), t_min, t_max,
                    )
                near_ref = ch[0]
                near_count = ch[2]
                far_ref = ch[1]
                far_count = ch[3]
                if t1 < t0:
                    near_ref = ch[1]
                    near_count = ch[3]
                    far_ref = ch[0]
                    far_count = ch[2]
                    tmp = t0
                    t0 = t1
                    t1 = tmp
                ref = -1
                if t0 < wp.inf:
                    ref = near_ref
                    count = near_count
                    if t1 < wp.inf:
                        wp.wrt_stack_push(stack, top, far_ref, far_count, 0.0)
                        top += 1
            if ref < 0 and top > 0:
                top -= 1
                ref = wp.wrt_stack_ref(stack, top)
                count = wp.wrt_stack_count(stack, top)
    return found


trace_compact_kernel, trace_compact_kernel_uncounted = closest_hit_kernels(
    compact_intersect, DeviceCompactBvh, "trace_compact_kernel", __name__
)


occluded_compact_kernel = any_hit_kernel(compact_occluded, DeviceCompactBvh, "occluded_compact_kernel", __name__)
