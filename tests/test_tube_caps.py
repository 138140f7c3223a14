"""A glowing capped tube's light draw near its flat caps (wrt.glowing_tubes with wrt.tube_caps): drawn by area alone
there (the draw by the angles the side subtends reaches only the side), a shading point 0.02 to 0.05 radii off a cap
estimated its irradiance with a relative noise of 12 to 110 per draw; the disk light's draw (by the solid angle of
the square around the cap, kept on the disk) brings it near 1. Every estimate stays unbiased against a float64
quadrature of the irradiance over the tube's side and the cap, refined around the point's foot on the cap; the
mixture's density integrates over that surface to the share of draws kept, and the density a draw reports is the one
``tube_pdf`` reads back (path's MIS weight of a hit)."""

import math

import numpy as np
import pytest
import warp as wp
from test_capsule_ends import FLOOR_PATCH, FLOOR_RES, assert_floor_renders_as, assert_unbiased_quiet_and_read_back
from test_glowing_spheres import RADIANCE, floor_mesh, materials
from test_subtended_tube import (
    CENTRE,
    ROT,
    TUBES,
    device_tube,
    draws,
    kept_kernel,
    side,
    sinh_grid,
    surface,
    to_world,
    tube_densities,
)

import wrt
from wrt.glowing_spheres import GLOW_CAPPED_CYLINDER

CAPPED = ["capped-cylinder", "capped-frustum"]


def cap_disk(tube, s, p, n=400):
    """``(q, nq, dA)`` float64 (the tube's frame, axis +Z): a quadrature of the cap ``s`` (-1 bottom, 1 top) of the
    capped tube ``tube`` (a row of :data:`TUBES`) in polar coordinates about its centre, on sinh grids in radius and
    angle about the foot of ``p`` on its plane, so that a point 0.02 radii off resolves."""
    kind, code, taper, r, h = tube
    cap = r * (taper if s > 0 else 1.0)
    height = max(abs(p[2] - s * h), 1e-6 * r)
    rho_p = math.hypot(p[0], p[1])
    rhos, wr = sinh_grid(min(rho_p, cap), height, 0.0, cap, n)
    phis, wphi = sinh_grid(0.0, height / max(rho_p, height), -math.pi, math.pi, 2 * n)
    rr, pp = np.meshgrid(rhos, phis + math.atan2(p[1], p[0]), indexing="ij")
    q = np.stack([rr * np.cos(pp), rr * np.sin(pp), np.full_like(rr, s * h)], -1).reshape(-1, 3)
    return q, np.broadcast_to([0.0, 0.0, s], q.shape), (rr * np.outer(wr, wphi)).reshape(-1)


def refined_surface(tube, p, s, single_sided, n=400):
    """``(q, nq, dA)``: :func:`test_subtended_tube.surface` (what a draw from ``p`` takes points of; its side refined
    about ``p``'s foot on it) with its cap ``s`` on :func:`cap_disk`'s grid, refined about ``p``'s foot on it."""
    q, nq, dA = surface(tube, p, single_sided=single_sided, n=n)
    rest = ~((nq[:, 2] == s) & (q[:, 2] == s * tube[4]))
    parts = [(q[rest], nq[rest], dA[rest]), cap_disk(tube, s, p, n)]
    return tuple(np.concatenate(x) for x in zip(*parts))


def irradiance(tube, p, n_p, s):
    """float64 irradiance over the radiance at ``p`` (normal ``n_p``, the tube's frame) from the single-sided capped
    tube ``tube`` beyond its cap ``s``: ``cos_p cos_l / d^2 dA`` summed over the points whose front faces ``p``."""
    q, nq, dA = refined_surface(tube, p, s, single_sided=False)
    v = q - p
    d = np.linalg.norm(v, axis=1)
    return float((np.clip(-(v * nq).sum(1) / d, 0.0, None) * np.clip(v @ n_p / d, 0.0, None) / d**2 * dA).sum())


def off_cap(name, s, gap, off):
    """``(p, n_p)``: a point ``gap`` radii (the cap's) off the cap ``s`` (-1 bottom, 1 top), over its point ``off``
    of its radius from the centre, facing it (the tube's frame)."""
    kind, code, taper, r, h = TUBES[name]
    cap = r * (taper if s > 0 else 1.0)
    return np.array([off * cap, 0.0, s * (h + gap * cap)]), np.array([0.0, 0.0, -s])


@pytest.mark.parametrize("name", CAPPED)
@pytest.mark.parametrize("end", [-1, 1], ids=["bottom", "top"])
@pytest.mark.parametrize("gap", [0.02, 0.05])
@pytest.mark.parametrize("off", [0.0, 0.7])
def test_a_point_near_a_cap_estimates_its_irradiance_unbiased_and_quiet(name, end, gap, off):
    """From a point 0.02 and 0.05 radii off either cap (over its centre and 0.7 radii out, facing it), 100,000 draws
    estimate the irradiance the quadrature gives within four standard errors plus 0.1%, with a relative noise per
    draw under 1.5 (drawn by area there, it was 12 to 110; now 0.7), and the density each draw reports is the one
    ``tube_pdf`` reads back at its point within 0.2% (all but one in a thousand)."""
    p, n_p = off_cap(name, end, gap, off)
    values, pdfs = draws(name, 1, p, n_p, 100_000, seed=11)
    assert_unbiased_quiet_and_read_back(values, pdfs, irradiance(TUBES[name], p, n_p, end))


def density_total_and_kept(tube, p, s, facing, count=200_000):
    """``(total, share)``: the density by area ``tube_pdf`` gives from ``p`` (the tube's frame) summed by the float64
    quadrature over what the capped tube ``tube`` (a row of :data:`TUBES`, placed as :func:`device_tube` places
    them) draws from (a double-sided tube's whole surface; a single-sided one's part
    :func:`test_subtended_tube.surface` names), its cap ``s`` refined about p's foot, and the share of ``count`` draws
    kept."""
    kind, code, taper, r, h = tube
    placed = (wp.vec4(*CENTRE, r), wp.vec4(*(ROT[:, 2] * h), code), taper)
    q, nq, dA = refined_surface(tube, p, s, single_sided=facing == 1)
    densities = tube_densities(placed, facing, p, q, nq)
    total = float((densities * dA).sum())
    us = np.random.default_rng(5).uniform(size=(count, 2)).astype(np.float32)
    kept = wp.zeros(count, dtype=float, device="cpu")
    wp.launch(kept_kernel, count, inputs=[*placed, facing, wp.vec3(*to_world(p)), wp.array(us, dtype=wp.vec2,
                                                                                             device="cpu")],
              outputs=[kept], device="cpu")
    return total, float(kept.numpy().mean())


@pytest.mark.parametrize("name", CAPPED)
@pytest.mark.parametrize("facing", [0, 1])
@pytest.mark.parametrize("off", [0.0, 0.9, 1.3])
def test_the_density_near_a_cap_integrates_to_the_share_of_draws_kept(name, facing, off):
    """From points 0.02 radii beyond the top cap's plane (over its centre, near its rim and past it, beside the side),
    the density by area ``tube_pdf`` gives, summed by the float64 quadrature over what the tube draws from, the top
    cap refined about p's foot, is the share of draws kept within 0.5%: the cap's draws that fall off the disk are
    dropped (200,000 draws count them)."""
    p, _ = off_cap(name, 1, 0.02, off)
    total, share = density_total_and_kept(TUBES[name], p, 1, facing)
    assert abs(total - share) < 5e-3, (total, share)
    assert share < 1.0, share  # the cap's draw takes part there


@pytest.mark.parametrize("facing", [0, 1])
@pytest.mark.parametrize("off", [0.0, 0.7])
def test_a_sharp_frustums_density_beyond_its_wide_cap_integrates_to_the_share_kept(facing, off):
    """A capped frustum whose top radius is a thousandth of its bottom one (0.3 and 3e-4, 0.9 each way), from points
    0.02 radii beyond its bottom cap: the density ``tube_pdf`` gives integrates to the share of draws kept within
    0.5%, its tiny top cap included (the area draw reaches it). The top cap's square, 6e-4 wide 1.8 away, has a solid
    angle float32 rounds to 0: its disk draw's pdf there was infinite and, times that cap's weight 0, made the
    density NaN at every point of it, though that cap takes no disk draws from there."""
    tube = ("cone", GLOW_CAPPED_CYLINDER, 1e-3, 0.3, 0.9)
    p = np.array([off * 0.3, 0.0, -0.9 - 0.02 * 0.3])
    total, share = density_total_and_kept(tube, p, -1, facing)
    assert abs(total - share) < 5e-3, (total, share)
    assert share < 1.0, share  # the bottom cap's draw takes part there


@pytest.mark.parametrize("name", CAPPED)
@pytest.mark.parametrize("end", [-1, 1], ids=["bottom", "top"])
def test_the_density_is_continuous_across_a_caps_plane_beside_the_tube(name, end):
    """From points 1e-5 radii either side of a cap's plane, 1.2 radii off the axis all round it (beside the tube: a
    floor a capped cylinder stands on), the density at side points differs by under 0.1%: path reads a hit's density
    from its ray's origin, just off the shading point, and light sampling from the shading point itself. Weighted by
    the solid angle of the square the cap is drawn through alone, the cap's draw took near all of the guided share
    just beyond the plane in the square's corners (its solid angle near 2 pi there) and none just inside it."""
    kind, code, taper, r, h = TUBES[name]
    z0, z1, ra, rb = side(kind, r, h, taper)
    cap = r * (taper if end > 0 else 1.0)
    slope = (rb - ra) / (z1 - z0)
    for angle in np.arange(16) * math.pi / 8 + 0.1:
        zs = np.linspace(z0, z1, 7)[1:-1]
        deltas = angle + np.array([-0.6, 0.0, 0.6])
        zz, dd = np.meshgrid(zs, deltas, indexing="ij")
        radius = ra + (rb - ra) * (zz - z0) / (z1 - z0)
        q = np.stack([radius * np.cos(dd), radius * np.sin(dd), zz], -1).reshape(-1, 3)
        nq = np.stack([np.cos(dd), np.sin(dd), np.full_like(dd, -slope)], -1).reshape(-1, 3) / math.hypot(1.0, slope)
        densities = []
        for side_of in (-1.0, 1.0):
            p = np.array([1.2 * cap * math.cos(angle), 1.2 * cap * math.sin(angle), end * (h + side_of * 1e-5 * r)])
            densities.append(tube_densities(device_tube(name), 1, p, q, nq))
        assert (densities[0] > 0.0).all()
        np.testing.assert_allclose(densities[1], densities[0], rtol=1e-3, err_msg=f"angle {angle}")


@pytest.mark.parametrize("name", CAPPED)
@pytest.mark.parametrize("end", [-1, 1], ids=["bottom", "top"])
@pytest.mark.parametrize("beyond", [0.05, 0.3])
def test_a_single_sided_caps_density_is_continuous_across_the_sides_extension(name, end, beyond):
    """From points 1e-5 radii either side of the side's extension past a cap (``beyond`` half lengths past the cap's
    plane: over the cap, or just outside its rim), the density at the cap's points, which a single-sided tube shows
    both, differs by under 2% (a cone's facing arc opens as the square root of the distance, 1% there). Inside the
    extension the side shows p no front and takes no draws by the angles it subtends; just outside it took nearly
    half of them, and the cap's density jumped 45-50%, the jump path's MIS met where a shading point and its ray's
    origin lay either side (a floor under a hanging cylinder, at its rim)."""
    kind, code, taper, r, h = TUBES[name]
    z0, z1, ra, rb = side(kind, r, h, taper)
    cap = r * (taper if end > 0 else 1.0)
    z = end * h * (1.0 + beyond)
    ext = ra + (rb - ra) * (z - z0) / (z1 - z0)  # the side's radius extended to height z
    rr, pp = np.meshgrid((np.arange(20) + 0.5) / 20 * cap, np.arange(40) * math.pi / 20, indexing="ij")
    q = np.stack([rr * np.cos(pp), rr * np.sin(pp), np.full_like(rr, end * h)], -1).reshape(-1, 3)
    nq = np.broadcast_to([0.0, 0.0, float(end)], q.shape)
    densities = []
    for side_of in (-1.0, 1.0):
        p = np.array([ext + side_of * 1e-5 * r, 0.0, z])
        densities.append(tube_densities(device_tube(name), 1, p, q, nq))
    assert (densities[0] > 0.0).all()
    np.testing.assert_allclose(densities[1], densities[0], rtol=0.02)


FLOOR_CAP_RADIUS, FLOOR_CAP_HALF, FLOOR_CAP_GAP = 0.3, 0.6, 0.03  # a standing cylinder's radius, half axis, lift


def disk_irradiance(radius, height, rho):
    """Irradiance over the radiance at a point facing a Lambertian disk of ``radius`` parallel to it, ``height``
    away, its foot ``rho`` from the disk's axis: the closed form ``pi / 2 (1 - (h^2 + rho^2 - R^2) /
    sqrt((h^2 + rho^2 + R^2)^2 - 4 R^2 rho^2))``."""
    h2, r2, R2 = height * height, rho * rho, radius * radius
    return math.pi / 2.0 * (1.0 - (h2 + r2 - R2) / np.sqrt((h2 + r2 + R2) ** 2 - 4.0 * R2 * r2))


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_floor_just_under_a_cylinders_cap_renders_as_the_closed_form(integrator):
    """A glowing capped cylinder standing 0.03 radii above a white floor: the floor patch under its bottom cap (all of
    whose light comes from the cap: it sees only the back of the side) renders as the disk's closed-form irradiance
    says, every pixel and the patch's mean within five and four standard errors (over eight seeds) plus 0.5%, path's
    light samples MIS-weighted against its BSDF's hits by the density ``tube_pdf`` reads back. Under whitted (light
    sampling alone) each pixel's standard error is under 15% of its value at 128 samples: drawn by area, the few
    draws on the cap's patch just over each floor point carried most of the light."""
    to_world = np.diag([FLOOR_CAP_RADIUS, FLOOR_CAP_RADIUS, FLOOR_CAP_HALF, 1.0])
    to_world[2, 3] = FLOOR_CAP_HALF + FLOOR_CAP_GAP * FLOOR_CAP_RADIUS
    shape = wrt.Shape("/Cylinder", "cylinder", to_world, material_id=1, params=np.array([1.0, 0.0, 0.0, 1.0],
                                                                                        np.float32))
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=materials())
    sub = 8
    xs = ((np.arange(FLOOR_RES * sub) + 0.5) / (FLOOR_RES * sub) - 0.5) * FLOOR_PATCH
    xx, yy = np.meshgrid(xs, -xs)
    e = disk_irradiance(FLOOR_CAP_RADIUS, FLOOR_CAP_GAP * FLOOR_CAP_RADIUS, np.hypot(xx, yy))
    assert_floor_renders_as(scene, integrator,
                            (RADIANCE / math.pi * e).reshape(FLOOR_RES, sub, FLOOR_RES, sub).mean(axis=(1, 3)))
