"""Where an instance draws a triangle of its prototype: its corners moved to the world, about the point of the
prototype that its BLAS is built about (:func:`wrt.tlas.blas_centres`), as the trace places that triangle. The one
rule the hit point (:func:`wrt.shade.hit_point`) and light sampling (:func:`wrt.light_sampling.emitter_triangle`)
place an instanced triangle by, so that a point sampled on an emitter lies on the surface a ray hits."""

import warp as wp

from .scene import DeviceScene
from .transforms import corners_to_world, corners_to_world_about


@wp.func
def instance_corners(scene: DeviceScene, instance: int, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """World corners of the prototype-space triangle ``a, b, c`` as ``instance`` (``>= 0``) draws it: about its
    prototype's BLAS centre where a scene has one (:func:`wrt.transforms.corners_to_world_about`), else about the
    prototype's origin (:func:`wrt.transforms.corners_to_world`, the same bits as before centres)."""
    m = scene.world_to_local[instance]
    wa = a
    wb = b
    wc = c
    if instance < scene.num_blas_offsets:
        wa, wb, wc = corners_to_world_about(m, scene.blas_centres[instance], scene.blas_offsets[instance], a, b, c)
    else:
        wa, wb, wc = corners_to_world(m, a, b, c)
    return wa, wb, wc
