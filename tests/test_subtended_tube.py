"""A glowing tube's light draw near its side (wrt.glowing_tubes mixing the draw uniform by area with
wrt.subtended_tube's draw by the angles the side subtends): a shading point 0.01 radii off a long cylinder's side
estimated its irradiance with a relative noise of 50 to 250 per sample (uniform by area, one draw in thousands
landing on the patch that fills half its sky); every tube's estimate is unbiased against a float64 quadrature of the
irradiance, its density by area integrates over what it draws from to the share of draws it keeps, and the density a
draw reports is the one ``tube_pdf`` reads back at the point drawn (path's MIS weight of a ray that hits the tube)."""

import math

import numpy as np
import pytest
import warp as wp
from test_glowing_tubes import AXIS, frame

from wrt.glowing_spheres import GLOW_CAPPED_CYLINDER, GLOW_CAPSULE, GLOW_OPEN_CYLINDER, GLOW_TAPERED_CAPSULE
from wrt.glowing_tubes import sample_tube, tube_pdf

CENTRE = np.array([0.2, -0.1, 0.5])
ROT = frame(AXIS)  # columns: the tube frame's X, Y and axis in the world
# (kind, GLOW_* code, taper, radius, half length): a long cylinder (open or capped) and capsule, ten radii each way,
# and a frustum, a cone to its apex and a tapered capsule, three radii each way.
TUBES = {"capped-cylinder": ("cylinder", GLOW_CAPPED_CYLINDER, 1.0, 0.1, 1.0),
         "open-cylinder": ("cylinder", GLOW_OPEN_CYLINDER, 1.0, 0.1, 1.0),
         "capsule": ("capsule", GLOW_CAPSULE, 1.0, 0.1, 1.0),
         "capped-frustum": ("cone", GLOW_CAPPED_CYLINDER, 0.4, 0.3, 0.9),
         "open-cone": ("cone", GLOW_OPEN_CYLINDER, 0.0, 0.3, 0.9),
         "tapered-capsule": ("tapered", GLOW_TAPERED_CAPSULE, 0.5, 0.3, 0.9)}


def side(kind, r, h, taper):
    """``(z0, z1, ra, rb)``: the side's ends along the axis from the centre and its radii there (a tapered capsule's
    cone touches its spheres at latitude asin((r - top) / 2 h), radii cos times theirs)."""
    top = r * taper
    if kind != "tapered":
        return -h, h, r, top
    s = (r - top) / (2.0 * h)
    c = math.sqrt(1.0 - s * s)
    return -h + r * s, h + top * s, r * c, top * c


def sinh_grid(centre, eps, lo, hi, n):
    """Midpoints ``centre + eps sinh t`` of ``n`` even steps in ``t`` over ``[lo, hi]``, and their lengths: steps
    ``eps`` apart times ``cosh t``, fine within ``eps`` of ``centre`` and smooth in ``t`` out to the ends."""
    t0, t1 = math.asinh((lo - centre) / eps), math.asinh((hi - centre) / eps)
    t = t0 + (np.arange(n) + 0.5) / n * (t1 - t0)
    return centre + eps * np.sinh(t), eps * np.cosh(t) * (t1 - t0) / n


def surface(tube, p, single_sided, n=400):
    """``(q, nq, dA)`` float64 in the frame of ``tube`` (a row of :data:`TUBES`; axis +Z, centre 0): a quadrature of
    the surface a draw from ``p`` (same frame) takes points of: the side on sinh grids around ``p``'s nearest point
    of it (resolving a point 0.01 radii off), the caps or spheres on even grids; ``single_sided``: only what the draw
    by area takes for it: a cylinder's or capsule's half of the side facing ``p`` and a cylinder's cap on ``p``'s
    side, a cone's points of the side whose front faces ``p`` (its tangent plane is the same along each straight
    line of it) and both caps."""
    kind, code, taper, r, h = tube
    z0, z1, ra, rb = side(kind, r, h, taper)
    slope = (rb - ra) / (z1 - z0)
    rho, phi_p = math.hypot(p[0], p[1]), math.atan2(p[1], p[0])
    a, e = np.array([ra, z0]), np.array([rb - ra, z1 - z0])
    foot = a + np.clip(np.dot(np.array([rho, p[2]]) - a, e) / np.dot(e, e), 0.0, 1.0) * e
    eps = max(math.hypot(rho - foot[0], p[2] - foot[1]), 1e-6 * r)
    zs, wz = sinh_grid(foot[1], eps, z0, z1, n)
    cone = taper != 1.0
    reach = math.pi / 2 if single_sided and not cone else math.pi
    phis, wphi = sinh_grid(0.0, eps / max(foot[0], 1e-3 * r), -reach, reach, 2 * n)
    zz, pp = np.meshgrid(zs, phis + phi_p, indexing="ij")
    radius = ra + slope * (zz - z0)
    radial = np.stack([np.cos(pp), np.sin(pp), np.zeros_like(pp)], -1)
    pts = [(radius[..., None] * radial + zz[..., None] * np.array([0.0, 0.0, 1.0])).reshape(-1, 3)]
    nrm = [((radial - slope * np.array([0.0, 0.0, 1.0])) / math.hypot(1.0, slope)).reshape(-1, 3)]
    area = [(radius * math.hypot(1.0, slope) * np.outer(wz, wphi)).reshape(-1)]
    if single_sided and cone:
        area[0] = area[0] * (((p - pts[0]) * nrm[0]).sum(1) > 0.0)
    m = n // 2
    phi = (np.arange(2 * m) + 0.5) / (2 * m) * 2.0 * math.pi
    for s in (1.0, -1.0):
        if kind == "cone" or kind == "cylinder":
            if code != GLOW_CAPPED_CYLINDER or (single_sided and not cone and s * p[2] < 0.0):
                continue
            cap = r * (taper if s > 0 else 1.0)
            rr, ph = np.meshgrid((np.arange(m) + 0.5) / m * cap, phi, indexing="ij")
            pts.append(np.stack([rr * np.cos(ph), rr * np.sin(ph), np.full_like(rr, s * h)], -1).reshape(-1, 3))
            nrm.append(np.broadcast_to([0.0, 0.0, s], pts[-1].shape))
            area.append((rr * (cap / m) * (math.pi / m)).reshape(-1))
        else:
            lat = math.asin((r - r * taper) / (2.0 * h))
            top = math.pi / 2 - s * lat
            ball = r * (taper if s > 0 else 1.0)
            th, ph = np.meshgrid((np.arange(m) + 0.5) / m * top, phi, indexing="ij")
            d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), s * np.cos(th)], -1).reshape(-1, 3)
            pts.append(d * ball + np.array([0.0, 0.0, s * h]))
            nrm.append(d)
            area.append((ball**2 * np.sin(th) * (top / m) * (math.pi / m)).reshape(-1))
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(area)


def irradiance(name, p, n_p):
    """:func:`irradiance_from` the tube ``name`` of :data:`TUBES`."""
    return irradiance_from(TUBES[name], p, n_p)


def irradiance_from(tube, p, n_p, n=400):
    """float64 irradiance over the radiance at ``p`` (normal ``n_p``, the tube's frame) from the single-sided tube
    (a row of :data:`TUBES`): the sum of ``cos_p cos_l / d^2 dA`` over the surface points whose front faces ``p``,
    all of which it sees (the tube is convex)."""
    q, nq, dA = surface(tube, p, single_sided=False, n=n)
    v = q - p
    d = np.linalg.norm(v, axis=1)
    cos_l = np.clip(-(v * nq).sum(1) / d, 0.0, None)
    return float((cos_l * np.clip(v @ n_p / d, 0.0, None) / d**2 * dA).sum())


@wp.kernel
def draw_kernel(row: wp.vec4, axis: wp.vec4, taper: float, facing: int, p: wp.vec3, n_p: wp.vec3,
                us: wp.array[wp.vec2],
                # outputs
                values: wp.array[float], pdfs: wp.array[wp.vec2]):
    """Each draw's irradiance estimate over the radiance ``cos_p / pdf`` (0 for a point facing away), and its
    solid-angle pdf as the draw reports it (``sample_light``: ``d^2 / (area cos_l)``) and as ``tube_pdf`` reads it
    back at the point."""
    i = wp.tid()
    q, ln, area, down = sample_tube(row, axis, taper, p, facing, us[i][0], us[i][1])
    to = (q - p) * down
    d2 = wp.length_sq(to)
    values[i] = 0.0
    pdfs[i] = wp.vec2(0.0)
    if d2 > 0.0 and area > 0.0:
        wi = to / wp.sqrt(d2)
        cos_l = -wp.dot(wi, ln)
        if facing == 0:
            cos_l = wp.abs(cos_l)
        if cos_l > 0.0:
            pdf = d2 / (area * cos_l)
            values[i] = wp.max(wp.dot(wi, n_p), 0.0) / pdf
            pdfs[i] = wp.vec2(pdf, tube_pdf(row, axis, taper, facing, p, wi, wp.sqrt(d2) / down, ln))


@wp.kernel
def density_kernel(row: wp.vec4, axis: wp.vec4, taper: float, facing: int, p: wp.vec3, qs: wp.array[wp.vec3],
                   ns: wp.array[wp.vec3],
                   # outputs
                   densities: wp.array[float]):
    """``tube_pdf`` at each point ``qs[i]`` (normal ``ns[i]``) as a density by area: ``pdf |cos_l| / d^2``."""
    i = wp.tid()
    to = qs[i] - p
    dist = wp.length(to)
    wi = to / dist
    densities[i] = tube_pdf(row, axis, taper, facing, p, wi, dist, ns[i]) * wp.abs(wp.dot(wi, ns[i])) / (dist * dist)


def tube_densities(placed, facing: int, p, q, nq) -> np.ndarray:
    """The density by area ``tube_pdf`` gives from ``p`` at each surface point ``q`` of unit normal ``nq`` (all in the
    tube's frame, placed by :func:`to_world`) of the tube ``placed`` (:func:`device_tube`'s), in float64."""
    out = wp.zeros(len(q), dtype=float, device="cpu")
    wp.launch(density_kernel, len(q), inputs=[*placed, facing, wp.vec3(*to_world(p)),
                                              wp.array(to_world(q), dtype=wp.vec3, device="cpu"),
                                              wp.array(to_world(nq, point=False), dtype=wp.vec3, device="cpu")],
              outputs=[out], device="cpu")
    return out.numpy().astype(np.float64)


@wp.kernel
def kept_kernel(row: wp.vec4, axis: wp.vec4, taper: float, facing: int, p: wp.vec3, us: wp.array[wp.vec2],
                # outputs
                kept: wp.array[float]):
    """1 where ``sample_tube`` draws a point, 0 where it drops the draw (its density 0)."""
    i = wp.tid()
    q, n, area, down = sample_tube(row, axis, taper, p, facing, us[i][0], us[i][1])
    kept[i] = wp.where(area > 0.0, 1.0, 0.0)


def device_tube(name):
    """``(row, axis, taper)`` of the tube in the world: centre CENTRE, axis along AXIS."""
    kind, code, taper, r, h = TUBES[name]
    return wp.vec4(*CENTRE, r), wp.vec4(*(ROT[:, 2] * h), code), taper


def to_world(v, point=True):
    """Points (or with ``point`` False, directions) ``(..., 3)`` of the tube's frame in the world."""
    return (CENTRE if point else 0.0) + np.asarray(v) @ ROT.T


def draws(name, facing, p, n_p, count, seed):
    """``(values, pdfs)`` float64 of :func:`draw_kernel` from ``p`` (the tube's frame) over ``count`` draws."""
    us = np.random.default_rng(seed).uniform(size=(count, 2)).astype(np.float32)
    values = wp.zeros(count, dtype=float, device="cpu")
    pdfs = wp.zeros(count, dtype=wp.vec2, device="cpu")
    wp.launch(draw_kernel, count, inputs=[*device_tube(name), facing, wp.vec3(*to_world(p)),
                                          wp.vec3(*to_world(n_p, point=False)),
                                          wp.array(us, dtype=wp.vec2, device="cpu")],
              outputs=[values, pdfs], device="cpu")
    return values.numpy().astype(np.float64), pdfs.numpy().astype(np.float64)


def off_side(name, gap):
    """``(p, n_p)``: a point ``gap`` radii off the side along its outward normal, a fifth of the way up from the
    centre, facing the tube (the tube's frame)."""
    kind, code, taper, r, h = TUBES[name]
    z0, z1, ra, rb = side(kind, r, h, taper)
    z = 0.2 * h
    slope = (rb - ra) / (z1 - z0)
    normal = np.array([1.0, 0.0, -slope]) / math.hypot(1.0, slope)
    p = np.array([ra + slope * (z - z0), 0.0, z]) + gap * r * normal
    return p, -normal


@pytest.mark.parametrize("name", TUBES)
@pytest.mark.parametrize("gap", [0.01, 0.1, 1.0])
def test_a_point_near_a_tube_estimates_its_irradiance_unbiased_and_quiet(name, gap):
    """From a point 0.01, 0.1 and 1 radii off each tube's side (facing it), 100,000 draws estimate the irradiance the
    quadrature gives within four standard errors plus 0.1%, and within 0.01, 0.1 radii with a relative noise per
    draw under 1.5: it was 48 to 255 at 0.01 radii, 7 to 28 at 0.1, drawn uniformly by area (now 0.6 and 0.5)."""
    p, n_p = off_side(name, gap)
    expected = irradiance(name, p, n_p)
    values, _ = draws(name, 1, p, n_p, 100_000, seed=11)
    se = values.std() / math.sqrt(len(values))
    assert abs(values.mean() - expected) < 4.0 * se + 1e-3 * expected, (values.mean(), expected, se)
    if gap < 0.5:
        assert values.std() < 1.5 * expected, values.std() / expected


POINTS = {"beside": (off_side, 0.3), "past-an-end": (lambda name, _: (np.array([0.05, 0.02, 1.4]), None), 0.0),
          "far": (lambda name, _: (np.array([2.0, -1.0, 0.7]), None), 0.0)}


@pytest.mark.parametrize("name", TUBES)
@pytest.mark.parametrize("where", POINTS)
@pytest.mark.parametrize("facing", [0, 1])
def test_the_tube_density_integrates_to_the_share_of_draws_kept_over_what_it_draws_from(name, where, facing):
    """The density by area ``tube_pdf`` gives, summed by the float64 quadrature over what the tube draws from (a
    double-sided tube's whole surface; a single-sided one's part :func:`surface` names), is the share of draws kept
    within 0.5%, from a point beside the side, one past an end near the axis (past a cone's apex) and one far off:
    1 but for a capsule's, whose draws by its end spheres' cones that enter a sphere off its end are dropped, and a
    capped tube's past an end, whose cap's draws that fall off the disk are (200,000 draws count them)."""
    make, gap = POINTS[where]
    p = make(name, gap)[0]
    q, nq, dA = surface(TUBES[name], p, single_sided=facing == 1)
    densities = tube_densities(device_tube(name), facing, p, q, nq)
    total = float((densities * dA).sum())
    count = 200_000
    us = np.random.default_rng(5).uniform(size=(count, 2)).astype(np.float32)
    kept = wp.zeros(count, dtype=float, device="cpu")
    wp.launch(kept_kernel, count, inputs=[*device_tube(name), facing, wp.vec3(*to_world(p)),
                                          wp.array(us, dtype=wp.vec2, device="cpu")], outputs=[kept], device="cpu")
    share = float(kept.numpy().mean())
    assert abs(total - share) < 5e-3, (total, share)
    if TUBES[name][1] == GLOW_OPEN_CYLINDER:  # (a capped tube's cap draws off the disk are dropped too)
        assert share == 1.0, share


@pytest.mark.parametrize("name", TUBES)
@pytest.mark.parametrize("facing", [0, 1])
def test_a_draw_reports_the_density_tube_pdf_reads_back(name, facing):
    """At every point drawn (from points 0.01 and 1 radii off the side, past an end and far off), the solid-angle pdf
    the draw reports is the one ``tube_pdf`` reads back at that point from the ray's direction and distance, within
    float32 rounding (all but one in a thousand within 0.2%: a cone's density grows without bound at its apex, where
    the radius it is over rounds; 16% off at a point 2e-6 radii from the apex): path weighs a ray that hits the tube
    by the latter against the light sample by the former."""
    checked = 0
    for p, n_p in [off_side(name, 0.01), off_side(name, 1.0), (np.array([0.05, 0.02, 1.4]), np.array([0, 0, -1.0])),
                   (np.array([2.0, -1.0, 0.7]), np.array([-1.0, 0, 0]))]:
        _, pdfs = draws(name, facing, p, n_p, 20_000, seed=3)
        drawn = pdfs[:, 0] > 0.0
        checked += drawn.sum()
        off = np.abs(pdfs[drawn, 1] / pdfs[drawn, 0] - 1.0)
        assert (off < 2e-3).sum() >= 0.999 * drawn.sum(), (p, np.sort(off)[-5:])
    assert checked > 20_000, checked


@pytest.mark.parametrize("name", ["open-cone", "capped-frustum"])
def test_the_density_is_continuous_across_a_cones_apex_plane(name):
    """From points 1e-5 either side of the plane through a cone's apex (a frustum's extended), 0.5 and 1.5 radii off
    the axis, the density at side points facing them differs by under 0.1%: path reads a hit's density from its
    ray's origin, just off the shading point, and light sampling from the shading point itself, so a floor in that
    plane would take the two from either side. Drawn by the angles past the apex too (uniformly in the arc p sees
    the front of, against the circle's draw on the near side), the density jumped there by 2 to 6%."""
    kind, code, taper, r, h = TUBES[name]
    apex = h * (1.0 + taper) / (1.0 - taper)  # where the radius r (1 - (1 - taper) (z + h) / 2 h) reaches 0
    z0, z1, ra, rb = side(kind, r, h, taper)
    zs = np.linspace(z0, z1, 7)[1:-1]
    deltas = np.array([0.3, 1.0, 1.4])
    zz, dd = np.meshgrid(zs, deltas, indexing="ij")
    radius = ra + (rb - ra) * (zz - z0) / (z1 - z0)
    q = np.stack([radius * np.cos(dd), radius * np.sin(dd), zz], -1).reshape(-1, 3)
    slope = (rb - ra) / (z1 - z0)
    nq = np.stack([np.cos(dd), np.sin(dd), np.full_like(dd, -slope)], -1).reshape(-1, 3) / math.hypot(1.0, slope)
    for rho in (0.5 * r, 1.5 * r):
        densities = []
        for side_of in (-1.0, 1.0):
            p = np.array([rho, 0.0, apex + side_of * 1e-5])
            densities.append(tube_densities(device_tube(name), 1, p, q, nq))
        assert (densities[0] > 0.0).all()
        np.testing.assert_allclose(densities[1], densities[0], rtol=1e-3)


@pytest.mark.parametrize("gap", [1e-3, 1e-4])
def test_a_flat_frustums_draw_reports_the_density_tube_pdf_reads_back(gap):
    """A frustum a thousandth of its radius long (radii 1 and 0.5: its side a near-flat ring half a radius wide),
    from points 1e-3 and 1e-4 radii off the side: the density ``tube_pdf`` reads back at each point drawn is the one
    the draw reports within 0.2% (all but one in a thousand). It placed the point along the side by its height,
    which the ring spans a thousandth of: the point's float32 rounding moved it 500 times as far along the side, and
    the density read back (which grows as the inverse cube of the distance there) was off by up to 2% and 20%."""
    name = "flat-frustum"
    TUBES[name] = ("cone", GLOW_CAPPED_CYLINDER, 0.5, 1.0, 5e-4)
    try:
        p, n_p = off_side(name, gap)
        _, pdfs = draws(name, 1, p, n_p, 20_000, seed=3)
    finally:
        del TUBES[name]
    drawn = pdfs[:, 0] > 0.0
    off = np.abs(pdfs[drawn, 1] / pdfs[drawn, 0] - 1.0)
    assert drawn.sum() > 10_000, drawn.sum()
    assert (off < 2e-3).sum() >= 0.999 * drawn.sum(), np.sort(off)[-5:]


def inside(name, where):
    """A point inside tube ``name`` (the tube's frame), a fifth of the way up its side: on its axis (``axis``), or
    nine tenths of the way out to its side (``wall``)."""
    kind, code, taper, r, h = TUBES[name]
    z0, z1, ra, rb = side(kind, r, h, taper)
    z = 0.2 * h
    return np.array([0.0 if where == "axis" else 0.9 * (ra + (rb - ra) * (z - z0) / (z1 - z0)), 0.0, z])


@pytest.mark.parametrize("name", TUBES)
@pytest.mark.parametrize("where", ["axis", "wall"])
def test_inside_a_double_sided_tube_the_density_integrates_to_one_and_draws_read_back(name, where):
    """From inside a double-sided tube (on its axis, and 0.9 of the way out to its side), where the draw by the
    angles the side subtends goes all round its axis: the density ``tube_pdf`` gives sums to 1 within 0.5% over the
    whole surface (the float64 quadrature), and every point drawn reads back the pdf the draw reported within 0.2%
    (all but one in a thousand). Guard: no other test draws from between a tube's ends inside it."""
    p = inside(name, where)
    q, nq, dA = surface(TUBES[name], p, single_sided=False)
    densities = tube_densities(device_tube(name), 0, p, q, nq)
    total = float((densities * dA).sum())
    assert abs(total - 1.0) < 5e-3, total
    _, pdfs = draws(name, 0, p, np.array([1.0, 0.0, 0.0]), 20_000, seed=5)
    drawn = pdfs[:, 0] > 0.0
    assert drawn.sum() > 19_000, drawn.sum()
    off = np.abs(pdfs[drawn, 1] / pdfs[drawn, 0] - 1.0)
    assert (off < 2e-3).sum() >= 0.999 * drawn.sum(), np.sort(off)[-5:]
