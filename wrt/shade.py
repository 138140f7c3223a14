"""Shading building blocks shared by every integrator: from a hit buffer entry to a shading point, camera paths,
AOVs and sample accumulation; the conventions of back-face culling and cut-out holes, which :mod:`wrt.hidden_hits`
passes by way of the accelerator.

The pipeline is a wavefront: kernels generate rays, an :class:`wrt.trace.Accelerator` fills a hit buffer
(``t, u, v, prim``), and shade kernels read it and write the next rays, so both accelerators serve every
integrator and no shading kernel traverses a BVH itself.

Conventions:

- Surfaces: the geometric normal (from the winding, ``cross(p1 - p0, p2 - p0)``) is turned to face the incoming
  ray; the shading normal (barycentric interpolation of the mesh's normals, or the face normal when it has none)
  is turned to the same side. ``front`` records whether the ray arrived on the winding's front side. A material's
  normal map then perturbs the shading normal (:func:`shading_point`, which the integrators and AOVs read), and
  either normal is turned towards the face normal just enough that the viewer's mirror direction lies above the
  surface (:func:`keep_reflection_above`).
- Back faces of single-sided meshes (``doubleSided = false``) are invisible to camera rays, as in usdview: they
  are culled by re-tracing those rays beyond the hit (:func:`wrt.hidden_hits.intersect_visible`), or, where the
  triangle has a coincident partner seen from there (:mod:`wrt.twins`: a two-sided card's other face), by taking the
  partner that contains the hit point. Bounce
  and shadow rays see both sides, so closed glass objects refract twice and single-sided walls still cast shadows;
  a bounce ray on a back face with such a partner takes the partner too.
  Camera and bounce rays
  skip the holes of cut-out materials (``opacity < opacityThreshold``) the same way, so the AOVs and every
  integrator start from the surface seen through them and a hole uses up no bounce: up to :data:`MAX_CULL_PASSES`
  hidden hits in a row (the passes stop once no ray needs another); a ray still in a hole after them ends its path.
- Shadow (and ambient-occlusion) rays pass holes too (:func:`wrt.hidden_hits.occluded_through_holes`): in a scene
  with cut-outs, the rays the any-hit query reports blocked are traced for their closest hit, again from just past it
  while it is a hole, for up to :data:`MAX_SHADOW_HOLE_PASSES` passes (as many holes as camera and bounce rays pass);
  a ray still in a hole after them stays blocked, with a warning (none inside a recorded CUDA graph). Geometry that a
  light's ``collection:shadowLink`` leaves out is passed the same way by that light's shadow rays
  (:mod:`wrt.light_links`). A shadow ray to an emissive triangle ends a few float32 rounding steps short of the
  point sampled on it, as one to an analytic light does, and is not blocked by that triangle (or its coincident
  partner there) where rounding puts it first: the end of the ray is traced for its closest hit.
  Glass (``opacity < 1`` without a threshold) is not a hole and blocks them: a unidirectional path tracer gets its
  light through refraction.
- The AOVs come from a ray through each pixel's centre and the lens centre. Colour samples jitter both
  (deterministic in ``seed``, pixel and sample index), sample 0 too in an image of several samples, whose AOV ray is
  then traced apart (:func:`camera_sample`): through the pixel centre it was a point sample of weight ``1 / spp``
  (an edge pixel off by that share of its coverage), and through the lens centre it blended a sharp pinhole image
  into the blur. An image of one sample takes sample 0 through the pixel centre (over the lens behind a thin lens).
"""

import warp as wp

from .camera import DeviceCamera, clipped_ray, film_ray
from .floats import FLOAT32_MAX, largest_magnitude
from .geometry import face_normal, stable_length
from .instance_corners import instance_corners, instance_magnitude
from .lights import DEFAULT_DOME_RADIANCE
from .materials import DeviceMaterials, eval_surface, lookup_binding, normal_map
from .primitives import shape_surface
from .sampling import rand01, sample_concentric_disk
from .scene import DeviceScene
from .transforms import (
    abs_vec,
    inverse_transform_magnitude,
    inverse_transform_vector,
    linear_part,
    local_ray_point,
    normal_to_world,
    translation,
)

# Same rounding on every device: no FMA contraction (nvrtc and clang would fuse different operations, so paths
# would diverge between CUDA and CPU); no backward pass (nothing differentiates the renderer; it costs compile time).
wp.set_module_options({"fuse_fp": False, "enable_backward": False})

# CPU compiler flags of the integrators' modules: Warp's default flags (warp.config.cpu_compiler_flags) with LLVM's
# inline threshold at 1000 instead of 9000. At 9000 clang inlined the surface read, the shading point and the light
# draws whole into every kernel and call site that uses them: the whitted module's object code was 437 KB and its
# compile 11.8 s of CPU, half the default scene's first render; at 1000 it is 286 KB and 7.4 s, and the kernels run
# faster (the default room at 320 x 240, 8 spp: whitted's shading 1.9-2.0 -> 1.5 s, path's 7.1-7.5 -> 3.8-4.0 s;
# at LLVM's own 225: 234 KB, 6.5 s, no faster than at 9000). Warp's source holds each function once either way;
# CUDA builds do not read these flags.
# Derived from Warp's flags as they are at import, so that its other flags (and a user's own) are kept.
SHADING_INLINE_THRESHOLD = 1000
SHADING_CPU_FLAGS = " ".join([*(f for f in wp.config.cpu_compiler_flags.split() if "-inline-threshold=" not in f),
                              f"-mllvm=-inline-threshold={SHADING_INLINE_THRESHOLD}"])

BACKGROUND = wp.constant(wp.vec3(*DEFAULT_DOME_RADIANCE))  # what camera rays see on a stage without lights
# How far a culled hit point may lie outside a coincident partner (wrt.twins), off its plane or past an edge, and still
# be taken as on it: relative to the partner's longest edge (float32 rounding of a point on a shared plane or edge).
PARTNER_TOLERANCE = wp.constant(1.0e-4)
# Closest-hit passes of a blocked shadow ray in a scene with cut-outs: it passes up to 31 holes (leaves of a dense
# canopy stack in the tens: 8 left rays through 10 leaf holes blocked); one still in a hole after them stays blocked.
MAX_SHADOW_HOLE_PASSES = 32
# Re-traces of a camera or bounce ray past hidden hits (holes; for camera rays, culled back faces too): it passes as
# many holes in a row as a shadow ray. One still on a back face after them keeps it; one still in a hole ends its path
# (as that shadow ray is blocked). Passes stop once no ray needs another, so the bound costs nothing on other scenes.
MAX_CULL_PASSES = MAX_SHADOW_HOLE_PASSES - 1
# How much an instance thins a triangle (sliver_scale in the world over sliver_scale in its prototype) scales an
# instanced hit's HitPoint.reach: a quarter of each aspect (SLIVER_SHARE), at most MAX_SLIVER_SCALE (aspect 65536; a
# degenerate world triangle, of no area, would lift ray origins to infinity). A triangle's own thinness no longer
# does (corner_reach): the triangle test is as exact on slivers as on well-shaped triangles.
SLIVER_SHARE = wp.constant(0.25)
MAX_SLIVER_SCALE = wp.constant(16384.0)


@wp.struct
class DeviceSurfaces:
    """Per-triangle shading data, indexed by triangle id (``prim``)."""

    uvs: wp.array2d[wp.vec2]  # (T, 3) texture coordinates per corner
    materials: wp.array[wp.int32]  # (T,) device material (0: the default material)
    double_sided: wp.array[wp.int32]  # (T,) 1 for triangles of double-sided meshes
    emitters: wp.array[wp.int32]  # (T,) light index of emissive triangles, -1 otherwise
    partner_offsets: wp.array[wp.int32]  # (T + 1,) triangle t's coincident partners (wrt.twins) are
    # partner_ranges[partner_offsets[t]:partner_offsets[t + 1]]; or (1,)
    partner_ranges: wp.array[wp.vec2i]  # (K,) (first geometry id, count) of consecutive partner triangles; or (1,)
    num_partners: int  # T when some triangle has a partner, else 0 (then the two arrays are placeholders)


@wp.struct
class HitPoint:
    """A hit reconstructed from the hit buffer."""

    p: wp.vec3  # world-space position
    ng: wp.vec3  # unit geometric normal facing the ray origin
    reach: float  # largest distance along an axis from p to the surface's corners (a shape: its centre): the scale of
    # the intersection tests' rounding (offset_ray_origin), thin triangles' too (corner_reach)
    err: wp.vec3  # per axis, the largest magnitude p's coordinate is summed from: its rounding scale (same use)
    inner: wp.vec3  # a point inside the surface that ray origins are pulled towards: the triangle's centroid (same use)
    ns: wp.vec3  # unit shading normal on the side of ng (normal map included after shading_point)
    front: int  # 1 when the ray hit the front (winding) side
    st: wp.vec2  # texture coordinates
    material: int  # device material index
    display: wp.vec3  # interpolated colour primvar (displayColor, ...), else the instance's colour, else NaN
    opacity: float  # interpolated displayOpacity (the default material's opacity), else NaN


@wp.func
def unit_or_zero(n: wp.vec3):
    """``n`` normalised, or zero when it has no length (a corner without a normal). Measured by
    :func:`stable_length`: an instance scaled by 1e-20 moves a unit normal to one 1e20 long, whose ``wp.length``
    overflowed, and its smooth normals were lost."""
    length = stable_length(n)
    if length > 0.0:
        return n / length
    return wp.vec3(0.0)


@wp.func
def point_in_triangle(a: wp.vec3, b: wp.vec3, c: wp.vec3, u: float, v: float):
    """The point of barycentric coordinates ``(1 - u - v, u, v)`` on triangle ``a, b, c``, as ``a`` plus a sum of
    edge vectors: that sum rounds at the triangle's size and the final addition to the nearest float, so the point
    never lies past a plane of the corners' coordinates (the wall it meets). Summed as ``w a + u b + v c``, each term
    rounded at the coordinates' magnitude: far from the origin the point of a floor fell up to an ulp past the wall
    beside it (0.008 at 1e5), and shadow rays leaving it went outside the room (lit lines along its corners)."""
    return a + (u * (b - a) + v * (c - a))


@wp.func
def corner_reach(a: wp.vec3, b: wp.vec3, c: wp.vec3, p: wp.vec3):
    """``HitPoint.reach`` of the point ``p`` on a triangle with world-space corners ``a``, ``b``, ``c``, however thin.

    A sliver's reach is not scaled up by its aspect (longest edge squared over twice its area): the triangle test's
    compensated edge functions (``geometry.difference_of_products``) put its plane within the same rounding of the
    corners' distance as a well-shaped triangle's. Rays leaving random points of fan slices, strip halves and caps of
    aspect 1 to 65536 with their coplanar neighbours (``benchmarks/sliver_self_hits.py``: 64,000 rays per shape and
    aspect, grazing to normal; float64 oracle of the plane and of the origin's side of it) asked for at most 0.32 of
    ``REACH_OFFSET`` times this reach at every aspect, as at aspect 1 (0.2; through ``wp.Mesh`` 0.62 and 0.35), and
    0.15 of the offset ``offset_ray_origin`` gives (``wp.Mesh`` 0.23): no self-hits in 1.7 million rays. With plain
    float32 edge functions the test's ``t`` erred by about the aspect's share (up to 0.054 times the aspect of that
    offset), and the reach was multiplied by a quarter of the aspect (up to 16384): a 1000 x 1 road of two triangles
    lifted its rays' origins 0.1 off it, and a kerb 0.05 high standing on it cast no shadow."""
    return wp.max(wp.max(largest_magnitude(a - p), largest_magnitude(b - p)), largest_magnitude(c - p))


@wp.func
def sliver_scale(a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """A quarter of the aspect of triangle ``a, b, c`` (longest edge squared over twice its area, edges measured by
    their largest component), between 1 and :data:`MAX_SLIVER_SCALE`; its ratio between an instanced triangle's world
    and prototype shapes measures how unevenly the instance stretches it (:func:`hit_point`)."""
    ab = b - a
    ac = c - a
    longest = wp.max(wp.max(largest_magnitude(ab), largest_magnitude(ac)), largest_magnitude(c - b))
    if not (longest > 0.0 and wp.isfinite(longest)):
        return 1.0
    twice_area = stable_length(wp.cross(ab / longest, ac / longest))  # scaled: the cross product cannot overflow
    if twice_area * MAX_SLIVER_SCALE <= SLIVER_SHARE:
        return MAX_SLIVER_SCALE
    return wp.max(SLIVER_SHARE / twice_area, 1.0)


@wp.func
def corner_err(a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """``HitPoint.err`` of a point interpolated from corners ``a``, ``b``, ``c``: their largest magnitude per axis."""
    return wp.max(wp.max(abs_vec(a), abs_vec(b)), abs_vec(c))


@wp.func
def shape_ray(scene: DeviceScene, prim: int, instance: int, o: wp.vec3, d: wp.vec3):
    """``(origin, direction)``: the world ray ``(o, d)`` in analytic shape ``prim``'s canonical space (drawn by
    ``instance``, -1: a world shape), moved there as :func:`shape_frame` moves a point, relative to the shape's
    origin; the ray parameter stays the world one."""
    j = prim - scene.num_prims
    m = scene.shape_to_local[j]
    if instance >= 0:
        mi = scene.world_to_local[instance]
        w = scene.shape_offsets[scene.shape_offset_firsts[j] + scene.instance_shape_ranks[instance]]
        return (linear_part(m) * (linear_part(mi) * ((o - translation(mi)) - w)),
                linear_part(m) * (linear_part(mi) * d))
    return linear_part(m) * (o - translation(m)), linear_part(m) * d


@wp.func
def shape_frame(scene: DeviceScene, prim: int, instance: int, o: wp.vec3, d: wp.vec3, t: float):
    """World-space point, front normal (not normalised), reach (``HitPoint.reach``: the point's distance from the
    shape's centre, the scale of the canonical test's rounding) and ``HitPoint.err`` of the hit at ``t`` on analytic
    shape ``prim``: the ray point is moved into the shape's canonical space, snapped onto the surface and moved back.

    The point is summed in the frame it is moved into (:func:`local_ray_point`: ``A ((o - c) + t d)``), relative to
    the shape's origin, so it is rounded at the scale of its distance from the ray's origin and the shape, as the
    trace's own canonical ray is. Taken as the world point ``o + t d`` first, it was rounded at the scale of its
    distance from the world origin: a sphere of radius 1 at 1e5 had normals 0.2 degrees off (a cone's up to 2.4
    degrees near its apex), 0.03 at 1e4, however near the camera. An instanced shape's origin is its instance's plus
    its offset ``w`` from it in world space, the float32 one the trace places it by
    (:meth:`wrt.Scene.instanced_shape_origins`): the point is ``A_s A_i (((o - c_i) - w) + t d)``. Summed relative
    to the instance's origin alone, it was rounded at the scale of the shape's distance from there: a sphere 1e5
    inside its prototype had normals 0.4 degrees off."""
    j = prim - scene.num_prims
    m = scene.shape_to_local[j]
    if instance >= 0:
        mi = scene.world_to_local[instance]
        w = scene.shape_offsets[scene.shape_offset_firsts[j] + scene.instance_shape_ranks[instance]]
        local = linear_part(m) * (linear_part(mi) * (((o - translation(mi)) - w) + t * d))
    else:
        local = local_ray_point(m, o, d, t)
    q, n = shape_surface(scene.shape_kinds[j], scene.shape_params[j], local)
    n = normal_to_world(m, n)
    offset = inverse_transform_vector(m, q)  # from the shape's origin
    err = inverse_transform_magnitude(m, abs_vec(q))
    centre = translation(m)
    if instance >= 0:
        n = normal_to_world(mi, n)
        offset = inverse_transform_vector(mi, offset)
        err = inverse_transform_magnitude(mi, err)
        centre = translation(mi) + w
    return centre + offset, n, largest_magnitude(offset), err


@wp.func
def hit_point(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    prim: int,
    instance: int,
    u: float,
    v: float,
    o: wp.vec3,
    d: wp.vec3,
    t: float,
):
    """Position, normals, texture coordinates and material of the hit ``(t, u, v, prim, instance)`` of ray
    ``(o, d)``; for an instance (``instance >= 0``) the prototype-space triangle is moved to world space."""
    h = HitPoint()
    a = scene.points[scene.indices[prim, 0]]
    b = scene.points[scene.indices[prim, 1]]
    c = scene.points[scene.indices[prim, 2]]
    w = 1.0 - u - v
    h.p = point_in_triangle(a, b, c, u, v)
    h.reach = corner_reach(a, b, c, h.p)
    h.err = corner_err(a, b, c)
    h.inner = (a + b + c) / 3.0
    ng = face_normal(a, b, c)
    n0 = scene.normals[prim, 0]
    n1 = scene.normals[prim, 1]
    n2 = scene.normals[prim, 2]
    if prim >= scene.num_prims:
        # An analytic shape: the point and normal come from the shape itself.
        p, n, reach, err = shape_frame(scene, prim, instance, o, d, t)
        h.p = p
        h.reach = reach
        h.err = err
        h.inner = p
        ng = n
        n0 = n
        n1 = n
        n2 = n
    elif instance >= 0:
        # Normals move by the inverse transpose, so the front side stays the front side under mirroring. Corner
        # normals are moved and renormalised before interpolation, exactly as a flattened copy stores them.
        m = scene.world_to_local[instance]
        h.err = instance_magnitude(scene, instance, h.err)  # from L where float32 cannot hold A^-1
        prototype_sliver = sliver_scale(a, b, c)
        a, b, c = instance_corners(scene, instance, a, b, c)  # about the BLAS's centre, as traced
        h.p = point_in_triangle(a, b, c, u, v)  # from the world corners, which the neighbours share
        # An instance that stretches its prototype unevenly moves ray origins into prototype space (tlas.moved_ray)
        # rounded at the scale of its largest stretch, and its world triangles rest on that rounding at the scale of
        # its smallest: a triangle it thins (its world aspect over its prototype one) gets that ratio, 1 for an
        # instance that keeps its shapes, never more than the larger aspect's quarter used before. Through instances
        # scaling by 0.03 to 30 along random axes, rays leaving triangles of aspect 1 to 65536 asked for up to 7.5
        # times REACH_OFFSET of the world corner reach, 0.27 of the offset with the ratio and HitPoint.err
        # (benchmarks/sliver_self_hits.py --instanced); without the ratio, a triangle of aspect 1 thinned to 142
        # (scales 20, 12 and 0.13) asked for 0.8 of its offset.
        h.reach = corner_reach(a, b, c, h.p) * wp.max(sliver_scale(a, b, c) / prototype_sliver, 1.0)
        h.inner = (a + b + c) / 3.0
        ng = normal_to_world(m, ng)
        n0 = unit_or_zero(normal_to_world(m, n0))
        n1 = unit_or_zero(normal_to_world(m, n1))
        n2 = unit_or_zero(normal_to_world(m, n2))
    ns = w * n0 + u * n1 + v * n2
    h.front = 1
    ng_length = stable_length(ng)  # an instance's A^T ng can be far from unit length
    if ng_length > 0.0:
        ng = ng / ng_length
    else:
        ng = -wp.normalize(d)  # a degenerate triangle can only be hit edge-on: face the ray
    if wp.dot(ng, d) > 0.0:
        ng = -ng
        h.front = 0
    ns_length = stable_length(ns)  # a shape's normal is A^T n: 1e20 long on a shape scaled by 1e-20
    if ns_length > 0.0:
        ns = ns / ns_length
        if wp.dot(ns, ng) < 0.0:
            ns = -ns
    else:
        ns = ng
    h.ng = ng
    h.ns = ns
    h.st = w * surf.uvs[prim, 0] + u * surf.uvs[prim, 1] + v * surf.uvs[prim, 2]
    h.material = surf.materials[prim]
    h.display = w * scene.colors[prim, 0] + u * scene.colors[prim, 1] + v * scene.colors[prim, 2]
    if instance >= 0 and instance < scene.num_instance_colors:
        # A PointInstancer's colour primvar colours the prototype geometry that has none of its own.
        if scene.takes_instance_color[prim] != wp.uint8(0):
            c = scene.instance_colors[instance]
            if not wp.isnan(c[0]):
                h.display = c
    h.opacity = wp.nan
    if prim < scene.num_opacities:
        h.opacity = w * scene.opacities[prim, 0] + u * scene.opacities[prim, 1] + v * scene.opacities[prim, 2]
    if wp.isnan(h.opacity) and instance >= 0 and instance < scene.num_instance_opacities:
        # An instance's displayOpacity (a PointInstancer's, a native instance's, a point's) is the opacity of the
        # prototype geometry that has none of its own.
        h.opacity = scene.instance_opacities[instance]
    return h


@wp.func
def keep_reflection_above(n: wp.vec3, ng: wp.vec3, wo: wp.vec3):
    """Shading normal ``n`` turned towards ``ng`` just enough that the mirror direction of ``wo`` about it lies above
    the geometric surface (by ``min(0.9 cos, 0.01)`` of ``wo``'s own cosine ``cos`` to ``ng``); unchanged where it
    already does. All three are unit vectors, ``ng`` and ``wo`` on the same side. Then ``dot(n, wo) > 0`` too: a
    normal map that tilts ``n`` away from the viewer made the BSDF black there (``cos_o <= 0``) and sent mirror rays
    into the surface. The bend stays in the plane of ``n`` and ``ng`` (Schuessler et al., "Microfacet-based Normal
    Mapping for Robust Monte Carlo Path Tracing", 2017, discuss the problem; this is the remedy of Blender Cycles'
    ``ensure_valid_specular_reflection``, solved in closed form)."""
    if wp.dot(n, ng) < 0.0:  # below the surface: reflect it over the tangent plane first
        n = wp.normalize(n - 2.0 * wp.dot(n, ng) * ng)
    cos_o = wp.dot(wo, ng)
    threshold = wp.min(0.9 * cos_o, 0.01)
    if 2.0 * wp.dot(n, wo) * wp.dot(n, ng) - cos_o >= threshold:  # dot(reflect(wo, n), ng)
        return n
    # Solve for n' = x_n X + z_n ng (X: the unit direction of n's tangential part) with dot(reflect(wo, n'), ng) =
    # threshold: 2 (x_n wo_x + z_n cos_o) z_n - cos_o = threshold, a quadratic in z_n^2 of which one root is valid.
    x = n - wp.dot(n, ng) * ng
    x_length = wp.length(x)
    if x_length <= 0.0:
        return ng
    x = x / x_length
    wo_x = wp.dot(wo, x)
    a = wo_x * wo_x + cos_o * cos_o
    if a <= 0.0:
        return ng
    b = 2.0 * (a + cos_o * threshold)
    c = (threshold + cos_o) * (threshold + cos_o)
    root = wp.sqrt(wp.max(b * b - 4.0 * a * c, 0.0))
    z2 = 0.25 * (b - root) / a
    if wo_x < 0.0:
        z2 = 0.25 * (b + root) / a
    z2 = wp.clamp(z2, 0.0, 1.0)
    bent = wp.normalize(wp.sqrt(1.0 - z2) * x + wp.sqrt(z2) * ng)
    if 2.0 * wp.dot(bent, wo) * wp.dot(bent, ng) - cos_o <= 0.0:  # rounding at the most grazing views
        return ng
    return bent


@wp.func
def unmapped_normal(h: HitPoint, d: wp.vec3):
    """``h.ns`` kept on the viewer's side (:func:`keep_reflection_above`): the normal of a hit whose normal map has
    no direction there, as of one without a map. Returned as it was interpolated, it leaned away from the viewer near
    a coarse mesh's silhouette, where a mirror was black (a map read at a constant ``st``, or a mesh without ``st``)."""
    return keep_reflection_above(h.ns, h.ng, -wp.normalize(d))


@wp.func
def tilted_normal(mats: DeviceMaterials, binding: int, h: HitPoint, t: wp.vec3, bt: wp.vec3, d: wp.vec3):
    """``normalize(x t + y bt + z h.ns)`` for the value ``(x, y, z)`` of normal map ``binding`` at ``h.st``, kept on
    the viewer's side (:func:`keep_reflection_above`); :func:`unmapped_normal` where it has no direction. A MaterialX
    normal map (``tex_mesh_frame``) whose input is 0 there is the flat normal, as ``mx_normalmap`` decodes it."""
    c = lookup_binding(mats, binding, h.st)
    bias = mats.tex_bias[binding]
    if mats.tex_mesh_frame[binding] != 0 and c[0] == bias[0] and c[1] == bias[1] and c[2] == bias[2]:
        # MaterialX's normalmap reads an input of 0 (texel * scale + bias == bias: a black texel) as the flat normal,
        # not 0 * 2 - 1: the black padding of a baked map was drawn bent into the surface.
        c = wp.vec4(0.0, 0.0, 1.0, c[3])
    m = c[0] * t + c[1] * bt + c[2] * h.ns
    m_length = wp.length(m)
    if not (m_length > 0.0 and wp.isfinite(m_length)):
        return unmapped_normal(h, d)
    return keep_reflection_above(m / m_length, h.ng, -wp.normalize(d))


@wp.func
def mapped_normal(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    binding: int,
    h: HitPoint,
    prim: int,
    instance: int,
    d: wp.vec3,
):
    """The shading normal of hit ``h`` on triangle ``prim`` perturbed by normal map ``binding`` (a texture binding
    of ``mats``): ``normalize(x T + y B + z N)`` for the map's value ``(x, y, z)``, with ``N = h.ns`` (facing the
    ray, as Storm's), ``T`` the direction of increasing s (the map's coordinates, after its ``UsdTransform2d``; of
    the mesh's own for a binding's ``tex_mesh_frame``, MaterialX's ``Tworld``) made orthogonal to ``N``, and
    ``B = +-cross(N, T)`` on the side of increasing t (OpenGL convention: +Y up the map; the side also follows
    mirroring transforms and mirrored texture coordinates). Then kept on the viewer's
    side of the surface (:func:`keep_reflection_above`). ``h.ns``, so kept (:func:`unmapped_normal`), is returned
    where the frame or the map value has no direction (texture coordinates of zero area, a zero texel), and so for
    a map read at a constant ``st``, which has no tangent directions at all: Storm's ``T`` and ``B``, from the
    screen derivatives of ``st``, are zero there, so its ``normalize(TBN n)`` is ``N`` too. (A frame built about
    ``N`` would turn the tilt with the object's orientation in world space: a rotated instance shaded unlike the
    object rotated.)"""
    xf = mats.tex_transform[binding]
    if mats.tex_mesh_frame[binding] != 0:  # MaterialX's normalmap: the frame of the mesh's st (Tworld)
        xf = wp.identity(n=3, dtype=float)
    if xf[0, 0] == 0.0 and xf[0, 1] == 0.0 and xf[1, 0] == 0.0 and xf[1, 1] == 0.0:  # constant_st_transform
        return unmapped_normal(h, d)
    # Tangents of the triangle: dp/ds and dp/dt of the map's coordinates, times the sign of the st area (their
    # directions, without dividing by it). The UsdTransform2d's translation cancels in the differences.
    st0 = surf.uvs[prim, 0]
    st1 = surf.uvs[prim, 1] - st0
    st2 = surf.uvs[prim, 2] - st0
    d1 = xf * wp.vec3(st1[0], st1[1], 0.0)
    d2 = xf * wp.vec3(st2[0], st2[1], 0.0)
    det = d1[0] * d2[1] - d1[1] * d2[0]
    if det == 0.0 or not wp.isfinite(det):
        return unmapped_normal(h, d)
    p0 = scene.points[scene.indices[prim, 0]]
    e1 = scene.points[scene.indices[prim, 1]] - p0
    e2 = scene.points[scene.indices[prim, 2]] - p0
    side = wp.sign(det)
    dp_ds = (d2[1] * e1 - d1[1] * e2) * side
    dp_dt = (d1[0] * e2 - d2[0] * e1) * side
    if instance >= 0:
        dp_ds = inverse_transform_vector(scene.world_to_local[instance], dp_ds)
        dp_dt = inverse_transform_vector(scene.world_to_local[instance], dp_dt)
    # Gram-Schmidt against the shading normal; the bitangent's side follows dp/dt.
    n = h.ns
    t = dp_ds - wp.dot(dp_ds, n) * n
    t_length = stable_length(t)
    if not (t_length > 0.0 and wp.isfinite(t_length)):
        return unmapped_normal(h, d)
    t = t / t_length
    bt = wp.cross(n, t)
    if wp.dot(bt, dp_dt) < 0.0:
        bt = -bt
    return tilted_normal(mats, binding, h, t, bt, d)


@wp.func
def shading_point(
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
    """:func:`hit_point` with the material's normal map applied to ``ns`` (:func:`mapped_normal`); meshes only, as
    analytic shapes have no texture coordinates. Without a normal map it costs one read of the material's slot."""
    h = hit_point(scene, surf, prim, instance, u, v, o, d, t)
    binding = normal_map(mats, h.material)
    if binding >= 0 and prim < scene.num_prims:
        h.ns = mapped_normal(scene, surf, mats, binding, h, prim, instance, d)
    else:
        # An interpolated normal leans away from the viewer near a coarse mesh's silhouette as a mapped one can:
        # the BSDF was black there and mirror rays went into the surface (a smooth-shaded mirror sphere of 16
        # segments showed black rims in a white furnace).
        h.ns = unmapped_normal(h, d)
    return h


FIRST_AT_CENTRE = wp.constant(0)  # camera_sample: sample 0 through the pixel centre and the lens centre
FIRST_ON_LENS = wp.constant(1)  # sample 0 through the pixel centre, over the lens
FIRST_SPREAD = wp.constant(2)  # sample 0 spread over the pixel and the lens, as every other sample


@wp.func
def camera_sample(
    cam: DeviceCamera,
    lens_radius: float,
    focus_distance: float,
    width: int,
    height: int,
    pixel: int,
    sample: int,
    first: int,
    state: wp.uint32,
):
    """Camera ray of ``sample`` at ``pixel``: origin, unit direction, ``t`` range and the advanced RNG state.

    Samples are jittered over the pixel and, with ``lens_radius > 0``, over the thin lens focused at
    ``focus_distance`` (measured along the view axis). Sample 0 goes as ``first`` says: through the pixel centre and
    the lens centre (``FIRST_AT_CENTRE``: the AOVs' ray, and a one-sample image's colour through a pinhole), through
    the pixel centre and over the lens (``FIRST_ON_LENS``: a one-sample image behind a thin lens, which shows its
    blur), or as the others (``FIRST_SPREAD``: an image of several samples, whose mean is then the pixel's area
    average; through the centre, sample 0 was a point sample of weight ``1 / spp``, and a pixel that an edge crossed
    away from its centre was off by that share: 0.15 for 0.3 at 2 spp).
    """
    i = pixel // width
    j = pixel - i * width
    sx = float(0.5)
    sy = float(0.5)
    lx = float(0.5)
    ly = float(0.5)
    thin_lens = lens_radius > 0.0 and cam.orthographic == 0
    if sample > 0 or first == FIRST_SPREAD:
        sx, state = rand01(state)
        sy, state = rand01(state)
        lx, state = rand01(state)
        ly, state = rand01(state)
    elif thin_lens and first == FIRST_ON_LENS:  # (a pinhole's sample 0 at the centre draws nothing)
        lx, state = rand01(state)
        ly, state = rand01(state)
    o, ray = film_ray(cam, (float(j) + sx) / float(width), (float(i) + sy) / float(height))
    if thin_lens and (sample > 0 or first != FIRST_AT_CENTRE):
        # Lens and focus plane are in camera space; ray keeps advancing one unit of camera-space depth per unit.
        focus = o + focus_distance * ray
        lens = sample_concentric_disk(lx, ly) * lens_radius
        o = o + lens[0] * cam.right + lens[1] * cam.up
        ray = (focus - o) / focus_distance
    o, d, t0, t1 = clipped_ray(cam, o, ray)
    return o, d, t0, t1, state


@wp.func
def path_rng(seed: int, pixel: int, sample: int):
    """The RNG state of a path: decorrelated across seeds, samples and pixels."""
    return wp.rand_init(int(wp.rand_init(seed, sample)), pixel)


@wp.kernel
def start_paths_kernel(
    cams: wp.array[DeviceCamera],
    lenses: wp.array[wp.vec2],
    width: int,
    height: int,
    first_sample: int,
    seed: int,
    first: int,
    # outputs
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
    views: wp.array[wp.int32],
):
    """Starts one path per (sample, view, pixel): entry ``i`` is pixel ``i % (V W H)`` of sample
    ``first_sample + i // (V W H)``, and that pixel is pixel ``p % (W H)`` of view (camera) ``p // (W H)``.

    ``lenses[view]`` is (lens radius, focus distance); ``first``: where sample 0 goes (:func:`camera_sample`:
    ``FIRST_AT_CENTRE`` for the AOV ray). The random stream depends
    on the pixel within its view, not on the view, so view ``k`` of a batch is exactly the image a render of camera
    ``k`` alone gives.
    """
    i = wp.tid()
    n_view = width * height
    n_pixels = n_view * cams.shape[0]
    p = i % n_pixels
    sample = first_sample + i // n_pixels
    view = p // n_view
    pixel = p - view * n_view
    state = path_rng(seed, pixel, sample)
    lens = lenses[view]
    o, d, t0, t1, state = camera_sample(cams[view], lens[0], lens[1], width, height, pixel, sample, first, state)
    origins[i] = o
    directions[i] = d
    t_mins[i] = t0
    t_maxs[i] = t1
    rng[i] = state
    throughput[i] = wp.vec3(1.0)
    radiance[i] = wp.vec3(0.0)
    alive[i] = 1
    pdf_prev[i] = 0.0
    prev_normal[i] = wp.vec3(0.0)
    views[i] = view  # the camera of the path: its headlight direction (light_sampling.sample_light_in_view)


@wp.kernel
def primary_aovs_kernel(
    scene: DeviceScene,
    surf: DeviceSurfaces,
    mats: DeviceMaterials,
    cams: wp.array[DeviceCamera],
    view_pixels: int,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    hit_t: wp.array[float],
    hit_u: wp.array[float],
    hit_v: wp.array[float],
    hit_prim: wp.array[wp.int32],
    hit_instance: wp.array[wp.int32],
    hit_cost: wp.array[wp.vec2i],
    # outputs
    depth: wp.array[float],
    z: wp.array[float],
    normal: wp.array[wp.vec3],
    geometric_normal: wp.array[wp.vec3],
    albedo: wp.array[wp.vec3],
    prim_out: wp.array[wp.int32],
    instance: wp.array[wp.int32],
    material: wp.array[wp.int32],
    cost: wp.array[wp.vec2i],
):
    """Data outputs of the camera rays (see :class:`wrt.image.Image` for their meaning); ray ``i`` belongs to
    camera ``i // view_pixels``."""
    i = wp.tid()
    prim = hit_prim[i]
    prim_out[i] = prim
    cost[i] = hit_cost[i]
    if prim < 0:
        depth[i] = wp.inf
        z[i] = wp.inf
        normal[i] = wp.vec3(0.0)
        geometric_normal[i] = wp.vec3(0.0)
        albedo[i] = wp.vec3(0.0)
        instance[i] = -1
        material[i] = -1
        return
    d = directions[i]
    h = shading_point(scene, surf, mats, prim, hit_instance[i], hit_u[i], hit_v[i], origins[i], d, hit_t[i])
    s = eval_surface(mats, h.material, h.st, h.display, h.opacity)
    depth[i] = hit_t[i] * wp.length(d)
    cam = cams[i // view_pixels]
    # Along the ray, as depth is, not from the hit point minus the eye: far from the world origin those two float32
    # points have lost the digits of their difference (5e-3 of a z of 5 at 1e6). The ray's origin is the eye, or
    # for an orthographic camera a film point near it.
    axis = cam.forward / stable_length(cam.forward)  # scaled with the camera: wp.normalize squared 1e20 to inf
    z[i] = wp.dot(origins[i] - cam.origin, axis) + depth[i] * wp.dot(wp.normalize(d), axis)
    normal[i] = h.ns
    geometric_normal[i] = h.ng
    albedo[i] = s.base_color
    instance[i] = hit_instance[i]
    # The last device material is the surface of noMaterialResponse mesh lights, "as if there is no Material
    # bound at all" (wrt.materials.no_response_material): -1, as for the default material.
    material[i] = wp.where(h.material == mats.flags.shape[0] - 1, -1, h.material - 1)


@wp.kernel
def accumulate_samples_kernel(
    radiance: wp.array[wp.vec3],
    n_pixels: int,
    samples: int,
    # outputs
    image: wp.array[wp.vec3],
    dropped: wp.array[wp.int32],
):
    """``image[p] += radiance`` of each sample of pixel ``p`` in sample order (so any split of the samples into
    launches gives the same sums); non-finite samples, and samples whose sum with the others overflows (a dome of
    1e38 gives finite samples, summing to inf), are dropped and counted."""
    p = wp.tid()
    acc = image[p]
    for s in range(samples):
        total = acc + radiance[s * n_pixels + p]
        if wp.isfinite(total):
            acc = total
        else:
            wp.atomic_add(dropped, 0, 1)
    image[p] = acc


@wp.kernel
def count_covered_kernel(
    hit_prim: wp.array[wp.int32],
    n_pixels: int,
    samples: int,
    # outputs
    launch_covered: wp.array[wp.int32],
):
    """``launch_covered[p]`` = the samples of pixel ``p`` (ray ``s * n_pixels + p``) in this launch whose camera ray
    hit something: the count behind the ``coverage`` AOV, the alpha a compositor needs of an antialiased edge."""
    p = wp.tid()
    count = int(0)
    for s in range(samples):
        if hit_prim[s * n_pixels + p] >= 0:
            count += 1
    launch_covered[p] = count


@wp.kernel
def count_alive_kernel(
    alive: wp.array[wp.int32],
    # outputs
    count: wp.array[wp.int32],
):
    """``count[0] += number of live paths``: whether a bounce loop goes on, for every integrator (here, not in the path
    integrator's module, so that a whitted or ao render does not compile the path tracer for it)."""
    i = wp.tid()
    if alive[i] == 1:
        wp.atomic_add(count, 0, 1)


@wp.kernel
def add_covered_kernel(
    launch_covered: wp.array[wp.int32],
    # outputs
    covered: wp.array[wp.int32],
):
    """``covered += launch_covered``, once the launch's radiance is added to the image (so that a render interrupted
    during a launch counts as many samples in both)."""
    p = wp.tid()
    covered[p] = covered[p] + launch_covered[p]


@wp.kernel
def coverage_kernel(
    covered: wp.array[wp.int32],
    samples: int,
    # outputs
    coverage: wp.array[float],
):
    """``coverage = covered / samples``: the share of each pixel's samples whose camera ray hit something."""
    p = wp.tid()
    coverage[p] = float(covered[p]) / float(samples)


@wp.kernel
def mean_image_kernel(
    image: wp.array[wp.vec3],
    samples: int,
    view_scales: wp.array[float],
    view_pixels: int,
    # outputs
    out: wp.array[wp.vec3],
    clamped: wp.array[wp.int32],
):
    """``out = image / samples * view_scales[view]``: a division, then a product, so it rounds exactly as the
    host's ``image.numpy() / samples * scale`` (:func:`wrt.render.mean_radiance`); a value past float32's range (an
    exposure above 1) is its largest, and the pixel counted in ``clamped``."""
    i = wp.tid()
    v = image[i] / float(samples) * view_scales[i // view_pixels]
    if largest_magnitude(v) > FLOAT32_MAX:
        v = wp.vec3(wp.min(v[0], FLOAT32_MAX), wp.min(v[1], FLOAT32_MAX), wp.min(v[2], FLOAT32_MAX))
        wp.atomic_add(clamped, 0, 1)
    out[i] = v
