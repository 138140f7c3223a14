"""Device side of glowing round tubes as lights (:mod:`wrt.glowing_spheres` builds their rows): a point drawn
uniformly by area over a cylinder's side (and its caps, where capped) or a capsule's side and hemispheres, and the
area of the whole surface, in closed form, that turns the draw's density ``1 / area`` into a solid-angle pdf
``dist^2 / (area |cos|)`` for both light sampling and the MIS weight of a ray that hits the tube.

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
def tube_area(row: wp.vec4, axis: wp.vec4, down: float):
    """``(area, side)``: the tube's whole area and its side's (the cylinder between the caps or hemispheres), times
    ``down^2``."""
    r = row[3] * down
    h = wp.length(wp.vec3(axis[0], axis[1], axis[2]) * down)
    side = 4.0 * PI * r * h  # 2 pi r around, 2 h along
    code = int(axis[3])
    ends = float(0.0)
    if code == TUBE_CAPPED:
        ends = 2.0 * PI * r * r
    elif code == TUBE_CAPSULE:
        ends = 4.0 * PI * r * r  # two hemispheres
    return side + ends, side


@wp.func
def sample_tube(row: wp.vec4, axis: wp.vec4, u1: float, u2: float):
    """``(q, n, area, down)``: a point ``q`` uniform by area on the tube's whole surface (its side, caps or
    hemispheres chosen in proportion to their areas by ``u1``), its unit outward normal ``n``, the area (times
    ``down^2``, :func:`tube_area`) and the tube's ``down`` (:func:`tube_scales`)."""
    down, up = tube_scales(row, axis)
    area, side = tube_area(row, axis, down)
    c = wp.vec3(row[0], row[1], row[2])
    half = wp.vec3(axis[0], axis[1], axis[2])
    r = row[3]
    w = wp.vec3(0.0, 0.0, 1.0)
    h_down = wp.length(half * down)
    if h_down > 0.0:
        w = (half * down) / h_down
    bx = basis_x(w)
    by = basis_y(w)
    share = side / area  # of the side
    q = c
    n = w
    if u1 < share:
        s = u1 / share  # uniform along the side
        phi = 2.0 * PI * u2
        n = wp.cos(phi) * bx + wp.sin(phi) * by
        q = c + (2.0 * s - 1.0) * half + r * n
    else:
        s = wp.min((u1 - share) / (1.0 - share), 1.0)
        if int(axis[3]) == TUBE_CAPSULE:
            # The two hemispheres make one sphere of radius r: a uniform direction, on the hemisphere it points to.
            n = sample_uniform_sphere(s, u2)
            q = c + wp.where(wp.dot(n, w) >= 0.0, 1.0, -1.0) * half + r * n
        else:
            # A cap, the top for s < 1/2: uniform on its disk.
            top = s < 0.5
            s2 = wp.where(top, 2.0 * s, 2.0 * s - 1.0)
            rad = r * wp.sqrt(s2)
            phi = 2.0 * PI * u2
            n = wp.where(top, w, -w)
            q = c + wp.where(top, 1.0, -1.0) * half + rad * (wp.cos(phi) * bx + wp.sin(phi) * by)
    return q, n, area, down


@wp.func
def tube_pdf(row: wp.vec4, axis: wp.vec4, d: wp.vec3, dist: float, n: wp.vec3):
    """Solid-angle pdf of :func:`sample_tube` drawing the point ``dist`` along unit ``d`` whose unit normal is ``n``
    (either side): ``dist^2 / (area |cos|)``, lengths times the tube's ``down``."""
    down, up = tube_scales(row, axis)
    area, side = tube_area(row, axis, down)
    cos_l = wp.abs(wp.dot(d, n))
    if cos_l <= 0.0 or area <= 0.0:
        return 0.0
    scaled = dist * down
    return scaled * scaled / (area * cos_l)
