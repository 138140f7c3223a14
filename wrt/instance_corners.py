"""Where an instance draws a triangle of its prototype: its corners moved to the world, about the point of the
prototype that its BLAS is built about (:func:`wrt.tlas.blas_centres`), as the trace places that triangle. The one
rule the hit point (:func:`wrt.shade.hit_point`) and light sampling (:func:`wrt.light_sampling.emitter_triangle`)
place an instanced triangle by, so that a point sampled on an emitter lies on the surface a ray hits."""

import warp as wp

from .scene import DeviceScene
from .transforms import corners_to_world, corners_to_world_about, inverse_linear, translation


@wp.func
def instance_corners(scene: DeviceScene, instance: int, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """World corners of the prototype-space triangle ``a, b, c`` as ``instance`` (``>= 0``) draws it: about its
    prototype's BLAS centre where a scene has one (:func:`wrt.transforms.corners_to_world_about`), else about the
    prototype's origin (:func:`wrt.transforms.corners_to_world`), by the instance's to-world linear part ``L``
    rounded once (:attr:`DeviceScene.local_linear`), or the float32 inverse of its ``A`` where float32 cannot hold
    ``L``."""
    m = scene.world_to_local[instance]
    inverse = scene.local_linear[instance]  # L, rounded once from float64
    if wp.isnan(inverse[0, 0]):  # not held in float32: the float32 inverse of A
        inverse = inverse_linear(m)
    origin = translation(m)
    wa = a
    wb = b
    wc = c
    if instance < scene.num_blas_offsets:
        wa, wb, wc = corners_to_world_about(inverse, scene.blas_origins[instance], scene.blas_centres[instance],
                                            scene.blas_origin_rests[instance], a, b, c)
    else:
        wa, wb, wc = corners_to_world(inverse, origin, a, b, c)
    return wa, wb, wc
