"""Rect lights and glowing planes sheared into parallelograms, drawn by the solid angle of the two triangles they split
into (wrt.spherical_parallelogram), against independent float64 oracles: Lambert's closed form for the parallelogram
(the mean of the draws and a rendered floor), quadrature of the pdf over the directions to the light's plane (it
integrates to 1), and the pdf a ray along each draw reads back. Drawn by area, a point near such a light estimated its
irradiance with a relative noise per draw of 30 (0.01 below a unit one) or 3.2 (0.1 below)."""

import math

import numpy as np
import pytest
import warp as wp
from light_oracle import polygon_irradiance
from shading_helpers import pixel_points, quad, top_down_camera
from test_lights import ALBEDO, PATCH, RES, above_horizon, light_estimates, light_renderer

import wrt
from wrt.light_sampling import DeviceLights, area_light_pdf, intersect_light, sample_light
from wrt.lights import RectLight
from wrt.materials import DeviceMaterials
from wrt.scene import DeviceScene
from wrt.shade import DeviceSurfaces

SHEAR = np.array([[1.0, 0.8, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # the Y axis leans into X
DRAWS = 200_000


def placed(linear, centre):
    to_world = np.eye(4)
    to_world[:3, :3] = linear
    to_world[:3, 3] = centre
    return to_world


def sheared_rect(centre=(0.0, 0.0, 0.0), linear=SHEAR):
    """A unit rect light under ``linear`` (emitting along -Z, down), and its corners (world, float64)."""
    to_world = placed(linear, centre)
    x, y, c = to_world[:3, 0], to_world[:3, 1], to_world[:3, 3]
    corners = [c + (su * x + sv * y) / 2 for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return RectLight(to_world=to_world, width=1.0, height=1.0, color=np.full(3, 2.0)), to_world, corners


@wp.kernel
def glow_estimates_kernel(lights: DeviceLights, scene: DeviceScene, mats: DeviceMaterials, surf: DeviceSurfaces,
                          k: int, p: wp.vec3, n: wp.vec3,
                          # outputs
                          irradiance: wp.array[float]):
    i = wp.tid()
    state = wp.rand_init(5, i)
    u1 = wp.randf(state)
    u2 = wp.randf(state)
    ls = sample_light(lights, scene, mats, surf.uvs, surf.materials, surf.double_sided, k, p, n, u1, u2)
    irradiance[i] = ls.value[0] * wp.max(wp.dot(n, ls.wi), 0.0)


@wp.kernel
def rect_pdf_kernel(lights: DeviceLights, p: wp.vec3, n: wp.vec3, dirs: wp.array[wp.vec3],
                    # outputs
                    pdfs: wp.array[float]):
    """The pdf path reads for light 0 along each direction: at its hit, 0 where it misses."""
    i = wp.tid()
    t, cos_l = intersect_light(lights, 0, p, dirs[i])
    pdfs[i] = 0.0
    if t < wp.inf:
        pdfs[i] = area_light_pdf(lights, 0, p, n, dirs[i], t, cos_l)


def glowing_plane_estimates(to_world, p, n):
    """Irradiance estimates at ``p`` (normal ``n``) from a glowing plane of radiance 2 placed by ``to_world`` (its
    canonical square [-1, 1]^2; its front along the transform's -Z, so that it faces as the rect light does)."""
    materials = [wrt.Material("/Glow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(2.0, 2.0, 2.0))]
    flip = placed(np.diag([1.0, -1.0, -1.0]), (0.0, 0.0, 0.0))  # the plane's front is its +Z: turned to -Z
    scene = wrt.Scene(meshes=[quad((0, 0, -50), (1, 0, 0), (0, 1, 0))], materials=materials,
                      shapes=[wrt.Shape("/Glow", "plane", to_world @ flip, material_id=0)])
    r = wrt.Renderer(scene, camera=top_down_camera((0, 0, 0), height=1.0), width=2, height=2, device="cpu")
    irradiance = wp.zeros(DRAWS, dtype=float, device=r.device)
    lights = r.device_lights
    wp.launch(glow_estimates_kernel, DRAWS, inputs=[lights, r.device_scene, r.materials, r.surfaces,
                                                    lights.first_glowing_sphere, wp.vec3(*p), wp.vec3(*n)],
              outputs=[irradiance], device=r.device)
    return irradiance.numpy().astype(np.float64)


# Points below the light (z = 0, emitting down): the relative noise per draw drawn by area there (measured before the
# draw by solid angle), and the bound drawn by solid angle (measured 0.040, 0.22, 0.36 and 0.125).
POINTS = {
    "0.01 below the centre": ((0.0, 0.0, -0.01), 30.0, 0.1),
    "0.1 below the centre": ((0.0, 0.0, -0.1), 3.2, 0.5),
    "0.01 below, beyond an end": ((0.9, 0.1, -0.01), 2.6, 1.0),
    "1 below": ((0.0, 0.0, -1.0), 0.25, 0.2),
}


def assert_read_back(ratios):
    """Each draw's pdf read back along its ray equals the one it reported (ratio 1), but for a few in 10^4 read as 0: a
    draw on the light's very edge passed by its own ray traced back, a rounding tie (1 of 200,000 draws from far off
    on an H100), as ``test_glowing_hull_pdf`` lets through."""
    tie = ratios == 0.0
    assert tie.sum() <= 1e-4 * len(ratios), f"{tie.sum()} of {len(ratios)} draws not read back"
    np.testing.assert_allclose(ratios[~tie], 1.0, rtol=2e-3)


@pytest.mark.parametrize("kind", ["rect light", "glowing plane"])
@pytest.mark.parametrize("where", list(POINTS))
def test_a_sheared_light_seen_from_near_is_drawn_by_solid_angle(kind, where):
    """A unit rect light or glowing plane whose Y axis leans into X by 0.8 is a parallelogram; from a point near it
    (facing it) the draws average to Lambert's closed form for that parallelogram and their noise per draw is below a
    bound the draw by area (its measured noise in POINTS) failed near the light; a rect light's draws read their pdf
    back along a ray."""
    p, _, bound = POINTS[where]
    n = np.array([0.0, 0.0, 1.0])
    light, to_world, corners = sheared_rect()
    expected = polygon_irradiance(p, n, corners, 2.0)
    if kind == "rect light":
        estimates, ratios = light_estimates(light, p, n, count=DRAWS)
        assert_read_back(ratios)
    else:
        estimates = glowing_plane_estimates(placed(SHEAR @ np.diag([0.5, 0.5, 1.0]), (0.0, 0.0, 0.0)), p, n)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error + 1e-4 * expected, (estimates.mean(), expected, error)
    assert estimates.std() < bound * expected, estimates.std() / expected


@pytest.mark.parametrize("kind", ["rect light", "glowing plane"])
def test_a_surface_tilted_away_from_a_sheared_light_near_it_draws_on_its_front(kind):
    """A point 0.01 below the sheared unit light, its normal along the light's plane tilted 1 degree away from it,
    sees half of the light above its horizon. Its cosine-weighted draws (96% of them, the light filling most of the
    hemisphere) were turned to its back, by the side of the plane the point lies on, where an opaque surface
    takes nothing: a relative noise per draw of 8.1. Drawn about the normal, where a corner of the light lies above
    its horizon (as a rect's are): 1.04. The mean is Lambert's closed form over the part of the parallelogram above
    the horizon (float64)."""
    t = math.radians(1.0)
    p, n = np.array([0.0, 0.1, -0.01]), np.array([math.cos(t), 0.0, -math.sin(t)])
    light, to_world, corners = sheared_rect()
    expected = polygon_irradiance(p, n, above_horizon(p, n, np.asarray(corners)), 2.0)
    if kind == "rect light":
        estimates, ratios = light_estimates(light, p, n, count=DRAWS)
        assert_read_back(ratios)
    else:
        estimates = glowing_plane_estimates(placed(SHEAR @ np.diag([0.5, 0.5, 1.0]), (0.0, 0.0, 0.0)), p, n)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error + 1e-4 * expected, (estimates.mean(), expected, error)
    assert estimates.std() < 2.0 * expected, estimates.std() / expected


# Points from which the pdf is integrated: near the centre, near an end, beside the light just below its plane, from
# where one half looks tiny (under 1e-3 sr: drawn by area within it, picked by its solid angle), far off to the side.
PDF_POINTS = {
    "near": (0.1, 0.2, -0.05),
    "near an end": (0.95, 0.3, -0.01),
    "beside, just below": (1.4, -0.2, -0.01),
    "one half tiny": (0.6, 0.3, -5e-4),
    "far": (3.0, 1.0, -2.0),
}


@pytest.mark.parametrize("where", list(PDF_POINTS))
def test_a_sheared_rect_lights_pdf_integrates_to_its_draws_share_and_is_read_back_as_drawn(where):
    """The pdf a ray that meets the sheared light reads back integrates over the directions to its plane (float64
    quadrature) to the share of draws that meet it (1 but for the cosine-weighted draws that pass it), and equals
    the pdf each draw reported."""
    p = np.array(PDF_POINTS[where])
    n = np.array([0.0, 0.0, 1.0])
    light, to_world, corners = sheared_rect()
    if where == "one half tiny":  # the case it stands for: one half under 1e-3 sr, the other over it (float64)
        a, b, c, d = corners[1], corners[2], corners[3], corners[0]  # b - d, the shorter diagonal, splits it
        halves = [polygon_solid_angle(p, [a, b, c]), polygon_solid_angle(p, [a, c, d])]
        assert min(halves) < 1e-3 < max(halves), halves
    r = light_renderer(light)
    directions, weights = parallelogram_directions(to_world, p)
    dirs = wp.array(directions.astype(np.float32), dtype=wp.vec3, device=r.device)
    pdfs = wp.zeros(len(dirs), dtype=float, device=r.device)
    wp.launch(rect_pdf_kernel, len(dirs), inputs=[r.device_lights, wp.vec3(*p), wp.vec3(*n), dirs], outputs=[pdfs],
              device=r.device)
    assert weights.sum() == pytest.approx(polygon_solid_angle(p, corners), rel=1e-4)  # the grid's own check
    integral = pdfs.numpy().astype(np.float64) @ weights
    estimates, ratios = light_estimates(light, p, n, count=DRAWS)
    assert_read_back(ratios)
    share = (estimates > 0.0).mean()
    assert share > 0.9, share
    assert integral == pytest.approx(share, abs=4.0 * np.sqrt(share * (1 - share) / DRAWS) + 0.002), (integral, share)


def graded(lo, hi, centre, n=800, least=1e-6):
    """``(nodes, widths)``: midpoints and widths of cells over ``[lo, hi]`` geometrically graded in their distance from
    ``centre`` (from ``least`` of the interval's length where it lies inside), ``n`` per side of it."""
    nodes, widths = [], []
    for side, far in ((1.0, hi), (-1.0, lo)):
        near = min(max(centre, lo), hi)
        start, end = abs(near - centre), abs(far - centre)
        if end <= start:
            continue
        edges = np.exp(np.linspace(np.log(max(start, least * (hi - lo))), np.log(end), n + 1))
        edges[0] = start
        nodes.append(centre + side * 0.5 * (edges[1:] + edges[:-1]))
        widths.append(np.diff(edges))
    return np.concatenate(nodes), np.concatenate(widths)


def parallelogram_directions(to_world, p):
    """``(directions, solid angles)`` from ``p`` to the points of the light's parallelogram ``to_world`` (its X and Y
    columns, unit width and height): a product grid in the edge coordinates ``(a, b)``, conforming to the edges and
    graded towards ``p``'s foot, each cell's area ``|x cross y| da db`` seen as ``cos / d^2``."""
    x, y, c = to_world[:3, 0], to_world[:3, 1], to_world[:3, 3]
    cross = np.cross(x, y)
    normal = cross / np.linalg.norm(cross)
    h = abs((p - c) @ normal)
    foot = np.linalg.lstsq(np.stack([x, y], -1), p - c, rcond=None)[0]
    a, da = graded(-0.5, 0.5, foot[0])
    b, db = graded(-0.5, 0.5, foot[1])
    aa, bb = (g.reshape(-1) for g in np.meshgrid(a, b))
    area = np.outer(db, da).reshape(-1) * np.linalg.norm(cross)
    to_q = c + aa[:, None] * x + bb[:, None] * y - p
    d = np.linalg.norm(to_q, axis=1)
    return to_q / d[:, None], area * h / d**3


def polygon_solid_angle(p, corners):
    """Solid angle (float64) of the planar polygon ``corners`` seen from ``p``: a fan of Van Oosterom and Strackee's
    triangles."""
    v = np.asarray(corners, np.float64) - np.asarray(p, np.float64)
    total = 0.0
    for i in range(1, len(v) - 1):
        a, b, c = v[0], v[i], v[i + 1]
        la, lb, lc = np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(c)
        total += 2.0 * math.atan2(abs(np.dot(a, np.cross(b, c))),
                                  la * lb * lc + np.dot(a, b) * lc + np.dot(b, c) * la + np.dot(c, a) * lb)
    return total


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_floor_under_a_sheared_rect_light_renders_as_lamberts_formula(integrator):
    """A grey floor 0.05 under a sheared unit rect light shows Lambert's closed form for the parallelogram (float64,
    averaged over each pixel, as its samples are: the light changes within a pixel near its edges), within what 256
    samples allow (a relative noise per draw up to 0.6 beside its edges): the mean over the patch within 1%, every
    pixel within 25%. Drawn by area, a draw's noise there was 3 to 30."""
    light, _, corners = sheared_rect((0.1, 0.0, 0.05))
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=[light])
    img = wrt.render(scene, camera=top_down_camera((0, 0, 0), height=PATCH), width=RES, height=RES, spp=256, seed=1,
                     device="cpu", integrator=integrator, max_depth=1)
    rendered = img.rgb.mean(axis=-1)
    sub = 6  # sub-pixels per side
    points = pixel_points((0, 0, 0), PATCH, RES * sub, RES * sub)
    n = np.array([0.0, 0.0, 1.0])
    fine = np.array([[polygon_irradiance(q, n, corners, 2.0) for q in row] for row in points])
    expected = fine.reshape(RES, sub, RES, sub).mean(axis=(1, 3)) * ALBEDO / np.pi
    ratio = rendered / expected
    assert abs(ratio.mean() - 1.0) < 0.01, ratio.mean()
    assert np.abs(ratio - 1.0).max() < 0.25, np.abs(ratio - 1.0).max()
