"""Device side of glowing round tubes as lights (:mod:`wrt.glowing_spheres` builds their rows): a point drawn
uniformly by area over a cylinder's side (and its caps, where capped) or a capsule's side and hemispheres, the part
of them a shading point can see the front of for a single-sided tube, and that part's area, in closed form, that
turns the draw's density ``1 / area`` into a solid-angle pdf ``dist^2 / (area |cos|)`` for both light sampling and
the MIS weight of a ray that hits the tube.

Lengths are taken times the power of two ``down`` that brings the tube's largest length (its radius or a component of
its half axis) into [1, 2): the area in world units squared overflowed float32 for a tube 1e19 across.
"""

import warp as wp

from .floats import largest_magnitude, power_scales
from .glowing_spheres import GLOW_CAPPED_CYLINDER, GLOW_CAPSULE
from .sampling import PI, basis_x, basis_y, sample_uniform_sphere

TUBE_CAPPED = wp.constant(GLOW_CAPPED_CYLINDER)
TUBE_CAPSULE = wp.constant(GLOW_CAPSULE)


@wp.func
def tube_scales(row: wp.vec4, axis: wp.vec4):
    """``(down, up = 1 / down)`` of the tube of ``row`` (world centre, radius) and ``axis`` (half axis, code)."""
    return power_scales(wp.max(row[3], largest_magnitude(wp.vec3(axis[0], axis[1], axis[2]))))


@wp.func
def tube_area(row: wp.vec4, axis: wp.vec4, down: float, facing: int):
    """``(area, side)``: the area (times ``down^2``) that :func:`sample_tube` draws from, and its side's share of it
    (the cylinder between the caps or hemispheres): the whole surface, or with ``facing`` 1 the half of the side
    that faces the shading point, the one cap on its side of the centre and both hemispheres."""
    r = row[3] * down
    h = wp.length(wp.vec3(axis[0], axis[1], axis[2]) * down)
    side = 4.0 * PI * r * h  # 2 pi r around, 2 h along
    code = int(axis[3])
    ends = float(0.0)
    if code == TUBE_CAPPED:
        ends = 2.0 * PI * r * r
        if facing == 1:
            ends = PI * r * r
    elif code == TUBE_CAPSULE:
        ends = 4.0 * PI * r * r  # two hemispheres
    if facing == 1:
        side = 0.5 * side
    return side + ends, side


@wp.func
def sample_tube(row: wp.vec4, axis: wp.vec4, p: wp.vec3, facing: int, u1: float, u2: float):
    """``(q, n, area, down)``: a point ``q`` uniform by area on the part of the tube :func:`tube_area` names for
    shading point ``p`` (its side, caps or hemispheres chosen in proportion to their areas by ``u1``), its unit
    outward normal ``n``, that area (times ``down^2``) and the tube's ``down`` (:func:`tube_scales`).

    ``facing`` 1 (a single-sided tube) leaves out what ``p`` cannot see the front of: a point of the side whose
    outward normal makes more than a right angle with ``p``'s direction from the axis (seen from outside the tube,
    the front of a side point shows only to points past its tangent plane, which lie in that half), and the cap on
    the other side of the centre. A ray from ``p`` that hits the tube's front therefore hits the part drawn from, at
    the density :func:`tube_pdf` reads back."""
    down, up = tube_scales(row, axis)
    area, side = tube_area(row, axis, down, facing)
    c = wp.vec3(row[0], row[1], row[2])
    half = wp.vec3(axis[0], axis[1], axis[2])
    r = row[3]
    w = wp.vec3(0.0, 0.0, 1.0)
    h_down = wp.length(half * down)
    if h_down > 0.0:
        w = (half * down) / h_down
    bx = basis_x(w)
    by = basis_y(w)
    to_p = (p - c) * down
    above = wp.where(wp.dot(to_p, w) >= 0.0, 1.0, -1.0)  # the side of the centre p lies on, along the axis
    share = side / area  # of the side
    q = c
    n = w
    if u1 < share:
        s = u1 / share  # uniform along the side
        phi = 2.0 * PI * u2
        if facing == 1:
            phi = wp.atan2(wp.dot(to_p, by), wp.dot(to_p, bx)) + (u2 - 0.5) * PI
        n = wp.cos(phi) * bx + wp.sin(phi) * by
        q = c + (2.0 * s - 1.0) * half + r * n
    else:
        s = wp.min((u1 - share) / (1.0 - share), 1.0)
        if int(axis[3]) == TUBE_CAPSULE:
            # The two hemispheres make one sphere of radius r: a uniform direction, on the hemisphere it points to.
            n = sample_uniform_sphere(s, u2)
            q = c + wp.where(wp.dot(n, w) >= 0.0, 1.0, -1.0) * half + r * n
        else:
            # A cap, uniform on its disk: the one on p's side, or with both drawn the top for s < 1/2.
            sign = above
            s2 = s
            if facing == 0:
                sign = wp.where(s < 0.5, 1.0, -1.0)
                s2 = wp.where(s < 0.5, 2.0 * s, 2.0 * s - 1.0)
            rad = r * wp.sqrt(s2)
            phi = 2.0 * PI * u2
            n = sign * w
            q = c + sign * half + rad * (wp.cos(phi) * bx + wp.sin(phi) * by)
    return q, n, area, down


@wp.func
def tube_pdf(row: wp.vec4, axis: wp.vec4, facing: int, d: wp.vec3, dist: float, n: wp.vec3):
    """Solid-angle pdf of :func:`sample_tube` (``facing`` as there) drawing the point ``dist`` along unit ``d``
    whose unit normal is ``n`` (either side), for a point the ray can hit: ``dist^2 / (area |cos|)``, lengths times
    the tube's ``down``."""
    down, up = tube_scales(row, axis)
    area, side = tube_area(row, axis, down, facing)
    cos_l = wp.abs(wp.dot(d, n))
    if cos_l <= 0.0 or area <= 0.0:
        return 0.0
    scaled = dist * down
    return scaled * scaled / (area * cos_l)
