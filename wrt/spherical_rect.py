"""Sampling a rectangle by the solid angle it subtends (Urena, Fajardo and King 2013, "An Area-Preserving
Parametrization for Spherical Rectangles"), mixed with cosine-weighted directions about the shading normal.

Uniform area sampling of a light that is large next to its distance (a sky panel over a floor) puts most samples far
off to the side, where they carry almost no light, so a few near samples carry the whole estimate and the image stays
noisy at any practical sample count. Solid-angle sampling spreads the samples evenly over what the shading point sees.
A light that fills most of the hemisphere is better sampled by the cosine a diffuse surface weighs it with, so a share
``solid angle / 2 pi`` of the samples are cosine-weighted directions (those that miss the rectangle carry nothing),
and the pdf is the mixture's. The solid angle is a difference of angles near 2 pi, which loses precision when the
rectangle looks small, so callers use this only where :func:`solid_angle_usable` says so and area sampling elsewhere
(small lights are sampled well by area anyway).
"""

import warp as wp

from .geometry import stable_length
from .sampling import INV_PI, PI, sample_cosine_hemisphere, to_world

# Below this solid angle (sr) float32 rounding of the edge angles is a visible fraction of it; above the maximum the
# rectangle fills nearly the whole hemisphere and the map's divisions by sin(au) lose precision.
SOLID_ANGLE_MIN = wp.constant(1.0e-3)
SOLID_ANGLE_MAX = wp.constant(2.0 * 3.14159265 - 1.0e-3)
# The rectangle is clipped to the square of half-side REACH * (the point's height above its plane) around the point's
# foot, which keeps the solid angle below SOLID_ANGLE_MAX. What is cut off lies far off to the side, at grazing angles
# to the plane: it gives a point facing the plane at most 1 / (1 + REACH^2) = 1.5e-5 of the irradiance under an
# endless light, but a point facing along the plane (a wall beside a ceiling panel, just below its plane) sees it head
# on, and it may be most of that point's light: callers draw a share by area over the whole light where it was cut.
REACH = wp.constant(256.0)


@wp.struct
class SphericalRect:
    """A rectangle as seen from a point ``o``, in the frame of its edges (Urena et al.'s notation)."""

    o: wp.vec3  # the viewpoint
    x: wp.vec3  # unit direction of the first edge
    y: wp.vec3  # unit direction of the second edge
    z: wp.vec3  # unit normal, oriented so that the rectangle's plane lies at z0 < 0
    x0: float  # the (clipped) rectangle spans [x0, x1] x [y0, y1] at height z0 in the frame (x, y, z) centred on o
    x1: float
    y0: float
    y1: float
    z0: float
    b0: float
    b1: float
    k: float
    solid_angle: float  # in steradians; 0 when o lies in the rectangle's plane
    clipped: float  # 1 when the reach cut part of the rectangle off, else 0


@wp.func
def with_angles(r: SphericalRect):
    """``r`` with the angles that follow from its bounds: the solid angle and Urena et al.'s ``b0, b1, k``."""
    if r.z0 == 0.0 or r.x0 >= r.x1 or r.y0 >= r.y1:
        r.solid_angle = 0.0  # seen edge on, or wholly beyond the reach
        return r
    # Normals of the four great circles through the edges (cross products of consecutive corners, in the frame).
    n0 = wp.normalize(wp.vec3(0.0, r.z0, -r.y0))
    n1 = wp.normalize(wp.vec3(-r.z0, 0.0, r.x1))
    n2 = wp.normalize(wp.vec3(0.0, -r.z0, r.y1))
    n3 = wp.normalize(wp.vec3(r.z0, 0.0, -r.x0))
    g0 = wp.acos(wp.clamp(-wp.dot(n0, n1), -1.0, 1.0))
    g1 = wp.acos(wp.clamp(-wp.dot(n1, n2), -1.0, 1.0))
    g2 = wp.acos(wp.clamp(-wp.dot(n2, n3), -1.0, 1.0))
    g3 = wp.acos(wp.clamp(-wp.dot(n3, n0), -1.0, 1.0))
    r.b0 = n0[2]
    r.b1 = n2[2]
    r.k = 2.0 * PI - g2 - g3
    r.solid_angle = wp.max(g0 + g1 - r.k, 0.0)
    return r


@wp.func
def spherical_rect(o: wp.vec3, centre: wp.vec3, ex: wp.vec3, ey: wp.vec3):
    """The rectangle ``centre + a ex + b ey`` (a, b in [-1/2, 1/2]; ``ex`` and ``ey`` orthogonal) seen from ``o``,
    clipped to the part within ``REACH`` heights of ``o``'s foot on its plane. The edges' lengths are
    ``stable_length``'s (``wp.length``'s bits where that keeps them): seen from 3 away, a light 1e21 wide has edges
    whose squares overflow, and it lit nothing. The height and the bounds are measured from the centre, rounded at
    ``o``'s distance from it: measured from a corner, they were rounded at the rectangle's size, and seen from 0.65
    off a glowing ellipse of radii 1e6 and 2e6 the points drawn lay 13% of their distance beyond it (its own surface
    shadowed them)."""
    r = SphericalRect()
    r.o = o
    ex_len = stable_length(ex)
    ey_len = stable_length(ey)
    r.x = ex / ex_len
    r.y = ey / ey_len
    r.z = wp.cross(r.x, r.y)
    d = centre - o
    r.z0 = wp.dot(d, r.z)
    if r.z0 > 0.0:
        r.z = -r.z
        r.z0 = -r.z0
    reach = -REACH * r.z0
    xc = wp.dot(d, r.x)
    yc = wp.dot(d, r.y)
    x0 = xc - 0.5 * ex_len
    y0 = yc - 0.5 * ey_len
    x1 = xc + 0.5 * ex_len
    y1 = yc + 0.5 * ey_len
    r.x0 = wp.max(x0, -reach)
    r.y0 = wp.max(y0, -reach)
    r.x1 = wp.min(x1, reach)
    r.y1 = wp.min(y1, reach)
    r.clipped = 0.0
    if r.x0 != x0 or r.y0 != y0 or r.x1 != x1 or r.y1 != y1:
        r.clipped = 1.0
    return with_angles(r)


@wp.func
def square_around_disk(o: wp.vec3, centre: wp.vec3, u: wp.vec3, v: wp.vec3):
    """The square around the disk ``centre + a u + b v`` (``a^2 + b^2 <= 1``; ``u`` and ``v`` orthogonal radius
    vectors) seen from ``o`` (:func:`spherical_rect`): a disk is drawn by solid angle through it, the draws that
    fall off the disk dropped, and its pdf is the square's on the disk."""
    return spherical_rect(o, centre, 2.0 * u, 2.0 * v)


@wp.func
def solid_angle_usable(r: SphericalRect, least: float):
    """True when :func:`sample_spherical_rect` is accurate for ``r`` and its solid angle is at least ``least``."""
    return r.solid_angle >= wp.max(least, SOLID_ANGLE_MIN) and r.solid_angle <= SOLID_ANGLE_MAX


@wp.func
def cosine_share(r: SphericalRect, n: wp.vec3):
    """The share of cosine-weighted samples, and the hemisphere axis they are drawn about: ``n`` where some of the
    (clipped) rectangle lies above its horizon, where an opaque surface takes light (``n`` faces the side the ray came
    from), else ``-n`` (the light lies wholly behind the surface: glass alone takes it). Turned by the sign of
    ``n . z`` alone, a surface tilted 1 degree away from a light's plane near it drew its cosine-weighted share (nearly
    all its draws) on its back, where an opaque surface takes nothing: a relative noise per draw of 16, not 1; a
    surface at right angles to the plane was turned by the rounding of ``z``."""
    if wp.length_sq(n) == 0.0:
        return 0.0, n
    # The largest n . (corner - o) over the rectangle's corners (x, y, z0) in its frame: above n's horizon if > 0.
    a = wp.dot(n, r.x)
    b = wp.dot(n, r.y)
    above = wp.max(a * r.x0, a * r.x1) + wp.max(b * r.y0, b * r.y1) + wp.dot(n, r.z) * r.z0
    return r.solid_angle / (2.0 * PI), wp.where(above > 0.0, n, -n)


@wp.func
def in_rect(r: SphericalRect, q: wp.vec3):
    """True when point ``q`` of the plane lies in the (clipped) rectangle."""
    xq = wp.dot(q - r.o, r.x)
    yq = wp.dot(q - r.o, r.y)
    return xq >= r.x0 and xq <= r.x1 and yq >= r.y0 and yq <= r.y1


@wp.func
def sample_spherical_rect(r: SphericalRect, n: wp.vec3, u1: float, u2: float):
    """A point of the rectangle's plane for uniform ``u1, u2``, and whether it lies in the (clipped) rectangle: a
    cosine-weighted direction about ``n`` or one uniform in the rectangle's solid angle (``u1`` picks, then is
    stretched back to [0, 1) for the direction)."""
    share, axis = cosine_share(r, n)
    if u1 < share:
        w = to_world(sample_cosine_hemisphere(u1 / share, u2), axis)
        toward = -wp.dot(w, r.z)  # the plane lies along -z
        if toward <= 0.0:
            return r.o, False
        q = r.o + (-r.z0 / toward) * w
        return q, in_rect(r, q)
    au = (u1 - share) / (1.0 - share) * r.solid_angle + r.k
    s, c = wp.sin(au), wp.cos(au)
    fu = (c * r.b0 - r.b1) / s
    cu = wp.clamp(wp.where(fu > 0.0, 1.0, -1.0) / wp.sqrt(fu * fu + r.b0 * r.b0), -1.0, 1.0)
    xu = wp.clamp(-(cu * r.z0) / wp.max(wp.sqrt(1.0 - cu * cu), 1.0e-30), r.x0, r.x1)
    dist = wp.sqrt(xu * xu + r.z0 * r.z0)
    h0 = r.y0 / wp.sqrt(dist * dist + r.y0 * r.y0)
    h1 = r.y1 / wp.sqrt(dist * dist + r.y1 * r.y1)
    hv = h0 + u2 * (h1 - h0)
    yv = wp.clamp(hv * dist / wp.sqrt(wp.max(1.0 - hv * hv, 1.0e-30)), r.y0, r.y1)
    return r.o + xu * r.x + yv * r.y + r.z0 * r.z, True


@wp.func
def spherical_rect_pdf(r: SphericalRect, n: wp.vec3, q: wp.vec3):
    """Solid-angle pdf with which :func:`sample_spherical_rect` picks the direction to point ``q`` of the plane; 0
    outside the (clipped) rectangle."""
    if not in_rect(r, q):
        return 0.0
    share, axis = cosine_share(r, n)
    cos_axis = wp.max(wp.dot(wp.normalize(q - r.o), axis), 0.0)
    return (1.0 - share) / r.solid_angle + share * cos_axis * INV_PI


__all__ = ["REACH", "SOLID_ANGLE_MAX", "SOLID_ANGLE_MIN", "SphericalRect", "sample_spherical_rect",
           "solid_angle_usable", "spherical_rect", "spherical_rect_pdf", "square_around_disk"]
