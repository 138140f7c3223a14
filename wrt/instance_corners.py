"""Where an instance draws a triangle of its prototype: its corners moved to the world, about the point of the
prototype that its BLAS is built about (:func:`wrt.tlas.blas_centres`), as the trace places that triangle. The one
rule the hit point (:func:`wrt.shade.hit_point`) and light sampling (:func:`wrt.light_sampling.emitter_triangle`)
place an instanced triangle by, so that a point sampled on an emitter lies on the surface a ray hits."""

import warp as wp

from .scene import DeviceScene
from .transforms import (
    abs_vec,
    corners_to_world,
    corners_to_world_about,
    inverse_linear,
    inverse_transform_magnitude,
    scaled_by,
    translation,
)


@wp.func
def local_scales(scene: DeviceScene, instance: int):
    """The two powers of two that ``instance``'s :attr:`DeviceScene.local_linear` row is its ``L`` over: 1 and 1 but
    for an ``L`` past float32's range (:meth:`wrt.Scene._local_linear`)."""
    scales = wp.vec2(1.0, 1.0)
    if instance < scene.num_local_scales:
        scales = scene.local_scales[instance]
    return scales


@wp.func
def instance_corners(scene: DeviceScene, instance: int, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """World corners of the prototype-space triangle ``a, b, c`` as ``instance`` (``>= 0``) draws it: about its
    prototype's BLAS centre where a scene has one (:func:`wrt.transforms.corners_to_world_about`), else about the
    prototype's origin (:func:`wrt.transforms.corners_to_world`), by the instance's to-world linear part ``L``
    rounded once (:attr:`DeviceScene.local_linear`, scaled by :func:`local_scales` where float32 cannot hold ``L``
    itself), or the float32 inverse of its ``A`` where float32 cannot hold ``L`` even so."""
    m = scene.world_to_local[instance]
    inverse = scene.local_linear[instance]  # L, rounded once from float64
    if wp.isnan(inverse[0, 0]):  # not held in float32: the float32 inverse of A
        inverse = inverse_linear(m)
    scales = local_scales(scene, instance)
    origin = translation(m)
    wa = a
    wb = b
    wc = c
    if instance < scene.num_blas_offsets:
        wa, wb, wc = corners_to_world_about(inverse, scales, scene.blas_origins[instance],
                                            scene.blas_centres[instance], scene.blas_origin_rests[instance], a, b, c)
    else:
        wa, wb, wc = corners_to_world(inverse, scales, origin, a, b, c)
    return wa, wb, wc


@wp.func
def instance_magnitude(scene: DeviceScene, instance: int, v: wp.vec3):
    """:func:`wrt.transforms.inverse_transform_magnitude` (``|A^-1| v + |c|``, the scale of a world point's rounding)
    of ``instance``'s world-to-local matrix; from its ``L`` where float32 cannot hold ``A^-1`` (:func:`local_scales`),
    where the float32 inverse overflowed (an instance scaled by 3e39: an infinite bound, and shadow rays from
    nowhere)."""
    m = scene.world_to_local[instance]
    if instance < scene.num_local_scales:  # read only in scenes with such an instance
        scales = scene.local_scales[instance]
        linear = scene.local_linear[instance]
        if (scales[0] != 1.0 or scales[1] != 1.0) and not wp.isnan(linear[0, 0]):
            terms = wp.vec3(0.0)
            for r in range(3):
                terms[r] = wp.abs(linear[r, 0]) * v[0] + wp.abs(linear[r, 1]) * v[1] + wp.abs(linear[r, 2]) * v[2]
            return scaled_by(terms, scales) + abs_vec(translation(m))
    return inverse_transform_magnitude(m, v)
