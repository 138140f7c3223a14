"""A sphere seen from a point: the cone it subtends, a direction drawn uniformly in it and where a ray enters the
sphere. Sphere lights, glowing spheres and the end spheres of glowing capsules (:mod:`wrt.glowing_tubes`) are drawn
by their cones; ellipsoids (:mod:`wrt.affine_lights`) intersect the unit sphere of their canonical frame.
"""

import warp as wp

from .floats import power_scales
from .sampling import sample_uniform_cone, to_world


@wp.func
def cone_of_sphere(c: wp.vec3, radius: float, p: wp.vec3):
    """``(cos_max, 1 - cos_max)`` of the cone the sphere of centre ``c`` subtends at ``p``; ``cos_max = 2`` when
    inside. Its lengths are taken times the power of two that brings ``radius`` into [1, 2) (their squares over- or
    underflowed in scenes 1e20 or 1e-22 across)."""
    down, _ = power_scales(radius)
    r = radius * down
    d2 = wp.length_sq((c - p) * down)
    if d2 <= r * r:
        return 2.0, 0.0
    sin2 = r * r / d2
    cos_max = wp.sqrt(wp.max(0.0, 1.0 - sin2))
    one_minus = sin2 / (1.0 + cos_max)  # 1 - cos_max without cancellation
    return cos_max, one_minus


@wp.func
def intersect_sphere(c: wp.vec3, r: float, o: wp.vec3, d: wp.vec3):
    """Nearest ``t > 0`` where ray ``o + t d`` (any length ``d``) enters the sphere of centre ``c`` and radius ``r``
    from outside; inf if none. Round sphere lights use it as it is, ellipsoids on the unit sphere of their canonical
    frame.

    The half chord from the ray's closest approach to the centre, ``r^2 - |closest - c|^2`` (Haines et al.,
    "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems 2019), as wrt/primitives.py does:
    ``b^2 - c`` cancels in float32 for a sphere small next to its distance, and rays saw a light 1000 radii away 15%
    too large."""
    oc = o - c
    if wp.dot(oc, oc) <= r * r:
        return float(wp.inf)
    dd = wp.dot(d, d)
    if dd <= 0.0:
        return float(wp.inf)
    t_mid = -wp.dot(oc, d) / dd
    closest = oc + t_mid * d
    half2 = r * r - wp.dot(closest, closest)
    if half2 < 0.0:
        return float(wp.inf)
    t = t_mid - wp.sqrt(half2 / dd)
    if t <= 0.0:
        return float(wp.inf)
    return t


@wp.func
def sample_sphere_cone(c: wp.vec3, radius: float, p: wp.vec3, u1: float, u2: float):
    """``(wi, t, one_minus)``: a unit direction from ``p`` uniform in the cone the sphere of centre ``c`` and
    ``radius`` subtends (solid-angle pdf ``1 / (2 pi one_minus)``), the distance along it to where it enters the
    sphere, and the cone's ``1 - cos_max``: 0 (nothing drawn) from inside. Lengths are taken times the power of two
    that brings ``radius`` into [1, 2) (the direction's squares overflowed 1e19 radii away in world units)."""
    cos_max, one_minus = cone_of_sphere(c, radius, p)
    if cos_max > 1.0 or one_minus <= 0.0:
        return wp.vec3(0.0, 0.0, 1.0), float(wp.inf), 0.0
    down, up = power_scales(radius)
    wi = wp.normalize(to_world(sample_uniform_cone(u1, u2, one_minus), wp.normalize((c - p) * down)))
    t = intersect_sphere(c * down, radius * down, p * down, wi) * up
    if t == wp.inf:
        t = wp.dot(c - p, wi)  # grazing: rounding missed the sphere by a hair
    return wi, t, one_minus
