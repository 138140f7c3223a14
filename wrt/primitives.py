"""Analytic primitives: ray intersection with spheres, boxes, cylinders, cones, capsules, planes and disks, each in
its own canonical space, plus the host-side :class:`Shape` that places one in the scene and its tessellation.

Every shape is intersected in a *canonical* space by the inverse-transformed ray (the lecture's "transform the ray
by the inverse transform": ``r'(t) = M^-1 p + t M^-1 d``, with ``t`` unchanged because the direction is not
renormalised). USD's size parameters (``radius``, ``size``, ``height``, ``width``, ``length``) and ``axis`` are folded
into the shape's transform, so one canonical shape per kind serves every gprim:

============  =========================================================================  ======================
kind          canonical shape                                                            parameters
============  =========================================================================  ======================
``sphere``    unit sphere at the origin                                                  -
``box``       ``[-1, 1]^3``                                                              -
``cylinder``  radius 1 around +Z, ``z`` in ``[-1, 1]``, caps at ``z = +-1``               ``capped`` (1 or 0)
``cone``      radius 1 at ``z = -1`` narrowing linearly to ``rho`` at ``z = 1`` (caps        ``capped`` (1 or 0),
              at both ends; ``rho = 0``: the apex, no top cap)                           ``rho`` in ``[0, 1)``
``capsule``   radius 1 around +Z: a cylinder for ``|z| <= H`` plus two hemispheres        ``H`` = half-height / radius
``tapered``   spheres of radius 1 at ``z = -H`` and ``rho`` at ``z = H`` joined by the       ``H``, ``rho`` in
              cone tangent to both (their convex hull; ``1 - rho < 2 H``)                ``[0, 1)``
``plane``     the square ``|x|, |y| <= 1`` at ``z = 0``, front along +Z                   -
``disk``      the unit disk at ``z = 0``, front along +Z                                 -
============  =========================================================================  ======================

``Cylinder_1`` with unequal radii is a ``cone`` with ``rho > 0`` (a frustum) and ``Capsule_1`` with unequal radii
is a ``tapered`` capsule, the larger radius at canonical ``-Z`` (a half turn about X puts it at USD's top when
``radiusTop`` is the larger): its tangent cone meets each sphere at the latitude ``asin((1 - rho) / (2 H))``. USD's
radii are the cone's at the ends of ``height`` (:func:`tapered_shape` finds the spheres, as
``UsdGeomCapsule_1::ComputeExtent`` and OpenUSD's ``GeomUtilCapsuleMeshGenerator`` place them).

Outward normals are the front side (``orientation = rightHanded``); ``params[3] = -1`` flips them
(``leftHanded``). Quadratics are solved in the numerically stable form of pbrt (``q = -(b + sign(b) sqrt(disc))``,
``t0 = q / a``, ``t1 = c / q``), with the discriminant of spheres and cylinders computed from the ray's closest
approach to the axis (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems, 2019),
so far-away rays keep their precision.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from .assignments import CountsAssignments, mark_checked
from .errors import (
    bottom_row_problem,
    did_you_mean,
    eight_bit_colors,
    flag,
    int32_problem,
    prim_path,
    stray_field,
    with_bottom_row,
)
from .floats import scaled_limit, unit_scales
from .geometry import ray_can_hit
from .instancing import invert_transforms, thicken_flat_transforms
from .ray_batch import host_array

SHAPE_SPHERE = wp.constant(0)
SHAPE_BOX = wp.constant(1)
SHAPE_CYLINDER = wp.constant(2)
SHAPE_CONE = wp.constant(3)
SHAPE_CAPSULE = wp.constant(4)
SHAPE_PLANE = wp.constant(5)
SHAPE_DISK = wp.constant(6)
SHAPE_TAPERED = wp.constant(7)
SHAPE_KINDS = {"sphere": 0, "box": 1, "cylinder": 2, "cone": 3, "capsule": 4, "plane": 5, "disk": 6,
               "tapered": 7}  # name -> code
DEFAULT_SEGMENTS = 64  # tessellation: segments around a circle (rings of a sphere: half as many)
MAX_SEGMENTS = 4096  # a sphere of 4096 segments is 16.8M triangles; 100000 ran out of memory without a message


# Device: intersections in canonical space


@wp.func
def nearest_root(t0: float, t1: float, t_min: float, t_max: float):
    """The smaller of ``t0 <= t1`` inside ``[t_min, t_max)``, else inf."""
    t = float(wp.inf)
    if t0 >= t_min and t0 < t_max:
        t = t0
    elif t1 >= t_min and t1 < t_max:
        t = t1
    return t


@wp.func
def solve_quadratic(a: float, b_half: float, c: float, disc: float):
    """Roots ``t0 <= t1`` of ``a t^2 + 2 b_half t + c`` given ``disc = b_half^2 - a c >= 0`` (pbrt's stable form)."""
    root = wp.sqrt(wp.max(disc, 0.0))
    q = -(b_half + wp.where(b_half >= 0.0, root, -root))
    t0 = float(wp.inf)
    t1 = float(wp.inf)
    if q != 0.0:
        t0 = q / a
        t1 = c / q
    elif a != 0.0:
        t0 = 0.0
        t1 = 0.0
    if t0 > t1:
        tmp = t0
        t0 = t1
        t1 = tmp
    return t0, t1


@wp.func
def sphere_roots(center_z: float, radius: float, o: wp.vec3, d: wp.vec3):
    """Both ``t0 <= t1`` where the line ``o + t d`` meets the sphere of ``radius`` centred at ``(0, 0, center_z)``
    (inf if it misses)."""
    oc = wp.vec3(o[0], o[1], o[2] - center_z)
    a = wp.dot(d, d)
    b_half = wp.dot(oc, d)
    closest = oc - (b_half / a) * d
    disc = a * (radius * radius - wp.dot(closest, closest))
    t0 = float(wp.inf)
    t1 = float(wp.inf)
    if disc >= 0.0:
        t0, t1 = solve_quadratic(a, b_half, wp.dot(oc, oc) - radius * radius, disc)
    return t0, t1


@wp.func
def intersect_unit_sphere(center_z: float, o: wp.vec3, d: wp.vec3, t_min: float, t_max: float):
    """Unit sphere centred at ``(0, 0, center_z)``: the nearest ``t`` in ``[t_min, t_max)``, inf if none."""
    t0, t1 = sphere_roots(center_z, 1.0, o, d)
    return nearest_root(t0, t1, t_min, t_max)


@wp.func
def intersect_sphere_part(
    center_z: float, radius: float, up: float, z_cut: float, o: wp.vec3, d: wp.vec3, t_min: float, t_max: float
):
    """The part of the sphere of ``radius`` at ``(0, 0, center_z)`` with ``up * (z - z_cut) >= 0`` (a hemisphere
    when ``z_cut = center_z``)."""
    t0, t1 = sphere_roots(center_z, radius, o, d)
    if t0 < wp.inf and up * (o[2] + t0 * d[2] - z_cut) < 0.0:
        t0 = wp.inf
    if t1 < wp.inf and up * (o[2] + t1 * d[2] - z_cut) < 0.0:
        t1 = wp.inf
    return nearest_root(wp.min(t0, t1), wp.max(t0, t1), t_min, t_max)


@wp.func
def intersect_unit_cylinder_side(o: wp.vec3, d: wp.vec3, z_lo: float, z_hi: float, t_min: float, t_max: float):
    """The side ``x^2 + y^2 = 1`` between ``z_lo`` and ``z_hi``: the nearest ``t`` in ``[t_min, t_max)``."""
    t = float(wp.inf)
    a = d[0] * d[0] + d[1] * d[1]
    if a > 0.0:
        b_half = o[0] * d[0] + o[1] * d[1]
        cx = o[0] - (b_half / a) * d[0]
        cy = o[1] - (b_half / a) * d[1]
        disc = a * (1.0 - (cx * cx + cy * cy))
        if disc >= 0.0:
            t0, t1 = solve_quadratic(a, b_half, o[0] * o[0] + o[1] * o[1] - 1.0, disc)
            z0 = o[2] + t0 * d[2]
            z1 = o[2] + t1 * d[2]
            if z0 < z_lo or z0 > z_hi:
                t0 = wp.inf
            if z1 < z_lo or z1 > z_hi:
                t1 = wp.inf
            t = nearest_root(wp.min(t0, t1), wp.max(t0, t1), t_min, t_max)
    return t


@wp.func
def intersect_disk_at(z0: float, radius: float, o: wp.vec3, d: wp.vec3, t_min: float, t_max: float):
    """The disk of ``radius`` around the Z axis at height ``z0``."""
    t = float(wp.inf)
    if d[2] != 0.0:
        s = (z0 - o[2]) / d[2]
        if s >= t_min and s < t_max:
            x = o[0] + s * d[0]
            y = o[1] + s * d[1]
            if x * x + y * y <= radius * radius:
                t = s
    return t


@wp.func
def intersect_unit_box(o: wp.vec3, d: wp.vec3, t_min: float, t_max: float):
    """``[-1, 1]^3``: the entry distance, or the exit distance for rays that start inside."""
    t_near = float(-wp.inf)
    t_far = float(wp.inf)
    for k in range(3):
        if d[k] != 0.0:
            inv = 1.0 / d[k]
            a = (-1.0 - o[k]) * inv
            b = (1.0 - o[k]) * inv
            t_near = wp.max(t_near, wp.min(a, b))
            t_far = wp.min(t_far, wp.max(a, b))
        elif o[k] < -1.0 or o[k] > 1.0:
            t_near = wp.inf
    t = float(wp.inf)
    if t_near <= t_far:
        t = nearest_root(t_near, t_far, t_min, t_max)
    return t


@wp.func
def intersect_cone_side(
    o: wp.vec3, d: wp.vec3, r0: float, slope: float, z_lo: float, z_hi: float, t_min: float, t_max: float
):
    """The side ``x^2 + y^2 = (r0 + slope z)^2`` for ``z`` in ``[z_lo, z_hi]``, where that radius is ``>= 0``.

    The quadratic is solved from the ray's point ``p`` nearest the canonical origin, as Haines et al. do for spheres:
    from a far origin, ``c = x^2 + y^2 - w^2`` was the difference of two large numbers, and its rounding made rays
    that pass near the surface (near the apex above all, where it curves most) hit it up to 3e-4 off (3e-3 near a
    tapered capsule's apex)."""
    t_c = -wp.dot(o, d) / wp.dot(d, d)
    p = o + t_c * d
    w = r0 + slope * p[2]  # the radius at p's height
    e = slope * d[2]  # and its change per unit of t
    a = d[0] * d[0] + d[1] * d[1] - e * e
    b_half = p[0] * d[0] + p[1] * d[1] - w * e
    c = p[0] * p[0] + p[1] * p[1] - w * w
    t0 = float(wp.inf)
    t1 = float(wp.inf)
    if wp.abs(a) < 1.0e-12 * wp.dot(d, d):
        # A ray parallel to the surface meets the cone once.
        if b_half != 0.0:
            t0 = -c / (2.0 * b_half)
    else:
        # b_half^2 - a c, written as |w d - e p|^2 - (p x d)^2 over x and y, a difference of two small squares: a
        # steep cone (the nearly flat ring between a tapered capsule's spheres when the small one almost sits inside
        # the big one) has large w and e, and b_half^2 and a c agreed in every float32 bit, so rays 1e-5 off the axis
        # missed the ring and went on to the far side.
        qx = w * d[0] - e * p[0]
        qy = w * d[1] - e * p[1]
        q_len = wp.sqrt(qx * qx + qy * qy)
        cross = wp.abs(p[0] * d[1] - p[1] * d[0])
        disc = (q_len - cross) * (q_len + cross)
        if disc >= 0.0:
            t0, t1 = solve_quadratic(a, b_half, c, disc)
    z0 = p[2] + t0 * d[2]
    z1 = p[2] + t1 * d[2]
    if not (z0 >= z_lo and z0 <= z_hi):
        t0 = wp.inf
    if not (z1 >= z_lo and z1 <= z_hi):
        t1 = wp.inf
    return nearest_root(wp.min(t0, t1) + t_c, wp.max(t0, t1) + t_c, t_min, t_max)


@wp.func
def cone_radius(rho: float):
    """``(r0, slope)`` of the canonical cone: radius ``r0 + slope z``, 1 at ``z = -1`` and ``rho`` at ``z = 1``."""
    return 0.5 + 0.5 * rho, 0.5 * rho - 0.5


@wp.func
def tangent_latitude(h: float, rho: float):
    """``(sin, cos)`` of the latitude at which the cone tangent to the canonical tapered capsule's spheres (radius 1
    at ``z = -h``, ``rho`` at ``z = h``) touches both: the sine is the radius difference over the centres' distance."""
    sin_lat = wp.min((1.0 - rho) / (2.0 * h), 1.0)
    return sin_lat, wp.sqrt(wp.max(1.0 - sin_lat * sin_lat, 0.0))


@wp.func
def intersect_shape(kind: int, params: wp.vec4, o: wp.vec3, d: wp.vec3, t_min: float, t_max: float):
    """Nearest ``t`` in ``[t_min, t_max)`` where ray ``o + t d`` (canonical space) meets shape ``kind``; inf if none.

    The direction is first scaled by a power of two so that its largest component lies in ``[1, 2)``: a shape of
    radius 1e-20 seen by a unit ray has a canonical direction of length 1e20, and the quadratics' ``d . d``
    overflowed (or underflowed, for huge shapes or tiny directions), so such shapes were missed. Scaling by a power
    of two is exact, so rays that were fine before get the same bits; limits that the scaling takes below float32's
    normal range are rounded up (``scaled_limit``), as ``ray_batch`` rounds them for the world ray's own scaling.

    A ray that is no finite float32 ray in canonical space (a world origin 2^102 away from a shape 2^-100 across)
    misses, as a BLAS takes it (``ray_can_hit``): the box test took an infinite origin for one inside every slab and
    returned ``t = -inf``, a hit below any ``t_min``."""
    t = float(wp.inf)
    if ray_can_hit(o, d, t_min, t_max):
        down, up = unit_scales(d)
        # o + t (d * down) is o + (t * down) d: the range scales up, the hit down.
        lo = scaled_limit(t_min, down, up)
        hi = scaled_limit(t_max, down, up)
        t = down * canonical_hit(kind, params, o, d * down, lo, hi)
    return t


@wp.func
def canonical_hit(kind: int, params: wp.vec4, o: wp.vec3, d: wp.vec3, t_min: float, t_max: float):
    """``intersect_shape`` for a direction of moderate length."""
    t = float(wp.inf)
    if kind == SHAPE_SPHERE:
        t = intersect_unit_sphere(0.0, o, d, t_min, t_max)
    elif kind == SHAPE_BOX:
        t = intersect_unit_box(o, d, t_min, t_max)
    elif kind == SHAPE_CYLINDER:
        t = intersect_unit_cylinder_side(o, d, -1.0, 1.0, t_min, t_max)
        if params[0] > 0.0:
            t = wp.min(t, intersect_disk_at(1.0, 1.0, o, d, t_min, t_max))
            t = wp.min(t, intersect_disk_at(-1.0, 1.0, o, d, t_min, t_max))
    elif kind == SHAPE_CONE:
        rho = params[1]
        r0, slope = cone_radius(rho)
        t = intersect_cone_side(o, d, r0, slope, -1.0, 1.0, t_min, t_max)
        if params[0] > 0.0:
            t = wp.min(t, intersect_disk_at(-1.0, 1.0, o, d, t_min, t_max))
            if rho > 0.0:
                t = wp.min(t, intersect_disk_at(1.0, rho, o, d, t_min, t_max))
    elif kind == SHAPE_CAPSULE:
        h = params[0]
        t = intersect_unit_cylinder_side(o, d, -h, h, t_min, t_max)
        t = wp.min(t, intersect_sphere_part(h, 1.0, 1.0, h, o, d, t_min, t_max))
        t = wp.min(t, intersect_sphere_part(-h, 1.0, -1.0, -h, o, d, t_min, t_max))
    elif kind == SHAPE_TAPERED:
        # The shape is convex, so its first hit is the nearest hit of its three parts, each cut at the tangent rings.
        h = params[0]
        rho = params[1]
        sin_lat, cos_lat = tangent_latitude(h, rho)
        z0 = -h + sin_lat  # the cone's bottom ring, on the sphere of radius 1
        z1 = h + rho * sin_lat  # its top ring, on the sphere of radius rho
        t = intersect_sphere_part(-h, 1.0, -1.0, z0, o, d, t_min, t_max)
        t = wp.min(t, intersect_sphere_part(h, rho, 1.0, z1, o, d, t_min, t_max))
        if cos_lat > 0.0:
            slope = -sin_lat / cos_lat
            t = wp.min(t, intersect_cone_side(o, d, cos_lat - slope * z0, slope, z0, z1, t_min, t_max))
    elif kind == SHAPE_PLANE:
        if d[2] != 0.0:
            s = -o[2] / d[2]
            if s >= t_min and s < t_max:
                x = o[0] + s * d[0]
                y = o[1] + s * d[1]
                if wp.abs(x) <= 1.0 and wp.abs(y) <= 1.0:
                    t = s
    elif kind == SHAPE_DISK:
        t = intersect_disk_at(0.0, 1.0, o, d, t_min, t_max)
    return t


@wp.func
def shape_surface(kind: int, params: wp.vec4, p: wp.vec3):
    """The point of the shape's surface nearest to ``p`` (a hit point off by rounding) and the outward normal there
    (unit, canonical space; flipped when ``params[3] < 0``). At rims the nearer surface wins."""
    q = p
    n = wp.vec3(0.0, 0.0, 1.0)
    if kind == SHAPE_SPHERE:
        n = wp.normalize(p)
        q = n
    elif kind == SHAPE_BOX:
        axis = int(0)
        if wp.abs(p[1]) > wp.abs(p[axis]):
            axis = 1
        if wp.abs(p[2]) > wp.abs(p[axis]):
            axis = 2
        s = wp.where(p[axis] >= 0.0, 1.0, -1.0)
        n = wp.vec3(0.0)
        n[axis] = s
        q[axis] = s
    elif kind == SHAPE_CYLINDER or kind == SHAPE_CAPSULE:
        h = float(1.0)
        if kind == SHAPE_CAPSULE:
            h = params[0]
        r = wp.sqrt(p[0] * p[0] + p[1] * p[1])
        radial = wp.vec3(1.0, 0.0, 0.0)
        if r > 0.0:
            radial = wp.vec3(p[0] / r, p[1] / r, 0.0)
        if kind == SHAPE_CAPSULE and wp.abs(p[2]) > h:
            c = wp.vec3(0.0, 0.0, wp.where(p[2] > 0.0, h, -h))
            n = wp.normalize(p - c)
            q = c + n
        elif kind == SHAPE_CYLINDER and params[0] > 0.0 and wp.abs(1.0 - wp.abs(p[2])) < wp.abs(1.0 - r):
            s = wp.where(p[2] >= 0.0, 1.0, -1.0)
            n = wp.vec3(0.0, 0.0, s)
            q = wp.vec3(p[0], p[1], s)
        else:
            n = radial
            q = wp.vec3(radial[0], radial[1], p[2])
    elif kind == SHAPE_CONE:
        rho = params[1]
        r0, slope = cone_radius(rho)
        r = wp.sqrt(p[0] * p[0] + p[1] * p[1])
        side = wp.abs(r - (r0 + slope * p[2])) / wp.sqrt(1.0 + slope * slope)
        bottom = wp.abs(p[2] + 1.0)
        top = float(wp.inf)  # no top cap at the apex
        if rho > 0.0:
            top = wp.abs(p[2] - 1.0)
        if params[0] > 0.0 and bottom < side and bottom <= top:
            n = wp.vec3(0.0, 0.0, -1.0)
            q = wp.vec3(p[0], p[1], -1.0)
        elif params[0] > 0.0 and top < side:
            n = wp.vec3(0.0, 0.0, 1.0)
            q = wp.vec3(p[0], p[1], 1.0)
        else:
            radial = wp.vec3(1.0, 0.0, 0.0)
            if r > 0.0:
                radial = wp.vec3(p[0] / r, p[1] / r, 0.0)
            n = wp.normalize(radial - wp.vec3(0.0, 0.0, slope))  # the gradient of r - (r0 + slope z)
            q = p
    elif kind == SHAPE_TAPERED:
        h = params[0]
        rho = params[1]
        sin_lat, cos_lat = tangent_latitude(h, rho)
        r = wp.sqrt(p[0] * p[0] + p[1] * p[1])
        radial = wp.vec3(1.0, 0.0, 0.0)
        if r > 0.0:
            radial = wp.vec3(p[0] / r, p[1] / r, 0.0)
        # The nearest part, from p's position along the tangent line (direction (-sin, cos) in the (r, z) plane)
        # past each sphere's tangent point; a top sphere of radius 0 (an apex) has no normal of its own.
        along = cos_lat * p[2] - sin_lat * r
        if along <= -cos_lat * h:
            centre = wp.vec3(0.0, 0.0, -h)
            n = wp.normalize(p - centre)
            q = centre + n
        elif along >= cos_lat * h and rho > 0.0:
            centre = wp.vec3(0.0, 0.0, h)
            n = wp.normalize(p - centre)
            q = centre + rho * n
        else:
            n = wp.vec3(cos_lat * radial[0], cos_lat * radial[1], sin_lat)
            q = p - (wp.dot(p - wp.vec3(0.0, 0.0, -h), n) - 1.0) * n  # the tangent plane is 1 from the bottom centre
    else:
        q = wp.vec3(p[0], p[1], 0.0)
    if params[3] < 0.0:
        n = -n
    return q, n


@wp.func
def shape_uv(kind: int, params: wp.vec4, p: wp.vec3):
    """Pseudo-barycentrics of a hit at canonical point ``p``, reported in hit buffers: ``u, v`` fall to 0 at the
    rims of flat faces (box faces, plane and disk edges, caps), so ``wrt.compare`` sees hits there as edge ties just
    as it does for triangle edges; elsewhere (curved surfaces) ``u = v = 1/3``. ``1 - u - v`` stays >= 1/3."""
    u = float(1.0 / 3.0)
    v = float(1.0 / 3.0)
    if kind == SHAPE_BOX:
        axis = int(0)
        if wp.abs(p[1]) > wp.abs(p[axis]):
            axis = 1
        if wp.abs(p[2]) > wp.abs(p[axis]):
            axis = 2
        a = p[(axis + 1) % 3]
        b = p[(axis + 2) % 3]
        u = wp.clamp(1.0 - wp.abs(a), 0.0, 1.0) / 3.0
        v = wp.clamp(1.0 - wp.abs(b), 0.0, 1.0) / 3.0
    elif kind == SHAPE_PLANE:
        u = wp.clamp(1.0 - wp.abs(p[0]), 0.0, 1.0) / 3.0
        v = wp.clamp(1.0 - wp.abs(p[1]), 0.0, 1.0) / 3.0
    elif kind == SHAPE_DISK or ((kind == SHAPE_CYLINDER or kind == SHAPE_CONE) and params[0] > 0.0):
        r = wp.sqrt(p[0] * p[0] + p[1] * p[1])
        rim = float(1.0)  # the radius of the cap at p's end (a cone's top: rho, 0 at the apex, which has none)
        if kind == SHAPE_CONE and p[2] > 0.0:
            rim = params[1]
        if kind == SHAPE_DISK or (rim > 0.0 and wp.abs(wp.abs(p[2]) - 1.0) < 1.0e-4):
            u = wp.clamp(rim - r, 0.0, 1.0) / 3.0
    return u, v


# Host: shapes in the scene


@dataclasses.dataclass
class Shape(CountsAssignments):
    """One analytic primitive placed in the scene (world space) or in a prototype (prototype space).

    Attributes:
        path: prim path of the source gprim (or a made-up name).
        kind: a key of :data:`SHAPE_KINDS`.
        to_world: ``(4, 4)`` float64 canonical space -> world (or prototype) space, column vectors; USD's size
            parameters and axis are part of it.
        params: ``(4,)`` float32: ``[capped or H, rho or 0, 0, orientation sign]`` (see the module docstring).
        color: ``(3,)`` float32 linear displayColor, or None for none (drawn grey 0.5, or in its instance's colour:
            ``Instances.colors``).
        material_id: index into ``Scene.materials``, -1 for the default material.
        double_sided: the gprim's ``doubleSided``: when False camera rays pass through its back (as for meshes).
        opacity: its ``displayOpacity`` in [0, 1] with the default material (as ``Mesh.opacities``), or None
            (opaque).
        st: ``(2,)`` float32 texture coordinate its material's textures read at every point (a constant ``st``
            primvar of the gprim or inherited), or None: their ``st_fallback`` (shapes have no texture coordinates).
    """

    path: str
    kind: str
    to_world: np.ndarray
    params: np.ndarray = dataclasses.field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 1.0], np.float32))
    color: np.ndarray | None = None
    material_id: int = -1
    double_sided: bool = False
    opacity: float | None = None
    st: np.ndarray | None = None

    def __post_init__(self):
        path = prim_path(self.path, f"wrt.Shape {self.kind!r}")
        if path is not self.path:
            self.path = path
        stray = stray_field(self, internal=("draws_nothing", "warned"))  # shape.radius = 2: read by nothing
        if stray:
            raise ValueError(f"shape {self.path}: {stray}")
        if not (isinstance(self.kind, str) and self.kind in SHAPE_KINDS):  # a list failed as unhashable
            hint = did_you_mean(self.kind, SHAPE_KINDS) if isinstance(self.kind, str) else ""
            raise ValueError(f"shape {self.path}: unknown shape kind {self.kind!r}{hint}; valid kinds: "
                             f"{', '.join(SHAPE_KINDS)}")
        if type(self.double_sided) is not bool:  # "no" was taken by its truth: double-sided
            self.double_sided = flag(self.double_sided, f"shape {self.path}: double_sided")
        if type(self.material_id) is not int or not -(2**31) <= self.material_id < 2**31:
            self.material_id = self._checked_material_id()  # the scene casts it to int32: 0.7, 2**32 drew material 0
        to_world = self._checked_to_world()
        # As for instances, lights and cameras: a Gf.Matrix4d passed untransposed has its translation in the bottom
        # row, which was dropped without a word (the shape drawn at the origin, sheared).
        problem = bottom_row_problem(f"shape {self.path} to_world", to_world) if np.isfinite(to_world).all() else None
        if problem:
            raise ValueError(problem)
        # A zero scale on one axis flattens it into a disc or sheet: thickened, as the USD loader thickens such
        # gprims; built in Python it had no canonical space to intersect in and vanished without a word.
        if not invert_transforms(to_world[None])[1][0]:
            thick, flat = thicken_flat_transforms(to_world[None])
            to_world = thick[0] if flat[0] else to_world
        # A line or a point draws nothing: the Scene holding it says so (Scene.warn_vanishing_shapes; load_usd draws
        # such gprims as meshes and says so itself), as it vanished without a word.
        object.__setattr__(self, "draws_nothing", not invert_transforms(to_world[None])[1][0]
                           and bool(np.isfinite(to_world).all()))
        object.__setattr__(self, "warned", False)
        if to_world is not self.to_world:  # only a real change: each assignment counts as a scene edit
            self.to_world = to_world
        self.params = self._real_numbers("params", 4, "4 finite numbers").astype(np.float32)
        if not np.isfinite(self.params).all():  # a capsule of NaN height, a cylinder of NaN caps: missed by every ray
            raise ValueError(f"shape {self.path}: params must be 4 finite numbers, got {self.params.tolist()}")
        if problem := self._params_problem():
            raise ValueError(f"shape {self.path}: {problem}")
        if self.color is not None:
            color = self._real_numbers("color", 3, "3 finite numbers or None")
            if problem := eight_bit_colors(color):
                raise ValueError(f"shape {self.path}: {problem}")
            self.color = color.astype(np.float32)
            if not np.isfinite(self.color).all():  # NaN would read as "none" on the device, inf shade as inf
                raise ValueError(f"shape {self.path}: color must be 3 finite numbers or None, got "
                                 f"{self.color.tolist()}")
        if self.opacity is not None:
            self.opacity = float(self._real_numbers("opacity", 1, "a number in [0, 1] or None")[0])
            if not 0.0 <= self.opacity <= 1.0:  # NaN too: it would mean "none" on the device
                raise ValueError(f"shape {self.path}: opacity must be in [0, 1] or None, got {self.opacity!r}")
        if self.st is not None:
            st = self._real_numbers("st", 2, "2 finite numbers or None").astype(np.float32)
            if not np.isfinite(st).all():
                raise ValueError(f"shape {self.path}: st must be 2 finite numbers or None, got {st.tolist()}")
            self.st = st
        mark_checked(self)

    def _params_problem(self) -> str | None:
        """Why finite :attr:`params` are refused for the shape's kind, or None: a capsule's negative ``H`` (half the
        height), a tapered capsule's ``H`` that is not positive, or a cone's or tapered capsule's ``rho`` outside
        [0, 1] (the module docstring's table). The loader never makes them; built in Python, a cone widening to
        ``rho = 2`` was cut off at its canonical box, a negative ``H`` or ``rho`` drew a shape of no USD prim, and a
        tapered capsule of ``H = 0`` failed in its tessellation (ZeroDivisionError), each without a word naming it."""
        h, rho = float(self.params[0]), float(self.params[1])
        if self.kind == "capsule" and h < 0.0:
            return f"params[0] (H, half the height over the radius) of a capsule must be >= 0, got {h!r}"
        if self.kind == "tapered" and not h > 0.0:
            return f"params[0] (H, half the distance between the spheres) of a tapered capsule must be > 0, got {h!r}"
        if self.kind in ("cone", "tapered") and not 0.0 <= rho <= 1.0:
            return f"params[1] (rho, the top radius) of a {self.kind} must be in [0, 1], got {rho!r}"
        return None

    def _real_numbers(self, name: str, count: int, need: str) -> np.ndarray:
        """Field ``name`` as ``(count,)`` real numbers, in the dtype given (integers kept for
        :func:`wrt.errors.eight_bit_colors`): one on a GPU (a ``wp.array`` on CUDA, a torch tensor) is copied to the
        host (:func:`wrt.ray_batch.host_array`), as a mesh's arrays are; numpy refused it, naming no shape. Text
        (``color="red"``, ``opacity="0.5"``), bools, complex values (their imaginary part dropped with only numpy's
        warning) and arrays of another size (numpy's "cannot reshape") are refused, as a mesh's colours are.

        Raises:
            ValueError: naming the shape and the field.
        """
        value = getattr(self, name)
        try:
            array = np.asarray(host_array(f"shape {self.path} {name}", value))
        except (TypeError, ValueError):  # a ragged list, an object DLPack cannot read
            array = None
        if array is None or array.dtype.kind not in "iuf" or array.size != count:
            got = f"{type(value).__name__} {value!r}" if array is None or array.size <= 16 else f"shape {array.shape}"
            raise ValueError(f"shape {self.path}: {name} must be {need}, got {got}")
        return array.reshape(count)

    def _checked_to_world(self) -> np.ndarray:
        """:attr:`to_world` as a ``(4, 4)`` float64 array: one on a GPU (a ``wp.array`` on CUDA, a torch tensor) is
        copied to the host (:func:`wrt.ray_batch.host_array`), as a mesh's arrays are, and a ``(3, 4)`` one (the
        affine part, as the device holds it) gets its bottom row ``(0, 0, 0, 1)``; both failed with numpy's messages,
        naming no shape. A ``(16,)`` one is read row by row, as before.

        Raises:
            ValueError: naming the shape, for any other shape or no numbers.
        """
        value = self.to_world
        if type(value) is np.ndarray and value.shape == (4, 4) and value.dtype == np.float64:
            # The loader's, kept as it is (the same object: an assignment counts as an edit); a view of another array
            # (poses[k] of the caller's (N, 4, 4) stack) is copied: Scene.freeze made the view alone read-only, and
            # the caller's edit of the stack moved the shape under the cached trees without a word.
            return value if value.base is None else value.copy()
        try:
            matrix = np.asarray(host_array(f"shape {self.path} to_world", value))
            if matrix.dtype.kind not in "iufO":  # text ("1.0"), bools and complex values converted without a word
                raise TypeError
            matrix = np.array(matrix, np.float64)  # a copy: a (16,) one was reshaped into a view
        except (TypeError, ValueError):  # text, a ragged list, an object numpy and DLPack cannot read
            matrix = None
        if matrix is not None:
            matrix = with_bottom_row(matrix)
        if matrix is None or matrix.shape not in ((4, 4), (16,)):
            got = f"shape {matrix.shape}" if matrix is not None else f"{type(value).__name__} {value!r}"
            raise ValueError(f"shape {self.path}: to_world must be a (4, 4) column-vector transform, p_world = M @ (p, "
                             f"1), or its top (3, 4), got {got}")
        return matrix.reshape(4, 4)

    def _checked_material_id(self) -> int:
        """:attr:`material_id` as an ``int``, checked as a mesh's ``material_ids`` are
        (:func:`wrt.errors.int32_problem`; a whole float is the integer it holds): the scene casts it to int32, where
        0.7 was cut to material 0 and 2**32 wrapped round to it, each without a word.

        Raises:
            ValueError: naming the shape.
        """
        value = self.material_id
        try:
            array = np.asarray(value)
        except ValueError:  # ragged
            array = np.asarray(None)
        if array.ndim != 0 or int32_problem(array.reshape(1)):
            raise ValueError(f"shape {self.path}: material_id must be an int32 integer (an index into Scene.materials, "
                             f"-1: the default material), got {value!r}")
        return int(array)

    def local_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Canonical-space box ``(lower, upper)``."""
        lower, upper = local_boxes([self])
        return lower[0], upper[0]


def local_boxes(shapes: list) -> tuple[np.ndarray, np.ndarray]:
    """``(N, 3)`` float64 canonical-space boxes ``(lowers, uppers)`` of ``shapes``, in one pass of numpy (a scene of
    100k shapes checked them one by one at every build): the unit cube, flat for a plane or disk, a capsule's and
    tapered capsule's stretched along z by their ``H`` (up to the top sphere ``rho`` of a tapered one)."""
    kinds = np.array([shape.kind for shape in shapes], dtype=object)
    params = np.array([shape.params for shape in shapes], np.float64).reshape(-1, 4)
    lowers, uppers = np.full((len(shapes), 3), -1.0), np.full((len(shapes), 3), 1.0)
    flat = (kinds == "plane") | (kinds == "disk")
    lowers[flat, 2] = uppers[flat, 2] = 0.0
    long = (kinds == "capsule") | (kinds == "tapered")
    top = np.where(kinds == "tapered", params[:, 1], 1.0)
    lowers[long, 2] = -1.0 - params[long, 0]
    uppers[long, 2] = top[long] + params[long, 0]
    return lowers, uppers


def axis_rotation(axis: str) -> np.ndarray:
    """``(3, 3)`` rotation taking canonical +Z to USD's ``axis`` (``"X"``, ``"Y"`` or ``"Z"``), with canonical X and Y
    on the axes that ``UsdGeom.Plane`` gives its width and length (X: width along Z; Y: width along X, length along
    Z; Z: width along X, length along Y)."""
    columns = {"X": ([0, 0, 1], [0, -1, 0], [1, 0, 0]), "Y": ([1, 0, 0], [0, 0, -1], [0, 1, 0]), "Z": np.eye(3)}
    if axis not in columns:
        raise ValueError(f"axis must be X, Y or Z, got {axis!r}")
    return np.array(columns[axis], np.float64).T


def shape_transform(linear: np.ndarray) -> np.ndarray:
    """A ``(4, 4)`` column-vector transform with ``linear`` as its 3x3 part."""
    m = np.eye(4)
    m[:3, :3] = linear
    return m


def tapered_shape(type_name: str, height: float, bottom: float, top: float):
    """The shape of a USD ``Cylinder_1`` or ``Capsule_1`` (``type_name``) of ``height`` and radii ``bottom`` at
    ``z = -height / 2`` and ``top`` at ``z = height / 2`` (one of them may be 0), its axis along +Z.

    Equal radii make a ``cylinder`` or ``capsule``, as ``Cylinder`` and ``Capsule`` do; unequal ones a capped
    ``cone`` whose apex is cut at the smaller radius (a frustum; the apex itself when it is 0) or a ``tapered``
    capsule, the larger end at canonical -Z (turned half about X when that end is the top): the cone of those radii
    at the ends of ``height`` and the spheres tangent to it there, as USD's extent and mesh generator have it (a
    capsule of height 0 is the larger sphere).

    Returns:
        ``(kind, transform, p0, p1)``: ``transform`` ``(4, 4)`` float64 canonical space -> the gprim's frame before
        its axis rotation, and ``Shape.params[0:2]``.
    """
    big, small = max(bottom, top), min(bottom, top)
    turn = np.eye(3) if bottom >= top else np.diag([1.0, -1.0, -1.0])  # a rotation: the winding stays
    if type_name == "Cylinder_1":
        if bottom == top:
            return "cylinder", shape_transform(np.diag([big, big, height / 2.0])), 1.0, 0.0
        return "cone", shape_transform(turn @ np.diag([big, big, height / 2.0])), 1.0, small / big
    if type_name != "Capsule_1":
        raise ValueError(f"type_name must be Cylinder_1 or Capsule_1, got {type_name!r}")
    if bottom == top:
        return "capsule", shape_transform(np.eye(3) * big), height / (2.0 * big), 0.0
    if height == 0.0:  # both spheres at the origin, as USD's extent has them: the larger
        return "sphere", shape_transform(np.eye(3) * big), 1.0, 0.0
    # The radii are the cone's at the ends of height; the spheres it is tangent to there are larger by the secant of
    # its slope and centred past the ends, as UsdGeomCapsule_1::ComputeExtent and GeomUtilCapsuleMeshGenerator place
    # them (larger end at canonical -Z here): centres -h/2 - slope * big and h/2 - slope * small.
    slope = (big - small) / height
    radius = big * math.sqrt(1.0 + slope * slope)  # of the larger sphere: the canonical unit
    middle = -slope * (big + small) / 2.0
    # Half the distance between the centres: always above half the difference of the sphere radii, so the smaller
    # sphere is never inside the larger (no special case, unlike spheres of the radii themselves at the ends).
    half = (height + slope * (big - small)) / 2.0
    m = shape_transform(turn * radius)
    m[:3, 3] = turn @ np.array([0.0, 0.0, middle])
    return "tapered", m, half / radius, small / big


def tessellate(shape: Shape, segments: int = DEFAULT_SEGMENTS):
    """Triangles approximating ``shape`` in its own (world or prototype) space, every vertex on the surface.

    A sphere gets ``segments`` meridians and ``segments // 2`` rings; circles of cylinders, cones and capsules get
    ``segments`` sides (capsule caps ``segments // 4`` rings each, a tapered capsule's caps as many per quarter turn
    of latitude); boxes, planes and their faces are exact. The position error of the curved parts falls as
    ``O(h^2)`` with the edge length ``h`` (the sagitta of each chord).

    Returns:
        ``points`` ``(V, 3)`` float64, ``indices`` ``(T, 3)`` int32 with ``cross(p1 - p0, p2 - p0)`` towards the front
        side, and ``normals`` ``(T, 3, 3)`` float64 unit shading normal per corner (the analytic normal; flat for
        flat faces), all in the shape's space.
    """
    segments = max(int(segments), 3)
    parts = []  # (points (V, 3), triangles (T, 3), corner normals (T, 3, 3)) in canonical space

    def add(points, triangles, normals_at=None, flat=None):
        points = np.asarray(points, np.float64)
        triangles = np.asarray(triangles, np.int64).reshape(-1, 3)
        if flat is not None:
            normals = np.broadcast_to(np.asarray(flat, np.float64), (len(triangles), 3, 3))
        else:
            normals = normals_at(points)[triangles]
        parts.append((points, triangles, normals))

    phi = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = np.stack([np.cos(phi), np.sin(phi)], axis=1)

    def band(z_lo_ring, z_hi_ring):
        """Triangles joining two rings of ``segments`` points (counter-clockwise seen from outside)."""
        i = np.arange(segments)
        j = (i + 1) % segments
        lo, hi = z_lo_ring + i, z_lo_ring + j
        return np.concatenate([np.stack([lo, hi, z_hi_ring + j], 1), np.stack([lo, z_hi_ring + j, z_hi_ring + i], 1)])

    def lathe(profile):
        """Surface of revolution through ``profile`` ``(R, 2)`` rows of (radius, z), bottom to top; poles (radius 0)
        become single points."""
        points, triangles = [], []
        index = []
        for r, z in profile:
            index.append(len(points))
            if r == 0.0:
                points.append([0.0, 0.0, z])
            else:
                points += [[r * c, r * s, z] for c, s in ring]
        for k in range(len(profile) - 1):
            (r0, _), (r1, _) = profile[k], profile[k + 1]
            a, b = index[k], index[k + 1]
            i = np.arange(segments)
            j = (i + 1) % segments
            if r0 == 0.0 and r1 == 0.0:  # two poles in a row (a tapered capsule whose point end lies on its sphere)
                continue
            if r0 == 0.0:
                triangles.append(np.stack([np.full(segments, a), b + j, b + i], 1))
            elif r1 == 0.0:
                triangles.append(np.stack([a + i, a + j, np.full(segments, b)], 1))
            else:
                triangles.append(band(a, b))
        return np.array(points), np.concatenate(triangles)

    def cap(z, up, radius=1.0):
        """A flat disk of ``radius`` at ``z``, facing +Z when ``up``."""
        points = np.concatenate([[[0.0, 0.0, z]], np.column_stack([radius * ring, np.full(segments, z)])])
        i = np.arange(segments)
        j = (i + 1) % segments
        tris = (np.stack([np.zeros(segments, np.int64), 1 + i, 1 + j], 1) if up
                else np.stack([np.zeros(segments, np.int64), 1 + j, 1 + i], 1))
        add(points, tris, flat=[0.0, 0.0, 1.0 if up else -1.0])

    def slanted_normals(p, slope):
        """Unit outward normals at points ``p`` of a surface of revolution whose radius falls by ``slope`` per unit
        of z (a cone's side)."""
        r = np.linalg.norm(p[:, :2], axis=1, keepdims=True)
        radial = np.where(r > 0, p[:, :2] / np.where(r > 0, r, 1.0), [1.0, 0.0])
        n = np.column_stack([radial, np.full(len(p), slope)])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def add_lathe(points, tris, normals_at, apex):
        """``add`` for a ``lathe``; when ``apex``, its last point is a top pole where a cone ends, which has no single
        normal: its corner of each triangle gets the normal of that triangle's own meridian (at the middle of its
        other corners)."""
        normals = normals_at(points)[tris]
        if apex:
            at_apex = tris[:, 2] == len(points) - 1
            normals[at_apex, 2] = normals_at(points[tris[at_apex][:, [0, 1]]].mean(axis=1))
        parts.append((points, tris, normals))

    kind = shape.kind
    if kind == "sphere":
        theta = np.linspace(-np.pi / 2, np.pi / 2, max(segments // 2, 2) + 1)
        points, tris = lathe([(math.cos(t) if abs(t) < np.pi / 2 else 0.0, math.sin(t)) for t in theta])
        add(points, tris, normals_at=lambda p: p / np.linalg.norm(p, axis=1, keepdims=True))
    elif kind == "box":
        corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float64)
        faces = [(0, 2, 3, 1, [0, 0, -1]), (4, 5, 7, 6, [0, 0, 1]), (0, 1, 5, 4, [0, -1, 0]),
                 (2, 6, 7, 3, [0, 1, 0]), (0, 4, 6, 2, [-1, 0, 0]), (1, 3, 7, 5, [1, 0, 0])]
        for a, b, c, d, n in faces:
            add(corners[[a, b, c, d]], [[0, 1, 2], [0, 2, 3]], flat=n)
    elif kind == "cylinder":
        points, tris = lathe([(1.0, -1.0), (1.0, 1.0)])
        add(points, tris, normals_at=lambda p: p * [1.0, 1.0, 0.0])
        if shape.params[0] > 0:
            cap(1.0, True)
            cap(-1.0, False)
    elif kind == "cone":
        rho = float(shape.params[1])
        points, tris = lathe([(1.0, -1.0), (rho, 1.0)])
        add_lathe(points, tris, lambda p: slanted_normals(p, 0.5 - 0.5 * rho), apex=rho == 0)
        if shape.params[0] > 0:
            cap(-1.0, False)
            if rho > 0:
                cap(1.0, True, rho)
    elif kind == "capsule":
        h = float(shape.params[0])
        rings = max(segments // 4, 2)
        theta = np.linspace(0.0, np.pi / 2, rings + 1)
        bottom = [(math.sin(t) if t > 0 else 0.0, -h - math.cos(t)) for t in theta]
        top = [(math.cos(t), h + math.sin(t)) if t < np.pi / 2 else (0.0, h + 1.0) for t in theta]
        points, tris = lathe(bottom + top)

        def capsule_normals(p):
            c = np.clip(p[:, 2], -h, h)
            n = p - np.column_stack([np.zeros((len(p), 2)), c])
            return n / np.linalg.norm(n, axis=1, keepdims=True)

        add(points, tris, normals_at=capsule_normals)
    elif kind == "tapered":
        h, rho = float(shape.params[0]), float(shape.params[1])
        sin_lat = min((1.0 - rho) / (2.0 * h), 1.0)
        lat = math.asin(sin_lat)
        quarter = max(segments // 4, 2)  # rings per quarter turn of latitude, as a capsule's caps have

        def arc(lo, hi, radius, z):
            """Rings of a sphere from latitude ``lo`` to ``hi``; the poles are single points."""
            theta = np.linspace(lo, hi, max(round(quarter * (hi - lo) / (np.pi / 2)), 1) + 1)
            return [(radius * math.cos(t) if abs(t) < np.pi / 2 else 0.0, z + radius * math.sin(t)) for t in theta]

        top = arc(lat, np.pi / 2, rho, h) if rho > 0 else [(0.0, h)]
        points, tris = lathe(arc(-np.pi / 2, lat, 1.0, -h) + top)

        def tapered_normals(p):
            # Each point's part, from its position along the tangent line (direction (-sin, cos) in (r, z))
            # past each sphere's tangent point; the cone's normal is (cos, sin) in (r, z).
            r = np.linalg.norm(p[:, :2], axis=1)
            along = math.cos(lat) * p[:, 2] - sin_lat * r
            n = slanted_normals(p, math.tan(lat))
            for centre, part in ((-h, along <= -math.cos(lat) * h), (h, (along >= math.cos(lat) * h) & (rho > 0))):
                n[part] = p[part] - [0.0, 0.0, centre]
            return n / np.linalg.norm(n, axis=1, keepdims=True)

        add_lathe(points, tris, tapered_normals, apex=rho == 0)
    elif kind == "plane":
        add([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]], flat=[0.0, 0.0, 1.0])
    elif kind == "disk":
        cap(0.0, True)

    # Concatenate, flip for leftHanded, move to the shape's space (normals by the inverse transpose).
    offsets = np.cumsum([0] + [len(p) for p, _, _ in parts])
    points = np.concatenate([p for p, _, _ in parts])
    tris = np.concatenate([t + o for (_, t, _), o in zip(parts, offsets)])
    normals = np.concatenate([n for _, _, n in parts])
    if shape.params[3] < 0:
        tris = tris[:, [0, 2, 1]]
        normals = -normals[:, [0, 2, 1]]
    m = shape.to_world
    linear = m[:3, :3]
    world_points = points @ linear.T + m[:3, 3]
    det = np.linalg.det(linear)
    if det < 0:  # a mirroring transform flips the winding
        tris = tris[:, [0, 2, 1]]
        normals = normals[:, [0, 2, 1]]
    cofactor = np.linalg.inv(linear).T if det != 0 else np.zeros((3, 3))  # no sign: mirrored normals stay outward
    world_normals = normals @ cofactor.T
    length = np.linalg.norm(world_normals, axis=2, keepdims=True)
    world_normals = np.where(length > 0, world_normals / np.where(length > 0, length, 1.0), 0.0)
    return world_points, tris.astype(np.int32), world_normals


__all__ = ["SHAPE_KINDS", "Shape", "axis_rotation", "intersect_shape", "shape_surface", "shape_uv", "tapered_shape",
           "tessellate"]
