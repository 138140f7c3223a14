"""Lights: irradiance on a plane against closed-form values, UsdLux radiometry (intensity, exposure, colour,
normalize) read from USD, and the default lights of a stage without any."""

import copy
import dataclasses
import math
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest
import warp as wp
from light_oracle import polygon_irradiance
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux
from shading_helpers import pixel_points, quad, top_down_camera

import wrt
from wrt.integrators.emitters import environment, lights_on_segment
from wrt.light_sampling import DeviceLights, area_light_pdf, intersect_light, sample_light
from wrt.lights import CylinderLight, DiskLight, DomeLight, RectLight, SphereLight
from wrt.materials import DeviceMaterials
from wrt.primitives import tessellate
from wrt.scene import DeviceScene
from wrt.shade import DeviceSurfaces

ALBEDO = 0.5  # the default material's grey: radiance = ALBEDO * E / pi
RES = 16  # pixels per side of the patch that is checked
PATCH = 0.8  # side of the checked patch of the plane, scene units


def render_plane(lights, spp=64, patch=PATCH, center=(0.0, 0.0, 0.0), seed=1):
    """Radiance ``(H, W)`` of a large grey plane z = 0 lit only by ``lights`` (direct light only), and the world
    point under each pixel."""
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=list(lights))
    cam = top_down_camera(center, height=patch)
    img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=spp, seed=seed, device="cpu", integrator="path",
                     max_depth=1)
    assert (img.aovs["prim"] >= 0).all()
    return img.rgb.mean(axis=-1), pixel_points(center, patch, RES, RES)


def rect_corner_factor(a, b, c):
    """View factor from a differential area to a parallel a x b rectangle at height c with one corner above it."""
    A, B = a / c, b / c
    sa, sb = np.sqrt(1 + A * A), np.sqrt(1 + B * B)
    return (A / sa * np.arctan(B / sa) + B / sb * np.arctan(A / sb)) / (2 * np.pi)


def rect_irradiance(points, half_w, half_h, height, radiance):
    """Irradiance at ``points`` (inside the footprint) from a parallel rectangle centred above the origin."""
    x, y = points[..., 0], points[..., 1]
    total = 0.0
    for a in (half_w - x, half_w + x):
        for b in (half_h - y, half_h + y):
            total = total + rect_corner_factor(a, b, height)
    return np.pi * radiance * total


def check(rendered, expected, tol=0.02, pixel_tol=0.25):
    ratio = rendered.mean() / expected.mean()
    assert abs(ratio - 1) < tol, f"mean radiance {rendered.mean():.5f} vs closed form {expected.mean():.5f}"
    assert np.abs(rendered / expected - 1).max() < pixel_tol  # no pixel is far off


def test_distant_light_illuminance_is_exact():
    direction = np.array([0.3, 0.2, -1.0]) / np.linalg.norm([0.3, 0.2, -1.0])
    light = wrt.DistantLight(direction=direction, color=np.full(3, 2.0))  # angle 0: color is E at normal incidence
    rendered, _ = render_plane([light], spp=4)
    np.testing.assert_allclose(rendered, ALBEDO * 2.0 * -direction[2] / np.pi, rtol=1e-4)


def test_soft_normalized_distant_light_illuminance():
    direction = np.array([0.0, 0.5, -1.0]) / np.linalg.norm([0.0, 0.5, -1.0])
    light = wrt.DistantLight(direction=direction, color=np.full(3, 3.0), angle=20.0, normalize=True)
    rendered, _ = render_plane([light])
    # A uniform disc centred on the axis gives E = E_normal * cos(theta) exactly.
    check(rendered, np.full_like(rendered, ALBEDO * 3.0 * -direction[2] / np.pi))


def test_unnormalized_distant_light_radiance_times_disc():
    light = wrt.DistantLight(direction=(0, 0, -1), color=np.full(3, 1000.0), angle=4.0)
    expected_e = 1000.0 * np.pi * math.sin(math.radians(2.0)) ** 2
    np.testing.assert_allclose(light.illuminance, expected_e, rtol=1e-6)
    rendered, _ = render_plane([light])
    check(rendered, np.full_like(rendered, ALBEDO * expected_e / np.pi))


def test_sphere_light_irradiance():
    radiance, radius, center = 4.0, 0.5, np.array([1.2, -0.3, 1.5])  # out of the camera's view
    light = SphereLight(position=center, radius=radius, color=np.full(3, radiance))
    rendered, points = render_plane([light])
    to_light = center - points
    d2 = (to_light**2).sum(-1)
    cos = to_light[..., 2] / np.sqrt(d2)
    expected = np.pi * radiance * radius**2 * cos / d2  # a Lambertian sphere above the horizon acts as a point
    check(rendered, ALBEDO * expected / np.pi)


def test_sphere_light_treated_as_point():
    radius, center = 0.5, np.array([0.0, 0.0, 2.0])
    light = SphereLight(position=center, radius=radius, color=np.full(3, 4.0), treat_as_point=True)
    rendered, points = render_plane([light], spp=1)  # one sample: through the pixel centres
    to_light = center - points
    d2 = (to_light**2).sum(-1)
    expected = np.pi * radius**2 * 4.0 * (to_light[..., 2] / np.sqrt(d2)) / d2
    np.testing.assert_allclose(rendered, ALBEDO * expected / np.pi, rtol=1e-4)


@pytest.mark.parametrize("normalize", [False, True])
def test_rect_light_irradiance(normalize):
    width, height, elevation, intensity = 2.0, 1.5, 1.0, 3.0
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, elevation)  # local -Z (the emitting side) points down at the plane
    light = RectLight(to_world=to_world, width=width, height=height, color=np.full(3, intensity), normalize=normalize)
    radiance = intensity / (width * height) if normalize else intensity
    np.testing.assert_allclose(light.radiance, radiance, rtol=1e-6)
    rendered, points = render_plane([light])
    check(rendered, ALBEDO * rect_irradiance(points, width / 2, height / 2, elevation, radiance) / np.pi)


def test_rect_light_emits_from_its_minus_z_side_only():
    down = np.eye(4)
    down[:3, 3] = (1.5, 0, 1.0)  # beside the camera's view
    up = down @ np.diag([1.0, 1.0, -1.0, 1.0])  # flipped: -Z points up, away from the plane
    lit, _ = render_plane([RectLight(to_world=down, width=2.0, height=2.0, color=np.full(3, 3.0))], spp=8)
    dark, _ = render_plane([RectLight(to_world=up, width=2.0, height=2.0, color=np.full(3, 3.0))], spp=8)
    assert lit.min() > 0.05 and dark.max() == 0.0


def numeric_irradiance(points, samples, normals, area, radiance):
    """Irradiance at ``points`` from an emitter given by dense samples (positions, emitting normals, area each)."""
    e = np.zeros(points.shape[:-1])
    for q, n in zip(samples, normals):
        to = q - points
        d2 = (to**2).sum(-1)
        cos_r = np.clip(to[..., 2] / np.sqrt(d2), 0, None)
        cos_l = np.clip(-(to @ n) / np.sqrt(d2), 0, None)
        e += radiance * cos_r * cos_l / d2 * area
    return e


def test_disk_light_irradiance():
    radius, elevation, radiance = 0.8, 1.2, 2.0
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, elevation)
    light = DiskLight(to_world=to_world, radius=radius, color=np.full(3, radiance))
    rendered, points = render_plane([light])
    rng = np.random.default_rng(3)
    r, phi = radius * np.sqrt(rng.random(20000)), 2 * np.pi * rng.random(20000)
    samples = np.stack([r * np.cos(phi), r * np.sin(phi), np.full_like(r, elevation)], -1)
    expected = numeric_irradiance(points, samples, np.tile([0, 0, -1.0], (len(r), 1)), np.pi * radius**2 / len(r),
                                  radiance)
    check(rendered, ALBEDO * expected / np.pi, tol=0.03)


@wp.kernel
def sample_light_kernel(
    lights: DeviceLights,
    scene: DeviceScene,
    mats: DeviceMaterials,
    surf: DeviceSurfaces,
    k: int,
    p: wp.vec3,
    n: wp.vec3,
    irradiance: wp.array[float],
    pdf_ratio: wp.array[float],
):
    """Per sample: the irradiance estimate at ``p`` (normal ``n``) from light ``k``, and the pdf that the MIS of a
    BSDF-sampled ray finds for the same direction over the one the sample reported (1 where they agree)."""
    i = wp.tid()
    state = wp.rand_init(7, i)
    u1 = wp.randf(state)
    u2 = wp.randf(state)
    ls = sample_light(lights, scene, mats, surf.uvs, surf.materials, surf.double_sided, k, p, n, u1, u2)
    irradiance[i] = ls.value[0] * wp.max(wp.dot(n, ls.wi), 0.0)
    pdf_ratio[i] = 1.0
    if ls.value[0] > 0.0:
        t, cos_l = intersect_light(lights, k, p, ls.wi)
        pdf_ratio[i] = area_light_pdf(lights, k, p, n, ls.wi, t, cos_l) / ls.pdf


DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


def light_renderer(light, device="cpu"):
    """A 2 x 2 renderer of ``light`` alone over a far quad (the scene needs a mesh), for its device lights."""
    scene = wrt.Scene(meshes=[quad((0, 0, -50), (1, 0, 0), (0, 1, 0))], lights=[light])
    return wrt.Renderer(scene, camera=top_down_camera((0, 0, 0), height=1.0), width=2, height=2, device=device)


def light_estimates(light, p, n, device="cpu", count=40000):
    """Irradiance estimates from ``light`` at ``p`` (normal ``n``) by ``sample_light``, and the per-sample pdf
    ratios."""
    r = light_renderer(light, device)
    irradiance, ratio = (wp.zeros(count, dtype=float, device=r.device) for _ in range(2))
    wp.launch(sample_light_kernel, count, inputs=[r.device_lights, r.device_scene, r.materials, r.surfaces, 0,
                                                  wp.vec3(*p), wp.vec3(*n)], outputs=[irradiance, ratio],
              device=r.device)
    return irradiance.numpy().astype(np.float64), ratio.numpy()


def tilted(angle_deg, position, width=None):
    """A light transform: rotated about X by ``angle_deg``, then moved to ``position``."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    m = np.eye(4)
    m[1:3, 1:3] = [[c, -s], [s, c]]
    m[:3, 3] = position
    return m


@pytest.mark.parametrize(
    "width, height, to_world, p",
    [
        (200.0, 200.0, tilted(0, (0, 0, 1)), (0, 0, 0)),  # fills most of the hemisphere: by solid angle
        (300.0, 2.0, tilted(0, (0, 0, 1)), (40, 0, 0)),  # a long strip
        (2.0, 1.5, tilted(30, (0.5, -1.0, 2.0)), (0, 0, 0)),  # tilted, off to the side
        (0.05, 0.05, tilted(0, (0, 0, 3)), (0, 0, 0)),  # looks tiny: by area
        (1.0, 1.0, tilted(0, (0, 0, 1e-3)), (0.5, 0.5, 0)),  # the point is 1e-3 below its corner
    ],
)
@pytest.mark.parametrize("device", DEVICES)
def test_rect_light_samples_give_the_closed_form_irradiance(width, height, to_world, p, device):
    """Every sampling strategy of a rect light (by solid angle when it looks large, cosine-weighted when it fills
    the hemisphere, by area when it looks tiny) averages to Lambert's closed form, and reports the pdf that a path's
    BSDF-sampled ray finds for the same direction (else MIS is biased). Area sampling alone left a 200 x 200 light
    one unit above the point at 0.24 of its irradiance in Whitted renders at 64 spp."""
    light = RectLight(to_world=to_world, width=width, height=height, color=np.full(3, 2.0))
    p, n = np.asarray(p, np.float64), np.array([0.0, 0.0, 1.0])
    u, v = light.edges()
    centre = to_world[:3, 3]
    corners = [centre + su * u / 2 + sv * v / 2 for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    expected = polygon_irradiance(p, n, corners, 2.0)
    estimates, ratios = light_estimates(light, p, n, device)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < max(4 * error, 1e-3 * expected), (estimates.mean(), expected, error)
    np.testing.assert_allclose(ratios, 1.0, rtol=2e-3)


@pytest.mark.parametrize("kind", ["rect", "disk"])
def test_sheared_rect_and_disk_lights_are_hit_where_they_are_sampled(kind):
    """Under a transform whose Y axis leans into X a rect light is a parallelogram and a disk light an ellipse: light
    sampling averages to Lambert's closed form for that polygon (the ellipse as a 512-gon), and a BSDF-sampled ray
    along each sampled direction hits the light there, with the same pdf. The hit test measured a point's
    coordinates by projecting it on each edge, as if the edges were perpendicular: 21% of the rect's samples and 29%
    of the disk's lay where rays missed the light (and camera rays saw a differently slanted shape)."""
    to_world = np.eye(4)
    to_world[:3, :3] = [[1.0, 0.8, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    to_world[:3, 3] = (0.2, 0.1, 1.0)
    p, n = np.zeros(3), np.array([0.0, 0.0, 1.0])
    x, y, centre = to_world[:3, 0], to_world[:3, 1], to_world[:3, 3]
    if kind == "rect":
        light = RectLight(to_world=to_world, width=1.0, height=1.0, color=np.full(3, 2.0))
        corners = [centre + (su * x + sv * y) / 2 for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    else:
        light = DiskLight(to_world=to_world, radius=0.5, color=np.full(3, 2.0))
        phi = np.arange(512) / 512 * 2 * np.pi
        corners = list(centre + 0.5 * (np.cos(phi)[:, None] * x + np.sin(phi)[:, None] * y))
    expected = polygon_irradiance(p, n, corners, 2.0)
    estimates, ratios = light_estimates(light, p, n)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error, (estimates.mean(), expected, error)
    np.testing.assert_allclose(ratios, 1.0, rtol=2e-3)


@pytest.mark.parametrize("device", DEVICES)
def test_a_disk_light_wider_than_the_scene_lights_it_evenly(device):
    """A disk light of radius 1e5 one unit above the point gives its on-axis closed form E = pi L r^2 / (r^2 + h^2)
    with little noise; sampled by area, nearly every sample landed kilometres away (2e-7 of the irradiance)."""
    light = DiskLight(to_world=tilted(0, (0, 0, 1)), radius=1e5, color=np.full(3, 2.0))
    estimates, ratios = light_estimates(light, (0, 0, 0), (0.0, 0.0, 1.0), device)
    assert abs(estimates.mean() / (2.0 * math.pi) - 1.0) < 2e-3 and estimates.std() < 0.1 * estimates.mean()
    np.testing.assert_allclose(ratios, 1.0, rtol=2e-3)


@pytest.mark.parametrize("p, n", [((0.6, 0.1, -0.01), (0.0, 0.0, 1.0)), ((0.6, 0.1, -0.01), (-1.0, 0.0, 0.0)),
                                  ((0.51, 0.1, -0.001), (-1.0, 0.0, 0.0))], ids=["facing it", "wall", "grazing wall"])
def test_a_disk_light_seen_from_beside_its_rim_is_drawn_by_solid_angle(p, n):
    """A point 0.01 below a disk light of radius 0.5 and 0.1 beyond its rim (or 1e-3 below and 0.01 beyond) sees the
    square around the disk under 1 sr, where disks were drawn by area, whose 1 / d^2 varies widely over a disk seen
    so near: a relative noise per draw of 3 to 14. Drawn by solid angle where the point lies within a radius of the
    disk, 0.6 to 1.3; the mean is Lambert's closed form, and a ray along each draw reads its pdf back."""
    light = DiskLight(to_world=tilted(0, (0.0, 0.0, 0.0)), radius=0.5, color=np.full(3, 2.0))
    phi = np.arange(1024) / 1024 * 2 * np.pi
    corners = list(np.stack([0.5 * np.cos(phi), 0.5 * np.sin(phi), np.zeros_like(phi)], -1))
    expected = polygon_irradiance(p, n, corners, 2.0)
    estimates, ratios = light_estimates(light, p, n)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error, (estimates.mean(), expected, error)
    assert estimates.std() < 2.0 * expected, estimates.std() / expected
    np.testing.assert_allclose(ratios, 1.0, rtol=2e-3)


@pytest.mark.parametrize("where", ["centre", "rim"])
def test_a_sheared_disk_light_seen_from_near_is_drawn_by_solid_angle(where):
    """A disk light of radius 0.5 under a transform whose Y axis leans into X and shrinks is an ellipse; a point 0.01
    below its centre, or below and 0.1 beyond the end of its major axis, sees the rectangle around it under a large
    solid angle. Its radius vectors were not at right angles, so it was drawn by area: a relative noise per draw of
    19 below the centre and 5.4 beyond the rim. Given its ellipse's axes it is drawn by solid angle: 0.05 and 1.1.
    The mean is Lambert's closed form for the ellipse as a 2048-gon, and a ray along each draw reads its pdf back."""
    to_world = np.eye(4)
    to_world[:3, :3] = [[1.0, 0.8, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 1.0]]
    x, y = to_world[:3, 0], to_world[:3, 1]
    light = DiskLight(to_world=to_world, radius=0.5, color=np.full(3, 2.0))
    axes, semi_axes, _ = np.linalg.svd(0.5 * np.stack([x, y], -1))
    p = np.array([0.0, 0.0, -0.01]) + (0.0 if where == "centre" else semi_axes[0] + 0.1) * axes[:, 0]
    n = np.array([0.0, 0.0, 1.0])
    phi = np.arange(2048) / 2048 * 2 * np.pi
    expected = polygon_irradiance(p, n, list(0.5 * (np.cos(phi)[:, None] * x + np.sin(phi)[:, None] * y)), 2.0)
    estimates, ratios = light_estimates(light, p, n)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error, (estimates.mean(), expected, error)
    assert estimates.std() < 2.0 * expected, estimates.std() / expected
    np.testing.assert_allclose(ratios, 1.0, rtol=2e-3)


def above_horizon(p, n, corners) -> np.ndarray:
    """The part of polygon ``corners`` above the horizon of point ``p`` (unit normal ``n``): the polygon clipped by
    the plane through ``p`` (Sutherland-Hodgman, float64), which Lambert's closed form then integrates."""
    kept = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        da, db = (a - p) @ n, (b - p) @ n
        if da > 0.0:
            kept.append(a)
        if (da > 0.0) != (db > 0.0):
            kept.append(a + (b - a) * (da / (da - db)))
    return np.asarray(kept)


@pytest.mark.parametrize("tilt", [1.0, 10.0])
@pytest.mark.parametrize("kind", ["rect", "disk"])
def test_a_surface_tilted_away_from_a_light_near_it_draws_on_its_front(kind, tilt):
    """A point 0.01 below a 2 x 2 rect light (a disk light of radius 1), its normal along the light's plane tilted
    ``tilt`` degrees away from it, sees nearly a hemisphere of light, half of it above its horizon. The draws
    cosine-weighted about the normal (nearly all of them, the light filling the hemisphere) were turned to its back,
    where the normal points away from the plane, and an opaque surface takes nothing there: a relative noise per draw
    of 16 to 17 (the 1.3% left to the draw by solid angle carried the light). Drawn about the normal, where part of
    the light lies above its horizon: 1.0 to 1.2. The mean is Lambert's closed form over the part of the light above
    the horizon, and a ray along each draw reads its pdf back."""
    t = math.radians(tilt)
    p, n = np.array([0.5, 0.1, -0.01]), np.array([math.cos(t), 0.0, -math.sin(t)])
    if kind == "rect":
        light = RectLight(to_world=tilted(0, (0.0, 0.0, 0.0)), width=2.0, height=2.0, color=np.full(3, 2.0))
        corners = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    else:
        light = DiskLight(to_world=tilted(0, (0.0, 0.0, 0.0)), radius=1.0, color=np.full(3, 2.0))
        phi = np.arange(2048) / 2048 * 2 * np.pi
        corners = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], -1)
    expected = polygon_irradiance(p, n, above_horizon(p, n, corners), 2.0)
    estimates, ratios = light_estimates(light, p, n)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error, (estimates.mean(), expected, error)
    assert estimates.std() < 2.0 * expected, estimates.std() / expected
    np.testing.assert_allclose(ratios, 1.0, rtol=2e-3)


@pytest.mark.parametrize("kind", ["rect", "disk"])
def test_light_sampling_reaches_the_far_part_of_a_light_a_wall_beside_it_sees(kind):
    """A wall facing a 2 x 2 rect light (or a disk of radius 1) 0.2 beside its edge and 1e-3 below its plane sees its
    far part at grazing angles but head-on (the wall's normal lies in the light's plane): light sampling alone (as
    ``whitted`` lights) averages to Lambert's closed form for the whole light, reporting the pdf a ray finds. The
    solid-angle draw covers only the part within 256 heights (0.256) of the point's foot, which holds 1.5e-5 of the
    light a point facing the plane gets, but most of the wall's: it got 0.0030 of its 0.0133 (the disk 0.011 of its
    0.020)."""
    to_world = tilted(0, (1.0, 0.0, 0.0))  # centred 1 beyond the wall's foot along x, emitting down (-z)
    p, n = np.array([-0.2, 0.0, -1e-3]), np.array([1.0, 0.0, 0.0])
    if kind == "disk":  # the wall inside the square around the disk (drawn through it), its normal towards the centre
        p, n = np.array([0.2, -0.8, -1e-3]), np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    if kind == "rect":
        light = RectLight(to_world=to_world, width=2.0, height=2.0, color=np.full(3, 2.0))
        corners = [(0.0, -1.0, 0.0), (2.0, -1.0, 0.0), (2.0, 1.0, 0.0), (0.0, 1.0, 0.0)]
    else:
        light = DiskLight(to_world=to_world, radius=1.0, color=np.full(3, 2.0))
        phi = np.arange(2048) / 2048 * 2 * np.pi
        corners = list(np.stack([1.0 + np.cos(phi), np.sin(phi), np.zeros_like(phi)], -1))
    expected = polygon_irradiance(p, n, corners, 2.0)
    estimates, ratios = light_estimates(light, p, n, count=100000)
    error = estimates.std() / math.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error + 2e-3 * expected, (estimates.mean(), expected, error)
    # Draws on the rect's near edge, seen at grazing angles from 1e-3 above its plane, may round off it for the ray
    # (float32): they must carry next to none of the light.
    off = np.abs(ratios - 1.0) > 2e-3
    assert estimates[off].sum() <= 1e-3 * estimates.sum(), off.mean()


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_floor_across_where_a_rect_lights_draw_starts_to_clip_renders_as_the_closed_form(integrator):
    """A 1 x 1 rect light standing upright (in the plane x = 0, emitting along +x, its bottom edge 0.05 above the
    floor) over floor points 0 to 0.0082 from its plane: the solid-angle draw reaches 256 heights from a point's
    foot, so it clips the light's top edge (1.05 up) for points nearer than 1.05 / 256 = 0.0041 and mixes in draws
    by area there (0.25 of them for the floor's normal, which lies in the light's plane), none beyond. path reads the
    MIS weight back at its bounce ray's origin, moved off the floor along +z, where the share may differ; the band
    where it does is the offset wide, and the floor on either side of the switch shows Lambert's closed form."""
    to_world = np.eye(4)
    to_world[:3, :3] = [[0, 0, -1], [0, 1, 0], [1, 0, 0]]  # the light's -z along +x, its width along z
    to_world[:3, 3] = (0.0, 0.0, 0.55)
    light = RectLight(to_world=to_world, width=1.0, height=1.0, color=np.full(3, 2.0))
    corners = [(0, -0.5, 0.05), (0, 0.5, 0.05), (0, 0.5, 1.05), (0, -0.5, 1.05)]
    switch, res = 1.05 / 256.0, 8
    centre, patch = (switch, 0.0, 0.0), 2.0 * switch
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=[light])
    points = pixel_points(centre, patch, res, res)
    expected = ALBEDO / math.pi * np.array([[polygon_irradiance(p, (0, 0, 1), corners, 2.0) for p in row]
                                            for row in points])
    ratios = np.array([wrt.render(scene, camera=top_down_camera(centre, height=patch), width=res, height=res,
                                  spp=64, seed=seed, device="cpu", integrator=integrator, max_depth=1).rgb.mean(-1)
                       for seed in range(4)]) / expected
    for side in (points[0, :, 0] < switch, points[0, :, 0] > switch):  # clipped (mixed draws), then not
        means = ratios[:, :, side].mean(axis=(1, 2))
        error = means.std(ddof=1) / 2.0
        assert abs(means.mean() - 1.0) < 4.0 * error + 2e-3, (means, error)
        assert error < 0.01


def test_cylinder_light_irradiance():
    length, radius, elevation, radiance = 3.0, 0.2, 1.0, 2.0
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0.8, elevation)  # beside the camera's view: lights are visible to camera rays
    light = CylinderLight(to_world=to_world, length=length, radius=radius, color=np.full(3, radiance))
    rendered, points = render_plane([light])
    rng = np.random.default_rng(4)
    x, phi = length * (rng.random(40000) - 0.5), 2 * np.pi * rng.random(40000)
    normals = np.stack([np.zeros_like(x), np.cos(phi), np.sin(phi)], -1)
    samples = np.stack([x, 0.8 + radius * np.cos(phi), elevation + radius * np.sin(phi)], -1)
    area = 2 * np.pi * radius * length / len(x)
    expected = numeric_irradiance(points, samples, normals, area, radiance)
    check(rendered, ALBEDO * expected / np.pi, tol=0.03, pixel_tol=0.5)  # a long tube: noisier pixels


def test_constant_dome_lights_an_open_plane():
    rendered, _ = render_plane([DomeLight(color=np.full(3, 0.7))], spp=16)
    np.testing.assert_allclose(rendered, ALBEDO * 0.7, rtol=1e-4)  # cosine sampling is exact here


def write_stage(tmp_path, build) -> str:
    path = str(tmp_path / "lights.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    build(stage)
    stage.Save()
    return path


def add_floor(stage) -> None:
    """``/Plane``: a 40 x 40 quad in the z = 0 plane, facing +Z."""
    plane = UsdGeom.Mesh.Define(stage, "/Plane")
    plane.CreatePointsAttr([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)])
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])


def test_usd_light_radiometry(tmp_path):
    def build(stage):
        rect = UsdLux.RectLight.Define(stage, "/Rect")
        rect.CreateWidthAttr(2.0)
        rect.CreateHeightAttr(0.5)
        rect.CreateIntensityAttr(3.0)
        rect.CreateExposureAttr(1.0)
        rect.CreateColorAttr(Gf.Vec3f(1.0, 0.5, 0.25))
        rect.CreateNormalizeAttr(True)
        UsdGeom.XformCommonAPI(rect).SetScale(Gf.Vec3f(2.0, 1.0, 1.0))
        sphere = UsdLux.SphereLight.Define(stage, "/Sphere")
        sphere.CreateRadiusAttr(0.25)
        sphere.CreateIntensityAttr(10.0)
        UsdGeom.XformCommonAPI(sphere).SetTranslate(Gf.Vec3d(1, 2, 3))
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.CreateIntensityAttr(5.0)
        sun.CreateNormalizeAttr(True)
        UsdLux.DiskLight.Define(stage, "/Disk").CreateRadiusAttr(0.1)
        UsdLux.CylinderLight.Define(stage, "/Tube").CreateLengthAttr(2.0)
        UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(0.5)

    scene = wrt.load_usd(write_stage(tmp_path, build))
    by_path = {light.path: light for light in scene.lights}
    assert set(by_path) == {"/Rect", "/Sphere", "/Sun", "/Disk", "/Tube", "/Dome"}
    rect = by_path["/Rect"]
    assert rect.area == pytest.approx(2.0 * 2.0 * 0.5)  # the transform's scale counts
    np.testing.assert_allclose(rect.radiance, np.array([1.0, 0.5, 0.25]) * 3.0 * 2.0 / 2.0, rtol=1e-6)
    sphere = by_path["/Sphere"]
    np.testing.assert_allclose(sphere.position, (1, 2, 3))
    assert sphere.radius == pytest.approx(0.25) and not sphere.treat_as_point
    np.testing.assert_allclose(by_path["/Sun"].illuminance, 5.0)
    np.testing.assert_allclose(by_path["/Dome"].color, 0.5)


@pytest.mark.parametrize("angle", [1e-15, 1e-30])
@pytest.mark.parametrize("normalize", [True, False])
def test_distant_light_of_a_tiny_angle_lights_as_its_disc_says(tmp_path, angle, normalize):
    """A sun disc so small that ``pi sin^2(angle / 2)`` leaves float32's range: normalized, its radiance
    ``E / (pi sin^2)`` was capped (a floor under 2 lux of a 1e-15 degree sun showed 4000 times too little) or its cone
    underflowed to a delta light of that radiance (1e-30 degrees: 1e30 times too bright); not normalized, the
    underflowed cone made the disc's radiance its illuminance (2 instead of ~1e-64). The floor shows ``E cos / pi``."""

    def build(stage):
        add_floor(stage)
        UsdGeom.Mesh(stage.GetPrimAtPath("/Plane")).CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.CreateAngleAttr(angle)
        sun.CreateIntensityAttr(2.0)
        sun.CreateNormalizeAttr(normalize)
        UsdGeom.XformCommonAPI(sun).SetRotate(Gf.Vec3f(30.0, 0.0, 0.0))

    scene = wrt.load_usd(write_stage(tmp_path, build))
    half = math.radians(angle) / 2.0
    e = 2.0 if normalize else 2.0 * math.pi * math.sin(half) ** 2  # at normal incidence, float64
    for integrator in ("whitted", "path"):
        img = wrt.render(scene, camera=top_down_camera(height=0.2), width=4, height=4, spp=4, seed=1,
                         device="cpu", integrator=integrator)
        np.testing.assert_allclose(img.rgb, e * math.cos(math.radians(30.0)) / math.pi, rtol=1e-5, atol=1e-30,
                                   err_msg=integrator)


@pytest.mark.parametrize("schema", [UsdLux.SphereLight, UsdLux.RectLight, UsdLux.DiskLight, UsdLux.CylinderLight])
def test_normalized_light_too_small_for_float32_is_a_point_a_line_or_named(tmp_path, schema):
    """A normalized light of size 1e-20, whose radiance ``intensity / area`` passes float32's range, emitted nothing
    with numpy's bare overflow warning. A sphere is the point light it tends to (intensity ``color / 4``: a white
    floor 1 below shows ``E / pi = 1 / pi`` of intensity 4), a cylinder the line light along its axis (``I_s = color /
    (pi l)``: a line this short is a point of intensity ``I_s l = 4 / pi`` straight below it, ``E / pi = 4 / pi^2``);
    rect and disk lights are skipped with a warning naming them."""

    def build(stage):
        add_floor(stage)
        UsdGeom.Mesh(stage.GetPrimAtPath("/Plane")).CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
        light = schema.Define(stage, "/Tiny")
        for name in ("Radius", "Width", "Height", "Length"):
            if hasattr(light, f"Create{name}Attr"):
                getattr(light, f"Create{name}Attr")(1e-20)
        light.CreateIntensityAttr(4.0)
        light.CreateNormalizeAttr(True)
        UsdGeom.XformCommonAPI(light).SetTranslate(Gf.Vec3d(0, 0, 1))
        if schema in (UsdLux.RectLight, UsdLux.DiskLight):  # a dark light, so that the stage gets no default lights
            UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(0.0)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(write_stage(tmp_path, build))
    messages = [str(w.message) for w in caught]
    assert not [m for m in messages if "overflow" in m or "divide" in m], messages
    if schema in (UsdLux.RectLight, UsdLux.DiskLight):
        assert [light.path for light in scene.lights] == ["/Sun"]
        assert any(re.search(r"normalized lights too small .* float32 were skipped: .*: /Tiny$", m) for m in messages)
        return
    assert not [m for m in messages if "/Tiny" in m], messages
    expected = 1.0 / math.pi if schema is UsdLux.SphereLight else 4.0 / math.pi**2
    for integrator in ("whitted", "path"):
        img = wrt.render(scene, camera=top_down_camera(height=0.02), width=2, height=2, spp=4, seed=1, device="cpu",
                         integrator=integrator)
        np.testing.assert_allclose(img.rgb, expected, rtol=1e-3, err_msg=integrator)


@pytest.mark.parametrize("schema", [UsdLux.SphereLight, UsdLux.RectLight, UsdLux.DiskLight, UsdLux.CylinderLight])
@pytest.mark.parametrize("scale", [1e-100, 1e-170, 0.0])
def test_normalized_light_whose_area_underflows_float64_is_a_point_or_named(tmp_path, schema, scale):
    """A normalized light of unit sizes under a double-precision transform that scales it by 1e-100 (its area 1e-200,
    whose norm squares the cross product past float64) or 1e-170 (an area past float64 itself) had an area of 0 and
    emitted nothing without a word, as a light of no area does. A sphere is the point light it tends to (intensity
    ``color / 4``: ``E / pi = 1 / pi`` on a white floor 1 below, for intensity 4); the other shapes are skipped with a
    warning naming them. A zero scale is a light of no area: it emits nothing (a sphere: a point light), unnamed."""

    def build(stage):
        add_floor(stage)
        UsdGeom.Mesh(stage.GetPrimAtPath("/Plane")).CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
        light = schema.Define(stage, "/Tiny")
        light.CreateIntensityAttr(4.0)
        light.CreateNormalizeAttr(True)
        m = Gf.Matrix4d(1.0).SetScale(Gf.Vec3d(scale, scale, scale)).SetTranslateOnly(Gf.Vec3d(0, 0, 1))
        UsdGeom.Xformable(light).AddTransformOp().Set(m)
        if schema is not UsdLux.SphereLight:  # a dark light, so that the stage gets no default lights
            UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(0.0)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(write_stage(tmp_path, build))
    named = [str(w.message) for w in caught if "/Tiny" in str(w.message)]
    if schema is not UsdLux.SphereLight:
        emitting = [light.path for light in scene.lights if np.any(light.radiance > 0)]
        assert emitting == [] and (len(named) == 1) == (scale > 0.0), named
        if scale > 0.0:
            assert re.search(r"normalized lights too small .* were skipped: .*: /Tiny$", named[0]), named
        return
    assert not named, named
    for integrator in ("whitted", "path"):
        img = wrt.render(scene, camera=top_down_camera(height=0.02), width=2, height=2, spp=4, seed=1, device="cpu",
                         integrator=integrator)
        np.testing.assert_allclose(img.rgb, 1.0 / math.pi, rtol=1e-3, err_msg=integrator)


def test_usd_rect_light_faces_its_minus_z_axis(tmp_path):
    def build(stage):
        add_floor(stage)
        rect = UsdLux.RectLight.Define(stage, "/Rect")
        rect.CreateIntensityAttr(2.0)
        rect.CreateWidthAttr(4.0)
        rect.CreateHeightAttr(4.0)
        UsdGeom.XformCommonAPI(rect).SetTranslate(Gf.Vec3d(0, 0, 1))

    scene = wrt.load_usd(write_stage(tmp_path, build))
    img = wrt.render(scene, camera=top_down_camera(height=0.4), width=8, height=8, spp=32, device="cpu",
                     integrator="path", max_depth=1)
    expected = ALBEDO * rect_irradiance(pixel_points((0, 0, 0), 0.4, 8, 8), 2.0, 2.0, 1.0, 2.0) / np.pi
    check(img.rgb.mean(axis=-1), expected)


def test_stage_without_lights_gets_headlight_and_dome():
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (4, 0, 0), (0, 4, 0))])
    img = wrt.render(scene, camera=top_down_camera(height=1.0), width=8, height=8, device="cpu")
    # Headlight along the view (E = 0.8 pi, normal incidence) plus the dome term of whitted: 0.5 * (0.8 + 0.2).
    np.testing.assert_allclose(img.rgb, ALBEDO * 1.0, rtol=1e-5)


def test_emissive_mesh_irradiance_matches_the_rect_light():
    from wrt.materials import Material

    width, height, elevation, radiance = 2.0, 1.5, 1.0, 3.0
    # An emissive quad facing down (front = -Z), beside nothing else: it is a light like the RectLight above.
    emitter = quad((0, 0, elevation), (0, height, 0), (width, 0, 0), name="/emitter", material=0, double_sided=False)
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")
    scene = wrt.Scene(meshes=[plane, emitter], materials=[Material(diffuse_color=0, emissive_color=radiance)])
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)  # below the emitter
    img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=64, device="cpu", integrator="path", max_depth=1)
    points = pixel_points((0, 0, 0), PATCH, RES, RES)
    check(img.rgb.mean(axis=-1), ALBEDO * rect_irradiance(points, width / 2, height / 2, elevation, radiance) / np.pi)


def dome_lit_plane(texture, facing_z, spp=64, to_world=None):
    """Radiance of a grey plane through the origin whose front faces ``facing_z`` (+1 or -1 along Z) or +Y
    (``facing_z = 0``), lit only by a textured dome; the camera looks at the plane's front."""
    if facing_z == 0:
        plane = quad((0, 0, 0), (40, 0, 0), (0, 0, -40), name="/plane")  # front +Y
        cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    else:
        plane = quad((0, 0, 0), (40, 0, 0), (0, 40 * facing_z, 0), name="/plane")
        cam = wrt.Camera.orthographic(eye=(0, 0, 3 * facing_z), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    plane.double_sided = False
    dome = DomeLight(color=np.ones(3, np.float32), texture=texture,
                     to_world=np.eye(4) if to_world is None else to_world)
    scene = wrt.Scene(meshes=[plane], lights=[dome])
    img = wrt.render(scene, camera=cam, width=4, height=4, spp=spp, device="cpu", integrator="path", max_depth=1)
    return img.rgb.mean()


def latlong(height=32, fn=None):
    """A (H, 2H, 4) lat-long texture with value ``fn(direction)`` per texel (OpenEXR convention, +Y pole)."""
    v = (np.arange(height) + 0.5) / height
    u = (np.arange(2 * height) + 0.5) / (2 * height)
    lat = np.pi * (0.5 - v)[:, None]
    lon = np.pi * (1 - 2 * u)[None, :]
    d = np.stack(np.broadcast_arrays(np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)), -1)
    tex = np.ones((height, 2 * height, 4), np.float32)
    tex[..., :3] = fn(d)[..., None]
    return tex


def test_textured_dome_sky_lights_the_upper_hemisphere():
    sky = latlong(fn=lambda d: (d[..., 1] > 0).astype(np.float32))  # 1 above the horizon (+Y), 0 below
    up = dome_lit_plane(sky, facing_z=0)
    assert up == pytest.approx(ALBEDO * 1.0, rel=0.02)  # an upward plane sees the whole sky: E = pi
    side = dome_lit_plane(sky, facing_z=1)
    assert side == pytest.approx(ALBEDO * 0.5, rel=0.04)  # a vertical plane sees half of it


def test_textured_dome_orientation_follows_openexr_latlong():
    front = latlong(fn=lambda d: (d[..., 2] > 0.5).astype(np.float32))  # a bright cap around +Z (longitude 0)
    facing = dome_lit_plane(front, facing_z=1)
    away = dome_lit_plane(front, facing_z=-1)
    assert facing > 0.1 and away == 0.0
    turned = np.eye(4)
    turned[:3, :3] = [[-1, 0, 0], [0, 1, 0], [0, 0, -1]]  # the dome turned 180 degrees about +Y
    assert dome_lit_plane(front, facing_z=-1, to_world=turned) == pytest.approx(facing, rel=0.05)


@pytest.mark.parametrize("scale", [1e10, 1e15])
def test_emissive_mesh_light_does_not_depend_on_scene_scale(scale):
    # The emitter's area is the length of a cross product, an edge length squared: wp.length overflowed for edges of
    # 1e10 and the light was lost. (Tiny scenes are limited by the fixed self-intersection offset of secondary rays.)
    from wrt.materials import Material

    def render(s):
        emitter = quad((0, 0, s), (0, 1.5 * s, 0), (2 * s, 0, 0), name="/emitter", material=0, double_sided=False)
        plane = quad((0, 0, 0), (40 * s, 0, 0), (0, 40 * s, 0), name="/plane")
        scene = wrt.Scene(meshes=[plane, emitter], materials=[Material(diffuse_color=0, emissive_color=3.0)])
        cam = wrt.Camera.orthographic(
            eye=(0, 0, 0.5 * s), target=(0, 0, 0), up=(0, 1, 0), height=PATCH * s, clipping_range=(0.01 * s, 10 * s)
        )
        return wrt.render(scene, camera=cam, width=8, height=8, spp=16, device="cpu", integrator="path", max_depth=1)

    unit = render(1.0).rgb
    assert unit.mean() > 0.1
    np.testing.assert_allclose(render(scale).rgb, unit, rtol=0.05, atol=1e-3)


DEFAULT_TIME_USDA = """#usda 1.0
def Material "M"
{
    token outputs:surface.connect = </M/PS.outputs:surface>
    def Shader "PS"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.timeSamples = { 1: (1, 0, 0), 10: (0, 0, 1) }
        token outputs:surface
    }
}
def Mesh "Plane" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-10, 0, 10), (10, 0, 10), (10, 0, -10), (-10, 0, -10)]
    rel material:binding = </M>
}
def DistantLight "Sun"
{
    float inputs:angle = 0
    float inputs:intensity.timeSamples = { 1: 3.0, 10: 6.0 }
    color3f inputs:color.timeSamples = { 1: (1, 0.5, 0.25) }
}
"""


def test_light_and_material_inputs_with_only_time_samples_read_the_first_at_the_default_time(tmp_path):
    """``time=None`` reads values that have only time samples at the first sample, for lights and materials as
    for points (their schema fallbacks, e.g. a distant light's intensity 50000, were used instead)."""
    path = tmp_path / "scene.usda"
    path.write_text(DEFAULT_TIME_USDA)
    default, first = wrt.load_usd(path), wrt.load_usd(path, time=1.0)
    np.testing.assert_allclose(default.lights[0].color, [3.0, 1.5, 0.75], rtol=1e-6)
    np.testing.assert_array_equal(default.lights[0].color, first.lights[0].color)
    np.testing.assert_array_equal(default.materials[0].diffuse_color, [1.0, 0.0, 0.0])


def test_whitted_warns_about_emitters_it_cannot_sample(tmp_path):
    """An emissive analytic shape that is not sampled (a sphere squashed flat, under 1e-6 of its width: glowing
    spheres and ellipsoids are, tests/test_glowing_spheres.py and tests/test_glowing_hulls.py) lights nothing under
    whitted: the render says so instead of silently showing a dark plane. A stage's emissive gprim is drawn as its
    tessellation (tests/test_emissive_gprims.py), so this is a scene built in Python; tessellated, it is sampled."""
    path = tmp_path / "scene.usda"
    path.write_text(
        '#usda 1.0\ndef Material "E"\n{\n    token outputs:surface.connect = </E/PS.outputs:surface>\n'
        '    def Shader "PS"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
        "        color3f inputs:emissiveColor = (1, 1, 1)\n        token outputs:surface\n    }\n}\n"
        'def Mesh "Plane"\n{\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n'
        "    point3f[] points = [(-9, -9, 0), (9, -9, 0), (9, 9, 0), (-9, 9, 0)]\n}\n"
        'def Sphere "Lamp" (prepend apiSchemas = ["MaterialBindingAPI"])\n{\n    double radius = 0.5\n'
        '    double3 xformOp:translate = (0, 0, 2)\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n'
        "    rel material:binding = </E>\n}\n"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loaded = wrt.load_usd(path)
        wrt.render(loaded, width=8, height=8)
    (plane,) = [m for m in loaded.meshes if m.path == "/Plane"]
    to_world = np.diag([0.5, 0.5, 0.5, 1.0])  # radius 0.5 at (0, 0, 2), column vectors
    to_world[2, 3] = 2.0
    sphere = wrt.Shape("/Lamp", "sphere", to_world, material_id=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a sphere is sampled
        wrt.render(wrt.Scene(meshes=[plane], shapes=[sphere], materials=loaded.materials), width=8, height=8)
    to_world = to_world.copy()
    to_world[0, 0] = 0.8  # an ellipsoid: sampled too
    sphere = wrt.Shape("/Lamp", "sphere", to_world, material_id=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wrt.render(wrt.Scene(meshes=[plane], shapes=[sphere], materials=loaded.materials), width=8, height=8)
    to_world = to_world.copy()
    to_world[0, 0] = 1e-8  # squashed flat: its ellipsoid's map has no float32 inverse
    sphere = wrt.Shape("/Lamp", "sphere", to_world, material_id=0)
    scene = wrt.Scene(meshes=[plane], shapes=[sphere], materials=loaded.materials)
    with pytest.warns(UserWarning, match="1 emissive analytic primitive"):
        wrt.render(scene, width=8, height=8)
    points, indices, _ = tessellate(sphere, 16)
    lamp = wrt.Mesh("/Lamp", points, indices, np.arange(len(indices)), material_ids=np.zeros(len(indices), np.int32))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wrt.render(wrt.Scene(meshes=[plane, lamp], materials=loaded.materials), width=8, height=8)


def test_coarse_textured_dome_is_unbiased(tmp_path):
    """A 2 x 8 lat-long dome, upper row 1 and lower row 0, over a white plane facing up: the path tracer's irradiance
    estimate converges to the filtered dome's (1 down to 45 degrees above the horizon, then falling linearly to 0.5 at
    it), 0.5 + (1/2 - 2/pi (pi/8 - 1/4)) = 0.9092, and so does whitted's ambient term (the dome's irradiance as
    spherical harmonics: exact for a dome of two colours split at the horizon; the dome's mean, 0.5, lit the plane
    before). The pdf took the Jacobian at the texel centre and the mean the centre's sin(theta): 4% and 11% too
    much."""
    from PIL import Image as PilImage

    texels = np.zeros((2, 8), np.uint8)
    texels[0] = 255
    PilImage.fromarray(texels, "L").save(tmp_path / "half.png")
    path = tmp_path / "dome.usda"
    path.write_text(
        '#usda 1.0\n(\n    upAxis = "Y"\n)\ndef Mesh "Plane"\n{\n    int[] faceVertexCounts = [4]\n'
        "    int[] faceVertexIndices = [0, 1, 2, 3]\n"
        "    point3f[] points = [(-100, 0, 100), (100, 0, 100), (100, 0, -100), (-100, 0, -100)]\n"
        "    color3f[] primvars:displayColor = [(1, 1, 1)]\n}\n"
        'def DomeLight "Dome"\n{\n    asset inputs:texture:file = @half.png@\n}\n'
        'def Camera "Cam"\n{\n    double3 xformOp:translate = (0, 3, 0)\n    float3 xformOp:rotateXYZ = (-90, 0, 0)\n'
        '    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]\n}\n'
    )
    scene = wrt.load_usd(path)
    renderer = wrt.Renderer(scene, width=1, height=1, integrator="path", max_depth=1)
    estimate = np.mean([renderer.render(spp=4096, seed=k).rgb[0, 0, 0] for k in range(4)])
    expected = 0.5 + (0.5 - 2 / np.pi * (np.pi / 8 - 0.25))
    assert abs(estimate - expected) < 0.01, estimate
    np.testing.assert_allclose(wrt.render(scene, width=1, height=1).rgb[0, 0], expected, rtol=1e-4)


def test_mesh_light_is_read_as_a_light_and_still_drawn(tmp_path):
    """MeshLightAPI makes the mesh a light (tests/test_mesh_lights.py); it was drawn as geometry that emitted
    nothing, with a warning."""

    def build(stage):
        mesh = UsdGeom.Mesh.Define(stage, "/Panel")
        mesh.CreatePointsAttr([(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)])
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        UsdLux.MeshLightAPI.Apply(mesh.GetPrim())
        UsdLux.LightAPI(mesh.GetPrim()).CreateIntensityAttr(10.0)

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(write_stage(tmp_path, build))
    assert [(type(light).__name__, light.path) for light in scene.lights] == [("MeshLight", "/Panel")]
    np.testing.assert_allclose(scene.lights[0].color, 10.0)
    assert scene.stats()["rendered_triangles"] == 2  # still drawn as geometry


def test_negative_light_colour_is_clamped_with_a_warning(tmp_path):
    """A negative colour channel (or intensity) would subtract light and give negative pixels."""

    def build(stage):
        add_floor(stage)
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.CreateIntensityAttr(2.0)
        sun.CreateAngleAttr(0.0)
        sun.CreateColorAttr(Gf.Vec3f(1.0, -1.0, 0.5))
        UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(-1.0)

    with pytest.warns(UserWarning, match=r"negative light colour.*2 prim\(s\): /Sun, /Dome"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    expected = ALBEDO * np.array([2.0, 0.0, 1.0]) / np.pi  # the sun's positive channels; the dome adds nothing
    img = wrt.render(scene, camera=top_down_camera(height=0.4), width=4, height=4, device="cpu")
    np.testing.assert_allclose(img.rgb, np.broadcast_to(expected, img.rgb.shape), rtol=1e-4, atol=1e-6)
    img = wrt.render(scene, camera=top_down_camera(height=0.4), width=4, height=4, spp=8, device="cpu",
                     integrator="path")
    assert img.rgb.min() >= 0.0 and img.rgb[..., 1].max() == 0.0


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_light_without_shadows_passes_through_occluders(integrator):
    """A quad floats between a sun and the plane; its shadow falls beside it, under the camera. A sun with ShadowAPI's
    ``shadow:enable`` off lights the shadowed patch as if the quad were not there."""
    direction = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)
    blocker = quad((0, 0, 1), (1.2, 0, 0), (0, 1.2, 0), name="/blocker")
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")
    lit = ALBEDO * 2.0 * -direction[2] / np.pi

    def shadowed_patch(shadows):
        sun = wrt.DistantLight(direction=direction, color=np.full(3, 2.0), shadows=shadows)
        scene = wrt.Scene(meshes=[plane, blocker], lights=[sun])
        img = wrt.render(scene, camera=top_down_camera((1.0, 0, 0), height=0.4), width=8, height=8, spp=1,
                         device="cpu", integrator=integrator, max_depth=1)
        assert (img.aovs["prim"] >= 0).all()
        return img.rgb.mean(axis=-1)

    np.testing.assert_allclose(shadowed_patch(True), 0.0, atol=1e-6)
    np.testing.assert_allclose(shadowed_patch(False), lit, rtol=1e-4)


BLOCKER = quad((0, 0, 0.3), (4, 0, 0), (0, -4, 0), name="/blocker", double_sided=False)  # faces down: cameras cull it


def lights_over_a_blocker():
    """A light of each kind whose MIS split differs, over :data:`BLOCKER` and the grey plane z = 0; per kind
    ``(light, unblocked, blocked)``: the radiance of the plane under a :data:`PATCH` view without the blocker and
    with it (closed forms, direct light only)."""
    rect_to_world = np.eye(4)
    rect_to_world[:3, 3] = (0, 0, 1.0)
    points = pixel_points((0, 0, 0), PATCH, RES, RES)
    center = np.array([1.2, 0.0, 1.0])  # beside the camera's view: lights are visible to camera rays
    to_sphere = center - points
    d2 = (to_sphere**2).sum(-1)
    # What the cosine-weighted sky sees past the blocker: 1 - the view factor of the blocker's square.
    sky = 1.0 - rect_irradiance(points, 2.0, 2.0, 0.3, 1.0) / np.pi
    return {
        "rect": (RectLight(to_world=rect_to_world, width=2.0, height=2.0, color=np.full(3, 3.0)),
                 ALBEDO * rect_irradiance(points, 1.0, 1.0, 1.0, 3.0) / np.pi, np.zeros((RES, RES))),
        # A sphere above the horizon lights a Lambertian point as a point light of intensity pi r^2 L does.
        "sphere": (SphereLight(position=center, radius=0.6, color=np.full(3, 3.0)),
                   ALBEDO * 3.0 * 0.6**2 * to_sphere[..., 2] / d2**1.5, np.zeros((RES, RES))),
        "dome": (DomeLight(color=np.full(3, 0.7)), np.full((RES, RES), ALBEDO * 0.7),
                 ALBEDO * 0.7 * sky),
    }


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("kind", ["rect", "sphere", "dome"])
@pytest.mark.parametrize("passed", ["shadow_enable_off", "shadow_link_excludes"])
def test_light_whose_shadows_pass_a_blocker_lights_the_floor_behind_it_fully(passed, kind, integrator):
    """A light with ``shadow:enable`` off, or whose shadowLink excludes the blocker, lights the floor under the
    blocker with the irradiance it gives without it. Before, ``path`` weighted its light samples against BSDF samples
    that the blocker stopped: the floor was 29% too dark under the rect light, 49% under the dome, 1.5% under the
    sphere (whose cone sampling takes most of the weight anyway). The same light with plain shadows is blocked as
    before (the floor under the rect and sphere lights black, the dome's sky seen past the blocker's edges; Whitted's
    dome term is unoccluded)."""
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")

    def render(light, spp=64):
        img = wrt.render(wrt.Scene(meshes=[plane, BLOCKER], lights=[light]), camera=top_down_camera(height=PATCH),
                         width=RES, height=RES, spp=spp, seed=1, device="cpu", integrator=integrator, max_depth=1)
        assert np.isin(img.aovs["prim"], (0, 1)).all()  # the plane's triangles, seen past the culled blocker
        return img.rgb.mean(axis=-1)

    light, unblocked, blocked = lights_over_a_blocker()[kind]
    if passed == "shadow_enable_off":
        passing = dataclasses.replace(light, shadows=False)
    else:
        passing = dataclasses.replace(light, shadow_link=wrt.LinkCollection.excluding("/blocker"))
    check(render(passing), unblocked)
    if kind == "dome" and integrator == "whitted":
        blocked = unblocked
    # The sky past the edges is a few percent of it, in a few samples: more of them, and the mean compared.
    np.testing.assert_allclose(render(light, spp=256).mean(), blocked.mean(), rtol=0.05, atol=1e-7)


SHADOW_TINT = np.array([0.5, 0.25, 0.0])


def render_over_blocker(light, integrator, spp=64, lights_given=False):
    """``(RES, RES, 3)`` radiance of the plane under :data:`BLOCKER`, lit by ``light`` alone (or the list of lights
    ``light`` where ``lights_given``; direct light only)."""
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")
    lights = light if lights_given else [light]
    img = wrt.render(wrt.Scene(meshes=[plane, BLOCKER], lights=lights), camera=top_down_camera(height=PATCH),
                     width=RES, height=RES, spp=spp, seed=1, device="cpu", integrator=integrator, max_depth=1)
    assert np.isin(img.aovs["prim"], (0, 1)).all()
    return img.rgb


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("kind", ["rect", "sphere", "dome"])
def test_shadow_color_tints_the_light_a_blocker_stops(kind, integrator):
    """ShadowAPI ``shadow:color``: light the blocker stops arrives times the colour, per channel, what passes it
    arrives whole: ``blocked + colour (unblocked - blocked)`` (it was black, with a warning). Whitted's dome term is
    unoccluded, so its floor is the unblocked one."""
    light, unblocked, blocked = lights_over_a_blocker()[kind]
    rgb = render_over_blocker(dataclasses.replace(light, shadow_color=SHADOW_TINT), integrator,
                              spp=256 if kind == "dome" else 64)
    if kind == "dome" and integrator == "whitted":
        blocked = unblocked
    for c in (0, 1):
        check(rgb[..., c], blocked + SHADOW_TINT[c] * (unblocked - blocked))
    if kind == "dome":  # the sky past the blocker's edges, in a few samples: the mean compared
        np.testing.assert_allclose(rgb[..., 2].mean(), blocked.mean(), rtol=0.05)
    else:
        assert rgb[..., 2].max() == 0.0


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("kind", ["rect", "sphere"])
def test_shadow_distance_keeps_farther_occluders_from_casting_shadows(kind, integrator):
    """ShadowAPI ``shadow:distance``: occluders further from the surface point than it cast no shadow. The blocker
    lies 0.3 above the floor: a distance of 0.2 lets the light through whole, one of 2 leaves the floor dark."""
    light, unblocked, _ = lights_over_a_blocker()[kind]
    check(render_over_blocker(dataclasses.replace(light, shadow_distance=0.2), integrator).mean(axis=-1), unblocked)
    assert render_over_blocker(dataclasses.replace(light, shadow_distance=2.0), integrator, spp=4).max() == 0.0


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_shadow_api_of_a_mesh_light_tints_and_limits_its_shadows_as_a_rect_lights(integrator):
    """ShadowAPI on a mesh light (MeshLightAPI): a 2 x 2 panel of radiance 3 facing down from z = 1 over
    :data:`BLOCKER` lights the floor as the rect light of :func:`lights_over_a_blocker` (closed form): its shadow
    tinted by ``shadow:color`` (``colour * unblocked`` per channel), and none cast from past ``shadow:distance``.
    Before, a mesh light took no ShadowAPI inputs (``wrt.MeshLight`` had no such fields; USD's were named in a
    warning and left out): its shadows were black."""
    panel = quad((0, 0, 1.0), (0, 2.0, 0), (2.0, 0, 0), name="/panel", double_sided=False)  # faces -Z
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")
    _, unblocked, _ = lights_over_a_blocker()["rect"]

    def render(**shadow_api):
        light = wrt.MeshLight("/panel", color=np.full(3, 3.0), **shadow_api)
        img = wrt.render(wrt.Scene(meshes=[plane, BLOCKER, panel], lights=[light]),
                         camera=top_down_camera(height=PATCH), width=RES, height=RES, spp=64, seed=1, device="cpu",
                         integrator=integrator, max_depth=1)
        assert np.isin(img.aovs["prim"], (0, 1)).all()  # the floor, seen past the culled blocker
        return img.rgb

    rgb = render(shadow_color=SHADOW_TINT)
    for c in (0, 1):
        check(rgb[..., c], SHADOW_TINT[c] * unblocked)
    assert rgb[..., 2].max() == 0.0
    check(render(shadow_distance=0.2).mean(axis=-1), unblocked)


def shadow_strength(d, distance, falloff, gamma):
    """ShadowAPI's shadow strength (1: full shadow) of an occluder ``d`` from the surface point, as the schema words
    it, in float64: none past ``distance``; in the falloff zone (its last ``falloff``, at most all of it; none for
    ``falloff <= 0``) ``t ** gamma`` with ``t`` falling linearly from 1 at the zone's start to 0 at ``distance``."""
    if distance >= 0.0 and d > distance:
        return 0.0
    zone = min(falloff, distance) if distance >= 0.0 and falloff > 0.0 else 0.0
    if zone <= 0.0 or d <= distance - zone:
        return 1.0
    return float(np.float64((distance - d) / zone) ** gamma)


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("distance, falloff, gamma", [(0.5, 0.4, 2.0), (0.5, 0.4, 1.0), (0.5, 0.4, 0.5),
                                                      (0.5, 5.0, 1.0), (0.5, 0.1, 1.0), (0.5, -1.0, 3.0),
                                                      (0.25, 0.2, 1.0)])
def test_shadow_falloff_fades_the_shadow_as_the_schema_says(integrator, distance, falloff, gamma):
    """ShadowAPI ``shadow:falloff`` and ``falloffGamma``: a sun straight down over :data:`BLOCKER` (0.3 above the
    floor, so every shadow ray meets it at 0.3) with a shadow distance, a falloff zone and a gamma lights the floor
    as ``1 - strength * (1 - shadow colour)`` of the unblocked light, the strength the schema's (float64). Before, the
    falloff was ignored (with a warning): the shadow was whole up to the distance (0.5 too dark at a strength of
    0.5)."""
    tint = np.array([0.0, 0.5, 1.0])
    sun = wrt.DistantLight(direction=(0, 0, -1), color=np.full(3, np.pi), shadow_distance=distance,
                           shadow_falloff=falloff, shadow_falloff_gamma=gamma, shadow_color=tint)
    rgb = render_over_blocker(sun, integrator).reshape(-1, 3)
    s = shadow_strength(0.3, distance, falloff, gamma)
    expected = ALBEDO * (1.0 - s * (1.0 - tint))  # E = pi: an unblocked floor shows ALBEDO
    # Each sample is blocked or not: the mean of the pixels' 64 samples each within 4 standard errors.
    np.testing.assert_allclose(rgb.mean(axis=0), expected, atol=4 * ALBEDO * np.sqrt(s * (1 - s) / (len(rgb) * 64))
                               + 1e-6)


def test_shadow_falloff_fades_the_shadow_of_each_of_many_lights():
    """The falloff of lights each picked with probability 2**-18 (a sun split into 2**18 suns over :data:`BLOCKER`):
    the floor is lit as the schema's strength says. Before, a shadow ray's reach was drawn from where the light-pick
    number (24 bits) fell inside the light's share of the cdf, which takes 2**24 * 2**-18 = 64 values: the strength
    a staircase of 64 steps, 33/64 for 32.1/64 (6 standard errors too dark here)."""
    n, falloff, strength = 2**18, 0.4, 32.1 / 64
    sun = wrt.DistantLight(direction=(0, 0, -1), color=np.full(3, np.pi / n), shadow_distance=0.3 + strength * falloff,
                           shadow_falloff=falloff)
    rgb = render_over_blocker([copy.copy(sun) for _ in range(n)], "path", spp=256, lights_given=True)
    s = shadow_strength(0.3, sun.shadow_distance, falloff, 1.0)
    assert abs(s - strength) < 1e-6
    samples = rgb.size // 3 * 256
    np.testing.assert_allclose(rgb.mean(), ALBEDO * (1.0 - s), atol=4 * ALBEDO * np.sqrt(s * (1 - s) / samples))


def test_usd_shadow_inputs_that_are_no_numbers_read_as_fallbacks_with_a_warning(tmp_path):
    """A shadow distance authored as text, a negative shadow colour or a negative falloff gamma (the schema's
    validator asks for >= 0) is read as the schema's fallback (any distance, black, 1), named in a warning with its
    light (the text as an input of another type than the schema's); the light is kept."""

    def build(stage):
        odd = UsdLux.DiskLight.Define(stage, "/Odd")
        odd.GetPrim().CreateAttribute("inputs:shadow:distance", Sdf.ValueTypeNames.String).Set("far")
        shadow = UsdLux.ShadowAPI.Apply(odd.GetPrim())
        shadow.CreateShadowColorAttr(Gf.Vec3f(0.5, -0.2, 0.0))
        shadow.CreateShadowFalloffGammaAttr(-2.0)

    with pytest.warns(UserWarning, match=r"ShadowAPI inputs that are not finite numbers.*inputs:shadow:color = "
                                         r"\(0\.5, -0\.2.*inputs:shadow:falloffGamma = -2\.0: 1\): /Odd$"):
        with pytest.warns(UserWarning, match=r"another type than the schema's.*\(string inputs:shadow:distance = "
                                             r"'far': 1\): /Odd$"):
            scene = wrt.load_usd(write_stage(tmp_path, build))
    (light,) = scene.lights
    assert light.shadow_color is None and light.shadow_distance == -1.0 and light.shadow_falloff_gamma == 1.0


def test_shadow_api_fields_are_checked_naming_the_light():
    with pytest.raises(wrt.SceneError, match="/Lamp: .*shadow_color must be finite numbers of shape"):
        SphereLight(position=(0, 0, 1), radius=0.1, color=np.ones(3), path="/Lamp", shadow_color=(0.5, -1.0, 0.0))
    with pytest.raises(wrt.SceneError, match="/Sun: .*shadow_distance must be a finite number"):
        wrt.DistantLight(direction=(0, 0, -1), color=np.ones(3), path="/Sun", shadow_distance=float("nan"))
    with pytest.raises(wrt.SceneError, match="/Sun: .*shadow_falloff_gamma must be a finite number >= 0"):
        wrt.DistantLight(direction=(0, 0, -1), color=np.ones(3), path="/Sun", shadow_falloff_gamma=-1.0)


def test_usd_shadow_enable_and_unsupported_shadow_inputs(tmp_path):
    """``inputs:shadow:enable`` is read (applied API or not), and so are the diffuse and specular multipliers, the
    shadow colour, distance and falloff (once named as not rendered), with the schema's fallbacks where none is
    authored."""

    def build(stage):
        off = UsdLux.SphereLight.Define(stage, "/NoShadows")
        UsdLux.ShadowAPI.Apply(off.GetPrim()).CreateShadowEnableAttr(False)
        UsdLux.RectLight.Define(stage, "/Plain")
        tinted = UsdLux.DiskLight.Define(stage, "/Tinted")
        UsdLux.ShadowAPI.Apply(tinted.GetPrim()).CreateShadowColorAttr(Gf.Vec3f(0.2, 0.0, 0.0))
        near = UsdLux.ShadowAPI.Apply(UsdLux.SphereLight.Define(stage, "/Near").GetPrim())
        near.CreateShadowDistanceAttr(3.0)
        near.CreateShadowFalloffAttr(1.0)
        shadowless = UsdLux.ShadowAPI.Apply(UsdLux.DiskLight.Define(stage, "/TintedShadowless").GetPrim())
        shadowless.CreateShadowEnableAttr(False)
        shadowless.CreateShadowFalloffAttr(2.0)
        shadowless.CreateShadowColorAttr(Gf.Vec3f(0.2, 0.0, 0.0))
        UsdLux.DistantLight.Define(stage, "/Dim").CreateDiffuseAttr(0.5)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(write_stage(tmp_path, build))
    messages = [str(w.message) for w in caught]
    assert not [m for m in messages if "shadow" in m.lower()], messages
    assert not any("multiplier" in m for m in messages), messages
    lights = {light.path: light for light in scene.lights}
    shadows = {path: light.shadows for path, light in lights.items()}
    assert shadows == {"/NoShadows": False, "/Plain": True, "/Tinted": True, "/Near": True,
                       "/TintedShadowless": False, "/Dim": True}
    np.testing.assert_allclose(lights["/Tinted"].shadow_color, (0.2, 0.0, 0.0), rtol=1e-6)
    assert lights["/Tinted"].shadow_distance == -1.0 and lights["/Near"].shadow_distance == 3.0
    memory = Usd.Stage.CreateInMemory()  # kept: a schema on a prim of a freed stage is invalid
    fallbacks = UsdLux.ShadowAPI.Apply(memory.DefinePrim("/L", "SphereLight"))  # its fallbacks, unauthored
    fallback = (fallbacks.GetShadowFalloffAttr().Get(), fallbacks.GetShadowFalloffGammaAttr().Get())
    falloffs = {path: (light.shadow_falloff, light.shadow_falloff_gamma) for path, light in lights.items()
                if path in ("/Near", "/Tinted")}
    assert falloffs == {"/Near": (1.0, fallback[1]), "/Tinted": fallback} and fallback == (-1.0, 1.0), falloffs
    assert lights["/Plain"].shadow_color is None and lights["/TintedShadowless"].shadow_color is None
    multipliers = {path: (light.diffuse, light.specular) for path, light in lights.items()}
    assert multipliers == {"/NoShadows": (1, 1), "/Plain": (1, 1), "/Tinted": (1, 1), "/Near": (1, 1),
                           "/TintedShadowless": (1, 1), "/Dim": (0.5, 1)}


def test_non_uniformly_scaled_sphere_light_is_an_ellipsoid(tmp_path):
    """A sphere light scaled unevenly or sheared loads as the ellipsoid it is (its transform's 3x3 as its frame,
    silently); a uniform scale scales the radius of a round sphere; a transform that flattens it (a singular one) is
    drawn as a sphere of the mean radius, and the load says so."""

    def build(stage):
        UsdGeom.XformCommonAPI(UsdLux.SphereLight.Define(stage, "/Squashed")).SetScale(Gf.Vec3f(1.0, 1.0, 0.25))
        UsdGeom.XformCommonAPI(UsdLux.SphereLight.Define(stage, "/Round")).SetScale(Gf.Vec3f(2.0, 2.0, 2.0))
        # Unit axes, but X and Y at 37 degrees: an ellipsoid that the lengths of the axes alone let through.
        sheared = UsdGeom.Xformable(UsdLux.SphereLight.Define(stage, "/Sheared"))
        sheared.AddTransformOp().Set(Gf.Matrix4d(1, 0, 0, 0, 0.8, 0.6, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1))
        UsdGeom.XformCommonAPI(UsdLux.SphereLight.Define(stage, "/Flat")).SetScale(Gf.Vec3f(1.0, 1.0, 0.0))

    with pytest.warns(UserWarning, match=r"SphereLights flattened.*1 prim\(s\): /Flat$"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    lights = {light.path: light for light in scene.lights}
    assert lights["/Round"].frame is None and lights["/Round"].radius == pytest.approx(1.0)
    np.testing.assert_allclose(lights["/Squashed"].ellipsoid(), np.diag([0.5, 0.5, 0.125]))
    np.testing.assert_allclose(lights["/Sheared"].ellipsoid(), 0.5 * np.array([[1, 0.8, 0], [0, 0.6, 0], [0, 0, 1]]))
    assert lights["/Flat"].ellipsoid() is None and lights["/Flat"].world_radius == pytest.approx(0.5 * 2 / 3)


def test_cylinder_light_with_an_elliptic_or_oblique_cross_section_is_drawn_as_authored(tmp_path):
    """A CylinderLight scaled unevenly across its axis (or sheared) is an elliptic tube, which wrt drew as a round one
    of the mean radius (23% too dark to 36% too bright on a floor below one of Y, Z scales 3 and 0.5): it loads
    silently and is drawn as authored (tests/test_usd_light_oracle.py). Scaling the length alone, or Y and Z
    evenly, keeps a round tube; a transform that flattens it (a singular one) is drawn round, with a warning."""

    def build(stage):
        UsdGeom.XformCommonAPI(UsdLux.CylinderLight.Define(stage, "/Flat")).SetScale(Gf.Vec3f(1.0, 3.0, 0.5))
        sheared = UsdGeom.Xformable(UsdLux.CylinderLight.Define(stage, "/Sheared"))
        sheared.AddTransformOp().Set(Gf.Matrix4d(1, 0, 0, 0, 0, 1, 0, 0, 0.6, 0, 0.8, 0, 0, 0, 0, 1))
        UsdGeom.XformCommonAPI(UsdLux.CylinderLight.Define(stage, "/Long")).SetScale(Gf.Vec3f(4.0, 2.0, 2.0))
        UsdGeom.XformCommonAPI(UsdLux.CylinderLight.Define(stage, "/Ribbon")).SetScale(Gf.Vec3f(1.0, 1.0, 0.0))

    with pytest.warns(UserWarning, match=r"CylinderLights flattened.*1 prim\(s\): /Ribbon$"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    lights = {light.path: light for light in scene.lights}
    assert lights["/Long"].tube() is None and lights["/Ribbon"].tube() is None
    axis, radius = lights["/Long"].world_shape()
    assert np.linalg.norm(axis) == pytest.approx(4.0) and radius == pytest.approx(1.0)
    np.testing.assert_allclose(lights["/Flat"].tube(), np.diag([1.0, 1.5, 0.25]))
    np.testing.assert_allclose(lights["/Sheared"].tube(), np.array([[1, 0, 0.3], [0, 0.5, 0], [0, 0, 0.4]]))


@pytest.mark.parametrize("exposure", [1024.0, 1e6, 200.0])
def test_light_exposure_that_overflows_is_skipped_with_a_warning(tmp_path, exposure):
    """``2.0**exposure`` raised a bare OverflowError out of load_usd from 1024 on, naming no file or prim; 200 fits
    a double but not the float32 colour. Both are colours that are not finite: skipped like a NaN colour."""

    def build(stage):
        UsdLux.SphereLight.Define(stage, "/Bright").CreateExposureAttr(exposure)
        UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(2.0)

    with pytest.warns(UserWarning, match=r"lights\.usda: lights whose colour .*exposure.* not finite.*: /Bright$"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    assert [light.path for light in scene.lights] == ["/Sun"]


def test_light_exposure_that_underflows_float32_is_skipped_with_a_warning(tmp_path):
    """An intensity of 1e-30 at exposure -80 is a colour of 8e-55 (float64), which float32 cannot hold: the light's
    colour was 0 and it lit nothing without a word. It is skipped with a warning naming it and the product; an
    intensity of 1e30 at exposure -80 (8.3e5) is the light of that colour (float64 numpy)."""

    def build(stage):
        dim = UsdLux.SphereLight.Define(stage, "/Dim")
        dim.CreateIntensityAttr(1e-30)
        dim.CreateExposureAttr(-80.0)
        bright = UsdLux.SphereLight.Define(stage, "/Bright")
        bright.CreateIntensityAttr(1e30)
        bright.CreateExposureAttr(-80.0)

    with pytest.warns(UserWarning, match=r"lights whose colour \* intensity \* 2\^exposure lies below float32's normal "
                                         r"range .*largest component 1e-30 \* 2\^-80.*: /Dim$"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    assert [light.path for light in scene.lights] == ["/Bright"]
    np.testing.assert_allclose(scene.lights[0].color, np.float64(np.float32(1e30)) * 2.0**-80, rtol=1e-7)


def test_light_colour_temperature_that_is_nan_is_skipped_with_a_warning(tmp_path):
    """``UsdLux.BlackbodyTemperatureAsRgb`` crashes the process (a segfault) on a NaN temperature, and load_usd
    passed the authored ``colorTemperature`` to it: loading the stage killed Python. Such a light is skipped with a
    warning naming it, in a child process so that a crash fails this test rather than the run."""

    def build(stage):
        light = UsdLux.SphereLight.Define(stage, "/Warm")
        light.CreateEnableColorTemperatureAttr(True)
        light.CreateColorTemperatureAttr(math.nan)
        UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(2.0)

    script = ("import warnings, wrt\nwith warnings.catch_warnings(record=True) as caught:\n"
              "    warnings.simplefilter('always')\n    scene = wrt.load_usd(__import__('sys').argv[1])\n"
              "print([light.path for light in scene.lights])\nprint(*[w.message for w in caught], sep='\\n')\n")
    done = subprocess.run([sys.executable, "-c", script, write_stage(tmp_path, build)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert lines[0] == "['/Sun']"
    assert any(re.search(r"lights\.usda: lights whose colorTemperature is NaN were skipped: "
                         r"1 prim\(s\) \(inputs:colorTemperature = nan: 1\): /Warm$", line) for line in lines[1:])


@pytest.mark.parametrize(
    "schema, attr, value",
    [
        (UsdLux.SphereLight, "radius", math.nan),
        (UsdLux.SphereLight, "radius", -1.0),
        (UsdLux.RectLight, "width", math.nan),
        (UsdLux.RectLight, "height", -2.0),
        (UsdLux.DiskLight, "radius", math.inf),
        (UsdLux.DistantLight, "angle", math.nan),
        (UsdLux.CylinderLight, "length", math.inf),
        (UsdLux.CylinderLight, "radius", -0.5),
    ],
)
def test_light_with_a_negative_or_non_finite_size_is_skipped_with_a_warning(tmp_path, schema, attr, value):
    """A NaN or infinite radius, width, length or angle loaded without a word and lit nothing (a black image); it is
    skipped like a light whose colour is not finite, and the warning names the prim and the attribute."""

    def build(stage):
        light = schema.Define(stage, "/Bad")
        getattr(light, f"Create{attr.capitalize()}Attr")(value)
        UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(2.0)

    pattern = rf"lights\.usda: lights with a negative or non-finite size were skipped: 1 prim\(s\) \(inputs:{attr} = "
    with pytest.warns(UserWarning, match=pattern + rf"{value:g}: 1\): /Bad$"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    assert [light.path for light in scene.lights] == ["/Sun"]


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: wrt.DistantLight([0, 0, 0], [1, 1, 1], path="/Sun"), r"^/Sun: DistantLight direction must not be"),
        (lambda: wrt.DistantLight([0, 0, -1], [np.nan, 1, 1], path="/Sun"), r"^/Sun: DistantLight color must be"),
        (lambda: wrt.DistantLight([0, 0, -1], [1, 1, 1], angle=math.inf), r"^DistantLight angle must be a finite"),
        (lambda: wrt.SphereLight([np.nan, 0, 5], 1.0, [1, 1, 1], path="/S"), r"^/S: SphereLight position must be"),
        (lambda: wrt.SphereLight([0, 0, 5], -1.0, [1, 1, 1], path="/S"), r"^/S: SphereLight radius must be .* >= 0"),
        (lambda: RectLight(np.eye(4), math.nan, 1.0, [1, 1, 1], path="/R"), r"^/R: RectLight width must be"),
        (lambda: RectLight(np.eye(4), 1.0, 1.0, [1, 1, 1e39], path="/R"), r"^/R: RectLight color must be finite"),
        (lambda: DiskLight(np.full((4, 4), np.inf), 1.0, [1, 1, 1], path="/D"), r"^/D: DiskLight to_world must be"),
        (lambda: CylinderLight(np.eye(4), 1.0, 0.5, [1, -1, 1], path="/C"), r"^/C: CylinderLight color .* >= 0"),
        (lambda: DomeLight([1, 1, 1], texture=np.ones((4, 8)), path="/Dome"), r"^/Dome: DomeLight texture must be"),
        (lambda: DomeLight("white", path="/Dome"), r"^/Dome: DomeLight color must be finite numbers"),
        # A Gf.Matrix4d passed untransposed: its translation lands in the bottom row, which no kernel reads.
        (lambda: RectLight(np.array(Gf.Matrix4d().SetTranslate(Gf.Vec3d(1, 2, 3))), 1.0, 1.0, [1, 1, 1], path="/R"),
         r"^/R: RectLight to_world has bottom row \[1.0, 2.0, 3.0, 1.0\]; it must be an affine"),
        (lambda: DomeLight([1, 1, 1], to_world=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1]]),
                           path="/Dome"), r"^/Dome: DomeLight to_world has bottom row"),
    ],
)
def test_lights_built_in_python_refuse_values_that_light_nothing(make, message):
    """A zero or NaN direction, a NaN colour or position rendered black without a word, and a 2D dome texture failed
    deep in Warp (a TypeError about 'dome_texels'): each raises at construction, naming the light and the field."""
    with pytest.raises(wrt.SceneError, match=message):
        make()


def test_usd_light_with_a_projective_transform_is_warned_about_and_read_as_its_affine_part(tmp_path):
    """A light's projective world transform (a last column other than (0, 0, 0, 1)) was dropped without a word, as
    meshes, instances and cameras report it."""

    def build(stage):
        rect = UsdLux.RectLight.Define(stage, "/Rect")
        rect.AddTransformOp().Set(Gf.Matrix4d(1, 0, 0, 0.05, 0, 1, 0, 0, 0, 0, 1, 0, 2, 3, 4, 1))

    with pytest.warns(UserWarning, match=r"world transform is projective; its last column was ignored.*: /Rect"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    (light,) = scene.lights
    np.testing.assert_array_equal(light.to_world[3], [0, 0, 0, 1])
    np.testing.assert_array_equal(light.to_world[:3, 3], [2, 3, 4])


def test_distant_light_direction_is_made_unit():
    """The kernels take the direction as a unit vector: a longer one made the light brighter."""
    np.testing.assert_allclose(wrt.DistantLight([0, 0, -2], [1, 1, 1]).direction, [0, 0, -1])


def test_usd_light_whose_scaled_radius_overflows_is_skipped_with_a_warning(tmp_path):
    """A scale of 1e100 keeps the transform finite in float64, but the sphere's world radius is not finite in float32
    (what the device reads): the light's own check refuses it, and the reader turns that into a skip."""

    def build(stage):
        big = UsdLux.SphereLight.Define(stage, "/Huge")
        big.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(1e100, 1e100, 1e100))
        UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(2.0)

    with pytest.warns(UserWarning, match=r"lights with values wrt cannot use were skipped.*SphereLight .*: /Huge$"):
        scene = wrt.load_usd(write_stage(tmp_path, build))
    assert [light.path for light in scene.lights] == ["/Sun"]


@wp.kernel
def environment_kernel(
    lights: DeviceLights,
    dirs: wp.array[wp.vec3],
    # outputs
    radiance: wp.array[float],
):
    """What an escaped ray along ``dirs[i]`` sees, with MIS weight 1 (a mirror's or the camera's ray)."""
    i = wp.tid()
    radiance[i] = environment(lights, dirs[i], 0.0, wp.vec3(0.0), 1, wp.vec3(0.0), 0)[0]


def radiance_seen(kernel, light, dirs):
    """``kernel``'s radiance along each direction of ``dirs`` (float64, rounded to float32) from ``light`` alone, on
    the renderer's device (a GPU's under render_on_cuda)."""
    r = light_renderer(light)
    radiance = wp.empty(len(dirs), dtype=float, device=r.device)
    directions = wp.array(dirs.astype(np.float32), dtype=wp.vec3, device=r.device)
    wp.launch(kernel, len(dirs), inputs=[r.device_lights, directions], outputs=[radiance], device=r.device)
    return radiance.numpy()


def cap_directions(axis, one_minus_max, count, rng):
    """``count`` unit directions uniform in the cap ``1 - cos <= one_minus_max`` around unit ``axis`` (float64),
    and their ``1 - cos``."""
    one_minus = rng.random(count) * one_minus_max
    sin_t = np.sqrt(one_minus * (2.0 - one_minus))
    phi = 2.0 * np.pi * rng.random(count)
    x = np.cross(axis, [0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.cross(axis, [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(axis, x)
    dirs = (1.0 - one_minus)[:, None] * axis + (sin_t * np.cos(phi))[:, None] * x + (sin_t * np.sin(phi))[:, None] * y
    return dirs, one_minus


@pytest.mark.parametrize("angle", [0.1, 0.05, 0.53, 3.0])
def test_a_small_sun_seen_by_rays_delivers_its_illuminance(angle, np_rng):
    """The sun disc of a soft DistantLight, as rays that escape see it (a perfect mirror reflecting the sun, or a
    camera looking at it), integrated over solid angle times the cosine, gives its illuminance E at normal incidence.
    The disc was the cone of float32(cos(angle / 2)), whose solid angle misses 2 pi (1 - cos) by 6% at 0.1 degrees
    and 25% at 0.05; light sampling (uniform in that cone, reporting pdf 1 / (2 pi (1 - cos))) drew from it too."""
    direction = np.array([0.3, -0.2, -1.0]) / np.linalg.norm([0.3, -0.2, -1.0])
    light = wrt.DistantLight(direction=direction, color=np.full(3, 2.0), angle=angle, normalize=True)  # E = 2
    # Directions uniform in a float64 cap of twice the disc's half-angle around the sun.
    count, cap_half = 200_000, math.radians(angle)
    axis = -direction
    dirs, one_minus = cap_directions(axis, 1.0 - math.cos(cap_half), count, np_rng)
    cap = 2.0 * math.pi * (1.0 - math.cos(cap_half))
    # Times the cosine at normal incidence.
    estimate = radiance_seen(environment_kernel, light, dirs) * (1.0 - one_minus)
    error = estimate.std() * cap / math.sqrt(count)
    assert abs(estimate.mean() * cap - 2.0) < max(4.0 * error, 2e-3), (estimate.mean() * cap, error)

    # Light sampling draws directions inside that disc only, with the pdf and value it reports.
    irradiance, _ = light_estimates(light, (0.0, 0.0, 0.0), axis)
    assert abs(irradiance.mean() - 2.0) < 2e-3 * 2.0


@wp.kernel
def lights_on_ray_kernel(
    lights: DeviceLights,
    dirs: wp.array[wp.vec3],
    # outputs
    radiance: wp.array[float],
):
    """Radiance of the area lights a ray from the origin along ``dirs[i]`` passes through, with MIS weight 1."""
    i = wp.tid()
    seen = lights_on_segment(lights, wp.vec3(0.0), dirs[i], 0.0, wp.inf, 0.0, wp.vec3(0.0), 1, wp.vec3(0.0), 0)
    radiance[i] = seen[0]


@pytest.mark.parametrize("distance, radius", [(10.0, 0.05), (100.0, 0.1), (1000.0, 0.5), (30.0, 0.01)])
def test_a_far_sphere_light_seen_by_rays_has_its_solid_angle(distance, radius, np_rng):
    """Rays from a point (a mirror's or the camera's) see a sphere light over its exact solid angle
    ``2 pi (1 - sqrt(1 - (r / d)^2))``: the discriminant ``b^2 - c`` cancelled in float32, and a sphere 1000 radii
    away looked 15% too large (30 radii of 0.01: 5% too small), while light sampling reported the exact cone."""
    axis = np.array([0.3, 0.5, 1.0]) / np.linalg.norm([0.3, 0.5, 1.0])
    light = SphereLight(position=axis * distance, radius=radius, color=np.ones(3))
    sin2 = (radius / distance) ** 2
    exact = 2.0 * math.pi * sin2 / (1.0 + math.sqrt(1.0 - sin2))  # 2 pi (1 - cos) without cancellation
    count = 200_000
    cap = 4.0 * exact / (2.0 * math.pi)  # 1 - cos of a cap of twice the light's angular radius (about)
    dirs, _ = cap_directions(axis, cap, count, np_rng)
    hits = radiance_seen(lights_on_ray_kernel, light, dirs)
    seen = hits.mean() * 2.0 * math.pi * cap
    error = hits.std() * 2.0 * math.pi * cap / math.sqrt(count)
    assert abs(seen - exact) < 4.0 * error, (seen / exact, error / exact)


def test_unprefixed_light_attributes_of_old_files_are_read_with_a_warning(tmp_path):
    """Files written before USD 21.05 (older Omniverse and Isaac Sim content) author ``intensity``, ``radius``,
    ``color`` ... without the ``inputs:`` prefix; they loaded as intensity 1, white, radius 0.5 without a word.
    A prefixed value, where both are authored, still wins."""
    path = tmp_path / "old_lights.usda"
    path.write_text("""#usda 1.0
def SphereLight "Old"
{
    float intensity = 3000
    float radius = 0.25
    color3f color = (1, 0.5, 0.25)
}
def DistantLight "Both"
{
    float intensity = 7
    float inputs:intensity = 2
    float angle = 0
}
def SphereLight "New"
{
    float inputs:intensity = 5
}
""")
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(str(path))
    by_path = {light.path: light for light in scene.lights}
    old = by_path["/Old"]
    assert old.radius == pytest.approx(0.25)
    np.testing.assert_allclose(old.color, np.array([1.0, 0.5, 0.25]) * 3000.0, rtol=1e-6)
    both = by_path["/Both"]
    assert both.angle == 0.0
    np.testing.assert_allclose(both.illuminance, 2.0)  # inputs:intensity, not the old 7
    np.testing.assert_allclose(by_path["/New"].color, 5.0)
    messages = [str(w.message) for w in record if "inputs: prefix" in str(w.message)]
    assert len(messages) == 1, messages
    assert "2 prim(s)" in messages[0] and "/Old" in messages[0] and "/Both" in messages[0]
    assert "/New" not in messages[0] and "intensity" in messages[0] and "radius" in messages[0]


MISTYPED_LIGHTS = """#usda 1.0
def SphereLight "Words"
{
    string inputs:intensity = "bright"
}
def DistantLight "Named"
{
    token inputs:color = "red"
}
def RectLight "Hot" (
    prepend apiSchemas = ["ShapingAPI"]
)
{
    bool inputs:enableColorTemperature = 1
    string inputs:colorTemperature = "warm"
}
def DiskLight "Cold"
{
    string inputs:colorTemperature = "cold"
    float inputs:intensity = 3
}
"""


def test_a_light_input_of_the_wrong_type_is_the_schemas_fallback_with_a_warning_naming_it(tmp_path):
    """A string intensity or a token colour stopped the whole load with "cannot read this prim", naming no input,
    and then skipped the light; USD's typed readers pass such a value over for the schema's fallback (intensity 1,
    white, 6500 K), and so does wrt, naming it. A colour temperature that is not enabled is not read."""
    path = tmp_path / "mistyped.usda"
    path.write_text(MISTYPED_LIGHTS)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    messages = [str(w.message) for w in caught if "another type than the schema's" in str(w.message)]
    assert len(messages) == 1, messages
    for name, shown in (("/Words", "string inputs:intensity = 'bright'"), ("/Named", "token inputs:color = 'red'"),
                        ("/Hot", "string inputs:colorTemperature = 'warm'")):
        assert name in messages[0] and shown in messages[0], messages[0]
    assert "/Cold" not in messages[0]
    assert [light.path for light in scene.lights] == ["/Words", "/Named", "/Hot", "/Cold"]
    stage = Usd.Stage.Open(str(path))
    fallback = Usd.SchemaRegistry().FindConcretePrimDefinition("DistantLight").GetAttributeFallbackValue
    np.testing.assert_allclose(scene.lights[1].color, fallback("inputs:intensity") * np.ones(3), rtol=1e-6)
    hot = UsdLux.RectLight(stage.GetPrimAtPath("/Hot"))
    rect = hot.GetPrim().GetPrimDefinition().GetAttributeFallbackValue
    blackbody = UsdLux.BlackbodyTemperatureAsRgb(rect("inputs:colorTemperature"))
    np.testing.assert_allclose(scene.lights[2].color, np.array(blackbody) * rect("inputs:intensity"), rtol=1e-5)
    assert hot.GetColorTemperatureAttr().Get() == "warm"  # (Python's untyped read hands the text back)
    intensity = UsdLux.DiskLight(stage.GetPrimAtPath("/Cold")).GetIntensityAttr().Get()
    np.testing.assert_allclose(scene.lights[3].color, intensity)


def test_a_blocked_light_input_is_the_schemas_fallback(tmp_path):
    """A value block (``= None``) resolves to the schema's fallback (USD's resolve info says so): a blocked
    DistantLight intensity was read as 1, 50000 times dimmer than USD's 50000."""
    path = tmp_path / "blocked.usda"
    path.write_text('#usda 1.0\ndef DistantLight "Sun"\n{\n    float inputs:intensity = None\n'
                    '    float inputs:angle = None\n    color3f inputs:color = None\n}\n')
    scene = wrt.load_usd(path)
    stage = Usd.Stage.Open(str(path))
    attr = stage.GetPrimAtPath("/Sun").GetAttribute("inputs:intensity")
    assert attr.GetResolveInfo().GetSource() == Usd.ResolveInfoSourceFallback
    schema = Usd.SchemaRegistry().FindConcretePrimDefinition("DistantLight")
    np.testing.assert_allclose(scene.lights[0].color, schema.GetAttributeFallbackValue("inputs:intensity"))
    np.testing.assert_allclose(scene.lights[0].angle, schema.GetAttributeFallbackValue("inputs:angle"), rtol=1e-6)


MISTYPED_SWITCHES = """#usda 1.0
def SphereLight "Words"
{
    string inputs:normalize = "yes"
    token inputs:enableColorTemperature = "x"
    float inputs:colorTemperature = 2000
    string treatAsPoint = "yes"
    float inputs:radius = 0.25
}
def SphereLight "Numbers" (
    prepend apiSchemas = ["ShadowAPI"]
)
{
    int inputs:shadow:enable = 0
    bool[] inputs:normalize = [1]
}
def SphereLight "Typed"
{
    bool inputs:normalize = 1
    bool treatAsPoint = 1
    bool inputs:shadow:enable = 0
}
"""


def test_a_light_switch_of_the_wrong_type_is_the_schema_fallback_with_a_warning_naming_it(tmp_path):
    """A bool light input authored with another type is no bool to USD's typed readers (``Get<bool>`` fails, Hydra
    reads the schema's fallback); wrt took Python's truth of the value: ``"yes"`` normalized, an ``int 0`` turned
    shadows off. The oracle: the schema registry's fallbacks; bool-typed inputs are read as authored."""
    path = tmp_path / "switches.usda"
    path.write_text(MISTYPED_SWITCHES)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    messages = [str(w.message) for w in caught if "not bool" in str(w.message)]
    assert len(messages) == 1, [str(w.message) for w in caught]
    for shown in ("/Words", "inputs:normalize = 'yes'", "inputs:enableColorTemperature = 'x'",
                  "treatAsPoint = 'yes'", "/Numbers", "inputs:shadow:enable = 0"):
        assert shown in messages[0]
    assert "/Typed" not in messages[0]
    stage = Usd.Stage.Open(str(path))
    sphere = stage.GetPrimAtPath("/Words").GetPrimDefinition()
    shadow = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("ShadowAPI")
    lights = {light.path: light for light in scene.lights}
    for name in ("/Words", "/Numbers"):
        assert lights[name].normalize == sphere.GetAttributeFallbackValue("inputs:normalize")
        assert lights[name].treat_as_point == sphere.GetAttributeFallbackValue("treatAsPoint")
        assert lights[name].shadows == shadow.GetAttributeFallbackValue("inputs:shadow:enable")
    # enableColorTemperature at its fallback (off): the colour is the authored white, no 2000 K tint
    assert not sphere.GetAttributeFallbackValue("inputs:enableColorTemperature")
    np.testing.assert_allclose(lights["/Words"].color, UsdLux.SphereLight(stage.GetPrimAtPath("/Words"))
                               .GetColorAttr().Get())
    typed = UsdLux.SphereLight(stage.GetPrimAtPath("/Typed"))
    assert lights["/Typed"].normalize == typed.GetNormalizeAttr().Get() is True
    assert lights["/Typed"].treat_as_point == typed.GetTreatAsPointAttr().Get() is True
    assert lights["/Typed"].shadows is False


def _render_without_runtime_warnings(path):
    """``(scene, rgb, the float32-skip warnings, every warning)`` of a load and 8x6 render of ``path`` in which a
    RuntimeWarning (numpy's overflow) fails."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("error", RuntimeWarning)
        scene = wrt.load_usd(path)
        image = wrt.render(scene, width=8, height=6, spp=1).rgb
    messages = [str(w.message) for w in caught if "to fit in float32 were skipped" in str(w.message)]
    return scene, image, messages, caught


def giant_light_stage(light: str) -> str:
    """A grey quad (displayColor 0.5) at z = -3 facing +Z, a camera at z = -1 looking down at it, and ``light``."""
    return f"""#usda 1.0
{light}
def Mesh "Quad"
{{
    point3f[] points = [(-1, -1, -3), (1, -1, -3), (1, 1, -3), (-1, 1, -3)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    color3f[] primvars:displayColor = [(0.5, 0.5, 0.5)]
}}
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 0, -1)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
"""


@pytest.mark.parametrize("light", [
    'def RectLight "Giant"\n{\n    float inputs:width = 1e38\n    float inputs:height = 1e38\n}',
    'def DiskLight "Giant"\n{\n    float inputs:radius = 1e38\n    bool inputs:normalize = 1\n}',
    'def CylinderLight "Giant"\n{\n    float inputs:radius = 1e30\n    float inputs:length = 1e38\n}',
    'def SphereLight "Giant"\n{\n    float inputs:radius = 1e38\n}',
    'def SphereLight "Giant"\n{\n    float inputs:radius = 1e38\n    bool treatAsPoint = 1\n}',
])
def test_a_light_whose_area_passes_float32_is_skipped_with_a_warning_naming_it(tmp_path, light):
    """Sizes near 1e38 overflowed the light table's float32 area (or a point sphere's intensity) behind numpy's bare
    'overflow encountered in cast', and the infinite area lit wrongly: a 1e38-wide RectLight over the grey quad
    gave 0 (whitted) or 0.3 (path) where an emitting plane filling the hemisphere gives albedo * L = 0.5. Now the
    light is skipped with a warning naming it, no RuntimeWarning escapes, and the image is the stage's without it."""
    path = tmp_path / "giant.usda"
    path.write_text(giant_light_stage(light + '\ndef DistantLight "Sun"\n{\n    float inputs:intensity = 2\n}'))
    scene, image, messages, caught = _render_without_runtime_warnings(path)
    assert len(messages) == 1 and "/Giant" in messages[0], [str(w.message) for w in caught]
    assert [light.path for light in scene.lights] == ["/Sun"]
    stage = Usd.Stage.Open(str(path))
    stage.RemovePrim("/Giant")
    without = tmp_path / "without.usda"
    stage.Export(str(without))
    np.testing.assert_array_equal(image, wrt.render(wrt.load_usd(without), width=8, height=6, spp=1).rgb)


@pytest.mark.parametrize("width", ["1e19", "1e30"])
def test_a_wide_light_lights_as_the_plane_it_nears(tmp_path, width):
    """A RectLight 1e19 or 1e30 wide (area 1e38 or 1e60: past float32, which skipped the light with a warning, as
    its pdf took the area in float32) filling the quad's hemisphere: radiance L over it gives a Lambertian surface of
    albedo 0.5 the radiance 0.5 L (irradiance pi L), as an infinite emitting plane would."""
    path = tmp_path / "wide.usda"
    path.write_text(giant_light_stage(f'def RectLight "Wide"\n{{\n    float inputs:width = {width}\n'
                                      f'    float inputs:height = {width}\n}}'))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        scene = wrt.load_usd(path)
        image = wrt.render(scene, width=8, height=6, spp=1).rgb
    assert [light.path for light in scene.lights] == ["/Wide"]
    np.testing.assert_allclose(image, 0.5, rtol=2e-2)  # 1 spp of solid-angle sampling: noise below 1%


@pytest.mark.parametrize("radius", [1.0e19, 1.0e30])
def test_a_sphere_light_whose_area_passes_float32_lights_as_its_solid_angle_says(tmp_path, radius):
    """A SphereLight of radius 1e19 or 1e30 (area past float32; kept since 8f7db73) twice its radius above the quad:
    it fills a cone of half-angle 30 degrees over it, irradiance pi L sin^2(30) = pi L / 4, so the grey quad (albedo
    0.5) shows 0.125 L. The light table cast the sphere's unused area to float32, and numpy's 'overflow encountered
    in cast' stopped the render where warnings are errors."""
    path = tmp_path / "sphere.usda"
    path.write_text(giant_light_stage(f'def SphereLight "Big"\n{{\n    float inputs:radius = {radius:g}\n'
                                      f'    double3 xformOp:translate = (0, 0, {2.0 * radius:g})\n'
                                      '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}'))
    scene, image, messages, caught = _render_without_runtime_warnings(path)
    assert not messages and [light.path for light in scene.lights] == ["/Big"], [str(w.message) for w in caught]
    np.testing.assert_allclose(image.mean(), 0.125, rtol=2e-2)


@pytest.mark.parametrize("width", ["1e15", "1e28"])
def test_an_instanced_light_scaled_past_float32_is_skipped_alone_with_a_warning_naming_it(tmp_path, width):
    """A PointInstancer's RectLight whose instance scale makes its size pass float32 (1e28 wide, scaled by 1e10) is
    skipped, named with its instance, and the other instance kept; the copied light went to the light table and
    overflowed there. Scaled to 1e25 wide (its area past float32, which skipped it too), both lamps are kept and
    light the quad as two emitting planes: albedo * 2 L."""
    path = tmp_path / "instanced.usda"
    path.write_text(giant_light_stage("""def PointInstancer "Inst"
{
    rel prototypes = [</Inst/Proto>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (5, 0, 0)]
    float3[] scales = [(1, 1, 1), (1e10, 1e10, 1)]
    def Xform "Proto"
    {
        def RectLight "Lamp"
        {
            float inputs:width = WIDTH
            float inputs:height = WIDTH
        }
    }
}""".replace("WIDTH", width)))
    scene, image, messages, caught = _render_without_runtime_warnings(path)
    if width == "1e15":
        assert not messages and [light.path for light in scene.lights] == ["/Inst/Proto/Lamp[0]", "/Inst/Proto/Lamp[1]"]
        np.testing.assert_allclose(image.mean(), 1.0, rtol=1e-2)  # 1 spp of each lamp: noise of a few %
        np.testing.assert_allclose(image, 1.0, rtol=5e-2)
        return
    assert len(messages) == 1 and "/Inst/Proto/Lamp[1]" in messages[0], [str(w.message) for w in caught]
    assert [light.path for light in scene.lights] == ["/Inst/Proto/Lamp[0]"]
    np.testing.assert_allclose(image, 0.5, rtol=2e-2)  # the kept lamp fills the quad's hemisphere: albedo * L


def test_a_light_too_large_for_float32_is_named_with_the_value_past_it_not_its_area(tmp_path):
    """Since lights are sampled in lengths scaled per light (8f7db73) a light is skipped for a size past 8.5e37, or a
    point sphere for an intensity past float32, not for its area; the warning still gave the area ('area 1e+38' for a
    RectLight 1e38 x 1 whose area fits float32, 'area 1.26e+61' for a point sphere of radius 1e30). It gives the
    authored width, and the point sphere's intensity pi r^2 L, each worked out here in float64."""
    path = tmp_path / "large.usda"
    path.write_text('#usda 1.0\ndef RectLight "Long"\n{\n    float inputs:width = 1e38\n'
                    '    float inputs:height = 1\n}\n'
                    'def SphereLight "Point"\n{\n    float inputs:radius = 1e20\n    bool treatAsPoint = 1\n}\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    assert scene.lights == []
    (message,) = [str(w.message) for w in caught if "to fit in float32 were skipped" in str(w.message)]
    stage = Usd.Stage.Open(str(path))
    width = UsdLux.RectLight(stage.GetPrimAtPath("/Long")).GetWidthAttr().Get()
    radius = UsdLux.SphereLight(stage.GetPrimAtPath("/Point")).GetRadiusAttr().Get()
    intensity = UsdLux.SphereLight(stage.GetPrimAtPath("/Point")).GetIntensityAttr().Get()
    assert f"size {width:.3g}: 1" in message and f"intensity {np.pi * radius**2 * intensity:.3g}: 1" in message
    assert "area" not in message, message


def test_a_light_placed_past_float32_is_named_for_its_position_not_its_size(tmp_path):
    """A sphere light of radius 1 translated to x = 1e38 is skipped (its centre does not fit the light table), and the
    warning named its 'size 1e+38': it names its position, read here through USD's own transform, and the size only
    of a light whose size is past float32 (a RectLight 1e38 wide at the origin)."""
    path = tmp_path / "far.usda"
    path.write_text('#usda 1.0\ndef SphereLight "Far"\n{\n    float inputs:radius = 1\n'
                    '    double3 xformOp:translate = (1e38, 0, 0)\n'
                    '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
                    'def RectLight "Long"\n{\n    float inputs:width = 1e38\n    float inputs:height = 1\n}\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    assert scene.lights == []
    (message,) = [str(w.message) for w in caught if "to fit in float32 were skipped" in str(w.message)]
    stage = Usd.Stage.Open(str(path))
    x = UsdGeom.Xformable(stage.GetPrimAtPath("/Far")).ComputeLocalToWorldTransform(0.0).ExtractTranslation()[0]
    width = UsdLux.RectLight(stage.GetPrimAtPath("/Long")).GetWidthAttr().Get()
    assert f"position {x:.3g}: 1" in message and f"size {width:.3g}: 1" in message, message


def test_several_domes_are_named_by_their_place_where_they_have_no_path():
    """Of several dome lights only the first is used: the warning names it and those left out, by path or, for lights
    built in Python without one, by their place in ``scene.lights`` (it said "only the first () is used")."""
    lights = [wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.ones(3, np.float32)),
              DomeLight(color=np.full(3, 0.3, np.float32)), DomeLight(color=np.full(3, 0.5, np.float32)),
              DomeLight(color=np.full(3, 0.5, np.float32), path="/Sky")]
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (2, 0, 0), (0, 2, 0))], lights=lights)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.render(scene, camera=top_down_camera(), width=2, height=2, device="cpu")
    said = [str(w.message) for w in caught if "dome lights" in str(w.message)]
    assert said == ["3 dome lights: only the first (scene.lights[1]) is used; scene.lights[2] and /Sky light nothing"]
