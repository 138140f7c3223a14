"""Two-level acceleration: a top-level BVH (TLAS) over instances, each pointing at a bottom-level BVH (BLAS).

Every prototype gets one BLAS, built once in prototype space however many instances draw it (about its box's centre
where that box lies far off the prototype's origin, :func:`blas_centres`; and a scaled copy per other power of two
its instances need, below); the non-instanced meshes of the scene form one more BLAS, in world space. The TLAS is
a :class:`wrt.bvh.FlatBvh` over the world boxes of its *entries*: one per instance (its prototype's BLAS and its
world-to-prototype transform) plus one for the world-space BLAS. It is built by the same builders as any BVH: each
entry is handed over as a degenerate triangle ``(lower, upper, lower)``, whose box is the entry's box and whose
centroid is the box centre.

Traversal (:func:`tlas_intersect`) walks the TLAS in world space; at a leaf it transforms the ray into each entry's
space by the inverse transform (origin as a point, direction as a vector, not renormalised, so ``t`` is the same in
both spaces) and runs the ordinary :func:`wrt.bvh.traverse.bvh_intersect` on the entry's BLAS with ``t_max`` set to
the best hit so far. An instance's ray first has its origin moved along it to near the instance (``t0``,
:func:`entry_ray`), its limits moved with it (:func:`shifted_limit`), and its hits reported at ``t0 + t``: moved
from far away, a stretched instance's local origin lost more than the instance's size to rounding. This is the
lecture's "transform the ray, not the primitive", and Wald et al., "Ray tracing
animated scenes using coherent grid traversal"/"two-level BVH" as in every production ray tracer (pbrt-v4
``Transform``/``BVHAggregate`` over instances, Embree/OptiX instance acceleration structures).

Analytic shapes (:mod:`wrt.primitives`) are entries of their own, one per shape and instance: the entry holds the
world-to-canonical transform (the instance's and the shape's composed; an instanced shape's placed relative to its
instance's origin, :func:`shape_entry_transforms`) and is intersected by :func:`wrt.primitives.intersect_shape` at
the TLAS leaf, with no BLAS.

Hits report the geometry id of the triangle or shape (:meth:`wrt.Scene.geometry` row, so prototype triangles appear
once; shapes after the triangles) and the instance (-1 for world-space geometry). Shape hits carry the
pseudo-barycentrics of :func:`wrt.primitives.shape_uv` (1/3 each on curved surfaces). Exact ties between the
triangles of two entries go to the smaller instance (world-space geometry first), as the rows of
``Scene.triangles()`` order them; a tie between a shape and a triangle or another shape is not ordered (a shape
entered after a tied hit does not take it; a triangle of a smaller instance than a shape's does).

An instance scaled past ``2^100`` (or below ``2^-100``) is traced in a copy of its prototype's BLAS scaled by the power
of two that undoes its scale (:func:`instance_exponents`): moved into its own space, a ray's direction is as long as
the inverse scale, and at 1e36 its components below 1e-38 (the box test's zero) were 1% of it, at 3e-39 it overflowed.

Memory: the TLAS nodes, one world-to-prototype 3x4 float32 matrix (48 bytes) and two int32 per instance (and 24
bytes more where a prototype's BLAS is built about its centre, :func:`blas_centres`); the unique
triangles once per prototype, plus once more per other power of two its instances are traced at (only instances
scaled past ``2^100`` or below ``2^-100`` ask for one: :func:`blas_parts`); see
:meth:`InstancedAccelerator.device_bytes`.
"""

from __future__ import annotations

import time

import numpy as np
import warp as wp

from .bvh import DeviceBvh, build_bvh, traverse
from .bvh.batched import BATCH_MAX_TRIANGLES
from .bvh.build import build_bvhs
from .bvh.layout import upload_many
from .bvh.stack import STACK_BUILD_OPTIONS, NodeStack
from .bvh.traverse import (
    any_hit_kernel,
    bvh_intersect,
    bvh_occluded,
    node_box,
    order_children,
    reachable,
    unit_ray,
)
from .bvh.turns import waits
from .floats import FLOAT32_MAX, largest_magnitude, next_up, unit_scales
from .geometry import box_origins, box_reach, intersect_ray_box, ray_can_hit, safe_inverse
from .instancing import device_transforms, invert_transforms, thicken_flat_transforms, world_boxes
from .primitives import SHAPE_CAPSULE, SHAPE_TAPERED, intersect_shape, local_boxes, shape_uv
from .scene import Scene, of_one_state
from .trace import Accelerator, HitBuffer, accelerator_build_options, check_finite_transforms
from .transforms import linear_part, mat34, transform_vector, translation
from .unique import sorted_unique

wp.set_module_options({"fuse_fp": False})  # bit-identical hits on every device: see the note in wrt/trace.py
wp.set_module_options({"enable_backward": False})  # no adjoint code: nothing differentiates a trace (wrt/trace.py)

wp.set_module_options({"extra_build_options": STACK_BUILD_OPTIONS})  # the traversal stack type's C++ code

# CUDA register cap of the TLAS trace kernels, which take 221 registers uncapped (one block per SM). A 1080p chess_set
# frame on an H200: uncapped 14.9 ms, 128: 8.9, 64: 6.9, 48: 7.7, 32: 12.4 (benchmarks/GPU_NOTES.md, row 9a).
TLAS_MAX_REGISTERS = 64
TLAS_LEAF_SIZE = 2  # most entries per TLAS leaf (each costs a BLAS traversal, so leaves stay small)
TLAS_INTERSECTION_COST = 4.0  # SAH cost of entering an entry relative to visiting a TLAS node
# An instance whose world-to-local matrix has its largest entry beyond 2^+-EXTREME_EXPONENT is traced at its own scale
# (instance_exponents): within it, a local direction's components below 1e-38, which the box test takes as 0, are
# below 2^-100 of its length, far below float32's precision.
EXTREME_EXPONENT = 100
SCALED_REACH = 125  # a scaled prototype's points stay within 2^125 (4.3e37), where the triangle test's differences fit


@wp.struct
class DeviceTlas:
    """The two-level structure on the device; entry arrays are in TLAS slot order."""

    lowers: wp.array[wp.vec3]  # TLAS node box minimum, world space
    uppers: wp.array[wp.vec3]  # TLAS node box maximum
    left_first: wp.array[wp.int32]  # left child (inner node) or first slot (leaf)
    prim_count: wp.array[wp.int32]  # entries in a leaf, 0 for an inner node
    entry_blas: wp.array[wp.int32]  # slot -> BLAS index into blases, or -1 - k for analytic shape entry k
    entry_instance: wp.array[wp.int32]  # slot -> instance (row of world_to_local), -1: world space, no transform
    world_to_local: wp.array[mat34]  # per instance: world -> prototype space
    blas_origins: wp.array[wp.vec3]  # per instance: its BLAS's origin in the world, the nearest float32
    # (blas_origins), and blas_origin_rests what that float32 leaves of it; one zero each when no prototype is built
    # about a centre (has_offsets 0), as in nearly every scene
    blas_origin_rests: wp.array[wp.vec3]
    blases: wp.array[DeviceBvh]  # one BLAS per prototype (prototype space) plus the world-space one
    blas_first: wp.array[wp.int32]  # geometry id of triangle 0 of each BLAS
    shape_xforms: wp.array[mat34]  # per shape entry: world -> the shape's canonical space (an instanced shape's
    # translation is its offset from its instance's origin: shape_entry_transforms)
    shape_rows: wp.array[wp.int32]  # per shape entry: geometry id of the shape
    shape_kinds: wp.array[wp.int32]  # per unique shape (geometry id - num_triangles): primitives.SHAPE_*
    shape_params: wp.array[wp.vec4]  # per unique shape: its parameters
    num_triangles: int  # unique triangles; geometry ids from here on are shapes
    num_entries: int  # entries in the TLAS; 0 means every ray misses
    has_offsets: int  # 1 when blas_origins and blas_origin_rests hold one row per instance, 0 when one zero


# A ray is moved (moved_ray) only when its local origin lies farther from the local origin than twice its geometry's
# reach (the largest coordinate of its box): a ray that starts on or near a surface keeps its exact t there (a ray
# from a box's face reports the face at t = 0, which t_max = 2^-149 keeps and t_min = 2^-149 drops), and its origin
# is as near the geometry as moving it would make it.
FAR_ORIGIN = wp.constant(2.0)


@wp.func
def moved_ray(m: mat34, base: wp.vec3, rest: wp.vec3, origin: wp.vec3, direction: wp.vec3, reach: float):
    """``(o, d, t0)``: the ray in the local space of world-to-local ``m`` (an instance's, or a shape's canonical
    space) whose origin lies at ``base + rest`` in the world (``m``'s ``c`` and 0; for an instance's BLAS built about
    its centre the float32 nearest its origin and what that leaves of it, :func:`blas_origins`), its origin moved
    along it to ``t0`` (``o + t d`` there is the world ray's point at ``t0 + t``) when it lies farther than
    ``FAR_ORIGIN`` times ``reach`` (how far the geometry reaches from the local origin) from it. ``w = (origin - base)
    - rest``: ``origin - base`` is exact near the geometry, and ``rest`` is far smaller. Held as ``c`` and ``L m``
    apart, ``origin - c`` was rounded at ``c``'s size where the instance lies far from ``c`` (a prototype built 1e6
    off its origin whose instances bring it back: rays met its BLAS up to 0.125 off, per ray, and a glowing one
    shadowed its own samples); held as one float32 ``c + L m``, it moved instances placed at 1e7 by up to 0.5.

    Moved into local space from its own origin as ``A w`` (``w = origin - c``, ``m = [A | c]``), a ray's local
    origin is rounded at the scale of ``|A| |w|``: a sheared or squashed instance (``|A|`` of 300 or 1e6) seen from
    900 away got one off by far more than its own size, and rays that met it at a fair angle grazed or missed its
    local triangles. Such a far ray's ``A w`` only finds ``t0``, where it passes closest to the local origin, ahead
    of its origin or behind it (0 where that is no finite float); the local origin is then ``A (w + t0 d)``, summed
    relative to ``c``: ``w + t0 d`` is rounded in the world (a shift of the world ray by float32's rounding of
    ``|w|``, which the instance's world shape tolerates), and ``A`` multiplies a point near the instance. Closest in
    local space, not the world: a squashed instance's local origin was still 2e5 away along its stretched axis
    where the ray passed 0.5 from ``c`` across it, and float32 kept the way there only to 1e-2 of its size. ``t0``
    does not depend on the ray's limits, so neither does a hit's ``t``. Behind too: a ray with a negative ``t_min``
    meets the instances behind its origin, and moved only towards those ahead it missed squashed ones behind it
    from 900 away (972 of 2,907 rays); a ray whose ``t_min`` is 0 or more cannot hit an instance it passes closest
    to behind its origin (from beyond twice the reach it only leaves it), so moving it changes no hit of its.

    ``t0`` is found from ``o`` and ``d`` scaled by the power of two that brings ``d``'s largest component into
    ``[1, 2)`` (``unit_scales``; ``a`` scaled, as ``o`` may be infinite): the same bits where nothing over- or
    underflows, and a scene scaled by ``2^-100`` or ``2^100`` is moved as the unscaled one (unscaled, ``d . d`` of an
    instance 2^-100 across overflowed to inf, of one 2^100 across underflowed to 0, and such rays were never moved).
    """
    a = linear_part(m)
    w = (origin - base) - rest
    d = transform_vector(m, direction)
    o = a * w
    t0 = float(0.0)
    if largest_magnitude(o) > FAR_ORIGIN * reach:
        down, _ = unit_scales(d)
        d_unit = d * down
        t0 = -wp.dot((a * down) * w, d_unit) / wp.dot(d_unit, d_unit)
        if not (wp.abs(t0) < FLOAT32_MAX):  # no finite float (NaN too)
            t0 = 0.0
        if t0 != 0.0:
            o = a * (w + t0 * direction)
    return o, d, t0


@wp.func
def entry_ray(tlas: DeviceTlas, instance: int, blas: DeviceBvh, origin: wp.vec3, direction: wp.vec3):
    """``(o, d, t0)``: the ray in the space of an entry with BLAS ``blas``, moved (:func:`moved_ray`; the BLAS's root
    box gives the reach); unchanged, with ``t0 = 0``, for world-space geometry (``instance < 0``)."""
    o = origin
    d = direction
    t0 = float(0.0)
    if instance >= 0:
        lower, upper = node_box(blas, 0)
        reach = wp.max(largest_magnitude(lower), largest_magnitude(upper))
        m = tlas.world_to_local[instance]
        base = translation(m)
        rest = wp.vec3(0.0)
        if tlas.has_offsets != 0:  # a BLAS built about its centre (blas_origins)
            base = tlas.blas_origins[instance]
            rest = tlas.blas_origin_rests[instance]
        o, d, t0 = moved_ray(m, base, rest, origin, direction, reach)
    return o, d, t0


@wp.func
def shifted_limit(limit: float, t0: float):
    """The smallest float32 ``t`` for which ``t0 + t`` rounds to ``limit`` or above: a limit on ``t`` for a ray whose
    origin moved to ``t0`` (:func:`entry_ray`) that keeps a hit, reported at ``t0 + t``, exactly as the unmoved
    limit keeps that ``t`` (``t_min <= t0 + t``, ``t0 + t < t_max``), and ``limit`` itself for ``t0 = 0``. So the
    closest hit and the any-hit query agree on every ray, a limit at a hit's own ``t`` (or one float past it)
    decides that hit exactly, and a later entry's hit at the best ``t`` so far loses the tie, as without the move.

    ``t0`` has either sign (:func:`entry_ray`). The search starts at ``limit - t0`` less half the gap below
    ``limit`` (where sums start to round to ``limit``): where ``t0`` is within a factor 2 of ``limit`` that is
    exact, and the answer or the float below it (floats near ``limit - t0`` are far finer than ``limit``'s there:
    stepping from ``limit - t0`` would take thousands of steps); elsewhere it is within two floats of the answer.
    The steps after it find the float itself. The closest hit takes it for ``t_min`` only: above, it drops hits at
    or past the best ``t`` after adding ``t0``, which needs only a limit no lower than this one."""
    x = limit
    if limit == 0.0:
        x = -t0  # t0 - t0 is 0, and t0 less the float below it is its gap: negative (t_min = 0 of most rays)
    elif t0 != 0.0 and wp.abs(limit) < wp.inf:
        half_gap = 0.5 * (limit + next_up(-limit))  # limit - (the float below limit), halved
        x = (limit - t0) - half_gap
        steps = int(0)  # at most two each way (tests/test_tlas_limits.py); the cap only guards against the unforeseen
        while x + t0 < limit and steps < 4:
            x = next_up(x)
            steps += 1
        below = -next_up(-x)
        while below + t0 >= limit and steps < 8:
            x = below
            below = -next_up(-x)
            steps += 1
    return x


@wp.func
def shape_entry(tlas: DeviceTlas, b: int, instance: int, origin: wp.vec3, direction: wp.vec3):
    """The ray in the canonical space of the analytic shape of entry ``b`` (``b = -1 - k`` for shape entry ``k``) of
    ``instance`` (-1: a world-space shape), moved to ``t0`` as an instance's (:func:`moved_ray`), and that shape's
    geometry id, kind and parameters.

    An instanced shape's entry holds its offset from the instance's origin (:func:`shape_entry_transforms`): the ray's
    origin is taken relative to the instance's origin first, as shading takes it (:func:`wrt.shade.shape_frame`)."""
    e = -1 - b
    row = tlas.shape_rows[e]
    j = row - tlas.num_triangles
    kind = tlas.shape_kinds[j]
    params = tlas.shape_params[j]
    reach = float(1.0)  # canonical shapes lie in [-1, 1]^3; (tapered) capsules out to h + 1 (h + rho) along z
    if kind == SHAPE_CAPSULE or kind == SHAPE_TAPERED:
        reach += wp.abs(params[0]) + wp.abs(params[1])
    start = origin
    if instance >= 0:
        start = origin - translation(tlas.world_to_local[instance])
    m = tlas.shape_xforms[e]
    o, d, t0 = moved_ray(m, translation(m), wp.vec3(0.0), start, direction, reach)
    return o, d, t0, row, kind, params


@wp.func
def tlas_intersect(tlas: DeviceTlas, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Closest hit with ``t_min <= t < t_max`` over every instance and the world-space geometry.

    Returns:
        ``(t, u, v, prim, instance, nodes_visited, triangles_tested)``; ``prim`` is the geometry id, ``-1`` (and
        ``t = inf``) on a miss; ``nodes_visited`` counts TLAS and BLAS nodes.
    """
    best_t = t_max
    best_u = float(0.0)
    best_v = float(0.0)
    best_prim = int(-1)
    best_instance = int(-1)
    nodes = int(0)
    tests = int(0)
    if tlas.num_entries > 0 and ray_can_hit(origin, direction, t_min, t_max):
        inv_dir = safe_inverse(direction)
        origin_lower, origin_upper = box_origins(origin, direction, box_reach(tlas.lowers[0], tlas.uppers[0]))
        stack = NodeStack()
        top = int(0)
        node = int(-1)
        root = intersect_ray_box(origin_lower, origin_upper, inv_dir, tlas.lowers[0], tlas.uppers[0], t_min, best_t)
        if reachable(root, best_t):
            node = 0
        while node >= 0:
            count = tlas.prim_count[node]
            first = tlas.left_first[node]
            if waits(count > 0):
                continue
            nodes += 1
            if count > 0:
                # Leaf: trace each entry's BLAS with the ray moved into its space, up to the best hit so far.
                for s in range(first, first + count):
                    instance = tlas.entry_instance[s]
                    b = tlas.entry_blas[s]
                    if b >= 0:
                        blas = tlas.blases[b]
                        o, d, t0 = entry_ray(tlas, instance, blas, origin, direction)
                        # An exact tie with the best hit goes to the smaller instance (world geometry, -1, first),
                        # as the rows of Scene.triangles() and the flattened layouts order them: given to the entry
                        # visited first, coincident copies won by tree and ray. Such an entry is searched up to
                        # best_t inclusive (one float further), or, moved to t0, up to where t0 + t passes best_t.
                        ties = best_prim >= 0 and instance < best_instance
                        hi = best_t
                        if ties:
                            hi = next_up(best_t)
                        if t0 != 0.0:
                            # Above every t with t0 + t < best_t; the check below drops a hit that rounds to best_t
                            # or past it (any other hit in this BLAS is farther), cheaper than the exact limit.
                            hi = next_up(best_t - t0)
                            if ties:
                                hi = shifted_limit(next_up(best_t), t0)
                        t, u, v, prim, n, k = bvh_intersect(blas, o, d, shifted_limit(t_min, t0), hi)
                        nodes += n
                        tests += k
                        if t0 != 0.0:
                            t = t0 + t
                        if prim >= 0 and (t < best_t or (ties and t == best_t)):
                            best_t = t
                            best_u = u
                            best_v = v
                            best_prim = tlas.blas_first[b] + prim
                            best_instance = instance
                    else:
                        # An analytic shape, intersected in its canonical space.
                        o, d, t0, row, kind, params = shape_entry(tlas, b, instance, origin, direction)
                        hi = best_t
                        if t0 != 0.0:
                            hi = next_up(best_t - t0)  # as for a BLAS above
                        t_local = intersect_shape(kind, params, o, d, shifted_limit(t_min, t0), hi)
                        tests += 1
                        t = t_local
                        if t0 != 0.0:
                            t = t0 + t_local
                        if t < best_t:
                            best_t = t
                            best_u, best_v = shape_uv(kind, params, o + t_local * d)
                            best_prim = row
                            best_instance = instance
                node = -1
            else:
                # Inner node: go to the nearer child that the ray enters, push the other one.
                left, right, t_left, t_right = order_children(
                    tlas.lowers, tlas.uppers, first, origin_lower, origin_upper, inv_dir, t_min, best_t
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
    if best_prim < 0:
        best_t = wp.inf
        best_instance = -1
    return best_t, best_u, best_v, best_prim, best_instance, nodes, tests


@wp.func
def tlas_occluded(tlas: DeviceTlas, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """Any hit with ``t_min <= t < t_max`` in any instance or the world-space geometry."""
    found = bool(False)
    if tlas.num_entries > 0 and ray_can_hit(origin, direction, t_min, t_max):
        inv_dir = safe_inverse(direction)
        origin_lower, origin_upper = box_origins(origin, direction, box_reach(tlas.lowers[0], tlas.uppers[0]))
        stack = NodeStack()
        top = int(0)
        node = int(-1)
        root = intersect_ray_box(origin_lower, origin_upper, inv_dir, tlas.lowers[0], tlas.uppers[0], t_min, t_max)
        if root < wp.inf:
            node = 0
        while node >= 0 and not found:
            count = tlas.prim_count[node]
            first = tlas.left_first[node]
            if waits(count > 0):
                continue
            if count > 0:
                for s in range(first, first + count):
                    b = tlas.entry_blas[s]
                    if not found and b >= 0:
                        blas = tlas.blases[b]
                        o, d, t0 = entry_ray(tlas, tlas.entry_instance[s], blas, origin, direction)
                        lo = shifted_limit(t_min, t0)
                        if bvh_occluded(blas, o, d, lo, shifted_limit(t_max, t0)):
                            found = True
                    elif not found:
                        o, d, t0, _row, kind, params = shape_entry(tlas, b, tlas.entry_instance[s], origin,
                                                                   direction)
                        lo = shifted_limit(t_min, t0)
                        if intersect_shape(kind, params, o, d, lo, shifted_limit(t_max, t0)) < wp.inf:
                            found = True
                node = -1
            else:
                left, right, t_left, t_right = order_children(
                    tlas.lowers, tlas.uppers, first, origin_lower, origin_upper, inv_dir, t_min, t_max
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


@wp.kernel(cuda_max_registers=TLAS_MAX_REGISTERS)
def trace_tlas_kernel(
    tlas: DeviceTlas,
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
    instances: wp.array[wp.int32],
):
    """Closest hit of every ray through the TLAS; ``prims`` are geometry ids, ``instances`` -1 for world geometry."""
    i = wp.tid()
    d, t_min, t_max, down = unit_ray(directions[i], t_mins[i], t_maxs[i])
    t, u, v, prim, instance, nodes, tests = tlas_intersect(tlas, origins[i], d, t_min, t_max)
    ts[i] = t * down
    us[i] = u
    vs[i] = v
    prims[i] = prim
    costs[i] = wp.vec2i(nodes, tests)
    instances[i] = instance


occluded_tlas_kernel = any_hit_kernel(tlas_occluded, DeviceTlas, "occluded_tlas_kernel", __name__, TLAS_MAX_REGISTERS)


class InstancedAccelerator(Accelerator):
    """wrt's two-level BVH: one BLAS per prototype and one for the world-space meshes, under a TLAS.

    Args:
        scene: the scene; its instances, prototypes and non-instanced meshes.
        builder: builder name, used for every BLAS and the TLAS.
        device: Warp device.
        reuse: an accelerator of the same scene's triangles, builder and options before its instances moved: its
            BLASes that this one needs are taken, not built again (:func:`wrt.trace.moved_accelerator`).
        **build_options: passed to every BLAS build (``leaf_size`` etc.), with the defaults of
            :func:`wrt.trace.accelerator_build_options` (SAH: ``presplit=6``). ``presplit`` applies to the BLASes of
            more than ``batched.BATCH_MAX_TRIANGLES`` (4096) triangles only: the small ones are built together on a
            CPU, which pre-splits cannot join, and thousands of prototypes built one by one took 4x as long.

    Attributes:
        blas: host :class:`wrt.bvh.FlatBvh` of each BLAS (the world-space one first when there is one).
        tlas: host :class:`wrt.bvh.FlatBvh` over the entries (also ``bvh``, the world-space tree previews draw).
        skipped_instances: indices of instances left out because their transform cannot be inverted.
        build_seconds: total build time of every BLAS it built and the TLAS when the accelerator was made (not of
            the BLASes taken from ``reuse``). :meth:`update` leaves it as it is: it once became the first build's
            BLAS times plus the new TLAS's, the time of neither.
        update_seconds: wall time of the last :meth:`update` (refits, BLASes built anew, the TLAS and the uploads);
            None before the first.
    """

    name = "wrt"
    unit_rays = True

    def __init__(self, scene: Scene, builder: str, device, *, reuse: InstancedAccelerator | None = None,
                 **build_options):
        check_finite_transforms(scene)
        self.device = device
        self.builder = builder
        self.build_options = accelerator_build_options(builder, build_options)
        points, indices = scene.geometry()
        self.blas, self._device_blas, self._blas_first, self._blas_parts = [], [], [], []
        self._refitters = []
        parts = blas_parts(scene)
        # The BLASes of ``reuse`` (the accelerator of the scene before its instances moved, of these triangles and
        # options) that it still needs: an instance skipped or scaled past 2^100 changes one part, not the others.
        kept = {} if reuse is None else {tuple(part): b for b, part in enumerate(reuse._blas_parts)}
        built = [part for part in parts if tuple(part) not in kept]
        meshes = [_part_triangles(scene, points, indices, *part) for part in built]
        # One call for every BLAS: on a CPU the small trees are built together (thousands of prototypes).
        new = dict(zip(map(tuple, built), zip(*self._build_blases(meshes)))) if built else {}
        trees, uploads = [], []
        for part in parts:
            tree, upload = new[tuple(part)] if tuple(part) in new else (reuse.blas[kept[tuple(part)]],
                                                                         reuse._device_blas[kept[tuple(part)]])
            trees.append(tree)
            uploads.append(upload)
        for part, bvh, d in zip(parts, trees, uploads):
            self.blas.append(bvh)
            self._device_blas.append(d)
            self._blas_first.append(part[1])
            self._blas_parts.append(part)
        if not self._device_blas:  # keep the array non-empty: an empty BLAS no ray enters
            empty = build_bvh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), builder, device=device)
            self._device_blas.append(empty.to_device(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), device))
            self._blas_first.append(0)
        self._build_tlas(scene)
        # The build that made this one: the BLASes taken from ``reuse`` were built (and timed) by another.
        self.build_seconds = sum(tree.build_seconds for tree, _ in new.values()) + self.tlas.build_seconds
        self.update_seconds = None

    def _presplits(self, triangles: int) -> bool:
        """Whether a BLAS of ``triangles`` is built with the ``presplit`` option (see the class docstring)."""
        return bool(self.build_options.get("presplit")) and triangles > BATCH_MAX_TRIANGLES

    def _blas_options(self, triangles: int) -> dict:
        """The build options of a BLAS of ``triangles``."""
        options = dict(self.build_options)
        if not self._presplits(triangles):
            options.pop("presplit", None)
        return options

    def update(self, scene: Scene, refit_blas: bool, rebuild=None) -> list[int]:
        """Follows ``scene``, a later frame of the scene this was built for with the same topology: refits every
        BLAS to the moved vertices when ``refit_blas``, builds anew each refitted BLAS ``b`` for which
        ``rebuild(b, tree)`` is true (``tree``: the refitted :class:`wrt.bvh.FlatBvh`; those picked are built together
        once every tree is refitted), then rebuilds the TLAS over the new instance transforms. Returns the
        indices of the BLASes built anew.

        Raises:
            ValueError: when ``scene`` needs other BLASes (a prototype gained or lost all its instances, or an
                instance's scale crossed ``2^100``: :func:`instance_exponents`), saying which.
        """
        start = time.perf_counter()
        check_finite_transforms(scene)
        parts = [tuple(p) for p in blas_parts(scene)]
        if parts != self._blas_parts:
            raise ValueError(f"{self._parts_change(scene, parts)}; build a new InstancedAccelerator")
        rebuilt = []
        if refit_blas:
            from .bvh.refit import Refitter

            points, indices = scene.geometry()
            if not self._refitters:
                self._refitters = [Refitter(b, d, self.device) for b, d in zip(self.blas, self._device_blas)]
            meshes = []
            for b, (refitter, part) in enumerate(zip(self._refitters, self._blas_parts)):
                mesh = _part_triangles(scene, points, indices, *part)
                refitter.refit(*mesh)
                if rebuild is not None and rebuild(b, self.blas[b]):
                    rebuilt.append(b)
                    meshes.append(mesh)
            # The host trees and uploads are replaced, not refilled (the TLAS below takes the new ones), all in one
            # call as at the build: on a CPU the small trees are built together (thousands of deforming prototypes
            # spent a dozen launches and allocations each, built one by one).
            if meshes:
                for b, tree, d in zip(rebuilt, *self._build_blases(meshes)):
                    self.blas[b], self._device_blas[b] = tree, d
                    self._refitters[b] = Refitter(tree, d, self.device)
        self._build_tlas(scene)
        wp.synchronize_device(self.device)  # the uploads are part of the update
        self.update_seconds = time.perf_counter() - start
        return rebuilt

    def _parts_change(self, scene: Scene, parts: list) -> str:
        """What made ``scene``'s BLAS ``parts`` (:func:`blas_parts`) differ from this structure's: instances whose
        :func:`instance_exponents` changed (named), or the prototypes. An instance scaled past ``2^100`` (or back)
        was reported as a change of the scene's prototypes, which were the same."""
        old, new = self._exponents, instance_exponents(scene)
        same_prototypes = {p[:3] for p in parts} == {p[:3] for p in self._blas_parts}
        if same_prototypes and len(old) == len(new) and (old != new).any():
            moved = np.flatnonzero(old != new)
            names = ", ".join(scene.instances.path(int(i)) for i in moved[:3])
            more = f" and {len(moved) - 3:,} more" if len(moved) > 3 else ""
            return (f"the scale of instance {names}{more} crossed 2^100 or 2^-100 (or came back), which traces it in "
                    "a copy of its prototype's BLAS scaled by another power of two (wrt.tlas.instance_exponents)")
        return "the scene's prototypes changed (their triangles, or a prototype gained or lost all its instances)"

    def _build_blases(self, meshes: list) -> tuple[list, list]:
        """The host trees (:func:`wrt.bvh.build.build_bvhs`) and their uploads for ``(points, indices)`` meshes."""
        trees = [None] * len(meshes)
        for presplit in (False, True):
            chosen = [j for j, (_, sub) in enumerate(meshes) if self._presplits(len(sub)) == presplit]
            if not chosen:
                continue
            options = self._blas_options(len(meshes[chosen[0]][1]))  # the same for every mesh chosen
            for j, tree in zip(chosen, build_bvhs([meshes[j] for j in chosen], self.builder, device=self.device,
                                                  **options)):
                trees[j] = tree
        if wp.get_device(self.device).is_cpu and trees:  # views of one upload per field (GPU: one upload per tree)
            return trees, upload_many(trees, meshes, self.device)
        return trees, [bvh.to_device(sub_points, sub, self.device) for bvh, (sub_points, sub) in zip(trees, meshes)]

    def _build_tlas(self, scene: Scene) -> None:
        """The TLAS over world boxes of the world-space BLAS, every instance of a prototype BLAS and every shape."""
        device, builder = self.device, self.builder
        blas_of_part = {(part, k): b for b, (part, _, _, k) in enumerate(self._blas_parts)}
        # Entries: the world-space meshes (no transform), then every instance of a non-empty prototype.
        entry_blas, entry_instance, lowers, uppers = [], [], [], []
        if (0, 0) in blas_of_part:
            b = blas_of_part[(0, 0)]
            entry_blas.append(np.array([b]))
            entry_instance.append(np.array([-1]))
            lowers.append(self.blas[b].lowers[:1].astype(np.float64))
            uppers.append(self.blas[b].uppers[:1].astype(np.float64))
        instances = scene.instances
        _, invertible = scene.instance_inverses()
        self.skipped_instances = np.flatnonzero(~invertible)
        rows = [r[invertible[r]] for r in instances.rows_of_prototypes(len(scene.prototypes))]
        exponents = self._exponents = instance_exponents(scene)
        centres = blas_centres(scene)[instances.prototype]
        origins, rests = blas_origins(instances.to_world, centres)
        for (part, k), b in blas_of_part.items():
            if part == 0:
                continue
            mine = rows[part - 1][exponents[rows[part - 1]] == k]
            placed = as_placed(instances.to_world[mine])
            # The BLAS's origin (moved_ray): the instance's float32 origin but for prototypes built about a centre.
            placed[:, :3, 3] = origins[mine].astype(np.float64) + rests[mine]
            placed[:, :3, :3] *= 2.0**-k  # from the BLAS's scaled space
            lo, hi = world_boxes(self.blas[b].lowers[0].astype(np.float64), self.blas[b].uppers[0].astype(np.float64),
                                 placed)
            entry_blas.append(np.full(len(mine), b))
            entry_instance.append(mine)
            lowers.append(lo)
            uppers.append(hi)
        # Shape entries: the non-instanced shapes, then every instance of a prototype with shapes, per shape.
        shape_to_world, shape_rows, shape_instances = [], [], []
        n_tri = scene.num_geometry_triangles
        for k, shape in enumerate(scene.shapes):
            shape_to_world.append(shape.to_world[None])
            shape_rows.append(np.array([n_tri + k]))
            shape_instances.append(np.array([-1]))
        for p, (first, count) in enumerate(scene.prototype_shape_ranges()):
            mine = rows[p]
            for k, shape in enumerate(scene.prototypes[p].shapes if count else []):
                shape_to_world.append(instances.to_world[mine] @ shape.to_world)
                shape_rows.append(np.full(len(mine), first + k))
                shape_instances.append(mine)
        shape_to_world = np.concatenate(shape_to_world or [np.zeros((0, 4, 4))])
        shape_rows = np.concatenate(shape_rows or [np.zeros(0)]).astype(np.int32)
        shape_instances = np.concatenate(shape_instances or [np.zeros(0)]).astype(np.int32)
        entry_instance.append(shape_instances)
        shape_to_local, shape_ok = invert_transforms(shape_to_world)
        if not shape_ok.all():
            # A shape squashed along an axis of its own, turned by its instance, is squashed along a turned axis,
            # which float32 cannot invert (instancing.FLOAT32_INVERSE_TOLERANCE): thickened, as such an instance or
            # shape is by itself (it was missed by every ray).
            refused = np.flatnonzero(~shape_ok)
            thick, thickened = thicken_flat_transforms(shape_to_world[refused])
            refused = refused[thickened]
            shape_to_world[refused] = thick[thickened]
            shape_to_local[refused], shape_ok[refused] = invert_transforms(shape_to_world[refused])
        warn_shapes_too_small(scene, shape_to_local, shape_ok, shape_rows - n_tri)
        # Every entry's box at once, from its shape's canonical box: a Python step per entry made the first trace of
        # 1M PointInstancer spheres take 44 s (7 s now), and the TLAS is rebuilt every animated frame.
        local_lo, local_hi = (b[shape_rows - n_tri] for b in local_boxes(scene._geometry_shapes()))
        shape_xforms, placed = shape_entry_transforms(shape_to_world, shape_to_local, shape_instances,
                                                      instances.to_world, scene.instanced_shape_origins()[0])
        lo, hi = world_boxes(local_lo, local_hi, placed)
        lowers.append(np.where(shape_ok[:, None], lo, np.inf))  # a degenerate shape: a box no ray enters
        uppers.append(np.where(shape_ok[:, None], hi, -np.inf))
        entry_blas.append(-1 - np.arange(len(shape_rows)))
        entry_blas = np.concatenate(entry_blas or [np.zeros(0)]).astype(np.int32)
        entry_instance = np.concatenate(entry_instance or [np.zeros(0)]).astype(np.int32)
        lowers = np.concatenate(lowers or [np.zeros((0, 3))]).astype(np.float32)
        uppers = np.concatenate(uppers or [np.zeros((0, 3))]).astype(np.float32)
        keep = np.all(lowers <= uppers, axis=1)  # leave out degenerate shapes
        entry_blas, entry_instance, lowers, uppers = entry_blas[keep], entry_instance[keep], lowers[keep], uppers[keep]
        # Round the boxes outwards so float32 storage never shrinks them.
        lowers = np.nextafter(lowers, np.float32(-np.inf))
        uppers = np.nextafter(uppers, np.float32(np.inf))
        self.num_entries = len(entry_blas)

        # TLAS over the entry boxes, each as a degenerate triangle (lower, upper, lower).
        box_points = np.ascontiguousarray(np.stack([lowers, uppers], axis=1).reshape(-1, 3))
        e = np.arange(self.num_entries, dtype=np.int32)
        box_tris = np.ascontiguousarray(np.stack([2 * e, 2 * e + 1, 2 * e], axis=1))
        self.tlas = build_bvh(box_points, box_tris, builder, device=device, leaf_size=TLAS_LEAF_SIZE,
                              intersection_cost=TLAS_INTERSECTION_COST)
        self.bvh = self.tlas  # the world-space tree, as BvhAccelerator.bvh (previews draw its boxes)
        slots = self.tlas.prim_ids  # slot -> entry: store the entries in slot order

        t = DeviceTlas()
        t.lowers = wp.array(self.tlas.lowers, dtype=wp.vec3, device=device)
        t.uppers = wp.array(self.tlas.uppers, dtype=wp.vec3, device=device)
        t.left_first = wp.array(self.tlas.left_first, dtype=wp.int32, device=device)
        t.prim_count = wp.array(self.tlas.prim_count, dtype=wp.int32, device=device)
        t.entry_blas = wp.array(_non_empty(entry_blas[slots]), dtype=wp.int32, device=device)
        t.entry_instance = wp.array(_non_empty(entry_instance[slots]), dtype=wp.int32, device=device)
        t.world_to_local = scene.world_to_local(device)
        if exponents.any():  # into the scaled BLASes' space: 2^k A
            inverse, _ = scene.instance_inverses()
            scaled = inverse * np.ldexp(1.0, exponents)[:, None, None]
            t.world_to_local = wp.array(device_transforms(scaled, instances.to_world), dtype=mat34, device=device)
        t.has_offsets = int(centres.any())  # else one zero each: 24 bytes per instance only where a BLAS is centred
        t.blas_origins, t.blas_origin_rests = (wp.array(a if t.has_offsets else np.zeros((1, 3), np.float32),
                                                        dtype=wp.vec3, device=device) for a in (origins, rests))
        t.blases = wp.array(self._device_blas, dtype=DeviceBvh, device=device)
        t.blas_first = wp.array(np.asarray(self._blas_first, np.int32), dtype=wp.int32, device=device)
        t.shape_xforms = wp.array(_non_empty(shape_xforms), dtype=mat34, device=device)
        t.shape_rows = wp.array(_non_empty(shape_rows), dtype=wp.int32, device=device)
        t.shape_kinds, t.shape_params, _ = scene.shape_arrays(device)
        t.num_triangles = n_tri
        t.num_entries = self.num_entries
        self.device_tlas = t
        self._tlas_arrays = [t.lowers, t.uppers, t.left_first, t.prim_count, t.entry_blas, t.entry_instance]
        self._tlas_arrays += [t.world_to_local, t.blas_origins, t.blas_origin_rests, t.blases, t.blas_first,
                              t.shape_xforms, t.shape_rows]
        self._blas_arrays = [a for d in self._device_blas[: len(self.blas)] for a in (
            d.lowers, d.uppers, d.left_first, d.prim_count, d.prim_ids, d.v0, d.v1, d.v2, d.nodes)]

    def device_bytes(self) -> dict:
        """Device memory of the structure, in bytes: ``blas`` (nodes and triangles of every BLAS, the scaled copies of
        :func:`blas_parts` included), ``tlas`` (TLAS nodes and per-entry data, instance transforms included) and
        ``total``."""
        blas = sum(a.capacity for a in self._blas_arrays)
        tlas = sum(a.capacity for a in self._tlas_arrays)
        return {"blas": int(blas), "tlas": int(tlas), "total": int(blas + tlas)}

    def kernels(self, costs) -> tuple:
        return (occluded_tlas_kernel,) if costs is None else (trace_tlas_kernel,)

    def _intersect(self, origins, directions, t_mins, t_maxs, hits: HitBuffer, costs: bool) -> None:
        # Always counted: the TLAS kernel's register cap (TLAS_MAX_REGISTERS) already decides its spills.
        wp.launch(
            trace_tlas_kernel,
            len(origins),
            inputs=[self.device_tlas, origins, directions, t_mins, t_maxs],
            outputs=[*hits.outputs, hits.instance],
            device=self.device,
            block_dim=traverse.trace_block_dim(self.device),
        )

    def _occluded(self, origins, directions, t_mins, t_maxs, blocked) -> None:
        wp.launch(
            occluded_tlas_kernel,
            len(origins),
            inputs=[self.device_tlas, origins, directions, t_mins, t_maxs],
            outputs=[blocked],
            device=self.device,
            block_dim=traverse.trace_block_dim(self.device),
        )


def blas_parts(scene: Scene) -> list[tuple[int, int, int, int]]:
    """``(part, first, count, k)`` of every BLAS ``scene`` needs: part 0 is the world-space meshes, part ``p + 1``
    prototype ``p`` (when it has triangles and an invertible instance) scaled by ``2^k`` for its instances of
    :func:`instance_exponents` ``k`` (one BLAS per exponent; 0 for nearly every scene); ``first, count`` are its
    :meth:`Scene.geometry` triangle rows."""
    parts = [(0, 0, scene.num_flat_triangles, 0)] if scene.num_flat_triangles else []
    instances = scene.instances
    _, invertible = scene.instance_inverses()
    exponents = instance_exponents(scene)
    # Invertible instances of each prototype at their own scale (exponent 0), and the other exponents drawn.
    drawn = np.bincount(instances.prototype[invertible & (exponents == 0)], minlength=len(scene.prototypes))
    scaled = {}
    extreme = exponents != 0
    for p, k in np.unique(np.stack([instances.prototype[extreme], exponents[extreme]], axis=1), axis=0):
        scaled.setdefault(int(p), set()).add(int(k))
    for p, (first, count) in enumerate(scene.prototype_ranges()):
        for k in ([0] if drawn[p] else []) + sorted(scaled.get(p, ())):
            if count:
                parts.append((p + 1, int(first), int(count), k))
    return parts


# A shape whose world-to-canonical matrix has an entry of 2^127 (1.7e38) or more (a sphere of radius 5.9e-39 or less)
# is missed by every ray: its canonical ray direction is scaled into [1, 2) by a power of two (unit_scales) whose
# exponent stops at float32's normal range, and no longer reaches it. (Smaller still, the matrix has no float32 inverse
# and the shape is named as singular.)
SHAPE_TO_LOCAL_LIMIT = 2.0**127


def warn_shapes_too_small(scene: Scene, to_local: np.ndarray, ok: np.ndarray, shapes: np.ndarray) -> None:
    """Warns naming the analytic shapes (``scene._geometry_shapes()[shapes[i]]`` placed by shape entry ``i``'s
    world-to-canonical matrix ``to_local[i]``, :func:`invert_transforms`' ``ok``) that rays miss, as they are too
    small for float32 (:data:`SHAPE_TO_LOCAL_LIMIT`): shapes scaled to 5e-39 or less, by their own transform or an
    instance's, vanished without a word. So do those with no float32 inverse (not ``ok``) whose own transform has
    one (a singular one is named by :meth:`wrt.Scene.warn_vanishing_shapes`, a singular instance is skipped and
    named): a sphere of radius 1e-6 in an instance scaled by 2^-110, each transform inverted by float32, their
    product (7.7e-40) not, vanished too."""
    if not len(shapes):
        return
    geometry = scene._geometry_shapes()
    small = ok & (np.abs(to_local[:, :, :3]).reshape(len(to_local), -1).max(axis=1) >= SHAPE_TO_LOCAL_LIMIT)
    if not ok.all():  # per unique shape, not per entry (a million instanced spheres are one shape)
        singular = np.array([getattr(shape, "draws_nothing", False) for shape in geometry], bool)
        small |= ~ok & ~singular[shapes]
    if small.any():
        paths = list(dict.fromkeys(geometry[j].path for j in shapes[small]))
        scene._warn_prims("shapes too small for float32 (scaled by 5.9e-39 or less: their world-to-shape "
                          "matrix passes 2^127, or has no float32 inverse) are missed by every ray; scale the scene up",
                          paths)


@of_one_state  # cached in the scene: made of one state of it (a viewer thread asks too)
def instance_exponents(scene: Scene) -> np.ndarray:
    """``(N,)`` int: for each instance whose world-to-local matrix ``A`` (:meth:`Scene.instance_inverses`) has its
    largest entry beyond ``2^EXTREME_EXPONENT`` or below ``2^-EXTREME_EXPONENT`` (an instance scaled by 1e36, or by
    1e-36), the power of two ``k`` that brings ``2^k A``'s into ``[1, 2)``; 0 for every other (and every singular)
    one. Such an instance is traced in its prototype's BLAS scaled by ``2^k`` (exactly: a power of two), with ``2^k
    A``, so that a ray moved into its space has a direction near unit length, as in the world. ``k`` is capped so
    that the scaled prototype stays within ``2^SCALED_REACH`` (an instance scaled by 3e38 made its points inf) and
    above ``2^-EXTREME_EXPONENT``; 0 for an instance of a prototype whose triangles reach nowhere (none, or all at
    its origin), which has no scaled BLAS."""
    key = ("instance_exponents",)
    if key not in scene._cache:
        inverse, ok = scene.instance_inverses()
        largest = np.abs(inverse[:, :, :3]).reshape(len(inverse), -1).max(axis=1) if len(inverse) else np.zeros(0)
        k = 1 - np.frexp(largest)[1]  # largest = m 2^e with m in [0.5, 1): 2^(1 - e) largest is in [1, 2)
        k = np.where(ok & (np.abs(k) > EXTREME_EXPONENT), k, 0).astype(np.int64)
        if k.any():
            centres = blas_centres(scene)
            reach = np.array([_triangle_reach(p, c) for p, c in zip(scene.prototypes, centres)])
            reach = reach[scene.instances.prototype]
            exponent = np.frexp(np.maximum(reach, 1e-38))[1]
            # 2^k reach within [2^-EXTREME_EXPONENT, 2^SCALED_REACH]: no inf, and no subnormal points (an instance
            # scaled by 3e-39 scaled its prototype there too, and a ray leaked between its triangles). A prototype
            # of no triangles (analytic shapes alone) has no BLAS to scale: 0. Given the exponent of a reach of
            # 1e-38 (+26 at a scale of 2^-110), its 2^k A overflowed float32 (numpy's bare "overflow encountered in
            # cast") for a matrix nothing reads.
            k = np.where((k != 0) & (reach > 0), np.clip(k, -EXTREME_EXPONENT - exponent, SCALED_REACH - exponent), 0)
        scene._cache[key] = k
    return scene._cache[key]


def _triangle_reach(prototype, centre=np.zeros(3)) -> float:
    """The largest ``|coordinate|`` of the points ``prototype``'s triangles use (0 when none) less ``centre`` (its
    :func:`blas_centres` row), the reach of its BLAS: points no face uses are left out, as from its box
    (:meth:`Prototype.bounds`) and the BVH build's checks (an unused point at 1e30 capped an instance's exponent at
    25 instead of 120, and an unused NaN counted as a reach of 1); a used one that is not finite is named by the
    checks of finite vertices."""
    reach = 0.0
    for m in prototype.meshes:
        if len(m.indices):
            with np.errstate(invalid="ignore"):
                size = np.abs(m.points[sorted_unique(m.indices)] - centre)
            reach = max(reach, float(size.max(initial=0.0, where=np.isfinite(size))))
    return reach


@of_one_state  # cached in the scene: made of one state of it (a viewer thread asks too)
def blas_centres(scene: Scene) -> np.ndarray:
    """``(P, 3)`` float64 (float32 values): the point of each prototype's space that its BLAS is built about (its
    points less it, :func:`_part_triangles`; its instances place it at :func:`blas_origins`): the
    centre of the box of the points its triangles use where that box lies farther from the prototype's origin than
    its own size, else 0 (so that the BLAS of nearly every prototype holds its points bit for bit). A prototype's
    analytic shapes are placed from the instance's own origin as before (:func:`shape_entry`).

    A ray moves into an instance's space through the float32 inverse ``A``, whose rounding, relative to ``A``,
    moves a local point by that much of its distance from the local origin: sheared octahedra 50 of their sizes
    from their prototype's origin were entered 50 times as far off as centred ones, and 117 of 2,812 rays aimed well
    inside their triangles missed them or hit another triangle (1 about the centre)."""
    key = ("blas_centres",)
    if key not in scene._cache:
        centres = np.zeros((len(scene.prototypes), 3))
        for p, prototype in enumerate(scene.prototypes):
            used = [m.points[sorted_unique(m.indices)] for m in prototype.meshes if len(m.indices)]
            if not used:
                continue
            used = np.concatenate(used).astype(np.float64)
            used = used[np.isfinite(used).all(axis=1)]
            if len(used) == 0:
                continue
            lower, upper = used.min(axis=0), used.max(axis=0)
            centre = ((lower + upper) / 2).astype(np.float32).astype(np.float64)
            if np.abs(centre).max() > (upper - lower).max():
                centres[p] = centre
        scene._cache[key] = centres
    return scene._cache[key]


def blas_origins(to_world: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(origins, rests)``, ``(N, 3)`` float32 each: where each instance (``to_world`` ``(N, 4, 4)``, ``L`` its linear
    part) places its BLAS's origin, the :func:`blas_centres` row ``m`` of its prototype (``centres`` ``(N, 3)``): at
    ``b = c + L m`` in float64, ``c`` the instance's float32 origin (where its analytic shapes are placed from), held
    as the float32 nearest ``b`` and what that leaves of it (:func:`moved_ray`; for ``m = 0``, ``c`` and 0). Held as
    ``c`` and ``L m`` apart, a ray's ``origin - c`` was rounded at ``c``'s size where the instance lies far from ``c``
    (a prototype 1e6 off its origin whose instances bring it back); as one float32 ``c + L m``, instances placed at
    1e7 (``c`` exact, a PointInstancer's float positions) moved by up to 0.5."""
    to_world = np.asarray(to_world, np.float64)
    placed = to_world[:, :3, 3].astype(np.float32).astype(np.float64)
    placed += np.einsum("nij,nj->ni", to_world[:, :3, :3], centres)
    origins = placed.astype(np.float32)
    return origins, (placed - origins).astype(np.float32)


def _part_triangles(scene: Scene, points, indices, part: int, first: int, count: int, exponent: int = 0) -> tuple:
    """Vertices (less the prototype's :func:`blas_centres` row, times ``2^exponent``) and triangles (re-indexed from
    0) of one BLAS part (:func:`blas_parts`)."""
    # geometry() concatenates the world-space meshes' vertices, then each prototype's, in order.
    v0, v1 = _part_vertex_offsets(scene)[part : part + 2]
    part_points = points[v0:v1]
    if part > 0 and blas_centres(scene)[part - 1].any():  # about its centre (shared corners stay shared)
        with np.errstate(over="ignore", invalid="ignore"):
            part_points = (part_points.astype(np.float64) - blas_centres(scene)[part - 1]).astype(np.float32)
    if exponent != 0:  # points no face uses may leave float32 (their reach is not the BLAS's): inf there, unused
        with np.errstate(over="ignore", invalid="ignore"):
            part_points = np.ldexp(part_points, exponent).astype(np.float32)
    return np.ascontiguousarray(part_points), np.ascontiguousarray(indices[first : first + count] - v0)


@of_one_state  # cached in the scene: made of one state of it (a viewer thread asks too)
def _part_vertex_offsets(scene: Scene) -> np.ndarray:
    """``(P + 2,)`` first :meth:`Scene.geometry` vertex of each part (world-space meshes, then each prototype), and
    the total; kept in the scene's cache, as every part asked for all of them (quadratic in the prototypes: 6 s
    for 2000 prototypes)."""
    key = ("part_vertex_offsets",)
    if key not in scene._cache:
        counts = [sum(len(m.points) for m in scene.meshes)]
        counts += [sum(len(m.points) for m in p.meshes) for p in scene.prototypes]
        scene._cache[key] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return scene._cache[key]


def as_placed(to_world: np.ndarray) -> np.ndarray:
    """``(N, 4, 4)`` transforms with their translations rounded to float32, as the device places each entry's local
    origin (``wrt.transforms``: ``[A | c]``), so that the entries' world boxes hold what the kernels trace."""
    placed = to_world.copy()
    placed[:, :3, 3] = placed[:, :3, 3].astype(np.float32)
    return placed


def shape_entry_transforms(shape_to_world: np.ndarray, shape_to_local: np.ndarray, shape_instances: np.ndarray,
                           instance_to_world: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(xforms (N, 3, 4) float32, placed (N, 4, 4) float64)`` of the shape entries: each shape placed by
    ``shape_to_world`` (an instanced one's: its instance's transform composed with its own; inverse
    ``shape_to_local``) in instance ``shape_instances`` (-1: a world-space shape; the instanced ones last, in the order
    of :meth:`wrt.Scene.instanced_shape_origins`, whose float32 ``offsets`` from their instance's origin they take).
    ``xforms`` are ``[A | c]`` of :mod:`wrt.transforms` for :func:`shape_entry`, where an instanced shape's ``c`` is
    its offset; ``placed`` has the translations where the device places the shapes, for their boxes (as
    :func:`as_placed`).

    An instanced shape lies where shading places it (:func:`wrt.shade.shape_frame`, which reads the same offsets): at
    its instance's float32 origin plus its offset, each rounded at its own scale. Its world centre rounded to float32
    once was up to half an ulp of its distance from the world origin off that place (0.004 at 1e5, 4 at 1e8), so
    shading snapped the hit onto a shape beside the one traced: hits 0.004 off the surface and normals 0.5 degrees
    off at 1e5; at 1e8 rays that a unit sphere should stop missed it, and hits were 2 units off, their normals up to
    90 degrees off."""
    relative = shape_to_world.copy()
    origins = np.zeros((len(shape_to_world), 3))
    instanced = shape_instances >= 0
    origins[instanced] = instance_to_world[shape_instances[instanced], :3, 3]
    relative[instanced, :3, 3] = offsets
    placed = shape_to_world.copy()
    placed[:, :3, 3] = origins.astype(np.float32).astype(np.float64) + relative[:, :3, 3].astype(np.float32)
    return device_transforms(shape_to_local, relative), placed


def _non_empty(a: np.ndarray) -> np.ndarray:
    """``a``, or one zero when it is empty (kernels need something to bind)."""
    return a if len(a) else np.zeros((1,) + a.shape[1:], a.dtype)


__all__ = ["DeviceTlas", "InstancedAccelerator", "tlas_intersect", "tlas_occluded"]
