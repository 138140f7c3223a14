"""Rays through Warp's builtin ``wp.Mesh`` BVH in wrt's conventions (``[t_min, t_max)``, hits as ``t, u, v, prim``):
the kernels behind ``accel="warp"`` (:class:`wrt.trace.WarpMeshAccelerator`).

They live apart from wrt's own trace kernels in :mod:`wrt.trace` because Warp compiles a whole module the first time
any of its kernels is launched: a render with ``accel="wrt"`` (the default) then compiles none of these.
"""

import warp as wp

from .bvh.traverse import unit_ray
from .geometry import box_origins, box_reach, intersect_ray_box, ray_can_hit, safe_inverse

# The rounding of wrt.trace (see the note there): no FMA contraction; no backward pass (nothing differentiates a trace,
# and it doubles the code Warp compiles).
wp.set_module_options({"fuse_fp": False, "enable_backward": False})

MESH_QUERY_SLACK = wp.constant(1.0 + 2.0**-18)  # relative, on the query length: 32 ulps; 4 were enough


@wp.func
def mesh_query_start(origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float, lower: wp.vec3,
                     upper: wp.vec3):
    """Where a ``wp.mesh_query_ray`` for ``[t_min, t_max)`` starts its ray (it accepts ``t >= 0`` only): at
    ``t_min``, but for a negative ``t_min`` no further back than the ray's entry into the mesh's box ``lower, upper``
    (nor past the origin, so rays with ``t_min = 0`` and ``t_min < 0`` meet what lies ahead alike). Started at
    ``t_min`` itself, a ``t_min`` far behind the scene (-1e5 in a unit scene) rounded the start by more than the
    triangles' size, and ``-inf`` made it NaN: every ray missed."""
    start = t_min
    if t_min < 0.0:
        origin_lower, origin_upper = box_origins(origin, direction, box_reach(lower, upper))
        # +inf when the ray misses the box; rounded down by a few ulps, so a hit on the box's face stays ahead.
        entry = intersect_ray_box(origin_lower, origin_upper, safe_inverse(direction), lower, upper, t_min, t_max)
        start = wp.max(t_min, wp.min(entry, 0.0))
    return start


@wp.func
def mesh_query(mesh: wp.uint64, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float, lower: wp.vec3,
               upper: wp.vec3):
    """Closest hit through ``wp.mesh_query_ray``, restricted to ``[t_min, t_max)`` and in wrt's conventions
    (``lower, upper``: the mesh's box)."""
    t = float(wp.inf)
    u = float(0.0)
    v = float(0.0)
    prim = int(-1)
    if ray_can_hit(origin, direction, t_min, t_max):
        start = mesh_query_start(origin, direction, t_min, t_max, lower, upper)
        # Its traversal drops a box entered within rounding of the limit (no slack), so a hit on a flat floor just
        # below t_max was lost: query a little further and drop what lies at or past t_max here (a closest hit past
        # t_max means none before it).
        q = wp.mesh_query_ray(mesh, origin + start * direction, direction, (t_max - start) * MESH_QUERY_SLACK)
        if q.result and q.t + start < t_max:
            t = q.t + start
            u = q.v
            v = 1.0 - q.u - q.v
            prim = q.face
    return t, u, v, prim


@wp.kernel
def trace_mesh_kernel(
    mesh: wp.uint64,
    lower: wp.vec3,
    upper: wp.vec3,
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
    """Closest hit of every ray through Warp's ``wp.Mesh`` BVH (costs are not available: written as 0). Each ray is
    traced scaled by ``unit_ray``, as wrt's own kernels trace it (see ``WarpMeshAccelerator.unit_rays``)."""
    i = wp.tid()
    d, t_min, t_max, down = unit_ray(directions[i], t_mins[i], t_maxs[i])
    t, u, v, prim = mesh_query(mesh, origins[i], d, t_min, t_max, lower, upper)
    ts[i] = t * down
    us[i] = u
    vs[i] = v
    prims[i] = prim
    costs[i] = wp.vec2i(0, 0)


@wp.kernel
def occluded_mesh_kernel(
    mesh: wp.uint64,
    lower: wp.vec3,
    upper: wp.vec3,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    blocked: wp.array[wp.int32],
):
    """1 for every ray that hits anything in ``[t_min, t_max)`` (``lower, upper``: the mesh's box). A ray with a
    finite ``t_max`` is blocked exactly when ``trace_mesh_kernel`` finds a hit for it: it is asked through the same
    closest-hit query, ``mesh_query``. ``wp.mesh_query_ray_anyhit`` gives no ``t`` to check against the limits, and
    from its start moved to ``t_min`` (or the box entry) its rounding differs from the closest-hit query's: asked
    first, it blocked 149 of 1,335 rays in ``[t, t + 1 ulp)`` around their own hits where trace found none, and some
    at ``t_max = t`` with no hit below it (and its traversal, like the closest-hit one's, drops a box entered within
    rounding of the limit, so it also missed a floor one ulp under ``t_max``). A ray with an infinite ``t_max`` has
    no limit to lose a box or a hit at and takes ``wp.mesh_query_ray_anyhit``, so ``wp.Mesh`` any-hit rays in the
    benchmarks (``t_max = inf``) cost Warp's query alone. Rays are scaled by ``unit_ray``, as in
    ``trace_mesh_kernel``."""
    i = wp.tid()
    origin = origins[i]
    direction, t_min, t_max, down = unit_ray(directions[i], t_mins[i], t_maxs[i])
    hit = False
    if ray_can_hit(origin, direction, t_min, t_max):
        if wp.isfinite(t_max):
            t, u, v, prim = mesh_query(mesh, origin, direction, t_min, t_max, lower, upper)
            hit = prim >= 0
        else:
            start = mesh_query_start(origin, direction, t_min, t_max, lower, upper)
            hit = wp.mesh_query_ray_anyhit(mesh, origin + start * direction, direction, t_max - start)
    blocked[i] = wp.where(hit, 1, 0)
