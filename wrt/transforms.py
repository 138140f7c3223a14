"""Affine transforms on the device: the 3x4 matrix type of instances and shapes, and how points, directions and
normals move between world and local space.

A ``mat34`` holds ``[A | b]``: ``local = A world + b`` for a world-to-local transform. Rays move into local space
by it (origin as a point, direction as a vector, not renormalised, so the ray parameter ``t`` is the same in both
spaces: the lecture's "transform the ray by the inverse transform"). Back in world space a point needs ``A^-1``;
a normal needs the inverse transpose of the local-to-world map, which is ``A^T`` itself, so no inverse is needed.
"""

import warp as wp

mat34 = wp.types.matrix(shape=(3, 4), dtype=wp.float32)  # affine transform: rows of [linear | translation]


@wp.func
def linear_part(m: mat34):
    """The 3x3 linear part ``A`` of ``[A | b]``."""
    return wp.mat33(m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2])


@wp.func
def transform_point(m: mat34, p: wp.vec3):
    """``A p + b``."""
    return m * wp.vec4(p[0], p[1], p[2], 1.0)


@wp.func
def transform_vector(m: mat34, v: wp.vec3):
    """``A v``."""
    return m * wp.vec4(v[0], v[1], v[2], 0.0)


@wp.func
def inverse_transform_point(m: mat34, p: wp.vec3):
    """The point that ``m`` maps to ``p``: ``A^-1 (p - b)`` (local to world for a world-to-local ``m``)."""
    return wp.inverse(linear_part(m)) * (p - wp.vec3(m[0, 3], m[1, 3], m[2, 3]))


@wp.func
def corners_to_world(m: mat34, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Corners ``a, b, c`` of a prototype-space triangle in world space, for its instance's world-to-local ``m``:
    each corner moved by ``A^-1 (p - b)``. The one rule both the hit point (:func:`wrt.shade.hit_point`) and light
    sampling (:func:`wrt.light_sampling.emitter_triangle`) place an instanced triangle by, so that a point sampled
    on an emitter lies on the surface a ray hits (to the bit)."""
    inverse = wp.inverse(linear_part(m))
    offset = wp.vec3(m[0, 3], m[1, 3], m[2, 3])
    return inverse * (a - offset), inverse * (b - offset), inverse * (c - offset)


@wp.func
def inverse_transform_vector(m: mat34, v: wp.vec3):
    """The vector that ``m`` maps to ``v``: ``A^-1 v`` (a local tangent in world space, for a world-to-local ``m``)."""
    return wp.inverse(linear_part(m)) * v


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
    """``|A^-1| (v + |b|)`` per component, for ``v >= 0`` the magnitudes of a point's local coordinates: bounds the
    terms that ``inverse_transform_point`` sums into each world coordinate (the scale of its rounding)."""
    inv = wp.inverse(linear_part(m))
    w = v + abs_vec(wp.vec3(m[0, 3], m[1, 3], m[2, 3]))
    out = wp.vec3()
    for r in range(3):
        out[r] = wp.abs(inv[r, 0]) * w[0] + wp.abs(inv[r, 1]) * w[1] + wp.abs(inv[r, 2]) * w[2]
    return out
