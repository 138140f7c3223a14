"""Sphere and cylinder lights under a transform that is no similarity: an ellipsoid, the image of the unit sphere
under the light's linear map ``M`` (its world 3x3 times its radius), and an elliptic or oblique tube, the image of
the unit tube (radius 1, length 1 along X, no caps) under ``M`` (the world 3x3 times ``diag(length, radius,
radius)``). Rays are intersected in the canonical frame (``A = M^-1``), where the ray parameter stays the world
distance. Round lights keep their own faster code in :mod:`wrt.light_sampling`.

Sampling works in the canonical frame too, since an affine map keeps which points a shading point sees (tangency
is preserved):

- ellipsoid: a direction uniform in the cone the unit sphere subtends at ``A (p - c)``, mapped to the world by
  ``M``; a linear map turns solid angle by ``|det A| / |A w|^3`` at world direction ``w``, so its pdf is
  ``1 / (2 pi (1 - cos_max) (g |A w|)^3)`` with ``g = |det M|^(1/3)``;
- tube: a point of the canonical tube drawn for ``A (p - c)`` as :mod:`wrt.glowing_tubes` draws an open round tube
  (uniformly by area on the half facing it, mixed with the draw by the angles the side subtends, so that points
  near the tube are not noisy), mapped by ``M``, whose area element there stretches by ``J = |M X x M t|`` (``t``
  the canonical tangent around the tube): world area density the canonical one over ``J``. The draw is not
  uniform by world solid angle, but near the tube the map is nearly affine on the patch that matters, and the
  density is exact whatever the map.

The emitting area, which ``normalize`` divides by and light selection weighs, is integrated on the host in float64
(:func:`ellipsoid_area`, :func:`elliptic_tube_area`): an ellipsoid's has no elementary closed form.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import warp as wp

from .glowing_tubes import TUBE_OPEN
from .sampling import PI, sample_uniform_cone, to_world
from .sphere_cone import intersect_sphere

# The canonical tube as wrt.glowing_tubes takes an open one: (centre, radius) and (half axis, code).
UNIT_TUBE = wp.constant(wp.vec4(0.0, 0.0, 0.0, 1.0))
UNIT_TUBE_AXIS = wp.constant(wp.vec4(0.5, 0.0, 0.0, float(TUBE_OPEN)))

# A light's linear map whose smallest singular value is below this share of its largest is flat (a disk, a ribbon):
# it cannot be inverted in float32, and the round light of the mean scale stands in for it (wrt.usd_lights warns).
FLAT_RATIO = 1e-6


@wp.func
def unit_sphere_cone(pc: wp.vec3):
    """``1 - cos_max`` of the cone the unit sphere subtends at canonical point ``pc``; 0 when inside or on it."""
    rho2 = wp.length_sq(pc)
    if rho2 <= 1.0:
        return 0.0
    sin2 = 1.0 / rho2
    return sin2 / (1.0 + wp.sqrt(wp.max(0.0, 1.0 - sin2)))  # 1 - cos_max without cancellation


@wp.func
def intersect_ellipsoid(c: wp.vec3, a: wp.mat33, o: wp.vec3, d: wp.vec3):
    """Nearest ``t > 0`` where unit ray ``o + t d`` enters the ellipsoid of centre ``c`` and world-to-canonical map
    ``a`` from outside; inf if none."""
    return intersect_sphere(wp.vec3(0.0), 1.0, a * (o - c), a * d)


@wp.func
def ellipsoid_pdf(c: wp.vec3, a: wp.mat33, g: float, p: wp.vec3, w: wp.vec3):
    """Solid-angle pdf with which :func:`sample_ellipsoid` draws unit direction ``w`` from ``p`` (``g``: the cube
    root of ``|det M|``); 0 from inside."""
    one_minus = unit_sphere_cone(a * (p - c))
    if one_minus <= 0.0:
        return 0.0
    return mapped_cone_pdf(a, g, one_minus, w)


@wp.func
def mapped_cone_pdf(a: wp.mat33, g: float, one_minus: float, w: wp.vec3):
    """Solid-angle pdf of world direction ``w`` drawn uniformly in a canonical cone of ``1 - cos`` ``one_minus`` (2:
    every direction) and mapped to the world by ``M``, the inverse of ``a``; ``g``, the cube root of ``|det M|``,
    scales ``|A w|`` near 1, so that its cube stays in float32 range. A linear map turns solid angle by
    ``|det A| / |A w|^3``."""
    s = g * wp.length(a * w)
    return 1.0 / (2.0 * PI * one_minus * s * s * s)


@wp.func
def sample_mapped_cone(m: wp.mat33, pc: wp.vec3, one_minus: float, u1: float, u2: float):
    """A unit world direction uniform in the canonical cone of ``1 - cos`` ``one_minus`` about ``-pc`` (canonical
    point ``pc`` looking at the origin; 2: every direction), mapped to the world by ``m``."""
    axis = wp.vec3(0.0, 0.0, 1.0)
    if wp.length_sq(pc) > 0.0:
        axis = -wp.normalize(pc)
    return wp.normalize(m * to_world(sample_uniform_cone(u1, u2, one_minus), axis))


@wp.func
def sample_ellipsoid(c: wp.vec3, m: wp.mat33, a: wp.mat33, g: float, p: wp.vec3, u1: float, u2: float):
    """A unit direction from ``p`` towards the ellipsoid (canonical-to-world map ``m``, its inverse ``a``), the
    distance to where it enters the ellipsoid and its solid-angle pdf (0: ``p`` is inside, nothing drawn)."""
    pc = a * (p - c)
    one_minus = unit_sphere_cone(pc)
    if one_minus <= 0.0:
        return wp.vec3(0.0, 0.0, 1.0), float(wp.inf), 0.0
    w = sample_mapped_cone(m, pc, one_minus, u1, u2)
    aw = a * w
    t = intersect_sphere(wp.vec3(0.0), 1.0, pc, aw)
    if t == wp.inf:
        t = -wp.dot(pc, aw) / wp.dot(aw, aw)  # grazing: rounding missed the ellipsoid by a hair
    return w, t, mapped_cone_pdf(a, g, one_minus, w)


@wp.func
def tube_normal(a: wp.mat33, radial: wp.vec3):
    """Unit world normal of the tube where its canonical normal is ``radial`` (``(0, cos, sin)``): normals turn by
    the inverse transpose."""
    return wp.normalize(wp.transpose(a) * radial)


@wp.func
def tube_stretch(m: wp.mat33, radial: wp.vec3):
    """Area of the tube's world surface element per canonical one where its canonical normal is ``radial``."""
    tangent = wp.vec3(0.0, -radial[2], radial[1])
    return wp.length(wp.cross(m * wp.vec3(1.0, 0.0, 0.0), m * tangent))


@wp.func
def intersect_elliptic_tube(c: wp.vec3, a: wp.mat33, o: wp.vec3, d: wp.vec3):
    """Distance along unit ray ``(o, d)`` to where it enters the tube of centre ``c`` and world-to-canonical map
    ``a`` from outside (inf if it misses), and the cosine there between ``-d`` and the world normal."""
    oc = a * (o - c)
    dc = a * d
    # The canonical tube is y^2 + z^2 = 1 for |x| <= 1/2: the 2D circle, from the ray's closest approach (Haines).
    op = wp.vec2(oc[1], oc[2])
    dp = wp.vec2(dc[1], dc[2])
    aa = wp.dot(dp, dp)
    if aa <= 0.0 or wp.dot(op, op) <= 1.0:
        return float(wp.inf), 0.0  # along the axis, or inside the tube: it emits outwards only
    t_mid = -wp.dot(op, dp) / aa
    closest = op + t_mid * dp
    half2 = 1.0 - wp.dot(closest, closest)
    if half2 < 0.0:
        return float(wp.inf), 0.0
    t = t_mid - wp.sqrt(half2 / aa)
    if t <= 0.0 or wp.abs(oc[0] + t * dc[0]) > 0.5:
        return float(wp.inf), 0.0
    hit = op + t * dp
    radial = wp.vec3(0.0, hit[0], hit[1]) / wp.length(hit)
    return t, wp.max(-wp.dot(d, tube_normal(a, radial)), 0.0)


@wp.func
def elliptic_tube_pdf_terms(c: wp.vec3, m: wp.mat33, a: wp.mat33, p: wp.vec3, q: wp.vec3, dist: float, cos_l: float):
    """The terms of the solid-angle pdf with which :func:`elliptic_tube_point` after
    :func:`wrt.glowing_tubes.sample_tube` draws, from ``p``, point ``q`` on the tube (at ``dist``, cosine ``cos_l``
    there; for a point ``p`` sees the front of): ``(drawn, to_p, qc, radial, dist^2, divisor)``, where the pdf is
    ``dist^2 density / divisor`` if ``drawn`` (else 0), ``density`` the unit tube's by area at ``qc`` (normal
    ``radial``) seen from ``to_p``, all in the canonical frame (:func:`wrt.glowing_tubes.tube_point_density`). The
    density is left to the caller so that :func:`wrt.light_sampling.area_light_pdf` calls it once for the round and
    the elliptic tube (each call site compiles it again)."""
    qc = a * (q - c)
    rho = wp.sqrt(qc[1] * qc[1] + qc[2] * qc[2])
    radial = wp.vec3(0.0)
    stretch = float(0.0)
    drawn = not (cos_l <= 0.0 or rho <= 0.0)  # (written so that a NaN goes on, as it did)
    if drawn:
        radial = wp.vec3(0.0, qc[1], qc[2]) / rho
        stretch = tube_stretch(m, radial)
        drawn = not (stretch <= 0.0)
    return drawn, a * (p - c), qc, radial, dist * dist, cos_l * stretch


@wp.func
def elliptic_tube_point(c: wp.vec3, m: wp.mat33, a: wp.mat33, qc: wp.vec3, radial: wp.vec3, area: float):
    """``(q, n, area)``: the point ``qc`` that :func:`wrt.glowing_tubes.sample_tube` drew on the unit tube as on an
    open single-sided round tube (uniformly by area over the half facing ``A (p - c)``, and by the angles the side
    subtends from there; canonical normal ``radial``, reciprocal area density ``area``, the unit tube's ``down`` being
    1), mapped by ``M``; with its unit world normal and the reciprocal of its world area density, the canonical one
    times the area stretch (0: nothing drawn). :func:`wrt.light_sampling.sample_light` draws the canonical point
    itself, so that its three tube lights share one call of ``sample_tube`` (each call site compiles it again)."""
    return c + m * qc, tube_normal(a, radial), area * tube_stretch(m, radial)


def flat(m: np.ndarray) -> bool:
    """Whether linear map ``m`` (``(3, 3)``) flattens the unit shape to a disk, ribbon or line (see ``FLAT_RATIO``)."""
    s = np.linalg.svd(np.asarray(m, np.float64), compute_uv=False)
    return not (np.all(np.isfinite(s)) and s[-1] > FLAT_RATIO * s[0])


def similar(m: np.ndarray, rtol: float = 1e-4) -> bool:
    """Whether ``m`` (``(3, 3)``) only turns, mirrors and scales evenly: its columns of one length at right angles."""
    m = np.asarray(m, np.float64)
    lengths = np.linalg.norm(m, axis=0)
    mean = lengths.mean()
    if np.isfinite(mean):  # np.allclose's test without its per-call cost, a tenth of reading a light; relative
        # alone: with allclose's atol of 1e-8, any frame below 1e-8 counted as even (an ellipsoid 1e-20 across drew
        # as a round sphere)
        even = bool(np.all(np.abs(lengths - mean) <= rtol * abs(mean)))
    else:  # infinite lengths, which allclose takes as equal
        even = bool(np.allclose(lengths, mean, rtol=rtol))
    return even and right_angled(*m.T, rtol=rtol)


def right_angled(*axes, rtol: float = 1e-4) -> bool:
    """Whether vectors ``axes`` are at right angles to each other (no shear)."""
    return all(abs(a @ b) <= rtol * np.linalg.norm(a) * np.linalg.norm(b)
               for i, a in enumerate(axes) for b in axes[i + 1:])


def _converged(integral, start: int = 64, most: int = 1 << 17, rtol: float = 1e-13) -> float:
    """``integral(n)`` with ``n`` doubled until two results agree to ``rtol`` (or ``n`` reaches ``most``)."""
    n, value = start, integral(start)
    while n < most:
        n *= 2
        finer = integral(n)
        if abs(finer - value) <= rtol * abs(finer):
            return float(finer)
        value = finer
    return float(value)


@functools.lru_cache(maxsize=256)
def _ellipsoid_area(a: float, b: float, c: float) -> float:
    # Area = integral over the unit sphere of |cof(M) u| = sqrt((bc u1)^2 + (ac u2)^2 + (ab u3)^2) (semi-axes
    # a >= b >= c). With u1 = z along the longest axis and dA = dz dphi (Archimedes), the z integral of
    # sqrt(alpha - gamma z^2) over [0, 1] is closed: (sqrt(beta) + alpha atan2(sqrt(gamma), sqrt(beta)) / sqrt(gamma))
    # / 2, beta = (bc)^2, alpha = a^2 (c^2 cos^2 + b^2 sin^2) >= beta, gamma = alpha - beta. The periodic phi
    # integral is left to the midpoint rule, exact to rounding once converged.
    def integral(n):
        phi = (np.arange(n) + 0.5) * (0.5 * math.pi / n)
        alpha = a * a * (c * c * np.cos(phi) ** 2 + b * b * np.sin(phi) ** 2)
        beta = (b * c) ** 2
        gamma = np.maximum(alpha - beta, 0.0)
        x2 = gamma / beta
        # atan(x) / x, by its series where x is small (there the quotient loses its digits)
        ratio = np.where(x2 < 1e-6, 1.0 - x2 / 3.0 + x2 * x2 / 5.0,
                         np.arctan(np.sqrt(x2)) / np.sqrt(np.maximum(x2, 1e-300)))
        inner = 0.5 * (math.sqrt(beta) + alpha * ratio / math.sqrt(beta))
        return 8.0 * inner.sum() * (0.5 * math.pi / n)

    return _converged(integral)


def ellipsoid_area(m: np.ndarray) -> float:
    """Surface area (float64) of the ellipsoid ``{M u : |u| = 1}`` of ``(3, 3)`` linear map ``m`` (not flat)."""
    a, b, c = np.linalg.svd(np.asarray(m, np.float64), compute_uv=False)
    return _ellipsoid_area(float(a), float(b), float(c))


@functools.lru_cache(maxsize=256)
def _tube_area(pp: float, pq: float, qq: float) -> float:
    # |P cos - Q sin| around the tube, P = M X x M Z and Q = M X x M Y (P.P, P.Q, Q.Q given): a periodic integrand,
    # so the midpoint rule converges geometrically.
    def integral(n):
        phi = (np.arange(n) + 0.5) * (2.0 * math.pi / n)
        cos, sin = np.cos(phi), np.sin(phi)
        return np.sqrt(np.maximum(pp * cos**2 - 2.0 * pq * cos * sin + qq * sin**2, 0.0)).sum() * (2.0 * math.pi / n)

    return _converged(integral)


def elliptic_tube_area(m: np.ndarray) -> float:
    """Lateral area (float64) of the tube ``{M (x, cos phi, sin phi) : |x| <= 1/2}`` of ``(3, 3)`` linear map
    ``m``."""
    m = np.asarray(m, np.float64)
    p, q = np.cross(m[:, 0], m[:, 2]), np.cross(m[:, 0], m[:, 1])
    return _tube_area(float(p @ p), float(p @ q), float(q @ q))
