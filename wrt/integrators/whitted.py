"""Whitted-style recursive ray tracing (Whitted 1980), as wavefront kernels.

At every hit: emission; direct light from every light with a shadow ray each (area and soft lights get one random
point per sample, so their shadows soften as ``spp`` grows; all emissive triangles together count as one light, of
which each sample reaches the one it keeps of several drawn by power: :mod:`wrt.emitter_resampling`); the dome
light as an unoccluded term: the dome's irradiance over pi (:mod:`wrt.dome_irradiance`) at the shading normal times
the directional albedo of the BSDF's diffuse lobe, and what its rough specular and clearcoat lobes (with multiple
scattering, as the path tracer's BSDF has them) reflect of it: a constant dome's radiance times their albedo,
a textured dome's estimated from one dome and one BSDF direction per sample (:func:`glossy_dome`); what ``path``
converges to for an unoccluded surface (use ``path`` for occluded sky light).
Then one continuation ray: the mirror direction for the smooth lobes (roughness below ``DELTA_ROUGHNESS``: a
metal's, a dielectric's or a specular workflow's specular lobe, weight ``F``, and a smooth clearcoat, each as
:func:`wrt.bsdf.sample_bsdf` weights it) and for glass (``opacity < 1``: reflection or Snell refraction, chosen with
probability proportional to their Fresnel weights; a thin-walled sheet's transmission goes straight on, see
:mod:`wrt.bsdf`). Other surfaces end the ray: a rough lobe takes its light from the light sampling above, and a
mirror ray from it would add the same lights a second time. ``max_depth`` bounds the number of mirror/refraction
bounces.
"""

import functools
from typing import NamedTuple

import warp as wp

from ..bsdf import (
    DELTA_ROUGHNESS,
    LobeAlbedos,
    Surface,
    dielectric_interface,
    eval_bsdf_lobes,
    eval_opaque,
    is_glass,
    lobe_albedos,
    mirror_reflection,
    opaque_fraction,
    reflect,
    sample_bsdf,
    surface_albedo,
    unreflected,
)
from ..dome_irradiance import sh_irradiance
from ..emitter_resampling import resample_emitter
from ..geometry import offset_ray_origin
from ..hidden_hits import CullScratch
from ..light_features import LightFeatures
from ..light_links import link_group, lit_by
from ..light_sampling import (
    DeviceLights,
    dome_pdf,
    dome_radiance,
    hit_emitter,
    lit_bsdf,
    sample_dome,
    sample_light_in_view_for,
    shadow_fades,
    shadow_tint,
)
from ..materials import DeviceMaterials, eval_surface
from ..microfacet_albedo import GgxAlbedo
from ..sampling import luminance, max_component, power_heuristic, rand01
from ..scene import DeviceScene
from ..shade import DeviceSurfaces, HitPoint, shading_point
from .emitters import environment, lights_on_segment_for, surface_emission
from .path import MAKING_KERNELS, MODULE_OPTIONS, aim_shadow_ray, clear_shadow_ray, features_module

# device-independent rounding, and a moderate inlining on the CPU: see wrt/shade.py
# (and of the modules of the kernels made per light features: path.features_module)
wp.set_module_options(MODULE_OPTIONS)


@wp.func
def mirror_weight(s: Surface, lobes: LobeAlbedos):
    """Weight of the opaque BSDF's mirror lobes, which Whitted lights with its mirror ray (``lobes``:
    :func:`wrt.bsdf.lobe_albedos` for the viewer): a smooth specular lobe's ``F`` under the clearcoat (``1 - coat``
    of it) and a smooth clearcoat's own, as :func:`wrt.bsdf.sample_bsdf` weights its mirror samples. A dielectric's
    lobe counts as a metal's: weighted by ``metallic``, smooth plastic had no reflection at all."""
    w = wp.vec3(0.0)
    if s.roughness < DELTA_ROUGHNESS:
        w = lobes.spec * (1.0 - lobes.coat)
    if s.clearcoat > 0.0 and s.clearcoat_roughness < DELTA_ROUGHNESS:
        w += wp.vec3(lobes.coat)
    return w


@wp.func
def dome_albedos(s: Surface, lobes: LobeAlbedos):
    """``(diffuse, specular)``: what the opaque BSDF's lobes that Whitted lights from the dome reflect of a uniform
    white dome, for the viewer of ``lobes`` (:func:`wrt.bsdf.lobe_albedos`): the diffuse lobe's albedo less what the
    lobes above it reflect (as :func:`wrt.bsdf.eval_opaque` scales it), and the directional albedos of the rough
    specular lobe (with its multiple scattering) and of a rough clearcoat. The mirror lobes are left to the mirror
    ray (:func:`mirror_weight`). The diffuse albedo was taken whole and a rough lobe weighted by ``metallic``: a
    dielectric's lobe and the clearcoat reflected none of the dome (a black plastic was black, 0.04 with the path
    tracer) and a half metal showed 0.46 against 0.52."""
    below = 1.0 - lobes.coat
    spec = lobes.spec + lobes.spec_ms
    diffuse = wp.cw_mul(unreflected(spec), surface_albedo(s)) * below
    specular = wp.vec3(0.0)
    if s.roughness >= DELTA_ROUGHNESS:
        specular = spec * below
    if s.clearcoat > 0.0 and s.clearcoat_roughness >= DELTA_ROUGHNESS:
        specular += wp.vec3(lobes.coat)
    return diffuse, specular


@wp.func
def dome_irradiance(lights: DeviceLights, n: wp.vec3):
    """The unoccluded dome's irradiance over pi at a surface facing world direction ``n``: what a white Lambertian
    surface reflects of it (:mod:`wrt.dome_irradiance`). The dome's mean radiance lit every surface alike: a floor
    under a blue sky over brown ground showed their average."""
    return sh_irradiance(lights.dome_sh, wp.normalize(lights.dome_to_local * n))


@wp.func
def has_glossy_lobe(s: Surface):
    """Whether the opaque BSDF has a non-delta specular lobe: a rough specular lobe (with its multiple scattering)
    or a rough clearcoat."""
    return s.roughness >= DELTA_ROUGHNESS or (s.clearcoat > 0.0 and s.clearcoat_roughness >= DELTA_ROUGHNESS)


@wp.func
def glossy_lobes(lobes: LobeAlbedos):
    """``lobes`` with the diffuse lobe's selection weight moved to the others: :func:`wrt.bsdf.sample_bsdf` then draws
    from the specular, multiple-scattering and clearcoat lobes alone, and :func:`wrt.bsdf.eval_opaque` returns the
    density of those draws (the BSDF values do not read the weights). All weights 0 where those lobes have none."""
    out = LobeAlbedos()
    out.spec = lobes.spec
    out.spec_ms = lobes.spec_ms
    out.ms_color = lobes.ms_color
    out.loss_o = lobes.loss_o
    out.average_loss = lobes.average_loss
    out.ms_total = lobes.ms_total
    out.coat = lobes.coat
    w = lobes.weights
    glossy = w[1] + w[2] + w[3]
    out.weights = wp.vec4(0.0)
    if glossy > 0.0:
        out.weights = wp.vec4(0.0, w[1] / glossy, w[2] / glossy, w[3] / glossy)
    return out


@wp.func
def glossy_dome(
    lights: DeviceLights,
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    s: Surface,
    lobes: LobeAlbedos,
    h: HitPoint,
    wo: wp.vec3,
    state: wp.uint32,
):
    """``(radiance, state)``: the unoccluded textured dome reflected by the opaque BSDF's non-delta specular lobes
    (before ``opaque_fraction``), estimated from one direction drawn from the dome and one from those lobes, weighted
    by the power heuristic: it converges to what ``path`` gives for an unoccluded surface, where a glossy lobe's
    reflection of the dome's irradiance blurred sharp skies as a diffuse surface does."""
    u1, state = rand01(state)
    u2, state = rand01(state)
    u3, state = rand01(state)
    u4, state = rand01(state)
    u5, state = rand01(state)
    total = wp.vec3(0.0)
    glossy = glossy_lobes(lobes)
    if glossy.weights[1] + glossy.weights[2] + glossy.weights[3] <= 0.0:
        return total, state
    ls = sample_dome(lights, lights.dome, h.ns, u1, u2)
    if ls.pdf > 0.0:
        _, f_s, p_bsdf = eval_opaque(s, mats.ggx_albedo, glossy, h.ns, h.ng, wo, ls.wi)
        total += wp.cw_mul(f_s, ls.value) * (wp.dot(h.ns, ls.wi) * power_heuristic(ls.pdf, p_bsdf))
    # u0 = 0: the opaque part, not glass; a delta lobe drawn is left to the mirror ray.
    b = sample_bsdf(s, mats.ggx_albedo, glossy, h.ns, h.ng, wo, h.front, 0.0, u3, u4, u5)
    if b.delta == 0 and b.transmitted == 0 and b.pdf > 0.0:
        _, f_s, p_bsdf = eval_opaque(s, mats.ggx_albedo, glossy, h.ns, h.ng, wo, b.wi)
        if p_bsdf > 0.0:
            weight = power_heuristic(p_bsdf, dome_pdf(lights, b.wi, h.ns))
            total += wp.cw_mul(f_s, dome_radiance(lights, b.wi)) * (wp.dot(h.ns, b.wi) / p_bsdf * weight)
    return total, state


@functools.cache
def shade_whitted_kernel_for(features: LightFeatures) -> wp.Kernel:
    """Whitted's emission and dome kernel for scenes whose lights need ``features``, in the module of whitted's
    kernels for them (:func:`wrt.integrators.path.features_module`)."""
    lights_on_segment = lights_on_segment_for(features)

    @wp.kernel(name="shade_whitted_kernel", module=features_module(__name__, features))
    def shade_whitted_kernel(
        scene: DeviceScene,
        surf: DeviceSurfaces,
        mats: DeviceMaterials,
        lights: DeviceLights,
        bounce: int,
        hit_t: wp.array[float],
        hit_u: wp.array[float],
        hit_v: wp.array[float],
        hit_prim: wp.array[wp.int32],
        hit_instance: wp.array[wp.int32],
        origins: wp.array[wp.vec3],
        directions: wp.array[wp.vec3],
        t_mins: wp.array[float],
        t_maxs: wp.array[float],
        throughput: wp.array[wp.vec3],
        link_groups: wp.array[wp.int32],
        # outputs
        radiance: wp.array[wp.vec3],
        alive: wp.array[wp.int32],
        rng: wp.array[wp.uint32],
    ):
        """Emission, light passed through, the environment of escaped rays and the dome term; the paths left alive
        (``alive = 1``) are those whose hit gets direct lighting and a continuation. Random numbers are drawn only for
        the glossy lobes under a textured dome (:func:`glossy_dome`)."""
        i = wp.tid()
        if alive[i] == 0:
            return
        o = origins[i]
        d = directions[i]
        T = throughput[i]
        L = radiance[i]
        prim = hit_prim[i]
        t_hit = hit_t[i]
        # Rays after the first are mirror and refraction rays: the lights' specular multipliers scale what they see,
        # and they see only the lights linked to the surface that sent them (link_groups, set by continue_whitted).
        camera = wp.where(bounce == 0, 1, 0)
        g_prev = link_groups[i]
        # A ray that meets nothing passes the lights up to its t_max, not infinity: a camera ray's far clipping plane or
        # a clipping plane's cut hides the lights past it, as it hides geometry (mirror rays have t_max = inf).
        end = wp.min(t_hit, t_maxs[i])
        L += wp.cw_mul(T, lights_on_segment(lights, o, d, t_mins[i], end, 0.0, wp.vec3(0.0), camera, wp.vec3(0.0),
                                            g_prev))
        if prim < 0:
            L += wp.cw_mul(T, environment(lights, d, 0.0, wp.vec3(0.0), camera, wp.vec3(0.0), g_prev))
            radiance[i] = L
            alive[i] = 0
            return
        h = shading_point(scene, surf, mats, prim, hit_instance[i], hit_u[i], hit_v[i], o, d, t_hit)
        s = eval_surface(mats, h.material, h.st, h.display, h.opacity)
        if s.opacity_threshold > 0.0 and s.opacity < s.opacity_threshold:
            # A hole the trace did not get past (more in a row than it passes: wrt.hidden_hits.intersect_visible) ends
            # the path, as it blocks a shadow ray.
            radiance[i] = L
            alive[i] = 0
            return
        if h.front == 1 or surf.double_sided[prim] == 1:
            e = hit_emitter(lights, surf.emitters[prim], prim, hit_instance[i])
            emitted = surface_emission(lights, mats, e, h.material, h.st, s.emission, camera, wp.vec3(0.0), g_prev)
            L += wp.cw_mul(T, emitted)
        if lights.dome >= 0 and lit_by(lights.links, link_group(lights.links, prim, hit_instance[i]), lights.dome):
            lobes = lobe_albedos(s, mats.ggx_albedo, wp.max(wp.dot(h.ns, -d), 0.0))
            diffuse, specular = dome_albedos(s, lobes)
            scale = lights.lobe_scale[lights.dome]  # the dome's diffuse and specular multipliers
            ambient = wp.cw_mul(diffuse * scale[0], dome_irradiance(lights, h.ns))
            if lights.dome_textured == 1 and has_glossy_lobe(s) and opaque_fraction(s) > 0.0:
                glossy, state = glossy_dome(lights, scene, surf, mats, s, lobes, h, -d, rng[i])
                rng[i] = state
                ambient += glossy * scale[1]
            else:
                # A constant dome: its irradiance about the mirror direction is its radiance, times the lobes' albedo.
                ambient += wp.cw_mul(specular * scale[1], dome_irradiance(lights, reflect(-d, h.ns)))
            L += wp.cw_mul(T, ambient) * opaque_fraction(s)
        radiance[i] = L

    return shade_whitted_kernel


@functools.cache
def whitted_lights_kernel_for(features: LightFeatures) -> wp.Kernel:
    """Whitted's direct-light kernel for scenes whose lights need ``features``, in the module of whitted's kernels
    for them (:func:`wrt.integrators.path.features_module`)."""
    sample_light_in_view = sample_light_in_view_for(features)

    @wp.kernel(name="whitted_lights_kernel", module=features_module(__name__, features))
    def whitted_lights_kernel(
        scene: DeviceScene,
        surf: DeviceSurfaces,
        mats: DeviceMaterials,
        lights: DeviceLights,
        groups: wp.array[wp.vec2i],
        first_group: int,
        num_groups: int,
        emitter_candidates: int,
        offset: int,
        origins: wp.array[wp.vec3],
        directions: wp.array[wp.vec3],
        hit_t: wp.array[float],
        hit_u: wp.array[float],
        hit_v: wp.array[float],
        hit_prim: wp.array[wp.int32],
        hit_instance: wp.array[wp.int32],
        throughput: wp.array[wp.vec3],
        alive: wp.array[wp.int32],
        views: wp.array[wp.int32],
        # outputs
        rng: wp.array[wp.uint32],
        shadow_origins: wp.array[wp.vec3],
        shadow_dirs: wp.array[wp.vec3],
        shadow_t_maxs: wp.array[float],
        shadow_lights: wp.array[wp.int32],
        shadow_any_hit_t_maxs: wp.array[float],
        contribution: wp.array[wp.vec3],
    ):
        """Direct light of path ``offset + tid`` from light groups ``[first_group, first_group + num_groups)`` of
        ``groups`` (each ``(first, count)``: lights ``[first, first + count)``; when ``count > 1`` the emissive
        triangles, one of them kept of ``emitter_candidates`` drawn by power: :mod:`wrt.emitter_resampling`), in group
        order: each one's contribution if unoccluded and the shadow ray that decides it, at ``j * n + i`` for the
        ``j``-th group of path ``i`` (``n`` paths); none from a light not linked to the surface.
        The random numbers are drawn group after group, as one launch per group drew them."""
        i = wp.tid() + offset
        n = origins.shape[0]
        for j in range(num_groups):
            # unless aimed below
            clear_shadow_ray(j * n + i, shadow_origins, shadow_dirs, shadow_t_maxs, shadow_lights,
                             shadow_any_hit_t_maxs)
            contribution[j * n + i] = wp.vec3(0.0)
        if alive[i] == 0:
            return
        o = origins[i]
        d = directions[i]
        prim = hit_prim[i]
        h = shading_point(scene, surf, mats, prim, hit_instance[i], hit_u[i], hit_v[i], o, d, hit_t[i])
        s = eval_surface(mats, h.material, h.st, h.display, h.opacity)
        group = link_group(lights.links, prim, hit_instance[i])
        wo = -d
        lobes = lobe_albedos(s, mats.ggx_albedo, wp.dot(h.ns, wo))
        state = rng[i]
        for j in range(num_groups):
            g = groups[first_group + j]
            first = g[0]
            count = g[1]
            u_pick, state = rand01(state)
            u1, state = rand01(state)
            u2, state = rand01(state)
            k = first
            p_pick = float(1.0)
            if count > 1:  # the emissive triangles: one kept of candidates drawn by power (wrt.emitter_resampling)
                k, p_pick, state = resample_emitter(lights, scene, surf.double_sided, first, count, emitter_candidates,
                                                    group, h.p, h.ns, s, mats.ggx_albedo, lobes, h.ng, wo, state)
            ls = sample_light_in_view(
                lights, scene, mats, surf.uvs, surf.materials, surf.double_sided, k, views[i], h.p, h.ns, u1, u2
            )
            if max_component(ls.value) > 0.0 and p_pick > 0.0 and lit_by(lights.links, group, k):
                f_d, f_s, _ = eval_bsdf_lobes(s, mats.ggx_albedo, lobes, h.ns, h.ng, wo, ls.wi)
                f = lit_bsdf(lights, k, f_d, f_s)
                if max_component(f) > 0.0:
                    # f is 0 below the shading or geometric horizon (eval_opaque), so |cos| is max(cos, 0) here.
                    cos_i = wp.abs(wp.dot(h.ns, ls.wi))
                    contribution[j * n + i] = wp.cw_mul(wp.cw_mul(throughput[i], f), ls.value) * (cos_i / p_pick)
                    # u_pick (unused by a group of one light), or a number of its own for a fading shadow
                    # (shadow_fades).
                    u_reach = u_pick
                    if count > 1 and shadow_fades(lights, k):
                        u_reach, state = rand01(state)
                    aim_shadow_ray(lights, k, h, ls, u_reach, j * n + i, shadow_origins, shadow_dirs, shadow_t_maxs,
                                   shadow_lights, shadow_any_hit_t_maxs)
        rng[i] = state

    return whitted_lights_kernel


@wp.kernel
def add_unoccluded_lights_kernel(
    lights: DeviceLights,
    num_groups: int,
    offset: int,
    contribution: wp.array[wp.vec3],
    shadow_t_maxs: wp.array[float],
    blocked: wp.array[wp.int32],
    shadow_lights: wp.array[wp.int32],
    # outputs
    radiance: wp.array[wp.vec3],
):
    """Adds to path ``offset + tid`` (of ``n = len(radiance)``) the contribution of each of its ``num_groups``
    shadow rays (``j * n + i``) that reached its light, in group order, and of those blocked the share their light's
    ShadowAPI colour lets through."""
    i = wp.tid() + offset
    n = radiance.shape[0]
    L = radiance[i]
    for j in range(num_groups):
        if shadow_t_maxs[j * n + i] > 0.0:
            if blocked[j * n + i] == 0:
                L = L + contribution[j * n + i]
            elif lights.shadow_api_on == 1:
                L = L + wp.cw_mul(contribution[j * n + i], shadow_tint(lights, shadow_lights[j * n + i]))
    radiance[i] = L


@wp.func
def whitted_continuation(s: Surface, tables: GgxAlbedo, ns: wp.vec3, ng: wp.vec3, front: int, wo: wp.vec3, u: float):
    """``(wi, weight, transmitted)``: the ray a Whitted path goes on with from surface ``s`` seen from ``wo``
    (shading normal ``ns`` and geometric ``ng`` on its side, ``front``: on the winding's front), the mirror ray or
    the transmitted one (``transmitted`` 1), picked by ``u`` in [0, 1) with probability proportional to their weights,
    and the factor of the path's throughput (zero: the path ends here)."""
    cos_o = wp.max(wp.dot(ns, wo), 0.0)
    op = opaque_fraction(s)
    w_refract = float(0.0)
    w_reflect = mirror_weight(s, lobe_albedos(s, tables, cos_o)) * op
    wt = wp.vec3(0.0)
    if is_glass(s) and cos_o > 0.0:
        fr, wt = dielectric_interface(s, ns, ng, wo, front)
        w_reflect += wp.vec3(fr * (1.0 - op))
        w_refract = (1.0 - fr) * (1.0 - op)
    p_reflect = luminance(w_reflect)
    total = p_reflect + w_refract
    if total <= 0.0 or cos_o <= 0.0:
        return wp.vec3(0.0), wp.vec3(0.0), 0
    if u * total < p_reflect:
        wi, lit = mirror_reflection(wo, ns, ng)  # as the path tracer's: none into the surface
        return wi, w_reflect * (total / p_reflect * lit), 0
    return wt, wp.vec3(total), 1  # w_refract / (w_refract / total); no 1 / eta^2: see bsdf.sample_bsdf


@wp.kernel
def continue_whitted_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    lights: DeviceLights,
    bounce: int,
    max_depth: int,
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    hit_instance: wp.array[wp.int32],
    # outputs
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    rng: wp.array[wp.uint32],
    throughput: wp.array[wp.vec3],
    alive: wp.array[wp.int32],
    link_groups: wp.array[wp.int32],
):
    """The mirror or refracted continuation of each shaded path, or its end."""
    i = wp.tid()
    if alive[i] == 0:  # ended at this hit (a miss or a hole), or earlier
        t_maxs[i] = 0.0
        return
    if bounce >= max_depth:
        alive[i] = 0
        t_maxs[i] = 0.0
        return
    d = directions[i]
    prim = hit_prim[i]
    h = shading_point(scene, surf, mats, prim, hit_instance[i], hit_u[i], hit_v[i], origins[i], d, hit_t[i])
    s = eval_surface(mats, h.material, h.st, h.display, h.opacity)
    # Drawn whether or not the path goes on: a path that ends here never reads its generator again.
    u, state = rand01(rng[i])
    rng[i] = state
    wi, weight, transmitted = whitted_continuation(s, mats.ggx_albedo, h.ns, h.ng, h.front, -d, u)
    T = wp.cw_mul(throughput[i], weight)
    if max_component(T) <= 0.0:
        alive[i] = 0
        t_maxs[i] = 0.0
        return
    directions[i] = wi
    if transmitted == 1:
        origins[i] = offset_ray_origin(h.p, -h.ng, h.reach, h.err, h.inner)
    else:
        origins[i] = offset_ray_origin(h.p, h.ng, h.reach, h.err, h.inner)
    throughput[i] = T
    link_groups[i] = link_group(lights.links, prim, hit_instance[i])
    t_mins[i] = 0.0
    t_maxs[i] = wp.inf


SHADOW_RAYS_PER_BATCH = 1 << 20  # shadow rays traced together: about 90 bytes of device memory each


def lights_per_batch(groups: int, paths: int) -> int:
    """Light groups lit in one launch for ``paths`` paths: as many as :data:`SHADOW_RAYS_PER_BATCH` shadow rays
    hold (at least 1, at most ``groups``). One launch per light made 10,000 lights 10,000 launches of the light
    kernel, the shadow-ray trace and the add per bounce (30 s for a 32 x 32 image on the CPU)."""
    return max(1, min(groups, SHADOW_RAYS_PER_BATCH // max(paths, 1)))


class ShadowRays:
    """``n`` shadow rays towards lights and the next-event contribution each adds if unoccluded (device arrays),
    with the scratch buffers of their trace through holes (:class:`wrt.hidden_hits.CullScratch`).

    Args:
        n: number of rays.
        device: Warp device.
        nothing_to_cull: as :class:`wrt.hidden_hits.CullScratch` takes it.
        no_holes: likewise.
    """

    BYTES_PER_RAY = 3 * 12 + 4 * 4 + CullScratch.BYTES_PER_RAY  # three vec3 and four 4-byte arrays, the scratch

    def __init__(self, n: int, device, nothing_to_cull: bool, no_holes: bool):
        self.n = n
        self.origins = wp.empty(n, dtype=wp.vec3, device=device)
        self.dirs = wp.empty(n, dtype=wp.vec3, device=device)
        self.t_mins = wp.zeros(n, dtype=float, device=device)
        self.t_maxs = wp.empty(n, dtype=float, device=device)
        self.lights = wp.empty(n, dtype=wp.int32, device=device)  # the light of each ray (-1: none), for shadow links
        self.blocked = wp.empty(n, dtype=wp.int32, device=device)
        self.contribution = wp.empty(n, dtype=wp.vec3, device=device)
        self.scratch = CullScratch(n, device, nothing_to_cull, no_holes)

    @classmethod
    def of(cls, origins, dirs, t_mins, t_maxs, lights, blocked, contribution, scratch) -> "ShadowRays":
        """Shadow rays held in arrays that exist already (a wavefront's own, one per path)."""
        rays = object.__new__(cls)
        rays.n = len(origins)
        rays.origins, rays.dirs, rays.t_mins, rays.t_maxs = origins, dirs, t_mins, t_maxs
        rays.lights, rays.blocked, rays.contribution, rays.scratch = lights, blocked, contribution, scratch
        return rays

    def head(self, m: int) -> "ShadowRays":
        """The first ``m`` rays (views, not copies)."""
        return ShadowRays.of(self.origins[:m], self.dirs[:m], self.t_mins[:m], self.t_maxs[:m], self.lights[:m],
                             self.blocked[:m], self.contribution[:m], self.scratch.head(m))

    @property
    def rays(self) -> list:
        return [self.origins, self.dirs, self.t_mins, self.t_maxs]

    @property
    def any_hit_t_maxs(self):
        """Where the kernel that aims the rays writes the end of each one's any-hit query
        (:func:`wrt.hidden_hits.any_hit_t_max`): the scratch's ``t_maxs``, free until the rays are traced."""
        return self.scratch.t_maxs


@functools.cache
def continue_whitted_kernel_for(features: LightFeatures) -> wp.Kernel:
    """:func:`continue_whitted_kernel` in the module of whitted's kernels for ``features``, so that a whitted render
    loads that one module (the kernel itself reads no light draw)."""
    return wp.kernel(continue_whitted_kernel.func, module=features_module(__name__, features))


@functools.cache
def add_unoccluded_lights_kernel_for(features: LightFeatures) -> wp.Kernel:
    """:func:`add_unoccluded_lights_kernel` in the module of whitted's kernels for ``features`` (as
    :func:`continue_whitted_kernel_for`)."""
    return wp.kernel(add_unoccluded_lights_kernel.func, module=features_module(__name__, features))


class WhittedKernels(NamedTuple):
    """The kernels of a whitted render for one set of light features (:func:`whitted_kernels`)."""

    shade: wp.Kernel  # shade_whitted_kernel_for(features)
    lights: wp.Kernel  # whitted_lights_kernel_for(features)
    continue_paths: wp.Kernel  # continue_whitted_kernel_for(features)
    add_unoccluded: wp.Kernel  # add_unoccluded_lights_kernel_for(features)


def whitted_kernels(features: LightFeatures) -> WhittedKernels:
    """Every kernel of a whitted render for ``features``, made together before any is launched, once, by one thread
    (see :func:`wrt.integrators.path.path_kernels`)."""
    with MAKING_KERNELS:
        return _made_whitted_kernels(features)


@functools.cache
def _made_whitted_kernels(features: LightFeatures) -> WhittedKernels:
    return WhittedKernels(shade_whitted_kernel_for(features), whitted_lights_kernel_for(features),
                          continue_whitted_kernel_for(features), add_unoccluded_lights_kernel_for(features))
