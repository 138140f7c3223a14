"""Sampling a triangle by the solid angle it subtends (Arvo 1995, "Stratified Sampling of Spherical Triangles"; the
form of Pharr et al., PBRT 4th ed., 6.5.4).

Uniform area sampling of an emissive triangle that is large next to its distance (a glowing ceiling panel over a
floor 0.1 below it) puts almost every sample far off to the side, where it carries almost no light, so the few that
land overhead carry the whole estimate: an integrator that samples lights alone (``whitted``) showed a floor 0.1 under
a 40 x 40 glowing quad at 0.07 of its light at 64 samples, the rest in rare bright pixels. By solid angle every sample
carries ``L cos(theta) * solid angle``, bounded. The solid angle is Van Oosterom and Strackee's (1983) arctangent,
which keeps its relative precision for small triangles; below ``SOLID_ANGLE_MIN`` the triangle is sampled by area
(float32 rounding of the corner angles is then a visible fraction of it, and area sampling serves small lights well).
"""

import warp as wp

from .geometry import stable_length
from .sampling import PI
from .spherical_rect import SOLID_ANGLE_MIN


@wp.func
def unit_towards(p: wp.vec3, q: wp.vec3):
    """Unit vector from ``p`` to ``q`` (zero where they coincide); stable_length keeps far corners finite."""
    v = q - p
    length = stable_length(v)
    if length > 0.0:
        return v / length
    return wp.vec3(0.0)


@wp.func
def triangle_solid_angle(a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Solid angle of the spherical triangle of unit vectors ``a, b, c`` (Van Oosterom and Strackee). The numerator
    is never negative, so ``atan2`` gives the half-angle in ``[0, pi]`` itself: no correction of a negative one, as
    the plain arctangent of their quotient would need."""
    numerator = wp.abs(wp.dot(a, wp.cross(b, c)))
    denominator = 1.0 + wp.dot(a, b) + wp.dot(b, c) + wp.dot(c, a)
    return 2.0 * wp.atan2(numerator, denominator)


@wp.func
def seen_solid_angle(p: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Solid angle triangle ``a, b, c`` subtends at ``p`` if it is to be sampled by solid angle from there, else 0
    (too small for float32, or ``p`` at a corner)."""
    ua = unit_towards(p, a)
    ub = unit_towards(p, b)
    uc = unit_towards(p, c)
    if wp.length_sq(ua) == 0.0 or wp.length_sq(ub) == 0.0 or wp.length_sq(uc) == 0.0:
        return 0.0
    omega = triangle_solid_angle(ua, ub, uc)
    return wp.where(omega >= SOLID_ANGLE_MIN, omega, 0.0)


@wp.func
def orthonormal_part(v: wp.vec3, w: wp.vec3):
    """The unit part of ``v`` orthogonal to unit ``w`` (Gram-Schmidt)."""
    return wp.normalize(v - wp.dot(v, w) * w)


@wp.func
def sample_spherical_triangle(p: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3, omega: float, u1: float, u2: float):
    """A unit direction from ``p`` uniform over the solid angle ``omega`` (:func:`seen_solid_angle`, > 0) of triangle
    ``a, b, c``."""
    va = unit_towards(p, a)
    vb = unit_towards(p, b)
    vc = unit_towards(p, c)
    n_ab = wp.normalize(wp.cross(va, vb))
    n_ca = wp.normalize(wp.cross(vc, va))
    alpha = wp.acos(wp.clamp(-wp.dot(n_ab, n_ca), -1.0, 1.0))  # the spherical triangle's angle at a
    # The sub-triangle of area u1 * omega: its angle sum, less pi, is that area.
    area_pi = PI + u1 * omega
    sin_phi = wp.sin(area_pi) * wp.cos(alpha) - wp.cos(area_pi) * wp.sin(alpha)
    cos_phi = wp.cos(area_pi) * wp.cos(alpha) + wp.sin(area_pi) * wp.sin(alpha)
    k1 = cos_phi + wp.cos(alpha)
    k2 = sin_phi - wp.sin(alpha) * wp.dot(va, vb)
    cos_b = (k2 + (k2 * cos_phi - k1 * sin_phi) * wp.cos(alpha)) / ((k2 * sin_phi + k1 * cos_phi) * wp.sin(alpha))
    cos_b = wp.clamp(cos_b, -1.0, 1.0)
    sin_b = wp.sqrt(wp.max(1.0 - cos_b * cos_b, 0.0))
    c_new = cos_b * va + sin_b * orthonormal_part(vc, va)  # the sub-triangle's third corner, on the arc a-c
    cos_t = 1.0 - u2 * (1.0 - wp.dot(c_new, vb))
    sin_t = wp.sqrt(wp.max(1.0 - cos_t * cos_t, 0.0))
    return wp.normalize(cos_t * vb + sin_t * orthonormal_part(c_new, vb))
