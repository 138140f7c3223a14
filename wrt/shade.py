"""Shading: hit buffer -> radiance and AOVs, with Lambert surfaces, distant lights and hard shadows.

Model (the spine's integrator; later integrators build on the same hit buffer):

- Surfaces are Lambertian with albedo = interpolated displayColor (neutral grey 0.5 without one).
- Each ``UsdLux.DistantLight`` of the stage adds ``albedo / pi * E * max(0, n . l)`` where ``E`` is its
  illuminance ``intensity * 2**exposure * color``, unless an any-hit shadow ray towards it is blocked.
- A stage without lights gets a headlight: a distant light along the view direction with ``E = 0.8 pi``,
  so a white surface facing the camera shows 0.8.
- A constant, unoccluded ambient term ``albedo * AMBIENT`` keeps shadows readable.
- Rays that miss show ``BACKGROUND``.

Normals: the geometric normal is turned to face the incoming ray (surfaces are two-sided); the shading normal
(barycentric interpolation of the mesh's normals, or the face normal when it has none) is turned to the same side.
"""

import warp as wp

from .geometry import offset_ray_origin
from .scene import DeviceScene

AMBIENT = wp.constant(0.2)  # radiance of the constant ambient term, for a white surface
BACKGROUND = wp.constant(wp.vec3(0.05, 0.06, 0.08))  # radiance of rays that miss, linear RGB
HEADLIGHT_IRRADIANCE = 0.8 * 3.14159265  # illuminance of the default headlight


@wp.func
def surface_at(scene: DeviceScene, prim: int, u: float, v: float, ray_dir: wp.vec3):
    """Geometric normal, shading normal (both unit, facing the ray's origin) and albedo at a hit."""
    a = scene.points[scene.indices[prim, 0]]
    b = scene.points[scene.indices[prim, 1]]
    c = scene.points[scene.indices[prim, 2]]
    ng = wp.cross(b - a, c - a)
    if wp.length(ng) > 0.0:
        ng = wp.normalize(ng)
    else:
        ng = -wp.normalize(ray_dir)  # a degenerate triangle can only be hit edge-on: face the ray
    if wp.dot(ng, ray_dir) > 0.0:
        ng = -ng
    w = 1.0 - u - v
    ns = w * scene.normals[prim, 0] + u * scene.normals[prim, 1] + v * scene.normals[prim, 2]
    if wp.length(ns) > 0.0:
        ns = wp.normalize(ns)
        if wp.dot(ns, ng) < 0.0:
            ns = -ns
    else:
        ns = ng
    albedo = w * scene.colors[prim, 0] + u * scene.colors[prim, 1] + v * scene.colors[prim, 2]
    return ng, ns, albedo


@wp.kernel
def prepare_shadow_rays_kernel(
    scene: DeviceScene,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    light_dirs: wp.array[wp.vec3],
    light: int,
    # outputs
    shadow_origins: wp.array[wp.vec3],
    shadow_dirs: wp.array[wp.vec3],
    shadow_t_maxs: wp.array[float],
):
    """A shadow ray from each hit towards light ``light`` (``t_max = 0``, i.e. no ray, for misses and back-lit
    points). ``light_dirs`` holds the direction each light travels in; a zero entry means the headlight."""
    i = wp.tid()
    prim = hit_prim[i]
    shadow_t_maxs[i] = 0.0
    shadow_origins[i] = origins[i]
    shadow_dirs[i] = directions[i]
    if prim < 0:
        return
    d = directions[i]
    ng, ns, albedo = surface_at(scene, prim, hit_u[i], hit_v[i], d)
    to_light = -light_dirs[light]
    if wp.length(to_light) == 0.0:
        to_light = -wp.normalize(d)
    if wp.dot(ng, to_light) <= 0.0:
        return
    shadow_origins[i] = offset_ray_origin(origins[i] + hit_t[i] * d, ng)
    shadow_dirs[i] = to_light
    shadow_t_maxs[i] = wp.inf


@wp.kernel
def accumulate_light_kernel(
    scene: DeviceScene,
    directions: wp.array[wp.vec3],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    shadow_t_maxs: wp.array[float],
    blocked: wp.array[wp.int32],
    light_dirs: wp.array[wp.vec3],
    light_irradiance: wp.array[wp.vec3],
    light: int,
    # outputs
    radiance: wp.array[wp.vec3],
):
    """Adds the unshadowed Lambert contribution of light ``light`` to each pixel sample."""
    i = wp.tid()
    prim = hit_prim[i]
    if prim < 0 or shadow_t_maxs[i] == 0.0 or blocked[i] == 1:
        return
    d = directions[i]
    ng, ns, albedo = surface_at(scene, prim, hit_u[i], hit_v[i], d)
    to_light = -light_dirs[light]
    if wp.length(to_light) == 0.0:
        to_light = -wp.normalize(d)
    cos_theta = wp.max(wp.dot(ns, wp.normalize(to_light)), 0.0)
    radiance[i] = radiance[i] + wp.cw_mul(albedo, light_irradiance[light]) * (cos_theta / wp.pi)


@wp.kernel
def shade_base_kernel(
    scene: DeviceScene,
    directions: wp.array[wp.vec3],
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    # outputs
    radiance: wp.array[wp.vec3],
    depth: wp.array[float],
    normal: wp.array[wp.vec3],
    albedo_out: wp.array[wp.vec3],
):
    """Starts each pixel sample's radiance (ambient or background) and writes its AOVs."""
    i = wp.tid()
    prim = hit_prim[i]
    if prim < 0:
        radiance[i] = BACKGROUND
        depth[i] = wp.inf
        normal[i] = wp.vec3(0.0)
        albedo_out[i] = wp.vec3(0.0)
        return
    d = directions[i]
    ng, ns, albedo = surface_at(scene, prim, hit_u[i], hit_v[i], d)
    radiance[i] = albedo * AMBIENT
    depth[i] = hit_t[i] * wp.length(d)
    normal[i] = ns
    albedo_out[i] = albedo


@wp.kernel
def accumulate_kernel(
    radiance: wp.array[wp.vec3],
    weight: float,
    # outputs
    image: wp.array[wp.vec3],
):
    """``image += weight * radiance``: averages pixel samples."""
    i = wp.tid()
    image[i] = image[i] + weight * radiance[i]
