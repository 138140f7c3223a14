"""Device side of glowing round tubes as lights (:mod:`wrt.glowing_spheres` builds their rows): a point drawn
uniformly by area over a cylinder's or cone's side (and its caps, where capped), a capsule's side and hemispheres or a
tapered capsule's cone and sphere zones,
the part of them a shading point can see the front of for a single-sided tube, and that part's area, in closed form;
mixed with a draw of the side by the angles it subtends (:mod:`wrt.subtended_tube`: drawn by area alone, a point
0.01 radii off a long cylinder estimated its light 250 times as noisily) and, for a capsule or tapered capsule, a
draw of each end by the cone its sphere subtends (:mod:`wrt.sphere_cone`), kept where the direction enters the
sphere on that end and dropped (nothing drawn) where it enters it inside the capsule: convex, the capsule shows p an
end point just where the sphere does, from outside, so the cone's density there is its solid-angle pdf times ``cos /
d^2`` for a point drawn and a point a ray hits alike (by area alone, a point 0.02 radii off an end estimated its
light with a relative noise of 20 to 210 per draw, now 0.65) or, for a capped tube, a draw of the cap p lies beyond
as a disk light's (:mod:`wrt.tube_caps`: by the solid angle of the square around it, kept on the disk; by area
alone, a point 0.02 to 0.05 radii off a cap estimated its light with a relative noise of 12 to 110, now 0.7). The
mixture's density in closed form (:func:`tube_density`; it sums to the share of draws kept) turns into a solid-angle
pdf ``dist^2 density / |cos|`` for both light sampling and the MIS weight of a ray that hits the tube.

Lengths are taken times the power of two ``down`` that brings the tube's largest length (its radius or a component of
its half axis) into [1, 2): the area in world units squared overflowed float32 for a tube 1e19 across.
"""

import warp as wp

from .floats import largest_magnitude, power_scales
from .glowing_spheres import GLOW_CAPPED_CYLINDER, GLOW_CAPSULE, GLOW_OPEN_CYLINDER, GLOW_TAPERED_CAPSULE
from .sampling import PI, basis_x, basis_y, sample_uniform_sphere
from .sphere_cone import cone_of_sphere, sample_sphere_cone
from .subtended_tube import sample_subtended, subtended_density
from .tube_caps import cap_density, cap_weight, sample_cap

TUBE_OPEN = wp.constant(GLOW_OPEN_CYLINDER)  # also a UsdLux CylinderLight's (wrt.light_sampling)
TUBE_CAPPED = wp.constant(GLOW_CAPPED_CYLINDER)
TUBE_CAPSULE = wp.constant(GLOW_CAPSULE)
TUBE_TAPERED = wp.constant(GLOW_TAPERED_CAPSULE)
# The share of sample_tube's draws made by the angles the side subtends (wrt.subtended_tube) and by the cones a
# capsule's end spheres subtend, where they can draw (side_view splits it): the rest, uniform by area, reach all.
SUBTENDED_SHARE = wp.constant(0.9)
# Farther than this from the side's centre (lengths times down: the tube's largest about 1), the draw by area alone:
# there the two draws are alike, and the subtended draw's cubed distances would overflow float32.
SUBTENDED_FAR = wp.constant(1.0e4)
# Within this share of the side's larger radius of a cone's apex plane, the subtended draw's share fades to 0.
APEX_FADE = wp.constant(0.1)


@wp.func
def tube_scales(row: wp.vec4, axis: wp.vec4):
    """``(down, up = 1 / down)`` of the tube of ``row`` (world centre, radius) and ``axis`` (half axis, code)."""
    return power_scales(wp.max(row[3], largest_magnitude(wp.vec3(axis[0], axis[1], axis[2]))))


@wp.func
def tube_axis(axis: wp.vec4, down: float):
    """``(w, h)``: the unit axis (towards the top) and half length (times ``down``) of the tube of ``axis``."""
    half = wp.vec3(axis[0], axis[1], axis[2]) * down
    h = wp.length(half)
    w = wp.vec3(0.0, 0.0, 1.0)
    if h > 0.0:
        w = half / h
    return w, h


@wp.func
def cone_reach(r: float, top: float, h: float, z: float):
    """The radius at height ``z`` of the cone of radii ``r`` (at ``-h``) and ``top`` (at ``h``) extended past its
    ends (negative past its apex)."""
    return 0.5 * (r + top) - (r - top) * z / (2.0 * h)


@wp.func
def facing_arc(r: float, top: float, h: float, to_p: wp.vec3, w: wp.vec3):
    """Half the angle about the axis, centred on the shading point's direction ``to_p`` from the centre, of the side
    :func:`sample_tube` draws from for a single-sided tube of radii ``r`` (bottom) and ``top`` and half length ``h``
    (lengths times ``down``).

    A cylinder's is a right angle: its half facing p, of constant area. A cone's tangent plane is the same all along
    a straight line of its side, and p sees the front of the line at angle ``a`` from its own direction just where
    ``rho cos a`` passes the cone's radius extended to p's height (``rho``: p's distance from the axis): the arc
    ``acos(radius / rho)``, none where p lies inside the cone's extension, all round past its apex."""
    if top == r or h <= 0.0:
        return 0.5 * PI
    z = wp.dot(to_p, w)
    rho = wp.length(to_p - z * w)
    reach = cone_reach(r, top, h, z)
    if rho <= reach:
        return 0.0
    if rho <= -reach:
        return PI
    return wp.acos(reach / rho)


@wp.func
def tube_side(r: float, top: float, h: float, code: int):
    """``(mid, half, bottom, top, sin_lat)``: the cylinder or cone of the side of a tube of radii ``r`` and ``top``
    and half axis ``h`` (lengths times ``down``): its centre's offset along the axis, half length and end radii, and
    for a tapered capsule the sine of the latitude where it touches the spheres (its normal's lean up the axis; the
    cone tangent to both spheres meets the bottom one at ``-h + r sin``, the top one at ``h + top sin``, its radii
    ``cos`` times theirs), 0 for the others, whose side runs between their ends."""
    if code != TUBE_TAPERED:
        return 0.0, h, r, top, 0.0
    sin_lat = wp.min((r - top) / (2.0 * h), 1.0)  # 1: the top sphere lies inside the bottom one, the side is empty
    cos_lat = wp.sqrt(wp.max(1.0 - sin_lat * sin_lat, 0.0))
    z0 = -h + r * sin_lat
    z1 = h + top * sin_lat
    return 0.5 * (z0 + z1), wp.max(0.5 * (z1 - z0), 0.0), r * cos_lat, top * cos_lat, sin_lat


@wp.func
def tube_area(row: wp.vec4, axis: wp.vec4, taper: float, down: float, facing: int, to_p: wp.vec3):
    """``(area, side, arc)``: the area (times ``down^2``) that :func:`sample_tube` draws from, its side's share of it
    (the cylinder or cone between the caps, hemispheres or, for a tapered capsule, sphere zones: :func:`tube_side`)
    and the half angle of the side's arc about the axis: the whole surface, or with ``facing`` 1 the side's arc that
    can face the shading point (``to_p`` from the centre, times ``down``: :func:`facing_arc`), a cylinder's one cap on
    its side of the centre (a cone's two: see below) and both hemispheres or sphere zones. ``taper``: the top radius
    over the bottom one (``row[3]``).

    A cone's caps differ in area, so drawing the one on p's side made the area jump where p crosses the plane
    through the centre; path weighs a hit by the density from the ray's origin, its last shading point moved off
    the surface, while light sampling drew from that point: on a floor through the centre's plane the two fell on
    either side and the floor came out 7% dark. Both caps keep the area continuous in p (a cylinder's are equal)."""
    r = row[3] * down
    top = r * taper
    w, h = tube_axis(axis, down)
    code = int(axis[3])
    mid, h_side, r_side, top_side, sin_lat = tube_side(r, top, h, code)
    # pi (r1 + r2) times the slant length
    side = PI * (r_side + top_side) * wp.sqrt(4.0 * h_side * h_side + (r_side - top_side) * (r_side - top_side))
    arc = PI
    ends = float(0.0)
    if code == TUBE_CAPPED:
        ends = PI * (r * r + top * top)
        if facing == 1 and top == r:
            ends = PI * r * r
    elif code == TUBE_CAPSULE:
        ends = 4.0 * PI * r * r  # two hemispheres
    elif code == TUBE_TAPERED:
        ends = 2.0 * PI * (r * r * (1.0 + sin_lat) + top * top * (1.0 - sin_lat))  # the zones below and above
    if facing == 1:
        arc = facing_arc(r_side, top_side, h_side, to_p - mid * w, w)
        side = side * (arc / PI)
    return side + ends, side, arc


@wp.func
def segment_distance(x: float, y: float, x0: float, y0: float, x1: float, y1: float):
    """The distance from ``(x, y)`` to the segment from ``(x0, y0)`` to ``(x1, y1)``."""
    ex = x1 - x0
    ey = y1 - y0
    t = wp.clamp(((x - x0) * ex + (y - y0) * ey) / wp.max(ex * ex + ey * ey, 1e-30), 0.0, 1.0)
    return wp.sqrt((x - x0 - t * ex) * (x - x0 - t * ex) + (y - y0 - t * ey) * (y - y0 - t * ey))


@wp.func
def end_distance(r: float, top: float, h: float, code: int, rho: float, z: float):
    """The distance from the point ``rho`` from the axis and ``z`` along it from the centre to the nearer of the
    tube's caps (radii ``r`` at ``-h``, ``top`` at ``h``) or spheres (a capsule's, a tapered capsule's); a large
    number for an open tube, which has none."""
    if code == TUBE_CAPPED:
        return wp.min(segment_distance(rho, z, 0.0, -h, r, -h), segment_distance(rho, z, 0.0, h, top, h))
    if code == TUBE_CAPSULE or code == TUBE_TAPERED:
        below = wp.abs(wp.sqrt(rho * rho + (z + h) * (z + h)) - r)
        return wp.min(below, wp.abs(wp.sqrt(rho * rho + (z - h) * (z - h)) - top))
    return SUBTENDED_FAR * 4.0


@wp.func
def side_view(r: float, top: float, h: float, code: int, w: wp.vec3, to_p: wp.vec3, facing: int, arc: float):
    """``(mid, ra, rb, half, reach, spread, rho, z, phi_p, share, low, high)``: the side (:func:`tube_side`, lengths
    times ``down``) and shading point (``to_p`` from the centre) as :mod:`wrt.subtended_tube` takes them (``reach``,
    ``spread``: its draw's arguments), p's angle about the axis from ``basis_x(w)``, and the shares of draws
    :func:`sample_tube` makes by the angles the side subtends (``share``: none where that draw has nothing to draw
    from, a single-sided tube's side p sees no front of, from inside its extension, past a cone's apex or far away;
    continuous in p: faded in from a cone's apex plane and, past the side's slab, from a single-sided side's extension)
    and by the cones a capsule's bottom and top spheres subtend (``low``, ``high``: none from inside the capsule, far
    away, or for a tapered capsule's top sphere inside its bottom one; continuous in p outside the capsule) or, for a
    capped tube, by its bottom and top caps' disk draws (:mod:`wrt.tube_caps`: none but for a cap p lies beyond)."""
    mid, half, ra, rb, sin_lat = tube_side(r, top, h, code)
    rel = to_p - mid * w
    z = wp.dot(rel, w)
    px = wp.dot(rel, basis_x(w))
    py = wp.dot(rel, basis_y(w))
    rho = wp.sqrt(px * px + py * py)
    phi_p = wp.atan2(py, px)
    reach = float(0.0)
    spread = float(0.0)
    fade = float(0.0)
    near = wp.max(rho, wp.abs(z)) < SUBTENDED_FAR
    if half > 0.0 and ra + rb > 0.0 and near:
        reach = cone_reach(ra, rb, half, z)
        # Past a cone's apex (reach <= 0) the draw by area alone, faded in from the apex's plane: drawn there by the
        # angles too, in the arc p sees the front of, the density jumped at that plane (a floor there would get its
        # light samples' density from one side of it and its hits' from its rays' origins just off it).
        fade = wp.clamp(reach / (APEX_FADE * wp.max(ra, rb)), 0.0, 1.0)
        if reach >= rho:
            reach = 0.0
            if facing == 0:
                spread = arc  # inside a double-sided tube or its extension: all round
    share = float(0.0)
    if fade > 0.0 and (reach > 0.0 or spread > 0.0):
        # Less of it the nearer p lies to the caps or spheres than to the side, which only the draw by area reaches
        # (continuous in p: path weighs a hit by the density from its ray's origin, just off the shading point).
        near_end = end_distance(r, top, h, code, rho, z + mid)
        to_side = segment_distance(rho, z, ra, -half, rb, half)
        share = SUBTENDED_SHARE * fade
        if near_end + to_side > 0.0:
            share = share * near_end * near_end / (near_end * near_end + to_side * to_side)
        if facing == 1:
            # Past the side's slab, none as p nears the side's extension, inside which a single-sided side shows p
            # no front (share 0 there): times ``off / (off + past)``. Cut off at it, the density jumped 45-50% at a
            # capped tube's cap p sees from both sides of it (path reads a hit's density from its ray's origin).
            off = rho - reach
            past = wp.max(wp.abs(z) - half, 0.0)
            share = share * off / (off + past)
    low = float(0.0)
    high = float(0.0)
    # (From inside the capsule, the cones enter their spheres inside it: none of their draws would be kept. Inside
    # the side's frustum here; inside an end sphere below.)
    inside = half > 0.0 and wp.abs(z) <= half and rho < cone_reach(ra, rb, half, z)
    if (code == TUBE_CAPSULE or code == TUBE_TAPERED) and near and not inside:
        # The rest of the guided share to a capsule's end spheres' cones, each by the square root of the share of
        # p's sky its cone fills (1 - cos_max: near all of it just off the sphere, none from inside), at most all
        # between them: by that share itself, points 0.3 to 3 radii off an end were up to 1.8 times as noisy; by
        # inverse squared distances, a third of the draws far beside a long capsule fell behind its side (dropped).
        cos_low, low = cone_of_sphere(-h * w, r, to_p)
        cos_high = float(0.0)
        if sin_lat < 1.0 and top > 0.0:  # (else the top sphere lies inside the bottom one)
            cos_high, high = cone_of_sphere(h * w, top, to_p)
        # Inside an end sphere (cos_max 2) p is inside the capsule too, past the side's slab as well: the other
        # end's cone, drawn there, lost every draw (2.5% to 8% from inside an end sphere past the side).
        inside_end = wp.max(cos_low, cos_high) > 1.0
        low = wp.where(inside_end, 0.0, wp.sqrt(low))
        high = wp.where(inside_end, 0.0, wp.sqrt(high))
    if code == TUBE_CAPPED and near:
        # A capped tube's caps by the disk draw (wrt.tube_caps), the one p lies beyond, weighted alike by the square
        # root of the share of p's sky the square around it fills (cap_weight: continuous in p off the cap): by area
        # alone, a point 0.02 radii off a cap estimated its light with a relative noise of 12 to 110 per draw.
        low = cap_weight(-1.0, r, h, w, to_p)
        high = cap_weight(1.0, top, h, w, to_p)
    rest = (SUBTENDED_SHARE - share) / wp.max(1.0, low + high)
    low = low * rest
    high = high * rest
    return mid, ra, rb, half, reach, spread, rho, z, phi_p, share, low, high


@wp.func
def end_sign(q_rel: wp.vec3, w: wp.vec3, mid: float, half: float, code: int):
    """1 for a point ``q_rel`` (from the centre) of a capsule's top end, the one above the side's middle ``mid``
    (:func:`side_view`), -1 for one of its bottom end: all of a tapered capsule's with no side (``half`` 0: its top
    sphere inside its bottom one)."""
    return wp.where(wp.dot(q_rel, w) >= mid and (half > 0.0 or code == TUBE_CAPSULE), 1.0, -1.0)


@wp.func
def end_cone_density(centre: wp.vec3, radius: float, to_p: wp.vec3, q_rel: wp.vec3):
    """Density by area with which a direction uniform in the cone the sphere of ``centre`` and ``radius`` subtends
    at p (``to_p``; all from the tube's centre, times ``down``) enters the sphere at its point ``q_rel``: the cone's
    solid-angle pdf times ``cos / d^2`` where the point faces p; 0 where it does not (rays enter the sphere on the
    side facing p), or from inside."""
    cos_max, one_minus = cone_of_sphere(centre, radius, to_p)
    v = to_p - q_rel
    facing = wp.dot(v, q_rel - centre) / radius
    if cos_max > 1.0 or one_minus <= 0.0 or facing <= 0.0:
        return 0.0
    d2 = wp.length_sq(v)
    return facing / (d2 * wp.sqrt(d2) * 2.0 * PI * one_minus)


@wp.func
def tube_density(r: float, top: float, h: float, code: int, w: wp.vec3, to_p: wp.vec3, facing: int, area: float,
                 arc: float, q_rel: wp.vec3, on_side: int):
    """Density by area (lengths times ``down``) with which :func:`sample_tube` draws the point ``q_rel`` from the
    centre (``on_side`` 1: on the side; the rest is caps or spheres), p ``to_p`` from it, ``area`` and ``arc`` as
    :func:`tube_area` gives them: the draw uniform by area's ``1 / area``, the draw by the angles the side subtends
    and, on a capsule's end (the top sphere's above the side's middle), the draw by that sphere's cone or, on a cap,
    its disk draw, mixed."""
    mid, ra, rb, half, reach, spread, rho, z, phi_p, share, low, high = side_view(r, top, h, code, w, to_p, facing,
                                                                                  arc)
    density = (1.0 - share - low - high) / area
    if on_side == 0 and low + high > 0.0 and code == TUBE_CAPPED:
        end = wp.where(wp.dot(q_rel, w) >= 0.0, 1.0, -1.0)  # a cap: its disk draw's, where it draws
        weight = wp.where(end > 0.0, high, low)
        if weight > 0.0:  # (the other cap's square may have a solid angle float32 rounds to 0: an infinite pdf)
            density += weight * cap_density(end, wp.where(end > 0.0, top, r), h, w, to_p, q_rel)
    elif on_side == 0 and low + high > 0.0:
        end = end_sign(q_rel, w, mid, half, code)  # a capsule's end: its sphere's cone's
        density += wp.where(end > 0.0, high, low) * end_cone_density(end * h * w, wp.where(end > 0.0, top, r), to_p,
                                                                     q_rel)
    if on_side == 1 and share > 0.0:
        rel = q_rel - mid * w
        delta = wp.atan2(wp.dot(rel, basis_y(w)), wp.dot(rel, basis_x(w))) - phi_p
        if delta > PI:
            delta = delta - 2.0 * PI
        if delta < -PI:
            delta = delta + 2.0 * PI
        qz = wp.dot(rel, w)
        along = (qz + half) / (2.0 * half)
        if wp.abs(rb - ra) > 2.0 * half:
            # A frustum wider than long (a near-flat ring): the point's radius places it along the side better than
            # its height, which the side spans less of; by the height, the point's float32 rounding moved it up to
            # 500 times as far along a ring 1e-3 radii long, and the density (growing as the inverse cube of the
            # distance near p) was read back 2% off from 1e-3 radii, 20% from 1e-4.
            along = (wp.length(rel - qz * w) - ra) / (rb - ra)
        density += share * subtended_density(ra, rb, half, reach, spread, rho, z, delta, along)
    return density


@wp.func
def sample_tube(row: wp.vec4, axis: wp.vec4, taper: float, p: wp.vec3, facing: int, u1: float, u2: float):
    """``(q, n, area, down)``: a point ``q`` on the tube drawn for shading point ``p``, its unit outward normal
    ``n``, one over the density by area it was drawn with (times ``down^2``; 0: nothing drawn) and the tube's
    ``down`` (:func:`tube_scales`). ``taper``: a cone's top radius over its bottom one (a tapered capsule's
    spheres'), 1 for cylinders and capsules.

    Draws mixed (:func:`tube_density`): by the angles the side subtends from ``p`` (:mod:`wrt.subtended_tube`) and,
    for a capsule, by the cones its end spheres subtend or, for a capped tube, by the solid angles of its caps
    (``SUBTENDED_SHARE`` of the draws between them where they can draw: :func:`side_view`; a cone's draw is dropped,
    nothing drawn, where it enters the sphere off its end, a cap's where it lands off the disk),
    and uniformly by area over the part of the tube :func:`tube_area` names for ``p`` (its side, caps, hemispheres
    or zones chosen in proportion to their areas).
    ``facing`` 1 (a single-sided tube) leaves out what ``p`` cannot see the front of: the points of the side off
    :func:`facing_arc` (for a cylinder, those whose outward normal makes more than a right angle with ``p``'s
    direction from the axis: seen from outside the tube, the front of a side point shows only to points past its
    tangent plane, which lie in that half), and a cylinder's cap on the other side of the centre. A ray from ``p``
    that hits the tube's front therefore hits a part drawn from, at the density :func:`tube_pdf` reads back."""
    down, up = tube_scales(row, axis)
    c = wp.vec3(row[0], row[1], row[2])
    to_p = (p - c) * down
    area, side, arc = tube_area(row, axis, taper, down, facing, to_p)
    half = wp.vec3(axis[0], axis[1], axis[2])
    r = row[3]
    w, h_down = tube_axis(axis, down)
    code = int(axis[3])
    _, _, _, _, sin_lat = tube_side(r * down, r * down * taper, h_down, code)  # the rest: side_view's below
    bx = basis_x(w)
    by = basis_y(w)
    above = wp.where(wp.dot(to_p, w) >= 0.0, 1.0, -1.0)  # the side of the centre p lies on, along the axis
    q = c
    n = w
    if area <= 0.0:
        return q, n, 0.0, down
    mid, r_side, top_side, h_side, reach, spread, rho, z, phi_p, by_angle, low, high = side_view(
        r * down, r * down * taper, h_down, code, w, to_p, facing, arc)
    on_side = int(0)
    guided = by_angle + low + high
    if u1 < by_angle:
        delta, qz, drawn = sample_subtended(r_side, top_side, h_side, reach, spread, rho, z, u1 / by_angle, u2)
        if drawn == 0:
            return q, n, 0.0, down
        phi = phi_p + delta
        radial = wp.cos(phi) * bx + wp.sin(phi) * by
        along = (qz + h_side) / (2.0 * h_side)
        q = c + ((mid + qz) * up) * w + ((r_side + (top_side - r_side) * along) * up) * radial
        n = radial
        if taper != 1.0:  # a cone's normal leans towards its top by the slope of its radius
            n = wp.normalize(2.0 * h_side * radial + (r_side - top_side) * w)
        on_side = 1
    elif u1 < guided and code == TUBE_CAPPED:
        # A cap by its disk draw (wrt.tube_caps), kept where it lands on the disk.
        end = wp.where(u1 < by_angle + low, -1.0, 1.0)
        u_end = wp.where(end > 0.0, (u1 - by_angle - low) / high, (u1 - by_angle) / low)
        q_rel, kept = sample_cap(end, r * down * wp.where(end > 0.0, taper, 1.0), h_down, w, to_p, wp.min(u_end, 1.0),
                                 u2)
        if not kept:
            return q, n, 0.0, down
        q = c + q_rel * up
        n = end * w
    elif u1 < guided:
        # A capsule's end sphere by the cone it subtends: where the direction enters the sphere, kept on the end
        # (the rest of the sphere's near side lies inside the capsule, behind its side or other end).
        end = wp.where(u1 < by_angle + low, -1.0, 1.0)
        ball = r * down * wp.where(end > 0.0, taper, 1.0)
        centre = end * h_down * w
        u_end = wp.where(end > 0.0, (u1 - by_angle - low) / high, (u1 - by_angle) / low)
        wi, t, one_minus = sample_sphere_cone(centre, ball, to_p, wp.min(u_end, 1.0), u2)
        n = wp.normalize(to_p + t * wi - centre)
        off_end = end_sign(centre + ball * n, w, mid, h_side, code) != end
        if one_minus <= 0.0 or wp.abs(wp.dot(centre + ball * n, w) - mid) < h_side or off_end:
            return q, n, 0.0, down
        q = c + (centre + ball * n) * up
    else:
        ua = (u1 - guided) / (1.0 - guided)
        share = side / area  # of the side
        if ua < share:
            f = ua / share
            on_side = 1
            # From the bottom along the side, with density proportional to the radius 1 - (1 - taper) s (uniform by
            # area): its CDF inverted in closed form, in the form without a cancellation (s = f for a cylinder).
            s = (1.0 + taper) * f / (1.0 + wp.sqrt(wp.max(1.0 - (1.0 - taper * taper) * f, 0.0)))
            phi = 2.0 * PI * u2
            if facing == 1:
                phi = wp.atan2(wp.dot(to_p, by), wp.dot(to_p, bx)) + (2.0 * u2 - 1.0) * arc
            radial = wp.cos(phi) * bx + wp.sin(phi) * by
            n = radial
            if code == TUBE_TAPERED:
                q = c + ((mid + (2.0 * s - 1.0) * h_side) * up) * w + (r_side * up * (1.0 - (1.0 - taper) * s)) * radial
            else:
                q = c + (2.0 * s - 1.0) * half + (r * (1.0 - (1.0 - taper) * s)) * radial
            if taper != 1.0:  # a cone's normal leans towards its top by the slope of its radius
                n = wp.normalize(2.0 * h_side * radial + (r_side - top_side) * w)
        else:
            s = wp.min((ua - share) / (1.0 - share), 1.0)
            if code == TUBE_TAPERED:
                # A zone of a sphere, uniform on it as its normal's height along the axis is (Archimedes): the bottom
                # sphere's below the latitude the side touches it at, or the top one's above, in proportion to area.
                low = r * r * (1.0 + sin_lat)
                low_share = low / (low + taper * taper * r * r * (1.0 - sin_lat))
                along = wp.where(s < low_share, -1.0 + (1.0 + sin_lat) * s / wp.max(low_share, 1e-30),
                                 sin_lat + (1.0 - sin_lat) * (s - low_share) / wp.max(1.0 - low_share, 1e-30))
                along = wp.clamp(along, -1.0, 1.0)
                phi = 2.0 * PI * u2
                n = along * w + wp.sqrt(wp.max(1.0 - along * along, 0.0)) * (wp.cos(phi) * bx + wp.sin(phi) * by)
                q = wp.where(s < low_share, c - half + r * n, c + half + (r * taper) * n)
            elif code == TUBE_CAPSULE:
                # The two hemispheres make one sphere of radius r: a uniform direction, on the hemisphere it points to.
                n = sample_uniform_sphere(s, u2)
                q = c + wp.where(wp.dot(n, w) >= 0.0, 1.0, -1.0) * half + r * n
            else:
                # A cap, uniform on its disk: a single-sided cylinder's on p's side, or with both drawn (a cone's, whose
                # caps differ: tube_area) the top in proportion to its area.
                sign = above
                s2 = s
                if facing == 0 or taper != 1.0:
                    top_share = taper * taper / (1.0 + taper * taper)
                    sign = wp.where(s < top_share, 1.0, -1.0)
                    s2 = wp.where(s < top_share, s / wp.max(top_share, 1e-30), (s - top_share) / (1.0 - top_share))
                rad = r * wp.where(sign > 0.0, taper, 1.0) * wp.sqrt(wp.min(s2, 1.0))
                phi = 2.0 * PI * u2
                n = sign * w
                q = c + sign * half + rad * (wp.cos(phi) * bx + wp.sin(phi) * by)
    density = tube_density(r * down, r * down * taper, h_down, code, w, to_p, facing, area, arc, (q - c) * down,
                           on_side)
    if density <= 0.0:
        return q, n, 0.0, down
    return q, n, 1.0 / density, down


@wp.func
def tube_point_density(row: wp.vec4, axis: wp.vec4, taper: float, facing: int, to_p: wp.vec3, q_rel: wp.vec3,
                       n: wp.vec3):
    """Density by area (lengths times the tube's ``down``) with which :func:`sample_tube` (``taper`` and ``facing``
    as there) draws the point ``q_rel`` from the centre (times ``down``) whose unit normal is ``n`` (either side), for
    the shading point ``to_p`` from the centre (times ``down``): :func:`tube_density`. The point is on the side unless
    it lies past the side's ends (a capsule's hemispheres, a tapered capsule's zones) or, capped, its normal is the
    axis."""
    down, up = tube_scales(row, axis)
    area, side, arc = tube_area(row, axis, taper, down, facing, to_p)
    if area <= 0.0:
        return 0.0
    w, h = tube_axis(axis, down)
    code = int(axis[3])
    r = row[3] * down
    mid, h_side, r_side, top_side, sin_lat = tube_side(r, r * taper, h, code)
    on_side = int(1)
    if code == TUBE_CAPPED:
        lean = wp.abs(r_side - top_side) / wp.sqrt(4.0 * h_side * h_side + (r_side - top_side) * (r_side - top_side))
        on_side = wp.where(wp.abs(wp.dot(n, w)) < 0.5 * (1.0 + lean), 1, 0)
    elif code == TUBE_CAPSULE or code == TUBE_TAPERED:
        on_side = wp.where(wp.abs(wp.dot(q_rel, w) - mid) < h_side, 1, 0)
    return tube_density(r, r * taper, h, code, w, to_p, facing, area, arc, q_rel, on_side)


@wp.func
def tube_pdf(row: wp.vec4, axis: wp.vec4, taper: float, facing: int, p: wp.vec3, d: wp.vec3, dist: float,
             n: wp.vec3):
    """Solid-angle pdf of :func:`sample_tube` (``taper`` and ``facing`` as there) from ``p`` drawing the point
    ``dist`` along unit ``d`` whose unit normal is ``n`` (either side), for a point the ray can hit:
    ``dist^2 density / |cos|`` (:func:`tube_point_density`), lengths times the tube's ``down``."""
    to_p, q, dist2, cos_l = tube_pdf_terms(row, axis, p, d, dist, n)
    if cos_l <= 0.0:
        return 0.0
    return dist2 * tube_point_density(row, axis, taper, facing, to_p, q, n) / cos_l


@wp.func
def tube_pdf_terms(row: wp.vec4, axis: wp.vec4, p: wp.vec3, d: wp.vec3, dist: float, n: wp.vec3):
    """``(to_p, q, dist^2, |cos|)`` of :func:`tube_pdf`: ``p`` and the point drawn relative to the centre, the squared
    distance and the cosine at the point, lengths times the tube's ``down``; the pdf is ``dist^2 density / |cos|``.
    Apart so that a caller with another tube's terms calls :func:`tube_point_density` once for both (each call site
    compiles it again)."""
    down, up = tube_scales(row, axis)
    to_p = (p - wp.vec3(row[0], row[1], row[2])) * down
    scaled = dist * down
    return to_p, to_p + d * scaled, scaled * scaled, wp.abs(wp.dot(d, n))
