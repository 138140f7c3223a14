"""Traversal of the flat binary BVH: closest hit (``bvh_intersect``) and any hit (``bvh_occluded``).

Both visit the nearer child first (ordered by box entry distance), keep the far child on a fixed stack of
``MAX_DEPTH`` entries (the builder guarantees the depth), and store each entry distance beside it so that a
popped node lying beyond the best hit so far is culled without touching memory. The stack is the uninitialised
:class:`wrt.bvh.stack.NodeStack`: a module whose kernels call these functions sets
``wp.set_module_options({"extra_build_options": STACK_BUILD_OPTIONS})``.

Tie rule: hits at exactly the same ``t`` are resolved towards the smaller triangle id, so the result does not
depend on the tree or the visiting order. Boxes are entered when their entry distance is ``<=`` the best ``t``
(not ``<``), which keeps ties reachable.
"""

import warp as wp

from ..floats import FLOAT32_MAX, unit_scales
from ..geometry import (
    ShearedRay,
    box_origins,
    box_reach,
    intersect_ray_box,
    intersect_ray_triangle,
    make_sheared_ray,
    ray_can_hit,
    safe_inverse,
)
from .layout import DeviceBvh
from .packed import load_child, load_link
from .stack import NodeStack
from .turns import waits
from .wide_cpu import on_cpu

# CUDA register cap of the trace and any-hit kernels of every layout: 64 registers give 4 blocks of 256 threads per
# SM where the compact kernel's 77 and the wide one's 70 gave 3. H200, against the uncapped kernels in one run:
# compact and wide incoherent +11-13%, binary unchanged (already 64), mixed on diffuse rays (GPU_NOTES.md, row 20).
# A layout's kernels may take another cap (``closest_hit_kernels``, ``any_hit_kernel``; the wide layouts' in wide.py).
TRACE_MAX_REGISTERS = 64
# CUDA threads per block of every trace and any-hit launch (wp.Mesh's too, so comparisons stay like for like). An SM
# keeps a block's registers until its slowest warp ends, and the rays of one block end far apart; with 64 threads a
# finished block is replaced sooner. H200, against Warp's default 256 (GPU_NOTES.md, row 48): BVH4 incoherent rays
# +7-8%, other ray kinds within 2%; the 1080p chess_set frame (TLAS) at half the camera distance 6.14 -> 5.88 ms;
# wp.Mesh +0-14%. Read at each launch (benchmarks override it). The CPU keeps Warp's default: there a block is a
# loop, and smaller ones only add overhead.
TRACE_BLOCK_DIM = 64


def trace_block_dim(device) -> int:
    """Threads per block of a trace or any-hit launch on ``device`` (see ``TRACE_BLOCK_DIM``)."""
    return TRACE_BLOCK_DIM if device.is_cuda else 256


@wp.func
def unit_ray(direction: wp.vec3, t_min: float, t_max: float):
    """``(direction * down, t_min / down, t_max / down, down)`` for the power of two ``down`` that brings the
    direction's largest component into ``[1, 2)``; a hit of that ray at ``t`` is one of the given ray at
    ``t * down``. Every trace and any-hit kernel starts from it (exact: ``wrt.floats``), because the slab test's
    constants assume such lengths: a zero component's inverse is 1e38 and, on the CPU, a ray in a box face plane was
    moved off it by 1e-18 (``geometry.box_origins``), so with a direction of length 1e-30 a triangle 1e-9 away
    (t = 1e21) lay beyond a flat slab's exit and was culled (the margin now follows the direction's length too).
    ``t_max`` is first capped at float32's largest value: a hit past it (a direction of length 1e-37 and a triangle
    100 away: t = 1e39) has no float32 ``t``, so it is a miss, to every kernel alike; uncapped, the scaled ray hit it
    and reported ``t * down = inf``."""
    down, up = unit_scales(direction)
    return direction * down, t_min * up, wp.min(t_max, FLOAT32_MAX) * up, down


def closest_hit_kernels(intersect, bvh_type, name: str, module: str, max_registers: int = TRACE_MAX_REGISTERS):
    """``(counted, uncounted)``: two kernels of ``module`` (whose build options they take) tracing the closest hit of
    every ray through ``intersect``, a layout's closest-hit function over a ``bvh_type``; named ``name`` and
    ``name + "_uncounted"``. The counted one writes (nodes visited, triangles tested) to ``costs``, the uncounted one
    leaves it untouched (see ``wrt.trace.Accelerator``). On CUDA they use at most ``max_registers`` registers."""

    def make(counted: bool):
        def trace_kernel(
            bvh: bvh_type,
            origins: wp.array[wp.vec3],
            directions: wp.array[wp.vec3],
            t_mins: wp.array[float],
            t_maxs: wp.array[float],
            # outputs
            ts: wp.array[float],
            us: wp.array[float],
            vs: wp.array[float],
            prims: wp.array[wp.int32],
            costs: wp.array[wp.vec2i],
        ):
            i = wp.tid()
            d, t_min, t_max, down = unit_ray(directions[i], t_mins[i], t_maxs[i])
            t, u, v, prim, nodes, tests = intersect(bvh, origins[i], d, t_min, t_max)
            ts[i] = t * down
            us[i] = u
            vs[i] = v
            prims[i] = prim
            if wp.static(counted):
                costs[i] = wp.vec2i(nodes, tests)

        kernel_name = name if counted else f"{name}_uncounted"
        return wp.kernel(trace_kernel, name=kernel_name, module=module, cuda_max_registers=max_registers)

    return make(True), make(False)


def any_hit_kernel(occluded, bvh_type, name: str, module: str, max_registers: int = TRACE_MAX_REGISTERS):
    """A kernel of ``module`` (whose build options it takes), named ``name``, writing 1 for every ray that
    ``occluded`` (a layout's any-hit function over a ``bvh_type``) finds blocked in ``[t_min, t_max)``, else 0; on
    CUDA it uses at most ``max_registers`` registers."""

    def occluded_kernel(
        bvh: bvh_type,
        origins: wp.array[wp.vec3],
        directions: wp.array[wp.vec3],
        t_mins: wp.array[float],
        t_maxs: wp.array[float],
        # outputs
        blocked: wp.array[wp.int32],
    ):
        i = wp.tid()
        d, t_min, t_max, down = unit_ray(directions[i], t_mins[i], t_maxs[i])
        blocked[i] = wp.where(occluded(bvh, origins[i], d, t_min, t_max), 1, 0)

    return wp.kernel(occluded_kernel, name=name, module=module, cuda_max_registers=max_registers)


@wp.func
def order_pair(
    first: int,
    lower0: wp.vec3,
    upper0: wp.vec3,
    lower1: wp.vec3,
    upper1: wp.vec3,
    origin_lower: wp.vec3,
    origin_upper: wp.vec3,
    inv_dir: wp.vec3,
    t_min: float,
    t_max: float,
):
    """The children ``first`` and ``first + 1`` of a binary node, with boxes ``(lower0, upper0)`` and
    ``(lower1, upper1)``, nearer entry first (the ray as for ``intersect_ray_box``).

    Returns:
        ``(near, far, t_near, t_far)``; an entry distance is ``inf`` when the ray misses that child's box.
    """
    near = first
    far = first + 1
    t_near = intersect_ray_box(origin_lower, origin_upper, inv_dir, lower0, upper0, t_min, t_max)
    t_far = intersect_ray_box(origin_lower, origin_upper, inv_dir, lower1, upper1, t_min, t_max)
    if t_far < t_near:
        near = first + 1
        far = first
        tmp = t_near
        t_near = t_far
        t_far = tmp
    return near, far, t_near, t_far


@wp.func
def order_children(
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    first: int,
    origin_lower: wp.vec3,
    origin_upper: wp.vec3,
    inv_dir: wp.vec3,
    t_min: float,
    t_max: float,
):
    """``order_pair`` with the children's boxes read from ``lowers`` and ``uppers``."""
    return order_pair(first, lowers[first], uppers[first], lowers[first + 1], uppers[first + 1], origin_lower,
                      origin_upper, inv_dir, t_min, t_max)


@wp.func
def node_box(bvh: DeviceBvh, node: int):
    """``(lower, upper)`` of a node, from the arrays of the device the code runs on (``DeviceBvh.nodes``)."""
    if on_cpu():
        return bvh.lowers[node], bvh.uppers[node]
    lower, upper, link = load_child(bvh.nodes, node)
    return lower, upper


@wp.func
def node_link(bvh: DeviceBvh, node: int):
    """``(left_first, prim_count)`` of a node: on CUDA the second of its two records, one 16-byte load."""
    if on_cpu():
        return bvh.left_first[node], bvh.prim_count[node]
    link = load_link(bvh.nodes, node)
    return link[0], link[1]


@wp.func
def order_bvh_children(
    bvh: DeviceBvh,
    first: int,
    origin_lower: wp.vec3,
    origin_upper: wp.vec3,
    inv_dir: wp.vec3,
    t_min: float,
    t_max: float,
):
    """``order_pair`` of a binary node of ``bvh``, its children's boxes read by ``node_box``."""
    lower0, upper0 = node_box(bvh, first)
    lower1, upper1 = node_box(bvh, first + 1)
    return order_pair(first, lower0, upper0, lower1, upper1, origin_lower, origin_upper, inv_dir, t_min, t_max)


@wp.func
def reachable(t_entry: float, best_t: float):
    """A box entered at ``t_entry`` (``inf`` = missed) may hold a hit that wins against ``best_t``."""
    return t_entry < wp.inf and t_entry <= best_t


@wp.func
def reported_hit(
    ray: ShearedRay,
    v0: wp.array[wp.vec3],
    v1: wp.array[wp.vec3],
    v2: wp.array[wp.vec3],
    prim_ids: wp.array[wp.int32],
    best_slot: int,
    best_t: float,
):
    """``(t, u, v, prim)`` of a closest-hit traversal that ended with the triangle in slot ``best_slot`` at
    ``best_t`` (``-1``: a miss, ``t = inf``). The traversal keeps only the slot and ``t``; the barycentrics are
    computed again here by the same deterministic test, bit for bit the ones it found, so two fewer values stay live
    through the loop (H200, with the uncounted kernels of ``wrt.trace.Accelerator``: BVH4 closest hit +6-8% on
    diffuse and incoherent rays; GPU_NOTES.md rows 37-38)."""
    t = float(wp.inf)
    u = float(0.0)
    v = float(0.0)
    prim = int(-1)
    if best_slot >= 0:
        hit, t_again, u, v = intersect_ray_triangle(ray, v0[best_slot], v1[best_slot], v2[best_slot])
        t = best_t
        prim = prim_ids[best_slot]
    return t, u, v, prim


@wp.func
def bvh_intersect(bvh: DeviceBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Closest hit with ``t_min <= t < t_max``.

    Returns:
        ``(t, u, v, prim, nodes_visited, triangles_tested)``; ``prim = -1`` and ``t = inf`` on a miss.
    """
    best_t = t_max
    best_slot = int(-1)
    nodes = int(0)
    tests = int(0)
    ray = make_sheared_ray(origin, direction)  # also for rays that cannot hit: reported_hit takes it
    if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, t_max):
        inv_dir = safe_inverse(direction)
        root_lower, root_upper = node_box(bvh, 0)
        origin_lower, origin_upper = box_origins(origin, direction, box_reach(root_lower, root_upper))
        stack = NodeStack()
        top = int(0)
        node = int(-1)
        root = intersect_ray_box(origin_lower, origin_upper, inv_dir, root_lower, root_upper, t_min, best_t)
        if reachable(root, best_t):
            node = 0
        while node >= 0:
            first, count = node_link(bvh, node)
            if waits(count > 0):
                continue
            nodes += 1
            if count > 0:
                # Leaf: test its triangles, stored in slot order.
                for s in range(first, first + count):
                    tests += 1
                    hit, t, u, v = intersect_ray_triangle(ray, bvh.v0[s], bvh.v1[s], bvh.v2[s])
                    if hit and t >= t_min:
                        if t < best_t or (t == best_t and best_slot >= 0 and bvh.prim_ids[s] < bvh.prim_ids[best_slot]):
                            best_t = t
                            best_slot = s
                node = -1
            else:
                # Inner node: go to the nearer child that the ray enters, push the other one.
                left, right, t_left, t_right = order_bvh_children(
                    bvh, first, origin_lower, origin_upper, inv_dir, t_min, best_t
                )
                node = -1
                if reachable(t_left, best_t):
                    node = left
                    if reachable(t_right, best_t):
                        wp.wrt_stack_push(stack, top, right, t_right)
                        top += 1
            # Pop the next node that may still hold a hit no farther than the best one.
            while node < 0 and top > 0:
                top -= 1
                if wp.wrt_stack_t(stack, top) <= best_t:
                    node = wp.wrt_stack_ref(stack, top)
    t, u, v, prim = reported_hit(ray, bvh.v0, bvh.v1, bvh.v2, bvh.prim_ids, best_slot, best_t)
    return t, u, v, prim, nodes, tests


@wp.func
def bvh_occluded(bvh: DeviceBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Any hit with ``t_min <= t < t_max``: True as soon as one is found."""
    found = bool(False)
    if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, t_max):
        ray = make_sheared_ray(origin, direction)
        inv_dir = safe_inverse(direction)
        root_lower, root_upper = node_box(bvh, 0)
        origin_lower, origin_upper = box_origins(origin, direction, box_reach(root_lower, root_upper))
        stack = NodeStack()
        top = int(0)
        node = int(-1)
        if intersect_ray_box(origin_lower, origin_upper, inv_dir, root_lower, root_upper, t_min, t_max) < wp.inf:
            node = 0
        while node >= 0 and not found:
            first, count = node_link(bvh, node)
            if waits(count > 0):
                continue
            if count > 0:
                for s in range(first, first + count):
                    hit, t, u, v = intersect_ray_triangle(ray, bvh.v0[s], bvh.v1[s], bvh.v2[s])
                    if hit and t >= t_min and t < t_max:
                        found = True
                node = -1
            else:
                left, right, t_left, t_right = order_bvh_children(
                    bvh, first, origin_lower, origin_upper, inv_dir, t_min, t_max
                )
                node = -1
                if t_left < wp.inf:
                    node = left
                    if t_right < wp.inf:
                        wp.wrt_stack_push(stack, top, right)
                        top += 1
            if node < 0 and top > 0:
                top -= 1
                node = wp.wrt_stack_ref(stack, top)
    return found
