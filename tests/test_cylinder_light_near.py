"""A UsdLux CylinderLight's light draw near its side (sample_light through wrt.glowing_tubes' open tube: uniform by
area over the half facing the point, mixed with wrt.subtended_tube's draw by the angles the side subtends). Drawn by
area alone, a point 0.01 radii off a long cylinder light estimated its irradiance with a relative noise of 100 or
more per draw. Against a float64 quadrature of the irradiance (tests/test_subtended_tube.py's sinh grids resolving the
near patch): the estimate is unbiased, quiet near the side, and the density ``area_light_pdf`` reads back (path's MIS
weight of a ray that hits the light) is the one the draw reported and integrates to 1 over the half drawn from."""

import math

import numpy as np
import pytest
import warp as wp
from test_affine_lights import renderer, sample_and_hit_kernel, turned
from test_subtended_tube import irradiance_from, surface

from wrt.glowing_spheres import GLOW_OPEN_CYLINDER
from wrt.light_sampling import DeviceLights, area_light_pdf
from wrt.lights import CylinderLight

CENTRE = np.array([0.2, -0.1, 1.6])
TURN = turned((10, 30, -20))
RADIUS, LENGTH = 0.1, 2.0  # ten radii each way
TUBE = ("cylinder", GLOW_OPEN_CYLINDER, 1.0, RADIUS, 0.5 * LENGTH)  # test_subtended_tube's row: open, no caps
FRAME = TURN[:, [1, 2, 0]]  # the tube frame's X, Y and axis (the light's local X) in the world


def light_renderer():
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = TURN, CENTRE
    return renderer(CylinderLight(m, LENGTH, RADIUS, np.ones(3)))


def off_side(gap):
    """``(p, n_p)`` in the tube frame: a point ``gap`` radii off the side, a fifth of the way up, facing it."""
    return np.array([RADIUS * (1.0 + gap), 0.0, 0.1 * LENGTH]), np.array([-1.0, 0.0, 0.0])


def draws(r, p, n_p, count):
    """``(estimates, pdf_ratio)`` float64: each draw's irradiance estimate (radiance 1) from ``p`` with normal ``n_p``
    (tube frame), and ``area_light_pdf`` at the point drawn over the pdf the draw reported."""
    out = [wp.zeros(count, dtype=float, device=r.device) for _ in range(3)]
    wp.launch(sample_and_hit_kernel, count, inputs=[r.device_lights, r.device_scene, r.materials, r.surfaces,
                                                    wp.vec3(*(CENTRE + FRAME @ p)), wp.vec3(*(FRAME @ n_p))],
              outputs=out, device=r.device)
    return out[0].numpy().astype(np.float64), out[1].numpy().astype(np.float64)


@wp.kernel
def density_kernel(lights: DeviceLights, p: wp.vec3, qs: wp.array[wp.vec3], ns: wp.array[wp.vec3],
                   # outputs
                   densities: wp.array[float]):
    """``area_light_pdf`` of light 0 at ``qs[i]`` (normal ``ns[i]``) from ``p`` as a density by area."""
    i = wp.tid()
    to = qs[i] - p
    dist = wp.length(to)
    wi = to / dist
    cos_l = wp.abs(wp.dot(wi, ns[i]))  # the facing half's back-facing points are drawn too (and dropped)
    densities[i] = area_light_pdf(lights, 0, p, wp.vec3(0.0), wi, dist, cos_l) * cos_l / (dist * dist)


@pytest.fixture(scope="module")
def lit():
    return light_renderer()


@pytest.mark.parametrize("gap", [0.01, 0.1, 1.0, 10.0])
def test_a_point_near_a_cylinder_light_estimates_its_irradiance_unbiased_and_quiet(lit, gap):
    """From 0.01, 0.1, 1 and 10 radii off the side, 50,000 draws estimate the quadrature's irradiance within four
    standard errors plus 0.1%, and within 0.1 radii with a relative noise per draw under 1.5 (drawn by area alone:
    100 to 430 at 0.01 radii, 27 to 86 at 0.1; now 0.6 and 0.5); the pdf a ray along each draw reads back is the
    one drawn with."""
    p, n_p = off_side(gap)
    expected = irradiance_from(TUBE, p, n_p)
    values, pdf_ratio = draws(lit, p, n_p, 50_000)
    se = values.std() / math.sqrt(len(values))
    assert abs(values.mean() - expected) < 4.0 * se + 1e-3 * expected, (values.mean(), expected, se)
    if gap < 0.5:
        assert values.std() < 1.5 * expected, values.std() / expected
    off = np.abs(pdf_ratio - 1.0) > 2e-3
    assert values[off].sum() <= 1e-3 * values.sum(), off.mean()


@pytest.mark.parametrize("p", [(0.101, 0.0, 0.2), (0.05, 0.02, 1.4), (2.0, -1.0, 0.7)], ids=["near", "past-end", "far"])
def test_the_cylinder_light_density_integrates_to_one_over_its_facing_half(lit, p):
    """``area_light_pdf`` as a density by area, summed by the float64 quadrature over the half of the side facing
    the point (what the draw by area takes points of; the subtended draw's lie inside it), is 1 within 0.5%."""
    p = np.asarray(p)
    q, nq, dA = surface(TUBE, p, single_sided=True)
    device = lit.device  # the renderer's (cuda:0 under benchmarks/render_on_cuda.py)
    densities = wp.zeros(len(q), dtype=float, device=device)
    wp.launch(density_kernel, len(q), inputs=[lit.device_lights, wp.vec3(*(CENTRE + FRAME @ p)),
                                              wp.array(CENTRE + q @ FRAME.T, dtype=wp.vec3, device=device),
                                              wp.array(nq @ FRAME.T, dtype=wp.vec3, device=device)],
              outputs=[densities], device=device)
    total = float((densities.numpy().astype(np.float64) * dA).sum())
    assert abs(total - 1.0) < 5e-3, total
