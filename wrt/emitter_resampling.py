"""Resampled importance sampling (RIS; Talbot et al. 2005, "Importance Resampling for Global Illumination") of the
emissive triangle that ``whitted`` lights a shading point with.

``whitted`` treats every emissive triangle (glowing materials and mesh lights) as one light and reaches one triangle
per sample. Drawn by power alone, most draws of a large emitter tessellated into many triangles (a glowing ceiling
panel over a room, a glowing wall far to the side) are triangles that look small from the shading point or lie
below its horizon, and the rare ones overhead carry the light: a noisy floor at low ``spp``. Here
:data:`EMITTER_CANDIDATES` triangles are drawn by power and one of them is kept with probability proportional to its
weight ``w = L seen b / pmf``: ``L`` the luminance the triangle emits (``DeviceLights.params[k][3]``, over the
brightest triangle's), ``seen`` :func:`seen_emitter`, its solid angle times the receiver's cosine, ``b`` the
luminance of the BSDF (as the light's diffuse and specular multipliers scale it) from the viewer towards the
triangle's centre plus :func:`bsdf_floor`, ``pmf`` the probability it was drawn with. The target density
``pmf w = L seen b`` is about the triangle's unshadowed light at the point, so a glossy receiver keeps the triangles
its lobe reflects. The kept triangle's selection probability is replaced by ``M pmf_k w_k / sum(w)``, the RIS weight
``sum(w) / M / (pmf_k w_k)``, so the estimate stays unbiased wherever every triangle that can light the point has a
positive ``w`` (only triangles that face away, lie below the horizon or are not light-linked to the surface get 0,
and they send the point nothing; ``L`` is at least 2^-32, and ``b`` keeps its floor where the BSDF turns the centre
away but not all of the triangle). The weight reads no texture (a texel black at a triangle's centre cannot zero
it): ``L`` is the emission its power was computed from. Every factor is free of length (a radiance, a solid angle,
a BSDF, a probability), so the pick is the same at any scene scale; the power over the area, a length to the -2,
left float32's range in scenes scaled far from 1. With the power in the target in place of ``L``, a large dim
triangle counted its area twice (once in its power, once in its solid angle).
"""

import warp as wp

from .bsdf import LobeAlbedos, Surface, eval_bsdf_lobes, surface_albedo
from .geometry import stable_length
from .glowing_tubes import tube_axis, tube_scales
from .light_links import lit_by
from .light_sampling import (
    LIGHT_GLOWING_HULL,
    LIGHT_GLOWING_SPHERE,
    LIGHT_GLOWING_TUBE,
    DeviceLights,
    emitter_triangle,
    hull_frame,
    light_kind,
    lit_bsdf,
    pick_in_group,
)
from .microfacet_albedo import GgxAlbedo
from .sampling import luminance, rand01
from .scene import DeviceScene
from .sphere_cone import cone_of_sphere
from .spherical_triangle import seen_solid_angle, unit_towards
from .subtended_tube import sine_span

# Triangles drawn by power per sample, one kept (1: the plain power pick). Each costs a triangle's corners and solid
# angle, no ray. Under a 4 x 4 ceiling panel of 2 x 16 x 16 triangles 2.5 over a floor (tests/test_emitter_resampling),
# the floor's noise at 4 spp was 0.74 of the plain pick's with 2, 0.52 with 4, 0.37 with 8, 0.29 with 16 and 0.22
# with 32: past 8 each doubling of the work buys less.
EMITTER_CANDIDATES = 8
# The least receiver cosine a glowing sphere is weighed with (seen_sphere).
SPHERE_COSINE_FLOOR = wp.constant(2.0**-20)
# The share of the surface's albedo over pi the target's BSDF factor keeps at least (bsdf_floor).
BSDF_FLOOR = wp.constant(0.25)
ALBEDO_LEAST = wp.constant(2.0**-20)  # of a black surface's floor


@wp.func
def seen_emitter(lights: DeviceLights, scene: DeviceScene, double_sided: wp.array[wp.int32], k: int, p: wp.vec3,
                 n: wp.vec3):
    """An unshadowed estimate of how much emissive triangle ``k`` lights point ``p`` (unit normal ``n``), per unit
    radiance: the solid angle it subtends (:func:`wrt.light_sampling.sample_light`'s, the area form for a triangle
    too small for float32's arctangent) times the largest cosine at ``p`` of its corners and its centre. Zero only
    where it sends ``p`` nothing: ``p`` behind a single-sided triangle, or every corner below ``p``'s horizon (the
    triangle lies in the half-space they span, where the BSDF reflects nothing). Returned with the unit direction
    from ``p`` to its centre. A glowing sphere of the group (wrt.glowing_spheres, after the triangles) is weighed by
    :func:`seen_sphere`, a glowing tube by :func:`seen_tube`."""
    kind = light_kind(lights, k)
    if kind == LIGHT_GLOWING_SPHERE:
        return seen_sphere(lights, k, p, n)
    if kind == LIGHT_GLOWING_TUBE:
        return seen_tube(lights, k, p, n)
    if kind == LIGHT_GLOWING_HULL:
        return seen_hull(lights, k, p, n)
    prim = lights.prims[k]
    a, b, c, cr, down = emitter_triangle(scene, prim, lights.instances[k])
    area2 = stable_length(cr)  # twice the area, times down^2
    if area2 <= 0.0:
        return 0.0, wp.vec3(0.0)
    centre = (a + b + c) / 3.0
    uc = unit_towards(p, centre)
    cos_l = -wp.dot(uc, cr / area2)  # at the light, as sample_light takes it
    if double_sided[prim] == 1:
        cos_l = wp.abs(cos_l)
    cos_r = wp.max(wp.max(wp.dot(n, unit_towards(p, a)), wp.dot(n, unit_towards(p, b))),
                   wp.max(wp.dot(n, unit_towards(p, c)), wp.dot(n, uc)))
    if cos_l <= 0.0 or cos_r <= 0.0:
        return 0.0, uc
    omega = seen_solid_angle(p, a, b, c)
    if omega == 0.0:
        # Area / distance^2 in lengths times down, as sample_light's area pdf takes them (no over- or underflow
        # where it has none).
        dist = wp.length((centre - p) * down)
        if dist > 0.0:
            omega = 0.5 * area2 * cos_l / (dist * dist)
    return omega * cos_r, uc


@wp.func
def seen_sphere(lights: DeviceLights, k: int, p: wp.vec3, n: wp.vec3):
    """:func:`seen_emitter` of glowing sphere ``k``: the solid angle of the cone it subtends at ``p`` times the
    largest cosine at ``p`` over that cone (1 where the normal points into it), kept above 2^-20 so that a sphere
    half below the horizon, which rounding could put wholly below it, keeps a chance; 0 inside the sphere, where
    ``sample_light`` draws nothing. Read as a triangle, a sphere's row took its shape id for a triangle's."""
    row = lights.glowing_spheres[k - lights.first_glowing_sphere]
    return seen_ball(wp.vec3(row[0], row[1], row[2]), row[3], p, n, 0.0)


@wp.func
def seen_tube(lights: DeviceLights, k: int, p: wp.vec3, n: wp.vec3):
    """:func:`seen_emitter` of glowing tube ``k``: about the solid angle it subtends (:func:`tube_solid_angle`), at
    most the cone of a ball around it (radius plus half length), times the largest cosine at ``p`` over that cone (1
    inside the ball, never below :data:`SPHERE_COSINE_FLOOR`), so that every point the tube can light keeps a
    weight. The ball's cone alone weighed a long thin tube as if it filled the ball, a hemisphere's 2 pi anywhere
    inside it: whitted drew the tube over a panel that sent the floor 160 times its light (the floor's noise at 4
    samples 0.97 of its light, now 0.10)."""
    j = k - lights.first_glowing_sphere
    row = lights.glowing_spheres[j]
    axis = lights.glowing_axes[j]
    c = wp.vec3(row[0], row[1], row[2])
    ball, cos_r, towards = ball_cone(c, row[3] + wp.length(wp.vec3(axis[0], axis[1], axis[2])), p, n, 2.0 * wp.pi)
    return wp.min(ball, tube_solid_angle(row, axis, lights.glowing_tapers[j], p)) * cos_r, towards


@wp.func
def seen_hull(lights: DeviceLights, k: int, p: wp.vec3, n: wp.vec3):
    """:func:`seen_emitter` of glowing hull ``k``: the cone of the ball around its ellipsoid (2 pi inside it), at
    most the ellipsoid's shadow over the squared distance to its centre (the shadow of ``M B`` along unit ``v`` is
    ``pi |det M| |A v|``), times the largest cosine at ``p`` over the ball's cone, so that every point the shape can
    light keeps a weight; the ball alone weighed a long thin box as if it filled the ball."""
    row = lights.glowing_spheres[k - lights.first_glowing_sphere]
    ball, cos_r, towards = ball_cone(wp.vec3(row[0], row[1], row[2]), row[3], p, n, 2.0 * wp.pi)
    c, m, a, g, down = hull_frame(lights, k)
    d2 = wp.length_sq(c - p * down)
    if d2 > 0.0:
        ball = wp.min(ball, wp.pi * g * g * g * wp.length(a * towards) / d2)
    return ball * cos_r, towards


@wp.func
def tube_solid_angle(row: wp.vec4, axis: wp.vec4, taper: float, p: wp.vec3):
    """About the solid angle a tube (a glowing tube's row, half axis and taper) subtends at ``p``, at most 2 pi: its
    axis' sine span seen from ``p`` (:func:`wrt.subtended_tube.sine_span`: a line at distance ``D`` of width ``2 r``
    subtends ``2 r span / D``) and its ends' disks' ``pi r^2 / d^2`` (what keeps it above 0 on the axis past an
    end), lengths times the tube's ``down``."""
    down, up = tube_scales(row, axis)
    to_p = (p - wp.vec3(row[0], row[1], row[2])) * down
    w, h = tube_axis(axis, down)
    r = row[3] * down
    top = r * taper
    z = wp.dot(to_p, w)
    across = wp.length(to_p - z * w)
    span, below_top, above_bottom = sine_span(across, -h - z, h - z)
    to_bottom = wp.length_sq(to_p + h * w)
    to_top = wp.length_sq(to_p - h * w)
    omega = float(2.0 * wp.pi)
    if across > 0.0 and to_bottom > 0.0 and to_top > 0.0:
        omega = (r + top) * span / across + wp.pi * (r * r / to_bottom + top * top / to_top)
    return wp.min(omega, 2.0 * wp.pi)


@wp.func
def seen_ball(c: wp.vec3, radius: float, p: wp.vec3, n: wp.vec3, inside: float):
    """:func:`seen_sphere` of the ball of centre ``c`` and ``radius``, ``inside`` where ``p`` lies in it."""
    omega, cos_r, towards = ball_cone(c, radius, p, n, inside)
    return omega * cos_r, towards


@wp.func
def ball_cone(c: wp.vec3, radius: float, p: wp.vec3, n: wp.vec3, inside: float):
    """``(omega, cos_r, towards)``: the solid angle of the cone the ball of centre ``c`` and ``radius`` subtends at
    ``p`` (``inside`` where ``p`` lies in it), the largest cosine at ``p`` over that cone (1 where the normal points
    into it or ``p`` lies inside; at least :data:`SPHERE_COSINE_FLOOR`) and the unit direction to ``c``."""
    cos_max, one_minus = cone_of_sphere(c, radius, p)
    towards = unit_towards(p, c)
    if cos_max > 1.0 or one_minus <= 0.0:
        return inside, 1.0, towards
    cos_a = wp.dot(n, towards)
    cos_r = float(1.0)
    if cos_a < cos_max:  # the cone's nearest direction to n: cos(a - theta_max)
        sin_a = wp.sqrt(wp.max(0.0, 1.0 - cos_a * cos_a))
        sin_max = wp.sqrt(wp.max(0.0, one_minus * (1.0 + cos_max)))
        cos_r = cos_a * cos_max + sin_a * sin_max
    return 2.0 * wp.pi * one_minus, wp.max(cos_r, SPHERE_COSINE_FLOOR), towards


@wp.func
def bsdf_floor(s: Surface, lobes: LobeAlbedos):
    """What the target adds to the BSDF's luminance towards a triangle's centre: :data:`BSDF_FLOOR` of the
    surface's albedo over pi (its lobes' at the viewing angle), at least 2^-20; positive, so that a triangle whose
    centre the BSDF turns away (below the horizon, off a glossy lobe) keeps a weight wherever part of it is lit."""
    albedo = luminance(surface_albedo(s) + lobes.spec + lobes.spec_ms + wp.vec3(lobes.coat)) / wp.pi
    return BSDF_FLOOR * wp.max(albedo, ALBEDO_LEAST)


@wp.func
def resample_emitter(
    lights: DeviceLights,
    scene: DeviceScene,
    double_sided: wp.array[wp.int32],
    first: int,
    count: int,
    candidates: int,
    group: int,
    p: wp.vec3,
    n: wp.vec3,
    receiver: Surface,
    tables: GgxAlbedo,
    lobes: LobeAlbedos,
    ng: wp.vec3,
    wo: wp.vec3,
    state: wp.uint32,
):
    """``(k, probability, state)``: one of triangle lights ``[first, first + count)`` for point ``p`` (normal
    ``n``, link group ``group``; ``receiver`` its surface, seen from ``wo``, geometric normal ``ng``, ``lobes``
    :func:`wrt.bsdf.lobe_albedos` for ``wo``), kept from ``candidates`` drawn by power
    (:func:`wrt.light_sampling.pick_in_group`) in proportion to the module's ``w`` (weighted reservoir sampling, one
    number per candidate), and the probability to divide its sample by, ``candidates pmf_k w_k / sum(w)`` (0: no
    candidate lights ``p``)."""
    kept = first
    kept_pmf = float(0.0)
    kept_weight = float(0.0)
    total = float(0.0)
    floor = bsdf_floor(receiver, lobes)
    for _c in range(candidates):
        u_pick, state = rand01(state)
        u_keep, state = rand01(state)
        k, pmf = pick_in_group(lights, first, count, u_pick)
        w = float(0.0)
        if lit_by(lights.links, group, k):
            seen, towards = seen_emitter(lights, scene, double_sided, k, p, n)
            if seen > 0.0:
                f_d, f_s, _ = eval_bsdf_lobes(receiver, tables, lobes, n, ng, wo, towards)
                w = lights.params[k][3] * seen * (luminance(lit_bsdf(lights, k, f_d, f_s)) + floor) / pmf
        total += w
        if w > 0.0 and u_keep * total < w:
            kept = k
            kept_pmf = pmf
            kept_weight = w
    if kept_weight <= 0.0:
        return first, 0.0, state
    return kept, kept_pmf * float(candidates) * (kept_weight / total), state
