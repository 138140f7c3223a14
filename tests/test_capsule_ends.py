"""A glowing capsule's (and tapered capsule's) light draw near its ends (wrt.glowing_tubes): drawn by area alone
there (the draw by the angles the side subtends reaches only the side), a shading point 0.02 to 0.05 radii off an
end sphere estimated its irradiance with a relative noise of 20 to 210 per draw; a third draw, a direction in the
cone the end's sphere subtends (kept where it enters the sphere on that end), brings it under 1. Every estimate stays
unbiased against a float64 quadrature of the irradiance over the capsule's surface, refined around the point's foot
on the end sphere, and the density a draw reports is the one ``tube_pdf`` reads back (path's MIS weight of a hit)."""

import math

import numpy as np
import pytest
import warp as wp
from test_glowing_spheres import RADIANCE, floor_mesh, materials
from test_glowing_tubes import frame
from test_subtended_tube import TUBES, device_tube, draws, kept_kernel, side, sinh_grid, surface, to_world

import wrt
from wrt.glowing_spheres import GLOW_CAPSULE, GLOW_TAPERED_CAPSULE

CAPSULES = ["capsule", "tapered-capsule"]


def end_zone(tube, s, p, n=400):
    """``(q, nq, dA)`` float64 (the tube's frame, axis +Z): a quadrature of the end ``s`` (-1 bottom, 1 top) of the
    capsule ``tube`` (a row of :data:`TUBES`): its sphere's zone past the latitude the side touches it at, on sinh
    grids in latitude and longitude about the foot of ``p`` on the sphere (its latitude clamped into the zone), so
    that a point 0.02 radii off resolves. The zone's edge is a grid line: no cell straddles it."""
    kind, code, taper, r, h = tube
    top = r * taper
    lat = math.asin((r - top) / (2.0 * h))
    ball = top if s > 0 else r
    centre = np.array([0.0, 0.0, s * h])
    lo, hi = (lat, math.pi / 2) if s > 0 else (-math.pi / 2, lat)
    u = p - centre
    dist = np.linalg.norm(u)
    beta_p = float(np.clip(math.asin(u[2] / dist), lo, hi))
    eps = max(abs(dist - ball) / ball, 1e-6)
    betas, wb = sinh_grid(beta_p, eps, lo, hi, n)
    phis, wphi = sinh_grid(0.0, eps / max(math.cos(beta_p), eps), -math.pi, math.pi, 2 * n)
    bb, pp = np.meshgrid(betas, phis + math.atan2(u[1], u[0]), indexing="ij")
    d = np.stack([np.cos(bb) * np.cos(pp), np.cos(bb) * np.sin(pp), np.sin(bb)], -1).reshape(-1, 3)
    return centre + ball * d, d, (ball**2 * np.cos(bb) * np.outer(wb, wphi)).reshape(-1)


def irradiance(tube, p, n_p, n=400):
    """float64 irradiance over the radiance at ``p`` (normal ``n_p``, the tube's frame) from the single-sided capsule
    ``tube`` (a row of :data:`TUBES`): ``cos_p cos_l / d^2 dA`` summed over the side
    (:func:`test_subtended_tube.surface`'s points of it, refined about ``p``'s foot on it) and both ends
    (:func:`end_zone`), over the points whose front faces ``p``."""
    z0, z1, _, _ = side(tube[0], tube[3], tube[4], tube[2])
    q, nq, dA = surface(tube, p, single_sided=False, n=n)
    on_side = (q[:, 2] > z0) & (q[:, 2] < z1)
    parts = [(q[on_side], nq[on_side], dA[on_side]), end_zone(tube, -1, p, n), end_zone(tube, 1, p, n)]
    total = 0.0
    for q, nq, dA in parts:
        v = q - p
        d = np.linalg.norm(v, axis=1)
        total += float((np.clip(-(v * nq).sum(1) / d, 0.0, None) * np.clip(v @ n_p / d, 0.0, None) / d**2 * dA).sum())
    return total


def off_end(name, s, gap, polar):
    """``(p, n_p)``: a point ``gap`` radii off the end sphere ``s`` (-1 bottom, 1 top) along its normal at ``polar``
    radians from the axis's outward direction, facing the sphere (the tube's frame)."""
    kind, code, taper, r, h = TUBES[name]
    ball = r * (taper if s > 0 else 1.0)
    normal = np.array([math.sin(polar), 0.0, s * math.cos(polar)])
    return np.array([0.0, 0.0, s * h]) + (1.0 + gap) * ball * normal, -normal


@pytest.mark.parametrize("name", CAPSULES)
@pytest.mark.parametrize("end", [-1, 1], ids=["bottom", "top"])
@pytest.mark.parametrize("gap", [0.02, 0.05])
@pytest.mark.parametrize("polar", [0.0, 0.8])
def test_a_point_near_a_capsule_end_estimates_its_irradiance_unbiased_and_quiet(name, end, gap, polar):
    """From a point 0.02 and 0.05 radii off either end sphere (on the axis and 0.8 radians off it, facing the
    sphere), 100,000 draws estimate the irradiance the quadrature gives within four standard errors plus 0.1%, with
    a relative noise per draw under 1.5 (0.65 to 0.7; drawn by area there, it was 20 to 210), and the density each
    draw reports is the one ``tube_pdf`` reads back at its point within 0.2% (all but one in a thousand)."""
    p, n_p = off_end(name, end, gap, polar)
    values, pdfs = draws(name, 1, p, n_p, 100_000, seed=11)
    assert_unbiased_quiet_and_read_back(values, pdfs, irradiance(TUBES[name], p, n_p))


def assert_unbiased_quiet_and_read_back(values, pdfs, expected):
    """Draws' irradiance ``values`` estimate ``expected`` within four standard errors plus 0.1%, with a relative noise
    per draw under 1.5, and the density each draw reports (``pdfs[:, 0]``) is the one ``tube_pdf`` reads back at its
    point (``pdfs[:, 1]``) within 0.2% (all but one in a thousand)."""
    se = values.std() / math.sqrt(len(values))
    assert abs(values.mean() - expected) < 4.0 * se + 1e-3 * expected, (values.mean(), expected, se)
    assert values.std() < 1.5 * expected, values.std() / expected
    drawn = pdfs[:, 0] > 0.0
    off = np.abs(pdfs[drawn, 1] / pdfs[drawn, 0] - 1.0)
    assert (off < 2e-3).sum() >= 0.999 * drawn.sum(), np.sort(off)[-5:]


FLOOR_RES = 4  # pixels per side of the floor patch seen
FLOOR_PATCH = 0.4  # the patch's side, centred under the capsule's lowest point
FLOOR_RADIUS, FLOOR_HALF, FLOOR_GAP = 0.3, 0.6, 0.03  # the bottom sphere's radius, the half axis, the lowest height
FLOOR_AXIS = np.array([0.4, 0.2, 1.0]) / np.linalg.norm([0.4, 0.2, 1.0])  # the capsule leans, its bottom end down
FLOOR_TUBES = {"capsule": ("capsule", GLOW_CAPSULE, 1.0), "tapered": ("tapered", GLOW_TAPERED_CAPSULE, 0.5)}


def floor_capsule(kind):
    """``(shape, tube, centre, rot)``: a glowing capsule or tapered capsule leaning over the floor, its bottom
    sphere FLOOR_GAP radii above it, as a ``wrt.Shape``, as a row of :data:`TUBES`, and its centre and frame."""
    kind, code, taper = FLOOR_TUBES[kind]
    rot = frame(FLOOR_AXIS)
    centre = np.array([0.0, 0.0, FLOOR_RADIUS * (1.0 + FLOOR_GAP)]) + FLOOR_HALF * FLOOR_AXIS
    to_world = np.eye(4)
    to_world[:3, :3] = rot * FLOOR_RADIUS
    to_world[:3, 3] = centre
    params = np.array([FLOOR_HALF / FLOOR_RADIUS, taper if kind == "tapered" else 0.0, 0.0, 1.0], np.float32)
    shape = wrt.Shape("/Capsule", kind, to_world, material_id=1, params=params)
    return shape, (kind, code, taper, FLOOR_RADIUS, FLOOR_HALF), centre, rot


def floor_oracle(kind, sub=4):
    """``(FLOOR_RES, FLOOR_RES)`` float64 radiance of the white floor (albedo 1: E / pi) under the capsule, each
    pixel averaged over ``sub`` x ``sub`` floor points (row 0 at +Y), E by :func:`irradiance`."""
    _, tube, centre, rot = floor_capsule(kind)
    xs = ((np.arange(FLOOR_RES * sub) + 0.5) / (FLOOR_RES * sub) - 0.5) * FLOOR_PATCH
    out = np.array([[irradiance(tube, rot.T @ (np.array([x, y, 0.0]) - centre), rot.T @ np.array([0.0, 0.0, 1.0]),
                                n=100) for x in xs] for y in -xs])
    return RADIANCE / math.pi * out.reshape(FLOOR_RES, sub, FLOOR_RES, sub).mean(axis=(1, 3))


def render_under(scene, integrator, spp, seed):
    """``(FLOOR_RES, FLOOR_RES)`` radiance of the floor patch seen by an orthographic camera between the floor and
    the capsule (0.004 up, below its lowest point), looking down, image up along +Y."""
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.004), target=(0, 0, 0), up=(0, 1, 0), height=FLOOR_PATCH,
                                  clipping_range=(0.0, 1.0))
    img = wrt.render(scene, camera=cam, width=FLOOR_RES, height=FLOOR_RES, spp=spp, seed=seed, integrator=integrator)
    return img.rgb.mean(axis=-1).astype(np.float64)


@pytest.mark.parametrize("kind", FLOOR_TUBES)
@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_floor_just_under_a_capsule_end_renders_as_the_quadrature(kind, integrator):
    """A glowing capsule (or tapered capsule) leaning with its bottom sphere 0.03 radii above a white floor: the floor
    under it renders as the float64 quadrature says, every pixel and the patch's mean within five and four standard
    errors (over eight seeds) plus 0.5%, path's light samples MIS-weighted against its BSDF's hits by the density
    ``tube_pdf`` reads back. Under whitted (light sampling alone) each pixel's standard error is under 15% of its
    value at 128 samples (4.3%); drawn by area near the end, it was 44% to 280% (a few draws on the sphere's patch
    nearest the floor carrying most of the light)."""
    shape, _, _, _ = floor_capsule(kind)
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=materials())
    assert_floor_renders_as(scene, integrator, floor_oracle(kind))


def assert_floor_renders_as(scene, integrator, expected):
    """The floor patch of ``scene`` rendered by ``integrator`` at 128 samples over eight seeds equals ``expected``
    (its pixels' float64 light) in every pixel and in the patch's mean, within five and four standard errors plus
    0.5%; under whitted (light sampling alone) each pixel's standard error is under 15% of its value."""
    images = np.stack([render_under(scene, integrator, 128, seed) for seed in range(3, 11)])
    se = images.std(axis=0, ddof=1) / math.sqrt(len(images))
    assert (np.abs(images.mean(axis=0) - expected) < 5.0 * se + 0.005 * expected).all(), (images.mean(0), expected)
    means = images.mean(axis=(1, 2))
    mean_se = means.std(ddof=1) / math.sqrt(len(means))
    assert abs(means.mean() - expected.mean()) < 4.0 * mean_se + 0.005 * expected.mean(), (means, expected.mean())
    if integrator == "whitted":
        assert (se < 0.15 * expected).all(), (se / expected).max()


@pytest.mark.parametrize("name", CAPSULES)
def test_no_draw_is_dropped_from_inside_a_double_sided_capsule(name):
    """From points inside a double-sided capsule (near an end, outside its sphere, and inside an end sphere, beside
    the side and past it: below the bottom sphere's centre, above the top one's) every draw is kept: a cone's
    direction from inside the convex capsule enters its sphere inside the capsule, never on its end, so drawing the
    ends' cones there wasted up to two draws in three (a third to three fifths kept); from inside an end sphere past
    the side, the other end's cone still drew and 2.5% to 8% were dropped."""
    kind, code, taper, r, h = TUBES[name]
    top = r * taper
    us = wp.array(np.random.default_rng(2).uniform(size=(50_000, 2)).astype(np.float32), dtype=wp.vec2, device="cpu")
    for p in (np.array([0.0, 0.0, -h + 1.5 * r]), np.array([0.3 * r, 0.0, h - 0.5 * top]),
              np.array([0.0, 0.0, -h - 0.5 * r]), np.array([0.5 * r, 0.0, -h - 0.3 * r]),
              np.array([0.0, 0.0, h + 0.5 * top])):
        kept = wp.zeros(len(us), dtype=float, device="cpu")
        wp.launch(kept_kernel, len(us), inputs=[*device_tube(name), 0, wp.vec3(*to_world(p)), us], outputs=[kept],
                  device="cpu")
        assert kept.numpy().min() == 1.0, (p, kept.numpy().mean())


# Capsules that are spheres: H = 0 (two hemispheres), and a tapered capsule whose top sphere (radius 0.03) lies
# inside its bottom one (radius 0.1, centres 0.04 apart: no side, its surface the bottom sphere).
BALLS = {"capsule-sphere": (("capsule", GLOW_CAPSULE, 1.0, 0.1, 0.0), 0.0),
         "tapered-inside": (("tapered", GLOW_TAPERED_CAPSULE, 0.3, 0.1, 0.02), -0.02)}


@pytest.mark.parametrize("name", BALLS)
@pytest.mark.parametrize("polar", [0.0, 1.2, 2.5])
def test_a_capsule_that_is_a_sphere_estimates_its_irradiance_as_the_closed_form(name, polar):
    """From points 0.02 radii off a capsule that is a sphere (above its top, beside it, below it), 200,000 draws
    estimate the sphere's irradiance ``pi (R / d)^2`` within four standard errors plus 0.1% with a relative noise per
    draw under 1.5 (1.25; 0.65 for the tapered one), and each draw's density is the one ``tube_pdf`` reads back. The
    tapered one's bottom cone dropped the points above the side's middle as its top end's, which has no area: from
    above, it estimated with a noise of 130."""
    tube, centre_z = BALLS[name]
    TUBES[name] = tube
    try:
        d = np.array([math.sin(polar), 0.0, math.cos(polar)])
        p = np.array([0.0, 0.0, centre_z]) + 1.02 * tube[3] * d
        values, pdfs = draws(name, 1, p, -d, 200_000, seed=4)
    finally:
        del TUBES[name]
    assert_unbiased_quiet_and_read_back(values, pdfs, math.pi / 1.02**2)
