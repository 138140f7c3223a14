"""Device side of glowing hulls (:mod:`wrt.glowing_spheres` builds their rows): a glowing analytic shape not sampled as
a round sphere or tube (a box; an ellipsoid, an elliptic or sheared tube; a shape that glows inwards) is drawn through
the ellipsoid around it, the image ``M B`` of the unit ball under its row's map ``M`` (``A = M^-1``): a direction
uniform in the cone the unit ball subtends at the canonical point ``A (p - c)`` (every direction from inside it), mapped
to the world by ``M``, and the light point is the shape's first hit along it, found as camera rays find it
(:func:`wrt.primitives.intersect_shape`); nothing where the direction misses the shape or meets its back (a plane or
disk is drawn as a rect or disk light is instead, :func:`flat_shape`: in its ellipsoid's cone a point near it was as
noisy as by area). The direction's solid-angle pdf (:func:`wrt.affine_lights.mapped_cone_pdf`) depends on the direction
alone, so a ray that hits the shape reads it back exactly, whatever the shape. An ellipsoid is its own ellipsoid: every
direction hits it.

A box mixes in a draw by area over its faces that face the shading point (:data:`BOX_AREA_SHARE` of the draws;
none from inside it). Measured in float64 on a floor's irradiance under a cube, a thin panel and a bar, the cone
alone, whose directions miss the box past its silhouette, was noisy far from it (0.75 to 2.4 relative noise per
draw), and the area alone where the floor touches the box (24 per draw at 0.01 from a cube's bottom edge, 1 / d^2
there); mixed, 0.3 to 3.9. A face whose plane passes within :data:`FACE_PLANE_TOLERANCE` of the point is not drawn by
area (it is seen edge-on, and the cone covers it): path reads the pdf back at its BSDF ray's origin, the shading
point moved off its surface, and where that surface shares the face's plane (a box standing on the floor) rounding
put the shading point on the face's outer side and the origin on its inner one: the two pdfs differed, their MIS
weights did not sum to 1, and the floor by the box came out 5 to 13% dark. For the same reason a point within
:data:`CONE_TOLERANCE` of the ellipsoid counts as inside it (its surface is the shape's for spheres and ellipsoids:
on the wall of a sphere that glows inwards, rounding put half the points outside, drawn in a hemisphere, and path's
ray origin inside, read back over every direction). The first hit is sought past :data:`SELF_HIT` of the lengths
about (the point's and the ellipsoid's): from a point on the shape itself the draw met the shape at distance 0, the
back of its inward face, and drew nothing (the wall of a grey inward sphere lit by itself showed half its light). A
nearer hit is read back with pdf 0, as the draw makes it: read back as the cone's pdf, MIS weighed down the light
that path's BSDF rays alone bring from there (a floor within 0.01 of a box 1e4 from the origin showed 0.90 of it).

Lengths are taken times the power of two ``down`` that brings the ellipsoid's largest semi-axis into [1, 2).
"""

import warp as wp

from .affine_lights import mapped_cone_pdf, sample_mapped_cone, unit_sphere_cone
from .floats import largest_magnitude
from .geometry import stable_length
from .primitives import SHAPE_BOX, SHAPE_DISK, SHAPE_PLANE, intersect_shape
from .scene import DeviceScene
from .shade import shape_frame, shape_ray
from .transforms import normal_to_world

# The share of a box's draws by the area of its faces that face the shading point (the rest in its ellipsoid's cone).
BOX_AREA_SHARE = wp.constant(0.75)
# A box's ellipsoid has its half edges times sqrt(3) as semi-axes (wrt.glowing_spheres.HULL_FACTORS).
ROOT3 = wp.constant(1.7320508075688772)
# How far off a face's plane, in half edges, a point must lie for the face to be drawn by area: past the rounding of a
# point in the plane and past the offset of a ray's origin from a surface there (1e-6 of the surface's size:
# REACH_OFFSET) for a box down to 1/16000 of a floor's size.
FACE_PLANE_TOLERANCE = wp.constant(2.0**-6)
# How far past the unit sphere, in |pc|^2, a canonical point still draws over every direction (as for the faces).
CONE_TOLERANCE = wp.constant(2.0**-6)
# The first hit's least distance, over the largest coordinate of the point and the ellipsoid's centre plus its size
# (in lengths times down): past the rounding of a point on the shape (a few float32 epsilons of them).
SELF_HIT = wp.constant(2.0**-20)


@wp.func
def flat_shape(scene: DeviceScene, prim: int):
    """Whether analytic shape ``prim`` is a plane or a disk, drawn as a rect or disk light is
    (:func:`wrt.light_sampling.flat_hull`), not in its ellipsoid's cone."""
    kind = scene.shape_kinds[prim - scene.num_prims]
    return kind == SHAPE_PLANE or kind == SHAPE_DISK


@wp.func
def flat_front(scene: DeviceScene, prim: int, instance: int):
    """A world vector (not unit) along the front normal of plane or disk ``prim`` drawn by ``instance`` (-1: a world
    shape): canonical +Z (-Z where ``params[3] < 0``) turned as :func:`wrt.shade.shape_frame` turns a hit's normal.
    Brought to a largest component of 1 between the shape's and the instance's turn, so that it neither over- nor
    underflows."""
    j = prim - scene.num_prims
    front = wp.where(scene.shape_params[j][3] < 0.0, -1.0, 1.0)
    n = normal_to_world(scene.shape_to_local[j], wp.vec3(0.0, 0.0, front))
    if instance >= 0:
        n = normal_to_world(scene.world_to_local[instance], n / largest_magnitude(n))
    return n


@wp.func
def hull_cone(pc: wp.vec3):
    """``1 - cos`` of the canonical cone directions are drawn in from canonical point ``pc``: the unit ball's, or
    every direction (2) from inside it or within :data:`CONE_TOLERANCE` of it; 0 where the ball is too far to subtend
    a float32 cone."""
    if wp.length_sq(pc) <= 1.0 + CONE_TOLERANCE:
        return 2.0
    return unit_sphere_cone(pc)


@wp.func
def box_faces(m: wp.mat33, pb: wp.vec3):
    """The area of each axis' face of the box (its ellipsoid's map ``m``: edges ``2 m / sqrt 3``) that faces the
    point at box coordinates ``pb`` (``[-1, 1]^3`` the box), 0 where ``pb`` lies between that axis' two faces or
    within :data:`FACE_PLANE_TOLERANCE` of their planes."""
    cx = m * wp.vec3(1.0, 0.0, 0.0)
    cy = m * wp.vec3(0.0, 1.0, 0.0)
    cz = m * wp.vec3(0.0, 0.0, 1.0)
    areas = wp.vec3(wp.length(wp.cross(cy, cz)), wp.length(wp.cross(cz, cx)), wp.length(wp.cross(cx, cy)))
    for i in range(3):
        if wp.abs(pb[i]) <= 1.0 + FACE_PLANE_TOLERANCE:
            areas[i] = 0.0
    return areas * (4.0 / 3.0)


@wp.func
def hit_face(qb: wp.vec3):
    """The axis of the box's face that box coordinates ``qb`` (a point on the box) lie on: their largest."""
    i = int(0)
    if wp.abs(qb[1]) > wp.abs(qb[i]):
        i = 1
    if wp.abs(qb[2]) > wp.abs(qb[i]):
        i = 2
    return i


@wp.func
def first_hit(scene: DeviceScene, prim: int, instance: int, p: wp.vec3, w: wp.vec3, t_min: float):
    """``(t, n)``: the distance along unit ``w`` from ``p`` to analytic shape ``prim``'s first hit past ``t_min``
    (drawn by ``instance``; inf: none) and the unit front normal there."""
    oc, dc = shape_ray(scene, prim, instance, p, w)
    j = prim - scene.num_prims
    t = intersect_shape(scene.shape_kinds[j], scene.shape_params[j], oc, dc, t_min, float(wp.inf))
    if t == wp.inf:
        return t, wp.vec3(0.0)
    q, n, reach, err = shape_frame(scene, prim, instance, p, w, t)
    # The world normal A^T n is as long as the shape is small: normalised by its squares, which overflowed float32
    # for a box 1e-19 wide, it lit nothing (stable_length scales them as shading does).
    length = stable_length(n)
    if length <= 0.0:
        return float(wp.inf), wp.vec3(0.0)
    return t, n / length


@wp.func
def self_hit_distance(c: wp.vec3, down: float, p: wp.vec3):
    """How near ``p`` (times ``down``) a hit of the shape whose ellipsoid's centre is ``c`` may lie for a draw to take
    it: :data:`SELF_HIT` of the point's and the ellipsoid's largest coordinates plus its size (below 2), in lengths
    times ``down``."""
    return SELF_HIT * (largest_magnitude(p * down) + largest_magnitude(c) + 2.0)


@wp.func
def hull_pdf(scene: DeviceScene, prim: int, c: wp.vec3, m: wp.mat33, a: wp.mat33, g: float, down: float, p: wp.vec3,
             w: wp.vec3, dist: float, n: wp.vec3):
    """Solid-angle pdf with which :func:`sample_hull` draws unit direction ``w`` from ``p`` towards shape ``prim``
    (its ellipsoid: centre ``c``, map ``m``, inverse ``a``, cube root ``g``, all in lengths times ``down``); a box's
    mixed with the area draw's density at its hit ``dist`` along ``w`` (unit normal ``n``). 0 for a hit nearer than
    :func:`self_hit_distance`, which the draw passes by."""
    if dist * down < self_hit_distance(c, down, p):
        return 0.0
    pc = a * (p * down - c)
    one_minus = hull_cone(pc)
    pdf = float(0.0)
    if one_minus > 0.0:
        pdf = mapped_cone_pdf(a, g, one_minus, w)
    if scene.shape_kinds[prim - scene.num_prims] == SHAPE_BOX:
        areas = box_faces(m, ROOT3 * pc)
        total = areas[0] + areas[1] + areas[2]
        if total > 0.0:
            d = dist * down
            cos_l = wp.abs(wp.dot(w, n))
            by_area = float(0.0)
            # Only a face the area draw takes: a point within FACE_PLANE_TOLERANCE off a face's plane sees that
            # face (edge-on) without drawing it by area.
            if cos_l > 0.0 and areas[hit_face(ROOT3 * (pc + a * (w * d)))] > 0.0:
                by_area = d * d / (cos_l * total)
            pdf = BOX_AREA_SHARE * by_area + (1.0 - BOX_AREA_SHARE) * pdf
    return pdf


@wp.func
def sample_hull(scene: DeviceScene, prim: int, instance: int, double_sided: int, c: wp.vec3, m: wp.mat33,
                a: wp.mat33, g: float, down: float, p: wp.vec3, u1: float, u2: float):
    """``(w, t, pdf)``: a unit direction from ``p`` to the first hit of glowing shape ``prim`` (drawn by
    ``instance``; its ellipsoid as :func:`hull_pdf` takes it), the distance to it and its solid-angle pdf (0: the
    direction missed the shape or met its back, nothing drawn)."""
    pc = a * (p * down - c)
    pb = ROOT3 * pc
    share = float(0.0)
    areas = wp.vec3(0.0)
    total = float(0.0)
    if scene.shape_kinds[prim - scene.num_prims] == SHAPE_BOX:
        areas = box_faces(m, pb)
        total = areas[0] + areas[1] + areas[2]
        if total > 0.0:
            share = BOX_AREA_SHARE
    w = wp.vec3(0.0, 0.0, 1.0)
    if u1 < share:
        # A face by its area, then a point uniform on it: u1's place within the face's share is one coordinate.
        left = u1 / share * total
        i = int(0)
        along = float(0.0)
        for axis in range(3):
            if areas[axis] > 0.0 and left >= 0.0:
                i = axis
                along = left / areas[axis]
                left -= areas[axis]
        along = wp.clamp(along, 0.0, 1.0) * 2.0 - 1.0
        qb = wp.vec3(0.0)
        qb[i] = wp.where(pb[i] > 0.0, 1.0, -1.0)
        qb[(i + 1) % 3] = along
        qb[(i + 2) % 3] = 2.0 * u2 - 1.0
        w = wp.normalize(c + m * (qb / ROOT3) - p * down)
    else:
        one_minus = hull_cone(pc)
        if one_minus <= 0.0:
            return w, float(wp.inf), 0.0
        w = sample_mapped_cone(m, pc, one_minus, (u1 - share) / (1.0 - share), u2)
    t, n = first_hit(scene, prim, instance, p, w, self_hit_distance(c, down, p) / down)
    if t == wp.inf:
        return w, t, 0.0
    cos_l = -wp.dot(w, n)
    if double_sided == 1:
        cos_l = wp.abs(cos_l)
    if cos_l <= 0.0:
        return w, t, 0.0
    return w, t, hull_pdf(scene, prim, c, m, a, g, down, p, w, t, n)
