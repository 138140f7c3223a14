"""Path tracing: unbiased Monte Carlo estimation of the rendering equation, one wavefront bounce per launch.

Each bounce runs ``intersect -> shade_path_kernel -> occluded -> add_unoccluded_kernel`` over every live path.
At a hit the kernel adds emission, draws one light for next-event estimation (its shadow ray is traced by the
accelerator afterwards) and samples the BSDF for the next ray. Light sampling and BSDF sampling are combined with
Veach's power heuristic (multiple importance sampling); delta lobes and delta lights take weight 1, and so does light
sampling of a light that casts no shadows or whose shadowLink leaves geometry out (its BSDF-sampled hits weight 0
where light sampling reaches: a bounce ray stops at occluders that the light's shadow rays pass, and lost its share
of the light behind them). After ``rr_depth`` bounces Russian roulette ends paths with probability
``q = max(0.05, 1 - min(1, max(throughput)))`` (at least 5% end at every such bounce, so a path of
throughput 1 cannot bounce on forever), dividing the survivors' throughput by their survival probability ``1 - q``.
``max_depth`` counts surface interactions: 1 gives direct lighting only.

Cut-out surfaces (``opacity < opacityThreshold``) are passed straight through by the trace before a hit gets here
(:func:`wrt.hidden_hits.intersect_visible`, for camera and bounce rays alike), so holes use up no bounce, and the
segment from the last scattering point to the hit behind the holes is one ray: lights seen through holes are
MIS-weighted by their pdf from that point, as next-event estimation weights them. A ray still in a hole after
:data:`wrt.shade.MAX_CULL_PASSES` holes in a row ends its path, as a shadow ray is blocked after as many
(:func:`wrt.hidden_hits.occluded_through_holes`).
"""

import dataclasses
import functools
import threading
from typing import NamedTuple

import warp as wp

from ..bsdf import eval_bsdf_lobes, lobe_albedos, sample_bsdf
from ..geometry import offset_ray_origin, stable_length
from ..hidden_hits import any_hit_t_max
from ..light_features import LightFeatures
from ..light_links import link_group, lit_by
from ..light_sampling import (
    LIGHT_GLOWING_HULL,
    LIGHT_GLOWING_SPHERE,
    LIGHT_GLOWING_TUBE,
    LIGHT_TRIANGLE,
    DeviceLights,
    LightSample,
    glowing_hull_pdf,
    glowing_sphere_pdf,
    glowing_tube_pdf,
    hit_emitter,
    light_kind,
    lit_bsdf,
    sample_light_in_view_for,
    shadow_direction,
    shadow_fades,
    shadow_reach,
    shadow_tint,
    triangle_light_pdf,
)
from ..materials import DeviceMaterials, eval_surface
from ..sampling import luminance, max_component, rand01, sample_cdf
from ..scene import DeviceScene
from ..shade import SHADING_CPU_FLAGS, DeviceSurfaces, HitPoint, shading_point
from .emitters import (
    environment,
    light_sample_weight,
    lights_on_segment_for,
    mis_weight,
    shadow_length,
    surface_emission,
)

# device-independent rounding, and a moderate inlining on the CPU: see wrt/shade.py
# (and of the modules of the kernels made per light features: features_module)
MODULE_OPTIONS = {"fuse_fp": False, "enable_backward": False, "cpu_compiler_flags": SHADING_CPU_FLAGS}
wp.set_module_options(MODULE_OPTIONS)

@wp.func
def shadow_ray_to(lights: DeviceLights, k: int, o: wp.vec3, p: wp.vec3, wi: wp.vec3, dist: float, u: float):
    """Direction and ``t_max`` of the shadow ray from ``o`` (``p`` moved off its surface by ``offset_ray_origin``)
    to light ``k`` sampled from ``p`` along unit ``wi`` at ``dist`` (inf: a light at infinity, along ``wi``);
    ``u`` draws the reach in a ShadowAPI falloff zone (:func:`wrt.light_sampling.shadow_reach`).

    Aimed from ``o`` at the sampled point, not along ``wi``: the ray along ``wi`` from ``o`` ended ``o - p`` away from
    that point (2e-5 on a floor 40 across), further than the 1e-4 of its length it then stopped short of an emissive
    triangle where the light is seen obliquely, and crossed the emitter's own surface there: a finely tessellated
    glowing sphere shadowed 1.3% of its own light. It stops short of the light by
    :func:`wrt.integrators.emitters.shadow_length`."""
    if dist == wp.inf:
        return shadow_direction(lights, k, wi), shadow_reach(lights, k, float(wp.inf), u)
    to = p + dist * wi - o
    length = stable_length(to)
    if length <= 0.0:
        return wp.vec3(0.0), 0.0
    reach = shadow_length(o, o + to, length)
    return shadow_direction(lights, k, to / length), shadow_reach(lights, k, reach, u)


@wp.func
def clear_shadow_ray(
    i: int,
    # outputs
    shadow_origins: wp.array[wp.vec3],
    shadow_dirs: wp.array[wp.vec3],
    shadow_t_maxs: wp.array[float],
    shadow_lights: wp.array[wp.int32],
    any_hit_t_maxs: wp.array[float],
):
    """Makes ray ``i``'s shadow ray empty (``t_max = 0``, no light): what it stays unless :func:`aim_shadow_ray`
    aims it."""
    shadow_origins[i] = wp.vec3(0.0)
    shadow_dirs[i] = wp.vec3(0.0)
    shadow_t_maxs[i] = 0.0
    shadow_lights[i] = -1
    any_hit_t_maxs[i] = 0.0


@wp.func
def aim_shadow_ray(
    lights: DeviceLights,
    k: int,
    h: HitPoint,
    ls: LightSample,
    u: float,
    i: int,
    # outputs
    shadow_origins: wp.array[wp.vec3],
    shadow_dirs: wp.array[wp.vec3],
    shadow_t_maxs: wp.array[float],
    shadow_lights: wp.array[wp.int32],
    any_hit_t_maxs: wp.array[float],
):
    """Writes ray ``i``'s shadow ray towards the point ``ls`` of light ``k`` sampled from hit ``h``: from ``h.p``
    moved off its surface, aimed by :func:`shadow_ray_to` (whitted's and path's next-event estimation); ``u``,
    uniform and independent of ``ls``, draws its reach in a ShadowAPI falloff zone. Also the end of its any-hit
    query (:func:`wrt.hidden_hits.any_hit_t_max`; shadow rays start at ``t_min = 0``), so that no launch of its
    own computes it."""
    o = offset_ray_origin(h.p, h.ng, h.reach, h.err, h.inner)
    shadow_origins[i] = o
    to_light, t_max = shadow_ray_to(lights, k, o, h.p, ls.wi, ls.dist, u)
    shadow_dirs[i] = to_light
    shadow_t_maxs[i] = t_max
    shadow_lights[i] = k
    any_hit_t_maxs[i] = any_hit_t_max(lights.num_analytic, k, 0.0, t_max)


@functools.cache
def features_module(integrator: str, features: LightFeatures):
    """The Warp module of integrator module ``integrator``'s kernels for scenes whose lights need ``features``
    (``wrt.integrators.path.shape_lights``, ...): a first render compiles the draws of the lights it has, not of every
    kind (``benchmarks/cuda_compile_time.py``). One module per integrator and features, all the integrator's kernels
    in it, so a render loads as many modules as before the variants: a module per kernel cost a cold CPU render
    about 1.5 s of compile per module, more than the CPU saved on the draws left out."""
    flags = [name for name, on in dataclasses.asdict(features).items() if on]
    module = wp.get_module(f"{integrator}.{'_'.join(flags) or 'no_features'}")
    module.options.update(MODULE_OPTIONS)
    return module


# Held while the kernels of a variant are made (path_kernels, whitted_kernels): functools.cache lets threads that ask
# for a new variant at once each make its kernels, and a kernel registered into a module another thread was loading
# missed that load's hash (Warp's launch then raised AttributeError: no tid_extent_limit_candidate, for every render
# of that variant in the process).
MAKING_KERNELS = threading.Lock()


@functools.cache
def shade_path_kernel_for(features: LightFeatures) -> wp.Kernel:
    """The path bounce kernel for scenes whose lights need ``features`` (:func:`wrt.light_features.light_features`;
    ``ALL_FEATURES`` serves any scene), in :func:`features_module`."""
    lights_on_segment = lights_on_segment_for(features)
    sample_light_in_view = sample_light_in_view_for(features)

    @wp.kernel(name="shade_path_kernel", module=features_module(__name__, features))
    def shade_path_kernel(
        scene: DeviceScene,
        surf: DeviceSurfaces,
        mats: DeviceMaterials,
        lights: DeviceLights,
        bounce: int,
        max_depth: int,
        rr_depth: int,
        hit_t: wp.array[float],
        hit_u: wp.array[float],
        hit_v: wp.array[float],
        hit_prim: wp.array[wp.int32],
        hit_instance: wp.array[wp.int32],
        views: wp.array[wp.int32],
        # outputs (paths are updated in place)
        origins: wp.array[wp.vec3],
        directions: wp.array[wp.vec3],
        t_mins: wp.array[float],
        t_maxs: wp.array[float],
        rng: wp.array[wp.uint32],
        throughput: wp.array[wp.vec3],
        radiance: wp.array[wp.vec3],
        alive: wp.array[wp.int32],
        pdf_prev: wp.array[float],
        prev_normal: wp.array[wp.vec3],
        diffuse_share: wp.array[wp.vec3],
        link_groups: wp.array[wp.int32],
        shadow_origins: wp.array[wp.vec3],
        shadow_dirs: wp.array[wp.vec3],
        shadow_t_maxs: wp.array[float],
        shadow_lights: wp.array[wp.int32],
        shadow_any_hit_t_maxs: wp.array[float],
        nee: wp.array[wp.vec3],
    ):
        """One bounce of every path: emission, next-event estimation (shadow ray + its contribution if unblocked) and
        the next ray."""
        i = wp.tid()
        # Every path gets a shadow ray, an empty one (t_max = 0) unless next-event estimation sets it below.
        clear_shadow_ray(i, shadow_origins, shadow_dirs, shadow_t_maxs, shadow_lights, shadow_any_hit_t_maxs)
        nee[i] = wp.vec3(0.0)
        if alive[i] == 0:
            t_maxs[i] = 0.0
            return
        o = origins[i]
        d = directions[i]
        T = throughput[i]
        L = radiance[i]
        state = rng[i]
        pdf_b = pdf_prev[i]
        prim = hit_prim[i]
        t_hit = hit_t[i]

        # Add the analytic lights the segment passes through, then what an escaped ray sees (scaled by the lights'
        # multipliers on the lobe that scattered the ray, and only lights linked to the surface that scattered it,
        # unless it is a camera ray).
        camera = wp.where(bounce == 0, 1, 0)
        share = diffuse_share[i]
        g_prev = link_groups[i]
        # A ray that meets nothing passes the lights up to its t_max, not infinity: a camera ray's far clipping plane or
        # a clipping plane's cut hides the lights past it, as it hides geometry (bounce rays have t_max = inf).
        end = wp.min(t_hit, t_maxs[i])
        L += wp.cw_mul(T, lights_on_segment(lights, o, d, t_mins[i], end, pdf_b, prev_normal[i], camera, share, g_prev))
        if prim < 0:
            L += wp.cw_mul(T, environment(lights, d, pdf_b, prev_normal[i], camera, share, g_prev))
            radiance[i] = L
            alive[i] = 0
            t_maxs[i] = 0.0
            return

        h = shading_point(scene, surf, mats, prim, hit_instance[i], hit_u[i], hit_v[i], o, d, t_hit)
        s = eval_surface(mats, h.material, h.st, h.display, h.opacity)
        group = link_group(lights.links, prim, hit_instance[i])

        # A hole the trace did not get past (more in a row than it passes) ends the path, as it blocks a shadow ray.
        if s.opacity_threshold > 0.0 and s.opacity < s.opacity_threshold:
            radiance[i] = L
            alive[i] = 0
            t_maxs[i] = 0.0
            return

        # Emission (a mesh light's as light sampling sees it, to rays a surface scattered), weighted against light
        # sampling of this triangle.
        if h.front == 1 or surf.double_sided[prim] == 1:
            e = hit_emitter(lights, surf.emitters[prim], prim, hit_instance[i])
            emitted = surface_emission(lights, mats, e, h.material, h.st, s.emission, camera, share, g_prev)
            if luminance(emitted) > 0.0:
                w = float(1.0)
                if e >= 0 and pdf_b > 0.0:
                    pdf_l = float(0.0)
                    e_kind = light_kind(lights, e)
                    if e_kind == LIGHT_TRIANGLE:
                        pdf_l = lights.pmf[e] * triangle_light_pdf(scene, surf.double_sided[prim], prim,
                                                                   hit_instance[i], o, d, t_hit)
                    elif wp.static(features.shape_lights):  # (else a glowing shape takes weight 1: it draws none)
                        if e_kind == LIGHT_GLOWING_SPHERE:
                            pdf_l = lights.pmf[e] * glowing_sphere_pdf(lights, e, o)
                        elif e_kind == LIGHT_GLOWING_TUBE:
                            pdf_l = lights.pmf[e] * glowing_tube_pdf(lights, e, surf.double_sided[prim], o, d, t_hit,
                                                                     h.ng)
                        elif e_kind == LIGHT_GLOWING_HULL:
                            pdf_l = lights.pmf[e] * glowing_hull_pdf(lights, scene, e, o, prev_normal[i], d, t_hit,
                                                                     h.ng)
                    w = mis_weight(lights, e, pdf_b, pdf_l)
                L += wp.cw_mul(T, emitted) * w
        if bounce >= max_depth:
            radiance[i] = L
            alive[i] = 0
            t_maxs[i] = 0.0
            return

        wo = -d
        lobes = lobe_albedos(s, mats.ggx_albedo, wp.dot(h.ns, wo))  # for both BSDF evaluations and the sample below
        # Next-event estimation: one light, one point on it (nothing from a light not linked to this surface).
        u_pick, state = rand01(state)
        u1, state = rand01(state)
        u2, state = rand01(state)
        if lights.count > 0:
            k = sample_cdf(lights.cdf, 0, lights.count, u_pick)
            pmf = lights.pmf[k]
            ls = sample_light_in_view(
                lights, scene, mats, surf.uvs, surf.materials, surf.double_sided, k, views[i], h.p, h.ns, u1, u2
            )
            if pmf > 0.0 and max_component(ls.value) > 0.0 and lit_by(lights.links, group, k):
                f_d, f_s, pdf_f = eval_bsdf_lobes(s, mats.ggx_albedo, lobes, h.ns, h.ng, wo, ls.wi)
                f = lit_bsdf(lights, k, f_d, f_s)
                if max_component(f) > 0.0:
                    w = light_sample_weight(lights, k, pmf * ls.pdf, pdf_f)
                    # f is 0 below the shading or geometric horizon (eval_opaque), so |cos| is max(cos, 0) here.
                    cos_i = wp.abs(wp.dot(h.ns, ls.wi))
                    nee[i] = wp.cw_mul(wp.cw_mul(T, f), ls.value) * (cos_i * w / pmf)
                    # A number of its own for a fading shadow only, so that other renders draw the numbers they drew.
                    u_reach = float(0.0)
                    if shadow_fades(lights, k):
                        u_reach, state = rand01(state)
                    aim_shadow_ray(lights, k, h, ls, u_reach, i, shadow_origins, shadow_dirs, shadow_t_maxs,
                                   shadow_lights, shadow_any_hit_t_maxs)

        # Sample the BSDF for the next ray.
        u0, state = rand01(state)
        u3, state = rand01(state)
        u4, state = rand01(state)
        u5, state = rand01(state)
        bs = sample_bsdf(s, mats.ggx_albedo, lobes, h.ns, h.ng, wo, h.front, u0, u3, u4, u5)
        T = wp.cw_mul(T, bs.weight)
        keep = max_component(T) > 0.0
        if keep and bounce + 1 >= rr_depth:
            q = wp.max(0.05, 1.0 - wp.min(1.0, max_component(T)))
            u_rr, state = rand01(state)
            if u_rr < q:
                keep = False
            else:
                T = T / (1.0 - q)
        radiance[i] = L
        rng[i] = state
        if not keep:
            alive[i] = 0
            t_maxs[i] = 0.0
            return
        throughput[i] = T
        if bs.transmitted == 1:
            origins[i] = offset_ray_origin(h.p, -h.ng, h.reach, h.err, h.inner)
            prev_normal[i] = -h.ns
        else:
            origins[i] = offset_ray_origin(h.p, h.ng, h.reach, h.err, h.inner)
            prev_normal[i] = h.ns
        directions[i] = bs.wi
        t_mins[i] = 0.0
        t_maxs[i] = wp.inf
        pdf_prev[i] = wp.where(bs.delta == 1, 0.0, bs.pdf)
        diffuse_share[i] = bs.diffuse
        link_groups[i] = group

    return shade_path_kernel


@wp.kernel
def add_unoccluded_kernel(
    lights: DeviceLights,
    contribution: wp.array[wp.vec3],
    shadow_t_maxs: wp.array[float],
    blocked: wp.array[wp.int32],
    shadow_lights: wp.array[wp.int32],
    # outputs
    radiance: wp.array[wp.vec3],
):
    """Adds each next-event contribution whose shadow ray reached its light, and of those blocked the share their
    light's ShadowAPI colour lets through."""
    i = wp.tid()
    if shadow_t_maxs[i] > 0.0:
        if blocked[i] == 0:
            radiance[i] = radiance[i] + contribution[i]
        elif lights.shadow_api_on == 1:
            radiance[i] = radiance[i] + wp.cw_mul(contribution[i], shadow_tint(lights, shadow_lights[i]))


@functools.cache
def add_unoccluded_kernel_for(features: LightFeatures) -> wp.Kernel:
    """:func:`add_unoccluded_kernel` in the module of :func:`shade_path_kernel_for` ``(features)``, so that a path
    render loads that one module (the kernel itself reads no light draw)."""
    return wp.kernel(add_unoccluded_kernel.func, module=features_module(__name__, features))


class PathKernels(NamedTuple):
    """The kernels of a path render for one set of light features (:func:`path_kernels`)."""

    shade: wp.Kernel  # shade_path_kernel_for(features)
    add_unoccluded: wp.Kernel  # add_unoccluded_kernel_for(features)


def path_kernels(features: LightFeatures) -> PathKernels:
    """Every kernel of a path render for ``features``, made together before any is launched: a kernel added to a
    module after it was loaded makes Warp build the module again (made one at a time, whitted's module was compiled
    three times in a cold render). Made once, by one thread (:data:`MAKING_KERNELS`)."""
    with MAKING_KERNELS:
        return _made_path_kernels(features)


@functools.cache
def _made_path_kernels(features: LightFeatures) -> PathKernels:
    return PathKernels(shade_path_kernel_for(features), add_unoccluded_kernel_for(features))


__all__ = ["PathKernels", "add_unoccluded_kernel_for", "mis_weight", "path_kernels", "shade_path_kernel_for"]
