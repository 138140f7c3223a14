"""Hits that a ray must pass: back faces of single-sided meshes (camera rays) and holes of cut-out materials (camera,
bounce and shadow rays), passed by tracing the ray again from just past them through the accelerator (see the
conventions in :mod:`wrt.shade`).

These kernels live apart from :mod:`wrt.shade` because Warp compiles a whole module the first time any of its kernels
is launched, and a scene whose meshes are all double-sided and have no cut-outs (the default scene) launches none of
them: a first render there does not compile them.
"""

import warnings

import warp as wp

from .errors import user_stacklevel
from .floats import largest_magnitude, unit_scales
from .geometry import face_normal
from .light_links import DeviceLinks, casts_shadow, link_group, upload_links
from .materials import DeviceMaterials, cut_out
from .scene import DeviceScene
from .shade import MAX_CULL_PASSES, MAX_SHADOW_HOLE_PASSES, PARTNER_TOLERANCE, DeviceSurfaces, shape_frame
from .transforms import transform_vector

wp.set_module_options({"fuse_fp": False, "enable_backward": False})  # the rounding of wrt.shade (see there)

CULL_EPSILON = wp.constant(1.0e-6)  # relative step past a culled back face before re-tracing
# The step past a culled face at t = 0 (or so near 0 that t * CULL_EPSILON is no step): float32's least normal
# number times 2, so the new t_min stays normal when unit_ray scales it by 1/2 (Accelerator docstring). An absolute
# step of 1e-30 passed over whole scenes 1e-30 across, and their camera rays saw nothing behind a culled face.
CULL_LEAST_STEP = wp.constant(2.0**-125)
# The t_min of a camera or bounce ray that needs no re-trace: an empty range (traced as a miss without visiting a
# node) that no re-trace has (those start just past a finite hit). Marked by t_max > 0 before, a clipping range wholly
# behind an orthographic camera's plane (far <= 0) never took its re-traced hit, and showed the culled back face.
DECIDED_T_MIN = wp.constant(float("inf"))


@wp.func
def t_past(t: float):
    """The ``t_min`` that traces a ray again from just past its hit at ``t``. The step is relative to ``t`` alone
    (the watertight test measures hits from the ray origin, so t's rounding is relative): an absolute floor of 1e-9
    skipped whatever lay just behind the culled face in a scene a few micrometres across, one of 1e-30 in a scene
    1e-30 across. Relative to ``|t|``: behind an orthographic camera of negative near (``t < 0``), ``t * 1e-6`` is
    negative, the step was 2^-125, no step at that ``t``, and every pass found the culled face again."""
    return t + wp.max(wp.abs(t) * CULL_EPSILON, CULL_LEAST_STEP)


@wp.func
def in_hole(surf: DeviceSurfaces, mats: DeviceMaterials, prim: int, u: float, v: float):
    """True when the hit ``(u, v)`` on ``prim`` (a geometry id, as hit buffers hold it: instances and analytic shapes
    included) lies in a hole of a cut-out material (``opacity < opacityThreshold``)."""
    st = (1.0 - u - v) * surf.uvs[prim, 0] + u * surf.uvs[prim, 1] + v * surf.uvs[prim, 2]
    return cut_out(mats, surf.materials[prim], st)


@wp.func
def back_face(scene: DeviceScene, surf: DeviceSurfaces, prim: int, instance: int, o: wp.vec3, d: wp.vec3, t: float):
    """True when the ray ``(o, d)`` meets ``prim`` (hit at ``t`` in ``instance``) on the back of a single-sided
    triangle or shape."""
    if surf.double_sided[prim] == 1:
        return False
    if prim >= scene.num_prims:
        p, n, reach, err = shape_frame(scene, prim, instance, o, d, t)
        return wp.dot(n, d) > 0.0
    a = scene.points[scene.indices[prim, 0]]
    b = scene.points[scene.indices[prim, 1]]
    c = scene.points[scene.indices[prim, 2]]
    if instance >= 0:
        m = scene.world_to_local[instance]
        local = transform_vector(m, d)  # n_world . d = n_local . (A d)
        if not wp.isfinite(local):
            # A's entries reach float32's range for an instance scaled by 3e-39, and a sheared one's A d passes it:
            # inf, its sign decided by one term, and a back face was drawn. Only the sign matters: with d' = d down
            # / 16 (|d'| < 2 sqrt(3) / 16), each row's |r . d'| <= sqrt(3) max|A| |d'| < 0.4 max|A| is finite.
            down, _ = unit_scales(d)
            local = transform_vector(m, d * (down * 0.0625))
        down, _ = unit_scales(local)  # the dot's products stay within float32 (face_normal's are below 8)
        d = local * down
    return wp.dot(face_normal(a, b, c), d) > 0.0


@wp.func
def hidden_hit(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    prim: int,
    instance: int,
    u: float,
    v: float,
    o: wp.vec3,
    d: wp.vec3,
    t: float,
):
    """True when a camera ray's hit ``(t, u, v, prim, instance)`` is not seen: a hole of a cut-out material, or the
    back of a single-sided triangle."""
    if in_hole(surf, mats, prim, u, v):
        return True
    return back_face(scene, surf, prim, instance, o, d, t)


@wp.func
def corner_weight(scene: DeviceScene, prim: int, w: wp.vec3, p: wp.vec3):
    """The barycentric weight in ``w`` (of ``prim``'s corners 0, 1, 2) of ``prim``'s corner at position ``p``."""
    if scene.points[scene.indices[prim, 1]] == p:
        return w[1]
    if scene.points[scene.indices[prim, 2]] == p:
        return w[2]
    return w[0]


@wp.func
def twin_uv(scene: DeviceScene, prim: int, twin: int, u: float, v: float):
    """The hit ``(u, v)`` on ``prim`` as barycentrics on its ``twin`` (the same corner positions in another order)."""
    w = wp.vec3(1.0 - u - v, u, v)
    return wp.vec2(corner_weight(scene, prim, w, scene.points[scene.indices[twin, 1]]),
                   corner_weight(scene, prim, w, scene.points[scene.indices[twin, 2]]))


@wp.func
def has_corner(scene: DeviceScene, prim: int, p: wp.vec3):
    """True when one of ``prim``'s corners is at ``p``."""
    return (scene.points[scene.indices[prim, 0]] == p or scene.points[scene.indices[prim, 1]] == p
            or scene.points[scene.indices[prim, 2]] == p)


@wp.func
def partner_weights(scene: DeviceScene, prim: int, partner: int, u: float, v: float):
    """Barycentric weights on ``partner`` (of its corners 0, 1, 2) of the hit ``(u, v)`` on ``prim``: exact for a
    twin (the same corner positions, :func:`twin_uv`), else of the hit point (object space, from its barycentrics)
    projected onto the partner's plane; all -1 when the point lies off that plane by more than
    :data:`PARTNER_TOLERANCE` of the partner's size (or the partner is degenerate)."""
    a = scene.points[scene.indices[partner, 0]]
    b = scene.points[scene.indices[partner, 1]]
    c = scene.points[scene.indices[partner, 2]]
    if has_corner(scene, prim, a) and has_corner(scene, prim, b) and has_corner(scene, prim, c):
        uv = twin_uv(scene, prim, partner, u, v)
        return wp.vec3(1.0 - uv[0] - uv[1], uv[0], uv[1])
    p = ((1.0 - u - v) * scene.points[scene.indices[prim, 0]] + u * scene.points[scene.indices[prim, 1]]
         + v * scene.points[scene.indices[prim, 2]])
    # Scaled by the power of two that brings the partner's longest edge component into [1, 2): the weights and the
    # test are ratios of products of up to six lengths, which over- or underflowed float32 in a scene 1e8 (or 1e-12)
    # across, where no partner was found and the camera saw through a card of two reversed single-sided faces.
    down, _ = unit_scales(wp.vec3(largest_magnitude(b - a), largest_magnitude(c - a), largest_magnitude(c - b)))
    e1, e2, q = (b - a) * down, (c - a) * down, (p - a) * down
    n = wp.cross(e1, e2)
    nn = wp.dot(n, n)
    size2 = wp.max(wp.max(wp.dot(e1, e1), wp.dot(e2, e2)), wp.length_sq((c - b) * down))
    off = wp.dot(q, n)
    if nn <= 0.0 or off * off > PARTNER_TOLERANCE * PARTNER_TOLERANCE * size2 * nn:
        return wp.vec3(-1.0)
    # p - a = s e1 + r e2 in the plane: cross(q, e2) = s n and cross(e1, q) = r n (q's normal part drops out).
    s = wp.dot(wp.cross(q, e2), n) / nn
    r = wp.dot(wp.cross(e1, q), n) / nn
    return wp.vec3(1.0 - s - r, s, r)


@wp.func
def locate_partner(scene: DeviceScene, surf: DeviceSurfaces, prim: int, u: float, v: float):
    """The partner of ``prim`` (:mod:`wrt.twins`) that contains the hit ``(u, v)`` on it: the largest smallest
    barycentric weight, at least ``-PARTNER_TOLERANCE`` (of equals the first: the smallest geometry id); -1 when
    none does."""
    best = int(-1)
    best_weight = float(-PARTNER_TOLERANCE)
    for k in range(surf.partner_offsets[prim], surf.partner_offsets[prim + 1]):
        r = surf.partner_ranges[k]
        for partner in range(r[0], r[0] + r[1]):
            w = partner_weights(scene, prim, partner, u, v)
            weight = wp.min(wp.min(w[0], w[1]), w[2])
            if weight > best_weight:
                best = partner
                best_weight = weight
    return best


@wp.func
def partner_uv(scene: DeviceScene, prim: int, partner: int, u: float, v: float):
    """The hit ``(u, v)`` on ``prim`` as ``(u, v)`` on ``partner`` (:func:`partner_weights`), clamped into it (a
    point on a shared edge may round a hair outside)."""
    w = partner_weights(scene, prim, partner, u, v)
    w = wp.vec3(wp.max(w[0], 0.0), wp.max(w[1], 0.0), wp.max(w[2], 0.0))
    total = w[0] + w[1] + w[2]
    return wp.vec2(w[1] / total, w[2] / total)


@wp.func
def hidden(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    back_faces: int,
    prim: int,
    instance: int,
    u: float,
    v: float,
    o: wp.vec3,
    d: wp.vec3,
    t: float,
):
    """:func:`hidden_hit` with ``back_faces = 1`` (camera rays), else (bounce rays, which see both sides) a hole."""
    if back_faces == 1:
        return hidden_hit(scene, surf, mats, prim, instance, u, v, o, d, t)
    return in_hole(surf, mats, prim, u, v)


@wp.kernel
def cull_hidden_hits_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    back_faces: int,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_maxs: wp.array[float],
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    hit_instance: wp.array[wp.int32],
    # outputs
    retry_t_mins: wp.array[float],
    retry_t_maxs: wp.array[float],
    retries: wp.array[wp.int32],
):
    """Marks rays whose closest hit is not seen (:func:`hidden`): they are re-traced from just past it to their
    ``t_max``; every other ray gets the empty range from :data:`DECIDED_T_MIN` to 0. A hit with a coincident partner
    (:mod:`wrt.twins`) that contains the hit point and is seen there becomes a hit on that partner instead (``hit_u,
    hit_v, hit_prim`` are rewritten in place) when the hit is hidden (the re-trace from past ``t`` would skip the
    partner too) or, for bounce rays, on the hit's back: they see a two-sided card's other face there, as camera rays
    do, not the back of the face the tie rule reported."""
    i = wp.tid()
    retry_t_mins[i] = DECIDED_T_MIN
    retry_t_maxs[i] = 0.0
    prim = hit_prim[i]
    if prim < 0:
        return
    instance, u, v, o, d, t = hit_instance[i], hit_u[i], hit_v[i], origins[i], directions[i], hit_t[i]
    partners = int(0)
    if surf.num_partners > 0 and prim < scene.num_prims:
        partners = surf.partner_offsets[prim + 1] - surf.partner_offsets[prim]
    hide = hidden(scene, surf, mats, back_faces, prim, instance, u, v, o, d, t)
    # Kept as it is unless hidden or, for a bounce ray, on the back of a face whose partner may show its front there.
    if not hide and (partners == 0 or back_faces == 1 or not back_face(scene, surf, prim, instance, o, d, t)):
        return
    if partners > 0:
        partner = locate_partner(scene, surf, prim, u, v)
        if partner >= 0:
            uv = partner_uv(scene, prim, partner, u, v)
            if not hidden(scene, surf, mats, back_faces, partner, instance, uv[0], uv[1], o, d, t):
                hit_u[i] = uv[0]
                hit_v[i] = uv[1]
                hit_prim[i] = partner
                return
    if not hide:
        return  # a bounce ray on the back of a face whose partner is a hole there (or none there): it sees that back
    retry_t_mins[i] = t_past(t)
    retry_t_maxs[i] = t_maxs[i]
    wp.atomic_add(retries, 0, 1)


@wp.kernel
def merge_hits_kernel(
    retry_t_mins: wp.array[float],
    t2: wp.array[float],
    u2: wp.array[float],
    v2: wp.array[float],
    prim2: wp.array[wp.int32],
    cost2: wp.array[wp.vec2i],
    instance2: wp.array[wp.int32],
    # outputs
    t: wp.array[float],
    u: wp.array[float],
    v: wp.array[float],
    prim: wp.array[wp.int32],
    cost: wp.array[wp.vec2i],
    instance: wp.array[wp.int32],
):
    """Takes the re-traced hit of every culled ray (``retry_t_mins`` other than :data:`DECIDED_T_MIN`, a miss
    where its range past the culled hit is empty) and adds its traversal cost."""
    i = wp.tid()
    if retry_t_mins[i] != DECIDED_T_MIN:
        t[i] = t2[i]
        u[i] = u2[i]
        v[i] = v2[i]
        prim[i] = prim2[i]
        cost[i] = cost[i] + cost2[i]
        instance[i] = instance2[i]


def intersect_visible(
    accel, surfaces: DeviceSurfaces, mats: DeviceMaterials, scene: DeviceScene, rays, hits, scratch, passes=None,
    camera_rays=True,
) -> None:
    """``accel.intersect`` that skips holes of cut-out materials and, for camera rays, back faces of single-sided
    meshes (see the module docstring).

    Args:
        accel: the :class:`wrt.trace.Accelerator`.
        surfaces: per-triangle shading data (``double_sided``, materials, texture coordinates).
        mats: the materials (for cut-outs).
        scene: the device scene.
        rays: ``[origins, directions, t_mins, t_maxs]`` device arrays.
        hits: the :class:`wrt.trace.HitBuffer` to fill.
        scratch: a :class:`CullScratch` of the same size.
        passes: run up to this many cull passes without reading anything back to the host (for CUDA graph
            capture: :func:`repeat_passes`); ``None``: up to :data:`MAX_CULL_PASSES`, stopping once no ray needs
            another.
        camera_rays: also cull back faces, and add the traversal costs to ``hits.cost`` (the cost AOV); ``False``
            for bounce rays, which see both sides of every surface (but take a back face's coincident partner) and
            pass holes only.
    """
    origins, directions, _, t_maxs = rays
    accel.intersect(*rays, hits, costs=camera_rays)
    # Bounce rays need the pass for holes, and for coincident partners (cull_hidden_hits_kernel).
    nothing_hidden = scratch.nothing_to_cull if camera_rays else scratch.no_holes and surfaces.num_partners == 0
    if nothing_hidden:
        return
    n = len(origins)

    def cull():  # marks the rays whose hit is hidden for a re-trace from past it; scratch.retries counts them
        scratch.retries.zero_()
        wp.launch(
            cull_hidden_hits_kernel,
            n,
            inputs=[scene, surfaces, mats, int(camera_rays), origins, directions, t_maxs, hits.t, hits.u, hits.v,
                    hits.prim, hits.instance],
            outputs=[scratch.t_mins, scratch.t_maxs, scratch.retries],
            device=scratch.device,
        )

    def retrace_and_cull():
        accel.intersect(origins, directions, scratch.t_mins, scratch.t_maxs, scratch.hits, costs=camera_rays)
        h2 = scratch.hits
        wp.launch(
            merge_hits_kernel,
            n,
            inputs=[scratch.t_mins, h2.t, h2.u, h2.v, h2.prim, h2.cost, h2.instance],
            outputs=[hits.t, hits.u, hits.v, hits.prim, hits.cost, hits.instance],
            device=scratch.device,
        )
        cull()

    cull()
    repeat_passes(retrace_and_cull, scratch, MAX_CULL_PASSES if passes is None else passes, passes is not None)


# Shadow rays to an emissive triangle end a few rounding steps short of the point sampled on it
# (wrt.integrators.emitters.shadow_length), where rounding can still put the triangle itself: the any-hit query, which
# cannot tell what it hit, stops this fraction of their length shorter, and the rest of the ray is traced for its
# closest hit, which blocks it unless it is the sampled triangle itself. Ended 1e-4 short in all, a shadow ray lit a
# floor 1000 away from a wall through it, from a glowing quad 0.05 behind the wall.
EMITTER_ANY_HIT_SHORTEN = wp.constant(1.0e-4)
# ``first_emitter`` of shadow rays that go to no light (ambient occlusion): no index reaches it.
NO_EMITTER = 2**31 - 1


@wp.func
def to_emitter(first_emitter: int, k: int):
    """Whether a shadow ray of light ``k`` goes to an emissive triangle (entries from ``first_emitter`` on:
    ``DeviceLights.num_analytic``)."""
    return k >= first_emitter


@wp.func
def any_hit_end(first_emitter: int, k: int, t_max: float):
    """Where the any-hit query of a shadow ray of light ``k`` ending at ``t_max`` stops: :data:`EMITTER_ANY_HIT_SHORTEN`
    of its length short for an emissive triangle (its own triangle lies within rounding of ``t_max``), else at
    ``t_max``."""
    if to_emitter(first_emitter, k):
        return t_max * (1.0 - EMITTER_ANY_HIT_SHORTEN)
    return t_max


@wp.func
def tail_start(first_emitter: int, k: int, t_min: float, t_max: float):
    """Where the closest-hit query of the end of a shadow ray to an emissive triangle (light ``k``) starts: at its
    any-hit end (:func:`any_hit_end`), not before ``t_min``. Where ``t_min`` lies past the any-hit end, an any-hit
    query ended here (:func:`any_hit_t_max`) is as empty as one ended there: every query takes hits in
    ``[t_min, t_max)``."""
    return wp.max(t_min, any_hit_end(first_emitter, k, t_max))


@wp.func
def any_hit_t_max(first_emitter: int, k: int, t_min: float, t_max: float):
    """The ``t_max`` of the any-hit query of a shadow ray of light ``k`` over ``[t_min, t_max)``
    (:func:`any_hit_end`), which is also where the closest-hit query of the rest of a ray to an emissive triangle
    starts (:func:`tail_start`): ``[t_min, end)`` and ``[end, t_max)``. Written by the kernels that aim shadow rays
    (``wrt.integrators.path.aim_shadow_ray``), else by :func:`end_any_hits_kernel`."""
    end = any_hit_end(first_emitter, k, t_max)
    if t_max > 0.0 and to_emitter(first_emitter, k):
        end = wp.max(t_min, end)  # tail_start's, from the end already found
    return end


@wp.kernel
def end_any_hits_kernel(
    first_emitter: int,
    shadow_lights: wp.array[wp.int32],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    any_hit_t_maxs: wp.array[float],
):
    """The ``t_max`` of each shadow ray's any-hit query (:func:`any_hit_t_max`)."""
    i = wp.tid()
    any_hit_t_maxs[i] = any_hit_t_max(first_emitter, shadow_lights[i], t_mins[i], t_maxs[i])


@wp.kernel
def start_shadow_holes_kernel(
    recheck_blocked: int,
    first_emitter: int,
    shadow_lights: wp.array[wp.int32],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    retry_t_mins: wp.array[float],
    retry_t_maxs: wp.array[float],
    blocked: wp.array[wp.int32],
    retries: wp.array[wp.int32],
):
    """Blocked shadow rays keep their range, to look for their closest hit (it may be a hole), where
    ``recheck_blocked`` is 1 (holes or shadow links: else the any-hit query decided them); unblocked rays to an
    emissive triangle take the end of their range that their any-hit query left out (:func:`any_hit_end`), blocked
    until their closest hit there decides them. Both are counted in ``retries``; the others get an empty range
    (``retry_t_maxs = 0``: decided). Unlike camera rays (whose ``t_max`` is a clipping range's far, <= 0 for one
    wholly behind an orthographic camera: :data:`DECIDED_T_MIN`), 0 never marks a live ray: every query takes hits
    in ``[t_min, t_max)`` and shadow rays start at ``t_min = 0``, so a retried one has ``t_max > 0``, and its passes
    move only ``t_min``."""
    i = wp.tid()
    retry_t_mins[i] = 0.0
    retry_t_maxs[i] = 0.0
    if blocked[i] == 1:
        if recheck_blocked == 1:
            retry_t_mins[i] = t_mins[i]
            retry_t_maxs[i] = t_maxs[i]
            wp.atomic_add(retries, 0, 1)
        return
    k = shadow_lights[i]
    if t_maxs[i] > 0.0 and to_emitter(first_emitter, k):
        start = tail_start(first_emitter, k, t_mins[i], t_maxs[i])
        if start < t_maxs[i]:
            retry_t_mins[i] = start
            retry_t_maxs[i] = t_maxs[i]
            blocked[i] = 1
            wp.atomic_add(retries, 0, 1)


@wp.func
def reaches_its_emitter(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    emitter_prims: wp.array[wp.int32],
    emitter_instances: wp.array[wp.int32],
    first_emitter: int,
    k: int,
    prim: int,
    instance: int,
    u: float,
    v: float,
):
    """Whether a shadow ray of light ``k`` that hit ``(u, v)`` on ``prim`` in ``instance`` met the emissive triangle
    it was aimed at (``DeviceLights.prims`` and ``instances`` of entry ``k``): that triangle, or a coincident partner
    (:mod:`wrt.twins`) whose partner there is that triangle, as a bounce ray takes it (``cull_hidden_hits_kernel``). A
    lamp of two single-sided faces back to back otherwise shadowed up to 8% of its light where a floor sees it at a
    grazing angle: its other face, hit first by rounding."""
    if not to_emitter(first_emitter, k) or emitter_instances[k] != instance:
        return False
    if emitter_prims[k] == prim:
        return True
    if surf.num_partners == 0 or prim >= scene.num_prims:
        return False
    if surf.partner_offsets[prim + 1] == surf.partner_offsets[prim]:
        return False
    return locate_partner(scene, surf, prim, u, v) == emitter_prims[k]


@wp.kernel
def pass_shadow_holes_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    links: DeviceLinks,
    first_emitter: int,
    emitter_prims: wp.array[wp.int32],
    emitter_instances: wp.array[wp.int32],
    shadow_lights: wp.array[wp.int32],
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    hit_instance: wp.array[wp.int32],
    # outputs
    retry_t_mins: wp.array[float],
    retry_t_maxs: wp.array[float],
    blocked: wp.array[wp.int32],
    retries: wp.array[wp.int32],
):
    """Decides each shadow ray still undecided (``retry_t_maxs > 0``) by its closest hit in its range: none, or the
    emissive triangle it was aimed at (:func:`reaches_its_emitter`) -> unblocked; a hole (:func:`in_hole`), or geometry
    that casts no shadow of the ray's light (``shadow_lights``, ``collection:shadowLink``) -> undecided, looked at
    again from just past it (and blocked until then); anything else -> blocked."""
    i = wp.tid()
    if retry_t_maxs[i] <= 0.0:
        return
    prim = hit_prim[i]
    passed = False
    reached = prim < 0
    if prim >= 0:
        reached = reaches_its_emitter(scene, surf, emitter_prims, emitter_instances, first_emitter, shadow_lights[i],
                                      prim, hit_instance[i], hit_u[i], hit_v[i])
    if prim >= 0 and not reached:
        passed = in_hole(surf, mats, prim, hit_u[i], hit_v[i])
        if links.shadow_linked == 1 and not passed:
            passed = not casts_shadow(links, link_group(links, prim, hit_instance[i]), shadow_lights[i])
    if passed:
        retry_t_mins[i] = t_past(hit_t[i])
        wp.atomic_add(retries, 0, 1)
        return
    if reached:
        blocked[i] = 0
    retry_t_mins[i] = 0.0
    retry_t_maxs[i] = 0.0


@wp.kernel
def reach_emitters_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    first_emitter: int,
    emitter_prims: wp.array[wp.int32],
    emitter_instances: wp.array[wp.int32],
    shadow_lights: wp.array[wp.int32],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    hit_instance: wp.array[wp.int32],
    # outputs
    blocked: wp.array[wp.int32],
):
    """Blocks each shadow ray that its any-hit query left unblocked and whose closest hit in the rest of its range
    (``hit_*``: an empty range, so none, but for rays to an emissive triangle) is not the emissive triangle it was
    aimed at (:func:`reaches_its_emitter`): ``pass_shadow_holes_kernel``'s one pass where no hole or shadow link can
    be passed."""
    i = wp.tid()
    prim = hit_prim[i]
    if blocked[i] == 0 and prim >= 0:
        if not reaches_its_emitter(scene, surf, emitter_prims, emitter_instances, first_emitter, shadow_lights[i],
                                   prim, hit_instance[i], hit_u[i], hit_v[i]):
            blocked[i] = 1


def occluded_through_holes(
    accel, surfaces: DeviceSurfaces, mats: DeviceMaterials, rays, blocked, scratch, passes=None, lights=None,
    shadow_lights=None, scene=None, any_hit_t_maxs=None,
) -> None:
    """``accel.occluded`` for shadow rays, which pass through the holes of cut-out materials (see the module
    docstring), and through geometry that casts no shadow of their light (shadow linking): rays the any-hit query
    reports blocked are traced for their closest hit, again from just past it while it is a hole or such geometry.
    A ray still in a hole after the last pass stays blocked. A ray to an emissive triangle is not blocked by that
    triangle itself: its any-hit query stops short of it (:func:`any_hit_end`) and the rest of the ray is decided by
    its closest hit, which reaches the light where it is the sampled triangle (a bounce ray that hits it sees its
    emission: the same rule of visibility for path's MIS).

    Args:
        accel: the :class:`wrt.trace.Accelerator`.
        surfaces: per-triangle shading data (materials, texture coordinates).
        mats: the materials (for cut-outs).
        rays: ``[origins, directions, t_mins, t_maxs]`` device arrays.
        blocked: ``(N,)`` int32 device array: 1 where ray ``i`` is blocked, else 0.
        scratch: a :class:`CullScratch` of the same size.
        passes: run up to this many closest-hit passes without reading anything back to the host (for CUDA
            graph capture: :func:`repeat_passes`); ``None``: up to :data:`MAX_SHADOW_HOLE_PASSES`, stopping once no
            ray needs another.
        lights: the :class:`wrt.light_sampling.DeviceLights` the rays go to, or None (rays to no light, as ambient
            occlusion's: every geometry casts every shadow).
        shadow_lights: ``(N,)`` int32 device array: the light each ray is the shadow ray of (-1: none), with
            ``lights``.
        scene: the :class:`wrt.scene.DeviceScene`, with ``lights`` that hold emissive triangles (for their
            coincident partners).
        any_hit_t_maxs: ``(N,)`` float device array of each ray's :func:`any_hit_t_max` (``first_emitter``:
            ``lights.num_analytic``), written by the kernel that aimed the rays; it may be ``scratch.t_maxs``.
            None: computed here, by one more launch.
    """
    origins, directions, t_mins, t_maxs = rays
    device = scratch.device
    links, first_emitter = _no_links(device), NO_EMITTER
    emitter_prims = emitter_instances = blocked  # not read without emitters
    if lights is None:
        shadow_lights = blocked  # not read then
    else:
        links = lights.links if lights.links.shadow_linked == 1 else links
        if lights.count > lights.num_analytic:
            if scene is None:
                raise ValueError("occluded_through_holes: shadow rays to emissive triangles need the DeviceScene "
                                 "(scene=) to tell the triangle they are aimed at from its coincident partners")
            first_emitter, emitter_prims, emitter_instances = lights.num_analytic, lights.prims, lights.instances
    recheck_blocked = not scratch.no_holes or links.shadow_linked == 1
    n = len(origins)
    if first_emitter == NO_EMITTER:
        accel.occluded(*rays, blocked)
        if not recheck_blocked:
            return
    else:  # the any-hit ends are read until start_shadow_holes_kernel writes the ranges to retrace to scratch
        if any_hit_t_maxs is None:
            any_hit_t_maxs = scratch.t_maxs
            wp.launch(end_any_hits_kernel, n, inputs=[first_emitter, shadow_lights, t_mins, t_maxs],
                      outputs=[any_hit_t_maxs], device=device)
        accel.occluded(origins, directions, t_mins, any_hit_t_maxs, blocked)
        if not recheck_blocked:
            # Nothing to pass but the ends of rays to emissive triangles: the closest hit of every ray's rest,
            # [any-hit end, t_max) (empty for the others), decides them at once, with no retry counted or read back.
            accel.intersect(origins, directions, any_hit_t_maxs, t_maxs, scratch.hits, costs=False)
            h = scratch.hits
            wp.launch(reach_emitters_kernel, n,
                      inputs=[scene, surfaces, first_emitter, emitter_prims, emitter_instances, shadow_lights,
                              h.u, h.v, h.prim, h.instance],
                      outputs=[blocked], device=device)
            return
    scene = DeviceScene() if scene is None else scene  # not read without emitters
    scratch.retries.zero_()
    wp.launch(start_shadow_holes_kernel, n, inputs=[int(recheck_blocked), first_emitter, shadow_lights, t_mins, t_maxs],
              outputs=[scratch.t_mins, scratch.t_maxs, blocked, scratch.retries], device=device)
    h = scratch.hits

    def one_pass():
        scratch.retries.zero_()
        accel.intersect(origins, directions, scratch.t_mins, scratch.t_maxs, h, costs=False)
        wp.launch(
            pass_shadow_holes_kernel,
            n,
            inputs=[scene, surfaces, mats, links, first_emitter, emitter_prims, emitter_instances, shadow_lights,
                    h.t, h.u, h.v, h.prim, h.instance],
            outputs=[scratch.t_mins, scratch.t_maxs, blocked, scratch.retries],
            device=device,
        )

    limit = MAX_SHADOW_HOLE_PASSES if passes is None else passes
    if repeat_passes(one_pass, scratch, limit, passes is not None):
        # One message for every call (warned once): a dense canopy, or a forest left out of a sun's shadowLink, would
        # otherwise be shadowed without a word.
        warnings.warn(f"some shadow rays still met a cut-out hole, or geometry outside their light's shadowLink, "
                      f"after {limit} passes; they count as blocked, so what lies behind is shadowed "
                      "(wrt.shade.MAX_SHADOW_HOLE_PASSES)", stacklevel=user_stacklevel())


_NO_LINKS = {}  # device -> DeviceLinks with linking off


def _no_links(device) -> DeviceLinks:
    key = str(wp.get_device(device))
    if key not in _NO_LINKS:
        _NO_LINKS[key] = upload_links(None, device)
    return _NO_LINKS[key]


@wp.kernel
def count_pass_kernel(limit: int, done: wp.array[wp.int32], retries: wp.array[wp.int32]):
    """Counts a pass of a loop recorded in a CUDA graph; after ``limit`` passes it ends the loop (``retries = 0``)."""
    done[0] = done[0] + 1
    if done[0] >= limit:
        retries[0] = 0


def repeat_passes(one_pass, scratch, limit: int, no_host_reads: bool) -> bool:
    """Runs ``one_pass()`` while ``scratch.retries[0] > 0`` (each pass counts the rays that need another), at most
    ``limit`` times; returns whether some ray still needed another after the last (read back only without
    ``no_host_reads``; else False).

    With ``no_host_reads`` (``Renderer.launch_frame``) nothing is read back: inside a CUDA graph capture that can
    hold conditional nodes (CUDA 12.4+) the passes are a loop of the graph, which stops as the host loop does (a
    20,000-leaf canopy's frame took 21.7 ms running all 31 + 32 passes per bounce in every replay, 15.2 ms with the
    loop); elsewhere exactly ``limit`` passes run."""
    device = wp.get_device(scratch.device)
    if not no_host_reads:
        for _ in range(limit):
            if int(scratch.retries.numpy()[0]) == 0:
                return False
            one_pass()
        return int(scratch.retries.numpy()[0]) > 0
    if device.is_cuda and device.is_capturing and wp.is_conditional_graph_supported():
        scratch.passes_done.zero_()

        def counted_pass():
            one_pass()
            wp.launch(count_pass_kernel, 1, inputs=[limit], outputs=[scratch.passes_done, scratch.retries],
                      device=device)

        wp.capture_while(scratch.retries, counted_pass)
        return False
    for _ in range(limit):
        one_pass()
    return False


class CullScratch:
    """Buffers for :func:`intersect_visible` and :func:`occluded_through_holes` (``n`` rays on ``device``).

    Args:
        n: number of rays.
        device: Warp device.
        nothing_to_cull: every mesh double-sided and no cut-outs: camera rays need no cull pass.
        no_holes: no cut-out material on any geometry: shadow rays are plain any-hit queries.
    """

    BYTES_PER_RAY = 4 + 4 + 28  # t_mins, t_maxs and hits (a trace.HitBuffer: its BYTES_PER_RAY)

    def __init__(self, n: int, device, nothing_to_cull: bool, no_holes: bool):
        from .trace import HitBuffer

        self.device = device
        self.nothing_to_cull = nothing_to_cull
        self.no_holes = no_holes
        self.t_mins = wp.empty(n, dtype=float, device=device)
        self.t_maxs = wp.empty(n, dtype=float, device=device)
        self.retries = wp.zeros(1, dtype=wp.int32, device=device)
        self.passes_done = wp.zeros(1, dtype=wp.int32, device=device)  # of a loop in a CUDA graph (repeat_passes)
        self.hits = HitBuffer(n, device)

    def head(self, m: int) -> "CullScratch":
        """The buffers of the first ``m`` rays (views, not copies; the retry counter is shared)."""
        out = object.__new__(CullScratch)
        out.device, out.nothing_to_cull, out.no_holes = self.device, self.nothing_to_cull, self.no_holes
        out.retries, out.passes_done = self.retries, self.passes_done
        out.t_mins, out.t_maxs, out.hits = self.t_mins[:m], self.t_maxs[:m], self.hits.slice(0, m)
        return out
