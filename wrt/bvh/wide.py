"""Wide layout: BVH4 or BVH8 collapsed from the canonical binary tree (Wald et al., "Getting Rid of Packets",
2008; Ernst and Greiner, "Multi Bounding Volume Hierarchies", 2008; tinybvh's ``BVH4``/``BVH8`` conversions).

Collapse by SAH (Ylitie et al. 2017, section 3.1): binary leaves stay leaves, and each binary inner node is either a
wide node or opened into its parent's wide node, whose children it then shares. Of all such collapses that give no
wide node more than ``width`` children, the conversion takes one with the least summed surface area of wide nodes,
the SAH term ``C_t A(n) / A(root)`` of the node visits, found by dynamic programming over the binary tree. (The
greedy rule that opens the inner child of largest area first visits up to 3% more nodes per ray and makes 1.2-1.8x
as many wide nodes: GPU_NOTES.md, row 56.) The conversion runs as Warp kernels, a bottom-up pass and a few launches
per wide level (``collapse.py``), on the host CPU or where a GPU-built tree already lives.

Storage has ``width`` child slots per node: a child box and a link ``(ref, count)``, where ``count > 0`` is a leaf
over slots ``[ref, ref + count)``, ``count == 0`` an inner wide node ``ref`` and ``count < 0`` an empty slot.
Triangles are stored in slot (leaf) order next to the nodes. On the device the slots take the form its traversal
reads fastest (``DeviceWideBvh``): on CUDA two 16-byte records per slot (``packed.py``), read in a loop over the
children that is unrolled (one kernel per width), so a node's loads are issued together.

Traversal tests all child boxes of a node (on the CPU all at once, with vector instructions: ``wide_cpu.py``) and
continues with the nearest entered child. The others are pushed far to near, except by a BVH8 node on CUDA, which
pushes them unsorted (``ORDERED_PUSH_WIDTH``); every entry keeps its entry distance for the cull on pop. Each wide
level pushes at most ``width - 1`` entries, and the wide tree is no deeper than the binary one, so a stack of
``8 * MAX_DEPTH`` entries suffices for both widths. Tie rule and culling are the binary traversal's, so results
agree ray by ray.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from ..geometry import (
    box_origins,
    box_reach,
    intersect_ray_box,
    intersect_ray_triangle,
    make_sheared_ray,
    ray_can_hit,
    safe_inverse,
)
from .collapse import collapse_wide
from .layout import DeviceFlatBvh, FlatBvh, upload_triangles
from .packed import load_child, load_link, pack_child
from .stack import WIDE_STACK, WideStack
from .traverse import TRACE_MAX_REGISTERS, any_hit_kernel, closest_hit_kernels, reachable, reported_hit
from .turns import waits
from .wide_cpu import BOX_PLANES, WIDE_BUILD_OPTIONS, device_links, device_node_boxes, on_cpu

# No FMA contraction, as in wrt/trace.py: on CUDA it fused the triangle test's distance (and ray_is_valid), so hits
# differed from the binary layout's and from the CPU's.
wp.set_module_options({"enable_backward": False, "fuse_fp": False, "extra_build_options": WIDE_BUILD_OPTIONS})

WIDE_WIDTHS = {"wide": 4, "wide8": 8}  # layout name -> children per node
# CUDA closest hit: nodes up to this width push their entered children far to near, each at its rank by entry
# distance; wider nodes continue with the nearest child and push the others unsorted, in reverse slot order (ranking
# eight children spilled registers, and an insertion sort in local memory was slow). With the nearest first, BVH8
# gained 3-39% on an H200 and its rays visit 0-8% more nodes (GPU_NOTES.md, row 51). The CPU sorts at every width:
# there the sort is cheap and the extra nodes cost BVH8 6-21%, so CPU and CUDA BVH8 visit different node counts
# (the same hits).
ORDERED_PUSH_WIDTH = 4
# CUDA register caps of the wide kernels where they differ from TRACE_MAX_REGISTERS (64), for 24 warps per SM
# instead of 32. BVH4 any hit: 80, where it uses 75 (no spills at 64 either); two H200 runs against 64: shadow rays
# chess_set 1.01, displaced sphere 1.04-1.05. At 80 the SASS issues a node's eight 16-byte child loads in one group
# instead of two (the same grouping did not help the BVH4 closest hit at 64: GPU_NOTES.md, row 50). BVH8 closest
# and any hit: 80 (spills 104 -> 28 B and 36 -> 0 B); one H200 run against 64: closest hit 0.97-1.11, any hit
# 0.99-1.08 (row 51). The binary and compact any-hit kernels lost 0-1% and 7-16% at 80 and keep 64 (row 49).
ANY_HIT_MAX_REGISTERS = {4: 80, 8: 80}
CLOSEST_HIT_MAX_REGISTERS = {8: 80}
WIDE_CHILD_BYTES = 32  # child lower (12) + upper (12) + ref (4) + count (4)


@wp.struct
class DeviceWideBvh:
    """A WideBvh and its triangles in device memory, stored in the form the device's traversal reads fastest (the
    other device's arrays hold one dummy entry)."""

    # CPU: child boxes as six runs of ``width`` floats per node, for its vector instructions (``wide_cpu``), and
    # links per child slot ``(wide node or first triangle slot, triangle count; 0 inner, -1 empty)``.
    boxes: wp.array[float]
    links: wp.array[wp.vec2i]
    # CUDA: per child slot two records, box and link, each read in one 16-byte load (``packed``).
    children: wp.array[wp.vec4]
    width: int  # child slots per node: 4 or 8
    prim_ids: wp.array[wp.int32]  # slot -> triangle id
    v0: wp.array[wp.vec3]  # triangle corners in slot order
    v1: wp.array[wp.vec3]
    v2: wp.array[wp.vec3]
    num_prims: int  # triangles in the tree; 0 means every ray misses


@dataclasses.dataclass
class WideBvh:
    """Host form of the wide layout (see module docstring).

    Attributes:
        lowers: ``(K * width, 3)`` float32 child box minima; child ``j`` of node ``k`` is entry ``k * width + j``.
        uppers: ``(K * width, 3)`` float32 child box maxima.
        refs: ``(K * width,)`` int32 child references.
        counts: ``(K * width,)`` int32 child triangle counts (0 inner, -1 empty).
        width: children per node, 4 or 8.
        depth: deepest wide level (root 0).
        prim_ids: ``(N,)`` int32 slot -> triangle id (the FlatBvh's).
    """

    lowers: np.ndarray
    uppers: np.ndarray
    refs: np.ndarray
    counts: np.ndarray
    width: int
    depth: int
    prim_ids: np.ndarray

    @property
    def num_nodes(self) -> int:
        """Number of wide nodes."""
        return len(self.refs) // self.width

    @property
    def num_prims(self) -> int:
        """Number of triangles."""
        return len(self.prim_ids)

    @property
    def bytes(self) -> int:
        """Node bytes plus slot -> triangle id bytes (the triangles themselves not counted)."""
        return WIDE_CHILD_BYTES * len(self.refs) + 4 * self.num_prims

    def fill(self) -> float:
        """Mean fraction of child slots in use."""
        return float((self.counts >= 0).mean()) if len(self.counts) else 0.0

    def to_device(self, points: np.ndarray, indices: np.ndarray, device=None) -> DeviceWideBvh:
        """Uploads the nodes and the triangles, in slot order, to ``device``."""
        device = wp.get_device(device)
        s = DeviceWideBvh()
        lowers, uppers = (self.lowers, self.uppers) if len(self.refs) else (np.zeros((self.width, 3), np.float32),) * 2
        links = np.stack([self.refs, self.counts], 1) if len(self.refs) else np.array([[0, -1]] * self.width)
        s.width = int(self.width)
        boxes = wp.array(lowers, dtype=wp.vec3, device=device), wp.array(uppers, dtype=wp.vec3, device=device)
        _store_children(s, *boxes, wp.array(links.astype(np.int32), dtype=wp.vec2i, device=device))
        s.prim_ids, s.v0, s.v1, s.v2 = upload_triangles(self.prim_ids, points, indices, device)
        s.num_prims = self.num_prims
        return s


def convert_wide(bvh: FlatBvh, width: int = 4) -> WideBvh:
    """Collapses the canonical binary tree into a ``width``-wide one (see module docstring), on the host CPU."""
    _check_width(width)
    if bvh.num_prims == 0:
        z = np.zeros((0, 3), np.float32)
        return WideBvh(z, z.copy(), np.zeros(0, np.int32), np.zeros(0, np.int32), width, 0, bvh.prim_ids.copy())
    binary = [
        wp.array(bvh.lowers, dtype=wp.vec3, device="cpu"),
        wp.array(bvh.uppers, dtype=wp.vec3, device="cpu"),
        wp.array(bvh.left_first, dtype=wp.int32, device="cpu"),
        wp.array(bvh.prim_count, dtype=wp.int32, device="cpu"),
    ]
    lowers, uppers, refs, counts, depth = _collapse(binary, width)
    return WideBvh(
        lowers=lowers.numpy().reshape(-1, 3),
        uppers=uppers.numpy().reshape(-1, 3),
        refs=refs.numpy(),
        counts=counts.numpy(),
        width=width,
        depth=depth,
        prim_ids=bvh.prim_ids.copy(),
    )


def device_wide_bvh(tree: DeviceFlatBvh, points: wp.array, indices: wp.array, width: int) -> DeviceWideBvh:
    """The wide layout of a tree over at least one triangle, made where the tree lives (a GPU-built tree never
    leaves the GPU); ``points`` and ``indices`` are the build's, on the same device."""
    _check_width(width)
    s = DeviceWideBvh()
    lowers, uppers, refs, counts, _ = _collapse([tree.lowers, tree.uppers, tree.left_first, tree.prim_count], width)
    s.width = int(width)
    _store_children(s, lowers, uppers, device_links(refs, counts))
    s.prim_ids, s.v0, s.v1, s.v2 = tree.slot_triangles(points, indices)
    s.num_prims = len(tree.prim_ids)
    return s


def _store_children(bvh: DeviceWideBvh, lowers: wp.array, uppers: wp.array, links: wp.array) -> None:
    """Stores the ``(K * width)`` child slots in ``bvh`` in the form its device traverses (see ``DeviceWideBvh``)."""
    device = lowers.device
    if device.is_cpu:
        bvh.boxes = device_node_boxes(lowers, uppers, bvh.width)
        bvh.links = links
        bvh.children = wp.zeros(1, dtype=wp.vec4, device=device)
    else:
        bvh.boxes = wp.zeros(1, dtype=float, device=device)
        bvh.links = wp.zeros(1, dtype=wp.vec2i, device=device)
        bvh.children = wp.empty(2 * len(lowers), dtype=wp.vec4, device=device)
        wp.launch(_pack_children, len(lowers), inputs=[lowers, uppers, links], outputs=[bvh.children], device=device)


@wp.func
def root_reach(bvh: DeviceWideBvh):
    """``geometry.box_reach`` of the tree's root box, the union of wide node 0's child boxes (the empty slots' are
    infinite and left out), for ``box_origins``: on the CPU from its box runs (``wide_cpu``), on CUDA from its child
    records."""
    reach = float(0.0)
    if on_cpu():
        for k in range(BOX_PLANES * bvh.width):
            x = wp.abs(bvh.boxes[k])
            if x < wp.inf:
                reach = wp.max(reach, x)
    else:
        for j in range(bvh.width):
            lower, upper, link = load_child(bvh.children, j)
            r = box_reach(lower, upper)
            if r < wp.inf:
                reach = wp.max(reach, r)
    return reach


@wp.kernel
def _pack_children(
    lowers: wp.array[wp.vec3], uppers: wp.array[wp.vec3], links: wp.array[wp.vec2i], children: wp.array[wp.vec4]
):
    """The CUDA child records. The CUDA traversal tests every slot's box before it reads the link, so an empty slot
    gets the box at (+inf, +inf, +inf), which every slab test misses (on each axis entry and exit are both +inf or
    both -inf); the collapse's inverted empty box would span every slab."""
    i = wp.tid()
    lower = lowers[i]
    upper = uppers[i]
    if links[i][1] < 0:
        lower = wp.vec3(wp.inf)
        upper = wp.vec3(wp.inf)
    pack_child(children, i, lower, upper, links[i])


def _check_width(width: int) -> None:
    if width not in (4, 8):
        raise ValueError(f"wide layout width must be 4 or 8, got {width}")


def _collapse(binary: list, width: int) -> tuple:
    lowers, uppers, refs, counts, depth = collapse_wide(*binary, width)
    assert (width - 1) * depth + width <= WIDE_STACK, "wide tree deeper than the traversal stack"
    return lowers, uppers, refs, counts, depth


def _traversal_kernels(width: int) -> tuple:
    """``(trace_kernel, uncounted_trace_kernel, occluded_kernel)`` of the wide layout of ``width``: on CUDA the loop
    over a node's children is unrolled (a compile-time width), so the loads of all child boxes can be issued
    together. The uncounted trace kernel does not count each ray's traversal cost."""

    EntryVec = wp.types.vector(width, float)

    def wide_intersect(bvh: DeviceWideBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
        """Closest hit with ``t_min <= t < t_max``.

        Returns:
            ``(t, u, v, prim, nodes_visited, triangles_tested)``; ``prim = -1`` and ``t = inf`` on a miss.
            ``nodes_visited`` counts wide nodes and leaves entered.
        """
        best_t = t_max
        best_slot = int(-1)
        nodes = int(0)
        tests = int(0)
        ray = make_sheared_ray(origin, direction)  # also for rays that cannot hit: reported_hit takes it
        if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, t_max):
            inv_dir = safe_inverse(direction)
            origin_lower, origin_upper = box_origins(origin, direction, root_reach(bvh))
            stack = WideStack()
            top = int(0)
            ref = int(0)  # current wide node or leaf; the root is wide node 0
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
                            tie = t == best_t and best_slot >= 0 and bvh.prim_ids[s] < bvh.prim_ids[best_slot]
                            if t < best_t or tie:
                                best_t = t
                                best_slot = s
                    ref = -1
                elif on_cpu():
                    step = wp.wrt_wide_enter(
                        bvh.boxes, bvh.links, ref, bvh.width, origin_lower, origin_upper, inv_dir, t_min,
                        best_t, stack, top, True,
                    )
                    ref = step[0]
                    count = step[1]
                    top = step[2]
                elif wp.static(width <= ORDERED_PUSH_WIDTH):
                    # Wide node: test every child box, then push the entered children far to near, each at its rank
                    # by entry distance (ties by slot), and continue with the nearest: no sort buffer in local memory.
                    entry = EntryVec()
                    node = ref
                    for j in range(wp.static(width)):
                        lower, upper, link = load_child(bvh.children, node * width + j)
                        entry[j] = intersect_ray_box(origin_lower, origin_upper, inv_dir, lower, upper, t_min, best_t)
                    m = int(0)
                    for j in range(wp.static(width)):
                        if reachable(entry[j], best_t):
                            m += 1
                    ref = -1
                    for j in range(wp.static(width)):
                        if reachable(entry[j], best_t):
                            rank = int(0)
                            for i in range(wp.static(width)):
                                if wp.static(i < j):
                                    if entry[i] <= entry[j]:
                                        rank += 1
                                elif wp.static(i > j):
                                    if entry[i] < entry[j]:
                                        rank += 1
                            # The link is read again (an L1 hit) rather than kept in registers through the ranking.
                            link = load_link(bvh.children, node * width + j)
                            if rank == 0:
                                ref = link[0]
                                count = link[1]
                            else:
                                wp.wrt_stack_push(stack, top + m - 1 - rank, link[0], link[1], entry[j])
                    top += wp.max(m - 1, 0)
                else:
                    # Wider nodes: continue with the nearest entered child (the first slot of least entry distance)
                    # and push the others in reverse slot order, unsorted, each with its entry distance for the cull
                    # on pop (see ORDERED_PUSH_WIDTH).
                    entry = EntryVec()
                    node = ref
                    for j in range(wp.static(width)):
                        lower, upper, link = load_child(bvh.children, node * width + j)
                        entry[j] = intersect_ray_box(origin_lower, origin_upper, inv_dir, lower, upper, t_min, best_t)
                    nearest = int(-1)
                    nearest_t = float(wp.inf)
                    for j in range(wp.static(width)):
                        if reachable(entry[j], best_t) and entry[j] < nearest_t:
                            nearest = j
                            nearest_t = entry[j]
                    ref = -1
                    for j in range(wp.static(width - 1), -1, -1):
                        if j != nearest and reachable(entry[j], best_t):
                            link = load_link(bvh.children, node * width + j)
                            wp.wrt_stack_push(stack, top, link[0], link[1], entry[j])
                            top += 1
                    if nearest >= 0:
                        link = load_link(bvh.children, node * width + nearest)
                        ref = link[0]
                        count = link[1]
                # Pop the next node that may still hold a hit no farther than the best one.
                while ref < 0 and top > 0:
                    top -= 1
                    if wp.wrt_stack_t(stack, top) <= best_t:
                        ref = wp.wrt_stack_ref(stack, top)
                        count = wp.wrt_stack_count(stack, top)
        t, u, v, prim = reported_hit(ray, bvh.v0, bvh.v1, bvh.v2, bvh.prim_ids, best_slot, best_t)
        return t, u, v, prim, nodes, tests

    def wide_occluded(bvh: DeviceWideBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
        """Any hit with ``t_min <= t < t_max``: True as soon as one is found."""
        found = bool(False)
        if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, t_max):
            ray = make_sheared_ray(origin, direction)
            inv_dir = safe_inverse(direction)
            origin_lower, origin_upper = box_origins(origin, direction, root_reach(bvh))
            stack = WideStack()
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
                elif on_cpu():
                    step = wp.wrt_wide_enter(
                        bvh.boxes, bvh.links, ref, bvh.width, origin_lower, origin_upper, inv_dir, t_min,
                        t_max, stack, top, False,
                    )
                    ref = -1
                    top = step[2]
                else:
                    # Any hit: no ordering needed; push every entered child.
                    node = ref
                    ref = -1
                    for j in range(wp.static(width)):
                        c = node * width + j
                        lower, upper, link = load_child(bvh.children, c)
                        t = intersect_ray_box(origin_lower, origin_upper, inv_dir, lower, upper, t_min, t_max)
                        if t < wp.inf:
                            wp.wrt_stack_push(stack, top, link[0], link[1], 0.0)
                            top += 1
                if ref < 0 and top > 0:
                    top -= 1
                    ref = wp.wrt_stack_ref(stack, top)
                    count = wp.wrt_stack_count(stack, top)
        return found

    def named(fn, suffix):
        # Warp keys functions and kernels by their qualified name: the two widths' copies need different ones.
        fn.__name__ = fn.__qualname__ = f"{fn.__name__}{suffix}"
        return fn

    wide_intersect = wp.func(named(wide_intersect, width))
    wide_occluded = wp.func(named(wide_occluded, width))
    name = f"trace_wide_kernel{width}"
    closest_cap = CLOSEST_HIT_MAX_REGISTERS.get(width, TRACE_MAX_REGISTERS)
    trace, uncounted = closest_hit_kernels(wide_intersect, DeviceWideBvh, name, __name__, closest_cap)
    any_cap = ANY_HIT_MAX_REGISTERS.get(width, TRACE_MAX_REGISTERS)
    occluded = any_hit_kernel(wide_occluded, DeviceWideBvh, f"occluded_wide_kernel{width}", __name__, any_cap)
    return trace, uncounted, occluded


WIDE_KERNELS = {width: _traversal_kernels(width) for width in sorted(set(WIDE_WIDTHS.values()))}
