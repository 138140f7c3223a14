"""Sampling a parallelogram by the solid angle it subtends: a rect light or glowing plane under a transform that
shears it, whose edges are not at right angles, as Urena et al.'s map (:mod:`wrt.spherical_rect`) needs them.

The parallelogram is split along its shorter diagonal into two triangles; one is picked with probability its share
of the solid angle, and a direction is drawn uniformly in that triangle's solid angle by Arvo's method
(:mod:`wrt.spherical_triangle`). The draw is then uniform over the parallelogram's solid angle, of pdf
``1 / (omega_abc + omega_acd)`` wherever the direction meets it, so a ray that hits the light reads the pdf back
without asking which triangle it crossed. A triangle that looks tiny (under ``SOLID_ANGLE_MIN``, where float32
rounding of Arvo's corner angles is a visible fraction of it) while the other does not (a point near the plane, by
one triangle and far from the other) is drawn uniformly by area within it instead, still picked by its share of the
solid angle: its pdf is that share over the area pdf of half the parallelogram. Where the whole looks tiny the caller
draws the parallelogram by area (small lights are sampled well by area).

A share ``(solid angle / 2 pi)^2`` of the draws are cosine-weighted directions about the shading normal (those that
miss the parallelogram carry nothing), and the pdf is the mixture's: uniform in solid angle alone, the receiver's
cosine varies over the directions a point near the plane sees, a relative noise per draw of 0.55 0.01 below the
centre of a unit parallelogram sheared by 0.8 (0.04 mixed). The share is the square of a rect's
(:func:`wrt.spherical_rect.cosine_share`): at the rect's share the draws that miss a light that looks only moderately
large doubled the noise 1 below it (0.06 by solid angle alone, 0.33 at the rect's share, 0.13 at its square). Drawn
by area alone, as before, the noise 0.01 below that parallelogram's centre was 34 per draw, 0.1 below 3.2.
"""

import warp as wp

from .geometry import stable_length
from .sampling import INV_PI, PI
from .spherical_rect import SOLID_ANGLE_MIN
from .spherical_triangle import subtended_solid_angle


@wp.struct
class SeenParallelogram:
    """A parallelogram as seen from a point: its corners in order around it, split along the diagonal ``a, c``."""

    a: wp.vec3  # corners (world), a-c the shorter diagonal: the triangles (a, b, c) and (a, c, d)
    b: wp.vec3
    c: wp.vec3
    d: wp.vec3
    omega_abc: float  # the solid angle triangle a, b, c subtends at the point (sr; 0 where the point is at a corner)
    omega_acd: float  # that of triangle a, c, d
    solid_angle: float  # their sum
    share: float  # the share of cosine-weighted draws (0 without a shading normal)
    axis: wp.vec3  # the unit axis they are drawn about: the shading normal, turned where the light lies behind it


@wp.func
def seen_parallelogram(p: wp.vec3, n: wp.vec3, centre: wp.vec3, u: wp.vec3, v: wp.vec3):
    """The parallelogram ``centre + a u + b v`` (a, b in [-1/2, 1/2]) seen from ``p``, of shading normal ``n`` (zero
    if none). Split along its shorter diagonal: the triangles of the longer one are needles for a strongly sheared
    light. The cosine-weighted share is drawn about ``n`` where some corner lies above its horizon, where an opaque
    surface takes light, else about ``-n`` (glass alone takes it), as a rect's (:func:`wrt.spherical_rect.
    cosine_share`): turned by the side of the plane ``p`` lies on, a surface tilted 1 degree away from a sheared light
    0.01 below it drew its cosine-weighted draws on its back, a relative noise per draw of 8.1, not 1.04."""
    s = SeenParallelogram()
    hu = 0.5 * u
    hv = 0.5 * v
    if stable_length(u + v) <= stable_length(u - v):
        s.a = centre - hu - hv
        s.b = centre + hu - hv
        s.c = centre + hu + hv
        s.d = centre - hu + hv
    else:
        s.a = centre + hu - hv
        s.b = centre + hu + hv
        s.c = centre - hu + hv
        s.d = centre - hu - hv
    s.omega_abc = subtended_solid_angle(p, s.a, s.b, s.c)
    s.omega_acd = subtended_solid_angle(p, s.a, s.c, s.d)
    s.solid_angle = s.omega_abc + s.omega_acd
    s.share = 0.0
    s.axis = n
    if wp.length_sq(n) > 0.0:
        fill = wp.min(s.solid_angle / (2.0 * PI), 1.0)  # squared: see the module docstring
        s.share = fill * fill
        above = wp.max(wp.max(wp.dot(n, s.a - p), wp.dot(n, s.b - p)), wp.max(wp.dot(n, s.c - p), wp.dot(n, s.d - p)))
        s.axis = wp.where(above > 0.0, n, -n)
    return s


@wp.func
def parallelogram_usable(s: SeenParallelogram):
    """True when the parallelogram is drawn by solid angle (:func:`pick_triangle`), else by area as a whole."""
    return s.solid_angle >= SOLID_ANGLE_MIN


@wp.func
def by_cosine(s: SeenParallelogram, u1: float):
    """Whether uniform ``u1`` picks a cosine-weighted draw about ``s.axis``, and ``u1`` stretched back to [0, 1)."""
    if u1 < s.share:
        return True, u1 / s.share
    return False, wp.min((u1 - s.share) / (1.0 - s.share), 1.0)


@wp.func
def pick_triangle(s: SeenParallelogram, u1: float):
    """``(a, b, c, omega, u1)``: the triangle of ``s`` that uniform ``u1`` picks by its share of the solid angle, its
    solid angle and ``u1`` stretched back to [0, 1)."""
    share = s.omega_abc / s.solid_angle
    if u1 < share:
        return s.a, s.b, s.c, s.omega_abc, wp.min(u1 / share, 1.0)
    return s.a, s.c, s.d, s.omega_acd, wp.min((u1 - share) / (1.0 - share), 1.0)


@wp.func
def triangle_by_solid_angle(omega: float):
    """True when a triangle of solid angle ``omega`` is drawn by Arvo's method, else by area within it."""
    return omega >= SOLID_ANGLE_MIN


@wp.func
def area_share_factor(s: SeenParallelogram, q: wp.vec3):
    """``omega_i / solid_angle`` of the triangle that point ``q`` of the plane lies in (on the side of the diagonal
    ``a, c`` that ``b`` lies on: triangle a, b, c), and whether that triangle is drawn by area."""
    # The sign of (c - a) x (q - a) along (c - a) x (b - a), of unit vectors where they can be: their products
    # overflowed for a light 1e20 wide.
    diagonal = s.c - s.a
    diagonal = diagonal / stable_length(diagonal)
    towards_b = wp.cross(diagonal, s.b - s.a)
    side = wp.dot(wp.cross(diagonal, q - s.a), towards_b / stable_length(towards_b))
    omega = wp.where(side >= 0.0, s.omega_abc, s.omega_acd)
    return omega / s.solid_angle, not triangle_by_solid_angle(omega)


@wp.func
def parallelogram_pdf(s: SeenParallelogram, q: wp.vec3, w: wp.vec3, by_area: float):
    """Solid-angle pdf of the draw of ``s`` along unit ``w`` from its point of view to point ``q`` of the
    parallelogram, ``by_area`` the pdf of a draw by area over the whole of it there: the cosine-weighted share's, and
    the rest's, ``1 / solid_angle``, or, where ``q`` lies in a half that looks tiny (drawn by area), that half's
    share of the solid angle over the area pdf of half the parallelogram."""
    pdf = s.share * wp.max(wp.dot(w, s.axis), 0.0) * INV_PI
    factor, within_by_area = area_share_factor(s, q)
    if within_by_area:
        return pdf + (1.0 - s.share) * 2.0 * factor * by_area
    return pdf + (1.0 - s.share) / s.solid_angle


__all__ = ["SeenParallelogram", "area_share_factor", "by_cosine", "parallelogram_pdf", "parallelogram_usable",
           "pick_triangle", "seen_parallelogram", "triangle_by_solid_angle"]
