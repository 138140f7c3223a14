"""Drawing a point of a round tube's side (a cylinder's or a cone's, bottom radius ``ra`` at ``z = -H``, top ``rb`` at
``z = H``, lengths of order 1) by the angles it subtends from a shading point p, close to uniformly by solid angle:
:mod:`wrt.glowing_tubes` mixes it with its draw uniform by area, which is noisy near the tube (a point 0.01 radii off
a long cylinder's side sees half its sky filled by a patch of the side a few hundredths of a radius across, which
few draws by area land on: its irradiance estimate's relative noise per draw was 255, mixed with this draw 0.6).

Coordinates are p's: ``rho`` its distance from the axis, ``z`` its height, ``delta`` a side point's angle about the
axis from p's. The angle ``delta`` is drawn uniformly in the angle that p sees the side's circle at its own height
subtend across the axis (``reach``: the cone's radius extended to p's height), when p lies outside it; otherwise
(inside a double-sided tube or its extension) uniformly in ``+-spread``. Along the straight line of the side at
``delta`` the point is drawn uniformly in the sine of its angle from the line's nearest point to p as p sees it:
the two draws together make a cylinder's strip of the side uniform by solid angle. Its density by area,
:func:`subtended_density`, is the product of the two, over the side's radius at the point."""

import warp as wp


@wp.func
def generator_line(ra: float, rb: float, H: float, rho: float, z: float, delta: float):
    """``(h, s_p, length)``: p's distance from the side's straight line at angle ``delta``, its nearest point's
    distance along the line from the bottom, and the line's length."""
    length = wp.sqrt(4.0 * H * H + (rb - ra) * (rb - ra))
    half_sin = wp.sin(0.5 * delta)
    # p's coordinate in the line's half plane, out from the axis, less ra: rho cos(delta) - ra without the
    # cancellation of its two terms just off the side.
    out = (rho - ra) - 2.0 * rho * half_sin * half_sin
    up = z + H
    s_p = (out * (rb - ra) + up * 2.0 * H) / length
    across = (out * 2.0 * H - up * (rb - ra)) / length  # in the half plane
    aside = rho * wp.sin(delta)  # out of it
    return wp.sqrt(across * across + aside * aside), s_p, length


@wp.func
def sine_span(h: float, s0: float, s1: float):
    """``(span, below_top, above_bottom)``: for a line at distance ``h`` from p whose ends lie ``s0 < s1`` along it
    from p's nearest point, the span of ``x = s / sqrt(h^2 + s^2)`` (the sine of the angle p sees a point at ``s``
    at from its nearest point), ``1 - x`` at ``s1`` and ``1 + x`` at ``s0``, each without the cancellation of
    differences of numbers near 1 (a point far along the axis from a tube's end sees every x near 1)."""
    d0 = wp.sqrt(h * h + s0 * s0)
    d1 = wp.sqrt(h * h + s1 * s1)
    span = float(0.0)
    if s0 >= 0.0 or s1 <= 0.0:
        # s1 / d1 - s0 / d0 of the same sign: h^2 (s1 - s0) (s1 + s0) / (d0 d1 (s1 d0 + s0 d1))
        ends = s1 * d0 + s0 * d1
        if ends != 0.0 and d0 > 0.0 and d1 > 0.0:
            span = (h / d0) * (h / d1) * (s1 - s0) * ((s1 + s0) / ends)
    else:
        span = s1 / d1 - s0 / d0
    below_top = 1.0 - s1 / wp.max(d1, 1e-30)
    if s1 >= 0.0 and d1 > 0.0:
        below_top = (h / d1) * (h / (d1 + s1))
    above_bottom = 1.0 + s0 / wp.max(d0, 1e-30)
    if s0 <= 0.0 and d0 > 0.0:
        above_bottom = (h / d0) * (h / (d0 - s0))
    return wp.max(span, 0.0), below_top, above_bottom


@wp.func
def angle_density(reach: float, spread: float, rho: float, delta: float):
    """Density of the angle ``delta`` (in ``(-pi, pi]``) the draw takes about the axis: uniform in the angle p sees
    the circle of radius ``reach`` at, for ``reach`` in ``(0, rho)``; otherwise uniform in ``+-spread``."""
    if reach > 0.0 and reach < rho:
        if wp.abs(delta) > wp.acos(reach / rho):
            return 0.0
        half_sin = wp.sin(0.5 * delta)
        sq = 2.0 * half_sin * half_sin
        gap = rho - reach
        # d(seen angle) / d(delta) = reach (rho cos(delta) - reach) / (distance from p to the circle's point)^2
        dist2 = gap * gap + 2.0 * rho * reach * sq
        seen = reach * (gap - rho * sq) / wp.max(dist2, 1e-30)
        return wp.max(seen, 0.0) / (2.0 * wp.asin(reach / rho))
    if spread <= 0.0 or wp.abs(delta) > spread:
        return 0.0
    return 0.5 / spread


@wp.func
def subtended_density(ra: float, rb: float, H: float, reach: float, spread: float, rho: float, z: float,
                      delta: float, along: float):
    """Density by area with which :func:`sample_subtended` draws the side's point at angle ``delta`` from p's and
    ``along`` its line from the bottom (0) to the top (1)."""
    p_angle = angle_density(reach, spread, rho, delta)
    if p_angle <= 0.0:
        return 0.0
    h, s_p, length = generator_line(ra, rb, H, rho, z, delta)
    span, below_top, above_bottom = sine_span(h, -s_p, length - s_p)
    if span <= 0.0:
        return 0.0
    t = wp.clamp(along, 0.0, 1.0)
    s = t * length - s_p
    d = wp.sqrt(h * h + s * s)
    radius = ra + (rb - ra) * t
    if d <= 0.0 or radius <= 0.0:
        return 0.0
    # ds density h^2 / (d^3 span), over the radius (the side's area element is radius d(delta) ds)
    return p_angle * (h / d) * (h / d) / (d * span * radius)


@wp.func
def sample_subtended(ra: float, rb: float, H: float, reach: float, spread: float, rho: float, z: float, u1: float,
                     u2: float):
    """``(delta, qz, drawn)``: the angle from p's about the axis and the height of a point drawn on the side
    (:func:`subtended_density`), ``drawn`` 0 where there was nothing to draw."""
    delta = float(0.0)
    if reach > 0.0 and reach < rho:
        # Uniform in the angle theta p sees the circle at, from its centre: the circle's near point along it.
        theta = (2.0 * u1 - 1.0) * wp.asin(reach / rho)
        c = wp.cos(theta)
        s = wp.sin(theta)
        t = (rho - reach) * (rho + reach) / (rho * c + wp.sqrt(wp.max(reach * reach - rho * rho * s * s, 0.0)))
        delta = wp.atan2(t * s, rho - t * c)
    elif spread > 0.0:
        delta = (2.0 * u1 - 1.0) * spread
    else:
        return 0.0, 0.0, 0
    h, s_p, length = generator_line(ra, rb, H, rho, z, delta)
    span, below_top, above_bottom = sine_span(h, -s_p, length - s_p)
    if span <= 0.0:
        return delta, 0.0, 0
    # x uniform in its span, its 1 - x and 1 + x as sums of positive terms; s = h x / sqrt((1 - x) (1 + x))
    one_minus = below_top + (1.0 - u2) * span
    one_plus = above_bottom + u2 * span
    x = wp.where(one_plus < one_minus, one_plus - 1.0, 1.0 - one_minus)
    cos_b = wp.sqrt(wp.max(one_minus * one_plus, 0.0))
    along = float(1.0)
    if x < 0.0:
        along = 0.0
    if cos_b > 0.0:
        along = wp.clamp((s_p + h * x / cos_b) / length, 0.0, 1.0)
    return delta, (2.0 * along - 1.0) * H, 1
