"""A capped tube's flat caps drawn as a disk light is (:mod:`wrt.spherical_rect`: by the solid angle of the square
around the disk, the draws off the disk dropped): :mod:`wrt.glowing_tubes` mixes this draw in for the cap a shading
point lies beyond, whose front it sees. Drawn by area alone, a point 0.02 to 0.05 radii off a cap estimated its
light with a relative noise of 12 to 110 per draw (few draws landing on the patch under it).

A cap is the disk of the tube's radius at its end ``end`` (-1 the bottom, at ``-h`` along the unit axis ``w``; 1 the
top, at ``h``), facing outwards along the axis; every point is taken from the tube's centre, lengths times its
``down`` (the tube's largest length about 1).
"""

import warp as wp

from .sampling import PI, basis_x, basis_y
from .spherical_rect import (
    SOLID_ANGLE_MIN,
    sample_spherical_rect,
    solid_angle_usable,
    spherical_rect_pdf,
    square_around_disk,
)


@wp.func
def seen_cap(end: float, radius: float, h: float, w: wp.vec3, to_p: wp.vec3):
    """The square around the cap ``end`` of ``radius`` as the shading point ``to_p`` sees it (a ``SphericalRect``)."""
    return square_around_disk(to_p, (end * h) * w, radius * basis_x(w), radius * basis_y(w))


@wp.func
def cap_weight(end: float, radius: float, h: float, w: wp.vec3, to_p: wp.vec3):
    """The weight of the cap's draw from ``to_p``: the square root of the share of p's sky (``solid angle / 2 pi``)
    the square around it fills, as a capsule end's cone's (:func:`wrt.glowing_tubes.side_view` shares the guided
    draws by these), times ``height / (height + out)``, ``out`` how far p's foot on the plane lies off the disk; 0
    unless p lies beyond the cap's plane (it sees the cap's front) and the square's solid angle is accurate
    (:func:`wrt.spherical_rect.solid_angle_usable`), faded in over ``SOLID_ANGLE_MIN`` above that bound. Continuous
    in p off the cap (path reads a hit's density from its ray's origin, just off the shading point): by the square
    alone, a point just beyond the plane in the square's corner, off the disk (a floor a cylinder stands on), gave
    the cap near all the guided draws (the square filled near all its sky) and one just short of it none."""
    height = end * wp.dot(to_p, w) - h
    if radius <= 0.0 or height <= 0.0:
        return 0.0
    r = seen_cap(end, radius, h, w, to_p)
    if not solid_angle_usable(r, 0.0):
        return 0.0
    out = wp.max(wp.length(to_p - wp.dot(to_p, w) * w) - radius, 0.0)
    fade = wp.clamp((r.solid_angle - SOLID_ANGLE_MIN) / SOLID_ANGLE_MIN, 0.0, 1.0)
    return wp.sqrt(r.solid_angle / (2.0 * PI)) * fade * height / (height + out)


@wp.func
def cap_density(end: float, radius: float, h: float, w: wp.vec3, to_p: wp.vec3, q_rel: wp.vec3):
    """Density by area with which :func:`sample_cap` draws the cap's point ``q_rel``: the square's solid-angle pdf
    times ``cos / d^2`` on the disk, 0 off it (and off the square cut to ``REACH`` heights around p's foot)."""
    if wp.length(q_rel - (end * h) * w) > radius:
        return 0.0
    v = to_p - q_rel
    d2 = wp.length_sq(v)
    if d2 <= 0.0:
        return 0.0
    pdf = spherical_rect_pdf(seen_cap(end, radius, h, w, to_p), wp.vec3(0.0), q_rel)
    return pdf * wp.abs(wp.dot(v, w)) / (d2 * wp.sqrt(d2))


@wp.func
def sample_cap(end: float, radius: float, h: float, w: wp.vec3, to_p: wp.vec3, u1: float, u2: float):
    """``(q_rel, kept)``: a point of the cap's plane drawn uniformly in the solid angle of the square around the cap
    (no cosine-weighted share: a tube's draw has no shading normal), kept where it lies on the disk."""
    q_rel, inside = sample_spherical_rect(seen_cap(end, radius, h, w, to_p), wp.vec3(0.0), u1, u2)
    return q_rel, inside and wp.length(q_rel - (end * h) * w) <= radius


__all__ = ["cap_density", "cap_weight", "sample_cap"]
