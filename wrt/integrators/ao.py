"""Ambient occlusion: the fraction of a cosine-weighted hemisphere around the shading normal that is free of
geometry within ``radius`` (one occlusion ray per sample). Rays that miss the scene count as unoccluded (1)."""

import warp as wp

from ..geometry import offset_ray_origin
from ..sampling import rand01, sample_cosine_hemisphere, to_world
from ..scene import DeviceScene
from ..shade import SHADING_CPU_FLAGS, DeviceSurfaces, hit_point

# device-independent rounding, and a moderate inlining on the CPU: see wrt/shade.py
wp.set_module_options({"fuse_fp": False, "enable_backward": False, "cpu_compiler_flags": SHADING_CPU_FLAGS})


@wp.kernel
def shade_ao_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    radius: float,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    hit_instance: wp.array[wp.int32],
    rng: wp.array[wp.uint32],
    # outputs
    shadow_origins: wp.array[wp.vec3],
    shadow_dirs: wp.array[wp.vec3],
    shadow_t_maxs: wp.array[float],
):
    """One cosine-weighted occlusion ray of length ``radius`` from each hit (``t_max = 0`` for misses)."""
    i = wp.tid()
    shadow_origins[i] = wp.vec3(0.0)  # an empty occlusion ray (t_max = 0) unless set below
    shadow_dirs[i] = wp.vec3(0.0)
    shadow_t_maxs[i] = 0.0
    prim = hit_prim[i]
    if prim < 0:
        return
    d = directions[i]
    h = hit_point(scene, surf, prim, hit_instance[i], hit_u[i], hit_v[i], origins[i], d, hit_t[i])
    state = rng[i]
    u1, state = rand01(state)
    u2, state = rand01(state)
    shadow_origins[i] = offset_ray_origin(h.p, h.ng, h.reach, h.err, h.inner)
    shadow_dirs[i] = to_world(sample_cosine_hemisphere(u1, u2), h.ns)
    shadow_t_maxs[i] = radius


@wp.kernel
def ao_value_kernel(
    shadow_t_maxs: wp.array[float],
    blocked: wp.array[wp.int32],
    # outputs
    radiance: wp.array[wp.vec3],
):
    """1 where the occlusion ray escaped (or there was nothing to occlude), 0 where it was blocked."""
    i = wp.tid()
    v = float(1.0)
    if shadow_t_maxs[i] > 0.0 and blocked[i] == 1:
        v = 0.0
    radiance[i] = wp.vec3(v)
