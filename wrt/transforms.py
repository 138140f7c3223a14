"""Affine transforms on the device: the 3x4 matrix type of instances and shapes, and how points, directions and
normals move between world and local space.

A ``mat34`` holds ``[A | c]``: ``local = A (world - c)`` for a world-to-local transform, where ``c`` is where the
local origin lies in the world (the to-world translation, :func:`wrt.instancing.device_transforms`) and ``A`` the
inverse of the to-world linear part. Rays move into local space by it (origin as a point, direction as a vector, not
renormalised, so the ray parameter ``t`` is the same in both spaces: the lecture's "transform the ray by the inverse
transform"). Back in world space a point needs ``A^-1``; a normal needs the inverse transpose of the local-to-world
map, which is ``A^T`` itself, so no inverse is needed.

The translation is subtracted before ``A`` is applied, not added after it as ``b = -A c``: a ray near an instance or
shape far from the world origin then comes into local space as exactly as its distance from ``c`` allows (``world -
c`` of nearby floats is exact), where ``A world + b`` summed terms of the size of the translation and cancelled them:
a sphere of radius 1 at 1e5 was hit up to 0.05 off its surface (6 ulps of 1e5), and instanced triangles there lost
ten times the hits their flattened copies lose.
"""

import warp as wp

from .floats import unit_scales

mat34 = wp.types.matrix(shape=(3, 4), dtype=wp.float32)  # affine transform: rows of [linear | translation]


@wp.func
def linear_part(m: mat34):
    """The 3x3 linear part ``A`` of ``[A | b]``."""
    return wp.mat33(m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2])


@wp.func
def translation(m: mat34):
    """``c`` of ``[A | c]``: the local origin in the world."""
    return wp.vec3(m[0, 3], m[1, 3], m[2, 3])


@wp.func
def transform_point(m: mat34, p: wp.vec3):
    """``A (p - c)``: a world point in local space."""
    return linear_part(m) * (p - translation(m))


@wp.func
def local_ray_point(m: mat34, o: wp.vec3, d: wp.vec3, t: float):
    """``A ((o - c) + t d)``: the point at ``t`` of the world ray ``o + t d`` in local space, summed relative to the
    local origin ``c``, so that it is rounded at the scale of the ray's way there, not of the point's distance from
    the world origin (``transform_point(m, o + t d)``; 8e-3 for a point at 1e5)."""
    return linear_part(m) * ((o - translation(m)) + t * d)


@wp.func
def transform_vector(m: mat34, v: wp.vec3):
    """``A v``."""
    return m * wp.vec4(v[0], v[1], v[2], 0.0)


@wp.func
def inverse_linear(m: mat34):
    """``A^-1``, inverted from ``D_r A D_c``, ``A`` with each row and then each column scaled by the power of two that
    brings its largest entry into ``[1, 2)``: ``A^-1 = D_c (D_r A D_c)^-1 D_r``, the same bits as ``wp.inverse(A)``
    where nothing over- or underflows (each product in the adjugate and determinant takes its entries from distinct
    rows and columns, so a power of two per row or column commutes with its rounding). ``wp.inverse`` divides by
    the determinant, a product of three entries, which vanished in float32 for an instance or shape scaled by 5e12 or
    more (and overflowed for one scaled by 2e-13 or less): its inverse was NaN, and so were the hit points, normals
    and offsets of shading on it (analytic shapes of a scene scaled by 1e20 were black). One power of two for the
    whole matrix was not enough for an uneven scale: a card instanced flat, ``(1, 1, 1e-20)``, kept two entries of
    2^-67 whose determinant underflowed, where ``wp.inverse`` had inverted it exactly."""
    a = linear_part(m)
    r0, _ = unit_scales(a[0])
    r1, _ = unit_scales(a[1])
    r2, _ = unit_scales(a[2])
    b = wp.matrix_from_rows(a[0] * r0, a[1] * r1, a[2] * r2)
    c0, _ = unit_scales(wp.vec3(b[0, 0], b[1, 0], b[2, 0]))
    c1, _ = unit_scales(wp.vec3(b[0, 1], b[1, 1], b[2, 1]))
    c2, _ = unit_scales(wp.vec3(b[0, 2], b[1, 2], b[2, 2]))
    cols = wp.vec3(c0, c1, c2)
    b = wp.matrix_from_rows(wp.cw_mul(b[0], cols), wp.cw_mul(b[1], cols), wp.cw_mul(b[2], cols))
    inv = wp.inverse(b)
    rows = wp.vec3(r0, r1, r2)
    return wp.matrix_from_rows(wp.cw_mul(inv[0], rows) * c0, wp.cw_mul(inv[1], rows) * c1, wp.cw_mul(inv[2], rows) * c2)


@wp.func
def inverse_transform_point(m: mat34, p: wp.vec3):
    """The point that ``m`` maps to ``p``: ``A^-1 p + c`` (local to world for a world-to-local ``m``)."""
    return inverse_linear(m) * p + translation(m)


@wp.func
def corners_to_world(inverse: wp.mat33, scales: wp.vec2, origin: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Corners ``a, b, c`` of a prototype-space triangle in world space, for its instance's local-to-world linear part
    ``inverse`` (``A^-1``) times ``scales``' two powers of two (1 and 1 but where float32 cannot hold ``A^-1``) and
    origin ``origin`` (``c`` of its world-to-local ``[A | c]``): each corner moved by ``A^-1 p + c``.
    :func:`wrt.instance_corners.instance_corners` is the one rule both the hit point (:func:`wrt.shade.hit_point`) and
    light sampling (:func:`wrt.light_sampling.emitter_triangle`) place an instanced triangle by, so that a point
    sampled on an emitter lies on the surface a ray hits (to the bit)."""
    return (scaled_by(inverse * a, scales) + origin, scaled_by(inverse * b, scales) + origin,
            scaled_by(inverse * c, scales) + origin)


@wp.func
def scaled_by(v: wp.vec3, scales: wp.vec2):
    """``v`` times the two powers of two of ``scales``, one after the other (their product may lie past float32's
    range: an instance scaled by 3e39); ``v`` itself, bit for bit, for 1 and 1."""
    return (v * scales[0]) * scales[1]


@wp.func
def corners_to_world_about(inverse: wp.mat33, scales: wp.vec2, origin: wp.vec3, centre: wp.vec3, rest: wp.vec3,
                           a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """:func:`corners_to_world` (``scales`` as there) of corners ``a, b, c`` of a prototype whose BLAS is built about
    ``centre`` (:func:`wrt.tlas.blas_centres`), which its instance places at ``origin + rest`` (the float32 nearest
    and what it leaves, :func:`wrt.tlas.blas_origins`): each corner moved by ``(A^-1 (p - centre) + rest) + origin``,
    as the trace moves rays into that BLAS. ``A^-1``'s rounding moves a point by its relative error times the point's
    distance from where it is applied: applied to ``p`` itself, the corners of sheared octahedra 50 of their sizes
    off their prototype's origin came up to 0.37 off the triangle traced (0.011 about the centre)."""
    return ((scaled_by(inverse * (a - centre), scales) + rest) + origin,
            (scaled_by(inverse * (b - centre), scales) + rest) + origin,
            (scaled_by(inverse * (c - centre), scales) + rest) + origin)


@wp.func
def inverse_transform_vector(m: mat34, v: wp.vec3):
    """The vector that ``m`` maps to ``v``: ``A^-1 v`` (a local tangent in world space, for a world-to-local ``m``)."""
    return inverse_linear(m) * v


@wp.func
def normal_to_world(m: mat34, n: wp.vec3):
    """A local-space normal in world space, for world-to-local ``m``: ``A^T n`` (not normalised)."""
    return wp.transpose(linear_part(m)) * n


@wp.func
def abs_vec(v: wp.vec3):
    """``|v|`` per component."""
    return wp.vec3(wp.abs(v[0]), wp.abs(v[1]), wp.abs(v[2]))


@wp.func
def inverse_transform_magnitude(m: mat34, v: wp.vec3):
    """``|A^-1| v + |c|`` per component, for ``v >= 0`` the magnitudes of a point's local coordinates: bounds the
    terms that ``inverse_transform_point`` sums into each world coordinate (the scale of its rounding)."""
    inv = inverse_linear(m)
    out = abs_vec(translation(m))
    for r in range(3):
        out[r] += wp.abs(inv[r, 0]) * v[0] + wp.abs(inv[r, 1]) * v[1] + wp.abs(inv[r, 2]) * v[2]
    return out
