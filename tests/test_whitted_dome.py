"""Whitted's dome term under a textured dome: a sky of two colours split at the horizon must light an open floor
with the sky's colour (the ground below the horizon cannot reach a floor facing up), as the path tracer and the
closed form say. Oracles: float64 quadrature of the bilinearly filtered texture (``shading_helpers.dome_integral``)."""

import numpy as np
import pytest
from shading_helpers import dome_integral, linear_weights, quad

import wrt
from wrt.dome_irradiance import irradiance_coefficients
from wrt.lights import DomeLight
from wrt.materials import Material

SKY = np.array([0.2, 0.45, 1.0])  # radiance above the horizon (+Y)
GROUND = np.array([0.9, 0.35, 0.05])  # below it


def two_colour_dome(height=32):
    """A ``(H, 2H, 4)`` lat-long texture (OpenEXR convention: +Y pole at the top row): SKY above the horizon, GROUND
    below (an even number of rows: the split falls between two rows)."""
    tex = np.ones((height, 2 * height, 4), np.float32)
    tex[: height // 2, :, :3] = SKY
    tex[height // 2:, :, :3] = GROUND
    return tex


def floor_radiance(material, integrator, spp, to_world=None, facing_y=True):
    """Mean RGB of an open floor through the origin whose front faces +Y (or +Z), lit only by the two-colour dome,
    seen head-on by an orthographic camera."""
    if facing_y:
        plane = quad((0, 0, 0), (40, 0, 0), (0, 0, -40), material=0)  # front +Y
        cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    else:
        plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), material=0)  # front +Z
        cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    dome = DomeLight(color=np.ones(3, np.float32), texture=two_colour_dome(),
                     to_world=np.eye(4) if to_world is None else to_world)
    scene = wrt.Scene(meshes=[plane], materials=[material], lights=[dome])
    img = wrt.render(scene, camera=cam, width=4, height=4, spp=spp, device="cpu", integrator=integrator,
                     max_depth=1, seed=7)
    return img.rgb.reshape(-1, 3).mean(axis=0)


LAMBERT = Material(diffuse_color=1.0, specular_edge=0.0, ior=1.0)  # no specular lobe: albedo 1


def test_whitted_lights_a_floor_by_the_sky_above_it_not_the_domes_mean():
    """A white Lambertian floor facing +Y shows the irradiance over pi of the sky above it (float64 quadrature of the
    filtered texture: SKY but for the one row blended at the horizon). Whitted took the dome's mean over the whole
    sphere, (SKY + GROUND) / 2: a blue sky lit the floor orange-grey."""
    expected = dome_integral(two_colour_dome()[..., :3], upper_only=True)
    np.testing.assert_allclose(floor_radiance(LAMBERT, "whitted", spp=1), expected, rtol=0.01)


def test_whitted_lights_a_wall_by_half_of_each_colour():
    """A wall facing +Z sees half the sky and half the ground: (SKY + GROUND) / 2 by symmetry."""
    got = floor_radiance(LAMBERT, "whitted", spp=1, facing_y=False)
    np.testing.assert_allclose(got, (SKY + GROUND) / 2, rtol=0.01)


def test_whitted_follows_the_domes_rotation():
    """The dome turned upside down (180 degrees about +Z) puts the ground above the floor."""
    turned = np.diag([-1.0, -1.0, 1.0, 1.0])
    expected = dome_integral(two_colour_dome()[::-1, :, :3], upper_only=True)
    np.testing.assert_allclose(floor_radiance(LAMBERT, "whitted", spp=1, to_world=turned), expected, rtol=0.01)


@pytest.mark.parametrize("roughness", [0.3, 0.7])
def test_whitted_reflects_the_sky_in_a_rough_white_metal_floor(roughness):
    """A rough white metal (albedo 1 with its multiple scattering) facing +Y reflects only directions above it: the
    sky's colour within the horizon row's blend, as the path tracer converges to. Whitted reflected the mean."""
    metal = Material(diffuse_color=1.0, metallic=1.0, roughness=roughness)
    expected = dome_integral(two_colour_dome()[..., :3], upper_only=True)
    np.testing.assert_allclose(floor_radiance(metal, "whitted", spp=1), expected, rtol=0.02)
    path = floor_radiance(metal, "path", spp=64)
    np.testing.assert_allclose(path, expected, rtol=0.03)


def test_irradiance_coefficients_are_the_filtered_domes_harmonics_times_the_cosines_bands(np_rng):
    """The nine coefficients of a random 6 x 12 dome against a float64 midpoint quadrature of the bilinearly filtered
    texture (longitude wrapping, latitude clamped) times the real harmonics written out from (x, y, z), and the
    clamped cosine's band factors 1, 2/3, 1/4 (Ramamoorthi and Hanrahan 2001)."""
    hgt, wid, n = 6, 12, 240
    texture = np_rng.random((hgt, wid, 3))
    theta = (np.arange(n) + 0.5) / n * np.pi
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    wy = linear_weights(theta / np.pi * hgt, hgt)
    wx = linear_weights((0.5 - phi / (2 * np.pi)) * wid, wid, wrap=True)
    radiance = np.einsum("tr,rck,pc->tpk", wy, texture, wx)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    x, y, z = np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)  # longitude phi from +Z towards +X
    harmonics = [0.5 / np.sqrt(np.pi) + 0 * x, *(np.sqrt(3 / (4 * np.pi)) * np.array([x, y, z])),
                 *(0.5 * np.sqrt(15 / np.pi) * np.array([x * y, y * z, x * z])),
                 0.25 * np.sqrt(5 / np.pi) * (3 * y * y - 1), 0.25 * np.sqrt(15 / np.pi) * (z * z - x * x)]
    weight = np.sin(t) * (np.pi / n) ** 2
    projected = np.array([np.einsum("tpk,tp->k", radiance, h * weight) for h in harmonics])
    bands = np.array([1.0] + [2 / 3] * 3 + [0.25] * 5)[:, None]
    colour = np.array([0.5, 2.0, 1.0])
    np.testing.assert_allclose(irradiance_coefficients(colour, texture), projected * bands * colour, atol=1e-4)
    constant = irradiance_coefficients(colour)  # a constant dome: c_0 Y_0 is its radiance, nothing else
    np.testing.assert_allclose(constant[0] * 0.5 / np.sqrt(np.pi), colour, rtol=1e-12)
    assert not constant[1:].any()
