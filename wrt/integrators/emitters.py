"""Radiance that a ray segment picks up from lights: analytic area lights it passes through, the emissive or
mesh-light triangle it hits and, for rays that escape, the dome and the discs of soft distant lights; each weighted
against BSDF sampling by MIS, and, for rays a surface scattered, by the lights' ``diffuse`` and ``specular``
multipliers on the lobes that scattered them (camera rays see lights unscaled), and left out where the light is not
linked to that surface (``collection:lightLink``, :mod:`wrt.light_links`)."""

import functools

import warp as wp

from ..floats import largest_magnitude
from ..light_features import ALL_FEATURES, LightFeatures
from ..light_links import lit_by
from ..light_sampling import (
    LIGHT_DISTANT,
    LIGHT_DOME,
    DeviceLights,
    area_light_pdf_for,
    distant_in_cone,
    dome_pdf,
    dome_radiance,
    emission_shaping_for,
    intersect_light_for,
    light_texture,
    lobe_factor,
    sampled_alone,
    triangle_emission,
)
from ..materials import DeviceMaterials
from ..sampling import power_heuristic

# Shadow rays stop, and every ray counts an analytic light behind what it hit, this fraction of the largest distance
# or coordinate involved short: 16 float32 rounding steps, so a light flush with a ceiling, at its distance but for
# rounding, is still reached. Rounding may still put an emissive triangle itself (geometry) before that end, which
# blocks no shadow ray aimed at it (wrt.hidden_hits.occluded_through_holes). 1e-4 of the length (SHADOW_SHORTEN, as it
# was) lit a floor 1000 away from a wall by a rect light, or a glowing quad, 0.05 behind it.
ROUNDING_MARGIN = wp.constant(2.0**-20)


@wp.func
def rounding_margin(o: wp.vec3, end: wp.vec3, length: float):
    """How far a light at ``end``, ``length`` along a ray from ``o``, may lie behind geometry hit there and still
    count as flush with it: :data:`ROUNDING_MARGIN` of the largest of ``length`` and the coordinates of ``o`` and
    ``end`` (the rounding of a hit distance grows with each)."""
    return ROUNDING_MARGIN * wp.max(length, wp.max(largest_magnitude(o), largest_magnitude(end)))


@wp.func
def shadow_length(o: wp.vec3, end: wp.vec3, length: float):
    """Where a shadow ray from ``o`` to the point ``end`` of a light, ``length`` away, stops: :func:`rounding_margin`
    short of it, for analytic lights and emissive triangles alike (the triangle that a ray is aimed at does not block
    it: :func:`wrt.hidden_hits.occluded_through_holes`)."""
    return length - rounding_margin(o, end, length)


@wp.func
def mis_weight(lights: DeviceLights, k: int, pdf_bsdf: float, pdf_light: float):
    """Weight of a BSDF-sampled hit on light ``k`` (``pdf_light``: the pdf of light sampling drawing it, selection
    included): 1 after delta events or for camera rays (``pdf_bsdf = 0``). A light without shadows, or whose
    shadowLink leaves some geometry out, gives light sampling the whole weight wherever it reaches
    (:func:`wrt.light_sampling.sampled_alone`, :func:`light_sample_weight`)."""
    if pdf_bsdf <= 0.0:
        return 1.0
    if sampled_alone(lights, k):
        return wp.where(pdf_light > 0.0, 0.0, 1.0)
    return power_heuristic(pdf_bsdf, pdf_light)


@wp.func
def light_sample_weight(lights: DeviceLights, k: int, pdf_light: float, pdf_bsdf: float):
    """Weight of next-event estimation towards light ``k`` (``pdf_light``: selection times solid-angle pdf, 0 for
    delta lights): the counterpart of :func:`mis_weight`, 1 for delta lights and lights sampled alone."""
    if pdf_light <= 0.0 or sampled_alone(lights, k):
        return 1.0
    return power_heuristic(pdf_light, pdf_bsdf)


@wp.func
def scattered_by(lights: DeviceLights, k: int, camera: int, diffuse_share: wp.vec3):
    """The factor of light ``k``'s multipliers on what a ray brings back from it: 1 for camera rays, else
    :func:`wrt.light_sampling.lobe_factor` for the surface that scattered the ray with ``diffuse_share`` diffusely."""
    if camera == 1:
        return wp.vec3(1.0)
    return lobe_factor(lights, k, diffuse_share)


@wp.func
def reaches(lights: DeviceLights, k: int, camera: int, group: int):
    """Whether what a ray brings back from light ``k`` counts: always for camera rays (cameras see every light),
    else where the light lights the surface that scattered the ray (link group ``group``)."""
    if camera == 1:
        return True
    return lit_by(lights.links, group, k)


@functools.cache
def lights_on_segment_for(features: LightFeatures):
    """:func:`lights_on_segment` of the lights of ``features`` (:mod:`wrt.light_features`)."""
    intersect_light = intersect_light_for(features)
    area_light_pdf = area_light_pdf_for(features)
    emission_shaping = emission_shaping_for(features)

    @wp.func
    def lights_on_segment(
        lights: DeviceLights,
        o: wp.vec3,
        d: wp.vec3,
        t_min: float,
        t_max: float,
        pdf_bsdf: float,
        n_prev: wp.vec3,
        camera: int,
        diffuse_share: wp.vec3,
        group: int,
    ):
        """Radiance of every analytic area light that unit ray ``(o, d)`` passes through in ``(t_min, t_max)``;
        ``n_prev`` is the shading normal at ``o`` (zero for camera rays); ``camera`` is 1 for camera rays, else
        ``diffuse_share`` is the share of the ray's weight its diffuse lobe gave, per channel (see
        :func:`scattered_by`), and ``group`` the link group of the surface at ``o`` (see :func:`reaches`). A light at
        ``t`` counts where geometry at ``t_max`` would not block a shadow ray to it, which stops :func:`rounding_margin`
        short (:func:`shadow_length`): ``t - margin < t_max``, for camera rays too, so that a light flush with a
        ceiling, which next-event estimation reaches, is met by BSDF-sampled rays (their MIS share of it) and seen by
        cameras. A camera ray of an orthographic camera whose near plane lies behind it has ``t_min < 0``: the lights
        are intersected from its start, ``o + t_min d``, as :func:`intersect_light` finds only hits ahead of its origin
        (a light between the near plane and the camera was not seen, where geometry there was); for ``t_min >= 0`` the
        origin is ``o`` itself."""
        total = wp.vec3(0.0)
        behind = wp.min(t_min, 0.0)
        start = o + behind * d
        for j in range(lights.num_segment_lights):  # the area lights alone (light_table.rays_meet)
            k = lights.segment_lights[j]
            if reaches(lights, k, camera, group):
                t, cos_l = intersect_light(lights, k, start, d)
                t = t + behind
                if t > t_min and t - rounding_margin(start, o + t * d, t - behind) < t_max:
                    pdf_l = lights.pmf[k] * area_light_pdf(lights, k, o, n_prev, d, t, cos_l)
                    L = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -d))  # leaving the light towards o
                    L = wp.cw_mul(L, light_texture(lights, k, o + t * d))
                    L = wp.cw_mul(L, scattered_by(lights, k, camera, diffuse_share))
                    total += L * mis_weight(lights, k, pdf_bsdf, pdf_l)
        return total

    return lights_on_segment


lights_on_segment = lights_on_segment_for(ALL_FEATURES)


@wp.func
def environment(
    lights: DeviceLights,
    d: wp.vec3,
    pdf_bsdf: float,
    n_prev: wp.vec3,
    camera: int,
    diffuse_share: wp.vec3,
    group: int,
):
    """Radiance arriving along an escaped ray ``d``: the dome and the discs of soft distant lights (``camera``,
    ``diffuse_share``, ``group``: see :func:`lights_on_segment`)."""
    total = wp.vec3(0.0)
    for j in range(lights.num_sky_lights):  # the dome and the soft distant lights alone (light_table.rays_meet)
        k = lights.sky_lights[j]
        kind = lights.kinds[k]
        if not reaches(lights, k, camera, group):
            continue
        if kind == LIGHT_DOME:
            pdf_l = lights.pmf[k] * dome_pdf(lights, d, n_prev)
            L = wp.cw_mul(dome_radiance(lights, d), scattered_by(lights, k, camera, diffuse_share))
            total += L * mis_weight(lights, k, pdf_bsdf, pdf_l)
        elif kind == LIGHT_DISTANT:
            if distant_in_cone(lights, k, d):
                pdf_l = lights.pmf[k] / lights.params[k][1]
                L = wp.cw_mul(lights.radiance[k], scattered_by(lights, k, camera, diffuse_share))
                total += L * mis_weight(lights, k, pdf_bsdf, pdf_l)
    return total


@wp.func
def surface_emission(
    lights: DeviceLights,
    mats: DeviceMaterials,
    e: int,
    m: int,
    st: wp.vec2,
    emission: wp.vec3,
    camera: int,
    diffuse_share: wp.vec3,
    group: int,
):
    """Radiance a ray picks up from the emitting side of the triangle it hit (material ``m`` at ``st``, whose
    ``emissiveColor`` there is ``emission``; ``e``: its light, -1 for none: ``DeviceSurfaces.emitters``). Emissive
    materials show ``emission``. A mesh light's triangle shows camera rays its material's glow (its light for
    ``noMaterialResponse``, whose surface has no material), and other rays its light (:func:`triangle_emission`, as
    light sampling draws it) times its multipliers, where it lights the surface that scattered them (``camera``,
    ``diffuse_share``, ``group``: see :func:`lights_on_segment`)."""
    if e < 0 or lights.params[e][2] == 0.0:  # no mesh light
        return emission
    if camera == 1:
        return wp.where(lights.params[e][1] > 0.0, lights.radiance[e], emission)
    if not reaches(lights, e, camera, group):
        return wp.vec3(0.0)
    return wp.cw_mul(triangle_emission(lights, mats, e, m, st), scattered_by(lights, e, camera, diffuse_share))
