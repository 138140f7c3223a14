"""The device side of lights: the :class:`DeviceLights` table (built by :mod:`wrt.light_table`) and the Warp
functions the integrators call on it: sampling a light from a shading point, and the radiance and pdf of a
light a ray hits, for multiple importance sampling (the radiometry is in :mod:`wrt.lights`).

Sampling: light ``k`` is picked with probability ``0.5 * power_k / sum(power) + 0.5 / count`` (a shaped light's power
times the share its shaping lets out); spheres are sampled by the cone they subtend; rect lights, and disk lights
that look large, uniformly by solid angle (Urena et al. 2013; disks through the square around them;
:mod:`wrt.spherical_rect`); triangles by solid angle unless they look tiny (:mod:`wrt.spherical_triangle`); rect
lights sheared into parallelograms by the solid angles of their two triangles (:mod:`wrt.spherical_parallelogram`);
other disk lights, rect lights and triangles that look tiny uniformly by area; cylinder lights as open glowing tubes
(:mod:`wrt.glowing_tubes`: uniformly by area over the half facing the shading point and by the angles their side
subtends, mixed); ellipsoids and elliptic tubes (sphere and cylinder lights under
a transform that is no similarity) through the unit sphere and tube they are images of (:mod:`wrt.affine_lights`);
glowing analytic shapes that are not round (boxes, ellipsoids, squeezed tubes, inward shapes) in the cone of an
ellipsoid around them, the light point their first hit (:mod:`wrt.glowing_hulls`), and glowing planes and disks as
rect and disk lights (:func:`flat_hull`);
soft distant lights
uniformly in their cone; a constant dome cosine-weighted about the shading normal and a textured dome by the
luminance of its filtered texture averaged over each texel (piecewise-constant 2D distribution, Pharr et al., PBRT
4th ed., A.5 and 12.5), so that every direction the filtered texture lights can be drawn.
"""

from __future__ import annotations

import functools

import warp as wp

from .affine_lights import (
    UNIT_TUBE,
    UNIT_TUBE_AXIS,
    ellipsoid_pdf,
    elliptic_tube_pdf_terms,
    elliptic_tube_point,
    intersect_ellipsoid,
    intersect_elliptic_tube,
    sample_ellipsoid,
)
from .floats import FLOAT32_MAX, largest_magnitude, power_scales, unit_scales
from .geometry import stable_length
from .glowing_hulls import flat_front, flat_shape, hull_pdf, sample_hull
from .glowing_spheres import GLOW_HULL
from .glowing_tubes import TUBE_OPEN, sample_tube, tube_pdf, tube_pdf_terms, tube_point_density
from .ies import ies_factor
from .instance_corners import instance_corners
from .light_features import ALL_FEATURES, LightFeatures
from .light_links import DeviceLinks
from .light_shaping import cone_and_focus
from .materials import DeviceMaterials, cut_out, eval_emission
from .primitives import SHAPE_DISK
from .sampling import (
    INV_PI,
    PI,
    cdf_remainder,
    sample_cdf,
    sample_concentric_disk,
    sample_cosine_hemisphere,
    sample_uniform_cone,
    sample_uniform_sphere,
    to_world,
)
from .scene import DeviceScene
from .sphere_cone import cone_of_sphere, intersect_sphere, sample_sphere_cone
from .spherical_parallelogram import (
    SeenParallelogram,
    by_cosine,
    parallelogram_pdf,
    parallelogram_usable,
    pick_triangle,
    seen_parallelogram,
    triangle_by_solid_angle,
)
from .spherical_rect import (
    SphericalRect,
    sample_spherical_rect,
    solid_angle_usable,
    spherical_rect,
    spherical_rect_pdf,
)
from .spherical_triangle import sample_spherical_triangle, seen_solid_angle
from .textures import WRAP_CLAMP, WRAP_REPEAT, wrap_coord
from .transforms import normal_to_world

LIGHT_DISTANT = wp.constant(0)
LIGHT_SPHERE = wp.constant(1)
LIGHT_RECT = wp.constant(2)
LIGHT_DISK = wp.constant(3)
LIGHT_CYLINDER = wp.constant(4)
LIGHT_DOME = wp.constant(5)
LIGHT_POINT = wp.constant(6)
LIGHT_TRIANGLE = wp.constant(7)
LIGHT_ELLIPSOID = wp.constant(8)  # a SphereLight scaled unevenly or sheared
LIGHT_ELLIPTIC_TUBE = wp.constant(9)  # a CylinderLight scaled unevenly across its axis or sheared
LIGHT_LINE = wp.constant(10)  # a CylinderLight with treatAsLine: a segment, radiance holds I_s (wrt.lights)
# A glowing analytic sphere (wrt.glowing_spheres): entries from first_glowing_sphere on, after the triangles, sampled
# as a sphere light is, with its material's emission.
LIGHT_GLOWING_SPHERE = wp.constant(11)
# A glowing round tube (wrt.glowing_spheres: a cylinder, cone or capsule): among the same entries, its glowing_axes
# row's code not GLOW_SPHERE; sampled by area and by the angles its side subtends, mixed (wrt.glowing_tubes).
LIGHT_GLOWING_TUBE = wp.constant(12)
# Any other glowing analytic shape (wrt.glowing_spheres: a box, plane or disk, an ellipsoid, an elliptic tube, a shape
# that glows inwards): among the same entries, its glowing_axes row's code GLOW_HULL; drawn in the cone of an
# ellipsoid around it, the light point its first hit (wrt.glowing_hulls).
LIGHT_GLOWING_HULL = wp.constant(13)
GLOWING_HULL = wp.constant(float(GLOW_HULL))
# A glowing plane's full edges over its hull map's first two columns, which hold its half edges times sqrt(2)
# (wrt.glowing_spheres.HULL_FACTORS); a disk's columns are its radius vectors.
ROOT2 = wp.constant(1.4142135623730951)

# DeviceLights.shadows: what blocks a light's shadow rays.
SHADOWS_OFF = wp.constant(0)  # nothing: ShadowAPI's shadow:enable is off (the rays are not traced)
SHADOWS_ON = wp.constant(1)  # every prim
SHADOWS_LINKED = wp.constant(2)  # only the prims its collection:shadowLink includes (it leaves some out)
# ShadowAPI's colour or distance: occluded light arrives tinted, occluders past the distance cast nothing (its
# collection:shadowLink, if any, still counts): shadow_api holds them.
SHADOWS_TINTED = wp.constant(3)

# A disk light is sampled by solid angle through the square around it, which wastes the 21% of samples that fall
# outside the disk: worth it only where the disk looks large (sr of the square), where area sampling is noisy, or
# where the point lies within a radius of the disk (seen_rect): beside its rim, near its plane, the square looks small
# but 1 / d^2 varies widely over the disk (a relative noise per draw of 3 to 14 by area, 0.6 to 1.3 by solid angle).
DISK_SOLID_ANGLE_LEAST = wp.constant(1.0)
# The share of a rect's or disk's draws made by area over the whole light, where the solid-angle draw covers only the
# part within wrt.spherical_rect.REACH heights of the point's foot (the point lies near the light's plane), for a
# shading normal along the plane (times 1 - |cos| to the plane's normal): what is cut off lies at grazing angles to the
# plane, at most 1.5e-5 of the light under an endless light for a normal facing it, but a wall beside a ceiling panel
# just below its plane sees it head on, and it can be most of the wall's light (lost to light sampling alone).
CLIPPED_AREA_SHARE = wp.constant(0.25)


@wp.func
def clipped_area_share(r: SphericalRect, n: wp.vec3):
    """The share of draws by area over the whole of a rect or disk light seen as ``r`` (:func:`seen_rect`) from a
    point of shading normal ``n`` (zero if none), mixed with those by solid angle: 0 where the reach cut nothing off."""
    if r.clipped == 0.0:
        return 0.0
    return CLIPPED_AREA_SHARE * (1.0 - wp.min(wp.abs(wp.dot(n, r.z)), 1.0))


@wp.struct
class DeviceLights:
    """Every light on the device: ``[0, num_analytic)`` are UsdLux lights, the rest triangles of emissive materials
    and of mesh lights: the world-space ones, then those of instances, one entry per prototype triangle and instance
    (an instance's entries consecutive, in its prototype's emitter order: ``DeviceSurfaces.emitters``). The columns
    marked (num_analytic) hold the analytic lights alone (at least one row): no triangle has a use for them, and a
    triangle's row is 60 bytes (64 with light linking), where it took 160 with them."""

    kinds: wp.array[wp.int32]  # (num_analytic) LIGHT_* kind; the triangles' is LIGHT_TRIANGLE (light_kind)
    radiance: wp.array[wp.vec3]  # L (area, dome, soft distant), E (delta distant), I (point), I_s (line);
    # triangles: see params
    position: wp.array[wp.vec3]  # (num_analytic) centre; for distant lights the direction of travel
    axis_u: wp.array[wp.vec3]  # (num_analytic) rect: full X edge; disk: X radius vector; cylinder, line: full axis
    axis_v: wp.array[wp.vec3]  # (num_analytic) rect: full Y edge; disk: Y radius vector
    normal: wp.array[wp.vec3]  # (num_analytic) rect, disk: unit emitting normal
    params: wp.array[wp.vec4]  # (radius | cos of half angle | ellipsoid's |det|^(1/3), solid angle of cone |
    # rect, disk, cylinder: their length scale's power of two ``down`` (light_scales), area (times down^2 for rect,
    # disk, cylinder, and a sphere's its radius' power of two: in float32 range at any scene scale) | 1 - cos,
    # right-angled axes);
    # triangles: (1: radiance times the material's emission, 1: camera rays see the radiance, 1: a mesh light's,
    # the luminance it emits over the brightest triangle's: wrt.emitter_resampling's target reads it)
    prims: wp.array[wp.int32]  # triangle id of LIGHT_TRIANGLE entries
    instances: wp.array[wp.int32]  # instance that draws a LIGHT_TRIANGLE entry's (prototype) triangle, -1: world
    instance_emitters: wp.array[wp.int32]  # (N,) each instance's first entry, -1: none sampled (or (1,) of -1)
    shadows: wp.array[wp.int32]  # SHADOWS_ON, SHADOWS_OFF, SHADOWS_LINKED or SHADOWS_TINTED: what blocks the light
    shadow_api: wp.array[wp.vec4]  # ShadowAPI (colour, distance) of SHADOWS_TINTED lights: (num_analytic), (count)
    # where the triangles of a mesh light are SHADOWS_TINTED
    shadow_fade: wp.array[wp.vec2]  # as shadow_api: their (falloff: width of the fading zone, 0: none; its gamma)
    shadow_api_on: int  # 1 when some light is SHADOWS_TINTED (otherwise shadow_api is not read)
    shaping: wp.array[wp.vec4]  # (num_analytic) (cone angle, smooth start (radians), focus, 1); all 0: unshaped
    shaping_axis: wp.array[wp.vec3]  # (num_analytic) unit primary axis (the light's -Z) of shaped lights
    focus_tint: wp.array[wp.vec3]  # (num_analytic) ShapingAPI focusTint of shaped lights
    ies: wp.array[wp.vec3i]  # (num_analytic) (offset into ies_data, vertical, horizontal angles) of an IES profile;
    # vertical 0: none (read only where shaping is on)
    ies_frame: wp.array[wp.mat33]  # (num_analytic) rows: the light's unit X, Y and primary axis (wrt.ies.ies_factor)
    ies_data: wp.array[float]  # the IES profiles, one after the other (wrt.ies.IesProfile.device_data)
    pmf: wp.array[float]  # selection probability of each light
    cdf: wp.array[float]  # (count + 1) running sum of pmf
    emitter_cdf: wp.array[float]  # (count - num_analytic + 1) the triangles' own cdf (their pmf over their total),
    # on the grid of the uniform numbers drawn (multiples of 2^-24): whitted draws one of them (pick_in_group)
    count: int  # number of lights
    radiance_scale: float  # power of two every emitted radiance is held times (wrt.radiance_scale; unread here)
    num_analytic: int  # number of UsdLux lights but mesh lights (they come first; then emissive and mesh triangles)
    # Glowing analytic spheres (LIGHT_GLOWING_SPHERE), the entries [first_glowing_sphere, count): prims holds the
    # shape's geometry id, instances its instance (-1: a world shape), params and radiance an emissive triangle's.
    first_glowing_sphere: int
    glowing_spheres: wp.array[wp.vec4]  # (count - first_glowing_sphere, or 1) world centre and radius
    glowing_axes: wp.array[wp.vec4]  # (as glowing_spheres) a tube's world half axis and GLOW_* code; 0: a sphere
    glowing_tapers: wp.array[float]  # (as glowing_spheres) a cone's top radius over its bottom one, 1 for the rest
    hull_maps: wp.array[wp.mat33]  # (2 H, or 2) each glowing hull's map from the unit ball to its ellipsoid, then
    # its inverse (a hull's glowing_axes row: (its index, cube root of the map's |det|, 0, GLOW_HULL))
    instance_glowing_spheres: wp.array[wp.int32]  # (N,) each instance's first glowing sphere entry, -1: none
    first_shape_id: int  # the geometry id of the first analytic shape (Scene.num_geometry_triangles)
    dome: int  # index of the dome light, -1 without one
    dome_to_local: wp.mat33  # world direction -> dome frame
    dome_textured: int  # 1 when the dome has a texture (a lat-long image in texels, described by texture[dome])
    dome_row_cdf: wp.array[float]  # (H + 1) marginal CDF over rows of filtered luminance * sin(theta)
    dome_col_cdf: wp.array[float]  # (H (W + 1)) CDF over columns in each row, row y's from y (W + 1)
    dome_sh: wp.array[wp.vec3]  # (9,) the dome's irradiance over pi, E(n) / pi, as spherical harmonics of bands 0-2 in
    # the dome's frame (wrt.dome_irradiance; zero without a dome)
    texture: wp.array[wp.vec3i]  # (num_analytic) (offset into texels, width, height) of a rect or dome light's
    # texture; width 0: none
    texels: wp.array[wp.vec3]  # the rect and dome lights' textures, row-major from the top row, one after the other
    lobe_scale: wp.array[wp.vec2]  # (diffuse, specular) multipliers (UsdLux inputs:diffuse, inputs:specular)
    headlight: int  # index of the default headlight, -1 without one: it travels along each view's direction
    headlight_dirs: wp.array[wp.vec3]  # (V,) unit direction of travel of the headlight in view (camera) V
    links: DeviceLinks  # light and shadow linking of the analytic lights (wrt.light_links)
    shapes: wp.array[wp.mat33]  # (num_analytic) ellipsoid, elliptic tube: map from the unit sphere or tube
    shape_inverses: wp.array[wp.mat33]  # (num_analytic) their inverses, world to canonical
    # What a BSDF-sampled ray can meet besides the triangles, in ascending order (at least one row): the analytic area
    # lights it may pass through, and the dome and soft distant lights it may escape into. A loop over every analytic
    # light per ray took 60 s for 2**18 delta suns at 65k samples, none of which a ray can meet.
    segment_lights: wp.array[wp.int32]  # (num_segment_lights) sphere, rect, disk, cylinder, ellipsoid, elliptic tube
    num_segment_lights: int
    sky_lights: wp.array[wp.int32]  # (num_sky_lights) the dome, and distant lights of a cone (params[1] > 0)
    num_sky_lights: int


@wp.struct
class LightSample:
    """A sampled direction towards a light."""

    wi: wp.vec3  # unit direction from the shading point towards the light
    dist: float  # distance to the sampled point (inf for distant and dome lights)
    value: wp.vec3  # incident radiance / solid-angle pdf; for delta lights the illuminance E (or I / d^2)
    pdf: float  # solid-angle pdf of the light sampling strategy (0 for delta lights)


@wp.struct
class FlatLight:
    """A rect or disk light (:func:`rect_light`) or a glowing plane or disk (:func:`flat_hull`) as their one draw in
    :func:`sample_light` takes it: by solid angle where it looks large (:func:`seen_rect`), else by area."""

    centre: wp.vec3  # world centre
    u: wp.vec3  # a rect's full first edge, a disk's first radius vector (world)
    v: wp.vec3  # a rect's full second edge, a disk's second radius vector
    normal: wp.vec3  # unit emitting normal
    disk: int  # 1: a disk (an ellipse, the points a u + b v with a^2 + b^2 <= 1), 0: a rect (a parallelogram)
    right_angled: int  # 1: u and v at right angles (a rect drawn through wrt.spherical_rect, else as a
    # parallelogram through wrt.spherical_parallelogram)
    down: float  # the power of two its lengths are taken times (light_scales)
    area: float  # its area times down^2


@wp.func
def dome_direction_uv(lights: DeviceLights, d: wp.vec3):
    """Lat-long texture coordinates ``(u, v)`` in [0, 1] (v = 0 at the top row) of world direction ``d``."""
    local_dir = lights.dome_to_local * d
    lon = wp.atan2(local_dir[0], local_dir[2])
    lat = wp.asin(wp.clamp(local_dir[1], -1.0, 1.0))
    return wp.vec2(0.5 * (1.0 - lon / PI), 0.5 - lat / PI)


@wp.func
def filtered_texel(texels: wp.array[wp.vec3], info: wp.vec3i, x: float, y: float, wrap_x: int):
    """Bilinearly filtered value of the light texture ``info`` = (offset into ``texels``, width, height) at
    continuous texel coordinates ``(x, y)`` from its top-left corner (texel centres at half-integers). Columns wrap
    by ``wrap_x`` (``WRAP_REPEAT``: lat-long longitude; ``WRAP_CLAMP``), rows clamp (the poles, a rect's edges)."""
    if not (wp.isfinite(x) and wp.isfinite(y)):
        return wp.vec3(0.0)
    w = info[1]
    h = info[2]
    # Keep the integer part in range before converting (a huge coordinate would overflow int).
    fx = wp.clamp(x, -1.0, float(w) + 1.0) - 0.5
    fy = wp.clamp(y, -1.0, float(h) + 1.0) - 0.5
    x0f = wp.floor(fx)
    y0f = wp.floor(fy)
    tx = fx - x0f
    ty = fy - y0f
    x0 = wrap_coord(int(x0f), w, wrap_x)
    x1 = wrap_coord(int(x0f) + 1, w, wrap_x)
    row0 = info[0] + wrap_coord(int(y0f), h, WRAP_CLAMP) * w
    row1 = info[0] + wrap_coord(int(y0f) + 1, h, WRAP_CLAMP) * w
    top = texels[row0 + x0] * (1.0 - tx) + texels[row0 + x1] * tx
    bottom = texels[row1 + x0] * (1.0 - tx) + texels[row1 + x1] * tx
    return top * (1.0 - ty) + bottom * ty


@wp.func
def dome_radiance(lights: DeviceLights, d: wp.vec3):
    """Radiance of the dome light arriving from world direction ``-d`` (i.e. seen along ``d``)."""
    k = lights.dome
    if k < 0:
        return wp.vec3(0.0)
    L = lights.radiance[k]
    if lights.dome_textured == 0:
        return L
    uv = dome_direction_uv(lights, d)
    info = lights.texture[k]
    texel = filtered_texel(lights.texels, info, uv[0] * float(info[1]), uv[1] * float(info[2]), WRAP_REPEAT)
    return wp.cw_mul(L, texel)


@wp.func
def dome_pdf(lights: DeviceLights, d: wp.vec3, n: wp.vec3):
    """Solid-angle pdf with which :func:`sample_light` draws direction ``d`` from the dome (``n``: shading normal)."""
    if lights.dome_textured == 0:
        if wp.length(n) == 0.0:
            return 0.25 * INV_PI
        return wp.max(wp.dot(n, d), 0.0) * INV_PI
    uv = dome_direction_uv(lights, d)
    info = lights.texture[lights.dome]
    w = info[1]
    h = info[2]
    x = wp.clamp(int(uv[0] * float(w)), 0, w - 1)
    y = wp.clamp(int(uv[1] * float(h)), 0, h - 1)
    total = lights.dome_row_cdf[h]
    if total <= 0.0:
        return 0.0
    f = lights.dome_col_cdf[y * (w + 1) + x + 1] - lights.dome_col_cdf[y * (w + 1) + x]
    pdf_uv = f / total * float(w * h)
    # The Jacobian of (u, v) -> direction at d itself, not at the texel's centre row: sample_light draws (u, v)
    # uniformly inside the texel, so only this matches what it draws (coarse maps were biased, +4% with 2 rows).
    y_local = wp.normalize(lights.dome_to_local * d)[1]
    sin_t = wp.sqrt(wp.max(1.0 - y_local * y_local, 0.0))
    if sin_t <= 0.0:
        return 0.0
    return pdf_uv / (2.0 * PI * PI * sin_t)


@wp.func
def light_kind(lights: DeviceLights, k: int):
    """The LIGHT_* kind of light ``k``: the rows past the analytic lights are triangles, then glowing spheres and
    tubes (``kinds`` holds the analytic lights' alone)."""
    if k >= lights.first_glowing_sphere:
        code = lights.glowing_axes[k - lights.first_glowing_sphere][3]
        if code == GLOWING_HULL:
            return LIGHT_GLOWING_HULL
        if code > 0.0:
            return LIGHT_GLOWING_TUBE
        return LIGHT_GLOWING_SPHERE
    if k >= lights.num_analytic:
        return LIGHT_TRIANGLE
    return lights.kinds[k]


@wp.func
def drawn_as_shape(kind: int):
    """Whether lights of ``kind`` are drawn by the shapes' code, which kernels built without
    ``LightFeatures.shape_lights`` leave out (:mod:`wrt.light_features`): glowing shapes and cylinder, line,
    ellipsoid and elliptic tube lights."""
    return kind == LIGHT_CYLINDER or kind == LIGHT_ELLIPSOID or kind == LIGHT_ELLIPTIC_TUBE or kind == LIGHT_LINE or (
        kind == LIGHT_GLOWING_SPHERE or kind == LIGHT_GLOWING_TUBE or kind == LIGHT_GLOWING_HULL)


@wp.func
def light_scales(lights: DeviceLights, k: int):
    """``(down, up = 1 / down)``: the power of two that brings analytic light ``k``'s lengths near 1 (a sphere's
    radius into [1, 2); a rect's, disk's or cylinder's largest edge, radius or axis component, an ellipsoid's or
    elliptic tube's largest entry of its map from the unit shape, set by :mod:`wrt.light_table`, whose ``params[2]``
    holds its area times ``down^2``), and 1 for other kinds (an ellipsoid's or elliptic tube's map moves by ``down``,
    its inverse by ``up``). Its sampling
    and pdf take distances times ``down``: exact, so the same bits where nothing over- or underflows, where an area
    over a distance squared in world units over- or underflowed float32 in scenes past 1e19 or under 1e-19 across
    (lights too dim, up to 89 times too bright, or black)."""
    kind = light_kind(lights, k)
    down = float(1.0)
    up = float(1.0)
    if kind == LIGHT_SPHERE:
        down, up = power_scales(lights.params[k][0])
    elif kind == LIGHT_RECT or kind == LIGHT_DISK or kind == LIGHT_CYLINDER:
        down = lights.params[k][1]
        up = 1.0 / down
    elif kind == LIGHT_ELLIPSOID or kind == LIGHT_ELLIPTIC_TUBE:
        down = lights.params[k][1]
        up = 1.0 / down
    return down, up


@wp.func
def cylinder_tube(lights: DeviceLights, k: int):
    """``(row, half)``: cylinder light ``k`` as :mod:`wrt.glowing_tubes` takes an open tube: (centre, radius) and
    (half axis, ``TUBE_OPEN``)."""
    c = lights.position[k]
    half = 0.5 * lights.axis_u[k]
    return wp.vec4(c[0], c[1], c[2], lights.params[k][0]), wp.vec4(half[0], half[1], half[2], float(TUBE_OPEN))


@wp.func
def intersect_sphere_light(lights: DeviceLights, k: int, o: wp.vec3, d: wp.vec3):
    """:func:`wrt.affine_lights.intersect_sphere` of sphere light ``k`` and the ray ``(o, unit d)``, in its scaled
    lengths (:func:`light_scales`): its squares overflowed for a sphere 1e19 wide."""
    down, up = light_scales(lights, k)
    return intersect_sphere(lights.position[k] * down, lights.params[k][0] * down, o * down, d) * up


@wp.func
def emission_shaping(lights: DeviceLights, k: int, w: wp.vec3):
    """The colour factor of analytic light ``k``'s ShapingAPI (its cone, focus and IES profile) on the radiance it
    emits along unit ``w`` (1 where unshaped: :mod:`wrt.light_shaping`)."""
    params = lights.shaping[k]
    if params[3] == 0.0:
        return wp.vec3(1.0)
    f = cone_and_focus(params, lights.shaping_axis[k], lights.focus_tint[k], w)
    info = lights.ies[k]
    if info[1] > 0:
        f = f * ies_factor(lights.ies_data, info, lights.ies_frame[k], w)
    return f


@wp.func
def unshaped_emission(lights: DeviceLights, k: int, w: wp.vec3):
    """:func:`emission_shaping` of a scene without shaped lights: 1 (the cone, focus and IES code not compiled)."""
    return wp.vec3(1.0)


def emission_shaping_for(features: LightFeatures):
    """:func:`emission_shaping`, or :func:`unshaped_emission` where ``features`` has no shaping."""
    return emission_shaping if features.shaping else unshaped_emission


@wp.func
def plane_coords(u: wp.vec3, v: wp.vec3, q: wp.vec3):
    """``(a, b)`` with ``q = a u + b v`` for ``q`` in the plane of edges ``u, v`` (from their origin): the
    coordinates along the edges of a rect light (in [-0.5, 0.5] on it) or along the radius vectors of a disk light,
    which a transform can shear out of right angles (a projection on each edge is right for perpendicular edges
    only). Solved from those projections, ``q.u / u.u`` and ``q.v / v.v``, of the vectors scaled first by the power
    of two that brings the edges' largest component into [1, 2) (exact: the same bits where nothing over- or
    underflows): ``u.u`` of a light 1e20 wide was inf, of one 1e-20 wide 0, and rays saw no light there."""
    down, _ = power_scales(wp.max(largest_magnitude(u), largest_magnitude(v)))
    u = u * down
    v = v * down
    q = q * down
    uu = wp.dot(u, u)
    vv = wp.dot(v, v)
    if uu <= 0.0 or vv <= 0.0:
        return wp.vec2(wp.inf, wp.inf)
    pu = wp.dot(q, u) / uu
    pv = wp.dot(q, v) / vv
    ku = wp.dot(u, v) / uu
    kv = wp.dot(u, v) / vv
    s = 1.0 - ku * kv  # sin^2 of the angle between the edges
    if s <= 0.0:
        return wp.vec2(wp.inf, wp.inf)
    return wp.vec2((pu - ku * pv) / s, (pv - kv * pu) / s)


@wp.func
def light_texture(lights: DeviceLights, k: int, q: wp.vec3):
    """Light ``k``'s texture at point ``q`` on it, filtered (1 without a texture). A rect light's texture lies
    upright seen from its lit side: column 0 at local +X, row 0 (the top) at local +Y."""
    info = lights.texture[k]
    if info[1] == 0:
        return wp.vec3(1.0)
    ab = plane_coords(lights.axis_u[k], lights.axis_v[k], q - lights.position[k])  # (-0.5, -0.5) at local -X, -Y
    return filtered_texel(lights.texels, info, (0.5 - ab[0]) * float(info[1]), (0.5 - ab[1]) * float(info[2]),
                          WRAP_CLAMP)


@wp.func
def lobe_factor(lights: DeviceLights, k: int, diffuse_share: wp.vec3):
    """The factor of light ``k``'s ``diffuse`` and ``specular`` multipliers on light a surface reflects with
    ``diffuse_share`` of it (per channel) through its diffuse lobe and the rest through its specular lobes."""
    m = lights.lobe_scale[k]
    return wp.vec3(m[1]) + (m[0] - m[1]) * diffuse_share


@wp.func
def lit_bsdf(lights: DeviceLights, k: int, f_diffuse: wp.vec3, f_specular: wp.vec3):
    """The BSDF value light ``k`` is reflected with: the diffuse lobe's ``f_diffuse`` and the specular lobes'
    ``f_specular`` (:func:`wrt.bsdf.eval_bsdf_lobes`) scaled by the light's ``diffuse`` and ``specular``
    multipliers."""
    m = lights.lobe_scale[k]
    return f_diffuse * m[0] + f_specular * m[1]


@wp.func
def sphere_cone(lights: DeviceLights, k: int, p: wp.vec3):
    """``(cos_max, 1 - cos_max)`` of the cone the sphere light subtends at ``p``; ``cos_max = 2`` when inside. Lengths
    are scaled by :func:`light_scales` (their squares over- or underflowed in scenes 1e20 or 1e-22 across)."""
    return cone_of_sphere(lights.position[k], lights.params[k][0], p)


@functools.cache
def intersect_light_for(features: LightFeatures):
    """:func:`intersect_light` of the lights of ``features`` (a cylinder, ellipsoid or elliptic tube light is missed
    where ``shape_lights`` is off): see :mod:`wrt.light_features`."""
    @wp.func
    def intersect_light(lights: DeviceLights, k: int, o: wp.vec3, d: wp.vec3):
        """Distance along unit ray ``(o, d)`` to the emitting side of analytic light ``k`` (inf if missed or not
        emitting towards the ray) and the cosine at the light (1 for spheres)."""
        kind = lights.kinds[k]
        c = lights.position[k]
        if kind == LIGHT_SPHERE:
            return intersect_sphere_light(lights, k, o, d), 1.0
        if kind == LIGHT_RECT or kind == LIGHT_DISK:
            n = lights.normal[k]
            denom = wp.dot(d, n)
            if denom >= 0.0:
                return float(wp.inf), 0.0
            t = wp.dot(c - o, n) / denom
            if t <= 0.0:
                return float(wp.inf), 0.0
            ab = plane_coords(lights.axis_u[k], lights.axis_v[k], o + t * d - c)
            inside = False
            if kind == LIGHT_RECT:
                inside = wp.abs(ab[0]) <= 0.5 and wp.abs(ab[1]) <= 0.5
            else:
                inside = wp.length_sq(ab) <= 1.0
            if inside:
                return t, -denom
            return float(wp.inf), 0.0
        if wp.static(features.shape_lights):  # (else they are met nowhere)
            if kind == LIGHT_CYLINDER:
                # In the light's scaled lengths (light_scales): the squares below overflowed for a tube 1e19 wide.
                down, up = light_scales(lights, k)
                axis = lights.axis_u[k] * down
                half = 0.5 * wp.length(axis)
                if half <= 0.0:
                    return float(wp.inf), 0.0
                w = axis / (2.0 * half)
                r = lights.params[k][0] * down
                oc = (o - c) * down
                dp = d - wp.dot(d, w) * w
                op = oc - wp.dot(oc, w) * w
                a = wp.dot(dp, dp)
                b = wp.dot(op, dp)
                cc = wp.dot(op, op) - r * r
                if a <= 0.0 or cc <= 0.0:
                    return float(wp.inf), 0.0
                disc = b * b - a * cc
                if disc < 0.0:
                    return float(wp.inf), 0.0
                t = (-b - wp.sqrt(disc)) / a
                if t <= 0.0 or wp.abs(wp.dot(oc + t * d, w)) > half:
                    return float(wp.inf), 0.0
                radial = op + t * dp
                return t * up, wp.max(-wp.dot(d, radial / r), 0.0)
            if kind == LIGHT_ELLIPSOID or kind == LIGHT_ELLIPTIC_TUBE:  # in the light's scaled lengths (light_scales)
                down, up = light_scales(lights, k)
                if kind == LIGHT_ELLIPSOID:
                    return intersect_ellipsoid(c * down, lights.shape_inverses[k] * up, o * down, d) * up, 1.0
                t, cos_l = intersect_elliptic_tube(c * down, lights.shape_inverses[k] * up, o * down, d)
                return t * up, cos_l
        return float(wp.inf), 0.0

    return intersect_light


intersect_light = intersect_light_for(ALL_FEATURES)


@wp.func
def rect_light(lights: DeviceLights, k: int):
    """Rect or disk light ``k`` as a :class:`FlatLight`."""
    f = FlatLight()
    f.centre = lights.position[k]
    f.u = lights.axis_u[k]
    f.v = lights.axis_v[k]
    f.normal = lights.normal[k]
    f.disk = 0
    if lights.kinds[k] == LIGHT_DISK:
        f.disk = 1
    f.right_angled = 0
    if lights.params[k][3] > 0.0:
        f.right_angled = 1
    f.down = lights.params[k][1]  # (light_scales)
    f.area = lights.params[k][2]
    return f


@wp.func
def seen_rect(f: FlatLight, p: wp.vec3):
    """Rect ``f``, or the square around disk ``f``, as seen from ``p``, whether it is sampled by solid angle from
    there (else by area; see :mod:`wrt.spherical_rect`), and ``(down, up)``: the
    rectangle and ``p`` are in lengths times ``down``, the power of two that brings ``p``'s height above the plane
    into [1, 2) (exact: the same bits where nothing over- or underflows). The rectangle is clipped to a square of
    ``REACH`` heights around ``p``'s foot, so its lengths are near the height: in world units, the edge lengths squared
    overflowed for a light 1e19 wide, and in the light's own (:func:`light_scales`) those of the clipped rectangle
    of one 1e30 wide seen from 3 away underflowed."""
    down = f.down  # p in the light's plane (height 0, or no finite height): no solid angle
    up = 1.0 / f.down
    height = wp.abs(wp.dot(p - f.centre, f.normal))
    if height > 0.0 and height < FLOAT32_MAX:
        down, up = power_scales(height)
    u = f.u * down  # full edges
    v = f.v * down
    least = float(0.0)
    if f.disk == 1:  # the square around the disk (square_around_disk: the same bits), in one call of spherical_rect
        # By solid angle where the square looks large, or where p lies within the disk's largest radius of its circle
        # (DISK_SOLID_ANGLE_LEAST).
        radius = wp.max(wp.length(u), wp.length(v))
        to_p = (p - f.centre) * down
        h = wp.dot(to_p, f.normal)
        out = wp.max(wp.length(to_p - h * f.normal) - radius, 0.0)
        if h * h + out * out >= radius * radius:
            least = DISK_SOLID_ANGLE_LEAST
        u = 2.0 * u
        v = 2.0 * v
    r = spherical_rect(p * down, f.centre * down, u, v)
    return r, f.right_angled == 1 and solid_angle_usable(r, least), down, up


@wp.func
def flat_light_pdf(f: FlatLight, p: wp.vec3, n: wp.vec3, d: wp.vec3, dist: float, cos_l: float):
    """Solid-angle pdf with which :func:`sample_light` draws rect or disk ``f`` from ``p`` (shading normal ``n``,
    zero if none) along unit ``d``, meeting it ``dist`` away at cosine ``cos_l``: by solid angle, mixed with the
    draw by area where the reach clipped it (:func:`clipped_area_share`), or by area; a parallelogram (a rect whose
    edges are not at right angles) by the solid angle of its two triangles (:mod:`wrt.spherical_parallelogram`)."""
    if cos_l <= 0.0 or f.area <= 0.0:
        return 0.0
    scaled = dist * f.down
    by_area = scaled * scaled / (cos_l * f.area)
    if f.disk == 0 and f.right_angled == 0:
        s = seen_parallelogram(p, n, f.centre, f.u, f.v)
        if not parallelogram_usable(s):
            return by_area
        return parallelogram_pdf(s, p + dist * d, d, by_area)
    r, by_solid_angle, rect_down, _ = seen_rect(f, p)
    if by_solid_angle:
        pdf = spherical_rect_pdf(r, n, (p + dist * d) * rect_down)
        share = clipped_area_share(r, n)
        if share > 0.0:  # mixed with draws by area (sample_light)
            pdf = (1.0 - share) * pdf + share * by_area
        return pdf
    return by_area


@functools.cache
def area_light_pdf_for(features: LightFeatures):
    """:func:`area_light_pdf` of the lights of ``features`` (0 for a cylinder, ellipsoid or elliptic tube light where
    ``shape_lights`` is off): see :mod:`wrt.light_features`."""
    @wp.func
    def area_light_pdf(lights: DeviceLights, k: int, p: wp.vec3, n: wp.vec3, d: wp.vec3, dist: float, cos_l: float):
        """Solid-angle pdf (without the selection probability) of analytic light ``k`` sampled from ``p`` (shading
        normal ``n``, zero if none) and seen along unit ``d`` at distance ``dist`` with cosine ``cos_l``."""
        kind = lights.kinds[k]
        if kind == LIGHT_SPHERE:
            cos_max, one_minus = sphere_cone(lights, k, p)
            if cos_max > 1.0 or one_minus <= 0.0:
                return 0.0
            return 1.0 / (2.0 * PI * one_minus)
        down, up = light_scales(lights, k)
        if wp.static(features.shape_lights):
            if kind == LIGHT_ELLIPSOID:
                return ellipsoid_pdf(lights.position[k] * down, lights.shape_inverses[k] * up,
                                     lights.params[k][0] * down, p * down, d)
            if kind == LIGHT_ELLIPTIC_TUBE or kind == LIGHT_CYLINDER:
                # The elliptic tube's pdf (wrt.affine_lights.elliptic_tube_pdf_terms) or the cylinder's
                # (wrt.glowing_tubes.tube_pdf of its open single-sided tube), through one call of the tubes' density:
                # each call site compiles it again.
                tube_row = UNIT_TUBE
                tube_axis = UNIT_TUBE_AXIS
                drawn = bool(False)
                to_p = wp.vec3(0.0)
                q = wp.vec3(0.0)
                tube_n = wp.vec3(0.0)
                dist2 = float(0.0)
                divisor = float(0.0)
                if kind == LIGHT_ELLIPTIC_TUBE:
                    drawn, to_p, q, tube_n, dist2, divisor = elliptic_tube_pdf_terms(
                        lights.position[k] * down, lights.shapes[k] * down, lights.shape_inverses[k] * up, p * down,
                        (p + dist * d) * down, dist * down, cos_l)
                elif not (cos_l <= 0.0):  # (a NaN goes on, as it did)
                    tube_row, tube_axis = cylinder_tube(lights, k)
                    w = wp.normalize(lights.axis_u[k] * down)
                    rel = (p - lights.position[k]) * down + d * (dist * down)
                    tube_n = wp.normalize(rel - wp.dot(rel, w) * w)
                    to_p, q, dist2, divisor = tube_pdf_terms(tube_row, tube_axis, p, d, dist, tube_n)
                    drawn = not (divisor <= 0.0)
                if not drawn:
                    return 0.0
                return dist2 * tube_point_density(tube_row, tube_axis, 1.0, 1, to_p, q, tube_n) / divisor
        elif drawn_as_shape(kind):  # (a stale variant's: nothing of a light it does not draw)
            return 0.0
        return flat_light_pdf(rect_light(lights, k), p, n, d, dist, cos_l)  # a rect or disk light

    return area_light_pdf


area_light_pdf = area_light_pdf_for(ALL_FEATURES)


@wp.func
def distant_in_cone(lights: DeviceLights, k: int, d: wp.vec3):
    """True when a ray along ``d`` looks into the disc of soft distant light ``k``."""
    # Compare chords, |d - axis|^2 = 2 (1 - cos): float32 rounds the cosine of a small disc by up to 25% of its
    # distance from 1 (a 0.05 degree sun looked 1.5 times its size), while the chord keeps its relative precision.
    cone = lights.params[k][1]
    return cone > 0.0 and wp.length_sq(d + lights.position[k]) <= 2.0 * lights.params[k][2]


@wp.func
def emitter_triangle(scene: DeviceScene, prim: int, instance: int):
    """World-space corners ``a, b, c`` of triangle ``prim`` as ``instance`` draws it (-1: world geometry), their
    cross product ``(b - a) x (c - a)`` times ``down^2`` turned to the triangle's front side, and ``down``: the power
    of two that brings the edges' largest component into [1, 2) (:func:`scaled_cross`; the cross product itself, an
    edge length squared, overflowed for a triangle 1e19 wide and vanished for one 1e-20 wide). It is turned to the
    front side: a mirroring instance transform reverses the corners' winding, not the side that
    :func:`wrt.shade.hit_point` calls the front (its normal moves by the inverse transpose). The corners move by
    :func:`wrt.instance_corners.instance_corners`, as ``hit_point``'s do, so sampled points lie on the surface hit."""
    a = scene.points[scene.indices[prim, 0]]
    b = scene.points[scene.indices[prim, 1]]
    c = scene.points[scene.indices[prim, 2]]
    cr, down = scaled_cross(a, b, c)
    if instance >= 0:
        m = scene.world_to_local[instance]
        front = normal_to_world(m, cr)
        a, b, c = instance_corners(scene, instance, a, b, c)
        cr, down = scaled_cross(a, b, c)
        if wp.dot(cr, front) < 0.0:
            cr = -cr
    return a, b, c, cr, down


@wp.func
def scaled_cross(a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """``((b - a) x (c - a) * down^2, down)``, ``down`` the power of two that brings the edges' largest component
    into [1, 2): exact, the same bits scaled where nothing over- or underflows."""
    ab = b - a
    ac = c - a
    down, _ = power_scales(wp.max(largest_magnitude(ab), largest_magnitude(ac)))
    return wp.cross(ab * down, ac * down), down


@wp.func
def triangle_weights(a: wp.vec3, b: wp.vec3, c: wp.vec3, q: wp.vec3, down: float):
    """Barycentric weights ``(of b, of c)`` of point ``q`` of triangle ``a, b, c``'s plane, clamped into the triangle;
    lengths times ``down`` (:func:`scaled_cross`), so the products neither over- nor underflow."""
    e1 = (b - a) * down
    e2 = (c - a) * down
    dq = (q - a) * down
    n = wp.cross(e1, e2)
    nn = wp.dot(n, n)
    bu = wp.clamp(wp.dot(wp.cross(dq, e2), n) / nn, 0.0, 1.0)
    bv = wp.clamp(wp.dot(wp.cross(e1, dq), n) / nn, 0.0, 1.0 - bu)
    return wp.vec2(bu, bv)


@wp.func
def hit_emitter(lights: DeviceLights, slot: int, prim: int, instance: int):
    """The light entry of an emitter triangle or glowing sphere ``prim`` a ray hit in ``instance`` (-1: world
    geometry), or -1: ``slot`` is its ``DeviceSurfaces.emitters``, the entry itself for world geometry, its place among
    its prototype's emitter triangles, or glowing spheres, for prototype geometry (each sampled instance's entries
    start at ``instance_emitters``, its spheres' at ``instance_glowing_spheres``)."""
    if slot < 0 or instance < 0:
        return slot
    first = lights.instance_emitters[instance]
    if prim >= lights.first_shape_id:
        first = lights.instance_glowing_spheres[instance]
    if first < 0:
        return -1
    return first + slot


@wp.func
def triangle_light_pdf(
    scene: DeviceScene, double_sided: int, prim: int, instance: int, o: wp.vec3, d: wp.vec3, dist: float
):
    """Solid-angle pdf of :func:`sample_light`'s sampling of triangle ``prim`` (drawn by ``instance``, -1: world
    geometry; by solid angle, else uniformly by area) seen from ``o`` along unit ``d``; 0 from its back when it is
    single-sided."""
    a, b, c, cr, down = emitter_triangle(scene, prim, instance)
    area2 = stable_length(cr)  # times down^2, as the distance is taken times down
    if area2 <= 0.0:
        return 0.0
    cos_l = -wp.dot(d, cr / area2)
    if double_sided == 1:
        cos_l = wp.abs(cos_l)
    if cos_l <= 0.0:
        return 0.0
    omega = seen_solid_angle(o, a, b, c)
    if omega > 0.0:
        return 1.0 / omega
    scaled = dist * down
    return scaled * scaled / (cos_l * 0.5 * area2)


@wp.func
def glowing_sphere_pdf(lights: DeviceLights, k: int, p: wp.vec3):
    """Solid-angle pdf of :func:`sample_light`'s sampling of glowing sphere ``k`` from ``p``: uniform in the cone
    it subtends (0 inside it)."""
    row = lights.glowing_spheres[k - lights.first_glowing_sphere]
    cos_max, one_minus = cone_of_sphere(wp.vec3(row[0], row[1], row[2]), row[3], p)
    if cos_max > 1.0 or one_minus <= 0.0:
        return 0.0
    return 1.0 / (2.0 * PI * one_minus)


@wp.func
def shape_emission(lights: DeviceLights, mats: DeviceMaterials, k: int, m: int, st: wp.vec2):
    """Radiance that glowing sphere or tube ``k`` (of material ``m``) emits, read at its one ``st``: none where its
    material cuts it out there (wholly, at one ``st``), a hole that rays pass and see no light in, as an emissive
    triangle's hole sends none (a cut-out glowing shape lit the floor under light sampling alone)."""
    if cut_out(mats, m, st):
        return wp.vec3(0.0)
    return triangle_emission(lights, mats, k, m, st)


@wp.func
def glowing_tube_pdf(lights: DeviceLights, k: int, double_sided: int, p: wp.vec3, d: wp.vec3, dist: float,
                     n: wp.vec3):
    """Solid-angle pdf of :func:`sample_light`'s sampling of glowing tube ``k`` (``double_sided`` its shape's flag)
    from ``p`` at the point ``dist`` along unit ``d`` whose unit normal is ``n``: :func:`wrt.glowing_tubes.tube_pdf`,
    the draw by area (over a cone's arc that can face ``p``, a cylinder's cap on ``p``'s side) and by the angles the
    side subtends, mixed."""
    j = k - lights.first_glowing_sphere
    return tube_pdf(lights.glowing_spheres[j], lights.glowing_axes[j], lights.glowing_tapers[j], 1 - double_sided,
                    p, d, dist, n)


@wp.func
def hull_frame(lights: DeviceLights, k: int):
    """``(c, m, a, g, down)``: glowing hull ``k``'s ellipsoid (wrt.glowing_hulls): its centre, its map from the unit
    ball, the inverse and the cube root of the map's ``|det|``, in lengths times ``down``, the power of two that
    brings its largest semi-axis into [1, 2) (in world units its squares overflowed for a shape 1e19 wide)."""
    j = k - lights.first_glowing_sphere
    row = lights.glowing_spheres[j]
    axis = lights.glowing_axes[j]
    h = int(axis[0])
    down, up = power_scales(row[3])
    return (wp.vec3(row[0], row[1], row[2]) * down, lights.hull_maps[2 * h] * down, lights.hull_maps[2 * h + 1] * up,
            axis[1] * down, down)


@wp.func
def flat_hull(lights: DeviceLights, scene: DeviceScene, k: int):
    """Glowing plane or disk ``k`` (a hull row, :func:`wrt.glowing_hulls.flat_shape`) as a :class:`FlatLight`: its
    edges or radius vectors from its ellipsoid's map (at right angles where its axes row says so), its normal on the
    shape's front (:func:`wrt.glowing_hulls.flat_front`), its lengths taken times the power of two that brings the
    ellipsoid's largest semi-axis into [1, 2)."""
    j = k - lights.first_glowing_sphere
    row = lights.glowing_spheres[j]
    axis = lights.glowing_axes[j]
    m = lights.hull_maps[2 * int(axis[0])]
    prim = lights.prims[k]
    f = FlatLight()
    f.centre = wp.vec3(row[0], row[1], row[2])
    f.disk = 0
    scale = ROOT2
    if scene.shape_kinds[prim - scene.num_prims] == SHAPE_DISK:
        f.disk = 1
        scale = 1.0
    f.u = wp.vec3(m[0, 0], m[1, 0], m[2, 0]) * scale
    f.v = wp.vec3(m[0, 1], m[1, 1], m[2, 1]) * scale
    f.right_angled = 0
    if axis[2] > 0.0:
        f.right_angled = 1
    down, up = power_scales(row[3])
    f.down = down
    cross = wp.cross(f.u * down, f.v * down)
    size = stable_length(cross)  # (positive: a plane or disk squashed to a line is left out, wrt.glowing_spheres)
    f.normal = cross / size
    if wp.dot(f.normal, flat_front(scene, prim, lights.instances[k])) < 0.0:
        f.normal = -f.normal
    f.area = size
    if f.disk == 1:
        f.area = PI * size
    return f


@wp.func
def flat_light(lights: DeviceLights, scene: DeviceScene, k: int):
    """Rect or disk light ``k`` (:func:`rect_light`) or glowing plane or disk ``k`` (:func:`flat_hull`) as a
    :class:`FlatLight`."""
    if light_kind(lights, k) == LIGHT_GLOWING_HULL:
        return flat_hull(lights, scene, k)
    return rect_light(lights, k)


@wp.func
def glowing_hull_pdf(lights: DeviceLights, scene: DeviceScene, k: int, p: wp.vec3, shading: wp.vec3, d: wp.vec3,
                     dist: float, n: wp.vec3):
    """Solid-angle pdf of :func:`sample_light`'s sampling of glowing hull ``k`` from ``p`` (shading normal
    ``shading``, zero if none) along unit ``d``, whose first hit of the shape lies ``dist`` away with unit normal
    ``n``: a plane's or disk's as a rect or disk light's (:func:`flat_light_pdf`), another shape's in its
    ellipsoid's cone (:func:`wrt.glowing_hulls.hull_pdf`)."""
    if flat_shape(scene, lights.prims[k]):
        f = flat_hull(lights, scene, k)
        return flat_light_pdf(f, p, shading, d, dist, wp.abs(wp.dot(d, f.normal)))
    c, m, a, g, down = hull_frame(lights, k)
    return hull_pdf(scene, lights.prims[k], c, m, a, g, down, p, d, dist, n)


@wp.func
def triangle_emission(lights: DeviceLights, mats: DeviceMaterials, k: int, m: int, st: wp.vec2):
    """Radiance that triangle light ``k`` (of material ``m``) emits at ``st``: its radiance factor times the
    material's ``emissiveColor``, or the factor alone for a mesh light whose light does not follow its material
    (``materialSyncMode`` ``independent`` or ``noMaterialResponse``)."""
    L = lights.radiance[k]
    if lights.params[k][0] > 0.0:
        L = wp.cw_mul(L, eval_emission(mats, m, st))
    return L


@wp.func
def shadow_direction(lights: DeviceLights, k: int, wi: wp.vec3):
    """The direction of the shadow ray towards light ``k``: ``wi``, or zero for a light that casts no shadows (a
    zero direction can hit nothing, so every accelerator reports the ray unblocked)."""
    return wp.where(lights.shadows[k] != SHADOWS_OFF, wi, wp.vec3(0.0))


@wp.func
def shadow_reach(lights: DeviceLights, k: int, t_max: float, u: float):
    """``t_max`` of a shadow ray towards light ``k``, shortened to its ShadowAPI ``shadow:distance`` (occluders
    further from the surface cast no shadow of it), kept above 0 so the ray still counts as aimed.

    In its falloff zone (the last ``F`` of the distance ``D``), an occluder at ``d`` casts a shadow of strength
    ``((D - d) / F) ** gamma``: the reach is drawn, with ``u`` uniform in [0, 1) and independent of the light sample,
    as ``D - F u ** (1 / gamma)``, which passes ``d`` with exactly that probability, so the shadow ray is blocked
    (the light arrives times ``shadow:color``) as often as the shadow is strong: the fade in expectation."""
    if lights.shadow_api_on == 1:
        if lights.shadows[k] == SHADOWS_TINTED:
            reach = lights.shadow_api[k][3]
            if reach >= 0.0:
                fade = lights.shadow_fade[k]
                if fade[0] > 0.0 and fade[1] > 0.0:
                    reach = reach - fade[0] * wp.where(fade[1] == 1.0, u, wp.pow(u, 1.0 / fade[1]))
                return wp.max(wp.min(t_max, reach), 1.0e-30)
    return t_max


@wp.func
def shadow_fades(lights: DeviceLights, k: int):
    """Light ``k``'s shadows fade out over a ShadowAPI falloff zone: its shadow rays need a number of their own for
    :func:`shadow_reach` (where the light-pick number fell inside the light's share of the cdf takes only about
    ``pmf * 2**24`` values: a staircase, not a fade, for one of 1e5 lights)."""
    if lights.shadow_api_on == 1:
        if lights.shadows[k] == SHADOWS_TINTED:
            if lights.shadow_api[k][3] >= 0.0:
                fade = lights.shadow_fade[k]
                return fade[0] > 0.0 and fade[1] > 0.0
    return False


@wp.func
def shadow_tint(lights: DeviceLights, k: int):
    """What reaches a surface of light ``k`` (-1: none) when its shadow ray is blocked: its ShadowAPI
    ``shadow:color`` (black for plain shadows)."""
    if lights.shadow_api_on == 0 or k < 0:
        return wp.vec3(0.0)
    if lights.shadows[k] != SHADOWS_TINTED:
        return wp.vec3(0.0)
    row = lights.shadow_api[k]
    return wp.vec3(row[0], row[1], row[2])


@wp.func
def sampled_alone(lights: DeviceLights, k: int):
    """Light ``k`` is left to light sampling alone (MIS weight 1): its shadow rays pass geometry (any, what its
    shadowLink leaves out, or occluders past its shadow distance), or bring its tinted light from behind it, where a
    BSDF-sampled ray towards it would stop, losing its share of the light."""
    return lights.shadows[k] != SHADOWS_ON


@wp.func
def empty_sample():
    """A :class:`LightSample` that draws nothing: no light, no pdf, at infinity along +z."""
    out = LightSample()
    out.wi = wp.vec3(0.0, 0.0, 1.0)
    out.dist = float(wp.inf)
    out.value = wp.vec3(0.0)
    out.pdf = 0.0
    return out


@wp.func
def sample_dome(lights: DeviceLights, k: int, n: wp.vec3, u1: float, u2: float):
    """:func:`sample_light` of the dome, light ``k``, at a point of shading normal ``n`` (zero if none): a constant
    dome cosine-weighted about ``n``, a textured one by its texels' luminance. Its own function so that whitted's
    glossy dome term draws the dome without compiling every other light's draw into its kernel again."""
    out = empty_sample()
    if lights.dome_textured == 0:
        if wp.length(n) > 0.0:
            out.wi = to_world(sample_cosine_hemisphere(u1, u2), n)
        else:
            out.wi = sample_uniform_sphere(u1, u2)
    else:
        w = lights.texture[k][1]
        h = lights.texture[k][2]
        # A row by the marginal CDF, then a column by that row's CDF; where u fell inside each places the
        # direction in the texel.
        y = sample_cdf(lights.dome_row_cdf, 0, h, u1)
        fy = cdf_remainder(lights.dome_row_cdf, 0, h, y, u1)
        x = sample_cdf(lights.dome_col_cdf, y * (w + 1), w, u2)
        fx = cdf_remainder(lights.dome_col_cdf, y * (w + 1), w, x, u2)
        uu = (float(x) + fx) / float(w)
        vv = (float(y) + fy) / float(h)
        lon = PI * (1.0 - 2.0 * uu)
        lat = PI * (0.5 - vv)
        local = wp.vec3(wp.cos(lat) * wp.sin(lon), wp.sin(lat), wp.cos(lat) * wp.cos(lon))
        out.wi = wp.normalize(wp.transpose(lights.dome_to_local) * local)
    out.pdf = dome_pdf(lights, out.wi, n)
    if out.pdf > 0.0:
        out.value = dome_radiance(lights, out.wi) / out.pdf
    return out


@functools.cache
def sample_light_for(features: LightFeatures):
    """:func:`sample_light` of the lights of ``features`` (see :mod:`wrt.light_features`): without ``shape_lights``
    the draws of glowing shapes and of cylinder, line, ellipsoid and elliptic tube lights are left out (they draw
    nothing), without ``shaping`` the cones, focus and IES profiles."""
    emission_shaping = emission_shaping_for(features)

    @wp.func
    def sample_light(
        lights: DeviceLights,
        scene: DeviceScene,
        mats: DeviceMaterials,
        uvs: wp.array2d[wp.vec2],
        tri_materials: wp.array[wp.int32],
        tri_double_sided: wp.array[wp.int32],
        k: int,
        p: wp.vec3,
        n: wp.vec3,
        u1: float,
        u2: float,
    ):
        """A direction from ``p`` (shading normal ``n``, zero if none) towards light ``k``; see :class:`LightSample`."""
        out = empty_sample()
        kind = light_kind(lights, k)
        # A glowing shape's emission, from its material at the shape's one texture coordinate (shapes read textures at a
        # constant st): read here once for the three kinds, since each call site compiled the texture lookups again.
        glow = wp.vec3(0.0)
        if wp.static(not features.shape_lights):
            if drawn_as_shape(kind):
                return out  # (a stale variant's: nothing from a light it does not draw)
        if wp.static(features.shape_lights):
            if kind == LIGHT_GLOWING_SPHERE or kind == LIGHT_GLOWING_HULL or kind == LIGHT_GLOWING_TUBE:
                glow_prim = lights.prims[k]
                glow = shape_emission(lights, mats, k, tri_materials[glow_prim], uvs[glow_prim, 0])
        if kind == LIGHT_DISTANT:
            d = -lights.position[k]
            cone = lights.params[k][1]
            if cone > 0.0:
                out.wi = to_world(sample_uniform_cone(u1, u2, lights.params[k][2]), d)
                out.pdf = 1.0 / cone
                out.value = lights.radiance[k] * cone
            else:
                out.wi = d
                out.value = lights.radiance[k]
            return out
        if kind == LIGHT_POINT:
            to = lights.position[k] - p
            d2 = wp.length_sq(to)
            if d2 > 0.0:
                out.dist = wp.sqrt(d2)
                out.wi = to / out.dist
                out.value = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -out.wi)) / d2
            return out
        if wp.static(features.shape_lights):
            if kind == LIGHT_LINE:
                # A point of the segment uniform in the angle phi it is seen at from p's foot on the line (s = h tan
                # phi): the pdf h / ((phi_b - phi_a) d^2) cancels the 1 / d^2 and, with sin(theta) = h / d, leaves
                # I_s sin(theta) / d^2 / pdf = I_s (phi_b - phi_a) / d (uniform along the length was 4x noisier up
                # close).
                seg = lights.axis_u[k]
                # Its length from the axis scaled to a largest entry of 1: the squares of a line under 1e-19 long
                # underflow float32, and it lit nothing (as a normalized tube too thin for float32 became,
                # wrt.lights.drawn_as_line).
                seg_scale = wp.max(wp.max(wp.abs(seg[0]), wp.abs(seg[1])), wp.abs(seg[2]))
                seg_length = float(0.0)
                if seg_scale > 0.0:
                    seg_length = seg_scale * wp.length(seg / seg_scale)
                if seg_length > 0.0:
                    seg_dir = seg / seg_length
                    seg_s = wp.dot(p - lights.position[k], seg_dir)  # p's coordinate along the line, from the centre
                    seg_foot = lights.position[k] + seg_s * seg_dir
                    seg_h = wp.length(p - seg_foot)  # p's distance from the line
                    if seg_h > 0.0:  # (on the line itself: sin(theta) = 0, it sends p nothing)
                        end_a = -0.5 * seg_length - seg_s  # the ends' coordinates from p's foot
                        end_b = 0.5 * seg_length - seg_s
                        # The angle the segment spans, phi_b - phi_a, as one atan2 of the length itself: the difference
                        # of two atans (and of the ends' coordinates, each rounded at |seg_s|) lost most of its digits
                        # where p is far from a short line (0.3% off 1e5 lengths away).
                        span = wp.atan2(seg_length * seg_h, seg_h * seg_h + end_a * end_b)
                        # Step the angle w = u1 * span from the end nearer the foot, placing the point by the tangent's
                        # addition formula (its offset from that end, no angle near pi / 2 rounded): phi_a + w rounded
                        # there, near the axis past an end, put the points 1% off.
                        seg_near = end_a
                        seg_near_at = -0.5 * seg_length
                        seg_w = u1 * span
                        if wp.abs(end_b) < wp.abs(end_a):
                            seg_near = end_b
                            seg_near_at = 0.5 * seg_length
                            seg_w = -seg_w
                        seg_sin = wp.sin(seg_w)
                        seg_offset = (seg_h * seg_h + seg_near * seg_near) * seg_sin
                        seg_offset = seg_offset / (seg_h * wp.cos(seg_w) - seg_near * seg_sin)
                        to = lights.position[k] + (seg_near_at + seg_offset) * seg_dir - p
                        out.dist = wp.length(to)
                        if out.dist > 0.0:
                            out.wi = to / out.dist
                            seg_value = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -out.wi))
                            out.value = seg_value * (span / out.dist)
                return out
        if kind == LIGHT_DOME:
            return sample_dome(lights, k, n, u1, u2)
        if kind == LIGHT_SPHERE:
            wi, t, one_minus = sample_sphere_cone(lights.position[k], lights.params[k][0], p, u1, u2)
            if one_minus <= 0.0:
                return out  # inside the sphere: it emits outwards only
            out.wi = wi
            out.dist = t
            out.pdf = 1.0 / (2.0 * PI * one_minus)
            out.value = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -out.wi)) * (2.0 * PI * one_minus)
            return out
        if wp.static(features.shape_lights):
            if kind == LIGHT_GLOWING_SPHERE:
                row = lights.glowing_spheres[k - lights.first_glowing_sphere]
                wi, t, g_one_minus = sample_sphere_cone(wp.vec3(row[0], row[1], row[2]), row[3], p, u1, u2)
                if g_one_minus <= 0.0:
                    return out  # inside the sphere: sampled from outside only (a hit inside takes MIS weight 1)
                out.wi = wi
                out.dist = t
                out.pdf = 1.0 / (2.0 * PI * g_one_minus)
                out.value = glow * (2.0 * PI * g_one_minus)
                return out
            if kind == LIGHT_GLOWING_HULL and not flat_shape(scene, lights.prims[k]):
                # In the cone of the ellipsoid around it, the light point the shape's first hit (wrt.glowing_hulls); a
                # plane or disk is drawn below, as a rect or disk light.
                prim = lights.prims[k]
                h_c, h_m, h_a, h_g, h_down = hull_frame(lights, k)
                wi, t, pdf = sample_hull(scene, prim, lights.instances[k], tri_double_sided[prim], h_c, h_m, h_a, h_g,
                                         h_down, p, u1, u2)
                if pdf > 0.0:
                    out.wi = wi
                    out.dist = t
                    out.pdf = pdf
                    out.value = glow / pdf
                return out
            if kind == LIGHT_ELLIPSOID:
                ell_down, ell_up = light_scales(lights, k)
                wi, t, pdf = sample_ellipsoid(lights.position[k] * ell_down, lights.shapes[k] * ell_down,
                                              lights.shape_inverses[k] * ell_up, lights.params[k][0] * ell_down,
                                              p * ell_down, u1, u2)
                if pdf > 0.0:
                    out.wi = wi
                    out.dist = t * ell_up
                    out.pdf = pdf
                    out.value = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -wi)) / pdf
                return out

        # Area sampling (rect and disk lights and glowing planes and disks that look large: by solid angle), cylinder,
        # triangle. Lengths and the area are taken times the light's power of two ``down`` (light_scales; triangles:
        # scaled_cross), exact where nothing over- or underflows: in world units a scene 1e20 across squared its
        # distances past float32.
        pdf_solid_angle = float(0.0)  # > 0: q was sampled by solid angle with this pdf
        area_share = float(0.0)  # > 0: mixed with a draw by area (clipped_area_share), pdf_solid_angle that draw's part
        q = wp.vec3(0.0)
        ln = wp.vec3(0.0)
        area = float(0.0)  # times down^2
        down, up = light_scales(lights, k)
        L = wp.vec3(0.0)
        two_sided = int(0)
        # Arvo's draw of a spherical triangle (wrt.spherical_triangle) at one call site (each call site compiled it
        # again) for an emissive triangle and for the half of a parallelogram picked by its share of the solid angle
        # (wrt.spherical_parallelogram): drawn where tri_omega > 0, towards the direction.
        flat = kind == LIGHT_RECT or kind == LIGHT_DISK or kind == LIGHT_GLOWING_HULL
        # A constant False where shape lights are left out: the tube branch below is then not compiled (wp.static).
        tube = wp.static(features.shape_lights)
        if tube:
            tube = kind == LIGHT_CYLINDER or kind == LIGHT_GLOWING_TUBE or kind == LIGHT_ELLIPTIC_TUBE
        f = FlatLight()
        sheared = SeenParallelogram()
        by_parallelogram = bool(False)  # f is a parallelogram drawn by its triangles' solid angles
        cosine_draw = bool(False)  # of those, a cosine-weighted direction
        half_omega = float(0.0)  # the solid angle of the half picked
        tri_a = wp.vec3(0.0)
        tri_b = wp.vec3(0.0)
        tri_c = wp.vec3(0.0)
        tri_cr = wp.vec3(0.0)
        tri_down = float(1.0)
        tri_omega = float(0.0)
        if flat:
            if wp.static(features.shape_lights):
                f = flat_light(lights, scene, k)
            else:
                f = rect_light(lights, k)
            if f.disk == 0 and f.right_angled == 0:
                sheared = seen_parallelogram(p, n, f.centre, f.u, f.v)
                if parallelogram_usable(sheared):
                    by_parallelogram = True
                    cosine_draw, u1 = by_cosine(sheared, u1)
                    if not cosine_draw:
                        tri_a, tri_b, tri_c, half_omega, u1 = pick_triangle(sheared, u1)
                        if triangle_by_solid_angle(half_omega):
                            tri_omega = half_omega
        elif kind == LIGHT_TRIANGLE:
            tri_a, tri_b, tri_c, tri_cr, tri_down = emitter_triangle(scene, lights.prims[k], lights.instances[k])
            tri_omega = seen_solid_angle(p, tri_a, tri_b, tri_c)
        towards = wp.vec3(0.0)
        if tri_omega > 0.0:
            towards = sample_spherical_triangle(p, tri_a, tri_b, tri_c, tri_omega, u1, u2)
        if flat:
            # One draw for both: a glowing plane or disk drawn in its ellipsoid's cone was as noisy as by area where a
            # point lies near it (a relative noise per draw of 41 at 0.01 over a unit square; by solid angle 0.03).
            if kind == LIGHT_GLOWING_HULL:
                L = glow
                two_sided = tri_double_sided[lights.prims[k]]
            else:
                L = lights.radiance[k]
            ln = f.normal
            area = f.area
            down = f.down
            seen, by_solid_angle, rect_down, rect_up = seen_rect(f, p)
            if by_solid_angle:
                area_share = clipped_area_share(seen, n)
            if by_parallelogram:  # (its pdf below: parallelogram_pdf)
                if cosine_draw or tri_omega > 0.0:  # q where the direction meets the plane, its height from the centre
                    w = towards
                    if cosine_draw:
                        w = to_world(sample_cosine_hemisphere(u1, u2), sheared.axis)
                    facing = wp.dot(w, ln)
                    if facing == 0.0:
                        return out
                    t = wp.dot(f.centre - p, ln) / facing
                    if not (t > 0.0):
                        return out
                    q = p + t * w
                    ab = plane_coords(f.u, f.v, q - f.centre)
                    if wp.abs(ab[0]) > 0.5 or wp.abs(ab[1]) > 0.5:
                        if cosine_draw:
                            return out  # it misses the light
                        # Arvo's point rounded off the edge is put back on it, where a ray along it finds the light.
                        q = f.centre + wp.clamp(ab[0], -0.5, 0.5) * f.u + wp.clamp(ab[1], -0.5, 0.5) * f.v
                else:  # a half that looks tiny: uniform by area within it
                    if half_omega <= 0.0:
                        return out
                    su = wp.sqrt(u1)
                    q = (1.0 - su) * tri_a + (su * (1.0 - u2)) * tri_b + (su * u2) * tri_c
            elif by_solid_angle and u1 >= area_share:
                u1 = (u1 - area_share) / (1.0 - area_share)
                q_down, inside = sample_spherical_rect(seen, n, u1, u2)  # q * rect_down
                if not inside:
                    return out
                pdf_solid_angle = spherical_rect_pdf(seen, n, q_down)
                q = q_down * rect_up
                if f.disk == 1:  # a point of the square around the disk: keep it if it lies on the disk
                    if wp.length_sq(plane_coords(f.u, f.v, q - f.centre)) > 1.0:
                        return out
            else:
                if area_share > 0.0:  # by area over the whole light, mixed with the draw by solid angle
                    u1 = u1 / area_share
                if f.disk == 0:
                    q = f.centre + (u1 - 0.5) * f.u + (u2 - 0.5) * f.v
                else:
                    dd = sample_concentric_disk(u1, u2)
                    q = f.centre + dd[0] * f.u + dd[1] * f.v
                if area_share > 0.0:
                    pdf_solid_angle = spherical_rect_pdf(seen, n, q * rect_down)  # 0 where the reach cut it off
            if kind != LIGHT_GLOWING_HULL:
                L = wp.cw_mul(L, light_texture(lights, k, q))
        elif tube:
            # Tubes, drawn by one call of sample_tube (a large function: each call site compiled it again) with the
            # tube's row, axis, taper, side and point of view:
            # - a cylinder light, an open single-sided tube (wrt.glowing_tubes): uniform by area over the half facing p
            #   and by the angles its side subtends, mixed; "area" is one over the mixture's density, in the tube's own
            #   lengths (down);
            # - a glowing tube, likewise over the part of it p can see the front of (the whole of a double-sided one);
            #   points facing away are dropped below;
            # - an elliptic tube, in its canonical frame as an open round tube, then mapped to the world
            #   (wrt.affine_lights; "area" = 1 / its area pdf).
            tube_row = UNIT_TUBE
            tube_axis = UNIT_TUBE_AXIS
            taper = float(1.0)
            one_sided = int(1)
            seen_from = p
            ell_c = wp.vec3(0.0)
            ell_m = wp.mat33(0.0)
            ell_a = wp.mat33(0.0)
            L = lights.radiance[k]
            if kind == LIGHT_CYLINDER:
                tube_row, tube_axis = cylinder_tube(lights, k)
            elif kind == LIGHT_GLOWING_TUBE:
                j = k - lights.first_glowing_sphere
                prim = lights.prims[k]
                two_sided = tri_double_sided[prim]
                tube_row = lights.glowing_spheres[j]
                tube_axis = lights.glowing_axes[j]
                taper = lights.glowing_tapers[j]
                one_sided = 1 - two_sided
                L = glow
            else:
                ell_c = lights.position[k] * down
                ell_m = lights.shapes[k] * down
                ell_a = lights.shape_inverses[k] * up
                seen_from = ell_a * (p * down - ell_c)
            q, ln, area, tube_down = sample_tube(tube_row, tube_axis, taper, seen_from, one_sided, u1, u2)
            if kind == LIGHT_ELLIPTIC_TUBE:
                q_down, ln, area = elliptic_tube_point(ell_c, ell_m, ell_a, q, ln, area)
                q = q_down * up
            else:
                down = tube_down
        else:
            prim = lights.prims[k]
            a = tri_a
            b = tri_b
            c = tri_c
            cr = tri_cr
            down = tri_down
            area = 0.5 * stable_length(cr)
            if area <= 0.0:
                return out
            ln = cr / (2.0 * area)
            bu = float(0.0)  # weight of b
            bv = float(0.0)  # weight of c
            omega = tri_omega
            if omega > 0.0:  # by solid angle (wrt.spherical_triangle): q where the direction meets the plane
                facing = wp.dot(towards, ln)
                if facing == 0.0:
                    return out
                q = p + (wp.dot(a - p, ln) / facing) * towards
                weights = triangle_weights(a, b, c, q, down)
                bu = weights[0]
                bv = weights[1]
                pdf_solid_angle = 1.0 / omega
            else:
                su = wp.sqrt(u1)
                bu = u2 * su
                bv = 1.0 - su  # (any uniform barycentric split works)
                q = (1.0 - bu - bv) * a + bu * b + bv * c
            bw = 1.0 - bu - bv
            st = bw * uvs[prim, 0] + bu * uvs[prim, 1] + bv * uvs[prim, 2]
            L = triangle_emission(lights, mats, k, tri_materials[prim], st)
            if cut_out(mats, tri_materials[prim], st):
                # A hole of an emissive cut-out: rays pass it and see no light there, so it sends none either.
                L = wp.vec3(0.0)
            two_sided = tri_double_sided[prim]
        # The direction and distance from q - p scaled by its own power of two (near a light 1e25 wide, times the
        # light's it underflowed), the area pdf's squared distance times the light's: both exact, the same bits.
        to = q - p
        to_down, to_up = unit_scales(to)
        to = to * to_down
        d2 = wp.length_sq(to)
        if d2 <= 0.0 or area <= 0.0:
            return out
        dist = wp.sqrt(d2)
        wi = to / dist
        cos_l = -wp.dot(wi, ln)
        if two_sided == 1:
            cos_l = wp.abs(cos_l)
        if cos_l <= 0.0:
            return out
        out.wi = wi
        out.dist = dist * to_up
        ratio = down * to_up  # |q - p| times the light's down: d2 times ratio^2
        if by_parallelogram:  # the expression flat_light_pdf reads back
            out.pdf = parallelogram_pdf(sheared, q, wi, d2 * ratio * ratio / (cos_l * area))
        elif area_share > 0.0:
            out.pdf = (1.0 - area_share) * pdf_solid_angle + area_share * (d2 * ratio * ratio / (cos_l * area))
        elif pdf_solid_angle > 0.0:
            out.pdf = pdf_solid_angle
        else:
            out.pdf = d2 * ratio * ratio / (cos_l * area)
        if kind != LIGHT_TRIANGLE and kind != LIGHT_GLOWING_TUBE and kind != LIGHT_GLOWING_HULL:  # (no shaping row)
            L = wp.cw_mul(L, emission_shaping(lights, k, -wi))
        out.value = L / out.pdf
        return out

    return sample_light


sample_light = sample_light_for(ALL_FEATURES)


@wp.func
def pick_in_group(lights: DeviceLights, first: int, count: int, u: float):
    """``(k, probability)``: one of lights ``[first, first + count)`` drawn by power with uniform ``u`` (whitted's light
    groups: one light alone, or the triangles ``[num_analytic, count)``), and the probability it was drawn with. The
    triangles are drawn by their own cdf, on the grid of ``u``, whose steps are exactly those probabilities: drawn by
    the lights' cdf from ``cdf[first] + u * (its rest)``, whose sum rounds, a triangle was drawn up to 2.5% more or
    less often than its pmf share said (200,000 triangles)."""
    if count <= 1:
        return first, 1.0
    base = first - lights.num_analytic
    j = sample_cdf(lights.emitter_cdf, base, count, u)
    whole = lights.emitter_cdf[base + count] - lights.emitter_cdf[base]
    return first + j, (lights.emitter_cdf[base + j + 1] - lights.emitter_cdf[base + j]) / whole


@functools.cache
def sample_light_in_view_for(features: LightFeatures):
    """:func:`sample_light_in_view` through :func:`sample_light_for` ``(features)``."""
    sample_light = sample_light_for(features)

    @wp.func
    def sample_light_in_view(
        lights: DeviceLights,
        scene: DeviceScene,
        mats: DeviceMaterials,
        uvs: wp.array2d[wp.vec2],
        tri_materials: wp.array[wp.int32],
        tri_double_sided: wp.array[wp.int32],
        k: int,
        view: int,
        p: wp.vec3,
        n: wp.vec3,
        u1: float,
        u2: float,
    ):
        """:func:`sample_light` for a path of camera ``view``: the default headlight (a delta distant light) arrives
        along that camera's viewing direction."""
        ls = sample_light(lights, scene, mats, uvs, tri_materials, tri_double_sided, k, p, n, u1, u2)
        if k == lights.headlight:
            ls.wi = -lights.headlight_dirs[view]
        return ls

    return sample_light_in_view


sample_light_in_view = sample_light_in_view_for(ALL_FEATURES)
