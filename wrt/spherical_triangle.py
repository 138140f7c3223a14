"""Sampling a triangle by the solid angle it subtends (Arvo 1995, "Stratified Sampling of Spherical Triangles"; the
steps of Pharr et al., PBRT 4th ed., 6.5.4, with the arc to the sub-triangle's corner as a half-angle tangent).

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
def smaller_sum(x: float, y: float, z: float, best: wp.vec2):
    """``best`` (``(sum of magnitudes, sum)``) or ``x + y + z`` where its terms' magnitudes sum to less."""
    cost = wp.abs(x) + wp.abs(y) + wp.abs(z)
    if cost < best[0]:
        return wp.vec2(cost, x + y + z)
    return best


@wp.func
def triangle_solid_angle(numerator: float, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Solid angle of the spherical triangle of unit vectors ``a, b, c`` (Van Oosterom and Strackee), ``numerator``
    their triple product's magnitude. Never negative, so ``atan2`` gives the half-angle in ``[0, pi]`` itself.

    The denominator ``1 + a.b + b.c + c.a`` is summed from the terms least in magnitude of the ways to write it
    without its constant: each ``x.y`` as itself, ``|x + y|^2 / 2 - 1`` or ``1 - |x - y|^2 / 2``, one sum's ``-1``
    cancelling the 1 and any other sum's a difference's ``+1``. Seen from near an edge's line of a needle (two
    corners nearly opposite, two nearly alike) the four terms near 1 summed to a value near 1e-6 and float32 rounding
    took the solid angle 44% off; near a broad triangle's edge a dot product near 0 is best as itself."""
    ab = wp.dot(a, b)
    bc = wp.dot(b, c)
    ca = wp.dot(c, a)
    s_ab = 0.5 * wp.length_sq(a + b)
    s_bc = 0.5 * wp.length_sq(b + c)
    s_ca = 0.5 * wp.length_sq(c + a)
    best = wp.vec2(1.0e30, 0.0)
    best = smaller_sum(s_ab, bc, ca, best)
    best = smaller_sum(s_bc, ca, ab, best)
    best = smaller_sum(s_ca, ab, bc, best)
    best = smaller_sum(s_ab, s_bc, -0.5 * wp.length_sq(c - a), best)
    best = smaller_sum(s_bc, s_ca, -0.5 * wp.length_sq(a - b), best)
    best = smaller_sum(s_ca, s_ab, -0.5 * wp.length_sq(b - c), best)
    return 2.0 * wp.atan2(numerator, best[1])


@wp.func
def subtended_solid_angle(p: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Solid angle triangle ``a, b, c`` subtends at ``p``, however small (0 where ``p`` is at a corner). The triple
    product is ``ua . ((b - a) x (c - a))`` over the distances to b and c: the edges are taken from the corners, not as
    differences of unit vectors nearly alike or opposite, whose cross product cancelled near the triangle's plane."""
    ua = unit_towards(p, a)
    ub = unit_towards(p, b)
    uc = unit_towards(p, c)
    if wp.length_sq(ua) == 0.0 or wp.length_sq(ub) == 0.0 or wp.length_sq(uc) == 0.0:
        return 0.0
    numerator = wp.abs(wp.dot(ua, wp.cross((b - a) / stable_length(b - p), (c - a) / stable_length(c - p))))
    return triangle_solid_angle(numerator, ua, ub, uc)


@wp.func
def seen_solid_angle(p: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Solid angle triangle ``a, b, c`` subtends at ``p`` (:func:`subtended_solid_angle`) if it is to be sampled by
    solid angle from there, else 0 (too small for float32, or ``p`` at a corner)."""
    omega = subtended_solid_angle(p, a, b, c)
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
    # The spherical triangle's angle at a, by atan2 of its sine and cosine: full precision near 0 and pi.
    alpha = wp.atan2(wp.length(wp.cross(n_ab, n_ca)), -wp.dot(n_ab, n_ca))
    # The sub-triangle of area x = u1 * omega keeps the angle at a; its third corner c' lies on the arc a-c, b' from
    # a, where tan(b' / 2) = sin(x / 2) / (tan(c / 2) sin(alpha - x / 2)) (Arvo's cos b' written as a half-angle
    # tangent; c is the side a-b, its half-angle's cosine and sine |va + vb| / 2 and |va - vb| / 2). Every factor is
    # free of cancellation: Arvo's quotient, its cos(alpha) an arccosine of a cosine near -1, drew from points near
    # the triangle's plane or an edge's line (1e-4 of its size away) 27% to 99% too little light, or twice too much.
    half_x = 0.5 * u1 * omega
    arc = 2.0 * wp.atan2(wp.length(va + vb) * wp.sin(half_x), wp.length(va - vb) * wp.max(wp.sin(alpha - half_x), 0.0))
    c_new = wp.cos(arc) * va + wp.sin(arc) * wp.cross(va, n_ca)  # along the arc a-c
    cos_t = 1.0 - u2 * (1.0 - wp.dot(c_new, vb))
    sin_t = wp.sqrt(wp.max(1.0 - cos_t * cos_t, 0.0))
    return wp.normalize(cos_t * vb + sin_t * orthonormal_part(c_new, vb))
