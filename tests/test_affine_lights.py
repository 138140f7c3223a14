"""Sphere lights scaled unevenly or sheared (ellipsoids) and cylinder lights so scaled across their axis (elliptic or
oblique tubes), built in Python: light sampling against irradiance integrated over the surface in float64
(tests/light_oracle.py), the pdf and distance a ray finds along each sampled direction, the solid angle rays see,
and the emitting area against closed forms (Carlson's R_G for the ellipsoid, the ellipse's perimeter for the tube)."""

import math

import numpy as np
import pytest
import warp as wp
from light_oracle import cylinder, irradiance, sphere
from shading_helpers import quad, top_down_camera

import wrt
from wrt.integrators.emitters import lights_on_segment
from wrt.light_sampling import DeviceLights, area_light_pdf, intersect_light, sample_light
from wrt.lights import CylinderLight, SphereLight
from wrt.materials import DeviceMaterials
from wrt.scene import DeviceScene
from wrt.shade import DeviceSurfaces


@wp.kernel
def sample_and_hit_kernel(
    lights: DeviceLights,
    scene: DeviceScene,
    mats: DeviceMaterials,
    surf: DeviceSurfaces,
    p: wp.vec3,
    n: wp.vec3,
    # outputs
    irradiance: wp.array[float],
    pdf_ratio: wp.array[float],
    dist_ratio: wp.array[float],
):
    """Per sample of light 0 from ``p`` (normal ``n``): the irradiance estimate, and the pdf and distance a ray along
    the sampled direction finds over those the sample reported (1 where they agree)."""
    i = wp.tid()
    state = wp.rand_init(11, i)
    u1 = wp.randf(state)
    u2 = wp.randf(state)
    ls = sample_light(lights, scene, mats, surf.uvs, surf.materials, surf.double_sided, 0, p, n, u1, u2)
    irradiance[i] = ls.value[0] * wp.max(wp.dot(n, ls.wi), 0.0)
    pdf_ratio[i] = 1.0
    dist_ratio[i] = 1.0
    if ls.value[0] > 0.0:
        t, cos_l = intersect_light(lights, 0, p, ls.wi)
        pdf_ratio[i] = area_light_pdf(lights, 0, p, n, ls.wi, t, cos_l) / ls.pdf
        dist_ratio[i] = t / ls.dist


@wp.kernel
def seen_kernel(
    lights: DeviceLights,
    p: wp.vec3,
    dirs: wp.array[wp.vec3],
    # outputs
    radiance: wp.array[float],
):
    """Radiance of the area lights a camera ray from ``p`` along ``dirs[i]`` sees."""
    i = wp.tid()
    radiance[i] = lights_on_segment(lights, p, dirs[i], 0.0, wp.inf, 0.0, wp.vec3(0.0), 1, wp.vec3(0.0), 0)[0]


def turned(angles_deg):
    """Rotation about X, then Y, then Z by ``angles_deg``."""
    ax, ay, az = np.radians(angles_deg)
    rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
    rz = np.array([[math.cos(az), -math.sin(az), 0], [math.sin(az), math.cos(az), 0], [0, 0, 1]])
    return rz @ ry @ rx


SQUASHED = turned((20, -35, 50)) @ np.diag([2.0, 0.5, 1.0])  # an ellipsoid of semi-axes 2 : 1 : 0.5, turned
SHEAR = turned((0, 0, 25)) @ np.array([[1.0, 0.8, 0.0], [0.0, 1.0, 0.6], [0.0, 0.0, 0.7]])  # unit X, leaning Y, Z
CENTRE = np.array([0.2, -0.1, 1.6])


def to_world(m3, centre=CENTRE):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = m3, centre
    return m


def lights_and_oracles():
    """``name: (light, oracle surface elements)`` with radiance 2."""
    return {
        "squashed_ellipsoid": (SphereLight(CENTRE, 0.4, np.full(3, 2.0), frame=SQUASHED),
                               sphere(to_world(SQUASHED), 0.4, n=400)),
        "sheared_ellipsoid": (SphereLight(CENTRE, 0.5, np.full(3, 2.0), frame=SHEAR),
                              sphere(to_world(SHEAR), 0.5, n=400)),
        "elliptic_tube": (CylinderLight(to_world(turned((10, 30, -20)) @ np.diag([1.5, 3.0, 0.6])), 1.0, 0.2,
                                        np.full(3, 2.0)), cylinder(to_world(turned((10, 30, -20)) @
                                                                            np.diag([1.5, 3.0, 0.6])), 1.0, 0.2, 400)),
        "oblique_tube": (CylinderLight(to_world(SHEAR), 1.2, 0.3, np.full(3, 2.0)),
                         cylinder(to_world(SHEAR), 1.2, 0.3, 400)),
    }


POINTS = [(0.0, 0.0, 0.0), (0.5, 0.3, 0.9), (-6.0, 4.0, -2.0)]  # below, close under it, far off to the side


def renderer(light, device="cpu"):
    scene = wrt.Scene(meshes=[quad((0, 0, -50), (1, 0, 0), (0, 1, 0))], lights=[light])
    return wrt.Renderer(scene, camera=top_down_camera((0, 0, 0), height=1.0), width=2, height=2, device=device)


DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("name", list(lights_and_oracles()))
def test_affine_light_samples_give_the_numerical_irradiance_and_the_pdf_rays_find(name, device):
    """Light sampling of an ellipsoid or elliptic tube averages to the irradiance integrated over its surface, from
    below it, close under it and far off; a ray along each sampled direction hits the light at the sampled distance
    and finds the pdf the sample reported (else MIS is biased), but for grazing samples that bring next to no light
    (float32 rounding, as for round tubes). wrt drew them round, of the mean scale."""
    light, elements = lights_and_oracles()[name]
    r = renderer(light, device)
    n = np.array([0.0, 0.0, 1.0])  # the oracle's irradiance is on a plane facing +Z
    for p in POINTS:
        count = 40000
        out = [wp.zeros(count, dtype=float, device=device) for _ in range(3)]
        wp.launch(sample_and_hit_kernel, count, inputs=[r.device_lights, r.device_scene, r.materials, r.surfaces,
                                                        wp.vec3(*p), wp.vec3(*n)], outputs=out, device=device)
        estimates, pdf_ratio, dist_ratio = (a.numpy().astype(np.float64) for a in out)
        expected = float(irradiance(np.array([p], np.float64), elements, radiance=2.0)[0])
        error = estimates.std() / math.sqrt(count)
        assert abs(estimates.mean() - expected) < max(4 * error, 2e-3 * expected), (p, estimates.mean(), expected)
        # Grazing samples (cos at the light near 0) disagree in float32 as a round tube's do: their light must be
        # negligible.
        off = (np.abs(pdf_ratio - 1.0) > 2e-3) | ~(np.abs(dist_ratio - 1.0) <= 1e-3)
        assert estimates[off].sum() <= 1e-3 * estimates.sum(), (p, off.mean())


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("name", list(lights_and_oracles()))
def test_rays_see_an_affine_light_over_its_solid_angle(name, np_rng, device):
    """Camera rays from a point see an ellipsoid or elliptic tube of radiance 2 over the solid angle of its surface
    facing the point (the integral of cos dA / d^2 there, float64)."""
    light, (q, normals, areas) = lights_and_oracles()[name]
    r = renderer(light, device)
    p = np.array([0.3, -0.4, 0.0])
    to = q - p
    d2 = (to**2).sum(-1)
    exact = (np.clip(-(to * normals).sum(-1) / np.sqrt(d2), 0, None) * areas / d2).sum()
    count = 400_000
    dirs = np_rng.normal(size=(count, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    radiance = wp.empty(count, dtype=float, device=device)
    directions = wp.array(dirs.astype(np.float32), dtype=wp.vec3, device=device)
    wp.launch(seen_kernel, count, inputs=[r.device_lights, wp.vec3(*p), directions], outputs=[radiance],
              device=device)
    hits = radiance.numpy() / 2.0
    seen = hits.mean() * 4.0 * math.pi
    error = hits.std() * 4.0 * math.pi / math.sqrt(count)
    assert abs(seen - exact) < 4.0 * error, (seen / exact, error / exact)


def test_affine_light_areas_match_closed_forms():
    """``normalize`` divides by the world area: an ellipsoid's is ``4 pi abc R_G(a^-2, b^-2, c^-2)`` (Carlson's
    symmetric integral, DLMF 19.33.1, from scipy), an elliptic tube's its length times the perimeter of its cross
    section (``4 a E(1 - b^2 / a^2)``); a treated-as-point ellipsoid radiates the power its surface does."""
    special = pytest.importorskip("scipy.special")
    light = SphereLight(CENTRE, 0.4, np.full(3, 3.0), frame=SQUASHED)
    a, b, c = 0.4 * np.array([2.0, 1.0, 0.5])
    area = 4 * math.pi * a * b * c * special.elliprg(a**-2, b**-2, c**-2)
    assert light.area == pytest.approx(area, rel=1e-12)
    normalized = SphereLight(CENTRE, 0.4, np.full(3, 3.0), normalize=True, frame=SQUASHED)
    np.testing.assert_allclose(normalized.radiance, 3.0 / area, rtol=1e-6)
    point = SphereLight(CENTRE, 0.4, np.full(3, 3.0), treat_as_point=True, frame=SQUASHED)
    assert 4 * math.pi * point.intensity[0] == pytest.approx(math.pi * area * 3.0, rel=1e-6)

    m3 = turned((10, 30, -20)) @ np.diag([1.5, 3.0, 0.6])  # cross section: semi-axes 3 r and 0.6 r, at right angles
    tube = CylinderLight(to_world(m3), 1.0, 0.2, np.full(3, 1.0))
    big, small = 3.0 * 0.2, 0.6 * 0.2
    assert tube.area == pytest.approx(1.5 * 4 * big * special.ellipe(1 - (small / big) ** 2), rel=1e-12)
    # Shear keeps the area of each cross section through the axis's normal plane: the oracle's sum is the check.
    oblique = CylinderLight(to_world(SHEAR), 1.2, 0.3, np.full(3, 1.0))
    assert oblique.area == pytest.approx(cylinder(to_world(SHEAR), 1.2, 0.3, 600)[2].sum(), rel=1e-5)


def test_round_lights_keep_their_round_representation():
    """A frame that only turns and scales evenly, and a tube scaled along its axis alone, stay the round lights (the
    fast path, unchanged); a frame that flattens the light falls back to the round light of the mean scale."""
    rotation = turned((30, 40, 50))
    assert SphereLight(CENTRE, 0.5, np.ones(3), frame=2.0 * rotation).ellipsoid() is None
    assert SphereLight(CENTRE, 0.5, np.ones(3), frame=2.0 * rotation).world_radius == pytest.approx(1.0)
    assert SphereLight(CENTRE, 0.5, np.ones(3), frame=np.diag([1.0, 1.0, 0.0])).ellipsoid() is None
    assert CylinderLight(to_world(rotation @ np.diag([4.0, 2.0, 2.0])), 1.0, 0.5, np.ones(3)).tube() is None
    assert CylinderLight(to_world(np.diag([1.0, 1.0, 0.0])), 1.0, 0.5, np.ones(3)).tube() is None
    assert CylinderLight(to_world(SHEAR), 1.0, 0.5, np.ones(3)).tube() is not None


@pytest.mark.parametrize("scale", [1.0, 1.0e-9, 1.0e-20, 1.0e-30])
def test_uneven_lights_stay_ellipsoids_and_elliptic_tubes_at_any_scale(scale):
    """A squashed sphere light and a tube of uneven cross section scaled by ``scale`` keep their shape: the map from
    the unit sphere or tube is the unscaled one times ``scale`` (and a frame scaled evenly stays round), also for
    lights placed by instances (``usd_placed_lights._shapes``). The tests of even scales took an absolute tolerance
    of 1e-8 (numpy's ``allclose``), so every light under 1e-8 across counted as round: an ellipsoid 1e-20 across
    was drawn as a sphere (the floor under it lit 20% brighter than unscaled)."""
    from wrt.usd_placed_lights import ELLIPSOID, ROUND, _shapes

    ellipsoid = SphereLight(CENTRE * scale, 0.4, np.ones(3), frame=SQUASHED * scale).ellipsoid()
    assert ellipsoid is not None
    np.testing.assert_allclose(ellipsoid, 0.4 * SQUASHED * scale, rtol=1e-12)
    m3 = turned((10, 30, -20)) @ np.diag([1.5, 3.0, 0.6])
    tube = CylinderLight(to_world(m3 * scale, CENTRE * scale), 1.0, 0.2, np.ones(3)).tube()
    assert tube is not None
    np.testing.assert_allclose(tube, m3 * scale * np.array([1.0, 0.2, 0.2]), rtol=1e-12)
    rotation = turned((30, 40, 50))
    assert SphereLight(CENTRE, 0.5, np.ones(3), frame=2.0 * scale * rotation).ellipsoid() is None
    np.testing.assert_array_equal(_shapes(SphereLight, np.stack([SQUASHED * scale, rotation * scale])),
                                  [ELLIPSOID, ROUND])
